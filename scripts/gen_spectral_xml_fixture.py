#!/usr/bin/env python3
"""Fixture of `<spectrum>` values in spectral mode: BSDFs and emitters evaluated at fixed
wavelengths by Mitsuba 3.9.1's `scalar_spectral` variant, for
crates/specula-render/tests/spectral_xml.rs.

Developer tool only: CI never runs it (CI has no Mitsuba). Needs `pip install mitsuba==3.9.1`.
Run from the repository root:

    python3 scripts/gen_spectral_xml_fixture.py

Writes tests/data/spectral_xml/fixture.json:
- `bsdf`: records {xml, wl: [a, b, c], wi, wo, value: [f·|cos θo| at a, b, c], tol}: the BSDF
  XML is loaded by Mitsuba (files relative to tests/data/spectral_xml/) and evaluated with
  `eval` at a surface point whose four wavelengths are (a, b, c, c). The principled models
  couple the wavelengths through the tints' luminance (Mitsuba's `luminance(value,
  wavelengths)`, the mean of ȳ(λ)·value(λ) over the path's four wavelengths, which Mitsuba
  draws as u, u + 1/4, u + 1/2, u + 3/4 through the inverse CDF of its wavelength density):
  their records hold, for a = λ(u0), b = λ(u0 + 1/3), c = λ(u0 + 2/3), Mitsuba's value at each
  of them on the path whose wavelengths are it and its quarter shifts (what its renders see
  at that wavelength, and what Specula's per-channel tint luminance reproduces).
  `tol`: the relative tolerance the test applies, 1e-4 where both sides evaluate the same
  spectrum, larger where the value goes through an RGB → spectrum upsampling (Specula
  computes its own coefficient table, Mitsuba reads its `rgb2spec` table: they agree to
  about 1e-2) or where the model itself differs slightly from Mitsuba's in RGB mode too
  (`roughplastic`: 2e-4; `roughconductor` is only evaluated at the first two direction pairs:
  at the third, Specula's RGB-mode value already differs by 3e-3, 0.187094 against Mitsuba's
  0.187658 for eta 1.5, k 2, alpha 0.3).
  Records of a `checkerboard` with spectral colours also give the texture coordinates `uv`
  (elsewhere 0.5, 0.5).
- `emitter`: records {xml (an emitter in a shape, or a point light), wl, value}: an area
  emitter's `eval` (radiance) or a point light's `sample_direction` weight at distance 1,
  at wavelengths (a, b, c, c).
"""
import json
import math
import pathlib

import drjit as dr
import mitsuba as mi

mi.set_variant("scalar_spectral")
DIR = pathlib.Path("tests/data/spectral_xml")
OUT = DIR / "fixture.json"
EXACT = 1e-4
UPSAMPLED = 2e-2


# plugin files (filename=) resolve against the fixture's directory
mi.file_resolver().prepend(str(DIR.resolve()))


def load(xml):
    return mi.load_string(xml)


def frame_si(wi, wl, uv=(0.5, 0.5)):
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(*wi)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.n = mi.Vector3f(0, 0, 1)
    si.uv = mi.Point2f(*uv)
    si.wavelengths = mi.Spectrum(*wl)
    return si


def bsdf_eval(b, wi, wo, wl4, uv=(0.5, 0.5)):
    v = b.eval(mi.BSDFContext(), frame_si(wi, wl4, uv), mi.Vector3f(*wo))
    return [float(v[k]) for k in range(4)]


