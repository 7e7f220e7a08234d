#!/usr/bin/env python3
"""Writes a UV sphere tessellated to about N triangles as a binary PLY (with vertex normals),
and a Mitsuba 3 scene around it: the benchmark's scaling scenes (`bench_render.py --scaling`),
the same scene at every tessellation. Nothing it writes is committed.

    python3 scripts/gen_sphere_mesh.py OUT_DIR 1000 10000 100000 1000000

For each count it writes OUT_DIR/sphere_<count>.ply and OUT_DIR/sphere_<count>.xml (a diffuse
sphere on a diffuse floor under a constant sky and a point light; `spp` and `res` are
`<default>` parameters) and prints the paths and the exact triangle counts.

The sphere has R rings of 2R quads (triangle fans at the poles): 4R(R − 1) triangles, R
chosen to come closest to the count asked for.
"""
import math, sys, pathlib

import numpy as np

SCENE = """<scene version="3.0.0">
    <default name="spp" value="16"/>
    <default name="res" value="256"/>
    <integrator type="path">
        <integer name="max_depth" value="4"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="35"/>
        <transform name="to_world">
            <lookat origin="0, 1.2, 4.5" target="0, 0, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="$res"/>
            <integer name="height" value="$res"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <emitter type="constant">
        <rgb name="radiance" value="0.5"/>
    </emitter>
    <emitter type="point">
        <point name="position" x="2" y="4" z="3"/>
        <rgb name="intensity" value="30"/>
    </emitter>
    <shape type="ply">
        <string name="filename" value="{ply}"/>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.7, 0.4, 0.2"/>
        </bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world">
            <rotate x="1" angle="-90"/>
            <scale value="5"/>
            <translate y="-1"/>
        </transform>
        <bsdf type="diffuse"/>
    </shape>
</scene>
"""


def rings_for(triangles):
    """R with 4R(R − 1) closest to `triangles` (R ≥ 3)."""
    r = max(3, round(0.5 + math.sqrt(0.25 + triangles / 4)))
    best = min((abs(4 * k * (k - 1) - triangles), k) for k in (r - 1, r, r + 1) if k >= 3)
    return best[1]


def sphere(rings):
    """(positions N×3 float32, faces M×3 int32) of a unit UV sphere."""
    cols = 2 * rings
    theta = np.pi * np.arange(1, rings) / rings  # the rings between the poles
    phi = 2 * np.pi * np.arange(cols) / cols
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    ring = np.stack(
        [st * np.cos(phi)[None, :], np.broadcast_to(ct, (rings - 1, cols)), st * np.sin(phi)[None, :]],
        axis=-1,
    ).reshape(-1, 3)
    pos = np.concatenate([[[0, 1, 0]], ring, [[0, -1, 0]]]).astype(np.float32)
    top, bottom = 0, len(pos) - 1
    idx = lambda j, i: 1 + j * cols + (i % cols)  # noqa: E731
    i = np.arange(cols)
    faces = [np.stack([np.full(cols, top), idx(0, i + 1), idx(0, i)], axis=1)]
    for j in range(rings - 2):
        a, b, c, d = idx(j, i), idx(j, i + 1), idx(j + 1, i), idx(j + 1, i + 1)
        faces.append(np.stack([a, b, d], axis=1))
        faces.append(np.stack([a, d, c], axis=1))
    j = rings - 2
    faces.append(np.stack([idx(j, i), idx(j, i + 1), np.full(cols, bottom)], axis=1))
    return pos, np.concatenate(faces).astype(np.int32)


def write_ply(path, pos, faces):
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(pos)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\n"
        f"element face {len(faces)}\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    verts = np.concatenate([pos, pos], axis=1).astype("<f4")  # unit sphere: normal = position
    f = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
    f["n"], f["i"] = 3, faces
    with open(path, "wb") as out:
        out.write(header.encode())
        out.write(verts.tobytes())
        out.write(f.tobytes())


def generate(out_dir, count):
    """Writes sphere_<count>.ply/.xml in out_dir; returns (xml path, triangle count)."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    pos, faces = sphere(rings_for(count))
    ply = out_dir / f"sphere_{count}.ply"
    write_ply(ply, pos, faces)
    xml = out_dir / f"sphere_{count}.xml"
    xml.write_text(SCENE.format(ply=ply.name))
    return xml, len(faces)


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    for n in sys.argv[2:]:
        xml, tris = generate(sys.argv[1], int(n))
        print(f"{xml}: {tris} triangles")


if __name__ == "__main__":
    main()
