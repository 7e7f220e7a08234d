#!/usr/bin/env python3
"""Generate the "agreement with Mitsuba 3" fixture for specula-bsdf.

Developer tool only: CI never runs it (CI has no Mitsuba). The output is committed as
crates/specula-bsdf/tests/data/mitsuba_fixture.txt and read by
crates/specula-bsdf/tests/mitsuba_agreement.rs.

How to run (needs `pip install mitsuba==3.9.1`; numpy is not needed):

    python3 scripts/gen_mitsuba_fixture.py

For every configuration below (a Specula spec string and the equivalent Mitsuba dict) it draws
random direction pairs with a fixed seed and records what Mitsuba's `scalar_rgb` variant
returns, in radiance mode (`mi.BSDFContext()`):

    model <id> <spec string up to the end of the line>
    eval wi.x wi.y wi.z wo.x wo.y wo.z r g b pdf
    sample wi.x wi.y wi.z s1 s2.x s2.y wo.x wo.y wo.z pdf r g b delta

`eval` lines hold Mitsuba's eval (f·|cosθo|, RGB) and pdf. `sample` lines hold Mitsuba's
sample(): the sampled direction, its pdf and its weight (value/pdf), and `delta` = 1 when the
sampled lobe is a Dirac lobe (then the direction is deterministic and comparable), 0 otherwise
(then only Specula's eval/pdf at Mitsuba's direction are comparable, because the warps that map
(s1, s2) to a direction differ). A failed sample is written with pdf 0 and weight 0.

Where Specula's defaults deliberately differ from Mitsuba's, the recorded spec strings select
Specula's Mitsuba-compatible options (see `mitsuba_compat`).

All inputs are rounded to float32 before they are given to Mitsuba, and every number is written
with the shortest decimal that reads back as the same float32, so both sides see bit-identical
inputs. Lines starting with '#' are comments.
"""
import math
import pathlib
import random
import re
import struct

import mitsuba as mi

mi.set_variant("scalar_rgb")

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "crates/specula-bsdf/tests/data/mitsuba_fixture.txt"
SEED = 20240611


def f32(x):
    return struct.unpack("f", struct.pack("f", float(x)))[0]


def fmt(x):
    """Shortest decimal that reads back as the same float32."""
    x = f32(x)
    if x == 0.0:
        return "0" if math.copysign(1.0, x) > 0 else "-0"
    for p in range(1, 10):
        s = "%.*g" % (p, x)
        if f32(float(s)) == x:
            return s
    return repr(x)


def rgb(*v):
    return {"type": "rgb", "value": list(v)}


# ---------------------------------------------------------------------------------------------
# Configurations: (Specula spec, Mitsuba dict, kind). kind picks the direction generator:
#   "reflect"  one-sided reflection model (upper hemisphere; a few wo below)
#   "twosided" reflection model made two-sided (wi on both sides)
#   "rough-dielectric"  reflection and transmission on both sides
#   "delta"    only Dirac lobes: sample() lines only
# alpha: typical roughness (to aim direction pairs at the glossy peak), or None.

CU_GGX = {"type": "roughconductor", "material": "Cu", "alpha": 0.2, "distribution": "ggx"}

