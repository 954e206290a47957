//! `fxshade synth`: synthesis (Yosys) and, where an open flow exists, place
//! and route (nextpnr) of a unit's generated RTL for a target, in a harness
//! that registers every port, so every timed path runs from a register to
//! a register and none starts or ends at a pin.
//!
//! The harness shifts the input vector in through one pin (a shift
//! register as wide as the unit's inputs, plus one bit for each set-up
//! port's valid), registers valid and ready both ways, registers the
//! outputs and folds them into one pin by XOR, so the pin count stays at
//! seven whatever the unit's width and no logic can be optimized away.
//! Every valid comes from a register of its own: a set-up port whose valid
//! were the item's could never load (its ready is low while the item's
//! valid is high), and synthesis would delete its registers and the
//! load-enable network with them, leaving their paths untimed. The unit
//! stays a module of its own (`keep_hierarchy`), so synthesis optimizes
//! nothing across its ports, as in a design that integrates it, and the
//! module placed is the one `--netlist` writes for co-simulation.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use fxshade_model::rtl::Emitted;

use super::ConfigArgs;

pub mod close;
use crate::output::{emit, OutputArgs, Table, UsageError};

/// A synthesis target: a technology family of the registry
/// (`fxshade_model::rtl::targets`) with a synthesis flow.
pub use fxshade_model::rtl::targets::Target;

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

/// The family called `name` if it has a synthesis flow.
pub fn synth_target(name: &str) -> Option<Target> {
    Target::from_name(name).filter(|t| t.synthesis().is_some())
}

/// The family as the resource estimate and the delay model describe it:
/// a family with a delay model (not the generic LUT mapping, which is no
/// device).
pub fn timing(target: Target) -> Option<Target> {
    target.delay().map(|_| target)
}

/// Whether timing closure can run on `t`: a delay model to pipeline with
/// and a place and route to measure with.
pub fn closes(t: Target) -> bool {
    t.delay().is_some() && t.place_route().is_ok()
}

/// The names of the synthesis targets for which `keep` holds, for an
/// error message (`ice40-hx8k, ice40-up5k or ecp5`).
pub fn synth_targets_where(keep: impl Fn(Target) -> bool) -> String {
    let names: Vec<&str> = Target::synthesized()
        .iter()
        .filter(|t| keep(**t))
        .map(|t| t.name())
        .collect();
    match names.split_last() {
        Some((last, [])) => (*last).to_string(),
        Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
        None => "none".into(),
    }
}

/// The placer's packaged alternative when only that is installed (the
/// program a run uses and whose version a cache key names).
fn installed_alternative(p: &fxshade_model::rtl::targets::PlaceRoute) -> Option<&'static str> {
    p.alternative
        .filter(|a| !crate::proc::has(p.tool, "--version") && crate::proc::has(a, "--version"))
}

/// The device a family's synthesis names in reports.
pub fn device_name(target: Target) -> &'static str {
    target.synthesis().map_or(target.name(), |s| s.device)
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
    /// Measure again even when a cached result exists (the new result
    /// replaces it).
    #[arg(long)]
    no_cache: bool,
    #[command(flatten)]
    out: OutputArgs,
}

