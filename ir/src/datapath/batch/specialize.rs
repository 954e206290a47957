//! A program specialized to lanes that differ only in some inputs: every
//! instruction none of those inputs reaches computes the same code in every
//! lane, so it runs once, here, and its code becomes a constant register.
//!
//! A search that sweeps one input of a row over its range (the killer
//! search's sweeps) runs each lane through the whole datapath although
//! most of it sees the same codes in every lane; the specialized program
//! runs only the instructions downstream of the swept input.
//!
//! Exactness: the folded codes come from the program itself, run on the
//! row as one lane with nothing fused (the engine's own arithmetic); a
//! folded quantization's overflow is its [`Step::apply`] on that lane's
//! operand, the call the block loop makes, and it is carried as flag bits
//! and counts every lane gets ([`Program`]`::base_flags`). So on lanes
//! whose fixed inputs hold the row's codes, the specialized program's
//! outputs, per-lane flags and per-stage overflow counts are the
//! program's.

use super::{Instr, Lanes, Overflows, Program, RegPool, BLOCK, IN_REGISTER};
use crate::quantize::Raw;

impl<R: Raw> Program<R> {
    /// This program for lanes whose inputs other than those marked in
    /// `varying` (one flag per input port) hold the codes of `row` (one
    /// code per input port): the instructions no varying input reaches are
    /// run once on `row` and become constants; the rest run per lane.
    /// Run it with every fixed input's slice holding its code of `row` in
    /// every lane; it then gives the outputs, per-lane overflow flags and
    /// per-stage overflow counts this program gives. `None` when a division
    /// or square root would be folded (their flags are set lane by lane in
    /// the block loop; no unit's search needs them folded).
    ///
    /// The interval analyses of the result ([`Program::run_interval`] and
    /// the rest) hold for boxes whose fixed inputs are `row`'s points; they
    /// do not see the folded quantizations, whose overflows are constant;
    /// [`Program::probe`] cannot name a folded quantization.
    ///
    /// # Panics
    ///
    /// When `row` or `varying` does not hold one entry per input port.
    pub fn specialize(&self, row: &[R], varying: &[bool]) -> Option<Program<R>> {
        assert_eq!(row.len(), self.inputs.len(), "one code per input port");
        assert_eq!(varying.len(), self.inputs.len(), "one flag per input port");
        // Which registers hold the same code in every lane.
        let mut uniform = vec![true; self.n_regs];
        for (&(d, _), &v) in self.inputs.iter().zip(varying) {
            uniform[d] = !v;
        }
        for ins in &self.instrs {
            let mut u = true;
            ins.each_operand(|a| u &= uniform[a]);
            uniform[ins.dest()] = u;
        }
        let folds = |ins: &Instr| uniform[ins.dest()];
        if self
            .instrs
            .iter()
            .any(|i| folds(i) && matches!(i, Instr::Div { .. } | Instr::Sqrt { .. }))
        {
            return None;
        }
        // The row as one lane, nothing fused: every instruction's code in
        // its register (or, for an output written in place, in `outs`).
        let inputs: Vec<&[R]> = row.iter().map(std::slice::from_ref).collect();
        let kept = self.pool.0.lock().ok().and_then(|mut p| p.pop());
        let mut regs = kept.unwrap_or_else(|| self.fresh_regs());
        self.load_block(&mut regs, &inputs, 0, 1);
        let mut outs: Vec<Vec<R>> = self.outputs.iter().map(|_| vec![R::ZERO]).collect();
        let mut ov = vec![0u64; self.stages.len()];
        let mut flags = [0u64; 1];
        let lanes = Lanes {
            inputs: &inputs,
            start: 0,
            len: 1,
        };
        let ovf = Overflows {
            counts: &mut ov,
            lanes: &mut flags,
            per_lane: true,
        };
        self.block_unfused(&mut regs, lanes, &mut outs, ovf);
        let (base_flags, base_overflows, instrs, consts) = {
            let code = |d: usize| -> R {
                match (self.out_of[d], self.port_of[d]) {
                    (IN_REGISTER, IN_REGISTER) => regs[d * BLOCK],
                    (IN_REGISTER, k) => row[k],
                    (k, _) => outs[k][0],
                }
            };
            let mut base_flags = self.base_flags;
            let mut base_overflows = self.base_overflows.clone();
            for ins in self.instrs.iter().filter(|i| folds(i)) {
                if let Instr::Quant {
                    a,
                    step,
                    round,
                    overflow,
                    stage,
                    flag,
                    ..
                } = *ins
                {
                    if step.apply(code(a), round, overflow).overflowed {
                        base_flags |= flag;
                        base_overflows.push(stage);
                    }
                }
            }
            let instrs: Vec<Instr> = self.instrs.iter().filter(|i| !folds(i)).cloned().collect();
            // The folded codes the rest reads, and folded outputs.
            let mut needed = vec![false; self.n_regs];
            for ins in &instrs {
                ins.each_operand(|a| needed[a] = true);
            }
            for &(o, _) in &self.outputs {
                needed[o] = true;
            }
            let mut consts = self.consts.clone();
            consts.extend(
                self.instrs
                    .iter()
                    .filter(|i| folds(i) && needed[i.dest()])
                    .map(|i| (i.dest(), code(i.dest()))),
            );
            (base_flags, base_overflows, instrs, consts)
        };
        if let Ok(mut p) = self.pool.0.lock() {
            if p.len() < super::POOLED_FILES {
                p.push(regs);
            }
        }
        Some(
            Program {
                instrs,
                consts,
                base_flags,
                base_overflows,
                pool: RegPool(std::sync::Mutex::new(Vec::new())),
                ..self.clone()
            }
            .laid_out(),
        )
    }
}

