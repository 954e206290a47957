//! `fxshade error`: error of the bit-accurate model against the f64
//! reference.

use clap::{Args, Subcommand};
use fxshade_model::analysis::{self, NormalizeReport, VectorStats};
use fxshade_model::convert::{from_f64, narrow};

use super::ConfigArgs;
use crate::output::{emit, OutputArgs, Table};

/// `fxshade error ...`
#[derive(Subcommand, Debug)]
pub enum ErrorCmd {
    /// The normalizer (method A): the g(d) stage over every d code of the
    /// interval, and whole vectors from random triangles meeting Θ, edges and
    /// corner cases, against exact normalization; the diffuse term in 8-bit
    /// levels.
    Normalize(NormalizeArgs),
    /// The interpolator (method C) followed by a normalizer fitted to the
    /// scheme's range of d: length error, and direction error against the
    /// normalized exact quadratic field and against normalized linear
    /// interpolation; the range of |N|² and the error with no normalization.
    Interp(InterpArgs),
    /// The polar transform (method B) against the exact implied frame:
    /// component error in LSBs, |L'| deviation, angle error, and the diffuse
    /// error against normal-map normals; exhaustive over angle codes where the
    /// space allows. `--sweep` tabulates the error over table depth and width.
    Polar(PolarArgs),
    /// The CORDIC angle unit (method B's per-pixel angles of N): α and β
    /// error in output LSBs and degrees against asin/atan2 of the exact
    /// input normal, over every input code where the space allows, else
    /// corner cases (poles, axes, the β seam, octant boundaries, extreme
    /// codes) and random normals as long and as short as quadratic
    /// interpolation makes them. `--sweep` tabulates the error and the
    /// generated RTL's adder bits over output width, iterations and guard
    /// bits, and marks the cheapest setting within 1 LSB per width.
    Angles(AnglesArgs),
}

/// Options of `error angles`.
#[derive(Args, Debug)]
pub struct AnglesArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    /// Random normals (beside the corner cases) when the input space is
    /// too large to cover.
    #[arg(long, default_value_t = 500_000)]
    count: usize,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Tabulate over output angle bits (8, 10, 11, 12, 14), iterations
    /// (bits − 3 ..= bits + 3) and guard bits (1 to 5: coordinates
    /// I4F<14 + g>, accumulator U0F<bits + g>), 20 000 random normals each.
    #[arg(long)]
    sweep: bool,
    /// Skip β over every input code pair (the exhaustive maximum beside
    /// the samples: about 15 s on two cores for 16-bit normals).
    #[arg(long)]
    sampled: bool,
    #[command(flatten)]
    out: OutputArgs,
}

