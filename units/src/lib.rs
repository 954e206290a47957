//! # fxshade-units
//!
//! fxshade's units layer, above the numbers, the IR and the RTL backend:
//!
//! * [`config`] — formats and parameters from TOML, with an embedded
//!   default, checked against every unit's declared section;
//! * [`units`] — the registry of units: [`interp`] (method C),
//!   [`normalizer`] (method A), [`angles`] (CORDIC polar angles of N),
//!   [`polar`] (method B), [`lighting`], and [`pipeline`], which chains
//!   them; [`rtl::units`] their RTL modules (design and input vectors);
//! * [`coeffs`], [`bounds`], [`paper`], [`mad_chain`] — the methods'
//!   coefficients, closed-form bounds, published numbers and the
//!   multiply-add chain;
//! * the scene: [`mesh`], [`texture`] and [`render`], a rasterizer that
//!   runs the pipeline on every pixel of a mesh beside an f64 reference.
//!
//! It depends on `fxshade-numbers`, `fxshade-ir` and `fxshade-backend`;
//! the vector flow (`fxshade-model`) and the CLI sit above it.
// No bare numeric `as` (see fxshade-numbers).
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
#![warn(missing_docs, clippy::missing_errors_doc, clippy::missing_panics_doc)]

pub mod angles;
pub mod bounds;
pub mod coeffs;
pub mod config;
pub mod input;
pub mod interp;
pub mod lighting;
pub mod mad_chain;
pub mod mesh;
pub mod normalizer;
pub mod paper;
pub mod pipeline;
pub mod polar;
pub mod render;
pub mod rtl;
pub mod texture;
pub mod units;

pub use config::Config;

// The layers below, under the paths the units are written with.
use fxshade_ir::{datapath, escape, sampling};
use fxshade_numbers::{format, quantize};

/// The source text of the units whose analyses are cached above this crate:
/// a result computed by an older unit is never served as current.
pub mod sources {
    /// `angles/mod.rs`: the CORDIC polar angles.
    pub const ANGLES: &str = include_str!("angles/mod.rs");
    /// `polar/mod.rs`: method B.
    pub const POLAR: &str = include_str!("polar/mod.rs");
    /// `lighting.rs`: the lighting unit.
    pub const LIGHTING: &str = include_str!("lighting.rs");
}
