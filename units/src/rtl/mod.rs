//! The RTL backend ([`fxshade_backend`]) re-exported, with what ties it to
//! the units: their registry of RTL modules ([`units`]) and the `[rtl]`
//! configuration section ([`section`]).

pub use fxshade_backend::*;

pub mod section;
pub mod units;
