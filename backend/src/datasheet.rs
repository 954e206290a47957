//! A datasheet per emitted module (`fxshade rtl <unit> --datasheet`): its
//! ports with their formats, its handshakes, reset, latency and throughput,
//! a timing diagram *simulated* on the module itself (the stimulus of
//! [`stimulus`], run by the CLI on Icarus, parsed by [`Wave::parse`]), and a
//! constraints file for the configured target ([`constraints`]).

use std::fmt::Write as _;

use super::timing::{Handshake, Pipelining, Target};
use super::Emitted;

/// One handshake of the diagram's stimulus, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Event {
    /// An item on `valid_i`/`ready_o`.
    Item,
    /// A record on set-up port `k` (`<name>_valid_i`/`<name>_ready_o`).
    Setup(usize),
}

fn events(e: &Emitted) -> Vec<Event> {
    let frame = e.setup.iter().position(|g| g.name == "frame");
    let tri = e.setup.iter().position(|g| g.name == "tri");
    let mut v = Vec::new();
    v.extend(frame.map(Event::Setup));
    v.extend(tri.map(Event::Setup));
    v.extend([Event::Item; 3]);
    v.extend(tri.map(Event::Setup));
    v.extend([Event::Item; 2]);
    v
}

/// The control signals the diagram shows, in order.
pub fn signals(e: &Emitted) -> Vec<String> {
    let mut s = vec!["rst_ni".to_string()];
    for g in &e.setup {
        s.push(format!("{}_valid_i", g.name));
        s.push(format!("{}_ready_o", g.name));
    }
    for n in ["valid_i", "ready_o", "valid_o", "ready_i"] {
        s.push(n.to_string());
    }
    s
}

/// A testbench that drives the module through the stimulus of the
/// diagram and prints every control signal once a cycle (at the rising
/// edge, the values it samples): reset for two cycles;
/// the frame and triangle records (a module with set-up ports); three
/// items; the next triangle; two items; every data input 0; and `ready_i`
/// low for two cycles after the first output transfer. Each record is
/// offered until taken, one at a time.
pub fn stimulus(e: &Emitted) -> String {
    let ev = events(e);
    let cycles = u32::try_from(ev.len()).unwrap_or(u32::MAX / 4) * 3 + e.latency + 16;
    let m = &e.module;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "// {m}_datasheet_tb.v: the stimulus of the datasheet's timing diagram.\n`timescale 1ns/1ps\n`default_nettype none\nmodule {m}_datasheet_tb;"
    );
    // The reset falls at 1 ns, an edge the asynchronous reset sees.
    t += "  reg clk_i = 1'b0;\n  reg rst_ni = 1'b1;\n  integer cycle = 0;\n";
    let _ = writeln!(
        t,
        "  reg  [7:0] step = 8'd0;\n  reg  [7:0] outs = 8'd0;\n  reg  [1:0] held = 2'd0;"
    );
    t += "  wire ready_i = ~(outs == 8'd1 && held != 2'd2);\n";
    t += "  wire valid_o, ready_o;\n";
    let mut conns: Vec<String> = vec![
        ".clk_i(clk_i)".into(),
        ".rst_ni(rst_ni)".into(),
        ".valid_i(valid_i)".into(),
        ".ready_o(ready_o)".into(),
        ".valid_o(valid_o)".into(),
        ".ready_i(ready_i)".into(),
    ];
    for g in &e.setup {
        let n = g.name;
        let _ = writeln!(t, "  wire {n}_valid_i, {n}_ready_o;");
        conns.push(format!(".{n}_valid_i({n}_valid_i)"));
        conns.push(format!(".{n}_ready_o({n}_ready_o)"));
    }
    for f in &e.inputs {
        conns.push(format!(".{}_i({}'d0)", f.name, f.format.width()));
    }
    for f in &e.outputs {
        let w = f.format.width();
        let _ = writeln!(t, "  wire [{}:0] {}_o;", w - 1, f.name);
        conns.push(format!(".{n}_o({n}_o)", n = f.name));
    }
    // The script: which handshake is offered at each step.
    let offered = |want: Event| -> String {
        let steps: Vec<String> = ev
            .iter()
            .enumerate()
            .filter(|(_, x)| **x == want)
            .map(|(k, _)| format!("step == 8'd{k}"))
            .collect();
        if steps.is_empty() {
            "1'b0".into()
        } else {
            format!("rst_ni & ({})", steps.join(" | "))
        }
    };
    let _ = writeln!(t, "  wire valid_i = {};", offered(Event::Item));
    let mut xfer = vec!["(valid_i & ready_o)".to_string()];
    for (k, g) in e.setup.iter().enumerate() {
        let _ = writeln!(
            t,
            "  assign {}_valid_i = {};",
            g.name,
            offered(Event::Setup(k))
        );
        xfer.push(format!("({n}_valid_i & {n}_ready_o)", n = g.name));
    }
    let _ = writeln!(t, "  {m} dut (\n    {}\n  );", conns.join(",\n    "));
    t += "  always #5 clk_i = ~clk_i;\n";
    t += "  always @(posedge clk_i) begin\n";
    t += "    cycle <= cycle + 1;\n";
    let _ = writeln!(t, "    if ({}) step <= step + 8'd1;", xfer.join(" | "));
    t += "    if (valid_o & ready_i) outs <= outs + 8'd1;\n";
    t += "    if (outs == 8'd1 && held != 2'd2) held <= held + 2'd1;\n";
    t += "  end\n";
    let names = signals(e);
    let _ = writeln!(
        t,
        "  always @(posedge clk_i) $display(\"wave %0d {}\", cycle, {});",
        vec!["%b"; names.len()].join(" "),
        names.join(", ")
    );
    let _ = writeln!(
        t,
        "  initial begin\n    #1 rst_ni = 1'b0;\n    repeat (2) @(negedge clk_i);\n    rst_ni = 1'b1;\n    repeat ({cycles}) @(negedge clk_i);\n    $finish;\n  end\nendmodule\n`default_nettype wire"
    );
    super::wrap::wrap_verilog(&t, super::wrap::WIDTH)
}

