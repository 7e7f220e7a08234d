#!/usr/bin/env python3
"""Scenes, grids and Mitsuba 3 references for the `heterogeneous` medium's conformance tests.

Writes into `crates/specula-render/tests/data/media/`:
- `smoke.vol` (32³, one channel): a smoke-like plume, sums of Gaussian puffs along a wavering
  rising column plus smoothed value noise, all from a fixed NumPy seed, falling to 0 at the
  grid's faces;
- `chroma_sigma_t.vol` (16³, RGB) and `chroma_albedo.vol` (8³, RGB): a blob whose extinction
  is red-heavy in its core and blue-heavy in its shell (chromatic extinction), and an albedo
  that varies across it;
- `med_hetero_smoke.xml`: the plume (`scale` 20, grey albedo 0.85, hg g = 0.3) in a `null` cube,
  over a diffuse floor, lit by a rectangular area light and a dim constant environment;
- `med_hetero_chromatic.xml`: the RGB blob, rotated and scaled by the grid's `to_world`, with
  the albedo grid (its own `to_world`), isotropic phase, in a `null` sphere, lit by a small
  spherical area light (sampled by cone from the medium) and a constant environment;
- `NAME.exr`: Mitsuba 3.9 `llvm_ad_rgb` renders at `REF_SPP` (half floats);
- `metrics.json`: the scenes' entries (merged into the file, other scenes kept): `ref_spp`,
  `resolution`, `ref_mean`, and Mitsuba's own 64-spp relMSE / block8 / mean ratio against the
  reference, averaged over 4 seeds, as `../shared/README.md` defines them.

Usage: python3 scripts/gen_media_hetero_refs.py   (from the repository root; a few minutes)
       python3 scripts/gen_media_hetero_refs.py --preview DIR   (grids, scenes, 32-spp PNGs in DIR)
Set DRJIT_LIBLLVM_PATH if Dr.Jit does not find LLVM (e.g. /usr/lib/x86_64-linux-gnu/libLLVM.so.19.1).
"""
import json
import os
import struct

import mitsuba as mi
import numpy as np
from refmetrics import block8, relmse

mi.set_variant("llvm_ad_rgb")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "crates", "specula-render", "tests", "data", "media")
REF_SPP = 4096
RES = 64
SEEDS = 4


def write_vol(path, data):
    """Mitsuba's binary .vol: data indexed [z, y, x, channel], x varying fastest."""
    z, y, x, c = data.shape
    with open(path, "wb") as f:
        f.write(b"VOL")
        f.write(struct.pack("<B", 3))
        f.write(struct.pack("<iiiii", 1, x, y, z, c))
        f.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        f.write(np.ascontiguousarray(data, dtype="<f4").tobytes())


def smooth(a, passes):
    for _ in range(passes):
        for ax in range(3):
            a = (np.roll(a, 1, ax) + 2 * a + np.roll(a, -1, ax)) / 4
    return a


def taper(n):
    """1 inside, falling to 0 over the outer texels (so the grid's faces are empty)."""
    t = (np.arange(n) + 0.5) / n
    return np.clip(np.minimum(t, 1 - t) * 8 - 0.15, 0, 1)


def smoke_grid():
    n = 32
    rng = np.random.default_rng(20261202)
    z, y, x = np.meshgrid(*[(np.arange(n) + 0.5) / n] * 3, indexing="ij")
    d = np.zeros((n, n, n))
    for k in range(14):
        h = 0.12 + 0.72 * k / 13
        cx = 0.5 + 0.12 * np.sin(6.0 * h + 0.7)
        cz = 0.5 + 0.10 * np.cos(5.0 * h)
        r = 0.07 + 0.11 * h
        d += np.exp(-((x - cx) ** 2 + (y - h) ** 2 * 1.8 + (z - cz) ** 2) / (2 * r * r))
    noise = smooth(rng.random((n, n, n)), 3)
    noise = (noise - noise.min()) / (noise.max() - noise.min())
    d *= 0.35 + 0.9 * noise
    w = taper(n)
    d *= w[:, None, None] * w[None, :, None] * w[None, None, :]
    d /= d.max()
    return d[..., None].astype(np.float32)


def chroma_grids():
    n = 16
    z, y, x = np.meshgrid(*[(np.arange(n) + 0.5) / n] * 3, indexing="ij")
    r2 = (x - 0.5) ** 2 + (y - 0.55) ** 2 * 1.3 + (z - 0.45) ** 2
    core = np.exp(-r2 / (2 * 0.12**2))
    shell = np.exp(-((np.sqrt(r2) - 0.28) ** 2) / (2 * 0.06**2))
    w = taper(n)
    w3 = w[:, None, None] * w[None, :, None] * w[None, None, :]
    st = np.stack([3.0 * core + 0.4 * shell, 1.5 * core + 1.2 * shell, 0.5 * core + 2.5 * shell], -1)
    st *= w3[..., None]
    m = 8
    z, y, x = np.meshgrid(*[(np.arange(m) + 0.5) / m] * 3, indexing="ij")
    alb = np.stack([0.55 + 0.4 * x, 0.9 - 0.5 * y, 0.35 + 0.6 * z], -1)
    return st.astype(np.float32), alb.astype(np.float32)


HEADER = """<scene version="3.0.0">
    <default name="spp" value="64"/>
    <default name="resx" value="{res}"/>
    <default name="resy" value="{res}"/>
    <integrator type="volpath">
        <integer name="max_depth" value="{depth}"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <transform name="to_world">
            <lookat origin="{origin}" target="{target}" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="$resx"/>
            <integer name="height" value="$resy"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <shape type="rectangle" id="floor">
        <transform name="to_world">
            <rotate x="1" angle="-90"/>
            <scale value="6"/>
        </transform>
        <bsdf type="diffuse">
            <rgb name="reflectance" value="0.5, 0.5, 0.5"/>
        </bsdf>
    </shape>
"""

