//! Interval evaluation of a compiled program: for every input in a range of
//! codes, bounds that provably contain every output code.
//!
//! Each node holds `[lo, hi]` in its own binary point, computed exactly in
//! `i128` (the program's intermediates fit there): a product takes the
//! smallest and largest of the four endpoint products, a sum or difference
//! the aligned endpoint sums, a maximum the endpoint maxima. Every
//! quantization is monotonic (floor, ceiling and the nearest modes never
//! reorder codes, and saturation clamps monotonically), so its endpoints'
//! quantizations bound it — unless wrap-around could occur, where the
//! evaluation gives up (`None`) and the caller splits the range.
//! Table reads, divisions and square roots give up too (not needed by the
//! units this serves).
//!
//! The bounds are rigorous, not tight: a value used twice (`d` in Horner's
//! scheme) is treated as two independent ranges, so the width of the
//! output bound shrinks with the width of the input range.

use super::{Instr, Program};
use crate::quantize::{Overflow, Raw, Step};
use fxshade_numbers::convert::narrow;

impl<R: Raw> Program<R> {
    /// Bounds `[lo, hi]` on every output code over the box of input codes
    /// `inputs[i] = (lo_i, hi_i)`, or `None` where the evaluation cannot
    /// bound an operation (possible wrap-around, a table, a division or a
    /// square root, a non-constant selector).
    ///
    /// # Panics
    ///
    /// When `inputs` does not hold one range per input port, or a range has
    /// `lo > hi`.
    pub fn run_interval(&self, inputs: &[(i128, i128)]) -> Option<Vec<(i128, i128)>> {
        assert_eq!(inputs.len(), self.inputs.len(), "one range per input port");
        assert!(
            inputs.iter().all(|r| r.0 <= r.1),
            "input ranges are ordered"
        );
        let (r, may) = self.box_ranges(inputs);
        // A quantization that may wrap: the bound would be its whole
        // format, useless to a caller that splits ranges instead.
        let wraps = self.instrs.iter().any(|ins| {
            matches!(*ins, Instr::Quant { d, overflow: Overflow::Wrap, .. } if may[d])
                || matches!(
                    ins,
                    Instr::Table { .. } | Instr::Div { .. } | Instr::Sqrt { .. }
                )
        });
        (!wraps).then(|| self.outputs.iter().map(|&(o, _)| r[o]).collect())
    }
}

impl<R: Raw> Program<R> {
    /// For every node, whether a quantization there can overflow for some
    /// input in the box `inputs` (a sound over-approximation: `false`
    /// proves it never does). Where one may overflow, its output is taken
    /// as its whole format (true of wrap and saturate alike); table reads
    /// span their contents, selections the union of their options, and
    /// divisions and square roots are assumed to overflow.
    pub fn may_overflow(&self, inputs: &[(i128, i128)]) -> Vec<bool> {
        self.box_ranges(inputs).1
    }

    /// The register of the operand of the quantization at `node`.
    pub(super) fn quant_operand(&self, node: usize) -> Option<usize> {
        self.instrs.iter().find_map(|ins| match *ins {
            Instr::Quant { d, a, .. } if d == node => Some(a),
            _ => None,
        })
    }

    /// The range of the exact operand of the quantization at `node` over the
    /// box `inputs` (sound, as [`Program::may_overflow`]), or `None` when
    /// `node` is not a quantization of the program.
    pub fn quant_operand_range(
        &self,
        inputs: &[(i128, i128)],
        node: usize,
    ) -> Option<(i128, i128)> {
        let a = self.quant_operand(node)?;
        Some(self.box_ranges(inputs).0[a])
    }

    /// The range of node `node`'s code over the box `inputs` (sound, as
    /// [`Program::may_overflow`]; a quantization that may wrap across a
    /// period of its format gets the whole format).
    pub fn node_range(&self, inputs: &[(i128, i128)], node: usize) -> (i128, i128) {
        self.box_ranges(inputs).0[node]
    }

    /// [`Program::node_range`] of each of `nodes`, from one evaluation.
    pub fn node_ranges(&self, inputs: &[(i128, i128)], nodes: &[usize]) -> Vec<(i128, i128)> {
        let r = self.box_ranges(inputs).0;
        nodes.iter().map(|&n| r[n]).collect()
    }

    /// Bits known to be zero at the bottom of the exact operand of the
    /// quantization at `node`, for every input in the box `inputs` (a
    /// sound under-count; 127 for an operand that is always 0), or `None`
    /// when `node` is not a quantization of the program. A rounding that
    /// drops no more bits than this never rounds.
    pub fn quant_operand_zeros(&self, inputs: &[(i128, i128)], node: usize) -> Option<u32> {
        let a = self.quant_operand(node)?;
        Some(self.known_zeros(inputs)[a])
    }

