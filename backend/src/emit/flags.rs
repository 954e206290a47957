//! Overflow flags: each quantization's overflow bit is registered once
//! after its stage and ORed there into one running register per stage id,
//! which travels to `ovf_o`; never more than one register per stage id per
//! stage, and a flag that cannot be set (the value cannot leave its
//! format) is not registered at all.

use crate::*;

impl<'a> Emitter<'a> {
    /// Quantization `node`'s overflow bit, wire `ovf`, computed in
    /// `stage`: the flags pass registers it once ([`Self::flag_chain`]).
    /// One that cannot be set (a constant 0: the value cannot leave its
    /// format) is registered nowhere and read by no flag; a wrapping
    /// quantizer's wire is then read by nothing else, so it goes to the
    /// `unused` sink (a saturating one's multiplexer reads it).
    pub(crate) fn overflow_bit(
        &mut self,
        node: usize,
        ovf: String,
        stage: u32,
        settable: bool,
        mode: Overflow,
    ) {
        if settable {
            self.ovf_at.insert((node, stage), ovf);
        } else {
            self.never_ovf[node] = true;
            if mode == Overflow::Wrap {
                self.unused.push(ovf);
            }
        }
    }

    /// The overflow bit of quantization `node` as it stands at `stage`:
    /// the wire it was computed on, carried by one register per later
    /// stage.
    ///
    /// # Panics
    ///
    /// If `node`'s bit was never computed, or `stage` lies before it.
    pub(crate) fn ovf_at(&mut self, node: usize, stage: u32) -> String {
        if let Some(n) = self.ovf_at.get(&(node, stage)) {
            return n.clone();
        }
        let s0 = self.ovf_first(node).expect("the bit was computed");
        assert!(stage > s0);
        let prev = self.ovf_at(node, stage - 1);
        let name = format!("{}_ovf_s{stage}", self.name[node]);
        self.reg(stage, &name, false, 1, &prev);
        self.ovf_at.insert((node, stage), name.clone());
        name
    }

    /// Flag `k` of `ovf_o` at `latency`: the OR of its quantizers' overflow
    /// bits, folded into one register per stage as they arrive. Each
    /// quantizer's bit is registered once after the stage that computes it
    /// (the OR never lengthens that stage's path) and ORed there into the
    /// flag's running register; before, every bit was carried on its own
    /// to the output and ORed only there (one flip-flop per quantizer and
    /// later stage). A bit that first exists at `latency` is ORed there
    /// unregistered, as before.
    pub(crate) fn flag_chain(&mut self, k: usize, nodes: &[usize], latency: u32) -> String {
        let mut parts: std::collections::BTreeMap<u32, Vec<String>> = Default::default();
        for &n in nodes {
            let first = self
                .ovf_first(n)
                .expect("a flag's quantizer computes its bit");
            let at = (first + 1).min(latency);
            let bit = self.ovf_at(n, at);
            parts.entry(at).or_default().push(bit);
        }
        let from = *parts.keys().next().expect("a flag has a quantizer");
        let mut acc: Option<String> = None;
        for s in from..=latency {
            if let Some(a) = acc.take() {
                let name = format!("ovf{k}_s{s}");
                self.reg(s, &name, false, 1, &a);
                acc = Some(name);
            }
            let Some(p) = parts.get(&s) else { continue };
            let mut terms: Vec<String> = acc.take().into_iter().collect();
            terms.extend(p.iter().cloned());
            acc = Some(if terms.len() == 1 {
                terms.remove(0)
            } else {
                // Four terms a line: lines stay under 100 columns.
                let w = format!("ovf{k}_or_s{s}");
                let lines: Vec<String> = terms.chunks(4).map(|c| c.join(" | ")).collect();
                self.body.push(format!(
                    "wire {w} =
    {};",
                    lines.join("\n    | ")
                ));
                w
            });
        }
        acc.expect("the last stage is reached")
    }

    /// The stage in which quantization `node`'s overflow bit is computed
    /// (None: it cannot overflow, or is not built).
    fn ovf_first(&self, node: usize) -> Option<u32> {
        self.ovf_at
            .keys()
            .filter(|(m, _)| *m == node)
            .map(|&(_, s)| s)
            .min()
    }
}

#[cfg(test)]
mod tests {
    use crate::datapath::{Datapath, Trace};
    use crate::emit::{sat, test_design};

    /// The flip-flops named as overflow flags in `v`: one per `reg`
    /// declaration whose name has `ovf`.
    fn flag_regs(v: &str) -> Vec<String> {
        v.lines()
            .filter_map(|l| l.trim().strip_prefix("reg"))
            .filter_map(|l| l.split_whitespace().last())
            .map(|n| n.trim_end_matches(';').to_string())
            .filter(|n| n.contains("ovf"))
            .collect()
    }

    /// A chain of saturating quantizations, three with stage id `t.sum`
    /// (each can overflow: a sum of two 8-bit values back into 8 bits) and
    /// one `t.wide` that cannot (8 bits into 12): the flag of `t.sum` is one
    /// running register per stage from the stage after its first
    /// quantizer, the three quantizers' bits each registered once, and
    /// `t.wide` has no flag register at all.
    #[test]
    fn one_running_flag_per_stage_id_per_stage_and_none_that_cannot_be_set() {
        let mut t = Trace::new();
        let a = t.input_named("a", &sat("t.in", 8));
        let b = t.input_named("b", &sat("t.in", 8));
        let w = t.quantize(a, &sat("t.wide", 12));
        let mut x = b;
        for _ in 0..3 {
            let s = t.add(x, a);
            x = t.quantize(s, &sat("t.sum", 8));
        }
        let y = t.add(x, w);
        let y = t.quantize(y, &sat("t.wide", 14));
        t.output("y", y);
        let e = crate::emit(&test_design(t)).expect("emits");
        let regs = flag_regs(&e.verilog);
        assert!(
            regs.iter().all(|r| !r.contains("t_wide")),
            "a flag that cannot be set is registered: {regs:?}"
        );
        // Per stage at most one running register of the flag, and each
        // quantizer's own bit registered once.
        let running: Vec<&String> = regs.iter().filter(|r| r.starts_with("ovf")).collect();
        let mut stages: Vec<&str> = running
            .iter()
            .filter_map(|r| r.rsplit("_s").next())
            .collect();
        let n = stages.len();
        stages.dedup();
        assert_eq!(
            stages.len(),
            n,
            "two running registers in one stage: {running:?}"
        );
        let own = regs.len() - running.len();
        assert_eq!(own, 3, "each quantizer's bit registered once: {regs:?}");
        assert!(running.len() < e.latency as usize, "{running:?}");
    }
}
