//! `fxshade bench`: speed of the model (figures go in BENCHMARKS.md; no test
//! asserts a time).

use std::hint::black_box;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::{Args, Subcommand};
use fxshade_model::datapath::{Compiled, Count, Datapath, Fixed, Reference, Trace};
use fxshade_model::mad_chain::mad_chain;
use fxshade_model::quantize::Raw;
use fxshade_model::{Format, Overflow, Quant, Rounding};

use crate::output::{emit, OutputArgs, Table};

/// `fxshade bench ...`
#[derive(Subcommand, Debug)]
pub enum BenchCmd {
    /// A chain of multiply-adds `x ← Q(a·x + b)` with run-time formats,
    /// bit-accurate, against the same chain in f64 on the same inputs.
    MadChain(MadChainArgs),
}

/// Options of `bench mad-chain`.
#[derive(Args, Debug)]
pub struct MadChainArgs {
    /// Number of input values.
    #[arg(long, default_value_t = 1 << 14)]
    inputs: usize,
    /// Multiply-adds per chain.
    #[arg(long, default_value_t = 16)]
    length: usize,
    /// Format of x and of every quantized step.
    #[arg(long, default_value = "I2F14")]
    format: Format,
    /// Format of the coefficients a and b.
    #[arg(long, default_value = "I2F14")]
    coef_format: Format,
    /// Rounding mode of each step (trunc, half_up, half_even).
    #[arg(long, default_value = "half_even", value_parser = parse_round)]
    round: Rounding,
    /// Minimum measuring time per context, in seconds.
    #[arg(long, default_value_t = 1.0)]
    seconds: f64,
    #[command(flatten)]
    out: OutputArgs,
}

fn parse_round(s: &str) -> Result<Rounding, String> {
    Rounding::from_name(s).ok_or_else(|| format!("`{s}` is not trunc, half_up or half_even"))
}

