//! `fxshade synth`: the arguments and the printed tables of a synthesis
//! ([`fxshade_flows::synth`] runs it), the closure loop's
//! ([`closure`]) and the delay and area models' calibrations.

use fxshade_model::convert::to_f64;
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
pub use fxshade_flows::synth::*;

use super::ConfigArgs;
use crate::output::{emit, OutputArgs, Table, UsageError};

pub mod closure;

/// `--target` of a synthesis: the families with a synthesis flow, each
/// with its one-line description in `--help`.
pub fn target_parser() -> impl clap::builder::TypedValueParser<Value = Target> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    PossibleValuesParser::new(
        Target::synthesized()
            .iter()
            .map(|t| PossibleValue::new(t.name()).help(t.about())),
    )
    .map(|name| synth_target(&name).expect("the parser admits only these names"))
}

/// `fxshade synth`
#[derive(Args, Debug)]
pub struct SynthArgs {
    /// Unit; the pipeline top of the configured path for `pipeline`;
    /// `calibrate`: the delay model's probes (one operation between two
    /// registers each), measured against the model's prediction.
    #[arg(value_parser = super::unit_arg(&["calibrate"]))]
    unit: String,
    /// Target.
    #[arg(long, value_parser = target_parser(), default_value = "generic")]
    target: Target,
    #[command(flatten)]
    cfg: ConfigArgs,
    /// The part of the target's family to place on (case-insensitive):
    /// ecp5 LFE5U-85F (default), LFE5U-45F, LFE5U-25F;
    /// ice40-hx8k iCE40HX8K (default), iCE40HX4K, iCE40HX1K; ice40-up5k
    /// iCE40UP5K; xc7 xc7a35t, xc7a100t, xc7a200t (no placer: synthesis's
    /// counts against the part's capacity). The utilisation is reported in
    /// percent, from the placer's report (none with --no-pnr but on xc7);
    /// a design that does not fit names the resource.
    #[arg(long, value_name = "PART")]
    device: Option<String>,
    /// Place-and-route seeds (the median Fmax is reported).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=15))]
    seeds: u32,
    /// Clock the placer aims for, MHz (default 100, or the one of
    /// `--clock-ns`).
    #[arg(long, value_parser = super::finite_f64)]
    freq: Option<f64>,
    /// Pipeline the RTL for this target's delay model at this clock
    /// period, ns (sets rtl.pipeline = "target", rtl.target to --target
    /// and rtl.clock_ns).
    #[arg(long = "clock-ns", value_name = "NS", value_parser = super::finite_f64)]
    clock_ns: Option<f64>,
    /// `compact` or `target` (sets rtl.pipeline; the configuration's
    /// rtl.target and rtl.clock_ns apply).
    #[arg(long, value_parser = ["compact", "target"])]
    pipeline: Option<String>,
    /// Stop after synthesis (no place and route).
    #[arg(long)]
    no_pnr: bool,
    /// Keep the harness, scripts and logs in this directory (new or empty).
    #[arg(long, value_name = "DIR")]
    keep: Option<PathBuf>,
    /// ECP5: leave every product register in the fabric, as Yosys maps
    /// it (by default they move into the MULT18X18D blocks; see
    /// `dsp_packed` in the JSON).
    #[arg(long)]
    no_dsp_pack: bool,
    /// ECP5: also write the unit's gate-level netlist, its module of the
    /// netlist placed (after the register packing, unless --no-dsp-pack;
    /// no cached result is read) into this directory (new or empty),
    /// with the simulation models of its cells, for a gate-level
    /// co-simulation: `fxshade rtl-check <unit> --sim icarus --rtl-dir
    /// DIR` with the same configuration and pipelining.
    #[arg(long, value_name = "DIR")]
    netlist: Option<PathBuf>,
    /// Timing closure: when the median Fmax misses the clock asked for
    /// (--freq, or 1000 / --clock-ns), pipeline again for a period the
    /// measured critical path corrects (the delay model's error on the
    /// slowest stage: next period = goal period x predicted / measured
    /// slowest stage) and place again, until the median meets the goal,
    /// re-pipelining changes nothing, or RUNS runs (default 4,
    /// `--close=RUNS`) are spent.
    /// The first run is pipelined at --clock-ns, else at the goal's
    /// period. Prints each run, then the last one met (else the fastest)
    /// as `synth` does, with the flags that reproduce it.
    #[arg(
        long,
        value_name = "RUNS",
        num_args = 0..=1,
        require_equals = true,
        default_missing_value = "4",
        value_parser = clap::value_parser!(u32).range(2..=12),
        conflicts_with_all = ["netlist", "keep", "no_pnr"]
    )]
    close: Option<u32>,
    /// With `calibrate`: the area model instead of the delay model:
    /// synthesize every unit and top in five configurations (the default,
    /// 12-bit normals, a wide set, 24 bits with the FIFO handshake, target
    /// pipelining at 8 ns; your
    /// --config and --set apply first), print the estimated LUT and FF
    /// beside the counted ones, and the coefficients a fit of these
    /// designs gives (no place and route).
    #[arg(long)]
    area: bool,
    /// With `calibrate --area`: which designs of the set to synthesize and
    /// fit: `units` (the six units, 30 designs), `tops` (the two pipeline
    /// tops, 10) or `all`. On a target whose products are all fabric logic
    /// (iCE40 HX8K) the tops take hours; a fit of the units alone then
    /// states its error on them.
    #[arg(long, value_parser = ["all", "units", "tops"], default_value = "all", requires = "area")]
    designs: String,
    /// Measure again even when a cached result exists (the new result
    /// replaces it).
    #[arg(long)]
    no_cache: bool,
    #[command(flatten)]
    out: OutputArgs,
}

