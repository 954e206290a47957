//! SMT-LIB 2 bit-vector encodings of a traced datapath: to ask a solver
//! whether any input makes a quantizer meet the event that tells a mutant
//! from the design ([`super::MutationKind`]: `unsat` proves the mutant
//! equivalent, a model is an input that may kill it), and the whole
//! function — every output and overflow flag of its inputs
//! ([`Trace::smt_function`]) — that `fxshade equiv` proves the emitted
//! Verilog equal to.
//!
//! Node `i` is a bit-vector of its exact width (two's complement when its
//! format is signed, extended by its signedness where read wider),
//! computed exactly: products and sums at the node's width, alignment by
//! left shifts, quantization as [`crate::quantize::Quant`] defines it
//! (slice, one increment, range check, wrap or saturate), table reads as
//! arrays of their entries (mutation events) or as trees of `ite` on the
//! index bits (the functions equivalence proofs use). Only the cone of the asked node is encoded; a
//! division or square root in it is not (`None`).

use super::{Mutation, MutationKind, Op, Trace, TV};
use crate::quantize::{Overflow, Rounding};

/// The SMT-LIB bit-vector literal of `v`'s low `w` bits, `(_ bv<m> <w>)`
/// with `m` their unsigned value.
pub fn lit(v: i128, w: u32) -> String {
    let m = if w >= 128 {
        v.cast_unsigned()
    } else {
        v.cast_unsigned() & ((1u128 << w) - 1)
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

/// The rounded value of `x` (a node of `wa` bits read at `fa` fraction
/// bits) for quantizer `q`, before its range check: (term, width,
/// overflow term).
fn quant_term(x: &str, wa: u32, fa: i32, q: &crate::quantize::Quant) -> (String, u32, String) {
    let sh = fa - q.format().frac();
    let (r, rw) = if sh > 0 {
        let sh = sh.unsigned_abs();
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
        let l = sh.unsigned_abs();
        let rw = wa + l;
        (
            format!("(bvshl {} {})", ext(x, wa, rw), lit(i128::from(l), rw)),
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
}

/// A traced datapath as one SMT-LIB 2 function of its inputs
/// ([`Trace::smt_function`]).
#[derive(Clone, Debug)]
pub struct SmtFunction {
    /// Declarations (`in<slot>`, table arrays) and definitions (`n<i>`
    /// for each node, `o<i>` for each quantization's overflow): no
    /// `set-logic`, no `check-sat`.
    pub defs: String,
    /// The input constants, slot order: name and width (the format's).
    pub inputs: Vec<(String, u32)>,
    /// Each output port: its name, the term of its code's bits and their
    /// width (the port format's).
    pub outputs: Vec<(String, String, u32)>,
    /// Each overflow-flag stage ([`Trace::flag_stages`] of the outputs, in
    /// order): its id and a `Bool` term, true when any quantization of
    /// that stage overflows.
    pub flags: Vec<(String, String)>,
    /// Whether the definitions use arrays (table reads): logic `QF_ABV`,
    /// else `QF_BV`.
    pub arrays: bool,
}

/// A slice of a product's operand: bits `lo .. lo + width` of its value,
/// read as two's complement when `signed` (the operand's top slice of a
/// signed operand), else unsigned.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct Chunk {
    /// The slice's lowest bit.
    pub lo: u32,
    /// Its width.
    pub width: u32,
    /// Whether it is read signed.
    pub signed: bool,
}

/// One partial product of a split product: a slice of the first operand
/// times a slice of the second.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct PartialProduct {
    /// The slice of the product's first operand (`Op::Mul(a, _)`).
    pub a: Chunk,
    /// The slice of its second operand.
    pub b: Chunk,
}

/// A product node `a·b` that the hardware builds as a sum of partial
/// products (a pipelined multiplier wider than one DSP block).
///
/// [`Trace::smt_function_split`] writes the node as the same sum, so a
/// solver that abstracts products meets the hardware's partial products on
/// both sides. The rewriting is exact (the split lemma), whenever
/// [`MulSplit::covers`] holds: with `x_j` the first operand's slices
/// (weights `2^lo_j`, the top one signed if the operand is, the others
/// unsigned) `a = Σ x_j·2^lo_j` as integers, likewise `b = Σ y_k·2^lo_k`,
/// so by distributivity `a·b = Σ x_j·y_k·2^(lo_j+lo_k)`; each `x_j·y_k`
/// is exact in the width of its extended factors (`p_w = w_x + w_y`, one
/// more bit for an unsigned factor of a signed partial), and the sum is
/// taken modulo `2^w`, the product node's width, as the node is.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct MulSplit {
    /// The product node.
    pub node: usize,
    /// Its partial products.
    pub parts: Vec<PartialProduct>,
}

impl MulSplit {
    /// Whether the parts are every pair of a partition of `a` (`wa` bits,
    /// signed when `sa`) into slices and a partition of `b`, each pair
    /// once, each slice signed exactly when it is the top slice of a
    /// signed operand: then the sum of the parts is `a·b` (the lemma of
    /// the type's documentation). A split that does not cover is not used.
    pub fn covers(&self, wa: u32, sa: bool, wb: u32, sb: bool) -> bool {
        let slices = |pick: &dyn Fn(&PartialProduct) -> Chunk, w: u32, signed: bool| {
            let mut cs: Vec<Chunk> = self.parts.iter().map(pick).collect();
            cs.sort_by_key(|c| c.lo);
            cs.dedup();
            let mut next = 0;
            for c in &cs {
                if c.lo != next || c.width == 0 {
                    return None;
                }
                // Checked: slices past the word's end are not a partition.
                next = c.lo.checked_add(c.width)?;
                if c.signed != (signed && next == w) {
                    return None;
                }
            }
            (next == w).then_some(cs)
        };
        let (Some(xa), Some(xb)) = (slices(&|p| p.a, wa, sa), slices(&|p| p.b, wb, sb)) else {
            return false;
        };
        // The lo values are distinct within each operand (a partition), so
        // chunk equality is positional.
        let mut pairs: Vec<(u32, u32)> = self.parts.iter().map(|p| (p.a.lo, p.b.lo)).collect();
        pairs.sort_unstable();
        pairs.dedup();
        let clash = self
            .parts
            .iter()
            .any(|p| !xa.contains(&p.a) || !xb.contains(&p.b));
        !clash && pairs.len() == self.parts.len() && pairs.len() == xa.len() * xb.len()
    }

    /// The sum of the parts as an SMT-LIB 2 term of `w` bits, `a` and `b`
    /// the operands' terms (`wa`, `wb` bits): each slice extended by its
    /// signedness to the partial's width `p_w`, the `p_w`-bit product
    /// extended (signed when either slice is) or cut to `w` bits, shifted
    /// by its weight, all added modulo `2^w`.
    pub fn smt_sum(&self, a: &str, wa: u32, b: &str, wb: u32, w: u32) -> String {
        let slice = |e: &str, we: u32, c: &Chunk| {
            if c.lo == 0 && c.width == we {
                e.to_string()
            } else {
                format!("((_ extract {} {}) {e})", c.lo + c.width - 1, c.lo)
            }
        };
        let widen = |e: String, from: u32, to: u32, signed: bool| {
            if to > from {
                let how = if signed { "sign_extend" } else { "zero_extend" };
                format!("((_ {how} {}) {e})", to - from)
            } else if to == from {
                e
            } else {
                format!("((_ extract {} 0) {e})", to - 1)
            }
        };
        let mut terms = Vec::new();
        for p in &self.parts {
            let shift = p.a.lo + p.b.lo;
            if shift >= w {
                continue;
            }
            let ps = p.a.signed || p.b.signed;
            let xw = p.a.width + u32::from(ps && !p.a.signed);
            let yw = p.b.width + u32::from(ps && !p.b.signed);
            let pw = xw + yw;
            let x = widen(slice(a, wa, &p.a), p.a.width, pw, p.a.signed);
            let y = widen(slice(b, wb, &p.b), p.b.width, pw, p.b.signed);
            let t = widen(format!("(bvmul {x} {y})"), pw, w, ps);
            terms.push(if shift == 0 {
                t
            } else {
                format!("(bvshl {t} {})", lit(i128::from(shift), w))
            });
        }
        match terms.len() {
            0 => lit(0, w),
            1 => terms.remove(0),
            _ => {
                let mut e = terms.remove(0);
                for t in terms {
                    e = format!("(bvadd {e} {t})");
                }
                e
            }
        }
    }
}

/// The entry `entry(base + j)` for `j` the low `bits` bits of `a`, as a
/// binary tree of `ite` on `a`'s bits (bit `bits - 1` first); equal
/// halves are one subtree.
fn mux_tree(bits: u32, base: usize, entry: &dyn Fn(usize) -> String) -> String {
    if bits == 0 {
        return entry(base);
    }
    let b = bits - 1;
    let lo = mux_tree(b, base, entry);
    let hi = mux_tree(b, base | (1 << b), entry);
    if lo == hi {
        lo
    } else {
        format!("(ite (= ((_ extract {b} {b}) a) #b1) {hi} {lo})")
    }
}

impl Trace {
    /// Declarations of the inputs and definitions `n<i>` of every node in
    /// `need` (and `o<i>`, the overflow of each quantization among them),
    /// appended to `s`; `None` when one is a division or square root.
    ///
    /// A table read is `(select tab<slot>_<w> index)` of an array whose
    /// entries are asserted, or with `mux_tables` `(tab<slot>_<w> index)`,
    /// a function that is a binary tree of `ite` on the index bits, most
    /// significant first (equal halves shared): the form a ROM takes in
    /// hardware, which a solver compares with the RTL's tables some 20
    /// times faster than an array.
    pub fn smt_nodes(
        &self,
        need: &[bool],
        cut: &[bool],
        splits: &[MulSplit],
        mux_tables: bool,
        s: &mut String,
    ) -> Option<()> {
        if need
            .iter()
            .zip(&self.ops)
            .any(|(n, op)| *n && matches!(op, Op::Div(..) | Op::Sqrt(..)))
        {
            return None;
        }
        let w = |i: usize| self.syms[i].width;
        for (slot, q) in self.inputs.iter().enumerate() {
            *s += &format!(
                "(declare-const in{slot} (_ BitVec {}))\n",
                q.format().width()
            );
        }
        for (i, _) in need.iter().enumerate().filter(|(_, n)| **n) {
            let wi = w(i);
            let val = |t: &TV, to: u32| self.smt_val(t.node(), to);
            let aligned = |t: &TV| {
                let sh = super::align(self.fracs[i], t.frac());
                if sh == 0 {
                    val(t, wi)
                } else {
                    format!("(bvshl {} {})", val(t, wi), lit(i128::from(sh), wi))
                }
            };
            let mut ovf_def = None;
            let e = match &self.ops[i] {
                Op::Input(slot) => {
                    let fw = self.inputs[*slot].format().width();
                    if fw != wi {
                        return None;
                    }
                    format!("in{slot}")
                }
                Op::Const(c) => lit(*c, wi),
                Op::Mul(a, b) => {
                    let (na, nb) = (a.node(), b.node());
                    let (wa, wb) = (w(na), w(nb));
                    let (sa, sb) = (self.syms[na].signed, self.syms[nb].signed);
                    match splits
                        .iter()
                        .find(|m| m.node == i && m.covers(wa, sa, wb, sb))
                    {
                        Some(m) => m.smt_sum(&format!("n{na}"), wa, &format!("n{nb}"), wb, wi),
                        None => format!("(bvmul {} {})", val(a, wi), val(b, wi)),
                    }
                }
                Op::Add(a, b) => format!("(bvadd {} {})", aligned(a), aligned(b)),
                Op::Sub(a, b) => format!("(bvsub {} {})", aligned(a), aligned(b)),
                Op::Max(a, b) => {
                    let (x, y) = (aligned(a), aligned(b));
                    let ge = if self.syms[i].signed {
                        "bvsge"
                    } else {
                        "bvuge"
                    };
                    format!("(ite ({ge} {x} {y}) {x} {y})")
                }
                Op::AddSigned(a, b, sg, flip) => {
                    let (x, y) = (aligned(a), aligned(b));
                    let neg = if self.syms[sg.node()].signed {
                        format!("(bvslt n{} {})", sg.node(), lit(0, w(sg.node())))
                    } else {
                        "false".to_string()
                    };
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
                        if sw < 64 && k as u64 >= 1u64 << sw {
                            continue;
                        }
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
                    let wa = w(a.node()) + 1;
                    let (re, cw, ovf) = quant_term(&val(a, wa), wa, a.frac(), q);
                    let f = q.format();
                    if f.width() != wi {
                        return None;
                    }
                    let fit = format!("((_ extract {} 0) {re})", f.width() - 1);
                    let e = match q.overflow() {
                        Overflow::Wrap => fit,
                        Overflow::Saturate => format!(
                            "(ite {ovf} (ite (bvslt {re} {}) {} {}) {fit})",
                            lit(0, cw),
                            lit(f.min_code(), wi),
                            lit(f.max_code(), wi)
                        ),
                    };
                    ovf_def = Some(ovf);
                    e
                }
                Op::Table(a, slot) => {
                    // Entry `codes[index bits mod len]`, as the compiled
                    // program reads it: an array of the entries.
                    let t = &self.tables[*slot];
                    let k = t.codes.len().trailing_zeros().max(1);
                    let name = format!("tab{slot}_{wi}");
                    let idx = val(a, k.max(w(a.node())));
                    let idx = format!("((_ extract {} 0) {idx})", k - 1);
                    if mux_tables {
                        if !s.contains(&format!("(define-fun {name} ")) {
                            let entry = |j: usize| lit(t.codes.get(j).copied().unwrap_or(0), wi);
                            *s += &format!(
                                "(define-fun {name} ((a (_ BitVec {k}))) (_ BitVec {wi}) {})\n",
                                mux_tree(k, 0, &entry)
                            );
                        }
                        format!("({name} {idx})")
                    } else {
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
                            *s += &decl;
                        }
                        format!("(select {name} {idx})")
                    }
                }
                Op::Div(..) | Op::Sqrt(..) => return None,
            };
            if cut.get(i).copied().unwrap_or(false) {
                // A cut: the node is a free value `c<i>`; `f<i>` is what
                // the datapath computes for it from its operands.
                *s += &format!("(declare-const c{i} (_ BitVec {wi}))\n");
                *s += &format!("(define-fun f{i} () (_ BitVec {wi}) {e})\n");
                *s += &format!("(define-fun n{i} () (_ BitVec {wi}) c{i})\n");
            } else {
                *s += &format!("(define-fun n{i} () (_ BitVec {wi}) {e})\n");
            }
            if let Some(o) = ovf_def {
                // The overflow reads only the operand, defined above.
                *s += &format!("(define-fun o{i} () Bool {o})\n");
            }
        }
        Some(())
    }

    /// Node `i`'s value `n<i>` (its exact width, two's complement when its
    /// format is signed) as `to` bits: extended by its signedness, or its
    /// low bits.
    fn smt_val(&self, i: usize, to: u32) -> String {
        let from = self.syms[i].width;
        let x = format!("n{i}");
        if to > from {
            let how = if self.syms[i].signed {
                "sign_extend"
            } else {
                "zero_extend"
            };
            format!("((_ {how} {}) {x})", to - from)
        } else if to == from {
            x
        } else {
            format!("((_ extract {} 0) {x})", to - 1)
        }
    }

    /// Every output port and overflow flag of the trace as SMT-LIB 2 terms
    /// of its inputs `in<slot>`, or `None` when a node the outputs read is
    /// a division or square root.
    ///
    /// Node `i` is `n<i>`, a bit-vector of its exact width (two's
    /// complement when its format is signed), computed exactly: products and sums
    /// at the node's width, alignment by left shifts, each quantization as
    /// [`crate::quantize::Quant`] defines it (the dropped bits rounded by
    /// one increment, then the range check: wrap or saturate), a table read
    /// as a tree of `ite` on its index bits (`tab<slot>_<w>`), a select as `option[sel]` (option 0 past
    /// the end), as the compiled program computes them. An output is its
    /// node (its port format's width); flag `k` is the OR
    /// of the overflows of every live quantization whose stage id is
    /// `flag_stages[k]`. Only nodes the outputs read are encoded.
    pub fn smt_function(&self) -> Option<SmtFunction> {
        self.smt_function_cut(&[])
    }

    /// As [`Trace::smt_function`], with every node `i` where `cut[i]` is
    /// true cut: `n<i>` is a free constant `c<i>` (declared), and `f<i>`
    /// is the term the datapath computes for it from its operands (which
    /// read the cuts before it). A proof by stages asks, for each cut, that
    /// the hardware's value equals `f<i>` when every cut equals its
    /// hardware value.
    pub fn smt_function_cut(&self, cut: &[bool]) -> Option<SmtFunction> {
        self.smt_function_tables(cut, &[], true)
    }

    /// As [`Trace::smt_function_cut`], each product node of `splits` whose
    /// split [covers](MulSplit::covers) its operands written as the sum of
    /// its partial products ([`MulSplit::smt_sum`]; the same value, by the
    /// split lemma), the others as one `bvmul`.
    pub fn smt_function_split(&self, cut: &[bool], splits: &[MulSplit]) -> Option<SmtFunction> {
        self.smt_function_tables(cut, splits, true)
    }

    /// As [`Trace::smt_function_cut`], tables as `ite` trees when
    /// `mux_tables`, else as arrays whose entries are asserted.
    pub fn smt_function_tables(
        &self,
        cut: &[bool],
        splits: &[MulSplit],
        mux_tables: bool,
    ) -> Option<SmtFunction> {
        let roots: Vec<TV> = self.outputs.iter().map(|p| p.value).collect();
        let need = self.live_nodes(&roots);
        let mut defs = String::new();
        self.smt_nodes(&need, cut, splits, mux_tables, &mut defs)?;
        let inputs = self
            .inputs
            .iter()
            .enumerate()
            .map(|(slot, q)| (format!("in{slot}"), q.format().width()))
            .collect();
        let outputs = self
            .outputs
            .iter()
            .map(|p| {
                let n = p.value.node();
                let fw = p.format.width();
                (p.name.clone(), self.smt_val(n, fw), fw)
            })
            .collect();
        let flags = self
            .flag_stages(&roots)
            .into_iter()
            .map(|id| {
                let terms: Vec<String> = (0..self.ops.len())
                    .filter(|&i| {
                        need[i]
                            && matches!(self.ops[i], Op::Quant(..))
                            && self.stage_ids[i].as_deref() == Some(id.as_str())
                    })
                    .map(|i| format!("o{i}"))
                    .collect();
                let t = match terms.len() {
                    0 => "false".to_string(),
                    1 => terms[0].clone(),
                    _ => format!("(or {})", terms.join(" ")),
                };
                (id, t)
            })
            .collect();
        let arrays = defs.contains("(Array ");
        Some(SmtFunction {
            defs,
            inputs,
            outputs,
            flags,
            arrays,
        })
    }

    /// The SMT-LIB 2 script asking whether some input makes the quantizer of
    /// `m` meet `m`'s event, or `None` when its cone holds an operation the
    /// encoding lacks. Inputs are `in<slot>` of their formats' widths.
    pub fn smt_event(&self, m: &Mutation) -> Option<String> {
        let Op::Quant(op_a, q) = &self.ops[m.node] else {
            return None;
        };
        let need = self.live_nodes(&[*op_a]);
        let mut s = String::from("(set-logic QF_BV)\n");
        self.smt_nodes(&need, &[], &[], false, &mut s)?;
        // The operand as a signed value one bit wider than its format.
        let wa = self.syms[op_a.node()].width + 1;
        let xa = self.smt_val(op_a.node(), wa);
        let sh = op_a.frac() - q.format().frac();
        let event = match m.kind {
            MutationKind::Overflow(_) => quant_term(&xa, wa, op_a.frac(), q).2,
            MutationKind::Round(_) if sh > 0 => {
                let sh = sh.unsigned_abs();
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
