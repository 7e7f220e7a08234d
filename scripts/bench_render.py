#!/usr/bin/env python3
"""Render benchmark: Specula beside Mitsuba 3, in the same run.

    cargo build --release -p specula-cli
    python3 scripts/bench_render.py --all              # every table below (markdown)
    python3 scripts/bench_render.py --all --quick      # a fast smoke run of the same
    python3 scripts/bench_render.py [--spp 256] [--scenes cbox,meshes,veach_mis] [--no-mitsuba]
    python3 scripts/bench_render.py --media            # med_absorbing_glass,med_subsurface,med_fog_box
    python3 scripts/bench_render.py --media --spp 32 --repeat 3

Without a section flag it prints the throughput table of earlier versions, samples/s
(pixels × spp / seconds) for each scene:
  - `specula render`: the render call only, from `specula render`'s own summary line (scene
    loading, BVH build and image writing excluded);
  - `specula process`: the whole `specula render` process, measured around it (start-up, XML
    parsing, mesh loading, BVH build, render, writing the EXR);
  - `mi scalar`, `mi llvm`: Mitsuba 3's `scalar_rgb` and `llvm_ad_rgb` variants, the render
    call only (`mi.render` + evaluation; scene loading excluded). For the LLVM variant one
    untimed warm-up render at 4 spp compiles the kernels first, so its figure excludes JIT
    compilation.

Sections (`--all` runs them all; each has its own flag):
  --throughput   cbox, meshes, veach_mis at 256 spp (`--spp`): Specula render-only and whole
                 process samples/s beside Mitsuba `llvm_ad_rgb`'s render call (kernels
                 compiled by an earlier render of the same size) and its whole process (Python
                 start, import, load, JIT compilation and the first render). The two take
                 turns (`--repeat` N turns); the ratio is given from the best runs and as the
                 median of each turn's ratio (steadier when the machine's speed drifts).
  --startup      Specula's start-up (everything before the first sample, from
                 `specula render --timings`, best of 2, or of `--repeat` N when larger;
                 process CPU: the least of the runs) for every loadable scene of
                 ../shared/mitsuba-data/docs/scenes and ../shared/scenes: median, worst, the
                 number over 0.1 s, and the slowest with their phases.
  --scaling      the same scene (scripts/gen_sphere_mesh.py, written to a temporary folder)
                 with 10^3 … 10^6 triangles at 1 and 2 threads: whole process and render.
  --memory       peak resident memory (the child's ru_maxrss) of Specula and of Mitsuba's
                 Python process (llvm_ad_rgb, load + render) on meshes and on 10^6 triangles.
  --equal-error  on cbox, mat_rough_copper, veach_mis, envmap_spheres: Mitsuba llvm's time for
                 64 spp, and Specula's whole-process time to reach Mitsuba's 64-spp relMSE
                 (../shared/reference/metrics.json; relMSE as ../shared/README.md defines it)
                 with `--sampler` TEE_SAMPLER (`--tee-sampler`, default sobol), interpolated
                 between renders at doubling sample counts; as a ratio to Mitsuba's time;
                 each scene twice: uniform sampling and `--adaptive`.
Mitsuba is optional (`pip install mitsuba`): without it the Specula columns still print (and
--equal-error needs it to read EXR files). Its `llvm_ad_rgb` variant needs libLLVM
(DRJIT_LIBLLVM_PATH; /usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 is used when it exists and the
variable is not set; `apt-get install libllvm19`). A Mitsuba failure prints its last error line
and shows n/a. `--repeat N` keeps each renderer's best of N runs (machines are noisy; compare the
ratios measured in one run). SPECULA_EXE overrides the path of the `specula` binary (default:
target/release/specula). `--threads` is passed to Specula only (0: all cores); Mitsuba uses
all cores (except in --scaling, where both get the thread count of the row).
"""
import argparse, json, os, re, statistics, subprocess, sys, time, pathlib

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


# ---------------------------------------------------------------------------------------------
# The sections of --all: every child process is measured alone (wall time, peak memory).

EXE = None  # the specula binary (set in main)
DOCS = root.parent / "shared" / "mitsuba-data" / "docs" / "scenes"
REFS = root.parent / "shared" / "reference"
MI_MARK = "@@MI@@"

