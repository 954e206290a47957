//! `fxshade bench`: speed of the model (figures go in BENCHMARKS.md; no test
//! asserts a time).

use fxshade_model::convert::{narrow, to_f64};
use std::hint::black_box;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::{Args, Subcommand};
use fxshade_model::datapath::{Compiled, Count, Datapath, Fixed, Program, Reference, Trace};
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
    /// Bit-accurate linear and quadratic normalizations per second (compiled
    /// batch path) against exact f64 normalization with glam on the same
    /// inputs; and the exhaustive g(d) analysis of a 20-bit d stage.
    Normalize(NormalizeBenchArgs),
    /// Bit-accurate polar transforms per second (compiled batch path)
    /// against the conventional f64 transform (T, B, N given: three dot
    /// products and a normalization, glam) on the same inputs.
    Polar(NormalizeBenchArgs),
    /// Co-simulation on Verilator: fxshade's harness against a minimal
    /// C++ harness and the Verilog testbench on the same modules and
    /// records, and `rtl-check`'s end-to-end rate against simulation only.
    Cosim(super::bench_cosim::CosimArgs),
    /// The renderer (one method, no RTL) per covered pixel against a
    /// simple f64 shader of the same image, and its peak memory.
    Render(super::bench_render::RenderBenchArgs),
    /// The bit-accurate engine on every instruction set this CPU has
    /// (portable, AVX2, AVX-512) against the same program as straight-line
    /// C compiled -O3 -march=native, outputs checked bit for bit.
    Engine(super::bench_engine::EngineArgs),
}

/// Options of `bench normalize`.
#[derive(Args, Debug)]
pub struct NormalizeBenchArgs {
    /// Number of input normals.
    #[arg(long, default_value_t = 1 << 16)]
    inputs: usize,
    /// Minimum measuring time per variant, in seconds.
    #[arg(long, default_value_t = 1.0)]
    seconds: f64,
    #[command(flatten)]
    out: OutputArgs,
}

fn bench_polar(a: &NormalizeBenchArgs) -> anyhow::Result<()> {
    use fxshade_model::polar::{self, Polar};
    use fxshade_model::sampling::Rng;
    let cfg = fxshade_model::Config::embedded();
    let p = Polar::from_config(&cfg).map_err(|e| anyhow::anyhow!("{e}"))?;
    let n = a.inputs.max(1);
    let mut rng = Rng::new(5);
    let f = p.angle.format();
    let code = |x: f64| -> anyhow::Result<i128> { Ok(p.angle.apply_f64(x.rem_euclid(1.0))?.code) };
    let mut cols: Vec<Vec<i128>> = (0..4).map(|_| Vec::with_capacity(n)).collect();
    let mut frames = Vec::with_capacity(n);
    for _ in 0..n {
        let (l, nn) = (rng.direction(), rng.direction());
        let (al, bl) = polar::angles_of(l);
        let (an, bn) = polar::angles_of(nn);
        for (c, x) in cols.iter_mut().zip([al, bl, an, bn]) {
            c.push(code(x)?);
        }
        // The baseline's inputs: the same angles' vectors and frame.
        let t = |c: i128| f.to_f64(c);
        let (l, nv) = (
            polar::vector_of(t(*cols[0].last().unwrap()), t(*cols[1].last().unwrap())),
            polar::vector_of(t(*cols[2].last().unwrap()), t(*cols[3].last().unwrap())),
        );
        let (tt, bb, nv) = polar::frame(nv, t(*cols[3].last().unwrap()));
        frames.push((tt, bb, nv, l));
    }
    let min = Duration::from_secs_f64(a.seconds.max(0.01));
    let time = |f: &mut dyn FnMut()| {
        let (mut reps, start) = (0u64, Instant::now());
        while start.elapsed() < min || reps == 0 {
            f();
            reps += 1;
        }
        start.elapsed().as_secs_f64() / (to_f64(reps) * to_f64(n))
    };
    let t_tbn = time(&mut || {
        for (t, b, nn, l) in black_box(&frames) {
            black_box(glam::DVec3::new(t.dot(*l), b.dot(*l), nn.dot(*l)).normalize());
        }
    });
    let t_polar = time_program(&p.compile()?, &cols, min) / to_f64(n);
    let mut t = Table::new(["transform", "ns per vector", "M vectors/s", "× f64 TBN"]).titled(
        format!("polar: {n} light vectors into tangent space, default formats, one core"),
    );
    t.row([
        "TBN matrix + normalize, f64 (glam)".to_string(),
        format!("{:.2}", t_tbn * 1e9),
        format!("{:.1}", 1e-6 / t_tbn),
        "1.00".into(),
    ]);
    t.row([
        "polar (6 mul, 3 add, 6 table reads), bit-accurate (compiled)".to_string(),
        format!("{:.2}", t_polar * 1e9),
        format!("{:.1}", 1e-6 / t_polar),
        format!("{:.2}", t_polar / t_tbn),
    ]);
    let json = serde_json::json!({"bench": "polar", "inputs": n, "tbn_f64_ns": t_tbn * 1e9, "polar_ns": t_polar * 1e9, "ratio": t_polar / t_tbn});
    emit(a.out, &[t], &json)
}

