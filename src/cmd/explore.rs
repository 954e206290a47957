//! `fxshade explore`: sweeps, Pareto fronts, word-length optimization.

use fxshade_model::convert::{narrow, to_f64};
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use clap::Args;
use fxshade_model::files::StagedDir;
use fxshade_model::rtl::units::VectorStream;

use super::ConfigArgs;
use crate::explore::{self, eval, optimize, sweep, Base, Cache, Goal, Options, Row};
use crate::output::{OutputArgs, Table, UsageError};
use crate::rtl_flow::{self, Sim};

pub use crate::explore::DEFAULT_MESHES;

/// `fxshade explore`
/// `fxshade explore-point JOB RESULT` (hidden: what a launcher runs):
/// evaluate one point, its metrics or its error written whole to `RESULT`;
/// exit status 1 when the model could not evaluate it.
#[derive(Args, Debug)]
pub struct PointArgs {
    /// The job file `explore --launcher` wrote.
    pub job: std::path::PathBuf,
    /// Where to write the outcome.
    pub result: std::path::PathBuf,
}

#[derive(Args, Debug)]
pub struct ExploreArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    /// A swept key and its values (repeatable; the sweep is the product):
    /// `normalize.d.format=U1F13..U1F21`, `width.normals=10..16`,
    /// `normalize.method=linear,quadratic`, `normalize.theta=0.3..0.6:0.1`,
    /// `polar.table_bits=8..12`. `width.<group>` sets every member of a
    /// width group (`--list-metrics` lists the groups).
    #[arg(long, value_name = "KEY=SPEC")]
    vary: Vec<String>,
    /// A sweep file (TOML) with any of `vary`, `set`, `mesh` (lists of
    /// strings), `size`, `samples`, `analyses`, `pareto`, `goal`,
    /// `minimize`; flags add to its lists and override its values.
    #[arg(long, value_name = "FILE")]
    sweep: Option<PathBuf>,
    /// Render this mesh for the `pipeline.*` image metrics (repeatable):
    /// sphere:N, torus:N[:AXIS] or an OBJ file.
    #[arg(long, value_name = "MESH")]
    mesh: Vec<String>,
    /// Size of those renders.
    #[arg(long, value_name = "WxH")]
    size: Option<String>,
    /// Random samples per unit analysis (default: each `fxshade error`
    /// command's own, so the figures are exactly what it prints).
    #[arg(long, value_name = "N")]
    samples: Option<usize>,
    /// Analyses to run, comma-separated: normalize, interp, polar, angles,
    /// lighting, pipeline, cost (default: all; pipeline when meshes are
    /// given).
    #[arg(long, value_delimiter = ',', value_name = "A,B")]
    analyses: Vec<String>,
    /// An error metric and a cost metric whose Pareto front to compute and
    /// plot (repeatable), e.g. `pipeline.max_err_levels:bit_products`.
    #[arg(long, value_name = "ERR:COST")]
    pareto: Vec<String>,
    /// A goal, `METRIC<=VALUE` (or <, >=, >; repeatable): the sweep marks
    /// the cheapest point meeting all; `--optimize` searches for one.
    #[arg(long, value_name = "METRIC<=V")]
    goal: Vec<String>,
    /// The cost `--optimize` minimizes and the sweep's Pareto fronts use by
    /// default: bit_products, adder_bits, table_bits, ff, muls, latency,
    /// the device estimates lut_est, ff_est, dsp_est, bram_est (for
    /// rtl.target), or a weighted sum (`2*dsp + lut/100`). With
    /// `--optimize`, `lut`, `synth_ff`, `dsp` and `bram` are minimized on
    /// their estimates and the winner's top is synthesized to confirm them
    /// (the count printed beside the estimate, with its error).
    #[arg(long, value_name = "COST")]
    minimize: Option<String>,
    /// Word-length optimization: the cheapest per-stage widths meeting every
    /// `--goal`, checked on both simulators, written as a configuration.
    #[arg(long)]
    optimize: bool,
    /// `--optimize`: keep this stage as configured (`unit.field`, or
    /// `width.<group>` for its members; repeatable). The stages a `--set`
    /// names and the output level (width group `level`, the pixel) are
    /// kept without it.
    #[arg(long, value_name = "KEY")]
    freeze: Vec<String>,
    /// `--optimize`: search this stage although a `--set` names it or it is
    /// the output level (`unit.field` or `width.<group>`; repeatable).
    #[arg(long, value_name = "KEY")]
    free: Vec<String>,
    /// With --optimize: also search this discrete knob over SPEC (the
    /// `--vary` spelling: `polar.table_bits=8..12`,
    /// `angles.iterations=8..16`, `normalize.method=linear,quadratic`): any
    /// key but a width (widths are searched already). Each knob takes every
    /// value with the widths found, the cheapest point meeting the goals
    /// wins, and the widths are narrowed again. Repeatable.
    #[arg(long, value_name = "KEY=SPEC")]
    knob: Vec<String>,
    /// Most points `--optimize` measures after the uniform widths (which
    /// are always measured: one point per width from 8 to 26 bits).
    #[arg(long, default_value_t = 400, value_name = "N")]
    max_evals: usize,
    /// Vectors the winner's RTL is checked on, per simulator.
    #[arg(long, default_value_t = 2000, value_name = "N")]
    rtl_count: usize,
    /// Do not check the winner's RTL (say so in the output).
    #[arg(long)]
    no_rtl_check: bool,
    /// With --optimize: close the winner's timing on this target (ice40-hx8k,
    /// ice40-up5k, ecp5), as `synth <--synth-unit> --target T --freq MHZ
    /// --close` does: pipelining changes no value, so the widths found stay
    /// the cheapest meeting the goals, and the winner is pipelined until
    /// the median Fmax meets --freq. Its measured LUT, FF, DSP, block RAM
    /// and Fmax are printed beside the estimates, optimized.toml holds the
    /// pipelining of the run that met, and the RTL check and the proof are
    /// of that design. Not met: the command fails (the files are written).
    #[arg(long, value_parser = super::synth::target_parser(), value_name = "TARGET", requires = "optimize")]
    close_on: Option<super::synth::Target>,
    /// The clock --close-on aims for, MHz.
    #[arg(long, value_name = "MHZ", default_value_t = 100.0, value_parser = super::finite_f64, requires = "close_on")]
    freq: f64,
    /// Place-and-route seeds of each --close-on run (the median decides).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=15), requires = "close_on")]
    seeds: u32,
    /// Runs --close-on may spend.
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u32).range(2..=12), requires = "close_on")]
    close_runs: u32,
    /// Do not prove the winner's pipeline top equivalent to its model
    /// (`fxshade equiv pipeline` on the winner; say so in the output).
    #[arg(long)]
    no_equiv: bool,
    /// Time limit of the winner's proof, seconds (0: none); past it the
    /// proof is reported `unknown after T s` and the run still succeeds.
    #[arg(long, value_name = "S", default_value_t = 600)]
    equiv_timeout: u64,
    /// `--shard K/N|auto`: measure only shard K of N (0-based) of the
    /// sweep's points; combine the shards' `explore.json` with `--merge`.
    #[command(flatten)]
    shard: crate::shard_args::ShardArgs,
    /// Combine the `explore.json` files (or directories holding one) of the
    /// shards of one sweep: fails if a shard is missing or repeated, or if
    /// they belong to different sweeps.
    #[arg(long, value_name = "FILE", num_args = 1..)]
    merge: Vec<PathBuf>,
    /// Where results are cached per configuration (default:
    /// $FXSHADE_CACHE_DIR/explore or ~/.cache/fxshade/explore).
    #[arg(long, value_name = "DIR")]
    cache: Option<PathBuf>,
    /// Measure every point again, and cache nothing.
    #[arg(long)]
    no_cache: bool,
    /// Start every point's evaluation through this command (split as a
    /// shell would): `'srun -N1 -n1 --quiet'`, `'bsub -K -q short'`,
    /// `'qrsh -now no'`, or a script; it is given the fxshade executable and
    /// `explore-point JOB RESULT`, which both must be visible where it runs
    /// (a shared file system). `--jobs` points run at once (default: the
    /// machine's cores); results are the same as a local run's.
    #[arg(long, value_name = "CMD")]
    launcher: Option<String>,
    /// Where `--launcher`'s job files go (a private directory is made in
    /// it and removed at the end; default: the current directory).
    #[arg(long, value_name = "DIR", requires = "launcher")]
    launch_dir: Option<PathBuf>,
    /// Points measured at once (default: all cores).
    #[arg(long, value_name = "J")]
    jobs: Option<usize>,
    /// Also synthesize every point with `fxshade synth` for this target
    /// (generic, ice40-hx8k, ice40-up5k, ecp5, xc7): the metrics lut,
    /// synth_ff, dsp, bram and (where a place and route exists) fmax_mhz.
    /// Synthesis is cached per configuration like every other figure.
    #[arg(long, value_parser = super::synth::target_parser(), value_name = "TARGET")]
    synth: Option<super::synth::Target>,
    /// The module `--synth` synthesizes: a unit, or `pipeline` (the top of
    /// the configured path, the default).
    #[arg(long, value_name = "UNIT", default_value = "pipeline", value_parser = super::unit_arg(&[]))]
    synth_unit: String,
    /// Print every metric and width group, and exit.
    #[arg(long)]
    list_metrics: bool,
    /// Output directory: explore.json, points.csv, pareto CSVs and plots
    /// (with --optimize: optimized.toml and optimize.json).
    #[arg(long, short = 'o', value_name = "DIR")]
    out: Option<PathBuf>,
    /// Replace `--out` even when it holds files fxshade did not write.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    output: OutputArgs,
}

