//! Scheduling: the stage each operation is computed in and its arrival
//! (nanoseconds after that stage's registers). With target pipelining an
//! operation joins its operands' stage while the delay model's budget
//! allows, else its operands are registered first ([`Emitter::place`]); a
//! quantization may be cut between its rounding incrementer and its range
//! check ([`Emitter::quant_timed`]). The second pass places table reads
//! just before their first reader ([`sink_plan`]).

use crate::*;

impl<'a> Emitter<'a> {
    /// Where an operation of delay `d` on `operands` goes: the stage of its
    /// latest operand and the time its inputs are ready there; with target
    /// pipelining, the next stage (operands registered, ready at 0) when
    /// `d` would not fit after them.
    pub(crate) fn place(&mut self, operands: &[usize], d: f64) -> (u32, f64) {
        let staged = operands.iter().any(|&n| self.stage[n].is_some());
        let s = operands
            .iter()
            .filter_map(|&n| self.stage[n])
            .max()
            .unwrap_or(0);
        let a = operands
            .iter()
            .map(|&n| self.arrival_at(n, s))
            .fold(0.0, f64::max);
        match self.timing {
            // Set-up values alone (no stage): no register to add before
            // them, so the operation stays at stage 0.
            Some((_, budget)) if staged && a > 0.0 && a + d > budget => {
                let a1 = operands
                    .iter()
                    .map(|&n| self.arrival_at(n, s + 1))
                    .fold(0.0, f64::max);
                (s + 1, a1)
            }
            _ => (s, a),
        }
    }

    /// When node `n`'s value is ready at `stage` (at or after its own):
    /// its arrival in its own stage; a set-up value's at any stage (its
    /// logic after its registers); 0 from a register, except the one right
    /// after a DSP product, which sits in the block ([`Self::dsp_out`]).
    pub(crate) fn arrival_at(&self, n: usize, stage: u32) -> f64 {
        match self.stage[n] {
            None => self.arrival[n],
            Some(s0) if s0 == stage => self.arrival[n],
            Some(s0) if s0 + 1 == stage && self.dsp_out[n] => self
                .model()
                .and_then(|m| m.dsp)
                .map_or(0.0, |d| d.route_out),
            Some(_) => 0.0,
        }
    }

    /// Record that node `i` is ready `t` ns into its stage.
    pub(crate) fn ready(&mut self, i: usize, t: f64, what: &str) {
        self.arrival[i] = t;
        self.worst = self.worst.max(t);
        if let Some((_, budget)) = self.timing {
            if t > budget + 1e-9 {
                self.too_slow
                    .push(format!("{what} ({} ns > {budget:.2} ns)", fmt_ns(t)));
            }
        }
    }

    /// The delay model, when pipelining for a target.
    pub(crate) fn model(&self) -> Option<timing::DelayModel> {
        self.timing.map(|(m, _)| m)
    }

    /// A quantization under target pipelining: its output is a wire (the
    /// next operation registers it if it must); the rounding incrementer
    /// and the range check with saturation share a stage when they fit,
    /// else the rounded value is registered between them.
    pub(crate) fn quant_timed(&mut self, i: usize, a: &TV, q: &crate::quantize::Quant) {
        let (m, budget) = self.timing.expect("target pipelining");
        let name = self.name[i].clone();
        let f = q.format();
        let sa = a.sym();
        let drop = a.frac() - f.frac();
        let rw = bits::rounded_width(sa.width, drop, q.round());
        let nearest = q.round() != Rounding::Trunc;
        let dr = m.round(drop.max(0).unsigned_abs(), rw, nearest);
        let checked = if bits::can_leave(rw, sa.signed, f.width(), f.signed()) {
            rw.saturating_sub(f.width()) + 1
        } else {
            0
        };
        let ds = m.saturate(checked, q.overflow() == Overflow::Saturate);
        let (s0, a0) = self.place(&[a.node()], 0.0);
        let both = dr > 0.0 && ds > 0.0;
        let (s, t, split) = if a0 + dr + ds <= budget {
            (s0, a0, false)
        } else if both && a0 + dr <= budget {
            (s0, a0, true)
        } else if a0 == 0.0 || self.stage[a.node()].is_none() {
            // Nothing to register before the operand (a register, or a
            // set-up value read wherever it is needed).
            (s0, a0, both && dr + ds > budget)
        } else {
            (s0 + 1, 0.0, both && dr + ds > budget)
        };
        let va = self.operand(a, s);
        let (yc, oc) = (format!("{name}_c"), format!("{name}_ovf_c"));
        let (src, stage, t_end) = if split {
            // Round into a format wide enough never to overflow, register,
            // then check the range and saturate: the same function.
            let rname = format!("{name}_rw");
            let r = bits::quantize(
                &va,
                &format!("{name}_rnd"),
                &rname,
                &format!("{name}_rnd_ovf"),
                rw,
                sa.signed,
                f.frac(),
                q.round(),
                Overflow::Wrap,
            );
            self.quant_logic(r);
            self.unused.push(format!("{name}_rnd_ovf"));
            let rq = format!("{name}_r_q");
            self.reg(s + 1, &rq, sa.signed, rw, &rname);
            self.worst = self.worst.max(t + dr);
            (
                Val {
                    expr: rq,
                    width: rw,
                    signed: sa.signed,
                    frac: f.frac(),
                },
                s + 1,
                ds,
            )
        } else {
            (va, s, t + dr + ds)
        };
        let round = if split { Rounding::Trunc } else { q.round() };
        let ql = bits::quantize(
            &src,
            &name,
            &yc,
            &oc,
            f.width(),
            f.signed(),
            f.frac(),
            round,
            q.overflow(),
        );
        let settable = self.quant_logic(ql);
        self.stage[i] = Some(stage);
        self.at.insert((i, stage), yc);
        self.overflow_bit(i, oc, stage, settable, q.overflow());
        self.ready(i, t_end, &name);
    }
}

