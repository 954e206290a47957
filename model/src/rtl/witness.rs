//! Witnesses: searching a mutant's killer through the *supports* of its
//! quantizer's operand ([`crate::datapath::Trace::supports`]: the nearest
//! quantizations and inputs it is computed from).
//!
//! A *witness* is a tuple of support codes at which design and mutant
//! differ where the supports' region meets the rest of the datapath (the
//! region's frontier, [`crate::datapath::Trace::cut_set_frontier`]): the
//! mutant's event happens and leaves the region. [`witness_search`] finds
//! witnesses two ways, in turn:
//!
//! - **moving a support**: a row's support codes with one support run over
//!   every code it can take (the tie of a product of two table reads, which
//!   one index alone runs into), then *realized* ([`Search::realize`]) as
//!   a row producing exactly those codes, by bisecting one input port at a
//!   time with interval analysis;
//! - **moving a port**: a row with one input port run over its codes; a
//!   lane whose supports are a witness is realized already (supports that
//!   share ports, which the first way would move apart).
//!
//! When the supports take at most [`LISTED_POINTS`] tuples of codes (two
//! 11-bit table indices), every tuple is run once ([`Search::list`]): none
//! is a witness, and the search ends; some are, and the first way realizes
//! those, one support at a time, instead of moving a support.
//!
//! A realized witness whose change a later rounding masks is *carried* to
//! an output ([`Search::carry`]): the ports no support reads are swept over
//! their ranges (they keep the witness), and the ports a support reads are
//! moved at random, the witness realized again through another port.

use super::mutants::{columns, wild_row};
use super::search::{frontier_in, full_box, quant_of, sweep, LEAVES_PER_LINE};
use super::Design;
use crate::datapath::{Boxes, Compiled, Mutation, TV};
use crate::format::Format;
use crate::sampling::Rng;
use crate::vectors::RtlError;
use fxshade_numbers::convert::narrow;

/// Codes one pass runs a support or a port over: all of them, or this many
/// random ones.
const WITNESS_LANES: i128 = 4096;

/// Interval evaluations a realization spends on one port, at most.
const REALIZE_EVALS: usize = 512;

/// One witness may spend one part in this many of the search's work on
/// each way of carrying its change to an output.
const CARRY_SHARE: usize = 64;

/// Moves of a port [`Search::carry`] tries at once.
const CARRY_MOVES: usize = 64;

/// The lanes a run of `n` rows is charged: at least one block (a run sets
/// up a block of registers whatever its length).
fn lanes(n: usize) -> usize {
    n.max(crate::datapath::BLOCK)
}

/// Witnesses taken from one pass, at most.
const WITNESSES_PER_PASS: usize = 4;

/// The most tuples of support codes [`Search::list`] runs through.
const LISTED_POINTS: i128 = 1 << 22;

/// The most witnesses [`Search::list`] keeps.
const LISTED_KEPT: usize = 256;

/// An input that tells mutant `m` apart from the design, found through
/// witnesses (module documentation), starting from `bases` (the unit's
/// own inputs) and random rows; at most `work` lane·operations (an
/// interval evaluation counted as four lanes). `None`: none found in the
/// budget (which proves nothing).
///
/// # Errors
///
/// [`RtlError::Compile`] when the program of the supports' codes, or the design or the
/// mutant to the supports' frontier or to the outputs, cannot be compiled
/// ([`Compiled::compile`]).
pub fn witness_search(
    d: &Design,
    m: &Mutation,
    bases: &[Vec<i128>],
    work: usize,
    seed: u64,
) -> Result<Option<Vec<i128>>, RtlError> {
    let Some(mut s) = Search::new(d, m, work, seed)? else {
        return Ok(None);
    };
    if s.listed == Some(Vec::new()) {
        // Every tuple of support codes was run: none is a witness.
        return Ok(None);
    }
    // Passes alternate: a support moved (or a listed witness realized)
    // from a random row, then a port moved from one of `bases` (a random
    // row when there are none).
    let mut pass = 0usize;
    while s.spent < s.work {
        let found = if pass.is_multiple_of(2) {
            let base = wild_row(&s.formats, &mut s.rng);
            if s.listed.is_some() {
                s.listed_witness(&base)
            } else {
                s.move_support(&base)
            }
        } else {
            let base = if bases.is_empty() {
                wild_row(&s.formats, &mut s.rng)
            } else {
                bases[narrow::<usize, _>(s.rng.below(bases.len() as u64))].clone()
            };
            s.move_port(&base)
        };
        pass += 1;
        if found.is_some() {
            return Ok(found);
        }
    }
    Ok(None)
}

