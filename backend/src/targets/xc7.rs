//! Xilinx 7-series: the delay model's constants and where they come from.
//!
//! Not calibrated (no open place and route): datasheet-class figures for a -1
//! Artix-7.

use super::Synthesis;
use crate::timing::{DelayModel, Dsp};

/// The delay model of this family (nanoseconds; fields in
/// [`DelayModel`]).
pub const DELAY: DelayModel = DelayModel {
    reg: 0.6,
    lut: 0.5,
    carry_base: 0.6,
    carry_bit: 0.03,
    mul_row: 0.35,
    dsp: Some(Dsp {
        a: 25,
        b: 18,
        comb: 3.4,
        combine: 1.0,
        route_in: 0.5,
        route_out: 0.5,
        mixed: false,
    }),
    bram: 2.2,
    word_select: 0.0,
};

/// How `fxshade synth` maps a module to this family with Yosys, and which
/// cells it counts as what.
pub const SYNTH: Synthesis = Synthesis {
    device: "Xilinx 7-series",
    yosys: "synth_xilinx -flatten -top fxs_harness",
    lut: &["LUT1", "LUT2", "LUT3", "LUT4", "LUT5", "LUT6"],
    ff: &["FDRE", "FDSE", "FDCE", "FDPE"],
    dsp: &["DSP48E1"],
    bram: &["RAMB18E1", "RAMB36E1"],
};
