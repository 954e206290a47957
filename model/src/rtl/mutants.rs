//! Mutation testing of a unit's vectors: every mutant of the traced
//! datapath ([`Trace::mutations`]: a changed rounding mode, a flipped
//! overflow mode, an off-by-one shift, one quantizer at a time) against the
//! vectors, in the model; and the inputs that tell apart the mutants a
//! vector set would otherwise miss. The RTL side ([`super::emit_mutants`])
//! builds every mutant into one module, so one simulator build checks them
//! all (`fxshade mutate`).

use super::Design;
use crate::datapath::{Compiled, Mutation, Trace, TV};
use crate::vectors::RtlError;
use fxshade_numbers::convert::narrow;

pub(super) fn columns(rows: &[Vec<i128>], n: usize) -> Vec<Vec<i128>> {
    (0..n)
        .map(|k| rows.iter().map(|r| r[k]).collect())
        .collect()
}

/// Outputs and per-lane overflow flags of `trace` on `rows`.
pub(super) fn run(
    trace: &Trace,
    roots: &[TV],
    cols: &[Vec<i128>],
) -> Result<(Vec<Vec<i128>>, Vec<u64>), RtlError> {
    let prog = Compiled::compile(trace, roots)?;
    let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
    Ok(prog.run_flags_i128(&refs))
}

/// The first lane whose outputs or flags differ.
pub(super) fn first_difference(
    a: &(Vec<Vec<i128>>, Vec<u64>),
    b: &(Vec<Vec<i128>>, Vec<u64>),
) -> Option<usize> {
    let n = a.1.len();
    (0..n).find(|&i| a.1[i] != b.1[i] || a.0.iter().zip(&b.0).any(|(x, y)| x[i] != y[i]))
}

/// Every mutant of `d` and the first of `rows` that tells it apart from
/// the design (outputs or overflow flags differ), if any.
///
/// # Errors
///
/// [`RtlError::Compile`] when the design or one of its mutants cannot be compiled
/// ([`Compiled::compile`]).
///
/// # Panics
///
/// When a row holds fewer codes than the design has input ports.
pub fn model_kills(
    d: &Design,
    rows: &[Vec<i128>],
) -> Result<Vec<(Mutation, Option<usize>)>, RtlError> {
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let cols = columns(rows, d.trace.input_ports().len());
    let want = run(&d.trace, &roots, &cols)?;
    d.trace
        .mutations(&roots)
        .into_iter()
        .map(|m| {
            let got = run(&d.trace.mutated(&m), &roots, &cols)?;
            Ok((m.clone(), first_difference(&want, &got)))
        })
        .collect()
}

/// Inputs from `pool` that tell apart every mutant `base` does not (at most
/// one per mutant, the first found; a row that kills several is taken
/// once), and the mutants no row of `base` or `pool` tells apart.
///
/// # Errors
///
/// [`RtlError::Compile`] when the design or one of its mutants cannot be compiled
/// ([`Compiled::compile`]).
///
/// # Panics
///
/// When a row of `base` or `pool` holds fewer codes than the design has input ports.
pub fn killers(
    d: &Design,
    base: &[Vec<i128>],
    pool: &[Vec<i128>],
) -> Result<(Vec<Vec<i128>>, Vec<Mutation>), RtlError> {
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let n_in = d.trace.input_ports().len();
    let base_cols = columns(base, n_in);
    let pool_cols = columns(pool, n_in);
    let base_want = run(&d.trace, &roots, &base_cols)?;
    let mut pool_want = None;
    let mut chosen: Vec<Vec<i128>> = Vec::new();
    let mut missed = Vec::new();
    for m in d.trace.mutations(&roots) {
        let t = d.trace.mutated(&m);
        if !base.is_empty() && first_difference(&base_want, &run(&t, &roots, &base_cols)?).is_some()
        {
            continue;
        }
        if !chosen.is_empty() {
            let cc = columns(&chosen, n_in);
            if first_difference(&run(&d.trace, &roots, &cc)?, &run(&t, &roots, &cc)?).is_some() {
                continue;
            }
        }
        if pool.is_empty() {
            missed.push(m);
            continue;
        }
        if pool_want.is_none() {
            pool_want = Some(run(&d.trace, &roots, &pool_cols)?);
        }
        let pw = pool_want.as_ref().expect("just set");
        match first_difference(pw, &run(&t, &roots, &pool_cols)?) {
            Some(i) => chosen.push(pool[i].clone()),
            None => missed.push(m),
        }
    }
    Ok((chosen, missed))
}

