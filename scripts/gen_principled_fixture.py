#!/usr/bin/env python3
"""Generate the "agreement with Mitsuba 3" fixture of the principled BSDFs for specula-bsdf.

Developer tool only: CI never runs it (CI has no Mitsuba). The output is committed as
crates/specula-bsdf/tests/data/principled_fixture.txt and read by
crates/specula-bsdf/tests/principled_agreement.rs.

How to run (needs `pip install mitsuba==3.9.1` and numpy):

    python3 scripts/gen_principled_fixture.py

It draws random parameter sets of `principled` and `principledthin` (every parameter either
left at its default, given as 0, or drawn from its range; some of them textures), and for each
random direction pairs with a fixed seed (plus one parameter set of each with every
texturable parameter textured), and records what Mitsuba's `scalar_rgb` variant
returns in radiance mode:

    model <id> <spec>                     the Specula spec (textured parameters are absent)
    tex <param> <u> <v> <c0> <c1> <c2>    the value of textured parameter <param> at (u, v), as
                                          Mitsuba's texture returns it (eval_1 in all three
                                          channels for scalar parameters)
    eval u v wi.x wi.y wi.z wo.x wo.y wo.z r g b pdf
    sample u v wi.x wi.y wi.z wo.x wo.y wo.z pdf r g b

`eval` holds Mitsuba's eval (f·|cosθo|, RGB) and pdf at texture coordinates (u, v). `sample`
holds a direction Mitsuba's sample() produced with its pdf and weight (value/pdf); only
Specula's eval and pdf at that direction are comparable, because the warps differ. Textures are
2×2 single-channel (scalar parameters) or RGB (`base_color`) bitmaps with nearest filtering,
looked up only at the centres of their cells, so Specula's test can stand in for them with the
recorded values (the bitmap plugin itself is tested elsewhere).

Records are left out where Specula deliberately differs (see models/principled.rs): from below
a `principled` surface whose transmission weight (1 − metallic)·spec_trans is 0 (Mitsuba's pdf
is non-zero there although its sampler produces nothing; Specula's is 0), and spec_trans is
never exactly 1 together with sheen.

All inputs are rounded to float32 before they are given to Mitsuba, and every number is written
with the shortest decimal that reads back as the same float32.
"""
import math
import pathlib
import random
import struct

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "crates/specula-bsdf/tests/data/principled_fixture.txt"
SEED = 20261202
N_PRINCIPLED = 40
N_THIN = 20
N_EVAL = 120
N_SAMPLE = 30
MAX_THETA = math.radians(89.0)
# records whose reference moves by more than this under float32-sized input perturbations are
# left out (see ill_conditioned)
REL_STABLE = 3e-5
UVS = [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)]


def f32(x):
    return struct.unpack("f", struct.pack("f", float(x)))[0]


def fmt(x):
    x = f32(x)
    if x == 0.0:
        return "0" if math.copysign(1.0, x) > 0 else "-0"
    for p in range(1, 10):
        s = "%.*g" % (p, x)
        if f32(float(s)) == x:
            return s
    return repr(x)


# (name, low, high) of the scalar parameters
PRINCIPLED_PARAMS = [
    ("roughness", 0.05, 1.0),
    ("anisotropic", 0.0, 1.0),
    ("metallic", 0.0, 1.0),
    ("spec_trans", 0.0, 0.999),
    ("spec_tint", 0.0, 1.0),
    ("sheen", 0.0, 1.0),
    ("sheen_tint", 0.0, 1.0),
    ("flatness", 0.0, 1.0),
    ("clearcoat", 0.0, 1.0),
    ("clearcoat_gloss", 0.0, 1.0),
]
THIN_PARAMS = [
    ("roughness", 0.05, 1.0),
    ("anisotropic", 0.0, 1.0),
    ("spec_trans", 0.0, 1.0),
    ("spec_tint", 0.0, 1.0),
    ("sheen", 0.0, 1.0),
    ("sheen_tint", 0.0, 1.0),
    ("flatness", 0.0, 1.0),
    ("diff_trans", 0.0, 2.0),
    ("eta", 1.05, 2.0),
]