/// The programs and the budget of one [`witness_search`].
struct Search {
    formats: Vec<Format>,
    /// The support nodes.
    sup: Vec<usize>,
    /// Each support's range of codes over every input.
    ranges: Vec<(i128, i128)>,
    /// The supports' codes from the input ports (and their interval
    /// evaluation along one port).
    sprog: Boxes<Compiled>,
    /// Design and mutant from the supports to their region's frontier.
    front: (Compiled, Compiled),
    /// The support each input of the front programs takes.
    order: Vec<usize>,
    /// Design and mutant, from the ports to the outputs and flags.
    whole: (Compiled, Compiled),
    /// The ports each support reads.
    reads: Vec<Vec<usize>>,
    /// How many nodes each port reaches: a realization tries the ports
    /// that reach fewest first (`β_H` before the normal a CORDIC reads),
    /// where interval analysis is tightest.
    fanout: Vec<usize>,
    /// The ports some support reads, and the others.
    read: Vec<usize>,
    free: Vec<usize>,
    /// Witnesses (every one, or [`LISTED_KEPT`] spread over them) when
    /// there are at most [`LISTED_POINTS`] tuples of support codes
    /// ([`Search::list`]); `None` when there are more.
    listed: Option<Vec<Vec<i128>>>,
    /// Operations run per lane: the design, the front programs, the
    /// supports.
    ops: (usize, usize, usize),
    rng: Rng,
    spent: usize,
    work: usize,
}

impl Search {
    /// The search for `m`, or `None` when no support can move.
    fn new(d: &Design, m: &Mutation, work: usize, seed: u64) -> Result<Option<Search>, RtlError> {
        let (_, _, x) = quant_of(d, m);
        let sup = d.trace.supports(x);
        let ports = d.trace.input_ports();
        let n_in = ports.len();
        let vals: Vec<TV> = sup.iter().map(|&c| d.trace.value(c)).collect();
        let sprog = Compiled::compile(&d.trace, &vals)?;
        let ranges = sprog.node_ranges(&full_box(d), &sup);
        if ranges.iter().all(|r| r.0 == r.1) {
            return Ok(None);
        }
        let t = d.trace.from_cuts(&sup);
        // The front programs' inputs are the supports in node order.
        let mut order: Vec<usize> = (0..sup.len()).collect();
        order.sort_by_key(|&j| sup[j]);
        let roots: Vec<TV> = d.trace.output_ports().iter().map(|p| p.value).collect();
        let front = frontier_in(d, &sup, &t);
        let reads: Vec<Vec<usize>> = vals
            .iter()
            .map(|&v| {
                let live = d.trace.live_nodes(&[v]);
                (0..n_in).filter(|&k| live[ports[k].value.node()]).collect()
            })
            .collect();
        let (read, free) = (0..n_in).partition(|k| reads.iter().any(|r| r.contains(k)));
        let live = |t: &crate::datapath::Trace, v: &[TV]| {
            t.live_nodes(v).iter().filter(|&&l| l).count().max(1)
        };
        let ops = (
            live(&d.trace, &roots),
            live(&t, &front),
            live(&d.trace, &vals),
        );
        let mut fanout = vec![0; n_in];
        for x in 0..d.trace.ops().len() {
            for node in d.trace.inputs_of(x) {
                if let Some(k) = ports.iter().position(|p| p.value.node() == node) {
                    fanout[k] += 1;
                }
            }
        }
        let mut s = Search {
            formats: ports.iter().map(|p| p.format).collect(),
            sup,
            ranges,
            sprog: Boxes::new(sprog),
            front: (
                Compiled::compile(&t, &front)?,
                Compiled::compile(&t.mutated(m), &front)?,
            ),
            order,
            whole: (
                Compiled::compile(&d.trace, &roots)?,
                Compiled::compile(&d.trace.mutated(m), &roots)?,
            ),
            reads,
            fanout,
            read,
            free,
            listed: None,
            ops,
            rng: Rng::new(seed ^ 0x7769_746e),
            spent: 0,
            work,
        };
        s.list();
        Ok(Some(s))
    }