/// Why mutant `m` of `d` cannot be told apart from the design by any
/// input, when that is proven: an overflow mode flipped at a quantization
/// that the interval analysis ([`Compiled::may_overflow`], over every code
/// of every input port) shows never overflows, or a rounding mode changed
/// at a quantization whose dropped bits are known to be zero for every
/// input ([`Compiled::quant_operand_zeros`]), or any change at a stage the
/// outputs read only as a CORDIC step's direction when the mutant keeps
/// every operand's sign ([`super::direction::sign_only`]). `None`: not proven.
///
/// # Errors
///
/// [`RtlError::Compile`] when the design (or, for a shift of a constant, the mutant) cannot be
/// compiled ([`Compiled::compile`]); the errors of [`super::direction::sign_only`].
pub fn equivalent(d: &Design, m: &Mutation) -> Result<Option<&'static str>, RtlError> {
    use crate::datapath::MutationKind;
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let prog = Compiled::compile(&d.trace, &roots)?;
    let box_: Vec<(i128, i128)> = d
        .trace
        .input_ports()
        .iter()
        .map(|p| (p.format.min_code(), p.format.max_code()))
        .collect();
    if super::direction::sign_only(d, m)? {
        return Ok(Some(super::direction::WHY));
    }
    Ok(match m.kind {
        MutationKind::Overflow(_) => (!prog.may_overflow(&box_)[m.node]).then_some(
            "equivalent: interval analysis over every input code proves the stage never overflows",
        ),
        MutationKind::Round(_) => {
            let crate::datapath::Op::Quant(a, q) = &d.trace.ops()[m.node] else {
                unreachable!("mutations are of quantizations")
            };
            let shift = q.step(a.frac()).shift;
            let zeros = prog.quant_operand_zeros(&box_, m.node).unwrap_or(0);
            (shift <= 0 || zeros >= narrow::<u32, _>(shift)).then_some(
                "equivalent: the bits the stage drops are zero for every input code (known-zero bit analysis), so it never rounds",
            )
        }
        MutationKind::Shift => {
            // A stage that quantizes a constant (the zero a CORDIC's angle
            // starts from): one evaluation settles it.
            let crate::datapath::Op::Quant(a, _) = &d.trace.ops()[m.node] else {
                unreachable!("mutations are of quantizations")
            };
            if d.trace.inputs_of(a.node()).is_empty() {
                let node = [d.trace.value(m.node)];
                let cols: Vec<Vec<i128>> = box_.iter().map(|r| vec![r.0]).collect();
                let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
                let want = Compiled::compile(&d.trace, &node)?.run_flags_i128(&refs);
                let got = Compiled::compile(&d.trace.mutated(m), &node)?.run_flags_i128(&refs);
                (want == got).then_some(
                    "equivalent: the stage quantizes a constant, and the mutant gives it the same code",
                )
            } else {
                None
            }
        }
    })
}

/// Lanes the directed search of [`directed_killers`] looks through at most.
pub const DIRECTED_LANES: usize = 1 << 18;

/// Whether the quantizer of `m` meets, on operand `x`, the event that makes
/// the mutant differ there: a tie with an even floor (half_even against
/// half_up), the half bit set (trunc against half_up), an overflow (wrap
/// against saturate).
pub(super) fn event(m: &Mutation, q: &crate::quantize::Quant, frac: i32, x: i128) -> bool {
    use crate::datapath::MutationKind;
    use crate::quantize::Rounding;
    let st = q.step(frac);
    match m.kind {
        MutationKind::Round(_) => {
            if st.shift <= 0 {
                return false;
            }
            let s = narrow::<u32, _>(st.shift);
            if s >= 127 {
                return false;
            }
            let low = x & ((1i128 << s) - 1);
            let half = 1i128 << (s - 1);
            match q.round() {
                Rounding::Trunc => low >= half,
                _ => low == half && (x >> s) & 1 == 0,
            }
        }
        MutationKind::Overflow(_) => st.apply(x, q.round(), q.overflow()).overflowed,
        MutationKind::Shift => true,
    }
}