    /// For every node, how many low bits of its code are zero for every
    /// input in the box: a constant's trailing zeros, a product's sum of
    /// its operands', a sum's least of its aligned operands', a
    /// quantization's operand's less the bits it drops (none left when it
    /// rounds or may saturate). Capped at 127.
    fn known_zeros(&self, inputs: &[(i128, i128)]) -> Vec<u32> {
        const CAP: u32 = 127;
        let tz = |c: i128| {
            if c == 0 {
                CAP
            } else {
                c.trailing_zeros().min(CAP)
            }
        };
        let (_, may) = self.box_ranges(inputs);
        let mut z = vec![0u32; self.n_regs];
        for &(d, c) in &self.consts {
            z[d] = tz(c.to_i128());
        }
        for (&(d, _), &(lo, hi)) in self.inputs.iter().zip(inputs) {
            z[d] = if lo == hi { tz(lo) } else { 0 };
        }
        let sh = |v: u32, s: u32| (v + s).min(CAP);
        for ins in &self.instrs {
            match *ins {
                Instr::Mul { d, a, b } => z[d] = (z[a] + z[b]).min(CAP),
                Instr::AddSub {
                    d, a, sa, b, sb, ..
                }
                | Instr::Max { d, a, sa, b, sb } => z[d] = sh(z[a], sa).min(sh(z[b], sb)),
                Instr::AddSigned {
                    d, a, sa, b, sb, ..
                } => z[d] = sh(z[a], sa).min(sh(z[b], sb)),
                Instr::Quant {
                    d,
                    a,
                    step,
                    overflow,
                    ..
                } => {
                    let kept = if step.shift <= 0 {
                        sh(z[a], step.shift.unsigned_abs())
                    } else {
                        z[a].saturating_sub(step.shift.unsigned_abs())
                    };
                    // Saturation replaces the code by an end of the format;
                    // wrap-around keeps the low bits.
                    z[d] = if may[d] && overflow == Overflow::Saturate {
                        0
                    } else {
                        kept.min(step.width)
                    };
                }
                Instr::Select { d, ref opts, .. } => {
                    z[d] = opts.iter().map(|&(o, s)| sh(z[o], s)).min().unwrap_or(0)
                }
                Instr::Table { d, table, .. } => {
                    z[d] = self.tables[table]
                        .iter()
                        .map(|c| tz(c.to_i128()))
                        .min()
                        .unwrap_or(0)
                }
                Instr::Div { d, .. } | Instr::Sqrt { d, .. } => z[d] = 0,
            }
        }
        z
    }

    /// A congruence `x ≡ offset (mod stride)` every value of the exact
    /// operand of the quantization at `node` satisfies, for every input in
    /// the box `inputs` (`stride` 0: the operand is the single value
    /// `offset`; `stride` 1: nothing known), or `None` when `node` is not a
    /// quantization of the program. With the operand's interval it decides
    /// exactly whether an affine operand can meet a rounding tie
    /// (`16320·K ≡ 2^24 (mod 2^26)` has one solution `K` where the
    /// interval alone admits one in every 4 112).
    pub fn quant_operand_congruence(
        &self,
        inputs: &[(i128, i128)],
        node: usize,
    ) -> Option<(i128, i128)> {
        let a = self.quant_operand(node)?;
        Some(self.congruences(inputs)[a])
    }

    /// For every node, `(stride, offset)` with every value `≡ offset (mod
    /// stride)` over the box (the congruence domain: a product of
    /// `o₁ + s₁·i` and `o₂ + s₂·j` is `o₁o₂` modulo `gcd(o₁s₂, o₂s₁,
    /// s₁s₂)`, a sum `o₁ + o₂` modulo `gcd(s₁, s₂)`; a quantization keeps
    /// the congruence only when it cannot overflow and its stride is a
    /// multiple of twice the step, so that every value rounds alike).
    fn congruences(&self, inputs: &[(i128, i128)]) -> Vec<(i128, i128)> {
        let (_, may) = self.box_ranges(inputs);
        self.congruences_with(inputs, &may)
    }

    /// [`Program::quant_operand_range`] and, where `need` asks for it
    /// given that range, [`Program::quant_operand_congruence`] (else
    /// `None`), from one interval pass where the two calls take two; `None`
    /// when `node` is not a quantization of the program.
    pub fn quant_operand_range_congruence(
        &self,
        inputs: &[(i128, i128)],
        node: usize,
        need: impl FnOnce((i128, i128)) -> bool,
    ) -> Option<RangeCongruence> {
        let a = self.quant_operand(node)?;
        let (r, may) = self.box_ranges(inputs);
        let range = r[a];
        Some((
            range,
            need(range).then(|| self.congruences_with(inputs, &may)[a]),
        ))
    }