def bitmap(values):
    """A 2×2 bitmap texture (values: 4 floats or 4 RGB triples), nearest filtering, raw."""
    a = np.array(values, dtype=np.float32)
    if a.ndim == 1:
        a = a.reshape(2, 2, 1)
    else:
        a = a.reshape(2, 2, 3)
    return {"type": "bitmap", "bitmap": mi.Bitmap(a), "raw": True, "filter_type": "nearest"}


def random_params(rng, plugin, table, textured):
    """(spec, Mitsuba dict, {textured param: plugin dict}) of one random configuration."""
    spec = [plugin]
    d = {"type": plugin}
    tex = {}
    # base colour
    every = textured == "all"
    u = 0.0 if every else rng.random()
    if textured and u < 0.5:
        tex["base_color"] = bitmap([[f32(rng.uniform(0.02, 1.0)) for _ in range(3)]
                                    for _ in range(4)])
    elif u < 0.85:
        c = [f32(rng.uniform(0.0, 1.0)) for _ in range(3)]
        spec.append("base_color=" + ",".join(fmt(x) for x in c))
        d["base_color"] = {"type": "rgb", "value": c}
    for name, lo, hi in table:
        u = 0.0 if every else rng.random()
        if textured and u < 0.3:
            tex[name] = bitmap([f32(rng.uniform(lo, hi)) for _ in range(4)])
        elif u < 0.4:
            continue  # default
        elif u < 0.47 and name not in ("eta", "roughness"):
            spec.append("%s=0" % name)
            d[name] = 0.0
        else:
            v = f32(rng.uniform(lo, hi))
            spec.append("%s=%s" % (name, fmt(v)))
            d[name] = v
    if plugin == "principled":
        u = rng.random()
        if u < 0.3:
            v = f32(rng.uniform(1.05, 2.5))
            spec.append("eta=%s" % fmt(v))
            d["eta"] = v
        elif u < 0.6:
            v = f32(rng.uniform(0.0, 1.0))
            spec.append("specular=%s" % fmt(v))
            d["specular"] = v
    for name, t in tex.items():
        d[name] = t
    return " ".join(spec), d, tex


def direction(theta, phi):
    s = math.sin(theta)
    return (s * math.cos(phi), s * math.sin(phi), math.cos(theta))


def rand_upper(rng):
    u = rng.random()
    if u < 0.03:
        return (0.0, 0.0, 1.0)
    if u < 0.25:
        theta = math.radians(rng.uniform(75.0, 89.0))
    else:
        theta = math.acos(rng.uniform(math.cos(MAX_THETA), 1.0))
    return direction(theta, rng.uniform(0.0, 2.0 * math.pi))


