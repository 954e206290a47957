//! `fxshade rtl-check <unit>`: co-simulate the unit's RTL against the model.

use fxshade_model::convert::to_f64;
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use fxshade_model::rtl::units::VectorStream;

use super::{ConfigArgs, PipelineArgs};
use crate::output::{emit, OutputArgs, Table};
use crate::rtl_flow::{self, CheckResult, Sim};

/// `fxshade rtl-check`
#[derive(Args, Debug)]
pub struct RtlCheckArgs {
    /// The unit.
    #[arg(value_parser = super::unit_arg(&[]))]
    unit: String,
    #[command(flatten)]
    cfg: ConfigArgs,
    #[command(flatten)]
    pipe: PipelineArgs,
    /// Simulator.
    #[arg(long, value_enum, default_value_t = Sim::Verilator)]
    sim: Sim,
    /// Number of vectors in the whole stream (streamed: memory does not
    /// grow with it).
    #[arg(long, default_value_t = 10_000)]
    count: usize,
    /// Seed of the vectors and of the testbench's random stalls.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// `--shard K/N|auto`: check only shard K of N (0-based), a
    /// deterministic, disjoint slice of the same stream (the corner cases
    /// are in shard 0). Combine the shards' results with `fxshade merge`.
    #[command(flatten)]
    shard: crate::shard_args::ShardArgs,
    /// Build the simulator into the cache and exit (a dependency job run
    /// once before a job array, so its tasks do not all build it).
    #[arg(long)]
    prebuild: bool,
    /// Also write the summary (`--json`'s) to `DIR/shard-K-of-N.json`
    /// (`DIR/run.json` without `--shard`), whole or not at all — a failed
    /// run too, and a run that stopped with an error writes a record of
    /// the error there — for `fxshade merge DIR`.
    #[arg(long, value_name = "DIR")]
    result: Option<PathBuf>,
    /// Simulations to run at once, each on a slice of the run (default: one
    /// on Verilator, whose simulator costs less than generating the
    /// vectors; one per core on Icarus).
    #[arg(long, value_name = "J")]
    jobs: Option<usize>,
    /// Percent of cycles with valid (input) or ready (output) held low.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(0..=90))]
    stall: u32,
    /// Write a waveform (FST with Verilator, VCD with Icarus) to this file
    /// (default: <unit>.fst or <unit>.vcd). Runs one job.
    // A String, not a PathBuf: clap refuses an empty path, and the empty
    // default_missing_value is what `--trace` alone gives.
    #[arg(long, value_name = "FILE", num_args = 0..=1, default_missing_value = "")]
    trace: Option<String>,
    /// Simulate the design files (`*.v`, testbenches excluded) of this
    /// directory instead of the Verilog `fxshade rtl` emits (for hand-edited
    /// RTL); the generated testbench and vectors are used as usual.
    #[arg(long, value_name = "DIR")]
    rtl_dir: Option<PathBuf>,
    /// Simulate the module behind an interface wrapper (`axis`:
    /// AXI4-Stream), the vectors driven through the wrapper's ports.
    #[arg(long, value_enum, value_name = "KIND")]
    wrap: Option<super::Wrap>,
    #[command(flatten)]
    out: OutputArgs,
}