fn bench_normalize(a: &NormalizeBenchArgs) -> anyhow::Result<()> {
    use fxshade_model::normalizer::{self, Method};
    use fxshade_model::sampling::{self, Rng};
    let cfg = fxshade_model::Config::embedded();
    let theta = cfg.section::<normalizer::NormalizeConfig>().theta;
    let mut rng = Rng::new(3);
    let vs: Vec<glam::DVec3> = (0..a.inputs.max(1))
        .map(|_| {
            sampling::lerp3(
                &sampling::triangle_meeting(theta, &mut rng),
                rng.barycentric(),
            )
        })
        .collect();
    let min = Duration::from_secs_f64(a.seconds.max(0.01));
    let stages = normalizer::Normalizer::stages(&cfg.section());
    let codes: Vec<Vec<i128>> = (0..3)
        .map(|k| {
            vs.iter()
                .map(|v| Ok(stages.normal.apply_f64(v[k])?.code))
                .collect::<anyhow::Result<_>>()
        })
        .collect::<anyhow::Result<_>>()?;
    let fin = stages.normal.format();
    let exact_in: Vec<glam::DVec3> = (0..vs.len())
        .map(|i| {
            glam::DVec3::new(
                fin.to_f64(codes[0][i]),
                fin.to_f64(codes[1][i]),
                fin.to_f64(codes[2][i]),
            )
        })
        .collect();
    let time = |f: &mut dyn FnMut()| {
        let (mut reps, start) = (0u64, Instant::now());
        while start.elapsed() < min || reps == 0 {
            f();
            reps += 1;
        }
        start.elapsed().as_secs_f64() / (to_f64(reps) * to_f64(vs.len()))
    };
    let t_glam = time(&mut || {
        for v in black_box(&exact_in) {
            black_box(v.normalize());
        }
    });
    let mut t =
        Table::new(["variant", "ns per normal", "M normals/s", "× glam f64"]).titled(format!(
            "normalize: {} interpolated normals (Θ = {theta}), default formats, one core",
            vs.len()
        ));
    let mut json = serde_json::json!({ "bench": "normalize", "inputs": vs.len(), "glam_f64_ns": t_glam * 1e9 });
    t.row([
        "exact, f64 (glam DVec3::normalize)".to_string(),
        format!("{:.2}", t_glam * 1e9),
        format!("{:.1}", 1e-6 / t_glam),
        "1.00".into(),
    ]);
    for m in [Method::Linear, Method::Quadratic] {
        let (n, _) = normalizer::design(
            m,
            stages,
            theta,
            fxshade_model::coeffs::Fit::Minimax,
            normalizer::Interval::Triangle,
            true,
        )?;
        let secs = time_program(&n.compile()?, &codes, min) / to_f64(vs.len());
        t.row([
            format!("{}, bit-accurate (compiled)", m.name()),
            format!("{:.2}", secs * 1e9),
            format!("{:.1}", 1e-6 / secs),
            format!("{:.2}", secs / t_glam),
        ]);
        json[format!("{}_ns", m.name())] = (secs * 1e9).into();
        json[format!("{}_ratio", m.name())] = (secs / t_glam).into();
    }
    // Exhaustive g(d) over every code of a 20-bit d format.
    let mut st20 = stages;
    st20.d = st20.d.with_format("U1F19".parse()?);
    let (n20, _) = normalizer::design(
        Method::Quadratic,
        st20,
        theta,
        fxshade_model::coeffs::Fit::Minimax,
        normalizer::Interval::Triangle,
        true,
    )?;
    let fd = st20.d.format();
    let start = Instant::now();
    let st = normalizer::g_stage_stats(&n20, fd.ulp(), fd.max_value())?;
    let t20 = start.elapsed().as_secs_f64();
    let mut g = Table::new(["exhaustive g(d) analysis", "d codes", "seconds"]);
    g.row([
        "quadratic, d in U1F19 (20 bits)".to_string(),
        st.samples.to_string(),
        format!("{t20:.3}"),
    ]);
    json["g_stage_20bit_codes"] = st.samples.into();
    json["g_stage_20bit_seconds"] = t20.into();
    emit(a.out, &[t, g], &json)
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
    start.elapsed().as_secs_f64() * 1e9 / (to_f64(reps) * to_f64(xs.len()) * to_f64(coefs.len()))
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
    let run = time_program(&prog, &[codes], min);
    Ok(run * 1e9 / (to_f64(xs.len()) * to_f64(ab.len())))
}

