//! One file per technology family, as FloPoCo's `Targets/*.cpp`: the
//! delay model the emitter pipelines with ([`DELAY`](ecp5::DELAY), with
//! the calibration's provenance at the top of the file) and how `fxshade
//! synth` maps a module to the family with Yosys ([`SYNTH`](ecp5::SYNTH):
//! the synthesis command, the device named in reports, the cell classes
//! counted). `timing::Target::model` and the CLI's synthesis targets read
//! these constants; nothing else states a family's numbers.
//!
//! Not yet a registry: a family is still also a variant of
//! [`crate::timing::Target`] (and of the CLI's synthesis target), so adding
//! one touches those enums and their matches too.

pub mod asic;
pub mod ecp5;
pub mod generic;
pub mod ice40_hx8k;
pub mod ice40_up5k;
pub mod xc7;

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
}
