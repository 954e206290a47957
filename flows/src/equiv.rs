//! `fxshade equiv <unit>|all`: prove that each emitted module computes its
//! traced datapath's function for every input value.
//!
//! Two sides meet in one SMT-LIB 2 query (a miter):
//!
//! * the **model**: the trace's outputs and overflow flags as bit-vector
//!   terms of its inputs, by the trace's own encoder
//!   ([`fxshade_model::datapath::Trace::smt_function`]), which reads the
//!   trace and never the Verilog;
//! * the **RTL**: the module's transition relation as Yosys reads the
//!   Verilog (`prep; memory_map; async2sync; dffunmap; write_smt2 -stbv`:
//!   word-level, one state vector per cycle), unrolled over the latency.
//!
//! The RTL starts in an arbitrary state (every register free), is reset in
//! cycle 0, then takes one item per cycle with `ready_i` high throughout
//! (no stalls): the first item (cycle 1, or cycle 2 after the set-up ports
//! load in cycle 1) is the model's input, the later ones are free. The
//! query asks for an input where `valid_o` is low `L` cycles later or an
//! output or `ovf_o` differs from the model's. `unsat` is a proof for every
//! input value, whatever the later items and the registers' power-up
//! values; a model is a counterexample, checked against the compiled trace
//! and replayed on Verilator. Stalls are the handshake proofs' part
//! (`fxshade formal`): they show that a stall never changes what an item
//! computes, so together the two cover every input sequence.

use fxshade_model::convert::narrow;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use anyhow::{bail, Context};
use fxshade_model::rtl::{units, Design, Emitted};

use crate::smt::{Reply, SExpr, Solver};
use crate::smt2_model::Smt2Model;
use std::collections::{HashMap, HashSet};

/// A proof's outcome.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// Equal for every input value.
    Proved,
    /// An input where they differ.
    Counterexample,
    /// The solver gave up or hit the time limit.
    Unknown,
}

/// An input where the module and the model differ.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Counterexample {
    /// The item's input codes, by port.
    pub inputs: Vec<(String, i128)>,
    /// What the RTL gives `L` cycles later: each output's code, `ovf`
    /// (when there are flags) and `valid`.
    pub rtl: Vec<(String, i128)>,
    /// What the model gives (the compiled trace); for a netlist, what the
    /// netlist gives.
    pub model: Vec<(String, i128)>,
    /// The vector set reproducing it (the item and the free items after
    /// it that the solver chose).
    pub vectors: Option<String>,
    /// Whether Verilator, run on that vector set with no stalls, reports
    /// a mismatch (`None`: not run).
    pub reproduced: Option<bool>,
}

/// One module's result.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Equiv {
    /// Module.
    pub module: String,
    /// Latency, cycles.
    pub latency: u32,
    /// The outcome.
    pub verdict: Verdict,
    /// The solver.
    pub solver: Solver,
    /// Seconds (Yosys and the solver).
    pub seconds: f64,
    /// Why unknown, when it is.
    pub reason: Option<String>,
    /// The counterexample, when there is one.
    pub counterexample: Option<Counterexample>,
    /// Products abstracted (model and RTL together): each an application
    /// of one uninterpreted function of its operand values.
    pub products: usize,
    /// How it was proved (or last tried).
    pub method: Method,
}

/// How a module was proved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// One query for the whole module.
    Whole,
    /// By stages: one query per cut (a quantization's signal), each with
    /// every cut free and equal on both sides, then the outputs.
    Stages(usize),
    /// A netlist against its RTL: the window query over this many cycles
    /// (two runs from any states agree in the last), and the register
    /// correspondence of this many equalities proved inductive (0: none,
    /// unrolled from reset over the window instead).
    Netlist(u32, usize),
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Method::Whole => f.write_str("whole"),
            Method::Stages(n) => write!(f, "by stages ({n} cuts)"),
            Method::Netlist(d, 0) => write!(f, "netlist, {d}-cycle window"),
            Method::Netlist(d, n) => write!(f, "netlist, {n} equalities, {d}-cycle window"),
        }
    }
}

/// A module to prove: its design, as emitted, and the Verilog text read.
pub struct Module {
    /// The design (its trace is the model side).
    pub design: Design,
    /// The emitted module (ports, latency, set-up ports).
    pub emitted: Emitted,
    /// The Verilog proved.
    pub text: String,
}