/// The simulated control signals, one value a cycle.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Wave {
    /// Signal names, in [`signals`] order.
    pub names: Vec<String>,
    /// Per signal, its value in each cycle.
    pub values: Vec<Vec<bool>>,
}

impl Wave {
    /// The `wave <cycle> <bits…>` lines of the [`stimulus`]'s output.
    pub fn parse(names: Vec<String>, out: &str) -> Option<Wave> {
        let mut values = vec![Vec::new(); names.len()];
        for l in out.lines().filter_map(|l| l.strip_prefix("wave ")) {
            let f: Vec<&str> = l.split_whitespace().collect();
            if f.len() != names.len() + 1 {
                return None;
            }
            for (k, b) in f[1..].iter().enumerate() {
                values[k].push(match *b {
                    "1" => true,
                    "0" => false,
                    _ => return None,
                });
            }
        }
        (!values[0].is_empty()).then_some(Wave { names, values })
    }

    /// A signal's values.
    pub fn of(&self, name: &str) -> Option<&[bool]> {
        let k = self.names.iter().position(|n| n == name)?;
        Some(&self.values[k])
    }

    fn cycles(&self) -> usize {
        self.values[0].len()
    }

    /// Runs of eight or more cycles in which no signal changes, as
    /// `(first, last)` (drawn as one `~` column).
    fn quiet(&self) -> Vec<(usize, usize)> {
        let n = self.cycles();
        let same = |c: usize| self.values.iter().all(|v| v[c] == v[c - 1]);
        let mut out = Vec::new();
        let mut c = 1;
        while c < n {
            if same(c) {
                let a = c;
                while c < n && same(c) {
                    c += 1;
                }
                if c - a >= 8 {
                    out.push((a + 1, c - 2));
                }
            } else {
                c += 1;
            }
        }
        out
    }

