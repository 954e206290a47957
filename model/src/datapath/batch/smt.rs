//! SMT-LIB 2 bit-vector encodings of a traced datapath, to ask a solver
//! (z3) whether any input makes a quantizer meet the event that tells a
//! mutant from the design ([`super::MutationKind`]): `unsat` proves the
//! mutant equivalent, a model is an input that may kill it.
//!
//! Node `i` is a signed bit-vector one bit wider than its exact width (so
//! unsigned values fit), computed exactly: products and sums at the node's
//! width, alignment by left shifts, quantization as the emitter writes it
//! (slice, one increment, range check, wrap or saturate), table reads as
//! arrays of their entries. Only the cone of the asked node is encoded; a
//! division or square root in it is not (`None`).

use super::{Mutation, MutationKind, Op, Trace, TV};
use crate::quantize::{Overflow, Rounding};

fn lit(v: i128, w: u32) -> String {
    let m = if w >= 128 {
        v as u128
    } else {
        (v as u128) & ((1u128 << w) - 1)
    };
    format!("(_ bv{m} {w})")
}

fn ext(e: &str, from: u32, to: u32) -> String {
    if to > from {
        format!("((_ sign_extend {}) {e})", to - from)
    } else if to == from {
        e.to_string()
    } else {
        format!("((_ extract {} 0) {e})", to - 1)
    }
}