/// What synthesis and place and route measured.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SynthResult {
    /// Unit.
    pub unit: String,
    /// Module.
    pub module: String,
    /// Target name.
    pub target: String,
    /// Device.
    pub device: String,
    /// Look-up tables.
    pub lut: u64,
    /// Flip-flops (the harness's own registers included: its input shift
    /// register, the output register and five handshake and pin bits).
    pub ff: u64,
    /// Of those, the harness's: the flip-flops of its own module in
    /// Yosys's statistics (the unit is a module of its own).
    pub harness_ff: u64,
    /// DSP blocks.
    pub dsp: u64,
    /// DSP blocks as [`fxshade_model::rtl::estimate`] predicts them from
    /// the emitted module alone, without synthesis (None: generic).
    #[serde(default)]
    pub dsp_estimate: Option<u64>,
    /// Block RAMs as [`fxshade_model::rtl::estimate`] predicts them from
    /// the emitted module's ROMs (None: generic).
    #[serde(default)]
    pub bram_estimate: Option<u64>,
    /// LUT cells as [`fxshade_model::rtl::estimate::AreaModel`] predicts
    /// them from the emitted module's arithmetic (None: generic), to set
    /// beside `lut`.
    #[serde(default)]
    pub lut_estimate: Option<u64>,
    /// The unit's flip-flops after synthesis as the area model predicts
    /// them, to set beside `ff − harness_ff`.
    #[serde(default)]
    pub ff_estimate: Option<u64>,
    /// The area model's terms of the emitted module (what a refit of the
    /// model reads: `fxshade synth calibrate --area`).
    #[serde(default)]
    pub area_terms: Option<fxshade_model::rtl::estimate::AreaTerms>,
    /// Block RAMs.
    pub bram: u64,
    /// Carry cells (SB_CARRY, CCU2C, CARRY4).
    pub carry: u64,
    /// Logic cells of the placed design as the device counts them
    /// ([`logic_cells`]: ECP5 TRELLIS_COMB, CCU2C counted twice; iCE40
    /// ICESTORM_LC), the median over the seeds; None without place and
    /// route. `lut` counts LUT4 cells only.
    #[serde(default)]
    pub logic_cells: Option<u64>,
    /// LUT-RAM cells (ECP5 TRELLIS_DPR16X4), apart from the logic.
    #[serde(default)]
    pub lut_ram: u64,
    /// Every cell type and its count.
    pub cells: Vec<(String, u64)>,
    /// How much of the part the design uses: the placer's report of the
    /// median seed (resources in use), or synthesis's counts against the
    /// part's capacity where no placer runs ([`crate::device`]); empty
    /// without either.
    #[serde(default)]
    pub utilisation: Vec<crate::device::Use>,
    /// Median Fmax over the seeds, MHz (None: no place and route).
    pub fmax_mhz: Option<f64>,
    /// Target pipelining: the Fmax the delay model predicts (its slowest
    /// stage, register overhead included), MHz, to set beside `fmax_mhz`;
    /// None for the compact pipeline.
    #[serde(default)]
    pub predicted_mhz: Option<f64>,
    /// Fmax per seed.
    pub fmax_seeds: Vec<f64>,
    /// Why there is no Fmax, when there is none.
    pub fmax_note: Option<String>,
    /// Cycles from an input transfer to its output (the unit's; the harness
    /// adds two).
    pub latency: u32,
    /// Results per second at Fmax: one vector per clock, millions.
    pub throughput_mps: Option<f64>,
    /// Seconds spent in Yosys.
    pub synth_seconds: f64,
    /// Seconds spent in nextpnr (all seeds).
    pub pnr_seconds: f64,
    /// ECP5: the registers moved into the MULT18X18D blocks after Yosys
    /// (counts above are of the netlist after the move).
    #[serde(default)]
    pub dsp_packed: Option<crate::dsp_pack::PackStats>,
    /// The flip-flops by role ([`crate::ff_roles`]), from the netlist
    /// placed (iCE40, ECP5; after the move into DSP blocks).
    #[serde(default)]
    pub ff_roles: Vec<(String, u64)>,
    /// Tool versions.
    pub tools: Vec<String>,
    /// The median seed's critical path, from nextpnr's JSON report, with
    /// the emitted signals it runs through (None without place and route).
    #[serde(default)]
    pub critical_path: Option<crate::critical_path::CriticalPath>,
    /// The median Fmax against the clock asked for (`--freq`, or
    /// `1000 / --clock-ns`); None without place and route.
    #[serde(default, skip_deserializing)]
    pub verdict: Option<crate::critical_path::Verdict>,
}

fn tool_version(tool: &str, arg: &str) -> Option<String> {
    crate::proc::version(tool, arg)
}

fn require(tool: &str, how: &str) -> anyhow::Result<()> {
    crate::proc::require(tool, "--version", how)
}

/// The harness around `e`'s module (see the module docs).
pub fn harness(e: &Emitted) -> String {
    let in_w: u32 = e.inputs.iter().map(|f| f.format.width()).sum();
    let out_w: u32 = e.outputs.iter().map(|f| f.format.width()).sum();
    let mut conns = vec![
        ".clk_i(clk_i)".to_string(),
        ".rst_ni(rst_ni)".into(),
        ".valid_i(valid_q)".into(),
        ".ready_o(ready_d)".into(),
    ];
    // Set-up ports load with the item's valid; their readies fold into
    // ready_o.
    let mut readies = vec!["ready_d".to_string()];
    let mut wires = String::new();
    for (k, g) in e.setup.iter().enumerate() {
        // Its own register: the bit after the inputs in the shift chain.
        conns.push(format!(".{}_valid_i(in_q[{}])", g.name, in_w + k as u32));
        conns.push(format!(".{n}_ready_o({n}_ready_d)", n = g.name));
        wires += &format!("  wire {}_ready_d;\n", g.name);
        readies.push(format!("{}_ready_d", g.name));
    }
    let mut at = 0;
    for f in &e.inputs {
        let w = f.format.width();
        conns.push(format!(".{}_i(in_q[{}:{}])", f.name, at + w - 1, at));
        at += w;
    }
    conns.push(".valid_o(valid_d)".into());
    conns.push(".ready_i(ready_q)".into());
    let mut at = 0;
    for f in &e.outputs {
        let w = f.format.width();
        conns.push(format!(".{}_o(out_d[{}:{}])", f.name, at + w - 1, at));
        at += w;
    }
    let chain_w = in_w + e.setup.len() as u32;
    let shift = if chain_w >= 2 {
        format!("{{in_q[{}:0], din_i}}", chain_w - 2)
    } else {
        "din_i".to_string()
    };
    format!(
        "// Synthesis harness for `{m}` (generated by fxshade synth): every port\n\
         // registered, so each timed path runs from a register to a register.\n\
         // Inputs (and each set-up port's valid) are shifted in through din_i;\n\
         // outputs fold into dout_o.\n\
         `default_nettype none\n\n\
         module fxs_harness (\n  input  wire clk_i,\n  input  wire rst_ni,\n  input  wire din_i,\n  \
         input  wire valid_i,\n  input  wire ready_i,\n  output reg  dout_o,\n  output reg  valid_o,\n  \
         output reg  ready_o\n);\n\
         \x20 reg  [{iw1}:0] in_q;\n  reg  valid_q, ready_q;\n  wire [{ow1}:0] out_d;\n  wire valid_d, ready_d;\n{wires}  \
         reg  [{ow1}:0] out_q;\n\n\
         \x20 always @(posedge clk_i) begin\n    in_q <= {shift};\n    valid_q <= valid_i;\n    ready_q <= ready_i;\n    \
         out_q <= out_d;\n    dout_o <= ^out_q;\n    valid_o <= valid_d;\n    ready_o <= {ready};\n  end\n\n\
         \x20 {m} dut (\n    {conns}\n  );\nendmodule\n",
        m = e.module,
        iw1 = chain_w.max(1) - 1,
        ow1 = out_w - 1,
        conns = conns.join(",\n    "),
        ready = readies.join(" & "),
    )
}

