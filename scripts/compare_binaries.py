#!/usr/bin/env python3
"""Compare two `specula` binaries on every scene of ../shared/mitsuba-data/docs/scenes and
../shared/scenes: start-up time and process CPU, and whether their images are the same bits.

    python3 scripts/compare_binaries.py OLD NEW                 # images + start-up, every scene
    python3 scripts/compare_binaries.py OLD NEW --repeat 5 --min-cpu 0.08   # timing only the slow
    python3 scripts/compare_binaries.py OLD NEW --images-only
    python3 scripts/compare_binaries.py OLD NEW --filter bsdf_normalmap

Each scene renders at 32×24, 1 spp, seed 0 (`--size`, `--spp` change them), with the two
binaries alternating so that both see the same load. Start-up is `specula render --timings`'s
"start-up" (wall time before the first sample); CPU is the process's user + system time (GNU
time), the least of the runs; wall is the process's wall time. Images are compared as the
bytes of the EXR files written (same bits: same pixels, same header) and, where the bytes
differ and Mitsuba's Python package is installed, as decoded pixels (files written before
Specula stored EXR tiles in increasing order have another header). Prints one line per
scene and a summary; exits 1 when any image differs or a scene loads in one binary only.
"""
import argparse, os, pathlib, re, subprocess, sys, tempfile, time

root = pathlib.Path(__file__).resolve().parent.parent
shared = root.parent / "shared"
TIMINGS = re.compile(r"start-up ([0-9.]+) s")


def scenes(filt):
    out = sorted((shared / "scenes").glob("*.xml")) + sorted(
        (shared / "mitsuba-data" / "docs" / "scenes").glob("*.xml"))
    return [s for s in out if not filt or re.search(filt, s.stem)]


def run(exe, scene, out, a):
    cmd = ["/usr/bin/time", "-f", "TIME %e %U %S", exe, "render", str(scene), "--quiet",
           "--timings", "-o", out, "--seed", "0", "--spp", str(a.spp), "--size", a.size,
           "--threads", str(a.threads)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0 and "undefined parameter '$spp'" in p.stderr:
        p = subprocess.run(cmd + ["-D", f"spp={a.spp}"], capture_output=True, text=True)
    tl = [l for l in p.stderr.splitlines() if l.startswith("TIME ")]
    if p.returncode != 0 or not tl:
        err = [l for l in p.stderr.splitlines() if not l.startswith(("TIME ", "Command exited"))]
        return None, (err or ["?"])[-1]
    wall, u, s = (float(x) for x in tl[-1].split()[1:])
    m = TIMINGS.search(p.stdout)
    return dict(wall=wall, cpu=u + s, startup=float(m.group(1)) if m else float("nan")), None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--min-cpu", type=float, default=0.0,
                    help="time only scenes whose first run took at least this CPU (s)")
    ap.add_argument("--filter", default="")
    ap.add_argument("--size", default="32x24")
    ap.add_argument("--spp", type=int, default=1)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--images-only", action="store_true")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="specula_cmp_")
    oa, ob = os.path.join(tmp, "old.exr"), os.path.join(tmp, "new.exr")
    print(f"load average at start: {os.getloadavg()}")
    hdr = f"{'scene':42s} {'image':9s} {'start-up old/new':>18s} {'CPU old/new':>14s} {'wall old/new':>14s}"
    print(hdr)
    bad, loaded, failed, rows = 0, 0, [], []
    for s in scenes(a.filter):
        ra, ea = run(a.old, s, oa, a)
        rb, eb = run(a.new, s, ob, a)
        name = f"{s.parent.parent.name}/{s.stem}" if s.parent.name == "scenes" else s.stem
        if ra is None or rb is None:
            if (ra is None) != (rb is None):
                bad += 1
                print(f"{name:42s} LOADS IN ONE ONLY: old: {ea if ra is None else 'ok'}; "
                      f"new: {eb if rb is None else 'ok'}")
            else:
                failed.append(name)
            continue
        loaded += 1
        same = open(oa, "rb").read() == open(ob, "rb").read()
        if not same:
            # files written before Specula stored EXR tiles in increasing order differ in
            # their headers (and could differ in tile order): compare the decoded pixels
            same = same_pixels(oa, ob)
        if not same:
            bad += 1
        runs_a, runs_b = [ra], [rb]
        if not a.images_only and max(ra["cpu"], rb["cpu"]) >= a.min_cpu:
            for _ in range(a.repeat - 1):
                runs_a.append(run(a.old, s, oa, a)[0])
                runs_b.append(run(a.new, s, ob, a)[0])
        best = lambda rs, k: min(r[k] for r in rs)
        line = f"{name:42s} {'same' if same else 'DIFFERENT':9s}"
        if not a.images_only:
            line += (f" {best(runs_a, 'startup'):8.3f}/{best(runs_b, 'startup'):<8.3f}"
                     f" {best(runs_a, 'cpu'):6.2f}/{best(runs_b, 'cpu'):<6.2f}"
                     f" {best(runs_a, 'wall'):6.2f}/{best(runs_b, 'wall'):<6.2f}")
        print(line, flush=True)
    print(f"\n{loaded} scenes loaded by both, {bad} differing (image or loadability), "
          f"{len(failed)} not loadable by either; load average at end: {os.getloadavg()}")
    sys.exit(1 if bad else 0)


def same_pixels(a, b):
    """Whether two EXR files hold the same pixels bit for bit (decoded by Mitsuba's Bitmap when
    `pip install mitsuba numpy` is available; otherwise False)."""
    try:
        import mitsuba as mi
        import numpy as np
        mi.set_variant("scalar_rgb")
    except Exception:
        return False
    x, y = np.array(mi.Bitmap(a)), np.array(mi.Bitmap(b))
    return x.shape == y.shape and bool((x.view(np.uint32) == y.view(np.uint32)).all())


if __name__ == "__main__":
    main()
