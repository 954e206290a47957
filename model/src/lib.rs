//! # fxshade-model
//!
//! A bit-accurate fixed-point model of a per-pixel shading pipeline, beside
//! an f64 reference. The arithmetic is written down once:
//!
//! * [`format`](mod@format) — fixed-point formats (signedness, width, fraction bits);
//! * [`quantize`] — the only place bits are dropped: rounding and overflow
//!   modes, each with the Verilog expression the RTL uses;
//! * [`datapath`] — the operations every unit is written in, run three ways:
//!   f64 reference, bit-accurate fixed point, and operation counting;
//! * [`config`] — formats and parameters from TOML, with an embedded default;
//! * [`units`] — the registry of units: [`interp`] (method C),
//!   [`normalizer`] (method A), [`angles`] (CORDIC polar angles of N),
//!   [`polar`] (method B), [`lighting`], and
//!   [`pipeline`], which chains them;
//! * [`render`] — a rasterizer that runs the pipeline on every pixel of a
//!   mesh, beside an f64 reference, with image metrics.
//!
//! `model/ARITHMETIC.md` states the contract the RTL follows.
#![warn(missing_docs)]

// The layers below, under the paths the units were written with.
pub use fxshade_ir::{datapath, escape, sampling};
pub use fxshade_numbers::{format, quantize};

pub mod analysis;
pub mod angles;
pub mod bounds;
pub mod cache;
pub mod coeffs;
pub mod config;
pub mod files;
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
pub mod vectors;

pub use config::Config;
pub use datapath::{Count, Datapath, Fixed, Fx, Reference};
pub use format::Format;
pub use quantize::{Overflow, Quant, Rounding};