    /// Runs the front programs over every tuple of support codes when
    /// there are at most [`LISTED_POINTS`], and keeps the witnesses (at
    /// most [`LISTED_KEPT`], spread evenly over the ones found). Its work
    /// (bounded by [`LISTED_POINTS`] runs of the front programs) is not
    /// counted against the search's.
    fn list(&mut self) {
        let spans: Vec<i128> = self.ranges.iter().map(|r| r.1 - r.0 + 1).collect();
        let total = spans.iter().try_fold(1i128, |a, &w| {
            a.checked_mul(w).filter(|&p| p <= LISTED_POINTS)
        });
        let Some(total) = total else { return };
        let spent = self.spent;
        const CHUNK: i128 = 1 << 16;
        let mut found = Vec::new();
        let mut start = 0;
        while start < total {
            let end = (start + CHUNK).min(total);
            // Tuple `i` in mixed radix: support 0 the fastest digit.
            let mut cols = Vec::with_capacity(spans.len());
            let mut radix = 1u64;
            for (&w, r) in spans.iter().zip(&self.ranges) {
                let w = narrow::<u64, _>(w);
                let col = (narrow::<u64, _>(start)..narrow::<u64, _>(end))
                    .map(|i| r.0 + i128::from(i / radix % w));
                cols.push(col.collect::<Vec<_>>());
                radix *= w;
            }
            let hits = self.witness_lanes(&cols);
            found.extend(
                (0..hits.len())
                    .filter(|&i| hits[i])
                    .map(|i| cols.iter().map(|c| c[i]).collect::<Vec<_>>()),
            );
            start = end;
        }
        let step = found.len().div_ceil(LISTED_KEPT).max(1);
        self.listed = Some(found.into_iter().step_by(step).collect());
        self.spent = spent;
    }

    /// A pass realizing one listed witness from `base`, one support at a
    /// time (each through a port it reads, the supports already placed
    /// held), then carrying it.
    fn listed_witness(&mut self, base: &[i128]) -> Option<Vec<i128>> {
        let listed = self.listed.as_ref().expect("listed witnesses");
        let w = listed[narrow::<usize, _>(self.rng.below(listed.len() as u64))].clone();
        let mut row = base.to_vec();
        let mut order: Vec<usize> = (0..self.sup.len()).collect();
        for i in (1..order.len()).rev() {
            order.swap(i, narrow::<usize, _>(self.rng.below(i as u64 + 1)));
        }
        let mut held = vec![false; self.sup.len()];
        for j in order {
            held[j] = true;
            if self.supports_of(std::slice::from_ref(&row))[0][j] == w[j] {
                continue;
            }
            let movable = self.reads[j].clone();
            row = self.realize(&w, &held, &row, &movable)?;
        }
        self.carry(row, &w)
    }

    /// The supports' codes of each row, one vector per row.
    fn supports_of(&mut self, rows: &[Vec<i128>]) -> Vec<Vec<i128>> {
        let cols = columns(rows, self.formats.len());
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        let (out, _) = self.sprog.program().run_flags_i128(&refs);
        self.spent += lanes(rows.len()) * self.ops.2;
        (0..rows.len())
            .map(|i| out.iter().map(|o| o[i]).collect())
            .collect()
    }

    /// Whether the region's frontier differs at each tuple of support
    /// codes.
    fn witnesses(&mut self, points: &[Vec<i128>]) -> Vec<bool> {
        let sup_cols: Vec<Vec<i128>> = (0..self.sup.len())
            .map(|j| points.iter().map(|p| p[j]).collect())
            .collect();
        self.witness_lanes(&sup_cols)
    }

    /// The first [`WITNESSES_PER_PASS`] of `points` that are witnesses.
    fn first_witnesses(&mut self, points: &[Vec<i128>]) -> Vec<usize> {
        let hits = self.witnesses(points);
        (0..points.len())
            .filter(|&i| hits[i])
            .take(WITNESSES_PER_PASS)
            .collect()
    }

    /// [`Search::witnesses`] of the tuples given as one column of codes
    /// per support.
    fn witness_lanes(&mut self, sup_cols: &[Vec<i128>]) -> Vec<bool> {
        let n = sup_cols[0].len();
        let refs: Vec<&[i128]> = self.order.iter().map(|&j| sup_cols[j].as_slice()).collect();
        let diff = self.front.0.differing_lanes(&self.front.1, &refs);
        self.spent += 2 * lanes(n) * self.ops.1;
        diff
    }

    /// The first of `rows` on which design and mutant differ.
    fn killer(&mut self, rows: &[Vec<i128>]) -> Option<usize> {
        let cols = columns(rows, self.formats.len());
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        let diff = self.whole.0.differing_lanes(&self.whole.1, &refs);
        self.spent += 2 * lanes(rows.len()) * self.ops.0;
        diff.iter().position(|&d| d)
    }

