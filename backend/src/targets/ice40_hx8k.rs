//! Lattice iCE40 HX8K: the delay model's constants and where they come from.
//!
//! Calibrated on nextpnr-ice40 0.4 (Debian
//! bookworm), HX8K ct256.

use super::{Family, FifoMemory, Part, PlaceRoute, Synthesis};
use crate::estimate::{AreaModel, BramRules};
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
    carry: &["SB_CARRY"],
    lut_ram: &[],
    bram18: &[],
};

/// nextpnr-ice40, for every iCE40 family.
pub const PLACE_ROUTE: PlaceRoute = PlaceRoute {
    tool: "nextpnr-ice40",
    alternative: None,
    install: "install it with `sudo apt-get install nextpnr-ice40 fpga-icestorm` \
              (./scripts/test does it when run as root), or pass --no-pnr",
    args: &["--pcf-allow-unconstrained"],
    logic_cell: "ICESTORM_LC",
};

/// SB_RAM40_4K, every iCE40's block RAM: 4 Kbit, one read port, 2048 × 2
/// … 256 × 16.
pub const BRAM: BramRules = BramRules {
    shapes: &[(2048, 2), (1024, 4), (512, 8), (256, 16)],
    ports: 1,
};

/// The clock constraint nextpnr-ice40 reads: a `.pcf` `set_frequency`.
pub fn pcf(clock_ns: f64) -> (&'static str, String) {
    (
        "pcf",
        format!("set_frequency clk_i {:.2}\n", 1000.0 / clock_ns),
    )
}

/// Lattice iCE40 HX (no multiplier blocks).
pub struct Ice40Hx8k;

impl Family for Ice40Hx8k {
    fn name(&self) -> &'static str {
        "ice40-hx8k"
    }
    fn about(&self) -> &'static str {
        "Lattice iCE40 HX: LUTs and carry chains only (no DSP), placed and routed by \
         nextpnr-ice40"
    }
    fn delay(&self) -> Option<DelayModel> {
        Some(DELAY)
    }
    fn synthesis(&self) -> Option<Synthesis> {
        Some(SYNTH)
    }
    fn place_route(&self) -> Result<PlaceRoute, &'static str> {
        Ok(PLACE_ROUTE)
    }
    fn parts(&self) -> &'static [Part] {
        &[
            Part {
                name: "iCE40HX8K",
                pnr_args: &["--hx8k", "--package", "ct256"],
                capacity: None,
            },
            Part {
                name: "iCE40HX4K",
                pnr_args: &["--hx4k", "--package", "tq144"],
                capacity: None,
            },
            Part {
                name: "iCE40HX1K",
                pnr_args: &["--hx1k", "--package", "tq144"],
                capacity: None,
            },
        ]
    }
    /// Fitted by `fxshade synth calibrate --area --target ice40-hx8k
    /// --designs units --json` (Yosys 0.23) on the 30 unit designs (every
    /// product is fabric logic here, and the two tops' ten designs take
    /// hours: they are out of sample); SB_LUT4 |error| median 4.9 %, max
    /// 18 % (the interpolator 14–18 % under); FF median 4.3 %, max 14 %.
    /// A full adder of a fabric product costs 2.25 LUTs, a carry-chain bit
    /// 0.88.
    fn area_model(&self) -> Option<AreaModel> {
        Some(AreaModel {
            lut: [
                0.8753, 2.428, 8.317, 5.536, 0.0, 0.1548, 0.0, 0.0, 2.207, 0.0, 2.251, 21.05,
            ],
            ff: [
                0.0, 0.08357, 0.0, 0.0, 0.0, 0.0164, 0.0, 0.7665, 0.9507, 0.0, 0.0, 3.099,
            ],
        })
    }
    fn bram_rules(&self) -> Option<BramRules> {
        Some(BRAM)
    }
    fn fifo_memory(&self) -> FifoMemory {
        FifoMemory::Block
    }
    fn constraint(&self, clock_ns: f64) -> (&'static str, String) {
        pcf(clock_ns)
    }
}
