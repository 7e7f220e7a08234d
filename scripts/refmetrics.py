"""What Specula's reference scripts share: the error metrics of ../shared/README.md and the
Mitsuba 3 loop that renders a reference and measures Mitsuba's own 64-spp error against it.

Developer tool only (CI never runs the scripts that use it). `mitsuba` is imported by the
functions that render, so the metric functions work without it.
"""
import re

import numpy as np


def relmse(img, ref, trim=True):
    """../shared/README.md: per pixel, the mean over channels of (img − ref)² / (ref² + 0.01);
    NaN or infinite values count as 1e30; the ⌊0.001·pixels⌋ largest are discarded (unless
    `trim` is false) and the rest averaged."""
    assert img.shape == ref.shape, (img.shape, ref.shape)
    with np.errstate(invalid="ignore", over="ignore"):
        e = ((img - ref) ** 2 / (ref**2 + 0.01)).mean(axis=2).ravel()
    e = np.where(np.isfinite(e), e, 1e30)
    k = int(0.001 * e.size)
    e = np.sort(e)[: e.size - k] if trim and k > 0 else e
    return float(e.mean())


def block(a, k=8):
    """Means over k×k blocks (a partial last row or column of blocks is dropped)."""
    h, w = a.shape[0] // k * k, a.shape[1] // k * k
    return a[:h, :w].reshape(h // k, k, w // k, k, a.shape[2]).mean((1, 3))


def block8(img, ref):
    """The block8 metric: relMSE of the 8×8 block means."""
    return relmse(block(img), block(ref))


def defaults(text):
    """A scene file's `<default name=… value=…/>` parameters."""
    return {m.group(1): m.group(2) for m in re.finditer(r'<default name="(\w+)" value="([^"]*)"', text)}


def render_rgb(scene, spp, seed):
    """Mitsuba's render of `scene`, its first three channels, in float64."""
    import mitsuba as mi

    return np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)[..., :3]


def reference(scene, spp, pass_spp=256, first_seed=1000):
    """A reference of `spp` samples per pixel: the mean of spp / pass_spp renders of pass_spp
    samples with seeds first_seed, first_seed + 1, …"""
    passes = max(1, spp // pass_spp)
    acc = None
    for i in range(passes):
        img = render_rgb(scene, min(spp, pass_spp), first_seed + i)
        acc = img if acc is None else acc + img
    return acc / passes


def own_error(scene, ref, seeds=2, spp=64):
    """Mitsuba's own error at `spp` against `ref`, averaged over seeds 0..seeds-1: the metrics
    entries `mitsuba_64spp_relmse`, `mitsuba_64spp_block8` and `mitsuba_64spp_mean_ratio`."""
    rel, b8, ratio = [], [], []
    for seed in range(seeds):
        img = render_rgb(scene, spp, seed)
        rel.append(relmse(img, ref))
        b8.append(block8(img, ref))
        ratio.append(img.mean((0, 1)) / ref.mean((0, 1)))
    return {
        "mitsuba_64spp_relmse": float(np.mean(rel)),
        "mitsuba_64spp_block8": float(np.mean(b8)),
        "mitsuba_64spp_mean_ratio": np.mean(ratio, 0).tolist(),
    }
