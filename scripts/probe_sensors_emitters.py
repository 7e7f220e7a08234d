#!/usr/bin/env python3
"""Probes of Mitsuba 3.9.1 (scalar_rgb) whose printed numbers are the expected values in the unit
tests of crates/specula-render/src/camera.rs (perspective/thinlens/orthographic rays, fov rules,
crop, principal point, parameter errors) and emitters/ (spot falloff and texture, projector
normalisation). Developer tool only (needs mitsuba and numpy): python3 scripts/probe_sensors_emitters.py
"""
import math

import numpy as np

# ---- probe_cam.py
def _probe_cam():
    import mitsuba as mi
    mi.set_variant('scalar_rgb')
    def cam(extra, w=64, h=48, crop=None):
        d={'type':'perspective','film':{'type':'hdrfilm','width':w,'height':h}}
        if crop: d['film'].update(crop)
        d.update(extra)
        return mi.load_dict(d)
    def dir(s, p):
        r,_=s.sample_ray(0,0.5,mi.Point2f(*p),mi.Point2f(0.5,0.5))
        return r.o, r.d, r.maxt
    for ex in [{}, {'focal_length':'35mm'}, {'focal_length':'50'}, {'fov':40,'fov_axis':'smaller'},{'fov':40,'principal_point_offset_x':0.1,'principal_point_offset_y':-0.2}]:
        s=cam(ex)
        print(ex, dir(s,(1,0.5)), dir(s,(0.5,1)), dir(s,(0,0)))
    s=cam({'fov':40}, crop={'crop_offset_x':10,'crop_offset_y':5,'crop_width':20,'crop_height':30})
    print('crop', dir(s,(0,0)), dir(s,(1,1)), s.film().crop_size(), s.film().size())
    s0=cam({'fov':40})
    print('full at crop corners', dir(s0,(10/64,5/48)), dir(s0,(30/64,35/48)))
    for bad in [{'fov':40,'focal_length':'20mm'},{'focal_length':'abc'},{'focal_length':'-5mm'},{'fov':0},{'fov':200},{'fov':40,'near_clip':0},{'fov':40,'near_clip':5,'far_clip':1}, {'fov':40,'to_world':mi.ScalarTransform4f().scale([2,2,2])}]:
        try:
            s=cam(bad); print('ok', bad, dir(s,(1,0.5)))
        except Exception as e: print('ERR', bad, str(e)[:200])
_probe_cam()

# ---- probe_cam2.py
def _probe_cam2():
    import mitsuba as mi
    mi.set_variant('scalar_rgb')
    T=mi.ScalarTransform4f
    def mk(t, extra, w=64, h=48, crop=None):
        d={'type':t,'film':{'type':'hdrfilm','width':w,'height':h}}
        if crop: d['film'].update(crop)
        d.update(extra)
        return mi.load_dict(d)
    def ray(s, p, a=(0.5,0.5)):
        r,_=s.sample_ray(0,0.5,mi.Point2f(*p),mi.Point2f(*a))
        return r.o, r.d, r.maxt
    for fl in ['35.5mm','20 mm','0mm','1e1mm']:
        try: s=mk('perspective',{'focal_length':fl}); print(fl, ray(s,(1,0.5)))
        except Exception as e: print('ERR',fl,str(e)[-120:])
    s=mk('thinlens',{'fov':40,'aperture_radius':0.5,'focus_distance':3})
    print(s)
    for p,a in [((0.5,0.5),(0.5,0.5)),((1,0.5),(1,0.5)),((0.25,0.75),(0.9,0.2))]:
        print('thin',p,a,ray(s,p,a))
    try: print(mk('thinlens',{'fov':40}))
    except Exception as e: print('ERR', str(e)[-150:])
    try: print(mk('thinlens',{'fov':40,'principal_point_offset_x':0.1}))
    except Exception as e: print('ERR', str(e)[-150:])
    s=mk('thinlens',{'fov':40,'aperture_radius':0.5,'focus_distance':3,'to_world':T().translate([1,2,3])})
    print('thin tw',ray(s,(0.25,0.75),(0.9,0.2)))
    s=mk('orthographic',{'to_world':T().look_at(origin=[0,0,-5],target=[0,0,0],up=[0,1,0])@T().scale([2,3,4])})
    print(s)
    for p in [(0,0),(1,1),(0.5,0.5),(0.25,0.75)]:
        print('ortho',p,ray(s,p))
    s=mk('orthographic',{'near_clip':1,'far_clip':10,'to_world':T().scale([2,3,4])})
    print('ortho clip', ray(s,(0.25,0.75)))
    s=mk('orthographic',{})
    print('ortho def', ray(s,(0.25,0.75)))
    s=mk('orthographic',{}, crop={'crop_offset_x':10,'crop_offset_y':5,'crop_width':20,'crop_height':30})
    print('ortho crop', ray(s,(0,0)))
    for bad in [{'fov':3}, {'focal_length':'3mm'},{'principal_point_offset_x':0.1}]:
      try: print(mk('orthographic',bad))
      except Exception as e: print('ERR', str(e)[-150:])
