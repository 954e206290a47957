//! Searching the inputs for the mutants random vectors miss, and proving
//! the others equivalent, through cuts of the datapath.
//!
//! A mutant differs from the design only where its quantizer meets the
//! mutant's event (a tie with an even floor, the half bit, an overflow:
//! [`super::mutants`]), and then only if the change survives to an output
//! or a flag.
//!
//! **One cut.** When every input reaches the quantizer's operand through
//! one quantization `c` (a *cut*, [`Trace::cuts`]: `d` before the linear
//! normalizer's `g = c0 + c1·d`, the dot product before the specular power
//! chain), everything from `c` up to where other inputs join in (the
//! region's *frontier*, [`Trace::cut_frontier`]) is a function of `c`'s
//! code alone. [`event_cut`] runs design and mutant over every code `c` can
//! take (at most [`MAX_CUT_CODES`]) and keeps the codes where the frontier
//! differs:
//!
//! - none: the mutant is **equivalent** (sound: the codes tried cover
//!   every code interval analysis allows at `c` over every input);
//! - some: they are rare among random inputs (4 codes of `d` in 2^18), and
//!   [`line_search`] finds inputs that produce them: it fixes every input
//!   but one at a random value and bisects the remaining input's range,
//!   keeping the halves whose interval at `c` still holds such a code, down
//!   to single inputs; those are run on the mutant, and when the change is
//!   masked further on, every input of the row is swept over its range.
//!
//! **Several cuts.** [`support_proof`] takes the quantizations the operand
//! is computed from as independent inputs and branches and bounds over
//! their codes, with intervals, congruences (`x ≡ r (mod s)`, which decide
//! a tie of an affine operand exactly) and table ranges, comparing the
//! region's frontier at the points left: none differs, the mutant is
//! equivalent. Where the supports are correlated (a CORDIC's `x` and `y`,
//! whose rotation keeps `y` shrinking and `x` below `K·|v|`),
//! [`input_proof`] branches over the input ports themselves instead: the
//! interval analysis splits each micro-rotation at the sign that steers
//! it, so on small enough boxes it follows the rotation.
//!
//! **Last resorts.** What neither steers nor proves goes to witnesses
//! ([`super::witness`]: codes of the supports where the mutant differs,
//! realized as inputs) and then to plain random rows
//! ([`super::probe`]), which beat any steering where several rare
//! conditions in low bits must meet (a late CORDIC rounding).
//!
//! [`Trace::cuts`]: crate::datapath::Trace::cuts
//! [`Trace::cut_frontier`]: crate::datapath::Trace::cut_frontier

use super::mutants::{columns, first_difference, range_meets, range_meets_mod, wild_row};
use super::Design;
use crate::datapath::{BoxEval, Boxes, Compiled, Mutation, MutationKind, Op, TV};
use crate::vectors::RtlError;
use fxshade_numbers::convert::{narrow, to_f64};
use std::rc::Rc;

/// The most codes of a cut [`event_cut`] enumerates.
pub const MAX_CUT_CODES: i128 = 1 << 22;

/// The codes of a cut at which the mutant's quantizer meets its event.
#[derive(Clone, Debug, PartialEq)]
pub struct EventCut {
    /// The cut: a quantization or input node through which every input
    /// reaches the mutant's quantizer.
    pub node: usize,
    /// Every code the cut can take (interval analysis over every input).
    pub range: (i128, i128),
    /// The codes in `range` that meet the event, ascending.
    pub codes: Vec<i128>,
}

/// What [`event_cut`] found.
#[derive(Clone, Debug, PartialEq)]
pub enum CutOutcome {
    /// No code of the cut meets the event: the mutant is equivalent.
    Proven(EventCut),
    /// These codes do.
    Event(EventCut),
    /// No cut with at most [`MAX_CUT_CODES`] codes (or a shift mutant,
    /// whose event is every input).
    NoCut,
}

/// The quantization of mutant `m` and the binary point of its operand.
pub(super) fn quant_of(d: &Design, m: &Mutation) -> (crate::quantize::Quant, i32, usize) {
    match &d.trace.ops()[m.node] {
        Op::Quant(a, q) => (*q, a.frac(), a.node()),
        _ => unreachable!("mutations are of quantizations"),
    }
}

/// The full box of input codes of `d`.
pub(super) fn full_box(d: &Design) -> Vec<(i128, i128)> {
    d.trace
        .input_ports()
        .iter()
        .map(|p| (p.format.min_code(), p.format.max_code()))
        .collect()
}

/// Bounds on the code of node `c` (a quantization or an input) over the
/// box `b`, from `prog` (compiled with `c` among its outputs' cone).
pub(super) fn code_range(
    d: &Design,
    prog: &Compiled,
    b: &[(i128, i128)],
    c: usize,
) -> Option<(i128, i128)> {
    code_range_with(d, b, c, || prog.quant_operand_range(b, c))
}

/// [`code_range`] given the range of `c`'s operand over `b`, asked for
/// where `c` is a quantization (`operand`).
fn code_range_with(
    d: &Design,
    b: &[(i128, i128)],
    c: usize,
    operand: impl FnOnce() -> Option<(i128, i128)>,
) -> Option<(i128, i128)> {
    match &d.trace.ops()[c] {
        Op::Input(_) => {
            let pos = d.trace.ops()[..c]
                .iter()
                .filter(|op| matches!(op, Op::Input(_)))
                .count();
            Some(b[pos])
        }
        Op::Quant(a, q) => {
            let (lo, hi) = operand()?;
            let (ql, qh) = (q.apply(lo, a.frac()), q.apply(hi, a.frac()));
            let f = q.format();
            if (ql.overflowed || qh.overflowed) && q.overflow() == crate::quantize::Overflow::Wrap {
                Some((f.min_code(), f.max_code()))
            } else {
                Some((ql.code, qh.code))
            }
        }
        _ => None,
    }
}

/// The nearest cut of mutant `m`'s operand with at most [`MAX_CUT_CODES`]
/// codes, and the codes of it that meet `m`'s event (see the module
/// documentation).
///
/// # Errors
///
/// [`RtlError::Compile`] when the program of a cut, or the design or the mutant from the cut
/// to its frontier, cannot be compiled ([`Compiled::compile`]).
pub fn event_cut(d: &Design, m: &Mutation) -> Result<CutOutcome, RtlError> {
    if m.kind == MutationKind::Shift {
        return Ok(CutOutcome::NoCut);
    }
    let (_, _, x) = quant_of(d, m);
    let full = full_box(d);
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    for c in d.trace.cuts(x) {
        let prog = Compiled::compile(&d.trace, &[d.trace.value(c)])?;
        let Some((lo, hi)) = code_range(d, &prog, &full, c) else {
            continue;
        };
        if hi - lo + 1 > MAX_CUT_CODES {
            continue;
        }
        let (t, pos) = d.trace.cut_at(c);
        let front: Vec<TV> = d
            .trace
            .cut_frontier(c, &roots)
            .into_iter()
            .map(|f| t.value(f))
            .collect();
        let orig = Compiled::compile(&t, &front)?;
        let mutant = Compiled::compile(&t.mutated(m), &front)?;
        let n_in = t
            .ops()
            .iter()
            .filter(|op| matches!(op, Op::Input(_)))
            .count();
        const CHUNK: i128 = 1 << 16;
        let mut codes = Vec::new();
        let mut start = lo;
        while start <= hi {
            let end = (start + CHUNK - 1).min(hi);
            let len = narrow::<usize, _>(end - start + 1);
            let mut cols = vec![vec![0i128; len]; n_in];
            cols[pos] = (start..=end).collect();
            let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
            let diff = orig.differing_lanes(&mutant, &refs);
            codes.extend((0..len).filter(|&i| diff[i]).map(|i| start + i as i128));
            start = end + 1;
        }
        let cut = EventCut {
            node: c,
            range: (lo, hi),
            codes,
        };
        return Ok(if cut.codes.is_empty() {
            CutOutcome::Proven(cut)
        } else {
            CutOutcome::Event(cut)
        });
    }
    Ok(CutOutcome::NoCut)
}