/// Run it.
pub fn run(a: &SynthArgs) -> anyhow::Result<()> {
    if let Some(c) = a.clock_ns {
        if !(c.is_finite() && c > 0.0) {
            return Err(UsageError(format!("--clock-ns {c}: give a period in ns above 0")).into());
        }
    }
    let freq = match (a.freq, a.clock_ns) {
        (Some(f), _) => f,
        (None, Some(c)) if c > 0.0 => 1000.0 / c,
        _ => 100.0,
    };
    if !(freq.is_finite() && freq > 0.0) {
        return Err(UsageError(format!("--freq {freq}: give a clock in MHz above 0")).into());
    }
    let device = match &a.device {
        Some(name) => Some(crate::device::Device::find(a.target, name).map_err(UsageError)?),
        None => None,
    };
    let tt = timing(a.target);
    if a.clock_ns.is_some() && tt.is_none() {
        return Err(UsageError(format!(
            "--clock-ns: --target {} has no delay model; give --target {}",
            a.target,
            synth_targets_where(|t| t.delay().is_some())
        ))
        .into());
    }
    for (flag, given, what) in [
        (
            "--netlist",
            a.netlist.is_some(),
            "gate-level netlists are written",
        ),
        ("--no-dsp-pack", a.no_dsp_pack, "register packing is done"),
    ] {
        if given && !a.target.packs_dsp_registers() {
            return Err(UsageError(format!(
                "{flag}: {what} for --target {} only (not {})",
                synth_targets_where(|t| t.packs_dsp_registers()),
                a.target.name()
            ))
            .into());
        }
    }
    for (flag, dir, what) in [
        (
            "--netlist",
            &a.netlist,
            "synth writes the netlist and its cell models there",
        ),
        (
            "--keep",
            &a.keep,
            "synth writes its harness, scripts and logs there",
        ),
    ] {
        if let Some(k) = dir {
            if std::fs::read_dir(k).is_ok_and(|mut d| d.next().is_some()) {
                return Err(UsageError(format!(
                    "{flag} {}: the directory is not empty; give a new or empty one ({what})",
                    k.display()
                ))
                .into());
            }
        }
    }
    if a.unit == "calibrate" {
        if a.netlist.is_some() {
            return Err(UsageError(
                "synth calibrate: --netlist writes a unit's netlist; give a unit instead of calibrate".into(),
            )
            .into());
        }
        let Some(tt) = tt else {
            return Err(UsageError(
                "synth calibrate: give --target ice40-hx8k, ice40-up5k, ecp5 or xc7 (the generic target has no delay model)".into(),
            )
            .into());
        };
        if a.area {
            return calibrate_area(a, tt, device);
        }
        return calibrate(a, tt, freq, device);
    }
    if a.area {
        return Err(UsageError(
            "--area calibrates the area model: give `synth calibrate --area --target T`".into(),
        )
        .into());
    }
    if let Some(runs) = a.close {
        let Some(tt) = tt.filter(|t| t.place_route().is_ok()) else {
            return Err(UsageError(format!(
                "--close: {} has no delay model or no place and route to measure with; give \
                 --target {}",
                a.target.name(),
                synth_targets_where(closes)
            ))
            .into());
        };
        return closure::run(a, tt, runs, freq, device);
    }
    let extra = super::pipeline_overrides(
        a.pipeline.as_deref(),
        a.clock_ns.map(|_| tt.expect("checked").name()),
        a.clock_ns,
    );
    let cfg = a.cfg.resolve_with(&extra)?;
    let bar = crate::progress::spinner("synth");
    if let Some(dir) = &a.netlist {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("--netlist: cannot create {}", dir.display()))?;
    }
    let (r, was_cached, written) = cached_with_netlist(
        &a.unit,
        &cfg,
        a.target,
        Flow {
            seeds: a.seeds,
            freq,
            pnr: !a.no_pnr,
            dsp_pack: !a.no_dsp_pack,
            device,
        },
        a.keep.as_deref(),
        !a.no_cache,
        a.netlist.as_deref(),
        &|m| bar.set_message(m.to_string()),
    )?;
    bar.finish_and_clear();
    let (tables, json) = result_tables(a, &r, was_cached, written.as_ref())?;
    emit(a.out, &tables, &json)
}