#[cfg(test)]
pub(super) mod tests {
    use crate::datapath::batch::{Isa, Program, Table, Trace, TV};
    use crate::datapath::Datapath;
    use crate::quantize::{Overflow, Quant, Rounding};
    use crate::sampling::Rng;

    /// A datapath with every kind of instruction the engine folds: fused
    /// and plain products and sums, a saturating and a wrapping
    /// quantization, a maximum, a sign-steered sum, selects of constants
    /// and of values, a table read, an input and a node named as outputs.
    pub(in crate::datapath::batch) fn datapath() -> (Trace, Vec<TV>) {
        let q = |s: &'static str, f: &str, r, o| Quant::new(s, f.parse().unwrap(), r, o);
        let v = q("v", "I2F14", Rounding::Trunc, Overflow::Saturate);
        let sq = q("sq", "I2F14", Rounding::Trunc, Overflow::Saturate);
        let sum = q("sum", "I2F14", Rounding::HalfUp, Overflow::Wrap);
        let dif = q("dif", "I2F12", Rounding::HalfEven, Overflow::Saturate);
        let ix = q("ix", "U6F6", Rounding::Trunc, Overflow::Wrap);
        let sel_q = q("sel", "U2F0", Rounding::Trunc, Overflow::Wrap);
        let entries = q("t", "I12F4", Rounding::Trunc, Overflow::Wrap);
        let table = Table {
            name: "t",
            index: ix.format(),
            out: entries,
            exact: |x| x,
            codes: (0..64)
                .map(|k| (k * 37 % 101) - 50 - 1000 * (k % 3))
                .collect(),
            storage: None,
        };
        let mut t = Trace::new();
        let x = t.input_named("x", &v);
        let y = t.input_named("y", &v);
        let z = t.input_named("z", &v);
        let sel = t.input_named("sel", &sel_q);
        let xy = t.mul(x, y);
        let p = t.quantize(xy, &sq);
        let pz = t.add(p, z);
        let s = t.quantize(pz, &sum);
        let xmy = t.sub(x, y);
        let d = t.quantize(xmy, &dif);
        let m = t.max(s, d);
        let mq = t.quantize(m, &sum);
        let g0 = t.add_signed(x, z, y, false);
        let g = t.quantize(g0, &sum);
        let zz = t.mul(z, z);
        let dot0 = t.add(xy, zz);
        let dot = t.quantize(dot0, &sq);
        let consts: Vec<TV> = [0.25, -0.5, 1.5]
            .iter()
            .map(|&c| t.constant(c, &v).unwrap())
            .collect();
        let sc = t.select(sel, &consts);
        let sv = t.select(sel, &[p, s, d, g]);
        let svq = t.quantize(sv, &dif);
        let i = t.quantize(z, &ix);
        let tab = t.table(&table, i);
        for (name, o) in [
            ("p", p),
            ("mq", mq),
            ("g", g),
            ("dot", dot),
            ("sc", sc),
            ("svq", svq),
            ("tab", tab),
            ("y", y),
            ("p_again", p),
        ] {
            t.output(name, o);
        }
        let outs = t.output_ports().iter().map(|p| p.value).collect();
        (t, outs)
    }

