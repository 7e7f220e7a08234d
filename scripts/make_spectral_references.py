#!/usr/bin/env python3
"""Mitsuba 3 spectral references of the shared scenes, for
crates/specula-render/tests/spectral_conformance.rs (Specula's `--mode spectral`).

Developer tool only: CI never runs it (CI has no Mitsuba). Needs `pip install mitsuba==3.9.1
numpy` and LLVM (`apt-get install -y libllvm19`). Run from the repository root, with
../shared beside it:

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
        python3 scripts/make_spectral_references.py [SCENE ...]

For every scene of ../shared/scenes/*.xml (or the ones named) it renders, with Mitsuba's
`llvm_ad_spectral` variant, at half the scene's resolution (its `resx`/`resy` defaults halved,
passed as scene parameters, as `specula render -D resx=… -D resy=…` does):
- `NAME.exr`: the reference, REF_SPP samples per pixel (4096 for scenes whose shared RGB
  reference used 4096, else 1024), accumulated over passes of PASS_SPP with distinct seeds;
- `metrics.json`: per scene `ref_spp`, `resolution`, `ref_mean` and Mitsuba's own error at 64
  spp against that reference averaged over SEEDS = 2 seeds (`mitsuba_64spp_relmse`,
  `mitsuba_64spp_block8`, `mitsuba_64spp_mean_ratio`; the metrics of ../shared/README.md), and
  `_skipped`: scenes Mitsuba's spectral variant cannot render, with its error.
into tests/data/spectral/. Stored as float16 EXR (half the size; the metrics are computed on
the float32 images before rounding, and the rounding, ≤ 5·10⁻⁴ relative, is far below them).
"""
import json
import pathlib
import sys
import time

import mitsuba as mi
import numpy as np

from refmetrics import defaults, own_error, reference

mi.set_variant("llvm_ad_spectral")
SHARED = pathlib.Path("../shared")
OUT = pathlib.Path("tests/data/spectral")
PASS_SPP = 256
SEEDS = 2


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    shared = json.loads((SHARED / "reference/metrics.json").read_text())
    mpath = OUT / "metrics.json"
    metrics = json.loads(mpath.read_text()) if mpath.exists() else {}
    skipped = metrics.pop("_skipped", {})
    names = sys.argv[1:] or sorted(p.stem for p in (SHARED / "scenes").glob("*.xml"))
    for name in names:
        path = SHARED / "scenes" / f"{name}.xml"
        d = defaults(path.read_text())
        w, h = int(d["resx"]) // 2, int(d["resy"]) // 2
        ref_spp = 4096 if shared.get(name, {}).get("ref_spp", 1024) > 1024 else 1024
        t0 = time.time()
        try:
            scene = mi.load_file(str(path), resx=w, resy=h)
            ref = reference(scene, ref_spp, PASS_SPP)
        except Exception as e:  # noqa: BLE001 - record what Mitsuba cannot render
            skipped[name] = str(e).splitlines()[0][:300]
            print(f"{name}: skipped ({skipped[name]})", flush=True)
            continue
        skipped.pop(name, None)
        mi.Bitmap(ref.astype(np.float16)).write(str(OUT / f"{name}.exr"))
        err = own_error(scene, ref, SEEDS)
        metrics[name] = {
            "ref_spp": ref_spp,
            "resolution": [w, h],
            "ref_mean": ref.mean((0, 1)).tolist(),
            **err,
        }
        print(f"{name}: {w}x{h} {ref_spp} spp in {time.time() - t0:.0f} s, "
              f"relmse {err['mitsuba_64spp_relmse']:.4g}, block8 {err['mitsuba_64spp_block8']:.3g}",
              flush=True)
        out = dict(sorted(metrics.items()))
        if skipped:
            out["_skipped"] = skipped
        mpath.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