/// The tables and the JSON `fxshade synth` prints for one result
/// (`written`: the netlist `--netlist` wrote).
pub(super) fn result_tables(
    a: &SynthArgs,
    r: &SynthResult,
    was_cached: bool,
    written: Option<&crate::netlist::Written>,
) -> anyhow::Result<(Vec<Table>, serde_json::Value)> {
    let mut t = Table::new([
        "unit",
        "device",
        "LUT",
        "logic cells (placed)",
        "LUT RAM",
        "FF",
        "DSP",
        "BRAM",
        "carry",
        "Fmax (MHz)",
        "predicted (MHz)",
        "latency",
        "Mvectors/s",
    ])
    .titled(format!(
        "{} on {}{} (FF includes the harness's {}; Fmax median of {} seed{})",
        r.module,
        r.device,
        if was_cached { ", from the cache" } else { "" },
        r.harness_ff,
        r.fmax_seeds.len().max(1),
        if r.fmax_seeds.len() == 1 { "" } else { "s" }
    ));
    t.row([
        r.unit.clone(),
        r.device.clone(),
        with_estimate(r.lut, r.lut_estimate),
        r.logic_cells.map_or("-".into(), |n| n.to_string()),
        r.lut_ram.to_string(),
        match r.ff_estimate {
            Some(est) => format!(
                "{} (unit {}, est. {est})",
                r.ff,
                r.ff.saturating_sub(r.harness_ff)
            ),
            None => r.ff.to_string(),
        },
        match r.dsp_estimate {
            Some(est) => format!("{} (est. {est})", r.dsp),
            None => r.dsp.to_string(),
        },
        match r.bram_estimate {
            Some(est) => format!("{} (est. {est})", r.bram),
            None => r.bram.to_string(),
        },
        r.carry.to_string(),
        r.fmax_mhz.map_or_else(
            || format!("- ({})", r.fmax_note.clone().unwrap_or_default()),
            |f| format!("{f:.1}"),
        ),
        r.predicted_mhz
            .map_or("- (compact)".into(), |f| format!("{f:.1}")),
        r.latency.to_string(),
        r.throughput_mps.map_or("-".into(), |f| format!("{f:.1}")),
    ]);
    let mut json = serde_json::to_value(r)?;
    json["cached"] = serde_json::json!(was_cached);
    let mut tables = vec![t];
    if !r.utilisation.is_empty() {
        let mut u = Table::new(["resource", "used", "available", "use"]).titled(format!(
            "Utilisation of the {} ({})",
            r.device,
            if r.fmax_seeds.is_empty() {
                "synthesis's counts against the part's capacity"
            } else {
                "the placer's report, median seed"
            }
        ));
        for x in &r.utilisation {
            u.row([
                x.resource.clone(),
                x.used.to_string(),
                x.available.to_string(),
                format!("{:.1} %", x.percent),
            ]);
        }
        tables.push(u);
    }
    if !r.ff_roles.is_empty() {
        let mut f = Table::new(["role", "flip-flops", "share"])
            .titled("Flip-flops by role (the netlist placed; roles: flows/src/ff_roles.rs)");
        let total: u64 = r.ff_roles.iter().map(|(_, n)| n).sum();
        for (role, n) in &r.ff_roles {
            f.row([
                role.clone(),
                n.to_string(),
                format!("{:.1} %", 100.0 * to_f64(*n) / to_f64(total.max(1))),
            ]);
        }
        tables.push(f);
    }
    if let (Some(v), Some(p)) = (&r.verdict, &r.critical_path) {
        let mut c = Table::new(["signal", "stage id", "node", "operation", "ns"]).titled(format!(
            "Timing: {}. Critical path of seed {}: {:.2} ns ({:.2} in cells, {:.2} routing), {} -> {}",
            v.line(),
            p.seed,
            p.delay_ns,
            p.logic_ns,
            p.routing_ns,
            crate::critical_path::signal_of(&p.from),
            crate::critical_path::signal_of(&p.to),
        ));
        for s in &p.signals {
            c.row([
                s.name.clone(),
                s.stage_id.clone().unwrap_or_else(|| "-".into()),
                s.node.map_or("-".into(), |n| n.to_string()),
                s.op.clone(),
                format!("{:.2}", s.delay_ns),
            ]);
        }
        tables.push(c);
    }
    if let Some(w) = written {
        json["netlist"] = serde_json::to_value(w)?;
        let mut n = Table::new(["file", "what"]).titled(format!(
            "Gate-level netlist of {} (check it: fxshade rtl-check {} --sim icarus --rtl-dir {} with the same configuration)",
            r.module,
            a.unit,
            a.netlist.as_ref().expect("written").display()
        ));
        n.row([
            w.netlist.display().to_string(),
            match w.packed {
                Some(p) => format!(
                    "netlist, {} blocks with operand registers and {} with output registers packed",
                    p.inputs, p.outputs
                ),
                None => "netlist, no register packing".into(),
            },
        ]);
        for m in &w.models {
            n.row([m.display().to_string(), "cell models".into()]);
        }
        tables.push(n);
    }
    Ok((tables, json))
}

