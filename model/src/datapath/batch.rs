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

#[derive(Clone, Debug)]
enum Op {
    Input(usize),
    Const(i128),
    Mul(TV, TV),
    Add(TV, TV),
    Sub(TV, TV),
    Max(TV, TV),
    Quant(TV, Quant),
    Table(TV, usize),
    Div(TV, TV, Quant),
    Sqrt(TV, Quant),
}

/// The recording context. Create inputs with [`Trace::input`], run the
/// unit's generic code on them, then [`Program::compile`] its outputs.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    ops: Vec<Op>,
    fracs: Vec<i32>,
    tables: Vec<Table>,
    inputs: Vec<Quant>,
    count: Count,
    const_overflows: Vec<&'static str>,
}

impl Trace {
    /// An empty trace.
    pub fn new() -> Self {
        Self::default()
    }
    fn push(&mut self, op: Op, frac: i32, sym: Sym) -> TV {
        self.ops.push(op);
        self.fracs.push(frac);
        TV {
            id: (self.ops.len() - 1) as u32,
            frac,
            sym,
        }
    }
    /// A new input port carrying codes of `q.format()`.
    pub fn input(&mut self, q: &Quant) -> TV {
        let slot = self.inputs.len();
        self.inputs.push(*q);
        let sym = self.count.constant(0.0, q).expect("0 is finite");
        self.push(Op::Input(slot), q.format().frac(), sym)
    }
    /// The counting run that went alongside the trace.
    pub fn count(&self) -> &Count {
        &self.count
    }
}

