//! Table reads: ROM functions in the source (full, or a quarter wave with
//! symmetry logic) read through a register, block RAM from
//! [`BLOCK_ROM_ENTRIES`] entries, and the double-buffered set-up ports'
//! bank selection.

use crate::*;

impl<'a> Emitter<'a> {
    /// The banked set-up group of a set-up input, if its group is banked.
    pub(crate) fn banked_group(&self, node: usize) -> Option<usize> {
        if !matches!(self.t.ops()[node], Op::Input(_)) {
            return None;
        }
        let g = self.groups[node];
        (0..self.banked.len()).find(|&k| g >> k & 1 == 1 && self.banked[k])
    }

    /// A banked set-up input as the item in `stage` sees it: bank 1 when
    /// the item's tag (`<group>_cur_q` at stage 0, `<group>_tag_q[s−1]`
    /// after) is 1, else bank 0. Reading it at `stage` makes the group's
    /// port wait for that stage (its drain).
    ///
    /// Pipelined for a target, a read at stage `s ≥ 1` is a register of
    /// stage `s` loaded from the banks as the item in stage `s − 1` sees
    /// them: the value then leaves a flip-flop, as a DSP block's operand
    /// register needs (a multiplexer in front of the multiplier keeps its
    /// operand registers in the fabric and the product combinational), and
    /// the port waits for stage `s − 1` only.
    pub(crate) fn bank_read(&mut self, node: usize, g: usize, stage: u32) -> String {
        if let Some(n) = self.bank_at.get(&(node, stage)) {
            return n.clone();
        }
        let registered = stage > 0 && self.timing.is_some();
        let read = if registered { stage - 1 } else { stage };
        self.drain[g] = self.drain[g].max(read);
        let field = self.name[node].trim_end_matches("_q").to_string();
        let group = self.group_names[g];
        let tag = if read == 0 {
            format!("{group}_cur_q")
        } else {
            format!("{group}_tag_q[{}]", read - 1)
        };
        let sym = self.t.sym(node);
        let mux = format!("{tag} ? {field}_b1_q : {field}_b0_q");
        let name = format!("{field}_bank_s{stage}");
        if registered {
            self.reg(stage, &name, sym.signed, sym.width, &mux);
        } else {
            self.body.push(format!(
                "wire {} {name} = {mux};",
                decl(sym.signed, sym.width)
            ));
        }
        self.bank_at.insert((node, stage), name.clone());
        name
    }

    pub(crate) fn rom(
        &mut self,
        entries: &[i128],
        base: &str,
        f: Format,
        addr_bits: u32,
    ) -> String {
        if let Some((_, n, _, _)) = self
            .roms
            .iter()
            .find(|(e, _, ff, _)| e == entries && *ff == f)
        {
            return n.clone();
        }
        let name = format!("{base}_rom");
        let mut t = String::new();
        // An array initialized once: simulators index it, synthesis reads
        // it as a ROM (its contents are the model's codes, in the source).
        let _ = writeln!(
            t,
            "// {name}: {} entries of {f}, the model's codes.",
            entries.len()
        );
        // Deep ROMs go to block RAM (their reads are registered straight
        // from the array); Yosys's cost model would otherwise build a ROM
        // read by six ports from logic.
        let _ = writeln!(
            t,
            "{}reg  {} {name} [0:{}];",
            if entries.len() >= BLOCK_ROM_ENTRIES {
                "(* rom_style = \"block\" *) "
            } else {
                ""
            },
            decl(f.signed(), f.width()),
            entries.len() - 1
        );
        t += "initial begin\n";
        for (i, &c) in entries.iter().enumerate() {
            let _ = writeln!(
                t,
                "  {name}[{i}] = {};",
                bits::sv(f.signed(), &bits::literal(f.width(), c))
            );
        }
        t += "end\n";
        let _ = addr_bits;
        self.rom_text.push(t);
        self.hw.rom_bits += entries.len() as u64 * u64::from(f.width());
        self.hw.roms.push(RomHw {
            name: name.clone(),
            entries: entries.len() as u64,
            width: f.width(),
            reads: 0,
            block: entries.len() >= BLOCK_ROM_ENTRIES,
        });
        self.roms
            .push((entries.to_vec(), name.clone(), f, addr_bits));
        name
    }