CONFIGS = [
    # diffuse
    ("diffuse", {"type": "diffuse"}, "reflect", None),
    ("diffuse reflectance=0.8", {"type": "diffuse", "reflectance": 0.8}, "reflect", None),
    ("diffuse reflectance=0.2,0.5,0.9",
     {"type": "diffuse", "reflectance": rgb(0.2, 0.5, 0.9)}, "reflect", None),
    # roughconductor
    ("roughconductor", {"type": "roughconductor"}, "reflect", 0.1),
    ("roughconductor material=Cu alpha=0.2 distribution=ggx", CU_GGX, "reflect", 0.2),
    ("roughconductor material=Cu alpha=0.05 distribution=beckmann",
     {"type": "roughconductor", "material": "Cu", "alpha": 0.05, "distribution": "beckmann"},
     "reflect", 0.05),
    ("roughconductor material=Au alpha=0.6 distribution=ggx",
     {"type": "roughconductor", "material": "Au", "alpha": 0.6, "distribution": "ggx"},
     "reflect", 0.6),
    ("roughconductor material=Al alpha=0.2 distribution=beckmann",
     {"type": "roughconductor", "material": "Al", "alpha": 0.2, "distribution": "beckmann"},
     "reflect", 0.2),
    ("roughconductor material=none alpha=0.05 distribution=ggx",
     {"type": "roughconductor", "material": "none", "alpha": 0.05, "distribution": "ggx"},
     "reflect", 0.05),
    ("roughconductor material=none alpha=0.6 distribution=beckmann",
     {"type": "roughconductor", "material": "none", "alpha": 0.6, "distribution": "beckmann"},
     "reflect", 0.6),
    ("roughconductor eta=0.2,0.9,1.1 k=3.9,2.4,2.1 alpha=0.2 distribution=ggx",
     {"type": "roughconductor", "eta": rgb(0.2, 0.9, 1.1), "k": rgb(3.9, 2.4, 2.1),
      "alpha": 0.2, "distribution": "ggx"}, "reflect", 0.2),
    ("roughconductor eta=1.5 k=2 alpha_u=0.05 alpha_v=0.3 distribution=ggx",
     {"type": "roughconductor", "eta": 1.5, "k": 2.0, "alpha_u": 0.05, "alpha_v": 0.3,
      "distribution": "ggx"}, "reflect", (0.05, 0.3)),
    ("roughconductor material=Au alpha_u=0.3 alpha_v=0.1 distribution=beckmann",
     {"type": "roughconductor", "material": "Au", "alpha_u": 0.3, "alpha_v": 0.1,
      "distribution": "beckmann"}, "reflect", (0.3, 0.1)),
    ("roughconductor material=Cu alpha=0.2 distribution=ggx sample_visible=false",
     dict(CU_GGX, sample_visible=False), "reflect", 0.2),
    ("roughconductor material=Al alpha_u=0.05 alpha_v=0.3 distribution=beckmann "
     "sample_visible=false",
     {"type": "roughconductor", "material": "Al", "alpha_u": 0.05, "alpha_v": 0.3,
      "distribution": "beckmann", "sample_visible": False}, "reflect", (0.05, 0.3)),
    ("roughconductor material=Au alpha=0.6 distribution=beckmann sample_visible=false",
     {"type": "roughconductor", "material": "Au", "alpha": 0.6, "distribution": "beckmann",
      "sample_visible": False}, "reflect", 0.6),
    ("roughconductor material=Cu alpha=0.2 distribution=ggx specular_reflectance=0.5,0.8,1",
     dict(CU_GGX, specular_reflectance=rgb(0.5, 0.8, 1.0)), "reflect", 0.2),
    # roughdielectric
    ("roughdielectric", {"type": "roughdielectric"}, "rough-dielectric", 0.1),
    ("roughdielectric distribution=ggx alpha=0.1 int_ior=bk7",
     {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.1, "int_ior": "bk7"},
     "rough-dielectric", 0.1),
    ("roughdielectric distribution=ggx alpha=0.4 int_ior=water",
     {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.4, "int_ior": "water"},
     "rough-dielectric", 0.4),
    ("roughdielectric distribution=beckmann alpha=0.4 int_ior=diamond",
     {"type": "roughdielectric", "distribution": "beckmann", "alpha": 0.4,
      "int_ior": "diamond"}, "rough-dielectric", 0.4),
    ("roughdielectric distribution=beckmann alpha=0.1 int_ior=1.7",
     {"type": "roughdielectric", "distribution": "beckmann", "alpha": 0.1, "int_ior": 1.7},
     "rough-dielectric", 0.1),
    ("roughdielectric distribution=ggx alpha_u=0.1 alpha_v=0.4 int_ior=1.7",
     {"type": "roughdielectric", "distribution": "ggx", "alpha_u": 0.1, "alpha_v": 0.4,
      "int_ior": 1.7}, "rough-dielectric", (0.1, 0.4)),
    ("roughdielectric distribution=beckmann alpha_u=0.4 alpha_v=0.1 int_ior=water",
     {"type": "roughdielectric", "distribution": "beckmann", "alpha_u": 0.4, "alpha_v": 0.1,
      "int_ior": "water"}, "rough-dielectric", (0.4, 0.1)),
    ("roughdielectric distribution=ggx alpha=0.1 int_ior=bk7 sample_visible=false",
     {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.1, "int_ior": "bk7",
      "sample_visible": False}, "rough-dielectric", 0.1),
    ("roughdielectric distribution=beckmann alpha=0.4 int_ior=water sample_visible=false",
     {"type": "roughdielectric", "distribution": "beckmann", "alpha": 0.4, "int_ior": "water",
      "sample_visible": False}, "rough-dielectric", 0.4),
    ("roughdielectric distribution=ggx alpha=0.2 int_ior=1 ext_ior=1.5",
     {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.2, "int_ior": 1.0,
      "ext_ior": 1.5}, "rough-dielectric", 0.2),
    # plastic (eval/pdf of the diffuse part, sample() of both lobes)
    ("plastic", {"type": "plastic"}, "reflect", None),
    ("plastic diffuse_reflectance=0.6,0.15,0.1",
     {"type": "plastic", "diffuse_reflectance": rgb(0.6, 0.15, 0.1)}, "reflect", None),
    ("plastic diffuse_reflectance=0.6,0.15,0.1 nonlinear=true",
     {"type": "plastic", "diffuse_reflectance": rgb(0.6, 0.15, 0.1), "nonlinear": True},
     "reflect", None),
    ("plastic int_ior=1.9 diffuse_reflectance=0.3",
     {"type": "plastic", "int_ior": 1.9, "diffuse_reflectance": 0.3}, "reflect", None),
    ("plastic int_ior=water nonlinear=true",
     {"type": "plastic", "int_ior": "water", "nonlinear": True}, "reflect", None),
    ("plastic int_ior='acrylic glass' specular_reflectance=0.7",
     {"type": "plastic", "int_ior": "acrylic glass", "specular_reflectance": 0.7},
     "reflect", None),
    # roughplastic
    ("roughplastic", {"type": "roughplastic"}, "reflect", 0.1),
    ("roughplastic distribution=ggx alpha=0.1",
     {"type": "roughplastic", "distribution": "ggx", "alpha": 0.1}, "reflect", 0.1),
    ("roughplastic distribution=ggx alpha=0.3 diffuse_reflectance=0.6,0.15,0.1",
     {"type": "roughplastic", "distribution": "ggx", "alpha": 0.3,
      "diffuse_reflectance": rgb(0.6, 0.15, 0.1)}, "reflect", 0.3),
    ("roughplastic distribution=beckmann alpha=0.3 nonlinear=true "
     "diffuse_reflectance=0.6,0.15,0.1",
     {"type": "roughplastic", "distribution": "beckmann", "alpha": 0.3, "nonlinear": True,
      "diffuse_reflectance": rgb(0.6, 0.15, 0.1)}, "reflect", 0.3),
    ("roughplastic distribution=ggx alpha=0.3 int_ior=1.9 nonlinear=true",
     {"type": "roughplastic", "distribution": "ggx", "alpha": 0.3, "int_ior": 1.9,
      "nonlinear": True}, "reflect", 0.3),
    ("roughplastic distribution=beckmann alpha=0.1 sample_visible=false",
     {"type": "roughplastic", "distribution": "beckmann", "alpha": 0.1,
      "sample_visible": False}, "reflect", 0.1),
    # twosided
    ("twosided { diffuse reflectance=0.2,0.5,0.9 }",
     {"type": "twosided", "a": {"type": "diffuse", "reflectance": rgb(0.2, 0.5, 0.9)}},
     "twosided", None),
    ("twosided { roughconductor material=Cu alpha=0.2 distribution=ggx }",
     {"type": "twosided", "a": CU_GGX}, "twosided", 0.2),
    ("twosided { diffuse reflectance=0.8 } { roughconductor material=Au alpha=0.3 }",
     {"type": "twosided", "a": {"type": "diffuse", "reflectance": 0.8},
      "b": {"type": "roughconductor", "material": "Au", "alpha": 0.3}}, "twosided", 0.3),
    # blendbsdf
    ("blendbsdf weight=0.3 { diffuse reflectance=0.8 } "
     "{ roughconductor material=Cu alpha=0.2 distribution=ggx }",
     {"type": "blendbsdf", "weight": 0.3, "a": {"type": "diffuse", "reflectance": 0.8},
      "b": CU_GGX}, "reflect", 0.2),
    ("blendbsdf weight=0.7 { roughplastic distribution=ggx alpha=0.3 } "
     "{ roughconductor material=Au alpha=0.1 }",
     {"type": "blendbsdf", "weight": 0.7,
      "a": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.3},
      "b": {"type": "roughconductor", "material": "Au", "alpha": 0.1}}, "reflect", 0.2),
    ("blendbsdf weight=0.3 { diffuse reflectance=0.8 } { conductor material=Au }",
     {"type": "blendbsdf", "weight": 0.3, "a": {"type": "diffuse", "reflectance": 0.8},
      "b": {"type": "conductor", "material": "Au"}}, "reflect", None),
    # Dirac models: sample() only
    ("conductor", {"type": "conductor"}, "delta", None),
    ("conductor material=Cu", {"type": "conductor", "material": "Cu"}, "delta", None),
    ("conductor material=Au", {"type": "conductor", "material": "Au"}, "delta", None),
    ("conductor material=Al", {"type": "conductor", "material": "Al"}, "delta", None),
    ("conductor eta=1.5 k=2 specular_reflectance=0.8,0.9,1",
     {"type": "conductor", "eta": 1.5, "k": 2.0, "specular_reflectance": rgb(0.8, 0.9, 1.0)},
     "delta", None),
    ("dielectric", {"type": "dielectric"}, "delta-both", None),
    ("dielectric int_ior=water", {"type": "dielectric", "int_ior": "water"}, "delta-both", None),
    ("dielectric int_ior=diamond", {"type": "dielectric", "int_ior": "diamond"}, "delta-both",
     None),
    ("dielectric int_ior=1.7 ext_ior=1.2 specular_transmittance=0.9,0.8,0.7",
     {"type": "dielectric", "int_ior": 1.7, "ext_ior": 1.2,
      "specular_transmittance": rgb(0.9, 0.8, 0.7)}, "delta-both", None),
    ("thindielectric", {"type": "thindielectric"}, "delta-both", None),
    ("thindielectric int_ior=diamond specular_reflectance=0.9",
     {"type": "thindielectric", "int_ior": "diamond", "specular_reflectance": 0.9},
     "delta-both", None),
]

