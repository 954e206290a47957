//! Interval evaluation of a box of input codes from an evaluated box that
//! differs from it in one input.
//!
//! A branch and bound over boxes (the killer search's proofs) splits one
//! input's range at a time, and a bisection along one input (its witness
//! search) moves one input of a row: the instructions that input does not
//! reach get the same ranges, overflow flags and congruences as in the box
//! the new one came from. [`Boxes::child`] copies those and runs only the
//! instructions the input reaches, in program order, with the same
//! per-instruction steps as the whole pass ([`Program::run_interval`] and
//! the rest), so every figure it gives is the one the whole pass gives on
//! the new box.
//!
//! That needs every register written once (by a constant, an input or
//! one instruction) and every instruction after those writing its
//! operands: true of every compiled program (a register is a node of the
//! trace, the instructions in trace order); a program with a register
//! written twice is evaluated whole on every box.
//!
//! A program's registers are the trace's nodes, most of them unused by a
//! program that computes one node's cone; the evaluation runs on a copy
//! of the program with the registers it uses numbered densely (constants,
//! inputs, instructions, outputs), so that a box's figures, copied from
//! box to box, hold only those.

use super::{Compiled, Instr, Program, RegPool};
use crate::quantize::Raw;
use std::borrow::Borrow;
use std::sync::Arc;

/// The interval evaluation of one box: every register's range, whether each
/// quantization may overflow, and (once asked for) every register's
/// congruence ([`Boxes`]).
#[derive(Clone, Debug)]
pub struct BoxEval {
    /// The box: one range of codes per input port.
    inputs: Vec<(i128, i128)>,
    /// Every register's range.
    ranges: Vec<(i128, i128)>,
    /// Whether the quantization writing each register may overflow.
    may: Vec<bool>,
    /// Every register's congruence, once computed.
    cong: Option<Congruences>,
    /// The congruences of the box this one came from, if computed there,
    /// and the input that changed: this box's follow from them.
    from: Option<(Congruences, usize)>,
    /// Whether an overflow flag the input reaches changed from that box's.
    may_changed: bool,
}

/// Every register's congruence `(stride, offset)` over a box, shared by
/// the boxes whose congruences are the same.
type Congruences = Arc<Vec<(i128, i128)>>;

impl BoxEval {
    /// The box evaluated: one range of codes per input port.
    #[must_use]
    pub fn inputs(&self) -> &[(i128, i128)] {
        &self.inputs
    }
}

/// A compiled program's interval evaluation of boxes of input codes, whole
/// ([`Boxes::root`]) or from a box that differs in one input
/// ([`Boxes::child`]); the program borrowed (`Boxes<&Compiled>`) or owned
/// (`Boxes<Compiled>`).
#[derive(Debug)]
pub struct Boxes<P: Borrow<Compiled>> {
    /// The program.
    prog: P,
    /// The program with its registers numbered densely.
    dense: Compiled,
    /// Each register of the program's dense number ([`UNUSED`] for one it
    /// does not use).
    index: Vec<usize>,
    /// For each input port, the instructions it reaches (their indices in
    /// program order), or `None` when a register is written twice.
    reach: Option<Vec<Vec<usize>>>,
}

/// [`Boxes`]`::index` of a register the program does not use.
const UNUSED: usize = usize::MAX;

impl<P: Borrow<Compiled>> Boxes<P> {
    /// The evaluator of `prog`'s boxes.
    #[must_use]
    pub fn new(prog: P) -> Boxes<P> {
        let (dense, index) = match prog.borrow() {
            Compiled::Narrow(p) => {
                let (d, i) = p.dense();
                (Compiled::Narrow(d), i)
            }
            Compiled::Wide(p) => {
                let (d, i) = p.dense();
                (Compiled::Wide(d), i)
            }
        };
        let reach = match &dense {
            Compiled::Narrow(p) => p.input_reach(),
            Compiled::Wide(p) => p.input_reach(),
        };
        Boxes {
            prog,
            dense,
            index,
            reach,
        }
    }

    /// The program.
    #[must_use]
    pub fn program(&self) -> &Compiled {
        self.prog.borrow()
    }

    /// The box `inputs` (one range of codes per input port), evaluated
    /// whole: every node's range and every quantization's overflow flag, as
    /// [`Program::node_range`] and [`Program::may_overflow`] give them.
    ///
    /// # Panics
    ///
    /// When `inputs` does not hold one range per input port.
    #[must_use]
    pub fn root(&self, inputs: &[(i128, i128)]) -> BoxEval {
        assert_eq!(inputs.len(), self.ports(), "one range per input port");
        let (ranges, may) = match &self.dense {
            Compiled::Narrow(p) => p.box_ranges(inputs),
            Compiled::Wide(p) => p.box_ranges(inputs),
        };
        BoxEval {
            inputs: inputs.to_vec(),
            ranges,
            may,
            cong: None,
            from: None,
            may_changed: false,
        }
    }

