//! `fxshade synth <unit> --close`: the closure loop ([`fxshade_flows::synth::close`])
//! run and printed.

use fxshade_flows::synth::close::{close, Closure, Outcome};
use fxshade_flows::synth::Flow;

use super::{result_tables, SynthArgs};
use crate::output::{emit, Table, UsageError};

/// The table of the runs, titled with the outcome.
pub fn table(c: &Closure, unit: &str) -> Table {
    let shown = &c.runs[c.shown];
    let mut t = Table::new([
        "run",
        "period planned (ns)",
        "latency",
        "predicted (MHz)",
        "Fmax median (MHz)",
        "seeds (MHz)",
        "goal",
        "measured / predicted period",
        "LUT4",
        "FF",
        "DSP",
        "BRAM",
        "critical path",
    ])
    .titled(format!(
        "Timing closure of {unit} on {} for {:.1} MHz: {}",
        c.result.device,
        c.goal_mhz,
        match (&c.outcome, &c.stopped) {
            (Outcome::Met, _) => format!("met in run {}", shown.run),
            (_, stop) => format!(
                "not met; stopped: {}; the fastest is run {}",
                stop.as_deref().unwrap_or("-"),
                shown.run
            ),
        }
    ));
    for r in &c.runs {
        t.row([
            format!("{}{}", r.run, if r.cached { " (cache)" } else { "" }),
            format!("{:.2}", r.clock_ns),
            r.latency.to_string(),
            r.predicted_mhz.map_or("-".into(), |f| format!("{f:.1}")),
            r.fmax_mhz.map_or("-".into(), |f| format!("{f:.1}")),
            r.fmax_seeds
                .iter()
                .map(|f| format!("{f:.1}"))
                .collect::<Vec<_>>()
                .join(" "),
            if r.met {
                "met".into()
            } else {
                "missed".to_string()
            },
            r.model_error.map_or("-".into(), |x| format!("{x:.3}")),
            r.lut.to_string(),
            r.ff.to_string(),
            r.dsp.to_string(),
            r.bram.to_string(),
            r.critical_path.clone().unwrap_or_else(|| "-".into()),
        ]);
    }
    t
}

/// `--close RUNS` for a target with delay model `tt`, goal `freq` MHz.
pub fn run(
    a: &SynthArgs,
    tt: fxshade_model::rtl::timing::Target,
    runs: u32,
    freq: f64,
    device: Option<crate::device::Device>,
) -> anyhow::Result<()> {
    if a.pipeline.as_deref() == Some("compact") {
        return Err(UsageError(
            "--close re-pipelines for the target's delay model; it cannot with --pipeline compact"
                .into(),
        )
        .into());
    }
    let flow = Flow {
        seeds: a.seeds,
        freq,
        pnr: true,
        dsp_pack: !a.no_dsp_pack,
        device,
    };
    let bar = crate::progress::spinner("synth --close");
    let c = close(
        &a.unit,
        &|extra| Ok(a.cfg.resolve_with(extra)?),
        a.target,
        tt,
        a.clock_ns.unwrap_or(1000.0 / freq),
        runs,
        flow,
        !a.no_cache,
        &|m| bar.set_message(m.to_string()),
        &|l| bar.suspend(|| eprintln!("synth --close: {l}")),
    );
    bar.finish_and_clear();
    let c = c?;
    let shown = &c.runs[c.shown];
    let sets: Vec<String> = c.set.iter().map(|s| format!("--set '{s}'")).collect();
    let mut repro = Table::new(["run", "command", "flags"]).titled(
        "To reproduce the run shown below: the configuration given (--config, --set) and these \
         flags, in place of any --clock-ns or --pipeline",
    );
    repro.row([
        shown.run.to_string(),
        "synth".into(),
        format!(
            "--target {} --clock-ns {} --freq {freq}",
            a.target.name(),
            shown.clock_ns
        ),
    ]);
    repro.row([
        shown.run.to_string(),
        "rtl, vectors, rtl-check, equiv, ...".into(),
        sets.join(" "),
    ]);
    let (mut tables, mut json) = result_tables(a, &c.result, shown.cached, None)?;
    tables.insert(0, table(&c, &a.unit));
    tables.insert(1, repro);
    json["closure"] = c.json();
    emit(a.out, &tables, &json)?;
    if c.outcome == Outcome::Met {
        Ok(())
    } else {
        anyhow::bail!(
            "timing not closed: {freq:.1} MHz not met in {} run{} (fastest {}, run {})",
            c.runs.len(),
            if c.runs.len() == 1 { "" } else { "s" },
            shown
                .fmax_mhz
                .map_or("no Fmax".into(), |f| format!("{f:.1} MHz")),
            shown.run
        )
    }
}
