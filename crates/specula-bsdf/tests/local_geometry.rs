//! `Bsdf::reads_local_geometry`: a model that says it does not read the shading point's
//! `dp_du`, `dp_dv` and `n_geo` gives the same values, bit for bit, whatever they are (so a
//! renderer may leave them unset), and the models that do read them say so.

mod common;
use common::Slope;
use glam::{Vec2, Vec3};
use specula_bsdf::{
    build_bsdf, parse_spec, Bsdf, BsdfContext, BsdfModel, Props, ShadingPoint, Spectrum, Value,
};
use std::sync::Arc;

fn wrap(plugin: &str, children: Vec<Bsdf>, params: Vec<(&str, Value)>) -> Bsdf {
    let mut p = Props::new(plugin, None);
    for (k, v) in params {
        p.set(k, v, None).unwrap();
    }
    for c in children {
        p.add_child(c, None);
    }
    build_bsdf(p).unwrap()
}

/// Deterministic directions over the sphere (both hemispheres) and sample numbers.
fn directions() -> Vec<(Vec3, Vec3, f32, Vec2)> {
    let mut rng = specula_bsdf::rng::Pcg32::new(7, 11);
    let dir = |rng: &mut specula_bsdf::rng::Pcg32| {
        let z = 2.0 * rng.next_f32() - 1.0;
        let phi = std::f32::consts::TAU * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    (0..200)
        .map(|_| {
            let wi = dir(&mut rng);
            let wo = dir(&mut rng);
            let u1 = rng.next_f32();
            let u2 = Vec2::new(rng.next_f32(), rng.next_f32());
            (wi, wo, u1, u2)
        })
        .collect()
}

/// (eval, pdf, sample) of `b` at two shading points that differ only in their local
/// geometry; returns whether all of them agree bit for bit.
fn same_at_both_points(b: &Bsdf) -> bool {
    let ctx = BsdfContext::RADIANCE;
    let plain = ShadingPoint {
        uv: Vec2::new(0.3, 0.7),
        ..ShadingPoint::default()
    };
    let tilted = ShadingPoint {
        dp_du: Vec3::new(0.9, 0.2, 0.4),
        dp_dv: Vec3::new(-0.1, 1.3, -0.5),
        n_geo: Vec3::new(0.3, -0.2, 0.93).normalize(),
        ..plain
    };
    let bits = |s: Spectrum| s.0.map(f32::to_bits);
    directions().into_iter().all(|(wi, wo, u1, u2)| {
        let (f0, p0) = b.eval_pdf(&ctx, &plain, wi, wo);
        let (f1, p1) = b.eval_pdf(&ctx, &tilted, wi, wo);
        let s0 = b.sample(&ctx, &plain, wi, u1, u2);
        let s1 = b.sample(&ctx, &tilted, wi, u1, u2);
        let same_sample = match (s0, s1) {
            (None, None) => true,
            (Some(a), Some(b)) => {
                a.wo.to_array().map(f32::to_bits) == b.wo.to_array().map(f32::to_bits)
                    && bits(a.weight) == bits(b.weight)
                    && a.pdf.to_bits() == b.pdf.to_bits()
                    && a.eta.to_bits() == b.eta.to_bits()
            }
            _ => false,
        };
        bits(f0) == bits(f1) && p0.to_bits() == p1.to_bits() && same_sample
    })
}

#[test]
fn models_that_do_not_read_the_local_geometry_ignore_it() {
    let specs = [
        "diffuse reflectance=0.7",
        "conductor material=Au",
        "roughconductor material=Cu alpha=0.2 distribution=ggx",
        "roughconductor alpha_u=0.05 alpha_v=0.3 distribution=beckmann",
        "dielectric",
        "thindielectric",
        "roughdielectric distribution=ggx alpha=0.3 int_ior=1.5",
        "plastic",
        "roughplastic distribution=ggx alpha=0.1 diffuse_reflectance=0.6,0.15,0.1",
        "sheen",
        "principled metallic=0.3 roughness=0.4 spec_trans=0.2",
        "principledthin roughness=0.3 diff_trans=0.4",
        "velvet",
        "null",
        "twosided { roughconductor distribution=ggx alpha=0.3 }",
        "blendbsdf weight=0.4 { diffuse } { roughconductor alpha=0.2 }",
        "mask opacity=0.6 { roughplastic distribution=ggx alpha=0.2 }",
        "normalmap normalmap=0.7,0.4,0.9 { roughconductor material=Au alpha=0.15 }",
    ];
    for spec in specs {
        let b = parse_spec(spec).unwrap();
        assert!(!b.reads_local_geometry(), "{spec}");
        assert!(same_at_both_points(&b), "{spec} reads the local geometry");
    }
}

#[test]
fn bump_maps_read_the_local_geometry_wherever_they_are_nested() {
    let b = || {
        wrap(
            "bumpmap",
            vec![parse_spec("roughplastic distribution=ggx alpha=0.2").unwrap()],
            vec![("height", Value::Texture(Arc::new(Slope)))],
        )
    };
    let d = || parse_spec("diffuse").unwrap();
    let wrapped = [
        ("bumpmap", b()),
        ("twosided", wrap("twosided", vec![b()], vec![])),
        ("twosided (back)", wrap("twosided", vec![d(), b()], vec![])),
        (
            "blendbsdf",
            wrap(
                "blendbsdf",
                vec![d(), b()],
                vec![("weight", Value::Float(0.5))],
            ),
        ),
        ("mask", wrap("mask", vec![b()], vec![])),
        (
            "normalmap",
            wrap(
                "normalmap",
                vec![b()],
                vec![("normalmap", Value::Rgb(Spectrum::new(0.6, 0.5, 0.9)))],
            ),
        ),
    ];
    for (name, b) in wrapped {
        assert!(b.reads_local_geometry(), "{name}");
        // and they do: the values change with it (so the first test can tell)
        assert!(!same_at_both_points(&b), "{name}");
    }
}
