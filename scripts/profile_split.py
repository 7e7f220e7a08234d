#!/usr/bin/env python3
"""Where each renderer's time per sample goes: ray traversal against everything else.

    python3 scripts/profile_split.py [--scenes cbox,meshes,veach_mis] [--spp 64]

For each scene, renders once with Specula and once with Mitsuba 3's `llvm_ad_rgb` (after a
warm-up render that compiles its kernels), each on one thread under `perf record` (Linux
`perf`, the kernel's sampling profiler: install `linux-perf`), and splits the samples taken
during the render into

- traversal: Specula's BVH walks (functions of `specula_render::accel`), Mitsuba's Embree
  (`libembree3.so`);
- shading and the rest: everything else in the process during the render (Specula's path
  loop, BSDFs, lights, film; Mitsuba's JIT-compiled kernels, Dr.Jit, Python).

Each renderer runs `--repeat` times per scene (default 3) and its fastest run is kept. It
prints, per scene, nanoseconds per sample in each part for both renderers and their
ratio, so that a change can be aimed at the part where Specula trails. The split is only as
good as perf's sampling (about 4000 samples per second of CPU; each row says how many it
used). One thread each, so that the two renderers' per-sample costs compare directly; neither
renderer's image is kept.
"""
import argparse
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

root = pathlib.Path(__file__).resolve().parent.parent
SCENES = root.parent / "shared" / "scenes"
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"

MI_CODE = r"""
import sys, time, resource
import drjit as dr, mitsuba as mi
mi.set_variant("llvm_ad_rgb")
dr.set_thread_count(1)
s = mi.load_file(sys.argv[1])
spp = int(sys.argv[2])
img = mi.render(s, spp=4); dr.eval(img); dr.sync_thread()  # compile the kernels
print("@@START", time.time(), flush=True)
t = time.perf_counter()
c = resource.getrusage(resource.RUSAGE_SELF)
img = mi.render(s, spp=spp, seed=1); dr.eval(img); dr.sync_thread()
print("@@RENDER", time.perf_counter() - t, flush=True)
c1 = resource.getrusage(resource.RUSAGE_SELF)
print("@@CPU", c1.ru_utime + c1.ru_stime - c.ru_utime - c.ru_stime, flush=True)
print("@@END", time.time(), flush=True)
"""


def perf_report(data, start=None, end=None):
    """(samples, shared object, symbol) rows of a perf.data file, optionally only the samples
    between perf timestamps `start` and `end` (seconds, in the clock the file was recorded
    with)."""
    cmd = ["perf", "report", "-i", str(data), "--no-children", "--sort", "dso,sym", "--stdio",
           "-F", "sample,dso,sym", "--percent-limit", "0", "-t", "\t"]
    if start is not None:
        cmd += ["--time", f"{start},{end}"]
    out = subprocess.run(cmd, capture_output=True, text=True).stdout
    rows = []
    for line in out.splitlines():
        f = line.split("\t")
        if len(f) >= 3 and f[0].strip().isdigit():
            rows.append((int(f[0]), f[1].strip(), f[2].strip()))
    return rows


def split(rows, traversal):
    t = sum(n for n, dso, sym in rows if traversal(dso, sym))
    return t, sum(n for n, _, _ in rows)


def specula(exe, scene, spp, tmp):
    data = tmp / "specula.data"
    out = subprocess.run(["perf", "record", "-q", "-o", str(data), exe, "render", str(scene),
                          "--spp", str(spp), "--threads", "1", "-o", str(tmp / "s.exr")],
                         capture_output=True, text=True)
    m = re.search(r"(\d+)×(\d+) at (\d+) spp .* in ([0-9.]+) s", out.stdout)
    if out.returncode != 0 or not m:
        sys.exit(f"specula failed on {scene.name}: {out.stderr.strip()[-300:]}")
    samples = int(m.group(1)) * int(m.group(2)) * int(m.group(3))
    render_s = float(m.group(4))
    rows = [r for r in perf_report(data) if "specula" in r[1]]
    # the render dominates the process (start-up is milliseconds); count the process's
    # samples in the binary, scaled to the render time
    trav, total = split(rows, lambda dso, sym: "specula_render::accel" in sym)
    return samples, render_s, trav, total


def mitsuba(scene, spp, tmp):
    data = tmp / "mitsuba.data"
    env = dict(os.environ)
    if not env.get("DRJIT_LIBLLVM_PATH") and os.path.exists(LLVM):
        env["DRJIT_LIBLLVM_PATH"] = LLVM
    out = subprocess.run(["perf", "record", "-q", "-k", "CLOCK_MONOTONIC", "-o", str(data),
                          sys.executable, "-c", MI_CODE, str(scene), str(spp)],
                         capture_output=True, text=True, env=env)
    marks = dict(re.findall(r"@@(\w+) ([0-9.e+-]+)", out.stdout))
    if out.returncode != 0 or "RENDER" not in marks:
        print(f"  mitsuba failed on {scene.name}: {out.stderr.strip()[-300:]}", file=sys.stderr)
        return None
    # only the samples of the timed render: perf's timestamps are CLOCK_MONOTONIC; Python's
    # time.time() is wall time, so map the marks through the offset between the two clocks
    offset = time.clock_gettime(time.CLOCK_MONOTONIC) - time.time()
    start = float(marks["START"]) + offset
    end = float(marks["END"]) + offset
    rows = perf_report(data, f"{start:.6f}", f"{end:.6f}")
    trav, total = split(rows, lambda dso, sym: "embree" in dso)
    # one worker thread: the render's CPU time is its wall time (checked, so that the
    # per-sample costs compare with Specula's single thread)
    cpu, wall = float(marks["CPU"]), float(marks["RENDER"])
    if cpu > 1.15 * wall:
        print(f"  note: Mitsuba used {cpu / wall:.2f} cores on {scene.name}; CPU time used",
              file=sys.stderr)
    return max(cpu, wall), trav, total


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default="cbox,meshes,veach_mis")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs per renderer and scene; the fastest run's split is kept "
                         "(shared machines are noisy)")
    a = ap.parse_args()
    exe = os.environ.get("SPECULA_EXE", str(root / "target" / "release" / "specula"))
    print("| scene | Specula traversal (ns/sample) | Specula rest | Mitsuba llvm Embree "
          "| Mitsuba llvm rest | traversal ratio | rest ratio | total ratio | perf samples "
          "(Specula / Mitsuba) |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        tmp = pathlib.Path(d)
        for name in a.scenes.split(","):
            scene = SCENES / f"{name}.xml"
            runs = [specula(exe, scene, a.spp, tmp) for _ in range(a.repeat)]
            n, s_render, s_trav, s_total = min(runs, key=lambda r: r[1])
            ns = s_render * 1e9 / n
            st, sr = ns * s_trav / s_total, ns * (s_total - s_trav) / s_total
            ms = [mitsuba(scene, a.spp, tmp) for _ in range(a.repeat)]
            m = None if None in ms else min(ms, key=lambda r: r[0])
            if m is None:
                print(f"| {name} | {st:.0f} | {sr:.0f} | | | | | | {s_total} / |")
                continue
            m_render, m_trav, m_total = m
            mns = m_render * 1e9 / n
            mt, mr = mns * m_trav / m_total, mns * (m_total - m_trav) / m_total
            print(f"| {name} | {st:.0f} | {sr:.0f} | {mt:.0f} | {mr:.0f} | {st / mt:.2f} "
                  f"| {sr / mr:.2f} | {ns / mns:.2f} | {s_total} / {m_total} |", flush=True)


if __name__ == "__main__":
    main()
