//! Lattice iCE40 HX8K: the delay model's constants and where they come from.
//!
//! / The target's delay model. Calibrated on nextpnr-ice40 0.4 (Debian
//! bookworm), HX8K ct256.

use super::Synthesis;
use crate::timing::DelayModel;

/// The delay model of this family (nanoseconds; fields in
/// [`DelayModel`]).
pub const DELAY: DelayModel = DelayModel {
    reg: 2.2,
    lut: 1.0,
    carry_base: 1.3,
    carry_bit: 0.13,
    mul_row: 1.7,
    dsp: None,
    bram: 3.0,
    word_select: 0.0,
};

/// How `fxshade synth` maps a module to this family with Yosys, and which
/// cells it counts as what.
pub const SYNTH: Synthesis = Synthesis {
    device: "iCE40 HX8K (ct256)",
    yosys: "synth_ice40 -top fxs_harness -json harness.json",
    lut: &["SB_LUT4"],
    ff: &["SB_DFF"],
    dsp: &["SB_MAC16"],
    bram: &["SB_RAM40_4K"],
};
