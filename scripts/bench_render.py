#!/usr/bin/env python3
"""Render throughput benchmark: Specula beside Mitsuba 3, in the same run.

    cargo build --release -p specula-cli
    python3 scripts/bench_render.py [--spp 256] [--scenes cbox,meshes,veach_mis] [--no-mitsuba]
    python3 scripts/bench_render.py --scenes med_absorbing_glass,med_subsurface,med_fog_box

Prints samples/s (pixels × spp / wall time of the render call only, scene loading excluded)
for each scene. Specula's figure comes from `specula render`'s own summary line. Mitsuba is
optional (`pip install mitsuba`); its `llvm_ad_rgb` variant needs libLLVM (set
DRJIT_LIBLLVM_PATH, e.g. to /usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 after
`apt-get install libllvm19`). For the LLVM variant one untimed warm-up render compiles the
kernels first. Machines are noisy: compare the ratios measured in one run. SPECULA_EXE overrides
the path of the `specula` binary (default: target/release/specula).
"""
import argparse, os, re, subprocess, sys, time, pathlib

root = pathlib.Path(__file__).resolve().parent.parent
shared = root.parent / "shared" / "scenes"

def specula(scene, spp, threads):
    exe = os.environ.get("SPECULA_EXE") or root / "target" / "release" / "specula"
    out = subprocess.run([str(exe), "render", str(scene), "-D", f"spp={spp}", "--quiet",
                          "--threads", str(threads), "-o", "/tmp/specula_bench.exr"],
                         capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(out.stderr)
    m = re.search(r"([0-9.]+) M samples/s", out.stdout)
    return float(m.group(1)) * 1e6

def mitsuba(variant, scene, spp):
    code = f"""
import time, mitsuba as mi
mi.set_variant({variant!r})
s = mi.load_file({str(scene)!r}, spp={spp})
film = s.sensors()[0].film()
w, h = film.size()
if {variant!r}.startswith('llvm'):
    mi.render(s, spp=4)  # compile kernels
t = time.perf_counter()
img = mi.render(s, spp={spp}, seed=1)
import drjit as dr
dr.eval(img); dr.sync_thread()
print(w * h * {spp} / (time.perf_counter() - t))
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=os.environ)
    if r.returncode != 0:
        return None
    return float(r.stdout.strip().splitlines()[-1])

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--scenes", default="cbox,meshes,veach_mis")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--no-mitsuba", action="store_true")
    a = ap.parse_args()
    print(f"{'scene':<12} {'specula':>10} {'mi scalar':>10} {'mi llvm':>10}   (M samples/s, {a.spp} spp)")
    for name in a.scenes.split(","):
        scene = shared / f"{name}.xml"
        if not scene.exists():  # the participating-media scenes (med_*) live apart
            scene = shared.parent / "media" / "scenes" / f"{name}.xml"
        sp = specula(scene, a.spp, a.threads)
        ms = ml = None
        if not a.no_mitsuba:
            ms = mitsuba("scalar_rgb", scene, a.spp)
            ml = mitsuba("llvm_ad_rgb", scene, a.spp)
        fmt = lambda v: f"{v / 1e6:10.3f}" if v else f"{'n/a':>10}"
        print(f"{name:<12} {fmt(sp)} {fmt(ms)} {fmt(ml)}")

if __name__ == "__main__":
    main()
