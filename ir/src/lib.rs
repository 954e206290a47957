//! # fxshade-ir
//!
//! fxshade's IR layer, above [`fxshade_numbers`]:
//!
//! * [`datapath`] — the operations every unit is written in, and the four
//!   contexts that run them: f64 reference, bit-accurate fixed point,
//!   operation counting, and the recorded [`Trace`](datapath::Trace)
//!   compiled for batches, with its analysis passes (interval bounds, SMT
//!   encoding, cut, mutation);
//! * [`sampling`] — the seeded generator and the input distributions
//!   (unit vectors, triangles, barycentric coordinates) every layer draws
//!   from;
//! * [`escape`] — user strings made safe for the generated files and the
//!   terminal;
//! * [`parallel`] — work spread over the cores, results in order.
//!
//! This crate depends only on `fxshade-numbers`; the units, the RTL backend
//! and the flows sit above it (`ARCHITECTURE.md`).
#![warn(missing_docs, clippy::missing_errors_doc, clippy::missing_panics_doc)]
// No bare numeric `as` (see fxshade-numbers): lossless is `From`, checked
// is `try_from`, reinterpretations are named, and the few narrowing ones
// left (`narrow`, `table_slot`, `code_value`, `float_index`) say why.
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

pub mod datapath;
pub mod escape;
pub mod parallel;
pub mod sampling;

// The numbers layer under the paths the datapath is written with.
use fxshade_numbers::{bits, format, quantize};

/// The source text of the compiled-trace modules, for cache keys above this
/// crate: a result computed by an older compiler or analysis is never served
/// as current.
pub mod sources {
    /// `datapath/batch.rs`: the trace, its compiler and its batch engine.
    pub const BATCH: &str = include_str!("datapath/batch.rs");
    /// `datapath/batch/interval.rs`: the interval analysis.
    pub const INTERVAL: &str = include_str!("datapath/batch/interval.rs");
    /// `datapath/batch/cut.rs`: the cut of a trace.
    pub const CUT: &str = include_str!("datapath/batch/cut.rs");
}
