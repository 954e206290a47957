//! Compiled batch execution of a datapath: the fast bit-accurate run.
//!
//! A unit's generic code is run once in [`Trace`], which records its
//! straight-line datapath (hardware datapaths have no data-dependent control
//! flow: `max` is an operation, not a branch) and, alongside, runs it in
//! [`Count`] to learn every exact width. [`Program::compile`] then resolves
//! each node's binary point into shift amounts, once; [`Program::run`]
//! executes instruction by instruction over blocks of lanes, each
//! instruction a tight integer loop whose rounding and overflow modes are
//! hoisted out of the loop. The arithmetic is the same code as
//! [`super::Fixed`] ([`Step::apply`], [`div_exact`], [`sqrt_exact`]);
//! tests check the two agree bit for bit.

use super::count::{Count, Sym};
use super::fixed::{div_exact, sqrt_exact};
use super::{Datapath, Table, WidthError};
use crate::format::{ConvertError, Format};
use crate::quantize::{Overflow, Quant, Raw, Rounding, Step};

mod boxes;
mod c;
mod cut;
mod interval;
mod mutation;
mod smt;
mod specialize;
pub use boxes::{BoxEval, Boxes};
pub use c::CError;
pub use mutation::{Mutation, MutationKind};
pub use smt::{lit as smt_literal, Chunk, MulSplit, PartialProduct, SmtFunction};

/// A value in a trace: the node that computes it, its binary point, and its
/// symbolic format.
#[derive(Clone, Copy, Debug)]
pub struct TV {
    id: u32,
    frac: i32,
    sym: Sym,
}

impl TV {
    /// Fraction bits of the value.
    pub fn frac(&self) -> i32 {
        self.frac
    }
}

impl TV {
    /// The node computing this value.
    pub fn node(&self) -> usize {
        self.id as usize
    }
    /// Its exact format.
    pub fn sym(&self) -> Sym {
        self.sym
    }
}

/// One recorded operation. Operands are [`TV`]s: a node and the binary point
/// it is read at (a `shl` moves the point without a node of its own).
#[derive(Clone, Debug)]
pub enum Op {
    /// Input port `slot`.
    Input(usize),
    /// A constant code, in the node's format.
    Const(i128),
    /// Exact product.
    Mul(TV, TV),
    /// Exact sum.
    Add(TV, TV),
    /// Exact difference.
    Sub(TV, TV),
    /// The larger value.
    Max(TV, TV),
    /// `a + σ·b`, `σ = −1` when the third operand is negative (inverted
    /// when the flag is set).
    AddSigned(TV, TV, TV, bool),
    /// Quantization.
    Quant(TV, Quant),
    /// Table read: index, table slot.
    Table(TV, usize),
    /// Division (no RTL).
    Div(TV, TV, Quant),
    /// Square root (no RTL).
    Sqrt(TV, Quant),
    /// `options[sel]`, option 0 past the end.
    Select(TV, Vec<TV>),
}

/// A named port of a traced datapath.
#[derive(Clone, Debug)]
pub struct Port {
    /// Name (`n_x`, `level`, …): the vector field and, with `_i`/`_o`, the
    /// Verilog port.
    pub name: String,
    /// The value (for inputs: the input node).
    pub value: TV,
    /// Its format (an input's quantization step, or an output's format).
    pub format: Format,
}

/// The recording context. Create inputs with [`Trace::input`] (or
/// [`Trace::input_named`]), run the unit's generic code on them, name the
/// outputs with [`Trace::output`], then [`Program::compile`] them or emit
/// Verilog from the graph (`crate::rtl`).
///
/// Stage ids are qualified by the unit scope they were recorded in
/// ([`Trace::enter`]): `normalize.g`, `polar.out`.
///
/// A square `y = Q(x · x)` with `x` in `I2F14`: the exact product is
/// `I4F28` (32 bits), quantized back to `I2F14` by truncation with
/// saturation. Its ports, and the compiled program against the closed form
/// `⌊c² / 2^14⌋` clamped to `2^15 − 1`:
///
/// ```
/// use fxshade_ir::datapath::{Datapath, Trace};
/// use fxshade_numbers::format::Format;
/// use fxshade_numbers::quantize::{Overflow, Quant, Rounding};
/// let f: Format = "I2F14".parse().unwrap();
/// let q = Quant::new("sq", f, Rounding::Trunc, Overflow::Saturate);
/// let mut t = Trace::new();
/// let x = t.input_named("x", &q);
/// let p = t.mul(x, x);
/// let y = t.quantize(p, &q);
/// t.output("y", y);
/// let ins = t.input_ports();
/// assert_eq!((ins[0].name.as_str(), ins[0].format), ("x", f));
/// let outs = t.output_ports();
/// assert_eq!((outs[0].name.as_str(), outs[0].format), ("y", f));
/// let codes: Vec<i128> = vec![-32768, -16384, -1, 0, 1, 16384, 23170, 32767];
/// let (out, overflows) = t.compile_outputs().unwrap().run_i128(&[&codes]);
/// let want: Vec<i128> = codes.iter().map(|c| ((c * c) >> 14).min(32767)).collect();
/// assert_eq!(out[0], want);
/// // (−2)² = 4 and 1.99…² do not fit: two lanes overflowed, at stage `sq`.
/// assert_eq!(overflows, vec![("sq", 2)]);
/// ```
#[derive(Clone, Debug, Default)]
pub struct Trace {
    ops: Vec<Op>,
    fracs: Vec<i32>,
    syms: Vec<Sym>,
    stage_ids: Vec<Option<String>>,
    tables: Vec<Table>,
    inputs: Vec<Quant>,
    input_names: Vec<String>,
    outputs: Vec<Port>,
    scope: Vec<&'static str>,
    count: Count,
    const_overflows: Vec<&'static str>,
}

impl Trace {
    /// An empty trace.
    pub fn new() -> Self {
        Self::default()
    }
    fn push(&mut self, op: Op, frac: i32, sym: Sym) -> TV {
        let stage = match &op {
            Op::Quant(_, q) | Op::Div(_, _, q) | Op::Sqrt(_, q) => Some(self.qualify(q.stage())),
            _ => None,
        };
        self.ops.push(op);
        self.fracs.push(frac);
        self.syms.push(sym);
        self.stage_ids.push(stage);
        TV {
            id: u32::try_from(self.ops.len() - 1).expect("fewer than 2^32 nodes"),
            frac,
            sym,
        }
    }
    fn qualify(&self, stage: &str) -> String {
        match self.scope.last() {
            Some(u) => format!("{u}.{stage}"),
            None => stage.to_string(),
        }
    }
    /// A new input port carrying codes of `q.format()`, named `in<slot>`.
    pub fn input(&mut self, q: &Quant) -> TV {
        let name = format!("in{}", self.inputs.len());
        self.input_named(&name, q)
    }
    /// A new input port named `name` carrying codes of `q.format()`.
    ///
    /// # Panics
    ///
    /// Never: the port is recorded for counting as the constant 0, which every
    /// format holds.
    pub fn input_named(&mut self, name: &str, q: &Quant) -> TV {
        let slot = self.inputs.len();
        self.inputs.push(*q);
        self.input_names.push(name.to_string());
        let sym = self.count.constant(0.0, q).expect("0 is finite");
        self.push(Op::Input(slot), q.format().frac(), sym)
    }
    /// Three input ports `name_x`, `name_y`, `name_z`.
    pub fn input3(&mut self, name: &str, q: &Quant) -> [TV; 3] {
        ["x", "y", "z"].map(|c| self.input_named(&format!("{name}_{c}"), q))
    }
    /// Name `v` as an output port. Its format is the value's exact format,
    /// which must be a valid [`Format`] (at most 64 bits): outputs are
    /// quantized values.
    ///
    /// # Panics
    ///
    /// When `v`'s exact format is not a valid [`Format`] (wider than 64 bits):
    /// quantize a value before naming it an output.
    pub fn output(&mut self, name: &str, v: TV) {
        let format = Format::new(v.sym.signed, v.sym.width, v.sym.frac)
            .expect("outputs are quantized values, at most 64 bits");
        self.outputs.push(Port {
            name: name.to_string(),
            value: v,
            format,
        });
    }
    /// Three output ports `name_x`, `name_y`, `name_z`.
    pub fn output3(&mut self, name: &str, v: [TV; 3]) {
        for (c, x) in ["x", "y", "z"].into_iter().zip(v) {
            self.output(&format!("{name}_{c}"), x);
        }
    }
    /// The counting run that went alongside the trace.
    pub fn count(&self) -> &Count {
        &self.count
    }
    /// The recorded operations, in order (node `i` is `ops()[i]`).
    pub fn ops(&self) -> &[Op] {
        &self.ops
    }
    /// The exact format of node `i`.
    pub fn sym(&self, i: usize) -> Sym {
        self.syms[i]
    }
    /// The qualified stage id of a quantization (or division, square root)
    /// node.
    pub fn stage_id(&self, i: usize) -> Option<&str> {
        self.stage_ids[i].as_deref()
    }
    /// The tables read, by slot.
    pub fn tables(&self) -> &[Table] {
        &self.tables
    }
    /// The input ports, in creation order.
    ///
    /// # Panics
    ///
    /// Never for a trace of fewer than `2^32` nodes (a node id is a `u32`).
    pub fn input_ports(&self) -> Vec<Port> {
        self.ops
            .iter()
            .enumerate()
            .filter_map(|(i, op)| match op {
                Op::Input(slot) => Some(Port {
                    name: self.input_names[*slot].clone(),
                    value: TV {
                        id: u32::try_from(i).expect("fewer than 2^32 nodes"),
                        frac: self.fracs[i],
                        sym: self.syms[i],
                    },
                    format: self.inputs[*slot].format(),
                }),
                _ => None,
            })
            .collect()
    }
    /// The real-arithmetic value of `outputs` for real input values
    /// `inputs` (by input slot, the order of [`Trace::input_ports`]): every
    /// node evaluated in f64 as [`super::Reference`] does (products, sums,
    /// differences and maxima exact up to f64 rounding; every quantization
    /// the identity, so no rounding and no saturation; a table read is its
    /// exact function of the index value; division and square root IEEE),
    /// constants at the value of their code. So the model's error against
    /// it is the quantization error of the datapath's formats alone. A
    /// select takes option `round(sel)` (option 0 past the end).
    pub fn run_f64(&self, inputs: &[f64], outputs: &[TV]) -> Vec<f64> {
        let mut v = vec![0f64; self.ops.len()];
        let read = |v: &[f64], t: &TV| {
            let i = t.node();
            v[i] * crate::format::exp2i(self.fracs[i] - t.frac)
        };
        for (i, op) in self.ops.iter().enumerate() {
            v[i] = match op {
                Op::Input(slot) => inputs.get(*slot).copied().unwrap_or(0.0),
                Op::Const(c) => code_value(*c, self.fracs[i]),
                Op::Mul(a, b) => read(&v, a) * read(&v, b),
                Op::Add(a, b) => read(&v, a) + read(&v, b),
                Op::Sub(a, b) => read(&v, a) - read(&v, b),
                Op::Max(a, b) => read(&v, a).max(read(&v, b)),
                Op::AddSigned(a, b, s, flip) => {
                    if (read(&v, s) < 0.0) != *flip {
                        read(&v, a) - read(&v, b)
                    } else {
                        read(&v, a) + read(&v, b)
                    }
                }
                Op::Quant(a, _) => read(&v, a),
                Op::Table(ix, slot) => (self.tables[*slot].exact)(read(&v, ix)),
                Op::Div(a, b, _) => read(&v, a) / read(&v, b),
                Op::Sqrt(a, _) => read(&v, a).sqrt(),
                Op::Select(sel, options) => {
                    let k = read(&v, sel).round();
                    let k = super::float_index(k)
                        .filter(|&k| k < options.len())
                        .unwrap_or(0);
                    read(&v, &options[k])
                }
            };
        }
        outputs.iter().map(|t| read(&v, t)).collect()
    }
    /// The named output ports, in the order they were named.
    pub fn output_ports(&self) -> &[Port] {
        &self.outputs
    }
    /// Which nodes the values `roots` depend on.
    pub fn live_nodes(&self, roots: &[TV]) -> Vec<bool> {
        let mut live = vec![false; self.ops.len()];
        for r in roots {
            live[r.node()] = true;
        }
        for i in (0..self.ops.len()).rev() {
            if !live[i] {
                continue;
            }
            let mut mark = |t: &TV| live[t.node()] = true;
            match &self.ops[i] {
                Op::Input(_) | Op::Const(_) => {}
                Op::Mul(a, b)
                | Op::Add(a, b)
                | Op::Sub(a, b)
                | Op::Max(a, b)
                | Op::Div(a, b, _) => {
                    mark(a);
                    mark(b);
                }
                Op::Quant(a, _) | Op::Table(a, _) | Op::Sqrt(a, _) => mark(a),
                Op::Select(s, o) => {
                    mark(s);
                    o.iter().for_each(mark);
                }
                Op::AddSigned(a, b, s, _) => {
                    mark(a);
                    mark(b);
                    mark(s);
                }
            }
        }
        live
    }
    /// The overflow-flag stages of the values `roots`: every distinct
    /// qualified stage id of a quantization (division, square root) they
    /// depend on, in trace order. Flag `k` of a vector is set when any
    /// quantization of stage `k` overflowed.
    pub fn flag_stages(&self, roots: &[TV]) -> Vec<String> {
        let live = self.live_nodes(roots);
        let mut v: Vec<String> = Vec::new();
        for (i, s) in self.stage_ids.iter().enumerate() {
            if let Some(s) = s {
                if live[i] && !v.contains(s) {
                    v.push(s.clone());
                }
            }
        }
        v
    }
    /// Compile the named outputs for batches.
    ///
    /// # Errors
    ///
    /// As [`Compiled::compile`].
    pub fn compile_outputs(&self) -> Result<Compiled, CompileError> {
        let outs: Vec<TV> = self.outputs.iter().map(|p| p.value).collect();
        Compiled::compile(self, &outs)
    }
}

