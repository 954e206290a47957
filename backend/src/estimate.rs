//! A fast resource estimate of an emitted module, without synthesis: the
//! DSP blocks its multipliers take on a target, by the rules Yosys's
//! `mul2dsp` techmap applies there (`techmap -map +/mul2dsp.v` with the
//! target's `DSP_*` macros, as `synth_ecp5`, `synth_ice40 -dsp` and
//! `synth_xilinx` set them in Yosys 0.23):
//!
//! - a product whose operand is narrower than the block's minimum (2 bits)
//!   or whose declared result is narrower than the target's minimum
//!   (iCE40 11 bits, Xilinx 9: `synth_xilinx` passes `DSP_Y_MINWIDTH=9`
//!   although its help does not show it) stays in the fabric (no block);
//!   these are checked before an unsigned product is widened for a
//!   signed-only block;
//! - the wider operand goes to the block's A port (`$mul` with
//!   `A_WIDTH < B_WIDTH` is swapped first);
//! - an operand wider than the port is cut into partial chunks of
//!   `partial − headroom` bits (headroom 1 where the block is signed only,
//!   Xilinx's DSP48E1) and a last chunk, each multiplied by the other
//!   operand and mapped again by the same rules; a chunk narrower than the
//!   minimum stays in the fabric;
//! - where the block takes each operand signed or unsigned (ECP5
//!   MULT18X18D, iCE40 SB_MAC16), a mixed product's zero-extension bit is
//!   not counted (Yosys drops it); where it is signed only, an unsigned
//!   product is widened by a bit on each side.
//!
//! Block RAMs: each ROM the emitter marks for block RAM takes as many
//! copies as its reads need ports, each the fewest blocks of one shape
//! that hold it ([`BramRules`]).
//!
//! What it does not model: products synthesis narrows further (constant
//! operands with trailing zeros, bits it proves constant), which can only
//! make the synthesized count smaller. `fxshade synth` prints the estimate
//! beside the count of the netlist.

use super::MulHw;
use crate::targets::Target;

/// A target's multiplier blocks, as Yosys's `mul2dsp` is told about them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DspRules {
    /// Widest A operand of one block.
    pub a_max: u32,
    /// Widest B operand of one block.
    pub b_max: u32,
    /// Width of an A chunk when A is cut (`DSP_A_MAXWIDTH_PARTIAL`).
    pub a_partial: u32,
    /// Width of a B chunk when B is cut.
    pub b_partial: u32,
    /// Narrowest operand mapped to a block.
    pub min: u32,
    /// Narrowest result mapped to a block (0: any).
    pub y_min: u32,
    /// The block multiplies signed operands only (`DSP_SIGNEDONLY`).
    pub signed_only: bool,
}

impl DspRules {
    /// The rules of `target` (None: it has no multiplier blocks, iCE40
    /// HX8K and a standard-cell process): its family's
    /// [`Family::dsp_rules`](crate::targets::Family::dsp_rules).
    pub fn of(target: Target) -> Option<DspRules> {
        target.dsp_rules()
    }

    /// Blocks for an `a × b` product of result width `y` as `mul2dsp`
    /// maps it (already swapped and widened).
    fn blocks(&self, a: u32, b: u32, y: u32) -> u64 {
        if a < self.min || b < self.min || y < self.y_min {
            return 0;
        }
        let h = u32::from(self.signed_only);
        if a > self.a_max {
            let step = self.a_partial - h;
            let n = (a - self.a_max).div_ceil(step);
            let last = a - n * step;
            // A chunk's result: its own width plus the other operand's,
            // at most the product's.
            let py = |w: u32| y.min(w + b);
            return u64::from(n) * self.blocks(self.a_partial, b, py(self.a_partial))
                + self.blocks(last, b, py(last));
        }
        if b > self.b_max {
            let step = self.b_partial - h;
            let n = (b - self.b_max).div_ceil(step);
            let last = b - n * step;
            let py = |w: u32| y.min(a + w);
            return u64::from(n) * self.blocks(a, self.b_partial, py(self.b_partial))
                + self.blocks(a, last, py(last));
        }
        1
    }