/// Whether mutant `m` is proven equivalent through the *supports* of its
/// quantizer's operand ([`crate::datapath::Trace::supports`]: the nearest
/// quantizations and inputs it is computed from, `spec` and `dot` for the
/// lighting level `255·(ks·spec + kd·max(dot, 0))`), taken as independent
/// inputs, each over every code interval analysis allows it. A branch and
/// bound over boxes of support codes drops the boxes where the operand's
/// interval cannot meet the mutant's event; the single points left are
/// run through the design and the mutant from the supports on, and
/// compared where the supports' region meets the rest of the datapath
/// ([`crate::datapath::Trace::cut_set_frontier`]). `Ok(true)`: no point
/// differs, so no input can (the supports of any input are one of the
/// points). `Ok(false)`: a point differs, or the search takes more than
/// `budget` boxes (a count, not a time: the outcome is the same on any
/// machine at any load).
///
/// # Errors
///
/// [`RtlError::Compile`] when a program of the proof (the supports' codes, the operand, or
/// the design or the mutant to the frontier) cannot be compiled ([`Compiled::compile`]).
pub fn support_proof(d: &Design, m: &Mutation, budget: u64) -> Result<bool, RtlError> {
    proof_over(d, m, &d.trace.supports(quant_of(d, m).2), budget)
}

/// Inputs of at most this many bits may join [`layer_proof`]'s second
/// layer (the normalizer's 3-bit segment selector beside three 16-bit
/// coordinates).
const NARROW_INPUT_BITS: u32 = 4;

/// Whether mutant `m` is proven equivalent by the branch and bound of
/// [`support_proof`] over the design's own input ports in the cone of
/// its operand: slower than over the supports where they are narrow, but
/// exact about every correlation between them (a CORDIC's rotation
/// invariant, lost when its coordinates are taken as independent).
///
/// # Errors
///
/// As [`support_proof`].
pub fn input_proof(d: &Design, m: &Mutation, budget: u64) -> Result<bool, RtlError> {
    proof_over(d, m, &d.trace.inputs_of(quant_of(d, m).2), budget)
}

/// Whether mutant `m` is proven equivalent by the branch and bound of
/// [`support_proof`] over the deepest *layer* of quantizations its operand
/// is computed from that reads no input port directly and has at most
/// three nodes: layer 0 is the operand's supports, layer `k + 1` the
/// supports of layer `k`'s operands. Between [`support_proof`] (one step
/// back, correlations lost) and [`input_proof`] (exact, but long cones):
/// for a CORDIC's second rotation it is that rotation's own inputs.
/// Failing that, the same over a layer grown one node at a time: the
/// latest quantization of the layer replaced by its supports (constant
/// stages left inside, an input of at most [`NARROW_INPUT_BITS`] joining),
/// the last such layer with at most three other nodes. For the
/// normalizer's output `n_x·g(d)` it is `{n_x, n_y, n_z}` and the segment
/// selector: `g` back to `d`, `d` back to the normal `n_x` belongs to,
/// where the layers above hold `n_x` and `g` as independent.
///
/// # Errors
///
/// As [`support_proof`], for each layer tried.
pub fn layer_proof(d: &Design, m: &Mutation, budget: u64) -> Result<bool, RtlError> {
    let t = &d.trace;
    let best = narrow_layer(t, quant_of(d, m).2);
    if let Some(b) = &best {
        if proof_over(d, m, b, budget)? {
            return Ok(true);
        }
    }
    // Constant stages (no input in their cone) stay inside the region.
    let varying = |v: Vec<usize>| -> Vec<usize> {
        v.into_iter()
            .filter(|&c| !t.inputs_of(c).is_empty())
            .collect()
    };
    let mut layer = varying(t.supports(quant_of(d, m).2));
    let mut latest = None;
    // A narrow input (a segment selector) may join the layer; a wide one
    // ends the expansion there.
    let narrow = |c: usize| t.value(c).sym().width <= NARROW_INPUT_BITS;
    let wide_input = |c: usize| matches!(t.ops()[c], Op::Input(_)) && !narrow(c);
    while let Some(c) = layer
        .iter()
        .copied()
        .filter(|&c| match &t.ops()[c] {
            Op::Quant(a, _) => !t.supports(a.node()).into_iter().any(wide_input),
            _ => false,
        })
        .max()
    {
        let Op::Quant(a, _) = &t.ops()[c] else {
            unreachable!("filtered to quantizations")
        };
        layer.retain(|&x| x != c);
        layer.extend(varying(t.supports(a.node())));
        layer.sort_unstable();
        layer.dedup();
        if layer.iter().filter(|&&c| !narrow(c)).count() <= 3 {
            latest = Some(layer.clone());
        }
    }
    match latest {
        Some(b) if Some(&b) != best.as_ref() => proof_over(d, m, &b, budget),
        _ => Ok(false),
    }
}

/// The deepest layer of quantizations node `x` is computed from that reads
/// no input port directly and has at most three nodes ([`layer_proof`]:
/// layer 0 is `x`'s supports, layer `k + 1` the supports of layer `k`'s
/// operands), or `None` when there is none: for a CORDIC's first rotation,
/// the normal it is given.
pub(super) fn narrow_layer(t: &crate::datapath::Trace, x: usize) -> Option<Vec<usize>> {
    let mut layer = t.supports(x);
    let mut best = None;
    for _ in 0..256 {
        let mut next: Vec<usize> = Vec::new();
        for &c in &layer {
            match &t.ops()[c] {
                Op::Quant(a, _) => next.extend(t.supports(a.node())),
                _ => next.push(c),
            }
        }
        next.sort_unstable();
        next.dedup();
        if next.is_empty() || next.iter().any(|&c| matches!(t.ops()[c], Op::Input(_))) {
            break;
        }
        if next.len() <= 3 {
            best = Some(next.clone());
        }
        if next == layer {
            break;
        }
        layer = next;
    }
    best
}

