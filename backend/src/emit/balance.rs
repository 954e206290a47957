//! Balancing: registers that carry a value from the stage it is computed
//! in to every later stage that reads it (`_q` registers and their `_d`
//! next values), and the set-up values read in a stage (banked set-up
//! inputs carried with the item, selections of constants built where they
//! are read).

use crate::*;

impl<'a> Emitter<'a> {
    pub(crate) fn reg(&mut self, stage: u32, name: &str, signed: bool, width: u32, src: &str) {
        self.body
            .push(format!("reg  {} {name};", decl(signed, width)));
        self.regs.push((stage, format!("{name} <= {src};")));
        self.hw.flops += u64::from(width);
    }

    /// [`Self::reg`] for a product's own operand register
    /// ([`Self::own_regs`]).
    pub(crate) fn own_reg(&mut self, stage: u32, name: &str, signed: bool, width: u32, src: &str) {
        self.body
            .push(format!("reg  {} {name};", decl(signed, width)));
        self.own_regs.push((stage, format!("{name} <= {src};")));
        self.hw.flops += u64::from(width);
    }

    /// The node's value at `stage` (balancing registers created on demand).
    pub(crate) fn value_at(&mut self, node: usize, stage: u32) -> String {
        if self.stage[node].is_some_and(|s0| stage >= s0) && !self.lazy[node] {
            let r = &mut self.first_read[node];
            *r = Some(r.map_or(stage, |x| x.min(stage)));
        }
        self.carry_to(node, stage)
    }

    /// [`Self::value_at`] without recording the read: the balancing
    /// registers' own chain.
    pub(crate) fn carry_to(&mut self, node: usize, stage: u32) -> String {
        if self.lazy[node] {
            return self.lazy_select(node, stage);
        }
        let Some(s0) = self.stage[node] else {
            if let Some(g) = self.banked_group(node) {
                return self.bank_read(node, g, stage);
            }
            let g = self.groups[node];
            for (k, d) in self.drain.iter_mut().enumerate() {
                if g >> k & 1 == 1 {
                    *d = (*d).max(stage);
                }
            }
            return self.name[node].clone();
        };
        assert!(stage >= s0, "values flow forward");
        if let Some(n) = self.at.get(&(node, stage)) {
            return n.clone();
        }
        let prev = self.carry_to(node, stage - 1);
        let sym = self.t.sym(node);
        let name = format!("{}_s{stage}", self.name[node]);
        self.reg(stage, &name, sym.signed, sym.width, &prev);
        self.at.insert((node, stage), name.clone());
        name
    }

    /// A banked set-up input taken from its bank at stage 0 and carried
    /// with the item to `stage` (one register a stage).
    pub(crate) fn carried(&mut self, node: usize, stage: u32) -> String {
        if stage == 0 {
            let g = self.banked_group(node).expect("a banked set-up input");
            return self.bank_read(node, g, 0);
        }
        if let Some(n) = self.carried.get(&(node, stage)) {
            return n.clone();
        }
        let prev = self.carried(node, stage - 1);
        let field = self.name[node].trim_end_matches("_q").to_string();
        let sym = self.t.sym(node);
        let name = format!("{field}_c_s{stage}");
        self.reg(stage, &name, sym.signed, sym.width, &prev);
        self.carried.insert((node, stage), name.clone());
        name
    }

    /// A selection of constants by a banked set-up input, read at `stage`:
    /// the selector is carried with the item (a few bits instead of the
    /// selected value's width, and no bank for later stages to wait for),
    /// and, pipelined for a target, the multiplexer sits in the stage
    /// before and its result is a register of `stage` (compact, or at stage
    /// 0, it is combinational in `stage`). So the normalizer's coefficient
    /// set costs one multiplexer (and register) per reading stage, and for
    /// a target no path runs from a set-up register through the
    /// multiplexer into a multiplier.
    pub(crate) fn lazy_select(&mut self, node: usize, stage: u32) -> String {
        if let Some(n) = self.lazy_at.get(&(node, stage)) {
            return n.clone();
        }
        let Op::Select(sel, opts) = self.t.ops()[node].clone() else {
            unreachable!("a lazy node is a selection")
        };
        let sym = self.t.sym(node);
        // Pipelined for a target, the multiplexer gets a stage of its own
        // (it is off the multiplier's path); compact, it sits in the
        // reading stage.
        let registered = stage > 0 && self.timing.is_some();
        let at = if registered { stage - 1 } else { stage };
        let vs = self.carried(sel.node(), at);
        let base = self.name[node].clone();
        let mux = format!("{base}_m{at}");
        self.case_select(node, &mux, &vs, sel.sym().width, &opts, at);
        let name = if !registered {
            mux
        } else {
            let r = format!("{base}_s{stage}");
            self.reg(stage, &r, sym.signed, sym.width, &mux);
            r
        };
        self.lazy_at.insert((node, stage), name.clone());
        name
    }

