//! `fxshade bench engine`: the bit-accurate engine on every instruction set
//! this CPU has, against the same program as straight-line C compiled with
//! `-O3 -march=native` (issue #35, item 2).
//!
//! Per workload (each unit's default design and the multiply-add chain),
//! on the same input codes: the engine's compiled batch run
//! ([`Program::run_into_on`]) on each available path (portable, AVX2,
//! AVX-512), and the program's C ([`Program::c_source`]) in a separate
//! process that reads the same codes, runs the kernel once, writes its
//! outputs and overflow counts (compared with the engine's, every lane,
//! before any time is reported) and then times itself. Times are CPU
//! seconds per vector, the median of `--repeats` alternated measurements,
//! each at least `--seconds` long.

use std::io::Write as _;
use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context};
use clap::Args;
use fxshade_model::convert::{narrow, to_f64};
use fxshade_model::datapath::{Compiled, Datapath, Isa, Program, Trace};
use fxshade_model::mad_chain::mad_chain;
use fxshade_model::rtl::units::{self, Part};
use fxshade_model::{Overflow, Quant, Rounding};

use super::bench_render::{cpu_now, median};
use crate::output::{emit, OutputArgs, Table};

/// Options of `bench engine`.
#[derive(Args, Debug)]
pub struct EngineArgs {
    /// Input vectors per workload.
    #[arg(long, default_value_t = 1 << 16)]
    inputs: usize,
    /// Minimum CPU seconds of each measurement.
    #[arg(long, default_value_t = 0.3)]
    seconds: f64,
    /// Alternated measurements of each variant (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// The baseline's C compiler (run as `CC -O3 -march=native`).
    #[arg(long, default_value = "cc")]
    cc: String,
    /// Workloads to measure (repeatable): a unit with RTL (its design for
    /// `--config`/`--set`, the embedded default without them) or `mad-chain` (16 steps, I2F14, half-even). Default: every
    /// unit but the pipeline tops, and the chain.
    #[arg(long = "workload")]
    workloads: Vec<String>,
    /// Keep each workload's C (kernel.c, main.c), its inputs and the
    /// baseline's executable in DIR/WORKLOAD (a new or empty directory).
    #[arg(long, value_name = "DIR")]
    keep: Option<std::path::PathBuf>,
    #[command(flatten)]
    cfg: super::ConfigArgs,
    #[command(flatten)]
    out: OutputArgs,
}

/// A program and its input columns.
struct Workload {
    name: String,
    prog: Program<i64>,
    cols: Vec<Vec<i64>>,
}

fn unit_workload(
    name: &str,
    cfg: &fxshade_model::Config,
    n: usize,
) -> anyhow::Result<Option<Workload>> {
    let u = units::unit(name).with_context(|| {
        format!(
            "--workload {name}: not a unit with RTL ({}) nor mad-chain",
            units::names()
        )
    })?;
    let d = u.design(cfg).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let outs: Vec<_> = d.trace.output_ports().iter().map(|p| p.value).collect();
    let Compiled::Narrow(prog) = Compiled::compile(&d.trace, &outs)? else {
        return Ok(None);
    };
    let rows = (u.inputs)(cfg, Part::Random(n), 1).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let cols = (0..d.trace.input_ports().len())
        .map(|k| rows.iter().map(|r| narrow::<i64, _>(r[k])).collect())
        .collect();
    Ok(Some(Workload {
        name: name.to_string(),
        prog,
        cols,
    }))
}

fn mad_workload(n: usize) -> anyhow::Result<Workload> {
    let fmt = "I2F14".parse()?;
    let q = Quant::new("x", fmt, Rounding::HalfEven, Overflow::Saturate);
    let qc = Quant::new("coef", fmt, Rounding::HalfEven, Overflow::Saturate);
    let mut rng = fxshade_model::sampling::Rng::new(1);
    let mut tr = Trace::new();
    let x = tr.input(&q);
    let c: Vec<_> = (0..16)
        .map(|_| {
            Ok((
                tr.constant(rng.uniform(-0.9, 0.9), &qc)?,
                tr.constant(rng.uniform(-0.1, 0.1), &qc)?,
            ))
        })
        .collect::<anyhow::Result<_>>()?;
    let y = mad_chain(&mut tr, &c, x, &q);
    let prog = Program::<i64>::compile(&tr, &[y])?;
    let col = (0..n)
        .map(|_| Ok(narrow::<i64, _>(q.apply_f64(rng.uniform(-1.0, 1.0))?.code)))
        .collect::<anyhow::Result<_>>()?;
    Ok(Workload {
        name: "mad-chain".into(),
        prog,
        cols: vec![col],
    })
}

/// CPU nanoseconds per vector of the engine on `isa`.
fn time_engine(w: &Workload, isa: Isa, secs: f64) -> f64 {
    let refs: Vec<&[i64]> = w.cols.iter().map(Vec::as_slice).collect();
    let mut outs = vec![Vec::new(); w.prog.output_fracs().len()];
    let (mut reps, c0) = (0u64, cpu_now());
    while cpu_now() - c0 < secs || reps == 0 {
        std::hint::black_box(
            w.prog
                .run_into_on(isa, std::hint::black_box(&refs), &mut outs),
        );
        reps += 1;
    }
    (cpu_now() - c0) * 1e9 / (to_f64(reps) * to_f64(w.cols[0].len()))
}

