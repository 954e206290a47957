//! Technology families, one file each, as FloPoCo's `Targets/*.cpp` and
//! Cranelift's `isa::lookup`: a family is a type implementing [`Family`]
//! (its delay model with the calibration's provenance at the top of its
//! file, how Yosys maps to it, how it is placed and routed, its parts, its
//! multiplier blocks, block and LUT RAM, and its area model), and the one
//! registry [`ALL`] lists them. Everything else reads a family through
//! [`Target`], a handle on a registry entry: the configuration's
//! `rtl.target` choices are the families with a delay model
//! ([`Target::pipelined_names`]), `fxshade synth --target` takes the
//! families with a synthesis flow ([`Target::synthesized`]), and no other
//! file names a family.
//!
//! Adding a family: its file here (a unit struct and its `impl Family`),
//! one `mod` line and one entry in [`ALL`], and a calibration test
//! (`tests/suite/synth.rs`).

use crate::estimate::{AreaModel, BramRules, DspRules};
use crate::timing::DelayModel;

pub mod asic;
pub mod ecp5;
pub mod generic;
pub mod ice40_hx8k;
pub mod ice40_up5k;
pub mod xc7;

/// Every family, in the order the command line lists them.
pub static ALL: &[Target] = &[
    Target(&generic::Generic),
    Target(&ice40_hx8k::Ice40Hx8k),
    Target(&ice40_up5k::Ice40Up5k),
    Target(&ecp5::Ecp5),
    Target(&xc7::Xc7),
    Target(&asic::Asic),
];

/// How a family is synthesized and counted.
#[derive(Clone, Copy, Debug)]
pub struct Synthesis {
    /// The device as reports name it.
    pub device: &'static str,
    /// The Yosys synthesis command (the harness's top is `fxs_harness`).
    pub yosys: &'static str,
    /// Cell type prefixes counted as LUTs.
    pub lut: &'static [&'static str],
    /// Cell type prefixes counted as flip-flops.
    pub ff: &'static [&'static str],
    /// Cell type prefixes counted as DSP blocks.
    pub dsp: &'static [&'static str],
    /// Cell type prefixes counted as block RAMs.
    pub bram: &'static [&'static str],
    /// Cell types counted as carry-chain cells.
    pub carry: &'static [&'static str],
    /// Cell types counted as LUT RAM.
    pub lut_ram: &'static [&'static str],
    /// Block RAM cell types and how many 18 Kb halves each is, for a part
    /// compared with a capacity table ([`Part::capacity`]).
    pub bram18: &'static [(&'static str, u64)],
}

/// How a family is placed and routed.
#[derive(Clone, Copy, Debug)]
pub struct PlaceRoute {
    /// The placer's program.
    pub tool: &'static str,
    /// Another program that runs the same placer (a packaged build, tried
    /// when `tool` is not installed), if any.
    pub alternative: Option<&'static str>,
    /// How to install it, for the error when neither is found.
    pub install: &'static str,
    /// Arguments the placer takes for every run beside the part's own, the
    /// netlist, the clock, the seed and the report.
    pub args: &'static [&'static str],
    /// The resource of the placer's utilisation report that counts logic
    /// cells (LUT slots).
    pub logic_cell: &'static str,
}

/// One part of a family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    /// Its name as `--device` takes it (case-insensitive) and as reported.
    pub name: &'static str,
    /// The placer's device and package arguments (none: no open placer).
    pub pnr_args: &'static [&'static str],
    /// Capacity by resource where no placer reports it: (LUT, FF, DSP,
    /// block RAM in 18 Kb halves).
    pub capacity: Option<[u64; 4]>,
}

/// Where an emitted output FIFO keeps its entries on a family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FifoMemory {
    /// Flip-flops (no memory inferred).
    Registers,
    /// LUT RAM: written synchronously, read asynchronously.
    Distributed,
    /// Block RAM: the read is registered, one cycle more.
    Block,
}

