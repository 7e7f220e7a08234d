#!/usr/bin/env python3
"""Render throughput benchmark: Specula beside Mitsuba 3, in the same run.

    cargo build --release -p specula-cli
    python3 scripts/bench_render.py [--spp 256] [--scenes cbox,meshes,veach_mis] [--no-mitsuba]
    python3 scripts/bench_render.py --media            # med_absorbing_glass,med_subsurface,med_fog_box
    python3 scripts/bench_render.py --media --spp 32 --repeat 3

Prints samples/s (pixels × spp / seconds) for each scene:
  - `specula render`: the render call only, from `specula render`'s own summary line (scene
    loading, BVH build and image writing excluded);
  - `specula process`: the whole `specula render` process, measured around it (start-up, XML
    parsing, mesh loading, BVH build, render, writing the EXR);
  - `mi scalar`, `mi llvm`: Mitsuba 3's `scalar_rgb` and `llvm_ad_rgb` variants, the render
    call only (`mi.render` + evaluation; scene loading excluded). For the LLVM variant one
    untimed warm-up render at 4 spp compiles the kernels first, so its figure excludes JIT
    compilation.
Mitsuba is optional (`pip install mitsuba`); its `llvm_ad_rgb` variant needs libLLVM
(DRJIT_LIBLLVM_PATH; /usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 is used when it exists and the
variable is not set; `apt-get install libllvm19`). A Mitsuba failure prints its last error line
and shows n/a. `--repeat N` keeps each renderer's best of N runs (machines are noisy; compare the
ratios measured in one run). SPECULA_EXE overrides the path of the `specula` binary (default:
target/release/specula). `--threads` is passed to Specula only (0: all cores); Mitsuba uses
all cores.
"""
import argparse, os, re, subprocess, sys, time, pathlib

root = pathlib.Path(__file__).resolve().parent.parent
shared = root.parent / "shared" / "scenes"
MEDIA = "med_absorbing_glass,med_subsurface,med_fog_box"
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def scene_path(name):
    scene = shared / f"{name}.xml"
    if not scene.exists():  # the participating-media scenes (med_*) live apart
        scene = shared.parent / "media" / "scenes" / f"{name}.xml"
    if not scene.exists():
        sys.exit(f"no scene '{name}' in {shared} or {shared.parent / 'media' / 'scenes'}")
    return scene


def specula(scene, spp, threads):
    """(render-only samples/s, whole-process samples/s, pixels)."""
    exe = os.environ.get("SPECULA_EXE") or root / "target" / "release" / "specula"
    t = time.perf_counter()
    out = subprocess.run([str(exe), "render", str(scene), "-D", f"spp={spp}", "--quiet",
                          "--threads", str(threads), "-o", "/tmp/specula_bench.exr"],
                         capture_output=True, text=True)
    wall = time.perf_counter() - t
    if out.returncode != 0:
        sys.exit(out.stderr)
    m = re.search(r"(\d+)×(\d+) at (\d+) spp .* ([0-9.]+) M samples/s", out.stdout)
    if not m:
        sys.exit(f"cannot read specula's summary line: {out.stdout!r}")
    w, h, n = int(m.group(1)), int(m.group(2)), int(m.group(3))
    return float(m.group(4)) * 1e6, w * h * n / wall, (w, h)


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
        last = (r.stderr.strip().splitlines() or ["(no message)"])[-1]
        print(f"  mitsuba {variant} failed on {scene.name}: {last}", file=sys.stderr)
        return None
    return float(r.stdout.strip().splitlines()[-1])


def best(f, repeat):
    vals = [f() for _ in range(repeat)]
    if any(v is None for v in vals):
        return None
    return max(vals)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--scenes", default="cbox,meshes,veach_mis")
    ap.add_argument("--media", action="store_true", help=f"the media scenes: {MEDIA}")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--no-mitsuba", action="store_true")
    a = ap.parse_args()
    if a.media:
        a.scenes = MEDIA
    if not os.environ.get("DRJIT_LIBLLVM_PATH") and os.path.exists(LLVM):
        os.environ["DRJIT_LIBLLVM_PATH"] = LLVM
    names = a.scenes.split(",")
    width = max(12, *(len(n) for n in names))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{a.spp} spp, {os.cpu_count()} cores, load average {load:.2f} at start; "
          f"M samples/s, best of {a.repeat}")
    print(f"{'scene':<{width}} {'size':>9} {'specula':>10} {'specula':>10} "
          f"{'mi scalar':>10} {'mi llvm':>10}")
    print(f"{'':<{width}} {'':>9} {'render':>10} {'process':>10} {'render':>10} {'render':>10}")
    fmt = lambda v: f"{v / 1e6:10.3f}" if v else f"{'n/a':>10}"
    for name in names:
        scene = scene_path(name)
        runs = [specula(scene, a.spp, a.threads) for _ in range(a.repeat)]
        sp = max(r[0] for r in runs)
        sp_proc = max(r[1] for r in runs)
        size = "{}x{}".format(*runs[0][2])
        ms = ml = None
        if not a.no_mitsuba:
            ms = best(lambda: mitsuba("scalar_rgb", scene, a.spp), a.repeat)
            ml = best(lambda: mitsuba("llvm_ad_rgb", scene, a.spp), a.repeat)
        print(f"{name:<{width}} {size:>9} {fmt(sp)} {fmt(sp_proc)} {fmt(ms)} {fmt(ml)}",
              flush=True)


if __name__ == "__main__":
    main()