ROUGH_PLUGINS = ("roughconductor", "roughdielectric", "roughplastic")


def mitsuba_compat(spec):
    """Select Specula's Mitsuba-compatible options where its defaults deliberately differ:
    - the Beckmann G1: Specula evaluates it exactly by default, Mitsuba uses Walter et al.'s
      rational approximation (`smith_g1=rational`); Beckmann is the default distribution;
    - plastic's internal diffuse Fresnel reflectance: Specula integrates the Fresnel formula,
      Mitsuba uses Egan & Hilgeman's polynomial fit (`diffuse_fresnel=fit`)."""
    out = []
    for part in re.split(r"([{}])", spec):
        toks = part.split()
        extra = []
        if toks and toks[0] in ROUGH_PLUGINS and "distribution=ggx" not in toks:
            extra.append("smith_g1=rational")
        if toks and toks[0] == "plastic":
            extra.append("diffuse_fresnel=fit")
        if extra:
            part = part.rstrip() + " " + " ".join(extra) + (" " if part.endswith(" ") else "")
        out.append(part)
    return "".join(out)


CONFIGS = [(mitsuba_compat(spec), d, kind, alpha) for spec, d, kind, alpha in CONFIGS]

N_EVAL = 220
N_SAMPLE_SMOOTH = 60
N_SAMPLE_DELTA = 240
MAX_THETA = math.radians(89.0)