impl Datapath for Trace {
    type V = TV;

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
    fn quantize(&mut self, a: TV, q: &Quant) -> TV {
        let sym = self.count.quantize(a.sym, q);
        self.push(Op::Quant(a, *q), q.format().frac(), sym)
    }
    fn table(&mut self, t: &Table, index: TV) -> TV {
        let sym = self.count.table(t, index.sym);
        let i = match self
            .tables
            .iter()
            .position(|x| x.name == t.name && x.codes.as_ptr() == t.codes.as_ptr())
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
    Quant {
        d: usize,
        a: usize,
        step: Step,
        round: Rounding,
        overflow: Overflow,
        stage: usize,
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
    },
    Sqrt {
        d: usize,
        a: usize,
        fa: i32,
        q: Quant,
        stage: usize,
    },
}

/// Lanes per block: registers of a block stay in the L1 cache.
pub const BLOCK: usize = 256;

/// A datapath compiled for codes of type `R`: instructions with resolved
/// shifts, one register (a block of lanes) per node.
#[derive(Clone, Debug)]
pub struct Program<R> {
    instrs: Vec<Instr>,
    n_regs: usize,
    consts: Vec<(usize, R)>,
    inputs: Vec<(usize, Quant)>,
    outputs: Vec<(usize, i32)>,
    tables: Vec<Vec<R>>,
    stages: Vec<&'static str>,
    const_overflows: Vec<&'static str>,
    counts: super::OpCounts,
    max_width: u32,
}

/// Why a trace cannot be compiled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompileError {
    /// An intermediate is wider than the code type holds exactly.
    #[error(transparent)]
    Width(#[from] WidthError),
    /// The `i64` fast path was asked for a datapath that needs more bits.
    #[error("the datapath needs {0}-bit intermediates; i64 codes hold 62")]
    TooWideForI64(u32),
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
    /// Compile the trace for the given outputs.
    pub fn compile(trace: &Trace, outputs: &[TV]) -> Result<Self, CompileError> {
        if let Some(e) = trace.count.width_errors().first() {
            return Err(e.clone().into());
        }
        if R::BITS == 64 && !trace.count.fits_i64() {
            return Err(CompileError::TooWideForI64(trace.count.max_width()));
        }
        let mut stages = Vec::new();
        let mut instrs = Vec::new();
        let mut consts = Vec::new();
        let mut inputs = Vec::new();
        let fr = |v: &TV| v.frac;
        for (d, op) in trace.ops.iter().enumerate() {
            let f = trace.fracs[d];
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
                    sa: (f - fr(a)) as u32,
                    b: b.id as usize,
                    sb: (f - fr(b)) as u32,
                    sub: matches!(op, Op::Sub(..)),
                }),
                Op::Max(a, b) => instrs.push(Instr::Max {
                    d,
                    a: a.id as usize,
                    sa: (f - fr(a)) as u32,
                    b: b.id as usize,
                    sb: (f - fr(b)) as u32,
                }),
                Op::Quant(a, q) => instrs.push(Instr::Quant {
                    d,
                    a: a.id as usize,
                    step: q.step(a.frac),
                    round: q.round(),
                    overflow: q.overflow(),
                    stage: stage_index(&mut stages, q.stage()),
                }),
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
                }),
                Op::Sqrt(a, q) => instrs.push(Instr::Sqrt {
                    d,
                    a: a.id as usize,
                    fa: a.frac,
                    q: *q,
                    stage: stage_index(&mut stages, q.stage()),
                }),
            }
        }
        Ok(Program {
            instrs,
            n_regs: trace.ops.len(),
            consts,
            inputs,
            outputs: outputs.iter().map(|o| (o.id as usize, o.frac)).collect(),
            tables: trace
                .tables
                .iter()
                .map(|t| t.codes.iter().map(|&c| R::from_i128(c)).collect())
                .collect(),
            stages,
            const_overflows: trace.const_overflows.clone(),
            counts: trace.count.counts(),
            max_width: trace.count.max_width(),
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
    /// The operation counts of one lane.
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
    /// cleared first; their capacity is reused across calls).
    pub fn run_into(&self, inputs: &[&[R]], outs: &mut [Vec<R>]) -> Vec<(&'static str, u64)> {
        assert_eq!(inputs.len(), self.inputs.len(), "one slice per input port");
        assert_eq!(outs.len(), self.outputs.len(), "one vector per output");
        let n = inputs.first().map_or(0, |s| s.len());
        assert!(
            inputs.iter().all(|s| s.len() == n),
            "input slices of equal length"
        );
        for o in outs.iter_mut() {
            o.clear();
            o.reserve(n);
        }
        let mut ov = vec![0u64; self.stages.len()];
        let mut regs = vec![R::ZERO; self.n_regs * BLOCK];
        for &(d, c) in &self.consts {
            regs[d * BLOCK..(d + 1) * BLOCK].fill(c);
        }
        let mut start = 0;
        while start < n {
            let len = BLOCK.min(n - start);
            for (&(d, _), src) in self.inputs.iter().zip(inputs) {
                regs[d * BLOCK..d * BLOCK + len].copy_from_slice(&src[start..start + len]);
            }
            self.block(&mut regs, len, &mut ov);
            for (&(o, _), out) in self.outputs.iter().zip(outs.iter_mut()) {
                out.extend_from_slice(&regs[o * BLOCK..o * BLOCK + len]);
            }
            start += len;
        }
        self.stages
            .iter()
            .zip(ov)
            .filter(|(_, n)| *n > 0)
            .map(|(s, n)| (*s, n))
            .collect()
    }

    /// One block of lanes, on the best instruction set this CPU has: the
    /// same body compiled twice, chosen once per process.
    fn block(&self, regs: &mut [R], len: usize, ov: &mut [u64]) {
        #[cfg(target_arch = "x86_64")]
        {
            static AVX2: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
            if *AVX2.get_or_init(|| std::arch::is_x86_feature_detected!("avx2")) {
                // SAFETY: the CPU supports AVX2 (checked just above).
                unsafe { block_avx2(self, regs, len, ov) };
                return;
            }
        }
        block_body(self, regs, len, ov)
    }
}

/// [`Program::block`] compiled with AVX2 enabled (wide integer shifts,
/// compares and selects let the loops vectorize).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn block_avx2<R: Raw>(p: &Program<R>, regs: &mut [R], len: usize, ov: &mut [u64]) {
    block_body(p, regs, len, ov)
}

#[inline(always)]
fn block_body<R: Raw>(p: &Program<R>, regs: &mut [R], len: usize, ov: &mut [u64]) {
    {
        let this = p;
        for ins in &this.instrs {
            match *ins {
                Instr::Mul { d, a, b } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let (x, y) = (
                        &lo[a * BLOCK..a * BLOCK + len],
                        &lo[b * BLOCK..b * BLOCK + len],
                    );
                    for ((o, &x), &y) in hi[..len].iter_mut().zip(x).zip(y) {
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
                        &lo[a * BLOCK..a * BLOCK + len],
                        &lo[b * BLOCK..b * BLOCK + len],
                    );
                    let it = hi[..len].iter_mut().zip(x).zip(y);
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
                        &lo[a * BLOCK..a * BLOCK + len],
                        &lo[b * BLOCK..b * BLOCK + len],
                    );
                    for ((o, &x), &y) in hi[..len].iter_mut().zip(x).zip(y) {
                        *o = (x << sa).max(y << sb);
                    }
                }
                Instr::Quant {
                    d,
                    a,
                    step,
                    round,
                    overflow,
                    stage,
                } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let src = &lo[a * BLOCK..a * BLOCK + len];
                    ov[stage] += quant_loop(src, &mut hi[..len], &step, round, overflow);
                }
                Instr::Table { d, a, table, index } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let src = &lo[a * BLOCK..a * BLOCK + len];
                    let t = &this.tables[table];
                    let mask = t.len() - 1;
                    for (o, &x) in hi[..len].iter_mut().zip(src) {
                        *o = t[index.to_bits(x.to_i128()) as usize & mask];
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
                } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let (x, y) = (
                        &lo[a * BLOCK..a * BLOCK + len],
                        &lo[b * BLOCK..b * BLOCK + len],
                    );
                    for ((o, &x), &y) in hi[..len].iter_mut().zip(x).zip(y) {
                        let r = div_exact(x.to_i128(), fa, y.to_i128(), fb, &q);
                        ov[stage] += r.overflowed as u64;
                        *o = R::from_i128(r.code);
                    }
                }
                Instr::Sqrt { d, a, fa, q, stage } => {
                    let (lo, hi) = regs.split_at_mut(d * BLOCK);
                    let src = &lo[a * BLOCK..a * BLOCK + len];
                    for (o, &x) in hi[..len].iter_mut().zip(src) {
                        let r = sqrt_exact(x.to_i128(), fa, &q);
                        ov[stage] += r.overflowed as u64;
                        *o = R::from_i128(r.code);
                    }
                }
            }
        }
    }
}

