//! Lattice iCE40 UP5K: the delay model's constants and where they come from.
//!
//! Calibrated on nextpnr-ice40 0.4, UP5K sg48 (a slower part).

use super::Synthesis;
use crate::timing::{DelayModel, Dsp};

/// The delay model of this family (nanoseconds; fields in
/// [`DelayModel`]).
pub const DELAY: DelayModel = DelayModel {
    reg: 3.0,
    lut: 2.4,
    carry_base: 5.0,
    carry_bit: 0.3,
    mul_row: 2.6,
    dsp: Some(Dsp {
        a: 16,
        b: 16,
        comb: 9.2,
        combine: 2.5,
        route_in: 5.0,
        route_out: 2.4,
        mixed: true,
    }),
    bram: 5.0,
    word_select: 0.0,
};

/// How `fxshade synth` maps a module to this family with Yosys, and which
/// cells it counts as what.
pub const SYNTH: Synthesis = Synthesis {
    device: "iCE40 UP5K (sg48)",
    yosys: "synth_ice40 -dsp -top fxs_harness -json harness.json",
    lut: &["SB_LUT4"],
    ff: &["SB_DFF"],
    dsp: &["SB_MAC16"],
    bram: &["SB_RAM40_4K"],
};