    /// The box `parent` with input port `port`'s range replaced by `range`:
    /// the same figures as [`Boxes::root`] of that box, from running only
    /// the instructions `port` reaches.
    ///
    /// # Panics
    ///
    /// When `port` is not an input port of the program.
    #[must_use]
    pub fn child(&self, parent: &BoxEval, port: usize, range: (i128, i128)) -> BoxEval {
        let mut inputs = parent.inputs.clone();
        inputs[port] = range;
        let Some(reach) = &self.reach else {
            return self.root(&inputs);
        };
        let mut ranges = parent.ranges.clone();
        let mut may = parent.may.clone();
        let may_changed = match &self.dense {
            Compiled::Narrow(p) => p.rerun(&reach[port], port, range, &mut ranges, &mut may),
            Compiled::Wide(p) => p.rerun(&reach[port], port, range, &mut ranges, &mut may),
        };
        BoxEval {
            inputs,
            ranges,
            may,
            cong: None,
            from: parent.cong.clone().map(|c| (c, port)),
            may_changed,
        }
    }

    /// The range of node `node`'s code over the box ([`Program::node_range`];
    /// `(0, 0)` for a node the program does not compute, as there).
    ///
    /// # Panics
    ///
    /// When `node` is not a node of the program's trace (as there).
    #[must_use]
    pub fn node_range(&self, e: &BoxEval, node: usize) -> (i128, i128) {
        match self.index[node] {
            UNUSED => (0, 0),
            i => e.ranges[i],
        }
    }

    /// The range of the exact operand of the quantization at `node` over the
    /// box ([`Program::quant_operand_range`]), or `None` when `node` is not
    /// a quantization of the program.
    #[must_use]
    pub fn quant_operand_range(&self, e: &BoxEval, node: usize) -> Option<(i128, i128)> {
        self.quant_operand(node).map(|a| e.ranges[a])
    }

    /// The congruence `(stride, offset)` of the exact operand of the
    /// quantization at `node` over the box
    /// ([`Program::quant_operand_congruence`]), or `None` when `node` is
    /// not a quantization of the program. Computed once per box: from the
    /// congruences of the box it came from where those were computed (the
    /// same vector when neither the changed input's congruence
    /// nor any overflow flag changed, else the instructions the input
    /// reaches run again), whole otherwise.
    pub fn quant_operand_congruence(&self, e: &mut BoxEval, node: usize) -> Option<(i128, i128)> {
        let a = self.quant_operand(node)?;
        Some(self.congruences(e)[a])
    }

    /// Every register's congruence over the box, computed on first use.
    fn congruences<'e>(&self, e: &'e mut BoxEval) -> &'e [(i128, i128)] {
        if e.cong.is_none() {
            let c = match (&e.from, &self.reach) {
                (Some((pc, port)), Some(reach)) => {
                    let mine = Program::<i64>::input_congruence(e.inputs[*port]);
                    let reg = self.input_reg(*port);
                    if !e.may_changed && pc[reg] == mine {
                        Arc::clone(pc)
                    } else {
                        let mut c = pc.as_ref().clone();
                        c[reg] = mine;
                        for &i in &reach[*port] {
                            Program::<i64>::congruence_step(self.instr(i), &mut c, &e.may);
                        }
                        Arc::new(c)
                    }
                }
                _ => Arc::new(match &self.dense {
                    Compiled::Narrow(p) => p.congruences_with(&e.inputs, &e.may),
                    Compiled::Wide(p) => p.congruences_with(&e.inputs, &e.may),
                }),
            };
            e.cong = Some(c);
        }
        e.cong.as_deref().expect("computed above")
    }

    /// How many input ports the program has.
    fn ports(&self) -> usize {
        match &self.dense {
            Compiled::Narrow(p) => p.inputs.len(),
            Compiled::Wide(p) => p.inputs.len(),
        }
    }

    /// The (dense) register input port `port` is loaded into.
    fn input_reg(&self, port: usize) -> usize {
        match &self.dense {
            Compiled::Narrow(p) => p.inputs[port].0,
            Compiled::Wide(p) => p.inputs[port].0,
        }
    }

    /// Instruction `i`.
    fn instr(&self, i: usize) -> &Instr {
        match &self.dense {
            Compiled::Narrow(p) => &p.instrs[i],
            Compiled::Wide(p) => &p.instrs[i],
        }
    }

    /// The (dense) register of the operand of the quantization at `node`.
    fn quant_operand(&self, node: usize) -> Option<usize> {
        let i = *self.index.get(node).filter(|&&i| i != UNUSED)?;
        match &self.dense {
            Compiled::Narrow(p) => p.quant_operand(i),
            Compiled::Wide(p) => p.quant_operand(i),
        }
    }
}

