//! Colour values carried through the material code.
//!
//! Specula renders in linear sRGB, as Mitsuba 3's `*_rgb` variants do. Every model is written
//! against the [`Spectrum`] alias and only uses the element-wise arithmetic below, so a sampled
//! spectral type with the same operations can replace [`Rgb`] later without touching the models.

use std::ops::{Add, AddAssign, Div, DivAssign, Index, Mul, MulAssign, Neg, Sub};

/// The colour type used by every BSDF (linear sRGB for now).
pub type Spectrum = Rgb;

/// In spectral mode, the wavelengths in nanometres that the three channels of a [`Spectrum`]
/// stand for (channel 0: the path's hero wavelength). See [`crate::spectral`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wavelengths(pub [f32; 3]);

/// A linear-sRGB triple.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rgb(pub [f32; 3]);

impl Rgb {
    pub const ZERO: Rgb = Rgb([0.0; 3]);
    pub const ONE: Rgb = Rgb([1.0; 3]);

    #[inline]
    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Rgb([r, g, b])
    }
    #[inline]
    pub const fn splat(v: f32) -> Self {
        Rgb([v, v, v])
    }
    #[inline]
    pub fn map(self, f: impl Fn(f32) -> f32) -> Self {
        Rgb([f(self.0[0]), f(self.0[1]), f(self.0[2])])
    }
    #[inline]
    pub fn zip(self, o: Rgb, f: impl Fn(f32, f32) -> f32) -> Self {
        Rgb([
            f(self.0[0], o.0[0]),
            f(self.0[1], o.0[1]),
            f(self.0[2], o.0[2]),
        ])
    }
    /// Arithmetic mean of the channels (Mitsuba's `mean()` of a colour).
    #[inline]
    pub fn mean(self) -> f32 {
        (self.0[0] + self.0[1] + self.0[2]) / 3.0
    }
    #[inline]
    pub fn max_component(self) -> f32 {
        self.0[0].max(self.0[1]).max(self.0[2])
    }
    #[inline]
    pub fn min_component(self) -> f32 {
        self.0[0].min(self.0[1]).min(self.0[2])
    }
    /// Luminance of linear sRGB (Rec. 709 weights).
    #[inline]
    pub fn luminance(self) -> f32 {
        0.212671 * self.0[0] + 0.715160 * self.0[1] + 0.072169 * self.0[2]
    }
    #[inline]
    pub fn is_black(self) -> bool {
        self.0 == [0.0; 3]
    }
    #[inline]
    pub fn is_finite(self) -> bool {
        self.0.iter().all(|v| v.is_finite())
    }
    #[inline]
    pub fn r(self) -> f32 {
        self.0[0]
    }
    #[inline]
    pub fn g(self) -> f32 {
        self.0[1]
    }
    #[inline]
    pub fn b(self) -> f32 {
        self.0[2]
    }
}

impl Index<usize> for Rgb {
    type Output = f32;
    #[inline]
    fn index(&self, i: usize) -> &f32 {
        &self.0[i]
    }
}

macro_rules! binop {
    ($tr:ident, $f:ident, $tra:ident, $fa:ident, $op:tt) => {
        impl $tr for Rgb {
            type Output = Rgb;
            #[inline]
            fn $f(self, o: Rgb) -> Rgb {
                Rgb([self.0[0] $op o.0[0], self.0[1] $op o.0[1], self.0[2] $op o.0[2]])
            }
        }
        impl $tr<f32> for Rgb {
            type Output = Rgb;
            #[inline]
            fn $f(self, o: f32) -> Rgb {
                Rgb([self.0[0] $op o, self.0[1] $op o, self.0[2] $op o])
            }
        }
        impl $tra for Rgb {
            #[inline]
            fn $fa(&mut self, o: Rgb) {
                *self = *self $op o;
            }
        }
        impl $tra<f32> for Rgb {
            #[inline]
            fn $fa(&mut self, o: f32) {
                *self = *self $op o;
            }
        }
    };
}
binop!(Add, add, AddAssign, add_assign, +);
binop!(Mul, mul, MulAssign, mul_assign, *);
binop!(Div, div, DivAssign, div_assign, /);

impl Sub for Rgb {
    type Output = Rgb;
    #[inline]
    fn sub(self, o: Rgb) -> Rgb {
        self.zip(o, |a, b| a - b)
    }
}
impl Sub<Rgb> for f32 {
    type Output = Rgb;
    #[inline]
    fn sub(self, o: Rgb) -> Rgb {
        o.map(|b| self - b)
    }
}
impl Mul<Rgb> for f32 {
    type Output = Rgb;
    #[inline]
    fn mul(self, o: Rgb) -> Rgb {
        o * self
    }
}
impl Neg for Rgb {
    type Output = Rgb;
    #[inline]
    fn neg(self) -> Rgb {
        self.map(|v| -v)
    }
}
impl From<f32> for Rgb {
    fn from(v: f32) -> Self {
        Rgb::splat(v)
    }
}
impl From<[f32; 3]> for Rgb {
    fn from(v: [f32; 3]) -> Self {
        Rgb(v)
    }
}
