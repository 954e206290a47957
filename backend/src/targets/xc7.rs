//! Xilinx 7-series: the delay model's constants and where they come from.
//!
//! Not calibrated (no open place and route): datasheet-class figures for a -1
//! Artix-7.

use super::{Family, FifoMemory, Part, Synthesis};
use crate::estimate::{AreaModel, BramRules, DspRules};
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
    carry: &["CARRY4"],
    lut_ram: &[],
    bram18: &[("RAMB18E1", 1), ("RAMB36E1", 2)],
};

/// Xilinx 7-series.
pub struct Xc7;

impl Family for Xc7 {
    fn name(&self) -> &'static str {
        "xc7"
    }
    fn about(&self) -> &'static str {
        "Xilinx 7-series: Yosys's synth_xilinx (LUT6, DSP48E1, RAMB18E1); no open place and \
         route, so no Fmax"
    }
    fn delay(&self) -> Option<DelayModel> {
        Some(DELAY)
    }
    fn synthesis(&self) -> Option<Synthesis> {
        Some(SYNTH)
    }
    fn place_route(&self) -> Result<super::PlaceRoute, &'static str> {
        Err("no open place and route for Xilinx 7-series")
    }
    /// Capacities from AMD/Xilinx DS180, "7 Series FPGAs Data Sheet:
    /// Overview", Artix-7 table: logic cells as 6-input LUTs, flip-flops,
    /// DSP48E1 slices, 36 Kb block RAMs counted as two 18 Kb halves.
    fn parts(&self) -> &'static [Part] {
        &[
            Part {
                name: "xc7a35t",
                pnr_args: &[],
                capacity: Some([20_800, 41_600, 90, 100]),
            },
            Part {
                name: "xc7a100t",
                pnr_args: &[],
                capacity: Some([63_400, 126_800, 240, 270]),
            },
            Part {
                name: "xc7a200t",
                pnr_args: &[],
                capacity: Some([134_600, 269_200, 740, 730]),
            },
        ]
    }
    /// None: a run given no part reports synthesis's counts only.
    fn default_part(&self) -> Option<Part> {
        None
    }
    fn part_prefix(&self) -> &'static str {
        "Xilinx 7-series "
    }
    /// DSP48E1 as `synth_xilinx` tells `mul2dsp` (`DSP_Y_MINWIDTH=9`
    /// although its help does not show it; signed only).
    fn dsp_rules(&self) -> Option<DspRules> {
        Some(DspRules {
            a_max: 25,
            b_max: 18,
            a_partial: 18,
            b_partial: 18,
            min: 2,
            y_min: 9,
            signed_only: true,
        })
    }
    /// RAMB18E1 (16384 × 1 … 1024 × 18) and RAMB36E1 (32768 × 1 … 2048 ×
    /// 18), two ports, each one block as synthesis counts them.
    fn bram_rules(&self) -> Option<BramRules> {
        Some(BramRules {
            shapes: &[
                (16384, 1),
                (8192, 2),
                (4096, 4),
                (2048, 9),
                (1024, 18),
                (32768, 1),
                (16384, 2),
                (8192, 4),
                (4096, 9),
                (2048, 18),
            ],
            ports: 2,
        })
    }
    /// Fitted by `fxshade synth calibrate --area --target xc7 --json`
    /// (Yosys 0.23) on 40 designs; LUT1-6 |error| median 9.9 %, max 37 %; FF
    /// median 29.5 %, max 55 % (synth_xilinx's DSP48E1 register absorption
    /// is not a term).
    fn area_model(&self) -> Option<AreaModel> {
        Some(AreaModel {
            lut: [
                0.0, 0.7202, 1.1822, 0.0, 1.3164, 0.0, 0.0, 0.06725, 0.4090, 1.0042, 0.0, 8.544,
            ],
            ff: [
                0.0, 0.4594, 0.5151, 0.0, 0.0, 0.0, 0.0, 0.4516, 0.02252, -1.9883, 0.0, 17.495,
            ],
        })
    }
    fn fifo_memory(&self) -> FifoMemory {
        FifoMemory::Distributed
    }
}
