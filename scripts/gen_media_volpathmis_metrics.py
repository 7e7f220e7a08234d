#!/usr/bin/env python3
"""Mitsuba 3's own 64-spp error of `volpathmis` on the media conformance scenes.

`volpathmis` (volumetric path tracing with spectral MIS) has the same expectation as `volpath`,
so the `volpath` references serve it too (`../shared/media/reference/NAME.exr`,
`crates/specula-render/tests/data/media/NAME.exr`). For each judged media scene this script
renders the scene with its integrator's type changed to `volpathmis` with Mitsuba 3
(llvm_ad_rgb) at 64 spp, 2 seeds, and writes the mean relMSE / block8 / mean ratio against the
reference (as `../shared/README.md` defines them) to
`crates/specula-render/tests/data/media/volpathmis_metrics.json`, with the scene's path
(`shared:` = relative to `../shared`, else relative to the repository root), the reference's,
and its `ref_spp`.

Usage: python3 scripts/gen_media_volpathmis_metrics.py   (from the repository root)
"""
import json
import os

import mitsuba as mi
import numpy as np
from refmetrics import block8, relmse

mi.set_variant("llvm_ad_rgb")
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(ROOT, "..", "shared")
LOCAL = "crates/specula-render/tests/data/media"
SCENES = [
    ("med_absorbing_glass", "shared:media/scenes", "shared:media/reference"),
    ("med_subsurface", "shared:media/scenes", "shared:media/reference"),
    ("med_fog_box_lifted", LOCAL, LOCAL),
    ("med_hetero_smoke", LOCAL, LOCAL),
    ("med_hetero_chromatic", LOCAL, LOCAL),
]


def resolve(p):
    return os.path.join(SHARED, p[len("shared:"):]) if p.startswith("shared:") else os.path.join(ROOT, p)


def main():
    out = {}
    for name, sdir, rdir in SCENES:
        scene_path = os.path.join(resolve(sdir), name + ".xml")
        ref_path = os.path.join(resolve(rdir), name + ".exr")
        text = open(scene_path).read()
        assert text.count('type="volpath"') == 1, name
        text = text.replace('type="volpath"', 'type="volpathmis"')
        # load from the scene's folder, so that relative file names resolve as in the file
        cwd = os.getcwd()
        os.chdir(os.path.dirname(scene_path))
        try:
            mi.Thread.thread().file_resolver().prepend(os.path.dirname(scene_path))
            scene = mi.load_string(text, spp=64)
        finally:
            os.chdir(cwd)
        ref = np.array(mi.Bitmap(ref_path)).astype(np.float64)[..., :3]
        rs, bs, ms = [], [], []
        for seed in range(2):
            img = np.array(mi.render(scene, spp=64, seed=seed)).astype(np.float64)
            rs.append(relmse(img, ref))
            bs.append(block8(img, ref))
            ms.append((img.mean(axis=(0, 1)) / ref.mean(axis=(0, 1))).tolist())
        metrics = json.load(open(os.path.join(resolve(rdir), "metrics.json")))[name]
        out[name] = {
            "scene": f"{sdir}/{name}.xml",
            "reference": f"{rdir}/{name}.exr",
            "ref_spp": metrics["ref_spp"],
            "mitsuba_64spp_relmse": float(np.mean(rs)),
            "mitsuba_64spp_block8": float(np.mean(bs)),
            "mitsuba_64spp_mean_ratio": np.mean(ms, axis=0).tolist(),
        }
        print(name, json.dumps(out[name]), flush=True)
    json.dump(out, open(os.path.join(ROOT, LOCAL, "volpathmis_metrics.json"), "w"), indent=1)


if __name__ == "__main__":
    main()