    /// Blocks for one emitted multiplier.
    pub fn blocks_of(&self, m: &MulHw) -> u64 {
        let (mut a, mut b) = (m.a_width, m.b_width);
        let y = if m.y_width == 0 { a + b } else { m.y_width };
        // mul2dsp checks the minimum widths before it widens an unsigned
        // product for a signed-only block.
        if a < self.min || b < self.min || y < self.y_min {
            return 0;
        }
        if self.signed_only {
            if !m.signed {
                a += 1;
                b += 1;
            }
        } else {
            // The block takes the unsigned operand as it is.
            a -= u32::from(m.a_zext);
            b -= u32::from(m.b_zext);
        }
        if a < b {
            std::mem::swap(&mut a, &mut b);
        }
        self.blocks(a, b, y)
    }
}

/// DSP blocks of every multiplier of `hw` on `target` (0 where the target
/// has none).
pub fn dsp_blocks(hw: &super::Hardware, target: Target) -> u64 {
    DspRules::of(target).map_or(0, |r| hw.muls.iter().map(|m| r.blocks_of(m)).sum())
}

/// A target's block RAM as a ROM uses it: its shapes (depth × width) and
/// the read ports one block gives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BramRules {
    /// The shapes one block can take (true dual port where it has two).
    pub shapes: &'static [(u64, u32)],
    /// Read ports per block.
    pub ports: u64,
}

impl BramRules {
    /// The rules of `target` (None for a standard-cell process): its
    /// family's [`Family::bram_rules`](crate::targets::Family::bram_rules).
    pub fn of(target: Target) -> Option<BramRules> {
        target.bram_rules()
    }

    /// Blocks for one ROM: as many copies as its reads need ports, each
    /// the fewest blocks of one shape that hold it; a ROM not marked for
    /// block RAM takes none.
    pub fn blocks_of(&self, r: &super::RomHw) -> u64 {
        if !r.block || r.reads == 0 {
            return 0;
        }
        let per_copy = self
            .shapes
            .iter()
            .map(|&(d, w)| r.entries.div_ceil(d) * u64::from(r.width.div_ceil(w)))
            .min()
            .unwrap_or(0);
        r.reads.div_ceil(self.ports) * per_copy
    }
}

/// Block RAMs of every ROM of `hw` on `target`.
pub fn bram_blocks(hw: &super::Hardware, target: Target) -> u64 {
    BramRules::of(target).map_or(0, |r| hw.roms.iter().map(|m| r.blocks_of(m)).sum())
}

/// What a module's logic is made of, in the units the area model counts
/// ([`AreaModel`]): each a sum read off [`super::Hardware`] and the
/// target's block rules, so a term is exact and only its cost is fitted.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AreaTerms {
    /// Σ width over adders, subtractors, rounding incrementers and
    /// comparators: one carry-chain bit each.
    pub carry_bits: f64,
    /// Σ width over sign-steered add/subtracts (a carry bit and an XOR).
    pub add_sub_bits: f64,
    /// Σ width × (options − 1) over multiplexers: 2:1 multiplexer bits.
    pub select_bits: f64,
    /// Σ bits read by quantizers' range checks.
    pub check_bits: f64,
    /// Σ output bits behind saturation multiplexers.
    pub saturate_bits: f64,
    /// Σ a × b over products (or chunks of products) no multiplier block
    /// takes on the target: partial-product bits built in logic.
    pub fabric_product_bits: f64,
    /// Σ entries × width × reads over ROMs built in logic (not marked for
    /// block RAM, or on a target without block RAM).
    pub logic_rom_bits: f64,
    /// Flip-flops the emitter declares ([`super::Hardware::flops`]), the
    /// FIFO's entries apart.
    pub flops: f64,
    /// The FIFO handshake's entries, bits ([`super::Hardware::fifo_bits`]):
    /// LUT RAM on ECP5.
    #[serde(default)]
    pub fifo_bits: f64,
    /// Multiplier blocks ([`dsp_blocks`]): on ECP5 their product
    /// registers move into the block ([`crate`]'s `dsp_pack`).
    pub dsp_blocks: f64,
    /// Σ (min(a, b) − 1) · max(a, b) over the same products as
    /// [`AreaTerms::fabric_product_bits`], `a` and `b` their operands'
    /// value bits (a zero-extension bit excluded): the full adders of an
    /// array multiplier. A product with a one-bit operand (a partial
    /// product row of a multiplier the emitter split for timing, summed
    /// by its own adders) has none.
    #[serde(default)]
    pub fabric_adder_bits: f64,
}