/// One quantization over a block, specialized on the modes.
#[inline(always)]
fn quant_loop<R: Raw>(
    src: &[R],
    dst: &mut [R],
    st: &Step,
    round: Rounding,
    overflow: Overflow,
) -> u64 {
    #[inline(always)]
    fn go<R: Raw>(src: &[R], dst: &mut [R], st: &Step, round: Rounding, overflow: Overflow) -> u64 {
        #[inline(always)]
        fn lanes<R: Raw>(
            src: &[R],
            dst: &mut [R],
            st: Step,
            round: Rounding,
            overflow: Overflow,
        ) -> u64 {
            let mut n = 0u64;
            for (o, &x) in dst.iter_mut().zip(src) {
                let r = st.apply(x, round, overflow);
                *o = r.code;
                n += r.overflowed as u64;
            }
            n
        }
        // Separate loops per shift direction, so each body is straight-line.
        let st = *st;
        if st.shift > 0 {
            lanes(src, dst, st, round, overflow)
        } else if st.shift == 0 {
            lanes(src, dst, Step { shift: 0, ..st }, round, overflow)
        } else {
            lanes(src, dst, st, round, overflow)
        }
    }
    use Overflow::*;
    use Rounding::*;
    // Each arm passes constants, so `go` is inlined with the modes folded.
    match (round, overflow) {
        (Trunc, Wrap) => go(src, dst, st, Trunc, Wrap),
        (Trunc, Saturate) => go(src, dst, st, Trunc, Saturate),
        (HalfUp, Wrap) => go(src, dst, st, HalfUp, Wrap),
        (HalfUp, Saturate) => go(src, dst, st, HalfUp, Saturate),
        (HalfEven, Wrap) => go(src, dst, st, HalfEven, Wrap),
        (HalfEven, Saturate) => go(src, dst, st, HalfEven, Saturate),
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

impl Compiled {
    /// Compile on the narrowest code type that holds the datapath.
    pub fn compile(trace: &Trace, outputs: &[TV]) -> Result<Self, CompileError> {
        if trace.count().fits_i64() {
            Ok(Compiled::Narrow(Program::compile(trace, outputs)?))
        } else {
            Ok(Compiled::Wide(Program::compile(trace, outputs)?))
        }
    }
    /// Run on `i128` codes (converted at the edges).
    pub fn run_i128(&self, inputs: &[&[i128]]) -> (Vec<Vec<i128>>, Vec<(&'static str, u64)>) {
        match self {
            Compiled::Wide(p) => p.run(inputs),
            Compiled::Narrow(p) => {
                let ins: Vec<Vec<i64>> = inputs
                    .iter()
                    .map(|s| s.iter().map(|&x| x as i64).collect())
                    .collect();
                let refs: Vec<&[i64]> = ins.iter().map(|v| v.as_slice()).collect();
                let (outs, ov) = p.run(&refs);
                (
                    outs.into_iter()
                        .map(|o| o.into_iter().map(|x| x as i128).collect())
                        .collect(),
                    ov,
                )
            }
        }
    }
    /// Whether the fast `i64` path was chosen.
    pub fn is_narrow(&self) -> bool {
        matches!(self, Compiled::Narrow(_))
    }
    /// The operation counts of one lane.
    pub fn counts(&self) -> &super::OpCounts {
        match self {
            Compiled::Narrow(p) => p.counts(),
            Compiled::Wide(p) => p.counts(),
        }
    }
}
