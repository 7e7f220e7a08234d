#!/usr/bin/env python3
"""Generate the Mitsuba 3 references of the sensor and emitter scenes that
crates/specula-render/tests/sensors_emitters.rs renders.

Developer tool only: CI never runs it (CI has no Mitsuba). Needs `pip install mitsuba==3.9.1
numpy`. Run from the repository root:

    python3 scripts/gen_sensor_emitter_refs.py

It writes, under crates/specula-render/tests/data/sensors_emitters/:
- `pattern.exr`: an 8×4 linear RGB texture (non-square, so that a projector's aspect ratio
  matters);
- the scenes `NAME.xml` (small films; every parameter this test is about: orthographic with a
  scaled `to_world`, thinlens with `focal_length`, perspective with a principal point offset,
  crop windows, spot with and without texture, projector, area emitters with textured radiance
  on a rectangle and a sphere);
- `NAME.exr`: Mitsuba's `llvm_ad_rgb` render at REF_SPP samples per pixel;
- `metrics.json`: per scene, Mitsuba's own error at 64 spp against that reference (relMSE and
  block8 as ../shared/README.md defines them, averaged over 2 seeds, and its worst per-channel
  mean deviation), which the test's criteria scale.
"""
import json
import pathlib

import mitsuba as mi
import numpy as np
from refmetrics import block, relmse

mi.set_variant("llvm_ad_rgb")
OUT = pathlib.Path("crates/specula-render/tests/data/sensors_emitters")
REF_SPP = 4096

COMMON = """
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
    </shape>
    <shape type="sphere">
        <point name="center" value="-1, 0.6, 0"/><float name="radius" value="0.6"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.6, 0.4"/></bsdf>
    </shape>
"""

SCENES = {
    # orthographic (extent from to_world's scale) + textured area emitters
    "ortho_textured_area": """<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="4"/></integrator>
    <sensor type="orthographic">
        <transform name="to_world"><scale x="2.2" y="2.2"/><lookat origin="0, 3, 6" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/><rfilter type="box"/></film>
    </sensor>
    <texture type="bitmap" id="pattern"><string name="filename" value="pattern.exr"/></texture>
    <shape type="rectangle">
        <transform name="to_world"><scale x="0.8" y="0.5"/><rotate x="1" angle="60"/><translate y="1.8" z="-1"/></transform>
        <emitter type="area"><ref name="radiance" id="pattern"/></emitter>
    </shape>
    <shape type="sphere">
        <point name="center" value="1, 0.8, 0.5"/><float name="radius" value="0.5"/>
        <emitter type="area">
            <texture type="checkerboard" name="radiance">
                <rgb name="color0" value="1, 0.6, 0.2"/><rgb name="color1" value="0.1, 0.4, 1"/>
                <transform name="to_uv"><scale x="4" y="4"/></transform>
            </texture>
        </emitter>
    </shape>
""" + COMMON + "</scene>\n",
    # thin lens with a focal length and a crop window; textured spot and projector
    "thinlens_crop_spot_projector": """<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="thinlens">
        <string name="focal_length" value="28mm"/>
        <float name="aperture_radius" value="0.1"/>
        <float name="focus_distance" value="5.5"/>
        <transform name="to_world"><lookat origin="0, 3, 6" target="0, 0.3, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm">
            <integer name="width" value="96"/><integer name="height" value="72"/>
            <integer name="crop_offset_x" value="16"/><integer name="crop_offset_y" value="8"/>
            <integer name="crop_width" value="64"/><integer name="crop_height" value="48"/>
        </film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="0.05"/></emitter>
    <emitter type="spot">
        <rgb name="intensity" value="20, 15, 10"/>
        <float name="cutoff_angle" value="35"/>
        <float name="beam_width" value="15"/>
        <texture type="checkerboard" name="texture">
            <transform name="to_uv"><scale x="4" y="4"/></transform>
        </texture>
        <transform name="to_world"><lookat origin="0.5, 4, 0" target="0, 0, 0" up="1, 0, 0"/></transform>
    </emitter>
    <emitter type="projector">
        <float name="fov" value="30"/>
        <float name="scale" value="2"/>
        <texture type="bitmap" name="irradiance"><string name="filename" value="pattern.exr"/></texture>
        <transform name="to_world"><lookat origin="3, 3, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
    </emitter>
""" + COMMON + "</scene>\n",
    # perspective at the 50 mm default with a principal point offset and a crop window;
    # an untextured spot with the default beam width and a constant projector
    "perspective_ppo_crop": """<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="perspective">
        <float name="principal_point_offset_x" value="0.1"/>
        <float name="principal_point_offset_y" value="-0.05"/>
        <float name="focus_distance" value="3"/>
        <transform name="to_world"><lookat origin="0, 3, 6" target="0, 0.3, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm">
            <integer name="width" value="80"/><integer name="height" value="60"/>
            <integer name="crop_offset_x" value="4"/><integer name="crop_offset_y" value="10"/>
            <integer name="crop_width" value="64"/><integer name="crop_height" value="48"/>
            <rfilter type="tent"/>
        </film>
    </sensor>
    <emitter type="spot">
        <rgb name="intensity" value="30"/>
        <float name="cutoff_angle" value="25"/>
        <transform name="to_world"><lookat origin="-2, 4, 1" target="-1, 0, 0" up="0, 0, 1"/></transform>
    </emitter>
    <emitter type="projector">
        <string name="focal_length" value="35mm"/>
        <rgb name="irradiance" value="0.5, 1, 2"/>
        <transform name="to_world"><lookat origin="3, 3, 3" target="0.5, 0, 0" up="0, 1, 0"/></transform>
    </emitter>
""" + COMMON + "</scene>\n",
}


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(7)
    pattern = (rng.random((4, 8, 3)) * 3.0).astype(np.float32)
    pattern[0, :, :] = [4.0, 0.5, 0.2]  # a distinct top row, to catch a flipped v
    mi.Bitmap(pattern).write(str(OUT / "pattern.exr"))
    metrics = {}
    for name, text in SCENES.items():
        path = OUT / f"{name}.xml"
        path.write_text(text)
        scene = mi.load_file(str(path))
        ref = np.array(mi.render(scene, spp=REF_SPP, seed=1000), dtype=np.float64)[..., :3]
        mi.Bitmap(ref.astype(np.float32)).write(str(OUT / f"{name}.exr"))
        rel, b8, dev = [], [], 0.0
        for seed in range(2):
            img = np.array(mi.render(scene, spp=64, seed=seed), dtype=np.float64)[..., :3]
            rel.append(relmse(img, ref))
            b8.append(relmse(block(img), block(ref)))
            ratio = img.reshape(-1, 3).mean(0) / ref.reshape(-1, 3).mean(0)
            dev = max(dev, float(np.abs(ratio - 1).max()))
        metrics[name] = {
            "resolution": [ref.shape[1], ref.shape[0]],
            "ref_spp": REF_SPP,
            "mitsuba_64spp_relmse": sum(rel) / 2,
            "mitsuba_64spp_block8": sum(b8) / 2,
            "mitsuba_64spp_max_mean_dev": dev,
        }
        print(name, metrics[name])
    (OUT / "metrics.json").write_text(json.dumps(metrics, indent=1) + "\n")


if __name__ == "__main__":
    main()
