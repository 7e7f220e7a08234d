#!/usr/bin/env python3
"""Generate the Mitsuba 3 references of the principled-BSDF scenes that
crates/specula-render/tests/principled_scenes.rs renders.

Developer tool only: CI never runs it (CI has no Mitsuba). Needs `pip install mitsuba==3.9.1
numpy`. Run from the repository root:

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 python3 scripts/gen_principled_refs.py

It writes, under crates/specula-render/tests/data/principled/:
- `albedo.exr`, `rough.exr`: small linear textures (an RGB colour pattern and a
  single-channel roughness/metallic pattern) that the textured scenes read through `bitmap`;
- the scenes `NAME.xml` (small films; `principled` with several parameter sets: a clear-coated,
  sheened dielectric, an anisotropic tinted metal, a flat fake-subsurface one, transmissive
  ones with `eta` and with `specular`, one with every scalar parameter textured, and
  `principledthin` lit from behind);
- `NAME.exr`: Mitsuba's `llvm_ad_rgb` render at REF_SPP samples per pixel;
- `metrics.json`: per scene, Mitsuba's own error at 64 spp against that reference (relMSE and
  block8 as ../shared/README.md defines them, averaged over SEEDS = 8 seeds (the caustics under the
  glass-like sphere make a 2-seed estimate itself noisy; the large light keeps them soft), and its worst per-channel
  mean deviation), which the test's criteria scale.
"""
import json
import pathlib

import mitsuba as mi
import numpy as np
from refmetrics import block, relmse

mi.set_variant("llvm_ad_rgb")
OUT = pathlib.Path("crates/specula-render/tests/data/principled")
REF_SPP = 4096
SEEDS = 8

HEAD = """<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="%(depth)d"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="%(fov)g"/>
        <transform name="to_world"><lookat origin="0, 1.2, 5" target="0, 0.45, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="%(w)d"/><integer name="height" value="%(h)d"/><rfilter type="box"/></film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="0.2, 0.22, 0.25"/></emitter>
    <shape type="rectangle">
        <transform name="to_world"><scale x="3" y="2"/><lookat origin="-2, 3.5, 3" target="0, 0.5, 0" up="0, 1, 0"/></transform>
        <emitter type="area"><rgb name="radiance" value="1.8, 1.7, 1.6"/></emitter>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><scale value="6"/></transform>
        <bsdf type="diffuse">
            <texture type="checkerboard" name="reflectance">
                <rgb name="color0" value="0.5, 0.5, 0.5"/><rgb name="color1" value="0.2, 0.2, 0.2"/>
                <transform name="to_uv"><scale x="12" y="12"/></transform>
            </texture>
        </bsdf>
    </shape>
"""


def sphere(x, bsdf, y=0.55, r=0.55):
    return """    <shape type="sphere">
        <point name="center" value="%g, %g, 0"/><float name="radius" value="%g"/>
%s
    </shape>
""" % (x, y, r, bsdf)


def principled(**params):
    out = ['        <bsdf type="principled">']
    for k, v in params.items():
        if isinstance(v, tuple):
            out.append('            <rgb name="%s" value="%s"/>' % (k, ", ".join("%g" % c for c in v)))
        elif isinstance(v, str):
            out.append(v)
        else:
            out.append('            <float name="%s" value="%g"/>' % (k, v))
    out.append("        </bsdf>")
    return "\n".join(out)


def bitmap(name, file, to_uv=None):
    t = ('            <texture type="bitmap" name="%s"><string name="filename" value="%s"/>'
         % (name, file))
    if to_uv:
        t += '<transform name="to_uv"><scale x="%g" y="%g"/></transform>' % to_uv
    return t + "</texture>"


def checker(name, c0, c1, scale):
    return ('            <texture type="checkerboard" name="%s"><float name="color0" value="%g"/>'
            '<float name="color1" value="%g"/><transform name="to_uv"><scale x="%g" y="%g"/>'
            '</transform></texture>' % (name, c0, c1, scale, scale))


SIZE = dict(w=96, h=48, fov=40, depth=6)

