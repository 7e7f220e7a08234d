#!/usr/bin/env python3
"""Instructions per sample of Specula and of Mitsuba 3's `llvm_ad_rgb`, counted by callgrind
(noise-free, unlike timings on a shared machine), split into ray traversal and the rest.

    python3 scripts/count_instructions.py                 # cbox at 64x64
    python3 scripts/count_instructions.py --scene veach_mis --size 64x48 --no-mitsuba
    # an A/B of two Specula binaries (same images expected), no Mitsuba:
    python3 scripts/count_instructions.py --exe OLD --exe NEW --scene cbox,meshes --no-mitsuba

Each renderer runs under `valgrind --tool=callgrind` at two sample counts (--low, --high) on one
thread; the difference divided by the extra samples is the per-sample cost, free of start-up,
parsing and Python. Specula's traversal is what its BVH walks count (functions in
`specula_render::accel`), the rest everything else; Mitsuba's traversal is Embree's and its
rest the JIT-compiled kernels (code without symbols), leaving out the kernels' compilation,
Python and Dr.Jit's own bookkeeping. Valgrind reports no
AVX-512, so under it Mitsuba's kernels and Embree use AVX2 (8 lanes), not the 16 lanes they
get natively on an AVX-512 CPU. Needs valgrind; Mitsuba (pip install mitsuba, and
DRJIT_LIBLLVM_PATH set to a libLLVM) unless --no-mitsuba. About a minute per Mitsuba run.
"""
import argparse, os, pathlib, re, subprocess, sys, tempfile

root = pathlib.Path(__file__).resolve().parent.parent
shared = root.parent / "shared"
LINE = re.compile(r"\s*([\d,]+)\s+\(\s*[\d.]+%\)\s+(.*)$")

MITSUBA = """
import sys, mitsuba as mi, drjit as dr
mi.set_variant('llvm_ad_rgb')
dr.set_thread_count(1)
w, h, spp = int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
scene = mi.load_file(sys.argv[1])
p = mi.traverse(scene.sensors()[0].film())
p['size'] = [w, h]; p['crop_size'] = [w, h]; p.update()
dr.eval(mi.render(scene, spp=spp))
"""


def callgrind(cmd, out):
    subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=" + out] + cmd,
                   check=True, capture_output=True)
    # inclusive=no, every function (threshold 100 %), names with their object
    text = subprocess.run(["callgrind_annotate", "--threshold=100", "--auto=no", out],
                          capture_output=True, text=True, check=True).stdout
    total, parts = 0, {}
    for line in text.splitlines():
        m = LINE.match(line)
        if not m:
            continue
        n = int(m.group(1).replace(",", ""))
        if "PROGRAM TOTALS" in m.group(2):
            total = n
            continue
        parts[m.group(2)] = parts.get(m.group(2), 0) + n
    return total, parts


def measure(label, cmd_for, is_traversal, is_rest, a, pixels):
    """`is_rest`: the functions counted as the rest (None: everything but the traversal)."""
    res = []
    with tempfile.TemporaryDirectory() as d:
        for spp in (a.low, a.high):
            total, parts = callgrind(cmd_for(spp), os.path.join(d, f"cg.{spp}"))
            trav = sum(n for name, n in parts.items() if is_traversal(name))
            rest = total - trav if is_rest is None else sum(
                n for name, n in parts.items() if is_rest(name))
            res.append((trav, rest))
    extra = (a.high - a.low) * pixels
    trav = (res[1][0] - res[0][0]) / extra
    rest = (res[1][1] - res[0][1]) / extra
    print(f"| {label} | {trav + rest:.0f} | {trav:.0f} | {rest:.0f} |")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="cbox",
                    help="one scene or a comma-separated list (names from ../shared/scenes, or "
                         "paths ending in .xml)")
    ap.add_argument("--size", default="64x64")
    ap.add_argument("--low", type=int, default=4)
    ap.add_argument("--high", type=int, default=36)
    ap.add_argument("--sampler", help="Specula's sampler (default: the scene's own)")
    ap.add_argument("--exe", action="append",
                    help="a Specula binary (repeat to compare; default $SPECULA_EXE or "
                         "target/release/specula)")
    ap.add_argument("--no-mitsuba", action="store_true")
    a = ap.parse_args()
    w, h = (int(v) for v in a.size.split("x"))
    exes = a.exe or [os.environ.get("SPECULA_EXE", str(root / "target" / "release" / "specula"))]
    for name in a.scene.split(","):
        # a name from ../shared/scenes, or the path of a scene file
        scene = pathlib.Path(name) if name.endswith(".xml") else shared / "scenes" / f"{name}.xml"
        print(f"Instructions per sample, {name} at {w}x{h} (callgrind, {a.high} - {a.low} spp, "
              "one thread)\n")
        print("| renderer | total | traversal | rest |")
        print("|---|---|---|---|")
        with tempfile.TemporaryDirectory() as d:
            img = os.path.join(d, "out.exr")
            extra = ["--sampler", a.sampler] if a.sampler else []
            for exe in exes:
                label = "Specula" if len(exes) == 1 else f"Specula `{exe}`"
                measure(label,
                        lambda spp: [exe, "render", str(scene), "--spp", str(spp), "--size",
                                     a.size, "--threads", "1", "--quiet", "-o", img] + extra,
                        lambda fn: "specula_render::accel" in fn, None, a, w * h)
        if not a.no_mitsuba:
            mitsuba(scene, w, h, a)
        print()


def mitsuba(scene, w, h, a):
    # the interpreter itself, not a shim script (valgrind would stop at its exec)
    py = os.path.realpath(sys.executable)
    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:
        f.write(MITSUBA)
    try:
        measure("Mitsuba llvm_ad_rgb (AVX2 under valgrind)",
                lambda spp: [py, f.name, str(scene), str(w), str(h), str(spp)],
                lambda name: "embree" in name,
                # its JIT-compiled kernels (no symbols), not Python, LLVM or the loader
                lambda name: name.startswith("???:0x") and name.endswith("[???]"), a, w * h)
    finally:
        os.unlink(f.name)


if __name__ == "__main__":
    main()