/// SplitMix64: a small, well-known generator for reproducible inputs.
pub struct SplitMix(pub u64);
impl SplitMix {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn time_per_mad<C: Datapath>(
    cx: &mut C,
    coefs: &[(C::V, C::V)],
    xs: &[C::V],
    q: &Quant,
    min: Duration,
) -> f64 {
    let mut reps = 0u64;
    let start = Instant::now();
    while start.elapsed() < min || reps == 0 {
        for &x in xs {
            black_box(mad_chain(cx, black_box(coefs), x, q));
        }
        reps += 1;
    }
    start.elapsed().as_secs_f64() * 1e9 / (reps as f64 * xs.len() as f64 * coefs.len() as f64)
}

fn time_fixed<R: Raw>(
    xs: &[f64],
    ab: &[(f64, f64)],
    q: &Quant,
    qc: &Quant,
    min: Duration,
) -> anyhow::Result<f64> {
    let mut fx = Fixed::<R>::new();
    let fxs = load(&mut fx, xs, q)?;
    let fc: Vec<_> = ab
        .iter()
        .map(|&(x, y)| Ok((fx.constant(x, qc)?, fx.constant(y, qc)?)))
        .collect::<anyhow::Result<_>>()?;
    Ok(time_per_mad(&mut fx, &fc, &fxs, q, min))
}

/// The compiled batch path: trace the chain once, run it over all inputs.
fn time_compiled(
    xs: &[f64],
    ab: &[(f64, f64)],
    q: &Quant,
    qc: &Quant,
    min: Duration,
) -> anyhow::Result<f64> {
    let mut tr = Trace::new();
    let x = tr.input(q);
    let c: Vec<_> = ab
        .iter()
        .map(|&(a, b)| Ok((tr.constant(a, qc)?, tr.constant(b, qc)?)))
        .collect::<anyhow::Result<_>>()?;
    let y = mad_chain(&mut tr, &c, x, q);
    let prog = Compiled::compile(&tr, &[y])?;
    let codes: Vec<i128> = xs
        .iter()
        .map(|&v| Ok(q.apply_f64(v)?.code))
        .collect::<anyhow::Result<_>>()?;
    let per = |t: f64, reps: u64| t * 1e9 / (reps as f64 * xs.len() as f64 * ab.len() as f64);
    Ok(match prog {
        Compiled::Narrow(p) => {
            let c64: Vec<i64> = codes.iter().map(|&c| c as i64).collect();
            let (mut reps, start) = (0u64, Instant::now());
            while start.elapsed() < min || reps == 0 {
                black_box(p.run(&[black_box(&c64)]));
                reps += 1;
            }
            per(start.elapsed().as_secs_f64(), reps)
        }
        Compiled::Wide(p) => {
            let (mut reps, start) = (0u64, Instant::now());
            while start.elapsed() < min || reps == 0 {
                black_box(p.run(&[black_box(&codes)]));
                reps += 1;
            }
            per(start.elapsed().as_secs_f64(), reps)
        }
    })
}

fn load<C: Datapath>(cx: &mut C, vals: &[f64], q: &Quant) -> anyhow::Result<Vec<C::V>> {
    vals.iter()
        .map(|&v| cx.constant(v, q).context("loading inputs"))
        .collect()
}

/// Run it.
pub fn run(cmd: &BenchCmd) -> anyhow::Result<()> {
    let BenchCmd::MadChain(a) = cmd;
    anyhow::ensure!(
        a.inputs > 0 && a.length > 0,
        "--inputs and --length must be positive"
    );
    let q = Quant::new("x", a.format, a.round, Overflow::Saturate);
    let qc = Quant::new(
        "coef",
        a.coef_format,
        Rounding::HalfEven,
        Overflow::Saturate,
    );
    let mut rng = SplitMix(1);
    let xs: Vec<f64> = (0..a.inputs).map(|_| rng.uniform(-1.0, 1.0)).collect();
    let ab: Vec<(f64, f64)> = (0..a.length)
        .map(|_| (rng.uniform(-0.9, 0.9), rng.uniform(-0.1, 0.1)))
        .collect();
    let min = Duration::from_secs_f64(a.seconds.max(0.01));

    // The counting run decides whether the i64 fast path holds these widths.
    let mut count = Count::new();
    let cx_in = load(&mut count, &xs[..1], &q)?;
    let cc: Vec<_> = ab
        .iter()
        .map(|&(x, y)| Ok((count.constant(x, &qc)?, count.constant(y, &qc)?)))
        .collect::<anyhow::Result<_>>()?;
    mad_chain(&mut count, &cc, cx_in[0], &q);
    anyhow::ensure!(
        count.width_errors().is_empty(),
        "{}",
        count.width_errors()[0]
    );

    let mut rf = Reference;
    let rxs = load(&mut rf, &xs, &q)?;
    let t_f64 = time_per_mad(&mut rf, &ab, &rxs, &q, min);
    let t_wide = time_fixed::<i128>(&xs, &ab, &q, &qc, min)?;
    let t_narrow = if count.fits_i64() {
        Some(time_fixed::<i64>(&xs, &ab, &q, &qc, min)?)
    } else {
        None
    };
    let t_compiled = time_compiled(&xs, &ab, &q, &qc, min)?;
    let t_fixed = t_compiled;
    let ratio = t_fixed / t_f64;

    let mut t = Table::new([
        "context",
        "ns per multiply-add",
        "M multiply-adds/s",
        "× f64",
    ])
    .titled(format!(
        "mad-chain: {} inputs × {} steps, x {} ({}), coefficients {}",
        a.inputs,
        a.length,
        a.format,
        a.round.name(),
        a.coef_format
    ));
    let mut row = |name: &str, ns: f64| {
        t.row([
            name.to_string(),
            format!("{ns:.2}"),
            format!("{:.0}", 1e3 / ns),
            format!("{:.2}", ns / t_f64),
        ])
    };
    row("f64 reference", t_f64);
    row("fixed, compiled batch (used by the tool)", t_compiled);
    if let Some(tn) = t_narrow {
        row("fixed, scalar context, i64 codes", tn);
    }
    row("fixed, scalar context, i128 codes", t_wide);
    let json = serde_json::json!({
        "bench": "mad-chain",
        "inputs": a.inputs, "length": a.length,
        "format": a.format.to_string(), "coef_format": a.coef_format.to_string(), "round": a.round.name(),
        "f64_ns_per_mad": t_f64, "fixed_ns_per_mad": t_fixed, "ratio": ratio,
        "fixed_scalar_i64_ns_per_mad": t_narrow, "fixed_compiled_ns_per_mad": t_compiled, "fixed_scalar_i128_ns_per_mad": t_wide, "max_exact_width": count.max_width(),
    });
    emit(a.out, &[t], &json)
}
