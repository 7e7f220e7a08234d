#!/usr/bin/env python3
"""Probe how Mitsuba 3.9's `blendbsdf` weights samples of a Dirac lobe.

A rough plastic (GGX, alpha 0.3, black base) blended with a smooth conductor; θi = 0.5 rad.
Prints the mean sample weight of each BSDF and of the blend (the blend's definition gives
(1-w)·mean_rp + w·F), then single samples per (weight, u1). The constants in
`crates/specula-bsdf/src/models/blend.rs` (tests) come from this output.
Usage: python3 scripts/probe_blendbsdf_dirac.py   (needs `pip install mitsuba`)
"""
import mitsuba as mi
import numpy as np

mi.set_variant('scalar_rgb')
RP = {'type': 'roughplastic', 'distribution': 'ggx', 'alpha': 0.3,
      'diffuse_reflectance': {'type': 'rgb', 'value': [0, 0, 0]}}
COND = {'type': 'conductor', 'eta': {'type': 'rgb', 'value': [0.2, 0.9, 1.1]},
        'k': {'type': 'rgb', 'value': [3.5, 2.3, 1.9]}}


def interaction():
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(np.sin(0.5), 0, np.cos(0.5))
    si.n = mi.Vector3f(0, 0, 1)
    si.sh_frame = mi.Frame3f(si.n)
    return si


for name, d in [('roughplastic', RP), ('conductor', COND),
                ('blend w=0.5', {'type': 'blendbsdf', 'weight': 0.5, 'a': RP, 'b': COND})]:
    b = mi.load_dict(d)
    rng = np.random.default_rng(1)
    acc, n = np.zeros(3), 20000
    for _ in range(n):
        _, w = b.sample(mi.BSDFContext(), interaction(), float(rng.random()),
                        mi.Point2f(float(rng.random()), float(rng.random())))
        acc += np.array(w)
    print(f'{name}: mean sample weight {acc / n}')

for wv in [0.25, 0.5, 0.8]:
    b = mi.load_dict({'type': 'blendbsdf', 'weight': wv, 'a': RP, 'b': COND})
    for u in [0.1, 0.3, 0.6, 0.9]:
        bs, w = b.sample(mi.BSDFContext(), interaction(), u, mi.Point2f(0.3, 0.7))
        print(f'weight={wv} u1={u}: type={int(bs.sampled_type)} pdf={float(bs.pdf):.7f} '
              f'sample weight={list(map(float, np.array(w)))}')
