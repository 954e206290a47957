//! The RTL view of the units: the backend ([`fxshade_backend`]: emitter,
//! testbench, targets, writer), re-exported under `rtl::`, and what needs
//! the units and the configuration: the unit registry of RTL modules
//! ([`units`]), the `[rtl]` configuration section ([`section`]), the
//! mutant-killer search ([`search`], [`mutants`], [`probe`], [`witness`],
//! [`direction`]) and the model the DPI package and the C ABI call
//! ([`unit_model`], [`dpi`]).

pub use fxshade_backend::*;

pub mod direction;
pub mod dpi;
pub mod mutants;
pub mod probe;
pub mod search;
pub mod section;
#[cfg(test)]
mod smt_checks;
pub mod unit_model;
pub mod units;
pub mod witness;