/// `fxshade synth calibrate`: every probe of the delay model placed and
/// routed, the measured period beside the predicted one.
fn calibrate(
    a: &SynthArgs,
    tt: fxshade_model::rtl::timing::Target,
    freq: f64,
    device: Option<crate::device::Device>,
) -> anyhow::Result<()> {
    if a.no_pnr {
        return Err(UsageError("synth calibrate measures periods: drop --no-pnr".into()).into());
    }
    let probes = fxshade_model::rtl::calibrate::probes(tt);
    let bar = crate::progress::bar(probes.len() as u64, "calibrate");
    let mut t = Table::new([
        "probe",
        "predicted (ns)",
        "measured (ns)",
        "measured / predicted",
        "LUT",
        "DSP",
    ])
    .titled(format!(
        "Delay model of {tt} against place and route on {} (median of {} seed{})",
        device_name(a.target),
        a.seeds,
        if a.seeds == 1 { "" } else { "s" }
    ));
    let mut rows = Vec::new();
    for p in &probes {
        bar.set_message(p.label.clone());
        let e = fxshade_model::rtl::emit(&p.design)?;
        let (r, _, _) = cached_emitted(
            "probe",
            &e,
            a.target,
            Flow {
                seeds: a.seeds,
                freq,
                pnr: true,
                dsp_pack: !a.no_dsp_pack,
                device,
            },
            None,
            !a.no_cache,
            None,
            &|_| {},
        )?;
        bar.inc(1);
        let measured = r.fmax_mhz.map(|f| 1000.0 / f);
        t.row([
            p.label.clone(),
            format!("{:.2}", p.predicted_ns),
            measured.map_or("-".into(), |m| format!("{m:.2}")),
            measured.map_or("-".into(), |m| format!("{:.2}", m / p.predicted_ns)),
            r.lut.to_string(),
            r.dsp.to_string(),
        ]);
        rows.push(serde_json::json!({
            "probe": p.label,
            "predicted_ns": p.predicted_ns,
            "measured_ns": measured,
            "lut": r.lut,
            "dsp": r.dsp,
        }));
    }
    bar.finish_and_clear();
    let json = serde_json::json!({
        "target": tt.name(),
        "device": device_name(a.target),
        "model": tt.delay(),
        "probes": rows,
    });
    emit(a.out, &[t], &json)
}

