//! `fxshade ops`: operation counts measured by running each unit's datapath
//! in the counting context.

use clap::Args;
use fxshade_model::convert::narrow;
use fxshade_model::units::{OpReport, UNITS};

use super::ConfigArgs;
use crate::output::{emit, OutputArgs, Table};

/// `fxshade ops`
#[derive(Args, Debug)]
pub struct OpsArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    /// Also synthesize each RTL unit and variant with Yosys to word-level
    /// cells and check its multipliers, adders and comparators against the
    /// counting context (exit status 1 on any disagreement).
    #[arg(long)]
    rtl: bool,
    #[command(flatten)]
    out: OutputArgs,
}

/// One RTL variant's word-level arithmetic, as the emitter built it from the
/// trace (`model_*`) and as Yosys read it back from the emitted Verilog
/// (`netlist_*`): every multiplier's operand widths and signedness, every
/// adder's width, comparators and table reads.
#[derive(Debug, Clone, serde::Serialize)]
pub struct NetlistCheck {
    /// Unit.
    pub unit: &'static str,
    /// Variant.
    pub variant: String,
    /// Multipliers of the trace, as `wide × narrow signed|unsigned`.
    pub model_mul: Vec<String>,
    /// `$mul` cells of the netlist, likewise.
    pub netlist_mul: Vec<String>,
    /// Adders, subtractors and rounding incrementers of the trace, as
    /// `A + B → Y` operand and result widths (every operand is brought to the
    /// result width by an explicit concatenation, so `A = B = Y`).
    pub model_add: Vec<String>,
    /// `$add`/`$sub` cells of the netlist, likewise.
    pub netlist_add: Vec<String>,
    /// Comparators (`max`) of the trace.
    pub model_compare: u64,
    /// `$gt`/`$lt`/`$ge`/`$le` cells of the netlist.
    pub netlist_compare: u64,
    /// Whether every list agrees.
    pub agree: bool,
}

/// `(type, parameters)` of every `$mul`, `$add`, `$sub` and comparison
/// cell in a Yosys RTLIL dump.
fn parse_cells(dump: &str) -> Vec<(String, std::collections::BTreeMap<String, i64>)> {
    let mut cells = Vec::new();
    let mut cur: Option<(String, std::collections::BTreeMap<String, i64>)> = None;
    for l in dump.lines() {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.as_slice() {
            ["cell", ty, ..] => cur = Some((ty.to_string(), Default::default())),
            ["parameter", k, v] => {
                if let Some((_, p)) = cur.as_mut() {
                    let v = v.trim_start_matches("32'");
                    let n = if v.chars().all(|c| c == '0' || c == '1') && v.len() == 32 {
                        i64::from_str_radix(v, 2).unwrap_or(0)
                    } else {
                        v.parse().unwrap_or(0)
                    };
                    p.insert(k.trim_start_matches('\\').to_string(), n);
                }
            }
            ["end"] => {
                if let Some(c) = cur.take() {
                    cells.push(c);
                }
            }
            _ => {}
        }
    }
    cells
}

/// Emit every RTL unit and variant, read each back with Yosys (`proc;
/// flatten; opt_clean`: no constant folding or width reduction, so the cells
/// have the widths the Verilog declares) and compare its arithmetic with the trace.
pub fn netlist_checks(cfg: &fxshade_model::Config) -> anyhow::Result<Vec<NetlistCheck>> {
    use anyhow::Context;
    use fxshade_model::rtl::units::{all, emit_unit};
    use rayon::prelude::*;
    crate::rtl_flow::require_tool("yosys", "yosys")?;
    // Every unit and variant, each read back by a Yosys of its own on a
    // core of its own; results in the registry's order.
    let pairs: Vec<_> = all()
        .flat_map(|u| u.variants.iter().map(move |&(v, s)| (u, v, s)))
        .collect();
    pairs
        .par_iter()
        .map(|&(u, variant, set)| -> anyhow::Result<NetlistCheck> {
            let mut c = cfg.clone();
            for o in fxshade_model::rtl::units::overrides(set) {
                c.apply_override(o)?;
            }
            let (_, e) = match emit_unit(u, &c) {
                Ok(x) => x,
                Err(err) => anyhow::bail!("{} ({variant}): {err}", u.name),
            };
            // A private scratch directory (no predictable name to race
            // for), and the tool run inside it on relative names, so a
            // space or a quote in TMPDIR never reaches its script.
            let tmp = tempfile::Builder::new()
                .prefix("fxshade-yosys-")
                .tempdir()
                .context("cannot create a temporary directory")?;
            let dir = tmp.path();
            let file = format!("{}.v", e.module);
            std::fs::write(dir.join(&file), &e.verilog)?;
            let script = format!(
                "read_verilog {file}; hierarchy -top {}; proc; flatten; opt_clean; tee -q -o cells.txt dump t:$mul t:$add t:$sub t:$gt t:$lt t:$ge t:$le",
                e.module,
            );
            let o = crate::proc::run(
                std::process::Command::new("yosys")
                    .args(["-q", "-p", &script])
                    .current_dir(dir),
                "yosys",
                crate::proc::Limit::build(),
                None,
            )?;
            anyhow::ensure!(
                o.status.success(),
                "yosys failed on {} ({variant}):\n{}",
                u.name,
                o.stderr
            );
            let dump = std::fs::read_to_string(dir.join("cells.txt"))?;
            drop(tmp);
            let cells = parse_cells(&dump);
            let p = |c: &std::collections::BTreeMap<String, i64>, k: &str| {
                c.get(k).copied().unwrap_or(0)
            };
            let mut netlist_mul: Vec<String> = cells
                .iter()
                .filter(|(t, _)| t == "$mul")
                .map(|(_, c)| {
                    let (a, b) = (narrow::<u32, _>(p(c, "A_WIDTH")), narrow::<u32, _>(p(c, "B_WIDTH")));
                    fxshade_model::rtl::MulHw {
                        a_width: a,
                        b_width: b,
                        signed: p(c, "A_SIGNED") == 1 && p(c, "B_SIGNED") == 1,
                        a_zext: false,
                        b_zext: false,
                        y_width: 0,
                    }
                    .to_string()
                })
                .collect();
            netlist_mul.sort();
            let mut netlist_add: Vec<String> = cells
                .iter()
                .filter(|(t, _)| t == "$add" || t == "$sub")
                .map(|(_, c)| {
                    format!(
                        "{} + {} → {}",
                        p(c, "A_WIDTH"),
                        p(c, "B_WIDTH"),
                        p(c, "Y_WIDTH")
                    )
                })
                .collect();
            netlist_add.sort();
            let netlist_compare = cells
                .iter()
                .filter(|(t, _)| ["$gt", "$lt", "$ge", "$le"].contains(&t.as_str()))
                .count() as u64;
            let h = &e.hardware;
            let mut model_mul: Vec<String> = h.muls.iter().map(|m| m.to_string()).collect();
            model_mul.sort();
            // An add/subtracter is written as an add and a subtract.
            let mut model_add: Vec<String> = h
                .adders
                .iter()
                .chain(&h.incrementers)
                .chain(h.add_subs.iter().flat_map(|w| [w, w]))
                .map(|w| format!("{w} + {w} → {w}"))
                .collect();
            model_add.sort();
            let agree = model_mul == netlist_mul
                && model_add == netlist_add
                && h.compares == netlist_compare;
            Ok(NetlistCheck {
                unit: u.name,
                variant: variant.to_string(),
                model_mul,
                netlist_mul,
                model_add,
                netlist_add,
                model_compare: h.compares,
                netlist_compare,
                agree,
            })
        })
        .collect()
}