    /// [`Program::congruences`] given the box's may-overflow flags
    /// ([`Program::box_ranges`]).
    pub(super) fn congruences_with(
        &self,
        inputs: &[(i128, i128)],
        may: &[bool],
    ) -> Vec<(i128, i128)> {
        let mut c = self.congruence_init(inputs);
        for ins in &self.instrs {
            Self::congruence_step(ins, &mut c, may);
        }
        c
    }

    /// The congruences before any instruction: constants' and inputs'
    /// (a single code is itself modulo 0, a range of codes anything), the
    /// rest unknown (`(1, 0)`).
    pub(super) fn congruence_init(&self, inputs: &[(i128, i128)]) -> Vec<(i128, i128)> {
        let mut c = vec![(1i128, 0i128); self.n_regs];
        for &(d, k) in &self.consts {
            c[d] = (0, k.to_i128());
        }
        for (&(d, _), &(lo, hi)) in self.inputs.iter().zip(inputs) {
            c[d] = Self::input_congruence((lo, hi));
        }
        c
    }

    /// An input's congruence over the codes `lo..=hi`.
    pub(super) fn input_congruence((lo, hi): (i128, i128)) -> (i128, i128) {
        if lo == hi {
            (0, lo)
        } else {
            (1, 0)
        }
    }

    /// One instruction of [`Program::congruences_with`]: its destination's
    /// congruence from its operands' and whether it may overflow.
    #[inline(always)]
    pub(super) fn congruence_step(ins: &Instr, c: &mut [(i128, i128)], may: &[bool]) {
        let r = match *ins {
            Instr::Mul { a, b, .. } => {
                let ((sa, oa), (sb, ob)) = (c[a], c[b]);
                (|| {
                    let s = gcd(
                        gcd(oa.checked_mul(sb)?, ob.checked_mul(sa)?),
                        sa.checked_mul(sb)?,
                    );
                    Some((s, oa.checked_mul(ob)?))
                })()
            }
            Instr::AddSub {
                a, sa, b, sb, sub, ..
            } => (|| {
                let (x, y) = (shl(c[a], sa)?, shl(c[b], sb)?);
                let o = if sub {
                    x.1.checked_sub(y.1)?
                } else {
                    x.1.checked_add(y.1)?
                };
                Some((gcd(x.0, y.0), o))
            })(),
            Instr::Max { a, sa, b, sb, .. } => (|| {
                let (x, y) = (shl(c[a], sa)?, shl(c[b], sb)?);
                Some((gcd(gcd(x.0, y.0), x.1.checked_sub(y.1)?), x.1))
            })(),
            Instr::AddSigned { a, sa, b, sb, .. } => (|| {
                let (x, y) = (shl(c[a], sa)?, shl(c[b], sb)?);
                Some((
                    gcd(gcd(x.0, y.0), y.1.checked_mul(2)?),
                    x.1.checked_add(y.1)?,
                ))
            })(),
            Instr::Quant {
                d,
                a,
                step,
                round,
                overflow,
                ..
            } => {
                let (sx, ox) = c[a];
                // The rounded code's congruence, overflow aside.
                let rounded = if sx == 0 {
                    let wide = Step {
                        min: i128::MIN,
                        max: i128::MAX,
                        ..step
                    };
                    let q = wide.apply(ox, round, Overflow::Saturate);
                    (!q.overflowed).then_some((0, q.code))
                } else if step.shift <= 0 {
                    shl((sx, ox), step.shift.unsigned_abs())
                } else if step.shift < 126 && sx % (1i128 << (step.shift + 1)) == 0 {
                    Some((
                        sx >> step.shift,
                        crate::quantize::round_shift_right(ox, step.shift.unsigned_abs(), round),
                    ))
                } else {
                    None
                };
                if !may[d] {
                    rounded
                } else if overflow == Overflow::Wrap && step.width < 126 {
                    // Wrapping subtracts a multiple of 2^width, which
                    // keeps the code's class modulo any divisor of it.
                    rounded.map(|(s, o)| (gcd(s, 1i128 << step.width), o))
                } else {
                    None
                }
            }
            Instr::Select { ref opts, .. } => (|| {
                let mut acc: Option<(i128, i128)> = None;
                for &(o, sh) in opts {
                    let x = shl(c[o], sh)?;
                    acc = Some(match acc {
                        None => x,
                        Some(p) => (gcd(gcd(p.0, x.0), p.1.checked_sub(x.1)?), p.1),
                    });
                }
                acc
            })(),
            Instr::Table { .. } | Instr::Div { .. } | Instr::Sqrt { .. } => None,
        };
        let d = ins.dest();
        c[d] = match r {
            Some((0, o)) => (0, o),
            Some((s, o)) => (s.abs(), o.rem_euclid(s.abs())),
            None => (1, 0),
        };
    }

    /// Every node's range over the box, and whether each quantization may
    /// overflow there.
    pub(super) fn box_ranges(&self, inputs: &[(i128, i128)]) -> (Vec<(i128, i128)>, Vec<bool>) {
        let (mut r, mut may) = self.interval_init(inputs);
        for ins in &self.instrs {
            self.interval_step(ins, &mut r, &mut may);
        }
        (r, may)
    }