impl Datapath for Trace {
    type V = TV;

    /// Stage ids recorded from here on are `unit.stage`; scopes nest and
    /// the innermost names the stage.
    fn enter(&mut self, unit: &'static str) {
        self.scope.push(unit);
    }
    fn leave(&mut self) {
        self.scope.pop();
    }

    fn constant(&mut self, x: f64, q: &Quant) -> Result<TV, ConvertError> {
        let r = q.apply_f64(x)?;
        if r.overflowed {
            self.const_overflows.push(q.stage());
        }
        let sym = self.count.constant(x, q)?;
        Ok(self.push(Op::Const(r.code), q.format().frac(), sym))
    }
    fn mul(&mut self, a: TV, b: TV) -> TV {
        let sym = self.count.mul(a.sym, b.sym);
        self.push(Op::Mul(a, b), a.frac + b.frac, sym)
    }
    fn add(&mut self, a: TV, b: TV) -> TV {
        let sym = self.count.add(a.sym, b.sym);
        self.push(Op::Add(a, b), a.frac.max(b.frac), sym)
    }
    fn sub(&mut self, a: TV, b: TV) -> TV {
        let sym = self.count.sub(a.sym, b.sym);
        self.push(Op::Sub(a, b), a.frac.max(b.frac), sym)
    }
    fn shl(&mut self, a: TV, n: i32) -> TV {
        // Wiring only: the same node, with the binary point moved.
        let sym = self.count.shl(a.sym, n);
        TV {
            id: a.id,
            frac: a.frac - n,
            sym,
        }
    }
    fn max(&mut self, a: TV, b: TV) -> TV {
        let sym = self.count.max(a.sym, b.sym);
        self.push(Op::Max(a, b), a.frac.max(b.frac), sym)
    }
    fn add_signed(&mut self, a: TV, b: TV, s: TV, flip: bool) -> TV {
        let sym = self.count.add_signed(a.sym, b.sym, s.sym, flip);
        self.push(Op::AddSigned(a, b, s, flip), a.frac.max(b.frac), sym)
    }
    fn quantize(&mut self, a: TV, q: &Quant) -> TV {
        let sym = self.count.quantize(a.sym, q);
        self.push(Op::Quant(a, *q), q.format().frac(), sym)
    }
    fn table(&mut self, t: &Table, index: TV) -> TV {
        let sym = self.count.table(t, index.sym);
        let i = match self
            .tables
            .iter()
            .position(|x| x.name == t.name && x.codes == t.codes)
        {
            Some(i) => i,
            None => {
                self.tables.push(t.clone());
                self.tables.len() - 1
            }
        };
        self.push(Op::Table(index, i), t.out.format().frac(), sym)
    }
    fn div(&mut self, a: TV, b: TV, q: &Quant) -> TV {
        let sym = self.count.div(a.sym, b.sym, q);
        self.push(Op::Div(a, b, *q), q.format().frac(), sym)
    }
    fn sqrt(&mut self, a: TV, q: &Quant) -> TV {
        let sym = self.count.sqrt(a.sym, q);
        self.push(Op::Sqrt(a, *q), q.format().frac(), sym)
    }
    fn select(&mut self, sel: TV, options: &[TV]) -> TV {
        let syms: Vec<Sym> = options.iter().map(|o| o.sym).collect();
        let sym = self.count.select(sel.sym, &syms);
        let frac = options.iter().map(|o| o.frac).max().expect("an option");
        self.push(Op::Select(sel, options.to_vec()), frac, sym)
    }
}

#[derive(Clone, Debug)]
enum Instr {
    Mul {
        d: usize,
        a: usize,
        b: usize,
    },
    AddSub {
        d: usize,
        a: usize,
        sa: u32,
        b: usize,
        sb: u32,
        sub: bool,
    },
    Max {
        d: usize,
        a: usize,
        sa: u32,
        b: usize,
        sb: u32,
    },
    AddSigned {
        d: usize,
        a: usize,
        sa: u32,
        b: usize,
        sb: u32,
        s: usize,
        flip: bool,
    },
    Quant {
        d: usize,
        a: usize,
        step: Step,
        round: Rounding,
        overflow: Overflow,
        stage: usize,
        flag: u64,
    },
    Select {
        d: usize,
        sel: usize,
        opts: Vec<(usize, u32)>,
        /// When every option is a constant: its slot in
        /// [`Program`]`::select_tables`, which holds the options' aligned
        /// values, so the lanes read a table (a vector gather) rather than
        /// a register per lane.
        konst: Option<usize>,
    },
    Table {
        d: usize,
        a: usize,
        table: usize,
        index: Format,
    },
    Div {
        d: usize,
        a: usize,
        fa: i32,
        b: usize,
        fb: i32,
        q: Quant,
        stage: usize,
        flag: u64,
    },
    Sqrt {
        d: usize,
        a: usize,
        fa: i32,
        q: Quant,
        stage: usize,
        flag: u64,
    },
}

impl Instr {
    /// Every register the instruction names (its destination and its
    /// operands) replaced by `f` of it.
    fn map_regs(&mut self, mut f: impl FnMut(usize) -> usize) {
        match self {
            Instr::Mul { d, a, b, .. }
            | Instr::AddSub { d, a, b, .. }
            | Instr::Max { d, a, b, .. }
            | Instr::Div { d, a, b, .. } => {
                (*d, *a, *b) = (f(*d), f(*a), f(*b));
            }
            Instr::AddSigned { d, a, b, s, .. } => {
                (*d, *a, *b, *s) = (f(*d), f(*a), f(*b), f(*s));
            }
            Instr::Quant { d, a, .. } | Instr::Table { d, a, .. } | Instr::Sqrt { d, a, .. } => {
                (*d, *a) = (f(*d), f(*a));
            }
            Instr::Select { d, sel, opts, .. } => {
                (*d, *sel) = (f(*d), f(*sel));
                for o in opts {
                    o.0 = f(o.0);
                }
            }
        }
    }

    /// The register an instruction writes.
    fn dest(&self) -> usize {
        match *self {
            Instr::Mul { d, .. }
            | Instr::AddSub { d, .. }
            | Instr::Max { d, .. }
            | Instr::AddSigned { d, .. }
            | Instr::Quant { d, .. }
            | Instr::Select { d, .. }
            | Instr::Table { d, .. }
            | Instr::Div { d, .. }
            | Instr::Sqrt { d, .. } => d,
        }
    }

    /// Call `f` with each register an instruction reads.
    fn each_operand(&self, mut f: impl FnMut(usize)) {
        match *self {
            Instr::Mul { a, b, .. }
            | Instr::AddSub { a, b, .. }
            | Instr::Max { a, b, .. }
            | Instr::Div { a, b, .. } => {
                f(a);
                f(b);
            }
            Instr::AddSigned { a, b, s, .. } => {
                f(a);
                f(b);
                f(s);
            }
            Instr::Quant { a, .. } | Instr::Table { a, .. } | Instr::Sqrt { a, .. } => f(a),
            Instr::Select { sel, ref opts, .. } => {
                f(sel);
                for o in opts {
                    f(o.0);
                }
            }
        }
    }
}

/// How an instruction runs when the block loop fuses ([`Program`]`::fused`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fusion {
    /// On its own.
    Alone,
    /// Not at all: the quantization that alone reads it computes it.
    Deferred,
    /// A quantization computing its operand, instruction `producer` (a
    /// product or sum), in the same pass; for a sum, `product` is an
    /// operand that is itself a deferred product: `(side_b, instruction)`.
    Quant {
        producer: usize,
        product: Option<(bool, usize)>,
    },
    /// A quantization of a sum of two to four products, each read by
    /// nothing else, through sums read by nothing else: `terms[..n]`, each
    /// a product's instruction, its left shift and whether it is
    /// subtracted (the sums' alignments and signs carried down to it).
    Dot { terms: [DotTerm; 4], n: usize },
}

/// One product of a [`Fusion::Dot`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
struct DotTerm {
    mul: usize,
    shift: u32,
    neg: bool,
}

/// The products a sum tree below node `n` adds up ([`Fusion::Dot`]),
/// shifted left by `shift` and negated when `neg`, appended to `out`; at
/// most `depth` more sums deep, each of its nodes read only once.
/// `single(n, ok)`: `n`'s instruction when it can fuse and `ok` accepts it.
fn dot_terms(
    n: usize,
    shift: u32,
    neg: bool,
    depth: usize,
    single: &dyn Fn(usize, fn(&Instr) -> bool) -> Option<usize>,
    instrs: &[Instr],
    out: &mut Vec<DotTerm>,
) -> bool {
    if let Some(mul) = single(n, |i| matches!(i, Instr::Mul { .. })) {
        out.push(DotTerm { mul, shift, neg });
        return true;
    }
    if depth == 0 {
        return false;
    }
    let Some(i) = single(n, |i| matches!(i, Instr::AddSub { .. })) else {
        return false;
    };
    let Instr::AddSub {
        a, sa, b, sb, sub, ..
    } = instrs[i]
    else {
        return false;
    };
    dot_terms(a, shift + sa, neg, depth - 1, single, instrs, out)
        && dot_terms(b, shift + sb, neg != sub, depth - 1, single, instrs, out)
}

/// Which instructions fuse ([`Fusion`]): a quantization whose operand is a
/// product or sum read by nothing else and no output computes it; a sum so
/// computed computes an operand that is such a product too. `readers`:
/// per node, how many operands name it; `named`: how many outputs.
fn fusions(instrs: &[Instr], readers: &[usize], named: &[usize]) -> Vec<Fusion> {
    let mut at = vec![usize::MAX; readers.len()];
    for (i, ins) in instrs.iter().enumerate() {
        at[ins.dest()] = i;
    }
    // Node `n`'s instruction when only one operand reads it, it is no
    // output, and it is of a kind `ok` accepts.
    let single = |n: usize, ok: fn(&Instr) -> bool| -> Option<usize> {
        let i = *at.get(n)?;
        (i != usize::MAX && readers[n] == 1 && named[n] == 0 && ok(&instrs[i])).then_some(i)
    };
    let mut f = vec![Fusion::Alone; instrs.len()];
    for (j, ins) in instrs.iter().enumerate() {
        let Instr::Quant { a, .. } = *ins else {
            continue;
        };
        let Some(p) = single(a, |i| matches!(i, Instr::Mul { .. } | Instr::AddSub { .. })) else {
            continue;
        };
        let mut terms = Vec::new();
        if dot_terms(a, 0, false, 2, &single, instrs, &mut terms) && (2..=4).contains(&terms.len())
        {
            // Every sum of the tree and every product runs in the pass.
            let mut stack = vec![a];
            while let Some(n) = stack.pop() {
                let i = at[n];
                f[i] = Fusion::Deferred;
                if let Instr::AddSub { a, b, .. } = instrs[i] {
                    stack.extend([a, b]);
                }
            }
            let mut arr = [DotTerm::default(); 4];
            arr[..terms.len()].copy_from_slice(&terms);
            f[j] = Fusion::Dot {
                terms: arr,
                n: terms.len(),
            };
            continue;
        }
        let is_mul: fn(&Instr) -> bool = |i| matches!(i, Instr::Mul { .. });
        let product = match instrs[p] {
            Instr::AddSub { a, b, .. } => single(a, is_mul)
                .map(|m| (false, m))
                .or_else(|| single(b, is_mul).map(|m| (true, m))),
            _ => None,
        };
        f[p] = Fusion::Deferred;
        if let Some((_, m)) = product {
            f[m] = Fusion::Deferred;
        }
        f[j] = Fusion::Quant {
            producer: p,
            product,
        };
    }
    f
}

/// Lanes per block: registers of a block stay in the L1 cache.
pub const BLOCK: usize = 256;

