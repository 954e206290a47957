//! The critical path of a placed design, read from nextpnr's JSON report
//! (`--report`, `critical_paths`), and mapped back to the emitted module's
//! signals, their trace nodes and stage ids; and the timing verdict of a
//! synthesis run against the clock asked for.
//!
//! nextpnr names a path as steps: `clk-to-q` of the launching register,
//! then for each net a `routing` step (with the net's name) and a `logic`
//! step through the cell it reaches, and a `setup` step into the capturing
//! register. The emitter names every signal stage-locally
//! (`Emitted::node_names`: `<stage id>_<k>`, `<stage id>_mul<k>`,
//! `<table>_<k>`, with suffixes such as `_s7` for the copy in stage 7),
//! and Yosys keeps those names on nets and derives cell names from them
//! (`normalize_d_mul0_SB_LUT4_O_23_LC`), so each step is given its node,
//! its operation and its stage id through the emitter's name map.

use fxshade_model::datapath::{Op, Trace};

/// One step of a critical path as nextpnr reports it.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Step {
    /// `clk-to-q`, `routing`, `logic` or `setup`.
    pub kind: String,
    /// The net routed (routing steps), else the cell passed through.
    pub name: String,
    /// Nanoseconds.
    pub delay_ns: f64,
}

/// The longest register-to-register path of one place-and-route run.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct CriticalPath {
    /// The seed whose report this is (the median seed's).
    pub seed: u64,
    /// The path's delay, ns (the sum of its steps).
    pub delay_ns: f64,
    /// Of which in cells (clock to output, logic, set-up).
    pub logic_ns: f64,
    /// Of which on wires.
    pub routing_ns: f64,
    /// The launching cell.
    pub from: String,
    /// The capturing cell.
    pub to: String,
    /// Every step, in order.
    pub steps: Vec<Step>,
    /// The emitted module's signals the path runs through, in order
    /// (filled in from the trace; not cached).
    #[serde(default)]
    pub signals: Vec<Signal>,
}

/// A signal of the emitted module on a critical path.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Signal {
    /// Its name in the emitted Verilog (Yosys's suffixes removed);
    /// `harness:<name>` for the synthesis harness's own registers.
    pub name: String,
    /// Its trace node, when it has one.
    pub node: Option<usize>,
    /// The operation of that node (`product`, `quantization`, …), or
    /// `input`, `set-up bank`, `control` (valid bits, tags, flags).
    pub op: String,
    /// The stage id of the node (its quantizer's, for a quantization).
    pub stage_id: Option<String>,
    /// Nanoseconds of the path spent on this signal's nets and cells.
    pub delay_ns: f64,
}

/// The critical path of a nextpnr JSON report: of its `critical_paths`,
/// the longest from a clock edge to the same clock.
pub fn parse(report: &[u8], seed: u64) -> Option<CriticalPath> {
    let j: serde_json::Value = serde_json::from_slice(report).ok()?;
    let mut best: Option<CriticalPath> = None;
    for p in j["critical_paths"].as_array()? {
        if p["from"] != p["to"] {
            continue;
        }
        let mut steps = Vec::new();
        for s in p["path"].as_array()? {
            let kind = s["type"].as_str()?.to_string();
            let name = match s["net"].as_str() {
                Some(n) => n.to_string(),
                None => s["to"]["cell"].as_str().unwrap_or_default().to_string(),
            };
            steps.push(Step {
                kind,
                name,
                delay_ns: s["delay"].as_f64()?,
            });
        }
        let delay_ns: f64 = steps.iter().map(|s| s.delay_ns).sum();
        let routing_ns: f64 = steps
            .iter()
            .filter(|s| s.kind == "routing")
            .map(|s| s.delay_ns)
            .sum();
        let path = p["path"].as_array()?;
        let cp = CriticalPath {
            seed,
            delay_ns,
            logic_ns: delay_ns - routing_ns,
            routing_ns,
            from: path.first()?["to"]["cell"].as_str()?.to_string(),
            to: path.last()?["to"]["cell"].as_str()?.to_string(),
            steps,
            signals: Vec::new(),
        };
        if best.as_ref().is_none_or(|b| cp.delay_ns > b.delay_ns) {
            best = Some(cp);
        }
    }
    best
}