SCENES = {
    # three opaque parameter sets
    "principled_opaque": HEAD % SIZE
    + sphere(-1.2, principled(base_color=(0.8, 0.15, 0.08), roughness=0.3, clearcoat=0.8,
                              clearcoat_gloss=0.6, sheen=0.6, sheen_tint=0.5, specular=0.6))
    + sphere(0.0, principled(base_color=(0.95, 0.7, 0.35), metallic=1.0, roughness=0.4,
                             anisotropic=0.7))
    + sphere(1.2, principled(base_color=(0.3, 0.6, 0.85), roughness=0.9, flatness=0.8,
                             spec_tint=0.6, metallic=0.25, sheen=0.3))
    + "</scene>\n",
    # transmission: a rough glass-like one with eta, a half-transmissive tinted one with
    # specular, and a clear-coated metal-dielectric mix
    "principled_transmissive": HEAD % dict(SIZE, depth=10)
    + sphere(-1.2, principled(base_color=(0.9, 0.95, 1.0), spec_trans=0.95, roughness=0.2,
                              eta=1.45))
    + sphere(0.0, principled(base_color=(0.9, 0.5, 0.3), spec_trans=0.5, roughness=0.45,
                             specular=0.8, spec_tint=0.3))
    + sphere(1.2, principled(base_color=(0.6, 0.8, 0.5), spec_trans=0.7, metallic=0.3,
                             roughness=0.3, clearcoat=1.0, clearcoat_gloss=0.9,
                             anisotropic=0.4))
    + "</scene>\n",
    # textures: base colour from a bitmap, roughness and metallic from a single-channel
    # bitmap, clearcoat and sheen from checkerboards; a textured transmissive one
    "principled_textured": HEAD % SIZE
    + sphere(-0.65, principled(
        base_color=bitmap("base_color", "albedo.exr", (2, 1)),
        roughness=bitmap("roughness", "rough.exr", (3, 2)),
        metallic=bitmap("metallic", "rough.exr", (1, 1)),
        clearcoat=checker("clearcoat", 0.0, 1.0, 6),
        sheen=checker("sheen", 1.0, 0.0, 4),
        spec_tint=checker("spec_tint", 0.0, 0.8, 5)))
    + sphere(0.65, principled(
        base_color=bitmap("base_color", "albedo.exr", (1, 1)),
        spec_trans=checker("spec_trans", 0.2, 0.9, 6),
        roughness=bitmap("roughness", "rough.exr", (2, 2)),
        anisotropic=checker("anisotropic", 0.0, 0.8, 3),
        flatness=checker("flatness", 0.9, 0.1, 4),
        sheen_tint=checker("sheen_tint", 1.0, 0.0, 2),
        clearcoat_gloss=checker("clearcoat_gloss", 0.2, 1.0, 5),
        clearcoat=0.5))
    + "</scene>\n",
    # principledthin: two sheets lit from behind (diffuse and specular transmission), one
    # textured
    "principledthin_sheets": HEAD % dict(SIZE, depth=8)
    + """    <shape type="rectangle">
        <transform name="to_world"><scale x="0.6" y="0.5"/><rotate y="1" angle="20"/><translate x="-0.7" y="0.6"/></transform>
        <bsdf type="principledthin">
            <rgb name="base_color" value="0.4, 0.8, 0.2"/>
            <float name="roughness" value="0.5"/>
            <float name="diff_trans" value="1.4"/>
            <float name="spec_trans" value="0.2"/>
            <float name="sheen" value="0.5"/>
            <float name="flatness" value="0.4"/>
        </bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale x="0.6" y="0.5"/><rotate y="1" angle="-25"/><translate x="0.7" y="0.6"/></transform>
        <bsdf type="principledthin">
""" + bitmap("base_color", "albedo.exr", (2, 2)) + """
""" + bitmap("roughness", "rough.exr", (1, 1)) + """
            <float name="spec_trans" value="0.7"/>
            <float name="eta" value="1.33"/>
            <float name="anisotropic" value="0.5"/>
            <float name="spec_tint" value="0.5"/>
""" + checker("diff_trans", 0.3, 1.5, 4) + """
        </bsdf>
    </shape>
    <shape type="sphere">
        <point name="center" value="0, 2.2, -3"/><float name="radius" value="0.5"/>
        <emitter type="area"><rgb name="radiance" value="12, 11, 9"/></emitter>
    </shape>
</scene>
""",
}


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(11)
    albedo = rng.uniform(0.05, 0.95, (8, 8, 3)).astype(np.float32)
    albedo[0, :, :] = [0.9, 0.1, 0.1]  # a distinct top row, to catch a flipped v
    mi.Bitmap(albedo).write(str(OUT / "albedo.exr"))
    rough = rng.uniform(0.05, 1.0, (4, 8, 1)).astype(np.float32)
    mi.Bitmap(rough).write(str(OUT / "rough.exr"))
    metrics = {}
    for name, text in SCENES.items():
        path = OUT / f"{name}.xml"
        path.write_text(text)
        scene = mi.load_file(str(path))
        ref = np.array(mi.render(scene, spp=REF_SPP, seed=1000), dtype=np.float64)[..., :3]
        mi.Bitmap(ref.astype(np.float32)).write(str(OUT / f"{name}.exr"))
        rel, b8, dev = [], [], 0.0
        for seed in range(SEEDS):
            img = np.array(mi.render(scene, spp=64, seed=seed), dtype=np.float64)[..., :3]
            rel.append(relmse(img, ref))
            b8.append(relmse(block(img), block(ref)))
            ratio = img.reshape(-1, 3).mean(0) / ref.reshape(-1, 3).mean(0)
            dev = max(dev, float(np.abs(ratio - 1).max()))
        metrics[name] = {
            "resolution": [ref.shape[1], ref.shape[0]],
            "ref_spp": REF_SPP,
            "ref_mean": [float(x) for x in ref.reshape(-1, 3).mean(0)],
            "mitsuba_64spp_relmse": sum(rel) / SEEDS,
            "mitsuba_64spp_block8": sum(b8) / SEEDS,
            "mitsuba_64spp_max_mean_dev": dev,
            "mitsuba_64spp_seeds": SEEDS,
        }
        print(name, metrics[name])
    (OUT / "metrics.json").write_text(json.dumps(metrics, indent=1) + "\n")


if __name__ == "__main__":
    main()