/// The area model's calibration set: each unit and both pipeline tops
/// (argument and extra `--set`s) in five configurations (label, `--set`s;
/// `{target}` names the target).
pub fn area_set() -> Vec<(String, String, Vec<String>)> {
    let designs: [(&str, &str, &[&str]); 8] = [
        ("normalize", "normalize", &[]),
        ("interp", "interp", &[]),
        ("polar", "polar", &[]),
        ("angles", "angles", &[]),
        ("lighting", "lighting", &[]),
        ("angle_interp", "angle_interp", &[]),
        ("pipeline", "smooth top", &["pipeline.path=smooth"]),
        ("pipeline", "mapped top", &["pipeline.path=mapped"]),
    ];
    let configs: [(&str, &[&str]); 5] = [
        ("default", &[]),
        ("12-bit normals", &["width.normals=12"]),
        (
            "wide",
            &[
                "width.normals=20",
                "width.light=20",
                "width.normalizer=24",
                "width.tables=20",
                "width.cordic=24",
                "width.shading=20",
            ],
        ),
        (
            "24-bit, FIFO handshake",
            &[
                "width.normals=24",
                "width.light=24",
                "width.normalizer=28",
                "width.tables=24",
                "width.cordic=28",
                "width.shading=24",
                "rtl.handshake=fifo",
            ],
        ),
        (
            "target 8 ns",
            &[
                "rtl.pipeline=target",
                "rtl.target={target}",
                "rtl.clock_ns=8",
            ],
        ),
    ];
    let mut v = Vec::new();
    for (unit, label, extra) in designs {
        for (c, sets) in configs {
            v.push((
                unit.to_string(),
                format!("{label}, {c}"),
                extra.iter().chain(sets).map(|s| s.to_string()).collect(),
            ));
        }
    }
    v
}

