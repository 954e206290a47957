//! `fxshade ops`: operation counts measured by running each unit's datapath
//! in the counting context.

use clap::Args;
use fxshade_model::units::{OpReport, UNITS};

use super::ConfigArgs;
use crate::output::{emit, OutputArgs, Table};

/// `fxshade ops`
#[derive(Args, Debug)]
pub struct OpsArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    #[command(flatten)]
    out: OutputArgs,
}

/// All reports for a configuration.
pub fn reports(cfg: &fxshade_model::Config) -> Vec<OpReport> {
    UNITS.iter().flat_map(|u| (u.ops)(cfg)).collect()
}

/// The reports as a table for people.
pub fn table(reports: &[OpReport]) -> Table {
    let mut t = Table::new([
        "unit",
        "variant",
        "stage",
        "mul",
        "add",
        "div",
        "sqrt",
        "table_read",
        "compare",
        "round",
        "saturate",
        "multipliers (a×b bits)",
        "paper claims",
    ])
    .titled("Operation counts, measured by running each datapath in the counting context");
    for r in reports {
        let c = &r.counts;
        let shapes = c
            .mul_shapes
            .iter()
            .map(|m| format!("{}×({}×{})", m.count, m.a_width, m.b_width))
            .collect::<Vec<_>>()
            .join(" ");
        let paper = r.paper.as_ref().map_or(String::from("-"), |p| {
            let parts: Vec<String> = [
                (p.mul, "mul"),
                (p.add, "add"),
                (p.div, "div"),
                (p.sqrt, "sqrt"),
                (p.table_read, "table"),
            ]
            .iter()
            .filter_map(|(n, what)| n.filter(|&n| n > 0).map(|n| format!("{n} {what}")))
            .collect();
            format!("{} ({})", parts.join(", "), p.source)
        });
        t.row([
            r.unit.to_string(),
            r.variant.to_string(),
            serde_json::to_value(r.stage)
                .expect("enum")
                .as_str()
                .unwrap_or("")
                .to_string(),
            c.mul.to_string(),
            c.add.to_string(),
            c.div.to_string(),
            c.sqrt.to_string(),
            c.table_read.to_string(),
            c.compare.to_string(),
            c.round.to_string(),
            c.saturate.to_string(),
            shapes,
            paper,
        ]);
    }
    t
}

/// The quantization points of every report as a table for people.
pub fn stages_table(reports: &[OpReport]) -> Table {
    let mut t = Table::new([
        "unit",
        "variant",
        "stage",
        "exact input",
        "bits",
        "output",
        "dropped bits",
        "round",
        "overflow",
    ])
    .titled("Quantization points, in datapath order (from the counting run)");
    for r in reports {
        for p in &r.quant_points {
            t.row([
                r.unit.to_string(),
                r.variant.to_string(),
                p.stage.to_string(),
                p.input.clone(),
                p.input_width.to_string(),
                p.output.to_string(),
                p.dropped_bits.to_string(),
                p.round.name().to_string(),
                p.overflow.name().to_string(),
            ]);
        }
    }
    t
}

/// Run it.
pub fn run(a: &OpsArgs) -> anyhow::Result<()> {
    let cfg = a.cfg.resolve()?;
    let r = reports(&cfg);
    emit(a.out, &[table(&r)], &serde_json::to_value(&r)?)
}

/// `fxshade stages`
#[derive(Args, Debug)]
pub struct StagesArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    #[command(flatten)]
    out: OutputArgs,
}

/// Run `fxshade stages`.
pub fn run_stages(a: &StagesArgs) -> anyhow::Result<()> {
    let cfg = a.cfg.resolve()?;
    let r = reports(&cfg);
    let points: Vec<_> = r
        .iter()
        .flat_map(|r| {
            r.quant_points.iter().map(move |p| {
                let mut v = serde_json::to_value(p).expect("serializable");
                v["unit"] = r.unit.into();
                v["variant"] = r.variant.into();
                v
            })
        })
        .collect();
    emit(
        a.out,
        &[stages_table(&r)],
        &serde_json::Value::Array(points),
    )
}