/// The baseline's `main`: read the codes, run once, write the outputs and
/// overflow counts, then time `repeats` measurements of `seconds` each.
fn c_main(w: &Workload) -> String {
    format!(
        r#"/* Generated by fxshade bench engine: the C baseline's driver. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#define N_IN {n_in}
#define N_OUT {n_out}
#define N_ST {n_st}
void fxs_kernel(size_t n, const int64_t *const *in, int64_t *const *out, uint64_t *ov);
static double cpu(void)
{{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}}
int main(int argc, char **argv)
{{
    if (argc != 5) return 2;
    FILE *f = fopen(argv[1], "rb");
    uint64_t n;
    if (!f || fread(&n, 8, 1, f) != 1) return 3;
    const int64_t *in[N_IN];
    int64_t *out[N_OUT];
    for (int i = 0; i < N_IN; i++) {{
        int64_t *p = malloc(n * 8);
        if (!p || fread(p, 8, n, f) != n) return 3;
        in[i] = p;
    }}
    fclose(f);
    for (int j = 0; j < N_OUT; j++) {{
        out[j] = malloc(n * 8);
        if (!out[j]) return 3;
    }}
    uint64_t ov[N_ST] = {{0}};
    fxs_kernel(n, in, out, ov);
    FILE *g = fopen(argv[2], "wb");
    if (!g) return 4;
    for (int j = 0; j < N_OUT; j++)
        if (fwrite(out[j], 8, n, g) != n) return 4;
    if (fwrite(ov, 8, N_ST, g) != N_ST || fclose(g) != 0) return 4;
    double secs = atof(argv[3]);
    int reps = atoi(argv[4]);
    for (int r = 0; r < reps; r++) {{
        uint64_t it = 0, scratch[N_ST] = {{0}};
        double t0 = cpu();
        do {{
            fxs_kernel(n, in, out, scratch);
            it++;
        }} while (cpu() - t0 < secs);
        printf("%.6f\n", (cpu() - t0) * 1e9 / ((double)it * (double)n));
    }}
    return 0;
}}
"#,
        n_in = w.cols.len(),
        n_out = w.prog.output_fracs().len(),
        n_st = w.prog.stage_names().len().max(1),
    )
}