    /// The ranges before any instruction: constants' and inputs', the
    /// rest `(0, 0)`; no quantization overflowing.
    pub(super) fn interval_init(&self, inputs: &[(i128, i128)]) -> (Vec<(i128, i128)>, Vec<bool>) {
        let mut r = vec![(0i128, 0i128); self.n_regs];
        let may = vec![false; self.n_regs];
        for &(d, c) in &self.consts {
            r[d] = (c.to_i128(), c.to_i128());
        }
        for (&(d, _), &(lo, hi)) in self.inputs.iter().zip(inputs) {
            r[d] = (lo, hi);
        }
        (r, may)
    }

    /// One instruction of [`Program::box_ranges`]: its destination's range
    /// from its operands' and, for a quantization, whether it may
    /// overflow (a division or square root always may).
    #[inline(always)]
    pub(super) fn interval_step(&self, ins: &Instr, r: &mut [(i128, i128)], may: &mut [bool]) {
        let hull = |v: &[i128]| {
            (
                *v.iter().min().expect("some"),
                *v.iter().max().expect("some"),
            )
        };
        match *ins {
            Instr::Mul { d, a, b } => {
                let (x, y) = (r[a], r[b]);
                r[d] = hull(&[x.0 * y.0, x.0 * y.1, x.1 * y.0, x.1 * y.1]);
            }
            Instr::AddSub {
                d,
                a,
                sa,
                b,
                sb,
                sub,
            } => {
                let x = (r[a].0 << sa, r[a].1 << sa);
                let y = (r[b].0 << sb, r[b].1 << sb);
                r[d] = if sub {
                    (x.0 - y.1, x.1 - y.0)
                } else {
                    (x.0 + y.0, x.1 + y.1)
                };
            }
            Instr::Max { d, a, sa, b, sb } => {
                let x = (r[a].0 << sa, r[a].1 << sa);
                let y = (r[b].0 << sb, r[b].1 << sb);
                r[d] = (x.0.max(y.0), x.1.max(y.1));
            }
            Instr::AddSigned {
                d,
                a,
                sa,
                b,
                sb,
                s,
                flip,
            } => {
                // `a ± b` for `s` in `rs`: subtract when `s < 0`
                // (`s ≥ 0` with `flip`), an operand that is `s` itself
                // taken over `rs` only.
                let half = |rs: (i128, i128), sub: bool| {
                    let pick = |n: usize| if n == s { rs } else { r[n] };
                    let (ra, rb) = (pick(a), pick(b));
                    let x = (ra.0 << sa, ra.1 << sa);
                    let y = (rb.0 << sb, rb.1 << sb);
                    if sub {
                        (x.0 - y.1, x.1 - y.0)
                    } else {
                        (x.0 + y.0, x.1 + y.1)
                    }
                };
                let rs = r[s];
                r[d] = if rs.1 < 0 {
                    half(rs, !flip)
                } else if rs.0 >= 0 {
                    half(rs, flip)
                } else {
                    // Either sign: each half of `s`'s range on its own
                    // (a CORDIC step `y ∓ x·2^-i` steered by `y`'s sign
                    // moves `y` towards zero, which the hull of the two
                    // whole-range results loses).
                    let (n, p) = (half((rs.0, -1), !flip), half((0, rs.1), flip));
                    (n.0.min(p.0), n.1.max(p.1))
                };
            }
            Instr::Quant {
                d,
                a,
                step,
                round,
                overflow,
                ..
            } => {
                let lo = step.apply(r[a].0, round, overflow);
                let hi = step.apply(r[a].1, round, overflow);
                may[d] = lo.overflowed || hi.overflowed;
                // Rounding and saturation are monotonic; wrap-around is
                // monotonic only within one period of 2^width codes, and
                // may land anywhere in the format when the rounded
                // interval spans two periods.
                r[d] = if may[d] && overflow == Overflow::Wrap {
                    let wide = Step {
                        min: i128::MIN,
                        max: i128::MAX,
                        ..step
                    };
                    let (rl, rh) = (
                        wide.apply(r[a].0, round, Overflow::Saturate),
                        wide.apply(r[a].1, round, Overflow::Saturate),
                    );
                    let one_period = !rl.overflowed
                        && !rh.overflowed
                        && step.width < 126
                        && rh.code - rl.code < 1i128 << step.width
                        && lo.code <= hi.code;
                    if one_period {
                        (lo.code, hi.code)
                    } else {
                        (step.min, step.max)
                    }
                } else {
                    (lo.code, hi.code)
                };
            }
            Instr::Select {
                d, sel, ref opts, ..
            } if r[sel].0 == r[sel].1 => {
                let s0 = r[sel].0;
                let (o, sh) = if let Some(&o) = usize::try_from(s0).ok().and_then(|i| opts.get(i)) {
                    o
                } else {
                    opts[0]
                };
                r[d] = (r[o].0 << sh, r[o].1 << sh);
            }
            Instr::Select {
                d,
                sel: _,
                ref opts,
                ..
            } => {
                r[d] = opts
                    .iter()
                    .fold((i128::MAX, i128::MIN), |(lo, hi), &(o, sh)| {
                        let (a, b) = (r[o].0 << sh, r[o].1 << sh);
                        (lo.min(a).min(b), hi.max(a).max(b))
                    });
            }
            Instr::Table { d, a, table, index } => {
                // The entries the index range reads (every entry when
                // it spans the table).
                let t = &self.tables[table];
                let (lo, hi) = r[a];
                let hull = &self.table_hulls[table];
                let mask = t.len().wrapping_sub(1);
                r[d] = if hi - lo >= t.len() as i128 {
                    hull.whole
                } else if t.len().is_power_of_two() && t.len().trailing_zeros() <= index.width() {
                    // Consecutive codes read consecutive slots (the
                    // index's bits modulo the table's length), past
                    // the last slot on from slot 0.
                    let first = super::table_slot(index.to_bits(lo), mask);
                    hull.range(t, first, narrow::<usize, _>(hi - lo) + 1)
                } else {
                    (lo..=hi).fold((i128::MAX, i128::MIN), |(mn, mx), x| {
                        let c = t[super::table_slot(index.to_bits(x), mask)].to_i128();
                        (mn.min(c), mx.max(c))
                    })
                };
            }
            Instr::Div { d, q, .. } | Instr::Sqrt { d, q, .. } => {
                may[d] = true;
                r[d] = (q.format().min_code(), q.format().max_code());
            }
        }
    }
}