/// The ports Yosys's SMT-LIB 2 model declares: (name, width), inputs and
/// outputs.
/// Ports as (name, width).
type Ports = Vec<(String, u32)>;

fn smt2_ports(smt2: &str) -> (Ports, Ports) {
    let mut ins = Vec::new();
    let mut outs = Vec::new();
    for l in smt2.lines() {
        for (tag, v) in [
            ("; yosys-smt2-input ", &mut ins),
            ("; yosys-smt2-output ", &mut outs),
        ] {
            if let Some(r) = l.strip_prefix(tag) {
                let mut it = r.split_whitespace();
                if let (Some(n), Some(w)) = (it.next(), it.next().and_then(|w| w.parse().ok())) {
                    v.push((n.to_string(), w));
                }
            }
        }
    }
    (ins, outs)
}

/// The RTL side: Yosys's word-level model of `text` (module `module`), as
/// SMT-LIB 2 with one bit-vector per state.
///
/// # Errors
///
/// The module cannot be written to `dir`, or Yosys cannot read it or write its SMT-LIB 2 model.
pub fn rtl_smt2(module: &str, text: &str, dir: &Path) -> anyhow::Result<String> {
    let file = format!("{module}.v");
    std::fs::write(dir.join(&file), text).context("cannot write the module")?;
    let smt = format!("{module}.smt2");
    // No optimization: `opt_expr` and `wreduce` would rewrite products
    // (a constant's trailing zeros become a shift), and products are
    // matched by their operand values.
    let ys = format!(
        "read_verilog -sv {file}\nhierarchy -check -top {module}\nproc\nflatten\n\
         opt_clean\nmemory -nomap\nmemory_map\nopt_clean\nasync2sync\ndffunmap\n\
         write_smt2 -stbv -wires {smt}\n"
    );
    let o = crate::proc::yosys_script(dir, "equiv.ys", &ys, "yosys (equivalence model)")?;
    if !o.status.success() {
        bail!("yosys could not read {module}:\n{}", o.text().trim_end());
    }
    std::fs::read_to_string(dir.join(&smt)).context("yosys wrote no SMT-LIB 2 model")
}

/// A miter: the script and what to read back from a model.
struct Miter {
    /// The whole-module query: `check-sat` and `get-value`.
    script: String,
    /// The proof by stages: one `check-sat` per cut, then the outputs'
    /// (each between `push` and `pop`); `None` with no cuts.
    staged: Option<String>,
    /// The cuts' modules, in the order of `staged`'s queries.
    cut_names: Vec<String>,
    /// The step whose outputs are compared.
    last: u32,
    /// The step the item enters.
    first: u32,
}

/// `t` (a bit-vector of width `w`) as the port's sort: Yosys declares
/// one-bit ports `Bool`.
fn as_port(t: &str, w: u32) -> String {
    if w == 1 {
        format!("(= {t} #b1)")
    } else {
        t.to_string()
    }
}