/// A value and where it came from (`--goal`, `sweep.toml:4`).
type Given = (String, String);

/// A sweep file's fields, each entry with its file and line.
#[derive(Default, Debug)]
struct SweepFile {
    vary: Vec<Given>,
    set: Vec<Given>,
    mesh: Vec<Given>,
    size: Option<Given>,
    samples: Option<usize>,
    analyses: Vec<Given>,
    pareto: Vec<Given>,
    goal: Vec<Given>,
    minimize: Option<Given>,
}

fn read_sweep(path: &Path) -> anyhow::Result<SweepFile> {
    let text = fxshade_model::files::read_text_limited(path).map_err(|e| {
        UsageError(format!(
            "--sweep {}: cannot read the sweep file: {e}",
            path.display()
        ))
    })?;
    let line = |span: Option<std::ops::Range<usize>>| {
        span.map_or(1, |s| {
            text[..s.start.min(text.len())].matches('\n').count() + 1
        })
    };
    let doc = toml_edit::ImDocument::parse(text.as_str()).map_err(|e: toml_edit::TomlError| {
        UsageError(format!(
            "{}:{}: {}",
            path.display(),
            line(e.span()),
            e.message()
        ))
    })?;
    let at = |span| format!("{}:{}", path.display(), line(span));
    let mut f = SweepFile::default();
    for (key, item) in doc.iter() {
        let here = at(item.span());
        let strings = || -> anyhow::Result<Vec<Given>> {
            let arr = item.as_array().ok_or_else(|| {
                UsageError(format!(
                    "{here}: `{key}` is a list of strings, e.g. {key} = [\"…\"]"
                ))
            })?;
            arr.iter()
                .map(|v| {
                    let vat = at(v.span());
                    v.as_str()
                        .map(|s| (s.to_string(), vat.clone()))
                        .ok_or_else(|| {
                            UsageError(format!("{vat}: `{key}` holds a value that is not a string"))
                                .into()
                        })
                })
                .collect()
        };
        match key {
            "vary" => f.vary = strings()?,
            "set" => f.set = strings()?,
            "mesh" => f.mesh = strings()?,
            "analyses" => f.analyses = strings()?,
            "pareto" => f.pareto = strings()?,
            "goal" => f.goal = strings()?,
            "size" | "minimize" => {
                let s = item
                    .as_str()
                    .ok_or_else(|| UsageError(format!("{here}: `{key}` is a string")))?;
                let g = Some((s.to_string(), here.clone()));
                if key == "size" {
                    f.size = g;
                } else {
                    f.minimize = g;
                }
            }
            "samples" => {
                f.samples = Some(
                    narrow::<usize, _>(item.as_integer()
                        .filter(|&n| n > 0)
                        .ok_or_else(|| UsageError(format!("{here}: `samples` is a positive integer")))?),
                )
            }
            _ => {
                return Err(UsageError(format!(
                    "{here}: unknown key `{key}`; expected vary, set, mesh, size, samples, analyses, pareto, goal, minimize"
                ))
                .into())
            }
        }
    }
    Ok(f)
}

/// Everything a run needs, from the flags and the sweep file.
struct Plan {
    base: Base,
    axes: Vec<sweep::Axis>,
    options: Options,
    pareto: Vec<(String, String)>,
    goals: Vec<Goal>,
    minimize: String,
}

/// The sweep file's entries, then the flag's (named `flag`).
fn given(file: &[Given], flags: &[String], flag: &str) -> Vec<Given> {
    file.iter()
        .cloned()
        .chain(flags.iter().map(|s| (s.clone(), flag.to_string())))
        .collect()
}

fn usage(e: anyhow::Error) -> anyhow::Error {
    UsageError(format!("{e:#}")).into()
}

/// Goals, Pareto pairs (error, cost) and the cost to minimize.
type Targets = (Vec<Goal>, Vec<(String, String)>, String);

/// Goals, the Pareto pairs and the cost to minimize, from the sweep file
/// and the flags.
fn targets(a: &ExploreArgs, file: &SweepFile) -> anyhow::Result<Targets> {
    let goals: Vec<Goal> = given(&file.goal, &a.goal, "--goal")
        .iter()
        .map(|(g, at)| Goal::parse(g, at).map_err(usage))
        .collect::<anyhow::Result<_>>()?;
    let (minimize, at) = a
        .minimize
        .clone()
        .map(|m| (m, "--minimize".to_string()))
        .or(file.minimize.clone())
        .unwrap_or_else(|| ("bit_products".into(), "--minimize".into()));
    let names: Vec<String> = if explore::cost_expr::is_expr(&minimize) {
        explore::cost_expr::CostExpr::parse(&minimize)
            .map_err(|e| UsageError(format!("{at} {e}")))?
            .metrics()
            .map(str::to_string)
            .collect()
    } else {
        vec![minimize.clone()]
    };
    for m in &names {
        explore::check_metric(&at, m).map_err(usage)?;
    }
    if let Some(m) = names
        .iter()
        .find(|m| eval::group_of(m) != "cost" || explore::higher_is_better(m))
    {
        return Err(UsageError(format!(
            "{at} `{m}`: not a cost; minimize one of {} (or a weighted sum of them: \
             `2*dsp_est + lut/100`)",
            eval::METRICS
                .iter()
                .filter(|(n, _)| eval::group_of(n) == "cost")
                .map(|(n, _)| *n)
                .collect::<Vec<_>>()
                .join(", ")
        ))
        .into());
    }
    let mut pareto = Vec::new();
    for (p, at) in given(&file.pareto, &a.pareto, "--pareto") {
        let (e, c) = p.split_once(':').ok_or_else(|| {
            UsageError(format!(
                "{at} `{p}`: write ERR:COST, e.g. pipeline.max_err_levels:bit_products"
            ))
        })?;
        explore::check_metric(&at, e.trim()).map_err(usage)?;
        explore::check_metric(&at, c.trim()).map_err(usage)?;
        pareto.push((e.trim().to_string(), c.trim().to_string()));
    }
    Ok((goals, pareto, minimize))
}

/// `minimize` with every metric synthesis measures replaced by its
/// estimate (`lut` by `lut_est`, `synth_ff` by `ff_est`, `dsp` by
/// `dsp_est`, `bram` by `bram_est`), whole names only, and the pairs
/// replaced.
fn on_estimates(minimize: &str) -> (String, Vec<(String, String)>) {
    const MAP: [(&str, &str); 4] = [
        ("lut", "lut_est"),
        ("synth_ff", "ff_est"),
        ("dsp", "dsp_est"),
        ("bram", "bram_est"),
    ];
    let mut out = String::new();
    let mut swapped = Vec::new();
    let mut word = String::new();
    let is_word = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '.';
    let mut flush = |word: &mut String, out: &mut String| {
        match MAP.iter().find(|(f, _)| *f == word.as_str()) {
            Some((f, t)) => {
                out.push_str(t);
                if !swapped.iter().any(|(x, _): &(String, String)| x == f) {
                    swapped.push((f.to_string(), t.to_string()));
                }
            }
            None => out.push_str(word),
        }
        word.clear();
    };
    for c in minimize.chars() {
        if is_word(c) {
            word.push(c);
        } else {
            flush(&mut word, &mut out);
            out.push(c);
        }
    }
    flush(&mut word, &mut out);
    (out, swapped)
}

/// The metrics `minimize` names: itself, or an expression's metrics.
fn minimized_metrics(minimize: &str) -> Vec<String> {
    match explore::cost_expr::CostExpr::parse(minimize) {
        Ok(e) if explore::cost_expr::is_expr(minimize) => e.metrics().map(str::to_string).collect(),
        _ => vec![minimize.to_string()],
    }
}