MI_CODE = r"""
import json, sys, time
a = json.loads(sys.argv[1])
t_start = time.time()
import drjit as dr, mitsuba as mi
mi.set_variant(a["variant"])
if a.get("threads"):
    dr.set_thread_count(a["threads"])
try:
    s = mi.load_file(a["scene"], **a.get("params", {}))
except Exception:
    if "spp" in a.get("params", {}):
        raise
    s = mi.load_file(a["scene"], spp=a["spp"])  # scenes that use $spp without a default
t_loaded = time.time()
film = s.sensors()[0].film()
w, h = film.size()
def render():
    t = time.perf_counter()
    img = mi.render(s, spp=a["spp"], seed=a.get("seed", 0))
    dr.eval(img); dr.sync_thread()
    return img, time.perf_counter() - t
img, first = render()
t_first = time.time()
warm = [render()[1] for _ in range(a.get("warm", 1))]
if a.get("out"):
    mi.Bitmap(img).write(a["out"])
print("@@MI@@" + json.dumps(dict(w=w, h=h, start=t_start, loaded=t_loaded, first_end=t_first,
                               first=first, render=min(warm) if warm else first)))
"""


class Run:
    """A finished child process: rc, wall seconds, peak resident memory (MB), stdout, stderr."""

    def __init__(self, rc, wall, rss_mb, cpu, out, err, t0):
        self.rc, self.wall, self.rss_mb, self.cpu = rc, wall, rss_mb, cpu
        self.out, self.err, self.t0 = out, err, t0


WRAPPER = r"""
import os, sys
pid = os.fork()
if pid == 0:
    os.execvp(sys.argv[2], sys.argv[2:])
_, status, ru = os.wait4(pid, 0)
open(sys.argv[1], "w").write(f"{ru.ru_maxrss} {ru.ru_utime + ru.ru_stime}")
sys.exit(os.waitstatus_to_exitcode(status) & 255)
"""


def run_measured(cmd, env=None):
    """Runs `cmd` alone and measures it: wall time and its own peak RSS. The RSS comes from a
    small intermediate process (GNU time, or a bare Python that forks it): a child forked
    straight from this script would count this script's memory (Mitsuba and numpy imported)
    as its own, since the kernel's maximum includes the pages it held before exec. (The bare
    Python fallback adds its own few MB.)"""
    import tempfile
    with tempfile.TemporaryFile("w+") as fo, tempfile.TemporaryFile("w+") as fe, \
            tempfile.NamedTemporaryFile("r", suffix=".rss") as fr:
        if os.path.exists("/usr/bin/time"):
            wrap = ["/usr/bin/time", "-f", "%M %U %S", "-o", fr.name]
        else:
            wrap = [sys.executable, "-c", WRAPPER, fr.name]
        t0_wall = time.time()
        t0 = time.perf_counter()
        p = subprocess.run(wrap + [str(c) for c in cmd], stdout=fo, stderr=fe, env=env)
        wall = time.perf_counter() - t0
        fo.seek(0), fe.seek(0)
        # (GNU time may write a "Command exited with non-zero status" line first)
        last = (open(fr.name).read().strip().splitlines() or [""])[-1].split()
        try:
            rss, cpu = int(last[0]) / 1024.0, sum(float(x) for x in last[1:])
        except (ValueError, IndexError):
            rss, cpu = float("nan"), float("nan")
        return Run(p.returncode, wall, rss, cpu, fo.read(), fe.read(), t0_wall)


SUMMARY = re.compile(r"(\d+)×(\d+) at (\d+) spp \(([\w ,]+)\) in ([0-9.]+) s — ([0-9.]+) M samples/s")
TIMINGS = re.compile(r"timings: (.*); start-up ([0-9.]+) s .*render ([0-9.]+) s, write ([0-9.]+) s")


