//! `fxshade bench cosim`: the co-simulation's speed beside its baselines,
//! measured in one run on the same emitted modules and the same records.
//!
//! Per unit (and top), on Verilator, from the records written to a
//! temporary directory once:
//! - **fxshade's harness** (`rtl/tb/fxs_vector_main.h`, what `rtl-check`
//!   runs): every record's index and pad, every output, the handshake;
//! - **the minimal harness** (`rtl/tb/fxs_minimal_main.h`) on the same
//!   shell: every record read into memory first, valid and ready held
//!   high, every output compared and nothing else;
//! - **the Verilog testbench** (`rtl/tb/fxs_vector_tb.vh`, `--binary`),
//!   what Verilator ran before and Icarus still runs;
//! - **end to end**: `rtl-check`'s own path at `--jobs 1`, vectors
//!   generated and streamed to the harness while it simulates.
//!
//! Simulation rates are vectors per CPU second of the simulator process
//! (user + system), the median of `--repeats` alternated runs; the ratio
//! "end to end / simulation only" divides wall-clock rates (the records
//! from disk against generation overlapped with simulation). Every run
//! must end `N passed, 0 failed`: a harness that checks nothing is not
//! measured.

use fxshade_model::convert::{narrow, to_f64};
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use fxshade_model::rtl::units::VectorStream;
use fxshade_model::vectors::VectorSource;

use crate::output::{emit, OutputArgs, Table};
use crate::rtl_flow::{self, Sim, Sources};

/// Options of `bench cosim`.
#[derive(Args, Debug)]
pub struct CosimArgs {
    /// Units to measure (default: every unit, the smooth top and the
    /// mapped top, `pipeline:mapped`).
    units: Vec<String>,
    /// Vectors per run.
    #[arg(long, default_value_t = 1_000_000)]
    count: usize,
    /// Runs of each harness (alternated; the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Leave out the Verilog testbench (one `--binary` build per unit).
    #[arg(long)]
    no_verilog_tb: bool,
    #[command(flatten)]
    cfg: super::ConfigArgs,
    #[command(flatten)]
    out: OutputArgs,
}

/// One simulator process: wall and CPU seconds, and its output.
struct Timed {
    wall: f64,
    cpu: f64,
    text: String,
}

