//! `fxshade equiv <unit> --netlist DIR`: prove the gate-level netlist that
//! `fxshade synth --netlist` wrote (Yosys's ECP5 mapping, then the register
//! packing into MULT18X18D blocks) equivalent to the emitted RTL, as
//! sequential circuits.
//!
//! Yosys reads both, the netlist with the cell models written beside it,
//! and builds a miter (`miter -equiv -make_outputs`): one circuit holding
//! both, same inputs, both outputs. fxshade unrolls its SMT-LIB 2 model
//! (products abstracted as in the RTL proof) and asks, with `ready_i` high
//! (no stalls: the RTL's handshake proofs cover those),
//!
//! 1. **from reset** (`rst_ni` low in cycle 0, every input free after),
//!    for a difference in cycles 1‥D;
//! 2. **induction**: from *any* pair of states, `rst_ni` high, for a
//!    difference in cycle D.
//!
//! A difference is a `valid`/`ready` output that differs, or (while the
//! RTL's `valid_o` is high) a data output or `ovf_o` that differs: data
//! under a low `valid_o` is nobody's to read. D is the latency and 2: with
//! `ready_i` high every pipeline register loads each cycle, so after the
//! latency both circuits' state is a function of the inputs alone. Both
//! `unsat`: equal at every cycle of every run from reset. A model of (1)
//! is a counterexample from reset, checked on the real products; a model
//! of (2) alone is not (the states may be unreachable): `unknown`.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use anyhow::{bail, Context};

use crate::cmd::equiv::{Counterexample, Equiv, Method, Module, Verdict};
use crate::smt::{Reply, Solver};

/// The miter's SMT-LIB 2 model: Yosys reads the RTL (`fxs_gold`) and the
/// netlist with its cell models (`fxs_gate`) from `netlist` and writes it.
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
    let q = |p: &Path| format!("\"{}\"", p.display().to_string().replace('"', "\\\""));
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
         async2sync\ndffunmap\nwrite_smt2 -stbv -wires miter.smt2",
        q(&std::fs::canonicalize(&top)?)
    );
    std::fs::write(dir.join("miter.ys"), ys).context("cannot write the Yosys script")?;
    let mut y = std::process::Command::new("yosys");
    y.current_dir(dir).args(["-q", "-s", "miter.ys"]);
    let o = crate::proc::run(
        &mut y,
        "yosys (netlist miter)",
        crate::proc::Limit::formal(),
        None,
    )?;
    if !o.status.success() {
        bail!(
            "yosys could not build the miter of {module} and its netlist:\n{}",
            o.text().trim_end()
        );
    }
    std::fs::read_to_string(dir.join("miter.smt2")).context("yosys wrote no miter model")
}

/// The miter's unrolled queries: (from reset, induction, the inputs to read
/// back from a model as (port, cycle), the output pairs compared).
fn queries(m: &Module, smt2: &str, depth: u32) -> anyhow::Result<(String, String, Vec<String>)> {
    let mut ins = Vec::new();
    let mut outs = Vec::new();
    for l in smt2.lines() {
        if let Some(r) = l.strip_prefix("; yosys-smt2-input ") {
            ins.extend(r.split_whitespace().next().map(str::to_string));
        }
        if let Some(r) = l.strip_prefix("; yosys-smt2-output ") {
            let mut it = r.split_whitespace();
            if let (Some(n), Some(w)) = (it.next(), it.next()) {
                outs.push((n.to_string(), w.parse::<u32>().unwrap_or(0)));
            }
        }
    }
    let at = |p: &str, k: u32| format!("(|fxs_miter_n {p}| s{k})");
    for p in ["in_rst_ni", "in_ready_i", "in_clk_i"] {
        anyhow::ensure!(
            ins.iter().any(|i| i == p),
            "{}: the miter has no input {p}",
            m.emitted.module
        );
    }
    // A difference in cycle k.
    let differs = |k: u32| -> String {
        let mut control = Vec::new();
        let mut data = Vec::new();
        for (n, _) in &outs {
            let Some(port) = n.strip_prefix("gold_") else {
                continue;
            };
            let ne = format!("(not (= {} {}))", at(n, k), at(&format!("gate_{port}"), k));
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
                at("gold_valid_o", k),
                data.join(" ")
            ));
        }
        format!("(or {})", any.join(" "))
    };
    let unroll = |reset: bool| {
        let mut s = String::from("(set-logic QF_BV)\n");
        s += smt2;
        for k in 0..=depth {
            let _ = writeln!(s, "(declare-const s{k} |fxs_miter_s|)");
        }
        for k in 0..depth {
            let _ = writeln!(s, "(assert (|fxs_miter_t| s{k} s{}))", k + 1);
        }
        for k in 0..=depth {
            let _ = writeln!(s, "(assert {})", at("in_ready_i", k));
            if reset && k == 0 {
                let _ = writeln!(s, "(assert (not {}))", at("in_rst_ni", k));
            } else {
                let _ = writeln!(s, "(assert {})", at("in_rst_ni", k));
            }
        }
        s
    };
    let mut from_reset = unroll(true);
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
    let mut induction = unroll(false);
    let _ = writeln!(induction, "(assert {})\n(check-sat)", differs(depth));
    let last: Vec<&String> = want
        .iter()
        .filter(|t| t.ends_with(&format!(" s{depth})")))
        .collect();
    let _ = writeln!(
        induction,
        "(get-value ({}))",
        last.iter()
            .map(|t| t.as_str())
            .collect::<Vec<_>>()
            .join(" ")
    );
    Ok((from_reset, induction, want))
}

