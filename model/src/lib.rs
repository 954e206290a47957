//! # fxshade-model
//!
//! A bit-accurate fixed-point model of a per-pixel shading pipeline, beside
//! an f64 reference, and the vector flow above it. This crate is the
//! vectors layer (the vector stream, manifests, writers, the mutant-killer
//! search, the cache, error analysis) and re-exports the layers below it
//! under one roof: `fxshade-numbers`, `fxshade-ir`, `fxshade-backend`,
//! `fxshade-units` (`ARCHITECTURE.md` draws the layers). The arithmetic is
//! written down once:
//!
//! * [`format`](mod@format) — fixed-point formats (signedness, width, fraction bits);
//! * [`quantize`] — the only place bits are dropped: rounding and overflow
//!   modes, each with the Verilog expression the RTL uses;
//! * [`datapath`] — the operations every unit is written in, run four ways:
//!   f64 reference, bit-accurate fixed point, compiled batches (the
//!   recorded trace) and operation counting;
//! * [`config`] — formats and parameters from TOML, with an embedded default;
//! * [`units`] — the registry of units: [`interp`] (method C),
//!   [`normalizer`] (method A), [`angles`] (CORDIC polar angles of N),
//!   [`polar`] (method B), [`lighting`], and
//!   [`pipeline`], which chains them;
//! * [`render`] — a rasterizer that runs the pipeline on every pixel of a
//!   mesh, beside an f64 reference, with image metrics.
//!
//! `model/ARITHMETIC.md` states the contract the RTL follows.
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

// The layers below, under the paths the callers were written with.
pub use fxshade_ir::{datapath, escape, parallel, sampling};
pub use fxshade_numbers::{convert, format, quantize};
pub use fxshade_units::{
    angles, bounds, coeffs, config, interp, lighting, mad_chain, mesh, normalizer, paper, pipeline,
    polar, render, texture, units,
};

pub mod analysis;
pub mod cache;
pub mod files;
pub mod rtl;
pub mod vectors;
pub mod writers;

pub use config::Config;
pub use datapath::{Count, Datapath, Fixed, Fx, Reference};
pub use format::Format;
pub use quantize::{Overflow, Quant, Rounding};
