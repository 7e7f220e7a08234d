//! Helpers shared by the integration tests (`mod common;` in each test file that uses them).

use glam::Vec2;
use specula_bsdf::{ShadingPoint, Spectrum};

/// A height field with a constant gradient, for `bumpmap` (only bitmaps have one in a scene).
#[derive(Debug)]
pub struct Slope;

impl specula_bsdf::Texture for Slope {
    fn eval(&self, _: &ShadingPoint) -> Spectrum {
        Spectrum::ZERO
    }
    fn mean(&self) -> Spectrum {
        Spectrum::ZERO
    }
    fn eval_1_grad(&self, _: &ShadingPoint) -> Option<Vec2> {
        Some(Vec2::new(0.6, -0.3))
    }
}