/// A datapath compiled for codes of type `R`: instructions with resolved
/// shifts, one register (a block of lanes) per node.
#[derive(Clone, Debug)]
pub struct Program<R> {
    instrs: Vec<Instr>,
    /// Per instruction, how it runs when the block loop fuses ([`Fusion`]):
    /// a quantization of a product or sum that nothing else reads computes
    /// that operand in its own pass over the lanes (the exact value stays
    /// in a vector register, never stored), unless the caller reads the
    /// quantization's operand ([`Program::probe`]).
    fused: Vec<Fusion>,
    n_regs: usize,
    consts: Vec<(usize, R)>,
    inputs: Vec<(usize, Quant)>,
    /// Per node: the input port its operations read in place, from the
    /// caller's slice ([`IN_REGISTER`]: from its register).
    port_of: Vec<usize>,
    /// The input ports still copied into their registers: read lane by lane
    /// by a select, or an output themselves.
    loaded: Vec<usize>,
    outputs: Vec<(usize, i32)>,
    /// Per node: the output its instruction writes in place, into the
    /// caller's output vector ([`IN_REGISTER`]: into its register).
    out_of: Vec<usize>,
    /// The outputs still copied out of their registers after each block:
    /// inputs or constants themselves, read by a later instruction, or a
    /// node given as two outputs.
    copied: Vec<usize>,
    tables: Vec<Vec<R>>,
    /// Per select of constants ([`Instr`]`::Select::konst`): the options'
    /// values, aligned as the select shifts them, padded with option 0 to
    /// a power of two (a slot past the options reads option 0, as the
    /// select does).
    select_tables: Vec<Vec<R>>,
    /// Each table's smallest and largest entry, whole and per block of
    /// entries (the interval analysis' range of a read).
    table_hulls: Vec<interval::TableHull>,
    stages: Vec<&'static str>,
    flag_stages: Vec<String>,
    const_overflows: Vec<&'static str>,
    counts: super::OpCounts,
    max_width: u32,
    /// Flag bits every lane carries: the stages of quantizations a
    /// [specialized](Program::specialize) program folded that overflowed
    /// (zero for a compiled one).
    base_flags: u64,
    /// The stage of each such folded quantization that overflowed, once
    /// per quantization: every lane counts it.
    base_overflows: Vec<usize>,
    pool: RegPool<R>,
}

/// Where a program's values live ([`Program`]`::port_of`, `loaded`,
/// `out_of`, `copied`) and which instructions fuse (`fused`): what
/// [`Program::compile`] derives from the instruction list, and
/// [`Program::specialize`] again from a shorter one.
struct Layout {
    port_of: Vec<usize>,
    loaded: Vec<usize>,
    out_of: Vec<usize>,
    copied: Vec<usize>,
    fused: Vec<Fusion>,
}

impl<R> Program<R> {
    /// This program with its layout derived again from its instructions,
    /// inputs and outputs ([`Layout::of`]), for a program built from
    /// another with those changed.
    fn laid_out(self) -> Program<R> {
        let Layout {
            port_of,
            loaded,
            out_of,
            copied,
            fused,
        } = Layout::of(&self.instrs, &self.inputs, &self.outputs, self.n_regs);
        Program {
            port_of,
            loaded,
            out_of,
            copied,
            fused,
            ..self
        }
    }
}

impl Layout {
    /// The layout of `instrs` over `n_regs` registers with these input
    /// ports and outputs.
    fn of(
        instrs: &[Instr],
        inputs: &[(usize, Quant)],
        outputs: &[(usize, i32)],
        n_regs: usize,
    ) -> Layout {
        // Operations read the inputs where the caller holds them (no copy
        // per block), except where a select reads them lane by lane or an
        // output is an input itself: those are copied into registers.
        let mut port_of = vec![IN_REGISTER; n_regs];
        for (k, &(d, _)) in inputs.iter().enumerate() {
            port_of[d] = k;
        }
        for ins in instrs {
            if let Instr::Select { opts, .. } = ins {
                for &(o, _) in opts {
                    port_of[o] = IN_REGISTER;
                }
            }
        }
        for &(o, _) in outputs {
            port_of[o] = IN_REGISTER;
        }
        let loaded = (0..inputs.len())
            .filter(|&k| port_of[inputs[k].0] == IN_REGISTER)
            .collect();
        // An output that an instruction writes and no instruction reads is
        // written straight into the caller's output vector (no copy out of
        // each block); the others are copied from their registers.
        let mut read = vec![false; n_regs];
        let mut written = vec![false; n_regs];
        for ins in instrs {
            written[ins.dest()] = true;
            ins.each_operand(|a| read[a] = true);
        }
        // (A node named by two outputs stays in its register: both copy it.)
        let mut named = vec![0usize; n_regs];
        for &(o, _) in outputs {
            named[o] += 1;
        }
        let mut out_of = vec![IN_REGISTER; n_regs];
        for (k, &(o, _)) in outputs.iter().enumerate() {
            if written[o] && !read[o] && named[o] == 1 {
                out_of[o] = k;
            }
        }
        let copied = (0..outputs.len())
            .filter(|&k| out_of[outputs[k].0] != k)
            .collect();
        let mut readers = vec![0usize; n_regs];
        for ins in instrs {
            ins.each_operand(|a| readers[a] += 1);
        }
        let fused = fusions(instrs, &readers, &named);
        Layout {
            port_of,
            loaded,
            out_of,
            copied,
            fused,
        }
    }
}

/// Register files of earlier runs, kept for the next run of the same
/// program (a search runs one program thousands of times on a few lanes;
/// allocating and zeroing a register per node each time cost more than the
/// run). A kept file needs no clearing: its constants never change, and
/// every other register a run reads is written earlier in the same block.
#[derive(Debug, Default)]
struct RegPool<R>(std::sync::Mutex<Vec<Vec<R>>>);

impl<R> Clone for RegPool<R> {
    /// A clone starts with no kept files.
    fn clone(&self) -> Self {
        RegPool(std::sync::Mutex::new(Vec::new()))
    }
}

/// [`Program`]`::port_of` of a node that lives in its register.
const IN_REGISTER: usize = usize::MAX;

/// Register files kept per program (one per thread that runs it at once,
/// up to this many).
const POOLED_FILES: usize = 4;

/// Why a trace cannot be compiled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompileError {
    /// An intermediate is wider than the code type holds exactly.
    #[error(transparent)]
    Width(#[from] WidthError),
    /// The `i64` fast path was asked for a datapath that needs more bits.
    #[error("the datapath needs {0}-bit intermediates; i64 codes hold 62")]
    TooWideForI64(u32),
    /// More distinct quantization stages than per-lane flags hold.
    #[error("the datapath has {0} quantization stages; per-vector overflow flags hold 64")]
    TooManyStages(usize),
}

fn stage_index(stages: &mut Vec<&'static str>, s: &'static str) -> usize {
    match stages.iter().position(|x| *x == s) {
        Some(i) => i,
        None => {
            stages.push(s);
            stages.len() - 1
        }
    }
}

impl<R: Raw> Program<R> {
    /// Compile the trace for the given outputs: the operations they read
    /// (every input port keeps its place among the program's inputs).
    ///
    /// # Errors
    ///
    /// A [`CompileError`]: the trace's counting run found an intermediate
    /// wider than the model holds exactly, an intermediate does not fit the
    /// code type `R`, or the quantization stages outnumber the flag bits.
    pub fn compile(trace: &Trace, outputs: &[TV]) -> Result<Self, CompileError> {
        if let Some(e) = trace.count.width_errors().first() {
            return Err(e.clone().into());
        }
        if R::BITS == 64 && !trace.count.fits_i64() {
            return Err(CompileError::TooWideForI64(trace.count.max_width()));
        }
        let mut stages = Vec::new();
        let flag_stages = trace.flag_stages(outputs);
        if flag_stages.len() > 64 {
            return Err(CompileError::TooManyStages(flag_stages.len()));
        }
        let live = trace.live_nodes(outputs);
        // Stage k is bit n−1−k: the first stage is the most significant
        // bit, as in the RTL's `ovf_o` and the vector files' `ovf` field.
        let n = flag_stages.len();
        let flag_of = |d: usize| -> u64 {
            if !live[d] {
                return 0;
            }
            let id = trace.stage_ids[d].as_deref().unwrap_or("");
            flag_stages
                .iter()
                .position(|s| s == id)
                .map_or(0, |k| 1u64 << (n - 1 - k))
        };
        let mut instrs = Vec::new();
        let mut consts = Vec::new();
        let mut inputs = Vec::new();
        let mut select_tables: Vec<Vec<R>> = Vec::new();
        let fr = |v: &TV| v.frac;
        for (d, op) in trace.ops.iter().enumerate() {
            let f = trace.fracs[d];
            // Operations no output reads are left out (their registers
            // stay zero); inputs keep their places, constants cost nothing.
            if !live[d] && !matches!(op, Op::Input(_) | Op::Const(_)) {
                continue;
            }
            match op {
                Op::Input(slot) => inputs.push((d, trace.inputs[*slot])),
                Op::Const(c) => consts.push((d, R::from_i128(*c))),
                Op::Mul(a, b) => instrs.push(Instr::Mul {
                    d,
                    a: a.id as usize,
                    b: b.id as usize,
                }),
                Op::Add(a, b) | Op::Sub(a, b) => instrs.push(Instr::AddSub {
                    d,
                    a: a.id as usize,
                    sa: align(f, fr(a)),
                    b: b.id as usize,
                    sb: align(f, fr(b)),
                    sub: matches!(op, Op::Sub(..)),
                }),
                Op::Max(a, b) => instrs.push(Instr::Max {
                    d,
                    a: a.id as usize,
                    sa: align(f, fr(a)),
                    b: b.id as usize,
                    sb: align(f, fr(b)),
                }),
                Op::AddSigned(a, b, s, flip) => instrs.push(Instr::AddSigned {
                    d,
                    a: a.id as usize,
                    sa: align(f, fr(a)),
                    b: b.id as usize,
                    sb: align(f, fr(b)),
                    s: s.id as usize,
                    flip: *flip,
                }),
                Op::Quant(a, q) => instrs.push(Instr::Quant {
                    d,
                    a: a.id as usize,
                    step: q.step(a.frac),
                    round: q.round(),
                    overflow: q.overflow(),
                    stage: stage_index(&mut stages, q.stage()),
                    flag: flag_of(d),
                }),
                Op::Select(sel, opts) => {
                    let opts: Vec<(usize, u32)> = opts
                        .iter()
                        .map(|o| (o.id as usize, align(f, fr(o))))
                        .collect();
                    // The values a select of constants reads: each
                    // option's register holds its constant in every lane.
                    let values: Option<Vec<R>> = opts
                        .iter()
                        .map(|&(o, sh)| match trace.ops[o] {
                            Op::Const(c) => Some(R::from_i128(c) << sh),
                            _ => None,
                        })
                        .collect();
                    let konst = values.map(|mut v| {
                        v.resize(v.len().next_power_of_two(), v[0]);
                        select_tables.push(v);
                        select_tables.len() - 1
                    });
                    instrs.push(Instr::Select {
                        d,
                        sel: sel.id as usize,
                        opts,
                        konst,
                    });
                }
                Op::Table(a, t) => instrs.push(Instr::Table {
                    d,
                    a: a.id as usize,
                    table: *t,
                    index: trace.tables[*t].index,
                }),
                Op::Div(a, b, q) => instrs.push(Instr::Div {
                    d,
                    a: a.id as usize,
                    fa: a.frac,
                    b: b.id as usize,
                    fb: b.frac,
                    q: *q,
                    stage: stage_index(&mut stages, q.stage()),
                    flag: flag_of(d),
                }),
                Op::Sqrt(a, q) => instrs.push(Instr::Sqrt {
                    d,
                    a: a.id as usize,
                    fa: a.frac,
                    q: *q,
                    stage: stage_index(&mut stages, q.stage()),
                    flag: flag_of(d),
                }),
            }
        }
        let outputs: Vec<(usize, i32)> = outputs.iter().map(|o| (o.id as usize, o.frac)).collect();
        let Layout {
            port_of,
            loaded,
            out_of,
            copied,
            fused,
        } = Layout::of(&instrs, &inputs, &outputs, trace.ops.len());
        let table_hulls = trace
            .tables
            .iter()
            .map(|t| interval::TableHull::of(&t.codes))
            .collect();
        Ok(Program {
            instrs,
            fused,
            n_regs: trace.ops.len(),
            consts,
            inputs,
            port_of,
            loaded,
            outputs,
            out_of,
            copied,
            tables: trace
                .tables
                .iter()
                .map(|t| t.codes.iter().map(|&c| R::from_i128(c)).collect())
                .collect(),
            select_tables,
            table_hulls,
            stages,
            flag_stages,
            const_overflows: trace.const_overflows.clone(),
            counts: trace.count.counts(),
            max_width: trace.count.max_width(),
            base_flags: 0,
            base_overflows: Vec::new(),
            pool: RegPool(std::sync::Mutex::new(Vec::new())),
        })
    }

    /// The input ports, in creation order.
    pub fn inputs(&self) -> impl Iterator<Item = &Quant> {
        self.inputs.iter().map(|(_, q)| q)
    }
    /// Fraction bits of each output.
    pub fn output_fracs(&self) -> Vec<i32> {
        self.outputs.iter().map(|o| o.1).collect()
    }
    /// How many instructions a lane runs (fewer than the operations
    /// [`Program::counts`] counts once [specialized](Program::specialize)).
    pub fn instructions(&self) -> usize {
        self.instrs.len()
    }
    /// The operation counts of one lane (of the program as compiled, also
    /// after [`Program::specialize`]).
    pub fn counts(&self) -> &super::OpCounts {
        &self.counts
    }
    /// The widest value, in bits of a signed container.
    pub fn max_width(&self) -> u32 {
        self.max_width
    }
    /// Stages whose constant overflowed when it was loaded.
    pub fn const_overflows(&self) -> &[&'static str] {
        &self.const_overflows
    }

