//! The area model's coefficients per target, fitted to synthesis.
//!
//! Provenance: `fxshade synth calibrate --area --target T --json` (Yosys
//! 0.23, the default configuration as the base) on the 40 designs of its
//! calibration set (8 units and tops × default, 12-bit normals, wide,
//! 24 bits with the FIFO handshake, target pipelining at 8 ns); the `refit` of its JSON, rounded. The
//! in-sample |error| of each fit is in its comment; refit and paste after
//! a change to the emitter or the synthesis scripts (the calibration test
//! in `tests/suite/synth.rs` checks three configurations against Yosys).
//!
//! Coefficient order: [`super::AreaTerms::NAMES`], then a constant.

use super::AreaModel;
use crate::timing::Target;

/// The fitted model of `target`; None where no fit exists (a standard-cell
/// process has no LUTs).
pub fn of(target: Target) -> Option<AreaModel> {
    match target {
        // 40 designs; LUT4 |error| median 12.3 %, max 62 % (the compact
        // `angles` unit, where ABC builds 2 694 L6MUX21 from a whole CORDIC
        // iteration per stage); FF median 9.3 %, max 24 %.
        Target::Ecp5 => Some(AreaModel {
            lut: [
                0.0, 0.6350, 0.6562, 0.0, 1.7960, 0.0, 0.0, 0.03831, 0.0, 0.2152, 24.09,
            ],
            ff: [
                0.1299, 0.3217, 0.0, 0.0, 0.0, 0.0, 0.0, 0.6419, 0.0, 2.3312, -1.3571,
            ],
        }),
        // 40 designs; SB_LUT4 |error| median 6.6 %, max 33 %; FF median
        // 11.6 %, max 45 %.
        Target::Ice40Up5k => Some(AreaModel {
            lut: [
                0.2421, 3.3415, 2.7516, 0.0, 0.05730, 0.1386, 0.0, 0.01570, 1.2405, 18.340, 0.0,
            ],
            ff: [
                0.0, 0.1746, 0.0, 0.0, 0.0, 0.0, 0.0, 0.7354, 1.1358, -3.3542, 15.730,
            ],
        }),
        // 40 designs; LUT1-6 |error| median 9.9 %, max 37 %; FF median
        // 29.5 %, max 55 % (synth_xilinx's DSP48E1 register absorption is
        // not a term).
        Target::Xc7 => Some(AreaModel {
            lut: [
                0.0, 0.7202, 1.1822, 0.0, 1.3164, 0.0, 0.0, 0.06725, 0.4090, 1.0042, 8.544,
            ],
            ff: [
                0.0, 0.4594, 0.5151, 0.0, 0.0, 0.0, 0.0, 0.4516, 0.02252, -1.9883, 17.495,
            ],
        }),
        _ => None,
    }
}