def specula_run(scene, spp=None, size=None, threads=0, sampler=None, seed=0, out=None,
                defines=(), adaptive=False):
    """One `specula render --timings`; None when the scene does not load (with its error)."""
    out = out or "/tmp/specula_bench.exr"
    cmd = [EXE, "render", scene, "--quiet", "--timings", "--threads", threads, "-o", out,
           "--seed", seed]
    if spp is not None:
        cmd += ["--spp", spp]
    if size:
        cmd += ["--size", "{}x{}".format(*size)]
    if sampler:
        cmd += ["--sampler", sampler]
    if adaptive:
        cmd += ["--adaptive"]
    for d in defines:
        cmd += ["-D", d]
    r = run_measured(cmd)
    if r.rc != 0 and "undefined parameter '$spp'" in r.err:
        r = run_measured(cmd + ["-D", f"spp={spp or 1}"])
    if r.rc != 0:
        return None, (r.err.strip().splitlines() or ["?"])[-1]
    m, t = SUMMARY.search(r.out), TIMINGS.search(r.out)
    if not (m and t):
        sys.exit(f"cannot read specula's output: {r.out!r}")
    w, h, n = int(m.group(1)), int(m.group(2)), int(m.group(3))
    phases = dict((k, float(v)) for k, v in re.findall(r"(\w+) ([0-9.]+) s", t.group(1)))
    return dict(w=w, h=h, spp=n, samples=w * h * n, wall=r.wall, rss=r.rss_mb, cpu=r.cpu,
                startup=float(t.group(2)), render=float(t.group(3)), write=float(t.group(4)),
                phases=phases), None


def mitsuba_run(scene, spp, variant="llvm_ad_rgb", threads=None, warm=1, out=None, params=None,
                seed=0):
    """Mitsuba in a fresh Python process: process time up to the end of its first (cold)
    render, the best warm render, its peak memory. None when Mitsuba fails."""
    arg = dict(variant=variant, scene=str(scene), spp=spp, threads=threads, warm=warm,
               out=out and str(out), params=params or {}, seed=seed)
    r = run_measured([sys.executable, "-c", MI_CODE, json.dumps(arg)], env=os.environ)
    line = [l for l in r.out.splitlines() if l.startswith(MI_MARK)]
    if r.rc != 0 or not line:
        last = (r.err.strip().splitlines() or ["(no message)"])[-1]
        print(f"  mitsuba {variant} failed on {pathlib.Path(scene).name}: {last}", file=sys.stderr)
        return None
    d = json.loads(line[0][len(MI_MARK):])
    d["process"] = d["first_end"] - r.t0  # launch → end of the first render
    d["rss"] = r.rss_mb
    d["samples"] = d["w"] * d["h"] * spp
    return d


def cpu_description():
    """The CPU's model and its widest vector instruction set (from /proc/cpuinfo where there is
    one), with the lane count Dr.Jit's LLVM backend compiles Mitsuba's kernels for on it: 16
    single-precision lanes with AVX-512, 8 with AVX2, 4 otherwise. Specula's own SIMD (the BVH's
    box and triangle tests, camera-ray packets) is 8 lanes wide with AVX2 on any of them, and
    its shading is scalar, so the same-run ratio depends on this: on an AVX-512 machine the
    LLVM variant runs twice the lanes of an AVX2 one."""
    info = {}
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if not line.strip():
                    break  # the first processor's block is enough
                key, _, value = line.partition(":")
                info.setdefault(key.strip(), value.strip())
    except OSError:
        pass
    model = info.get("model name", "unknown CPU")
    if "cpu family" in info:
        model += f" (family {info['cpu family']}, model {info.get('model', '?')})"
    flags = set(info.get("flags", "").split())
    if "avx512f" in flags:
        isa, lanes = "AVX-512", 16
    elif "avx2" in flags:
        isa, lanes = "AVX2", 8
    else:
        isa, lanes = "SSE", 4
    return f"{model}; {isa}: Mitsuba llvm runs {lanes} lanes, Specula's SIMD 8 (AVX2) or 4"


def have_mitsuba():
    try:
        import mitsuba  # noqa: F401
        return True
    except Exception:  # noqa: BLE001
        return False


def f_ms(v, digits=3):
    return "n/a" if v is None else f"{v:.{digits}f}"


def table(header, rows):
    print("| " + " | ".join(header) + " |")
    print("|" + "|".join("---" for _ in header) + "|")
    for r in rows:
        print("| " + " | ".join(str(c) for c in r) + " |", flush=True)
    print()