def normalize(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def micro_normal(rng, alpha):
    k = rng.uniform(0.3, 2.0)
    sx, sy = rng.gauss(0.0, alpha * k), rng.gauss(0.0, alpha * k)
    return normalize((-sx, -sy, 1.0))


def reflect(w, m):
    d = 2.0 * dot(w, m)
    return tuple(d * mc - wc for wc, mc in zip(w, m))


def refract(w, m, eta):
    c = dot(w, m)
    e = eta if c > 0 else 1.0 / eta
    ct2 = 1.0 - (1.0 - c * c) / (e * e)
    if ct2 <= 0.0:
        return None
    ct = math.sqrt(ct2) * (-1.0 if c > 0 else 1.0)
    return tuple(mc * (c / e + ct) - wc / e for wc, mc in zip(w, m))


def rounded(v):
    return tuple(f32(c) for c in v)


def make_si(uv, wi):
    si = mi.SurfaceInteraction3f()
    si.uv = mi.Point2f(*uv)
    si.wi = mi.Vector3f(*wi)
    return si


def tex_value(t, name, uv):
    si = make_si(uv, (0.0, 0.0, 1.0))
    if name == "base_color":
        v = t.eval(si)
        return [float(v[0]), float(v[1]), float(v[2])]
    v = float(t.eval_1(si))
    return [v, v, v]


def param_at(d, texvals, name, uv, default):
    if name in texvals:
        return texvals[name][uv][0]
    return float(d.get(name, default))


def perturbed(rng, w):
    """w moved by about 1e-7 (an ulp or two of float32) in a random direction, renormalised."""
    t = [rng.gauss(0.0, 1.0) for _ in range(3)]
    n = math.sqrt(sum(c * c for c in t))
    return rounded(normalize(tuple(c + 1e-7 * x / n for c, x in zip(w, t))))


def ill_conditioned(rng, bsdf, ctx, uv, wi, wo, v, p):
    """True when Mitsuba's eval or pdf changes by more than REL_STABLE (relative) when wi or wo
    move by an ulp or two of float32: there two float32 implementations cannot agree to 1e-4 (e.g.
    the half vector near the critical angle, where 1 − F has a square-root singularity, or
    the peak of an α = 0.001 lobe), so such records are left out."""
    ref = [float(v[0]), float(v[1]), float(v[2]), float(p)]
    for k in range(4):
        wi2, wo2 = (perturbed(rng, wi), wo) if k < 2 else (wi, perturbed(rng, wo))
        si = make_si(uv, wi2)
        v2 = bsdf.eval(ctx, si, mi.Vector3f(*wo2))
        p2 = bsdf.pdf(ctx, si, mi.Vector3f(*wo2))
        for a, b in zip(ref, [float(v2[0]), float(v2[1]), float(v2[2]), float(p2)]):
            m = max(abs(a), abs(b))
            if m > 1e-8 and abs(a - b) > REL_STABLE * m:
                return True
    return False


def main():
    rng = random.Random(SEED)
    lines = [
        "# Mitsuba 3 reference values for crates/specula-bsdf/tests/principled_agreement.rs.",
        "# Generated by scripts/gen_principled_fixture.py with mitsuba %s (scalar_rgb, radiance);"
        % mi.__version__,
        "# do not edit by hand. Formats:",
        "#   model <id> <spec>",
        "#   tex <param> u v c0 c1 c2",
        "#   eval u v wi.x wi.y wi.z wo.x wo.y wo.z r g b pdf   (Mitsuba eval = f*|cos theta_o|)",
        "#   sample u v wi.x wi.y wi.z wo.x wo.y wo.z pdf r g b",
    ]
    configs = []
    for i in range(N_PRINCIPLED):
        configs.append(("principled", PRINCIPLED_PARAMS, i % 3 == 2))
    for i in range(N_THIN):
        configs.append(("principledthin", THIN_PARAMS, i % 3 == 2))
    # and one of each with every parameter that can be a texture textured
    configs.append(("principled", PRINCIPLED_PARAMS, "all"))
    configs.append(("principledthin", THIN_PARAMS, "all"))
    ctx = mi.BSDFContext()
    dropped = 0
    for idx, (plugin, table, textured) in enumerate(configs):
        spec, d, tex = random_params(rng, plugin, table, textured)
        bsdf = mi.load_dict(d)
        lines.append("model %d %s" % (idx, spec))
        texvals = {}
        for name in tex:
            t = mi.load_dict(tex[name])
            texvals[name] = {}
            for uv in UVS:
                v = tex_value(t, name, uv)
                texvals[name][uv] = v
                lines.append("tex %s %s %s %s" % (name, fmt(uv[0]), fmt(uv[1]),
                                                  " ".join(fmt(x) for x in v)))
        # the effective IOR, to aim refraction pairs
        if plugin == "principled":
            eta = float(d["eta"]) if "eta" in d else \
                2.0 / (1.0 - math.sqrt(0.08 * float(d.get("specular", 0.5)))) - 1.0
        n_eval = 0
        while n_eval < N_EVAL:
            uv = UVS[rng.randrange(4)] if tex else (0.0, 0.0)
            roughness = param_at(d, texvals, "roughness", uv, 0.5)
            alpha = max(roughness * roughness, 0.01)
            if plugin == "principled":
                st = param_at(d, texvals, "spec_trans", uv, 0.0)
                metallic = param_at(d, texvals, "metallic", uv, 0.0)
                below_ok = (1.0 - metallic) * st > 0.0
            else:
                below_ok = True
                eta = param_at(d, texvals, "eta", uv, 1.5)
            wi = rand_upper(rng)
            if below_ok and rng.random() < 0.4:
                wi = (wi[0], wi[1], -wi[2])
            u = rng.random()
            if u < 0.35:
                wo = rand_upper(rng)
                if rng.random() < 0.45:
                    wo = (wo[0], wo[1], -wo[2])
            else:
                m = micro_normal(rng, alpha)
                if wi[2] < 0:
                    m = (m[0], m[1], -m[2])
                if rng.random() < 0.5:
                    if plugin == "principled":
                        wo = refract(wi, m, eta)
                        if wo is None:
                            continue
                    else:
                        r = reflect(wi, m)
                        wo = (r[0], r[1], -r[2])
                else:
                    wo = reflect(wi, m)
                if abs(wo[2]) < math.cos(MAX_THETA) or wo[2] == 0.0:
                    continue
            wi, wo = rounded(normalize(wi)), rounded(normalize(wo))
            si = make_si(uv, wi)
            v = bsdf.eval(ctx, si, mi.Vector3f(*wo))
            p = bsdf.pdf(ctx, si, mi.Vector3f(*wo))
            if ill_conditioned(rng, bsdf, ctx, uv, wi, wo, v, p):
                dropped += 1
                continue
            vals = (*uv, *wi, *wo, float(v[0]), float(v[1]), float(v[2]), float(p))
            lines.append("eval " + " ".join(fmt(x) for x in vals))
            n_eval += 1
        n_samp = 0
        tries = 0
        while n_samp < N_SAMPLE and tries < 20 * N_SAMPLE:
            tries += 1
            uv = UVS[rng.randrange(4)] if tex else (0.0, 0.0)
            if plugin == "principled":
                st = param_at(d, texvals, "spec_trans", uv, 0.0)
                metallic = param_at(d, texvals, "metallic", uv, 0.0)
                below_ok = (1.0 - metallic) * st > 0.0
            else:
                below_ok = True
            wi = rand_upper(rng)
            if below_ok and rng.random() < 0.4:
                wi = (wi[0], wi[1], -wi[2])
            wi = rounded(normalize(wi))
            s1 = f32(rng.random())
            s2 = (f32(rng.random()), f32(rng.random()))
            si = make_si(uv, wi)
            bs, w = bsdf.sample(ctx, si, s1, mi.Point2f(*s2))
            pdf = float(bs.pdf)
            wv = [float(w[0]), float(w[1]), float(w[2])]
            if not (pdf > 0.0) or wv == [0.0, 0.0, 0.0]:
                continue
            wo = (float(bs.wo[0]), float(bs.wo[1]), float(bs.wo[2]))
            si = make_si(uv, wi)
            v = bsdf.eval(ctx, si, mi.Vector3f(*wo))
            if ill_conditioned(rng, bsdf, ctx, uv, wi, wo, v, bs.pdf):
                dropped += 1
                continue
            vals = (*uv, *wi, *wo, pdf, *wv)
            lines.append("sample " + " ".join(fmt(x) for x in vals))
            n_samp += 1
    lines.insert(7, "# %d ill-conditioned records left out (REL_STABLE = %g)" % (dropped, REL_STABLE))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n")
    print("wrote %s (%d lines, %d bytes); %d ill-conditioned records left out"
          % (OUT, len(lines), OUT.stat().st_size, dropped))


if __name__ == "__main__":
    main()
