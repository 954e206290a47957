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
    /// Also synthesize each RTL unit and variant with Yosys to word-level
    /// cells and check its multipliers, adders and comparators against the
    /// counting context (exit status 1 on any disagreement).
    #[arg(long)]
    rtl: bool,
    #[command(flatten)]
    out: OutputArgs,
}

/// Word-level cells of one RTL variant, beside the model's counts.
#[derive(Debug, Clone, serde::Serialize)]
pub struct NetlistCheck {
    /// Unit.
    pub unit: &'static str,
    /// Variant.
    pub variant: String,
    /// `$mul` cells.
    pub netlist_mul: u64,
    /// `$add` and `$sub` cells.
    pub netlist_add: u64,
    /// `$lt`, `$gt`, `$le` and `$ge` cells.
    pub netlist_compare: u64,
    /// Cell types by result width, e.g. `$mul_34: 3`.
    pub netlist_cells: std::collections::BTreeMap<String, u64>,
    /// Model multiplications.
    pub model_mul: u64,
    /// Model additions plus rounding incrementers.
    pub model_add: u64,
    /// Model comparisons plus two range comparators per quantization.
    pub model_compare: u64,
    /// Table (ROM) instances in the netlist.
    pub netlist_table_read: u64,
    /// Model table reads.
    pub model_table_read: u64,
    /// Whether all four agree.
    pub agree: bool,
}

/// Synthesize every RTL unit and variant with Yosys and compare.
pub fn netlist_checks(cfg: &fxshade_model::Config) -> anyhow::Result<Vec<NetlistCheck>> {
    use anyhow::Context;
    crate::rtl_flow::require_tool("yosys", "yosys")?;
    let mut out = Vec::new();
    for u in crate::rtl_flow::RTL_UNITS {
        for &(variant, set) in u.variants {
            let mut c = cfg.clone();
            c.apply_override(set)?;
            let params = (u.params)(&c)?;
            let dir = std::env::temp_dir().join(format!(
                "fxshade-yosys-{}-{}-{variant}",
                std::process::id(),
                u.name
            ));
            let _ = std::fs::remove_dir_all(&dir);
            let src = crate::rtl_flow::write_sources(u, &params, &dir)?;
            // Table modules are read as black boxes (`read_verilog -lib`): their
            // instances are counted as table reads, their addressing is not
            // datapath arithmetic.
            let is_box = |rel: &str| u.blackbox.iter().any(|b| rel == format!("{b}.v"));
            // The black box is the real module's header (parameters and
            // ports, up to the end of its port list) with an empty body.
            let mut lib = String::new();
            for (rel, text) in u.sources[..u.design_files]
                .iter()
                .filter(|(rel, _)| is_box(rel))
            {
                let start = text.find("module ").context("a module")?;
                let end = start + text[start..].find(");").context("a port list")? + 2;
                let stub = src.join(format!("{rel}.box.v"));
                std::fs::write(
                    &stub,
                    format!("(* blackbox *)\n{}\nendmodule\n", &text[start..end]),
                )?;
                lib += &format!("read_verilog {}; ", stub.display());
            }
            let files: Vec<String> = u.sources[..u.design_files]
                .iter()
                .filter(|(rel, _)| !is_box(rel))
                .map(|(rel, _)| src.join(rel).display().to_string())
                .collect();
            let script = format!(
                "{lib}read_verilog -I{} {}; hierarchy -top {}; proc; flatten; opt_expr; opt_clean; tee -o {} stat; tee -o {} stat -width",
                src.display(),
                files.join(" "),
                u.top,
                dir.join("stat.txt").display(),
                dir.join("width.txt").display()
            );
            let o = std::process::Command::new("yosys")
                .args(["-q", "-p", &script])
                .output()
                .context("cannot run yosys")?;
            anyhow::ensure!(
                o.status.success(),
                "yosys failed on {} ({variant}):\n{}",
                u.name,
                String::from_utf8_lossy(&o.stderr)
            );
            let parse = |f: &str| -> anyhow::Result<std::collections::BTreeMap<String, u64>> {
                let t = std::fs::read_to_string(dir.join(f))?;
                Ok(t.lines()
                    .filter_map(|l| {
                        let mut w = l.split_whitespace();
                        let (name, n) = (w.next()?, w.next()?);
                        if !name.starts_with('$') && !u.blackbox.contains(&name) {
                            return None;
                        }
                        Some((name.to_string(), n.parse().ok()?))
                    })
                    .collect())
            };
            let stat = parse("stat.txt")?;
            let widths = parse("width.txt")?;
            let _ = std::fs::remove_dir_all(&dir);
            let n = |k: &str| stat.get(k).copied().unwrap_or(0);
            let model = (u.count)(&c)?;
            let mc = model.counts();
            let (netlist_mul, netlist_add, netlist_compare) = (
                n("$mul"),
                n("$add") + n("$sub"),
                n("$lt") + n("$gt") + n("$le") + n("$ge"),
            );
            let flagged = model
                .quant_points()
                .iter()
                .filter(|p| !u.unflagged.contains(&p.stage))
                .filter(|p| {
                    u.flags_overflow || p.overflow != fxshade_model::quantize::Overflow::Wrap
                })
                .count() as u64;
            let (model_mul, model_add, model_compare) =
                (mc.mul, mc.add + mc.round, mc.compare + 2 * flagged);
            let netlist_tables: u64 = u
                .blackbox
                .iter()
                .map(|b| stat.get(*b).copied().unwrap_or(0))
                .sum();
            out.push(NetlistCheck {
                unit: u.name,
                variant: variant.to_string(),
                netlist_mul,
                netlist_add,
                netlist_compare,
                netlist_cells: widths
                    .into_iter()
                    .filter(|(k, _)| {
                        ["$mul", "$add", "$sub", "$lt", "$gt"]
                            .iter()
                            .any(|p| k.starts_with(p))
                    })
                    .collect(),
                model_mul,
                model_add,
                model_compare,
                netlist_table_read: netlist_tables,
                model_table_read: mc.table_read,
                agree: (netlist_mul, netlist_add, netlist_compare, netlist_tables)
                    == (model_mul, model_add, model_compare, mc.table_read),
            });
        }
    }
    Ok(out)
}

/// The netlist checks as a table.
pub fn netlist_table(checks: &[NetlistCheck]) -> Table {
    let mut t = Table::new([
        "unit",
        "variant",
        "model mul",
        "netlist $mul",
        "model add+round",
        "netlist $add/$sub",
        "model 2×quantize",
        "netlist $lt/$gt",
        "agree",
        "netlist cells (type_width: count)",
    ])
    .titled("RTL netlists (Yosys, word-level cells) beside the counting context");
    for c in checks {
        t.row([
            c.unit.to_string(),
            c.variant.clone(),
            c.model_mul.to_string(),
            c.netlist_mul.to_string(),
            c.model_add.to_string(),
            c.netlist_add.to_string(),
            c.model_compare.to_string(),
            c.netlist_compare.to_string(),
            if c.agree { "yes" } else { "NO" }.to_string(),
            c.netlist_cells
                .iter()
                .map(|(k, v)| format!("{k}: {v}"))
                .collect::<Vec<_>>()
                .join(", "),
        ]);
    }
    t
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
