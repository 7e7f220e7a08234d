//! Cost of one `eval` and one `sample` call per model.
//!
//! Run with `cargo bench -p specula-bsdf` (add a filter such as `-- eval/` or
//! `-- roughconductor` to run a subset). Each benchmark cycles through 1024 pre-generated
//! queries (wi, wo, u1, u2), so the random number generator is not measured; group names are
//! `eval/<model>` and `sample/<model>`; `merl` and `merl_interpolated` are a MERL table
//! (a rough copper tabulated in memory) with nearest-bin and multilinear lookups.

use std::time::Duration;

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use glam::{Vec2, Vec3};
use specula_bsdf::measured::merl::Merl;
use specula_bsdf::rng::Pcg32;
use specula_bsdf::warp::{square_to_cosine_hemisphere, square_to_uniform_sphere};
use specula_bsdf::{parse_spec, Bsdf, BsdfContext, BsdfModel, ShadingPoint};

/// Number of pre-generated queries (a power of two, so cycling is a mask).
const N: usize = 1024;

/// Where the query directions lie.
#[derive(Clone, Copy)]
enum Domain {
    /// wi and wo in the upper hemisphere (one-sided reflection models).
    Reflection,
    /// wi on both sides and wo anywhere on the sphere (transmission, two-sided models).
    Sphere,
}

/// (benchmark name, material spec, query domain)
const MODELS: &[(&str, &str, Domain)] = &[
    ("diffuse", "diffuse reflectance=0.5", Domain::Reflection),
    ("conductor_cu", "conductor material=Cu", Domain::Reflection),
    (
        "roughconductor_ggx",
        "roughconductor material=Cu distribution=ggx alpha=0.2",
        Domain::Reflection,
    ),
    (
        "roughconductor_beckmann",
        "roughconductor material=Cu distribution=beckmann alpha=0.2",
        Domain::Reflection,
    ),
    (
        "roughconductor_ggx_aniso",
        "roughconductor material=Cu distribution=ggx alpha_u=0.05 alpha_v=0.3",
        Domain::Reflection,
    ),
    ("dielectric", "dielectric int_ior=1.5", Domain::Sphere),
    (
        "thindielectric",
        "thindielectric int_ior=1.5",
        Domain::Sphere,
    ),
    (
        "roughdielectric_ggx",
        "roughdielectric int_ior=1.5 distribution=ggx alpha=0.2",
        Domain::Sphere,
    ),
    (
        "plastic",
        "plastic diffuse_reflectance=0.5",
        Domain::Reflection,
    ),
    (
        "roughplastic_ggx",
        "roughplastic diffuse_reflectance=0.5 distribution=ggx alpha=0.1",
        Domain::Reflection,
    ),
    (
        "sheen",
        "sheen reflectance=0.8 roughness=0.5",
        Domain::Reflection,
    ),
    (
        "principled",
        "principled base_color=0.8,0.3,0.2 roughness=0.4 metallic=0.2 spec_tint=0.3 \
         sheen=0.5 clearcoat=0.5 clearcoat_gloss=0.7",
        Domain::Reflection,
    ),
    (
        "principled_spec_trans",
        "principled base_color=0.9 roughness=0.3 spec_trans=0.8 eta=1.5",
        Domain::Sphere,
    ),
    (
        "principledthin",
        "principledthin base_color=0.4,0.8,0.2 roughness=0.5 spec_trans=0.3 diff_trans=1",
        Domain::Sphere,
    ),
    (
        "twosided_diffuse",
        "twosided { diffuse reflectance=0.5 }",
        Domain::Sphere,
    ),
    (
        "blendbsdf",
        "blendbsdf weight=0.3 { diffuse reflectance=0.8 } \
         { roughconductor material=Au distribution=ggx alpha=0.2 }",
        Domain::Reflection,
    ),
];

struct Query {
    wi: Vec3,
    wo: Vec3,
    u1: f32,
    u2: Vec2,
}

fn queries(domain: Domain) -> Vec<Query> {
    let mut rng = Pcg32::new(0x5eed, 7);
    (0..N)
        .map(|_| {
            let wi = square_to_cosine_hemisphere(rng.next_vec2());
            let (wi, wo) = match domain {
                Domain::Reflection => (wi, square_to_cosine_hemisphere(rng.next_vec2())),
                Domain::Sphere => {
                    let below = rng.next_f32() < 0.5;
                    let wi = if below {
                        Vec3::new(wi.x, wi.y, -wi.z)
                    } else {
                        wi
                    };
                    (wi, square_to_uniform_sphere(rng.next_vec2()))
                }
            };
            Query {
                wi,
                wo,
                u1: rng.next_f32(),
                u2: rng.next_vec2(),
            }
        })
        .collect()
}

fn bench_models(c: &mut Criterion) {
    let mut models: Vec<(&str, Bsdf, Vec<Query>)> = MODELS
        .iter()
        .map(|(name, spec, domain)| {
            let bsdf = parse_spec(spec).unwrap_or_else(|e| panic!("{name}: {e}"));
            (*name, bsdf, queries(*domain))
        })
        .collect();
    // MERL tables: a rough copper tabulated in memory (the same 90×90×180 layout and cost as a
    // file from the database), nearest-bin and interpolated lookups
    let copper = parse_spec("roughconductor material=Cu distribution=ggx alpha=0.2").unwrap();
    let merl = Merl::measure(&copper);
    let mut interpolated = merl.clone();
    interpolated.interpolate = true;
    models.push(("merl", Bsdf::Merl(merl), queries(Domain::Reflection)));
    models.push((
        "merl_interpolated",
        Bsdf::Merl(interpolated),
        queries(Domain::Reflection),
    ));
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();

    let mut eval = c.benchmark_group("eval");
    for (name, bsdf, qs) in &models {
        eval.bench_function(*name, |b| {
            let mut i = 0usize;
            b.iter(|| {
                let q = &qs[i & (N - 1)];
                i = i.wrapping_add(1);
                bsdf.eval(&ctx, &sp, black_box(q.wi), black_box(q.wo))
            })
        });
    }
    eval.finish();

    let mut sample = c.benchmark_group("sample");
    for (name, bsdf, qs) in &models {
        sample.bench_function(*name, |b| {
            let mut i = 0usize;
            b.iter(|| {
                let q = &qs[i & (N - 1)];
                i = i.wrapping_add(1);
                bsdf.sample(&ctx, &sp, black_box(q.wi), black_box(q.u1), black_box(q.u2))
            })
        });
    }
    sample.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
        .sample_size(20)
}

criterion_group! {
    name = benches;
    config = config();
    targets = bench_models
}
criterion_main!(benches);