/// Build the miter of module `m` (Yosys's model `smt2`): the whole
/// query, and the proof by stages (every cut of the emitter whose signal
/// Yosys's model names).
fn miter(m: &Module, smt2: &str) -> anyhow::Result<Miter> {
    let e = &m.emitted;
    let module = &e.module;
    let no_rtl = || format!("{module}: the datapath divides or takes a square root (no RTL)");
    // Products the emitter split are written as the same sums of partial
    // products (exact: the split lemma, `MulSplit`).
    let f = m
        .design
        .trace
        .smt_function_split(&[], &e.splits)
        .with_context(no_rtl)?;
    let mut cut = vec![false; m.design.trace.ops().len()];
    let mut cuts = Vec::new();
    for (i, k, name) in &e.cuts {
        if smt2.contains(&format!("(define-fun |{module}_n {name}| ")) {
            cut[*i] = true;
            cuts.push((*i, *k, name.clone()));
        }
    }
    let fc = m
        .design
        .trace
        .smt_function_split(&cut, &e.splits)
        .with_context(no_rtl)?;
    let (ins, outs) = smt2_ports(smt2);
    let width = |list: &[(String, u32)], p: &str| {
        list.iter()
            .find(|(n, _)| n == p)
            .map(|(_, w)| *w)
            .with_context(|| format!("{module}: the RTL has no port {p}"))
    };
    let at = |p: &str, k: u32| format!("(|{module}_n {p}| s{k})");
    // Set-up records from cycle 1, each offered until taken: a banked or
    // stage-0 port takes it at once, a held port with a drain the cycle
    // after (its ready is a register). The item follows them.
    let held = |g: &fxshade_model::rtl::SetupPort| g.banks == 1 && g.drain > 0;
    let setup_cycles = |g: &fxshade_model::rtl::SetupPort| if held(g) { 2 } else { 1 };
    let first = 1 + e.setup.iter().map(setup_cycles).max().unwrap_or(0);
    let last = first + e.latency;
    let mut s = String::new();
    s += "\n; The RTL unrolled: reset in step 0, then one item per cycle.\n";
    for k in 0..=last {
        let _ = writeln!(s, "(declare-const s{k} |{module}_s|)");
    }
    for p in ["rst_ni", "ready_i", "valid_i"] {
        width(&ins, p)?;
    }
    let _ = writeln!(s, "(assert (not {}))", at("rst_ni", 0));
    for k in 1..=last {
        let _ = writeln!(s, "(assert {})", at("rst_ni", k));
        let _ = writeln!(s, "(assert {})", at("ready_i", k));
        let v = at("valid_i", k);
        if k >= first {
            let _ = writeln!(s, "(assert {v})");
        } else {
            let _ = writeln!(s, "(assert (not {v}))");
        }
        for g in &e.setup {
            let gv = at(&format!("{}_valid_i", g.name), k);
            if k <= setup_cycles(g) {
                let _ = writeln!(s, "(assert {gv})");
            } else {
                let _ = writeln!(s, "(assert (not {gv}))");
            }
        }
    }
    // The item's inputs are the model's.
    let ports = m.design.trace.input_ports();
    for (slot, p) in ports.iter().enumerate() {
        let port = format!("{}_i", p.name);
        let w = width(&ins, &port)?;
        anyhow::ensure!(
            w == f.inputs[slot].1,
            "{module}: port {port} is {w} bits, the model's input {}",
            f.inputs[slot].1
        );
        let group = e.setup.iter().find(|g| g.fields.contains(&p.name));
        let ks: Vec<u32> = match group {
            Some(g) => (1..=setup_cycles(g)).collect(),
            None => vec![first],
        };
        for k in ks {
            let _ = writeln!(
                s,
                "(assert (= {} {}))",
                at(&port, k),
                as_port(&f.inputs[slot].0, w)
            );
        }
    }
    // Equal outputs, flags and valid at the last step, or a counterexample.
    let mut eq = vec![at("valid_o", last)];
    for (name, term, w) in &f.outputs {
        let port = format!("{name}_o");
        let pw = width(&outs, &port)?;
        anyhow::ensure!(
            pw == *w,
            "{module}: port {port} is {pw} bits, the model's output {w}"
        );
        eq.push(format!("(= {} {})", at(&port, last), as_port(term, pw)));
    }
    if !f.flags.is_empty() {
        let pw = width(&outs, "ovf_o")?;
        anyhow::ensure!(
            pw as usize == f.flags.len(),
            "{module}: ovf_o is {pw} bits, the model has {} flag stages",
            f.flags.len()
        );
        let bits: Vec<String> = f
            .flags
            .iter()
            .map(|(_, t)| format!("(ite {t} #b1 #b0)"))
            .collect();
        let model = if bits.len() == 1 {
            bits[0].clone()
        } else {
            format!("(concat {})", bits.join(" "))
        };
        eq.push(format!("(= {} {})", at("ovf_o", last), as_port(&model, pw)));
    }
    let goal = format!("(not (and {}))", eq.join(" "));
    let unrolled = s;
    let mut whole_trans = String::new();
    for k in 0..last {
        let _ = writeln!(whole_trans, "(assert (|{module}_t| s{k} s{}))", k + 1);
    }
    let head = |defs: &str| {
        let mut h = String::new();
        h += if f.arrays {
            "(set-logic QF_ABV)\n"
        } else {
            "(set-logic QF_BV)\n"
        };
        h += smt2;
        h += "\n; The model: the traced datapath's function.\n";
        h += defs;
        h += &unrolled;
        h
    };
    // By stages: each query holds only its cone of influence, back to the
    // cuts it reads (their signals in their stages, each equal to a free
    // value `c<i>`: a definition, so sound for any cut list) and no
    // further; registers outside the cone are free in every cycle (an
    // assumption dropped, so `unsat` is still a proof).
    let staged = (!cuts.is_empty()).then(|| {
        let g = Smt2Model::parse(module, smt2);
        let wire = |name: &str| format!("{module}_n {name}");
        // Several cuts may be one net in one cycle (a quantization the
        // range analysis proved exact is its operand's wire): each is
        // defined wherever the net is met.
        let mut stop_of: HashMap<(String, u32), Vec<usize>> = HashMap::new();
        for (n, (_, k, name)) in cuts.iter().enumerate() {
            stop_of
                .entry((g.resolve(&wire(name)).to_string(), first + k))
                .or_default()
                .push(n);
        }
        let stops: HashSet<(String, u32)> = stop_of.keys().cloned().collect();
        let w = |i: usize| m.design.trace.sym(i).width;
        let mut t = head(&fc.defs);
        t += "; By stages: one query per cut, then the outputs, each over its cone.\n";
        let query = |t: &mut String, roots: &[(String, u32)], enter: bool, goal: &str| {
            let (trans, mut hit) = g.cone(roots, &stops, enter);
            // A root that is a cut's net too: that cut's definition holds
            // there (the query's own cut among them, which is harmless:
            // its goal compares the net with f<i>, not with c<i>).
            for (w, k) in roots {
                let key = (g.resolve(w).to_string(), *k);
                if stop_of.contains_key(&key) && !hit.contains(&key) {
                    hit.push(key);
                }
            }
            t.push_str("(push 1)\n");
            for (next, field, k) in &trans {
                let _ = writeln!(t, "(assert (= (|{next}| s{k}) (|{field}| s{})))", k + 1);
            }
            for n in hit.iter().flat_map(|h| &stop_of[h]) {
                let (i, k, name) = &cuts[*n];
                let _ = writeln!(
                    t,
                    "(assert (= (|{}| s{}) {}))",
                    wire(name),
                    first + k,
                    as_port(&format!("c{i}"), w(*i))
                );
            }
            let _ = writeln!(t, "(assert {goal})\n(check-sat)\n(pop 1)");
        };
        for (i, k, name) in &cuts {
            let goal = format!(
                "(not (= (|{}| s{}) {}))",
                wire(name),
                first + k,
                as_port(&format!("f{i}"), w(*i))
            );
            query(&mut t, &[(wire(name), first + k)], true, &goal);
        }
        let mut roots: Vec<(String, u32)> = f
            .outputs
            .iter()
            .map(|(name, _, _)| (wire(&format!("{name}_o")), last))
            .collect();
        roots.push((wire("valid_o"), last));
        if !f.flags.is_empty() {
            roots.push((wire("ovf_o"), last));
        }
        query(&mut t, &roots, false, &goal);
        t
    });
    let mut s = head(&f.defs);
    s += &whole_trans;
    let _ = writeln!(s, "(assert {goal})");
    s += "(check-sat)\n(get-value (";
    for (n, _) in &f.inputs {
        let _ = write!(s, " {n}");
    }
    // The later items (for the replay) and what the RTL gives.
    for k in first..=last {
        for p in &ports {
            if !e.setup.iter().any(|g| g.fields.contains(&p.name)) {
                let _ = write!(s, " {}", at(&format!("{}_i", p.name), k));
            }
        }
    }
    for (name, _, _) in &f.outputs {
        let _ = write!(s, " {}", at(&format!("{name}_o"), last));
    }
    if !f.flags.is_empty() {
        let _ = write!(s, " {}", at("ovf_o", last));
    }
    let _ = write!(s, " {}", at("valid_o", last));
    s += "))\n";
    Ok(Miter {
        script: s,
        staged,
        cut_names: cuts.into_iter().map(|(_, _, n)| n).collect(),
        last,
        first,
    })
}