    /// One more read port of the ROM `name`.
    pub(crate) fn count_read(&mut self, name: &str) {
        if let Some(r) = self.hw.roms.iter_mut().find(|r| r.name == name) {
            r.reads += 1;
        }
    }

    /// A table read at stage `s`, registered into `s + 1`. With `late`,
    /// the raw entry and its quadrant bits are registered once more, into
    /// `s + 2`, before the quarter-turn choice and the sign (a period too
    /// short for the block RAM's clock-to-output and that logic).
    pub(crate) fn table_read(&mut self, i: usize, idx: &Val, tb: &Table, s: u32, late: bool) {
        let f = tb.out.format();
        let t = tb.index.width();
        let base = &self.name[i].clone();
        let ix = idx.slice(t - 1, 0);
        let value = match &tb.storage {
            None => {
                let rom = self.rom(&tb.codes, tb.name, f, t);
                self.count_read(&rom);
                format!("{rom}[{ix}]")
            }
            Some(q) => {
                // j = i + phase·quarter turn; quadrant h = j[t−1:t−2].
                let j = format!("{base}_j");
                let jexpr = if q.phase == 0 {
                    ix.clone()
                } else {
                    self.hw.adders.push(2);
                    format!(
                        "{{{} + 2'd{}, {}}}",
                        idx.slice(t - 1, t - 2),
                        q.phase,
                        idx.slice(t - 3, 0)
                    )
                };
                self.body.push(format!("wire [{}:0] {j} = {jexpr};", t - 1));
                let a = format!("{base}_a");
                // Odd quadrants read the mirror image: 2^(t−2) − r.
                self.body.push(format!(
                    "wire [{}:0] {a} = {j}[{}] ? ({} - {{1'b0, {j}[{}:0]}}) : {{1'b0, {j}[{}:0]}};",
                    t - 2,
                    t - 2,
                    bits::literal(t - 1, 1i128 << (t - 2)),
                    t - 3,
                    t - 3
                ));
                self.hw.adders.push(t - 1);
                // The ROM holds the first 2^(t−2) entries, a power of two a
                // block RAM holds exactly; the quarter-turn entry (address
                // 2^(t−2), the only one with that bit set) is a constant.
                // The read is registered straight from the ROM, so synthesis
                // can map it to a block RAM's registered read port; the
                // quarter-turn choice and the sign are applied after that
                // register, in the next stage, by the reading operation.
                let depth = 1usize << (t - 2);
                let rom = self.rom(&q.entries[..depth], "quarter", f, t - 2);
                self.count_read(&rom);
                let raw = format!("{base}_raw");
                self.reg(
                    s + 1,
                    &raw,
                    f.signed(),
                    f.width(),
                    &format!("{rom}[{a}[{}:0]]", t - 3),
                );
                let top = format!("{base}_top");
                self.reg(s + 1, &top, false, 1, &format!("{a}[{}]", t - 2));
                let neg = format!("{base}_neg_q");
                self.reg(s + 1, &neg, false, 1, &format!("{j}[{}]", t - 1));
                let (raw, top, neg, so) = if late {
                    let (r2, t2, n2) = (
                        format!("{raw}_s{}", s + 2),
                        format!("{top}_s{}", s + 2),
                        format!("{neg}_s{}", s + 2),
                    );
                    self.reg(s + 2, &r2, f.signed(), f.width(), &raw);
                    self.reg(s + 2, &t2, false, 1, &top);
                    self.reg(s + 2, &n2, false, 1, &neg);
                    (r2, t2, n2, s + 2)
                } else {
                    (raw, top, neg, s + 1)
                };
                let v = format!("{base}_v");
                self.body.push(format!(
                    "wire {} {v} = {top} ? {} : {raw};",
                    decl(f.signed(), f.width()),
                    bits::sv(f.signed(), &bits::literal(f.width(), q.entries[depth]))
                ));
                // Negated in one more bit, then back into the entry format.
                let n = format!("{base}_n");
                let vv = Val {
                    expr: v.clone(),
                    width: f.width(),
                    signed: f.signed(),
                    frac: f.frac(),
                };
                self.body.push(format!(
                    "wire signed [{}:0] {n} = {};",
                    f.width(),
                    bits::sv(
                        true,
                        &format!(
                            "{} - {}",
                            bits::literal(f.width() + 1, 0),
                            bits::align(&vv, 0, f.width() + 1)
                        )
                    )
                ));
                self.hw.adders.push(f.width() + 1);
                let nv = Val {
                    expr: n,
                    width: f.width() + 1,
                    signed: true,
                    frac: f.frac(),
                };
                let ny = format!("{base}_nv");
                let qz = bits::quantize(
                    &nv,
                    &format!("{base}_neg"),
                    &ny,
                    &format!("unused_{base}_novf"),
                    f.width(),
                    f.signed(),
                    f.frac(),
                    Rounding::Trunc,
                    tb.out.overflow(),
                );
                self.hw.check_bits += u64::from(qz.check_bits);
                self.hw.saturate_bits += u64::from(qz.saturate_bits);
                // The negation's choice below.
                self.hw.select_bits += u64::from(f.width());
                self.body.extend(qz.lines);
                let out = base.clone();
                self.body.push(format!(
                    "wire {} {out} = {};",
                    decl(f.signed(), f.width()),
                    bits::sv(f.signed(), &format!("{neg} ? {ny} : {v}"))
                ));
                self.stage[i] = Some(so);
                self.at.insert((i, so), out);
                self.hw.table_reads += 1;
                return;
            }
        };
        // Registered read.
        let out = base.clone();
        self.reg(s + 1, &out, f.signed(), f.width(), &value);
        self.at.insert((i, s + 1), out);
        self.hw.table_reads += 1;
    }
}