def section_throughput(a, mem):
    print(f"### Throughput ({a.spp} spp; M samples/s; best of {a.repeat}, the two renderers "
          "alternating)\n")
    rows = []
    for name in a.scenes.split(","):
        scene = scene_path(name)
        # Specula and Mitsuba take turns, so that a drift in the machine's speed (up to 1.6×
        # within an hour on the development machine) reaches both; the last column is the
        # median of the ratios of each turn's pair of runs
        runs, ms = [], []
        for _ in range(a.repeat):
            runs.append(specula_run(scene, defines=[f"spp={a.spp}"], threads=a.threads)[0])
            if a.mitsuba:
                ms.append(mitsuba_run(scene, a.spp))
        sp = max(r["samples"] / r["render"] for r in runs)
        proc = max(r["samples"] / r["wall"] for r in runs)
        mem[("specula", name)] = max(r["rss"] for r in runs)
        ml, pair = None, None
        if a.mitsuba and all(ms):
            ml = dict(render=max(m["samples"] / m["render"] for m in ms),
                      process=max(m["samples"] / m["process"] for m in ms))
            mem[("mitsuba", name)] = max(m["rss"] for m in ms)
            pair = statistics.median((r["samples"] / r["wall"]) / (m["samples"] / m["render"])
                                     for r, m in zip(runs, ms))
        r0 = runs[0]
        ratio = f"{proc / ml['render']:.2f}" if ml else "n/a"
        rows.append([name, f"{r0['w']}×{r0['h']}", f"{sp / 1e6:.3f}", f"{proc / 1e6:.3f}",
                     f_ms(ml and ml["render"] / 1e6), f_ms(ml and ml["process"] / 1e6), ratio,
                     f"{pair:.2f}" if pair else "n/a"])
    table(["scene", "size", "Specula render", "Specula process", "Mitsuba llvm render",
           "Mitsuba llvm process", "Specula process / Mitsuba render",
           "same, median of the turns' ratios"], rows)


def startup_scenes(quick):
    scenes = sorted(shared.glob("*.xml"))
    docs = sorted(DOCS.glob("*.xml"))
    if quick:
        keep = ("bsdf_bumpmap_with", "bsdf_normalmap_with", "bsdf_plastic_default",
                "shape_ply_bunny", "emitter_envmap", "integrator_direct_bsdf")
        docs = [d for d in docs if d.stem in keep]
    return scenes + docs


def section_startup(a):
    scenes = startup_scenes(a.quick)
    runs = 1 if a.quick else max(2, a.repeat)
    results, failed = [], []
    for s in scenes:
        best_run, least_cpu = None, float("inf")
        for _ in range(runs):
            r, err = specula_run(s, spp=1, size=(32, 24), threads=a.threads)
            if r is None:
                break
            least_cpu = min(least_cpu, r["cpu"])
            if best_run is None or r["startup"] < best_run["startup"]:
                best_run = r
        if best_run is not None:
            best_run["cpu"] = least_cpu
        if best_run is None:
            failed.append((s.stem, err))
        else:
            results.append((s, best_run))
    st = sorted(r["startup"] for _, r in results)
    med = st[len(st) // 2] if st else float("nan")
    cpu = sorted(r["cpu"] for _, r in results)
    over = [x for x in st if x > 0.1]
    print(f"### Start-up (before the first sample; best of {runs})\n")
    print("Wall time inside `specula render` up to its first sample; CPU: the whole process's "
          "user + system time at 1 spp, 32×24 (all threads; less sensitive to a busy "
          "machine).\n")
    table(["scenes loaded", "median (s)", "worst (s)", "over 0.1 s", "median CPU (s)",
           "worst CPU (s)", "not loadable"],
          [[len(results), f"{med:.3f}", f"{st[-1]:.3f}" if st else "n/a", len(over),
            f"{cpu[len(cpu) // 2]:.3f}" if cpu else "n/a", f"{cpu[-1]:.3f}" if cpu else "n/a",
            len(failed)]])
    slow = sorted(results, key=lambda x: -x[1]["startup"])[: a.slowest]
    phases = list(slow[0][1]["phases"]) if slow else []
    rows = []
    for s, r in slow:
        where = "scenes" if s.parent == shared else "docs"
        rows.append([f"{s.stem} ({where})", f"{r['startup']:.3f}", f"{r['cpu']:.3f}"]
                    + [f"{r['phases'][p]:.3f}" for p in phases])
    print(f"Slowest {len(slow)} (seconds per phase, on the loading thread: images decoded on "
          "other threads count as the time spent waiting for them; bvh on a thread of its "
          "own, at the same time as textures and bsdfs):\n")
    table(["scene", "start-up", "process CPU"] + phases, rows)


def section_scaling(a, mem):
    import tempfile
    sys.path.insert(0, str(root / "scripts"))
    import gen_sphere_mesh
    counts = [1000, 10_000] if a.quick else [1000, 10_000, 100_000, 1_000_000]
    spp, res = (4, 64) if a.quick else (16, 256)
    print(f"### Scaling (a sphere on a floor, {res}×{res}, {spp} spp; seconds)\n")
    rows = []
    with tempfile.TemporaryDirectory(prefix="specula-scaling-") as tmp:
        for n in counts:
            xml, tris = gen_sphere_mesh.generate(tmp, n)
            for threads in (1, 2):
                d = [f"spp={spp}", f"res={res}"]
                r, err = specula_run(xml, threads=threads, defines=d)
                if r is None:
                    sys.exit(f"specula failed on {xml}: {err}")
                m = None
                if a.mitsuba:
                    m = mitsuba_run(xml, spp, threads=threads, params=dict(spp=spp, res=res))
                if threads == 2 or os.cpu_count() == 1:
                    mem[("specula", tris)] = r["rss"]
                    if m:
                        mem[("mitsuba", tris)] = m["rss"]
                rows.append([f"{tris:,}", threads, f"{r['wall']:.3f}", f"{r['startup']:.3f}",
                             f"{r['render']:.3f}", f_ms(m and m["process"]),
                             f_ms(m and m["loaded"] - m["start"]), f_ms(m and m["render"])])
    table(["triangles", "threads", "Specula process", "Specula start-up", "Specula render",
           "Mitsuba process", "Mitsuba import + load", "Mitsuba render"], rows)


def section_memory(a, mem):
    print("### Peak resident memory (MB)\n")
    order = lambda k: ((0, "") if k == "meshes"  # noqa: E731
                       else (1, f"{k:012}") if isinstance(k, int) else (2, k))
    keys = sorted({k for _, k in mem}, key=order)
    rows = []
    for k in keys:
        s, m = mem.get(("specula", k)), mem.get(("mitsuba", k))
        name = f"sphere, {k:,} triangles" if isinstance(k, int) else k
        rows.append([name, f_ms(s, 0), f_ms(m, 0), f"{s / m:.2f}" if s and m else "n/a"])
    table(["scene", "Specula", "Mitsuba llvm (Python process)", "ratio"], rows)


def read_exr(path):
    import mitsuba as mi
    import numpy as np
    mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(str(path)).convert(mi.Bitmap.PixelFormat.RGB,
                                                 mi.Struct.Type.Float32, False),
                    dtype=np.float64)[..., :3]


