use super::*;
use std::path::Path;

fn scene(integrator: &str, extra: &str) -> Result<Scene> {
    let text = format!(
        r#"<scene version="3.0.0">
    {integrator}
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="9"/><integer name="height" value="3"/><rfilter type="box"/></film>
    </sensor>
    <shape type="sphere"><float name="radius" value="0.5"/><point name="center" x="-1.3" y="0" z="0"/></shape>
    <shape type="sphere"><float name="radius" value="0.5"/></shape>
    {extra}
</scene>"#
    );
    Scene::from_xml_str(&text, "<test>", Path::new("."), &[])
}

/// Sphere lights sampled by their cone (in f32): every sample lies on the sphere's near
/// side, inside the cone, with the pdf `area_light_pdf` gives, for a large close sphere
/// and a tiny distant one (where 1 − cosθmax ≈ 5e-11).
#[test]
fn sphere_light_cone_samples_lie_on_the_sphere() {
    for (r, z) in [(1.0f32, 2.5f32), (1e-3, -100.0)] {
        let light = format!(
            r#"<shape type="sphere"><float name="radius" value="{r}"/><point name="center" x="0.3" y="0.1" z="{z}"/><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#
        );
        let s = scene(r#"<integrator type="path"/>"#, &light).unwrap();
        let Light::Area { shape, .. } = &s.lights[0] else {
            panic!("not an area light")
        };
        let shape = *shape;
        let c = Vec3::new(0.3, 0.1, z);
        let x = Vec3::new(0.0, 0.0, 4.0);
        let mut n = 0;
        for i in 0..64 {
            for j in 0..16 {
                let u = Vec2::new((i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 16.0);
                let Some(ls) = s.sample_light(x, u) else {
                    continue;
                };
                n += 1;
                let p = x + ls.wi * ls.dist;
                let err = ((p - c).length() - r).abs();
                assert!(err <= 1e-5 * (x - c).length(), "{r} {z}: off by {err}");
                // the near side: the surface faces x
                assert!((p - c).dot(x - p) >= -1e-4 * r * (x - c).length());
                let pdf = s.area_light_pdf(shape, x, p, (p - c) / r);
                assert!((ls.pdf / pdf - 1.0).abs() < 1e-5, "{} vs {pdf}", ls.pdf);
                assert!((ls.wi.length() - 1.0).abs() < 1e-6);
            }
        }
        assert_eq!(n, 64 * 16, "{r} {z}: samples refused");
    }
}

#[test]
fn parses_mitsuba_parameters_and_refuses_bad_ones() {
    let s = scene(
        r#"<integrator type="direct"><integer name="shading_samples" value="3"/></integrator>"#,
        "",
    )
    .unwrap();
    assert_eq!(
        s.integrator,
        Integrator::Direct(DirectSettings {
            emitter_samples: 3,
            bsdf_samples: 3,
            hide_emitters: false
        })
    );
    let s = scene(r#"<integrator type="aov"><string name="aovs" value="nn:sh_normal, position:position, depth.y:depth"/><integrator type="path" name="image"/></integrator>"#, "").unwrap();
    assert_eq!(
        s.integrator.aov_channels(),
        [
            "image.R",
            "image.G",
            "image.B",
            "image.A",
            "nn.X",
            "nn.Y",
            "nn.Z",
            "position.X",
            "position.Y",
            "position.Z",
            "depth.y.T"
        ]
    );
    // every AOV type of Mitsuba 3.9, with Mitsuba's channel suffixes
    let s = scene(r#"<integrator type="aov"><string name="aovs" value="a:albedo,b:dp_du,c:dp_dv,d:duv_dx,e:duv_dy"/></integrator>"#, "").unwrap();
    assert_eq!(
        s.integrator.aov_channels().join(" "),
        "a.R a.G a.B b.X b.Y b.Z c.X c.Y c.Z d.U d.V e.U e.V"
    );
    assert!(s.integrator.needs_differentials());
    assert!(!Integrator::default().needs_differentials());
    for (bad, msg) in [
        (
            r#"<integrator type="direct"><integer name="emitter_samples" value="-1"/></integrator>"#,
            "emitter_samples",
        ),
        (
            r#"<integrator type="direct"><integer name="max_depth" value="2"/></integrator>"#,
            "max_depth",
        ),
        (
            r#"<integrator type="direct"><integer name="shading_samples" value="2"/><integer name="bsdf_samples" value="0"/></integrator>"#,
            "not both",
        ),
        (
            r#"<integrator type="direct"><integer name="emitter_samples" value="0"/><integer name="bsdf_samples" value="0"/></integrator>"#,
            "at least one",
        ),
        (
            r#"<integrator type="aov"><string name="aovs" value="a:nonsense"/></integrator>"#,
            "invalid AOV type 'nonsense'",
        ),
        (
            r#"<integrator type="aov"><string name="aovs" value="a:boundary_test"/></integrator>"#,
            "invalid AOV type 'boundary_test'",
        ),
        (
            r#"<integrator type="aov"><string name="aovs" value="depth"/></integrator>"#,
            "name:type",
        ),
        (
            r#"<integrator type="depth"><integrator type="path"/></integrator>"#,
            "cannot be nested",
        ),
        (r#"<integrator type="ptracer"/>"#, "not supported"),
    ] {
        let e = scene(bad, "").err().unwrap().to_string();
        assert!(e.contains(msg) && e.contains("<test>:2:"), "{e}");
    }
}

#[test]
fn uv_partials_solve_the_tangent_plane() {
    // the plane z = 0 with ∂p/∂u = (2, 0, 0), ∂p/∂v = (0.5, 3, 0), seen from above by a
    // ray along −z; the differential rays start 0.1 over in x and y (orthographic)
    let mut si = SurfaceGeometry {
        p: Vec3::new(0.2, 0.1, 0.0),
        n_geo: Vec3::Z,
        sh_frame: specula_bsdf::frame::Frame::from_normal(Vec3::Z),
        uv: Vec2::ZERO,
        dp_du: Vec3::new(2.0, 0.0, 0.0),
        dp_dv: Vec3::new(0.5, 3.0, 0.0),
    };
    let (o, d) = (Vec3::new(0.2, 0.1, 5.0), -Vec3::Z);
    let diff = RayDifferentials {
        o_x: o + Vec3::X * 0.1,
        d_x: d,
        o_y: o + Vec3::Y * 0.1,
        d_y: d,
    };
    // Δp = u·(2, 0, 0) + v·(0.5, 3, 0): Δp = (0.1, 0, 0) ⇒ (0.05, 0); (0, 0.1, 0) ⇒
    // v = 1/30, u = −0.5·v/2
    let (dx, dy) = diff.uv_partials(&si);
    assert!((dx - Vec2::new(0.05, 0.0)).length() < 1e-6, "{dx}");
    assert!(
        (dy - Vec2::new(-0.25 / 30.0, 1.0 / 30.0)).length() < 1e-6,
        "{dy}"
    );
    // halving the differentials halves the partials (Mitsuba's 1/√spp with 4 spp)
    let (hx, hy) = diff.scaled(o, d, 0.5).uv_partials(&si);
    assert!((hx - dx * 0.5).length() < 1e-6 && (hy - dy * 0.5).length() < 1e-6);
    // a degenerate parameterisation gives 0, not NaN
    si.dp_du = Vec3::ZERO;
    assert_eq!(diff.uv_partials(&si), (Vec2::ZERO, Vec2::ZERO));
}

#[test]
fn depth_and_aovs_of_the_first_hit() {
    let s = scene(r#"<integrator type="aov"><string name="aovs" value="d:depth,p:prim_index,s:shape_index,n:geo_normal,uv:uv"/></integrator>"#, "").unwrap();
    let mut rng = specula_bsdf::rng::Pcg32::new(1, 1);
    let mut c = Counters::default();
    let mut out = [f32::NAN; 8];
    // the centre pixel looks at the second sphere's front
    let ray = s.camera.ray(Vec2::new(0.5, 0.5));
    let hit = s.intersect(&ray);
    let l = s.sample(&s.integrator, ray, hit, &mut rng, &mut c, &mut out);
    assert_eq!(l, Rgb::ZERO);
    let t = 5.0 - 0.5 - 0.01; // near clip 0.01
    assert!((out[0] - t).abs() < 1e-3, "{out:?}");
    assert_eq!(out[1..3], [0.0, 2.0]);
    assert!((Vec3::from_slice(&out[3..6]) - Vec3::Z).length() < 1e-3);
    assert!(out[6..8].iter().all(|v| (0.0..=1.0).contains(v)));
    // a miss: all zero
    let ray = s.camera.ray(Vec2::new(0.5, 0.02));
    let l = s.sample(
        &s.integrator,
        ray,
        s.intersect(&ray),
        &mut rng,
        &mut c,
        &mut out,
    );
    assert_eq!((l, out), (Rgb::ZERO, [0.0; 8]));
    // the depth integrator agrees with the AOV
    let d = scene(r#"<integrator type="depth"/>"#, "").unwrap();
    let ray = d.camera.ray(Vec2::new(0.5, 0.5));
    let l = d.li(ray, &mut rng, &mut c);
    assert!((l.r() - t).abs() < 1e-3 && l.r() == l.b());
}

#[test]
fn direct_strategies_agree_in_expectation() {
    // a diffuse sphere under a spherical area light and a constant environment: emitter
    // sampling, BSDF sampling and their combination estimate the same value
    let light = r#"<shape type="sphere"><point name="center" x="0" y="2" z="2"/><float name="radius" value="0.5"/><emitter type="area"><rgb name="radiance" value="4"/></emitter></shape>
        <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>"#;
    let est = |e: u32, b: u32| {
        let s = scene(&format!(r#"<integrator type="direct"><integer name="emitter_samples" value="{e}"/><integer name="bsdf_samples" value="{b}"/></integrator>"#), light).unwrap();
        let mut rng = specula_bsdf::rng::Pcg32::new(7, 3);
        let mut c = Counters::default();
        let ray = s.camera.ray(Vec2::new(0.5, 0.45));
        let n = 200_000;
        let mut acc = 0.0f64;
        for _ in 0..n {
            acc += s.li(ray, &mut rng, &mut c).g() as f64;
        }
        acc / n as f64
    };
    let both = est(1, 1);
    let lum = est(1, 0);
    let bsdf = est(0, 1);
    let many = est(3, 2);
    assert!(both > 0.05, "{both}");
    for (name, v) in [("emitter", lum), ("bsdf", bsdf), ("3+2", many)] {
        assert!((v / both - 1.0).abs() < 0.02, "{name}: {v} vs {both}");
    }
}

/// Where the scene's one infinite light is an environment map large enough to prefetch, the
/// path loop makes its lookup before tracing a bounce's ray and finishes it if the ray
/// escapes: that gives what `infinite_radiance` gives from the direction, bit for bit, with
/// and without a BSDF pdf for MIS; with a second infinite light nothing is kept (the general
/// loop runs).
#[test]
fn kept_envmap_lookup_gives_infinite_radiance_bit_for_bit() {
    let mut s = scene(r#"<integrator type="path"/>"#, "").unwrap();
    let (w, h) = (256, 128);
    // a map with structure in both directions, so that a wrong cell or weight shows
    let data = (0..w * h * 3)
        .map(|k| {
            let (x, y, c) = ((k / 3) % w, (k / 3) / w, k % 3);
            0.1 + ((x * 7 + y * 13 + c * 5) % 17) as f32
                + if (x / 16 + y / 16) % 2 == 0 {
                    30.0
                } else {
                    0.0
                }
        })
        .collect();
    let img = crate::image_io::Image {
        width: w,
        height: h,
        channels: 3,
        data,
    };
    let to_world = glam::Mat4::from_rotation_y(0.7) * glam::Mat4::from_rotation_x(-0.3);
    let e = crate::emitters::Envmap::new(&img, false, 1.5, &to_world).unwrap();
    s.add_light(crate::emitters::Emitter::Envmap(Box::new(e)));
    assert_eq!(s.prefetched_maps, s.infinite_lights);
    let mut rng = specula_bsdf::rng::Pcg32::new(7, 0);
    for i in 0..4000 {
        let d = specula_bsdf::warp::square_to_uniform_sphere(rng.next_vec2());
        let d = if i % 5 == 0 { d * 3.0 } else { d }; // not normalised
        let (e, l) = s.prefetch_infinite(d).expect("the lookup is kept");
        for pdf in [None, Some(0.3), Some(7.0)] {
            let want = s.infinite_radiance(d, pdf, 1.0, None);
            let got = s.envmap_radiance_at(e, l, pdf);
            assert_eq!(
                got.0.map(f32::to_bits),
                want.0.map(f32::to_bits),
                "{d} {pdf:?}"
            );
        }
    }
    s.add_light(crate::emitters::Emitter::constant(Rgb::splat(0.5)));
    assert!(s.prefetch_infinite(Vec3::Y).is_none());
}