/// The branch and bound of [`support_proof`] over the cuts `sup` of `m`'s
/// operand (quantizations or inputs that together determine it), giving up
/// after `budget` boxes (every single point counts as one).
fn proof_over(d: &Design, m: &Mutation, sup: &[usize], budget: u64) -> Result<bool, RtlError> {
    if m.kind == MutationKind::Shift {
        return Ok(false);
    }
    let (q, frac, _) = quant_of(d, m);
    let st = q.step(frac);
    let sup = sup.to_vec();
    if sup.is_empty() {
        return Ok(false);
    }
    let full = full_box(d);
    let vals: Vec<TV> = sup.iter().map(|&c| d.trace.value(c)).collect();
    let prog = Compiled::compile(&d.trace, &vals)?;
    let mut ranges = Vec::new();
    for &c in &sup {
        match code_range(d, &prog, &full, c) {
            Some(r) => ranges.push(r),
            None => return Ok(false),
        }
    }
    // The trace with every support made an input.
    let mut t = d.trace.clone();
    for &c in &sup {
        t = t.cut_at(c).0;
    }
    let inputs: Vec<usize> = (0..t.ops().len())
        .filter(|&i| matches!(t.ops()[i], Op::Input(_)))
        .collect();
    let pos: Vec<usize> = sup
        .iter()
        .map(|c| {
            inputs
                .iter()
                .position(|i| i == c)
                .expect("a support is an input")
        })
        .collect();
    let front = frontier_in(d, &sup, &t);
    let xprog = Compiled::compile(&t, &[t.value(m.node)])?;
    let orig = Compiled::compile(&t, &front)?;
    let mutant = Compiled::compile(&t.mutated(m), &front)?;
    let mut b: Vec<(i128, i128)> = vec![(0, 0); inputs.len()];
    // How much the operand spreads per code of each support, the others
    // held at their lowest code (exact where the operand is affine in the
    // supports, a heuristic elsewhere).
    let slope: Vec<f64> = (0..ranges.len())
        .map(|k| {
            for (j, &p) in pos.iter().enumerate() {
                b[p] = if j == k {
                    ranges[j]
                } else {
                    (ranges[j].0, ranges[j].0)
                };
            }
            let w = to_f64((ranges[k].1 - ranges[k].0).max(1));
            xprog
                .quant_operand_range(&b, m.node)
                .map_or(1.0, |(lo, hi)| to_f64(hi - lo) / w)
                .max(1e-9)
        })
        .collect();
    // Each box with the evaluated box it was split from and the support
    // split: only what that support reaches is evaluated again.
    let eval = Boxes::new(&xprog);
    let mut stack: Vec<(Vec<(i128, i128)>, Split)> = vec![(ranges, None)];
    let mut points: Vec<Vec<i128>> = Vec::new();
    let mut boxes = 0;
    let flush = |points: &mut Vec<Vec<i128>>| -> bool {
        if points.is_empty() {
            return false;
        }
        let mut cols = vec![vec![0i128; points.len()]; inputs.len()];
        for (j, p) in points.iter().enumerate() {
            for (k, &v) in p.iter().enumerate() {
                cols[pos[k]][j] = v;
            }
        }
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        let diff = orig.differing_lanes(&mutant, &refs);
        points.clear();
        diff.contains(&true)
    };
    while let Some((r, from)) = stack.pop() {
        boxes += 1;
        if boxes > budget {
            return Ok(false);
        }
        let mut e = match from {
            Some((parent, k)) => eval.child(&parent, pos[k], r[k]),
            None => {
                for (k, &p) in pos.iter().enumerate() {
                    b[p] = r[k];
                }
                eval.root(&b)
            }
        };
        let Some((lo, hi)) = eval.quant_operand_range(&e, m.node) else {
            return Ok(false);
        };
        // Congruences decide rounding ties; an overflow is a matter of
        // range alone (and the congruence costs another pass).
        let cong = if matches!(m.kind, MutationKind::Round(_)) && range_meets(m, &q, &st, lo, hi) {
            eval.quant_operand_congruence(&mut e, m.node)
        } else {
            None
        };
        if !range_meets(m, &q, &st, lo, hi) {
            continue;
        }
        if cong.is_some_and(|c| !range_meets_mod(m, &q, &st, lo, hi, c)) {
            continue;
        }
        // Split the support that spreads the operand most: its width
        // times its spread per code over the whole box.
        let widest = (0..r.len())
            .filter(|&k| r[k].0 < r[k].1)
            .max_by(|&i, &j| {
                let w = |k: usize| to_f64(r[k].1 - r[k].0) * slope[k];
                w(i).total_cmp(&w(j))
            })
            .unwrap_or(0);
        if r[widest].0 == r[widest].1 {
            points.push(r.iter().map(|v| v.0).collect());
            if points.len() >= 4096 && flush(&mut points) {
                return Ok(false);
            }
            continue;
        }
        let (a, z) = r[widest];
        let mid = a + (z - a).div_euclid(2);
        let (mut left, mut right) = (r.clone(), r);
        left[widest] = (a, mid);
        right[widest] = (mid + 1, z);
        let e = Rc::new(e);
        stack.push((left, Some((Rc::clone(&e), widest))));
        stack.push((right, Some((e, widest))));
    }
    Ok(!flush(&mut points))
}

/// The evaluated box a box of a branch and bound was split from, and the
/// input split (`None` for the first box).
pub(super) type Split = Option<(Rc<BoxEval>, usize)>;

/// The frontier of the region of the cuts `sup` towards `d`'s outputs
/// ([`crate::datapath::Trace::cut_set_frontier`]), as values of `t` (`d`'s
/// trace with `sup` made inputs).
pub(super) fn frontier_in(d: &Design, sup: &[usize], t: &crate::datapath::Trace) -> Vec<TV> {
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    d.trace
        .cut_set_frontier(sup, &roots)
        .into_iter()
        .map(|f| t.value(f))
        .collect()
}

/// Whether `codes` (ascending) holds a code in `[lo, hi]`.
fn holds(codes: &[i128], lo: i128, hi: i128) -> bool {
    let i = codes.partition_point(|&c| c < lo);
    i < codes.len() && codes[i] <= hi
}

/// Leaves one line contributes at most (spread over the line, they tell
/// apart masking that depends on where along it the event falls).
pub(super) const LEAVES_PER_LINE: usize = 8;

/// Lane·operations [`line_search`] spends on sweeps at most per mutant
/// (about a second).
pub const SWEEP_WORK: usize = 1 << 29;

/// Codes of one input a sweep runs at most (all of a 16-bit input).
const SWEEP_CODES: i128 = 1 << 16;

/// Rows that differ from `row` in one input, `inputs` of the input ports
/// `among` in turn (in a random order), that input running over its whole
/// range (or [`SWEEP_CODES`] codes spread over it): the first that tells
/// the two programs apart. Adds the lanes run to `swept`.
#[allow(clippy::too_many_arguments)]
pub(super) fn sweep(
    row: &[i128],
    formats: &[crate::format::Format],
    among: &[usize],
    inputs: usize,
    orig: &Compiled,
    mutant: &Compiled,
    rng: &mut crate::sampling::Rng,
    swept: &mut usize,
    limit: usize,
) -> Option<Vec<i128>> {
    const CHUNK: i128 = 4096;
    let mut order = among.to_vec();
    for i in (1..order.len()).rev() {
        order.swap(i, narrow::<usize, _>(rng.below(i as u64 + 1)));
    }
    let mut cols: Vec<Vec<i128>> = row.iter().map(|&v| vec![v; CHUNK as usize]).collect();
    for k in order.into_iter().take(inputs) {
        let (lo, hi) = (formats[k].min_code(), formats[k].max_code());
        let span = hi - lo + 1;
        let total = span.min(SWEEP_CODES);
        let mut done = 0;
        if *swept >= limit {
            return None;
        }
        // Only input `k` changes along the sweep: what it does not reach
        // is run once (the same codes, flags and lanes counted).
        let varying: Vec<bool> = (0..row.len()).map(|j| j == k).collect();
        let pair = orig
            .specialize(row, &varying)
            .zip(mutant.specialize(row, &varying));
        let (orig, mutant) = pair.as_ref().map_or((orig, mutant), |(o, m)| (o, m));
        while done < total {
            if *swept >= limit {
                return None;
            }
            let len = narrow::<usize, _>((total - done).min(CHUNK));
            for (i, c) in cols[k][..len].iter_mut().enumerate() {
                *c = if span <= SWEEP_CODES {
                    lo + done + i as i128
                } else {
                    lo + i128::from(rng.below(narrow::<u64, _>(span.min(i128::from(u64::MAX)))))
                };
            }
            done += len as i128;
            *swept += len;
            let refs: Vec<&[i128]> = cols.iter().map(|c| &c[..len]).collect();
            if let Some(i) = orig.differing_lanes(mutant, &refs).iter().position(|&d| d) {
                let mut r = row.to_vec();
                r[k] = cols[k][i];
                return Some(r);
            }
        }
        cols[k].fill(row[k]);
    }
    None
}

