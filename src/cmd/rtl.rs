//! `fxshade rtl <unit>`: emit a unit's Verilog (and its testbench) from its
//! traced datapath for a configuration.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use fxshade_model::files;
use fxshade_model::rtl::units::{self, RtlUnit};
use fxshade_model::rtl::Emitted;

use super::{ConfigArgs, PipelineArgs};
use crate::output::{emit, OutputArgs, Table};
use crate::rtl_flow::configs_all;

/// `fxshade rtl`
#[derive(Args, Debug)]
pub struct RtlArgs {
    /// The unit; `all`: every unit, and the pipeline top of every path
    /// (what `rtl/` holds for the default configuration); `list`: the units
    /// with RTL and their variants (nothing is written).
    #[arg(value_parser = super::unit_arg(&["all", "list"]))]
    unit: String,
    #[command(flatten)]
    cfg: ConfigArgs,
    #[command(flatten)]
    pipe: PipelineArgs,
    /// Output directory: `<module>.v` (and with `--testbench`
    /// `<module>_tb.v`) are written into it, each file replaced atomically;
    /// nothing else in it is touched.
    /// (Required except with `list`.)
    #[arg(long, short = 'o', value_name = "DIR")]
    out: Option<PathBuf>,
    /// Also write each module's self-checking testbench (`<module>_tb.v`,
    /// the one `fxshade vectors` and `rtl-check` use).
    #[arg(long)]
    testbench: bool,
    /// Also write each module's SystemVerilog DPI-C package
    /// (`<module>_dpi_pkg.sv`: the model through the C ABI library
    /// `libfxshade_capi`, typed by the module's ports) and a scoreboard
    /// testbench driving the module against it (`<module>_dpi_tb.sv`).
    #[arg(long)]
    dpi: bool,
    /// Also write each module behind an interface wrapper:
    /// `<module>_axis.v` (AXI4-Stream; with `--testbench` also
    /// `<module>_axis_tb.v`, the vector testbench driving the wrapper).
    #[arg(long, value_enum, value_name = "KIND")]
    wrap: Option<super::Wrap>,
    /// Also write `<module>.core`, a FuseSoC CAPI2 core of the module
    /// (`fxshade:<unit>:<variant>_<config hash>:<fxshade version>`, targets `default` and
    /// `lint`); `fxshade vectors --core` writes one with the testbench, the
    /// vectors and a `sim` target.
    #[arg(long)]
    core: bool,
    /// Also write each module's datasheet: `<module>_datasheet.md` (ports
    /// and formats, handshakes, reset, latency and throughput, and a timing
    /// diagram simulated on the module with Icarus), `<module>_wave.json`
    /// (the diagram as WaveDrom) and the clock constraint for `rtl.target`
    /// at `rtl.clock_ns` (`<module>.lpf` on ECP5, `.pcf` on iCE40, `.sdc`
    /// otherwise).
    #[arg(long)]
    datasheet: bool,
    /// With `--datasheet`: the targets of its resource table, each a Yosys
    /// synthesis of the module without place and route (comma-separated
    /// names as `synth --target` takes them; default: the configuration's
    /// `rtl.target`; `none`: no table).
    #[arg(long, value_name = "TARGETS", requires = "datasheet")]
    resources: Option<String>,
    /// Replace files in `--out` that fxshade did not write or that were
    /// edited since (refused otherwise, naming the file).
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    fmt: OutputArgs,
}

/// The emitted modules `fxshade rtl all` writes for a configuration: every
/// unit, and the pipeline top of every variant (smooth, mapped with CORDIC
/// angles, mapped with interpolated angles).
pub fn emit_all(cfg: &fxshade_model::Config) -> anyhow::Result<Vec<(&'static RtlUnit, Emitted)>> {
    configs_all(cfg)?
        .into_iter()
        .map(|(u, c)| Ok((u, units::emit_unit(u, &c)?.1)))
        .collect()
}