/// The value of `term` in a model.
fn value(pairs: &[(SExpr, SExpr)], term: &str) -> anyhow::Result<u128> {
    pairs
        .iter()
        .find(|(t, _)| t.to_string() == term)
        .and_then(|(_, v)| v.bits())
        .map(|(b, _)| b)
        .with_context(|| format!("the solver's model has no value for {term}"))
}

/// Answer the staged script `st` (a prefix, then one `(push 1) …
/// (check-sat) (pop 1)` block per query), its queries split over the
/// worker threads (each part one solver run with the prefix), in order.
/// A part that does not finish answers `unknown` for each of its queries.
fn check_staged(solver: Solver, st: &str, timeout: u64) -> anyhow::Result<Vec<Reply>> {
    let mut parts = st.split("\n(push 1)\n");
    let prefix = parts.next().unwrap_or_default();
    let blocks: Vec<&str> = parts.collect();
    let threads = rayon::current_num_threads().max(1);
    // At least 8 queries a run: each run reads the whole prefix.
    let per = blocks.len().div_ceil(threads).max(8);
    use rayon::prelude::*;
    let answers: Vec<Vec<Reply>> = blocks
        .par_chunks(per.max(1))
        .map(|chunk| {
            let mut script = String::with_capacity(prefix.len() + chunk.len() * 1024);
            script += prefix;
            for b in chunk {
                script += "\n(push 1)\n";
                script += b;
            }
            script.push('\n');
            let mut a = solver.check_each(&script, timeout)?;
            a.resize(chunk.len(), Reply::Unknown("timeout".into()));
            Ok(a)
        })
        .collect::<anyhow::Result<_>>()?;
    Ok(answers.into_iter().flatten().collect())
}