impl Trace {
    /// The SMT-LIB 2 script asking whether some input makes the quantizer of
    /// `m` meet `m`'s event, or `None` when its cone holds an operation the
    /// encoding lacks. Inputs are `in<slot>` of their formats' widths.
    pub fn smt_event(&self, m: &Mutation) -> Option<String> {
        let Op::Quant(op_a, q) = &self.ops[m.node] else {
            return None;
        };
        // The cone.
        let mut need = vec![false; self.ops.len()];
        need[op_a.node()] = true;
        for i in (0..self.ops.len()).rev() {
            if !need[i] {
                continue;
            }
            let mut mark = |t: &TV| need[t.node()] = true;
            match &self.ops[i] {
                Op::Mul(a, b) | Op::Add(a, b) | Op::Sub(a, b) | Op::Max(a, b) => {
                    mark(a);
                    mark(b);
                }
                Op::Quant(a, _) | Op::Table(a, _) => mark(a),
                Op::Select(s, o) => {
                    mark(s);
                    o.iter().for_each(mark);
                }
                Op::AddSigned(a, b, s, _) => {
                    mark(a);
                    mark(b);
                    mark(s);
                }
                Op::Div(..) | Op::Sqrt(..) => return None,
                Op::Input(_) | Op::Const(_) => {}
            }
        }
        let w = |i: usize| self.syms[i].width + 1;
        let mut s = String::from("(set-logic QF_BV)\n");
        for (slot, q) in self.inputs.iter().enumerate() {
            s += &format!(
                "(declare-const in{slot} (_ BitVec {}))\n",
                q.format().width()
            );
        }
        // The rounded value of `x` (node a read at frac fa) for quantizer q:
        // (expression, width, overflow expression).
        let quant =
            |x: &str, wa: u32, fa: i32, q: &crate::quantize::Quant| -> (String, u32, String) {
                let sh = fa - q.format().frac();
                let (r, rw) = if sh > 0 {
                    let sh = sh as u32;
                    let xe = if wa < sh + 1 {
                        ext(x, wa, sh + 1)
                    } else {
                        x.to_string()
                    };
                    let xw = wa.max(sh + 1);
                    let t = format!("((_ extract {} {sh}) {xe})", xw - 1);
                    let tw = xw - sh + 1;
                    let t = ext(&t, xw - sh, tw);
                    let bit = |k: u32| format!("((_ extract {k} {k}) {xe})");
                    let inc = match q.round() {
                        Rounding::Trunc => None,
                        Rounding::HalfUp => Some(bit(sh - 1)),
                        Rounding::HalfEven => Some(if sh >= 2 {
                            format!(
                                "(bvand {} (bvor {} (ite (= ((_ extract {} 0) {xe}) {}) #b0 #b1)))",
                                bit(sh - 1),
                                bit(sh),
                                sh - 2,
                                lit(0, sh - 1)
                            )
                        } else {
                            format!("(bvand {} {})", bit(sh - 1), bit(sh))
                        }),
                    };
                    match inc {
                        None => (t, tw),
                        Some(i) => (format!("(bvadd {t} ((_ zero_extend {}) {i}))", tw - 1), tw),
                    }
                } else {
                    let l = (-sh) as u32;
                    let rw = wa + l;
                    (
                        format!("(bvshl {} {})", ext(x, wa, rw), lit(l as i128, rw)),
                        rw,
                    )
                };
                let f = q.format();
                let cw = rw.max(f.width() + 2);
                let re = ext(&r, rw, cw);
                let ovf = format!(
                    "(or (bvslt {re} {}) (bvsgt {re} {}))",
                    lit(f.min_code(), cw),
                    lit(f.max_code(), cw)
                );
                (re, cw, ovf)
            };
        for (i, _) in need.iter().enumerate().filter(|(_, n)| **n) {
            let wi = w(i);
            let val = |t: &TV, to: u32| ext(&format!("n{}", t.node()), w(t.node()), to);
            let aligned = |t: &TV| {
                let sh = (self.fracs[i] - t.frac()) as u32;
                if sh == 0 {
                    val(t, wi)
                } else {
                    format!("(bvshl {} {})", val(t, wi), lit(sh as i128, wi))
                }
            };
            let e = match &self.ops[i] {
                Op::Input(slot) => {
                    let f = self.inputs[*slot].format();
                    if f.signed() {
                        ext(&format!("in{slot}"), f.width(), wi)
                    } else {
                        format!("((_ zero_extend {}) in{slot})", wi - f.width())
                    }
                }
                Op::Const(c) => lit(*c, wi),
                Op::Mul(a, b) => format!("(bvmul {} {})", val(a, wi), val(b, wi)),
                Op::Add(a, b) => format!("(bvadd {} {})", aligned(a), aligned(b)),
                Op::Sub(a, b) => format!("(bvsub {} {})", aligned(a), aligned(b)),
                Op::Max(a, b) => {
                    let (x, y) = (aligned(a), aligned(b));
                    format!("(ite (bvsge {x} {y}) {x} {y})")
                }
                Op::AddSigned(a, b, sg, flip) => {
                    let (x, y) = (aligned(a), aligned(b));
                    let neg = format!("(bvslt n{} {})", sg.node(), lit(0, w(sg.node())));
                    let (sub, add) = (format!("(bvsub {x} {y})"), format!("(bvadd {x} {y})"));
                    if *flip {
                        format!("(ite {neg} {add} {sub})")
                    } else {
                        format!("(ite {neg} {sub} {add})")
                    }
                }
                Op::Select(sel, opts) => {
                    let sw = w(sel.node());
                    let mut e = aligned(&opts[0]);
                    for (k, o) in opts.iter().enumerate().skip(1).rev() {
                        e = format!(
                            "(ite (= n{} {}) {} {e})",
                            sel.node(),
                            lit(k as i128, sw),
                            aligned(o)
                        );
                    }
                    e
                }
                Op::Quant(a, q) => {
                    let (re, cw, ovf) = quant(&format!("n{}", a.node()), w(a.node()), a.frac(), q);
                    let f = q.format();
                    let low = format!("((_ extract {} 0) {re})", f.width() - 1);
                    let fit = if f.signed() {
                        ext(&low, f.width(), wi)
                    } else {
                        format!("((_ zero_extend {}) {low})", wi - f.width())
                    };
                    match q.overflow() {
                        Overflow::Wrap => fit,
                        Overflow::Saturate => format!(
                            "(ite {ovf} (ite (bvslt {re} {}) {} {}) {fit})",
                            lit(0, cw),
                            lit(f.min_code(), wi),
                            lit(f.max_code(), wi)
                        ),
                    }
                }
                Op::Table(a, slot) => {
                    // Entry `codes[index bits mod len]`, as the compiled
                    // program reads it: an array of the entries.
                    let t = &self.tables[*slot];
                    let k = t.codes.len().trailing_zeros().max(1);
                    let name = format!("tab{slot}_{wi}");
                    if !s.contains(&format!("(declare-const {name} ")) {
                        let mut decl = format!(
                            "(declare-const {name} (Array (_ BitVec {k}) (_ BitVec {wi})))\n"
                        );
                        for (j, &c) in t.codes.iter().enumerate() {
                            decl += &format!(
                                "(assert (= (select {name} {}) {}))\n",
                                lit(j as i128, k),
                                lit(c, wi)
                            );
                        }
                        s += &decl;
                    }
                    let wa = w(a.node());
                    let idx = if wa >= k {
                        format!("((_ extract {} 0) n{})", k - 1, a.node())
                    } else {
                        format!("((_ zero_extend {}) n{})", k - wa, a.node())
                    };
                    format!("(select {name} {idx})")
                }
                Op::Div(..) | Op::Sqrt(..) => return None,
            };
            s += &format!("(define-fun n{i} () (_ BitVec {wi}) {e})\n");
        }
        let xa = format!("n{}", op_a.node());
        let wa = w(op_a.node());
        let sh = op_a.frac() - q.format().frac();
        let event = match m.kind {
            MutationKind::Overflow(_) => quant(&xa, wa, op_a.frac(), q).2,
            MutationKind::Round(_) if sh > 0 => {
                let sh = sh as u32;
                let xw = wa.max(sh + 1);
                let xe = ext(&xa, wa, xw);
                let bit = |k: u32| format!("((_ extract {k} {k}) {xe})");
                match q.round() {
                    Rounding::Trunc => format!("(= {} #b1)", bit(sh - 1)),
                    _ => format!(
                        "(and (= ((_ extract {} 0) {xe}) {}) (= {} #b0))",
                        sh - 1,
                        lit(1i128 << (sh - 1), sh),
                        bit(sh)
                    ),
                }
            }
            _ => return None,
        };
        if s.contains("(Array ") {
            s = s.replacen("(set-logic QF_BV)", "(set-logic QF_ABV)", 1);
        }
        s += &format!("(assert {event})\n(check-sat)\n(get-value (");
        for slot in 0..self.inputs.len() {
            s += &format!(" in{slot}");
        }
        s += "))\n";
        Some(s)
    }
}
