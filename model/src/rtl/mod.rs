//! The RTL view of the units: the backend ([`fxshade_backend`]: emitter,
//! testbench, targets, writer), the registry of units with RTL and the
//! `[rtl]` configuration section ([`fxshade_units::rtl`]), re-exported
//! under `rtl::`, and the vector flow above them: the streams of vectors
//! ([`units`]), the mutant-killer search ([`search`], [`mutants`], [`probe`], [`witness`],
//! [`direction`]) and the model the DPI package and the C ABI call
//! ([`unit_model`], [`dpi`]).

pub use fxshade_units::rtl::*;

pub mod direction;
pub mod dpi;
pub mod mutants;
pub mod probe;
pub mod search;
#[cfg(test)]
mod smt_checks;
pub mod unit_model;
pub mod units;
pub mod witness;