/// Prove one module in `dir` (a scratch directory); with a
/// counterexample, also the vector rows that replay it.
///
/// # Errors
///
/// The module's trace has no SMT function, the miter cannot be built from Yosys's model, or the
/// solver fails to run or answers what cannot be parsed; a counterexample is an `Ok` verdict.
pub fn prove(
    m: &Module,
    solver: Solver,
    timeout: u64,
    dir: &Path,
) -> anyhow::Result<(Equiv, Vec<Vec<i128>>)> {
    let t0 = Instant::now();
    let e = &m.emitted;
    let smt2 = rtl_smt2(&e.module, &m.text, dir)?;
    let mi = miter(m, &smt2)?;
    if let Some(d) = &crate::settings::get().smt_dump {
        let _ = std::fs::write(d.join(format!("{}-equiv.smt2", e.module)), &mi.script);
    }
    // Products abstracted; a model of the whole query is checked on the
    // real products with every free input fixed to the model's values.
    let abstracted = |script: &str| -> anyhow::Result<(String, usize)> {
        let (abs, n) = crate::smt::abstract_products(script)?;
        let decl = crate::smt::product_declarations();
        let abs = abs
            .replacen(
                "(set-logic QF_BV)",
                &format!("(set-logic QF_UFBV)\n{decl}"),
                1,
            )
            .replacen(
                "(set-logic QF_ABV)",
                &format!("(set-logic QF_AUFBV)\n{decl}"),
                1,
            );
        Ok((abs, n))
    };
    let (abs, n_products) = abstracted(&mi.script)?;
    let dump = |name: &str, text: &str| {
        if let Some(d) = &crate::settings::get().smt_dump {
            let _ = std::fs::write(d.join(format!("{}-{name}.smt2", e.module)), text);
        }
    };
    dump("equiv-abs", &abs);
    // First by stages: every cut, then the outputs from the cuts.
    let mut staged_note = None;
    if let Some(st) = &mi.staged {
        let (st, _) = abstracted(st)?;
        dump("equiv-staged", &st);
        let answers = check_staged(solver, &st, timeout)?;
        let n = mi.cut_names.len() + 1;
        if answers.len() == n && answers.iter().all(|r| *r == Reply::Unsat) {
            return Ok((
                Equiv {
                    module: e.module.clone(),
                    latency: e.latency,
                    verdict: Verdict::Proved,
                    solver,
                    seconds: t0.elapsed().as_secs_f64(),
                    reason: None,
                    counterexample: None,
                    products: n_products,
                    method: Method::Stages(mi.cut_names.len()),
                },
                Vec::new(),
            ));
        }
        let what = |k: usize| {
            mi.cut_names
                .get(k)
                .map_or("the outputs".to_string(), |c| format!("cut {c}"))
        };
        let bad = match answers.iter().position(|r| *r != Reply::Unsat) {
            Some(k) if answers[k] == Reply::Sat(Vec::new()) => format!("{} differs", what(k)),
            Some(k) => format!(
                "{} unknown ({})",
                what(k),
                match &answers[k] {
                    Reply::Unknown(why) => why.as_str(),
                    _ => "no answer",
                }
            ),
            None => format!("{} of {n} queries answered", answers.len()),
        };
        staged_note = Some(format!("by stages: {bad}"));
    }
    let reply = solver.check(&abs, timeout)?;
    let mut rows = Vec::new();
    let mut out = Equiv {
        module: e.module.clone(),
        latency: e.latency,
        verdict: Verdict::Unknown,
        solver,
        seconds: 0.0,
        reason: None,
        counterexample: None,
        products: n_products,
        method: Method::Whole,
    };
    let left = |t0: Instant| {
        if timeout == 0 {
            0
        } else {
            timeout.saturating_sub(t0.elapsed().as_secs()).max(1)
        }
    };
    match reply {
        Reply::Unsat => out.verdict = Verdict::Proved,
        Reply::Unknown(why) => {
            out.reason = Some(format!(
                "{} answered {why} after {:.0} s",
                solver.name(),
                t0.elapsed().as_secs_f64()
            ))
        }
        Reply::Sat(pairs) => {
            // Fix the free inputs to the model's and ask with the real
            // products.
            let mut fix = String::new();
            for (t, v) in &pairs {
                let is_input = t.atom().is_some_and(|a| a.starts_with("in"))
                    || (t
                        .to_string()
                        .ends_with(|c: char| c.is_ascii_digit() || c == ')')
                        && t.head().is_some_and(|h| h.ends_with("_i|")));
                if is_input {
                    let _ = writeln!(fix, "(assert (= {t} {v}))");
                }
            }
            let concrete =
                mi.script
                    .replacen("\n(check-sat)\n", &format!("\n{fix}(check-sat)\n"), 1);
            match solver.check(&concrete, left(t0))? {
                Reply::Sat(pairs) => {
                    out.verdict = Verdict::Counterexample;
                    let (c, r) = counterexample(m, &mi, &pairs)?;
                    out.counterexample = Some(c);
                    rows = r;
                }
                Reply::Unsat => {
                    // The abstraction's difference is not real at those
                    // inputs: ask with the real products and every input
                    // free (slow: the solver bit-blasts the multipliers).
                    match solver.check(&mi.script, left(t0))? {
                        Reply::Sat(pairs) => {
                            out.verdict = Verdict::Counterexample;
                            let (c, r) = counterexample(m, &mi, &pairs)?;
                            out.counterexample = Some(c);
                            rows = r;
                        }
                        Reply::Unsat => out.verdict = Verdict::Proved,
                        Reply::Unknown(why) => {
                            out.reason = Some(format!(
                                "{} answered {why} on the real products after {:.0} s \
                                 (the products' abstraction alone admits a difference)",
                                solver.name(),
                                t0.elapsed().as_secs_f64()
                            ))
                        }
                    }
                }
                Reply::Unknown(why) => {
                    out.reason = Some(format!(
                        "{} answered {why} on the real products after {:.0} s",
                        solver.name(),
                        t0.elapsed().as_secs_f64()
                    ))
                }
            }
        }
    }
    if out.verdict == Verdict::Unknown {
        if let Some(n) = staged_note {
            out.reason = Some(format!(
                "{n}; whole: {}",
                out.reason.take().unwrap_or_default()
            ));
        }
    }
    out.seconds = t0.elapsed().as_secs_f64();
    Ok((out, rows))
}