/// An input that tells mutant `m` apart from the design, found by line
/// search (module documentation) towards the event codes of `cut`, or
/// towards the event at the mutant's own quantizer when `cut` is `None`;
/// at most `budget` interval evaluations. `bases` are rows to start lines
/// from (the unit's own inputs) besides random ones.
///
/// # Errors
///
/// [`RtlError::Compile`] when the program to the cut (or to the mutant's quantizer), or the
/// design or the mutant to the outputs, cannot be compiled ([`Compiled::compile`]).
pub fn line_search(
    d: &Design,
    m: &Mutation,
    cut: Option<&EventCut>,
    bases: &[Vec<i128>],
    budget: usize,
    sweep_work: usize,
    seed: u64,
) -> Result<Option<Vec<i128>>, RtlError> {
    let (q, frac, x) = quant_of(d, m);
    let st = q.step(frac);
    let target = cut.map_or(m.node, |c| c.node);
    let tprog = Compiled::compile(&d.trace, &[d.trace.value(target)])?;
    let eval = Boxes::new(&tprog);
    let hits = |e: &mut BoxEval| -> bool {
        match cut {
            Some(c) => code_range_with(d, e.inputs(), c.node, || {
                eval.quant_operand_range(e, c.node)
            })
            .is_some_and(|(lo, hi)| holds(&c.codes, lo, hi)),
            // The congruence is taken only where the range meets.
            None => eval.quant_operand_range(e, m.node).is_some_and(|(lo, hi)| {
                range_meets(m, &q, &st, lo, hi)
                    && eval
                        .quant_operand_congruence(e, m.node)
                        .is_some_and(|c| range_meets_mod(m, &q, &st, lo, hi, c))
            }),
        }
    };
    let ports = d.trace.input_ports();
    let formats: Vec<_> = ports.iter().map(|p| p.format).collect();
    let cone = d
        .trace
        .live_nodes(&[d.trace.value(if cut.is_some() { target } else { x })]);
    let dims: Vec<usize> = (0..ports.len())
        .filter(|&k| cone[ports[k].value.node()])
        .collect();
    if dims.is_empty() {
        return Ok(None);
    }
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let orig = Compiled::compile(&d.trace, &roots)?;
    let mutant = Compiled::compile(&d.trace.mutated(m), &roots)?;
    let n_in = ports.len();
    let all_inputs: Vec<usize> = (0..n_in).collect();
    let sweep_lanes = sweep_work / d.trace.ops().len().max(1);
    let mut rng = crate::sampling::Rng::new(seed ^ 0x6c69_6e65);
    let mut evals = 0;
    let mut swept = 0usize;
    let mut line = 0usize;
    // Random-row sweeps are for roundings only (see below).
    let random_sweeps = !matches!(m.kind, MutationKind::Overflow(_));
    while evals < budget || (random_sweeps && swept < sweep_lanes) {
        let base = if !bases.is_empty() && line % 2 == 1 {
            bases[narrow::<usize, _>(rng.below(bases.len() as u64))].clone()
        } else {
            wild_row(&formats, &mut rng)
        };
        line += 1;
        let k = dims[narrow::<usize, _>(rng.below(dims.len() as u64))];
        let mut b: Vec<(i128, i128)> = base.iter().map(|&v| (v, v)).collect();
        let mut stack = if evals < budget {
            vec![(formats[k].min_code(), formats[k].max_code())]
        } else {
            Vec::new()
        };
        let mut leaves = Vec::new();
        // The line's first box evaluated whole, the rest from it (they
        // differ from it in input `k` only).
        let mut first: Option<BoxEval> = None;
        while let Some((lo, hi)) = stack.pop() {
            evals += 1;
            if evals > budget {
                break;
            }
            b[k] = (lo, hi);
            let mut e = match &first {
                Some(f) => eval.child(f, k, (lo, hi)),
                None => eval.root(&b),
            };
            let hit = hits(&mut e);
            first.get_or_insert(e);
            if !hit {
                continue;
            }
            if lo == hi {
                leaves.push(lo);
                if leaves.len() >= LEAVES_PER_LINE {
                    break;
                }
                continue;
            }
            let mid = lo + (hi - lo) / 2;
            if rng.below(2) == 0 {
                stack.push((lo, mid));
                stack.push((mid + 1, hi));
            } else {
                stack.push((mid + 1, hi));
                stack.push((lo, mid));
            }
        }
        if leaves.is_empty() {
            // No event on this line: sweep one input of the base row (not
            // for an overflow, which the bisection finds wherever one can
            // happen; a rounding's change may need the rest of the row to
            // line up, which a sweep tries).
            if swept < sweep_lanes && random_sweeps {
                if let Some(r) = sweep(
                    &base,
                    &formats,
                    &all_inputs,
                    1,
                    &orig,
                    &mutant,
                    &mut rng,
                    &mut swept,
                    sweep_lanes,
                ) {
                    return Ok(Some(r));
                }
            }
            continue;
        }
        let rows: Vec<Vec<i128>> = leaves
            .iter()
            .map(|&v| {
                let mut r = base.clone();
                r[k] = v;
                r
            })
            .collect();
        let cols = columns(&rows, ports.len());
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        if let Some(i) = orig.differing_lanes(&mutant, &refs).iter().position(|&d| d) {
            return Ok(Some(rows[i].clone()));
        }
        // The event reaches the cut's frontier but is masked further on
        // (a ±1 difference that a later rounding absorbs): sweep every
        // input of one such row over its range, the other inputs held.
        if swept < sweep_lanes {
            let row = &rows[narrow::<usize, _>(rng.below(rows.len() as u64))];
            if let Some(r) = sweep(
                row,
                &formats,
                &all_inputs,
                n_in,
                &orig,
                &mutant,
                &mut rng,
                &mut swept,
                sweep_lanes,
            ) {
                return Ok(Some(r));
            }
        }
    }
    Ok(None)
}

/// Interval evaluations [`killers`] spends on line bisection per mutant, at
/// most.
pub const LINE_EVALS: usize = 4000;

/// Interval evaluations times the design's nodes [`killers`] spends on
/// line bisection per mutant (fewer evaluations for a large design).
pub const LINE_WORK: usize = 1 << 18;

/// Boxes [`killers`] gives [`support_proof`], [`input_proof`] and
/// [`layer_proof`] each, per mutant the line search misses, before the
/// witness search. Budgets are counts,
/// never times, so the same design and seed prove the same mutants on any
/// machine at any load. Measured on the default designs (2026-11): every
/// proof of the first round that succeeds takes at most 3 775 boxes;
/// 16 384 boxes take 8-35 ms (the 30 ms deadline they replace).
pub const KILLER_PROOF_BOXES: u64 = 1 << 14;

/// Boxes [`killers`] gives [`super::direction::direction_proof`] (a branch
/// and bound over the inputs of a CORDIC rotation: 1 127 317 boxes, about
/// a second, for the default angles unit's last fold, which the search
/// would spend seconds on in vain).
pub const KILLER_DIRECTION_BOXES: u64 = 1 << 21;

/// Lane·operations [`killers`] spends on sweeps per mutant (rounding and
/// shift mutants only: about a second each; the rows found are cached).
/// A late CORDIC rounding is told apart by about one row in 10^6.
pub const KILLER_SWEEP_WORK: usize = 1 << 29;

/// Lane·operations [`killers`] spends on [`super::witness::witness_search`]
/// per rounding or shift mutant the line search misses (about half a
/// second; twice that in the second round);
/// an overflow gets one part in [`OVERFLOW_WITNESS_SHARE`] (the line
/// search's bisection finds an overflow wherever one can happen, so the
/// witnesses seldom add one).
pub const KILLER_WITNESS_WORK: usize = 1 << 28;

/// See [`KILLER_WITNESS_WORK`].
pub const OVERFLOW_WITNESS_SHARE: usize = 16;

