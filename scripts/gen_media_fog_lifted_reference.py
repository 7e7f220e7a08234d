#!/usr/bin/env python3
"""Reference for `med_fog_box` with the fog cube lifted by 1 mm (`translate y=1.201`).

In `../shared/media/scenes/med_fog_box.xml` the bottom face of the fog cube (a `null` boundary)
is coplanar with the floor (y = 0). Which of the two a ray hits first there is decided by the
rounding of two different intersection routines, so Mitsuba's reference shows, under the box, a
pattern of the two triangles of the cube's face that no other renderer reproduces. Lifting the
cube 1 mm removes the tie and nothing else; this script renders that scene with Mitsuba 3
(llvm_ad_rgb) at 2048 spp, writes it as a half-float EXR beside the media conformance test, and
measures Mitsuba's own 64-spp error against it (2 seeds), as `../shared/README.md` defines it.

Usage: python3 scripts/gen_media_fog_lifted_reference.py   (from the repository root)
"""
import json
import os
import re

import mitsuba as mi
import numpy as np
from refmetrics import block8, relmse

mi.set_variant("llvm_ad_rgb")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SRC = os.path.join(ROOT, "..", "shared", "media", "scenes", "med_fog_box.xml")
OUT = os.path.join(ROOT, "crates", "specula-render", "tests", "data", "media")


def lifted_xml():
    text = open(SRC).read()
    new, n = re.subn(r'<translate y="1.2"/>', '<translate y="1.201"/>', text)
    assert n == 1
    return new


def main():
    os.makedirs(OUT, exist_ok=True)
    xml = lifted_xml()
    open(os.path.join(OUT, "med_fog_box_lifted.xml"), "w").write(xml)
    scene = mi.load_string(xml, spp=64)
    ref = np.array(mi.render(scene, spp=2048, seed=1000))
    # stored as half floats (the comparison tolerates their 2^-11 relative rounding)
    bmp = mi.Bitmap(ref).convert(component_format=mi.Struct.Type.Float16)
    bmp.write(os.path.join(OUT, "med_fog_box_lifted.exr"))
    ref16 = np.array(mi.Bitmap(os.path.join(OUT, "med_fog_box_lifted.exr"))).astype(np.float64)
    rs, bs, ms = [], [], []
    for seed in range(2):
        img = np.array(mi.render(scene, spp=64, seed=seed)).astype(np.float64)
        rs.append(relmse(img, ref16))
        bs.append(block8(img, ref16))
        ms.append((img.mean(axis=(0, 1)) / ref16.mean(axis=(0, 1))).tolist())
    metrics = {
        "med_fog_box_lifted": {
            "ref_spp": 2048,
            "resolution": [ref.shape[1], ref.shape[0]],
            "ref_mean": ref16.mean(axis=(0, 1)).tolist(),
            "mitsuba_64spp_relmse": float(np.mean(rs)),
            "mitsuba_64spp_block8": float(np.mean(bs)),
            "mitsuba_64spp_mean_ratio": np.mean(ms, axis=0).tolist(),
        }
    }
    json.dump(metrics, open(os.path.join(OUT, "metrics.json"), "w"), indent=1)
    print(json.dumps(metrics, indent=1))


if __name__ == "__main__":
    main()