    /// The multiplexer of selection `node` as a `case` on `sel` (`width`
    /// bits) into `reg name`, its options read at `stage` and aligned to
    /// the node's format; option 0 past the last.
    pub(crate) fn case_select(
        &mut self,
        node: usize,
        name: &str,
        sel: &str,
        width: u32,
        opts: &[TV],
        stage: u32,
    ) {
        let sym = self.t.sym(node);
        let vals: Vec<String> = opts
            .iter()
            .map(|o| {
                let v = self.operand(o, stage);
                bits::sv(
                    sym.signed,
                    &bits::align(&v, shift_up(sym.frac, v.frac), sym.width),
                )
            })
            .collect();
        self.hw.selects += 1;
        self.hw.select_bits += u64::from(sym.width) * (vals.len() as u64).saturating_sub(1);
        self.body
            .push(format!("reg  {} {name};", decl(sym.signed, sym.width)));
        let mut t = "always @* begin\n".to_string();
        let _ = writeln!(t, "  case ({sel})");
        for (k, v) in vals.iter().enumerate().skip(1) {
            let _ = writeln!(t, "    {width}'d{k}: {name} = {v};");
        }
        let _ = writeln!(t, "    default: {name} = {};", vals[0]);
        t += "  endcase\nend";
        self.body.push(t);
    }
}

#[cfg(test)]
mod tests {
    use crate::datapath::{Datapath, Trace};
    use crate::emit::{sat, test_design};

    /// `y1 = Q(a + b)`, `y_{k+1} = Q(y_k + b)` for `depth` quantizations,
    /// then `z = Q(y_depth + a)`: `a` is read at the input and again after
    /// `depth` registered stages.
    fn late_read(depth: usize) -> Trace {
        let mut t = Trace::new();
        let a = t.input_named("a", &sat("b.in", 8));
        let b = t.input_named("b", &sat("b.in", 8));
        let s = t.add(a, b);
        let mut y = t.quantize(s, &sat("b.y", 12));
        for _ in 1..depth {
            let s = t.add(y, b);
            y = t.quantize(s, &sat("b.y", 12));
        }
        let s = t.add(y, a);
        let z = t.quantize(s, &sat("b.z", 12));
        t.output("z", z);
        t
    }

    /// The balancing pass carries a value read `k` stages after it is
    /// made through exactly one register per stage it crosses (`a_i_s1_q`
    /// … `a_i_s<k>_q`, 8 bits each: the input's width), and the
    /// compact pipeline's latency is one stage per quantization (`depth`
    /// of `y`, one of `z`) and one for the output register.
    #[test]
    fn a_late_read_is_carried_by_one_register_per_stage() {
        for depth in 1..=5usize {
            let e = crate::emit(&test_design(late_read(depth))).expect("emits");
            let carried: Vec<&str> = e
                .verilog
                .lines()
                .filter(|l| l.trim_start().starts_with("reg "))
                .filter(|l| l.contains(" a_i_s"))
                .collect();
            assert_eq!(carried.len(), depth, "depth {depth}:\n{}", e.verilog);
            for k in 1..=depth {
                let name = format!("a_i_s{k}_q;");
                assert!(
                    carried
                        .iter()
                        .any(|l| l.contains("[7:0]") && l.ends_with(&name)),
                    "no {name} at depth {depth}: {carried:?}"
                );
            }
            assert_eq!(e.latency as usize, depth + 1 + 1, "depth {depth}");
        }
    }
}
