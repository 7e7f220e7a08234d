#!/usr/bin/env python3
"""Time to equal error: how long Specula takes to reach Mitsuba's 64-spp error, beside Mitsuba.

    cargo build --release -p specula-cli
    python3 scripts/time_to_error.py [--scenes cbox,mat_rough_copper,veach_mis,envmap_spheres]
                                     [--samplers sobol,independent] [--spp 4,8,16,32,64]
                                     [--seeds 0,1] [--threads 0] [--no-mitsuba] [--json out.json]

For each scene and sampler, renders `../shared/scenes/NAME.xml` with `specula render --sampler
SAMPLER -D spp=N --seed K` at every N of `--spp` and K of `--seeds`, timing the whole process
(start-up, parsing, BVH build, render, writing the EXR), and computes the relMSE of each image
against `../shared/reference/NAME.exr` exactly as `../shared/README.md` defines it (per pixel,
the mean over channels of (img − ref)² / (ref² + 0.01); the ⌊0.001·pixels⌋ largest dropped; a
non-finite pixel counts as a huge error). At each N the relMSE is averaged over seeds (as
Mitsuba's figure is) and the time is the smallest over seeds (the machine is shared and noisy).
The target is `mitsuba_64spp_relmse` from `../shared/reference/metrics.json` (Mitsuba
`llvm_ad_rgb`, 64 spp, averaged over 4 seeds); the time at which Specula reaches it is
interpolated linearly in log(time)–log(relMSE) between the two measured points that bracket it
(extrapolated from the nearest two, and marked `~`, when no pair brackets it); the spp is
interpolated the same way.

Mitsuba's time is its `llvm_ad_rgb` render call at 64 spp, measured in the same run (scene
loading excluded; one untimed render at 64 spp with another seed first compiles the kernels, so
JIT compilation is excluded too; the best of `--mitsuba-repeat` timed renders), with the relMSE
of that image printed beside it as a check. It needs libLLVM: DRJIT_LIBLLVM_PATH, or
/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 (`apt-get install libllvm19`) when the variable is unset.

ratio = Specula's time to equal error / Mitsuba's 64-spp render time (target ≤ 0.5). The machine
this runs on may be shared: `cpu ratio` is the same ratio with CPU seconds (user + system, all
threads: Specula's whole process, Mitsuba's render call), which other processes disturb less.

Importable: `time_to_equal_error(scene, sampler, ...) -> dict` (see its docstring) and
`mitsuba_time(scene, spp) -> dict`; `relmse(img, ref)` and `read_exr(path)` as well.
SPECULA_EXE overrides the path of the `specula` binary (default: target/release/specula).
"""
import argparse, json, math, os, pathlib, resource, subprocess, sys, tempfile, time

import numpy as np
from refmetrics import relmse

root = pathlib.Path(__file__).resolve().parent.parent
shared = root.parent / "shared"
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
SCENES = "cbox,mat_rough_copper,veach_mis,envmap_spheres"


def read_exr(path):
    """An EXR as an H×W×3 float64 array (Mitsuba's Bitmap reader)."""
    import mitsuba as mi
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    b = mi.Bitmap(str(path))
    a = np.array(b, dtype=np.float64)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.shape[2] == 1:
        a = np.repeat(a, 3, axis=2)
    return a[:, :, :3]


def reference(scene):
    ref = read_exr(shared / "reference" / f"{scene}.exr")
    metrics = json.loads((shared / "reference" / "metrics.json").read_text())[scene]
    return ref, metrics


def _children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def specula_run(scene, sampler, spp, seed, threads=0, out=None, cpu=None):
    """(whole-process seconds, image) of one `specula render`; with `cpu` a list, the
    process's CPU seconds (user + system, all threads) are appended to it."""
    exe = os.environ.get("SPECULA_EXE") or str(root / "target" / "release" / "specula")
    tmp = None
    if out is None:
        tmp = tempfile.NamedTemporaryFile(suffix=".exr", delete=False)
        tmp.close()
        out = tmp.name
    cmd = [exe, "render", str(shared / "scenes" / f"{scene}.xml"), "-D", f"spp={spp}",
           "--seed", str(seed), "--threads", str(threads), "--quiet", "-o", out]
    if sampler:
        cmd += ["--sampler", sampler]
    c = _children_cpu()
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if cpu is not None:
        cpu.append(_children_cpu() - c)
    if r.returncode != 0:
        raise RuntimeError(f"specula failed on {scene}: {r.stderr.strip()}")
    img = read_exr(out)
    if tmp is not None:
        os.unlink(out)
    return wall, img


def _loglog(xs, ys, y):
    """x where the piecewise log-log line through (xs, ys) meets y, and whether it was
    extrapolated. ys need not be monotone: the first bracketing pair (in x order) is used."""
    lx = [math.log(v) for v in xs]
    ly = [math.log(max(v, 1e-300)) for v in ys]
    t = math.log(y)
    for i in range(len(lx) - 1):
        a, b = ly[i], ly[i + 1]
        if (a - t) * (b - t) <= 0 and a != b:
            return math.exp(lx[i] + (t - a) * (lx[i + 1] - lx[i]) / (b - a)), False
    # extrapolate from the end nearest the target
    i = 0 if t > ly[0] else len(lx) - 2
    a, b = ly[i], ly[i + 1]
    if a == b:
        return float("nan"), True
    return math.exp(lx[i] + (t - a) * (lx[i + 1] - lx[i]) / (b - a)), True


