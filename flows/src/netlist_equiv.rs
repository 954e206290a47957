//! `fxshade equiv <unit> --netlist DIR`: prove the gate-level netlist that
//! `fxshade synth --netlist` wrote (Yosys's ECP5 mapping, then the register
//! packing into MULT18X18D blocks) equivalent to the emitted RTL, as
//! sequential circuits.
//!
//! Yosys reads both, the netlist with the cell models written beside it,
//! and builds a miter (`miter -equiv -make_outputs`): one circuit holding
//! both, same inputs, both outputs, with `ready_i` tied high (no stalls:
//! the RTL's handshake proofs cover those) and the logic that makes
//! constant removed. A *difference* is a `valid` or `ready` output that
//! differs, or (while the RTL's `valid_o` is high) a data output or
//! `ovf_o` that differs: data under a low `valid_o` is nobody's to read.
//! D is the latency and 2.
//!
//! **The proof: register correspondence and a window.**
//!
//! 1. **Correspondence** ([`crate::netlist_corr`]): candidate equalities
//!    between the RTL's nets and the netlist's nets of the same name, bit
//!    by bit, and between each register the packing moved into a block and
//!    the RTL register it replaces; two simulations from reset by the
//!    solver drop those that plainly fail; then the greatest inductive
//!    subset `I`: from any state where `I` holds, one cycle with any
//!    inputs, `I` holds again and the outputs agree (one transition per
//!    query, products abstracted as below). And `I` holds in some state
//!    (else the step proves nothing).
//! 2. **Window**, for each circuit on its own (over its cone of
//!    influence): two runs from *any* two states in cycle 1, the same
//!    inputs (the reset among them) in cycles 1‥D: its compared outputs
//!    agree in cycle D, and in every cycle 1‥D when cycle 1 is a reset.
//!    So a circuit's outputs in cycle D of any window, and in every cycle
//!    after a reset, are a function of the window's inputs alone.
//!
//! Both `unsat` is a proof for every run that starts with a reset, in
//! every cycle, and for every run in cycles ≥ D: take the run of the miter
//! from a state of `I` (reached from any state of `I` the cycle before,
//! so with any inputs) with the same inputs over the window; each circuit
//! gives what it gives in the real run (2), and the two agree there (1).
//!
//! Products are abstracted as in the RTL proof (an uninterpreted function
//! of the operands' values, so identical multipliers match without
//! bit-blasting), with a **range lemma** per product: its value lies
//! between the bounds of the exact product of operands known by their
//! form (a zero-extended operand is not negative), since synthesis narrows
//! a product to the bits it can have and reads no others.
//!
//! When the step fails (a netlist that is not equivalent, or one whose
//! nets the candidates miss), the miter is unrolled **from reset** over D
//! cycles, every input free: a model whose products are exact, checked on
//! the real products at its inputs, is a counterexample.

use fxshade_model::convert::narrow;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use anyhow::{bail, Context};

use crate::equiv::{Counterexample, Equiv, Method, Module, Verdict};
use std::collections::HashSet;

use crate::smt::{Reply, SExpr, Solver};

