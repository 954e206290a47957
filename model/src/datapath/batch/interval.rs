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
use crate::quantize::{Overflow, Raw};

impl<R: Raw> Program<R> {
    /// Bounds `[lo, hi]` on every output code over the box of input codes
    /// `inputs[i] = (lo_i, hi_i)`, or `None` where the evaluation cannot
    /// bound an operation (possible wrap-around, a table, a division or a
    /// square root, a non-constant selector).
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

    /// The range of the exact operand of the quantization at `node` over the
    /// box `inputs` (sound, as [`Program::may_overflow`]), or `None` when
    /// `node` is not a quantization of the program.
    pub fn quant_operand_range(
        &self,
        inputs: &[(i128, i128)],
        node: usize,
    ) -> Option<(i128, i128)> {
        let a = self.instrs.iter().find_map(|ins| match *ins {
            Instr::Quant { d, a, .. } if d == node => Some(a),
            _ => None,
        })?;
        Some(self.box_ranges(inputs).0[a])
    }

    /// Every node's range over the box, and whether each quantization may
    /// overflow there.
    fn box_ranges(&self, inputs: &[(i128, i128)]) -> (Vec<(i128, i128)>, Vec<bool>) {
        let mut r = vec![(0i128, 0i128); self.n_regs];
        let mut may = vec![false; self.n_regs];
        for &(d, c) in &self.consts {
            r[d] = (c.to_i128(), c.to_i128());
        }
        for (&(d, _), &(lo, hi)) in self.inputs.iter().zip(inputs) {
            r[d] = (lo, hi);
        }
        let hull = |v: &[i128]| {
            (
                *v.iter().min().expect("some"),
                *v.iter().max().expect("some"),
            )
        };
        for ins in &self.instrs {
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
                    let x = (r[a].0 << sa, r[a].1 << sa);
                    let y = (r[b].0 << sb, r[b].1 << sb);
                    let add = (x.0 + y.0, x.1 + y.1);
                    let sub = (x.0 - y.1, x.1 - y.0);
                    // The sign of `s` over its range: known, or either.
                    let (neg, pos) = (r[s].0 < 0, r[s].1 >= 0);
                    let (can_sub, can_add) = if flip { (pos, neg) } else { (neg, pos) };
                    r[d] = match (can_sub, can_add) {
                        (true, false) => sub,
                        (false, true) => add,
                        _ => (add.0.min(sub.0), add.1.max(sub.1)),
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
                    // not, and may then land anywhere in the format.
                    r[d] = if may[d] && overflow == Overflow::Wrap {
                        (step.min, step.max)
                    } else {
                        (lo.code, hi.code)
                    };
                }
                Instr::Select { d, sel, ref opts } if r[sel].0 == r[sel].1 => {
                    let s0 = r[sel].0;
                    let (o, sh) = if (0..opts.len() as i128).contains(&s0) {
                        opts[s0 as usize]
                    } else {
                        opts[0]
                    };
                    r[d] = (r[o].0 << sh, r[o].1 << sh);
                }
                Instr::Select {
                    d,
                    sel: _,
                    ref opts,
                } => {
                    let v: Vec<i128> = opts
                        .iter()
                        .flat_map(|&(o, sh)| [r[o].0 << sh, r[o].1 << sh])
                        .collect();
                    r[d] = hull(&v);
                }
                Instr::Table { d, table, .. } => {
                    let v: Vec<i128> = self.tables[table].iter().map(|c| c.to_i128()).collect();
                    r[d] = hull(&v);
                }
                Instr::Div { d, q, .. } | Instr::Sqrt { d, q, .. } => {
                    may[d] = true;
                    r[d] = (q.format().min_code(), q.format().max_code());
                }
            }
        }
        (r, may)
    }
}

#[cfg(test)]
mod tests {
    use crate::datapath::{Compiled, Datapath, Trace};
    use crate::format::Format;
    use crate::quantize::{Overflow, Quant, Rounding};

    /// The bounds contain every output of every input in the range
    /// (checked against the lane-by-lane run), for a Horner quadratic.
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
}
