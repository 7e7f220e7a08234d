#!/usr/bin/env python3
"""Render CPU time of two `specula` binaries on the same scenes, alternated so that both see the
same load, one thread: the least user + system time of `--repeat` runs each.

    python3 scripts/compare_cpu.py OLD NEW                      # cbox, meshes, veach_mis, envmap_spheres
    python3 scripts/compare_cpu.py OLD NEW --spp 32 --repeat 9 --scenes cbox
    python3 scripts/compare_cpu.py OLD NEW --sampler sobol  # the sampler time to equal error uses

Scenes are ../shared/scenes/NAME.xml at their own film size. On a machine whose speed drifts,
only the ratio printed in the last column means anything; for a change of a few percent use
many repeats.
"""
import argparse
import pathlib
import resource
import subprocess
import tempfile

root = pathlib.Path(__file__).resolve().parent.parent
shared = root.parent / "shared"


def cpu(exe, scene, spp, out, sampler=None):
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    extra = ["--sampler", sampler] if sampler else []
    subprocess.run([exe, "render", str(shared / "scenes" / f"{scene}.xml"), "--spp", str(spp),
                    "--threads", "1", "--quiet", "-o", out] + extra, check=True,
                   capture_output=True)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--scenes", default="cbox,meshes,veach_mis,envmap_spheres")
    ap.add_argument("--sampler", help="render with this sampler (default: the scene's own)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = str(pathlib.Path(tmp) / "out.exr")
        print("| scene | old CPU (s) | new CPU (s) | new / old |")
        print("|---|---|---|---|")
        for s in a.scenes.split(","):
            old = new = float("inf")
            for _ in range(a.repeat):
                old = min(old, cpu(a.old, s, a.spp, out, a.sampler))
                new = min(new, cpu(a.new, s, a.spp, out, a.sampler))
            print(f"| {s} | {old:.3f} | {new:.3f} | {new / old:.3f} |", flush=True)


if __name__ == "__main__":
    main()