def relmse(img, ref):
    """../shared/README.md: per pixel mean over channels of (img − ref)²/(ref² + 0.01), the
    ⌊0.001·pixels⌋ largest discarded, the mean of the rest; NaN/Inf count as huge."""
    import numpy as np
    e = ((img - ref) ** 2 / (ref ** 2 + 0.01)).mean(axis=2).ravel()
    e = np.where(np.isfinite(e), e, 1e30)
    drop = int(0.001 * e.size)
    e = np.sort(e)[: e.size - drop] if drop else e
    return float(e.mean())


def section_equal_error(a):
    import math
    scenes = ["cbox"] if a.quick else ["cbox", "mat_rough_copper", "veach_mis", "envmap_spheres"]
    metrics = json.load(open(REFS / "metrics.json"))
    print(f"### Time to equal error (Specula `--sampler {a.tee_sampler}`, whole process, vs "
          f"Mitsuba llvm_ad_rgb's 64-spp relMSE)\n")
    if not a.mitsuba:
        print("(needs Mitsuba to read the references: skipped)\n")
        return
    rows = []
    ladder = [4, 8, 16, 32, 64] if a.quick else [4, 8, 16, 32, 64, 128, 256, 512]
    for name in scenes:
        scene = scene_path(name)
        target = metrics[name]["mitsuba_64spp_relmse"]
        ref = read_exr(REFS / f"{name}.exr")
        m = mitsuba_run(scene, 64, warm=1)
        for adaptive in (False, True):
            pts = []  # (spp, relmse, wall)
            for spp in ladder:
                out = f"/tmp/specula_tee_{name}.exr"
                r, err = specula_run(scene, spp=spp, sampler=a.tee_sampler, threads=a.threads,
                                     out=out, adaptive=adaptive)
                if r is None:
                    sys.exit(f"specula failed on {name}: {err}")
                e = relmse(read_exr(out), ref)
                pts.append((r["spp"], e, r["wall"]))
                if e <= target:
                    break
            # log-log interpolation of relMSE between the two sample counts around the
            # target; time linear in spp between them
            t_eq, spp_eq = None, None
            for (s0, e0, t0), (s1, e1, t1) in zip(pts, pts[1:]):
                if e0 > target >= e1:
                    f = (math.log(e0) - math.log(target)) / (math.log(e0) - math.log(e1))
                    spp_eq = math.exp(math.log(s0) + f * (math.log(s1) - math.log(s0)))
                    t_eq = t0 + (spp_eq - s0) / (s1 - s0) * (t1 - t0)
            if t_eq is None and pts and pts[0][1] <= target:
                spp_eq, t_eq = pts[0][0], pts[0][2]  # already there at the first count
            ladder_s = ", ".join(f"{s}: {e:.4g} in {t:.2f} s" for s, e, t in pts)
            rows.append([name, "adaptive" if adaptive else "uniform", f"{target:.4g}",
                         f_ms(m and m["render"], 2), f_ms(m and m["process"], 2),
                         f"{spp_eq:.0f}" if spp_eq else "not reached",
                         f_ms(t_eq, 2),
                         f"{t_eq / m['render']:.2f}" if (t_eq and m) else "n/a",
                         ladder_s])
    table(["scene", "Specula sampling", "Mitsuba 64-spp relMSE", "Mitsuba 64 spp render (s)",
           "Mitsuba process (s)", "Specula spp to match", "Specula process (s)",
           "ratio to Mitsuba render", "Specula spp: relMSE in time"], rows)