/// The miter's SMT-LIB 2 model: Yosys reads the RTL (`fxs_gold`) and the
/// netlist with its cell models (`fxs_gate`) from `netlist`, ties
/// `ready_i` high and writes it.
fn miter_smt2(m: &Module, netlist: &Path, dir: &Path) -> anyhow::Result<String> {
    let module = &m.emitted.module;
    let top = netlist.join(format!("{module}.v"));
    anyhow::ensure!(
        top.is_file(),
        "--netlist: {} holds no {module}.v (write it with `fxshade synth {module} --target \
         ecp5 --netlist {}`)",
        netlist.display(),
        netlist.display()
    );
    let mut models = Vec::new();
    for e in std::fs::read_dir(netlist)
        .with_context(|| format!("--netlist: cannot read {}", netlist.display()))?
    {
        let p = e?.path();
        if p.extension().is_some_and(|x| x == "v") && p != top {
            models.push(std::fs::canonicalize(&p)?);
        }
    }
    models.sort();
    std::fs::write(dir.join("gold.v"), &m.text).context("cannot write the RTL")?;
    // Yosys script arguments: quoted; a newline or quote would end them.
    for p in models.iter().chain(std::iter::once(&top)) {
        let t = p.display().to_string();
        anyhow::ensure!(
            !t.contains(['\n', '\r', '"']),
            "--netlist: the path {t:?} holds a newline or a double quote, which a Yosys \
             script cannot quote; rename it"
        );
    }
    let q = |p: &Path| format!("\"{}\"", p.display());
    let mut ys = String::new();
    let _ = writeln!(ys, "read_verilog -sv gold.v\nrename {module} fxs_gold");
    for p in &models {
        let _ = writeln!(ys, "read_verilog {}", q(p));
    }
    let _ = writeln!(
        ys,
        "read_verilog {}\nrename {module} fxs_gate\nhierarchy -check\nproc\n\
         miter -equiv -flatten -make_outputs fxs_gold fxs_gate fxs_miter\n\
         hierarchy -top fxs_miter\nproc\nopt_clean\nmemory -nomap\nmemory_map\nopt_clean\n\
         async2sync\ndffunmap\ndelete -port fxs_miter/in_ready_i\ncd fxs_miter\n\
         connect -set in_ready_i 1'b1\ncd ..\nopt_clean\n\
         write_smt2 -stbv -wires miter.smt2",
        q(&std::fs::canonicalize(&top)?)
    );
    let o = crate::proc::yosys_script(dir, "miter.ys", &ys, "yosys (netlist miter)")?;
    if !o.status.success() {
        bail!(
            "yosys could not build the miter of {module} and its netlist:\n{}",
            o.text().trim_end()
        );
    }
    std::fs::read_to_string(dir.join("miter.smt2")).context("yosys wrote no miter model")
}

/// The miter's outputs (name, width), from Yosys's comments.
fn outputs(smt2: &str) -> Vec<(String, u32)> {
    let mut outs = Vec::new();
    for l in smt2.lines() {
        if let Some(r) = l.strip_prefix("; yosys-smt2-output ") {
            let mut it = r.split_whitespace();
            if let (Some(n), Some(w)) = (it.next(), it.next()) {
                outs.push((n.to_string(), w.parse::<u32>().unwrap_or(0)));
            }
        }
    }
    outs
}

/// The RTL and the netlist differ in state `state`: a `valid` or `ready`
/// output, or (while the RTL's `valid_o` is high) a data output.
fn differs_in(outs: &[(String, u32)], state: &str) -> String {
    let at = |p: &str| format!("(|fxs_miter_n {p}| {state})");
    let mut control = Vec::new();
    let mut data = Vec::new();
    for (n, _) in outs {
        let Some(port) = n.strip_prefix("gold_") else {
            continue;
        };
        let ne = format!("(not (= {} {}))", at(n), at(&format!("gate_{port}")));
        if port.ends_with("valid_o") || port.ends_with("ready_o") {
            control.push(ne);
        } else {
            data.push(ne);
        }
    }
    let mut any = control;
    if !data.is_empty() {
        any.push(format!(
            "(and {} (or {}))",
            at("gold_valid_o"),
            data.join(" ")
        ));
    }
    format!("(or false {})", any.join(" "))
}

