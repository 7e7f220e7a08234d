//! `eval`, `pdf`, `eval_pdf` and `sample` never touch the heap: counted with a global
//! allocator wrapper over every model (this test binary holds only this test, so no other
//! thread allocates while it counts).

use glam::{Vec2, Vec3};
use specula_bsdf::{parse_spec, BsdfContext, BsdfModel, ShadingPoint};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn hot_paths_do_not_allocate() {
    let specs = [
        "diffuse",
        "conductor material=Cu",
        "roughconductor distribution=ggx alpha=0.2",
        "roughconductor distribution=beckmann alpha_u=0.05 alpha_v=0.3",
        "dielectric",
        "thindielectric",
        "roughdielectric distribution=beckmann alpha=0.3",
        "roughdielectric distribution=ggx alpha=0.3 sample_visible=false",
        "plastic",
        "roughplastic distribution=ggx alpha=0.1",
        "sheen roughness=0.3",
        "principled metallic=0.3 spec_trans=0.5 clearcoat=0.5 sheen=0.5 spec_tint=0.5 flatness=0.5",
        "principledthin spec_trans=0.5 diff_trans=0.8 sheen=0.5 spec_tint=0.5",
        "twosided { roughconductor alpha=0.2 }",
        "blendbsdf weight=0.4 { diffuse } { plastic }",
        "roughconductor distribution=ggx alpha=0.7 material=Au multiscatter=true",
        "roughconductor distribution=beckmann alpha_u=0.1 alpha_v=0.5 multiscatter=true",
        "roughdielectric distribution=ggx alpha=0.6 multiscatter=true",
        "roughplastic distribution=beckmann alpha=0.4 multiscatter=true",
        "principled metallic=0.6 spec_trans=0.5 roughness=0.6 anisotropic=0.4 multiscatter=true",
        "roughconductor distribution=ggx alpha=0.5 material=Cu specular_reflectance=0.9,0.8,0.7 multiscatter=true",
    ];
    // build everything (which may allocate) before counting
    let models: Vec<_> = specs.iter().map(|s| parse_spec(s).unwrap()).collect();
    let mut rng = specula_bsdf::rng::Pcg32::new(3, 3);
    let dirs: Vec<(Vec3, Vec3, f32, Vec2)> = (0..256)
        .map(|_| {
            let a = specula_bsdf::warp::square_to_uniform_sphere(rng.next_vec2());
            let b = specula_bsdf::warp::square_to_uniform_sphere(rng.next_vec2());
            (a, b, rng.next_f32(), rng.next_vec2())
        })
        .collect();
    let sp = ShadingPoint::default();
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    let mut acc = 0.0f32;
    for m in &models {
        for ctx in [BsdfContext::RADIANCE, BsdfContext::IMPORTANCE] {
            for &(wi, wo, u1, u2) in &dirs {
                acc += m.eval(&ctx, &sp, wi, wo).r();
                acc += m.pdf(&ctx, &sp, wi, wo);
                acc += m.eval_pdf(&ctx, &sp, wi, wo).1;
                if let Some(s) = m.sample(&ctx, &sp, wi, u1, u2) {
                    acc += s.pdf;
                }
            }
        }
    }
    let after = ALLOCATIONS.load(Ordering::SeqCst);
    assert!(acc.is_finite());
    assert_eq!(
        after - before,
        0,
        "{} heap allocations on the hot paths",
        after - before
    );
}