def direction(theta, phi):
    s = math.sin(theta)
    return (s * math.cos(phi), s * math.sin(phi), math.cos(theta))


def rand_upper(rng):
    """A direction in the upper hemisphere: mostly uniform in cosθ, often grazing (75°–89°),
    sometimes exactly at the pole."""
    u = rng.random()
    if u < 0.03:
        return (0.0, 0.0, 1.0)
    if u < 0.3:
        theta = math.radians(rng.uniform(75.0, 89.0))
    else:
        theta = math.acos(rng.uniform(math.cos(MAX_THETA), 1.0))
    return direction(theta, rng.uniform(0.0, 2.0 * math.pi))


def flip(w):
    return (w[0], w[1], -w[2])


def normalize(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def micro_normal(rng, alpha):
    """A microfacet normal with Gaussian slopes about as wide as the distribution."""
    au, av = alpha if isinstance(alpha, tuple) else (alpha, alpha)
    k = rng.uniform(0.3, 2.0)
    sx, sy = rng.gauss(0.0, au * k), rng.gauss(0.0, av * k)
    return normalize((-sx, -sy, 1.0))


def reflect(w, m):
    d = 2.0 * dot(w, m)
    return tuple(d * mc - wc for wc, mc in zip(w, m))


def refract(w, m, eta):
    """Refract w (pointing away from the surface, on m's side when w·m > 0) through a facet m;
    eta = η_int/η_ext. None under total internal reflection."""
    c = dot(w, m)
    e = eta if c > 0 else 1.0 / eta  # η_t/η_i
    ct2 = 1.0 - (1.0 - c * c) / (e * e)
    if ct2 <= 0.0:
        return None
    ct = math.sqrt(ct2) * (-1.0 if c > 0 else 1.0)
    return tuple(mc * (c / e + ct) - wc / e for wc, mc in zip(w, m))


def graze_ok(w):
    return abs(w[2]) >= math.cos(MAX_THETA) - 1e-9


def rounded(v):
    return tuple(f32(c) for c in v)


def eval_pairs(rng, kind, alpha, eta, n):
    pairs = []
    while len(pairs) < n:
        u = rng.random()
        wi = rand_upper(rng)
        inside = False
        if kind == "twosided" and rng.random() < 0.4:
            inside = True
        if kind == "rough-dielectric" and rng.random() < 0.45:
            inside = True
        if inside:
            wi = flip(wi)
        if u < 0.35 or alpha is None:
            # independent directions
            wo = rand_upper(rng)
            if kind == "rough-dielectric":
                if rng.random() < 0.5:
                    wo = flip(wo)
            elif inside or rng.random() < 0.05:
                wo = flip(wo)  # below the horizon (one-sided: zero)
            if kind == "twosided" and inside and rng.random() < 0.1:
                wo = flip(wo)
        else:
            m = micro_normal(rng, alpha)
            if wi[2] < 0:
                m = flip(m)
            if kind == "rough-dielectric" and rng.random() < 0.5:
                wo = refract(wi, m, eta)
                if wo is None:
                    continue
            else:
                wo = reflect(wi, m)
            if not graze_ok(wo) or wo[2] == 0.0:
                continue
        pairs.append((rounded(wi), rounded(wo)))
    return pairs


def mi_vec(v):
    return mi.Vector3f(*v)


def do_eval(bsdf, wi, wo):
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    si.wi = mi_vec(wi)
    v = bsdf.eval(ctx, si, mi_vec(wo))
    p = bsdf.pdf(ctx, si, mi_vec(wo))
    return [float(v[0]), float(v[1]), float(v[2])], float(p)


def do_sample(bsdf, wi, s1, s2):
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    si.wi = mi_vec(wi)
    bs, w = bsdf.sample(ctx, si, s1, mi.Point2f(*s2))
    wv = [float(w[0]), float(w[1]), float(w[2])]
    pdf = float(bs.pdf)
    if not (pdf > 0.0) or wv == [0.0, 0.0, 0.0]:
        return (0.0, 0.0, 0.0), 0.0, [0.0, 0.0, 0.0], 0
    delta = 1 if mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta) else 0
    return (float(bs.wo[0]), float(bs.wo[1]), float(bs.wo[2])), pdf, wv, delta