/// A table's entries' hull, whole and per block of [`TableHull::BLOCK`]
/// entries, for the range of the entries a range of index codes reads
/// without visiting each.
#[derive(Clone, Debug)]
pub(super) struct TableHull {
    /// The smallest and largest entry.
    pub(super) whole: (i128, i128),
    /// The same per block of entries (the last may be shorter).
    blocks: Vec<(i128, i128)>,
}

impl TableHull {
    /// Entries per block.
    const BLOCK: usize = 32;

    /// The hulls of `codes` (`(0, 0)` when empty).
    pub(super) fn of(codes: &[i128]) -> TableHull {
        let hull = |c: &[i128]| {
            c.iter()
                .fold(None, |h: Option<(i128, i128)>, &x| {
                    Some(h.map_or((x, x), |(lo, hi)| (lo.min(x), hi.max(x))))
                })
                .unwrap_or((0, 0))
        };
        TableHull {
            whole: hull(codes),
            blocks: codes.chunks(Self::BLOCK).map(hull).collect(),
        }
    }

    /// The smallest and largest of the `count` entries of `t` from slot
    /// `first` on, wrapping past the last slot to slot 0 (`count` at most
    /// `t.len()`, at least 1): those of whole blocks from the blocks'
    /// hulls, the rest entry by entry. The same pair as visiting every
    /// entry.
    pub(super) fn range<R: Raw>(&self, t: &[R], first: usize, count: usize) -> (i128, i128) {
        let mut h = (i128::MAX, i128::MIN);
        let end = first + count;
        // One or two runs of slots (the second after wrapping to 0).
        for (s, e) in [(first, end.min(t.len())), (0, end.saturating_sub(t.len()))] {
            let mut i = s;
            while i < e {
                let (lo, hi) = if i.is_multiple_of(Self::BLOCK) && i + Self::BLOCK <= e {
                    let b = self.blocks[i / Self::BLOCK];
                    i += Self::BLOCK;
                    b
                } else {
                    let c = t[i].to_i128();
                    i += 1;
                    (c, c)
                };
                h = (h.0.min(lo), h.1.max(hi));
            }
        }
        h
    }
}

/// A quantization operand's range `(lo, hi)` over a box and, if asked
/// for, its congruence `(stride, offset)`
/// ([`Program::quant_operand_range_congruence`]).
pub type RangeCongruence = ((i128, i128), Option<(i128, i128)>);

/// `gcd(|a|, |b|)` (`gcd(0, 0) = 0`), saturated at `i128::MAX` (only
/// `gcd(i128::MIN, 0)` and `gcd(i128::MIN, i128::MIN)` are larger). By
/// Stein's binary algorithm: shifts and subtractions, where Euclid's
/// `u128` remainders are software divisions.
fn gcd(a: i128, b: i128) -> i128 {
    let (mut a, mut b) = (a.unsigned_abs(), b.unsigned_abs());
    if a == 0 || b == 0 {
        return i128::try_from(a | b).unwrap_or(i128::MAX);
    }
    let twos = (a | b).trailing_zeros();
    a >>= a.trailing_zeros();
    loop {
        b >>= b.trailing_zeros();
        if a > b {
            std::mem::swap(&mut a, &mut b);
        }
        b -= a;
        if b == 0 {
            break;
        }
    }
    i128::try_from(a << twos).unwrap_or(i128::MAX)
}