    /// A pass moving one support over its codes: lane `i` takes the
    /// supports of row `i` (`base`, then random rows) with one support
    /// replaced by code `i` of its range.
    fn move_support(&mut self, base: &[i128]) -> Option<Vec<i128>> {
        let movable: Vec<usize> = (0..self.sup.len())
            .filter(|&j| self.ranges[j].0 < self.ranges[j].1)
            .collect();
        let j = movable[narrow::<usize, _>(self.rng.below(movable.len() as u64))];
        let codes = self.codes(self.ranges[j]);
        let rows: Vec<Vec<i128>> = std::iter::once(base.to_vec())
            .chain((1..codes.len()).map(|_| wild_row(&self.formats, &mut self.rng)))
            .collect();
        let mut points = self.supports_of(&rows);
        for (p, &c) in points.iter_mut().zip(&codes) {
            p[j] = c;
        }
        for i in self.first_witnesses(&points) {
            let movable = self.reads[j].clone();
            let all = vec![true; self.sup.len()];
            if let Some(row) = self.realize(&points[i], &all, &rows[i], &movable) {
                if let Some(k) = self.carry(row, &points[i]) {
                    return Some(k);
                }
            }
        }
        None
    }

    /// A pass moving one port of `base` that a support reads over its codes.
    fn move_port(&mut self, base: &[i128]) -> Option<Vec<i128>> {
        if self.read.is_empty() {
            return None;
        }
        let k = self.read[narrow::<usize, _>(self.rng.below(self.read.len() as u64))];
        let f = self.formats[k];
        let rows: Vec<Vec<i128>> = self
            .codes((f.min_code(), f.max_code()))
            .into_iter()
            .map(|c| {
                let mut r = base.to_vec();
                r[k] = c;
                r
            })
            .collect();
        if let Some(i) = self.killer(&rows) {
            return Some(rows[i].clone());
        }
        let points = self.supports_of(&rows);
        for i in self.first_witnesses(&points) {
            if let Some(k) = self.carry(rows[i].clone(), &points[i]) {
                return Some(k);
            }
        }
        None
    }

    /// Every code of `range`, or [`WITNESS_LANES`] random ones.
    fn codes(&mut self, (lo, hi): (i128, i128)) -> Vec<i128> {
        let span = hi - lo + 1;
        if span <= WITNESS_LANES {
            (lo..=hi).collect()
        } else {
            let s = narrow::<u64, _>(span.min(i128::from(u64::MAX)));
            (0..WITNESS_LANES)
                .map(|_| lo + i128::from(self.rng.below(s)))
                .collect()
        }
    }

    /// A row that differs from `base` in one of the ports `movable` (those
    /// reaching fewest nodes first, ties in a random order) and whose
    /// supports marked in `held` take exactly their codes in `target`:
    /// that port's range is bisected, keeping the halves whose interval at
    /// every held support still holds its target code ([`REALIZE_EVALS`]
    /// evaluations per port), and the single codes left are checked
    /// exactly.
    fn realize(
        &mut self,
        target: &[i128],
        held: &[bool],
        base: &[i128],
        movable: &[usize],
    ) -> Option<Vec<i128>> {
        let mut order = movable.to_vec();
        for i in (1..order.len()).rev() {
            order.swap(i, narrow::<usize, _>(self.rng.below(i as u64 + 1)));
        }
        order.sort_by_key(|&k| self.fanout[k]);
        // Every box is `base` with one port's range: only what that port
        // reaches is evaluated again.
        let at_base = {
            let b: Vec<(i128, i128)> = base.iter().map(|&v| (v, v)).collect();
            self.sprog.root(&b)
        };
        for k in order {
            let f = self.formats[k];
            let mut stack = vec![(f.min_code(), f.max_code())];
            let mut evals = 0;
            let mut leaves = Vec::new();
            while let Some((lo, hi)) = stack.pop() {
                evals += 1;
                if evals > REALIZE_EVALS || leaves.len() >= LEAVES_PER_LINE {
                    break;
                }
                self.spent += 4 * self.ops.2;
                let e = self.sprog.child(&at_base, k, (lo, hi));
                let r: Vec<(i128, i128)> = self
                    .sup
                    .iter()
                    .map(|&n| self.sprog.node_range(&e, n))
                    .collect();
                let holds = |j: usize| !held[j] || (r[j].0 <= target[j] && target[j] <= r[j].1);
                if !(0..r.len()).all(holds) {
                    continue;
                }
                if lo == hi {
                    leaves.push(lo);
                    continue;
                }
                let mid = lo + (hi - lo).div_euclid(2);
                let halves = [(lo, mid), (mid + 1, hi)];
                let first = narrow::<usize, _>(self.rng.below(2));
                stack.push(halves[first]);
                stack.push(halves[1 - first]);
            }
            let rows: Vec<Vec<i128>> = leaves
                .into_iter()
                .map(|v| {
                    let mut r = base.to_vec();
                    r[k] = v;
                    r
                })
                .collect();
            if rows.is_empty() {
                continue;
            }
            let got = self.supports_of(&rows);
            let exact = |g: &Vec<i128>| (0..g.len()).all(|j| !held[j] || g[j] == target[j]);
            if let Some(i) = got.iter().position(exact) {
                return Some(rows[i].clone());
            }
        }
        None
    }

