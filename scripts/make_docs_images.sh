#!/usr/bin/env bash
# Regenerates every picture in README.md (docs/*.png) with the current code:
#
#     bash scripts/make_docs_images.sh
#
# The scene renders and the MERL slice read ../shared (the conformance scenes and data).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p specula-cli
S=target/release/specula
SHARED=../shared
mkdir -p docs

for scene in cbox meshes veach_mis; do
    $S render "$SHARED/scenes/$scene.xml" -D spp=256 --quiet -o "docs/$scene.png"
done

$S brdf plot "roughconductor material=Cu alpha=0.2 distribution=ggx" -o docs/lobe.png
$S fresnel plot --ior 1.5 -o docs/fresnel.png
$S fresnel plot --material Au -o docs/fresnel_au.png
$S fresnel plot --ior bk7 --spectral -o docs/fresnel_bk7_spectral.png
$S fresnel dispersion -o docs/dispersion.png >/dev/null
# the dispersive prism: needs the spectral mode (`--mode spectral`)
$S render examples/prism.xml -D spp=256 --quiet -o docs/prism_rgb.png
$S render examples/prism.xml --mode spectral -D spp=256 --quiet -o docs/prism_spectral.png
$S brdf slice "$SHARED/data/merl/mitsuba_rough_plastic.binary" -o docs/slice.png
$S brdf albedo "roughconductor material=none alpha=0.8 distribution=ggx" -o docs/albedo.png
P="principled base_color=0.8,0.3,0.2 roughness=0.35 spec_trans=0.6 clearcoat=0.8 clearcoat_gloss=0.8 sheen=0.5"
PT="principledthin base_color=0.4,0.8,0.2 roughness=0.3 spec_trans=0.5 diff_trans=1 eta=1.33"
$S brdf plot "$P" -o docs/principled_lobe.png
$S brdf albedo "$P" -o docs/principled_albedo.png >/dev/null
$S brdf plot "$PT" -o docs/principledthin_lobe.png
$S brdf albedo "$PT" -o docs/principledthin_albedo.png >/dev/null
$S gallery --no-presets --quiet --columns 2 --size 200 -o docs/multiscatter.png \
    "roughconductor alpha=0.8 material=Au distribution=ggx" \
    "roughconductor multiscatter=true alpha=0.8 material=Au distribution=ggx" \
    "roughdielectric alpha=1 int_ior=1.5 distribution=ggx" \
    "roughdielectric multiscatter=true alpha=1 int_ior=1.5 distribution=ggx" \
    "principled metallic=1 roughness=0.9 base_color=0.9,0.6,0.2" \
    "principled multiscatter=true metallic=1 roughness=0.9 base_color=0.9,0.6,0.2"
$S phase plot hg --g 0.2,0.6,0.9,-0.4 rayleigh --log -o docs/phase.png
$S gallery --quiet -o docs/gallery.png "$SHARED/data/merl/mitsuba_rough_copper.binary" \
    "$SHARED/data/rgl/acrylic_felt_green_rgb.bsdf"
$S gallery --no-presets --quiet -o docs/cloth_gallery.png \
    "irawan pattern=polyester repeatU=60 repeatV=30 warp_kd=0.03,0.08,0.3 warp_ks=0.5 weft_kd=0.03,0.08,0.3 weft_ks=0.5" \
    "irawan pattern=denim repeatU=60 repeatV=30 warp_kd=0.03,0.07,0.25 warp_ks=0.15 weft_kd=0.6,0.6,0.55 weft_ks=0.15" \
    "irawan pattern=charmeuse repeatU=60 repeatV=30 warp_kd=0.25,0.02,0.05 warp_ks=0.6 weft_kd=0.25,0.02,0.05 weft_ks=0.3" \
    "blendbsdf weight=0.6 { diffuse reflectance=0.2,0.01,0.04 } { velvet reflectance=0.9,0.25,0.4 sigma=0.3 }"
echo "docs/*.png regenerated"