/// Read a counterexample from the solver's model and check the model side
/// against the compiled trace.
/// Also the stream that replays it: the item and the later items the
/// solver chose, as vector rows.
fn counterexample(
    m: &Module,
    mi: &Miter,
    pairs: &[(SExpr, SExpr)],
) -> anyhow::Result<(Counterexample, Vec<Vec<i128>>)> {
    let e = &m.emitted;
    let module = &e.module;
    let ports = m.design.trace.input_ports();
    let mut item = Vec::new();
    for (slot, p) in ports.iter().enumerate() {
        let b = value(pairs, &format!("in{slot}"))?;
        item.push(p.format.from_bits(narrow::<u64, _>(b)));
    }
    // The compiled trace's outputs and flags for the item.
    let prog = units::compile_outputs(&m.design)?;
    let cols: Vec<Vec<i128>> = item.iter().map(|&c| vec![c]).collect();
    let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
    let (outs, flags) = prog.run_flags_i128(&refs);
    let mut model = Vec::new();
    let mut rtl = Vec::new();
    let at = |p: &str| format!("(|{module}_n {p}| s{})", mi.last);
    for (k, p) in m.design.trace.output_ports().iter().enumerate() {
        model.push((p.name.clone(), outs[k][0]));
        let b = value(pairs, &at(&format!("{}_o", p.name)))?;
        rtl.push((p.name.clone(), p.format.from_bits(narrow::<u64, _>(b))));
    }
    if !e.flags.is_empty() {
        model.push(("ovf".into(), i128::from(flags[0])));
        rtl.push(("ovf".into(), narrow::<i128, _>(value(pairs, &at("ovf_o"))?)));
    }
    model.push(("valid".into(), 1));
    rtl.push((
        "valid".into(),
        narrow::<i128, _>(value(pairs, &at("valid_o"))?),
    ));
    if model == rtl {
        bail!(
            "{module}: the solver's counterexample is none: the RTL gives what the compiled \
             trace gives ({model:?}), so the SMT encoding of the trace is wrong"
        );
    }
    let inputs = ports
        .iter()
        .zip(&item)
        .map(|(p, &c)| (p.name.clone(), c))
        .collect();
    // The stream the solver chose: the item, then the later items (set-up
    // fields as loaded).
    let mut rows = Vec::new();
    for k in mi.first..=mi.last {
        let mut row = Vec::new();
        for (slot, p) in ports.iter().enumerate() {
            let setup = e.setup.iter().any(|g| g.fields.contains(&p.name));
            if setup || k == mi.first {
                row.push(item[slot]);
            } else {
                let b = value(pairs, &format!("(|{module}_n {}_i| s{k})", p.name))?;
                row.push(p.format.from_bits(narrow::<u64, _>(b)));
            }
        }
        // Vector rows are in the emitted input fields' order.
        let by_field: Vec<i128> = e
            .inputs
            .iter()
            .map(|fl| {
                ports
                    .iter()
                    .position(|p| p.name == fl.name)
                    .map(|i| row[i])
                    .with_context(|| format!("{module}: no input port for field {}", fl.name))
            })
            .collect::<anyhow::Result<_>>()?;
        rows.push(by_field);
    }
    Ok((
        Counterexample {
            inputs,
            rtl,
            model,
            vectors: None,
            reproduced: None,
        },
        rows,
    ))
}

