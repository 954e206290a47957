//! Target-driven pipelining: a delay model per target, in the spirit of
//! FloPoCo's `Target` classes, and the policy the emitter follows.
//!
//! The emitter walks the traced datapath in order and keeps, for every
//! value, the stage it is computed in and its *arrival*: nanoseconds after
//! that stage's registers. An operation whose inputs arrive at `a` and
//! which takes `d` joins their stage while `a + d ≤ budget`
//! ([`DelayModel::budget`]: the clock period less the register overhead);
//! otherwise its operands are registered first and it starts the next
//! stage. A quantization may be cut between its rounding incrementer and
//! its range check and saturation; a multiplier too slow for the period is
//! split into partial products (on a target without DSP blocks a few bits
//! of the narrower operand each, on a DSP target block-sized tiles of both
//! operands), registered, and summed by a tree of adders over the following
//! stages. A table read is registered (block
//! RAM); the value leaves the RAM [`DelayModel::bram`] after the clock.
//!
//! Delays of one operation, in nanoseconds (`w` a result width):
//!
//! | operation | delay |
//! |---|---|
//! | add, subtract | `carry(w)` = `carry_base + w·carry_bit` |
//! | add/subtract steered by a sign | `lut + carry(w)` |
//! | max | `carry(w) + lut + word_select` |
//! | select of n | `lut · ⌈log2 n / 2⌉` |
//! | multiply, LUTs, `a × b` bits | `⌈log2 min(a,b)⌉·mul_row + carry(a+b)` |
//! | multiply, DSP | `dsp.comb`, plus `dsp.combine` per level of DSP tiles summed |
//! | into a DSP's input register | `dsp.route_in` before the period ends |
//! | out of a DSP's output register | logic after it starts at `dsp.route_out` |
//! | rounding (nearest) | `max(carry(w), lut·(⌈log4 s⌉ + 1))`, `s` dropped bits |
//! | range check and saturate | `lut·⌈log4 k⌉ + lut + word_select`, `k` bits checked |
//!
//! The constants are calibrated against nextpnr by `fxshade synth
//! calibrate --target T` (BENCHMARKS.md lists predicted against measured).

/// A technology family (one file each in [`crate::targets`]); the emitter
/// reads its [`Family::delay`](crate::targets::Family::delay).
pub use crate::targets::Target;

/// A hard multiplier block.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Dsp {
    /// Widest first operand (signed) of one block.
    pub a: u32,
    /// Widest second operand (signed) of one block.
    pub b: u32,
    /// Delay through the block without its internal registers, ns.
    pub comb: f64,
    /// Each level of summing the tiles of a product wider than one block.
    pub combine: f64,
    /// Routing from the fabric into the block's input registers: an
    /// operand computed in the stage before must be ready this much before
    /// the period ends, else it is registered in the fabric first.
    pub route_in: f64,
    /// Routing from the block's output register back into the fabric: a
    /// product registered in the block reaches the logic of the next stage
    /// this late (a fabric register after it hides it).
    pub route_out: f64,
    /// Whether the block takes each operand signed or unsigned (ECP5's
    /// MULT18X18D `SIGNEDA`/`SIGNEDB`, iCE40's SB_MAC16 `A_SIGNED`/
    /// `B_SIGNED`): the unsigned operand of a mixed product then fits the
    /// block at its own width (Yosys drops the zero extension bit), not one
    /// bit wider. False where the block is signed only (Xilinx DSP48).
    pub mixed: bool,
}

/// Delays of one target, in nanoseconds (module documentation).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct DelayModel {
    /// Clock-to-output plus set-up of a flip-flop, and clock skew.
    pub reg: f64,
    /// One LUT level with its share of routing.
    pub lut: f64,
    /// Entering and leaving a carry chain.
    pub carry_base: f64,
    /// Each bit of a carry chain.
    pub carry_bit: f64,
    /// Each level of the partial-product tree of a multiplier built from
    /// LUTs and carry chains.
    pub mul_row: f64,
    /// The hard multiplier, if the target has one.
    pub dsp: Option<Dsp>,
    /// Clock to output of a registered block-RAM read.
    pub bram: f64,
    /// A select that steers a whole word (the saturating multiplexer after
    /// a range check, the one after a maximum's compare): the routing of
    /// its fan-out to every bit, on top of the LUT level.
    pub word_select: f64,
}

fn ceil_log(n: u32, base: u32) -> u32 {
    let mut levels = 0;
    let mut reach = 1u64;
    while reach < u64::from(n) {
        reach *= u64::from(base);
        levels += 1;
    }
    levels
}

