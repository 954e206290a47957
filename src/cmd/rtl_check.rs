//! `fxshade rtl-check <unit>`: co-simulate the unit's RTL against the model.

use std::path::PathBuf;

use clap::Args;

use super::ConfigArgs;
use crate::output::{emit, OutputArgs, Table};
use crate::rtl_flow::{self, Sim};

/// `fxshade rtl-check`
#[derive(Args, Debug)]
pub struct RtlCheckArgs {
    /// The unit (interp, normalize, polar, lighting, angle_interp, pipeline).
    unit: String,
    #[command(flatten)]
    cfg: ConfigArgs,
    /// Simulator.
    #[arg(long, value_enum, default_value_t = Sim::Verilator)]
    sim: Sim,
    /// Number of vectors.
    #[arg(long, default_value_t = 10_000)]
    count: usize,
    /// Seed of the vectors and of the testbench's random stalls.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Percent of cycles with valid (input) or ready (output) held low.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(0..=90))]
    stall: u32,
    /// Write a waveform (FST with Verilator, VCD with Icarus) to this file
    /// (default: <unit>.fst or <unit>.vcd).
    // A String, not a PathBuf: clap refuses an empty path, and the empty
    // default_missing_value is what `--trace` alone gives.
    #[arg(long, value_name = "FILE", num_args = 0..=1, default_missing_value = "")]
    trace: Option<String>,
    /// Simulate the design files (`*.v`, testbenches excluded) of this
    /// directory instead of the Verilog `fxshade rtl` emits (for hand-edited
    /// RTL); the generated testbench and vectors are used as usual.
    #[arg(long, value_name = "DIR")]
    rtl_dir: Option<PathBuf>,
    #[command(flatten)]
    out: OutputArgs,
}

/// Run it; exit status 0 only when every vector passed.
pub fn run(a: &RtlCheckArgs) -> anyhow::Result<()> {
    let u = rtl_flow::unit(&a.unit)?;
    let cfg = a.cfg.resolve()?;
    let v = fxshade_model::rtl::units::vectors(u, &cfg, a.count, a.seed)?;
    let sources = match &a.rtl_dir {
        Some(d) => rtl_flow::Sources::from_dir(&v, d)?,
        None => rtl_flow::Sources::emitted(&v),
    };
    let trace = a.trace.as_ref().map(|t| {
        if t.is_empty() {
            PathBuf::from(format!(
                "{}.{}",
                u.name,
                if a.sim == Sim::Verilator {
                    "fst"
                } else {
                    "vcd"
                }
            ))
        } else {
            PathBuf::from(t)
        }
    });
    let r = rtl_flow::check_with(
        &v,
        &sources,
        a.sim,
        a.seed,
        a.stall,
        trace.as_deref(),
        false,
    )?;
    let mut t = Table::new([
        "unit",
        "simulator",
        "vectors",
        "passed",
        "failed",
        "latency (cycles)",
        "vectors/s (simulation)",
        "load (s)",
        "vectors/s (with load)",
        "build (s)",
    ])
    .titled(format!(
        "rtl-check {} ({}), configuration {}",
        u.name, v.variant, cfg.source
    ));
    t.row([
        u.name.to_string(),
        format!("{:?}", a.sim).to_lowercase(),
        r.count.to_string(),
        r.passed.to_string(),
        r.failed.to_string(),
        r.latency.map_or("-".into(), |l| l.to_string()),
        format!("{:.0}", r.vectors_per_second),
        format!("{:.2}", r.load_seconds),
        format!("{:.0}", r.vectors_per_second_end_to_end),
        format!("{:.1}", r.build_seconds),
    ]);
    if !a.out.json {
        eprintln!("design: {}", r.design);
        for m in &r.mismatches {
            eprintln!("{m}");
        }
        for e in &r.errors {
            eprintln!("{e}");
        }
        if let Some(p) = &r.trace {
            eprintln!("waveform: {}", p.display());
        }
    }
    emit(a.out, &[t], &serde_json::to_value(&r)?)?;
    anyhow::ensure!(
        r.ok(),
        "{} of {} vectors failed ({} passed)",
        r.count as u64 - r.passed.min(r.count as u64),
        r.count,
        r.passed
    );
    Ok(())
}