def lobe_threshold(bsdf, spec, wi):
    """The probability with which sample() picks the first lobe for this wi (the s1 threshold),
    or None when s1 does not select a lobe."""
    if spec.startswith("blendbsdf"):
        return float(spec.split("weight=")[1].split()[0])
    if spec.startswith(("dielectric", "thindielectric", "plastic")):
        _, pdf, _, delta = do_sample(bsdf, wi, 0.0, (0.5, 0.5))
        return pdf if delta else None
    return None


def sample_inputs(rng, bsdf, spec, kind, n):
    out = []
    while len(out) < n:
        wi = rand_upper(rng)
        if kind in ("twosided", "rough-dielectric") and rng.random() < 0.4:
            wi = flip(wi)
        if kind == "delta-both" and rng.random() < 0.45:
            # from inside: half of them steep enough (θ < 41°) to refract out of most media,
            # the others mostly beyond the critical angle (total internal reflection)
            if rng.random() < 0.5:
                wi = direction(math.acos(rng.uniform(0.76, 1.0)), rng.uniform(0.0, 2.0 * math.pi))
            wi = flip(wi)
        wi = rounded(wi)
        s1 = f32(rng.random())
        s2 = (f32(rng.random()), f32(rng.random()))
        t = lobe_threshold(bsdf, spec, wi)
        if t is not None and abs(s1 - t) < 1e-3:
            continue  # a lobe-selection tie: float32 rounding could pick either lobe
        out.append((wi, s1, s2))
    return out