/// A random input: each field a random code with random trailing zeros, an
/// extreme (min, max, 0, ±1, one inside the ends) or any code.
pub(super) fn wild_row(
    formats: &[crate::format::Format],
    rng: &mut crate::sampling::Rng,
) -> Vec<i128> {
    formats
        .iter()
        .map(|&f| match rng.below(3) {
            0 => crate::vectors::structured_code(f, rng),
            1 => {
                let c = [
                    f.min_code(),
                    f.max_code(),
                    0,
                    1,
                    -1,
                    f.min_code() + 1,
                    f.max_code() - 1,
                ][narrow::<usize, _>(rng.below(7))];
                c.clamp(f.min_code(), f.max_code())
            }
            _ => {
                f.min_code()
                    + i128::from(rng.below(narrow::<u64, _>(f.max_code() - f.min_code() + 1)))
            }
        })
        .collect()
}

/// Inputs that kill `survivors` (mutants no earlier vector tells apart),
/// found by looking inside the design: random inputs ([`wild_row`], up to
/// [`DIRECTED_LANES`]) run once through the original, the operand of each
/// survivor's quantizer examined for the event that makes it differ
/// ([`event`]), and each candidate confirmed by running the mutant on it
/// (an event does not always reach an output). Returns the inputs and the
/// mutants still not told apart.
///
/// # Errors
///
/// [`RtlError::Compile`] when the design or a survivor cannot be compiled
/// ([`Compiled::compile`]).
pub fn directed_killers(
    d: &Design,
    survivors: &[Mutation],
    seed: u64,
) -> Result<(Vec<Vec<i128>>, Vec<Mutation>), RtlError> {
    if survivors.is_empty() {
        return Ok((Vec::new(), Vec::new()));
    }
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let prog = Compiled::compile(&d.trace, &roots)?;
    let formats: Vec<_> = d.trace.input_ports().iter().map(|p| p.format).collect();
    let n_in = formats.len();
    let nodes: Vec<usize> = survivors.iter().map(|m| m.node).collect();
    let quants: Vec<(crate::quantize::Quant, i32)> = survivors
        .iter()
        .map(|m| match &d.trace.ops()[m.node] {
            crate::datapath::Op::Quant(a, q) => (*q, a.frac()),
            _ => unreachable!("mutations are of quantizations"),
        })
        .collect();
    let mut rng = crate::sampling::Rng::new(seed ^ 0x6469_7265_6374);
    let mut found: Vec<Option<Vec<i128>>> = vec![None; survivors.len()];
    let mut mutant_traces: Vec<Option<Trace>> = vec![None; survivors.len()];
    const CHUNK: usize = 8192;
    let mut looked = 0;
    while looked < DIRECTED_LANES && found.iter().any(|f| f.is_none()) {
        let rows: Vec<Vec<i128>> = (0..CHUNK).map(|_| wild_row(&formats, &mut rng)).collect();
        looked += CHUNK;
        let cols = columns(&rows, n_in);
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        let open: Vec<usize> = (0..survivors.len())
            .filter(|&k| found[k].is_none())
            .collect();
        let probe_nodes: Vec<usize> = open.iter().map(|&k| nodes[k]).collect();
        let probes = prog.probe_i128(&refs, &probe_nodes);
        for (p, &k) in probes.iter().zip(&open) {
            let (q, frac) = &quants[k];
            let cands: Vec<usize> = (0..CHUNK)
                .filter(|&i| event(&survivors[k], q, *frac, p[i]))
                .take(64)
                .collect();
            if cands.is_empty() {
                continue;
            }
            let sub: Vec<Vec<i128>> = cands.iter().map(|&i| rows[i].clone()).collect();
            let sc = columns(&sub, n_in);
            let t = mutant_traces[k].get_or_insert_with(|| d.trace.mutated(&survivors[k]));
            if let Some(i) = first_difference(&run(&d.trace, &roots, &sc)?, &run(t, &roots, &sc)?) {
                found[k] = Some(sub[i].clone());
            }
        }
    }
    let mut killers: Vec<Vec<i128>> = Vec::new();
    let mut missed = Vec::new();
    for (k, f) in found.into_iter().enumerate() {
        match f {
            Some(r) => {
                if !killers.contains(&r) {
                    killers.push(r)
                }
            }
            None => missed.push(survivors[k].clone()),
        }
    }
    Ok((killers, missed))
}

/// What a box search ([`box_search`]) concluded about one mutant.
#[derive(Clone, Debug, PartialEq)]
pub enum BoxOutcome {
    /// An input that tells the mutant apart (confirmed by running it).
    Killer(Vec<i128>),
    /// No input meets the event that makes the mutant differ: it is
    /// equivalent (the interval bounds prove it over every input code).
    Proven,
    /// Neither within the budget.
    Unknown,
}