/// Abstract the products of `script` (as the RTL proof does).
fn abstracted(script: &str) -> anyhow::Result<String> {
    let (abs, _) = crate::smt::abstract_products(script)?;
    Ok(abs.replacen(
        "(set-logic QF_BV)",
        &format!(
            "(set-logic QF_UFBV)\n{}",
            crate::smt::product_declarations()
        ),
        1,
    ))
}

/// Prove the netlist in `netlist` equivalent to `m`'s RTL (scratch files in
/// `dir`).
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
    let (from_reset, induction, want) = queries(m, &smt2, depth)?;
    let mut out = Equiv {
        module: m.emitted.module.clone(),
        latency: m.emitted.latency,
        verdict: Verdict::Unknown,
        solver,
        seconds: 0.0,
        reason: None,
        counterexample: None,
        products: 0,
        method: Method::Netlist(depth),
    };
    let left = || {
        if timeout == 0 {
            0
        } else {
            timeout.saturating_sub(t0.elapsed().as_secs()).max(1)
        }
    };
    if let Some(d) = std::env::var_os("FXSHADE_SMT_DUMP") {
        let d = Path::new(&d);
        let _ = std::fs::write(
            d.join(format!("{}-netlist-reset.smt2", out.module)),
            &from_reset,
        );
        let _ = std::fs::write(
            d.join(format!("{}-netlist-step.smt2", out.module)),
            &induction,
        );
    }
    let abs = abstracted(&from_reset)?;
    out.products = abs.matches("(fxs_mulc ").count();
    let base = match solver.check(&abs, left())? {
        Reply::Sat(pairs) => {
            // Check it on the real products, every input fixed.
            let mut fix = String::new();
            for (t, v) in &pairs {
                if t.to_string().contains("|fxs_miter_n in_") {
                    let _ = writeln!(fix, "(assert (= {t} {v}))");
                }
            }
            let concrete =
                from_reset.replacen("\n(check-sat)\n", &format!("\n{fix}(check-sat)\n"), 1);
            solver.check(&concrete, left())?
        }
        r => r,
    };
    match base {
        Reply::Sat(pairs) => {
            out.verdict = Verdict::Counterexample;
            out.counterexample = Some(counterexample(&pairs, &want));
        }
        Reply::Unknown(why) => {
            out.reason = Some(format!("from reset: {} answered {why}", solver.name()));
        }
        Reply::Unsat => match solver.check(&abstracted(&induction)?, left())? {
            Reply::Unsat => out.verdict = Verdict::Proved,
            Reply::Sat(_) => {
                out.reason = Some(format!(
                    "equal for {depth} cycles from reset, but the induction step fails \
                     (two states, maybe unreachable, that differ {depth} cycles on)"
                ))
            }
            Reply::Unknown(why) => {
                out.reason = Some(format!("induction: {} answered {why}", solver.name()))
            }
        },
    }
    out.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// The first cycle where the two differ, from a model of the query from
/// reset: the inputs of every cycle up to it, and both circuits' outputs.
fn counterexample(
    pairs: &[(crate::smt::SExpr, crate::smt::SExpr)],
    want: &[String],
) -> Counterexample {
    let val = |t: &str| {
        pairs
            .iter()
            .find(|(k, _)| k.to_string() == t)
            .and_then(|(_, v)| v.bits())
            .map_or(-1, |(b, _)| b as i128)
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
            c.inputs.push((format!("{p}@{k}"), *v));
        } else if *k == first {
            if let Some(p) = n.strip_prefix("gold_") {
                c.rtl.push((p.to_string(), *v));
            } else if let Some(p) = n.strip_prefix("gate_") {
                c.model.push((p.to_string(), *v));
            }
        }
    }
    c
}