/// The window query for one circuit of the miter (`side`: `gold_` or
/// `gate_`) over `depth` cycles, restricted to its cone of influence: two
/// runs from any two states in cycle 1 (`s1`, `r1`), the same inputs, the
/// reset among them, in cycles 1‥D; do its compared outputs differ between
/// the runs in cycle D, or in any cycle when cycle 1 is a reset? `unsat`:
/// D cycles after any state, and every cycle after a reset, its outputs
/// are a function of the inputs alone. Registers outside the cone are free
/// (an assumption dropped: `unsat` is still a proof).
fn window_query(smt2: &str, side: &str, depth: u32) -> String {
    let g = crate::smt2_model::Smt2Model::parse("fxs_miter", smt2);
    let mut ins = Vec::new();
    for l in smt2.lines() {
        if let Some(r) = l.strip_prefix("; yosys-smt2-input ") {
            ins.extend(r.split_whitespace().next().map(str::to_string));
        }
    }
    let outs: Vec<(String, u32)> = outputs(smt2)
        .into_iter()
        .filter(|(n, _)| n.starts_with(side))
        .collect();
    // Cone cycle k is state k + 1.
    let roots: Vec<(String, u32)> = (0..depth)
        .flat_map(|k| {
            outs.iter()
                .map(move |(n, _)| (format!("fxs_miter_n {n}"), k))
        })
        .collect();
    let (trans, _) = g.cone(&roots, &std::collections::HashSet::new(), true);
    let mut q = String::from("(set-logic QF_BV)\n");
    q += smt2;
    q.push('\n');
    let on = |p: &str, c: &str, k: u32| format!("(|fxs_miter_n {p}| {c}{k})");
    for c in ["s", "r"] {
        for k in 1..=depth {
            let _ = writeln!(q, "(declare-const {c}{k} |fxs_miter_s|)");
        }
        for (next, field, k) in &trans {
            let _ = writeln!(
                q,
                "(assert (= (|{next}| {c}{}) (|{field}| {c}{})))",
                k + 1,
                k + 2
            );
        }
    }
    for k in 1..=depth {
        for i in &ins {
            if i != "in_clk_i" {
                let _ = writeln!(q, "(assert (= {} {}))", on(i, "s", k), on(i, "r", k));
            }
        }
    }
    let diff_at = |k: u32| {
        let mut diff = Vec::new();
        let mut data = Vec::new();
        for (n, _) in &outs {
            let ne = format!("(not (= {} {}))", on(n, "s", k), on(n, "r", k));
            if n.ends_with("valid_o") || n.ends_with("ready_o") {
                diff.push(ne);
            } else {
                data.push(ne);
            }
        }
        if !data.is_empty() {
            diff.push(format!(
                "(and {} (or {}))",
                on(&format!("{side}valid_o"), "s", k),
                data.join(" ")
            ));
        }
        format!("(or false {})", diff.join(" "))
    };
    let early: Vec<String> = (1..depth).map(diff_at).collect();
    let _ = writeln!(
        q,
        "(assert (or {} (and (not {}) (or false {}))))\n(check-sat)",
        diff_at(depth),
        on("in_rst_ni", "s", 1),
        early.join(" ")
    );
    q
}

/// Each circuit's window query ([`window_query`]), both at once, each
/// under the product abstraction with its refinement: `Unsat` when both
/// are, else the first other answer.
fn windows(
    smt2: &str,
    depth: u32,
    solver: Solver,
    timeout: u64,
    t0: Instant,
) -> anyhow::Result<Reply> {
    std::thread::scope(|sc| {
        let hs = ["gold_", "gate_"].map(|side| {
            let q = window_query(smt2, side, depth);
            sc.spawn(move || {
                let left = || {
                    if timeout == 0 {
                        0
                    } else {
                        timeout.saturating_sub(t0.elapsed().as_secs()).max(1)
                    }
                };
                solve_refined(solver, &q, &["s", "r"], 1..=depth, &left, &|p| {
                    Ok(Reply::Sat(p.to_vec()))
                })
                .map(|(r, _)| r)
            })
        });
        let mut all = Reply::Unsat;
        for h in hs {
            let r = h
                .join()
                .map_err(|_| anyhow::anyhow!("a window query panicked"))??;
            if !matches!(r, Reply::Unsat) && matches!(all, Reply::Unsat) {
                all = r;
            }
        }
        Ok(all)
    })
}