SMOKE = HEADER.format(res=RES, depth=16, fov=38, origin="0, 1.4, -4.6", target="0, 1.0, 0") + """    <shape type="rectangle" id="key_light">
        <transform name="to_world">
            <scale value="0.6"/>
            <lookat origin="2.2, 3.6, -1.4" target="0, 1, 0" up="0, 1, 0"/>
        </transform>
        <emitter type="area">
            <rgb name="radiance" value="16, 14, 11"/>
        </emitter>
    </shape>
    <emitter type="constant">
        <rgb name="radiance" value="0.12, 0.14, 0.18"/>
    </emitter>
    <medium type="heterogeneous" id="smoke">
        <volume type="gridvolume" name="sigma_t">
            <string name="filename" value="smoke.vol"/>
            <transform name="to_world">
                <scale x="1.6" y="2.0" z="1.6"/>
                <translate x="-0.8" y="0.01" z="-0.8"/>
            </transform>
        </volume>
        <float name="scale" value="20"/>
        <float name="albedo" value="0.85"/>
        <phase type="hg">
            <float name="g" value="0.3"/>
        </phase>
    </medium>
    <shape type="cube" id="smoke_bounds">
        <transform name="to_world">
            <scale x="0.8" y="1.0" z="0.8"/>
            <translate y="1.01"/>
        </transform>
        <bsdf type="null"/>
        <ref name="interior" id="smoke"/>
    </shape>
</scene>
"""

CHROMA = HEADER.format(res=RES, depth=16, fov=34, origin="0.6, 1.5, -4.2", target="0, 0.95, 0") + """    <shape type="sphere" id="lamp">
        <point name="center" value="-1.6, 2.6, -0.6"/>
        <float name="radius" value="0.25"/>
        <emitter type="area">
            <rgb name="radiance" value="30, 30, 30"/>
        </emitter>
    </shape>
    <emitter type="constant">
        <rgb name="radiance" value="0.3, 0.3, 0.3"/>
    </emitter>
    <medium type="heterogeneous" id="blob">
        <volume type="gridvolume" name="sigma_t">
            <string name="filename" value="chroma_sigma_t.vol"/>
            <transform name="to_world">
                <translate value="-0.5, -0.5, -0.5"/>
                <rotate y="1" angle="30"/>
                <rotate x="1" angle="15"/>
                <scale value="1.3"/>
                <translate y="0.95"/>
            </transform>
        </volume>
        <volume type="gridvolume" name="albedo">
            <string name="filename" value="chroma_albedo.vol"/>
            <transform name="to_world">
                <scale value="2"/>
                <translate value="-1, 0, -1"/>
            </transform>
        </volume>
        <float name="scale" value="4"/>
        <phase type="isotropic"/>
    </medium>
    <shape type="sphere" id="blob_bounds">
        <point name="center" value="0, 0.95, 0"/>
        <float name="radius" value="0.94"/>
        <bsdf type="null"/>
        <ref name="interior" id="blob"/>
    </shape>
</scene>
"""


def main(preview=None):
    os.makedirs(OUT, exist_ok=True)
    write_vol(os.path.join(OUT, "smoke.vol"), smoke_grid())
    st, alb = chroma_grids()
    write_vol(os.path.join(OUT, "chroma_sigma_t.vol"), st)
    write_vol(os.path.join(OUT, "chroma_albedo.vol"), alb)
    mpath = os.path.join(OUT, "metrics.json")
    metrics = json.load(open(mpath)) if os.path.exists(mpath) else {}
    for name, xml in [("med_hetero_smoke", SMOKE), ("med_hetero_chromatic", CHROMA)]:
        path = os.path.join(OUT, name + ".xml")
        open(path, "w").write(xml)
        scene = mi.load_file(path, spp=64)
        if preview:
            img = mi.render(scene, spp=32, seed=0)
            mi.util.write_bitmap(os.path.join(preview, name + ".png"), img)
            continue
        ref = np.array(mi.render(scene, spp=REF_SPP, seed=1000))
        exr = os.path.join(OUT, name + ".exr")
        mi.Bitmap(ref).convert(component_format=mi.Struct.Type.Float16).write(exr)
        ref16 = np.array(mi.Bitmap(exr)).astype(np.float64)
        rs, bs, ms = [], [], []
        for seed in range(SEEDS):
            img = np.array(mi.render(scene, spp=64, seed=seed)).astype(np.float64)
            rs.append(relmse(img, ref16))
            bs.append(block8(img, ref16))
            ms.append((img.mean(axis=(0, 1)) / ref16.mean(axis=(0, 1))).tolist())
        metrics[name] = {
            "ref_spp": REF_SPP,
            "resolution": [ref.shape[1], ref.shape[0]],
            "ref_mean": ref16.mean(axis=(0, 1)).tolist(),
            "mitsuba_64spp_relmse": float(np.mean(rs)),
            "mitsuba_64spp_block8": float(np.mean(bs)),
            "mitsuba_64spp_mean_ratio": np.mean(ms, axis=0).tolist(),
        }
        print(name, json.dumps(metrics[name]), flush=True)
    if not preview:
        json.dump(metrics, open(mpath, "w"), indent=1)


if __name__ == "__main__":
    import sys

    # `--preview DIR`: write the grids and scenes, and 32-spp PNG previews into DIR only
    main(sys.argv[2] if len(sys.argv) > 2 and sys.argv[1] == "--preview" else None)