    /// Run every lane: `inputs[i]` holds the codes of input port `i` (all of
    /// one length `n`); returns the codes of each output (length `n`) and the
    /// overflows per stage.
    pub fn run(&self, inputs: &[&[R]]) -> (Vec<Vec<R>>, Vec<(&'static str, u64)>) {
        let mut outs: Vec<Vec<R>> = self.outputs.iter().map(|_| Vec::new()).collect();
        let ov = self.run_into(inputs, &mut outs);
        (outs, ov)
    }

    /// As [`Program::run`], writing into `outs` (one vector per output,
    /// its contents replaced by the run's `n` codes; their capacity is
    /// reused across calls).
    pub fn run_into(&self, inputs: &[&[R]], outs: &mut [Vec<R>]) -> Vec<(&'static str, u64)> {
        self.run_lanes(inputs, outs, None)
    }

    /// The overflow-flag stages ([`Trace::flag_stages`]): stage `k` of `n`
    /// is bit `n − 1 − k` of a lane's flags (the first stage the most
    /// significant bit, as in the RTL's `ovf_o` and the vector files).
    pub fn flag_stages(&self) -> &[String] {
        &self.flag_stages
    }

    /// As [`Program::run`], with each lane's overflow flags: bit `n − 1 − k`
    /// set when a quantization of [`Program::flag_stages`]`[k]` (of `n`)
    /// overflowed in that lane — the word the RTL's `ovf_o` carries.
    pub fn run_flags(&self, inputs: &[&[R]]) -> (Vec<Vec<R>>, Vec<u64>) {
        let mut outs: Vec<Vec<R>> = self.outputs.iter().map(|_| Vec::new()).collect();
        let mut flags = Vec::new();
        self.run_lanes(inputs, &mut outs, Some(&mut flags));
        (outs, flags)
    }

    /// The exact (unquantized) operand of each quantization node in
    /// `nodes`, per lane: what the quantizer at that node received. For
    /// looking inside the datapath (rounding ties, overflows) without
    /// re-running it in the scalar context.
    ///
    /// # Panics
    ///
    /// When a node of `nodes` is not a quantization the program computes.
    pub fn probe(&self, inputs: &[&[R]], nodes: &[usize]) -> Vec<Vec<i128>> {
        let operand: Vec<usize> = nodes
            .iter()
            .map(|&n| {
                self.instrs
                    .iter()
                    .find_map(|ins| match *ins {
                        Instr::Quant { d, a, .. } if d == n => Some(a),
                        _ => None,
                    })
                    .unwrap_or_else(|| panic!("node {n} is not a quantization of the program"))
            })
            .collect();
        let n = inputs.first().map_or(0, |s| s.len());
        let mut probes: Vec<Vec<i128>> = nodes.iter().map(|_| Vec::with_capacity(n)).collect();
        let mut ov = vec![0u64; self.stages.len()];
        let mut flags = [0u64; BLOCK];
        let mut regs = self.fresh_regs();
        // The outputs written in place need somewhere to go.
        let mut outs: Vec<Vec<R>> = self.outputs.iter().map(|_| vec![R::ZERO; n]).collect();
        let mut start = 0;
        while start < n {
            let len = BLOCK.min(n - start);
            self.load_block(&mut regs, inputs, start, len);
            let lanes = Lanes { inputs, start, len };
            let ovf = Overflows {
                counts: &mut ov,
                lanes: &mut flags[..len],
                per_lane: false,
            };
            self.block_unfused(&mut regs, lanes, &mut outs, ovf);
            for (p, &a) in probes.iter_mut().zip(&operand) {
                let x = operand_of(&self.port_of, &regs, lanes, a);
                p.extend(x.iter().map(|x| x.to_i128()));
            }
            start += len;
        }
        probes
    }

    /// The folded quantizations' overflows ([`Program`]`::base_flags`) in
    /// lanes `start..start + len`: counted per stage, and in the lanes'
    /// flags when the caller reads them.
    fn add_base_flags(
        &self,
        ov: &mut [u64],
        lane_flags: Option<&mut Vec<u64>>,
        start: usize,
        len: usize,
    ) {
        for &s in &self.base_overflows {
            ov[s] += len as u64;
        }
        if let Some(f) = lane_flags {
            if self.base_flags != 0 {
                for f in &mut f[start..start + len] {
                    *f |= self.base_flags;
                }
            }
        }
    }

    /// A block of registers with the constants loaded.
    fn fresh_regs(&self) -> Vec<R> {
        let mut regs = vec![R::ZERO; self.n_regs * BLOCK];
        for &(d, c) in &self.consts {
            regs[d * BLOCK..(d + 1) * BLOCK].fill(c);
        }
        regs
    }

    /// Lanes `start..start + len` of the inputs that are not read in place
    /// ([`Program`]`::loaded`) into their registers.
    fn load_block(&self, regs: &mut [R], inputs: &[&[R]], start: usize, len: usize) {
        for &k in &self.loaded {
            let d = self.inputs[k].0;
            regs[d * BLOCK..d * BLOCK + len].copy_from_slice(&inputs[k][start..start + len]);
        }
    }

    fn run_lanes(
        &self,
        inputs: &[&[R]],
        outs: &mut [Vec<R>],
        lane_flags: Option<&mut Vec<u64>>,
    ) -> Vec<(&'static str, u64)> {
        self.run_lanes_on(Isa::current(), inputs, outs, lane_flags)
    }

    fn run_lanes_on(
        &self,
        isa: Isa,
        inputs: &[&[R]],
        outs: &mut [Vec<R>],
        mut lane_flags: Option<&mut Vec<u64>>,
    ) -> Vec<(&'static str, u64)> {
        assert_eq!(inputs.len(), self.inputs.len(), "one slice per input port");
        assert_eq!(outs.len(), self.outputs.len(), "one vector per output");
        let n = inputs.first().map_or(0, |s| s.len());
        assert!(
            inputs.iter().all(|s| s.len() == n),
            "input slices of equal length"
        );
        // Every output holds `n` codes before the first block: the
        // instructions write their lanes in place (a vector already `n`
        // long is overwritten, not cleared).
        for o in outs.iter_mut() {
            if o.len() != n {
                o.clear();
                o.resize(n, R::ZERO);
            }
        }
        let mut ov = vec![0u64; self.stages.len()];
        let mut flags = [0u64; BLOCK];
        // The lanes' flags are or-ed into zeros, in place when asked for.
        if let Some(f) = lane_flags.as_deref_mut() {
            f.clear();
            f.resize(n, 0);
        }
        let kept = self.pool.0.lock().ok().and_then(|mut p| p.pop());
        let mut regs = kept.unwrap_or_else(|| self.fresh_regs());
        let mut start = 0;
        while start < n {
            let len = BLOCK.min(n - start);
            self.load_block(&mut regs, inputs, start, len);
            let lanes = Lanes { inputs, start, len };
            let per_lane = lane_flags.is_some();
            let block_flags = match lane_flags.as_deref_mut() {
                Some(f) => &mut f[start..start + len],
                None => {
                    flags[..len].fill(0);
                    &mut flags[..len]
                }
            };
            let ovf = Overflows {
                counts: &mut ov,
                lanes: block_flags,
                per_lane,
            };
            self.block_on(isa, &mut regs, lanes, outs, ovf);
            self.add_base_flags(&mut ov, lane_flags.as_deref_mut(), start, len);
            for &k in &self.copied {
                let o = self.outputs[k].0;
                outs[k][start..start + len].copy_from_slice(&regs[o * BLOCK..o * BLOCK + len]);
            }
            start += len;
        }
        if let Ok(mut p) = self.pool.0.lock() {
            if p.len() < POOLED_FILES {
                p.push(regs);
            }
        }
        self.stages
            .iter()
            .zip(ov)
            .filter(|(_, n)| *n > 0)
            .map(|(s, n)| (*s, n))
            .collect()
    }

    /// One block of lanes, on the instruction set [`Isa::current`] chose,
    /// every quantization's operand in its register (nothing fused).
    fn block_unfused(
        &self,
        regs: &mut [R],
        lanes: Lanes<'_, R>,
        outs: &mut [Vec<R>],
        ovf: Overflows<'_>,
    ) {
        Isa::current().run(Block {
            p: self,
            regs,
            lanes,
            outs,
            ovf,
            fuse: false,
        });
    }

    /// One block of lanes on `isa`: the same body compiled once per
    /// instruction set.
    fn block_on(
        &self,
        isa: Isa,
        regs: &mut [R],
        lanes: Lanes<'_, R>,
        outs: &mut [Vec<R>],
        ovf: Overflows<'_>,
    ) {
        isa.run(Block {
            p: self,
            regs,
            lanes,
            outs,
            ovf,
            // The portable path keeps the pairs apart: its quantization
            // loops vectorize apart, and fused they ran slower there
            // (`bench engine`'s chain: 26 ns a vector against 30).
            fuse: isa != Isa::Portable,
        });
    }

    /// As [`Program::run_into`], on the instruction set `isa` rather than
    /// the one [`Isa::current`] chose (for tests that every path computes
    /// the same codes, and for `fxshade bench engine`).
    ///
    /// # Panics
    ///
    /// When this CPU lacks `isa` ([`Isa::available`]), or as
    /// [`Program::run_into`] on mismatched slices.
    pub fn run_into_on(
        &self,
        isa: Isa,
        inputs: &[&[R]],
        outs: &mut [Vec<R>],
    ) -> Vec<(&'static str, u64)> {
        assert!(
            isa.available(),
            "{} is not available on this CPU",
            isa.name()
        );
        self.run_lanes_on(isa, inputs, outs, None)
    }
}

/// An instruction set the engine's block loop is compiled for. Every path
/// runs the same Rust body ([`block_body`]'s loops over 256 lanes; the
/// vector paths run a product or sum and its quantization as one loop,
/// [`Program`]`::fused`, the same exact values then the same quantization),
/// so the codes and overflow counts are identical by construction; the suite
/// checks it on every path the test machine has
/// (`every_instruction_set_computes_the_same_codes`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// The target's baseline: SSE2 on x86-64, NEON on aarch64 (NEON is part
    /// of Rust's aarch64 baseline, so the portable body is the NEON path).
    Portable,
    /// x86-64 AVX2: 256-bit integer shifts, compares and selects.
    Avx2,
    /// x86-64 AVX-512 F, BW, DQ and VL: 512-bit lanes, 64-bit multiplies
    /// (`vpmullq`) and mask registers.
    Avx512,
}

impl Isa {
    /// Every path, narrowest first.
    pub const ALL: [Isa; 3] = [Isa::Portable, Isa::Avx2, Isa::Avx512];

    /// Its name in `bench engine` and in errors.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Portable if cfg!(target_arch = "aarch64") => "neon",
            Isa::Portable => "portable",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    /// Whether this CPU runs it (detected at run time).
    pub fn available(self) -> bool {
        match self {
            Isa::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512bw")
                    && std::arch::is_x86_feature_detected!("avx512dq")
                    && std::arch::is_x86_feature_detected!("avx512vl")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The widest path this CPU has, chosen once per process.
    pub fn current() -> Isa {
        static BEST: std::sync::OnceLock<Isa> = std::sync::OnceLock::new();
        *BEST.get_or_init(|| {
            Isa::ALL
                .into_iter()
                .rev()
                .find(|i| i.available())
                .unwrap_or(Isa::Portable)
        })
    }
}

/// A computation [`Isa::run`] compiles once per instruction set. Mark
/// [`Kernel::call`] `#[inline(always)]` (and whatever it calls in its loops):
/// only inlined code is compiled with the path's features.
pub trait Kernel {
    /// What it computes.
    type Output;
    /// Compute it.
    fn call(self) -> Self::Output;
}

impl Isa {
    /// `k.call()`, from a function compiled with this instruction set
    /// enabled, so that the loops inlined into it are vectorized for it;
    /// on [`Isa::Portable`] a plain call. Floating-point results are those
    /// of the same operations without the features (Rust never fuses
    /// `a·b + c` into one rounding), so only the speed depends on the path.
    ///
    /// # Panics
    ///
    /// When this CPU lacks `self` ([`Isa::available`]).
    pub fn run<K: Kernel>(self, k: K) -> K::Output {
        assert!(
            self.available(),
            "{} is not available on this CPU",
            self.name()
        );
        match self {
            // SAFETY: the CPU supports AVX-512 F/BW/DQ/VL (asserted above).
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => unsafe { run_avx512(k) },
            // SAFETY: the CPU supports AVX2 (asserted above).
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => unsafe { run_avx2(k) },
            _ => k.call(),
        }
    }
}

/// [`Isa::run`] on AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_avx2<K: Kernel>(k: K) -> K::Output {
    k.call()
}

/// [`Isa::run`] on AVX-512 F, BW, DQ and VL.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
fn run_avx512<K: Kernel>(k: K) -> K::Output {
    k.call()
}

/// One block of lanes as an [`Isa::run`] kernel: [`block_body`] compiled
/// once per instruction set (AVX2: wide integer shifts, compares and
/// selects; AVX-512: 512-bit vectors, native 64-bit multiplies and
/// arithmetic right shifts, mask registers for the selects).
struct Block<'a, R> {
    p: &'a Program<R>,
    regs: &'a mut [R],
    lanes: Lanes<'a, R>,
    /// The caller's output vectors, `n` codes each.
    outs: &'a mut [Vec<R>],
    ovf: Overflows<'a>,
    /// Whether [`Program`]`::fused` instructions run as one pass.
    fuse: bool,
}