def main():
    rng = random.Random(SEED)
    lines = [
        "# Mitsuba 3 reference values for crates/specula-bsdf/tests/mitsuba_agreement.rs.",
        "# Generated by scripts/gen_mitsuba_fixture.py with mitsuba %s (scalar_rgb, radiance);"
        % mi.__version__,
        "# do not edit by hand. Formats:",
        "#   model <id> <spec>",
        "#   eval wi.x wi.y wi.z wo.x wo.y wo.z r g b pdf        (Mitsuba eval = f*|cos theta_o|)",
        "#   sample wi.x wi.y wi.z s1 s2.x s2.y wo.x wo.y wo.z pdf r g b delta",
    ]
    for idx, (spec, d, kind, alpha) in enumerate(CONFIGS):
        bsdf = mi.load_dict(d)
        lines.append("model %d %s" % (idx, spec))
        lines.append("# mitsuba: %r" % (d,))
        eta = None
        if kind == "rough-dielectric":
            # the relative index, to aim refraction pairs: read back from Mitsuba
            eta = float(mi.traverse(bsdf)["eta"])
        if kind not in ("delta", "delta-both"):
            for wi, wo in eval_pairs(rng, kind, alpha, eta, N_EVAL):
                v, p = do_eval(bsdf, wi, wo)
                lines.append("eval " + " ".join(fmt(x) for x in (*wi, *wo, *v, p)))
            n_samp = N_SAMPLE_SMOOTH
            if spec.startswith(("plastic", "blendbsdf weight=0.3 { diffuse reflectance=0.8 } "
                                             "{ conductor")):
                n_samp = N_SAMPLE_DELTA
        else:
            n_samp = N_SAMPLE_DELTA
        for wi, s1, s2 in sample_inputs(rng, bsdf, spec, kind, n_samp):
            wo, pdf, w, delta = do_sample(bsdf, wi, s1, s2)
            lines.append("sample " + " ".join(fmt(x) for x in (*wi, s1, *s2, *wo, pdf, *w))
                         + " %d" % delta)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n")
    print("wrote %s (%d lines, %d bytes)" % (OUT, len(lines), OUT.stat().st_size))


if __name__ == "__main__":
    main()