/// The miter's query from reset over `depth` cycles, and the terms to read
/// back from a model of it (every input and output pair in every cycle).
fn queries(m: &Module, smt2: &str, depth: u32) -> anyhow::Result<(String, Vec<String>)> {
    let mut ins = Vec::new();
    for l in smt2.lines() {
        if let Some(r) = l.strip_prefix("; yosys-smt2-input ") {
            ins.extend(r.split_whitespace().next().map(str::to_string));
        }
    }
    let outs = outputs(smt2);
    let at = |p: &str, k: u32| format!("(|fxs_miter_n {p}| s{k})");
    for p in ["in_rst_ni", "in_clk_i"] {
        anyhow::ensure!(
            ins.iter().any(|i| i == p),
            "{}: the miter has no input {p}",
            m.emitted.module
        );
    }
    // A difference in cycle k.
    let differs = |k: u32| differs_in(&outs, &format!("s{k}"));
    let mut from_reset = String::from("(set-logic QF_BV)\n");
    from_reset += smt2;
    for k in 0..=depth {
        let _ = writeln!(from_reset, "(declare-const s{k} |fxs_miter_s|)");
    }
    for k in 0..depth {
        let _ = writeln!(from_reset, "(assert (|fxs_miter_t| s{k} s{}))", k + 1);
    }
    let _ = writeln!(from_reset, "(assert (not {}))", at("in_rst_ni", 0));
    for k in 1..=depth {
        let _ = writeln!(from_reset, "(assert {})", at("in_rst_ni", k));
    }
    let d: Vec<String> = (1..=depth).map(differs).collect();
    let _ = writeln!(from_reset, "(assert (or {}))\n(check-sat)", d.join(" "));
    // The values to read back: every input in every cycle, every output
    // pair in every cycle.
    let mut want = Vec::new();
    for k in 0..=depth {
        for i in &ins {
            if i != "in_clk_i" {
                want.push(at(i, k));
            }
        }
        for (n, _) in &outs {
            if n.starts_with("gold_") || n.starts_with("gate_") {
                want.push(at(n, k));
            }
        }
    }
    let _ = writeln!(from_reset, "(get-value ({}))", want.join(" "));
    Ok((from_reset, want))
}

/// `query` with its products abstracted as the RTL proof does (a product
/// by a constant `c·2^k` as the product by `c` shifted: synthesis writes
/// it so), except those numbered in `keep`, and the products that are
/// whole function bodies.
fn abstracted(
    query: &str,
    keep: &HashSet<usize>,
) -> anyhow::Result<(String, Vec<crate::smt::ProductSite>)> {
    let (abs, _, sites) = crate::smt::abstract_products_sites(query, true, keep)?;
    let abs = abs.replacen(
        "(set-logic QF_BV)",
        &format!(
            "(set-logic QF_UFBV)\n{}",
            crate::smt::product_declarations()
        ),
        1,
    );
    Ok((abs, sites))
}

/// What [`solve_refined`] asks of a model whose products are all exact.
type Confirm<'a> = dyn Fn(&[(SExpr, SExpr)]) -> anyhow::Result<Reply> + 'a;

