//! # fxshade-numbers
//!
//! fxshade's bottom layer, the arithmetic every other layer is written in:
//!
//! * [`format`](mod@format) — fixed-point formats (signedness, width,
//!   fraction bits) and the conversion of values to codes;
//! * [`quantize`] — the only place bits are dropped: rounding and overflow
//!   modes, exact on `i128` codes;
//! * [`convert`] — the named numeric conversions (nearest `f64`,
//!   saturating from `f64`, checked narrowing) used where `From` cannot;
//! * [`bits`] — each quantization written out bit for bit as a Verilog
//!   expression, and the widths the rounding needs (the RTL backend writes
//!   them; the mutation pass of the IR asks which range checks can fire).
//!
//! This crate depends on no other fxshade crate (the workspace's layers are
//! listed in `ARCHITECTURE.md`).
#![warn(missing_docs, clippy::missing_errors_doc, clippy::missing_panics_doc)]
// No bare numeric `as`: a conversion is lossless (`From`), checked
// (`try_from`), a named reinterpretation (`cast_unsigned`, `unsigned_abs`),
// or allowed where it stands with the reason it cannot lose anything.
#![warn(
    clippy::cast_lossless,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::cast_precision_loss
)]
// Tests build expected values with plain conversions.
#![cfg_attr(
    test,
    allow(
        clippy::cast_lossless,
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_possible_wrap,
        clippy::cast_precision_loss
    )
)]

pub mod bits;
pub mod convert;
pub mod format;
pub mod quantize;

pub use format::Format;
pub use quantize::{Overflow, Quant, Rounding};

/// The source text of [`quantize`], for cache keys above this crate: a
/// result computed by an older quantization is never served as current.
pub const QUANTIZE_SOURCE: &str = include_str!("quantize.rs");