def time_to_equal_error(scene, sampler="sobol", spps=(4, 8, 16, 32, 64), seeds=(0, 1),
                        threads=0, target=None, log=None):
    """Specula's wall time to reach `target` relMSE (default: Mitsuba's 64-spp figure from
    metrics.json) on `scene` with `sampler` (None: the scene's own).

    Returns a dict: scene, sampler, target, points = [{spp, time (wall s, best over seeds),
    cpu (CPU s of the process, best over seeds), relmse (mean over seeds)}], time, cpu (s) and
    spp at the target (log-log interpolation), extrapolated (bool).
    """
    ref, metrics = reference(scene)
    if target is None:
        target = metrics["mitsuba_64spp_relmse"]
    points = []
    for spp in spps:
        times, cpus, errs = [], [], []
        for seed in seeds:
            t, img = specula_run(scene, sampler, spp, seed, threads, cpu=cpus)
            times.append(t)
            errs.append(relmse(img, ref))
        p = {"spp": spp, "time": min(times), "cpu": min(cpus), "relmse": sum(errs) / len(errs)}
        points.append(p)
        if log:
            log(f"  {scene} {sampler or 'scene'} {spp:>5} spp: {p['time']:7.3f} s "
                f"(cpu {p['cpu']:.3f} s), relMSE {p['relmse']:.3e}")
    errs = [p["relmse"] for p in points]
    t, ext = _loglog([p["time"] for p in points], errs, target)
    c, _ = _loglog([p["cpu"] for p in points], errs, target)
    n, _ = _loglog([p["spp"] for p in points], errs, target)
    return {"scene": scene, "sampler": sampler or "scene", "target": target, "points": points,
            "time": t, "cpu": c, "spp": n, "extrapolated": ext}


def mitsuba_time(scene, spp=64, repeat=1, warm_seed=7, seed=1):
    """Mitsuba llvm_ad_rgb's render-call time at `spp` (kernels compiled by a first, untimed
    render at the same spp), run in a subprocess. Returns {time (wall s), cpu (CPU s of the
    render call, all threads), relmse} or {error}."""
    code = f"""
import json, time, numpy as np, mitsuba as mi, drjit as dr
mi.set_variant('llvm_ad_rgb')
s = mi.load_file({str(shared / 'scenes' / f'{scene}.xml')!r}, spp={spp})
img = mi.render(s, spp={spp}, seed={warm_seed}); dr.eval(img); dr.sync_thread()
best = cpu = None
for k in range({repeat}):
    t, c = time.perf_counter(), time.process_time()
    img = mi.render(s, spp={spp}, seed={seed} + k)
    dr.eval(img); dr.sync_thread()
    dt, dc = time.perf_counter() - t, time.process_time() - c
    best = dt if best is None else min(best, dt)
    cpu = dc if cpu is None else min(cpu, dc)
    if k == 0:
        first = np.array(img, dtype=np.float64)
print(json.dumps({{'time': best, 'cpu': cpu}}))
np.save({str(pathlib.Path(tempfile.gettempdir()) / f'tte_mi_{scene}.npy')!r}, first)
"""
    env = dict(os.environ)
    if "DRJIT_LIBLLVM_PATH" not in env and os.path.exists(LLVM):
        env["DRJIT_LIBLLVM_PATH"] = LLVM
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    if r.returncode != 0:
        last = (r.stderr.strip().splitlines() or ["(no message)"])[-1]
        return {"error": last}
    res = json.loads(r.stdout.strip().splitlines()[-1])
    npy = pathlib.Path(tempfile.gettempdir()) / f"tte_mi_{scene}.npy"
    img = np.load(npy)
    npy.unlink()
    ref, _ = reference(scene)
    res["relmse"] = relmse(img[:, :, :3], ref)
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", default=SCENES)
    ap.add_argument("--samplers", default="sobol",
                    help="comma-separated --sampler names; 'scene' keeps the scene's own")
    ap.add_argument("--spp", default="4,8,16,32,64")
    ap.add_argument("--seeds", default="0,1")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--no-mitsuba", action="store_true")
    ap.add_argument("--mitsuba-repeat", type=int, default=2)
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--quiet", action="store_true", help="only the table")
    a = ap.parse_args()
    spps = [int(v) for v in a.spp.split(",")]
    seeds = [int(v) for v in a.seeds.split(",")]
    log = None if a.quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    results = []
    for scene in a.scenes.split(","):
        mi = {"error": "skipped"} if a.no_mitsuba else mitsuba_time(scene, 64, a.mitsuba_repeat)
        if log:
            log(f"{scene}: mitsuba llvm 64 spp: {mi}")
        for smp in a.samplers.split(","):
            r = time_to_equal_error(scene, None if smp == "scene" else smp, spps, seeds,
                                    a.threads, log=log)
            r["mitsuba"] = mi
            results.append(r)
    print(f"{'scene':<18} {'sampler':<12} {'target':>9} {'mi 64spp':>9} {'mi relMSE':>9} "
          f"{'spp':>7} {'specula':>9} {'ratio':>6} {'cpu ratio':>9}")
    for r in results:
        mi = r["mitsuba"]
        mt, mc = mi.get("time"), mi.get("cpu")
        ext = "~" if r["extrapolated"] else " "
        ratio = r["time"] / mt if mt else float("nan")
        cratio = r["cpu"] / mc if mc else float("nan")
        print(f"{r['scene']:<18} {r['sampler']:<12} {r['target']:>9.3e} "
              f"{(f'{mt:.3f} s' if mt else 'n/a'):>9} "
              f"{(format(mi['relmse'], '.3e') if 'relmse' in mi else 'n/a'):>9} "
              f"{ext}{r['spp']:>6.1f} {ext}{r['time']:>6.3f} s {ratio:>6.2f} {cratio:>9.2f}")
    if a.json:
        pathlib.Path(a.json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
