//! fxshade's flows: everything that runs a tool or a long computation on
//! the model's and the backend's output, for the CLI to call and print.
//!
//! | module | flow |
//! |---|---|
//! | [`proc`] | child processes with limits; tool probes |
//! | [`rtl_flow`] | Verilator and Icarus builds, streamed co-simulation |
//! | [`synth`] | Yosys synthesis, nextpnr place and route, the synthesis cache, timing closure ([`synth::close`]) |
//! | [`device`] | a part's capacity and what a design uses of it |
//! | [`netlist`], [`dsp_pack`], [`ff_roles`], [`critical_path`] | the synthesized netlist: written for co-simulation, MULT18 packing, flip-flops by role, the placer's critical path |
//! | [`formal`] | the handshake proofs (Yosys, yosys-smtbmc, z3) |
//! | [`smt`], [`smt2_model`] | SMT-LIB 2 to a solver, Yosys's `write_smt2` model read back |
//! | [`equiv`], [`netlist_equiv`], [`netlist_corr`] | RTL and netlist equivalence proofs |
//! | [`mutate`] | mutation testing of the vectors on the RTL |
//! | [`explore`] | sweeps and the design-space optimizer, on this machine or a launcher |
//! | [`scene`] | the meshes a `--mesh` names |
//! | [`report`] | the figures of `fxshade report` that run a flow |
//! | [`shard`] | deterministic slices of a run for job arrays |
//!
//! The flows read no environment variable: the CLI hands them its
//! [`settings`]. Progress is told through callbacks, never drawn here.
//! Errors are `anyhow` chains with the file, tool and limit they concern;
//! a [`UsageError`] is a bad flag or input file (the CLI exits with
//! status 2).

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

pub mod critical_path;
pub mod device;
pub mod dsp_pack;
pub mod equiv;
pub mod explore;
pub mod ff_roles;
pub mod formal;
pub mod mutate;
pub mod netlist;
pub mod netlist_corr;
pub mod netlist_equiv;
pub mod proc;
pub mod report;
pub mod rtl_flow;
pub mod scene;
pub mod settings;
pub mod shard;
pub mod smt;
pub mod smt2_model;
pub mod synth;

/// A bad flag or input file: printed as `error: …` with exit status 2, as
/// configuration errors are.
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}