/// A congruence scaled by `2^s`, if it fits.
fn shl((s, o): (i128, i128), sh: u32) -> Option<(i128, i128)> {
    let k = 1i128.checked_shl(sh)?;
    Some((s.checked_mul(k)?, o.checked_mul(k)?))
}

#[cfg(test)]
mod tests {
    use super::gcd;
    use crate::datapath::{Compiled, Datapath, Trace};
    use crate::format::Format;
    use crate::quantize::{Overflow, Quant, Rounding};

    /// A random sub-range of `lo..=hi` (a single code when `point`).
    fn random_range(
        rng: &mut crate::sampling::Rng,
        lo: i128,
        hi: i128,
        point: bool,
    ) -> (i128, i128) {
        let a = lo + rng.below((hi - lo + 1) as u64) as i128;
        let b = if point {
            a
        } else {
            lo + rng.below((hi - lo + 1) as u64) as i128
        };
        (a.min(b), a.max(b))
    }

    /// Every point of a two-input box, as two input columns.
    fn box_lanes(bx: &[(i128, i128); 2]) -> (Vec<i128>, Vec<i128>) {
        (bx[0].0..=bx[0].1)
            .flat_map(|a| (bx[1].0..=bx[1].1).map(move |b| (a, b)))
            .unzip()
    }

    /// The bounds contain every output of every input in the range
    /// (checked against the lane-by-lane run), for a Horner quadratic.
    /// Stein's gcd against Euclid's on edge and random values of every
    /// sign and size.
    /// The hull of a wrapping run of slots from the blocks' hulls is the
    /// hull of its entries visited one by one: tables of 1 to 2 048
    /// entries (whole blocks or not), every start, runs of 1 to the whole
    /// table.
    #[test]
    fn table_hull_ranges_are_the_entries_hulls() {
        let mut rng = crate::sampling::Rng::new(11);
        for len in [1usize, 5, 31, 32, 33, 64, 100, 2048] {
            let t: Vec<i64> = (0..len)
                .map(|_| i64::try_from(rng.below(1 << 20)).unwrap() - (1 << 19))
                .collect();
            let codes: Vec<i128> = t.iter().map(|&c| i128::from(c)).collect();
            let hull = super::TableHull::of(&codes);
            assert_eq!(
                hull.whole,
                (*codes.iter().min().unwrap(), *codes.iter().max().unwrap())
            );
            for _ in 0..400 {
                let first = usize::try_from(rng.below(len as u64)).unwrap();
                let count = 1 + usize::try_from(rng.below(len as u64)).unwrap();
                let run: Vec<i128> = (0..count).map(|i| codes[(first + i) % len]).collect();
                let want = (*run.iter().min().unwrap(), *run.iter().max().unwrap());
                assert_eq!(hull.range(&t, first, count), want, "{len} {first} {count}");
            }
        }
    }

    #[test]
    fn binary_gcd_is_euclids() {
        fn euclid(a: i128, b: i128) -> i128 {
            let (mut a, mut b) = (a.unsigned_abs(), b.unsigned_abs());
            while b != 0 {
                (a, b) = (b, a % b);
            }
            i128::try_from(a).unwrap_or(i128::MAX)
        }
        let mut rng = crate::sampling::Rng::new(9);
        let mut vals = vec![
            0,
            1,
            -1,
            2,
            3,
            6,
            -12,
            1 << 40,
            i128::MAX,
            i128::MIN,
            i128::MIN + 1,
        ];
        for _ in 0..400 {
            let k = rng.below(127) as u32;
            let v = i128::from(rng.below(u64::MAX)) << k.min(63);
            let v = v >> rng.below(64);
            vals.push(if rng.below(2) == 0 { v } else { -v });
            // Shared factors, so that the gcd is not always 1.
            vals.push((3 * 5 * 7 * i128::from(rng.below(1 << 30))) << rng.below(40));
        }
        for &a in &vals {
            for &b in vals.iter().step_by(7) {
                assert_eq!(gcd(a, b), euclid(a, b), "gcd({a}, {b})");
            }
        }
    }