/// Where a block's quantizations report their overflows.
struct Overflows<'a> {
    /// Per stage, the overflows counted so far.
    counts: &'a mut [u64],
    /// Per lane of the block (`len` of them), the flag bits of the stages
    /// that overflowed there.
    lanes: &'a mut [u64],
    /// Whether the caller reads `lanes`: without, quantizations only count
    /// (the divisions and square roots, lane by lane anyway, still write
    /// `lanes`).
    per_lane: bool,
}

impl<R: Raw> Kernel for Block<'_, R> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        block_body(
            self.p, self.regs, self.lanes, self.outs, self.ovf, self.fuse,
        );
    }
}

#[inline(always)]
fn block_body<R: Raw>(
    p: &Program<R>,
    regs: &mut [R],
    lanes: Lanes<'_, R>,
    outs: &mut [Vec<R>],
    ovf: Overflows<'_>,
    fuse: bool,
) {
    let Overflows {
        counts: ov,
        lanes: flags,
        per_lane: want_flags,
    } = ovf;
    let len = lanes.len;
    let start = lanes.start;
    let port_of = &p.port_of[..];
    let out_of = &p.out_of[..];
    // Where instruction `d` writes its lanes: its register (in `hi`, the
    // registers from `d` on) or, for an output no instruction reads, the
    // caller's output vector.
    macro_rules! dest {
        ($hi:expr, $d:expr) => {
            match out_of[$d] {
                IN_REGISTER => &mut $hi[..len],
                k => &mut outs[k][start..start + len],
            }
        };
    }
    {
        let this = p;
        for (i, ins) in this.instrs.iter().enumerate() {
            match (fuse, this.fused[i], ins) {
                (true, Fusion::Deferred, _) => continue,
                (
                    true,
                    fusion @ (Fusion::Dot { .. } | Fusion::Quant { .. }),
                    &Instr::Quant {
                        d,
                        step,
                        round,
                        overflow,
                        stage,
                        flag,
                        ..
                    },
                ) => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let (dst, fl) = (dest!(hi, d), &mut flags[..len]);
                    let q = QuantOf {
                        flag,
                        st: &step,
                        round,
                        overflow,
                        want_flags,
                    };
                    let at = |n: usize| operand_of(port_of, lo, lanes, n);
                    ov[stage] += match fusion {
                        Fusion::Dot { terms, n } => {
                            // The terms past `n` repeat the first (their lanes are
                            // read, never summed).
                            let factors: [[&[R]; 2]; 4] = std::array::from_fn(|t| {
                                match this.instrs[terms[if t < n { t } else { 0 }].mul] {
                                    Instr::Mul { a, b, .. } => [at(a), at(b)],
                                    _ => unreachable!("a dot's term is a product"),
                                }
                            });
                            let sh = terms.map(|t| t.shift);
                            let neg = terms.map(|t| t.neg);
                            // Σ ±(x·y << s), in wrapping arithmetic: the exact sum
                            // fits its node, so any order gives it.
                            let term = move |x: R, y: R, t: usize| {
                                let p = x.mul_raw(y) << sh[t];
                                if neg[t] {
                                    R::ZERO - p
                                } else {
                                    p
                                }
                            };
                            let [[a0, b0], [a1, b1], [a2, b2], [a3, b3]] = factors;
                            match n {
                                2 => q.run(
                                    [a0, b0, a1, b1],
                                    dst,
                                    fl,
                                    move |[x0, y0, x1, y1]: [R; 4]| {
                                        term(x0, y0, 0).wrapping_add_raw(term(x1, y1, 1))
                                    },
                                ),
                                3 => q.run(
                                    [a0, b0, a1, b1, a2, b2],
                                    dst,
                                    fl,
                                    move |[x0, y0, x1, y1, x2, y2]: [R; 6]| {
                                        term(x0, y0, 0)
                                            .wrapping_add_raw(term(x1, y1, 1))
                                            .wrapping_add_raw(term(x2, y2, 2))
                                    },
                                ),
                                _ => q.run(
                                    [a0, b0, a1, b1, a2, b2, a3, b3],
                                    dst,
                                    fl,
                                    move |[x0, y0, x1, y1, x2, y2, x3, y3]: [R; 8]| {
                                        term(x0, y0, 0)
                                            .wrapping_add_raw(term(x1, y1, 1))
                                            .wrapping_add_raw(term(x2, y2, 2))
                                            .wrapping_add_raw(term(x3, y3, 3))
                                    },
                                ),
                            }
                        }
                        Fusion::Quant { producer, product } => {
                            let mul = |m: usize| match this.instrs[m] {
                                Instr::Mul { a, b, .. } => (at(a), at(b)),
                                _ => unreachable!("a fused product is a product"),
                            };
                            match (&this.instrs[producer], product) {
                                (&Instr::Mul { a, b, .. }, _) => {
                                    q.run([at(a), at(b)], dst, fl, |[x, y]: [R; 2]| x.mul_raw(y))
                                }
                                (
                                    &Instr::AddSub {
                                        a, sa, b, sb, sub, ..
                                    },
                                    None,
                                ) => {
                                    if sub {
                                        q.run([at(a), at(b)], dst, fl, move |[x, y]: [R; 2]| {
                                            (x << sa) - (y << sb)
                                        })
                                    } else {
                                        q.run([at(a), at(b)], dst, fl, move |[x, y]: [R; 2]| {
                                            (x << sa) + (y << sb)
                                        })
                                    }
                                }
                                (&Instr::AddSub { sa, b, sb, sub, .. }, Some((false, m))) => {
                                    let (x, y) = mul(m);
                                    if sub {
                                        q.run([x, y, at(b)], dst, fl, move |[x, y, z]: [R; 3]| {
                                            (x.mul_raw(y) << sa) - (z << sb)
                                        })
                                    } else {
                                        q.run([x, y, at(b)], dst, fl, move |[x, y, z]: [R; 3]| {
                                            (x.mul_raw(y) << sa) + (z << sb)
                                        })
                                    }
                                }
                                (&Instr::AddSub { a, sa, sb, sub, .. }, Some((true, m))) => {
                                    let (x, y) = mul(m);
                                    if sub {
                                        q.run([x, y, at(a)], dst, fl, move |[x, y, z]: [R; 3]| {
                                            (z << sa) - (x.mul_raw(y) << sb)
                                        })
                                    } else {
                                        q.run([x, y, at(a)], dst, fl, move |[x, y, z]: [R; 3]| {
                                            (z << sa) + (x.mul_raw(y) << sb)
                                        })
                                    }
                                }
                                _ => unreachable!("only products and sums are fused"),
                            }
                        }
                        _ => unreachable!("the arm's pattern"),
                    };
                    continue;
                }
                _ => {}
            }
            match *ins {
                Instr::Mul { d, a, b } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let (x, y) = (
                        operand_of(port_of, lo, lanes, a),
                        operand_of(port_of, lo, lanes, b),
                    );
                    for ((o, &x), &y) in dest!(hi, d).iter_mut().zip(x).zip(y) {
                        *o = x.mul_raw(y);
                    }
                }
                Instr::AddSub {
                    d,
                    a,
                    sa,
                    b,
                    sb,
                    sub,
                } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let (x, y) = (
                        operand_of(port_of, lo, lanes, a),
                        operand_of(port_of, lo, lanes, b),
                    );
                    let it = dest!(hi, d).iter_mut().zip(x).zip(y);
                    if sub {
                        for ((o, &x), &y) in it {
                            *o = (x << sa) - (y << sb);
                        }
                    } else {
                        for ((o, &x), &y) in it {
                            *o = (x << sa) + (y << sb);
                        }
                    }
                }
                Instr::Max { d, a, sa, b, sb } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let (x, y) = (
                        operand_of(port_of, lo, lanes, a),
                        operand_of(port_of, lo, lanes, b),
                    );
                    for ((o, &x), &y) in dest!(hi, d).iter_mut().zip(x).zip(y) {
                        *o = (x << sa).max(y << sb);
                    }
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
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let (x, y, sg) = (
                        operand_of(port_of, lo, lanes, a),
                        operand_of(port_of, lo, lanes, b),
                        operand_of(port_of, lo, lanes, s),
                    );
                    for (((o, &x), &y), &sg) in dest!(hi, d).iter_mut().zip(x).zip(y).zip(sg) {
                        *o = if (sg < R::ZERO) != flip {
                            (x << sa) - (y << sb)
                        } else {
                            (x << sa) + (y << sb)
                        };
                    }
                }
                Instr::Quant {
                    d,
                    a,
                    step,
                    round,
                    overflow,
                    stage,
                    flag,
                } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let src = operand_of(port_of, lo, lanes, a);
                    let (dst, fl) = (dest!(hi, d), &mut flags[..len]);
                    ov[stage] += if want_flags {
                        quant_loop::<R, true>(src, dst, fl, flag, &step, round, overflow)
                    } else {
                        quant_loop::<R, false>(src, dst, fl, flag, &step, round, overflow)
                    };
                }
                Instr::Select {
                    d,
                    sel,
                    ref opts,
                    konst: Some(kt),
                } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let s = operand_of(port_of, lo, lanes, sel);
                    // As the general select below, from a table of the
                    // options' values: `mask + 1` entries held in locals
                    // (no bounds check), a selector outside `0 ..= last`
                    // reads option 0.
                    let mask = this.select_tables[kt].len() - 1;
                    let t: &[R] = &this.select_tables[kt][..=mask];
                    let last = R::from_i128(i128::from(narrow_u32(opts.len())) - 1);
                    for (o, &x) in dest!(hi, d).iter_mut().zip(s) {
                        let slot = if x.in_range(R::ZERO, last) {
                            lane_slot(x)
                        } else {
                            0
                        };
                        *o = t[slot & mask];
                    }
                }
                Instr::Select {
                    d,
                    sel,
                    ref opts,
                    konst: None,
                } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let s = operand_of(port_of, lo, lanes, sel);
                    for (k, o) in dest!(hi, d).iter_mut().enumerate() {
                        let i = s[k].to_i128();
                        let (src, sh) =
                            if let Some(&o) = usize::try_from(i).ok().and_then(|i| opts.get(i)) {
                                o
                            } else {
                                opts[0]
                            };
                        *o = lo[src * BLOCK + k] << sh;
                    }
                }
                Instr::Table { d, a, table, index } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let src = operand_of(port_of, lo, lanes, a);
                    // A slice of exactly `mask + 1` entries, held in locals:
                    // no bounds check (`slot ≤ mask`) and no reload of the
                    // table through `p` per lane, so the loop vectorizes
                    // (a gather).
                    let mask = this.tables[table].len() - 1;
                    let t: &[R] = &this.tables[table][..=mask];
                    for (o, &x) in dest!(hi, d).iter_mut().zip(src) {
                        *o = t[table_slot(index.to_bits(x.to_i128()), mask)];
                    }
                }
                Instr::Div {
                    d,
                    a,
                    fa,
                    b,
                    fb,
                    q,
                    stage,
                    flag,
                } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let (x, y) = (
                        operand_of(port_of, lo, lanes, a),
                        operand_of(port_of, lo, lanes, b),
                    );
                    for (k, ((o, &x), &y)) in dest!(hi, d).iter_mut().zip(x).zip(y).enumerate() {
                        let r = div_exact(x.to_i128(), fa, y.to_i128(), fb, &q);
                        ov[stage] += u64::from(r.overflowed);
                        flags[k] |= flag * u64::from(r.overflowed);
                        *o = R::from_i128(r.code);
                    }
                }
                Instr::Sqrt {
                    d,
                    a,
                    fa,
                    q,
                    stage,
                    flag,
                } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let src = operand_of(port_of, lo, lanes, a);
                    for (k, (o, &x)) in dest!(hi, d).iter_mut().zip(src).enumerate() {
                        let r = sqrt_exact(x.to_i128(), fa, &q);
                        ov[stage] += u64::from(r.overflowed);
                        flags[k] |= flag * u64::from(r.overflowed);
                        *o = R::from_i128(r.code);
                    }
                }
            }
        }
    }
}

/// The lanes of one block: `start..start + len` of the caller's `inputs`.
#[derive(Clone, Copy)]
struct Lanes<'a, R> {
    inputs: &'a [&'a [R]],
    start: usize,
    len: usize,
}

/// Node `a`'s lanes of the block: from the caller's input slice when the
/// program reads that input in place, else from its register in `lo`.
#[inline(always)]
fn operand_of<'a, R>(port_of: &[usize], lo: &'a [R], lanes: Lanes<'a, R>, a: usize) -> &'a [R] {
    let Lanes { inputs, start, len } = lanes;
    match port_of[a] {
        IN_REGISTER => &lo[a * BLOCK..a * BLOCK + len],
        k => &inputs[k][start..start + len],
    }
}