    /// For rows of random codes (and rows where `x·y` saturates, so that a
    /// folded quantization overflows), each input and each pair of inputs
    /// varying over 700 lanes (three blocks, the last partial): the
    /// specialized program gives the program's outputs, per-lane flags and
    /// per-stage counts on every instruction set, as `i64` and `i128`
    /// codes, and runs fewer instructions unless every input varies.
    #[test]
    fn specialized_programs_give_the_programs_codes_flags_and_counts() {
        let (t, outs) = datapath();
        let narrow = Program::<i64>::compile(&t, &outs).unwrap();
        let wide = Program::<i128>::compile(&t, &outs).unwrap();
        let mut rng = Rng::new(7);
        let ranges = [
            (-32768i64, 32767i64),
            (-32768, 32767),
            (-32768, 32767),
            (0, 3),
        ];
        let code = |k: usize, rng: &mut Rng| {
            let (lo, hi) = ranges[k];
            lo + i64::try_from(rng.below(u64::try_from(hi - lo + 1).unwrap())).unwrap()
        };
        let mut folded_overflow = false;
        for r in 0..24 {
            let row: Vec<i64> = if r % 4 == 0 {
                vec![-32768, -32768, code(2, &mut rng), code(3, &mut rng)]
            } else {
                (0..4).map(|k| code(k, &mut rng)).collect()
            };
            for mask in 1u32..16 {
                if mask.count_ones() > 2 {
                    continue;
                }
                let varying: Vec<bool> = (0..4).map(|k| mask >> k & 1 == 1).collect();
                let cols: Vec<Vec<i64>> = (0..4)
                    .map(|k| {
                        (0..700)
                            .map(|_| {
                                if varying[k] {
                                    code(k, &mut rng)
                                } else {
                                    row[k]
                                }
                            })
                            .collect()
                    })
                    .collect();
                let refs: Vec<&[i64]> = cols.iter().map(Vec::as_slice).collect();
                let s = narrow
                    .specialize(&row, &varying)
                    .expect("nothing to refuse");
                assert!(s.instrs.len() < narrow.instrs.len(), "{varying:?}");
                folded_overflow |= s.base_flags != 0;
                // The C form cannot count folded overflows: it says so.
                assert_eq!(
                    s.c_source().err(),
                    (!s.base_overflows.is_empty()).then_some(super::super::c::CError::Specialized)
                );
                assert_eq!(
                    s.run_flags(&refs),
                    narrow.run_flags(&refs),
                    "{row:?} {varying:?}"
                );
                for isa in Isa::ALL.into_iter().filter(|i| i.available()) {
                    let (mut a, mut b) = (Vec::new(), Vec::new());
                    a.resize(outs.len(), Vec::new());
                    b.resize(outs.len(), Vec::new());
                    let ca = s.run_into_on(isa, &refs, &mut a);
                    let cb = narrow.run_into_on(isa, &refs, &mut b);
                    assert_eq!((a, ca), (b, cb), "{} {row:?} {varying:?}", isa.name());
                }
                let row128: Vec<i128> = row.iter().map(|&c| i128::from(c)).collect();
                let cols128: Vec<Vec<i128>> = cols
                    .iter()
                    .map(|c| c.iter().map(|&x| i128::from(x)).collect())
                    .collect();
                let refs128: Vec<&[i128]> = cols128.iter().map(Vec::as_slice).collect();
                let w = wide
                    .specialize(&row128, &varying)
                    .expect("nothing to refuse");
                assert_eq!(w.run_flags(&refs128), wide.run_flags(&refs128));
            }
        }
        assert!(folded_overflow, "a folded quantization overflowed");
    }
}