/// Inputs that tell apart `survivors` (mutants no earlier vector tells
/// apart), found through cuts, line search and witnesses ([`event_cut`],
/// [`line_search`], [`super::witness::witness_search`], small budgets: this
/// runs whenever vectors are made), starting lines from `bases` as well as
/// random rows; the roundings and shifts still missed get a second witness
/// search, then random rows ([`super::probe::random_probe`]). Mutants
/// proven equivalent on the way ([`super::direction`] among the proofs)
/// are skipped. Returns the inputs (one per mutant
/// found, each taken once) and the mutants still not told apart. `search`
/// says how much work each step gets ([`Search`]).
///
/// # Errors
///
/// [`RtlError::Compile`] when a program cannot be compiled: the errors of
/// [`super::mutants::equivalent`], [`event_cut`], the proofs, [`line_search`],
/// [`super::witness::witness_search`] and [`super::probe::Probe::new`], and of running the
/// rows found on the design and the mutants.
///
/// # Panics
///
/// If a survivor is not a mutation of a quantization of `d`
/// ([`Trace::mutations`](crate::datapath::Trace::mutations)). The probes' locks are never
/// poisoned: a panic in a search thread ends the search first ([`parallel_map`]).
pub fn killers(
    d: &Design,
    survivors: &[Mutation],
    bases: &[Vec<i128>],
    seed: u64,
    search: Search,
) -> Result<(Vec<Vec<i128>>, Vec<Mutation>), RtlError> {
    let quick = search == Search::Quick;
    let proof_boxes = || search.proof_boxes();
    let work = |full: usize| search.work(full);
    let one = |i: usize, m: &Mutation| -> Result<Option<Option<Vec<i128>>>, RtlError> {
        if super::mutants::equivalent(d, m)?.is_some() {
            return Ok(None);
        }
        let cut = match event_cut(d, m)? {
            CutOutcome::Proven(_) => return Ok(None),
            CutOutcome::Event(c) => Some(c),
            CutOutcome::NoCut => None,
        };
        // The line search first: a row it finds tells the mutant apart,
        // so no (sound) proof could have proven it equivalent, and the
        // proofs a killable mutant would run to their budget are saved.
        // Then a proof that ends in time saves the witness search; one
        // that does not changes nothing.
        let s = seed.wrapping_add(i as u64);
        if let Some(row) = line_search(
            d,
            m,
            cut.as_ref(),
            bases,
            LINE_EVALS.min(LINE_WORK / d.trace.ops().len().max(1)),
            work(KILLER_SWEEP_WORK),
            s,
        )? {
            return Ok(Some(Some(row)));
        }
        if cut.is_none()
            && (super::direction::direction_proof(
                d,
                m,
                if quick {
                    proof_boxes()
                } else {
                    KILLER_DIRECTION_BOXES
                },
            )? || support_proof(d, m, proof_boxes())?
                || input_proof(d, m, proof_boxes())?
                || layer_proof(d, m, proof_boxes())?)
        {
            return Ok(None);
        }
        Ok(Some(super::witness::witness_search(
            d,
            m,
            bases,
            work(if matches!(m.kind, MutationKind::Overflow(_)) {
                KILLER_WITNESS_WORK / OVERFLOW_WITNESS_SHARE
            } else {
                KILLER_WITNESS_WORK
            }),
            s,
        )?))
    };
    // Each mutant's search is seeded on its own, so the result does not
    // depend on how the work is shared among threads.
    let results = parallel_map(survivors, one)?;
    let mut rows: Vec<Vec<i128>> = Vec::new();
    let mut missed = Vec::new();
    for (m, r) in survivors.iter().zip(results) {
        match r {
            None => {}
            Some(Some(row)) if !rows.contains(&row) => rows.push(row),
            Some(Some(_)) => {}
            Some(None) => missed.push(m.clone()),
        }
    }
    // The roundings and shifts no row found tells apart get a second
    // witness search on another seed with twice the work: its success
    // depends on the witnesses it happens to start from (a polar tie:
    // about nine runs in ten; a CORDIC rounding in `angles`, node 150 of
    // shift_add, only here).
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let cols = columns(&rows, d.trace.input_ports().len());
    let want = super::mutants::run(&d.trace, &roots, &cols)?;
    let mut again = Vec::new();
    let mut left = Vec::new();
    for m in missed {
        let told = !rows.is_empty()
            && first_difference(
                &want,
                &super::mutants::run(&d.trace.mutated(&m), &roots, &cols)?,
            )
            .is_some();
        if told {
            continue;
        }
        if matches!(m.kind, MutationKind::Overflow(_)) || quick {
            left.push(m);
        } else {
            again.push(m);
        }
    }
    let second = parallel_map(&again, |i, m| {
        let s = seed.wrapping_add(i as u64) ^ SECOND_ROUND_SEED;
        super::witness::witness_search(d, m, bases, 2 * KILLER_WITNESS_WORK, s)
    })?;
    let mut third = Vec::new();
    for (m, r) in again.into_iter().zip(second) {
        match r {
            Some(row) if !rows.contains(&row) => rows.push(row),
            Some(_) => {}
            None => third.push(m),
        }
    }
    // What is left is killed, if at all, where several rare conditions in
    // low bits meet (a late CORDIC rounding): random rows find it faster
    // than any steering ([`super::probe`]).
    // Random rows: every mutant runs a piece at a time, in lockstep, from a
    // pool shared by all (so a design with many survivors stays bounded,
    // and which rows are found does not depend on timing). A quick search
    // skips them.
    if quick {
        left.extend(third);
        return Ok((rows, left));
    }
    let late = parallel_map(&third, |_, m| {
        let b = KILLER_LATE_PROOF_BOXES;
        Ok(support_proof(d, m, b)? || input_proof(d, m, b)? || layer_proof(d, m, b)?)
    })?;
    let mut probes = Vec::new();
    for (i, (m, proven)) in third.into_iter().zip(late).enumerate() {
        if proven {
            continue;
        }
        let s = seed.wrapping_add(i as u64) ^ PROBE_ROUND_SEED;
        match super::probe::Probe::new(d, &m, s)? {
            Some(p) => probes.push((m, std::sync::Mutex::new(p))),
            None => left.push(m),
        }
    }
    let mut pool = KILLER_PROBE_POOL;
    let mut done = vec![false; probes.len()];
    loop {
        let active: Vec<usize> = (0..probes.len())
            .filter(|&k| !done[k] && probes[k].1.lock().expect("probe").spent < KILLER_PROBE_WORK)
            .collect();
        if active.is_empty() || pool == 0 {
            break;
        }
        let found = parallel_map(&active, |_, &k| {
            let mut p = probes[k].1.lock().expect("probe");
            let before = p.spent;
            let r = p.run(KILLER_PROBE_PIECE);
            Ok((r, p.spent - before))
        })?;
        for (&k, (r, used)) in active.iter().zip(found) {
            pool = pool.saturating_sub(used);
            if let Some(row) = r {
                done[k] = true;
                if !rows.contains(&row) {
                    rows.push(row);
                }
            }
        }
    }
    for ((m, _), done) in probes.into_iter().zip(done) {
        if !done {
            left.push(m);
        }
    }
    Ok((rows, left))
}

/// Lane·operations one piece of [`killers`]' random rows runs per mutant.
const KILLER_PROBE_PIECE: usize = 1 << 29;

/// Lane·operations of random rows [`killers`] spends per design, over every
/// mutant: two mutants' full budgets (about 7 s).
pub const KILLER_PROBE_POOL: usize = 2 * KILLER_PROBE_WORK;

/// How thoroughly [`killers`] searches for the inputs that tell mutants
/// apart. An option the caller passes (the CLI reads it from
/// `FXSHADE_SEARCH` at its edge); the vectors of the two differ and are
/// cached apart.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Search {
    /// Every budget as stated ([`KILLER_PROOF_BOXES`],
    /// [`KILLER_SWEEP_WORK`], …), a second witness round and random rows:
    /// the golden vectors.
    #[default]
    Full,
    /// A [`QUICK_SHARE`] of each sweep and witness budget, no second
    /// witness round, no random rows, and [`QUICK_PROOF_BOXES`] for every
    /// proof, the direction proof included (the mapped pipeline top on the
    /// narrow configuration: 1.9 s against 16 s for the full search, 3.1
    /// CPU-s against 30). For checks of RTL against model over many
    /// configurations, where the rarest killers matter less than the time
    /// (the suite's co-simulation checks).
    Quick,
}

impl Search {
    /// The name used in cache keys and by `FXSHADE_SEARCH`.
    pub fn name(self) -> &'static str {
        match self {
            Search::Full => "full",
            Search::Quick => "quick",
        }
    }

    /// The mode a name (`full`, `quick`) stands for.
    pub fn from_name(s: &str) -> Option<Search> {
        match s {
            "full" => Some(Search::Full),
            "quick" => Some(Search::Quick),
            _ => None,
        }
    }

    /// [`KILLER_PROOF_BOXES`], or [`QUICK_PROOF_BOXES`] in a quick search.
    fn proof_boxes(self) -> u64 {
        match self {
            Search::Full => KILLER_PROOF_BOXES,
            Search::Quick => QUICK_PROOF_BOXES,
        }
    }

    /// The work budget `full`, or its [`QUICK_SHARE`] in a quick search.
    fn work(self, full: usize) -> usize {
        match self {
            Search::Full => full,
            Search::Quick => full / QUICK_SHARE,
        }
    }
}

/// A quick search's share of each work budget of [`killers`].
pub const QUICK_SHARE: usize = 16;