/// `fxshade synth calibrate --area`: the area model against synthesis on
/// [`area_set`], and a refit.
fn calibrate_area(
    a: &SynthArgs,
    tt: fxshade_model::rtl::timing::Target,
    device: Option<crate::device::Device>,
) -> anyhow::Result<()> {
    use fxshade_model::rtl::estimate::{fit::fit, AreaModel, AreaTerms, TERMS};
    // A target without a fit yet is calibrated all the same: its model
    // columns are then zero and say so.
    let fitted = AreaModel::of(tt);
    let model = fitted.unwrap_or(AreaModel {
        lut: [0.0; TERMS + 1],
        ff: [0.0; TERMS + 1],
    });
    let set: Vec<_> = area_set()
        .into_iter()
        .filter(|(unit, _, _)| match a.designs.as_str() {
            "units" => unit != "pipeline",
            "tops" => unit == "pipeline",
            _ => true,
        })
        .collect();
    let bar = crate::progress::bar(set.len() as u64, "calibrate --area");
    let mut rows: Vec<(String, AreaTerms, u64, u64)> = Vec::new();
    for (unit, label, sets) in &set {
        bar.set_message(label.clone());
        let extra: Vec<String> = sets
            .iter()
            .map(|s| s.replace("{target}", tt.name()))
            .collect();
        let cfg = a
            .cfg
            .resolve_with(&extra)
            .with_context(|| format!("calibration design {label}"))?;
        let (r, _, _) = cached_with_netlist(
            unit,
            &cfg,
            a.target,
            Flow {
                seeds: 1,
                freq: 100.0,
                pnr: false,
                dsp_pack: !a.no_dsp_pack,
                device,
            },
            None,
            !a.no_cache,
            None,
            &|_| {},
        )
        .with_context(|| format!("calibration design {label}"))?;
        bar.inc(1);
        let terms = r.area_terms.expect("a target with an area model has terms");
        rows.push((
            label.clone(),
            terms,
            r.lut,
            r.ff.saturating_sub(r.harness_ff),
        ));
    }
    bar.finish_and_clear();
    let x: Vec<[f64; TERMS]> = rows.iter().map(|r| r.1.values()).collect();
    let lut_y: Vec<f64> = rows.iter().map(|r| to_f64(r.2)).collect();
    let ff_y: Vec<f64> = rows.iter().map(|r| to_f64(r.3)).collect();
    // Every term costs cells; only the multiplier blocks may take
    // flip-flops away (ECP5's product registers move into them).
    let lut_fit = fit(&x, &lut_y, [true; TERMS + 1]);
    let mut ff_sign = [true; TERMS + 1];
    ff_sign[9] = false;
    ff_sign[TERMS] = false;
    let ff_fit = fit(&x, &ff_y, ff_sign);
    let refit = AreaModel {
        lut: lut_fit,
        ff: ff_fit,
    };
    let pct = |est: u64, got: u64| 100.0 * (to_f64(est) - to_f64(got)) / (to_f64(got.max(1)));
    let mut t = Table::new([
        "design",
        "LUT",
        "LUT est.",
        "error",
        "refit",
        "FF (unit)",
        "FF est.",
        "error",
        "refit",
    ])
    .titled(format!(
        "Area model of {tt} against Yosys on {} designs (error = (estimate - synthesis) / synthesis){}",
        rows.len(),
        if fitted.is_none() {
            "; no model for this target yet: estimates 0, see the refit"
        } else {
            ""
        }
    ));
    let mut json_rows = Vec::new();
    let (mut lut_err, mut ff_err, mut lut_re, mut ff_re) = (vec![], vec![], vec![], vec![]);
    for (label, terms, lut, ff) in &rows {
        let (le, fe) = (model.lut(terms), model.ff(terms));
        let (lr, fr) = (refit.lut(terms), refit.ff(terms));
        lut_err.push(pct(le, *lut).abs());
        ff_err.push(pct(fe, *ff).abs());
        lut_re.push(pct(lr, *lut).abs());
        ff_re.push(pct(fr, *ff).abs());
        t.row([
            label.clone(),
            lut.to_string(),
            le.to_string(),
            format!("{:+.1} %", pct(le, *lut)),
            format!("{:+.1} %", pct(lr, *lut)),
            ff.to_string(),
            fe.to_string(),
            format!("{:+.1} %", pct(fe, *ff)),
            format!("{:+.1} %", pct(fr, *ff)),
        ]);
        json_rows.push(serde_json::json!({
            "design": label,
            "terms": terms,
            "lut": lut,
            "ff": ff,
            "lut_estimate": le,
            "ff_estimate": fe,
        }));
    }
    let stats = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2], *v.last().unwrap_or(&0.0))
    };
    let (lm, lx) = stats(&mut lut_err);
    let (fm, fx) = stats(&mut ff_err);
    let (rlm, rlx) = stats(&mut lut_re);
    let (rfm, rfx) = stats(&mut ff_re);
    let mut c = Table::new([
        "term",
        "LUT per unit (model)",
        "refit",
        "FF per unit (model)",
        "refit",
    ])
    .titled(format!(
        "Coefficients: |error| median/max LUT {lm:.1}/{lx:.1} %, FF {fm:.1}/{fx:.1} % \
             (model); LUT {rlm:.1}/{rlx:.1} %, FF {rfm:.1}/{rfx:.1} % (refit, in-sample)"
    ));
    for (k, name) in AreaTerms::NAMES
        .iter()
        .chain(["constant"].iter())
        .enumerate()
    {
        c.row([
            name.to_string(),
            format!("{:.4}", model.lut[k]),
            format!("{:.4}", refit.lut[k]),
            format!("{:.4}", model.ff[k]),
            format!("{:.4}", refit.ff[k]),
        ]);
    }
    let json = serde_json::json!({
        "target": tt.name(),
        "device": device_name(a.target),
        "design_set": a.designs,
        "designs": json_rows,
        "model": fitted.map(|m| serde_json::json!({"lut": m.lut, "ff": m.ff})),
        "refit": {"lut": refit.lut, "ff": refit.ff},
        "abs_error_pct": {
            "lut_median": lm, "lut_max": lx, "ff_median": fm, "ff_max": fx,
            "refit_lut_median": rlm, "refit_lut_max": rlx,
            "refit_ff_median": rfm, "refit_ff_max": rfx,
        },
    });
    emit(a.out, &[t, c], &json)
}
