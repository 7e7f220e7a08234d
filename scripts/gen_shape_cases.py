#!/usr/bin/env python3
"""Prints the Mitsuba 3 reference cases of `geometry/tests.rs`'s cylinder and instance tests.

Shoots rays at small scenes in Mitsuba 3 (`scalar_rgb`) and prints Rust `Case` / `SCase`
literals (hit t, p, n, shading frame, uv; sampled p, n, uv, pdf). Transforms are spelled as in
the Rust tests (`rot`, `sc`, `tr` compose left to right like `ScalarTransform4f().rotate(..)
.scale(..)`). Usage: python3 scripts/gen_shape_cases.py > /tmp/cases.rs
"""
import mitsuba as mi

mi.set_variant("scalar_rgb")
T = mi.ScalarTransform4f


def f(v):
    return "[" + ", ".join(f"{float(x):.7}" for x in v) + "]"


def cases(name, shape, rays, samples=()):
    sc = mi.load_dict({"type": "scene", "s": shape})
    print(f"    const {name}: &[Case] = &[")
    for o, d in rays:
        si = sc.ray_intersect(mi.Ray3f(o, d))
        assert si.is_valid(), (name, o, d)
        fr = si.sh_frame
        print(f"        Case {{ o: {f(o)}, d: {f(d)}, t: {float(si.t):.7}, p: {f(si.p)}, n: {f(si.n)}, "
              f"sn: {f(fr.n)}, ss: {f(fr.s)}, st: {f(fr.t)}, uv: {f(si.uv)} }},")
    print("    ];")
    if samples:
        sh = sc.shapes()[0]
        print(f"    const S_{name}: &[SCase] = &[")
        for u in samples:
            ps = sh.sample_position(0, u)
            print(f"        SCase {{ u: {f(u)}, p: {f(ps.p)}, n: {f(ps.n)}, uv: {f(ps.uv)}, pdf: {float(ps.pdf):.7} }},")
        print("    ];")


def surface_rays(shape, us, inside=None):
    """Rays from outside towards sampled points (and from `inside` to them)."""
    sc = mi.load_dict({"type": "scene", "s": shape})
    sh = sc.shapes()[0]
    rays = []
    for u in us:
        ps = sh.sample_position(0, u)
        n = mi.ScalarVector3f(ps.n) * (-1 if shape.get("flip_normals") else 1)
        o = ps.p + 2.0 * mi.ScalarVector3f(n + mi.ScalarVector3f(0.1, 0.2, 0.3))
        rays.append(([float(x) for x in o], [float(x) for x in (ps.p - o)]))
        if inside is not None:
            rays.append((inside, [float(x) for x in (ps.p - mi.ScalarPoint3f(inside))]))
    return rays


SAMPLES = [[0.3, 0.6], [0.8, 0.1]]
US = [[0.3, 0.6], [0.7, 0.2], [0.5, 0.9]]
configs = [
    ("CYL", dict(type="cylinder"), [0.0, 0.0, 0.5]),
    ("CYL_P", dict(type="cylinder", radius=0.5, p0=[0.1, 0.2, 0.3], p1=[1.0, 0.5, 2.0]), [0.55, 0.35, 1.15]),
    ("CYL_FLIP", dict(type="cylinder", radius=0.5, flip_normals=True,
                      to_world=T().rotate([0, 0, 1], 225).translate([0, 0, 0.2])), [0.0, 0.0, 0.7]),
    ("CYL_XF", dict(type="cylinder", to_world=T().rotate([1, 0, 0], 20).scale([2, 2, 0.5])), None),
    ("CYL_MIRROR", dict(type="cylinder", radius=-0.5, to_world=T().scale([-1, 1, 1])), None),
]
for name, shape, inside in configs:
    cases(name, shape, surface_rays(shape, US, inside), SAMPLES)

# Instances: the same XML as `geometry/tests.rs`'s `INSTANCE_XML` (a group of a sphere and a
# rectangle, two instances: a similarity and a non-uniform scale).
INSTANCE_XML = """<scene version="3.0.0">
    <shape type="shapegroup" id="g">
        <shape type="sphere"><point name="center" x="0.5" y="0" z="0"/><float name="radius" value="0.5"/>
            <bsdf type="diffuse"/></shape>
        <shape type="rectangle"><transform name="to_world"><translate z="-1"/></transform>
            <bsdf type="conductor"/></shape>
    </shape>
    <shape type="instance"><ref id="g"/>
        <transform name="to_world"><scale value="2"/><rotate z="1" angle="30"/><translate x="1" y="2" z="3"/></transform>
    </shape>
    <shape type="instance"><ref id="g"/>
        <transform name="to_world"><scale x="1" y="2" z="0.5"/><rotate x="1" angle="40"/><translate x="-5"/></transform>
    </shape>
</scene>"""
sc = mi.load_string(INSTANCE_XML)
print("    const INSTANCE: &[Case] = &[")
for o, d in [([1.5, 2.5, 10.0], [0.01, 0.02, -1.0]), ([2.0, 4.0, 10.0], [-0.1, -0.1, -1.0]),
             ([-4.5, 5.0, 2.0], [0.0, -5.0, -2.0]), ([-5.3, 0.2, -6.0], [0.0, 0.0, 1.0]),
             ([-4.4, 6.0, 0.1], [0.0, -1.0, 0.0]), ([-4.45, 0.1, 5.0], [0.0, 0.0, -1.0])]:
    si = sc.ray_intersect(mi.Ray3f(o, d))
    assert si.is_valid(), (o, d)
    fr = si.sh_frame
    bsdf = str(si.bsdf()).split("[")[0]
    print(f"        // {bsdf}")
    print(f"        Case {{ o: {f(o)}, d: {f(d)}, t: {float(si.t):.7}, p: {f(si.p)}, n: {f(si.n)}, "
          f"sn: {f(fr.n)}, ss: {f(fr.s)}, st: {f(fr.t)}, uv: {f(si.uv)} }},")
print("    ];")