/// One quantization over a block, specialized on the modes.
#[inline(always)]
fn quant_loop<R: Raw, const FLAGS: bool>(
    src: &[R],
    dst: &mut [R],
    flags: &mut [u64],
    flag: u64,
    st: &Step,
    round: Rounding,
    overflow: Overflow,
) -> u64 {
    #[inline(always)]
    fn go<R: Raw, const FLAGS: bool>(
        src: &[R],
        dst: &mut [R],
        flags: &mut [u64],
        flag: u64,
        st: &Step,
        round: Rounding,
        overflow: Overflow,
    ) -> u64 {
        #[inline(always)]
        fn lanes<R: Raw, const FLAGS: bool>(
            src: &[R],
            dst: &mut [R],
            flags: &mut [u64],
            flag: u64,
            st: Step,
            round: Rounding,
            overflow: Overflow,
        ) -> u64 {
            let mut n = 0u64;
            if FLAGS {
                for ((o, f), &x) in dst.iter_mut().zip(flags.iter_mut()).zip(src) {
                    let r = st.apply(x, round, overflow);
                    *o = r.code;
                    n += u64::from(r.overflowed);
                    *f |= flag * u64::from(r.overflowed);
                }
            } else {
                for (o, &x) in dst.iter_mut().zip(src) {
                    let r = st.apply(x, round, overflow);
                    *o = r.code;
                    n += u64::from(r.overflowed);
                }
            }
            n
        }
        // Separate loops per shift direction, so each body is straight-line.
        let st = *st;
        if st.shift > 0 {
            lanes::<R, FLAGS>(src, dst, flags, flag, st, round, overflow)
        } else if st.shift == 0 {
            lanes::<R, FLAGS>(
                src,
                dst,
                flags,
                flag,
                Step { shift: 0, ..st },
                round,
                overflow,
            )
        } else {
            lanes::<R, FLAGS>(src, dst, flags, flag, st, round, overflow)
        }
    }
    use Overflow::*;
    use Rounding::*;
    // Each arm passes constants, so `go` is inlined with the modes folded.
    match (round, overflow) {
        (Trunc, Wrap) => go::<R, FLAGS>(src, dst, flags, flag, st, Trunc, Wrap),
        (Trunc, Saturate) => go::<R, FLAGS>(src, dst, flags, flag, st, Trunc, Saturate),
        (HalfUp, Wrap) => go::<R, FLAGS>(src, dst, flags, flag, st, HalfUp, Wrap),
        (HalfUp, Saturate) => go::<R, FLAGS>(src, dst, flags, flag, st, HalfUp, Saturate),
        (HalfEven, Wrap) => go::<R, FLAGS>(src, dst, flags, flag, st, HalfEven, Wrap),
        (HalfEven, Saturate) => go::<R, FLAGS>(src, dst, flags, flag, st, HalfEven, Saturate),
    }
}

/// A quantization whose operand a fused instruction computes lane by lane
/// ([`Fusion::Quant`]).
struct QuantOf<'a> {
    flag: u64,
    st: &'a Step,
    round: Rounding,
    overflow: Overflow,
    /// Whether the caller reads the lanes' flags ([`Overflows`]).
    want_flags: bool,
}

impl QuantOf<'_> {
    /// `dst[k] = Q(f([src[0][k], …]))` over a block, `f` exact: what the
    /// fused instructions then [`quant_loop`] compute, in one pass.
    /// Returns the overflows, and or-s `flag` into `flags` where one
    /// happened when the caller reads them.
    #[inline(always)]
    fn run<R: Raw, const K: usize>(
        &self,
        src: [&[R]; K],
        dst: &mut [R],
        flags: &mut [u64],
        f: impl Fn([R; K]) -> R + Copy,
    ) -> u64 {
        /// The loop, its modes and shift direction constants.
        #[inline(always)]
        #[allow(clippy::too_many_arguments)]
        fn lanes<R: Raw, const K: usize, const FLAGS: bool>(
            src: [&[R]; K],
            dst: &mut [R],
            flags: &mut [u64],
            f: impl Fn([R; K]) -> R + Copy,
            flag: u64,
            st: Step,
            round: Rounding,
            overflow: Overflow,
        ) -> u64 {
            let len = dst.len();
            // Every slice `len` long, so the loop's indexing needs no check.
            let mut s = src;
            for x in &mut s {
                *x = &x[..len];
            }
            let flags = &mut flags[..len];
            let mut n = 0u64;
            for k in 0..len {
                // A plain loop over `K` (unrolled), not `array::map`, whose
                // drop guard kept the lanes from vectorizing.
                let mut v = [s[0][k]; K];
                for t in 1..K {
                    v[t] = s[t][k];
                }
                let r = st.apply(f(v), round, overflow);
                dst[k] = r.code;
                n += u64::from(r.overflowed);
                if FLAGS {
                    flags[k] |= flag * u64::from(r.overflowed);
                }
            }
            n
        }
        /// As in [`quant_loop`]: a loop per shift direction.
        #[inline(always)]
        #[allow(clippy::too_many_arguments)]
        fn go<R: Raw, const K: usize, const FLAGS: bool>(
            q: &QuantOf<'_>,
            src: [&[R]; K],
            dst: &mut [R],
            flags: &mut [u64],
            f: impl Fn([R; K]) -> R + Copy,
            round: Rounding,
            overflow: Overflow,
        ) -> u64 {
            let (st, flag) = (*q.st, q.flag);
            if st.shift > 0 {
                lanes::<R, K, FLAGS>(src, dst, flags, f, flag, st, round, overflow)
            } else if st.shift == 0 {
                let st = Step { shift: 0, ..st };
                lanes::<R, K, FLAGS>(src, dst, flags, f, flag, st, round, overflow)
            } else {
                lanes::<R, K, FLAGS>(src, dst, flags, f, flag, st, round, overflow)
            }
        }
        /// Each arm passes constants, so `go` is inlined with the modes folded.
        #[inline(always)]
        fn modes<R: Raw, const K: usize, const FLAGS: bool>(
            q: &QuantOf<'_>,
            src: [&[R]; K],
            dst: &mut [R],
            flags: &mut [u64],
            f: impl Fn([R; K]) -> R + Copy,
        ) -> u64 {
            use Overflow::*;
            use Rounding::*;
            match (q.round, q.overflow) {
                (Trunc, Wrap) => go::<R, K, FLAGS>(q, src, dst, flags, f, Trunc, Wrap),
                (Trunc, Saturate) => go::<R, K, FLAGS>(q, src, dst, flags, f, Trunc, Saturate),
                (HalfUp, Wrap) => go::<R, K, FLAGS>(q, src, dst, flags, f, HalfUp, Wrap),
                (HalfUp, Saturate) => go::<R, K, FLAGS>(q, src, dst, flags, f, HalfUp, Saturate),
                (HalfEven, Wrap) => go::<R, K, FLAGS>(q, src, dst, flags, f, HalfEven, Wrap),
                (HalfEven, Saturate) => {
                    go::<R, K, FLAGS>(q, src, dst, flags, f, HalfEven, Saturate)
                }
            }
        }
        if self.want_flags {
            modes::<R, K, true>(self, src, dst, flags, f)
        } else {
            modes::<R, K, false>(self, src, dst, flags, f)
        }
    }
}

/// A compiled program on the code type the widths allow: `i64` when every
/// value fits in 62 bits, `i128` otherwise.
#[derive(Clone, Debug)]
pub enum Compiled {
    /// The fast path.
    Narrow(Program<i64>),
    /// Up to [`super::MAX_EXACT_WIDTH`] bits.
    Wide(Program<i128>),
}

/// `code · 2^−frac`, rounded to the nearest f64 (exact for codes of at
/// most 53 significant bits).
#[allow(clippy::cast_precision_loss, reason = "the documented rounding to f64")]
pub(crate) fn code_value(code: i128, frac: i32) -> f64 {
    code as f64 * crate::format::exp2i(-frac)
}

/// An input code of a program compiled narrow, as `i64`: every input
/// format of such a program is at most 64 bits wide, so the code fits (the
/// low 64 bits, as `as` keeps them, are the code).
#[allow(
    clippy::cast_possible_truncation,
    reason = "a narrow program's input codes fit i64 (see above)"
)]
fn narrow(x: i128) -> i64 {
    x as i64
}

/// The entry of a table of `mask + 1` entries (a power of two) that raw
/// index bits select.
#[allow(
    clippy::cast_possible_truncation,
    reason = "masked to the table's size, which is a usize"
)]
pub(crate) fn table_slot(bits: u64, mask: usize) -> usize {
    bits as usize & mask
}

/// A selector code's low bits as an index (the caller has checked it is
/// in `0 ..= last` of a short list).
#[inline(always)]
#[allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "a code checked to be a small non-negative index"
)]
fn lane_slot<R: Raw>(x: R) -> usize {
    x.to_i128() as usize
}

/// A list's length as `u32` (selects have a handful of options).
fn narrow_u32(n: usize) -> u32 {
    u32::try_from(n).expect("a select has fewer than 2^32 options")
}

/// The left shift aligning a value of `frac` fraction bits to `to`
/// (`to ≥ frac`: `to` is the widest operand's).
pub(crate) fn align(to: i32, frac: i32) -> u32 {
    u32::try_from(to - frac).expect("aligned to the widest operand's fraction")
}

/// Per lane, whether the outputs `oa` with flags `fa` differ from `ob`
/// with `fb` (any output code, or the flag word).
fn lanes_differ<R: PartialEq>(oa: &[Vec<R>], fa: &[u64], ob: &[Vec<R>], fb: &[u64]) -> Vec<bool> {
    let mut d: Vec<bool> = fa.iter().zip(fb).map(|(x, y)| x != y).collect();
    for (x, y) in oa.iter().zip(ob) {
        for ((d, x), y) in d.iter_mut().zip(x).zip(y) {
            *d |= x != y;
        }
    }
    d
}

/// Run `f` on `inputs` converted to `i64` codes (they fit: the program was
/// compiled narrow), and its outputs back to `i128`.
fn on_i64<T>(
    inputs: &[&[i128]],
    f: impl FnOnce(&[&[i64]]) -> (Vec<Vec<i64>>, T),
) -> (Vec<Vec<i128>>, T) {
    let ins: Vec<Vec<i64>> = inputs
        .iter()
        .map(|s| s.iter().map(|&x| narrow(x)).collect())
        .collect();
    let refs: Vec<&[i64]> = ins.iter().map(|v| v.as_slice()).collect();
    let (outs, extra) = f(&refs);
    (
        outs.into_iter()
            .map(|o| o.into_iter().map(i128::from).collect())
            .collect(),
        extra,
    )
}