fn run_angles(a: &AnglesArgs) -> anyhow::Result<()> {
    fxshade_model::analysis::check_samples("--count", a.count)
        .map_err(crate::output::UsageError)?;
    let cfg = a.cfg.resolve()?;
    let head = [
        "angle bits",
        "iterations",
        "xy",
        "theta",
        "adder bits",
        "flip-flops",
        "latency",
        "samples",
        "max α err (LSB)",
        "max β err (LSB)",
        "max β err in cap (LSB)",
        "rms (LSB)",
        "max α (°)",
        "max β (°)",
        "max direction (°)",
        "short inputs",
        "max err short (LSB)",
        "overflows",
    ];
    let cells = |r: &analysis::AnglesReport, mark: &str| {
        let s = &r.stats;
        vec![
            r.angle_bits.to_string(),
            r.iterations.to_string(),
            r.xy.clone(),
            r.theta.clone(),
            format!("{}{mark}", r.adder_bits),
            r.flops.to_string(),
            r.latency.to_string(),
            s.samples.to_string(),
            format!("{:.3}", s.max_alpha_lsb),
            format!("{:.3}", s.max_beta_lsb),
            format!("{:.2}", s.max_beta_lsb_cap),
            format!("{:.3}", s.rms_lsb),
            format!("{:.4}", s.max_alpha_deg),
            format!("{:.4}", s.max_beta_deg),
            format!("{:.4}", s.max_direction_deg),
            s.short_inputs.to_string(),
            format!("{:.1}", s.max_short_lsb),
            s.overflows.to_string(),
        ]
    };
    if !a.sweep {
        let bar = crate::progress::bar(1, "error angles");
        let r = analysis::angles(&cfg, a.count, a.seed)?;
        let (lo, hi) = analysis::angles_length_range();
        let beta = if a.sampled {
            None
        } else {
            Some(analysis::angles_beta_every_code(&cfg, lo, hi)?)
        };
        bar.finish_and_clear();
        let mut t = Table::new(head).titled(format!(
            "angles: CORDIC vectoring, {} iterations, coordinates {}, accumulator {}, out {}; \
             coverage: {} (every figure a maximum over these samples)",
            r.iterations, r.xy, r.theta, r.out, r.stats.coverage
        ));
        t.row(cells(&r, ""));
        let mut tables = vec![t];
        let mut json = serde_json::to_value(&r)?;
        if let Some(b) = &beta {
            let mut e = Table::new([
                "inputs",
                "basis",
                "max β err (LSB)",
                "max β (°)",
                "at (x, z) codes",
                "overflows",
            ])
            .titled("β over every input code (it depends on x and z alone): an exhaustive maximum");
            e.row([
                format!(
                    "every (x, z) with |N| in [{lo:.4}, {hi:.4}] more than {}° from the y axis",
                    fxshade_model::render::POLAR_CAP_DEG
                ),
                format!("exhaustive: {} code pairs", b.covered),
                format!("{:.3}", b.max_beta_lsb),
                format!("{:.4}", b.max_beta_deg),
                format!("({}, {})", b.worst.0, b.worst.1),
                b.overflows.to_string(),
            ]);
            tables.push(e);
            json["beta_every_code"] = serde_json::to_value(b)?;
        }
        return emit(a.out, &tables, &json);
    }
    let widths = [8u32, 10, 11, 12, 14];
    let guards = [1u32, 2, 3, 4, 5];
    let nf = cfg
        .section::<fxshade_model::angles::AnglesConfig>()
        .normal
        .format()
        .frac();
    let bar = crate::progress::bar(
        (widths.len() * 7 * guards.len()) as u64,
        "error angles --sweep",
    );
    let mut rows: Vec<analysis::AnglesReport> = Vec::new();
    for &k in &widths {
        for n in k - 3..=k + 3 {
            for &g in &guards {
                let mut c = cfg.clone();
                for o in [
                    format!("polar.angle_bits={k}"),
                    format!("polar.table_bits={}", k.min(16)),
                    format!("polar.index.format=\"U0F{}\"", k.min(16)),
                    format!("angles.out.format=\"U0F{k}\""),
                    format!("angles.iterations={n}"),
                    format!("angles.xy.format=\"I4F{}\"", nf + narrow::<i32, _>(g)),
                    format!("angles.theta.format=\"U0F{}\"", k + g),
                ] {
                    c.apply_override(&o)?;
                }
                rows.push(analysis::angles(&c, 20_000, a.seed)?);
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    // The cheapest setting (adder bits) per width with α and β within 1 LSB.
    let mut best: Vec<Option<usize>> = vec![None; widths.len()];
    for (i, r) in rows.iter().enumerate() {
        let w = widths
            .iter()
            .position(|&k| k == r.angle_bits)
            .expect("swept");
        let ok = r.stats.max_alpha_lsb <= 1.0 && r.stats.max_beta_lsb <= 1.0;
        if ok && best[w].is_none_or(|b| rows[b].adder_bits > r.adder_bits) {
            best[w] = Some(i);
        }
    }
    let mut t = Table::new(head).titled(format!(
        "angles sweep: 20 000 random normals and the corner cases each; * marks the fewest adder bits with α and β within 1 LSB (β outside the {}° polar cap)",
        fxshade_model::render::POLAR_CAP_DEG
    ));
    for (i, r) in rows.iter().enumerate() {
        let mark = if best.contains(&Some(i)) { " *" } else { "" };
        t.row(cells(r, mark));
    }
    let json = serde_json::json!({
        "points": rows,
        "cheapest_within_1_lsb": best
            .iter()
            .zip(widths)
            .map(|(b, k)| serde_json::json!({"angle_bits": k, "point": b}))
            .collect::<Vec<_>>(),
    });
    emit(a.out, &[t], &json)
}

/// Options of `error polar`.
#[derive(Args, Debug)]
pub struct PolarArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    /// Random samples when the angle space is too large to cover.
    #[arg(long, default_value_t = 500_000)]
    count: usize,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Tabulate over table depth (table_bits 6 ..= angle_bits) and entry
    /// width (10 to 18 bits), 50 000 random samples each.
    #[arg(long)]
    sweep: bool,
    /// Random samples (`--count`) even where every code triple can be
    /// covered (11-bit angles and fewer: 39 s on two cores for 11 bits).
    #[arg(long)]
    sampled: bool,
    #[command(flatten)]
    out: OutputArgs,
}

fn run_polar(a: &PolarArgs) -> anyhow::Result<()> {
    fxshade_model::analysis::check_samples("--count", a.count)
        .map_err(crate::output::UsageError)?;
    let cfg = a.cfg.resolve()?;
    let stat_cells = |s: &analysis::PolarStats| {
        vec![
            s.samples.to_string(),
            s.coverage.to_string(),
            format!("{:.2}", s.max_lsb_err),
            format!("{:.3}", s.rms_lsb_err),
            format!("{:.3e}", s.max_len_dev),
            format!("{:.4}", s.max_angle_err_deg),
            format!("{:.2}", s.max_diffuse_err_levels),
            s.overflows.to_string(),
        ]
    };
    let head = [
        "samples",
        "coverage",
        "max LSB err",
        "rms LSB err",
        "max | |L'| − 1 |",
        "max angle (°)",
        "max diffuse err (levels)",
        "overflows",
    ];
    if a.sweep {
        let polar: fxshade_model::polar::PolarConfig = cfg.section();
        let base = i64::from(polar.angle_bits);
        let mut rows = Vec::new();
        let mut t = Table::new(
            ["table_bits", "table format", "table bits stored"]
                .into_iter()
                .chain(head),
        )
        .titled(format!(
            "polar sweep: angle_bits = {base}, organisation {}, 50 000 random samples each",
            polar.organisation.name()
        ));
        let bar = crate::progress::bar(
            narrow::<u64, _>(((base - 5) * 5).max(0)),
            "error polar --sweep",
        );
        for tb in 6..=base.min(14) {
            for w in [10, 12, 14, 16, 18] {
                let mut c = cfg.clone();
                c.apply_override(&format!("polar.table_bits={tb}"))?;
                c.apply_override(&format!("polar.table.format=I2F{}", w - 2))?;
                let r = analysis::polar(&c, 50_000, a.seed, 0)?;
                let mut cells = vec![
                    tb.to_string(),
                    r.table_format.clone(),
                    r.table_size_bits.to_string(),
                ];
                cells.extend(stat_cells(&r.stats));
                t.row(cells);
                rows.push(r);
                bar.inc(1);
            }
        }
        bar.finish_and_clear();
        return emit(a.out, &[t], &serde_json::to_value(&rows)?);
    }
    let bar = crate::progress::bar(1, "error polar");
    let r = analysis::polar(
        &cfg,
        a.count,
        a.seed,
        if a.sampled {
            0
        } else {
            analysis::POLAR_EXHAUSTIVE
        },
    )?;
    bar.finish_and_clear();
    let mut t = Table::new(head).titled(format!(
        "polar: {}-bit angles, {}-bit table index, {} table of {} entries ({}), {} bits stored per table",
        r.angle_bits,
        r.table_bits,
        match r.organisation {
            fxshade_model::polar::Organisation::Full => "full",
            fxshade_model::polar::Organisation::Quarter => "quarter-wave",
        },
        1u64 << r.table_bits,
        r.table_format,
        r.table_size_bits
    ));
    t.row(stat_cells(&r.stats));
    emit(a.out, &[t], &serde_json::to_value(&r)?)
}

/// Options of `error interp`.
#[derive(Args, Debug)]
pub struct InterpArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    /// linear or quadratic (default: interp.scheme).
    #[arg(long)]
    scheme: Option<String>,
    /// Convexity threshold Θ of the sampled triangles (default: normalize.theta).
    #[arg(long, value_parser = super::finite_f64)]
    theta: Option<f64>,
    /// exact, none, newton, taylor, linear or quadratic (default: normalize.method).
    #[arg(long)]
    normalizer: Option<String>,
    /// Random pixels.
    #[arg(long, default_value_t = 200_000)]
    count: usize,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    out: OutputArgs,
}

fn run_interp(a: &InterpArgs) -> anyhow::Result<()> {
    fxshade_model::analysis::check_samples("--count", a.count)
        .map_err(crate::output::UsageError)?;
    let mut cfg_args = a.cfg.clone();
    if let Some(s) = &a.scheme {
        cfg_args.set.push(format!("interp.scheme=\"{s}\""));
    }
    if let Some(m) = &a.normalizer {
        cfg_args.set.push(format!("normalize.method=\"{m}\""));
    }
    if let Some(t) = a.theta {
        cfg_args.set.push(format!("normalize.theta={t}"));
    }
    let cfg = cfg_args.resolve()?;
    let scheme = cfg.section::<fxshade_model::interp::InterpConfig>().scheme;
    let nu: fxshade_model::normalizer::NormalizeConfig = cfg.section();
    let (method, theta) = (nu.method, nu.theta);
    let bar = crate::progress::bar(1000, "error interp");
    let r = analysis::interp(&cfg, scheme, method, theta, a.count, a.seed, &mut |f| {
        bar.set_position(from_f64::<u64>(f * 1000.0))
    })?;
    bar.finish_and_clear();
    let mut t = Table::new([
        "pixels",
        "d range (measured)",
        "d range (bound)",
        "max rel err",
        "rms rel err",
        "max angle vs quadratic (°)",
        "max angle vs linear (°)",
        "unnormalized max rel err",
        "overflows",
    ])
    .titled(format!(
        "interp: {} interpolation, then normalizer {} fitted on d ∈ [{:.6}, {:.6}] (Θ = {})",
        scheme.name(),
        method.name(),
        r.interval.0,
        r.interval.1,
        theta
    ));
    t.row([
        r.samples.to_string(),
        format!("[{:.6}, {:.6}]", r.d_min, r.d_max),
        format!("[{:.6}, {:.6}]", r.d_bound.0, r.d_bound.1),
        format!("{:.3e}", r.max_rel_err),
        format!("{:.3e}", r.rms_rel_err),
        format!("{:.4}", r.max_angle_err_deg),
        format!("{:.4}", r.vs_linear.max_angle_err_deg),
        format!("{:.3e}", r.unnormalized_max_rel_err),
        r.overflows.to_string(),
    ]);
    emit(a.out, &[t], &serde_json::to_value(&r)?)
}

/// Options of `error normalize`.
#[derive(Args, Debug)]
pub struct NormalizeArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    /// Convexity threshold Θ (sets normalize.theta).
    #[arg(long, value_parser = super::finite_f64)]
    theta: Option<f64>,
    /// exact, none, newton, taylor, linear or quadratic (sets normalize.method).
    #[arg(long)]
    method: Option<String>,
    /// edge or triangle: the interval the coefficients are fitted on (sets
    /// normalize.interval).
    #[arg(long)]
    interval: Option<String>,
    /// Random whole-triangle samples.
    #[arg(long, default_value_t = 200_000)]
    count: usize,
    /// Seed of the random samples.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    out: OutputArgs,
}