/// `query` (one `check-sat`) under the product abstraction, refined: when
/// a model gives an abstracted product a value that is not the product of
/// its operands' values (in some state `<p><k>`, `p` in `states`, `k` in
/// `cycles`), that product is made exact and the query asked again. A
/// model whose read-back products are all exact goes to `confirm`, whose
/// `Sat` is the answer; otherwise the query is asked with every product
/// exact. Returns the reply and how many products stayed abstract.
fn solve_refined(
    solver: Solver,
    query: &str,
    states: &[&str],
    cycles: std::ops::RangeInclusive<u32>,
    left: &dyn Fn() -> u64,
    confirm: &Confirm,
) -> anyhow::Result<(Reply, usize)> {
    let mut keep = HashSet::new();
    loop {
        let (abs, sites) = abstracted(query, &keep)?;
        let live: Vec<&crate::smt::ProductSite> =
            sites.iter().filter(|s| !keep.contains(&s.number)).collect();
        // Each live product's operands as functions of the state, and the
        // terms to read back: (number, width, product, a, b).
        let mut defs = String::new();
        let mut terms = Vec::new();
        for site in &live {
            let w = site.width;
            for (x, t) in [("a", &site.a), ("b", &site.b)] {
                let _ = writeln!(
                    defs,
                    "(define-fun fxs_site{}_{x} (({} {})) (_ BitVec {w}) {t})",
                    site.number, site.arg, site.arg_sort
                );
            }
            for p in states {
                for k in cycles.clone() {
                    let at = |f: &str| format!("({f} {p}{k})");
                    terms.push((
                        site.number,
                        w,
                        at(&format!("|{}|", site.function)),
                        at(&format!("fxs_site{}_a", site.number)),
                        at(&format!("fxs_site{}_b", site.number)),
                    ));
                }
            }
        }
        let gv: Vec<&str> = terms
            .iter()
            .flat_map(|(_, _, p, a, b)| [p.as_str(), a.as_str(), b.as_str()])
            .collect();
        for site in &live {
            for p in states {
                for k in cycles.clone() {
                    if let Some(l) = crate::smt::range_lemma(site, &format!("{p}{k}")) {
                        defs += &l;
                        defs.push('\n');
                    }
                }
            }
        }
        let mut script = abs.replacen("(check-sat)", &format!("{defs}(check-sat)"), 1);
        if !gv.is_empty() {
            script = if script.contains("(get-value (") {
                script.replacen("(get-value (", &format!("(get-value ({} ", gv.join(" ")), 1)
            } else {
                format!("{}\n(get-value ({}))\n", script.trim_end(), gv.join(" "))
            };
        }
        let reply = solver.check(&script, left())?;
        let Reply::Sat(pairs) = reply else {
            return Ok((reply, live.len()));
        };
        let val = |t: &str| {
            pairs
                .iter()
                .find(|(k, _)| k.to_string() == t)
                .and_then(|(_, v)| v.bits())
                .map(|(b, _)| b)
        };
        let mut wrong = HashSet::new();
        for (n, w, p, a, b) in &terms {
            if let (Some(p), Some(a), Some(b)) = (val(p), val(a), val(b)) {
                let mask = if *w >= 128 {
                    u128::MAX
                } else {
                    (1u128 << w) - 1
                };
                if a.wrapping_mul(b) & mask != p & mask {
                    wrong.insert(*n);
                }
            }
        }
        if wrong.is_empty() {
            return match confirm(&pairs)? {
                Reply::Sat(p) => Ok((Reply::Sat(p), live.len())),
                _ => Ok((solver.check(query, left())?, 0)),
            };
        }
        keep.extend(wrong);
    }
}