    /// The diagram in ASCII: a column a cycle, `#` high, `_` low, `~` for a
    /// stretch in which nothing changes (named under the diagram).
    pub fn ascii(&self) -> String {
        let quiet = self.quiet();
        let shown: Vec<Option<usize>> = {
            let mut v = Vec::new();
            let mut c = 0;
            while c < self.cycles() {
                if let Some(&(a, b)) = quiet.iter().find(|(a, _)| *a == c) {
                    v.push(None);
                    c = b + 1;
                    let _ = a;
                } else {
                    v.push(Some(c));
                    c += 1;
                }
            }
            v
        };
        let w = self.names.iter().map(|n| n.len()).max().unwrap_or(0);
        let mut t = String::new();
        let ruler: String = shown
            .iter()
            .map(|c| match c {
                Some(c) if c % 5 == 0 => u32::try_from(c / 5 % 10)
                    .ok()
                    .and_then(|d| char::from_digit(d, 10))
                    .unwrap_or('?'),
                Some(_) => '.',
                None => '~',
            })
            .collect();
        let _ = writeln!(t, "{:w$}  {ruler}", "cycle/5");
        for (n, v) in self.names.iter().zip(&self.values) {
            let row: String = shown
                .iter()
                .map(|c| match c {
                    Some(c) if v[*c] => '#',
                    Some(_) => '_',
                    None => '~',
                })
                .collect();
            let _ = writeln!(t, "{n:w$}  {row}");
        }
        for (a, b) in quiet {
            let _ = writeln!(t, "~ : cycles {a}..{b}, no control signal changes");
        }
        t
    }

    /// The same as WaveDrom JSON (`{"signal": [{"name", "wave"}]}`, `|` for
    /// a quiet stretch).
    ///
    /// # Panics
    ///
    /// Never: the JSON is built from strings.
    pub fn wavedrom(&self) -> String {
        let quiet = self.quiet();
        let mut sig = Vec::new();
        for (n, v) in self.names.iter().zip(&self.values) {
            let mut wave = String::new();
            let mut last: Option<bool> = None;
            let mut c = 0;
            while c < v.len() {
                if let Some(&(_, b)) = quiet.iter().find(|(a, _)| *a == c) {
                    wave.push('|');
                    c = b + 1;
                    continue;
                }
                wave.push(match (last, v[c]) {
                    (Some(l), x) if l == x => '.',
                    (_, true) => '1',
                    (_, false) => '0',
                });
                last = Some(v[c]);
                c += 1;
            }
            sig.push(serde_json::json!({"name": n, "wave": wave}));
        }
        serde_json::to_string_pretty(&serde_json::json!({
            "signal": sig,
            "head": {"text": "simulated on the emitted module (Icarus), one column a cycle"}
        }))
        .expect("plain JSON")
    }
}

/// The constraints file for the target: its name suffix and text, the
/// family's [`Family::constraint`](crate::targets::Family::constraint)
/// after a header (ECP5: an `.lpf` `FREQUENCY PORT`; iCE40: a `.pcf`
/// `set_frequency`, which nextpnr-ice40 reads; any other: an SDC
/// `create_clock`). Every path of an emitted module runs from a register
/// to the next stage's register in one cycle (set-up registers included:
/// an item reads them in the cycle it is in the stage), so there are no
/// multicycle or false paths to declare.
pub fn constraints(module: &str, target: Target, clock_ns: f64) -> (&'static str, String) {
    let mhz = 1000.0 / clock_ns;
    let head = format!(
        "# {module}: clock constraint for {} at {clock_ns} ns ({mhz:.2} MHz), written by fxshade.\n# Every path is single-cycle: no multicycle or false paths.\n",
        target.name(),
    );
    let (ext, line) = target.constraint(clock_ns);
    (ext, format!("{head}{line}"))
}