def unit(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def lam(u):
    """Mitsuba's wavelength for the uniform number u (`sample_rgb_spectrum`)."""
    return float(mi.sample_rgb_spectrum(u % 1.0)[0])


WL = [[450.0, 550.0, 650.0], [405.5, 532.25, 611.75], [380.0, 498.0, 700.0]]
# hero numbers of the principled records (the three wavelengths are u0, u0 + 1/3, u0 + 2/3)
U0 = [0.1, 0.37, 0.61, 0.93]
DIRS = [
    ([0.3, 0.1, 0.9486833], [-0.2, -0.3, 0.9327379]),
    (unit([0.6, 0.2, 0.5]), unit([-0.55, -0.15, 0.6])),
    (unit([0.1, -0.7, 0.3]), unit([0.2, 0.5, 0.7])),
]
DIRS_T = [(unit([0.3, 0.1, 0.8]), unit([-0.25, -0.1, -0.9]))]

LIST = '<spectrum name="reflectance" value="400:0.2, 500:1.5, 600:0.3"/>'
BASES = [
    '<spectrum name="base_color" value="360:0.1, 440:0.8, 470:0.8, 520:0.15, 600:0.05, 650:0.4, 830:0.5"/>',
    '<spectrum name="base_color" value="360:0.6, 500:0.3, 560:0.9, 830:0.2"/>',
    '<spectrum name="base_color" filename="floor.spd"/>',
]
BSDFS = [
    ('<bsdf type="diffuse">' + LIST + '</bsdf>', EXACT),
    ('<bsdf type="diffuse"><spectrum name="reflectance" value="360:0.04, 528:0.04, 538:0.95, 552:0.95, 562:0.04, 830:0.04"/></bsdf>', EXACT),
    ('<bsdf type="diffuse"><spectrum name="reflectance" filename="floor.spd"/></bsdf>', EXACT),
    ('<bsdf type="diffuse"><spectrum name="reflectance" type="regular"><float name="wavelength_min" value="380"/>'
     '<float name="wavelength_max" value="780"/><string name="values" value="0.7, 0.6, 0.2, 0.05, 0.05, 0.1, 0.5, 0.8, 0.85"/></spectrum></bsdf>', EXACT),
    ('<bsdf type="diffuse"><spectrum name="reflectance" type="uniform"><float name="value" value="0.7"/></spectrum></bsdf>', EXACT),
    ('<bsdf type="diffuse"><spectrum name="reflectance" value="0.35"/></bsdf>', EXACT),
    ('<bsdf type="diffuse"><spectrum name="reflectance" type="d65"><float name="scale" value="0.5"/></spectrum></bsdf>', EXACT),
    ('<bsdf type="diffuse"><spectrum name="reflectance" type="d65"><rgb name="color" value="0.2, 0.5, 0.8"/></spectrum></bsdf>', UPSAMPLED),
    ('<bsdf type="diffuse"><spectrum name="reflectance" type="srgb"><rgb name="color" value="0.2, 0.5, 0.8"/></spectrum></bsdf>', UPSAMPLED),
    ('<bsdf type="roughconductor"><float name="alpha" value="0.3"/><spectrum name="eta" filename="metal_eta.spd"/>'
     '<spectrum name="k" filename="metal_k.spd"/></bsdf>', EXACT),
    ('<bsdf type="roughconductor"><float name="alpha" value="0.25"/><spectrum name="eta" value="360:0.3, 480:0.3, 520:1.8, 830:2.0"/>'
     '<spectrum name="k" value="360:3.5, 600:2.2, 830:3.0"/><spectrum name="specular_reflectance" value="400:1, 600:0.5, 700:0.9"/></bsdf>', EXACT),
    ('<bsdf type="roughplastic"><float name="alpha" value="0.2"/><spectrum name="diffuse_reflectance" filename="floor.spd"/></bsdf>', 3e-4),
]
PRINCIPLED = [
    ('principled', BASES[0], '<float name="metallic" value="0.2"/><float name="roughness" value="0.35"/>'
     '<float name="spec_tint" value="1"/><float name="sheen" value="1"/><float name="sheen_tint" value="1"/>'),
    ('principled', BASES[1], '<float name="spec_tint" value="0.6"/><float name="sheen" value="0.5"/>'
     '<float name="sheen_tint" value="0.3"/><float name="roughness" value="0.5"/>'),
    ('principled', BASES[2], '<float name="metallic" value="0.5"/><float name="spec_tint" value="0.8"/>'
     '<float name="anisotropic" value="0.4"/><float name="roughness" value="0.3"/><float name="clearcoat" value="0.5"/>'),
    ('principled', BASES[1], '<float name="spec_trans" value="0.5"/><float name="spec_tint" value="1"/>'
     '<float name="sheen" value="0.7"/><float name="sheen_tint" value="1"/><float name="roughness" value="0.4"/>'),
    ('principledthin', BASES[0], '<float name="spec_tint" value="1"/><float name="sheen" value="0.8"/>'
     '<float name="sheen_tint" value="1"/><float name="roughness" value="0.4"/><float name="spec_trans" value="0.4"/>'),
    ('principledthin', BASES[2], '<float name="spec_tint" value="0.5"/><float name="sheen" value="1"/>'
     '<float name="sheen_tint" value="0.6"/><float name="roughness" value="0.6"/><float name="diff_trans" value="0.5"/>'),
]
EMITTERS = [
    '<spectrum name="radiance" value="400:0.2, 500:1.5, 600:0.3"/>',
    '<spectrum name="radiance" filename="lamp.spd"/>',
    '<spectrum name="radiance" value="0.5"/>',
    '<spectrum name="radiance" type="uniform"><float name="value" value="0.7"/></spectrum>',
    '<spectrum name="radiance" type="blackbody"><float name="temperature" value="1900"/></spectrum>',
    '<spectrum name="radiance" type="blackbody"><float name="temperature" value="5000"/>'
    '<float name="wavelength_min" value="450"/><float name="wavelength_max" value="620"/></spectrum>',
    '<spectrum name="radiance" type="d65"><float name="scale" value="2"/></spectrum>',
    '<rgb name="radiance" value="0.5"/>',
    '<float name="radiance" value="0.5"/>',
]


def main():
    bsdf = []
    for xml, tol in BSDFS:
        b = load(xml.replace("<bsdf ", '<bsdf version="3.0.0" ', 1))
        dirs = DIRS[:2] if "roughconductor" in xml else DIRS
        for wl in WL:
            for wi, wo in dirs:
                v = bsdf_eval(b, wi, wo, wl + [wl[2]])
                bsdf.append({"xml": xml, "wl": wl, "wi": wi, "wo": wo, "value": v[:3], "tol": tol})
    for kind, base, rest in PRINCIPLED:
        xml = f'<bsdf type="{kind}">{base}{rest}</bsdf>'
        b = load(xml.replace("<bsdf ", '<bsdf version="3.0.0" ', 1))
        dirs = DIRS + (DIRS_T if kind == "principledthin" or "spec_trans" in rest else [])
        for u0 in U0:
            us = [u0 + k / 3 for k in range(3)]
            wl = [lam(u) for u in us]
            for wi, wo in dirs:
                # channel k: Mitsuba's value at λ(u_k) on a path whose wavelengths are
                # u_k and its quarter shifts
                v = [bsdf_eval(b, wi, wo, [lam(u + j / 4) for j in range(4)])[0] for u in us]
                bsdf.append({"xml": xml, "wl": wl, "wi": wi, "wo": wo, "value": v, "tol": EXACT})
    # a checkerboard with spectral colours, at a point of each colour
    xml = ('<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">'
           '<spectrum name="color0" value="360:0.04, 528:0.04, 538:0.95, 552:0.95, 562:0.04, 830:0.04"/>'
           '<spectrum name="color1" filename="floor.spd"/></texture></bsdf>')
    b = load(xml.replace("<bsdf ", '<bsdf version="3.0.0" ', 1).replace("<texture ", '<texture version="3.0.0" ', 0))
    for uv in [(0.25, 0.25), (0.75, 0.25)]:
        for wl in WL:
            wi, wo = DIRS[0]
            v = bsdf_eval(b, wi, wo, wl + [wl[2]], uv)
            bsdf.append({"xml": xml, "uv": list(uv), "wl": wl, "wi": wi, "wo": wo, "value": v[:3], "tol": EXACT})
    emitter = []
    for spec in EMITTERS:
        xml = f'<shape type="rectangle"><emitter type="area">{spec}</emitter></shape>'
        e = load(xml.replace("<shape ", '<shape version="3.0.0" ', 1)).emitter()
        for wl in WL:
            si = frame_si([0, 0, 1], wl + [wl[2]])
            v = e.eval(si)
            emitter.append({"xml": xml, "wl": wl, "value": [float(v[k]) for k in range(3)]})
        pspec = spec.replace('name="radiance"', 'name="intensity"')
        xml = f'<emitter type="point"><point name="position" value="0, 0, 1"/>{pspec}</emitter>'
        e = load(xml.replace("<emitter ", '<emitter version="3.0.0" ', 1))
        for wl in WL:
            it = dr.zeros(mi.Interaction3f)
            it.wavelengths = mi.Spectrum(*(wl + [wl[2]]))
            _, w = e.sample_direction(it, mi.Point2f(0.5, 0.5))
            emitter.append({"xml": xml, "wl": wl, "value": [float(w[k]) for k in range(3)]})
    OUT.write_text(json.dumps({"bsdf": bsdf, "emitter": emitter}, indent=0) + "\n")
    print(f"{len(bsdf)} BSDF and {len(emitter)} emitter records")


if __name__ == "__main__":
    main()
