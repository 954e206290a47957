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

use fxshade_model::convert::{narrow, to_f64};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context};
use fxshade_model::rtl::Emitted;

pub mod close;

/// A synthesis target: a technology family of the registry
/// (`fxshade_model::rtl::targets`) with a synthesis flow.
pub use fxshade_model::rtl::targets::Target;

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
        conns.push(format!(
            ".{}_valid_i(in_q[{}])",
            g.name,
            in_w + narrow::<u32, _>(k)
        ));
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
    let chain_w = in_w + narrow::<u32, _>(e.setup.len());
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
///
/// # Errors
///
/// The tool cannot be run or runs past the synthesis limit, the log cannot be written, or the
/// tool exits non-zero (the log's tail in the error).
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
///
/// # Errors
///
/// A tool is missing, Yosys or the placer fails, the design does not fit the part, or a report
/// cannot be read.
///
/// # Panics
///
/// Never: the median seed is one of the seeds run.
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
///
/// # Errors
///
/// As [`cached_with_netlist`].
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
///
/// # Errors
///
/// The unit or its module cannot be emitted, the cache cannot be used, or the synthesis fails
/// ([`synthesize`]).
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
///
/// # Errors
///
/// As [`cached_with_netlist`].
#[allow(clippy::too_many_arguments)]
pub fn cached_emitted(
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
            100.0 * (to_f64(e) - to_f64(measured)) / to_f64(measured.max(1))
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