/// `3× a, 1× b` for a list of shapes.
fn grouped(items: impl Iterator<Item = String>) -> String {
    let mut m: std::collections::BTreeMap<String, usize> = Default::default();
    for i in items {
        *m.entry(i).or_default() += 1;
    }
    m.iter()
        .map(|(k, n)| format!("{n}× {k}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// `fxshade rtl list`: the registry's units with RTL and their variants.
fn list(a: &RtlArgs) -> anyhow::Result<()> {
    let mut t =
        Table::new(["unit", "variants (override)", "what"]).titled("Units with generated RTL");
    let mut json = Vec::new();
    for u in units::all() {
        t.row([
            u.name.to_string(),
            u.variants
                .iter()
                .map(|(n, s)| format!("{n} ({s})"))
                .collect::<Vec<_>>()
                .join(", "),
            u.doc.to_string(),
        ]);
        json.push(serde_json::json!({
            "unit": u.name,
            "doc": u.doc,
            "variants": u.variants.iter().map(|(n, s)| serde_json::json!({"name": n, "set": s})).collect::<Vec<_>>(),
        }));
    }
    emit(a.fmt, &[t], &serde_json::Value::Array(json))
}

/// The datasheet files of one module: the Markdown, the WaveDrom JSON
/// and the constraints, the diagram simulated on Icarus.
fn datasheet(
    u: &RtlUnit,
    c: &fxshade_model::Config,
    e: &Emitted,
    resources: Option<&str>,
) -> anyhow::Result<Vec<(String, String)>> {
    use fxshade_model::rtl::datasheet as ds;
    use fxshade_model::rtl::timing::Target;
    crate::rtl_flow::require_tool("iverilog", "iverilog")?;
    crate::rtl_flow::require_tool("vvp", "iverilog")?;
    let d = units::emit_unit(u, c)?.0;
    let dir = tempfile::Builder::new()
        .prefix("fxshade-datasheet-")
        .tempdir()
        .context("cannot create a temporary directory")?;
    let m = &e.module;
    std::fs::write(dir.path().join(format!("{m}.v")), &e.verilog)?;
    std::fs::write(dir.path().join("tb.v"), ds::stimulus(e))?;
    let mut ic = std::process::Command::new("iverilog");
    ic.current_dir(dir.path())
        .args(["-g2012", "-o", "sim", "tb.v"])
        .arg(format!("{m}.v"));
    crate::rtl_flow::run_tool(&mut ic, "iverilog")?;
    let mut vc = std::process::Command::new("vvp");
    vc.current_dir(dir.path()).args(["-n", "sim"]);
    let out = crate::rtl_flow::run_tool(&mut vc, "vvp")?;
    let wave = ds::Wave::parse(ds::signals(e), &out).with_context(|| {
        format!(
            "{m}: the datasheet's simulation printed no wave:\n{}",
            out.lines().take(12).collect::<Vec<_>>().join("\n")
        )
    })?;
    let rtl: fxshade_model::rtl::section::RtlConfig = c.section();
    let (target, clock) = (rtl.target, rtl.clock_ns);
    let (ext, text) = ds::constraints(m, target, clock);
    use super::synth::synth_target;
    let targets: Vec<Target> = match resources {
        Some("none") => Vec::new(),
        // The configured target (a process without an open flow: Yosys's
        // generic LUT mapping).
        None => vec![synth_target(target.name())
            .or_else(|| synth_target("generic"))
            .context("no generic synthesis flow in the registry")?],
        Some(list) => list
            .split(',')
            .map(|n| {
                synth_target(n.trim()).ok_or_else(|| {
                    let names: Vec<&str> = Target::synthesized().iter().map(|t| t.name()).collect();
                    anyhow::anyhow!(
                        "--resources: unknown target `{}` (one of {}, or none)",
                        n.trim(),
                        names.join(", ")
                    )
                })
            })
            .collect::<anyhow::Result<_>>()?,
    };
    let mut rows = Vec::new();
    for t in targets {
        let flow = super::synth::Flow {
            seeds: 1,
            freq: 1000.0 / clock,
            pnr: false,
            dsp_pack: true,
            device: None,
        };
        let (r, _) = super::synth::cached(u.name, c, t, flow, None, true, &|_| {})
            .with_context(|| format!("{m}: synthesis for the resource table ({})", t.name()))?;
        rows.push(ds::Resources {
            target: r.target.clone(),
            device: r.device.clone(),
            luts: r.lut,
            carry: r.carry,
            lut_ram: r.lut_ram,
            ff: r.ff.saturating_sub(r.harness_ff),
            dsp: r.dsp,
            bram: r.bram,
        });
    }
    Ok(vec![
        (
            format!("{m}_datasheet.md"),
            ds::markdown(
                e,
                u.name,
                &d.variant,
                d.handshake,
                target,
                clock,
                &wave,
                &rows,
            ),
        ),
        (format!("{m}_wave.json"), wave.wavedrom()),
        (format!("{m}.{ext}"), text),
    ])
}

/// Run it.
pub fn run(a: &RtlArgs) -> anyhow::Result<()> {
    if a.unit == "list" {
        return list(a);
    }
    let Some(out) = a.out.as_ref() else {
        anyhow::bail!("--out DIR is required: the directory to write the Verilog into");
    };
    let cfg = a.cfg.resolve_with(&a.pipe.overrides())?;
    let start = std::time::Instant::now();
    let configs = if a.unit == "all" {
        configs_all(&cfg)?
    } else {
        vec![(crate::rtl_flow::unit(&a.unit)?, cfg.clone())]
    };
    let mut emitted: Vec<(&'static RtlUnit, Emitted)> = Vec::new();
    let mut dpi = Vec::new();
    for (u, c) in &configs {
        if a.dpi {
            let m = fxshade_model::rtl::unit_model::UnitModel::of(u, c)?;
            let pkg = fxshade_model::rtl::dpi::package(&m)?;
            let tb = fxshade_model::rtl::dpi::scoreboard(&m)?;
            dpi.push((m.module().to_string(), pkg, tb));
            emitted.push((*u, m.emitted));
        } else {
            emitted.push((*u, units::emit_unit(u, c)?.1));
        }
    }
    let secs = start.elapsed().as_secs_f64();
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut t = Table::new([
        "module",
        "latency",
        "multipliers",
        "adders (result bits)",
        "add/subtracters (bits)",
        "rounding incrementers (bits)",
        "table reads",
        "ROM bits",
        "flip-flops",
        "files",
    ])
    .titled(format!(
        "Verilog emitted from the traced datapaths, configuration {} ({secs:.2} s)",
        cfg.describe()
    ));
    let mut json = Vec::new();
    // Every file is checked before any is written: a file of the user's
    // (or one edited since fxshade wrote it) is never replaced unless forced.
    let mut record = files::FilesRecord::open(out);
    let mut writes: Vec<(String, &str)> = Vec::new();
    for (_, e) in &emitted {
        writes.push((format!("{}.v", e.module), &e.verilog));
        if a.testbench {
            writes.push((format!("{}_tb.v", e.module), &e.testbench));
        }
    }
    for (module, pkg, tb) in &dpi {
        writes.push((format!("{module}_dpi_pkg.sv"), pkg));
        writes.push((format!("{module}_dpi_tb.sv"), tb));
    }
    let wrapped: Vec<(String, String, String)> = match a.wrap {
        Some(super::Wrap::Axis) => emitted
            .iter()
            .map(|(u, e)| {
                (
                    e.module.clone(),
                    fxshade_model::rtl::axis::wrapper(u.name, e),
                    fxshade_model::rtl::axis::testbench(e),
                )
            })
            .collect(),
        None => Vec::new(),
    };
    let cores: Vec<(String, String)> = if a.core {
        configs
            .iter()
            .zip(&emitted)
            .map(|((u, c), (_, e))| {
                let design = units::emit_unit(u, c)?.0;
                Ok((
                    format!("{}.core", e.module),
                    fxshade_model::rtl::core::capi2(
                        u.name,
                        &design.variant,
                        &e.module,
                        design.config_hash(),
                        None,
                    ),
                ))
            })
            .collect::<anyhow::Result<_>>()?
    } else {
        Vec::new()
    };
    for (name, text) in &cores {
        writes.push((name.clone(), text));
    }
    let sheets: Vec<(String, String)> = if a.datasheet {
        let mut v = Vec::new();
        for ((u, c), (_, e)) in configs.iter().zip(&emitted) {
            v.extend(datasheet(u, c, e, a.resources.as_deref())?);
        }
        v
    } else {
        Vec::new()
    };
    for (name, text) in &sheets {
        writes.push((name.clone(), text));
    }
    for (module, w, tb) in &wrapped {
        writes.push((format!("{module}_axis.v"), w));
        if a.testbench {
            writes.push((format!("{module}_axis_tb.v"), tb));
        }
    }
    if !a.force {
        for (name, text) in &writes {
            if let Some(why) = record.blocks(name, text.as_bytes()) {
                return Err(crate::output::UsageError(format!(
                    "{why}; nothing was written (write elsewhere, or pass --force to replace it)"
                ))
                .into());
            }
        }
    }
    for (name, text) in &writes {
        record
            .write(name, text.as_bytes())
            .with_context(|| format!("cannot write {}", out.join(name).display()))?;
    }
    record
        .save()
        .with_context(|| format!("cannot write {}", out.join(files::FILES_RECORD).display()))?;
    for (_, e) in &emitted {
        let mut files = vec![format!("{}.v", e.module)];
        if a.testbench {
            files.push(format!("{}_tb.v", e.module));
        }
        if a.dpi {
            files.push(format!("{}_dpi_pkg.sv", e.module));
            files.push(format!("{}_dpi_tb.sv", e.module));
        }
        if a.core {
            files.push(format!("{}.core", e.module));
        }
        if a.wrap.is_some() {
            files.push(format!("{}_axis.v", e.module));
            if a.testbench {
                files.push(format!("{}_axis_tb.v", e.module));
            }
        }
        let h = &e.hardware;
        t.row([
            e.module.clone(),
            e.latency.to_string(),
            grouped(h.muls.iter().map(|m| m.to_string())),
            grouped(h.adders.iter().map(|w| format!("{w}"))),
            grouped(h.add_subs.iter().map(|w| format!("{w}"))),
            grouped(h.incrementers.iter().map(|w| format!("{w}"))),
            h.table_reads.to_string(),
            h.rom_bits.to_string(),
            h.flops.to_string(),
            files.join(" "),
        ]);
        json.push(serde_json::json!({
            "module": e.module,
            "inputs": e.inputs.len(),
            "outputs": e.outputs.iter().filter(|f| f.name != "ovf" || e.flags.is_empty()).count(),
            "axis": a.wrap.map(|_| fxshade_model::rtl::axis::streams(e)),
            "latency": e.latency,
            "flags": e.flags,
            "hardware": h,
            "setup_ports": e.setup,
            "files": files,
            "dir": out,
        }));
    }
    emit(a.fmt, &[t], &serde_json::Value::Array(json))
}