/// Count cells of a Yosys `stat` report: the cell lines of the top
/// module's (flattened) statistics.
fn parse_stat(text: &str) -> Vec<(String, u64)> {
    let mut cells = Vec::new();
    let mut on = false;
    for l in text.lines() {
        let t = l.trim();
        if t.starts_with("Number of cells:") {
            on = true;
            cells.clear();
            continue;
        }
        if on {
            let mut it = t.split_whitespace();
            match (it.next(), it.next(), it.next()) {
                (Some(name), Some(n), None) => match n.parse::<u64>() {
                    Ok(n) => cells.push((name.to_string(), n)),
                    Err(_) => on = false,
                },
                _ => on = false,
            }
        }
    }
    cells
}

/// The cell lines of module `module`'s own block of a Yosys `stat`
/// report (`=== module ===`): its cells, an instance of a submodule
/// counted as one cell of that module's name.
fn parse_stat_module(text: &str, module: &str) -> Vec<(String, u64)> {
    let head = format!("=== {module} ===");
    let mut block = String::new();
    let mut on = false;
    for l in text.lines() {
        let t = l.trim();
        if t.starts_with("=== ") {
            on = t == head;
            continue;
        }
        if on {
            block.push_str(l);
            block.push('\n');
        }
    }
    parse_stat(&block)
}

fn e_module(unit: &str) -> String {
    format!("`{unit}`")
}

/// A nextpnr utilisation report: `(resource, used, available)` per line
/// `Info: \t  TRELLIS_COMB:  4521/83640     5%`.
pub fn utilisation(log: &str) -> Vec<(String, u64, u64)> {
    log.lines()
        .filter_map(|l| {
            let t = l.trim_start_matches("Info:").trim();
            let (name, rest) = t.split_once(':')?;
            if !rest.contains('/') || !rest.trim_end().ends_with('%') {
                return None;
            }
            let rest = rest.replace('/', " ");
            let mut it = rest.split_whitespace();
            let used: u64 = it.next()?.parse().ok()?;
            let avail: u64 = it.next()?.parse().ok()?;
            Some((name.trim().to_string(), used, avail))
        })
        .collect()
}

/// The resources a nextpnr utilisation report shows over 100 %:
/// `ICESTORM_DSP 20/8`.
pub fn overfull(log: &str) -> Vec<String> {
    utilisation(log)
        .into_iter()
        .filter(|(_, used, avail)| used > avail)
        .map(|(name, used, avail)| format!("{name} {used}/{avail}"))
        .collect()
}

/// The logic cells the placed design uses as the device counts them, from
/// the placer's utilisation report: the resource `cell` (the family's
/// [`PlaceRoute::logic_cell`](fxshade_model::rtl::targets::PlaceRoute):
/// ECP5 `TRELLIS_COMB`, a LUT4 slot, of which a CCU2C carry cell takes two
/// and LUT RAM its own; iCE40 `ICESTORM_LC`).
pub fn logic_cells(log: &str, cell: &str) -> Option<u64> {
    utilisation(log)
        .into_iter()
        .find(|(n, _, _)| n == cell)
        .map(|(_, used, _)| used)
}

