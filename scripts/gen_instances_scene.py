#!/usr/bin/env python3
"""Writes a scene of N×N instances of one 10⁴-triangle mesh (Mitsuba 3 shapegroup/instance),
to show that instancing costs memory per group, not per instance.

Usage: python3 scripts/gen_instances_scene.py OUT_DIR [N=100]
Writes OUT_DIR/blob.ply (a bumpy sphere: 50 × 100 quads = 10⁴ triangles, binary PLY) and
OUT_DIR/instances.xml (N² instances on a grid, each rotated and scaled differently, under a
sun-like directional light and a constant sky). Then, e.g.:
    /usr/bin/time -v specula render OUT_DIR/instances.xml --spp 4 -o /tmp/instances.exr
"""
import math
import os
import struct
import sys

out = sys.argv[1]
n = int(sys.argv[2]) if len(sys.argv) > 2 else 100
os.makedirs(out, exist_ok=True)

# a bumpy UV sphere: (ST + 1) × (SL + 1) vertices, ST × SL quads = 2·ST·SL triangles
ST, SL = 50, 100
verts = []
for i in range(ST + 1):
    th = math.pi * i / ST
    for j in range(SL + 1):
        ph = 2 * math.pi * j / SL
        r = 1.0 + 0.08 * math.sin(5 * th) * math.cos(7 * ph)
        verts.append((r * math.sin(th) * math.cos(ph), r * math.sin(th) * math.sin(ph), r * math.cos(th)))
faces = []
for i in range(ST):
    for j in range(SL):
        a = i * (SL + 1) + j
        b = a + SL + 1
        faces.append((a, b, a + 1))
        faces.append((a + 1, b, b + 1))
assert len(faces) == 10_000
with open(os.path.join(out, "blob.ply"), "wb") as f:
    f.write(
        f"ply\nformat binary_little_endian 1.0\nelement vertex {len(verts)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n".encode()
    )
    for v in verts:
        f.write(struct.pack("<3f", *v))
    for t in faces:
        f.write(struct.pack("<B3i", 3, *t))

lines = [
    '<scene version="3.0.0">',
    '  <integrator type="path"><integer name="max_depth" value="3"/></integrator>',
    '  <sensor type="perspective"><float name="fov" value="50"/>',
    f'    <transform name="to_world"><lookat origin="{-0.2 * n}, {-0.2 * n}, {0.35 * n}" '
    f'target="{1.5 * n}, {1.5 * n}, 0" up="0, 0, 1"/></transform>',
    '    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>',
    '    <film type="hdrfilm"><integer name="width" value="320"/><integer name="height" value="240"/></film>',
    "  </sensor>",
    '  <emitter type="directional"><vector name="direction" x="1" y="0.5" z="-1"/>'
    '<rgb name="irradiance" value="3"/></emitter>',
    '  <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>',
    '  <shape type="shapegroup" id="blob">',
    '    <shape type="ply"><string name="filename" value="blob.ply"/>',
    '      <bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.6, 0.3, 0.1"/></bsdf>',
    "    </shape>",
    "  </shape>",
    '  <shape type="rectangle"><transform name="to_world"><scale value="1e4"/></transform>'
    '<bsdf type="diffuse"/></shape>',
]
for i in range(n):
    for j in range(n):
        k = i * n + j
        s = 0.6 + 0.5 * ((k * 7919) % 101) / 101
        ang = (k * 37) % 360
        lines.append(
            f'  <shape type="instance"><ref id="blob"/><transform name="to_world">'
            f'<scale value="{s:.3f}"/><rotate x="1" y="1" z="0" angle="{ang}"/>'
            f'<translate x="{3 * i}" y="{3 * j}" z="{s:.3f}"/></transform></shape>'
        )
lines.append("</scene>")
with open(os.path.join(out, "instances.xml"), "w") as f:
    f.write("\n".join(lines) + "\n")
print(f"wrote {out}/instances.xml ({n * n} instances) and {out}/blob.ply ({len(faces)} triangles)")
