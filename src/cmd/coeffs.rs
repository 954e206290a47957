//! `fxshade coeffs`: design `g(d) ≈ 1/√d` coefficients.

use anyhow::Context;
use clap::Args;
use fxshade_model::coeffs::{self, Fit};
use fxshade_model::normalizer::{self, Interval, Method, Normalizer};
use fxshade_model::Format;

use super::ConfigArgs;
use crate::output::{emit, OutputArgs, Table};

/// `fxshade coeffs`
#[derive(Args, Debug)]
pub struct CoeffsArgs {
    /// Convexity threshold Θ (the interval follows from it and --interval).
    #[arg(long, default_value_t = 0.5, value_parser = super::finite_f64)]
    theta: f64,
    /// 1 (linear k·d + p) or 2 (quadratic a·d² + b·d + c).
    #[arg(long, default_value_t = 2)]
    degree: usize,
    /// nodes (Chebyshev interpolation), series (truncated Chebyshev series)
    /// or minimax (least maximum relative error).
    #[arg(long, default_value = "minimax", value_parser = parse_fit)]
    fit: Fit,
    /// edge: [(1+Θ)/2, 1] (the paper's); triangle: [(1+2Θ)/3, 1].
    #[arg(long, default_value = "triangle", value_parser = parse_interval)]
    interval: Interval,
    /// Explicit lower end of the interval (with --hi; overrides Θ).
    #[arg(long, requires = "hi", value_parser = super::finite_f64)]
    lo: Option<f64>,
    /// Explicit upper end of the interval.
    #[arg(long, requires = "lo", value_parser = super::finite_f64)]
    hi: Option<f64>,
    /// Quantize the coefficients to this format (e.g. I3F15): rounding and
    /// search, each evaluated by the bit-accurate g(d) stage of the
    /// configuration's [normalize] formats.
    #[arg(long, value_name = "FORMAT")]
    coef_format: Option<Format>,
    #[command(flatten)]
    cfg: ConfigArgs,
    #[command(flatten)]
    out: OutputArgs,
}

fn parse_fit(s: &str) -> Result<Fit, String> {
    Fit::from_name(s).ok_or_else(|| format!("`{s}` is not nodes, series or minimax"))
}
fn parse_interval(s: &str) -> Result<Interval, String> {
    Interval::from_name(s).ok_or_else(|| format!("`{s}` is not edge or triangle"))
}

/// Run it.
pub fn run(a: &CoeffsArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        (0.0..1.0).contains(&a.theta),
        "--theta {} is outside [0, 1)",
        a.theta
    );
    let (lo, hi) = match (a.lo, a.hi) {
        (Some(lo), Some(hi)) => (lo, hi),
        _ => a.interval.bounds(a.theta),
    };
    let p = coeffs::design(a.fit, lo, hi, a.degree).context("--degree, --lo, --hi")?;
    let (err, at) = coeffs::max_rel_err(&p, lo, hi);
    let mut json = serde_json::json!({
        "fit": a.fit.name(), "degree": a.degree, "theta": a.theta,
        "interval": [lo, hi], "coeffs": p.highest_first(), "coeffs_order": fxshade_model::coeffs::ORDER, "max_rel_err": err, "worst_d": at,
    });
    let names = if a.degree == 1 {
        vec!["k", "p"]
    } else {
        vec!["a", "b", "c"]
    };
    let mut t = Table::new([
        "coefficients",
        "values (highest power first)",
        "max rel err",
        "at d",
    ])
    .titled(format!(
        "g(d) ≈ 1/√d, degree {}, {} fit on [{lo:.6}, {hi:.6}]",
        a.degree,
        a.fit.name()
    ));
    let fmt_vals = |v: &[f64]| {
        v.iter()
            .zip(&names)
            .map(|(x, n)| format!("{n} = {x:.9}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    t.row([
        "real".to_string(),
        fmt_vals(&p.highest_first()),
        format!("{err:.4e}"),
        format!("{at:.6}"),
    ]);
    if let Some(f) = a.coef_format {
        let cfg = a.cfg.resolve()?;
        let mut stages = Normalizer::stages(&cfg.section());
        stages.coef = stages.coef.with_format(f);
        let method = if a.degree == 1 {
            Method::Linear
        } else {
            Method::Quadratic
        };
        let (_, design) = normalizer::design(method, stages, a.theta, a.fit, a.interval, true)
            .map_err(anyhow::Error::from)
            .and_then(|(n, d)| {
                // An explicit interval: redo the design there.
                if a.lo.is_some() {
                    design_on(method, n.q, lo, hi, a.fit)
                } else {
                    Ok(((), d.expect("linear and quadratic have designs")))
                }
            })?;
        let rev = |v: &[f64]| v.iter().rev().copied().collect::<Vec<_>>();
        for (name, c) in [("rounded", &design.rounded), ("searched", &design.searched)] {
            t.row([
                format!("{name} to {f}"),
                format!(
                    "{}  (codes {:?})",
                    fmt_vals(&rev(&c.values)),
                    c.codes.iter().rev().collect::<Vec<_>>()
                ),
                format!(
                    "{:.4e} real, {:.4e} model",
                    c.max_rel_err_real, c.max_rel_err_model
                ),
                String::new(),
            ]);
        }
        let q = |c: &normalizer::CoeffChoice| {
            serde_json::json!({
                "coeffs": rev(&c.values), "codes": c.codes.iter().rev().collect::<Vec<_>>(),
                "max_rel_err": c.max_rel_err_model, "max_rel_err_real": c.max_rel_err_real,
            })
        };
        json["coef_format"] = f.to_string().into();
        json["rounded"] = q(&design.rounded);
        json["searched"] = q(&design.searched);
    }
    emit(a.out, &[t], &json)
}

/// A design on an explicit interval (Θ-free).
fn design_on(
    method: Method,
    stages: normalizer::Stages,
    lo: f64,
    hi: f64,
    fit: Fit,
) -> anyhow::Result<((), normalizer::Design)> {
    let (_, d) = normalizer::design_interval(
        method,
        stages,
        f64::NAN,
        fit,
        Interval::Triangle,
        (lo, hi),
        true,
    )?;
    Ok(((), d.expect("linear and quadratic have designs")))
}