    /// `row` (whose supports are the witness `target`) or a row that keeps
    /// the witness, on which design and mutant differ: the ports no support
    /// reads swept over their ranges one at a time, then ports a support
    /// reads moved at random and the witness realized again through
    /// another port (the polar transform's `β_H − φ_N` index keeps its code
    /// when `β_H` follows a move of the normal, while `θ_N`, which the
    /// change passes through, moves). Each way spends at most one part in
    /// [`CARRY_SHARE`] of the search's work.
    fn carry(&mut self, row: Vec<i128>, target: &[i128]) -> Option<Vec<i128>> {
        if self.killer(std::slice::from_ref(&row)).is_some() {
            return Some(row);
        }
        let mut swept = 0;
        let found = sweep(
            &row,
            &self.formats,
            &self.free,
            self.free.len(),
            &self.whole.0,
            &self.whole.1,
            &mut self.rng,
            &mut swept,
            self.work / (CARRY_SHARE * self.ops.0),
        );
        self.spent += 2 * swept * self.ops.0;
        if found.is_some() {
            return found;
        }
        let stop = self.spent + self.work / CARRY_SHARE;
        while self.spent < stop && !self.read.is_empty() {
            let moves: Vec<(usize, Vec<i128>)> = (0..CARRY_MOVES)
                .map(|_| {
                    let k = self.read[narrow::<usize, _>(self.rng.below(self.read.len() as u64))];
                    let mut moved = row.clone();
                    moved[k] = wild_row(&self.formats[k..=k], &mut self.rng)[0];
                    (k, moved)
                })
                .collect();
            let rows: Vec<Vec<i128>> = moves.iter().map(|m| m.1.clone()).collect();
            let got = self.supports_of(&rows);
            let mut again = Vec::new();
            for ((k, moved), g) in moves.into_iter().zip(got) {
                if g.as_slice() == target {
                    again.push(moved);
                } else if self.spent < stop {
                    let others: Vec<usize> =
                        self.read.iter().copied().filter(|&p| p != k).collect();
                    let all = vec![true; target.len()];
                    again.extend(self.realize(target, &all, &moved, &others));
                }
            }
            if let Some(i) = self.killer(&again) {
                return Some(again.swap_remove(i));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `y = round(a·b)` to 7 bits (a tie needs the product's low five bits
    /// to be `10000`), then `z = round(y·c)` to 3 fraction bits, which
    /// masks most changes of `y` (`search::tests::masked_tie`). Every input
    /// is run on design and mutant (exhaustive): a row the witness search
    /// returns tells its mutant apart, and it finds a
    /// row for every killable rounding mutant, among them `y`'s
    /// half_even → half_up, which 287 of the 2^18 inputs kill (counted
    /// apart from fxshade, by a script of the same arithmetic).
    #[test]
    fn witnesses_are_killers_and_found_behind_a_masking_rounding() {
        let (d, y, rows) = crate::rtl::search::tests::masked_tie();
        let kills = crate::rtl::mutants::model_kills(&d, &rows).unwrap();
        let (mut found, mut tie) = (0, false);
        for (m, first) in kills {
            let r = witness_search(&d, &m, &[], 1 << 24, 3).unwrap();
            if let Some(row) = &r {
                assert!(
                    crate::rtl::mutants::tells_apart(&d, &m, row).unwrap(),
                    "{m}: {row:?} is no killer"
                );
            }
            if first.is_some() && !matches!(m.kind, crate::datapath::MutationKind::Overflow(_)) {
                assert!(r.is_some(), "{m}: killable, no witness found");
                found += 1;
                tie |=
                    m.node == y.node() && matches!(m.kind, crate::datapath::MutationKind::Round(_));
            }
        }
        assert!(tie, "y's rounding is not killable");
        assert!(found >= 2, "only {found} killable roundings");
    }
}
