//! The f64 reference context.

use super::{Datapath, Table};
use crate::format::ConvertError;
use crate::quantize::Quant;

/// Real arithmetic in f64: quantization is the identity, tables give the
/// exact function, division and square root are IEEE operations. Inputs must
/// be finite.
#[derive(Clone, Copy, Debug, Default)]
pub struct Reference;

impl Datapath for Reference {
    type V = f64;

    fn constant(&mut self, x: f64, _q: &Quant) -> Result<f64, ConvertError> {
        if x.is_nan() {
            Err(ConvertError::NaN)
        } else if x.is_infinite() {
            Err(ConvertError::Infinite(x))
        } else {
            Ok(x)
        }
    }
    #[inline]
    fn mul(&mut self, a: f64, b: f64) -> f64 {
        a * b
    }
    #[inline]
    fn add(&mut self, a: f64, b: f64) -> f64 {
        a + b
    }
    #[inline]
    fn sub(&mut self, a: f64, b: f64) -> f64 {
        a - b
    }
    #[inline]
    fn shl(&mut self, a: f64, n: i32) -> f64 {
        a * crate::format::exp2i(n)
    }
    #[inline]
    fn max(&mut self, a: f64, b: f64) -> f64 {
        a.max(b)
    }
    #[inline]
    fn add_signed(&mut self, a: f64, b: f64, s: f64, flip: bool) -> f64 {
        if (s < 0.0) != flip {
            a - b
        } else {
            a + b
        }
    }
    #[inline]
    fn quantize(&mut self, a: f64, _q: &Quant) -> f64 {
        a
    }
    #[inline]
    fn table(&mut self, t: &Table, index: f64) -> f64 {
        (t.exact)(index)
    }
    #[inline]
    fn div(&mut self, a: f64, b: f64, _q: &Quant) -> f64 {
        a / b
    }
    #[inline]
    fn sqrt(&mut self, a: f64, _q: &Quant) -> f64 {
        a.max(0.0).sqrt()
    }
    #[inline]
    fn select(&mut self, sel: f64, options: &[f64]) -> f64 {
        match super::float_index(sel).and_then(|i| options.get(i)) {
            Some(&o) => o,
            None => options[0],
        }
    }
}
