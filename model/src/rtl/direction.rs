//! Equivalence proofs for a stage the outputs read only as a CORDIC step's
//! direction: the sign that steers [`Op::AddSigned`] (`a ± b`, `−` when the
//! selector is negative), and the magnitude it folds into the other
//! coordinate (`x + |y|·2^−i`, truncated back to `x`'s format).
//!
//! A mutant of such a stage is equivalent when it keeps the sign of every
//! code, and, for the folds, when `|y|·2^−i` and the mutant's value of it
//! round to the same amount: a late step's `|y|` is far below one LSB of
//! `x`, which a CORDIC's convergence guarantees (`|y_i| ≲ x·2^−i`) and a
//! branch and bound over the input codes proves ([`direction_proof`]).

use super::Design;
use crate::datapath::{Boxes, Compiled, Mutation, Op, TV};
use crate::quantize::{round_shift_right, Overflow, Quant, Rounding, Step};
use crate::vectors::RtlError;
use fxshade_numbers::convert::narrow;
use std::rc::Rc;

/// Why [`sign_only`] or [`direction_proof`] proves a mutant equivalent.
pub const WHY: &str = "equivalent: the outputs read the stage only as CORDIC steps' direction (its sign) and as the magnitude folded into the other coordinate; the mutant keeps every code's sign, and a branch and bound over the input codes keeps the stage where the design's and the mutant's folded magnitudes round alike";

/// Widest quantizer shift looked at (the sign window is `2^(shift+2)`
/// codes).
const WINDOW_SHIFT: i32 = 20;

/// Input ports [`direction_proof`] branches over directly, at most.
const MAX_PORTS: usize = 3;

/// Codes on either side of zero [`safe_bound`] looks at, at most.
const SAFE_CODES: i128 = 1 << 22;

/// A live reader of the stage.
enum Reader {
    /// The selector of an [`Op::AddSigned`] whose other operands are not
    /// the stage: only the sign is read.
    Sign,
    /// `a ± |n|·2^sb` (an [`Op::AddSigned`] steered by `n` itself), read
    /// only by quantizations whose dropped bits `a`'s term leaves zero:
    /// each quantization's shift and rounding, and the sign of the fold.
    Fold {
        /// Left shift of `|n|` into the sum's binary point.
        sb: u32,
        /// `a − |n|` (the flag of the [`Op::AddSigned`]).
        sub: bool,
        /// Shift and rounding of every quantization reading the sum.
        quants: Vec<(i32, Rounding)>,
    },
}

/// The live readers of `n` (those on a path to an output), or `None` when
/// one reads more of `n` than its sign and folded magnitude.
fn readers(d: &Design, n: usize) -> Option<Vec<Reader>> {
    let t = &d.trace;
    let ops = t.ops();
    let roots: Vec<TV> = t.output_ports().iter().map(|p| p.value).collect();
    if roots.iter().any(|r| r.node() == n) {
        return None;
    }
    let live = t.live_nodes(&roots);
    let reads = |x: usize| -> Vec<usize> {
        (x + 1..ops.len())
            .filter(|&i| live[i] && t.operands(i).contains(&x))
            .collect()
    };
    let mut out = Vec::new();
    for i in reads(n) {
        let Op::AddSigned(a, b, s, flip) = ops[i] else {
            return None;
        };
        if s.node() != n || a.node() == n {
            return None;
        }
        if b.node() != n {
            out.push(Reader::Sign);
            continue;
        }
        let f = a.frac().max(b.frac());
        let (sa, sb) = (
            narrow::<u32, _>(f - a.frac()),
            narrow::<u32, _>(f - b.frac()),
        );
        let mut quants = Vec::new();
        for j in reads(i) {
            let Op::Quant(r, q) = &ops[j] else {
                return None;
            };
            // `r` read at another binary point than the sum's is not a
            // fold, and `a`'s term must leave the dropped bits zero.
            let shift = q.step(f).shift;
            if r.frac() != f || shift > narrow::<i32, _>(sa) {
                return None;
            }
            quants.push((shift, q.round()));
        }
        out.push(Reader::Fold {
            sb,
            sub: flip,
            quants,
        });
    }
    Some(out)
}