/// Boxes a quick search ([`Search::Quick`]) gives each proof before the witnesses (a quarter
/// of [`KILLER_PROOF_BOXES`]).
pub const QUICK_PROOF_BOXES: u64 = 1 << 12;

/// Boxes [`killers`] gives each proof again before its third round (the
/// support proof takes the pipeline top's `lighting.level` half_up in
/// 234 797 boxes, about 0.25 s, where the random rows would spend 8 s in
/// vain).
pub const KILLER_LATE_PROOF_BOXES: u64 = 1 << 18;

/// Mixed into the seeds of [`killers`]' third round.
const PROBE_ROUND_SEED: u64 = 0x0074_6869_7264;

/// Lane·operations of [`super::probe::random_probe`] per rounding or shift
/// mutant the witness searches miss: 3.5 s on the `angles` unit where
/// nothing is found, about 24 million rows; the late CORDIC roundings it is
/// for are killed by 1.6 rows in 10 million (measured), found in 0.1–2.6 s
/// over six seeds each.
pub const KILLER_PROBE_WORK: usize = 1 << 33;

/// Mixed into the seeds of [`killers`]' second round.
const SECOND_ROUND_SEED: u64 = 0x7365_636f_6e64;

/// `f(i, x)` for every element of `xs`, in order, on as many threads as
/// the machine has cores.
///
/// # Errors
///
/// The first error of `f` in the order of `xs`, once every element has been mapped.
///
/// # Panics
///
/// When `f` panics: the panic of its thread is raised again.
pub fn parallel_map<T: Sync, U: Send>(
    xs: &[T],
    f: impl Fn(usize, &T) -> Result<U, RtlError> + Sync,
) -> Result<Vec<U>, RtlError> {
    crate::parallel::map_in_order(xs, f).into_iter().collect()
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::config::Config;
    use crate::datapath::{Datapath, Trace};
    use crate::format::Format;
    use crate::quantize::{Overflow, Quant, Rounding};

    /// A design around `trace`, for tests.
    pub(in crate::rtl) fn design(trace: Trace) -> Design {
        Design {
            module: "t".into(),
            unit: "t",
            variant: String::new(),
            trace,
            config_source: String::new(),
            config_toml: String::new(),
            config_key: String::new(),
            notes: Vec::new(),
            pipelining: super::super::timing::Pipelining::Compact,
            setup: Vec::new(),
            handshake: super::super::timing::Handshake::Stall,
            parameters: serde_json::Value::Null,
        }
    }

    fn q(stage: &'static str, f: &str, r: Rounding, o: Overflow) -> Quant {
        Quant::new(stage, f.parse::<Format>().unwrap(), r, o)
    }

    /// `y = round(a·b)` to 7 bits (a tie needs the product's low five bits
    /// to be `10000`), then `z = round(y·c)` to 3 fraction bits, which
    /// masks most changes of `y`; `a`, `b` 6-bit unsigned, `c` 6-bit
    /// signed: the design, `y`, and every input (for the witness search's
    /// and the random rows' tests).
    pub(in crate::rtl) fn masked_tie() -> (Design, TV, Vec<Vec<i128>>) {
        let mut t = Trace::new();
        let a = t.input_named("a", &q("a", "U0F6", Rounding::Trunc, Overflow::Saturate));
        let b = t.input_named("b", &q("b", "U0F6", Rounding::Trunc, Overflow::Saturate));
        let c = t.input_named("c", &q("c", "I1F5", Rounding::Trunc, Overflow::Saturate));
        let p = t.mul(a, b);
        let y = t.quantize(p, &q("y", "U0F7", Rounding::HalfEven, Overflow::Saturate));
        let z = t.mul(y, c);
        let out = t.quantize(z, &q("z", "I1F3", Rounding::HalfEven, Overflow::Saturate));
        t.output("z", out);
        let rows = (0..64)
            .flat_map(|a| (0..64).flat_map(move |b| (-32..32).map(move |c| vec![a, b, c])))
            .collect();
        (design(t), y, rows)
    }

    /// Every input of a design with two 8-bit inputs, and whether each
    /// mutant's outputs or flags differ on some input (exhaustive).
    fn killable(d: &Design) -> Vec<(Mutation, bool)> {
        let rows: Vec<Vec<i128>> = (-128..128)
            .flat_map(|a| (0..256).map(move |b| vec![a, b]))
            .collect();
        super::super::mutants::model_kills(d, &rows)
            .unwrap()
            .into_iter()
            .map(|(m, first)| (m, first.is_some()))
            .collect()
    }

    /// A small datapath with a chain of roundings on one input (`a²`
    /// quantized twice, then `(a²)²`) joined by a second input at the end:
    /// the cut analysis is sound (a proven mutant differs on no input, by
    /// exhaustive simulation) and complete on this chain (every mutant
    /// some input kills has event codes, and the line search finds a
    /// killer for it, checked by running it).
    #[test]
    fn cut_proofs_are_sound_and_line_search_finds_killers() {
        let mut t = Trace::new();
        let a = t.input_named("a", &q("a", "I1F7", Rounding::Trunc, Overflow::Saturate));
        let b = t.input_named("b", &q("b", "U0F8", Rounding::Trunc, Overflow::Saturate));
        let sq = t.mul(a, a);
        let s1 = t.quantize(sq, &q("s1", "U1F9", Rounding::HalfEven, Overflow::Saturate));
        let s2 = t.quantize(s1, &q("s2", "U1F6", Rounding::HalfEven, Overflow::Saturate));
        let p = t.mul(s2, s2);
        let s3 = t.quantize(p, &q("s3", "U0F5", Rounding::Trunc, Overflow::Saturate));
        let e = t.mul(s3, b);
        let y = t.quantize(e, &q("y", "U0F6", Rounding::HalfEven, Overflow::Wrap));
        t.output("y", y);
        let d = design(t);
        let mut proven = 0;
        let mut found = 0;
        for (m, kill) in killable(&d) {
            match event_cut(&d, &m).unwrap() {
                CutOutcome::Proven(_) => {
                    assert!(!kill, "{m} is proven equivalent, yet an input kills it");
                    proven += 1;
                }
                CutOutcome::Event(c) if kill => {
                    let r = line_search(&d, &m, Some(&c), &[], 4000, 1 << 20, 7)
                        .unwrap()
                        .unwrap_or_else(|| panic!("{m}: no killer found"));
                    assert!(super::super::mutants::tells_apart(&d, &m, &r).unwrap());
                    found += 1;
                }
                _ => {}
            }
        }
        eprintln!("proven {proven}, found {found}");
        assert!(proven >= 2 && found >= 3, "proven {proven}, found {found}");
    }

    /// A five-step CORDIC in vectoring mode (`x ± y·2^-i`, `y ∓ x·2^-i`,
    /// steered by `y`'s sign; `x` from an 8-bit unsigned input, `y` from
    /// an 8-bit signed one; coordinates `I2F7` saturating; the angle `U0F8`
    /// wrapping), checked against every input: no mutant the input or
    /// layer branch and bound proves equivalent is killable, and the input
    /// branch and bound proves overflow mutants the support branch and
    /// bound cannot (its coordinates, taken as independent, lose the
    /// rotation that keeps `y` shrinking).
    #[test]
    fn input_and_layer_proofs_are_sound_on_a_cordic() {
        let mut t = Trace::new();
        let a = t.input_named("a", &q("a", "I1F7", Rounding::Trunc, Overflow::Saturate));
        let b = t.input_named("b", &q("b", "U0F8", Rounding::Trunc, Overflow::Saturate));
        let xy = q("xy", "I2F7", Rounding::Trunc, Overflow::Saturate);
        let th = q("th", "U0F8", Rounding::HalfEven, Overflow::Wrap);
        let mut x = t.quantize(b, &xy);
        let mut y = t.quantize(a, &xy);
        let mut th_v = t.constant(0.0, &th).unwrap();
        for i in 0..5 {
            let at = t
                .constant(0.5f64.powi(i).atan() / std::f64::consts::TAU, &th)
                .unwrap();
            let ys = t.shl(y, -i);
            let xs = t.shl(x, -i);
            let nx = t.add_signed(x, ys, y, false);
            let ny = t.add_signed(y, xs, y, true);
            let nt = t.add_signed(th_v, at, y, false);
            x = t.quantize(nx, &xy);
            y = t.quantize(ny, &xy);
            th_v = t.quantize(nt, &th);
        }
        let out = t.quantize(th_v, &q("out", "U0F5", Rounding::HalfEven, Overflow::Wrap));
        t.output("angle", out);
        let d = design(t);
        // A budget far above what any of these proofs takes (counts, not
        // time: the test's outcome does not depend on the machine's load).
        let budget = || 1u64 << 26;
        let mut gained = 0;
        for (m, kill) in killable(&d) {
            let by_input = input_proof(&d, &m, budget()).unwrap();
            let by_layer = layer_proof(&d, &m, budget()).unwrap();
            assert!(
                !(kill && by_input),
                "{m}: the input proof claims a killable mutant"
            );
            assert!(
                !(kill && by_layer),
                "{m}: the layer proof claims a killable mutant"
            );
            if by_input && !support_proof(&d, &m, budget()).unwrap() {
                gained += 1;
            }
        }
        assert!(
            gained >= 1,
            "the input proof proved nothing the support proof could not"
        );
    }

    /// A normalizer `n·g(d)`, `d = n·n`, `g = 2.5 − 1.5·d` (saturating
    /// stages; `n` three 7-bit signed inputs, each rounded to 6 bits, the
    /// output `I2F5`: `|n_x·g|` stays below 1.25, though `|n_x| ≤ 1` and
    /// `g ≤ 2.5` apart allow 2.5), checked against every input: no mutant the layer
    /// branch and bound proves equivalent is killable, and it proves an
    /// output overflow the support branch and bound cannot (its supports,
    /// `n_x` and `g`, taken as independent, lose that `g` is small where
    /// `n` is long). The layer it needs is `{n_x, n_y, n_z}`: `g`
    /// expanded back to `d`, `d` back to the normal.
    #[test]
    fn layer_proof_follows_a_normalizer_back_to_its_normal() {
        let mut t = Trace::new();
        let fin = q("n", "I1F6", Rounding::Trunc, Overflow::Saturate);
        let ins: Vec<TV> = ["x", "y", "z"]
            .iter()
            .map(|&n| t.input_named(n, &fin))
            .collect();
        let nq = q("normal", "I1F5", Rounding::HalfEven, Overflow::Saturate);
        let n: Vec<TV> = ins.iter().map(|&v| t.quantize(v, &nq)).collect();
        let sq: Vec<TV> = n.iter().map(|&v| t.mul(v, v)).collect();
        let s01 = t.add(sq[0], sq[1]);
        let s = t.add(s01, sq[2]);
        let d = t.quantize(s, &q("d", "U2F6", Rounding::HalfEven, Overflow::Saturate));
        let gq = q("g", "U2F6", Rounding::HalfEven, Overflow::Saturate);
        let c0 = t.constant(2.5, &gq).unwrap();
        let c1 = t.constant(1.5, &gq).unwrap();
        let c1d = t.mul(c1, d);
        let gs = t.sub(c0, c1d);
        let g = t.quantize(gs, &gq);
        let oq = q("out", "I2F5", Rounding::HalfEven, Overflow::Saturate);
        for (name, &v) in ["ox", "oy", "oz"].iter().zip(&n) {
            let p = t.mul(v, g);
            let o = t.quantize(p, &oq);
            t.output(name, o);
        }
        let dsg = design(t);
        let rows: Vec<Vec<i128>> = (-64..64)
            .flat_map(|x| (-64..64).flat_map(move |y| (-64..64).map(move |z| vec![x, y, z])))
            .collect();
        // A budget far above what any of these proofs takes (counts, not
        // time: the test's outcome does not depend on the machine's load).
        let budget = || 1u64 << 26;
        let mut gained = 0;
        for (m, first) in super::super::mutants::model_kills(&dsg, &rows).unwrap() {
            let by_layer = layer_proof(&dsg, &m, budget()).unwrap();
            assert!(
                !(first.is_some() && by_layer),
                "{m}: the layer proof claims a killable mutant"
            );
            if by_layer && !support_proof(&dsg, &m, budget()).unwrap() {
                gained += 1;
            }
        }
        assert!(
            gained >= 1,
            "the layer proof proved nothing the support proof could not"
        );
    }

    /// An off-by-one shift of a stage that quantizes a constant is
    /// equivalent when the constant is zero (the start of a CORDIC's
    /// angle) and killable otherwise; `equivalent` tells them apart by
    /// evaluating the stage once, and exhaustion agrees.
    #[test]
    fn shifted_constant_stages() {
        let mut t = Trace::new();
        let a = t.input_named("a", &q("a", "I1F7", Rounding::Trunc, Overflow::Saturate));
        let _b = t.input_named("b", &q("b", "U0F8", Rounding::Trunc, Overflow::Saturate));
        let k = q("k", "U0F4", Rounding::HalfEven, Overflow::Saturate);
        let zero = t.constant(0.0, &k).unwrap();
        let z = t.quantize(
            zero,
            &q("z", "U0F6", Rounding::HalfEven, Overflow::Saturate),
        );
        let three = t.constant(0.75, &k).unwrap();
        let h = t.quantize(
            three,
            &q("h", "U0F6", Rounding::HalfEven, Overflow::Saturate),
        );
        let s = t.add(a, z);
        let s = t.add(s, h);
        let y = t.quantize(s, &q("y", "I2F7", Rounding::Trunc, Overflow::Saturate));
        t.output("y", y);
        let d = design(t);
        let mut seen = 0;
        for (m, kill) in killable(&d) {
            if m.kind != MutationKind::Shift || !(m.node == z.node() || m.node == h.node()) {
                continue;
            }
            let eq = super::super::mutants::equivalent(&d, &m).unwrap().is_some();
            assert_eq!(eq, m.node == z.node(), "{m}");
            assert_eq!(kill, !eq, "{m}");
            seen += 1;
        }
        assert!(seen >= 2, "{seen} shift mutants of the constant stages");
    }

    /// The linear normalizer's `g = c0 + c1·d` rounded half_up instead of
    /// half_even (the mutant random vectors missed): the event codes of
    /// its cut `d` are exactly those a closed form gives — `c1·d + c0·2^17`
    /// with low 15 bits `2^14` and bit 15 clear — and the input the line
    /// search returns makes `d = round_half_even(N·N / 2^11)` one of them.
    #[test]
    fn linear_normalizer_g_tie_is_found() {
        let mut cfg = Config::embedded();
        cfg.apply_override("normalize.method=\"linear\"").unwrap();
        let u = super::super::units::unit("normalize").unwrap();
        let d = u.design(&cfg).unwrap();
        let t = &d.trace;
        let g = (0..t.ops().len())
            .find(|&i| t.stage_id(i) == Some("normalize.g"))
            .unwrap();
        let m = t
            .mutations(&[t.value(g)])
            .into_iter()
            .find(|m| m.node == g && matches!(m.kind, MutationKind::Round(Rounding::HalfUp)))
            .unwrap();
        let consts: Vec<i128> = t
            .ops()
            .iter()
            .filter_map(|op| match op {
                Op::Const(c) => Some(*c),
                _ => None,
            })
            .collect();
        let (c0, c1) = (consts[0], consts[1]);
        // g's operand: c1 (I?F15) · d (U1F17) + c0 (F15) aligned to F32.
        let tie = |dc: i128| {
            let x = c1 * dc + (c0 << 17);
            x & 0x7fff == 0x4000 && (x >> 15) & 1 == 0
        };
        let want: Vec<i128> = (0..1 << 18).filter(|&dc| tie(dc)).collect();
        assert!(!want.is_empty());
        let CutOutcome::Event(c) = event_cut(&d, &m).unwrap() else {
            panic!("no event codes")
        };
        assert_eq!(c.codes, want);
        let r = line_search(&d, &m, Some(&c), &[], 4000, 1 << 22, 1)
            .unwrap()
            .expect("a killer");
        let nn: i128 = r.iter().map(|v| v * v).sum();
        let (fl, rem) = (nn >> 11, nn & 0x7ff);
        let dc = if rem > 0x400 || (rem == 0x400 && fl & 1 == 1) {
            fl + 1
        } else {
            fl
        };
        assert!(tie(dc.min((1 << 18) - 1)), "{r:?}: d = {dc}");
    }

    /// Known-zero bits: an I2F14 input widened to I4F18 and shifted right
    /// by 1..4 drops only zero bits, so a rounding mode changed there is
    /// proven equivalent; shifted by 5 it is not (and an input kills it).
    #[test]
    fn known_zero_bits_prove_exact_shifts() {
        for (shift, exact) in [(1, true), (4, true), (5, false)] {
            let mut t = Trace::new();
            let a = t.input_named("a", &q("in", "I2F14", Rounding::Trunc, Overflow::Saturate));
            let w = t.quantize(a, &q("xy", "I4F18", Rounding::Trunc, Overflow::Saturate));
            let half = t
                .constant(
                    0.5f64.powi(shift),
                    &q(
                        "k",
                        &format!("U0F{shift}"),
                        Rounding::Trunc,
                        Overflow::Saturate,
                    ),
                )
                .unwrap();
            let p = t.mul(w, half);
            let y = t.quantize(p, &q("y", "I4F18", Rounding::Trunc, Overflow::Saturate));
            t.output("y", y);
            let d = design(t);
            let m = d
                .trace
                .mutations(&[d.trace.value(y.node())])
                .into_iter()
                .find(|m| m.node == y.node() && matches!(m.kind, MutationKind::Round(_)))
                .unwrap();
            let proven = super::super::mutants::equivalent(&d, &m).unwrap().is_some();
            assert_eq!(proven, exact, "shift {shift}");
            let rows: Vec<Vec<i128>> = (-32768..32768).map(|v| vec![v]).collect();
            let killed = super::super::mutants::model_kills(&d, &rows)
                .unwrap()
                .into_iter()
                .any(|(mm, f)| mm == m && f.is_some());
            assert_eq!(killed, !exact, "shift {shift}");
        }
    }

    /// The congruence-aware event test against brute force: for rounding
    /// ties (half_even against half_up) it is exact, for the half bit
    /// (trunc against half_up) it is sound, and exact when the stride is a
    /// multiple of the step.
    #[test]
    fn congruence_event_test_matches_brute_force() {
        use super::super::mutants::{event, range_meets_mod};
        let mut rng = crate::sampling::Rng::new(3);
        for (round, kind) in [
            (Rounding::HalfEven, Rounding::HalfUp),
            (Rounding::Trunc, Rounding::HalfUp),
        ] {
            let m = Mutation {
                node: 0,
                stage: String::new(),
                kind: MutationKind::Round(kind),
            };
            for _ in 0..20000 {
                let s = 1 + rng.below(5) as i32;
                let qq = q("x", "I40F0", round, Overflow::Saturate);
                let st = qq.step(s);
                let stride = i128::from(rng.below(70));
                let off = if stride == 0 {
                    i128::from(rng.below(400)) - 200
                } else {
                    i128::from(rng.below(stride as u64))
                };
                let lo = i128::from(rng.below(400)) - 200;
                let hi = lo + i128::from(rng.below(150));
                let brute = (lo..=hi).any(|x| {
                    (if stride == 0 {
                        x == off
                    } else {
                        x.rem_euclid(stride) == off
                    }) && event(&m, &qq, s, x)
                });
                let got = range_meets_mod(&m, &qq, &st, lo, hi, (stride, off));
                assert!(
                    got || !brute,
                    "{round:?} s {s} stride {stride} off {off} [{lo}, {hi}]: missed"
                );
                let exact = round != Rounding::Trunc || stride == 0 || stride % (1 << s) == 0;
                if exact {
                    assert_eq!(
                        got, brute,
                        "{round:?} s {s} stride {stride} off {off} [{lo}, {hi}]"
                    );
                }
            }
        }
    }

    /// The lighting level `Q(16320·spec + 391680·max(dot, 0))` (F25 to
    /// U8F0) rounded half_up instead of half_even: a closed form shows the
    /// only tie with an even floor is at `spec + 24·dot = 786432`, where
    /// the level (382.5) saturates to 255 either way, so the mutant is
    /// equivalent — and the support branch and bound proves it. With a
    /// 10-bit level the tie is no longer masked, and the proof fails.
    #[test]
    fn support_proof_of_the_lighting_level_tie() {
        let ties: Vec<i128> = (0..=262143 + 24 * 32767)
            .filter(|k: &i128| (16320 * k) % (1 << 26) == 1 << 24)
            .collect();
        assert_eq!(ties, [786432]);
        assert!(
            (16320 * ties[0]) >> 25 > 255,
            "the tie lies above the largest level"
        );
        for (set, provable) in [(None, true), (Some("lighting.level.format=U10F0"), false)] {
            let mut cfg = Config::embedded();
            if let Some(o) = set {
                cfg.apply_override(o).unwrap();
            }
            let u = super::super::units::unit("lighting").unwrap();
            let d = u.design(&cfg).unwrap();
            let t = &d.trace;
            let roots: Vec<TV> = t.output_ports().iter().map(|p| p.value).collect();
            let m = t
                .mutations(&roots)
                .into_iter()
                .find(|m| m.stage == "lighting.level" && matches!(m.kind, MutationKind::Round(_)))
                .unwrap();
            let budget = 1u64 << 28;
            assert_eq!(support_proof(&d, &m, budget).unwrap(), provable, "{set:?}");
        }
    }

    /// The sweeps run the design and a mutant specialized to the swept
    /// input ([`Compiled::specialize`]): on the mapped pipeline top (27
    /// inputs, tables, CORDIC steps), for mutants across its stages, each
    /// input swept over 600 random codes from random rows, the specialized
    /// pair tells the same lanes apart as the whole programs, and each
    /// specialized program gives the whole program's codes and flags.
    #[test]
    fn specialized_sweeps_tell_apart_the_lanes_the_programs_do() {
        let u = crate::rtl::units::all()
            .find(|u| u.name == "pipeline")
            .unwrap();
        let mut cfg = Config::embedded();
        cfg.apply_override("pipeline.path=\"mapped\"").unwrap();
        let d = u.design(&cfg).unwrap();
        let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
        let orig = Compiled::compile(&d.trace, &roots).unwrap();
        let formats: Vec<Format> = d.trace.input_ports().iter().map(|p| p.format).collect();
        let all = d.trace.mutations(&roots);
        let mut rng = crate::sampling::Rng::new(5);
        let (mut told, mut shorter) = (0, 0);
        for m in all.iter().step_by(all.len() / 12) {
            let mutant = Compiled::compile(&d.trace.mutated(m), &roots).unwrap();
            for k in 0..formats.len() {
                let row = wild_row(&formats, &mut rng);
                let mut cols: Vec<Vec<i128>> = row.iter().map(|&v| vec![v; 600]).collect();
                let f = formats[k];
                for c in &mut cols[k] {
                    *c = f.min_code()
                        + i128::from(rng.below(narrow::<u64, _>(f.max_code() - f.min_code() + 1)));
                }
                let refs: Vec<&[i128]> = cols.iter().map(Vec::as_slice).collect();
                let varying: Vec<bool> = (0..formats.len()).map(|j| j == k).collect();
                let so = orig.specialize(&row, &varying).unwrap();
                let sm = mutant.specialize(&row, &varying).unwrap();
                let want = orig.differing_lanes(&mutant, &refs);
                assert_eq!(so.differing_lanes(&sm, &refs), want, "{m}, input {k}");
                assert_eq!(
                    so.run_flags_i128(&refs),
                    orig.run_flags_i128(&refs),
                    "input {k}"
                );
                assert_eq!(
                    sm.run_flags_i128(&refs),
                    mutant.run_flags_i128(&refs),
                    "{m}, {k}"
                );
                told += want.iter().filter(|&&x| x).count();
                shorter += usize::from(so.instructions() < orig.instructions());
            }
        }
        // The check compared something: lanes told apart, programs folded.
        assert!(told > 0 && shorter > 0, "{told} {shorter}");
    }
}
