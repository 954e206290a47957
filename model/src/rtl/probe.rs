//! The last resort of the killer search ([`super::search::killers`]):
//! random input rows, run through the design and the mutant side by side,
//! until one tells them apart or the work runs out.
//!
//! Some mutants are killed only where several rare things meet, each in
//! low bits no interval analysis or bisection steers: `angles`' late CORDIC
//! roundings (`x_9` rounded half_up instead of truncated) change an output
//! only where the `+1` survives the next truncation of `y` (one row in
//! 512), lands on `y = −1` so that a later step turns the other way (one in
//! about 3 000), and moves the angle across a rounding boundary of the
//! output (one in three): about 1.6 rows in ten million, measured. The
//! design runs ten million rows a second, so a plain random search finds
//! such a row in about a second, where the witness search
//! ([`super::witness`]), steering one support at a time, finds it in one
//! seed out of four with 2^31 lane·operations.

use super::Design;
use crate::datapath::{Compiled, Mutation, TV};
use crate::sampling::Rng;
use crate::vectors::RtlError;
use fxshade_numbers::convert::narrow;

/// Rows per batch.
const BLOCK: usize = 1 << 14;

/// Lane·operations a carry ([`super::search::sweep`] of the free ports)
/// may take per row that changes a checkpoint.
const CARRY_WORK: usize = 1 << 30;

/// A row of input codes on which mutant `m` gives an output of `d` another
/// code than the design does, or `None` when none is found within `work`
/// lane·operations (rows times the operations run): [`Probe::run`] from
/// [`Probe::new`].
///
/// # Errors
///
/// As [`Probe::new`].
pub fn random_probe(
    d: &Design,
    m: &Mutation,
    work: usize,
    seed: u64,
) -> Result<Option<Vec<i128>>, RtlError> {
    Ok(match Probe::new(d, m, seed)? {
        Some(mut p) => p.run(work),
        None => None,
    })
}

/// A random search for an input that tells one mutant apart, run in
/// pieces ([`Probe::run`]) so that several can share a budget
/// deterministically.
///
/// Rows are drawn uniformly over every input port's codes. When some ports
/// do not reach the mutated stage (the light and half vectors beside the
/// normal a CORDIC reads in the pipeline top), the rows are first run only
/// to the *checkpoints*: the values the stage reaches that the other ports
/// do not (the CORDIC's angles), where they meet the rest of the datapath
/// or leave as outputs. A row that changes a checkpoint is carried to an
/// output by sweeping the free ports one at a time.
pub struct Probe {
    /// Design and mutant to the checkpoints.
    near: (Compiled, Compiled),
    /// Design and mutant to the outputs the stage reaches, when there are
    /// free ports.
    whole: Option<(Compiled, Compiled)>,
    free: Vec<usize>,
    formats: Vec<crate::format::Format>,
    /// Operations per row to the checkpoints, per lane to the outputs.
    per_row: usize,
    per_lane: usize,
    rng: Rng,
    /// Lane·operations run so far.
    pub spent: usize,
}

impl Probe {
    /// The search for mutant `m` of `d`, seeded by `seed`; `None` when no
    /// output depends on the stage.
    ///
    /// # Errors
    ///
    /// [`RtlError::Compile`] when the design or the mutant cannot be compiled to the checkpoints
    /// or to the outputs the stage reaches ([`Compiled::compile`]).
    pub fn new(d: &Design, m: &Mutation, seed: u64) -> Result<Option<Probe>, RtlError> {
        let t = &d.trace;
        let n = t.ops().len();
        let down = t.downstream(m.node);
        let outs: Vec<TV> = t
            .output_ports()
            .iter()
            .map(|p| p.value)
            .filter(|v| down[v.node()])
            .collect();
        if outs.is_empty() {
            return Ok(None);
        }
        // The ports each node is computed from, as bits.
        let ports = t.input_ports();
        let mut mask = vec![0u128; n];
        for i in 0..n {
            mask[i] = t.operands(i).iter().fold(0, |a, &o| a | mask[o]);
            if let Some(k) = ports.iter().position(|p| p.value.node() == i) {
                mask[i] |= 1 << k.min(127);
            }
        }
        let near = mask[m.node];
        let free: Vec<usize> = (0..ports.len())
            .filter(|&k| near >> k.min(127) & 1 == 0)
            .collect();
        let live = t.live_nodes(&outs);
        let targets: Vec<TV> = if free.is_empty() {
            outs.clone()
        } else {
            (0..n)
                .filter(|&i| down[i] && mask[i] & !near == 0)
                .filter(|&i| {
                    outs.iter().any(|o| o.node() == i)
                        || (i + 1..n)
                            .any(|j| live[j] && mask[j] & !near != 0 && t.operands(j).contains(&i))
                })
                .map(|i| t.value(i))
                .collect()
        };
        let mutant = t.mutated(m);
        let cost = |roots: &[TV]| t.live_nodes(roots).iter().filter(|&&l| l).count().max(1) * 2;
        let whole = if free.is_empty() {
            None
        } else {
            Some((
                Compiled::compile(t, &outs)?,
                Compiled::compile(&mutant, &outs)?,
            ))
        };
        Ok(Some(Probe {
            near: (
                Compiled::compile(t, &targets)?,
                Compiled::compile(&mutant, &targets)?,
            ),
            whole,
            free,
            formats: ports.iter().map(|p| p.format).collect(),
            per_row: cost(&targets),
            per_lane: cost(&outs),
            rng: Rng::new(seed ^ 0x0070_726f_6265),
            spent: 0,
        }))
    }

