#!/usr/bin/env python3
"""Spectral-mode throughput: Specula's `--mode spectral` against its RGB mode, and Mitsuba 3's
`llvm_ad_spectral` against `llvm_ad_rgb`, all in the same run.

    cargo build --release -p specula-cli
    python3 scripts/bench_spectral.py [--spp 64] [--scenes cbox,mat_diffuse_textured,envmap_spheres]
        [--repeat 2] [--threads 0] [--no-mitsuba] [--media]

Prints samples/s (pixels × spp / seconds of the render call; scene loading excluded): for
Specula from `specula render`'s summary line (spectral mode's one-off upsampling table is
computed before the render starts, so it is excluded too; the script prints its cost
separately), for Mitsuba around `mi.render` after an untimed 4-spp warm-up render that compiles
the kernels. `--media` takes the participating-media scenes of ../shared/media/scenes
(default med_absorbing_glass,med_fog_box,med_subsurface; `volpath`) instead. `--repeat N` keeps each figure's best of N runs. Mitsuba is optional (pip
`mitsuba`, libLLVM: DRJIT_LIBLLVM_PATH, /usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 by default).
"""
import argparse, os, re, subprocess, sys, time, pathlib

root = pathlib.Path(__file__).resolve().parent.parent
shared = root.parent / "shared" / "scenes"
shared_media = root.parent / "shared" / "media" / "scenes"
MEDIA_SCENES = "med_absorbing_glass,med_fog_box,med_subsurface"
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def specula(scene, spp, threads, mode):
    exe = os.environ.get("SPECULA_EXE") or root / "target" / "release" / "specula"
    t = time.perf_counter()
    out = subprocess.run([str(exe), "render", str(scene), "-D", f"spp={spp}", "--quiet",
                          "--threads", str(threads), "--mode", mode, "-o", "/tmp/specula_bench.exr"],
                         capture_output=True, text=True)
    wall = time.perf_counter() - t
    if out.returncode != 0:
        sys.exit(out.stderr)
    m = re.search(r"at (\d+) spp .* in ([0-9.]+) s — ([0-9.]+) M samples/s", out.stdout)
    if not m:
        sys.exit(f"cannot read specula's summary line: {out.stdout!r}")
    return float(m.group(3)) * 1e6, wall - float(m.group(2))


def mitsuba(variant, scene, spp):
    code = f"""
import time, mitsuba as mi, drjit as dr
mi.set_variant({variant!r})
s = mi.load_file({str(scene)!r}, spp={spp})
w, h = s.sensors()[0].film().size()
mi.render(s, spp=4)
t = time.perf_counter()
img = mi.render(s, spp={spp}, seed=1)
dr.eval(img); dr.sync_thread()
print(w * h * {spp} / (time.perf_counter() - t))
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=os.environ)
    if r.returncode != 0:
        last = (r.stderr.strip().splitlines() or ["(no message)"])[-1]
        print(f"  mitsuba {variant} failed on {scene.name}: {last}", file=sys.stderr)
        return None
    return float(r.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--scenes", default=None,
                    help="default cbox,mat_diffuse_textured,envmap_spheres,mat_glass "
                    f"(with --media: {MEDIA_SCENES})")
    ap.add_argument("--media", action="store_true",
                    help="scenes from ../shared/media/scenes (participating media)")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--no-mitsuba", action="store_true")
    a = ap.parse_args()
    if os.path.exists(LLVM):
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
    fmt = lambda v: "n/a" if v is None else f"{v / 1e6:.3f}"
    print(f"{'scene':<22} {'Specula rgb':>12} {'spectral':>10} {'ratio':>6}"
          f" {'mi llvm rgb':>12} {'spectral':>10} {'ratio':>6}   (M samples/s, {a.spp} spp)")
    names = a.scenes or (MEDIA_SCENES if a.media
                         else "cbox,mat_diffuse_textured,envmap_spheres,mat_glass")
    for name in names.split(","):
        scene = (shared_media if a.media else shared) / f"{name}.xml"
        best = lambda f: max((f() for _ in range(a.repeat)), key=lambda v: -1 if v is None else v)
        rgb = best(lambda: specula(scene, a.spp, a.threads, "rgb")[0])
        spec = best(lambda: specula(scene, a.spp, a.threads, "spectral")[0])
        mr = ms = None
        if not a.no_mitsuba:
            mr = best(lambda: mitsuba("llvm_ad_rgb", scene, a.spp))
            ms = best(lambda: mitsuba("llvm_ad_spectral", scene, a.spp))
        ratio = lambda x, y: "n/a" if x is None or y is None else f"{x / y:.2f}"
        print(f"{name:<22} {fmt(rgb):>12} {fmt(spec):>10} {ratio(spec, rgb):>6}"
              f" {fmt(mr):>12} {fmt(ms):>10} {ratio(ms, mr):>6}", flush=True)
    # the one-off cost of spectral mode's upsampling table: the difference in time outside the
    # render call between a spectral and an RGB run of a tiny render
    tiny = shared / "mat_diffuse.xml"
    _, o_rgb = specula(tiny, 1, a.threads, "rgb")
    _, o_spec = specula(tiny, 1, a.threads, "spectral")
    print(f"upsampling table (once per process): {o_spec - o_rgb:.2f} s")


if __name__ == "__main__":
    main()
