//! Yosys's generic synthesis mapped to 4-input LUTs: no vendor cells, no
//! delay model, no place and route (a technology-independent count).

use super::{Family, Synthesis};

/// How `fxshade synth` maps a module to generic LUTs, and which cells it
/// counts as what.
pub const SYNTH: Synthesis = Synthesis {
    device: "generic 4-input LUTs",
    yosys: "synth -flatten -top fxs_harness; abc -lut 4; opt_clean",
    lut: &["$lut"],
    ff: &["$_DFF", "$_SDFF", "$_DFFE", "$_SDFFE", "$_ALDFF"],
    dsp: &[],
    bram: &[],
    carry: &[],
    lut_ram: &[],
    bram18: &[],
};

/// Yosys's generic LUT mapping.
pub struct Generic;

impl Family for Generic {
    fn name(&self) -> &'static str {
        "generic"
    }
    fn about(&self) -> &'static str {
        "Yosys's generic synthesis mapped to 4-input LUTs (no vendor cells, no place and route)"
    }
    fn synthesis(&self) -> Option<Synthesis> {
        Some(SYNTH)
    }
    fn place_route(&self) -> Result<super::PlaceRoute, &'static str> {
        Err("generic synthesis: no device to place and route")
    }
}
