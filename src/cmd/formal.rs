//! `fxshade formal <unit>|all`: the arguments and the printed verdicts of
//! the handshake proofs ([`fxshade_flows::formal`] proves them).

use anyhow::{bail, Context};
use clap::Args;
use fxshade_flows::formal;

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

/// Run it.
pub fn run(a: &FormalArgs) -> anyhow::Result<()> {
    if a.jobs == Some(0) {
        return Err(UsageError("--jobs 0: give at least 1".into()).into());
    }
    formal::require_tools()?;
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
    let bar = crate::progress::bar(modules.len() as u64, "formal");
    let done = |top: &str| {
        bar.set_message(top.to_string());
        bar.inc(1);
    };
    let targets: Vec<formal::Module> = modules
        .iter()
        .zip(texts)
        .map(|(e, (top, text))| formal::Module {
            top,
            text,
            latency: e.latency,
        })
        .collect();
    let proofs = formal::prove_all(&targets, a.depth, a.cover, jobs, &done);
    bar.finish_and_clear();
    let proofs = proofs?;
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
    let ok = proofs.iter().all(formal::Proof::ok);
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