impl DelayModel {
    /// Combinational time per stage for a clock period of `clock_ns`.
    pub fn budget(&self, clock_ns: f64) -> f64 {
        clock_ns - self.reg
    }
    /// A carry chain of `w` bits.
    pub fn carry(&self, w: u32) -> f64 {
        self.carry_base + f64::from(w) * self.carry_bit
    }
    /// An adder or subtractor of `w` result bits.
    pub fn add(&self, w: u32) -> f64 {
        self.carry(w)
    }
    /// An adder/subtractor steered by a sign bit.
    pub fn add_signed(&self, w: u32) -> f64 {
        self.lut + self.carry(w)
    }
    /// `max` of two `w`-bit values: a comparison and a multiplexer.
    pub fn max(&self, w: u32) -> f64 {
        self.carry(w) + self.lut + self.word_select
    }
    /// A multiplexer of `n` inputs.
    pub fn select(&self, n: u32) -> f64 {
        self.lut * f64::from(ceil_log(n, 4).max(1))
    }
    /// A multiplier of `a × b` bits (as built: an unsigned operand of a
    /// mixed product is already extended by its bit).
    pub fn mul(&self, a: u32, b: u32) -> f64 {
        match self.dsp {
            Some(d) => {
                let tiles = a.div_ceil(d.a).max(1) * b.div_ceil(d.b).max(1);
                let tiles = if tiles > 1 {
                    // Either orientation: the block fits one way or both.
                    tiles.min(a.div_ceil(d.b) * b.div_ceil(d.a))
                } else {
                    1
                };
                d.comb + f64::from(ceil_log(tiles, 2)) * d.combine
            }
            None => self.lut_mul(a, b),
        }
    }
    /// A multiplier built from LUTs and carry chains: a tree of
    /// `⌈log2 min(a, b)⌉` levels of partial-product adders, then the final
    /// carry chain.
    pub fn lut_mul(&self, a: u32, b: u32) -> f64 {
        f64::from(ceil_log(a.min(b), 2).max(1)) * self.mul_row + self.carry(a + b)
    }
    /// The rounding incrementer of a nearest mode dropping `s` bits into a
    /// `w`-bit result (`s = 0` or truncation: no logic): a carry chain fed
    /// straight by the half bit; half-even's tie detect over the `s − 1`
    /// bits below it runs beside the chain and clears the LSB with one more
    /// LUT, so the slower of the two counts.
    pub fn round(&self, s: u32, w: u32, nearest: bool) -> f64 {
        if !nearest || s == 0 {
            0.0
        } else {
            self.carry(w)
                .max(self.lut * f64::from(ceil_log(s, 4).max(1) + 1))
        }
    }
    /// The range check of `k` bits and the saturating multiplexer (none
    /// when `k` is 0: the value cannot leave the format).
    pub fn saturate(&self, k: u32, saturate: bool) -> f64 {
        if k == 0 {
            0.0
        } else {
            self.lut * f64::from(ceil_log(k + 1, 4).max(1))
                + if saturate {
                    self.lut + self.word_select
                } else {
                    0.0
                }
        }
    }
}

/// How the emitter places pipeline registers.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub enum Pipelining {
    /// A register after every quantization and every table read: one stage
    /// per arithmetic step, whatever its delay.
    Compact,
    /// Registers where the delay model needs them for `clock_ns` on
    /// `target` (a family with a delay model: the emitter refuses one
    /// without).
    Target {
        /// The technology.
        target: Target,
        /// The requested clock period, ns.
        clock_ns: f64,
    },
}

impl Pipelining {
    /// One line for headers and reports.
    pub fn describe(&self) -> String {
        match self {
            Pipelining::Compact => {
                "compact (a register after every quantization and table read)".into()
            }
            Pipelining::Target { target, clock_ns } => format!(
                "target {target} at {clock_ns} ns ({:.1} MHz)",
                1000.0 / clock_ns
            ),
        }
    }
}

/// How a generated module's stages hand items on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Handshake {
    /// One global stall, a register: every stage holds while the
    /// two-entry output buffer (the head register, which drives the
    /// ports, and a skid register) is full; `ready_o = en`.
    Stall,
    /// A pipeline that never stalls, ending in an output FIFO with room
    /// for every item in flight and a head register; `ready_o` is a
    /// registered credit check.
    Fifo,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_are_ceilings() {
        assert_eq!(ceil_log(1, 4), 0);
        assert_eq!(ceil_log(4, 4), 1);
        assert_eq!(ceil_log(5, 4), 2);
        assert_eq!(ceil_log(16, 4), 2);
        assert_eq!(ceil_log(3, 2), 2);
    }

    #[test]
    fn a_dsp_tile_is_one_block_and_wider_products_sum_tiles() {
        let m = crate::targets::ecp5::DELAY;
        let d = m.dsp.unwrap();
        assert_eq!(m.mul(18, 18), d.comb);
        // 19 × 18 needs two tiles and one level summing them.
        assert!((m.mul(19, 18) - d.comb - d.combine).abs() < 1e-12);
        // LUT multipliers grow with the narrower operand.
        let h = crate::targets::ice40_hx8k::DELAY;
        assert!(h.mul(16, 8) < h.mul(16, 16));
        assert_eq!(h.mul(16, 8), h.mul(8, 16));
    }
}
