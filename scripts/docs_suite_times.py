#!/usr/bin/env python3
"""Times Mitsuba's documentation scenes in Specula and in Mitsuba 3, side by side.

For every scene with a reference in ../shared/mitsuba-data/reference (its metrics.json gives
the reduced `resolution`), renders at 64 spp:
  - Specula: the whole process, `specula render NAME.xml --size WxH --spp 64` (wall clock);
  - Mitsuba: `mi.load_file` then the film resized through `mi.traverse` (as the references
    were made), and the `mi.render` call alone (wall clock, after one warm-up render of 1 spp
    so that JIT compilation is not counted), in the variant given (default llvm_ad_rgb; set
    DRJIT_LIBLLVM_PATH for it).
Prints a Markdown table. Not part of CI.

    python3 scripts/docs_suite_times.py [--variant llvm_ad_rgb] [--scenes a,b] [--specula PATH]
"""
import argparse, json, os, subprocess, sys, time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared" / "mitsuba-data"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--scenes", default=None)
    ap.add_argument("--specula", default=str(ROOT / "target/release/specula"))
    ap.add_argument("--spp", type=int, default=64)
    a = ap.parse_args()
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
    import mitsuba as mi
    mi.set_variant(a.variant)
    metrics = json.load(open(SHARED / "reference/metrics.json"))
    names = sorted(k for k in metrics if not k.startswith("_"))
    if a.scenes:
        names = [n for n in names if n in a.scenes.split(",")]
    print(f"| scene | size | Specula process (s) | Mitsuba {a.variant} render (s) | ratio |")
    print("|---|---|---|---|---|")
    for name in names:
        w, h = metrics[name]["resolution"]
        path = SHARED / "docs/scenes" / f"{name}.xml"
        cmd = [a.specula, "render", str(path), "--size", f"{w}x{h}", "--spp", str(a.spp),
               "-o", "/tmp/docs_suite_times.exr", "--quiet"]
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0 and "undefined parameter '$spp'" in r.stderr:
            # scenes that use $spp without a default (Mitsuba is loaded with spp= too)
            t0 = time.perf_counter()
            r = subprocess.run(cmd + ["-D", f"spp={a.spp}"], capture_output=True, text=True)
        t_spec = time.perf_counter() - t0
        spec = f"{t_spec:.2f}" if r.returncode == 0 else "fails"
        try:
            try:
                scene = mi.load_file(str(path))
            except Exception:
                scene = mi.load_file(str(path), spp=a.spp)
            params = mi.traverse(scene.sensors()[0].film())
            params["size"] = [w, h]
            params["crop_size"] = [w, h]
            params["crop_offset"] = [0, 0]
            params.update()
            mi.render(scene, spp=1)
            t0 = time.perf_counter()
            img = mi.render(scene, spp=a.spp)
            mi.Bitmap(img)  # forces evaluation in the JIT variants
            t_mi = time.perf_counter() - t0
            mits = f"{t_mi:.2f}"
        except Exception as e:  # noqa: BLE001
            t_mi, mits = None, f"fails ({str(e).splitlines()[0][:40]})"
        ratio = f"{t_spec / t_mi:.2f}" if (r.returncode == 0 and t_mi) else ""
        print(f"| {name} | {w}×{h} | {spec} | {mits} | {ratio} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