impl<R: Raw> Program<R> {
    /// This program with the registers it uses (constants, inputs,
    /// instructions' destinations and operands, outputs) numbered `0..n`
    /// in their order, and each register's new
    /// number ([`UNUSED`] where it uses none). It runs as this program
    /// does.
    fn dense(&self) -> (Program<R>, Vec<usize>) {
        let mut used = vec![false; self.n_regs];
        // Every constant, read or not: its node's range is its value.
        for &(d, _) in &self.consts {
            used[d] = true;
        }
        for &(d, _) in &self.inputs {
            used[d] = true;
        }
        for &(o, _) in &self.outputs {
            used[o] = true;
        }
        for ins in &self.instrs {
            used[ins.dest()] = true;
            ins.each_operand(|a| used[a] = true);
        }
        let mut index = vec![UNUSED; self.n_regs];
        let mut n = 0;
        for (r, &u) in used.iter().enumerate() {
            if u {
                index[r] = n;
                n += 1;
            }
        }
        let mut instrs = self.instrs.clone();
        for ins in &mut instrs {
            ins.map_regs(|r| index[r]);
        }
        let inputs: Vec<(usize, _)> = self.inputs.iter().map(|&(d, q)| (index[d], q)).collect();
        let outputs: Vec<(usize, i32)> = self.outputs.iter().map(|&(o, f)| (index[o], f)).collect();
        let consts = self.consts.iter().map(|&(d, c)| (index[d], c)).collect();
        let p = Program {
            instrs,
            n_regs: n,
            consts,
            inputs,
            outputs,
            pool: RegPool(std::sync::Mutex::new(Vec::new())),
            ..self.clone()
        };
        (p.laid_out(), index)
    }

    /// For each input port, the indices of the instructions it reaches, in
    /// program order; `None` when a register is written by more than one
    /// instruction or by an instruction and as a constant or an input
    /// (then a box's figures cannot be patched from another's).
    fn input_reach(&self) -> Option<Vec<Vec<usize>>> {
        let mut written = vec![false; self.n_regs];
        let mut once = |d: usize| !std::mem::replace(&mut written[d], true);
        let sources = self.consts.iter().map(|c| c.0);
        let dests = self.instrs.iter().map(Instr::dest);
        if !sources
            .chain(self.inputs.iter().map(|i| i.0))
            .chain(dests)
            .all(&mut once)
        {
            return None;
        }
        let mut reached = vec![false; self.n_regs];
        Some(
            self.inputs
                .iter()
                .map(|&(reg, _)| {
                    reached.fill(false);
                    reached[reg] = true;
                    let mut list = Vec::new();
                    for (i, ins) in self.instrs.iter().enumerate() {
                        let mut hit = false;
                        ins.each_operand(|a| hit |= reached[a]);
                        if hit {
                            reached[ins.dest()] = true;
                            list.push(i);
                        }
                    }
                    list
                })
                .collect(),
        )
    }

    /// Input port `port` set to `range` in `ranges`, and the instructions
    /// `reach` (those it reaches, in program order) run again: whether an
    /// overflow flag changed.
    fn rerun(
        &self,
        reach: &[usize],
        port: usize,
        range: (i128, i128),
        ranges: &mut [(i128, i128)],
        may: &mut [bool],
    ) -> bool {
        ranges[self.inputs[port].0] = range;
        let mut changed = false;
        for &i in reach {
            let ins = &self.instrs[i];
            let d = ins.dest();
            let before = may[d];
            self.interval_step(ins, ranges, may);
            changed |= may[d] != before;
        }
        changed
    }
}

#[cfg(test)]
mod tests {
    use super::Boxes;
    use crate::datapath::batch::specialize::tests::datapath;
    use crate::datapath::{Compiled, Datapath};
    use crate::quantize::{Overflow, Quant, Rounding};
    use crate::sampling::Rng;

    /// A random sub-range of `lo..=hi` (a single code one time in four).
    fn sub_range(rng: &mut Rng, (lo, hi): (i128, i128)) -> (i128, i128) {
        let pick = |rng: &mut Rng| lo + i128::from(rng.below(u64::try_from(hi - lo + 1).unwrap()));
        let a = pick(rng);
        let b = if rng.below(4) == 0 { a } else { pick(rng) };
        (a.min(b), a.max(b))
    }

