#!/usr/bin/env python3
"""Render the AOV fixture scenes with Mitsuba 3.9.1 and record every channel of every pixel.

Developer tool only (CI has no Mitsuba). Reads crates/specula-render/tests/data/
aov_fixture.xml, aov_fixture_ortho.xml and aov_fixture_thinlens.xml (Mitsuba's `aov` integrator with every AOV type, a
stratified sampler without jitter, so that the four samples of each pixel lie at fixed
positions), renders them in scalar_rgb, and writes crates/specula-render/tests/data/
aov_fixture.txt, which crates/specula-render/tests/aov.rs compares Specula's render with.
Run: python3 scripts/gen_aov_fixture.py   (needs `pip install mitsuba==3.9.1`)

Also prints Mitsuba's `eval_diffuse_reflectance` for the BSDFs of the unit test in
crates/specula-bsdf/src/models/albedo.rs (`--albedo`).

Lines:
    scene <file name>
    channels <name> <name> ...
    <x> <y> <value per channel>
"""
import pathlib, sys, struct
import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
ROOT = pathlib.Path(__file__).resolve().parent.parent
DATA = ROOT / "crates/specula-render/tests/data"


def fmt(x):
    x = struct.unpack("f", struct.pack("f", float(x)))[0]
    for p in range(1, 10):
        s = "%.*g" % (p, x)
        if struct.unpack("f", struct.pack("f", float(s)))[0] == x:
            return s
    return repr(x)


def albedo_probe():
    import drjit as dr, math
    d = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.2, 0.4, 0.6]}}
    rc = {"type": "roughconductor", "alpha": 0.3}
    cases = {
        "diffuse": d, "conductor": {"type": "conductor"}, "dielectric": {"type": "dielectric"},
        "thindielectric": {"type": "thindielectric"}, "null": {"type": "null"},
        "roughconductor": rc, "roughdielectric": {"type": "roughdielectric", "alpha": 0.3},
        "plastic": {"type": "plastic", "diffuse_reflectance": {"type": "rgb", "value": [0.2, 0.4, 0.6]}},
        "roughplastic": {"type": "roughplastic", "diffuse_reflectance": {"type": "rgb", "value": [0.2, 0.4, 0.6]}},
        "twosided(diffuse, diffuse)": {"type": "twosided", "a": d, "b": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.7, 0.1, 0.1]}}},
        "twosided(roughconductor)": {"type": "twosided", "a": rc},
        "blendbsdf(diffuse, plastic)": {"type": "blendbsdf", "weight": 0.25, "a": d, "b": {"type": "plastic", "diffuse_reflectance": {"type": "rgb", "value": [0.7, 0.1, 0.1]}}},
        "blendbsdf(diffuse, roughconductor)": {"type": "blendbsdf", "weight": 0.25, "a": d, "b": rc},
        "mask(diffuse)": {"type": "mask", "opacity": 0.3, "b": d},
        "mask(roughconductor)": {"type": "mask", "opacity": 0.3, "b": rc},
    }
    wis = [mi.Vector3f(0, 0, 1), dr.normalize(mi.Vector3f(0.3, 0.2, 0.9)),
           dr.normalize(mi.Vector3f(0.3, 0.2, -0.9))]
    for name, desc in cases.items():
        b = mi.load_dict(desc)
        vals = []
        for wi in wis:
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.wi = wi
            si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
            si.n = mi.Vector3f(0, 0, 1)
            si.uv = mi.Point2f(0.3, 0.3)
            si.dp_du, si.dp_dv = mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0)
            vals.append(b.eval_diffuse_reflectance(si))
        print(f"{name:36s}", "  ".join(str(v) for v in vals))


if "--albedo" in sys.argv:
    albedo_probe()
    sys.exit()

lines = []
for name in ["aov_fixture.xml", "aov_fixture_ortho.xml", "aov_fixture_thinlens.xml"]:
    scene = mi.load_file(str(DATA / name))
    img = np.array(mi.render(scene))
    names = list(scene.integrator().aov_names())
    assert img.shape[2] == len(names), (img.shape, names)
    lines.append("scene " + name)
    lines.append("channels " + " ".join(names))
    h, w, _ = img.shape
    for y in range(h):
        for x in range(w):
            lines.append(f"{x} {y} " + " ".join(fmt(v) for v in img[y, x]))
(DATA / "aov_fixture.txt").write_text("\n".join(lines) + "\n")
print(f"wrote {DATA / 'aov_fixture.txt'} ({len(lines)} lines)")