/// A double-buffered set-up port `n` whose banks are read up to stage
/// `w` ([`SetupGroup::banked`]): the banks, the current bank `<n>_cur_q`
/// (the one an item accepted now reads), one tag bit per stage 1..`w`
/// (the bank of the item there) and the registered ready. A record loads
/// the other bank and makes it current; it is accepted while no item in
/// stages 1..`w` reads that bank, so an item accepted in the same cycle
/// keeps the old bank, and the ready is the same test on the next cycle's
/// state, held in a register (no path from an input port to it). Returns
/// the text and the flip-flops besides the banks.
pub(crate) fn banked_port(
    n: &str,
    doc: &str,
    w: u32,
    regs: &[(String, String, Format)],
    fifo: bool,
) -> (String, u64) {
    let mut t = comment(
        "  // ",
        &format!(
            "Set-up port `{n}`: {doc}. Two banks: a record loads the bank the items in stages 1..{w} do not read and makes it the current one; each item carries the bank it read (a tag per stage), so the next record loads while the last one's items are in flight. Ready is a register."
        ),
    );
    let _ = writeln!(t, "  reg  {n}_cur_q;");
    let _ = writeln!(t, "  reg  {n}_ready_q;");
    let _ = writeln!(t, "  wire {n}_load = {n}_valid_i & {n}_ready_q;");
    let _ = writeln!(t, "  wire {n}_cur_d = {n}_cur_q ^ {n}_load;");
    let _ = writeln!(t, "  assign {n}_ready_o = {n}_ready_q;");
    let mut extra = 2;
    if w == 0 {
        // Only stage 0 reads the banks: the other one is always free.
        t += "  always @(posedge clk_i or negedge rst_ni) begin
";
        let _ = writeln!(
            t,
            "    if (!rst_ni) begin
      {n}_cur_q <= 1'b0;
      {n}_ready_q <= 1'b1;
    end else begin
      {n}_cur_q <= {n}_cur_d;
      {n}_ready_q <= 1'b1;
    end"
        );
        t += "  end
";
    } else {
        extra += u64::from(w);
        let (step, shift_in) = if fifo {
            ("1'b1", "in_xfer")
        } else {
            ("en", "in_take")
        };
        let shift = |reg: &str, bit: &str| {
            if w == 1 {
                bit.to_string()
            } else {
                format!("{{{reg}[{}:0], {bit}}}", w - 2)
            }
        };
        let _ = writeln!(t, "  reg  [{}:0] {n}_tag_q;", w - 1);
        let _ = writeln!(
            t,
            "  wire [{}:0] {n}_tag_d = {step} ? {} : {n}_tag_q;",
            w - 1,
            shift(&format!("{n}_tag_q"), &format!("{n}_cur_q"))
        );
        let _ = writeln!(
            t,
            "  wire [{}:0] {n}_busy_d = {step} ? {} : valid_q[{}:0];",
            w - 1,
            shift("valid_q", shift_in),
            w - 1
        );
        t += "  always @(posedge clk_i or negedge rst_ni) begin
";
        let _ = writeln!(
            t,
            "    if (!rst_ni) begin
      {n}_cur_q <= 1'b0;
      {n}_tag_q <= {w}'b0;
      {n}_ready_q <= 1'b1;
    end else begin
      {n}_cur_q <= {n}_cur_d;
      {n}_tag_q <= {n}_tag_d;"
        );
        let _ = writeln!(
            t,
            "      {n}_ready_q <= ~|({n}_busy_d & ({n}_tag_d ^ {{{w}{{{n}_cur_d}}}}));
    end"
        );
        t += "  end
";
    }
    for (q, _, f) in regs {
        let base = q.trim_end_matches("_q");
        for b in 0..2 {
            let _ = writeln!(t, "  reg  {} {base}_b{b}_q;", decl(f.signed(), f.width()));
        }
    }
    if !regs.is_empty() {
        t += "  always @(posedge clk_i) begin
";
        let _ = writeln!(t, "    if ({n}_load & {n}_cur_q) begin");
        for (q, i, _) in regs {
            let _ = writeln!(t, "      {}_b0_q <= {i};", q.trim_end_matches("_q"));
        }
        let _ = writeln!(
            t,
            "    end
    if ({n}_load & ~{n}_cur_q) begin"
        );
        for (q, i, _) in regs {
            let _ = writeln!(t, "      {}_b1_q <= {i};", q.trim_end_matches("_q"));
        }
        t += "    end
  end
";
    }
    t += "
";
    (t, extra)
}