_probe_cam2()

# ---- probe_cam3.py
def _probe_cam3():
    import mitsuba as mi
    mi.set_variant('scalar_rgb')
    T=mi.ScalarTransform4f
    def mk(t, extra, w=64, h=48, crop=None):
        d={'type':t,'film':{'type':'hdrfilm','width':w,'height':h}}
        if crop: d['film'].update(crop)
        d.update(extra)
        return mi.load_dict(d)
    def ray(s, p, a=(0.5,0.5)):
        r,_=s.sample_ray(0,0.5,mi.Point2f(*p),mi.Point2f(*a))
        return r.o, r.d, r.maxt
    for t,ex in [('thinlens',{'aperture_radius':0.2}),('thinlens',{'aperture_radius':0.0,'focus_distance':2}),('thinlens',{'aperture_radius':0.2,'principal_point_offset_x':0.1}),('perspective',{'focal_length':'20mm','fov_axis':'x'}),('thinlens',{'aperture_radius':0.2,'focus_distance':-1}),('thinlens',{'aperture_radius':-0.2}),('perspective',{'focus_distance':-3}),('thinlens',{'aperture_radius':0.2,'to_world':T().scale(2)}),('orthographic',{'focus_distance':3}),('perspective',{'fov':30,'fov_axis':'X'})]:
      try: s=mk(t,ex); print('ok',t,ex,ray(s,(0.25,0.75),(0.9,0.2)))
      except Exception as e: print('ERR',t,ex, str(e)[-150:])
    try:
        s=mk('perspective',{'fov':30}, crop={'crop_offset_x':60,'crop_offset_y':5,'crop_width':20,'crop_height':30})
        print(s.film().crop_size(), s.film().crop_offset())
    except Exception as e: print('ERR', str(e)[-150:])
    for c in [{'crop_width':0},{'crop_offset_x':-1},{'crop_width':100}]:
      try: s=mk('perspective',{'fov':30}, crop=c); print(c, s.film().crop_size(), s.film().crop_offset())
      except Exception as e: print('ERR',c, str(e)[-150:])
_probe_cam3()

# ---- probe_cam4.py
def _probe_cam4():
    import mitsuba as mi
    mi.set_variant('scalar_rgb')
    T=mi.ScalarTransform4f
    def mk(t, extra, w=64, h=48, crop=None):
        d={'type':t,'film':{'type':'hdrfilm','width':w,'height':h}}
        if crop: d['film'].update(crop)
        d.update(extra)
        return mi.load_dict(d)
    def ray(s, p, a=(0.5,0.5)):
        r,_=s.sample_ray(0,0.5,mi.Point2f(*p),mi.Point2f(*a))
        return r.o, r.d, r.maxt
    for fc in [100, 1e4]:
      s=mk('thinlens',{'aperture_radius':0.2,'far_clip':fc}); o,d,_=ray(s,(0.25,0.75),(0.9,0.2)); print(fc, o, d, [o[i]+d[i]*(fc-0.01)/d[2] for i in range(3)])
    for c in [{'crop_width':0},{'crop_offset_x':-1},{'crop_offset_x':10},{'crop_width':100},{'crop_width':20,'crop_height':10}]:
      try: s=mk('perspective',{'fov':30}, crop=c); print(c, s.film().crop_size(), s.film().crop_offset())
      except Exception as e: print('ERR',c, str(e)[-150:])
    for t,ex in [('thinlens',{'aperture_radius':0.2,'to_world':T().scale(2)}),('orthographic',{'principal_point_offset_x':0.1}),('thinlens',{'aperture_radius':0.2,'fov':20,'fov_axis':'y'})]:
      try: s=mk(t,ex); print('ok',t,ex,ray(s,(0.25,0.75),(0.9,0.2)))
      except Exception as e: print('ERR',t,ex, str(e)[-250:].replace('\n',' '))
_probe_cam4()

# ---- probe_ppo.py
def _probe_ppo():
    import mitsuba as mi
    mi.set_variant('scalar_rgb')
    def mk(crop, ppo):
        d={'type':'perspective','fov':40,'film':{'type':'hdrfilm','width':64,'height':48}}
        d['film'].update(crop); d.update(ppo); return mi.load_dict(d)
    def dr(s,p):
        r,_=s.sample_ray(0,0.5,mi.Point2f(*p),mi.Point2f(0.5,0.5)); d=r.d; return [d[0]/d[2], d[1]/d[2]]
    crop={'crop_offset_x':10,'crop_offset_y':5,'crop_width':20,'crop_height':30}
    ppo={'principal_point_offset_x':0.1,'principal_point_offset_y':-0.2}
    for p in [(0,0),(1,1),(0.5,0.5)]:
        print(p, 'crop+ppo',dr(mk(crop,ppo),p),'crop',dr(mk(crop,{}),p),'ppo',dr(mk({},ppo),p),'none',dr(mk({},{}),p))
_probe_ppo()

