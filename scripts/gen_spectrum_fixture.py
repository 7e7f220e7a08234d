#!/usr/bin/env python3
"""Generate the "<spectrum> to RGB agrees with Mitsuba 3" fixture for specula-render.

Developer tool only: CI never runs it (CI has no Mitsuba). The output is committed as
crates/specula-render/tests/data/spectra/fixture.txt (with the .spd files it names, copied
from the Mitsuba package's data/ior folder into the same folder) and read by
crates/specula-render/tests/spectra.rs.

How to run (needs `pip install mitsuba==3.9.1`; numpy is not needed):

    python3 scripts/gen_spectrum_fixture.py

Each case is a <spectrum> element (named "c") and the way a plugin reads it:
  reflectance  Mitsuba's get_texture           (here: diffuse `reflectance`)
  unbounded    Mitsuba's get_unbounded_texture (here: conductor `eta`)
  emission     Mitsuba's get_emissive_texture  (here: point emitter `intensity`)
The element is loaded by Mitsuba's `scalar_rgb` XML parser inside that plugin and the RGB it
produced is read back with mi.traverse. Lines:

    case <usage> <r> <g> <b> <xml element on one line>

Mitsuba 3.9.1's RGB variants load `blackbody`, `regular` and `irregular` spectra but cannot
render them ("Not implemented for non-spectral modes"); Specula converts them as the equivalent
wavelength list, and so does this script: `regular`/`irregular` as their `value="λ:v, …"` list,
`blackbody` as the list of its values (Mitsuba's `scalar_spectral` blackbody plugin) at the
1000 wavelengths that Mitsuba's spectrum_list_to_srgb samples, which that function then
reproduces exactly. Such cases record what Mitsuba's parser makes of that list.
Numbers are written with repr() of the float32 value Mitsuba returned.
"""
import pathlib
import re
import shutil

import mitsuba as mi

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT_DIR = ROOT / "crates/specula-render/tests/data/spectra"
OUT = OUT_DIR / "fixture.txt"
DOCS = ROOT.parent / "shared/mitsuba-data/docs/scenes"
MI_DATA = pathlib.Path(mi.__file__).parent / "data/ior"
SPD_FILES = ["Cu.eta.spd", "Cu.k.spd", "Au.eta.spd", "Au.k.spd", "Ag.k.spd", "TiO2.eta.spd"]

HOSTS = {
    "reflectance": ('<bsdf type="diffuse" id="h">', "</bsdf>", "reflectance"),
    "unbounded": ('<bsdf type="conductor" id="h">', "</bsdf>", "eta"),
    "emission": ('<emitter type="point" id="h">', "</emitter>", "intensity"),
}


def mitsuba_rgb(element, usage, base=OUT_DIR):
    """What Mitsuba's scalar_rgb parser gives the parameter `usage` reads from `element`."""
    mi.set_variant("scalar_rgb")
    head, tail, name = HOSTS[usage]
    el = element.replace('name="c"', f'name="{name}"', 1)
    el = re.sub(r'filename="([^"]+)"', lambda m: f'filename="{base / m.group(1)}"', el)
    scene = mi.load_string(f'<scene version="3.0.0">{head}{el}{tail}</scene>')
    params = mi.traverse(scene)
    v = params[f"h.{name}.value"]
    try:
        return [float(v[0]), float(v[1]), float(v[2])]
    except TypeError:  # a uniform texture stores a single float
        return [float(v)] * 3


def grid():
    """The wavelengths of Mitsuba's spectrum_list_to_srgb (same double arithmetic)."""
    return [360.0 + (i / 999.0) * (830.0 - 360.0) for i in range(1000)]


def blackbody_as_list(temperature, lo=360.0, hi=830.0):
    mi.set_variant("scalar_spectral")
    props = {"type": "blackbody", "temperature": temperature}
    if (lo, hi) != (360.0, 830.0):
        props.update(wavelength_min=lo, wavelength_max=hi)
    bb = mi.load_dict(props)
    si = mi.SurfaceInteraction3f()
    pairs = []
    for w in grid():
        if lo <= w <= hi:
            si.wavelengths = mi.Spectrum(w, w, w, w)
            pairs.append(f"{w!r}:{float(bb.eval(si)[0])!r}")
    return '<spectrum name="c" value="' + ", ".join(pairs) + '"/>'