/// Run `cmd` to its end; its CPU time from `wait4`.
fn timed(cmd: &mut Command) -> anyhow::Result<Timed> {
    use std::io::Read;
    let start = Instant::now();
    let mut child = cmd
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .context("cannot run a benchmark simulation")?;
    let mut text = String::new();
    let mut err = String::new();
    let mut so = child.stdout.take().expect("piped");
    let mut se = child.stderr.take().expect("piped");
    std::thread::scope(|s| {
        s.spawn(|| se.read_to_string(&mut err));
        let _ = so.read_to_string(&mut text);
    });
    let mut status = 0;
    // SAFETY: a zeroed rusage is a valid out-parameter.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: reaping our own child.
    unsafe { libc::wait4(narrow::<i32, _>(child.id()), &mut status, 0, &mut ru) };
    let wall = start.elapsed().as_secs_f64();
    let tv = |t: libc::timeval| to_f64(t.tv_sec) + to_f64(t.tv_usec) * 1e-6;
    Ok(Timed {
        wall,
        cpu: tv(ru.ru_utime) + tv(ru.ru_stime),
        text: text + &err,
    })
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Write the stream's records to `dir/inputs.bin` and `dir/expected.bin`.
fn write_records(v: &VectorStream, dir: &Path) -> anyhow::Result<()> {
    use std::io::Write;
    let mut fi = std::io::BufWriter::new(std::fs::File::create(dir.join("inputs.bin"))?);
    let mut fe = std::io::BufWriter::new(std::fs::File::create(dir.join("expected.bin"))?);
    let mut start = 0;
    while start < v.len() {
        let len = 65_536.min(v.len() - start);
        let (mut bi, mut be) = (Vec::new(), Vec::new());
        v.records(start, len, &mut bi, &mut be)?;
        fi.write_all(&bi)?;
        fe.write_all(&be)?;
        start += len;
    }
    fi.flush()?;
    fe.flush()?;
    Ok(())
}

/// The measured figures of one unit.
#[derive(serde::Serialize)]
struct Row {
    unit: String,
    variant: String,
    count: usize,
    cycles_per_vector: f64,
    /// Vectors per simulator CPU second, fxshade's harness.
    fxshade_per_cpu_second: f64,
    /// The same, the minimal harness.
    minimal_per_cpu_second: f64,
    /// fxshade / minimal (target ≥ 0.70).
    ratio_to_minimal: f64,
    /// The Verilog testbench on Verilator, per CPU second.
    verilog_tb_per_cpu_second: Option<f64>,
    /// Simulation only, fxshade's harness on records from disk, per wall
    /// second.
    simulation_only_per_wall_second: f64,
    /// `rtl-check --jobs 1` end to end, per wall second.
    end_to_end_per_wall_second: f64,
    /// end to end / simulation only (target ≥ 0.60).
    ratio_end_to_end: f64,
    /// CPU seconds the generator spent in the end-to-end run.
    generator_cpu_seconds: f64,
}

fn bench_one(a: &CosimArgs, name: &str, tmp: &Path) -> anyhow::Result<Row> {
    let (unit, extra): (&str, Vec<String>) = match name {
        "pipeline:mapped" => ("pipeline", vec!["pipeline.path=\"mapped\"".into()]),
        n => (n, Vec::new()),
    };
    let u = rtl_flow::unit(unit)?;
    let cfg = a.cfg.resolve_with(&extra)?;
    let stream = VectorStream::new(u, &cfg, a.count, 1, None, super::search_mode()?)?;
    let rtl = stream.rtl();
    let sources = Sources::emitted(&rtl);
    let dir = tmp.join(name.replace(':', "-"));
    std::fs::create_dir_all(&dir)?;
    write_records(&stream, &dir)?;
    let tool = rtl_flow::build(u.name, &sources, Sim::Verilator, false)?;
    let mut min_src = sources.clone();
    if let Some(h) = &mut min_src.harness {
        h.minimal = true;
    }
    let minimal = rtl_flow::build(u.name, &min_src, Sim::Verilator, false)?;
    let tb = if a.no_verilog_tb {
        None
    } else {
        let mut s = sources.clone();
        s.harness = None;
        Some(rtl_flow::build(u.name, &s, Sim::Verilator, false)?)
    };
    let n = a.count;
    let want = format!("{n} passed, 0 failed");
    let run = |b: &rtl_flow::Build, checker: bool| -> anyhow::Result<Timed> {
        let mut c = Command::new(b.binary(Sim::Verilator));
        c.current_dir(&dir).arg(format!("+N={n}"));
        if checker {
            c.args(["+STALL=0", "+SEED=1", "+FIRST=0"]);
        }
        let t = timed(&mut c)?;
        if !t.text.contains(&want) {
            bail!(
                "{name}: a benchmark run did not pass every vector:\n{}",
                t.text.trim_end()
            );
        }
        Ok(t)
    };
    let (mut t_tool, mut t_min, mut t_tb, mut w_tool) = (vec![], vec![], vec![], vec![]);
    let mut cycles = None;
    for _ in 0..a.repeats.max(1) {
        let t = run(&tool, true)?;
        cycles = t
            .text
            .lines()
            .find_map(|l| l.strip_prefix("cycles ")?.trim().parse::<f64>().ok());
        t_tool.push(t.cpu);
        w_tool.push(t.wall);
        t_min.push(run(&minimal, false)?.cpu);
        if let Some(b) = &tb {
            t_tb.push(run(b, true)?.cpu);
        }
    }
    // End to end: rtl-check's own path, one job, no stalls.
    let mut e2e = Vec::new();
    let mut gen = 0.0;
    for _ in 0..a.repeats.max(1) {
        let r = rtl_flow::check_with(&stream, &sources, Sim::Verilator, 1, 0, None, false)?;
        anyhow::ensure!(r.ok(), "{name}: rtl-check failed in the benchmark");
        e2e.push(r.seconds);
        gen = r.generate_seconds;
    }
    let _ = std::fs::remove_dir_all(&dir);
    let per = |s: f64| to_f64(n) / s.max(1e-9);
    let (tool_r, min_r) = (per(median(t_tool)), per(median(t_min)));
    let (sim_w, e2e_w) = (per(median(w_tool)), per(median(e2e)));
    Ok(Row {
        unit: name.to_string(),
        variant: stream.design.variant.clone(),
        count: n,
        cycles_per_vector: cycles.unwrap_or(f64::NAN) / to_f64(n),
        fxshade_per_cpu_second: tool_r,
        minimal_per_cpu_second: min_r,
        ratio_to_minimal: tool_r / min_r,
        verilog_tb_per_cpu_second: (!t_tb.is_empty()).then(|| per(median(t_tb))),
        simulation_only_per_wall_second: sim_w,
        end_to_end_per_wall_second: e2e_w,
        ratio_end_to_end: e2e_w / sim_w,
        generator_cpu_seconds: gen,
    })
}

/// Run `bench cosim`.
pub fn run(a: &CosimArgs) -> anyhow::Result<()> {
    anyhow::ensure!(a.count > 0, "--count must be positive");
    let names: Vec<String> = if a.units.is_empty() {
        fxshade_model::rtl::units::all()
            .map(|u| u.name.to_string())
            .chain(["pipeline:mapped".to_string()])
            .collect()
    } else {
        a.units.clone()
    };
    let tmp = tempfile::tempdir().context("cannot make a temporary directory")?;
    let bar = crate::progress::bar(names.len() as u64, "bench cosim");
    let mut rows = Vec::new();
    for name in &names {
        bar.set_message(name.clone());
        rows.push(bench_one(a, name, tmp.path())?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let m = |x: f64| format!("{:.2}", x / 1e6);
    let mut t = Table::new([
        "unit",
        "cycles/vector",
        "fxshade M/s (CPU)",
        "minimal M/s (CPU)",
        "fxshade/minimal",
        "Verilog tb M/s (CPU)",
        "simulation only M/s (wall)",
        "end to end M/s (wall)",
        "end to end/simulation",
    ])
    .titled(format!(
        "bench cosim: Verilator ({}), {} vectors, no stalls, median of {} (targets: fxshade/minimal \
         >= 0.70, end to end/simulation >= 0.60)",
        Sim::Verilator.version(),
        a.count,
        a.repeats.max(1)
    ));
    for r in &rows {
        t.row([
            r.unit.clone(),
            format!("{:.2}", r.cycles_per_vector),
            m(r.fxshade_per_cpu_second),
            m(r.minimal_per_cpu_second),
            format!("{:.2}", r.ratio_to_minimal),
            r.verilog_tb_per_cpu_second.map_or("-".into(), m),
            m(r.simulation_only_per_wall_second),
            m(r.end_to_end_per_wall_second),
            format!("{:.2}", r.ratio_end_to_end),
        ]);
    }
    let json = serde_json::json!({
        "bench": "cosim",
        "simulator": Sim::Verilator.version(),
        "count": a.count,
        "repeats": a.repeats.max(1),
        "cores": std::thread::available_parallelism().map_or(1, |n| n.get()),
        "units": rows,
    });
    emit(a.out, &[t], &json)
}