/// How many [`AreaTerms`] there are; an [`AreaModel`] holds one coefficient
/// per term and a constant.
pub const TERMS: usize = 11;

impl AreaTerms {
    /// The terms of `hw` on `target`.
    #[allow(
        clippy::cast_precision_loss,
        reason = "bit and block counts, far below 2^53: exact in f64"
    )]
    pub fn of(hw: &super::Hardware, target: Target) -> AreaTerms {
        let dsp = DspRules::of(target);
        let bram = BramRules::of(target);
        let in_fabric = |m: &&MulHw| dsp.is_none_or(|r| r.blocks_of(m) == 0);
        let fabric = |m: &MulHw| -> f64 { f64::from(m.a_width) * f64::from(m.b_width) };
        let adders = |m: &MulHw| -> f64 {
            let a = m.a_width.saturating_sub(u32::from(m.a_zext));
            let b = m.b_width.saturating_sub(u32::from(m.b_zext));
            f64::from(a.min(b).saturating_sub(1)) * f64::from(a.max(b))
        };
        let sum = |v: &[u32]| v.iter().map(|&w| f64::from(w)).sum::<f64>();
        AreaTerms {
            carry_bits: sum(&hw.adders) + sum(&hw.incrementers) + hw.compare_bits as f64,
            add_sub_bits: sum(&hw.add_subs),
            select_bits: hw.select_bits as f64,
            check_bits: hw.check_bits as f64,
            saturate_bits: hw.saturate_bits as f64,
            fabric_product_bits: hw.muls.iter().filter(in_fabric).map(fabric).sum(),
            logic_rom_bits: hw
                .roms
                .iter()
                .filter(|r| bram.is_none_or(|b| b.blocks_of(r) == 0))
                .map(|r| r.entries as f64 * f64::from(r.width) * r.reads as f64)
                .sum(),
            flops: hw.flops.saturating_sub(hw.fifo_bits) as f64,
            fifo_bits: hw.fifo_bits as f64,
            dsp_blocks: dsp_blocks(hw, target) as f64,
            fabric_adder_bits: hw.muls.iter().filter(in_fabric).map(adders).sum(),
        }
    }

    /// The terms as a vector in [`AreaTerms::NAMES`] order.
    pub fn values(&self) -> [f64; TERMS] {
        [
            self.carry_bits,
            self.add_sub_bits,
            self.select_bits,
            self.check_bits,
            self.saturate_bits,
            self.fabric_product_bits,
            self.logic_rom_bits,
            self.flops,
            self.fifo_bits,
            self.dsp_blocks,
            self.fabric_adder_bits,
        ]
    }

    /// The terms' names, as in the JSON.
    pub const NAMES: [&'static str; TERMS] = [
        "carry_bits",
        "add_sub_bits",
        "select_bits",
        "check_bits",
        "saturate_bits",
        "fabric_product_bits",
        "logic_rom_bits",
        "flops",
        "fifo_bits",
        "dsp_blocks",
        "fabric_adder_bits",
    ];
}

/// A target's look-up-table and flip-flop cost per [`AreaTerms`] term,
/// fitted to synthesis (`fxshade synth calibrate --area --target T`
/// synthesizes the calibration set and prints the fit): the estimate is
/// `Σ coefficient × term`, rounded to a whole cell.
///
/// Provenance of every family's fit (in its file in [`crate::targets`]):
/// `fxshade synth calibrate --area --target T --json` (Yosys 0.23, the
/// default configuration as the base) on the 40 designs of its calibration
/// set (8 units and tops × default, 12-bit normals, wide, 24 bits with the
/// FIFO handshake, target pipelining at 8 ns; iCE40 HX8K on the 30 unit
/// designs, `--designs units`); the `refit` of its JSON, rounded. The fits
/// made before [`AreaTerms::fabric_adder_bits`] existed give it 0 (ECP5,
/// UP5K, xc7: their products are mostly in blocks). The in-sample |error| of each fit is in its doc; refit and
/// paste after a change to the emitter or the synthesis scripts (the
/// calibration test in `tests/suite/synth.rs` checks three configurations
/// against Yosys).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaModel {
    /// LUT cells (the count `fxshade synth` reports as `lut`) per term,
    /// in [`AreaTerms::NAMES`] order, and a constant last.
    pub lut: [f64; TERMS + 1],
    /// Flip-flops after synthesis (the harness's own excluded) per term,
    /// and a constant last.
    pub ff: [f64; TERMS + 1],
}