    /// Search on until a row is found or `work` more lane·operations are
    /// spent (whole batches of rows: it may run over by one).
    pub fn run(&mut self, work: usize) -> Option<Vec<i128>> {
        let stop = self.spent + work;
        while self.spent < stop {
            let rng = &mut self.rng;
            let cols: Vec<Vec<i128>> = self
                .formats
                .iter()
                .map(|f| {
                    let (lo, hi) = (f.min_code(), f.max_code());
                    // A port of 64 bits or more: the lowest 2^64 − 1 codes
                    // (as the sweeps do), not a span cast to zero.
                    let span = narrow::<u64, _>((hi - lo + 1).min(i128::from(u64::MAX)));
                    (0..BLOCK)
                        .map(|_| lo + i128::from(rng.below(span)))
                        .collect()
                })
                .collect();
            let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
            let (a, b) = (self.near.0.run_i128(&refs).0, self.near.1.run_i128(&refs).0);
            self.spent += BLOCK * self.per_row;
            for i in (0..BLOCK).filter(|&i| a.iter().zip(&b).any(|(x, y)| x[i] != y[i])) {
                let row: Vec<i128> = cols.iter().map(|c| c[i]).collect();
                let Some((w, g)) = &self.whole else {
                    return Some(row);
                };
                let mut swept = 0;
                let found = super::search::sweep(
                    &row,
                    &self.formats,
                    &self.free,
                    self.free.len(),
                    w,
                    g,
                    &mut self.rng,
                    &mut swept,
                    CARRY_WORK / self.per_lane,
                );
                self.spent += swept * self.per_lane;
                if found.is_some() {
                    return found;
                }
                if self.spent >= stop {
                    return None;
                }
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datapath::MutationKind;

    /// `y = round(a·b)` to 7 bits, then `z = round(y·c)` to 3 fraction bits
    /// (`search::tests::masked_tie`, as for the witness search): `y`'s mutants reach the
    /// output only through `c`, so the probe meets them at `y` and carries
    /// them by sweeping `c`. Against every input (exhaustive): each row
    /// the probe returns kills its mutant, it finds one for every killable
    /// rounding or shift, and none for the others.
    #[test]
    fn probe_rows_kill_and_reach_every_killable_mutant() {
        let (d, y, rows) = crate::rtl::search::tests::masked_tie();
        let mut carried = 0;
        for (m, first) in crate::rtl::mutants::model_kills(&d, &rows).unwrap() {
            if matches!(m.kind, MutationKind::Overflow(_)) {
                continue;
            }
            let r = random_probe(&d, &m, 1 << 26, 5).unwrap();
            if let Some(row) = &r {
                assert!(
                    crate::rtl::mutants::tells_apart(&d, &m, row).unwrap(),
                    "{m}: {row:?} is no killer"
                );
            }
            assert_eq!(
                r.is_some(),
                first.is_some(),
                "{m}: killable {first:?}, found {r:?}"
            );
            if r.is_some() && m.node == y.node() {
                carried += 1;
            }
        }
        assert!(carried >= 2, "{carried} of y's mutants found");
    }
}
