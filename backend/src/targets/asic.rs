//! A generic standard-cell process (about 28 nm): the delay model's
//! constants and where they come from.
//!
//! Not calibrated: order-of-magnitude gate delays, 28 nm library.

use super::Family;
use crate::timing::DelayModel;

/// The delay model of this family (nanoseconds; fields in
/// [`DelayModel`]).
pub const DELAY: DelayModel = DelayModel {
    reg: 0.08,
    lut: 0.04,
    carry_base: 0.05,
    carry_bit: 0.012,
    mul_row: 0.03,
    dsp: None,
    bram: 0.3,
    word_select: 0.0,
};

/// A generic standard-cell process.
pub struct Asic;

impl Family for Asic {
    fn name(&self) -> &'static str {
        "asic"
    }
    fn about(&self) -> &'static str {
        "a generic standard-cell process (about 28 nm): gates, no blocks; a delay model only"
    }
    fn delay(&self) -> Option<DelayModel> {
        Some(DELAY)
    }
}
