//! Overflow flags: each quantization's overflow bit is registered once
//! after its stage and ORed there into one running register per stage id,
//! which travels to `ovf_o`; never more than one register per stage id per
//! stage, and a flag that cannot be set (the value cannot leave its
//! format) is not registered at all.

use crate::*;

impl<'a> Emitter<'a> {
    pub(crate) fn ovf_at(&mut self, node: usize, stage: u32) -> String {
        let s0 = self.stage[node].expect("a quantization has a stage");
        if let Some(n) = self.ovf_at.get(&(node, stage)) {
            return n.clone();
        }
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
                .ovf_at
                .keys()
                .filter(|(m, _)| *m == n)
                .map(|&(_, s)| s)
                .min()
                .unwrap_or_else(|| self.stage[n].expect("a quantization has a stage"));
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
}