/// Whether adding `u` or `w` to any multiple of `2^s` rounds (mode `r`,
/// `s` bits dropped) to the same code.
fn round_alike(u: i128, w: i128, s: i32, r: Rounding) -> bool {
    if u == w {
        return true;
    }
    if s <= 0 {
        return false;
    }
    let sh = narrow::<u32, _>(s);
    let tie = |v: i128| v.rem_euclid(1 << sh) == 1 << (sh - 1);
    match r {
        Rounding::Trunc => (u >> sh) == (w >> sh),
        Rounding::HalfUp => {
            round_shift_right(u, sh, Rounding::HalfUp) == round_shift_right(w, sh, Rounding::HalfUp)
        }
        // A tie rounds by the parity of the multiple: not the same unless
        // neither is one.
        Rounding::HalfEven => {
            !tie(u)
                && !tie(w)
                && round_shift_right(u, sh, Rounding::HalfUp)
                    == round_shift_right(w, sh, Rounding::HalfUp)
        }
    }
}

/// The stage's quantizer in the design and in the mutant: the step and
/// the quantization.
fn sides(d: &Design, m: &Mutation) -> Option<[(Step, Quant); 2]> {
    let mutant = d.trace.mutated(m);
    let (Op::Quant(a, q), Op::Quant(ma, mq)) = (&d.trace.ops()[m.node], &mutant.ops()[m.node])
    else {
        return None;
    };
    Some([(q.step(a.frac()), *q), (mq.step(ma.frac()), *mq)])
}

/// Whether the mutant gives every operand code in `[lo, hi]` the design's
/// sign. Exhaustive where the signs can differ: both quantizers are
/// monotone non-decreasing in the operand (every rounding mode is; so is
/// saturation, and wrapping where the ends of the range do not overflow),
/// so each maps the operands below one threshold to negative codes. Both
/// thresholds lie in `[−2^(k+1), 2^(k+1)]` for `k` the larger shift (an
/// operand of `−2^(k+1)` units is negative in every mode), evaluated code by
/// code; outside it the ends' signs hold by monotony.
fn keeps_sign(sides: &[(Step, Quant); 2], lo: i128, hi: i128) -> bool {
    let apply = |(st, q): &(Step, Quant), v: i128| st.apply(v, q.round(), q.overflow());
    let monotone = sides.iter().all(|s| {
        s.1.overflow() == Overflow::Saturate
            || !(apply(s, lo).overflowed || apply(s, hi).overflowed)
    });
    let k = sides
        .iter()
        .map(|(st, _)| st.shift)
        .max()
        .unwrap_or(0)
        .max(0);
    if !monotone || k > WINDOW_SHIFT {
        return false;
    }
    let negative = |v: i128| sides.each_ref().map(|s| apply(s, v).code < 0);
    let (wlo, whi) = (lo.max(-(1 << (k + 1))), hi.min(1 << (k + 1)));
    (wlo..=whi).all(|v| negative(v)[0] == negative(v)[1])
        && (lo >= wlo || negative(wlo) == [true, true])
        && (hi <= whi || negative(whi) == [false, false])
}

/// The full box of input codes and the outputs' program.
fn program(d: &Design) -> Result<(Compiled, Vec<(i128, i128)>), RtlError> {
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    Ok((
        Compiled::compile(&d.trace, &roots)?,
        super::search::full_box(d),
    ))
}

/// Whether mutant `m` is equivalent because the outputs read its stage
/// only as the sign of CORDIC steps' directions and the mutant keeps every
/// operand's sign ([`keeps_sign`] over the operand's range from interval
/// analysis): no branch and bound, cheap enough for
/// [`super::mutants::equivalent`].
///
/// # Errors
///
/// [`RtlError::Compile`] when the design's outputs cannot be compiled
/// ([`Compiled::compile`]).
pub fn sign_only(d: &Design, m: &Mutation) -> Result<bool, RtlError> {
    let Some(rs) = readers(d, m.node) else {
        return Ok(false);
    };
    if rs.iter().any(|r| matches!(r, Reader::Fold { .. })) {
        return Ok(false);
    }
    let Some(sides) = sides(d, m) else {
        return Ok(false);
    };
    let (prog, full) = program(d)?;
    Ok(prog
        .quant_operand_range(&full, m.node)
        .is_some_and(|(lo, hi)| keeps_sign(&sides, lo, hi)))
}