impl AreaModel {
    /// The model of `target` (None: a standard-cell process, which has no
    /// LUTs): its family's
    /// [`Family::area_model`](crate::targets::Family::area_model).
    pub fn of(target: Target) -> Option<AreaModel> {
        target.area_model()
    }

    #[allow(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "clamped at 0 and rounded: a whole, non-negative count (saturating)"
    )]
    fn apply(c: &[f64; TERMS + 1], t: &AreaTerms) -> u64 {
        let v = t.values();
        let s: f64 = v.iter().zip(c).map(|(x, k)| x * k).sum::<f64>() + c[TERMS];
        // Non-negative and finite by construction of the terms; a cell
        // count is whole.
        s.max(0.0).round() as u64
    }

    /// Estimated LUT cells of a module with `terms`.
    pub fn lut(&self, terms: &AreaTerms) -> u64 {
        Self::apply(&self.lut, terms)
    }

    /// Estimated flip-flops of a module with `terms`.
    pub fn ff(&self, terms: &AreaTerms) -> u64 {
        Self::apply(&self.ff, terms)
    }
}

/// Estimated LUT cells of `hw` on `target` (None: no LUTs there).
pub fn lut_cells(hw: &super::Hardware, target: Target) -> Option<u64> {
    AreaModel::of(target).map(|m| m.lut(&AreaTerms::of(hw, target)))
}

/// Estimated flip-flops of `hw` on `target` after synthesis (None: no
/// model there).
pub fn flip_flops(hw: &super::Hardware, target: Target) -> Option<u64> {
    AreaModel::of(target).map(|m| m.ff(&AreaTerms::of(hw, target)))
}

pub mod fit;

#[cfg(test)]
mod tests {
    use super::*;

    fn mul(a: u32, b: u32, signed: bool, a_zext: bool, b_zext: bool) -> MulHw {
        MulHw {
            a_width: a,
            b_width: b,
            signed,
            a_zext,
            b_zext,
            y_width: 0,
        }
    }

    /// Closed forms: a 16 × 16 array multiplier adds 15 rows of 16 bits
    /// (240 full adders) and a 12-bit × (1-bit zero-extended) partial
    /// product row none; on ECP5 the 16 × 16 is a MULT18X18D (no fabric)
    /// and the row stays in the fabric.
    #[test]
    fn fabric_adders_are_those_of_array_multipliers() {
        let hw = crate::Hardware {
            muls: vec![
                mul(16, 16, true, false, false),
                mul(12, 2, true, false, true),
            ],
            ..Default::default()
        };
        let hx = AreaTerms::of(&hw, Target::from_name("ice40-hx8k").unwrap());
        assert_eq!(hx.fabric_adder_bits, 240.0);
        assert_eq!(hx.fabric_product_bits, 256.0 + 24.0);
        let ecp5 = AreaTerms::of(&hw, Target::from_name("ecp5").unwrap());
        assert_eq!(ecp5.fabric_adder_bits, 0.0);
        assert_eq!(ecp5.fabric_product_bits, 24.0);
    }