/// The netlist checks as a table.
pub fn netlist_table(checks: &[NetlistCheck]) -> Table {
    let mut t = Table::new([
        "unit",
        "variant",
        "multipliers (trace)",
        "$mul (netlist)",
        "adders A + B → Y (trace)",
        "$add/$sub A + B → Y (netlist)",
        "compare (trace / netlist)",
        "agree",
    ])
    .titled("Emitted RTL read back by Yosys, beside the traced datapath");
    let join = |v: &[String]| v.join(", ");
    for c in checks {
        t.row([
            c.unit.to_string(),
            c.variant.clone(),
            join(&c.model_mul),
            join(&c.netlist_mul),
            c.model_add.join(", "),
            c.netlist_add.join(", "),
            format!("{} / {}", c.model_compare, c.netlist_compare),
            if c.agree { "yes" } else { "NO" }.to_string(),
        ]);
    }
    t
}

/// All reports for a configuration.
pub fn reports(cfg: &fxshade_model::Config) -> Vec<OpReport> {
    UNITS.iter().flat_map(|u| u.ops(cfg)).collect()
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
        "multipliers (count× formats → as built)",
        "paper claims",
    ])
    .titled("Operation counts, measured by running each datapath in the counting context");
    for r in reports {
        let c = &r.counts;
        let shapes = c
            .mul_formats
            .iter()
            .map(|m| format!("{}× {} × {} → {}", m.count, m.a, m.b, m.hardware))
            .collect::<Vec<_>>()
            .join("; ");
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
        "stage id",
        "exact input",
        "bits",
        "output",
        "dropped bits",
        "round",
        "overflow",
        "in RTL",
    ])
    .titled(
        "Quantization points, in datapath order (from the counting run); \
         `dead`: no output reads it, so the RTL has no such register and no flag",
    );
    for r in reports {
        for p in &r.quant_points {
            t.row([
                r.unit.to_string(),
                r.variant.to_string(),
                p.id.clone(),
                p.input.clone(),
                p.input_width.to_string(),
                p.output.to_string(),
                p.dropped_bits.to_string(),
                p.round.name().to_string(),
                p.overflow.name().to_string(),
                match p.live {
                    Some(true) => "yes",
                    Some(false) => "dead",
                    None => "-",
                }
                .to_string(),
            ]);
        }
    }
    t
}

/// Run it.
pub fn run(a: &OpsArgs) -> anyhow::Result<()> {
    let cfg = a.cfg.resolve()?;
    let r = reports(&cfg);
    if !a.rtl {
        return emit(a.out, &[table(&r)], &serde_json::to_value(&r)?);
    }
    let checks = netlist_checks(&cfg)?;
    emit(
        a.out,
        &[table(&r), netlist_table(&checks)],
        &serde_json::json!({ "model": r, "rtl": checks }),
    )?;
    let bad: Vec<String> = checks
        .iter()
        .filter(|c| !c.agree)
        .map(|c| format!("{} ({})", c.unit, c.variant))
        .collect();
    anyhow::ensure!(
        bad.is_empty(),
        "the RTL and the model are not the same datapath: {}",
        bad.join(", ")
    );
    Ok(())
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