/// Whether some code in `[lo, hi]` meets the event of `m` at a quantizer
/// of step `st` (see [`event`]).
pub(super) fn range_meets(
    m: &Mutation,
    q: &crate::quantize::Quant,
    st: &crate::quantize::Step,
    lo: i128,
    hi: i128,
) -> bool {
    use crate::datapath::MutationKind;
    use crate::quantize::Rounding;
    let has_residue = |c: i128, modulus: i128| lo + (c - lo).rem_euclid(modulus) <= hi;
    match m.kind {
        MutationKind::Round(_) => {
            if st.shift <= 0 || st.shift >= 120 {
                return false;
            }
            let s = narrow::<u32, _>(st.shift);
            let half = 1i128 << (s - 1);
            match q.round() {
                Rounding::Trunc => {
                    // Some v with v mod 2^s ≥ half.
                    let r = lo.rem_euclid(1i128 << s);
                    r >= half || lo + (half - r) <= hi
                }
                _ => has_residue(half, 1i128 << (s + 1)),
            }
        }
        MutationKind::Overflow(_) => {
            st.apply(lo, q.round(), q.overflow()).overflowed
                || st.apply(hi, q.round(), q.overflow()).overflowed
        }
        MutationKind::Shift => true,
    }
}

/// [`range_meets`] knowing also that every operand value is `≡ off (mod
/// stride)` (`stride` 0: the operand is `off`): a rounding tie is then a
/// pair of congruences, solved exactly (Chinese remainder), and a half bit
/// is fixed when the stride is a multiple of the step.
pub(super) fn range_meets_mod(
    m: &Mutation,
    q: &crate::quantize::Quant,
    st: &crate::quantize::Step,
    lo: i128,
    hi: i128,
    (stride, off): (i128, i128),
) -> bool {
    use crate::datapath::MutationKind;
    use crate::quantize::Rounding;
    if stride == 0 {
        return lo <= off && off <= hi && range_meets(m, q, st, off, off);
    }
    let coarse = range_meets(m, q, st, lo, hi);
    if stride == 1 || !coarse || !matches!(m.kind, MutationKind::Round(_)) {
        return coarse;
    }
    let s = narrow::<u32, _>(st.shift);
    let half = 1i128 << (s - 1);
    // The first operand value ≥ lo that is ≡ x0 (mod l), within hi?
    let has = |x0: i128, l: i128| lo + (x0 - lo).rem_euclid(l) <= hi;
    if q.round() == Rounding::Trunc {
        let step = 1i128 << s;
        return if stride % step == 0 {
            off.rem_euclid(step) >= half && has(off, stride)
        } else {
            coarse
        };
    }
    // x ≡ off (mod stride) and x ≡ half (mod 2^(s+1)).
    let big_m = 1i128 << (s + 1);
    let g = 1i128 << stride.trailing_zeros().min(s + 1);
    if (half - off).rem_euclid(g) != 0 {
        return false;
    }
    let mg = big_m / g;
    let t0 = if mg == 1 {
        0
    } else {
        // (stride/g)·t ≡ (half − off)/g (mod mg), stride/g odd.
        let a = narrow::<u128, _>(stride / g);
        let mut inv = a;
        for _ in 0..7 {
            inv = inv.wrapping_mul(2u128.wrapping_sub(a.wrapping_mul(inv)));
        }
        let rhs = ((half - off) / g).rem_euclid(mg) as u128;
        narrow::<i128, _>(rhs.wrapping_mul(inv) & (narrow::<u128, _>(mg) - 1))
    };
    match (stride.checked_mul(t0), (stride / g).checked_mul(big_m)) {
        (Some(st0), Some(l)) => match off.checked_add(st0) {
            Some(x0) => has(x0, l),
            None => coarse,
        },
        _ => coarse,
    }
}

