#!/usr/bin/env python3
"""Why ../shared/media/scenes/med_fog_box.xml cannot be matched: its fog cube's bottom face lies
in the floor's plane, and in Mitsuba 3.9 a camera ray that reaches that plane inside the fog hits
either the floor or the cube's (null) bottom face, depending on rounding; after crossing the
bottom face, the spawned ray misses the floor and leaves the scene below it (light leaks
through the floor). Prints, for pixels of three image rows, the shapes each camera ray meets
(`fog_` = the fog cube's null boundary, `floo` = the floor, `miss` = nothing: fallen through).
About half the rays under the fog fall through. Specula's tests judge `med_fog_box_lifted`
(the cube raised by 1 mm, reference from scripts/gen_media_fog_lifted_reference.py) instead. Usage: python3 scripts/probe_fog_box_coplanar.py
"""
import mitsuba as mi, numpy as np
mi.set_variant('scalar_rgb')
s = mi.load_file('/work/shared/media/scenes/med_fog_box.xml')
cam = s.sensors()[0]
names = {}
cnt = {}
for y in [160, 172, 185]:
    row = []
    for x in range(0, 256, 8):
        ray, _ = cam.sample_ray(0, 0.5, mi.Point2f((x+0.5)/256, (y+0.5)/192), mi.Point2f(0.5))
        si = s.ray_intersect(ray)
        # follow through null surfaces
        seq = []
        for k in range(4):
            if not si.is_valid(): seq.append('miss'); break
            sid = si.shape.id(); seq.append(sid)
            if sid != 'fog_volume': break
            ray = si.spawn_ray(ray.d)
            si = s.ray_intersect(ray)
        row.append('>'.join(x[:4] for x in seq))
    print(y, row)