fn row(t: &mut Table, name: &str, s: &VectorStats) {
    t.row([
        name.to_string(),
        format!("max over {} samples", s.samples),
        format!("{:.3e}", s.max_rel_err),
        format!("{:.3e}", s.mean_rel_err),
        format!("{:.3e}", s.rms_rel_err),
        format!("{:.2}", s.max_lsb_err),
        format!("{:.2}", s.max_diffuse_err_levels),
        s.overflows.to_string(),
    ]);
}

/// The report as tables.
pub fn tables(r: &NormalizeReport) -> Vec<Table> {
    let mut t = Table::new([
        "inputs",
        "basis",
        "max rel err",
        "mean rel err",
        "rms rel err",
        "max LSB err",
        "max diffuse err (levels)",
        "overflows",
    ])
    .titled(format!(
        "normalize, method {}, Θ = {}, coefficients fitted on the {} interval [{:.6}, {:.6}], {}: {}",
        r.method.name(),
        r.theta,
        r.interval_kind.name(),
        r.interval.0,
        r.interval.1,
        fxshade_model::coeffs::ORDER,
        fxshade_model::coeffs::named_highest_first(
            &r.coeffs.iter().rev().copied().collect::<Vec<_>>()
        )
    ));
    let g = &r.g_stage;
    t.row([
        "g(d) stage".to_string(),
        match g.max_rel_err_bound {
            None => format!("exhaustive: every d code ({})", g.samples),
            Some(_) => format!("{} d codes; max proven by branch and bound", g.samples),
        },
        match g.max_rel_err_bound {
            None => format!("{:.3e}", g.max_rel_err),
            Some(b) => format!("{:.3e} (≤ {b:.3e})", g.max_rel_err),
        },
        format!("{:.3e}", g.mean_rel_err),
        format!("{:.3e}", g.rms_rel_err),
        "-".into(),
        "-".into(),
        g.overflows.to_string(),
    ]);
    row(&mut t, "whole triangles meeting Θ", &r.triangles);
    row(&mut t, "triangle edges", &r.edges);
    row(&mut t, "outside (extreme components)", &r.outside);
    let mut b = Table::new([
        "inputs",
        "basis",
        "| |N'| − 1 | ≤",
        "|N' − N̂| ≤",
        "diffuse err (levels) ≤",
    ])
    .titled(
        "Proven bounds, for every input code quantized from a vector of the range (not samples): \
         the scale error per d code, plus one output rounding in each component",
    );
    for (name, p) in [
        ("whole triangles meeting Θ", &r.proven_triangles),
        ("triangle edges", &r.proven_edges),
    ] {
        b.row([
            format!("{name}: |N|² in [{:.6}, {:.6}]", p.exact_d.0, p.exact_d.1),
            format!("proven: {} ({} codes)", p.how, p.codes),
            format!("{:.3e}", p.length),
            format!("{:.3e}", p.vector),
            format!(
                "{:.2} (of which {} rounding)",
                p.diffuse_levels, p.level_rounding
            ),
        ]);
    }
    vec![t, b]
}