/// Refuse two axes that set the same `unit.field`: the later one would
/// silently win and the earlier one's labels would be wrong.
fn check_disjoint(axes: &[sweep::Axis]) -> anyhow::Result<()> {
    let fields = |ax: &sweep::Axis| -> std::collections::BTreeSet<String> {
        ax.values
            .iter()
            .flat_map(|v| v.overrides.iter())
            .filter_map(|o| o.split_once('=').map(|(k, _)| k.trim()))
            .map(|k| k.split('.').take(2).collect::<Vec<_>>().join("."))
            .collect()
    };
    for (i, x) in axes.iter().enumerate() {
        for y in &axes[..i] {
            if let Some(f) = fields(x).intersection(&fields(y)).next() {
                return Err(UsageError(format!(
                    "--vary {} and --vary {} both set {f}: sweep it on one axis",
                    y.key, x.key
                ))
                .into());
            }
        }
    }
    Ok(())
}

fn plan(a: &ExploreArgs) -> anyhow::Result<Plan> {
    for (flag, given) in [
        ("--freeze", &a.freeze),
        ("--free", &a.free),
        ("--knob", &a.knob),
    ] {
        if !a.optimize && !given.is_empty() {
            return Err(UsageError(format!(
                "{flag}: it steers the search of --optimize; give --optimize too"
            ))
            .into());
        }
    }
    let file = match &a.sweep {
        Some(p) => read_sweep(p)?,
        None => SweepFile::default(),
    };
    for (s, at) in &file.set {
        fxshade_model::Config::embedded()
            .apply_override(s)
            .map_err(|e| UsageError(format!("{at}: {e}")))?;
    }
    let base = Base {
        config: a.cfg.config.clone(),
        set: file
            .set
            .iter()
            .map(|(s, _)| s.clone())
            .chain(a.cfg.set.iter().cloned())
            .collect(),
    };
    let base_cfg = fxshade_model::Config::resolve(base.config.as_deref(), &base.set)?;
    let mut axes = Vec::new();
    for (spec, at) in given(&file.vary, &a.vary, "--vary") {
        axes.push(sweep::parse_axis(&spec, &base_cfg, &at).map_err(usage)?);
    }
    check_disjoint(&axes)?;
    let (goals, mut pareto, mut minimize) = targets(a, &file)?;
    if a.optimize && a.synth.is_none() {
        // The search cannot synthesize every point: what the device counts
        // is minimized on its estimate, and the winner is synthesized to
        // confirm it.
        let (m, swapped) = on_estimates(&minimize);
        if !swapped.is_empty() {
            eprintln!(
                "explore: --optimize minimizes {} on the estimate{} (no synthesis per point); \
                 the winner is synthesized to confirm it",
                swapped
                    .iter()
                    .map(|(f, t)| format!("`{f}` as `{t}`"))
                    .collect::<Vec<_>>()
                    .join(", "),
                if swapped.len() == 1 { "" } else { "s" }
            );
            minimize = m;
        }
    }
    let given_meshes = given(&file.mesh, &a.mesh, "--mesh");
    // Each mesh is checked here, named by where it was given.
    for (m, at) in &given_meshes {
        let procedural = m.starts_with("sphere:") || m.starts_with("torus:");
        if !(procedural || std::path::Path::new(m).is_file()) {
            return Err(UsageError(format!(
                "{at}: mesh `{m}`: no such file; give sphere:N, torus:N or an .obj file"
            ))
            .into());
        }
    }
    let mut meshes: Vec<String> = given_meshes.into_iter().map(|(m, _)| m).collect();
    let asked = given(&file.analyses, &a.analyses, "--analyses");
    for (x, at) in &asked {
        if !eval::ANALYSES.contains(&x.as_str()) {
            return Err(UsageError(format!(
                "{at} `{x}`: expected {}",
                eval::ANALYSES.join(", ")
            ))
            .into());
        }
    }
    let mut analyses: Vec<String> = asked.into_iter().map(|(x, _)| x).collect();
    let needed: Vec<String> = goals
        .iter()
        .map(|g| g.metric.clone())
        .chain(pareto.iter().flat_map(|(e, c)| [e.clone(), c.clone()]))
        .chain(minimized_metrics(&minimize))
        .collect();
    if analyses.is_empty() {
        analyses = if a.optimize {
            vec!["cost".into()]
        } else {
            eval::ANALYSES
                .iter()
                .filter(|&&x| x != "pipeline" || !meshes.is_empty())
                .map(|s| s.to_string())
                .collect()
        };
    }
    if a.synth.is_none() {
        if let Some(m) = needed
            .iter()
            .find(|m| eval::SYNTH_METRICS.contains(&m.as_str()))
        {
            return Err(UsageError(format!(
                "`{m}` is measured by synthesis: add --synth TARGET (e.g. --synth ice40-hx8k)"
            ))
            .into());
        }
    }
    if a.synth.is_some() {
        crate::rtl_flow::unit(&a.synth_unit)
            .map_err(|e| UsageError(format!("--synth-unit: {e:#}")))?;
    }
    for m in &needed {
        let g = eval::group_of(m).to_string();
        if !analyses.contains(&g) {
            analyses.push(g);
        }
        // A unit's own cost (`cost.<unit>.*`) is measured with its analysis.
        if let Some(u) = m.strip_prefix("cost.").and_then(|r| r.split('.').next()) {
            if eval::UNIT_COSTS.contains(&u) && !analyses.iter().any(|x| x == u) {
                analyses.push(u.to_string());
            }
        }
    }
    if analyses.iter().any(|x| x == "pipeline") && meshes.is_empty() {
        meshes = DEFAULT_MESHES.iter().map(|s| s.to_string()).collect();
    }
    if pareto.is_empty() {
        let err = goals.first().map(|g| g.metric.clone()).unwrap_or_else(|| {
            if analyses.iter().any(|x| x == "pipeline") {
                "pipeline.max_err_levels".into()
            } else {
                "normalize.max_rel_err".into()
            }
        });
        if analyses.contains(&eval::group_of(&err).to_string()) {
            pareto.push((err, minimize.clone()));
        }
    }
    let (size, size_at) = match (&a.size, &file.size) {
        (Some(s), _) => (s.clone(), "--size".to_string()),
        (None, Some((s, at))) => (s.clone(), at.clone()),
        (None, None) => ("128x128".into(), "--size".into()),
    };
    let size =
        super::render::parse_size(&size).map_err(|e| UsageError(format!("{size_at}: {e:#}")))?;
    let samples = a.samples.or(file.samples);
    if samples == Some(0) {
        return Err(UsageError("--samples 0: give at least 1".into()).into());
    }
    if let Some(n) = samples {
        fxshade_model::analysis::check_samples("--samples", n).map_err(UsageError)?;
    }
    // Order the analyses as declared, so the options (and the cache keys)
    // do not depend on the order they were asked in.
    let analyses = eval::ANALYSES
        .iter()
        .filter(|x| analyses.iter().any(|y| y == *x))
        .map(|s| s.to_string())
        .collect();
    let inputs = explore::inputs_fingerprint(base.config.as_deref(), &meshes)?;
    Ok(Plan {
        base,
        axes,
        options: Options {
            analyses,
            meshes,
            size,
            samples,
            inputs,
            synth: a
                .synth
                .map(|t| (t.name().to_string(), a.synth_unit.clone())),
        },
        pareto,
        goals,
        minimize,
    })
}

/// The sweep's identity: shards of one sweep share it.
fn sweep_id(p: &Plan, total: usize) -> String {
    sweep_id_of(&p.base, &p.axes, &p.options, total)
}

/// The fingerprint of a sweep: its base, its axes with their values, its
/// options and its size.
fn sweep_id_of(base: &Base, axes: &[sweep::Axis], options: &Options, total: usize) -> String {
    let j = serde_json::json!({
        "base": base, "axes": axes, "options": options, "total": total,
    });
    format!(
        "{:016x}",
        fxshade_model::vectors::fingerprint(&[j.to_string().as_bytes()])
    )
}

/// The file written as `explore.json` (and read by `--merge`).
#[derive(serde::Serialize, serde::Deserialize)]
struct Results {
    sweep_id: String,
    total: usize,
    shard: Option<(usize, usize)>,
    /// Where the shard came from (its scheduler's task numbering).
    #[serde(default)]
    scheduler: Option<crate::shard::Scheduler>,
    /// fxshade's version: shards of one sweep share it.
    #[serde(default)]
    fxshade_version: String,
    axes: Vec<String>,
    /// The axes with their values (what `--merge` checks each row
    /// against).
    #[serde(default)]
    sweep: Vec<sweep::Axis>,
    base: Base,
    options: Options,
    pareto_metrics: Vec<(String, String)>,
    goals: Vec<Goal>,
    minimize: String,
    rows: Vec<Row>,
    #[serde(default)]
    pareto: Vec<serde_json::Value>,
    #[serde(default)]
    /// The sweep index of the cheapest point meeting every goal.
    cheapest_meeting_goals: Option<usize>,
    /// Each measured point's configuration file and `--set` line.
    #[serde(default)]
    point_configs: Vec<PointConfig>,
    /// A two-axis sweep's grids: per shown metric, its CSV and heat map.
    #[serde(default)]
    grids: Vec<serde_json::Value>,
}

