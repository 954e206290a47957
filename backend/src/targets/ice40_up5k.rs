//! Lattice iCE40 UP5K: the delay model's constants and where they come from.
//!
//! Calibrated on nextpnr-ice40 0.4, UP5K sg48 (a slower part).

use super::{Family, FifoMemory, Part, PlaceRoute, Synthesis};
use crate::estimate::{AreaModel, BramRules, DspRules};
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
    carry: &["SB_CARRY"],
    lut_ram: &[],
    bram18: &[],
};

/// Lattice iCE40 UP5K (eight SB_MAC16).
pub struct Ice40Up5k;

impl Family for Ice40Up5k {
    fn name(&self) -> &'static str {
        "ice40-up5k"
    }
    fn about(&self) -> &'static str {
        "Lattice iCE40 UP5K: with its eight SB_MAC16 DSPs, placed and routed by \
         nextpnr-ice40 (sg48 package)"
    }
    fn delay(&self) -> Option<DelayModel> {
        Some(DELAY)
    }
    fn synthesis(&self) -> Option<Synthesis> {
        Some(SYNTH)
    }
    fn place_route(&self) -> Result<PlaceRoute, &'static str> {
        Ok(super::ice40_hx8k::PLACE_ROUTE)
    }
    fn parts(&self) -> &'static [Part] {
        &[Part {
            name: "iCE40UP5K",
            pnr_args: &["--up5k", "--package", "sg48"],
            capacity: None,
        }]
    }
    /// SB_MAC16 as `synth_ice40 -dsp` tells `mul2dsp` (results narrower
    /// than 11 bits stay in the fabric).
    fn dsp_rules(&self) -> Option<DspRules> {
        Some(DspRules {
            a_max: 16,
            b_max: 16,
            a_partial: 16,
            b_partial: 16,
            min: 2,
            y_min: 11,
            signed_only: false,
        })
    }
    /// Fitted by `fxshade synth calibrate --area --target ice40-up5k
    /// --json` (Yosys 0.23) on 40 designs; SB_LUT4 |error| median 6.6 %, max
    /// 33 %; FF median 11.6 %, max 45 %.
    fn area_model(&self) -> Option<AreaModel> {
        Some(AreaModel {
            lut: [
                0.2421, 3.3415, 2.7516, 0.0, 0.05730, 0.1386, 0.0, 0.01570, 1.2405, 18.340, 0.0,
                0.0,
            ],
            ff: [
                0.0, 0.1746, 0.0, 0.0, 0.0, 0.0, 0.0, 0.7354, 1.1358, -3.3542, 0.0, 15.730,
            ],
        })
    }
    fn bram_rules(&self) -> Option<BramRules> {
        Some(super::ice40_hx8k::BRAM)
    }
    fn fifo_memory(&self) -> FifoMemory {
        FifoMemory::Block
    }
    fn constraint(&self, clock_ns: f64) -> (&'static str, String) {
        super::ice40_hx8k::pcf(clock_ns)
    }
}
