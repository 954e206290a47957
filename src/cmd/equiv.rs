//! `fxshade equiv <unit>|all`: the arguments and the printed verdicts of
//! the equivalence proofs ([`fxshade_flows::equiv`] proves them).

use anyhow::{bail, Context};
use clap::Args;
pub use fxshade_flows::equiv::*;
use fxshade_flows::smt::Solver;
use std::path::PathBuf;

use super::{ConfigArgs, PipelineArgs};
use crate::output::{emit, OutputArgs, Table, UsageError};

/// `fxshade equiv`
#[derive(Args, Debug)]
pub struct EquivArgs {
    /// The unit, or `all`: every module `fxshade rtl all` writes (every
    /// unit and the pipeline top of every path).
    #[arg(value_parser = super::unit_arg(&["all"]))]
    unit: String,
    #[command(flatten)]
    cfg: ConfigArgs,
    #[command(flatten)]
    pipe: PipelineArgs,
    /// Prove the modules in this directory (`<module>.v`, e.g. hand-edited
    /// RTL) instead of the Verilog `fxshade rtl` emits.
    #[arg(long, value_name = "DIR")]
    rtl_dir: Option<PathBuf>,
    /// Prove the gate-level netlist in this directory (what `fxshade synth
    /// <unit> --target ecp5 --netlist DIR` wrote: `<module>.v` and its cell
    /// models) equivalent to the RTL, sequentially (registers moved),
    /// instead of the RTL against the model. Give the configuration and
    /// pipelining the netlist was synthesized with.
    #[arg(long, value_name = "DIR")]
    netlist: Option<PathBuf>,
    /// The SMT solver.
    #[arg(long, value_enum, default_value_t = Solver::Bitwuzla)]
    solver: Solver,
    /// The solver's time limit per module, seconds (0: none); a module
    /// past it is `unknown`, never proved. The limit is wall time: on a
    /// loaded machine a proof near it may come out `unknown`.
    #[arg(long, value_name = "S", default_value_t = 600)]
    timeout: u64,
    /// Where a counterexample's vector set is written, one directory per
    /// module (`DIR/<module>`, replaced if fxshade wrote it).
    #[arg(long, value_name = "DIR", default_value = "equiv-cex")]
    cex_dir: PathBuf,
    /// Modules to prove at once (default: the machine's cores).
    #[arg(long, value_name = "J")]
    jobs: Option<usize>,
    #[command(flatten)]
    out: OutputArgs,
}

/// A proof's outcome.
/// Run it.
pub fn run(a: &EquivArgs) -> anyhow::Result<()> {
    if a.jobs == Some(0) {
        return Err(UsageError("--jobs 0: give at least 1".into()).into());
    }
    crate::rtl_flow::require_tool("yosys", "yosys")?;
    a.solver.version()?;
    let cfg = a.cfg.resolve_with(&a.pipe.overrides())?;
    let mods = modules(&a.unit, &cfg, a.rtl_dir.as_deref())?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = a.jobs.map_or(cores, |j| j.min(256));
    let res = match &a.netlist {
        None => {
            let bar = crate::progress::bar(mods.len() as u64, "equiv");
            let done = |m: &str| {
                bar.set_message(m.to_string());
                bar.inc(1);
            };
            let res = prove_all(&mods, a.solver, a.timeout, jobs, Some(&a.cex_dir), &done);
            bar.finish_and_clear();
            res?
        }
        Some(dir) => {
            if a.rtl_dir.is_some() {
                return Err(UsageError(
                    "--netlist proves a netlist against the emitted RTL; give --netlist or \
                     --rtl-dir, not both"
                        .into(),
                )
                .into());
            }
            if mods.len() != 1 {
                return Err(UsageError(format!(
                    "--netlist {}: give the one unit the netlist is of, not `{}`",
                    dir.display(),
                    a.unit
                ))
                .into());
            }
            let scratch = tempfile::Builder::new()
                .prefix("fxshade-equiv-")
                .tempdir()
                .context("cannot create a temporary directory")?;
            vec![crate::netlist_equiv::prove(
                &mods[0],
                dir,
                a.solver,
                a.timeout,
                scratch.path(),
            )?]
        }
    };
    let versus = if a.netlist.is_some() {
        "netlist"
    } else {
        "model"
    };
    let mut t = Table::new([
        "module",
        "latency",
        "equivalence",
        "method",
        "solver",
        "seconds",
    ])
    .titled(if a.netlist.is_some() {
        "Equivalence of the gate-level netlist with the RTL, every input sequence from reset \
         (no stalls)"
    } else {
        "Equivalence of the RTL with the traced datapath, every input value (no stalls; \
         stalls: `fxshade formal`)"
    });
    for p in &res {
        t.row([
            p.module.clone(),
            p.latency.to_string(),
            match p.verdict {
                Verdict::Proved => "proved".to_string(),
                Verdict::Counterexample => "COUNTEREXAMPLE".to_string(),
                Verdict::Unknown => format!("unknown after {:.0} s", p.seconds),
            },
            p.method.to_string(),
            p.solver.name().to_string(),
            format!("{:.1}", p.seconds),
        ]);
    }
    let mut tables = vec![t];
    for p in &res {
        if let Some(c) = &p.counterexample {
            let mut ct = Table::new(["port", "value"]).titled(format!(
                "{}: counterexample{}",
                p.module,
                match (&c.vectors, c.reproduced) {
                    (Some(v), Some(true)) => format!(" (vectors in {v}; Verilator fails on them)"),
                    (Some(v), Some(false)) => format!(
                        " (vectors in {v}; Verilator passes them: the difference needs the \
                         registers' power-up values)"
                    ),
                    (Some(v), None) => format!(" (vectors in {v})"),
                    (None, _) => String::new(),
                }
            ));
            for (n, v) in &c.inputs {
                ct.row([format!("in {n}"), v.to_string()]);
            }
            for ((n, r), (_, mv)) in c.rtl.iter().zip(&c.model) {
                ct.row([
                    format!("out {n}"),
                    format!(
                        "rtl {r}, {versus} {mv}{}",
                        if r == mv { "" } else { "  <- differs" }
                    ),
                ]);
            }
            tables.push(ct);
        }
    }
    let ok = res.iter().all(|p| p.verdict == Verdict::Proved);
    emit(
        a.out,
        &tables,
        &serde_json::json!({ "ok": ok, "modules": res }),
    )?;
    if !ok {
        let bad: Vec<String> = res
            .iter()
            .filter(|p| p.verdict != Verdict::Proved)
            .map(|p| {
                format!(
                    "{}: {}",
                    p.module,
                    match p.verdict {
                        Verdict::Counterexample => "counterexample".to_string(),
                        _ => p.reason.clone().unwrap_or_else(|| "unknown".into()),
                    }
                )
            })
            .collect();
        bail!("not proved: {}", bad.join("; "));
    }
    Ok(())
}
