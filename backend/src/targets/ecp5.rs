//! Lattice ECP5: the delay model's constants and where they come from.
//!
//! Calibrated on nextpnr-ecp5 (yowasp), LFE5U-85F speed grade 6. The
//! multiplier as the flow builds it, operand and product registers packed
//! into the MULT18X18D (`synth calibrate --target ecp5`, packed column of
//! BENCHMARKS.md): one block measures 2.87-4.16 ns register to register, so
//! `comb` = 4.16 less `reg`; a 24 x 18 product (two tiles, one sum) 7.08 ns,
//! so `combine` = 7.08 - 4.16. (Before packing: 7.0 and 1.5.) With the
//! packer's no-copy rule (issue #37) the blocks of a product Yosys splits
//! share their operand registers, which then stay in the fabric: the smooth
//! top at 8 ns measured 8.76 and 8.91 ns (seeds 1, 3; 11.8 on seed 2)
//! register to register through a 19 x 17 product in two blocks and their
//! sum, so `combine` = 8.9 - 0.9 - 3.3 = 4.7 and the emitter splits such a
//! product itself (own operand registers per block, the sum a stage later)
//! whenever 8.9 ns does not fit the period. word_select: the smooth top at 8
//! ns (issue #37) measured 11.2 ns on a range check, saturating multiplexer
//! and maximum that the model put at 7.9 (nextpnr: 5.9 ns of it routing, most
//! of it the two selects' fan-out to 16 bits); 1.5 ns a word select.

use super::Synthesis;
use crate::timing::{DelayModel, Dsp};

/// The delay model of this family (nanoseconds; fields in
/// [`DelayModel`]).
pub const DELAY: DelayModel = DelayModel {
    reg: 0.9,
    lut: 1.1,
    carry_base: 2.0,
    carry_bit: 0.035,
    mul_row: 1.0,
    dsp: Some(Dsp {
        a: 18,
        b: 18,
        comb: 3.3,
        combine: 4.7,
        route_in: 3.2,
        route_out: 3.4,
        mixed: true,
    }),
    bram: 3.5,
    word_select: 1.5,
};

/// How `fxshade synth` maps a module to this family with Yosys, and which
/// cells it counts as what.
pub const SYNTH: Synthesis = Synthesis {
    device: "ECP5 LFE5U-85F (CABGA381)",
    yosys: "synth_ecp5 -top fxs_harness -json harness.json",
    lut: &["LUT4"],
    ff: &["TRELLIS_FF"],
    dsp: &["MULT18X18D", "ALU54B"],
    bram: &["DP16KD"],
};