/// Seconds per run of `prog` over every lane of `cols` (the codes of each
/// input port): the codes are converted once to the program's code type,
/// the output buffers are reused, and the run repeats for at least `min`.
fn time_program(prog: &Compiled, cols: &[Vec<i128>], min: Duration) -> f64 {
    fn go<R: Raw>(p: &Program<R>, cols: &[Vec<R>], min: Duration) -> f64 {
        let refs: Vec<&[R]> = cols.iter().map(|c| c.as_slice()).collect();
        let mut outs = vec![Vec::new(); p.output_fracs().len()];
        let (mut reps, start) = (0u64, Instant::now());
        while start.elapsed() < min || reps == 0 {
            black_box(p.run_into(black_box(&refs), &mut outs));
            reps += 1;
        }
        start.elapsed().as_secs_f64() / to_f64(reps)
    }
    match prog {
        Compiled::Narrow(p) => {
            let narrow: Vec<Vec<i64>> = cols
                .iter()
                .map(|c| c.iter().map(|&x| narrow::<i64, _>(x)).collect())
                .collect();
            go(p, &narrow, min)
        }
        Compiled::Wide(p) => go(p, cols, min),
    }
}

fn load<C: Datapath>(cx: &mut C, vals: &[f64], q: &Quant) -> anyhow::Result<Vec<C::V>> {
    vals.iter()
        .map(|&v| cx.constant(v, q).context("loading inputs"))
        .collect()
}

/// Run it.
pub fn run(cmd: &BenchCmd) -> anyhow::Result<()> {
    let a = match cmd {
        BenchCmd::MadChain(a) => a,
        BenchCmd::Normalize(a) => return bench_normalize(a),
        BenchCmd::Polar(a) => return bench_polar(a),
        BenchCmd::Cosim(a) => return super::bench_cosim::run(a),
        BenchCmd::Render(a) => return super::bench_render::run(a),
        BenchCmd::Engine(a) => return super::bench_engine::run(a),
    };
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
    let mut rng = fxshade_model::sampling::Rng::new(1);
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