def main_all(a):
    global EXE
    EXE = os.environ.get("SPECULA_EXE") or root / "target" / "release" / "specula"
    a.mitsuba = not a.no_mitsuba and have_mitsuba()
    if a.quick:
        a.spp = 16 if a.spp == 256 else a.spp
    sections = [s for s in ("throughput", "startup", "scaling", "memory", "equal_error")
                if getattr(a, s) or a.all]
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    mi_version = "absent"
    if a.mitsuba:
        import mitsuba
        mi_version = mitsuba.__version__
    print(f"Specula ({EXE}) beside Mitsuba {mi_version} (llvm_ad_rgb), {os.cpu_count()} cores, "
          f"load average {load:.2f} at start{', quick' if a.quick else ''}\n\n"
          f"CPU: {cpu_description()}\n")
    mem = {}
    t = time.perf_counter()
    if "throughput" in sections or "memory" in sections:
        section_throughput(a, mem)
    if "startup" in sections:
        section_startup(a)
    if "scaling" in sections or "memory" in sections:
        section_scaling(a, mem)
    if "memory" in sections:
        section_memory(a, mem)
    if "equal_error" in sections:
        section_equal_error(a)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"({time.perf_counter() - t:.0f} s; load average {load:.2f} at the end)")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--scenes", default="cbox,meshes,veach_mis")
    ap.add_argument("--media", action="store_true", help=f"the media scenes: {MEDIA}")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--no-mitsuba", action="store_true")
    ap.add_argument("--all", action="store_true", help="every section below")
    ap.add_argument("--throughput", action="store_true")
    ap.add_argument("--startup", action="store_true")
    ap.add_argument("--scaling", action="store_true")
    ap.add_argument("--memory", action="store_true")
    ap.add_argument("--equal-error", dest="equal_error", action="store_true")
    ap.add_argument("--quick", action="store_true", help="a fast smoke run of the sections")
    ap.add_argument("--tee-sampler", default="sobol",
                    help="Specula's sampler for --equal-error (default sobol)")
    ap.add_argument("--slowest", type=int, default=8,
                    help="how many of the slowest start-ups to break down (default 8)")
    a = ap.parse_args()
    if a.media:
        a.scenes = MEDIA
    if not os.environ.get("DRJIT_LIBLLVM_PATH") and os.path.exists(LLVM):
        os.environ["DRJIT_LIBLLVM_PATH"] = LLVM
    if a.all or a.throughput or a.startup or a.scaling or a.memory or a.equal_error:
        return main_all(a)
    names = a.scenes.split(",")
    width = max(12, *(len(n) for n in names))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{a.spp} spp, {os.cpu_count()} cores, load average {load:.2f} at start; "
          f"M samples/s, best of {a.repeat}")
    print(f"CPU: {cpu_description()}")
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