impl Compiled {
    /// Compile on the narrowest code type that holds the datapath.
    ///
    /// # Errors
    ///
    /// As [`Program::compile`].
    pub fn compile(trace: &Trace, outputs: &[TV]) -> Result<Self, CompileError> {
        if trace.count().fits_i64() {
            Ok(Compiled::Narrow(Program::compile(trace, outputs)?))
        } else {
            Ok(Compiled::Wide(Program::compile(trace, outputs)?))
        }
    }
    /// Run on `i128` codes (converted at the edges).
    pub fn run_i128(&self, inputs: &[&[i128]]) -> (Vec<Vec<i128>>, Vec<(&'static str, u64)>) {
        self.run_i128_on(Isa::current(), inputs)
    }
    /// As [`Compiled::run_i128`], on the instruction set `isa`.
    ///
    /// # Panics
    ///
    /// When this CPU lacks `isa` ([`Isa::available`]).
    pub fn run_i128_on(
        &self,
        isa: Isa,
        inputs: &[&[i128]],
    ) -> (Vec<Vec<i128>>, Vec<(&'static str, u64)>) {
        fn go<R: Raw>(
            p: &Program<R>,
            isa: Isa,
            inputs: &[&[R]],
        ) -> (Vec<Vec<R>>, Vec<(&'static str, u64)>) {
            let mut outs: Vec<Vec<R>> = p.outputs.iter().map(|_| Vec::new()).collect();
            let ov = p.run_into_on(isa, inputs, &mut outs);
            (outs, ov)
        }
        match self {
            Compiled::Wide(p) => go(p, isa, inputs),
            Compiled::Narrow(p) => on_i64(inputs, |refs| go(p, isa, refs)),
        }
    }
    /// Run on `i128` codes with per-lane overflow flags
    /// ([`Program::run_flags`]).
    pub fn run_flags_i128(&self, inputs: &[&[i128]]) -> (Vec<Vec<i128>>, Vec<u64>) {
        match self {
            Compiled::Wide(p) => p.run_flags(inputs),
            Compiled::Narrow(p) => on_i64(inputs, |refs| p.run_flags(refs)),
        }
    }
    /// This program for lanes whose inputs other than those marked in
    /// `varying` hold the codes of `row` ([`Program::specialize`]): the
    /// instructions no varying input reaches run once, here. `None` where
    /// that would fold a division or a square root.
    ///
    /// # Panics
    ///
    /// When `row` or `varying` does not hold one entry per input port. (A
    /// narrow program takes `row`'s codes as `i64`, as its runs take their
    /// inputs: input codes of a narrow program fit.)
    pub fn specialize(&self, row: &[i128], varying: &[bool]) -> Option<Compiled> {
        match self {
            Compiled::Wide(p) => p.specialize(row, varying).map(Compiled::Wide),
            Compiled::Narrow(p) => {
                let row: Vec<i64> = row.iter().map(|&c| narrow(c)).collect();
                p.specialize(&row, varying).map(Compiled::Narrow)
            }
        }
    }
    /// Whether `self` and `other` (a mutant, say) differ at each lane on the
    /// same inputs: some output code or the overflow-flag word
    /// ([`Program::run_flags`]) is not the same. What comparing the two
    /// [`Compiled::run_flags_i128`] results lane by lane gives, without
    /// converting the outputs back to `i128` (and the inputs to `i64`
    /// once, not once per program) when both are narrow.
    pub fn differing_lanes(&self, other: &Compiled, inputs: &[&[i128]]) -> Vec<bool> {
        fn cmp<R: Raw>(a: &Program<R>, b: &Program<R>, inputs: &[&[R]]) -> Vec<bool> {
            let ((oa, fa), (ob, fb)) = (a.run_flags(inputs), b.run_flags(inputs));
            lanes_differ(&oa, &fa, &ob, &fb)
        }
        match (self, other) {
            (Compiled::Narrow(a), Compiled::Narrow(b)) => {
                let ins: Vec<Vec<i64>> = inputs
                    .iter()
                    .map(|s| s.iter().map(|&x| narrow(x)).collect())
                    .collect();
                let refs: Vec<&[i64]> = ins.iter().map(Vec::as_slice).collect();
                cmp(a, b, &refs)
            }
            (Compiled::Wide(a), Compiled::Wide(b)) => cmp(a, b, inputs),
            _ => {
                let ((oa, fa), (ob, fb)) =
                    (self.run_flags_i128(inputs), other.run_flags_i128(inputs));
                lanes_differ(&oa, &fa, &ob, &fb)
            }
        }
    }
    /// Bounds on every output over a box of input codes
    /// ([`Program::run_interval`]).
    pub fn run_interval(&self, inputs: &[(i128, i128)]) -> Option<Vec<(i128, i128)>> {
        match self {
            Compiled::Narrow(p) => p.run_interval(inputs),
            Compiled::Wide(p) => p.run_interval(inputs),
        }
    }
    /// Per node, whether a quantization can overflow over a box of input
    /// codes ([`Program::may_overflow`]).
    pub fn may_overflow(&self, inputs: &[(i128, i128)]) -> Vec<bool> {
        match self {
            Compiled::Narrow(p) => p.may_overflow(inputs),
            Compiled::Wide(p) => p.may_overflow(inputs),
        }
    }
    /// The range of a node's code over a box of input codes
    /// ([`Program::node_range`]).
    pub fn node_range(&self, inputs: &[(i128, i128)], node: usize) -> (i128, i128) {
        match self {
            Compiled::Narrow(p) => p.node_range(inputs, node),
            Compiled::Wide(p) => p.node_range(inputs, node),
        }
    }
    /// The ranges of several nodes' codes over a box of input codes
    /// ([`Program::node_ranges`]).
    pub fn node_ranges(&self, inputs: &[(i128, i128)], nodes: &[usize]) -> Vec<(i128, i128)> {
        match self {
            Compiled::Narrow(p) => p.node_ranges(inputs, nodes),
            Compiled::Wide(p) => p.node_ranges(inputs, nodes),
        }
    }
    /// The range of a quantization's operand over a box of input codes
    /// ([`Program::quant_operand_range`]).
    pub fn quant_operand_range(
        &self,
        inputs: &[(i128, i128)],
        node: usize,
    ) -> Option<(i128, i128)> {
        match self {
            Compiled::Narrow(p) => p.quant_operand_range(inputs, node),
            Compiled::Wide(p) => p.quant_operand_range(inputs, node),
        }
    }
    /// A congruence of a quantization's operand over a box of input codes
    /// ([`Program::quant_operand_congruence`]).
    pub fn quant_operand_congruence(
        &self,
        inputs: &[(i128, i128)],
        node: usize,
    ) -> Option<(i128, i128)> {
        match self {
            Compiled::Narrow(p) => p.quant_operand_congruence(inputs, node),
            Compiled::Wide(p) => p.quant_operand_congruence(inputs, node),
        }
    }
    /// A quantization's operand range over a box of input codes and, where
    /// `need` asks for it, its congruence, from one interval pass
    /// ([`Program::quant_operand_range_congruence`]).
    pub fn quant_operand_range_congruence(
        &self,
        inputs: &[(i128, i128)],
        node: usize,
        need: impl FnOnce((i128, i128)) -> bool,
    ) -> Option<interval::RangeCongruence> {
        match self {
            Compiled::Narrow(p) => p.quant_operand_range_congruence(inputs, node, need),
            Compiled::Wide(p) => p.quant_operand_range_congruence(inputs, node, need),
        }
    }
    /// Low bits known zero in a quantization's operand over a box of input
    /// codes ([`Program::quant_operand_zeros`]).
    pub fn quant_operand_zeros(&self, inputs: &[(i128, i128)], node: usize) -> Option<u32> {
        match self {
            Compiled::Narrow(p) => p.quant_operand_zeros(inputs, node),
            Compiled::Wide(p) => p.quant_operand_zeros(inputs, node),
        }
    }
    /// The operands of quantization nodes per lane ([`Program::probe`]).
    pub fn probe_i128(&self, inputs: &[&[i128]], nodes: &[usize]) -> Vec<Vec<i128>> {
        match self {
            Compiled::Wide(p) => p.probe(inputs, nodes),
            Compiled::Narrow(p) => {
                let conv: Vec<Vec<i64>> = inputs
                    .iter()
                    .map(|c| c.iter().map(|&x| narrow(x)).collect())
                    .collect();
                let refs: Vec<&[i64]> = conv.iter().map(|c| c.as_slice()).collect();
                p.probe(&refs, nodes)
            }
        }
    }
    /// The overflow-flag stages.
    pub fn flag_stages(&self) -> &[String] {
        match self {
            Compiled::Narrow(p) => p.flag_stages(),
            Compiled::Wide(p) => p.flag_stages(),
        }
    }
    /// Whether the fast `i64` path was chosen.
    pub fn is_narrow(&self) -> bool {
        matches!(self, Compiled::Narrow(_))
    }
    /// How many instructions a lane runs (fewer than the operations
    /// [`Compiled::counts`] counts once [specialized](Compiled::specialize)).
    pub fn instructions(&self) -> usize {
        match self {
            Compiled::Narrow(p) => p.instrs.len(),
            Compiled::Wide(p) => p.instrs.len(),
        }
    }
    /// The operation counts of one lane (of the program as compiled, also
    /// after [`Compiled::specialize`]).
    pub fn counts(&self) -> &super::OpCounts {
        match self {
            Compiled::Narrow(p) => p.counts(),
            Compiled::Wide(p) => p.counts(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An output written in place (`e`) beside outputs copied out of their
    /// registers (`y`, read by a later instruction; `x`, an input; `s`,
    /// named twice), over seven blocks (the last one partial), on every
    /// instruction set this CPU has, into fresh and reused vectors,
    /// against closed forms: `y = min(⌊c²/2^14⌋, 2^15 − 1)`,
    /// `s = clamp(y + c)`, `e = clamp(c − y)` in I2F14.
    #[test]
    fn outputs_in_place_and_copied_give_the_closed_forms() {
        let f: Format = "I2F14".parse().unwrap();
        let sq = Quant::new("sq", f, Rounding::Trunc, Overflow::Saturate);
        let sum = Quant::new("sum", f, Rounding::Trunc, Overflow::Saturate);
        let mut t = Trace::new();
        let x = t.input_named("x", &sq);
        let p = t.mul(x, x);
        let y = t.quantize(p, &sq);
        let s0 = t.add(y, x);
        let s = t.quantize(s0, &sum);
        let e0 = t.sub(x, y);
        let e = t.quantize(e0, &sum);
        for (name, v) in [("y", y), ("s", s), ("x", x), ("s_again", s), ("e", e)] {
            t.output(name, v);
        }
        let outs: Vec<TV> = t.output_ports().iter().map(|p| p.value).collect();
        let prog = Program::<i64>::compile(&t, &outs).unwrap();
        assert_eq!(
            prog.copied,
            vec![0, 1, 2, 3],
            "only `e` is written in place"
        );

        let codes: Vec<i64> = (-32768..32768).step_by(37).collect();
        assert!(codes.len() > 6 * BLOCK && !codes.len().is_multiple_of(BLOCK));
        let want_y = |c: i64| ((c * c) >> 14).min(32767);
        let want_s = |c: i64| (want_y(c) + c).clamp(-32768, 32767);
        let want_e = |c: i64| (c - want_y(c)).clamp(-32768, 32767);
        let check = |got: &[Vec<i64>], lanes: &[i64]| {
            assert_eq!(got.len(), 5);
            for (k, &c) in lanes.iter().enumerate() {
                let w = [want_y(c), want_s(c), c, want_s(c), want_e(c)];
                for (o, &w) in got.iter().zip(&w) {
                    assert_eq!(o.len(), lanes.len());
                    assert_eq!(
                        o[k],
                        w,
                        "lane {k}, code {c}: {:?}",
                        got.iter().map(|o| o[k]).collect::<Vec<_>>()
                    );
                }
            }
        };
        let mut reused: Vec<Vec<i64>> = vec![Vec::new(); 5];
        for isa in Isa::ALL.into_iter().filter(|i| i.available()) {
            let mut fresh: Vec<Vec<i64>> = vec![Vec::new(); 5];
            prog.run_into_on(isa, &[&codes], &mut fresh);
            check(&fresh, &codes);
            // A vector of the right length is overwritten, one of another
            // length replaced.
            prog.run_into_on(isa, &[&codes], &mut reused);
            check(&reused, &codes);
            prog.run_into_on(isa, &[&codes[..300]], &mut reused);
            check(&reused, &codes[..300]);
        }
        // Per-lane flags, written in place: a flag where y, s or e saturated.
        let (got, flags) = prog.run_flags(&[&codes]);
        check(&got, &codes);
        for (&c, &fl) in codes.iter().zip(&flags) {
            let y_ovf = (c * c) >> 14 > 32767;
            let s_ovf = !(-32768..=32767).contains(&(want_y(c) + c));
            let e_ovf = !(-32768..=32767).contains(&(c - want_y(c)));
            assert_eq!(fl != 0, y_ovf || s_ovf || e_ovf, "flags of code {c}");
        }
        // The probe runs the same blocks: the squares before quantization.
        let probe = prog.probe(&[&codes], &[y.node()]);
        let sq: Vec<i128> = codes.iter().map(|&c| i128::from(c * c)).collect();
        assert_eq!(probe[0], sq);
        // Without lane flags the quantizations still count every overflow:
        // per stage, the lanes where y (stage `sq`), s and e (`sum`) clip.
        let n_sq = codes.iter().filter(|&&c| (c * c) >> 14 > 32767).count();
        let n_sum = codes
            .iter()
            .map(|&c| {
                let y = want_y(c);
                usize::from(!(-32768..=32767).contains(&(y + c)))
                    + usize::from(!(-32768..=32767).contains(&(c - y)))
            })
            .sum::<usize>();
        assert!(n_sq > 0 && n_sum > 0);
        for isa in Isa::ALL.into_iter().filter(|i| i.available()) {
            let ov = prog.run_into_on(isa, &[&codes], &mut reused);
            assert_eq!(
                ov,
                vec![("sq", n_sq as u64), ("sum", n_sum as u64)],
                "{}",
                isa.name()
            );
        }
    }

    /// Quantized products, sums, differences and multiply-adds, each run
    /// as one pass with its quantization ([`Fusion`]; the operations
    /// traced first and the quantizations after, so the passes run apart
    /// from where the operations stand), for every rounding and overflow
    /// mode, as `i64` and `i128` codes, on every instruction set, with
    /// per-lane flags and per-stage counts, against closed forms in `i128`
    /// division (no shifts): `m = Q(a·b)` (I4F8 × I4F8 to I3F6, ten bits
    /// dropped), `s = Q(a + c)` (c in I4F4 aligned to F8, to I3F6, two
    /// dropped), `e = Q(a − b)` (to I4F10, two appended), `u = Q(b·c + a)`
    /// and `v = Q(a − b·c)` (F12, to I3F6, six dropped), and sums of two,
    /// three and four products (F16, to I3F6): `w2 = Q(a·b − b·c)`,
    /// `w3 = Q((a·a + b·b) + c·c)`, `w4 = Q((a·b − a·c) − (b·b + c·c))`.
    /// The probe still sees the exact product (it runs unfused).
    #[test]
    fn fused_quantizations_give_the_closed_forms() {
        fn want(v: i128, shift: i32, width: u32, r: Rounding, o: Overflow) -> (i128, bool) {
            let q = if shift > 0 {
                let d = 1i128 << shift;
                let (f, rem) = (v.div_euclid(d), v.rem_euclid(d));
                match r {
                    Rounding::Trunc => f,
                    Rounding::HalfUp => f + i128::from(2 * rem >= d),
                    Rounding::HalfEven => {
                        f + i128::from(2 * rem > d || (2 * rem == d && f % 2 != 0))
                    }
                }
            } else {
                v * (1i128 << -shift)
            };
            let (min, max) = (-(1i128 << (width - 1)), (1i128 << (width - 1)) - 1);
            let code = match o {
                Overflow::Saturate => q.clamp(min, max),
                Overflow::Wrap => (q - min).rem_euclid(1i128 << width) + min,
            };
            (code, q < min || q > max)
        }
        fn check<R: Raw>(prog: &Program<R>, ins: [&[R]; 3], r: Rounding, o: Overflow) {
            let quants = prog
                .fused
                .iter()
                .filter(|f| matches!(f, Fusion::Quant { .. }));
            assert_eq!(
                quants.count(),
                5,
                "the quantizations of one operation fused"
            );
            let dots: Vec<usize> = prog
                .fused
                .iter()
                .filter_map(|f| match f {
                    Fusion::Dot { n, .. } => Some(*n),
                    _ => None,
                })
                .collect();
            assert_eq!(dots, [2, 3, 4], "the sums of products fused");
            let madds = prog.fused.iter().filter(|f| {
                matches!(
                    f,
                    Fusion::Quant {
                        product: Some(_),
                        ..
                    }
                )
            });
            assert_eq!(madds.count(), 2, "both multiply-adds fused");
            let [a, b, c] = ins;
            let want_lane = |k: usize| {
                let (a, b, c) = (a[k].to_i128(), b[k].to_i128(), c[k].to_i128());
                [
                    want(a * b, 10, 9, r, o),
                    want(a + c * 16, 2, 9, r, o),
                    want(a - b, -2, 14, r, o),
                    want(b * c + a * 16, 6, 9, r, o),
                    want(a * 16 - b * c, 6, 9, r, o),
                    want(a * b - b * c * 16, 10, 9, r, o),
                    want(a * a + b * b + c * c * 256, 10, 9, r, o),
                    want(a * b - a * c * 16 - b * b - c * c * 256, 10, 9, r, o),
                ]
            };
            let mut counts = [0u64; 8];
            for k in 0..a.len() {
                for (n, w) in counts.iter_mut().zip(want_lane(k)) {
                    *n += u64::from(w.1);
                }
            }
            assert!(
                counts.iter().all(|&n| n > 0),
                "{r:?} {o:?}: every stage overflows"
            );
            let names = ["m", "s", "e", "u", "v", "w2", "w3", "w4"];
            let want_ov: Vec<(&str, u64)> = names.into_iter().zip(counts).collect();
            for isa in Isa::ALL.into_iter().filter(|i| i.available()) {
                let mut outs = vec![Vec::new(); 8];
                let ov = prog.run_into_on(isa, &ins, &mut outs);
                assert_eq!(ov, want_ov, "{} {r:?} {o:?}", isa.name());
                for k in 0..a.len() {
                    let got: Vec<i128> = outs.iter().map(|o| o[k].to_i128()).collect();
                    let w: Vec<i128> = want_lane(k).iter().map(|w| w.0).collect();
                    assert_eq!(got, w, "{} {r:?} {o:?} lane {k}", isa.name());
                }
            }
            let (outs, flags) = prog.run_flags(&ins);
            assert_eq!(prog.flag_stages(), names);
            for k in 0..a.len() {
                let w = want_lane(k);
                let got: Vec<i128> = outs.iter().map(|o| o[k].to_i128()).collect();
                assert_eq!(got, w.iter().map(|w| w.0).collect::<Vec<_>>(), "lane {k}");
                let bits = w.iter().fold(0u64, |acc, w| (acc << 1) | u64::from(w.1));
                assert_eq!(flags[k], bits, "{r:?} {o:?} flags of lane {k}");
            }
            let probe = prog.probe(&ins, &[prog.outputs[0].0]);
            let products: Vec<i128> = (0..a.len())
                .map(|k| a[k].to_i128() * b[k].to_i128())
                .collect();
            assert_eq!(probe[0], products);
        }
        let (f8, f4): (Format, Format) = ("I4F8".parse().unwrap(), "I4F4".parse().unwrap());
        // Pairs over the whole 12-bit range, from a fixed linear congruence.
        let mut x = 12345u64;
        let mut draw = |lo: i64, hi: i64| {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            lo + i64::try_from((x >> 33) % u64::try_from(hi - lo + 1).unwrap()).unwrap()
        };
        let n = 5 * BLOCK + 77;
        let a: Vec<i64> = (0..n).map(|_| draw(-2048, 2047)).collect();
        let b: Vec<i64> = (0..n).map(|_| draw(-2048, 2047)).collect();
        let c: Vec<i64> = (0..n).map(|_| draw(-128, 127)).collect();
        let wide = |v: &[i64]| v.iter().map(|&x| i128::from(x)).collect::<Vec<i128>>();
        let (aw, bw, cw) = (wide(&a), wide(&b), wide(&c));
        for r in Rounding::ALL {
            for o in [Overflow::Wrap, Overflow::Saturate] {
                let mut t = Trace::new();
                let qa = Quant::new("a", f8, Rounding::Trunc, Overflow::Saturate);
                let qc = Quant::new("c", f4, Rounding::Trunc, Overflow::Saturate);
                let ai = t.input_named("a", &qa);
                let bi = t.input_named("b", &qa);
                let ci = t.input_named("c", &qc);
                let p = t.mul(ai, bi);
                let s0 = t.add(ai, ci);
                let e0 = t.sub(ai, bi);
                let pu = t.mul(bi, ci);
                let u0 = t.add(pu, ai);
                let pv = t.mul(bi, ci);
                let v0 = t.sub(ai, pv);
                let narrow: Format = "I3F6".parse().unwrap();
                let m = t.quantize(p, &Quant::new("m", narrow, r, o));
                let s = t.quantize(s0, &Quant::new("s", narrow, r, o));
                let e = t.quantize(e0, &Quant::new("e", "I4F10".parse().unwrap(), r, o));
                let u = t.quantize(u0, &Quant::new("u", narrow, r, o));
                let v = t.quantize(v0, &Quant::new("v", narrow, r, o));
                let (ab, bc) = (t.mul(ai, bi), t.mul(bi, ci));
                let w20 = t.sub(ab, bc);
                let w2 = t.quantize(w20, &Quant::new("w2", narrow, r, o));
                let (aa, bb, cc) = (t.mul(ai, ai), t.mul(bi, bi), t.mul(ci, ci));
                let w30 = t.add(aa, bb);
                let w31 = t.add(w30, cc);
                let w3 = t.quantize(w31, &Quant::new("w3", narrow, r, o));
                let (ab, ac, bb, cc) = (t.mul(ai, bi), t.mul(ai, ci), t.mul(bi, bi), t.mul(ci, ci));
                let (l, rr) = (t.sub(ab, ac), t.add(bb, cc));
                let w40 = t.sub(l, rr);
                let w4 = t.quantize(w40, &Quant::new("w4", narrow, r, o));
                let named = [("m", m), ("s", s), ("e", e), ("u", u), ("v", v)];
                for (name, val) in named
                    .into_iter()
                    .chain([("w2", w2), ("w3", w3), ("w4", w4)])
                {
                    t.output(name, val);
                }
                let outs: Vec<TV> = t.output_ports().iter().map(|p| p.value).collect();
                check(
                    &Program::<i64>::compile(&t, &outs).unwrap(),
                    [&a, &b, &c],
                    r,
                    o,
                );
                check(
                    &Program::<i128>::compile(&t, &outs).unwrap(),
                    [&aw, &bw, &cw],
                    r,
                    o,
                );
            }
        }
    }

    /// A 64-entry table read through a 6-bit index, and the same table
    /// read through a quantized sum: lane counts off the vector widths
    /// (the vector loops' scalar tails), on every instruction set, `i64` and
    /// `i128`, against the entries themselves.
    #[test]
    fn table_reads_give_the_entries_on_every_instruction_set() {
        let iq = Quant::new(
            "i",
            "U6F6".parse().unwrap(),
            Rounding::Trunc,
            Overflow::Wrap,
        );
        let out = Quant::new(
            "t",
            "I12F4".parse().unwrap(),
            Rounding::Trunc,
            Overflow::Wrap,
        );
        let codes: Vec<i128> = (0..64)
            .map(|k| (k * 37 % 101) - 50 - 1000 * (k % 3))
            .collect();
        let table = Table {
            name: "t",
            index: iq.format(),
            out,
            exact: |x| x,
            codes: codes.clone(),
            storage: None,
        };
        for n in [1usize, 7, 9, 255, 257, 1003] {
            let mut t = Trace::new();
            let a = t.input_named("a", &iq);
            let b = t.input_named("b", &iq);
            let y = t.table(&table, a);
            let s = t.add(a, b);
            let w = t.quantize(s, &iq);
            let z = t.table(&table, w);
            t.output("y", y);
            t.output("z", z);
            let xs: Vec<i64> = (0..n as i64).map(|k| (k * 29 + 5) % 64).collect();
            let ys: Vec<i64> = (0..n as i64).map(|k| (k * 13 + 60) % 64).collect();
            let want_y: Vec<i128> = xs.iter().map(|&x| codes[x as usize]).collect();
            let want_z: Vec<i128> = xs
                .iter()
                .zip(&ys)
                .map(|(&x, &v)| codes[((x + v) % 64) as usize])
                .collect();
            let narrow = Program::<i64>::compile(&t, &[y, z]).unwrap();
            let wide = Program::<i128>::compile(&t, &[y, z]).unwrap();
            let wx: Vec<i128> = xs.iter().map(|&x| i128::from(x)).collect();
            let wy: Vec<i128> = ys.iter().map(|&x| i128::from(x)).collect();
            for isa in Isa::ALL.into_iter().filter(|i| i.available()) {
                let mut got = vec![Vec::new(), Vec::new()];
                narrow.run_into_on(isa, &[xs.as_slice(), ys.as_slice()], &mut got);
                let mut got_wide = vec![Vec::new(), Vec::new()];
                wide.run_into_on(isa, &[wx.as_slice(), wy.as_slice()], &mut got_wide);
                let got: Vec<Vec<i128>> = got
                    .iter()
                    .map(|c| c.iter().map(|&x| i128::from(x)).collect())
                    .collect();
                for (g, name) in [(&got, "i64"), (&got_wide, "i128")] {
                    assert_eq!(g[0], want_y, "{} {name}, {n} lanes: y", isa.name());
                    assert_eq!(g[1], want_z, "{} {name}, {n} lanes: z", isa.name());
                }
            }
        }
    }

    /// A select whose options are all constants reads them from a table
    /// (`konst`); one whose options are inputs reads registers lane by
    /// lane. Both against the closed form `options[sel]`, option 0 for a
    /// selector past the last option or negative, with the options on
    /// three binary points (aligned to the finest), over every selector
    /// code of an 8-bit signed format and several blocks, on every
    /// instruction set, as `i64` and `i128` codes.
    #[test]
    fn a_select_of_constants_reads_the_options_by_selector() {
        let sel_q = Quant::new(
            "sel",
            "I8F0".parse().unwrap(),
            Rounding::Trunc,
            Overflow::Wrap,
        );
        let fmts = ["I4F2", "I4F4", "I2F6", "I4F4", "I6F0"];
        let vals = [-1.25, 3.0625, 1.515_625, -7.9375, 21.0];
        // Every option as a code of the finest binary point (6 bits).
        let want_opt: Vec<i64> = vals.iter().map(|&v: &f64| (v * 64.0) as i64).collect();
        let want = |sel: i64| -> i64 {
            usize::try_from(sel)
                .ok()
                .and_then(|k| want_opt.get(k))
                .copied()
                .unwrap_or(want_opt[0])
        };
        let sels: Vec<i64> = (0..6).flat_map(|_| -128..128).collect();
        assert!(sels.len() > 5 * BLOCK);
        for constants in [true, false] {
            let mut t = Trace::new();
            let sel = t.input_named("sel", &sel_q);
            let opts: Vec<TV> = fmts
                .iter()
                .zip(vals)
                .enumerate()
                .map(|(k, (f, v))| {
                    let q = Quant::new("o", f.parse().unwrap(), Rounding::Trunc, Overflow::Wrap);
                    if constants {
                        t.constant(v, &q).unwrap()
                    } else {
                        t.input_named(&format!("o{k}"), &q)
                    }
                })
                .collect();
            let y = t.select(sel, &opts);
            assert_eq!(y.frac, 6);
            t.output("y", y);
            let mut cols: Vec<Vec<i64>> = vec![sels.clone()];
            if !constants {
                for (f, v) in fmts.iter().zip(vals) {
                    let frac = f.parse::<Format>().unwrap().frac();
                    let code = (v * f64::from(1u32 << frac)) as i64;
                    cols.push(vec![code; sels.len()]);
                }
            }
            let narrow = Program::<i64>::compile(&t, &[y]).unwrap();
            let wide = Program::<i128>::compile(&t, &[y]).unwrap();
            assert_eq!(narrow.select_tables.len(), usize::from(constants));
            assert_eq!(wide.select_tables.len(), usize::from(constants));
            let refs: Vec<&[i64]> = cols.iter().map(Vec::as_slice).collect();
            let wide_cols: Vec<Vec<i128>> = cols
                .iter()
                .map(|c| c.iter().map(|&x| i128::from(x)).collect())
                .collect();
            let wide_refs: Vec<&[i128]> = wide_cols.iter().map(Vec::as_slice).collect();
            for isa in Isa::ALL.into_iter().filter(|i| i.available()) {
                let mut got = vec![Vec::new()];
                narrow.run_into_on(isa, &refs, &mut got);
                let mut got_wide = vec![Vec::new()];
                wide.run_into_on(isa, &wide_refs, &mut got_wide);
                for (k, &sc) in sels.iter().enumerate() {
                    let w = want(sc);
                    assert_eq!(got[0][k], w, "{}, selector {sc}", isa.name());
                    assert_eq!(
                        got_wide[0][k],
                        i128::from(w),
                        "{}, selector {sc}",
                        isa.name()
                    );
                }
            }
        }
    }
}