/// Write a counterexample's stream as a vector set in `dir` and replay it
/// on Verilator (when installed) with no stalls.
fn replay(
    m: &Module,
    rows: Vec<Vec<i128>>,
    dir: &Path,
    c: &mut Counterexample,
) -> anyhow::Result<()> {
    let mut set = units::vector_set(&m.design, &m.emitted, rows, 0, 1)?;
    set.rtl.verilog = m.text.clone();
    let d = fxshade_model::files::StagedDir::new(dir)
        .with_context(|| format!("cannot write the counterexample to {}", dir.display()))?;
    fxshade_model::vectors::write_set(
        &d,
        "",
        &set,
        &set.manifest(),
        &set.config_toml,
        &set.rtl,
        fxshade_model::writers::WRITERS,
        &mut |_| {},
    )
    .with_context(|| format!("cannot write the counterexample to {}", dir.display()))?;
    d.commit()
        .with_context(|| format!("cannot write the counterexample to {}", dir.display()))?;
    c.vectors = Some(dir.display().to_string());
    if crate::proc::has("verilator", "--version") {
        let src = crate::rtl_flow::Sources::emitted(&set.rtl);
        let r = crate::rtl_flow::check_with(
            &set,
            &src,
            crate::rtl_flow::Sim::Verilator,
            1,
            0,
            None,
            false,
        )?;
        c.reproduced = Some(r.failed > 0);
    }
    Ok(())
}