    #[test]
    fn bounds_contain_every_lane() {
        let q = |s, f: &str, r| Quant::new(s, f.parse::<Format>().unwrap(), r, Overflow::Saturate);
        let mut tr = Trace::new();
        let d = tr.input(&q("d", "U1F12", Rounding::Trunc));
        let c2 = tr
            .constant(0.375, &q("c", "I3F10", Rounding::HalfEven))
            .unwrap();
        let c1 = tr
            .constant(-1.25, &q("c", "I3F10", Rounding::HalfEven))
            .unwrap();
        let c0 = tr
            .constant(1.875, &q("c", "I3F10", Rounding::HalfEven))
            .unwrap();
        let t = tr.mul(c2, d);
        let t = tr.add(t, c1);
        let t = tr.quantize(t, &q("t", "I2F9", Rounding::HalfEven));
        let t = tr.mul(t, d);
        let t = tr.add(t, c0);
        let g = tr.quantize(t, &q("g", "U2F8", Rounding::HalfUp));
        let Compiled::Narrow(p) = Compiled::compile(&tr, &[g]).unwrap() else {
            panic!("narrow")
        };
        let codes: Vec<i64> = (0..8192).collect();
        let (out, _) = p.run(&[&codes]);
        for (lo, hi) in [(0, 0), (100, 163), (4000, 8191), (0, 8191), (777, 778)] {
            let b = p.run_interval(&[(lo, hi)]).unwrap()[0];
            let (mn, mx) = out[0][lo as usize..=hi as usize]
                .iter()
                .fold((i64::MAX, i64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            assert!(
                b.0 <= mn as i128 && mx as i128 <= b.1,
                "{lo}..{hi}: {b:?} vs {mn}..{mx}"
            );
            if lo == hi {
                assert_eq!(b, (mn as i128, mx as i128), "a point is evaluated exactly");
            }
        }
    }

    /// Three CORDIC vectoring steps (`x ± y·2^-i`, `y ∓ x·2^-i`, steered
    /// by `y`'s own sign, as in `angles`) and an angle accumulator that
    /// wraps modulo its format, and a product wrapped into 5 bits: over
    /// random boxes, straddling zero or not, every quantizer operand lies
    /// in its interval and every quantized code in its node's range (the analysis splits a self-steered step
    /// at zero and keeps a wrap inside one period monotonic). The bound on
    /// the last `y` is also checked to be tighter than the hull of both
    /// steering choices.
    #[test]
    fn self_steered_steps_and_one_period_wraps_hold_on_every_lane() {
        let q = |s, f: &str, r, o| Quant::new(s, f.parse::<Format>().unwrap(), r, o);
        let mut tr = Trace::new();
        let x0 = tr.input(&q("x", "U1F6", Rounding::Trunc, Overflow::Saturate));
        let y0 = tr.input(&q("y", "I1F6", Rounding::Trunc, Overflow::Saturate));
        let zero = tr
            .constant(0.0, &q("t", "U0F8", Rounding::HalfEven, Overflow::Wrap))
            .unwrap();
        let xy = q("xy", "I3F8", Rounding::Trunc, Overflow::Saturate);
        let th = q("th", "U0F8", Rounding::HalfEven, Overflow::Wrap);
        let (mut x, mut y, mut t) = (x0, y0, zero);
        let mut quants = Vec::new();
        let mut thetas = Vec::new();
        for i in 0..3 {
            let at = tr
                .constant(
                    (0.5f64.powi(i)).atan() / std::f64::consts::TAU,
                    &q("a", "U0F8", Rounding::HalfEven, Overflow::Wrap),
                )
                .unwrap();
            let ys = tr.shl(y, -i);
            let xs = tr.shl(x, -i);
            let nx = tr.add_signed(x, ys, y, false);
            let ny = tr.add_signed(y, xs, y, true);
            let nt = tr.add_signed(t, at, y, false);
            x = tr.quantize(nx, &xy);
            y = tr.quantize(ny, &xy);
            t = tr.quantize(nt, &th);
            quants.extend([x.node(), y.node(), t.node()]);
            thetas.push(t.node());
        }
        // A product wrapped into few bits: its range spans many periods
        // over a wide box, one over a narrow one.
        let p = tr.mul(x0, y0);
        let pw = tr.quantize(p, &q("p", "I1F3", Rounding::HalfUp, Overflow::Wrap));
        quants.push(pw.node());
        let c = Compiled::compile(&tr, &[x, y, t, pw]).unwrap();
        let tvs: Vec<_> = quants.iter().map(|&n| tr.value(n)).collect();
        let all = Compiled::compile(&tr, &tvs).unwrap();
        let mut rng = crate::sampling::Rng::new(7);
        let mut tighter = false;
        for round in 0..300 {
            let point = round % 4 == 0;
            let bx = [
                random_range(&mut rng, 0, 127, point),
                random_range(&mut rng, -128, 127, point),
            ];
            let (ca, cb) = box_lanes(&bx);
            let operands = c.probe_i128(&[&ca, &cb], &quants);
            let (probes, _) = all.run_flags_i128(&[&ca, &cb]);
            for (k, &n) in quants.iter().enumerate() {
                let (rl, rh) = c.node_range(&bx, n);
                for &v in &probes[k] {
                    assert!(
                        rl <= v && v <= rh,
                        "node {n} box {bx:?}: {v} outside {rl}..{rh}"
                    );
                }
                let (lo, hi) = c.quant_operand_range(&bx, n).unwrap();
                let (st, off) = c.quant_operand_congruence(&bx, n).unwrap();
                // The two from one pass: the same, the congruence on demand.
                assert_eq!(
                    c.quant_operand_range_congruence(&bx, n, |r| r == (lo, hi)),
                    Some(((lo, hi), Some((st, off))))
                );
                assert_eq!(
                    c.quant_operand_range_congruence(&bx, n, |_| false),
                    Some(((lo, hi), None))
                );
                for &v in &operands[k] {
                    assert!(
                        lo <= v && v <= hi,
                        "operand of {n} box {bx:?}: {v} outside {lo}..{hi}"
                    );
                    assert!(
                        st == 0 && v == off || st > 0 && v.rem_euclid(st) == off,
                        "operand of {n} box {bx:?}: {v} not ≡ {off} mod {st}"
                    );
                }
            }
            // The angle's parity survives the wraps: odd after ±32, ±19.
            let last = *thetas.last().unwrap();
            let (st, off) = c.quant_operand_congruence(&bx, last).unwrap();
            assert!(st == 2 && off == 1 || st == 0 && off % 2 == 1, "{st} {off}");
            // The last y: a box straddling y = 0 is where splitting at the
            // sign pays.
            if bx[1].0 < 0 && bx[1].1 >= 0 && bx[0].0 > 16 {
                let (lo, hi) = c.node_range(&bx, y.node());
                let hull = (bx[1].1 - bx[1].0) + 2 * bx[0].1 * 4;
                tighter |= hi - lo < hull;
            }
        }
        assert!(tighter, "the split bound was never tighter than the hull");
    }

    /// The congruence, known-zero and table-range analyses hold on every
    /// lane: over random boxes (points among them) of a datapath with
    /// products, sums, a maximum, exact and rounding quantizations and a
    /// table read, every quantizer operand lies in its interval, is `≡
    /// offset (mod stride)`, and has its known low zero bits.
    #[test]
    fn congruences_and_zeros_hold_on_every_lane() {
        let q = |s, f: &str, r| Quant::new(s, f.parse::<Format>().unwrap(), r, Overflow::Saturate);
        let mut tr = Trace::new();
        let a = tr.input(&q("a", "I1F7", Rounding::Trunc));
        let b = tr.input(&q("b", "U0F8", Rounding::Trunc));
        let k = tr
            .constant(0.75, &q("k", "U0F4", Rounding::HalfEven))
            .unwrap();
        let w = tr.quantize(a, &q("w", "I3F11", Rounding::Trunc));
        let p = tr.mul(w, k);
        let bb = tr.mul(b, b);
        let s = tr.add(p, bb);
        let r1 = tr.quantize(s, &q("r1", "I3F9", Rounding::HalfEven));
        let m = tr.max(r1, w);
        let r2 = tr.quantize(m, &q("r2", "U0F6", Rounding::HalfUp));
        fn f(x: f64) -> f64 {
            (x * 3.0).sin()
        }
        let t = crate::datapath::Table::build(
            "t",
            "U0F6".parse().unwrap(),
            q("t", "I1F10", Rounding::HalfEven),
            f,
        )
        .unwrap();
        let tbl = tr.table(&t, r2);
        let e = tr.mul(tbl, b);
        let r3 = tr.quantize(e, &q("r3", "I1F6", Rounding::HalfEven));
        let nodes = [w.node(), r1.node(), r2.node(), r3.node()];
        let c = Compiled::compile(&tr, &[r3]).unwrap();
        let mut rng = crate::sampling::Rng::new(5);
        for round in 0..200 {
            let point = round % 3 == 0;
            let bx = [
                random_range(&mut rng, -128, 127, point),
                random_range(&mut rng, 0, 255, point),
            ];
            let (ca, cb) = box_lanes(&bx);
            let probes = c.probe_i128(&[&ca, &cb], &nodes);
            for (k, &n) in nodes.iter().enumerate() {
                let (lo, hi) = c.quant_operand_range(&bx, n).unwrap();
                let (st, off) = c.quant_operand_congruence(&bx, n).unwrap();
                let z = c.quant_operand_zeros(&bx, n).unwrap();
                for &x in &probes[k] {
                    assert!(
                        lo <= x && x <= hi,
                        "node {n} box {bx:?}: {x} outside {lo}..{hi}"
                    );
                    if st == 0 {
                        assert_eq!(x, off, "node {n} box {bx:?}");
                    } else {
                        assert_eq!(x.rem_euclid(st), off, "node {n} box {bx:?}: {x} mod {st}");
                    }
                    assert!(
                        x == 0 || x.trailing_zeros() >= z,
                        "node {n} box {bx:?}: {x} has fewer than {z} zeros"
                    );
                }
            }
        }
    }
}