    /// Chains of boxes, each from the one before by changing one input's
    /// range (to a sub-range or anywhere in its format, a single code or
    /// not), on a datapath with every kind of instruction but division and
    /// square root, as `i64` and
    /// `i128` programs: every node's range and every quantization's
    /// operand range and congruence are those the whole pass gives on the
    /// same box ([`Compiled::node_ranges`] and the rest, which the
    /// interval tests check against lane-by-lane runs), whether or not the
    /// box before had its congruences computed; and the programs with
    /// their registers renumbered run as the programs do.
    #[test]
    fn child_boxes_give_the_whole_pass_figures() {
        let (mut t, _) = datapath();
        // `x` to two more fraction bits (stride 4 unless it saturates,
        // where it saturates for half its range), and back with a
        // rounding: the second's operand's congruence follows the first's
        // overflow flag.
        let q =
            |s: &'static str, f: &str, r| Quant::new(s, f.parse().unwrap(), r, Overflow::Saturate);
        let x = t.input_ports()[0].value;
        let fine = t.quantize(x, &q("fine", "I1F16", Rounding::Trunc));
        let back = t.quantize(fine, &q("back", "I1F15", Rounding::HalfEven));
        t.output("back", back);
        let outs: Vec<_> = t.output_ports().iter().map(|p| p.value).collect();
        let formats: Vec<(i128, i128)> = t
            .input_ports()
            .iter()
            .map(|p| (p.format.min_code(), p.format.max_code()))
            .collect();
        let quants: Vec<usize> = (0..t.ops().len())
            .filter(|&n| matches!(t.ops()[n], crate::datapath::Op::Quant(..)))
            .collect();
        let nodes: Vec<usize> = (0..t.ops().len()).collect();
        let mut shared = 0;
        // The whole datapath, and one output's cone (most registers unused).
        for (wide, outs) in [false, true]
            .into_iter()
            .flat_map(|w| [(w, outs.clone()), (w, vec![outs[3]])])
        {
            let prog = if wide {
                Compiled::Wide(crate::datapath::batch::Program::compile(&t, &outs).unwrap())
            } else {
                Compiled::Narrow(crate::datapath::batch::Program::compile(&t, &outs).unwrap())
            };
            let boxes = Boxes::new(&prog);
            assert!(boxes.reach.is_some(), "a compiled program is patched");
            let used = boxes.index.iter().filter(|&&i| i != super::UNUSED).count();
            assert!(used < t.ops().len() || outs.len() > 1, "a cone is dense");
            let mut rng = Rng::new(11);
            // The dense program runs as the program does.
            let cols: Vec<Vec<i128>> = formats
                .iter()
                .map(|&r| (0..300).map(|_| sub_range(&mut rng, r).0).collect())
                .collect();
            let refs: Vec<&[i128]> = cols.iter().map(Vec::as_slice).collect();
            assert_eq!(
                boxes.dense.run_flags_i128(&refs),
                prog.run_flags_i128(&refs)
            );
            for _chain in 0..40 {
                let mut e = boxes.root(&formats);
                for _step in 0..30 {
                    let port = fxshade_numbers::convert::narrow::<usize, _>(
                        rng.below(formats.len() as u64),
                    );
                    let within = if rng.below(3) == 0 {
                        formats[port]
                    } else {
                        e.inputs()[port]
                    };
                    let range = sub_range(&mut rng, within);
                    let mut child = boxes.child(&e, port, range);
                    let b = child.inputs().to_vec();
                    assert_eq!(
                        nodes
                            .iter()
                            .map(|&n| boxes.node_range(&child, n))
                            .collect::<Vec<_>>(),
                        prog.node_ranges(&b, &nodes),
                        "{b:?}"
                    );
                    for &q in &quants {
                        assert_eq!(
                            boxes.quant_operand_range(&child, q),
                            prog.quant_operand_range(&b, q)
                        );
                        let before = child.cong.is_some();
                        assert_eq!(
                            boxes.quant_operand_congruence(&mut child, q),
                            prog.quant_operand_congruence(&b, q),
                            "{b:?} node {q}"
                        );
                        if let (false, Some(c), Some((pc, _))) = (before, &child.cong, &child.from)
                        {
                            shared += usize::from(std::sync::Arc::ptr_eq(pc, c));
                        }
                    }
                    // One box in three leaves its congruences uncomputed
                    // (its child's come whole), the rest pass theirs on
                    // along chains, as in a branch and bound.
                    if rng.below(3) == 0 {
                        child.cong = None;
                    }
                    e = child;
                }
            }
        }
        assert!(shared > 0, "some boxes share their parent's congruences");
    }
}