/// The last "Max frequency for clock" figure of a nextpnr log, MHz.
pub fn parse_fmax(log: &str) -> Option<f64> {
    log.lines()
        .filter(|l| l.contains("Max frequency for clock"))
        .filter_map(|l| {
            let after = l.split("': ").nth(1)?;
            after.split_whitespace().next()?.parse::<f64>().ok()
        })
        .next_back()
}

/// Run `cmd`, write its output to `log`, and fail with the output's last
/// lines when it fails.
pub fn run_logged(cmd: &mut Command, log: &Path, what: &str) -> anyhow::Result<String> {
    let o = crate::proc::run(cmd, what, crate::proc::Limit::synth(), None)?;
    let text = o.text();
    std::fs::write(log, &text).with_context(|| format!("cannot write {}", log.display()))?;
    if !o.status.success() {
        let tail: Vec<&str> = text.lines().rev().take(15).collect();
        bail!(
            "{what} failed (log: {}):\n{}",
            log.display(),
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        );
    }
    Ok(text)
}

/// How a unit is synthesized, placed and routed (part of the cache key).
#[derive(Clone, Copy, Debug)]
pub struct Flow {
    /// Place-and-route seeds (the median Fmax is reported).
    pub seeds: u32,
    /// The clock the placer aims for, MHz.
    pub freq: f64,
    /// Place and route (false: synthesis only).
    pub pnr: bool,
    /// ECP5: move product registers into the MULT18X18D blocks
    /// ([`crate::dsp_pack`]).
    pub dsp_pack: bool,
    /// The part placed on (None: the family's default,
    /// [`crate::device::Device::default_of`]).
    pub device: Option<crate::device::Device>,
}

impl Flow {
    /// One seed at 100 MHz, placed and routed, packed: what the report and
    /// `explore` look up.
    pub const DEFAULT: Flow = Flow {
        seeds: 1,
        freq: 100.0,
        pnr: true,
        dsp_pack: true,
        device: None,
    };
}