/// Branch and bound over boxes of input codes for mutant `m`: a box whose
/// operand range at the mutated quantizer cannot meet the mutant's event
/// ([`event`]: a tie with an even floor, the half bit, an overflow) is
/// dropped; the others are split along their widest input until they are
/// single inputs, which are run on the mutant. Ends with a killer, with a
/// proof that no input meets the event (every box dropped: the mutant is
/// equivalent), or after `budget` boxes.
///
/// # Errors
///
/// [`RtlError::Compile`] when the design or the mutant cannot be compiled
/// ([`Compiled::compile`]).
///
/// # Panics
///
/// When the node of `m` is not a quantization of `d`, or when `d` has no input port and
/// the operand range of that quantization may meet the mutant's event.
pub fn box_search(
    d: &Design,
    m: &Mutation,
    budget: usize,
    seed: u64,
) -> Result<BoxOutcome, RtlError> {
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let prog = Compiled::compile(&d.trace, &roots)?;
    let (q, frac) = match &d.trace.ops()[m.node] {
        crate::datapath::Op::Quant(a, q) => (*q, a.frac()),
        _ => unreachable!("mutations are of quantizations"),
    };
    let st = q.step(frac);
    let n_in = d.trace.input_ports().len();
    let full: Vec<(i128, i128)> = d
        .trace
        .input_ports()
        .iter()
        .map(|p| (p.format.min_code(), p.format.max_code()))
        .collect();
    let mut rng = crate::sampling::Rng::new(seed ^ 0x0062_6f78);
    let mut stack = vec![full];
    let mut masked = false;
    let mut mutant: Option<Trace> = None;
    let mut evals = 0;
    while let Some(b) = stack.pop() {
        evals += 1;
        if evals > budget {
            return Ok(BoxOutcome::Unknown);
        }
        // The congruence only where the range meets, from the same
        // interval pass.
        let Some(((lo, hi), cong)) = prog
            .quant_operand_range_congruence(&b, m.node, |(lo, hi)| range_meets(m, &q, &st, lo, hi))
        else {
            return Ok(BoxOutcome::Unknown);
        };
        if !cong.is_some_and(|c| range_meets_mod(m, &q, &st, lo, hi, c)) {
            continue;
        }
        let widest = (0..n_in).max_by_key(|&k| b[k].1 - b[k].0).expect("inputs");
        if b[widest].1 == b[widest].0 {
            // A single input: run it.
            let row: Vec<i128> = b.iter().map(|x| x.0).collect();
            let cols = columns(std::slice::from_ref(&row), n_in);
            let t = mutant.get_or_insert_with(|| d.trace.mutated(m));
            if first_difference(&run(&d.trace, &roots, &cols)?, &run(t, &roots, &cols)?).is_some() {
                return Ok(BoxOutcome::Killer(row));
            }
            masked = true;
            continue;
        }
        let (a, z) = b[widest];
        let mid = a + (z - a) / 2;
        let (mut left, mut right) = (b.clone(), b);
        left[widest] = (a, mid);
        right[widest] = (mid + 1, z);
        if rng.below(2) == 0 {
            stack.push(left);
            stack.push(right);
        } else {
            stack.push(right);
            stack.push(left);
        }
    }
    Ok(if masked {
        BoxOutcome::Unknown
    } else {
        BoxOutcome::Proven
    })
}

/// Whether `row` tells mutant `m` apart from the design (outputs or flags).
///
/// # Errors
///
/// [`RtlError::Compile`] when the design or the mutant cannot be compiled
/// ([`Compiled::compile`]).
///
/// # Panics
///
/// When `row` holds fewer codes than the design has input ports.
pub fn tells_apart(d: &Design, m: &Mutation, row: &[i128]) -> Result<bool, RtlError> {
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let cols = columns(&[row.to_vec()], d.trace.input_ports().len());
    Ok(first_difference(
        &run(&d.trace, &roots, &cols)?,
        &run(&d.trace.mutated(m), &roots, &cols)?,
    )
    .is_some())
}

/// Whether `row` makes the quantizer of `m` meet `m`'s event (computed by
/// probing the compiled design, independently of any solver).
///
/// # Errors
///
/// [`RtlError::Compile`] when the design cannot be compiled ([`Compiled::compile`]).
///
/// # Panics
///
/// When `row` holds fewer codes than the design has input ports, or the node of `m` is
/// not a quantization of `d`.
pub fn meets_event(d: &Design, m: &Mutation, row: &[i128]) -> Result<bool, RtlError> {
    let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let prog = Compiled::compile(&d.trace, &roots)?;
    let cols = columns(&[row.to_vec()], d.trace.input_ports().len());
    let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
    let x = prog.probe_i128(&refs, &[m.node])[0][0];
    let (q, frac) = match &d.trace.ops()[m.node] {
        crate::datapath::Op::Quant(a, q) => (*q, a.frac()),
        _ => unreachable!("mutations are of quantizations"),
    };
    Ok(event(m, &q, frac, x))
}
