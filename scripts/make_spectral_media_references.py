#!/usr/bin/env python3
"""Mitsuba 3 spectral references of the shared participating-media scenes
(../shared/media/scenes/med_*.xml), for the media part of
crates/specula-render/tests/spectral_conformance.rs (Specula's `--mode spectral` with `volpath`).

Developer tool only: CI never runs it (CI has no Mitsuba). Same requirements and conventions as
scripts/make_spectral_references.py (metrics and Mitsuba loop from scripts/refmetrics.py). Run from the
repository root, with ../shared beside it:

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
        python3 scripts/make_spectral_media_references.py [SCENE ...]

For every scene of ../shared/media/scenes/*.xml and of LOCAL (the judged stand-in for
`med_fog_box`, whose fog cube's bottom face is coplanar with the floor — see
tests/media_conformance.rs — and the two `heterogeneous` scenes, an RGB grid with an RGB albedo
grid and a one-channel grid, in crates/specula-render/tests/data/media), or the ones named, it
renders with Mitsuba's `llvm_ad_spectral` variant at half the scene's resolution (`resx`/`resy`
halved; the 64×64 LOCAL scenes at their own):
- `tests/data/spectral/NAME.exr`: the reference, REF_SPP samples per pixel (4096 where the
  shared RGB reference has more than 1024, as the other spectral references), accumulated over
  passes of PASS_SPP with distinct seeds, stored as float16;
- `tests/data/spectral/med_metrics.json`: per scene `ref_spp`, `resolution`, `ref_mean` and
  Mitsuba's own error at 64 spp against that reference averaged over SEEDS = 2 seeds
  (`mitsuba_64spp_relmse`, `mitsuba_64spp_block8`, `mitsuba_64spp_mean_ratio`), and the seconds
  the reference took (`ref_seconds`).
"""
import json
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from make_spectral_references import PASS_SPP, SEEDS  # noqa: E402
from refmetrics import defaults, own_error, reference  # noqa: E402

import mitsuba as mi  # noqa: E402
import numpy as np  # noqa: E402

mi.set_variant("llvm_ad_spectral")
SHARED = pathlib.Path("../shared/media")
LOCAL_DIR = pathlib.Path("crates/specula-render/tests/data/media")
LOCAL = ["med_fog_box_lifted", "med_hetero_chromatic", "med_hetero_smoke"]
OUT = pathlib.Path("tests/data/spectral")


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    shared = json.loads((SHARED / "reference/metrics.json").read_text())
    shared.update(json.loads((LOCAL_DIR / "metrics.json").read_text()))
    mpath = OUT / "med_metrics.json"
    metrics = json.loads(mpath.read_text()) if mpath.exists() else {}
    names = sys.argv[1:] or sorted(p.stem for p in (SHARED / "scenes").glob("*.xml")) + LOCAL
    for name in names:
        local = name in LOCAL
        path = (LOCAL_DIR if local else SHARED / "scenes") / f"{name}.xml"
        d = defaults(path.read_text())
        half = 1 if local and int(d["resx"]) <= 64 else 2
        w, h = int(d["resx"]) // half, int(d["resy"]) // half
        ref_spp = 4096 if shared.get(name, {}).get("ref_spp", 1024) > 1024 else 1024
        t0 = time.time()
        scene = mi.load_file(str(path), resx=w, resy=h)
        ref = reference(scene, ref_spp, PASS_SPP)
        ref_seconds = time.time() - t0
        mi.Bitmap(ref.astype(np.float16)).write(str(OUT / f"{name}.exr"))
        err = own_error(scene, ref, SEEDS)
        metrics[name] = {
            "scene": str(path),
            "ref_spp": ref_spp,
            "resolution": [w, h],
            "ref_mean": ref.mean((0, 1)).tolist(),
            "ref_seconds": round(ref_seconds, 1),
            **err,
        }
        print(f"{name}: {w}x{h} {ref_spp} spp in {ref_seconds:.0f} s, "
              f"relmse {err['mitsuba_64spp_relmse']:.4g}, block8 {err['mitsuba_64spp_block8']:.3g}, "
              f"mean {ref.mean((0, 1))}", flush=True)
        mpath.write_text(json.dumps(dict(sorted(metrics.items())), indent=1) + "\n")


if __name__ == "__main__":
    main()
