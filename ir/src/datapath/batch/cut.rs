//! Cuts of a trace: a node through which every input reaches another, so
//! that the second is a function of the first alone; and the trace with
//! such a node made an input port, to evaluate that function over every
//! code of the cut (the mutation search, `crate::rtl::search`).

use super::{Op, Trace, TV};

impl Trace {
    /// The value node `n` computes, read at its own binary point.
    ///
    /// # Panics
    ///
    /// If `n` is not a node of this trace, or is `2^32` or more.
    pub fn value(&self, n: usize) -> TV {
        TV {
            id: u32::try_from(n).expect("fewer than 2^32 nodes"),
            frac: self.fracs[n],
            sym: self.syms[n],
        }
    }

    /// The operands of node `i`.
    pub fn operands(&self, i: usize) -> Vec<usize> {
        match &self.ops[i] {
            Op::Input(_) | Op::Const(_) => vec![],
            Op::Mul(a, b) | Op::Add(a, b) | Op::Sub(a, b) | Op::Max(a, b) | Op::Div(a, b, _) => {
                vec![a.node(), b.node()]
            }
            Op::Quant(a, _) | Op::Table(a, _) | Op::Sqrt(a, _) => vec![a.node()],
            Op::Select(s, o) => std::iter::once(s.node())
                .chain(o.iter().map(|t| t.node()))
                .collect(),
            Op::AddSigned(a, b, s, _) => vec![a.node(), b.node(), s.node()],
        }
    }

    /// The nodes computed from node `x` (itself included): where a change
    /// of `x` can show.
    pub fn downstream(&self, x: usize) -> Vec<bool> {
        let mut down = vec![false; self.ops.len()];
        down[x] = true;
        for i in x + 1..self.ops.len() {
            down[i] = self.operands(i).iter().any(|&o| down[o]);
        }
        down
    }

    /// The nodes node `x` depends on (itself included), not looking
    /// through `stop`.
    fn cone(&self, x: usize, stop: Option<usize>) -> Vec<bool> {
        let mut need = vec![false; self.ops.len()];
        need[x] = true;
        for i in (0..=x).rev() {
            if !need[i] || Some(i) == stop && i != x {
                continue;
            }
            for o in self.operands(i) {
                need[o] = true;
            }
        }
        need
    }

    /// The quantizations and input ports `c` through which every input
    /// port reaches node `x` (with `c` taken as a leaf, the cone of `x`
    /// holds no other input port), nearest to `x` first. `x` itself is
    /// not among them.
    pub fn cuts(&self, x: usize) -> Vec<usize> {
        let cone = self.cone(x, None);
        (0..x)
            .rev()
            .filter(|&c| cone[c] && matches!(self.ops[c], Op::Quant(..) | Op::Input(_)))
            .filter(|&c| {
                let sub = self.cone(x, Some(c));
                !(0..x).any(|i| sub[i] && i != c && matches!(self.ops[i], Op::Input(_)))
            })
            .collect()
    }

    /// The input port nodes in the cone of node `x` (every node `x` is
    /// computed from), in node order.
    pub fn inputs_of(&self, x: usize) -> Vec<usize> {
        let cone = self.cone(x, None);
        (0..=x)
            .filter(|&i| cone[i] && matches!(self.ops[i], Op::Input(_)))
            .collect()
    }

    /// The quantizations and input ports node `x` reads through operations
    /// that are not quantizations (its operands, their operands, … up to
    /// the first quantization or input on each path; `x` itself when it is
    /// one): a set of cuts of `x` that [`Trace::cut_at`] can make inputs,
    /// taken as independent.
    pub fn supports(&self, x: usize) -> Vec<usize> {
        let mut seen = vec![false; self.ops.len()];
        let mut stack = vec![x];
        let mut out = Vec::new();
        while let Some(i) = stack.pop() {
            if std::mem::replace(&mut seen[i], true) {
                continue;
            }
            match self.ops[i] {
                Op::Quant(..) | Op::Input(_) => out.push(i),
                _ => stack.extend(self.operands(i)),
            }
        }
        out.sort_unstable();
        out
    }

    /// This trace with node `c` (a quantization or an input port) replaced
    /// by a new input port of `c`'s format, named `cut`; and the position of
    /// that port among the compiled program's inputs (which are the input
    /// nodes in node order, the replaced port's old inputs included).
    ///
    /// # Panics
    ///
    /// When node `c` is neither a quantization nor an input port, or out of
    /// range.
    pub fn cut_at(&self, c: usize) -> (Trace, usize) {
        let q = match &self.ops[c] {
            Op::Quant(_, q) => *q,
            Op::Input(s) => self.inputs[*s],
            op => panic!("node {c} ({op:?}) is neither a quantization nor an input"),
        };
        let mut t = self.clone();
        let slot = t.inputs.len();
        t.inputs.push(q);
        t.input_names.push("cut".to_string());
        t.ops[c] = Op::Input(slot);
        let pos = t.ops[..c]
            .iter()
            .filter(|op| matches!(op, Op::Input(_)))
            .count();
        (t, pos)
    }
}

impl Trace {
    /// This trace with each of the nodes `cs` (quantizations or input
    /// ports) made an input port ([`Trace::cut_at`]) and every other input
    /// port made the constant code 0: the function from `cs` to the nodes
    /// of their region ([`Trace::cut_set_frontier`]), which read no other
    /// port. The compiled program's inputs are `cs` in node order.
    pub fn from_cuts(&self, cs: &[usize]) -> Trace {
        let mut t = self.clone();
        for &c in cs {
            t = t.cut_at(c).0;
        }
        for (i, op) in t.ops.iter_mut().enumerate() {
            if matches!(op, Op::Input(_)) && !cs.contains(&i) {
                *op = Op::Const(0);
            }
        }
        t
    }

    /// The frontier of the region of cut `c` towards the values `roots`:
    /// the region is every node that depends on `c` and on no other input
    /// port (and `c`), the frontier every node of it that is a root or an
    /// operand of a live node outside it. Every path from the region to
    /// the roots leaves through the frontier, so two traces that differ
    /// only inside the region agree on the roots wherever they agree on
    /// the frontier.
    pub fn cut_frontier(&self, c: usize, roots: &[TV]) -> Vec<usize> {
        self.cut_set_frontier(&[c], roots)
    }

    /// [`Trace::cut_frontier`] of a set of cuts: the region is every node
    /// that depends on some of `cs` and on no other input port.
    pub fn cut_set_frontier(&self, cs: &[usize], roots: &[TV]) -> Vec<usize> {
        let n = self.ops.len();
        let mut dep = vec![false; n];
        let mut other = vec![false; n];
        for i in 0..n {
            if cs.contains(&i) {
                dep[i] = true;
                continue;
            }
            if let Op::Input(_) = self.ops[i] {
                other[i] = true;
                continue;
            }
            for o in self.operands(i) {
                dep[i] |= dep[o];
                other[i] |= other[o];
            }
        }
        let region: Vec<bool> = (0..n).map(|i| dep[i] && !other[i]).collect();
        let live = self.live_nodes(roots);
        let mut front = vec![false; n];
        for r in roots {
            if region[r.node()] {
                front[r.node()] = true;
            }
        }
        for j in 0..n {
            if live[j] && !region[j] {
                for o in self.operands(j) {
                    if region[o] {
                        front[o] = true;
                    }
                }
            }
        }
        (0..n).filter(|&i| front[i]).collect()
    }
}
