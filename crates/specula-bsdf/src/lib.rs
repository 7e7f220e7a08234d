//! # specula-bsdf
//!
//! Specula's standalone material library: every BSDF a materials-and-appearance course
//! teaches, with Mitsuba 3's plugin names, parameters and conventions, each evaluated,
//! importance-sampled and checked.
//!
//! ```
//! use specula_bsdf::{parse_spec, BsdfContext, BsdfModel, ShadingPoint};
//! use glam::{Vec2, Vec3};
//! let copper = parse_spec("roughconductor material=Cu alpha=0.2 distribution=ggx").unwrap();
//! let wi = Vec3::new(0.3, 0.0, 0.954).normalize();
//! let s = copper
//!     .sample(&BsdfContext::RADIANCE, &ShadingPoint::default(), wi, 0.5, Vec2::new(0.3, 0.7))
//!     .unwrap();
//! assert!(s.pdf > 0.0 && s.weight.is_finite());
//! ```

pub mod bsdf;
pub mod build;
pub mod check;
pub mod data;
pub mod frame;
pub mod fresnel;
pub mod math;
pub mod measured;
pub mod microfacet;
pub mod models;
pub mod multiscatter;
pub mod props;
pub mod quad;
pub mod rng;
pub mod spec;
pub mod spectral;
pub mod spectrum;
pub mod warp;

pub use bsdf::{
    BsdfContext, BsdfModel, BsdfSample, FloatParam, LobeFlags, ShadingPoint, SpectrumParam,
    SurfaceData, Texture, TransportMode,
};
pub use build::build_bsdf;
pub use models::Bsdf;
pub use props::{BuildError, Props, Value};
pub use spec::parse_spec;
pub use spectrum::{Rgb, Spectrum, Wavelengths};