/// One run's (or one shard's) summary, as `--json` prints it and `fxshade
/// merge` reads it.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct RunSummary {
    /// Unit.
    pub unit: String,
    /// Variant.
    pub variant: String,
    /// Simulator.
    pub sim: String,
    /// Hash of the effective configuration.
    pub config_hash: String,
    /// Seed.
    pub seed: u64,
    /// Vectors in the whole stream.
    pub total: usize,
    /// `[K, N]` when one shard was checked.
    pub shard: Option<(usize, usize)>,
    /// Where the shard came from and how its scheduler numbers tasks.
    pub scheduler: Option<crate::shard::Scheduler>,
    /// SHA-256 of the simulated design files and testbench
    /// ([`rtl_flow::Sources::fingerprint`]).
    pub design_fingerprint: String,
    /// Where the design came from (`emitted by fxshade rtl` or a directory).
    pub design_origin: String,
    /// The simulator's version line.
    pub simulator_version: String,
    /// fxshade's version.
    pub fxshade_version: String,
    /// First vector checked.
    pub first: usize,
    /// Vectors checked.
    pub count: usize,
    /// Passed.
    pub passed: u64,
    /// Failed.
    pub failed: u64,
    /// Smallest input-to-output latency seen, in cycles.
    pub latency: Option<u64>,
    /// Jobs.
    pub jobs: usize,
    /// Wall-clock seconds of the run, building excluded.
    pub seconds: f64,
    /// Vectors per CPU second of one simulator: the run's vectors over
    /// the CPU seconds of all its simulator processes (simulation, reading
    /// and checking records; not waiting for them). The same definition as
    /// each run's `vectors_per_second`.
    pub vectors_per_second: f64,
    /// The simulators together: [`Self::vectors_per_second`] times the
    /// jobs (what they reach when each has a core and never waits).
    #[serde(default)]
    pub vectors_per_second_all_simulators: f64,
    /// Vectors per wall-clock second of the whole run, generation
    /// included (end to end).
    pub vectors_per_second_end_to_end: f64,
    /// Seconds building.
    pub build_seconds: f64,
    /// Each job's result.
    #[serde(default, skip_deserializing)]
    pub runs: Vec<CheckResult>,
}

/// A run that stopped with an error, as `--result` records it for
/// `fxshade merge`.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct RunError {
    /// Always `error`.
    pub outcome: String,
    /// Unit.
    pub unit: String,
    /// `[K, N]`.
    pub shard: Option<(usize, usize)>,
    /// Where the shard came from.
    pub scheduler: Option<crate::shard::Scheduler>,
    /// The error, with its causes.
    pub error: String,
}

/// The file `--result DIR` writes for `shard`.
pub fn result_file(dir: &std::path::Path, shard: Option<(usize, usize)>) -> PathBuf {
    match shard {
        Some((k, n)) => dir.join(format!("shard-{k}-of-{n}.json")),
        None => dir.join("run.json"),
    }
}

/// Write `text` to `path` whole or not at all (a temporary file beside it,
/// synced, renamed).
fn write_whole(path: &std::path::Path, text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let dir = path.parent().unwrap_or(std::path::Path::new("."));
    let mut t = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("cannot write {}", path.display()))?;
    t.write_all(text.as_bytes())
        .and_then(|()| t.as_file().sync_all())
        .with_context(|| format!("cannot write {}", path.display()))?;
    t.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

/// Run it; exit status 0 only when every vector passed. With `--result`,
/// a run that stops with an error leaves a record of it.
pub fn run(a: &RtlCheckArgs) -> anyhow::Result<()> {
    let shard = a.shard.resolve()?;
    if let Some(dir) = &a.result {
        // Refuse a result directory that cannot be written before any work.
        std::fs::create_dir_all(dir)
            .with_context(|| format!("--result {}: cannot create it", dir.display()))?;
    }
    let r = run_shard(a, shard.as_ref());
    if let (Err(e), Some(dir)) = (&r, &a.result) {
        // An error after the summary was written (printing it to a closed
        // stdout) leaves the summary: it is the run's result.
        let written = RESULT_WRITTEN.load(std::sync::atomic::Ordering::SeqCst);
        if e.downcast_ref::<Failed>().is_none() && !written {
            let rec = RunError {
                outcome: "error".into(),
                unit: a.unit.clone(),
                shard: shard.as_ref().map(|s| (s.k, s.n)),
                scheduler: shard.as_ref().map(|s| s.scheduler.clone()),
                error: format!("{e:#}"),
            };
            let path = result_file(dir, rec.shard);
            let _ = write_whole(&path, &serde_json::to_string_pretty(&rec)?);
        }
    }
    r
}