    /// Closed forms: on ECP5 a product of operands up to 18 bits is one
    /// MULT18X18D, a 25 × 18 two (the issue's example), a 36 × 36 four; a
    /// 19 × 16 one block and a 1-bit chunk left to the fabric; a mixed
    /// 18-bit unsigned × 16-bit signed (built 19 × 16) one.
    #[test]
    fn ecp5_blocks_follow_mul2dsp() {
        let r = DspRules::of(Target::from_name("ecp5").unwrap()).unwrap();
        assert_eq!(r.blocks_of(&mul(18, 18, true, false, false)), 1);
        assert_eq!(r.blocks_of(&mul(25, 18, true, false, false)), 2);
        assert_eq!(r.blocks_of(&mul(36, 36, false, false, false)), 4);
        assert_eq!(r.blocks_of(&mul(19, 16, true, false, false)), 1);
        assert_eq!(r.blocks_of(&mul(19, 16, true, true, false)), 1);
        assert_eq!(r.blocks_of(&mul(16, 19, true, false, true)), 1);
        assert_eq!(r.blocks_of(&mul(37, 20, true, false, false)), 4);
        assert_eq!(r.blocks_of(&mul(1, 16, false, false, false)), 0);
    }

    /// iCE40 UP5K: 16 × 16 blocks, results under 11 bits in the fabric;
    /// Xilinx: 25 × 18 signed blocks, an unsigned 24 × 17 widened to
    /// 25 × 18 (one block), a 26 × 18 signed cut into a 17-bit chunk and a
    /// 9-bit one (two).
    #[test]
    fn ice40_and_xc7_blocks_follow_mul2dsp() {
        let r = DspRules::of(Target::from_name("ice40-up5k").unwrap()).unwrap();
        assert_eq!(r.blocks_of(&mul(16, 16, true, false, false)), 1);
        assert_eq!(r.blocks_of(&mul(5, 5, true, false, false)), 0);
        assert_eq!(r.blocks_of(&mul(17, 16, false, false, false)), 1);
        // 20 × 20: 16 × 16, 16 × 4 and 4 × 16 in blocks, 4 × 4 (8 bits of
        // result) in the fabric.
        assert_eq!(r.blocks_of(&mul(20, 20, false, false, false)), 3);
        let x = DspRules::of(Target::from_name("xc7").unwrap()).unwrap();
        assert_eq!(x.blocks_of(&mul(24, 17, false, false, false)), 1);
        assert_eq!(x.blocks_of(&mul(26, 18, true, false, false)), 2);
        assert!(DspRules::of(Target::from_name("ice40-hx8k").unwrap()).is_none());
        // Minimum widths before widening: an unsigned 4 × 4 (8-bit result)
        // stays in logic on Xilinx (result under 9 bits), as does an 8 × 8
        // kept to 10 bits on iCE40 (under 11).
        assert_eq!(x.blocks_of(&mul(4, 4, false, false, false)), 0);
        let mut narrow = mul(8, 8, false, false, false);
        narrow.y_width = 10;
        assert_eq!(r.blocks_of(&narrow), 0);
        narrow.y_width = 16;
        assert_eq!(r.blocks_of(&narrow), 1);
    }

    /// The polar unit's quarter-wave ROM, 512 × 16 read by six ports:
    /// three dual-port blocks on ECP5 and Xilinx, twelve 256 × 16 iCE40
    /// blocks (two a copy, one port each); a small ROM in logic.
    #[test]
    fn roms_take_blocks_by_shape_and_ports() {
        let rom = |entries, width, reads, block| crate::RomHw {
            name: "r".into(),
            entries,
            width,
            reads,
            block,
        };
        let q = rom(512, 16, 6, true);
        assert_eq!(
            BramRules::of(Target::from_name("ecp5").unwrap())
                .unwrap()
                .blocks_of(&q),
            3
        );
        assert_eq!(
            BramRules::of(Target::from_name("xc7").unwrap())
                .unwrap()
                .blocks_of(&q),
            3
        );
        assert_eq!(
            BramRules::of(Target::from_name("ice40-up5k").unwrap())
                .unwrap()
                .blocks_of(&q),
            12
        );
        assert_eq!(
            BramRules::of(Target::from_name("ecp5").unwrap())
                .unwrap()
                .blocks_of(&rom(4096, 20, 1, true)),
            5
        );
        assert_eq!(
            BramRules::of(Target::from_name("ecp5").unwrap())
                .unwrap()
                .blocks_of(&rom(64, 16, 2, false)),
            0
        );
        // 4096 × 9: one RAMB36E1 (two RAMB18E1 would do it too).
        assert_eq!(
            BramRules::of(Target::from_name("xc7").unwrap())
                .unwrap()
                .blocks_of(&rom(4096, 9, 1, true)),
            1
        );
    }
}
