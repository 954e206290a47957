//! `fxshade formal <unit>|all`: prove the handshake properties every
//! generated module carries in its `ifdef FORMAL` block (no item created,
//! lost or duplicated; `valid_o` and the outputs held under stall; the
//! pipeline drains) with Yosys, yosys-smtbmc and z3.
//!
//! The datapath is abstracted: every combinational datapath wire's driver
//! becomes a cut point (Yosys's `cutpoint`: a free value each cycle). The
//! properties do not read the data, and an abstraction admits every
//! behaviour of the real logic and more, so a proof of the abstracted
//! module is a proof of the module; registers, the valid chain, the stall
//! and the outputs stay exactly as emitted. Each module is checked three
//! ways: bounded model checking from reset (`--depth` cycles) and
//! k-induction (the same depth): both passing is an unbounded proof. With
//! `--cover`, a cover run must also reach an output transfer from reset.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;

use super::{ConfigArgs, PipelineArgs};
use crate::output::{emit, OutputArgs, Table, UsageError};

/// `fxshade formal`
#[derive(Args, Debug)]
pub struct FormalArgs {
    /// The unit, or `all`: every module `fxshade rtl all` writes (every
    /// unit and the pipeline top of every path).
    #[arg(value_parser = super::unit_arg(&["all"]))]
    unit: String,
    #[command(flatten)]
    cfg: ConfigArgs,
    #[command(flatten)]
    pipe: PipelineArgs,
    /// Induction depth (and the bounded check's): the properties are
    /// inductive at 2.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=20))]
    depth: u32,
    /// Also search for an output transfer from reset (a cover run of
    /// latency + 4 cycles: slow on the deep tops, minutes).
    #[arg(long)]
    cover: bool,
    /// Prove the modules in this directory (`<module>.v`, e.g. hand-edited
    /// RTL that keeps its `ifdef FORMAL` block) instead of the Verilog
    /// `fxshade rtl` emits.
    #[arg(long, value_name = "DIR")]
    rtl_dir: Option<std::path::PathBuf>,
    /// Modules to prove at once (default: the machine's cores); each runs
    /// Yosys and yosys-smtbmc on one core.
    #[arg(long, value_name = "J")]
    jobs: Option<usize>,
    /// Prove each module behind an interface wrapper (`axis`): the
    /// wrapper's AXI4-Stream master rules with the module's properties.
    #[arg(long, value_enum, value_name = "KIND")]
    wrap: Option<super::Wrap>,
    #[command(flatten)]
    out: OutputArgs,
}

/// One module's result.
#[derive(Debug, serde::Serialize)]
struct Proof {
    module: String,
    latency: u32,
    bmc: bool,
    induction: bool,
    cover: Option<bool>,
    seconds: f64,
    /// The first failing property or the tool's error, when one failed.
    failure: Option<String>,
}