/// Synthesize (and place and route) `e` for `target` in `dir`.
pub fn synthesize(
    unit: &str,
    e: &Emitted,
    target: Target,
    flow: Flow,
    dir: &Path,
    progress: &dyn Fn(&str),
) -> anyhow::Result<SynthResult> {
    let Flow {
        seeds,
        freq,
        pnr,
        dsp_pack,
        device,
    } = flow;
    let device = device.or(crate::device::Device::default_of(target));
    let Some(synthesis) = target.synthesis() else {
        bail!("--target {target}: the family has no synthesis flow");
    };
    crate::rtl_flow::require_tool("yosys", "yosys")?;
    // The placer and the program that runs it: its own, or the packaged
    // alternative when only that is installed.
    let placer = match target.place_route() {
        Ok(p) if pnr => match installed_alternative(&p) {
            Some(a) => Some((p, a)),
            None => {
                require(p.tool, p.install)?;
                Some((p, p.tool))
            }
        },
        _ => None,
    };
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    std::fs::write(dir.join(format!("{}.v", e.module)), &e.verilog)?;
    std::fs::write(dir.join("fxs_harness.v"), harness(e))?;
    // The unit stays a module of its own (`keep_hierarchy`): synthesis
    // optimizes nothing across its ports, as in a design that integrates
    // it, its registers are packed there, and that module, as placed, is
    // what `--netlist` writes for co-simulation (nextpnr flattens the
    // hierarchy itself).
    let script = format!(
        "read_verilog -sv {m}.v fxs_harness.v\nsetattr -mod -set keep_hierarchy 1 {m}\n\
         {synth}\ntee -q -o stat.txt stat\n",
        m = e.module,
        synth = synthesis.yosys
    );
    std::fs::write(dir.join("synth.ys"), &script)?;
    progress("Yosys");
    let t0 = Instant::now();
    run_logged(
        Command::new("yosys")
            .args(["-q", "-s", "synth.ys"])
            .current_dir(dir),
        &dir.join("yosys.log"),
        "yosys",
    )?;
    let synth_seconds = t0.elapsed().as_secs_f64();
    let stat =
        std::fs::read_to_string(dir.join("stat.txt")).context("yosys wrote no statistics")?;
    let mut cells = parse_stat(&stat);
    let mut dsp_packed = None;
    if target.packs_dsp_registers() && dsp_pack {
        // Yosys leaves a product's registers in the fabric on ECP5: move
        // them into the MULT18X18D blocks (crate::dsp_pack). The netlist
        // Yosys wrote stays beside it as harness_yosys.json.
        let path = dir.join("harness.json");
        let text = std::fs::read(&path).context("yosys wrote no netlist")?;
        std::fs::write(dir.join("harness_yosys.json"), &text)?;
        let mut netlist: serde_json::Value =
            serde_json::from_slice(&text).context("yosys's netlist is not JSON")?;
        let st = crate::dsp_pack::pack_mult18(&mut netlist, &e.module)?;
        std::fs::write(&path, serde_json::to_vec(&netlist)?)?;
        cells = crate::dsp_pack::cell_counts(&netlist, "fxs_harness");
        dsp_packed = Some(st);
    }
    let setup_fields: Vec<String> = e.setup.iter().flat_map(|g| g.fields.clone()).collect();
    let ff_roles = match std::fs::read(dir.join("harness.json")) {
        Ok(text) => {
            let n: serde_json::Value =
                serde_json::from_slice(&text).context("yosys's netlist is not JSON")?;
            crate::ff_roles::roles(&n, "fxs_harness", &setup_fields, synthesis.ff)
        }
        Err(_) => Vec::new(),
    };
    let classes = [synthesis.lut, synthesis.ff, synthesis.dsp, synthesis.bram];
    let [lut, ff, dsp, bram] = classes.map(|prefixes| {
        cells
            .iter()
            .filter(|(n, _)| prefixes.iter().any(|p| n.starts_with(p)))
            .map(|(_, c)| c)
            .sum::<u64>()
    });
    let carry = cells
        .iter()
        .filter(|(n, _)| synthesis.carry.contains(&n.as_str()))
        .map(|(_, c)| c)
        .sum();
    // The harness's own flip-flops, as synthesis left them: those of its
    // module (the unit is a module of its own).
    let ff_class = synthesis.ff;
    let harness_ff = parse_stat_module(&stat, "fxs_harness")
        .iter()
        .filter(|(n, _)| ff_class.iter().any(|p| n.starts_with(p)))
        .map(|(_, c)| c)
        .sum();
    let mut r = SynthResult {
        unit: unit.to_string(),
        module: e.module.clone(),
        target: target.name().to_string(),
        device: device.map_or_else(|| synthesis.device.to_string(), |d| d.describe()),
        utilisation: Vec::new(),
        lut,
        ff,
        harness_ff,
        dsp,
        dsp_estimate: None,
        bram_estimate: None,
        lut_estimate: None,
        ff_estimate: None,
        area_terms: None,
        bram,
        carry,
        logic_cells: None,
        lut_ram: cells
            .iter()
            .filter(|(n, _)| synthesis.lut_ram.contains(&n.as_str()))
            .map(|(_, c)| c)
            .sum(),
        cells,
        fmax_mhz: None,
        predicted_mhz: e.predicted_ns.map(|t| 1000.0 / t),
        fmax_seeds: Vec::new(),
        fmax_note: None,
        latency: e.latency,
        throughput_mps: None,
        synth_seconds,
        pnr_seconds: 0.0,
        dsp_packed,
        ff_roles,
        critical_path: None,
        verdict: None,
        tools: [tool_version("yosys", "-V")]
            .into_iter()
            .chain(placer.map(|(_, program)| tool_version(program, "--version")))
            .flatten()
            .collect(),
    };
    fill_estimates(&mut r, &e.hardware, target);
    if let Some(d) = device.filter(|d| d.capacity.is_some()) {
        // No placer counts for this family: synthesis's counts against the
        // part's capacity (block RAM in 18 Kb halves).
        let count = |t: &str| {
            r.cells
                .iter()
                .filter(|(n, _)| n == t)
                .map(|(_, c)| c)
                .sum::<u64>()
        };
        let bram18 = synthesis
            .bram18
            .iter()
            .map(|(cell, halves)| halves * count(cell))
            .sum();
        r.utilisation = crate::device::from_capacity(&d, r.lut, r.ff, r.dsp, bram18);
        let over = crate::device::overfull(&r.utilisation);
        if !over.is_empty() {
            bail!(
                "{} does not fit the {}: {}",
                e_module(unit),
                d.describe(),
                over.join(", ")
            );
        }
    }
    let Some((place, tool)) = placer else {
        r.fmax_note = Some(match target.place_route() {
            Err(why) => why.into(),
            Ok(_) => "--no-pnr".into(),
        });
        return Ok(r);
    };
    let t1 = Instant::now();
    let mut placed_logic = Vec::new();
    let mut logs = Vec::new();
    for seed in 1..=seeds {
        progress(&format!("nextpnr, seed {seed} of {seeds}"));
        let mut cmd = Command::new(tool);
        let part = device.context("a placed target has a device")?;
        let report = format!("report_seed{seed}.json");
        cmd.args(part.pnr_args)
            .args(place.args)
            .args(["--json", "harness.json", "--freq"])
            .arg(format!("{freq}"))
            .args(["--seed", &seed.to_string()])
            .args(["--report", &report])
            .arg("--timing-allow-fail")
            .current_dir(dir);
        let log_path = dir.join(format!("nextpnr_seed{seed}.log"));
        let log = match run_logged(&mut cmd, &log_path, tool) {
            Ok(l) => l,
            Err(e) => {
                let text = std::fs::read_to_string(&log_path).unwrap_or_default();
                let over = overfull(&text);
                if over.is_empty() {
                    return Err(e);
                }
                bail!(
                    "{} does not fit the {}: {} (log: {})",
                    e_module(unit),
                    part.describe(),
                    over.join(", "),
                    log_path.display()
                );
            }
        };
        let f = parse_fmax(&log).with_context(|| {
            format!(
                "{tool} reported no Fmax (log: {})",
                dir.join(format!("nextpnr_seed{seed}.log")).display()
            )
        })?;
        r.fmax_seeds.push(f);
        if let Some(n) = logic_cells(&log, place.logic_cell) {
            placed_logic.push(n);
        }
        logs.push(log);
    }
    placed_logic.sort_unstable();
    r.logic_cells = placed_logic.get(placed_logic.len() / 2).copied();
    r.pnr_seconds = t1.elapsed().as_secs_f64();
    let mut s = r.fmax_seeds.clone();
    s.sort_by(f64::total_cmp);
    let med = s[s.len() / 2];
    r.fmax_mhz = Some(med);
    r.throughput_mps = Some(med);
    // The median seed's critical path (the first seed with that Fmax).
    let seed = r
        .fmax_seeds
        .iter()
        .position(|&f| f == med)
        .expect("the median is a seed")
        + 1;
    r.utilisation = crate::device::placed(&logs[seed - 1]);
    let report = dir.join(format!("report_seed{seed}.json"));
    let bytes = std::fs::read(&report)
        .with_context(|| format!("{tool} wrote no timing report {}", report.display()))?;
    r.critical_path = Some(
        crate::critical_path::parse(&bytes, seed as u64).with_context(|| {
            format!(
                "{}: no clock-to-clock critical path in it",
                report.display()
            )
        })?,
    );
    Ok(r)
}

