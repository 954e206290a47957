//! The emitter's passes over one traced datapath, each an `impl` block of
//! the crate's `Emitter` (or free functions) in a module of its own:
//! schedule → balance → flags → tables and products as nodes are placed →
//! handshake → formal properties; `emit_with` in the crate root runs them
//! and the naming and line-wrapping passes write the text.

pub(crate) mod balance;
pub(crate) mod flags;
pub(crate) mod formal;
pub(crate) mod handshake;
pub(crate) mod multiply;
pub(crate) mod schedule;
pub(crate) mod tables;