/// The largest `V` such that on every operand code whose design code lies
/// in `[−V, V]` every fold rounds the design's and the mutant's magnitudes
/// alike, or `None` when there is none. The operand codes in `[lo, hi]` are
/// scanned outward from zero (at most [`SAFE_CODES`] each way) to the first
/// one that is not safe; the quantizer is monotone, so every operand code
/// beyond it has a design code beyond that one's.
fn safe_bound(rs: &[Reader], sides: &[(Step, Quant); 2], lo: i128, hi: i128) -> Option<i128> {
    let apply = |(st, q): &(Step, Quant), v: i128| st.apply(v, q.round(), q.overflow()).code;
    let ok = |v: i128| {
        let (c, w) = (apply(&sides[0], v), apply(&sides[1], v));
        rs.iter().all(|r| match r {
            Reader::Sign => true,
            Reader::Fold { sb, sub, quants } => {
                let signed = |x: i128| {
                    if *sub {
                        -(x.abs() << sb)
                    } else {
                        x.abs() << sb
                    }
                };
                quants
                    .iter()
                    .all(|&(s, rd)| round_alike(signed(c), signed(w), s, rd))
            }
        })
    };
    let q = |v: i128| apply(&sides[0], v);
    // One side: the operand codes `0, dir, 2·dir, …` up to `end` (an end
    // of the range, or the scan's cap): the bound that side allows.
    let side = |dir: i128, end: i128| -> i128 {
        let reach = end.abs().min(SAFE_CODES);
        match (0..=reach).map(|k| k * dir).find(|&v| !ok(v)) {
            Some(v) => dir * q(v) - 1,
            None if end.abs() <= SAFE_CODES => i128::MAX,
            None => dir * q(dir * SAFE_CODES) - 1,
        }
    };
    let b = side(1, hi.max(0)).min(side(-1, lo.min(0)));
    (b >= 0).then_some(b)
}

/// Whether mutant `m` is proven equivalent as a stage read only as CORDIC
/// directions ([`Reader`]): the mutant keeps every operand's sign, and a
/// branch and bound over boxes of the input codes in the stage's cone
/// shows (by interval analysis, [`Compiled::node_range`]) that the stage's
/// code stays within the bound where the folded magnitudes round alike.
/// `Ok(false)`: not such a stage, a single input lies outside the bound,
/// or the search takes more than `budget` boxes (a count: the outcome does
/// not depend on the machine's load).
///
/// # Errors
///
/// [`RtlError::Compile`] when the design's outputs, the layer branched over, or the cut
/// trace computing the stage cannot be compiled ([`Compiled::compile`]).
pub fn direction_proof(d: &Design, m: &Mutation, budget: u64) -> Result<bool, RtlError> {
    proof(d, m, budget, MAX_PORTS)
}