/// Build the C baseline of `w` in `dir`, run it, check its outputs against
/// the engine's and return its times (CPU ns per vector, one per repeat).
fn run_c(a: &EngineArgs, w: &Workload, dir: &Path) -> anyhow::Result<Vec<f64>> {
    let src = w
        .prog
        .c_source()
        .map_err(|e| anyhow::anyhow!("{}: {e}", w.name))?;
    let (k, m, exe) = (
        dir.join("kernel.c"),
        dir.join("main.c"),
        dir.join("baseline"),
    );
    std::fs::write(&k, src)?;
    std::fs::write(&m, c_main(w))?;
    let o = Command::new(&a.cc)
        .args(["-O3", "-march=native", "-std=gnu99", "-o"])
        .arg(&exe)
        .arg(&k)
        .arg(&m)
        .output()
        .with_context(|| format!("--cc {}: cannot run the C compiler", a.cc))?;
    if !o.status.success() {
        bail!(
            "{}: the C baseline did not compile:\n{}",
            w.name,
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let n = w.cols[0].len();
    let mut bytes = Vec::with_capacity(8 + 8 * n * w.cols.len());
    bytes.extend_from_slice(&u64::try_from(n)?.to_le_bytes());
    for c in &w.cols {
        for v in c {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let (inf, outf) = (dir.join("in.bin"), dir.join("out.bin"));
    std::fs::write(&inf, bytes)?;
    let o = Command::new(&exe)
        .arg(&inf)
        .arg(&outf)
        .arg(format!("{}", a.seconds))
        .arg(a.repeats.to_string())
        .output()
        .with_context(|| format!("{}: cannot run the C baseline", w.name))?;
    if !o.status.success() {
        bail!("{}: the C baseline failed ({})", w.name, o.status);
    }
    // Bit for bit against the engine.
    let refs: Vec<&[i64]> = w.cols.iter().map(Vec::as_slice).collect();
    let (outs, ov) = w.prog.run(&refs);
    let got = std::fs::read(&outf)?;
    let word = |i: usize| {
        let b: [u8; 8] = got[8 * i..8 * i + 8].try_into().expect("8 bytes");
        i64::from_le_bytes(b)
    };
    let n_st = w.prog.stage_names().len();
    if got.len() != 8 * (n * outs.len() + n_st.max(1)) {
        bail!("{}: the C baseline wrote {} bytes", w.name, got.len());
    }
    for (j, o) in outs.iter().enumerate() {
        for (i, &e) in o.iter().enumerate() {
            if word(j * n + i) != e {
                bail!(
                    "{}: the C baseline differs from the engine at output {j}, vector {i}: {} \
                     against {e}",
                    w.name,
                    word(j * n + i)
                );
            }
        }
    }
    let c_ov: Vec<(&str, u64)> = w
        .prog
        .stage_names()
        .iter()
        .enumerate()
        .map(|(s, name)| (*name, word(n * outs.len() + s).cast_unsigned()))
        .filter(|(_, c)| *c > 0)
        .collect();
    if c_ov != ov {
        bail!(
            "{}: the C baseline's overflow counts {c_ov:?} differ from the engine's {ov:?}",
            w.name
        );
    }
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| {
            l.trim()
                .parse::<f64>()
                .with_context(|| format!("{}: the C baseline printed `{l}`", w.name))
        })
        .collect()
}

/// Run it.
///
/// # Errors
///
/// Bad flags, a workload that does not build, a C compiler that fails, or
/// a baseline whose outputs differ from the engine's.
pub fn run(a: &EngineArgs) -> anyhow::Result<()> {
    if a.inputs == 0 || a.repeats == 0 || !(a.seconds > 0.0 && a.seconds.is_finite()) {
        return Err(crate::output::UsageError(
            "--inputs and --repeats must be positive and --seconds a positive number".into(),
        )
        .into());
    }
    let names: Vec<String> = if a.workloads.is_empty() {
        units::all()
            .filter(|u| u.name != "pipeline")
            .map(|u| u.name.to_string())
            .chain(["mad-chain".to_string()])
            .collect()
    } else {
        a.workloads.clone()
    };
    let cfg = a.cfg.resolve()?;
    let isas: Vec<Isa> = Isa::ALL.into_iter().filter(|i| i.available()).collect();
    let tmp = tempfile::tempdir().context("cannot make a temporary directory")?;
    let root = match &a.keep {
        Some(k) => {
            let listed = || std::fs::read_dir(k).with_context(|| format!("--keep {}", k.display()));
            if k.exists() && listed()?.next().is_some() {
                return Err(crate::output::UsageError(format!(
                    "--keep {}: not empty (it must be new or empty)",
                    k.display()
                ))
                .into());
            }
            std::fs::create_dir_all(k)
                .with_context(|| format!("--keep {}: cannot create it", k.display()))?;
            k.clone()
        }
        None => tmp.path().to_path_buf(),
    };
    let mut head = vec!["workload".to_string(), "ops/vector".to_string()];
    head.extend(isas.iter().map(|i| format!("engine {} (ns)", i.name())));
    head.extend(["C -O3 -march=native (ns)".into(), "engine/C".into()]);
    let mut t = Table::new(head).titled(format!(
        "engine: CPU ns per vector, {} vectors, median of {} alternated runs; engine path \
         used: {}",
        a.inputs,
        a.repeats,
        Isa::current().name()
    ));
    let mut rows_json = Vec::new();
    for name in &names {
        let w = if name == "mad-chain" {
            mad_workload(a.inputs)?
        } else if let Some(w) = unit_workload(name, &cfg, a.inputs)? {
            w
        } else {
            eprintln!("bench engine: {name} needs 128-bit codes; the C baseline is 64-bit only");
            continue;
        };
        eprintln!("bench engine: {name}");
        let dir = root.join(&w.name);
        std::fs::create_dir_all(&dir)?;
        let c = run_c(a, &w, &dir)?;
        let mut eng: Vec<Vec<f64>> = vec![Vec::new(); isas.len()];
        for _ in 0..a.repeats {
            for (k, &isa) in isas.iter().enumerate() {
                eng[k].push(time_engine(&w, isa, a.seconds));
            }
        }
        let eng: Vec<f64> = eng.into_iter().map(median).collect();
        let c_ns = median(c);
        let best = eng.last().copied().unwrap_or(f64::NAN);
        let counts = w.prog.counts();
        let ops = counts.mul + counts.add + counts.table_read;
        let mut row = vec![w.name.clone(), ops.to_string()];
        row.extend(eng.iter().map(|x| format!("{x:.2}")));
        row.extend([format!("{c_ns:.2}"), format!("{:.2}", best / c_ns)]);
        t.row(row);
        let per: serde_json::Map<String, serde_json::Value> = isas
            .iter()
            .zip(&eng)
            .map(|(i, x)| (i.name().to_string(), (*x).into()))
            .collect();
        rows_json.push(serde_json::json!({
            "workload": w.name,
            "engine_ns": per,
            "c_ns": c_ns,
            "engine_over_c": best / c_ns,
            "outputs_checked": w.cols[0].len() * w.prog.output_fracs().len(),
        }));
    }
    let _ = std::io::stderr().flush();
    let json = serde_json::json!({
        "bench": "engine",
        "inputs": a.inputs,
        "repeats": a.repeats,
        "cc": a.cc,
        "isa_used": Isa::current().name(),
        "isas": isas.iter().map(|i| i.name()).collect::<Vec<_>>(),
        "workloads": rows_json,
    });
    emit(a.out, &[t], &json)
}