/// One row of a datasheet's resource table: the module synthesized for a
/// target by Yosys (no place and route), the synthesis harness's own
/// flip-flops left out.
#[derive(Clone, Debug, PartialEq)]
pub struct Resources {
    /// The target's name (`ecp5`, `ice40-up5k`, ...).
    pub target: String,
    /// The device the flow synthesizes for.
    pub device: String,
    /// LUT cells (LUT4 on iCE40 and ECP5, LUT1-6 on xc7; carry cells
    /// apart).
    pub luts: u64,
    /// Carry cells (ECP5 `CCU2C`: two LUTs each; iCE40 `SB_CARRY`).
    pub carry: u64,
    /// LUT RAM cells (ECP5 `TRELLIS_DPR16X4`).
    pub lut_ram: u64,
    /// The module's flip-flops in the fabric (after moving product
    /// registers into DSP blocks on ECP5).
    pub ff: u64,
    /// DSP blocks.
    pub dsp: u64,
    /// Block RAMs.
    pub bram: u64,
}

/// The datasheet in Markdown; `resources`: the resource table's rows
/// (none: the table says how to get it).
#[allow(clippy::too_many_arguments)]
pub fn markdown(
    e: &Emitted,
    unit: &str,
    variant: &str,
    handshake: Handshake,
    target: Target,
    clock_ns: f64,
    wave: &Wave,
    resources: &[Resources],
) -> String {
    let m = &e.module;
    let mut t = String::new();
    let _ = writeln!(t, "# `{m}`: datasheet\n");
    let _ = writeln!(
        t,
        "Unit `{unit}` ({variant}), generated by fxshade {}. The module's header\n(`{m}.v`) names the configuration and its hash.\n",
        env!("CARGO_PKG_VERSION")
    );
    t += "## Summary\n\n| | |\n|---|---|\n";
    let pipe = match e.pipelining {
        Pipelining::Compact => {
            "compact (a register after every quantization and table read)".into()
        }
        Pipelining::Target { target, clock_ns } => format!(
            "for {} at {clock_ns} ns{}",
            target.name(),
            e.predicted_ns.map_or(String::new(), |p| format!(
                " (delay model: {:.1} MHz)",
                1000.0 / p
            ))
        ),
    };
    let _ = writeln!(t, "| pipelining | {pipe} |");
    let _ = writeln!(t, "| latency | {} cycles from an item's transfer on `valid_i`/`ready_o` to its result on `valid_o` (no stalls) |", e.latency);
    let _ = writeln!(
        t,
        "| throughput | one item per clock while `ready_i` is high{} |",
        if e.setup.iter().any(|g| g.banks == 2) {
            "; a triangle record costs no cycle when the triangle port's other bank is free"
        } else if e.setup.is_empty() {
            ""
        } else {
            "; a set-up record waits for the stages reading its registers to drain"
        }
    );
    let _ = writeln!(t, "| handshake | {} |", match handshake {
        Handshake::Stall => "stall: one global stall, a register: the stages stop while the two-entry output buffer is full; `ready_o`, `valid_o` and every output port are registers (no path from any input port to any output port)",
        Handshake::Fifo => "fifo: the pipeline never stalls and ends in an output FIFO with a head register; `ready_o`, `valid_o` and every output port are registers (no path from any input port to any output port)",
    });
    let _ = writeln!(t, "| flip-flops (emitter's count) | {} |", e.hardware.flops);
    let _ = writeln!(t, "| multipliers | {} |", e.hardware.muls.len());
    let _ = writeln!(
        t,
        "| constraints | `{m}.{}`: {} at {clock_ns} ns ({:.2} MHz) |\n",
        constraints(m, target, clock_ns).0,
        target.name(),
        1000.0 / clock_ns
    );
    t += "## Resources\n\n";
    if resources.is_empty() {
        t += "No table: `fxshade rtl --datasheet --resources TARGET[,TARGET...]` synthesizes the module for each target (Yosys) and lists what it uses; `fxshade synth` adds place and route and Fmax.\n\n";
    } else {
        t += "Synthesized by Yosys for each target, without place and route (`fxshade synth` adds them and the Fmax); flip-flops are the module's own in the fabric (on ECP5 after the product registers moved into the DSP blocks).\n\n";
        t += "| target | device | LUTs | carry cells | LUT RAM | flip-flops | DSP | block RAM |\n|---|---|---|---|---|---|---|---|\n";
        for r in resources {
            let _ = writeln!(
                t,
                "| {} | {} | {} | {} | {} | {} | {} | {} |",
                r.target, r.device, r.luts, r.carry, r.lut_ram, r.ff, r.dsp, r.bram
            );
        }
        t += "\n";
    }
    t += "## Ports\n\n| port | direction | bits | format | loaded by | meaning |\n|---|---|---|---|---|---|\n";
    let _ = writeln!(t, "| `clk_i` | in | 1 | | | clock, rising edge |");
    let _ = writeln!(
        t,
        "| `rst_ni` | in | 1 | | | asynchronous reset, active low |"
    );
    let _ = writeln!(t, "| `valid_i` | in | 1 | | | an item is offered |");
    let _ = writeln!(
        t,
        "| `ready_o` | out | 1 | | | the item is taken when `valid_i & ready_o` at a rising edge |"
    );
    for g in &e.setup {
        let _ = writeln!(
            t,
            "| `{n}_valid_i` | in | 1 | | | a `{n}` record is offered ({}) |",
            g.doc,
            n = g.name
        );
        let _ = writeln!(t, "| `{n}_ready_o` | out | 1 | | | the record is taken when `{n}_valid_i & {n}_ready_o` |", n = g.name);
    }
    for f in &e.inputs {
        let by = e
            .setup
            .iter()
            .find(|g| g.fields.contains(&f.name))
            .map_or("item".to_string(), |g| format!("`{}` port", g.name));
        let _ = writeln!(
            t,
            "| `{}_i` | in | {} | {} | {by} | |",
            f.name,
            f.format.width(),
            f.format
        );
    }
    let _ = writeln!(t, "| `valid_o` | out | 1 | | | a result is offered |");
    let _ = writeln!(
        t,
        "| `ready_i` | in | 1 | | | the result is taken when `valid_o & ready_i` |"
    );
    for f in &e.outputs {
        let meaning = if f.name == "ovf" {
            format!(
                "overflow flags, one per stage id, bit {} first: {}",
                e.flags.len().saturating_sub(1),
                e.flags.join(", ")
            )
        } else {
            String::new()
        };
        let _ = writeln!(
            t,
            "| `{}_o` | out | {} | {} | | {meaning} |",
            f.name,
            f.format.width(),
            f.format
        );
    }
    t += "\n## Handshakes\n\n";
    t += "Items: valid/ready on both sides. An item offered stays offered, unchanged, until taken; a result offered stays offered, unchanged, until taken. Results leave in the order items entered, one per item.\n\n";
    for g in &e.setup {
        if g.banks == 2 {
            let _ = writeln!(t, "Set-up port `{n}` ({}): two banks. A record loads the bank that no item in stages 1..{} reads and becomes current; every item computes with the record current when it was taken (one taken in the same cycle as a record keeps the old one). `{n}_ready_o` is a register.\n", g.doc, g.drain, n = g.name);
        } else {
            let _ = writeln!(t, "Set-up port `{n}` ({}): one register a field. `{n}_ready_o` is a register: it rises the cycle after a record is offered, once stages 1..{} will be empty, and in that cycle the record is taken and no item is (`ready_o` low); every item computes with the record current when it was taken.\n", g.doc, g.drain, n = g.name);
        }
    }
    if !e.setup.is_empty() {
        t += "Send a port's record before the first item that needs it; before the first record after reset the set-up registers hold no defined value.\n\n";
    }
    t += "## Reset\n\n`rst_ni` is asynchronous and active low. It clears the valid bits (and the FIFO's pointers, the set-up ports' state); the data registers have no reset and hold whatever they held, which no valid bit exposes. Release it synchronously to `clk_i` (a reset synchronizer in the integrating design) and offer nothing while it is low. After release the module takes items at once.\n\n";
    t += "## Timing diagram\n\nSimulated on this module (Icarus), one column a cycle, `#` high, `_` low: reset, the set-up records, items, the next triangle, and `ready_i` low for two cycles after the first result. WaveDrom source: `";
    let _ = writeln!(t, "{m}_wave.json`.\n\n```text\n{}```\n", wave.ascii());
    t
}