/// Prove the netlist in `netlist` equivalent to `m`'s RTL (scratch files in
/// `dir`).
///
/// # Errors
///
/// Yosys cannot build the miter, the correspondence or a stage query cannot be built, or the
/// solver fails to run; a counterexample is an `Ok` verdict.
pub fn prove(
    m: &Module,
    netlist: &Path,
    solver: Solver,
    timeout: u64,
    dir: &Path,
) -> anyhow::Result<Equiv> {
    let t0 = Instant::now();
    let smt2 = miter_smt2(m, netlist, dir)?;
    let depth = m.emitted.latency + 2;
    let (from_reset, want) = queries(m, &smt2, depth)?;
    let mut out = Equiv {
        module: m.emitted.module.clone(),
        latency: m.emitted.latency,
        verdict: Verdict::Unknown,
        solver,
        seconds: 0.0,
        reason: None,
        counterexample: None,
        products: 0,
        method: Method::Netlist(depth, 0),
    };
    let left = || {
        if timeout == 0 {
            0
        } else {
            timeout.saturating_sub(t0.elapsed().as_secs()).max(1)
        }
    };
    if let Some(d) = &crate::settings::get().smt_dump {
        let _ = std::fs::write(
            d.join(format!("{}-netlist-reset.smt2", out.module)),
            &from_reset,
        );
    }
    // The register correspondence: the greatest inductive subset of the
    // candidates, then the window.
    let text = std::fs::read_to_string(netlist.join(format!("{}.v", out.module)))
        .with_context(|| format!("--netlist: cannot read {}.v", out.module))?;
    let cands = crate::netlist_corr::candidates(&smt2, &m.text, &text);
    let outs = outputs(&smt2);
    let mut alive = vec![true; cands.len()];
    // Two simulations from reset drop the candidates that plainly fail.
    for seed in [0x9e37_79b9_7f4a_7c15_u64, 0x2545_f491_4f6c_dd1d] {
        let q = crate::netlist_corr::sim_query(&smt2, &cands, depth + 2, seed);
        if let Reply::Sat(pairs) = solver.check(&q, left())? {
            let n = cands.len();
            for (i, (_, v)) in pairs.iter().enumerate() {
                if v.atom() == Some("false") {
                    alive[i % n] = false;
                }
            }
        }
        if crate::settings::get().smt_dump.is_some() {
            eprintln!(
                "simulation: {} of {} candidates left, {:.1} s",
                alive.iter().filter(|a| **a).count(),
                cands.len(),
                t0.elapsed().as_secs_f64()
            );
        }
    }
    let step = loop {
        let live: Vec<&crate::netlist_corr::Candidate> = cands
            .iter()
            .zip(&alive)
            .filter_map(|(c, a)| a.then_some(c))
            .collect();
        let q = crate::netlist_corr::step_query(&smt2, &live, &|st| differs_in(&outs, st));
        let dump = &crate::settings::get().smt_dump;
        if let Some(d) = dump {
            let _ = std::fs::write(
                Path::new(d).join(format!("{}-netlist-step.smt2", out.module)),
                &q,
            );
            eprintln!(
                "step: {} live, {:.1} s",
                live.len(),
                t0.elapsed().as_secs_f64()
            );
        }
        // Under the product abstraction alone: a model may owe a failed
        // equality to a product's value, which only drops a candidate
        // (sound); the correspondence makes both sides' products the same
        // function of the same operands, so exact products are not needed.
        let (abs, sites) = abstracted(&q, &HashSet::new())?;
        let mut lemmas = String::new();
        for site in &sites {
            for st in ["s1", "s2"] {
                if let Some(l) = crate::smt::range_lemma(site, st) {
                    lemmas += &l;
                    lemmas.push('\n');
                }
            }
        }
        let abs = abs.replacen("(check-sat)", &format!("{lemmas}(check-sat)"), 1);
        if let Some(d) = &dump {
            let _ = std::fs::write(
                Path::new(d).join(format!("{}-netlist-step-abstracted.smt2", out.module)),
                &abs,
            );
        }
        let r = solver.check(&abs, left())?;
        match r {
            Reply::Unsat => break Ok(live.len()),
            Reply::Unknown(why) => {
                break Err(format!(
                    "the inductive step: {} answered {why}",
                    solver.name()
                ))
            }
            Reply::Sat(pairs) => {
                let failed: HashSet<usize> = pairs
                    .iter()
                    .filter(|(_, v)| v.atom() == Some("false"))
                    .filter_map(|(k, _)| k.atom()?.strip_prefix("fxs_k")?.parse().ok())
                    .collect();
                if failed.is_empty() {
                    break Err(format!(
                        "the outputs differ in a state where all {} equalities of the \
                         correspondence hold",
                        live.len()
                    ));
                }
                let idx: Vec<usize> = alive
                    .iter()
                    .enumerate()
                    .filter_map(|(i, a)| a.then_some(i))
                    .collect();
                for f in failed {
                    if dump.is_some() {
                        eprintln!("  dropped {}", live[f].name);
                    }
                    alive[idx[f]] = false;
                }
            }
        }
    };
    out.method = Method::Netlist(depth, *step.as_ref().unwrap_or(&0));
    if let Ok(n) = step {
        // The invariant must hold somewhere, or the step proves nothing.
        let live: Vec<&crate::netlist_corr::Candidate> = cands
            .iter()
            .zip(&alive)
            .filter_map(|(c, a)| a.then_some(c))
            .collect();
        match solver.check(&crate::netlist_corr::sanity_query(&smt2, &live), left())? {
            Reply::Sat(_) => {
                let w = windows(&smt2, depth, solver, timeout, t0)?;
                if crate::settings::get().smt_dump.is_some() {
                    eprintln!(
                        "window: {} at {:.1} s",
                        if matches!(w, Reply::Unsat) {
                            "unsat"
                        } else {
                            "not unsat"
                        },
                        t0.elapsed().as_secs_f64()
                    );
                }
                match w {
                    Reply::Unsat => out.verdict = Verdict::Proved,
                    Reply::Sat(_) => {
                        out.reason = Some(format!(
                            "the {n} equalities are inductive, but an output in cycle {depth} \
                             still depends on the state of cycle 1 (a register that keeps its \
                             value)"
                        ))
                    }
                    Reply::Unknown(why) => {
                        out.reason = Some(format!(
                            "the {n} equalities are inductive; window: {} answered {why}",
                            solver.name()
                        ))
                    }
                }
                out.seconds = t0.elapsed().as_secs_f64();
                return Ok(out);
            }
            Reply::Unsat => {
                out.reason = Some(format!("the {n} equalities hold in no state"));
            }
            Reply::Unknown(why) => {
                out.reason = Some(format!(
                    "the invariant's state: {} answered {why}",
                    solver.name()
                ));
            }
        }
        out.seconds = t0.elapsed().as_secs_f64();
        return Ok(out);
    }
    let step_failed = step.err().unwrap_or_default();
    // No correspondence: look for a difference from reset.
    // From reset: a model whose products are all exact is checked on the
    // circuit with its inputs fixed (the free initial state aside).
    let confirm = |pairs: &[(SExpr, SExpr)]| -> anyhow::Result<Reply> {
        let mut fix = String::new();
        for (t, v) in pairs {
            if t.to_string().contains("|fxs_miter_n in_") {
                let _ = writeln!(fix, "(assert (= {t} {v}))");
            }
        }
        let q = from_reset.replacen("\n(check-sat)\n", &format!("\n{fix}(check-sat)\n"), 1);
        solver.check(&q, left())
    };
    let (base, n) = solve_refined(solver, &from_reset, &["s"], 0..=depth, &left, &confirm)?;
    out.products = n;
    match base {
        Reply::Sat(pairs) => {
            out.verdict = Verdict::Counterexample;
            out.counterexample = Some(counterexample(m, &pairs, &want));
        }
        Reply::Unknown(why) => {
            out.reason = Some(format!(
                "{step_failed}; from reset: {} answered {why}",
                solver.name()
            ));
        }
        Reply::Unsat => {
            // The window: a model with every product exact is a real
            // dependence on the state.
            let w = windows(&smt2, depth, solver, timeout, t0)?;
            match w {
                Reply::Unsat => out.verdict = Verdict::Proved,
                Reply::Sat(_) => {
                    out.reason = Some(format!(
                        "equal for {depth} cycles from reset, but an output in cycle {depth} \
                         still depends on the state of cycle 1 (a register that keeps its \
                         value), so the check from reset does not cover every run"
                    ))
                }
                Reply::Unknown(why) => {
                    out.reason = Some(format!(
                        "equal for {depth} cycles from reset; window: {} answered {why}",
                        solver.name()
                    ))
                }
            }
        }
    }
    out.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// A port's code from its bits: two's complement when the field it
/// carries is signed (a port `n_x_i` carries field `nx`: names compared
/// without `_` and the `_i`/`_o` suffix); other ports as unsigned bits.
fn code(m: &Module, port: &str, bits: i128) -> i128 {
    let key = |n: &str| n.replace('_', "");
    let bare = port
        .strip_suffix("_i")
        .or_else(|| port.strip_suffix("_o"))
        .unwrap_or(port);
    let f = m
        .emitted
        .inputs
        .iter()
        .chain(&m.emitted.outputs)
        .find(|f| key(&f.name) == key(bare));
    match f {
        Some(f) if bits >= 0 && f.format.width() < 64 => f.format.from_bits(narrow::<u64, _>(bits)),
        _ => bits,
    }
}

/// The first cycle where the two differ, from a model of the query from
/// reset: the inputs of every cycle up to it, and both circuits' outputs.
fn counterexample(
    m: &Module,
    pairs: &[(crate::smt::SExpr, crate::smt::SExpr)],
    want: &[String],
) -> Counterexample {
    let val = |t: &str| {
        pairs
            .iter()
            .find(|(k, _)| k.to_string() == t)
            .and_then(|(_, v)| v.bits())
            .map_or(-1, |(b, _)| narrow::<i128, _>(b))
    };
    // (name, cycle) of each wanted term.
    let parse = |t: &str| -> Option<(String, u32)> {
        let name = t
            .split('|')
            .nth(1)?
            .strip_prefix("fxs_miter_n ")?
            .to_string();
        let k = t.rsplit(" s").next()?.trim_end_matches(')').parse().ok()?;
        Some((name, k))
    };
    let terms: Vec<(String, u32, i128)> = want
        .iter()
        .filter_map(|t| parse(t).map(|(n, k)| (n, k, val(t))))
        .collect();
    let first = (1..)
        .take_while(|k| terms.iter().any(|(_, c, _)| c == k))
        .find(|&k| {
            terms.iter().any(|(n, c, v)| {
                *c == k
                    && n.strip_prefix("gold_").is_some_and(|p| {
                        terms
                            .iter()
                            .any(|(g, gc, gv)| *gc == k && g == &format!("gate_{p}") && gv != v)
                    })
            })
        })
        .unwrap_or(0);
    let mut c = Counterexample {
        inputs: Vec::new(),
        rtl: Vec::new(),
        model: Vec::new(),
        vectors: None,
        reproduced: None,
    };
    for (n, k, v) in &terms {
        if *k > first {
            continue;
        }
        if let Some(p) = n.strip_prefix("in_") {
            c.inputs.push((format!("{p}@{k}"), code(m, p, *v)));
        } else if *k == first {
            if let Some(p) = n.strip_prefix("gold_") {
                c.rtl.push((p.to_string(), code(m, p, *v)));
            } else if let Some(p) = n.strip_prefix("gate_") {
                c.model.push((p.to_string(), code(m, p, *v)));
            }
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `6·x` against `2x + 4x` as an adder tree: the abstraction admits a
    /// difference (the product is any function of `x`), the refinement
    /// finds the product's value wrong in the model, makes it exact and
    /// proves the two equal.
    #[test]
    fn refinement_makes_a_wrongly_valued_product_exact() {
        let q = "(set-logic QF_BV)\n(define-sort S () (_ BitVec 8))\n\
                 (define-fun x ((state S)) (_ BitVec 8) state)\n\
                 (define-fun p ((state S)) (_ BitVec 8) (bvmul (x state) #x06))\n\
                 (declare-const s0 S)\n\
                 (assert (not (= (p s0) (bvadd (bvshl (x s0) #x01) (bvshl (x s0) #x02)))))\n\
                 (check-sat)\n";
        let solver = Solver::Bitwuzla;
        let (abs, sites) = abstracted(q, &HashSet::new()).unwrap();
        assert_eq!(sites.len(), 1);
        assert!(matches!(solver.check(&abs, 0).unwrap(), Reply::Sat(_)));
        let (r, abstract_left) = solve_refined(solver, q, &["s"], 0..=0, &|| 0, &|p| {
            Ok(Reply::Sat(p.to_vec()))
        })
        .unwrap();
        assert_eq!(r, Reply::Unsat);
        assert_eq!(abstract_left, 0);
    }
}