/// How to reproduce one point in another command.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
struct PointConfig {
    /// The point's sweep index.
    index: usize,
    /// Its effective configuration, relative to the output directory
    /// (`points/point_<index>.toml`; `--config` reads it).
    file: String,
    /// The same configuration as flags: the base's `--config` and every
    /// `--set` (the base's, then the point's), shell-quoted.
    flags: String,
}

/// `s` quoted for a POSIX shell.
fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"._-=/:,+".contains(&b))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// Run it.
pub fn run(a: &ExploreArgs) -> anyhow::Result<()> {
    let r = run_all(a);
    crate::explore::launch::cleanup();
    r
}

fn run_all(a: &ExploreArgs) -> anyhow::Result<()> {
    if a.list_metrics {
        let mut t = Table::new(["metric", "meaning"]);
        for (n, d) in eval::METRICS {
            t.row([*n, *d]);
        }
        let mut g = Table::new([
            "width group",
            "members (default configuration)",
            "what it carries",
        ]);
        let cfg = fxshade_model::Config::embedded();
        for (name, doc) in fxshade_model::config::WIDTH_GROUPS {
            let m = cfg
                .group_members(name)
                .unwrap_or_default()
                .iter()
                .map(|(k, q)| format!("{k} {}", q.format()))
                .collect::<Vec<_>>()
                .join(", ");
            g.row([format!("width.{name}"), m, doc.to_string()]);
        }
        let json = serde_json::json!({
            "metrics": eval::METRICS.iter().map(|(n, d)| serde_json::json!({"name": n, "meaning": d})).collect::<Vec<_>>(),
            "groups": fxshade_model::config::WIDTH_GROUPS.iter().map(|(n, d)| serde_json::json!({"name": n, "meaning": d})).collect::<Vec<_>>(),
        });
        return crate::output::emit(a.output, &[t, g], &json);
    }
    if let Some(j) = a.jobs {
        if j == 0 {
            return Err(UsageError("--jobs 0: give at least 1".into()).into());
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(j)
            .build_global()
            .context("cannot start the worker threads")?;
    }
    if let Some(l) = &a.launcher {
        crate::explore::launch::install(l, a.launch_dir.as_deref())?;
    }
    let cache = Cache::new(if a.no_cache {
        None
    } else {
        Some(match &a.cache {
            Some(c) => c.clone(),
            None => Cache::default_dir()?,
        })
    })?;
    if !a.merge.is_empty() {
        return merge(a);
    }
    // Everything the plan reads (the sweep file, the configuration, the
    // meshes it names) is input: a problem with it is a usage error
    // (status 2), whatever its cause.
    let p = plan(a).map_err(|e| {
        if e.downcast_ref::<UsageError>().is_some()
            || e.downcast_ref::<fxshade_model::config::ConfigErrors>()
                .is_some()
        {
            e
        } else {
            usage(e)
        }
    })?;
    let Some(out) = &a.out else {
        return Err(UsageError("--out DIR: where to write the results".into()).into());
    };
    // The output directory is checked before any point is measured.
    StagedDir::check(out, a.force).map_err(|e| UsageError(format!("--out: {e}")))?;
    if a.optimize {
        return run_optimize(a, &p, &cache, out);
    }
    let points = sweep::points(&p.axes)?;
    let total = points.len();
    let shard = a.shard.resolve()?;
    let mine: Vec<sweep::Point> = match shard.as_ref().map(|s| (s.k, s.n)) {
        Some((k, n)) => points.into_iter().filter(|x| x.index % n == k).collect(),
        None => points,
    };
    let meshes = explore::load_meshes(&p.options).map_err(usage)?;
    let bar = crate::progress::bar_eta(mine.len() as u64, "explore");
    let rows = explore::measure(&p.base, &mine, &p.options, &meshes, &cache, &|| bar.inc(1));
    bar.finish_and_clear();
    let res = Results {
        sweep_id: sweep_id(&p, total),
        total,
        shard: shard.as_ref().map(|s| (s.k, s.n)),
        scheduler: shard.map(|s| s.scheduler),
        fxshade_version: env!("CARGO_PKG_VERSION").to_string(),
        axes: p.axes.iter().map(|x| x.key.clone()).collect(),
        sweep: p.axes.clone(),
        base: p.base.clone(),
        options: p.options.clone(),
        pareto_metrics: p.pareto.clone(),
        goals: p.goals.clone(),
        minimize: p.minimize.clone(),
        rows,
        pareto: Vec::new(),
        cheapest_meeting_goals: None,
        point_configs: Vec::new(),
        grids: Vec::new(),
    };
    finish(a, res, out)
}

/// The cheapest row meeting every goal (by the cost minimized).
fn cheapest(rows: &[Row], goals: &[Goal], cost: &str) -> Option<usize> {
    if goals.is_empty() {
        return None;
    }
    rows.iter()
        .enumerate()
        .filter(|(_, r)| goals.iter().all(|g| g.met(r)))
        .filter_map(|(i, r)| Some((i, r.get(cost)?)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

fn label(r: &Row) -> String {
    r.labels
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Pareto fronts, plots, files and the printed table.
fn finish(a: &ExploreArgs, mut res: Results, out: &Path) -> anyhow::Result<()> {
    launch_failures()?;
    res.rows.sort_by_key(|r| r.index);
    let dir = staged(a, out)?;
    let best = cheapest(&res.rows, &res.goals, &res.minimize);
    res.cheapest_meeting_goals = best.map(|i| res.rows[i].index);
    let mut pareto_json = Vec::new();
    for (k, (e, c)) in res.pareto_metrics.iter().enumerate() {
        let front = explore::pareto(&res.rows, e, c);
        let mut t = csv::Writer::from_writer(Vec::new());
        t.write_record(["index", "point", e.as_str(), c.as_str()])?;
        for &i in &front {
            let r = &res.rows[i];
            t.write_record([
                r.index.to_string(),
                label(r),
                format!("{}", r.get(e).unwrap_or(f64::NAN)),
                format!("{}", r.get(c).unwrap_or(f64::NAN)),
            ])?;
        }
        let stem = if k == 0 {
            "pareto".to_string()
        } else {
            format!("pareto_{k}")
        };
        dir.write(&format!("{stem}.csv"), &t.into_inner()?)?;
        let all: Vec<(f64, f64)> = res
            .rows
            .iter()
            .filter(|r| r.error.is_none())
            .filter_map(|r| Some((r.get(c)?, r.get(e)?)))
            .collect();
        let line: Vec<(f64, f64)> = front
            .iter()
            .filter_map(|&i| Some((res.rows[i].get(c)?, res.rows[i].get(e)?)))
            .collect();
        let marks: Vec<(String, f64, f64)> = best
            .and_then(|i| {
                let r = &res.rows[i];
                Some((
                    format!("cheapest meeting the goals: {}", label(r)),
                    r.get(c)?,
                    r.get(e)?,
                ))
            })
            .into_iter()
            .collect();
        let log = all.iter().all(|p| p.1 > 0.0) && !explore::higher_is_better(e);
        let (png, svg) = crate::plot::plot(
            &crate::plot::Frame {
                title: &format!("Pareto front: {e} against {c}"),
                x: c,
                y: e,
                log_y: log,
            },
            &[("Pareto front".into(), line)],
            &all,
            &marks,
        )?;
        dir.write(&format!("{stem}.png"), &png)?;
        dir.write(&format!("{stem}.svg"), svg.as_bytes())?;
        pareto_json.push(serde_json::json!({
            "error": e, "cost": c, "points": front.iter().map(|&i| res.rows[i].index).collect::<Vec<_>>(),
            "csv": format!("{stem}.csv"), "png": format!("{stem}.png"), "svg": format!("{stem}.svg"),
        }));
    }
    res.pareto = pareto_json;
    // Error against the first axis, one curve per value of the others.
    if let (Some(first), false) = (res.axes.first(), res.rows.is_empty()) {
        let xs: Option<Vec<f64>> = res
            .rows
            .iter()
            .map(|r| explore::axis_x(&r.labels[0].1))
            .collect();
        if let Some(xs) = xs {
            let metrics: Vec<String> = {
                let mut m: Vec<String> =
                    res.pareto_metrics.iter().map(|(e, _)| e.clone()).collect();
                m.dedup();
                m
            };
            for (k, metric) in metrics.iter().enumerate() {
                let mut series: Vec<crate::plot::Series> = Vec::new();
                for (r, &x) in res.rows.iter().zip(&xs) {
                    let Some(y) = r.get(metric).filter(|_| r.error.is_none()) else {
                        continue;
                    };
                    let name = r.labels[1..]
                        .iter()
                        .map(|(k, v)| format!("{k}={v}"))
                        .collect::<Vec<_>>()
                        .join(" ");
                    let name = if name.is_empty() {
                        metric.clone()
                    } else {
                        name
                    };
                    match series.iter_mut().find(|s| s.0 == name) {
                        Some(s) => s.1.push((x, y)),
                        None => series.push((name, vec![(x, y)])),
                    }
                }
                let log = series.iter().flat_map(|s| &s.1).all(|p| p.1 > 0.0)
                    && !explore::higher_is_better(metric);
                let xl = if res.rows[0].labels[0]
                    .1
                    .parse::<fxshade_model::format::Format>()
                    .is_ok()
                    || first.starts_with("width.")
                {
                    format!("{first} (total bits)")
                } else {
                    first.clone()
                };
                let (png, svg) = crate::plot::plot(
                    &crate::plot::Frame {
                        title: &format!("{metric} against {first}"),
                        x: &xl,
                        y: metric,
                        log_y: log,
                    },
                    &series,
                    &[],
                    &[],
                )?;
                let stem = if k == 0 {
                    "error_vs_axis".to_string()
                } else {
                    format!("error_vs_axis_{k}")
                };
                dir.write(&format!("{stem}.png"), &png)?;
                dir.write(&format!("{stem}.svg"), svg.as_bytes())?;
            }
        }
    }
    // A two-axis sweep: each shown metric as a grid (CSV, heat map).
    let mut grid_tables = Vec::new();
    res.grids.clear();
    if res.axes.len() == 2 && !res.rows.is_empty() {
        let values = |k: usize| {
            let mut v: Vec<String> = Vec::new();
            for r in &res.rows {
                if !v.contains(&r.labels[k].1) {
                    v.push(r.labels[k].1.clone());
                }
            }
            v
        };
        let (xs, ys) = (values(0), values(1));
        for (k, metric) in shown_metrics(&res).iter().enumerate() {
            let cells: Vec<Vec<Option<f64>>> = xs
                .iter()
                .map(|x| {
                    ys.iter()
                        .map(|y| {
                            res.rows
                                .iter()
                                .find(|r| &r.labels[0].1 == x && &r.labels[1].1 == y)
                                .filter(|r| r.error.is_none())
                                .and_then(|r| r.get(metric))
                        })
                        .collect()
                })
                .collect();
            let stem = format!("grid_{k}");
            let mut w = csv::Writer::from_writer(Vec::new());
            let mut head = vec![format!("{} \\ {}", res.axes[0], res.axes[1])];
            head.extend(ys.iter().cloned());
            w.write_record(&head)?;
            let mut t = Table::new(head.clone()).titled(format!(
                "{metric} over {} (down) and {} (across); {stem}.csv, {stem}.png",
                res.axes[0], res.axes[1]
            ));
            for (x, col) in xs.iter().zip(&cells) {
                let mut row = vec![x.clone()];
                row.extend(
                    col.iter()
                        .map(|v| v.map_or(String::new(), |v| format!("{v}"))),
                );
                w.write_record(&row)?;
                let mut shown_row = vec![x.clone()];
                shown_row.extend(col.iter().map(|v| v.map_or("-".into(), fmt_num)));
                t.row(shown_row);
            }
            dir.write(&format!("{stem}.csv"), &w.into_inner()?)?;
            let (png, svg) = crate::plot::grid(
                &crate::plot::Grid {
                    title: &format!("{metric} over {} and {}", res.axes[0], res.axes[1]),
                    x: (&res.axes[0], &xs),
                    y: (&res.axes[1], &ys),
                    cells: &cells,
                },
                &fmt_num,
            )?;
            dir.write(&format!("{stem}.png"), &png)?;
            dir.write(&format!("{stem}.svg"), svg.as_bytes())?;
            res.grids.push(serde_json::json!({
                "metric": metric, "x": res.axes[0], "y": res.axes[1],
                "csv": format!("{stem}.csv"), "png": format!("{stem}.png"), "svg": format!("{stem}.svg"),
            }));
            grid_tables.push(t);
        }
    }
    // Every point's configuration, as a file `--config` reads and as the
    // flags that make it, so `vectors`, `synth`, `render` reproduce it.
    res.point_configs.clear();
    for r in res.rows.iter().filter(|r| r.error.is_none()) {
        let Ok(cfg) = res.base.resolve(&r.overrides) else {
            continue;
        };
        let mut flags: Vec<String> = Vec::new();
        if let Some(c) = &res.base.config {
            // Absolute, so the flags work from any directory.
            let c = std::path::absolute(c).unwrap_or_else(|_| c.clone());
            flags.push(format!(
                "--config {}",
                shell_quote(&c.display().to_string())
            ));
        }
        // The axes' own spelling (`width.normals=12`) where it makes the
        // same configuration, else the overrides it expands to.
        let spelled: Vec<String> = r.labels.iter().map(|(k, v)| format!("{k}={v}")).collect();
        let same = res
            .base
            .resolve(&spelled)
            .is_ok_and(|c| explore::canonical(&c) == explore::canonical(&cfg));
        let sets = if same { &spelled } else { &r.overrides };
        for o in res.base.set.iter().chain(sets) {
            flags.push(format!("--set {}", shell_quote(o)));
        }
        let flags = flags.join(" ");
        let file = format!("points/point_{:04}.toml", r.index);
        let text = format!(
            "# fxshade explore point {}: {}\n# the same configuration as flags: {}\n{}",
            r.index,
            fxshade_model::escape::line(&label(r)),
            fxshade_model::escape::line(&flags),
            cfg.to_toml()
        );
        dir.write(&file, text.as_bytes())?;
        res.point_configs.push(PointConfig {
            index: r.index,
            file,
            flags,
        });
    }
    dir.write(
        "points.csv",
        explore::to_csv(&res.axes, &res.rows)?.as_bytes(),
    )?;
    dir.write(
        "explore.json",
        serde_json::to_string_pretty(&res)?.as_bytes(),
    )?;
    dir.commit()?;
    // The printed table: the axes, the Pareto metrics and the goals' metrics.
    let shown = shown_metrics(&res);
    let mut header = vec!["#".to_string()];
    header.extend(res.axes.iter().cloned());
    header.extend(shown.iter().map(|m| with_design(m, &res.options)));
    header.push("note".into());
    let mut t = Table::new(header).titled(format!(
        "{} of {} points{} (every metric: {}/points.csv; each point's configuration: \
         points/point_<#>.toml)",
        res.rows.len(),
        res.total,
        res.shard
            .map_or(String::new(), |(k, n)| format!(", shard {k}/{n}")),
        out.display()
    ));
    let fronts: Vec<&serde_json::Value> = res.pareto.iter().collect();
    for (i, r) in res.rows.iter().enumerate() {
        let mut row = vec![r.index.to_string()];
        row.extend(r.labels.iter().map(|(_, v)| v.clone()));
        for m in &shown {
            row.push(r.get(m).map_or("-".into(), fmt_num));
        }
        let mut note = Vec::new();
        if let Some(e) = &r.error {
            note.push(e.chars().take(80).collect::<String>());
        }
        if fronts
            .first()
            .and_then(|f| f["points"].as_array())
            .is_some_and(|p| p.iter().any(|x| x.as_u64() == Some(r.index as u64)))
        {
            note.push("pareto".into());
        }
        if best == Some(i) {
            note.push("cheapest meeting the goals".into());
        }
        row.push(note.join("; "));
        t.row(row);
    }
    let mut tables = vec![t];
    tables.extend(grid_tables);
    crate::output::emit(a.output, &tables, &serde_json::to_value(&res)?)
}

/// A metric's column heading with the design it measures: the top's
/// costs `[top]`, `--synth`'s figures `[<unit> on <target>]`; a unit's own
/// costs (`cost.<unit>.*`) and the error metrics name it already.
fn with_design(m: &str, o: &explore::Options) -> String {
    if eval::SYNTH_METRICS.contains(&m) {
        return match &o.synth {
            Some((target, unit)) => format!("{m} [{unit} on {target}]"),
            None => m.to_string(),
        };
    }
    if eval::group_of(m) == "cost" && !m.starts_with("cost.") {
        return format!("{m} [top]");
    }
    m.to_string()
}

/// The metrics a sweep shows: its Pareto metrics, then its goals'.
fn shown_metrics(res: &Results) -> Vec<String> {
    let mut shown: Vec<String> = Vec::new();
    for (e, c) in &res.pareto_metrics {
        for m in [e, c] {
            if !shown.contains(m) {
                shown.push(m.clone());
            }
        }
    }
    for g in &res.goals {
        if !shown.contains(&g.metric) {
            shown.push(g.metric.clone());
        }
    }
    shown
}

fn fmt_num(v: f64) -> String {
    if v == v.trunc() && v.abs() < 1e9 {
        format!("{v}")
    } else if v.abs() >= 0.01 {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

fn staged(a: &ExploreArgs, out: &Path) -> anyhow::Result<StagedDir> {
    if a.force {
        StagedDir::new_forced(out)
    } else {
        StagedDir::new(out)
    }
    .with_context(|| format!("cannot write the results to {}", out.display()))
}

/// Fail when a point could not be launched (`--launcher`): its row would
/// read as the model's verdict. Nothing is written; what was measured is
/// cached, so a re-run measures only the rest.
fn launch_failures() -> anyhow::Result<()> {
    let f = crate::explore::launch::failures();
    if !f.is_empty() {
        bail!(
            "{} point{} could not be launched, so nothing was written (a re-run measures only \
             them):\n{}",
            f.len(),
            if f.len() == 1 { "" } else { "s" },
            f.join("\n")
        );
    }
    Ok(())
}

/// `--merge`: the shards' rows as one sweep.
fn merge(a: &ExploreArgs) -> anyhow::Result<()> {
    let Some(out) = &a.out else {
        return Err(UsageError("--out DIR: where to write the merged results".into()).into());
    };
    let mut parts: Vec<(PathBuf, Results)> = Vec::new();
    for f in &a.merge {
        let f = if f.is_dir() {
            f.join("explore.json")
        } else {
            f.clone()
        };
        let text = fxshade_model::files::read_text_limited(&f)
            .map_err(|e| UsageError(format!("--merge {}: cannot read: {e}", f.display())))?;
        let r: Results = serde_json::from_str(&text).with_context(|| {
            format!("{}: not an explore.json of `fxshade explore`", f.display())
        })?;
        parts.push((f, r));
    }
    let (f0, r0) = &parts[0];
    if r0.shard.is_none() {
        bail!(
            "{}: not a shard (run `fxshade explore --shard K/N`)",
            f0.display()
        );
    }
    for (f, r) in &parts {
        if r.fxshade_version != r0.fxshade_version {
            bail!(
                "{}: measured by fxshade {}, but {} by fxshade {}: measure the odd shard again",
                f.display(),
                if r.fxshade_version.is_empty() {
                    "(older)"
                } else {
                    &r.fxshade_version
                },
                f0.display(),
                if r0.fxshade_version.is_empty() {
                    "(older)"
                } else {
                    &r0.fxshade_version
                },
            );
        }
        if r.sweep_id != r0.sweep_id {
            bail!(
                "{} and {} are shards of different sweeps (axes, options or base differ)",
                f0.display(),
                f.display()
            );
        }
        // The sweep a shard names is the one its fingerprint says, and
        // every row is the point its index names in it.
        if r.sweep.is_empty() && r.total > 1 {
            bail!(
                "{}: written by an older fxshade without the sweep's values: measure it again",
                f.display()
            );
        }
        if sweep_id_of(&r.base, &r.sweep, &r.options, r.total) != r.sweep_id {
            bail!(
                "{}: its sweep does not match its fingerprint (edited?)",
                f.display()
            );
        }
        let points = sweep::points(&r.sweep)?;
        for row in &r.rows {
            let ok = points
                .get(row.index)
                .is_some_and(|p| p.labels == row.labels && p.overrides == row.overrides);
            if !ok {
                bail!(
                    "{}: row {} ({}) is not point {} of the sweep",
                    f.display(),
                    row.index,
                    label(row),
                    row.index
                );
            }
        }
    }
    super::merge::check_shards(
        &parts
            .iter()
            .map(|(f, r)| (f.clone(), r.shard, r.scheduler.clone()))
            .collect::<Vec<_>>(),
    )?;
    let mut rows: Vec<Row> = parts
        .iter()
        .flat_map(|(_, r)| r.rows.iter().cloned())
        .collect();
    rows.sort_by_key(|r| r.index);
    if rows.len() != r0.total || rows.iter().enumerate().any(|(i, r)| r.index != i) {
        bail!(
            "the shards hold {} points of {}: not one whole sweep",
            rows.len(),
            r0.total
        );
    }
    let (_, first) = parts.swap_remove(0);
    let mut res = Results {
        shard: None,
        scheduler: None,
        rows,
        pareto: Vec::new(),
        cheapest_meeting_goals: None,
        point_configs: Vec::new(),
        grids: Vec::new(),
        ..first
    };
    // Goals, Pareto pairs and the cost given to --merge replace the shards'
    // (they do not change what was measured, only what is marked).
    let (goals, pareto, minimize) = targets(a, &SweepFile::default())?;
    if !a.goal.is_empty() {
        res.goals = goals;
    }
    if !a.pareto.is_empty() {
        res.pareto_metrics = pareto;
    }
    if a.minimize.is_some() {
        res.minimize = minimize;
    }
    finish(a, res, out)
}

/// `--optimize`.
fn run_optimize(a: &ExploreArgs, p: &Plan, cache: &Cache, out: &Path) -> anyhow::Result<()> {
    if p.goals.is_empty() {
        return Err(UsageError("--optimize needs at least one --goal METRIC<=VALUE".into()).into());
    }
    if !p.axes.is_empty() || a.shard.shard.is_some() {
        return Err(UsageError(
            "--optimize searches widths itself: give no --vary or --shard".into(),
        )
        .into());
    }
    // --close-on: a target with a delay model and a place and route.
    let close_timing = match a.close_on {
        None => None,
        Some(t) => {
            let tt = Some(t)
                .filter(|t| super::synth::closes(*t))
                .ok_or_else(|| {
                    UsageError(format!(
                        "--close-on {}: give a target with a delay model and a place and route \
                     ({})",
                        t.name(),
                        super::synth::synth_targets_where(super::synth::closes)
                    ))
                })?;
            if !(a.freq.is_finite() && a.freq > 0.0) {
                return Err(
                    UsageError(format!("--freq {}: give a clock in MHz above 0", a.freq)).into(),
                );
            }
            Some(tt)
        }
    };
    // The search estimates for the device it closes on (`dsp_est`,
    // `bram_est` read rtl.target), unless the designer set rtl.target.
    let mut base = p.base.clone();
    if let Some(t) = a.close_on {
        if !base
            .set
            .iter()
            .any(|s| s.split('=').next().map(str::trim) == Some("rtl.target"))
        {
            base.set.push(format!("rtl.target=\"{}\"", t.name()));
        }
    }
    let cfg = fxshade_model::Config::resolve(base.config.as_deref(), &base.set)?;
    // An area estimate needs a fit for rtl.target: say so before searching.
    let target = cfg
        .section::<fxshade_model::rtl::section::RtlConfig>()
        .target
        .name();
    if let Some(m) = minimized_metrics(&p.minimize)
        .into_iter()
        .find(|m| m == "lut_est" || m == "ff_est")
    {
        use fxshade_model::rtl::targets::Target;
        let t = Target::from_name(target);
        if t.and_then(|t| t.area_model()).is_none() {
            let fitted: Vec<&str> = Target::all()
                .iter()
                .filter(|t| t.area_model().is_some())
                .map(|t| t.name())
                .collect();
            let why = if t.is_some_and(|t| t.synthesis().is_some()) {
                format!(
                    "which has none yet (`fxshade synth calibrate --area --target {target}` \
                     measures one)"
                )
            } else {
                "which has no LUT cells to count".to_string()
            };
            return Err(UsageError(format!(
                "--minimize: `{m}` needs an area model for rtl.target {target}, {why} (fitted: \
                 {}); give --set 'rtl.target=\"ecp5\"' or --close-on ecp5",
                fitted.join(", ")
            ))
            .into());
        }
    }
    let frozen = optimize::frozen(&cfg, &base.set, &a.freeze, &a.free).map_err(UsageError)?;
    let mut knobs: Vec<explore::sweep::Axis> = Vec::new();
    for spec in &a.knob {
        let k = explore::sweep::parse_axis(spec, &cfg, "--knob")
            .map_err(|e| UsageError(format!("{e:#}")))?;
        let key = k.key.as_str();
        if key.starts_with("width.")
            || key.ends_with(".format")
            || optimize::vars(&cfg).0.iter().any(|v| v.key == key)
        {
            return Err(UsageError(format!(
                "--knob {key}: a width; --optimize searches the widths already (--freeze keeps one)"
            ))
            .into());
        }
        if base
            .set
            .iter()
            .any(|s| s.split('=').next().map(str::trim) == Some(key))
        {
            return Err(UsageError(format!(
                "--knob {key}: --set names it too; the designer's value is not searched (drop one)"
            ))
            .into());
        }
        if key.starts_with("rtl.") || key.starts_with("pipeline.") {
            return Err(UsageError(format!(
                "--knob {key}: not searchable (rtl.* is the pipelining --close-on sets; \
                 pipeline.* changes the units on the path the widths are searched on)"
            ))
            .into());
        }
        if knobs.iter().any(|x| x.key == key) {
            return Err(UsageError(format!("--knob {key}: given twice")).into());
        }
        knobs.push(k);
    }
    let meshes = explore::load_meshes(&p.options)?;
    let bar = crate::progress::bar_eta(a.max_evals as u64, "optimize");
    let o = optimize::run(
        &base,
        &cfg,
        &p.goals,
        &p.minimize,
        &p.options,
        &meshes,
        cache,
        a.max_evals,
        &frozen,
        &knobs,
        &|what| {
            bar.set_message(what.to_string());
            bar.inc(1);
        },
    );
    bar.finish_and_clear();
    launch_failures()?;
    let o = o?;
    // Close the winner's timing: its pipelining is added to its overrides.
    let closure = match a.close_on {
        None => None,
        Some(t) => {
            let tt = close_timing.expect("checked before the search");
            let bar = crate::progress::spinner("explore: closing the winner's timing");
            let c = super::synth::close::close(
                &a.synth_unit,
                &|extra| {
                    let all: Vec<String> =
                        o.winner.overrides.iter().chain(extra).cloned().collect();
                    base.resolve(&all)
                        .map_err(|e| anyhow::anyhow!("the winner's configuration: {e}"))
                },
                t,
                tt,
                1000.0 / a.freq,
                a.close_runs,
                super::synth::Flow {
                    seeds: a.seeds,
                    freq: a.freq,
                    pnr: true,
                    dsp_pack: true,
                    device: None,
                },
                !a.no_cache,
                &|m| bar.set_message(m.to_string()),
                &|l| bar.suspend(|| eprintln!("explore: closing timing: {l}")),
            );
            bar.finish_and_clear();
            Some(c?)
        }
    };
    let mut win_overrides = o.winner.overrides.clone();
    if let Some(c) = &closure {
        win_overrides.extend(c.set.iter().cloned());
    }
    let win_cfg = p
        .base
        .resolve(&win_overrides)
        .map_err(|e| anyhow::anyhow!("the winner's configuration: {e}"))?;
    // A cost minimized on its estimate: synthesize the winner's top (what
    // the estimate describes) for rtl.target, to set the count beside it.
    let confirmed = if closure.is_none()
        && minimized_metrics(&o.minimize)
            .iter()
            .any(|m| m.ends_with("_est"))
    {
        let name = win_cfg
            .section::<fxshade_model::rtl::section::RtlConfig>()
            .target
            .name();
        match super::synth::synth_target(name).ok_or(()) {
            Err(()) => {
                eprintln!(
                    "explore: rtl.target {name} has no synthesis flow: the estimate stands unconfirmed"
                );
                None
            }
            Ok(t) => {
                let bar = crate::progress::spinner("explore: synthesizing the winner");
                let r = super::synth::cached_with_netlist(
                    "pipeline",
                    &win_cfg,
                    t,
                    super::synth::Flow {
                        seeds: 1,
                        freq: 100.0,
                        pnr: false,
                        dsp_pack: true,
                        device: None,
                    },
                    None,
                    !a.no_cache,
                    None,
                    &|m| bar.set_message(m.to_string()),
                )
                .context("synthesizing the winner to confirm its estimate");
                bar.finish_and_clear();
                Some(r?.0)
            }
        }
    } else {
        None
    };
    // Check the winner's RTL top on both simulators.
    let mut checks = Vec::new();
    if !a.no_rtl_check {
        let u = rtl_flow::unit("pipeline")?;
        let stream = VectorStream::new(u, &win_cfg, a.rtl_count, 1, None, super::search_mode()?)?;
        let sources = rtl_flow::Sources::emitted(&stream.rtl());
        for sim in [Sim::Verilator, Sim::Icarus] {
            // A step of minutes on a big top: a line when it starts.
            eprintln!(
                "explore: checking the winner's RTL top on {sim:?} ({} vectors)",
                a.rtl_count
            );
            let r = rtl_flow::check_with(&stream, &sources, sim, 1, 20, None, false)
                .with_context(|| format!("checking the winner's RTL on {sim:?}"))?;
            checks.push(serde_json::json!({
                "sim": format!("{sim:?}").to_lowercase(), "count": r.count,
                "passed": r.passed, "failed": r.failed, "ok": r.ok(),
            }));
            if !r.ok() {
                bail!(
                    "the winner's RTL fails on {sim:?}: {} of {} vectors ({})",
                    r.failed,
                    r.count,
                    r.mismatches.first().cloned().unwrap_or_default()
                );
            }
        }
    }
    // Prove the winner's top against its model: a counterexample fails the
    // run (the emitter wrote RTL that is not the model); unknown is said.
    let equiv = if a.no_equiv {
        serde_json::json!("skipped (--no-equiv)")
    } else {
        eprintln!(
            "explore: proving the winner's RTL top equal to its model ({})",
            if a.equiv_timeout == 0 {
                "no time limit".to_string()
            } else {
                format!("at most {} s", a.equiv_timeout)
            }
        );
        let mods = super::equiv::modules("pipeline", &win_cfg, None)?;
        let bar = crate::progress::bar(mods.len() as u64, "equiv");
        let done = |m: &str| {
            bar.set_message(m.to_string());
            bar.inc(1);
        };
        let res = super::equiv::prove_all(
            &mods,
            crate::smt::Solver::Bitwuzla,
            a.equiv_timeout,
            1,
            None,
            &done,
        );
        bar.finish_and_clear();
        let res = res.context("proving the winner's pipeline top")?;
        for e in &res {
            match e.verdict {
                super::equiv::Verdict::Counterexample => bail!(
                    "the winner's {} is NOT its model: a counterexample (run `fxshade equiv \
                     pipeline --config optimized.toml` for it)",
                    e.module
                ),
                super::equiv::Verdict::Proved => eprintln!(
                    "explore: the winner's {} is proved equivalent to its model ({:.1} s)",
                    e.module, e.seconds
                ),
                super::equiv::Verdict::Unknown => eprintln!(
                    "explore: the winner's {} is unknown after {:.0} s ({})",
                    e.module,
                    e.seconds,
                    e.reason.as_deref().unwrap_or("")
                ),
            }
        }
        serde_json::to_value(&res)?
    };
    let dir = staged(a, out)?;
    // Comment lines: the user's goal and metric names escaped to one line.
    let mut toml = format!(
        "# fxshade explore --optimize: the cheapest widths found ({} = {}) meeting {}\n# uniform baseline: {} bits, {} = {}; saving {:.1} %\n",
        fxshade_model::escape::line(&o.minimize),
        o.winner.get(&o.minimize).unwrap_or(f64::NAN),
        fxshade_model::escape::line(
            &o.goals.iter().map(|g| g.to_string()).collect::<Vec<_>>().join(", ")
        ),
        o.baseline_width,
        fxshade_model::escape::line(&o.minimize),
        o.baseline.get(&o.minimize).unwrap_or(f64::NAN),
        100.0 * o.saving
    );
    if !o.knobs.is_empty() {
        toml += &format!(
            "# knobs searched: {}\n",
            fxshade_model::escape::line(
                &o.knobs
                    .iter()
                    .map(|(k, _, v)| format!("{k} = {v}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        );
    }
    if !o.frozen.is_empty() {
        toml += &format!(
            "# kept as configured (not searched): {}\n",
            fxshade_model::escape::line(
                &o.frozen
                    .iter()
                    .map(|(k, f)| format!("{k} {f}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        );
    }
    if let Some(c) = &closure {
        toml += &format!(
            "# timing of {}: {} on {}, {}\n",
            c.result.module,
            c.result
                .verdict
                .as_ref()
                .map_or_else(|| "no Fmax".into(), |v| v.line()),
            fxshade_model::escape::line(&c.result.device),
            match c.outcome {
                super::synth::close::Outcome::Met => format!("closed in {} run(s)", c.runs.len()),
                _ => format!(
                    "NOT closed: {}",
                    fxshade_model::escape::line(c.stopped.as_deref().unwrap_or("-"))
                ),
            }
        );
    }
    toml += &win_cfg.to_toml();
    dir.write("optimized.toml", toml.as_bytes())?;
    let json = serde_json::json!({
        "outcome": o,
        "rtl_check": if a.no_rtl_check { serde_json::json!("skipped (--no-rtl-check)") } else { serde_json::json!(checks) },
        "equivalence": equiv,
        "options": p.options,
        "confirmed": confirmed,
        "closure": closure.as_ref().map(|c| {
            let mut j = c.json();
            j["result"] = serde_json::to_value(&c.result).unwrap_or_default();
            j
        }),
    });
    dir.write(
        "optimize.json",
        serde_json::to_string_pretty(&json)?.as_bytes(),
    )?;
    // Cost of each uniform width, with the baseline and the winner marked.
    let uni: Vec<(f64, f64)> = o
        .uniform
        .iter()
        .filter_map(|&(w, _, c)| Some((f64::from(w), c?)))
        .collect();
    let ok: Vec<(f64, f64)> = o
        .uniform
        .iter()
        .filter(|u| u.1)
        .filter_map(|&(w, _, c)| Some((f64::from(w), c?)))
        .collect();
    let wc = o.winner.get(&o.minimize).unwrap_or(f64::NAN);
    let span: Vec<(f64, f64)> = [optimize::UNIFORM_MIN, optimize::UNIFORM_MAX]
        .iter()
        .map(|&w| (f64::from(w), wc))
        .collect();
    let (png, svg) = crate::plot::plot(
        &crate::plot::Frame {
            title: &format!(
                "{} of uniform widths and of the optimized widths",
                o.minimize
            ),
            x: "uniform width (bits)",
            y: &o.minimize,
            log_y: false,
        },
        &[
            ("every stage at one width".into(), uni),
            ("uniform widths meeting the goals".into(), ok),
            (format!("optimized per-stage widths: {}", fmt_num(wc)), span),
        ],
        &[],
        &[],
    )?;
    dir.write("optimize.png", &png)?;
    dir.write("optimize.svg", svg.as_bytes())?;
    dir.commit()?;
    let mut t = Table::new(["stage", "baseline", "optimized"]).titled(format!(
        "Cheapest widths meeting {} ({} = {} against {} at a uniform {} bits: {:.1} % less; {} points measured)",
        o.goals.iter().map(|g| g.to_string()).collect::<Vec<_>>().join(", "),
        o.minimize,
        fmt_num(wc),
        fmt_num(o.baseline.get(&o.minimize).unwrap_or(f64::NAN)),
        o.baseline_width,
        100.0 * o.saving,
        o.evaluations
    ));
    let vars = &o.vars;
    let bw: Vec<u32> = vars
        .iter()
        .map(|v| o.baseline_width.max(v.min_width()))
        .collect();
    let bo = optimize::overrides(vars, &bw).unwrap_or_default();
    let wo = optimize::overrides(vars, &o.widths).unwrap_or_default();
    for (k, v) in vars.iter().enumerate() {
        let f = |s: &[String]| {
            s.get(k)
                .and_then(|x| x.split_once('='))
                .map_or("-".to_string(), |x| x.1.to_string())
        };
        t.row([v.key.clone(), f(&bo), f(&wo)]);
    }
    for (key, format) in &o.frozen {
        let kept = format!("{format} (kept)");
        t.row([key.clone(), kept.clone(), kept]);
    }
    for (key, from, to) in &o.knobs {
        t.row([format!("{key} (knob)"), from.clone(), to.clone()]);
    }
    let mut m = Table::new(["metric", "baseline", "optimized"]);
    let mut names: Vec<String> = o.goals.iter().map(|g| g.metric.clone()).collect();
    for c in ["bit_products", "adder_bits", "table_bits", "ff"] {
        if !names.iter().any(|n| n == c) {
            names.push(c.into());
        }
    }
    for n in names {
        m.row([
            n.clone(),
            o.baseline.get(&n).map_or("-".into(), fmt_num),
            o.winner.get(&n).map_or("-".into(), fmt_num),
        ]);
    }
    let mut c = Table::new(["RTL check of the optimized top", "vectors", "passed"]);
    if a.no_rtl_check {
        c.row(["skipped (--no-rtl-check)", "-", "-"]);
    }
    for ch in &checks {
        c.row([
            ch["sim"].as_str().unwrap_or("").to_string(),
            ch["count"].to_string(),
            ch["passed"].to_string(),
        ]);
    }
    let mut tables = vec![t, m, c];
    if let Some(cl) = &closure {
        tables.push(super::synth::closure::table(cl, &a.synth_unit));
        tables.push(closed_table(cl));
    }
    if let Some(r) = &confirmed {
        tables.push(counted_table(
            r,
            format!(
                "The winner's {} as synthesized for {} (no place and route; the harness's {} FF \
                 excluded; estimates from the module alone, error against the count)",
                r.module, r.device, r.harness_ff
            ),
        ));
    }
    crate::output::emit(a.output, &tables, &json)?;
    if !a.output.json {
        crate::output::print_out(&format!(
            "configuration written to {}/optimized.toml\n",
            out.display()
        ))?;
    }
    if let Some(c) = &closure {
        if c.outcome != super::synth::close::Outcome::Met {
            bail!(
                "the winner's timing is not closed: {:.1} MHz not met ({})",
                c.goal_mhz,
                c.stopped.as_deref().unwrap_or("-")
            );
        }
    }
    Ok(())
}

/// The closed winner's synthesized module as the device counts it, beside
/// the estimates of that same module (LUT, FF, DSP and block RAM without
/// synthesis, the delay model's Fmax).
fn closed_table(c: &super::synth::close::Closure) -> Table {
    let r = &c.result;
    counted_table(
        r,
        format!(
            "The winner's {} as placed on {} (run {} of the timing closure; the harness's {} FF \
             excluded; estimates from the module alone, error against the count)",
            r.module, r.device, c.runs[c.shown].run, r.harness_ff
        ),
    )
}

/// A synthesized module's counts beside their estimates, with the error.
fn counted_table(r: &super::synth::SynthResult, title: String) -> Table {
    let mut t = Table::new(["measure", "measured", "estimate (error)"]).titled(title);
    if r.fmax_mhz.is_some() {
        t.row([
            "Fmax median (MHz)".to_string(),
            r.fmax_mhz.map_or("-".into(), |f| format!("{f:.1}")),
            r.predicted_mhz
                .map_or("-".into(), |f| format!("{f:.1} (delay model)")),
        ]);
    }
    let est = |e: Option<u64>, m: u64| {
        e.map_or("-".into(), |e| {
            format!(
                "{e} ({:+.0} %)",
                100.0 * (to_f64(e) - to_f64(m)) / to_f64(m.max(1))
            )
        })
    };
    let unit_ff = r.ff.saturating_sub(r.harness_ff);
    for (name, m, e) in [
        ("LUT4", r.lut, r.lut_estimate),
        ("FF (the unit's)", unit_ff, r.ff_estimate),
        ("DSP", r.dsp, r.dsp_estimate),
        ("BRAM", r.bram, r.bram_estimate),
    ] {
        t.row([name.to_string(), m.to_string(), est(e, m)]);
    }
    t.row([
        "latency (cycles)".to_string(),
        r.latency.to_string(),
        "-".into(),
    ]);
    t
}

#[cfg(test)]
mod tests {
    use super::{on_estimates, shell_quote};

    /// Device metrics become their estimates, whole names only.
    #[test]
    fn device_costs_are_minimized_on_their_estimates() {
        assert_eq!(
            on_estimates("2*dsp + lut/100"),
            (
                "2*dsp_est + lut_est/100".to_string(),
                vec![
                    ("dsp".to_string(), "dsp_est".to_string()),
                    ("lut".to_string(), "lut_est".to_string())
                ]
            )
        );
        assert_eq!(on_estimates("synth_ff").0, "ff_est");
        assert_eq!(
            on_estimates("bit_products + ff + dsp_est"),
            ("bit_products + ff + dsp_est".to_string(), vec![])
        );
    }

    #[test]
    fn flags_are_quoted_for_a_shell() {
        assert_eq!(shell_quote("width.normals=12"), "width.normals=12");
        assert_eq!(
            shell_quote("pipeline.path=\"mapped\""),
            "'pipeline.path=\"mapped\"'"
        );
        assert_eq!(shell_quote("a b'c"), "'a b'\\''c'");
        assert_eq!(shell_quote(""), "''");
    }
}