/// Every module of `unit` (or `all`) for `cfg`, with the text to prove.
///
/// # Errors
///
/// `unit` names no unit, a pipeline variant's overrides do not apply, the module cannot be
/// emitted, or `rtl_dir` lacks its file.
pub fn modules(
    unit: &str,
    cfg: &fxshade_model::Config,
    rtl_dir: Option<&Path>,
) -> anyhow::Result<Vec<Module>> {
    let list: Vec<(&'static units::RtlUnit, fxshade_model::Config)> = if unit == "all" {
        crate::rtl_flow::configs_all(cfg)?
    } else {
        vec![(crate::rtl_flow::unit(unit)?, cfg.clone())]
    };
    list.into_iter()
        .map(|(u, c)| {
            let (design, emitted) = units::emit_unit(u, &c)?;
            let text = match rtl_dir {
                None => emitted.verilog.clone(),
                Some(d) => {
                    let f = d.join(format!("{}.v", emitted.module));
                    std::fs::read_to_string(&f)
                        .with_context(|| format!("--rtl-dir: cannot read {}", f.display()))?
                }
            };
            Ok(Module {
                design,
                emitted,
                text,
            })
        })
        .collect()
}

/// Prove `modules` with `jobs` at once; counterexamples written under
/// `cex_dir` (none: not written or replayed); `done` is told the name of
/// each module as its proof ends.
///
/// # Errors
///
/// No temporary directory or worker threads, or a proof's own error ([`prove`]); a
/// counterexample or an `unknown` is a verdict, not an error.
pub fn prove_all(
    modules: &[Module],
    solver: Solver,
    timeout: u64,
    jobs: usize,
    cex_dir: Option<&Path>,
    done: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<Vec<Equiv>> {
    crate::proc::in_scratch_dirs("fxshade-equiv-", jobs, modules, |m, sub| {
        let (mut p, rows) = prove(m, solver, timeout, sub)?;
        record(m, &p);
        if let Some(c) = p.counterexample.as_mut() {
            if let Some(cd) = cex_dir {
                replay(m, rows, &cd.join(&m.emitted.module), c)?;
            }
        }
        done(&m.emitted.module);
        Ok(p)
    })
}

/// The cache key of a proof of `m`: this program's fingerprint, the
/// module's name and Verilog, and the model's SMT function (so a proof is
/// found again only for the same program, RTL text and model); `None`
/// when the program cannot be fingerprinted or the model has no function.
fn proof_key(m: &Module) -> Option<String> {
    let fp = fxshade_model::cache::program_fingerprint()?;
    let f = m.design.trace.smt_function()?;
    Some(fxshade_model::cache::sha256_key(&[
        b"equiv-proof-1",
        fp.as_bytes(),
        m.emitted.module.as_bytes(),
        m.text.as_bytes(),
        f.defs.as_bytes(),
    ]))
}

/// Record a proof of `m` in the user's private cache (`equiv/<key>.json`),
/// where `rtl-check` finds it. Only proofs are recorded; a cache that
/// cannot be used records nothing.
fn record(m: &Module, p: &Equiv) {
    if p.verdict != Verdict::Proved {
        return;
    }
    let (Some(key), Ok(dir)) = (proof_key(m), fxshade_model::cache::subdir("equiv")) else {
        return;
    };
    if let Ok(text) = serde_json::to_vec_pretty(p) {
        let _ = fxshade_model::cache::write(&dir.join(format!("{key}.json")), &text);
    }
}

/// The recorded proof of `m`, when this program proved this Verilog
/// against this model before (the user's private cache; an entry anyone
/// else could have written is refused).
pub fn recorded(m: &Module) -> Option<serde_json::Value> {
    let key = proof_key(m)?;
    let dir = fxshade_model::cache::subdir("equiv").ok()?;
    let bytes = fxshade_model::cache::read(&dir.join(format!("{key}.json"))).ok()??;
    let v: serde_json::Value = serde_json::from_slice(&bytes).ok()?;
    (v["verdict"] == "proved" && v["module"] == m.emitted.module.as_str()).then_some(v)
}

/// What `rtl-check` prints for `m`: `proved (…)`, or how to prove it.
pub fn status_line(m: &Module, unit: &str) -> String {
    match recorded(m) {
        Some(v) => format!(
            "proved ({}, {}, {:.1} s)",
            v["method"]
                .as_object()
                .and_then(|o| o.iter().next())
                .map_or_else(
                    || v["method"].as_str().unwrap_or("?").to_string(),
                    |(k, n)| format!("{k} {n}")
                ),
            v["solver"].as_str().unwrap_or("?"),
            v["seconds"].as_f64().unwrap_or(0.0)
        ),
        None => format!("not proved: run `fxshade equiv {unit}` with this configuration"),
    }
}