/// [`direction_proof`], branching over the ports when there are at most
/// `max_ports` of them.
fn proof(d: &Design, m: &Mutation, budget: u64, max_ports: usize) -> Result<bool, RtlError> {
    let Some(rs) = readers(d, m.node) else {
        return Ok(false);
    };
    let Some(sides) = sides(d, m) else {
        return Ok(false);
    };
    let (prog, full) = program(d)?;
    let Some((lo, hi)) = prog.quant_operand_range(&full, m.node) else {
        return Ok(false);
    };
    if !keeps_sign(&sides, lo, hi) {
        return Ok(false);
    }
    if rs.iter().all(|r| matches!(r, Reader::Sign)) {
        return Ok(true);
    }
    let Some(bound) = safe_bound(&rs, &sides, lo, hi) else {
        return Ok(false);
    };
    // The domain: the input ports in the stage's cone when there are at
    // most three, else the narrowest layer of quantizations it is computed
    // from (the normal a CORDIC is given, wherever it comes from), each
    // over the codes interval analysis allows it. (Ports first: the
    // `angles` unit's last fold takes 1.1 million boxes over its normal,
    // 9.4 million over the rotation's first `x` and `y`.)
    let t = &d.trace;
    let Op::Quant(op, _) = &t.ops()[m.node] else {
        return Ok(false);
    };
    let cone = t.inputs_of(m.node);
    let layer = if cone.len() <= max_ports {
        None
    } else {
        super::search::narrow_layer(t, op.node())
    };
    let (cut, dims, full) = match layer {
        Some(layer) => {
            let vals: Vec<TV> = layer.iter().map(|&c| t.value(c)).collect();
            let lprog = Compiled::compile(t, &vals)?;
            let mut cut = t.clone();
            for &c in &layer {
                cut = cut.cut_at(c).0;
            }
            let inputs: Vec<usize> = (0..cut.ops().len())
                .filter(|&i| matches!(cut.ops()[i], Op::Input(_)))
                .collect();
            let mut b: Vec<(i128, i128)> = (0..inputs.len()).map(|_| (0, 0)).collect();
            let mut dims = Vec::new();
            for &c in &layer {
                let Some(r) = super::search::code_range(d, &lprog, &full, c) else {
                    return Ok(false);
                };
                let k = inputs
                    .iter()
                    .position(|&i| i == c)
                    .expect("a cut is an input");
                b[k] = r;
                dims.push(k);
            }
            (cut, dims, b)
        }
        None => {
            let dims = t
                .input_ports()
                .iter()
                .enumerate()
                .filter(|(_, p)| cone.contains(&p.value.node()))
                .map(|(i, _)| i)
                .collect();
            (t.clone(), dims, full)
        }
    };
    let prog = Compiled::compile(&cut, &[cut.value(m.node)])?;
    let ports = dims;
    // Each box with the evaluated box it was split from and the port
    // split: only what that port reaches is evaluated again.
    let eval = Boxes::new(&prog);
    let mut stack: Vec<(Vec<(i128, i128)>, super::search::Split)> = vec![(full.clone(), None)];
    let mut boxes = 0u64;
    while let Some((b, from)) = stack.pop() {
        boxes += 1;
        if boxes > budget {
            return Ok(false);
        }
        let e = match from {
            Some((parent, p)) => eval.child(&parent, p, b[p]),
            None => eval.root(&b),
        };
        let (nlo, nhi) = eval.node_range(&e, m.node);
        if -bound <= nlo && nhi <= bound {
            continue;
        }
        let Some(&widest) = ports
            .iter()
            .filter(|&&p| b[p].0 < b[p].1)
            .max_by_key(|&&p| b[p].1 - b[p].0)
        else {
            return Ok(false);
        };
        let (a, z) = b[widest];
        let mid = a + (z - a).div_euclid(2);
        let (mut left, mut right) = (b.clone(), b);
        left[widest] = (a, mid);
        right[widest] = (mid + 1, z);
        let e = Rc::new(e);
        stack.push((left, Some((Rc::clone(&e), widest))));
        stack.push((right, Some((e, widest))));
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::datapath::MutationKind;

    /// The angles unit on 6-bit normals with six micro-rotations, and
    /// `xy` with `frac` fraction bits.
    fn small_angles(frac: u32) -> Design {
        let mut cfg = Config::embedded();
        for o in [
            "angles.iterations=6".to_string(),
            "angles.normal.format=I2F4".into(),
            format!("angles.xy.format=I4F{frac}"),
            "angles.theta.format=U0F10".into(),
            "angles.out.format=U0F8".into(),
        ] {
            cfg.apply_override(&o).unwrap();
        }
        let u = super::super::units::unit("angles").unwrap();
        u.design(&cfg).unwrap()
    }

    /// Soundness by exhaustion over every input of two small CORDICs: no
    /// mutant [`sign_only`] or [`direction_proof`] proves is killed by any
    /// input. With `xy` at 6 fraction bits the last fold of the first
    /// rotation (`x + |y|·2^−5`) stays below one LSB of `x`, and the proof
    /// must take the off-by-one shift of that `y`; at 7 bits it does not
    /// (the normal's length reaches 2·√2, so `|y|` reaches 32 codes), the
    /// shift is killable, and the bound check must refuse it. (Measured over
    /// 3 to 11 bits: proven up to 6, killable from 7.) Branching over the
    /// normal's ports and over the rotation's first layer must agree.
    #[test]
    fn direction_proofs_are_sound_and_take_folds_below_an_lsb() {
        let rows: Vec<Vec<i128>> = (-32..32)
            .flat_map(|x| (-32..32).flat_map(move |y| (-32..32).map(move |z| vec![x, y, z])))
            .collect();
        // A count far above what these proofs take: no dependence on load.
        let budget = || 1u64 << 26;
        for (frac, want_fold) in [(6, true), (7, false)] {
            let d = small_angles(frac);
            let mut folds = 0;
            let mut killable_folds = 0;
            for (m, first) in super::super::mutants::model_kills(&d, &rows).unwrap() {
                let by_sign = sign_only(&d, &m).unwrap();
                let by_bound = direction_proof(&d, &m, budget()).unwrap();
                // The same over the layer the rotation starts from.
                let by_layer = proof(&d, &m, budget(), 0).unwrap();
                assert_eq!(
                    by_layer, by_bound,
                    "xy frac {frac}: {m}: over the ports {by_bound}, over the layer {by_layer}"
                );
                assert!(
                    first.is_none() || !(by_sign || by_bound),
                    "xy frac {frac}: {m} is proven equivalent, yet input {:?} kills it",
                    first.map(|i| &rows[i])
                );
                let fold = m.kind == MutationKind::Shift
                    && readers(&d, m.node)
                        .is_some_and(|r| r.iter().any(|r| matches!(r, Reader::Fold { .. })));
                if fold && by_bound {
                    folds += 1;
                }
                if fold && first.is_some() {
                    killable_folds += 1;
                }
            }
            assert_eq!(
                folds > 0,
                want_fold,
                "xy frac {frac}: {folds} fold shifts proven"
            );
            assert_eq!(
                killable_folds > 0,
                !want_fold,
                "xy frac {frac}: {killable_folds} killable fold shifts"
            );
        }
    }
}
