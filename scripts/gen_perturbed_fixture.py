#!/usr/bin/env python3
"""Generate the Mitsuba 3.9.1 reference values for `bumpmap`, `normalmap` and `mask`.

Developer tool only (CI has no Mitsuba). Output: crates/specula-bsdf/tests/data/
perturbed_fixture.txt, read by crates/specula-bsdf/tests/perturbed_agreement.rs.
Run: python3 scripts/gen_perturbed_fixture.py   (needs `pip install mitsuba==3.9.1`)

Every case evaluates a Mitsuba BSDF at a surface interaction whose shading frame is the
identity (so local and world coordinates agree) with chosen dp_du, dp_dv and geometric normal,
and records `eval` (f·|cosθo|, RGB) and `pdf` for random direction pairs; for a nested
`conductor` (Dirac) it also records `sample` (direction, pdf, weight), which is deterministic.

Bump maps: the height field is a 2×2 bilinear `bitmap`; the line records Mitsuba's own
`eval_1_grad` at the lookup uv, which the Rust test feeds to the model through a texture that
returns that gradient. Normal maps: a 1×1 `raw` bitmap holding the colour c.

Lines:
    nested <mitsuba-name> <specula spec>
    bump  scale flip shadow gu gv dpdu(3) dpdv(3) ngeo(3)
    normal flip shadow c(3)
    mask  opacity
    eval  wi(3) wo(3) r g b pdf
    sample wi(3) s1 s2x s2y wo(3) pdf r g b      (pdf 0: no sample)
"""
import math, pathlib, random, struct
import mitsuba as mi
import drjit as dr

mi.set_variant("scalar_rgb")
ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "crates/specula-bsdf/tests/data/perturbed_fixture.txt"
rng = random.Random(20261201)

def f32(x):
    return struct.unpack("f", struct.pack("f", float(x)))[0]

def fmt(x):
    x = f32(x)
    if x == 0.0:
        return "0"
    for p in range(1, 10):
        s = "%.*g" % (p, x)
        if f32(float(s)) == x:
            return s
    return repr(x)

def vec(v):
    return " ".join(fmt(c) for c in v)

def rdir(upper=False):
    while True:
        v = [rng.uniform(-1, 1) for _ in range(3)]
        n = math.sqrt(sum(c * c for c in v))
        if 0.1 < n <= 1:
            v = [f32(c / n) for c in v]
            if upper:
                v[2] = abs(v[2])
            return v

NESTED = [
    ("diffuse", {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.6, 0.7]}},
     "diffuse reflectance=0.5,0.6,0.7"),
    ("roughconductor", {"type": "roughconductor", "material": "Cu", "alpha": 0.2, "distribution": "ggx"},
     "roughconductor material=Cu alpha=0.2 distribution=ggx"),
    ("conductor", {"type": "conductor", "material": "Au"}, "conductor material=Au"),
]

def bitmap(vals, h, w, c):
    return mi.Bitmap(mi.TensorXf(vals, shape=(h, w, c)))

lines = []
ctx = mi.BSDFContext()

def run_cases(b, si_base, delta):
    for _ in range(12):
        wi = rdir(upper=rng.random() < 0.8)
        si = mi.SurfaceInteraction3f(si_base)
        si.wi = mi.Vector3f(wi)
        if not delta:
            for _ in range(3):
                wo = rdir()
                v = b.eval(ctx, si, mi.Vector3f(wo))
                pdf = b.pdf(ctx, si, mi.Vector3f(wo))
                lines.append(f"eval {vec(wi)} {vec(wo)} {vec(v)} {fmt(pdf)}")
        s1 = f32(rng.random()); s2 = [f32(rng.random()), f32(rng.random())]
        bs, w = b.sample(ctx, si, s1, mi.Point2f(s2))
        pdf = bs.pdf if dr.any(w != 0) else 0.0
        lines.append(f"sample {vec(wi)} {fmt(s1)} {vec(s2)} {vec(bs.wo)} {fmt(pdf)} {vec(w)}")

def base_si(dpdu, dpdv, ngeo, uv):
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
    si.n = mi.Normal3f(ngeo)
    si.dp_du = mi.Vector3f(dpdu)
    si.dp_dv = mi.Vector3f(dpdv)
    si.uv = mi.Point2f(uv)
    return si

for mname, mdict, spec in NESTED:
    delta = mname == "conductor"
    # bump maps
    for scale, flip, shadow in [(1.0, True, True), (0.3, False, True), (2.0, True, False)]:
        vals = [f32(rng.random()) for _ in range(12)]
        tex = {"type": "bitmap", "bitmap": bitmap(vals, 2, 2, 3), "raw": True}
        uv = [f32(rng.uniform(0.3, 0.7)), f32(rng.uniform(0.3, 0.7))]
        dpdu = [f32(rng.uniform(0.5, 2)), f32(rng.uniform(-0.3, 0.3)), f32(rng.uniform(-0.2, 0.2))]
        dpdv = [f32(rng.uniform(-0.3, 0.3)), f32(rng.uniform(0.5, 2)), f32(rng.uniform(-0.2, 0.2))]
        ng = dr.normalize(mi.Vector3f(rng.uniform(-0.2, 0.2), rng.uniform(-0.2, 0.2), 1.0))
        ngeo = [f32(c) for c in ng]
        b = mi.load_dict({"type": "bumpmap", "scale": scale, "flip_invalid_normals": flip,
                          "use_shadowing_function": shadow, "tex": tex, "bsdf": mdict})
        t = mi.load_dict(tex)
        si = base_si(dpdu, dpdv, ngeo, uv)
        g = t.eval_1_grad(si)
        lines.append(f"nested {mname} {spec}")
        lines.append(f"bump {fmt(scale)} {int(flip)} {int(shadow)} {fmt(g[0])} {fmt(g[1])} {vec(dpdu)} {vec(dpdv)} {vec(ngeo)}")
        run_cases(b, si, delta)
    # normal maps
    for flip, shadow in [(True, True), (False, True), (True, False)]:
        c = [f32(rng.uniform(0.2, 0.8)), f32(rng.uniform(0.2, 0.8)), f32(rng.uniform(0.6, 1.0))]
        b = mi.load_dict({"type": "normalmap", "flip_invalid_normals": flip, "use_shadowing_function": shadow,
                          "normalmap": {"type": "bitmap", "bitmap": bitmap(c, 1, 1, 3), "raw": True, "filter_type": "nearest"},
                          "bsdf": mdict})
        si = base_si([1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5])
        lines.append(f"nested {mname} {spec}")
        lines.append(f"normal {int(flip)} {int(shadow)} {vec(c)}")
        run_cases(b, si, delta)
    # mask
    for op in [0.0, 0.3, 1.0]:
        b = mi.load_dict({"type": "mask", "opacity": op, "bsdf": mdict})
        si = base_si([1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5])
        lines.append(f"nested {mname} {spec}")
        lines.append(f"mask {fmt(op)}")
        run_cases(b, si, delta)

OUT.write_text("# generated by scripts/gen_perturbed_fixture.py from Mitsuba %s\n" % mi.__version__ + "\n".join(lines) + "\n")
print(OUT, len(lines))