/// The datapath's combinational wires of an emitted module: every `wire
/// NAME = …;` between its `// Datapath.` and `// Pipeline registers` lines.
pub fn datapath_wires(verilog: &str) -> Vec<String> {
    let (Some(a), Some(b)) = (
        verilog.find("  // Datapath."),
        verilog.find("  // Pipeline registers"),
    ) else {
        return Vec::new();
    };
    verilog[a..b]
        .lines()
        .filter_map(|l| {
            let l = l.trim_start().strip_prefix("wire ")?;
            let (lhs, _) = l.split_once(" = ")?;
            lhs.split_whitespace()
                .last()
                .filter(|n| n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
                .map(str::to_string)
        })
        .collect()
}

/// The Yosys script that reads `file` (module `top`) with its formal
/// properties, cuts the datapath and writes `out` for yosys-smtbmc.
pub fn yosys_script(file: &str, top: &str, wires: &[String], out: &str) -> String {
    let mut s = format!("read_verilog -formal -sv {file}\nprep -top {top}\n");
    if !wires.is_empty() {
        // The drivers of the datapath wires (never a register, a memory or
        // a port: those stay as emitted).
        let sel: Vec<String> = wires.iter().map(|w| format!("w:{w}")).collect();
        s += &format!("select -set dpw {}\n", sel.join(" "));
        s += "cutpoint @dpw %ci1 w:* %d t:$dff %d t:$adff %d t:$mem* %d\n";
        s += "opt_clean\n";
    }
    s += &format!("async2sync\ndffunmap\nwrite_smt2 {out}\n");
    s
}

fn smtbmc(dir: &Path, args: &[&str], what: &str) -> anyhow::Result<(bool, String)> {
    let mut c = Command::new("yosys-smtbmc");
    c.current_dir(dir).args(["-s", "z3", "--unroll"]).args(args);
    let text = crate::proc::run(&mut c, what, crate::proc::Limit::formal(), None)?.text();
    let status = text
        .lines()
        .rev()
        .find(|l| l.contains("Status:"))
        .map(|l| l.contains("PASSED"));
    match status {
        Some(ok) => {
            // The failing property (its source line), else the verdict.
            let pick = |pat: &str| {
                text.lines()
                    .find(|l| l.contains(pat))
                    .map(|l| l.split("  ").last().unwrap_or(l).trim().to_string())
            };
            let why = pick("Assert failed")
                .or_else(|| pick("Unreached"))
                .or_else(|| pick("failed"))
                .unwrap_or_default();
            Ok((ok, why))
        }
        None => bail!(
            "{what} gave no status; its output:\n{}",
            text.lines()
                .rev()
                .take(15)
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect::<Vec<_>>()
                .join("\n")
        ),
    }
}

/// Prove one emitted module in `dir` (a scratch directory).
fn prove(
    module: &str,
    verilog: &str,
    latency: u32,
    depth: u32,
    cover: bool,
    dir: &Path,
) -> anyhow::Result<Proof> {
    let t0 = Instant::now();
    let file = format!("{module}.v");
    std::fs::write(dir.join(&file), verilog).context("cannot write the module")?;
    let smt = format!("{module}.smt2");
    let ys = yosys_script(&file, module, &datapath_wires(verilog), &smt);
    let o = crate::proc::yosys_script(dir, "formal.ys", &ys, "yosys (formal model)")?;
    let text = o.text();
    if !o.status.success() {
        bail!("yosys could not build the formal model of {module}:\n{text}");
    }
    let d = depth.to_string();
    let (bmc, w1) = smtbmc(dir, &["-t", &d, &smt], "yosys-smtbmc (bounded)")?;
    let (ind, w2) = smtbmc(dir, &["-i", "-t", &d, &smt], "yosys-smtbmc (induction)")?;
    let (cov, w3) = if cover {
        let cd = (latency + 4).to_string();
        let (c, w) = smtbmc(dir, &["-c", "-t", &cd, &smt], "yosys-smtbmc (cover)")?;
        (Some(c), w)
    } else {
        (None, String::new())
    };
    let failure = [(bmc, w1), (ind, w2), (cov != Some(false), w3)]
        .into_iter()
        .find(|(ok, _)| !ok)
        .map(|(_, w)| w);
    Ok(Proof {
        module: module.to_string(),
        latency,
        bmc,
        induction: ind,
        cover: cov,
        seconds: t0.elapsed().as_secs_f64(),
        failure,
    })
}

/// Run it.
pub fn run(a: &FormalArgs) -> anyhow::Result<()> {
    if a.jobs == Some(0) {
        return Err(UsageError("--jobs 0: give at least 1".into()).into());
    }
    crate::rtl_flow::require_tool("yosys", "yosys")?;
    if !crate::proc::has("yosys-smtbmc", "-h") {
        bail!("yosys-smtbmc is not installed: it comes with Debian's yosys (`sudo apt-get install yosys`)");
    }
    if !crate::proc::has("z3", "--version") {
        bail!("z3 is not installed: install it with `sudo apt-get install z3` (./scripts/test does it when run as root)");
    }
    let cfg = a.cfg.resolve_with(&a.pipe.overrides())?;
    let (units, modules): (Vec<&'static str>, Vec<fxshade_model::rtl::Emitted>) = if a.unit == "all"
    {
        super::rtl::emit_all(&cfg)?
            .into_iter()
            .map(|(u, e)| (u.name, e))
            .unzip()
    } else {
        let u = crate::rtl_flow::unit(&a.unit)?;
        (
            vec![u.name],
            vec![fxshade_model::rtl::units::emit_unit(u, &cfg)?.1],
        )
    };
    let dir = tempfile::Builder::new()
        .prefix("fxshade-formal-")
        .tempdir()
        .context("cannot create a temporary directory")?;
    // Every module's text first, so that a missing file or property block
    // is an error before any proof starts.
    let texts = modules
        .iter()
        .map(|e| {
            let text = match &a.rtl_dir {
                None => e.verilog.clone(),
                Some(d) => {
                    let f = d.join(format!("{}.v", e.module));
                    std::fs::read_to_string(&f)
                        .with_context(|| format!("--rtl-dir: cannot read {}", f.display()))?
                }
            };
            if !text.contains("`ifdef FORMAL") {
                bail!(
                    "{}: the module has no `ifdef FORMAL block of properties to prove",
                    e.module
                );
            }
            Ok(text)
        })
        .zip(&units)
        .zip(&modules)
        .map(|((text, unit), e)| {
            let text = text?;
            Ok(match a.wrap {
                Some(super::Wrap::Axis) => {
                    // The wrapper of --rtl-dir when it holds one, else the
                    // emitted one.
                    let own = a
                        .rtl_dir
                        .as_ref()
                        .map(|d| d.join(format!("{}_axis.v", e.module)))
                        .filter(|f| f.exists());
                    let wrapper = match own {
                        Some(f) => std::fs::read_to_string(&f)
                            .with_context(|| format!("--rtl-dir: cannot read {}", f.display()))?,
                        None => fxshade_model::rtl::axis::wrapper(unit, e),
                    };
                    (format!("{}_axis", e.module), text + "\n" + &wrapper)
                }
                None => (e.module.clone(), text),
            })
        })
        .collect::<anyhow::Result<Vec<(String, String)>>>()?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = a.jobs.map_or(cores, |j| j.min(256));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .context("cannot start the worker threads")?;
    let bar = crate::progress::bar(modules.len() as u64, "formal");
    // Each module in a scratch directory of its own; results in the
    // modules' order.
    let proofs = pool.install(|| {
        use rayon::prelude::*;
        modules
            .par_iter()
            .zip(&texts)
            .enumerate()
            .map(|(k, (e, (top, text)))| {
                let sub = dir.path().join(k.to_string());
                std::fs::create_dir(&sub).context("cannot create a scratch directory")?;
                let p = prove(top, text, e.latency, a.depth, a.cover, &sub)?;
                bar.set_message(top.clone());
                bar.inc(1);
                Ok(p)
            })
            .collect::<anyhow::Result<Vec<Proof>>>()
    })?;
    bar.finish_and_clear();
    let mut t = Table::new([
        "module",
        "latency",
        "bounded",
        "induction",
        "cover",
        "seconds",
    ])
    .titled(format!(
        "Handshake properties (yosys-smtbmc, z3; depth {}; datapath cut)",
        a.depth
    ));
    let verdict = |b: bool| if b { "proved" } else { "FAILED" }.to_string();
    for p in &proofs {
        t.row([
            p.module.clone(),
            p.latency.to_string(),
            verdict(p.bmc),
            verdict(p.induction),
            match p.cover {
                Some(true) => "reached",
                Some(false) => "NOT REACHED",
                None => "-",
            }
            .to_string(),
            format!("{:.1}", p.seconds),
        ]);
    }
    let ok = proofs
        .iter()
        .all(|p| p.bmc && p.induction && p.cover != Some(false));
    emit(
        a.out,
        &[t],
        &serde_json::json!({ "ok": ok, "modules": proofs }),
    )?;
    if !ok {
        let bad: Vec<String> = proofs
            .iter()
            .filter(|p| p.failure.is_some())
            .map(|p| format!("{}: {}", p.module, p.failure.clone().unwrap_or_default()))
            .collect();
        bail!("the handshake properties fail: {}", bad.join("; "));
    }
    Ok(())
}