def main():
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    for f in SPD_FILES:
        shutil.copyfile(MI_DATA / f, OUT_DIR / f)

    cases = []  # (usages, element written in the fixture, element given to Mitsuba or None)
    all3 = ["reflectance", "unbounded", "emission"]

    # every distinct wavelength list of Mitsuba's documentation scenes
    seen = set()
    for xml in sorted(DOCS.glob("*.xml")):
        for m in re.finditer(r'<spectrum name="[^"]*" value="([^"]*:[^"]*)"/>', xml.read_text()):
            if m.group(1) not in seen:
                seen.add(m.group(1))
                cases.append((all3, f'<spectrum name="c" value="{m.group(1)}"/>', None))
    # hand-made lists: irregular spacing, beyond 360-830 nm, narrow, negative, out of gamut
    for v in [
        "400:0.5, 700:0.5",
        "360:1, 830:1",
        "300:1.8, 400:1.65, 500:0.9, 600:0.2, 700:0.16, 800:0.18",
        "350:0.1, 420:0.9, 421:0.2, 560:0.7, 900:0.3",
        "400:0.5 500:0.7",
        "590:1,600:1",
        "400:-1, 500:5, 700:1",
        "380:0, 450:30, 451:0, 830:0",
        "100:0.5, 200:0.7",
        "400:3, 700:3",
    ]:
        if v not in seen:
            seen.add(v)
            cases.append((all3, f'<spectrum name="c" value="{v}"/>', None))
    # constants
    for v in ["0.5", "3", "-0.25"]:
        cases.append((all3, f'<spectrum name="c" value="{v}"/>', None))
    # .spd files
    for f in SPD_FILES:
        cases.append((all3, f'<spectrum name="c" filename="{f}"/>', None))
    # spectrum plugins Mitsuba's RGB variants evaluate
    for el in [
        '<spectrum type="uniform" name="c"><float name="value" value="0.3"/></spectrum>',
        '<spectrum type="d65" name="c"/>',
        '<spectrum type="d65" name="c"><rgb name="color" value="0.5, 0.2, 0.1"/>'
        '<float name="scale" value="2"/></spectrum>',
        '<spectrum type="srgb" name="c"><rgb name="color" value="0.1, 0.5, 0.9"/></spectrum>',
        '<spectrum type="srgb" name="c"><rgb name="color" value="3, 0.5, 0.9"/>'
        '<boolean name="unbounded" value="true"/></spectrum>',
    ]:
        cases.append((all3, el, None))
    # ones they load but cannot render: the equivalent list
    cases.append(
        (
            all3,
            '<spectrum type="regular" name="c"><float name="wavelength_min" value="400"/>'
            '<float name="wavelength_max" value="700"/>'
            '<string name="values" value="0.1, 0.5, 0.9, 0.3"/></spectrum>',
            '<spectrum name="c" value="400:0.1, 500:0.5, 600:0.9, 700:0.3"/>',
        )
    )
    cases.append(
        (
            all3,
            '<spectrum type="irregular" name="c"><string name="wavelengths" value="380, 455.5, 610, 720"/>'
            '<string name="values" value="0.2, 0.8, 0.1, 0.6"/></spectrum>',
            '<spectrum name="c" value="380:0.2, 455.5:0.8, 610:0.1, 720:0.6"/>',
        )
    )
    for t in [1000, 2700, 3000, 5000, 6500, 10000]:
        cases.append(
            (
                ["emission"],
                f'<spectrum type="blackbody" name="c"><float name="temperature" value="{t}"/></spectrum>',
                blackbody_as_list(t),
            )
        )
    cases.append(
        (
            ["emission"],
            '<spectrum type="blackbody" name="c"><float name="temperature" value="4000"/>'
            '<float name="wavelength_min" value="450"/><float name="wavelength_max" value="650"/></spectrum>',
            blackbody_as_list(4000, 450.0, 650.0),
        )
    )

    lines = [
        "# Generated by scripts/gen_spectrum_fixture.py with Mitsuba "
        + mi.__version__
        + " (scalar_rgb): case <usage> <r> <g> <b> <element>",
    ]
    for usages, el, mitsuba_el in cases:
        for usage in usages:
            rgb = mitsuba_rgb(mitsuba_el or el, usage)
            lines.append(f"case {usage} {rgb[0]!r} {rgb[1]!r} {rgb[2]!r} {el}")
    OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {len(lines) - 1} cases to {OUT}")


if __name__ == "__main__":
    main()