/// A technology family: everything fxshade knows of it, in its own file.
/// Every method but [`name`](Family::name) and [`about`](Family::about)
/// has a default that says "the family has none".
pub trait Family: Sync {
    /// The name on the command line and in `rtl.target`.
    fn name(&self) -> &'static str;
    /// One line for `--help`.
    fn about(&self) -> &'static str;
    /// The delay model the emitter pipelines with (None: `rtl.target`
    /// does not take the family).
    fn delay(&self) -> Option<DelayModel> {
        None
    }
    /// How Yosys maps a module to it (None: `fxshade synth` does not take
    /// the family).
    fn synthesis(&self) -> Option<Synthesis> {
        None
    }
    /// How it is placed and routed; `Err` says why there is no Fmax.
    ///
    /// # Errors
    ///
    /// The reason the family has no open place and route.
    fn place_route(&self) -> Result<PlaceRoute, &'static str> {
        Err("no open place and route")
    }
    /// Its parts; the first is the default (but see
    /// [`default_part`](Family::default_part)).
    fn parts(&self) -> &'static [Part] {
        &[]
    }
    /// The part used when `--device` is not given.
    fn default_part(&self) -> Option<Part> {
        self.parts().first().copied()
    }
    /// What precedes a part's name in reports (`ECP5 `).
    fn part_prefix(&self) -> &'static str {
        ""
    }
    /// Its multiplier blocks as Yosys's `mul2dsp` is told about them.
    fn dsp_rules(&self) -> Option<DspRules> {
        None
    }
    /// Its block RAM shapes and ports.
    fn bram_rules(&self) -> Option<BramRules> {
        None
    }
    /// Its area model, fitted to synthesis.
    fn area_model(&self) -> Option<AreaModel> {
        None
    }
    /// Where an output FIFO keeps its entries.
    fn fifo_memory(&self) -> FifoMemory {
        FifoMemory::Registers
    }
    /// Whether the emitter gives each block of a product it splits its own
    /// operand registers (a family whose blocks absorb their operand
    /// registers only when nothing else reads them).
    fn split_products_own_operands(&self) -> bool {
        false
    }
    /// Whether `fxshade synth` moves a product's registers into the
    /// multiplier blocks after Yosys (`--no-dsp-pack` turns it off) and
    /// can write the placed netlist (`--netlist`).
    fn packs_dsp_registers(&self) -> bool {
        false
    }
    /// The clock constraint: the file's extension and the line after the
    /// header (an SDC `create_clock` unless the family says otherwise).
    fn constraint(&self, clock_ns: f64) -> (&'static str, String) {
        (
            "sdc",
            format!("create_clock -name clk_i -period {clock_ns} [get_ports clk_i]\n"),
        )
    }
}

/// A handle on one family of the registry ([`ALL`]); compares and
/// serializes by name.
#[derive(Clone, Copy)]
pub struct Target(&'static dyn Family);

impl Target {
    /// Every family.
    pub fn all() -> &'static [Target] {
        ALL
    }

    /// The family called `name`.
    pub fn from_name(name: &str) -> Option<Target> {
        ALL.iter().copied().find(|t| t.name() == name)
    }

    /// The families with a delay model, in registry order.
    pub fn pipelined() -> impl Iterator<Item = Target> {
        ALL.iter().copied().filter(|t| t.delay().is_some())
    }

    /// The names of [`Target::pipelined`] (the `rtl.target` choices).
    pub fn pipelined_names() -> &'static [&'static str] {
        static NAMES: std::sync::LazyLock<Vec<&'static str>> =
            std::sync::LazyLock::new(|| Target::pipelined().map(|t| t.name()).collect());
        &NAMES
    }

    /// The families with a synthesis flow, in registry order.
    pub fn synthesized() -> &'static [Target] {
        static LIST: std::sync::LazyLock<Vec<Target>> = std::sync::LazyLock::new(|| {
            ALL.iter()
                .copied()
                .filter(|t| t.synthesis().is_some())
                .collect()
        });
        &LIST
    }

    /// The family's description.
    pub fn family(self) -> &'static dyn Family {
        self.0
    }
}

impl std::ops::Deref for Target {
    type Target = dyn Family;
    fn deref(&self) -> &(dyn Family + 'static) {
        self.0
    }
}

impl PartialEq for Target {
    fn eq(&self, other: &Target) -> bool {
        self.name() == other.name()
    }
}

impl Eq for Target {}

impl std::fmt::Debug for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Target({})", self.name())
    }
}

impl std::fmt::Display for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl serde::Serialize for Target {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// Read from a family's name ([`Target::from_name`]).
impl<'de> serde::Deserialize<'de> for Target {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        Target::from_name(&name)
            .ok_or_else(|| serde::de::Error::custom(format!("`{name}` names no target family")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_round_trip() {
        for t in ALL {
            assert_eq!(Target::from_name(t.name()), Some(*t));
            assert_eq!(ALL.iter().filter(|u| u.name() == t.name()).count(), 1);
        }
        assert_eq!(Target::from_name("ice40"), None);
    }

    #[test]
    fn a_placed_family_has_parts_with_placer_arguments() {
        for t in ALL {
            for p in t.parts() {
                // A part either names the placer's device or carries the
                // capacity table a report compares with.
                assert_eq!(p.pnr_args.is_empty(), p.capacity.is_some(), "{}", p.name);
                assert_eq!(
                    !p.pnr_args.is_empty(),
                    t.place_route().is_ok(),
                    "{}: {}",
                    t.name(),
                    p.name
                );
            }
        }
    }
}
