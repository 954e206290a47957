//! Mutants of a traced datapath: one quantization changed at a time, the
//! faults a hand-written or mis-generated RTL most often has. They measure
//! how good a vector set is (a set that cannot tell a mutant from the
//! original would pass that faulty RTL), and they steer vector generation
//! towards inputs that tell them apart.

use super::{Op, Trace, TV};
use crate::quantize::{Overflow, Rounding};

/// What a mutant changes at one quantization.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MutationKind {
    /// Another rounding mode (half_even ↔ half_up; trunc → half_up).
    Round(Rounding),
    /// The other overflow mode.
    Overflow(Overflow),
    /// The input's binary point read one bit off: one more bit dropped
    /// (the slice taken one position higher).
    Shift,
}

/// One mutant: a quantization node and its change.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Mutation {
    /// The trace node of the quantization.
    pub node: usize,
    /// Its qualified stage id (`normalize.g`).
    pub stage: String,
    /// The change.
    pub kind: MutationKind,
}

impl std::fmt::Display for Mutation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.kind {
            MutationKind::Round(r) => write!(
                f,
                "{} (node {}): rounding {}",
                self.stage,
                self.node,
                r.name()
            ),
            MutationKind::Overflow(o) => {
                write!(
                    f,
                    "{} (node {}): overflow {}",
                    self.stage,
                    self.node,
                    o.name()
                )
            }
            MutationKind::Shift => {
                write!(f, "{} (node {}): slice one bit high", self.stage, self.node)
            }
        }
    }
}

impl Trace {
    /// Every mutant of the quantizations live for `roots`, in node order:
    /// for each, a changed rounding mode where bits are dropped, a flipped
    /// overflow mode where the rounded value's width can leave the format
    /// (elsewhere the range check is constant and the mutant identical),
    /// and an off-by-one shift.
    pub fn mutations(&self, roots: &[TV]) -> Vec<Mutation> {
        let live = self.live_nodes(roots);
        let mut v = Vec::new();
        for (i, op) in self.ops.iter().enumerate() {
            let Op::Quant(a, q) = op else { continue };
            if !live[i] {
                continue;
            }
            let stage = self.stage_ids[i].clone().unwrap_or_default();
            let m = |kind| Mutation {
                node: i,
                stage: stage.clone(),
                kind,
            };
            let dropped = a.frac - q.format().frac();
            if dropped > 0 {
                v.push(m(MutationKind::Round(match q.round() {
                    Rounding::HalfEven => Rounding::HalfUp,
                    Rounding::HalfUp => Rounding::HalfEven,
                    Rounding::Trunc => Rounding::HalfUp,
                })));
            }
            if can_overflow(a.sym.width, a.sym.signed, dropped, q) {
                v.push(m(MutationKind::Overflow(match q.overflow() {
                    Overflow::Wrap => Overflow::Saturate,
                    Overflow::Saturate => Overflow::Wrap,
                })));
            }
            v.push(m(MutationKind::Shift));
        }
        v
    }

    /// The trace with `m` applied.
    ///
    /// # Panics
    ///
    /// When `m.node` is not a quantization node of this trace (mutations come
    /// from [`Trace::mutations`], which lists only those).
    pub fn mutated(&self, m: &Mutation) -> Trace {
        let mut t = self.clone();
        if let Op::Quant(a, q) = &mut t.ops[m.node] {
            match m.kind {
                MutationKind::Round(r) => *q = q.with_round(r),
                MutationKind::Overflow(o) => *q = q.with_overflow(o),
                MutationKind::Shift => a.frac += 1,
            }
        } else {
            panic!("mutation of node {} which is not a quantization", m.node);
        }
        t
    }
}

/// Whether the rounded value (width `xw` before rounding, `dropped` bits
/// dropped or added) can lie outside `q`'s format: the emitter's range
/// check is then not a constant 0 (the emitter's own width rules).
fn can_overflow(xw: u32, xs: bool, dropped: i32, q: &crate::quantize::Quant) -> bool {
    let rw = crate::bits::rounded_width(xw, dropped, q.round());
    crate::bits::can_leave(rw, xs, q.format().width(), q.format().signed())
}