# ---- probe_em.py
def _probe_em():
    import mitsuba as mi
    mi.set_variant('scalar_rgb')
    T=mi.ScalarTransform4f
    def sd(e, p):
        it=mi.Interaction3f(); it.p=mi.Point3f(*p); it.wavelengths=[]
        ds,w=e.sample_direction(it, mi.Point2f(0.3,0.6))
        return (ds.d, ds.dist, ds.pdf, ds.delta, w, ds.uv)
    e=mi.load_dict({'type':'spot','intensity':{'type':'rgb','value':[1,2,3]},'cutoff_angle':30,'to_world':T().look_at(origin=[0,0,0],target=[0,0,1],up=[0,1,0])})
    for th in [0,10,20,22.5,25,29,29.9,30,31]:
        t=math.radians(th); print('spot',th, sd(e,[math.sin(t)*2,0,math.cos(t)*2])[4])
    e=mi.load_dict({'type':'spot','to_world':T().translate([1,0,0])@T().scale(2)})
    print('spot scale', sd(e,[1,0,2]))
    for bad in [{'cutoff_angle':0},{'cutoff_angle':100},{'cutoff_angle':20,'beam_width':25},{'cutoff_angle':-5},{'beam_width':-5}]:
      try: e=mi.load_dict(dict(type='spot',**bad)); print('ok',bad, [sd(e,[math.sin(math.radians(t)),0,math.cos(math.radians(t))])[4][0] for t in [0,5,10,15,19]])
      except Exception as ex: print('ERR',bad,str(ex)[-150:])
    # textured
    import numpy as np
    bm=mi.Bitmap(np.array([[[1,0,0],[0,1,0]],[[0,0,1],[1,1,1]]],dtype=np.float32))
    e=mi.load_dict({'type':'spot','cutoff_angle':30,'texture':{'type':'bitmap','bitmap':bm,'filter_type':'nearest'}})
    for p in [[0.3,0.3,1],[-0.3,0.3,1],[0.3,-0.3,1],[-0.3,-0.3,1],[0.5,0,1]]:
        r=sd(e,p); print('tex',p,r[4], r[5])
_probe_em()

# ---- probe_em2.py
def _probe_em2():
    import mitsuba as mi
    import numpy as np
    mi.set_variant('scalar_rgb')
    T=mi.ScalarTransform4f
    def sd(e, p):
        it=mi.Interaction3f(); it.p=mi.Point3f(*p); it.wavelengths=[]
        ds,w=e.sample_direction(it, mi.Point2f(0.3,0.6))
        return (ds.d, ds.dist, ds.pdf, ds.delta, w, ds.uv, ds.n)
    bm=mi.Bitmap(np.array([[[1,0,0],[0,1,0]],[[0,0,1],[1,1,1]]],dtype=np.float32))
    e=mi.load_dict({'type':'spot','cutoff_angle':30,'texture':{'type':'bitmap','bitmap':bm,'filter_type':'nearest'}})
    for p in [[0.3,0.3,1],[-0.3,0.3,1],[0.3,-0.3,1],[-0.3,-0.3,1],[0.5,0,1]]:
        r=sd(e,p); print('spottex',p,r[4])
    e=mi.load_dict({'type':'projector','irradiance':{'type':'bitmap','bitmap':bm,'filter_type':'nearest'},'fov':40})
    for p in [[0.3,0.2,1],[-0.3,0.2,1],[0.3,-0.2,1],[-0.3,-0.2,1],[0,0,1],[0,0,2],[0.5,0,1],[0,0,-1],[0.36,0,1],[0.37,0,1]]:
        r=sd(e,p); print('proj',p,r[4], r[5], r[1])
    e=mi.load_dict({'type':'projector','irradiance':{'type':'rgb','value':[1,2,3]},'fov':40,'scale':2})
    for p in [[0,0,1],[0.2,0.1,1]]:
        r=sd(e,p); print('projc',p,r[4], r[5], r[1], r[6])
    bm=mi.Bitmap(np.ones((10,30,3),dtype=np.float32))
    e=mi.load_dict({'type':'projector','irradiance':{'type':'bitmap','bitmap':bm},'fov':40})
    for p in [[0,0,1],[0.2,0.1,1],[0,0.2,1]]:
        r=sd(e,p); print('proj 30x10',p,r[4], r[5], r[1])
    e=mi.load_dict({'type':'projector','irradiance':{'type':'bitmap','bitmap':bm}})
    print('proj default fov', sd(e,[0.2,0.1,1])[4])
    e=mi.load_dict({'type':'projector','irradiance':{'type':'bitmap','bitmap':bm},'focal_length':'35mm','to_world':T().translate([1,2,3])@T().rotate([0,1,0],30)})
    print('proj tw', sd(e,[1.5,2.1,4])[4:6])
    e=mi.load_dict({'type':'projector','fov':40,'to_world':T().scale(2)})
    print('proj scale', sd(e,[0.2,0.1,1])[4:6])
    print(e)
_probe_em2()