/// Set once `--result`'s summary is written.
static RESULT_WRITTEN: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Vectors failed (the summary is written; not a run error).
#[derive(Debug)]
struct Failed(String);

impl std::fmt::Display for Failed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Failed {}

/// The default `--jobs`: one simulation on Verilator, whose simulator
/// costs a fraction of the vector generator for every unit (a second job
/// only competes with the generator threads for the cores: 5 % slower on
/// interp here, BENCHMARKS.md), and one per core on Icarus, which costs
/// several times the generator. A constant of the simulator, never of a
/// measured time: the slices (and with them the stall patterns each
/// simulation draws) must not depend on the machine's load.
fn default_jobs(sim: Sim, cores: usize) -> usize {
    match sim {
        Sim::Verilator => 1,
        Sim::Icarus => cores,
    }
}

fn run_shard(a: &RtlCheckArgs, shard: Option<&crate::shard::Shard>) -> anyhow::Result<()> {
    if a.jobs == Some(0) {
        return Err(crate::output::UsageError("--jobs 0: give at least 1".into()).into());
    }
    let kn = shard.map(|s| (s.k, s.n));
    let u = rtl_flow::unit(&a.unit)?;
    let cfg = a.cfg.resolve_with(&a.pipe.overrides())?;
    let stream = VectorStream::new(u, &cfg, a.count, a.seed, kn, super::search_mode()?)?;
    if let Some((k, n)) = kn {
        anyhow::ensure!(
            stream.count > 0,
            "--shard {k}/{n} of --count {}: this shard holds no vector (use fewer shards than vectors)",
            a.count
        );
    }
    let rtl = stream.rtl();
    let sources = match &a.rtl_dir {
        Some(d) => rtl_flow::Sources::from_dir(&rtl, d)?,
        None => rtl_flow::Sources::emitted(&rtl),
    };
    let sources = match a.wrap {
        Some(super::Wrap::Axis) => sources.with_axis(u.name, &stream.emitted),
        None => sources,
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
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = if trace.is_some() {
        1
    } else {
        a.jobs
            .unwrap_or_else(|| default_jobs(a.sim, cores))
            .clamp(1, 256)
            .min(stream.count.max(1))
    };
    // Build once, before the jobs share it.
    let b = rtl_flow::build(u.name, &sources, a.sim, trace.is_some())?;
    if a.prebuild {
        crate::output::print_out(&format!(
            "{} ({}) on {}: {} in {} ({:.1} s)\n",
            u.name,
            stream.design.variant,
            a.sim.version(),
            if b.seconds > 0.0 {
                "built"
            } else {
                "already built"
            },
            b.dir.display(),
            b.seconds
        ))?;
        return Ok(());
    }
    let start = std::time::Instant::now();
    let bar =
        (stream.count >= 1_000_000).then(|| crate::progress::bar(stream.count as u64, "rtl-check"));
    if let Some(b) = &bar {
        let b = b.clone();
        *rtl_flow::PROGRESS.lock().unwrap_or_else(|e| e.into_inner()) =
            Some(Box::new(move |n| b.inc(n)));
    }
    let results: Vec<anyhow::Result<CheckResult>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..jobs)
            .map(|j| {
                let slice = stream.slice(j, jobs);
                let (sources, trace) = (&sources, trace.as_deref());
                s.spawn(move || {
                    rtl_flow::check_with(&slice, sources, a.sim, a.seed, a.stall, trace, false)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err(anyhow::anyhow!("a job panicked")))
            })
            .collect()
    });
    let seconds = start.elapsed().as_secs_f64();
    rtl_flow::PROGRESS
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .take();
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let runs: Vec<CheckResult> = results.into_iter().collect::<anyhow::Result<_>>()?;
    let passed: u64 = runs.iter().map(|r| r.passed).sum();
    let failed: u64 = runs.iter().map(|r| r.failed).sum();
    let cpu: f64 = runs.iter().map(|r| r.sim_cpu_seconds).sum();
    let summary = RunSummary {
        unit: u.name.to_string(),
        variant: stream.design.variant.clone(),
        sim: format!("{:?}", a.sim).to_lowercase(),
        config_hash: format!(
            "{:016x}",
            fxshade_model::vectors::fingerprint(&[stream.design.config_toml.as_bytes()])
        ),
        seed: a.seed,
        total: a.count,
        shard: kn,
        scheduler: shard.map(|s| s.scheduler.clone()),
        design_fingerprint: sources.fingerprint(),
        design_origin: sources.origin.clone(),
        simulator_version: a.sim.version().to_string(),
        fxshade_version: env!("CARGO_PKG_VERSION").to_string(),
        first: stream.first,
        count: stream.count,
        passed,
        failed,
        latency: runs.iter().filter_map(|r| r.latency).min(),
        jobs,
        seconds,
        vectors_per_second: to_f64(stream.count) / cpu.max(1e-9),
        vectors_per_second_all_simulators: to_f64(stream.count) / cpu.max(1e-9) * to_f64(jobs),
        vectors_per_second_end_to_end: to_f64(stream.count) / seconds.max(1e-9),
        build_seconds: b.seconds,
        runs,
    };
    let mut t = Table::new([
        "unit",
        "simulator",
        "vectors",
        "passed",
        "failed",
        "latency (cycles)",
        "jobs",
        "vectors/s per simulator (CPU)",
        "vectors/s all simulators (CPU)",
        "vectors/s end to end (wall)",
        "build (s)",
    ])
    .titled(format!(
        "rtl-check {} ({}), configuration {}{}",
        u.name,
        stream.design.variant,
        cfg.describe(),
        match kn {
            Some((k, n)) => format!(
                ", shard {k}/{n}: vectors {}..{}",
                stream.first,
                stream.first + stream.count
            ),
            None => String::new(),
        }
    ));
    t.row([
        u.name.to_string(),
        summary.sim.clone(),
        stream.count.to_string(),
        passed.to_string(),
        failed.to_string(),
        summary
            .runs
            .iter()
            .filter_map(|r| r.latency)
            .min()
            .map_or("-".into(), |l| l.to_string()),
        jobs.to_string(),
        format!("{:.0}", summary.vectors_per_second),
        format!("{:.0}", summary.vectors_per_second_all_simulators),
        format!("{:.0}", summary.vectors_per_second_end_to_end),
        format!("{:.1}", b.seconds),
    ]);
    if !a.out.json {
        eprintln!("design: {}", sources.origin);
        for r in &summary.runs {
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
    }
    // Whether `fxshade equiv` proved this module (this Verilog, this
    // model, this program) before: read from the user's private cache.
    let equivalence = super::equiv::modules(&a.unit, &cfg, a.rtl_dir.as_deref())
        .ok()
        .and_then(|ms| ms.into_iter().next())
        .map_or_else(
            || "not proved (no model function)".to_string(),
            |m| super::equiv::status_line(&m, &a.unit),
        );
    if !a.out.json {
        eprintln!("equivalence with the model: {equivalence}");
    }
    let mut json = serde_json::to_value(&summary).context("summary")?;
    json["equivalence"] = serde_json::Value::String(equivalence);
    if let Some(dir) = &a.result {
        write_whole(&result_file(dir, kn), &serde_json::to_string_pretty(&json)?)?;
        RESULT_WRITTEN.store(true, std::sync::atomic::Ordering::SeqCst);
    }
    emit(a.out, &[t], &json)?;
    if failed != 0 || passed != stream.count as u64 {
        return Err(Failed(format!(
            "{} of {} vectors failed ({} passed)",
            stream.count as u64 - passed.min(stream.count as u64),
            stream.count,
            passed
        ))
        .into());
    }
    Ok(())
}