/// The emitted signal a net or cell name of the synthesized harness
/// stands for: `dut.` and the bit index removed, and the suffixes Yosys
/// appends when it names cells and the nets between them (`_SB_LUT4…`,
/// `_TRELLIS…`, `$…`); `harness:<name>` outside the module under test.
pub fn signal_of(name: &str) -> String {
    let (inside, rest) = match name.strip_prefix("dut.") {
        Some(r) => (true, r),
        None => (false, name),
    };
    let mut base = rest.split('[').next().unwrap_or(rest);
    for cut in [
        "_SB_", "_TRELLIS", "_LUT4", "_CCU2", "_MULT18", "_ALU54", "_DP16KD", "_DFF", "_DPR16", "$",
    ] {
        if let Some(k) = base.find(cut) {
            base = &base[..k];
        }
    }
    if inside {
        base.to_string()
    } else {
        format!("harness:{base}")
    }
}

fn op_name(op: &Op) -> &'static str {
    match op {
        Op::Input(_) => "input",
        Op::Const(_) => "constant",
        Op::Mul(..) => "product",
        Op::Add(..) => "sum",
        Op::Sub(..) => "difference",
        Op::Max(..) => "maximum",
        Op::AddSigned(..) => "add or subtract",
        Op::Quant(..) => "quantization",
        Op::Table(..) => "table read",
        Op::Div(..) => "division",
        Op::Sqrt(..) => "square root",
        Op::Select(..) => "selection",
    }
}

/// The trace node an emitted signal name belongs to, and what it is:
/// `names` are the emitter's node names (`Emitted::node_names`,
/// stage-local: `normalize_d_0`, `normalize_d_mul1`, `sin_0`); a signal is
/// a node's name or that name followed by `_` and a register's or the
/// naming pass's suffix (`_s3`, `_q`, `_d`, `_ovf`), the longest name
/// winning.
pub fn node_of(
    trace: &Trace,
    names: &[String],
    signal: &str,
) -> (Option<usize>, String, Option<String>) {
    if signal.starts_with("harness:") {
        return (None, "harness register".into(), None);
    }
    let ops = trace.ops();
    let named = names
        .iter()
        .enumerate()
        .filter(|(i, n)| {
            *i < ops.len()
                && !matches!(ops[*i], Op::Input(_))
                && (signal == n.as_str()
                    || signal
                        .strip_prefix(n.as_str())
                        .is_some_and(|r| r.starts_with('_')))
        })
        .max_by_key(|(_, n)| n.len());
    if let Some((i, _)) = named {
        let stage = trace.stage_id(i).map(str::to_string);
        return (Some(i), op_name(&ops[i]).to_string(), stage);
    }
    // An input port (`n1_x_i`), a set-up register or bank (`n1_x_q`,
    // `n1_x_b0_q`, `n1_x_bank_s3_q`) or the selector carried (`sel_c_s3_q`).
    let mut best: Option<(usize, usize)> = None;
    for p in trace.input_ports() {
        let n = p.name.as_str();
        if signal == n || signal.starts_with(&format!("{n}_")) {
            let i = p.value.node();
            if best.is_none_or(|(_, l)| n.len() > l) {
                best = Some((i, n.len()));
            }
        }
    }
    if let Some((i, l)) = best {
        let rest = &signal[l..];
        let what =
            if rest.starts_with("_b0") || rest.starts_with("_b1") || rest.starts_with("_bank") {
                "set-up bank"
            } else if rest == "_q" {
                "set-up register"
            } else {
                "input"
            };
        return (Some(i), what.into(), None);
    }
    (None, "control".into(), None)
}

impl CriticalPath {
    /// Fill [`Self::signals`]: each step's signal, consecutive steps of
    /// one signal merged, their delays summed.
    pub fn map_signals(&mut self, trace: &Trace, names: &[String]) {
        let mut out: Vec<Signal> = Vec::new();
        for s in &self.steps {
            let name = signal_of(&s.name);
            // A net Yosys left unnamed (`$abc$…`) belongs to the signal
            // before it.
            let unnamed = name == "harness:" || name.is_empty();
            match out.last_mut() {
                Some(last) if last.name == name || unnamed => last.delay_ns += s.delay_ns,
                _ => {
                    let (node, op, stage_id) = node_of(trace, names, &name);
                    out.push(Signal {
                        name,
                        node,
                        op,
                        stage_id,
                        delay_ns: s.delay_ns,
                    });
                }
            }
        }
        self.signals = out;
    }
}

