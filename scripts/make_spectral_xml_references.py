#!/usr/bin/env python3
"""Mitsuba 3 spectral references of the `<spectrum>` scenes of tests/data/spectral_xml/, for
crates/specula-render/tests/spectral_xml.rs (Specula's `--mode spectral` with `<spectrum>`
values: wavelength lists, `.spd` files, `regular`, `blackbody`, `srgb`, uniform values, on
BSDFs and emitters).

Developer tool only: CI never runs it (CI has no Mitsuba). Needs `pip install mitsuba==3.9.1
numpy` and LLVM (`apt-get install -y libllvm19`). Run from the repository root:

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \\
        python3 scripts/make_spectral_xml_references.py [SCENE ...]

As scripts/make_spectral_references.py does for the shared scenes, for every
tests/data/spectral_xml/*.xml (or the ones named) it renders with Mitsuba's
`llvm_ad_spectral` variant, at the scene's own (small) resolution:
- `NAME.exr`: the reference, REF_SPP samples per pixel accumulated over passes of PASS_SPP
  with distinct seeds (float16 EXR);
- `metrics.json`: per scene `ref_spp`, `resolution`, `ref_mean` and Mitsuba's own error at 64
  spp against that reference averaged over SEEDS = 2 seeds (`mitsuba_64spp_relmse`,
  `mitsuba_64spp_block8`, `mitsuba_64spp_mean_ratio`; the metrics of ../shared/README.md).
The same is done for SHARED: scenes of ../shared that are written with `<spectrum>` values (Mitsuba's
documentation Cornell box of its spectral variants), at a reduced film size set through
`mi.traverse` (what Specula's `LoadOptions::size` reproduces); their metrics entries name the
file (`shared`, relative to ../shared) and the test skips them where ../shared is absent.
It also renders each scene with `llvm_ad_rgb` at 64 spp and records its mean
(`rgb_mode_mean`, or the error the RGB variant gives): how differently the RGB variants see the same file (the spectra converted
to RGB when the scene loads), for the report.
"""
import json
import pathlib
import sys
import time

import mitsuba as mi
import numpy as np

from refmetrics import defaults, own_error, reference

DIR = pathlib.Path("tests/data/spectral_xml")
SHARED = {"variants_cbox_spectral": ("mitsuba-data/docs/scenes/variants_cbox_spectral.xml", (125, 125))}
REF_SPP = 4096
PASS_SPP = 256
SEEDS = 2


def load(name):
    """The scene `name` and its film size."""
    if name in SHARED:
        rel, (w, h) = SHARED[name]
        scene = mi.load_file(str(pathlib.Path("../shared") / rel))
        params = mi.traverse(scene)
        key = next(k for k in params.keys() if k.endswith("film.size"))
        params[key] = [w, h]
        params.update()
        return scene, (w, h)
    path = DIR / f"{name}.xml"
    d = defaults(path.read_text())
    return mi.load_file(str(path)), (int(d["resx"]), int(d["resy"]))


def main():
    mpath = DIR / "metrics.json"
    metrics = json.loads(mpath.read_text()) if mpath.exists() else {}
    names = sys.argv[1:] or sorted(p.stem for p in DIR.glob("*.xml")) + sorted(SHARED)
    rgb_means = {}
    mi.set_variant("llvm_ad_rgb")
    for name in names:
        try:
            scene, _ = load(name)
            img = np.array(mi.render(scene, spp=64, seed=0))
            rgb_means[name] = img[..., :3].mean((0, 1)).tolist()
        except Exception as e:  # noqa: BLE001 - e.g. blackbody: "Not implemented for non-spectral modes"
            rgb_means[name] = str(e.__cause__ or e).splitlines()[0][:200]
    mi.set_variant("llvm_ad_spectral")
    for name in names:
        t0 = time.time()
        scene, (w, h) = load(name)
        ref = reference(scene, REF_SPP, PASS_SPP)
        mi.Bitmap(ref.astype(np.float16)).write(str(DIR / f"{name}.exr"))
        err = own_error(scene, ref, SEEDS)
        metrics[name] = {
            **({"shared": SHARED[name][0]} if name in SHARED else {}),
            "ref_spp": REF_SPP,
            "resolution": [w, h],
            "ref_mean": ref.mean((0, 1)).tolist(),
            "rgb_mode_mean": rgb_means[name],
            **err,
        }
        print(f"{name}: {w}x{h} {REF_SPP} spp in {time.time() - t0:.0f} s, "
              f"relmse {err['mitsuba_64spp_relmse']:.4g}, block8 {err['mitsuba_64spp_block8']:.3g}, "
              f"mean {ref.mean((0, 1))}, "
              f"RGB variant's mean {rgb_means[name]}", flush=True)
        mpath.write_text(json.dumps(dict(sorted(metrics.items())), indent=1) + "\n")


if __name__ == "__main__":
    main()
