#!/usr/bin/env python3
"""Compare Specula's render of Mitsuba's docs scene `integrator_aov.xml` (which has no
reference image) with Mitsuba 3.9.1's render of the same file, channel by channel.

Developer tool only. Usage:
    specula render ../shared/mitsuba-data/docs/scenes/integrator_aov.xml --size 64x48 -o /tmp/aov.exr
    python3 scripts/compare_docs_aov.py /tmp/aov.exr [path/to/integrator_aov.xml]
Mitsuba renders the file with its film resized to Specula's image (as the docs references are
made). Prints, per channel, both means and the median and 99th percentile of the per-pixel
absolute difference (the AOVs are deterministic where a pixel is covered by one surface; pixel
positions are random in both renderers, so silhouettes differ, and the nested path tracer's
image is noisy).
"""
import sys, pathlib
import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
exr = sys.argv[1]
root = pathlib.Path(__file__).resolve().parent.parent
xml = sys.argv[2] if len(sys.argv) > 2 else str(root / "../shared/mitsuba-data/docs/scenes/integrator_aov.xml")

def channels(bmp):
    a = np.array(bmp)
    st = bmp.struct_()
    return {st[i].name: a[:, :, i] for i in range(len(st))}

ours = channels(mi.Bitmap(exr))
h, w = next(iter(ours.values())).shape
scene = mi.load_file(xml)
params = mi.traverse(scene)
for k in list(params.keys()):
    if k.endswith("film.size") or k.endswith("film.crop_size"):
        params[k] = mi.ScalarVector2u(w, h)
params.update()
mi.render(scene)
film = scene.sensors()[0].film()
theirs = channels(film.bitmap())
print(f"{'channel':10s} {'Specula mean':>13s} {'Mitsuba mean':>13s} {'median |d|':>11s} {'p99 |d|':>9s}")
for name in sorted(theirs):
    if name not in ours:
        print(f"{name:10s} missing in Specula's image")
        continue
    a, b = ours[name], theirs[name]
    d = np.abs(a - b)
    print(f"{name:10s} {a.mean():13.5f} {b.mean():13.5f} {np.median(d):11.2e} {np.percentile(d, 99):9.2e}")
extra = sorted(set(ours) - set(theirs))
if extra:
    print("only in Specula's image:", extra)