/// Met or missed: the median Fmax against the clock asked for.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Verdict {
    /// The clock asked for, MHz.
    pub target_mhz: f64,
    /// The median Fmax over the seeds, MHz.
    pub fmax_mhz: f64,
    /// `fmax_mhz >= target_mhz`.
    pub met: bool,
    /// `fmax_mhz − target_mhz` (negative: missed by that much).
    pub margin_mhz: f64,
    /// The same in percent of the target.
    pub margin_percent: f64,
    /// Seeds that reached the target, of all.
    pub seeds_met: usize,
    /// Seeds run.
    pub seeds: usize,
}

impl Verdict {
    /// The verdict of `fmax` (median) and the per-seed results against
    /// `target` MHz.
    pub fn new(target: f64, fmax: f64, seeds: &[f64]) -> Self {
        Verdict {
            target_mhz: target,
            fmax_mhz: fmax,
            met: fmax >= target,
            margin_mhz: fmax - target,
            margin_percent: (fmax - target) / target * 100.0,
            seeds_met: seeds.iter().filter(|&&f| f >= target).count(),
            seeds: seeds.len(),
        }
    }

    /// `met 100 MHz: median 103.2 MHz (+3.2 %), 3 of 3 seeds` or
    /// `MISSED 100 MHz by 17.6 MHz (-17.6 %): median 82.4 MHz, 0 of 3 seeds`.
    pub fn line(&self) -> String {
        if self.met {
            format!(
                "met {:.1} MHz: median {:.1} MHz ({:+.1} %), {} of {} seeds",
                self.target_mhz, self.fmax_mhz, self.margin_percent, self.seeds_met, self.seeds
            )
        } else {
            format!(
                "MISSED {:.1} MHz by {:.1} MHz ({:+.1} %): median {:.1} MHz, {} of {} seeds",
                self.target_mhz,
                -self.margin_mhz,
                self.margin_percent,
                self.fmax_mhz,
                self.seeds_met,
                self.seeds
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yosys_suffixes_and_bits_are_removed() {
        assert_eq!(signal_of("dut.t5_SB_LUT4_O_23_I2_SB_LUT4_O_I2[2]"), "t5");
        assert_eq!(
            signal_of("dut.angle_interp_angle_9_r[14]"),
            "angle_interp_angle_9_r"
        );
        assert_eq!(signal_of("in_q_SB_DFF_Q_20_DFFLC"), "harness:in_q");
        assert_eq!(signal_of("dut.x$abc$123"), "x");
    }

    #[test]
    fn a_report_gives_its_longest_clock_to_clock_path() {
        let r = br#"{"critical_paths": [
          {"from": "posedge c", "to": "posedge c", "path": [
            {"type": "clk-to-q", "delay": 0.5, "from": {"cell": "a"}, "to": {"cell": "a"}},
            {"type": "routing", "net": "dut.t1[0]", "delay": 1.25, "from": {"cell": "a"}, "to": {"cell": "b"}},
            {"type": "setup", "delay": 0.25, "from": {"cell": "b"}, "to": {"cell": "b"}}]},
          {"from": "<async>", "to": "posedge c", "path": [
            {"type": "routing", "net": "x", "delay": 9.0, "from": {"cell": "p"}, "to": {"cell": "q"}}]}
        ]}"#;
        let p = parse(r, 2).unwrap();
        assert_eq!(p.delay_ns, 2.0);
        assert_eq!(p.routing_ns, 1.25);
        assert_eq!(p.logic_ns, 0.75);
        assert_eq!((p.from.as_str(), p.to.as_str()), ("a", "b"));
        assert_eq!(p.seed, 2);
    }

    #[test]
    fn verdicts_say_by_how_much() {
        let v = Verdict::new(100.0, 82.4, &[85.7, 82.4, 81.9]);
        assert!(!v.met);
        assert!((v.margin_mhz + 17.6).abs() < 1e-9);
        assert_eq!(v.seeds_met, 0);
        assert!(
            v.line().starts_with("MISSED 100.0 MHz by 17.6 MHz"),
            "{}",
            v.line()
        );
        let v = Verdict::new(50.0, 54.0, &[54.0]);
        assert!(v.met && v.seeds_met == 1);
    }
}