#[cfg(test)]
mod tests {
    use crate::datapath::{Datapath, Table, Trace};
    use crate::emit::{sat, test_design};
    use crate::format::Format;

    fn negate_half(x: f64) -> f64 {
        0.75 - 1.5 * x
    }

    /// The ROM the tables pass writes holds the table's codes, each at its
    /// index, in two's complement of the entry width: decoded here from the
    /// Verilog text and compared with the codes `Table::build` computed
    /// from the tabulated function. One table read counts one read port.
    #[test]
    fn the_rom_holds_every_code_at_its_index() {
        let index = Format::new(false, 4, 4).expect("U0F4");
        let out = crate::quantize::Quant::new(
            "t.entry",
            Format::new(true, 8, 6).expect("I2F6"),
            crate::quantize::Rounding::HalfEven,
            crate::quantize::Overflow::Saturate,
        );
        let tb = Table::build("ramp", index, out, negate_half).expect("a table");
        let mut t = Trace::new();
        let i = t.input_named(
            "i",
            &crate::quantize::Quant::new(
                "t.in",
                index,
                crate::quantize::Rounding::Trunc,
                crate::quantize::Overflow::Wrap,
            ),
        );
        let v = t.table(&tb, i);
        let y = t.quantize(v, &sat("t.out", 8));
        t.output("y", y);
        let e = crate::emit(&test_design(t)).expect("emits");
        let mut seen = 0;
        for line in e.verilog.lines() {
            let Some(rest) = line.trim().strip_prefix("ramp_rom[") else {
                continue;
            };
            let (k, lit) = rest.split_once("] = ").expect("an entry line");
            let k: usize = k.parse().expect("an index");
            // `$signed(8'h30);` or `8'h30;`
            let hex = lit.trim_end_matches(';').trim_end_matches(')');
            let hex = hex.rsplit('h').next().expect("a literal");
            let raw = i128::from_str_radix(hex, 16).expect("hex");
            let code = if raw >= 128 { raw - 256 } else { raw };
            // The closed form, independently of the table's own codes.
            let want = (negate_half(k as f64 / 16.0) * 64.0).round_ties_even();
            assert_eq!(code as f64, want.clamp(-128.0, 127.0), "entry {k}: {line}");
            seen += 1;
        }
        assert_eq!(seen, 16, "{}", e.verilog);
        let rom = e.hardware.roms.iter().find(|r| r.name == "ramp_rom");
        let rom = rom.expect("the ROM is counted");
        assert_eq!((rom.entries, rom.width, rom.reads), (16, 8, 1));
    }
}