/// The flow's own steps, in the cache key: a change to them measures
/// again.
const FLOW: &str = "ecp5-mult18-pack-4-stage-loads-no-copies-output-buffer-unit-module";

fn cache_entry(e: &Emitted, target: Target, flow: Flow) -> anyhow::Result<PathBuf> {
    let Flow {
        seeds,
        freq,
        pnr,
        dsp_pack,
        device,
    } = flow;
    let device = device
        .or(crate::device::Device::default_of(target))
        .map_or("", |d| d.name);
    // The versions of the tools the family's flow runs (Yosys and its
    // placer, or the placer's packaged build), once per family and process.
    static VERSIONS: std::sync::Mutex<Vec<(&'static str, String)>> =
        std::sync::Mutex::new(Vec::new());
    let versions = {
        let mut known = VERSIONS.lock().unwrap_or_else(|e| e.into_inner());
        match known.iter().find(|(n, _)| *n == target.name()) {
            Some((_, v)) => v.clone(),
            None => {
                let placer = target.place_route().ok().map(|p| {
                    tool_version(installed_alternative(&p).unwrap_or(p.tool), "--version")
                });
                let v = format!("{:?} {:?}", tool_version("yosys", "-V"), placer.flatten());
                known.push((target.name(), v.clone()));
                v
            }
        }
    };
    let key = fxshade_model::vectors::fingerprint(&[
        e.verilog.as_bytes(),
        harness(e).as_bytes(),
        target.name().as_bytes(),
        format!("{seeds} {freq} {pnr} {dsp_pack} {device} {versions} {FLOW}").as_bytes(),
    ]);
    Ok(fxshade_model::cache::subdir("synth")?.join(format!("{key:016x}.json")))
}

/// The result cached at `entry`, if a whole one of the user's own is there
/// (a cache someone else could have written is an error).
fn read_entry(entry: &Path) -> anyhow::Result<Option<SynthResult>> {
    Ok(fxshade_model::cache::read(entry)?.and_then(|b| serde_json::from_slice(&b).ok()))
}

/// A cached result of `fxshade synth` for this unit, configuration and
/// target (one seed at 100 MHz, with place and route), without running
/// any tool but `-V`.
pub fn lookup(unit: &str, cfg: &fxshade_model::Config, target: Target) -> Option<SynthResult> {
    let u = crate::rtl_flow::unit(unit).ok()?;
    let (_, e) = fxshade_model::rtl::units::emit_unit(u, cfg).ok()?;
    let entry = cache_entry(&e, target, Flow::DEFAULT).ok()?;
    read_entry(&entry).ok()?
}

/// Synthesize a unit of a configuration, from the cache when it can: the
/// key holds the emitted Verilog, the target, the seeds, the clock asked
/// for and the tool versions.
pub fn cached(
    unit: &str,
    cfg: &fxshade_model::Config,
    target: Target,
    flow: Flow,
    keep: Option<&Path>,
    use_cache: bool,
    progress: &dyn Fn(&str),
) -> anyhow::Result<(SynthResult, bool)> {
    let (r, hit, _) =
        cached_with_netlist(unit, cfg, target, flow, keep, use_cache, None, progress)?;
    Ok((r, hit))
}

/// [`cached`], and with `netlist` (ECP5) the unit's module of the netlist
/// placed written there ([`crate::netlist::write`]): that needs the run's
/// own netlist, so the cache is not read (the new result replaces the
/// cached one).
#[allow(clippy::too_many_arguments)]
pub fn cached_with_netlist(
    unit: &str,
    cfg: &fxshade_model::Config,
    target: Target,
    flow: Flow,
    keep: Option<&Path>,
    use_cache: bool,
    netlist: Option<&Path>,
    progress: &dyn Fn(&str),
) -> anyhow::Result<(SynthResult, bool, Option<crate::netlist::Written>)> {
    let u = crate::rtl_flow::unit(unit)?;
    let (d, e) = fxshade_model::rtl::units::emit_unit(u, cfg)?;
    let (mut r, hit, written) = cached_emitted(
        unit,
        &e,
        target,
        flow,
        keep,
        use_cache && netlist.is_none(),
        netlist,
        progress,
    )?;
    if let Some(p) = &mut r.critical_path {
        p.map_signals(&d.trace, &e.node_names);
    }
    r.verdict = r
        .fmax_mhz
        .map(|f| crate::critical_path::Verdict::new(flow.freq, f, &r.fmax_seeds));
    Ok((r, hit, written))
}

/// [`cached_with_netlist`] for an emitted module.
#[allow(clippy::too_many_arguments)]
fn cached_emitted(
    unit: &str,
    e: &Emitted,
    target: Target,
    flow: Flow,
    keep: Option<&Path>,
    use_cache: bool,
    netlist: Option<&Path>,
    progress: &dyn Fn(&str),
) -> anyhow::Result<(SynthResult, bool, Option<crate::netlist::Written>)> {
    let entry = cache_entry(e, target, flow)?;
    if use_cache && keep.is_none() {
        if let Some(mut r) = read_entry(&entry)? {
            // Entries cached before the prediction and the estimate were
            // recorded lack them (both come from the emitted module).
            r.predicted_mhz = e.predicted_ns.map(|t| 1000.0 / t);
            fill_estimates(&mut r, &e.hardware, target);
            return Ok((r, true, None));
        }
    }
    let mut tmp = None;
    let dir = match keep {
        Some(d) => d.to_path_buf(),
        None => {
            let t = tempfile::Builder::new()
                .prefix("fxshade-synth-")
                .tempdir()
                .context("cannot create a temporary directory")?;
            let p = t.path().to_path_buf();
            tmp = Some(t);
            p
        }
    };
    let run = synthesize(unit, e, target, flow, &dir, progress).and_then(|r| {
        let Some(out) = netlist else {
            return Ok((r, None));
        };
        progress("gate-level netlist (Yosys)");
        let work = dir.join("netlist");
        std::fs::create_dir_all(&work)
            .with_context(|| format!("cannot create {}", work.display()))?;
        let w = crate::netlist::write(e, &dir.join("harness.json"), r.dsp_packed, &work, out)?;
        Ok((r, Some(w)))
    });
    let (r, written) = match run {
        Ok(r) => r,
        Err(err) => {
            // Keep the logs the error names.
            if let Some(t) = tmp.take() {
                let _ = t.keep();
            }
            return Err(err);
        }
    };
    // Measured afresh (with or without --no-cache): the cache keeps it (a
    // full file system only costs the next run its time).
    match fxshade_model::cache::write(&entry, &serde_json::to_vec(&r)?) {
        Ok(()) | Err(fxshade_model::cache::CacheError::Full { .. }) => {}
        Err(e) => return Err(e.into()),
    }
    Ok((r, false, written))
}

/// `measured (est. E, ±x %)` where an estimate exists.
pub fn with_estimate(measured: u64, estimate: Option<u64>) -> String {
    match estimate {
        Some(e) => format!(
            "{measured} (est. {e}, {:+.0} %)",
            100.0 * (e as f64 - measured as f64) / measured.max(1) as f64
        ),
        None => measured.to_string(),
    }
}

/// The estimates of the emitted module's resources on `target`, without
/// synthesis ([`fxshade_model::rtl::estimate`]), set beside what synthesis
/// counted (cached entries get them afresh: they come from the module).
fn fill_estimates(r: &mut SynthResult, hw: &fxshade_model::rtl::Hardware, target: Target) {
    use fxshade_model::rtl::estimate as est;
    let t = timing(target);
    r.dsp_estimate = t.map(|t| est::dsp_blocks(hw, t));
    r.bram_estimate = t.map(|t| est::bram_blocks(hw, t));
    r.lut_estimate = t.and_then(|t| est::lut_cells(hw, t));
    r.ff_estimate = t.and_then(|t| est::flip_flops(hw, t));
    r.area_terms = t.map(|t| est::AreaTerms::of(hw, t));
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
        return close::run(a, tt, runs, freq, device);
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
            .titled("Flip-flops by role (the netlist placed; roles: src/ff_roles.rs)");
        let total: u64 = r.ff_roles.iter().map(|(_, n)| n).sum();
        for (role, n) in &r.ff_roles {
            f.row([
                role.clone(),
                n.to_string(),
                format!("{:.1} %", 100.0 * *n as f64 / total.max(1) as f64),
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
    use fxshade_model::rtl::estimate::{fit::fit, AreaModel, AreaTerms};
    // A target without a fit yet is calibrated all the same: its model
    // columns are then zero and say so.
    let fitted = AreaModel::of(tt);
    let model = fitted.unwrap_or(AreaModel {
        lut: [0.0; 11],
        ff: [0.0; 11],
    });
    let set = area_set();
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
    let x: Vec<[f64; 10]> = rows.iter().map(|r| r.1.values()).collect();
    let lut_y: Vec<f64> = rows.iter().map(|r| r.2 as f64).collect();
    let ff_y: Vec<f64> = rows.iter().map(|r| r.3 as f64).collect();
    // Every term costs cells; only the multiplier blocks may take
    // flip-flops away (ECP5's product registers move into them).
    let lut_fit = fit(&x, &lut_y, [true; 11]);
    let mut ff_sign = [true; 11];
    ff_sign[9] = false;
    ff_sign[10] = false;
    let ff_fit = fit(&x, &ff_y, ff_sign);
    let refit = AreaModel {
        lut: lut_fit,
        ff: ff_fit,
    };
    let pct = |est: u64, got: u64| 100.0 * (est as f64 - got as f64) / (got.max(1) as f64);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stat_cells_and_fmax_are_read_from_tool_output() {
        let stat = "=== fxs_harness ===\n\n   Number of wires:   10\n   Number of cells:   7\n     SB_CARRY   2\n     SB_DFF   3\n     SB_LUT4   2\n\n";
        assert_eq!(
            parse_stat(stat),
            [
                ("SB_CARRY".to_string(), 2),
                ("SB_DFF".into(), 3),
                ("SB_LUT4".into(), 2)
            ]
        );
        let log = "Info: Max frequency for clock 'clk_i$SB_IO_IN_$glb_clk': 61.20 MHz (PASS at 12.00 MHz)\n\
                   Info: Max frequency for clock 'clk_i$SB_IO_IN_$glb_clk': 58.91 MHz (FAIL at 100.00 MHz)\n";
        assert_eq!(parse_fmax(log), Some(58.91));
        assert_eq!(parse_fmax("nothing"), None);
        let log = "Info: \t        ICESTORM_PLL:     0/    1     0%\nInfo: \t        ICESTORM_DSP:    20/    8   250%\n";
        assert_eq!(overfull(log), ["ICESTORM_DSP 20/8"]);
        assert_eq!(logic_cells(log, "ICESTORM_LC"), None);
        // nextpnr-ecp5 0.11's report (from a placed smooth top).
        let log = "Info: Device utilisation:\n\
                   Info: \t          TRELLIS_IO:     7/  365     1%\n\
                   Info: \t        TRELLIS_COMB:  4521/83640     5%\n\
                   Info: \t          TRELLIS_FF: 10631/83640    12%\n";
        assert_eq!(logic_cells(log, "TRELLIS_COMB"), Some(4521));
        assert!(overfull(log).is_empty());
        let log = "Info: \t         ICESTORM_LC:  1234/ 7680    16%\n";
        assert_eq!(logic_cells(log, "ICESTORM_LC"), Some(1234));
    }

    /// Yosys 0.23's `stat` of a harness that keeps the unit a module of
    /// its own (trimmed): the totals are the last block's, the harness's
    /// own cells its module's block.
    #[test]
    fn stat_of_a_hierarchy_gives_totals_and_the_harness_module() {
        let stat = "=== fxs_harness ===

   Number of wires:   20
   Number of cells:  123
                         LUT4   17
     TRELLIS_FF  105
     normalize    1

                    === normalize ===

   Number of cells:  2174
     LUT4  277
                         MULT18X18D    8
     TRELLIS_FF 1711

                    === design hierarchy ===

   fxs_harness    1
     normalize    1

                       Number of wires:  451
   Number of cells:  2296
     LUT4  294
                         MULT18X18D    8
     TRELLIS_FF 1816
";
        assert_eq!(
            parse_stat(stat),
            [
                ("LUT4".to_string(), 294),
                ("MULT18X18D".into(), 8),
                ("TRELLIS_FF".into(), 1816)
            ]
        );
        assert_eq!(
            parse_stat_module(stat, "fxs_harness"),
            [
                ("LUT4".to_string(), 17),
                ("TRELLIS_FF".into(), 105),
                ("normalize".into(), 1)
            ]
        );
        assert!(parse_stat_module(stat, "other").is_empty());
    }
}