/// Run it.
pub fn run(cmd: &ErrorCmd) -> anyhow::Result<()> {
    let a = match cmd {
        ErrorCmd::Normalize(a) => a,
        ErrorCmd::Interp(a) => return run_interp(a),
        ErrorCmd::Polar(a) => return run_polar(a),
        ErrorCmd::Angles(a) => return run_angles(a),
    };
    fxshade_model::analysis::check_samples("--count", a.count)
        .map_err(crate::output::UsageError)?;
    let mut cfg_args = a.cfg.clone();
    if let Some(t) = a.theta {
        cfg_args.set.push(format!("normalize.theta={t}"));
    }
    if let Some(m) = &a.method {
        cfg_args.set.push(format!("normalize.method=\"{m}\""));
    }
    if let Some(i) = &a.interval {
        cfg_args.set.push(format!("normalize.interval=\"{i}\""));
    }
    let cfg = cfg_args.resolve()?;
    let bar = crate::progress::bar(1000, "error normalize");
    let r = analysis::normalize(&cfg, a.count, a.seed, &mut |f| {
        bar.set_position(from_f64::<u64>(f * 1000.0))
    })?;
    bar.finish_and_clear();
    let mut json = serde_json::to_value(&r)?;
    // One coefficient order everywhere (the report's are highest power
    // first already): stated.
    json["coeffs_order"] = serde_json::json!(fxshade_model::coeffs::ORDER);
    for (k, v) in serde_json::to_value(r.triangles)?
        .as_object()
        .expect("struct")
        .iter()
    {
        json[k] = v.clone();
    }
    emit(a.out, &tables(&r), &json)
}