/// Where the second pass places table reads, from a first pass `e`: a
/// table read whose value is first read at stage `r` later than the stage
/// after its own is placed so that its value appears just before `r`, and
/// its address (no wider than its value) waits in the balancing registers
/// instead. Its readers keep their stages: with no delay model the value
/// is read at `r` from the read's register (address stage `r − 1`); with
/// one, at least one more register lies between (address stage `r − 3`,
/// room for the quarter wave's late stage), so the value arrives at `r`
/// from a register as before. `None`: placed as soon as the address
/// allows.
pub(crate) fn sink_plan(e: &Emitter) -> Vec<Option<u32>> {
    let t = e.t;
    let margin = if e.timing.is_some() { 3 } else { 1 };
    t.ops()
        .iter()
        .enumerate()
        .map(|(i, op)| {
            let Op::Table(a, slot) = op else {
                return None;
            };
            let narrower = t.tables()[*slot].index.width() <= t.sym(i).width;
            let staged = e.stage[a.node()].is_some() && !e.lazy[i];
            let (out, r) = (e.stage[i]?, e.first_read[i]?);
            let k = r.checked_sub(margin)?;
            (narrower && staged && k >= out).then_some(k)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use crate::datapath::{Datapath, Trace};
    use crate::emit::{sat, test_design};
    use crate::timing::{Pipelining, Target};

    /// A chain of twelve additions, each quantized back to 16 bits.
    fn chain() -> Trace {
        let mut t = Trace::new();
        let a = t.input_named("a", &sat("c.in", 16));
        let mut x = t.input_named("b", &sat("c.in", 16));
        for _ in 0..12 {
            let s = t.add(x, a);
            x = t.quantize(s, &sat("c.sum", 16));
        }
        t.output("y", x);
        t
    }

    /// Target pipelining on every family with a delay model: the slowest
    /// stage the model predicts fits the period whenever one addition and
    /// its quantizer do (nothing is too slow to fit), a longer period never
    /// needs more stages, and the compact pipeline (a register after every
    /// quantization) is never shorter than a generous period's.
    #[test]
    fn stages_fit_the_period_and_a_longer_period_needs_no_more() {
        for target in Target::pipelined() {
            let m = target.delay().expect("a pipelined family");
            let mut last = u32::MAX;
            for clock_ns in [1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 20.0, 40.0].map(|c| {
                // The same periods relative to the family's own speed.
                c * (m.reg + m.add(17) + m.saturate(1, true)) / 4.0
            }) {
                let mut d = test_design(chain());
                d.pipelining = Pipelining::Target { target, clock_ns };
                let e = crate::emit(&d).expect("emits");
                let one = m.reg + m.add(17) + m.saturate(1, true);
                let p = e.predicted_ns.expect("target pipelining predicts");
                if one <= clock_ns {
                    assert!(p <= clock_ns + 1e-9, "{target} at {clock_ns}: {p}");
                }
                assert!(
                    e.latency <= last,
                    "{target} at {clock_ns}: {} > {last}",
                    e.latency
                );
                last = e.latency;
            }
            let compact = crate::emit(&test_design(chain())).expect("emits");
            assert!(
                compact.latency >= last,
                "{target}: compact {}",
                compact.latency
            );
        }
    }
}
