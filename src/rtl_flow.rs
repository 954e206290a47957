//! The RTL flow: generate vectors and parameters for a configuration, build
//! the unit's testbench with Verilator or Icarus Verilog (cached per
//! configuration), run it, and read back `N passed, M failed`.
//!
//! Adding a unit means adding its Verilog, its testbench and an entry in
//! [`RTL_UNITS`]; the flow, the vector writer and the testbench driver
//! (`rtl/tb/fxs_vector_tb.vh`) are shared.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context};
use fxshade_model::vectors::{fingerprint, ParamsHeader, VectorSet};
use fxshade_model::Config;

/// A unit with RTL.
pub struct RtlUnit {
    /// Unit name (its configuration section, `rtl/<name>.v`).
    pub name: &'static str,
    /// Top module of the design.
    pub top: &'static str,
    /// Top module of the testbench.
    pub tb_top: &'static str,
    /// Sources, relative to `rtl/`, embedded in the binary: design files
    /// first, testbench files last.
    pub sources: &'static [(&'static str, &'static str)],
    /// Number of leading entries of `sources` that are the design.
    pub design_files: usize,
    /// The vectors of a configuration.
    pub vectors: fn(&Config, usize, u64) -> anyhow::Result<VectorSet>,
    /// The parameter header of a configuration.
    pub params: fn(&Config) -> anyhow::Result<ParamsHeader>,
    /// The variants the RTL implements: name and the `--set` override
    /// selecting it.
    pub variants: &'static [(&'static str, &'static str)],
    /// The counting run of the datapath the RTL implements, for a
    /// configuration (to compare with its netlist).
    pub count: fn(&Config) -> anyhow::Result<fxshade_model::Count>,
    /// Modules that are table reads (ROMs): kept as black boxes in the
    /// netlist, counted as table reads, their addressing not as arithmetic.
    pub blackbox: &'static [&'static str],
    /// Stages whose overflow the RTL does not observe because they wrap by
    /// design (the polar transform's angle index): no range comparators.
    pub unflagged: &'static [&'static str],
    /// Whether the RTL outputs overflow flags. When it does not (the
    /// pipeline top outputs the level only), a wrapping quantization needs
    /// no range comparators and synthesis removes them.
    pub flags_overflow: bool,
}

macro_rules! rtl_source {
    ($p:literal) => {
        ($p, include_str!(concat!("../rtl/", $p)))
    };
}

/// Every unit with RTL.
pub static RTL_UNITS: &[RtlUnit] = &[
    RtlUnit {
        name: "normalize",
        top: "normalize",
        tb_top: "normalize_tb",
        sources: &[
            rtl_source!("fxs_quant.v"),
            rtl_source!("fxs_pipe_ctrl.v"),
            rtl_source!("fxs_side_delay.v"),
            rtl_source!("fxs_mad_q.v"),
            rtl_source!("normalize.v"),
            rtl_source!("tb/fxs_vector_tb.vh"),
            rtl_source!("tb/normalize_tb.v"),
        ],
        design_files: 5,
        vectors: |cfg, n, seed| Ok(fxshade_model::normalizer::rtl::vectors(cfg, n, seed)?),
        params: |cfg| Ok(fxshade_model::normalizer::rtl::params_header(cfg)?.2),
        variants: &[
            ("linear", "normalize.method=\"linear\""),
            ("quadratic", "normalize.method=\"quadratic\""),
        ],
        count: |cfg| Ok(fxshade_model::normalizer::from_config(cfg)?.0.count()?),
        blackbox: &[],
        unflagged: &[],
        flags_overflow: true,
    },
    RtlUnit {
        name: "interp",
        top: "interp",
        tb_top: "interp_tb",
        sources: &[
            rtl_source!("fxs_quant.v"),
            rtl_source!("fxs_pipe_ctrl.v"),
            rtl_source!("fxs_side_delay.v"),
            rtl_source!("interp.v"),
            rtl_source!("tb/fxs_vector_tb.vh"),
            rtl_source!("tb/interp_tb.v"),
        ],
        design_files: 4,
        vectors: |cfg, n, seed| Ok(fxshade_model::interp::rtl::vectors(cfg, n, seed)?),
        params: |cfg| Ok(fxshade_model::interp::rtl::params_header(cfg)?.1),
        variants: &[
            ("linear", "interp.scheme=\"linear\""),
            ("quadratic", "interp.scheme=\"quadratic\""),
        ],
        count: |cfg| {
            let i = fxshade_model::interp::Interp::from_config(
                cfg.unit(fxshade_model::interp::DECL.name),
            );
            Ok(i.count()?.1)
        },
        blackbox: &[],
        unflagged: &[],
        flags_overflow: true,
    },
    RtlUnit {
        name: "polar",
        top: "polar",
        tb_top: "polar_tb",
        sources: &[
            rtl_source!("fxs_quant.v"),
            rtl_source!("fxs_pipe_ctrl.v"),
            rtl_source!("fxs_side_delay.v"),
            rtl_source!("fxs_sincos_rom.v"),
            rtl_source!("fxs_mad_q.v"),
            rtl_source!("polar.v"),
            rtl_source!("tb/fxs_vector_tb.vh"),
            rtl_source!("tb/polar_tb.v"),
        ],
        design_files: 6,
        vectors: |cfg, n, seed| Ok(fxshade_model::polar::rtl::vectors(cfg, n, seed)?),
        params: |cfg| Ok(fxshade_model::polar::rtl::params_header(cfg)?.1),
        variants: &[
            ("quarter", "polar.organisation=\"quarter\""),
            ("full", "polar.organisation=\"full\""),
        ],
        count: |cfg| {
            let p =
                fxshade_model::polar::Polar::from_config(cfg.unit(fxshade_model::polar::DECL.name))
                    .map_err(|e| anyhow::anyhow!("{e}"))?;
            Ok(p.count()?)
        },
        blackbox: &["fxs_sincos_rom"],
        unflagged: &["index"],
        flags_overflow: true,
    },
    RtlUnit {
        name: "pipeline",
        top: "pipeline",
        tb_top: "pipeline_tb",
        sources: &[
            rtl_source!("fxs_quant.v"),
            rtl_source!("fxs_pipe_ctrl.v"),
            rtl_source!("fxs_side_delay.v"),
            rtl_source!("fxs_mad_q.v"),
            rtl_source!("fxs_sincos_rom.v"),
            rtl_source!("interp.v"),
            rtl_source!("normalize.v"),
            rtl_source!("polar.v"),
            rtl_source!("angle_interp.v"),
            rtl_source!("lighting.v"),
            rtl_source!("pipeline.v"),
            rtl_source!("tb/fxs_vector_tb.vh"),
            rtl_source!("tb/pipeline_tb.v"),
        ],
        design_files: 11,
        vectors: |cfg, n, seed| Ok(fxshade_model::pipeline::rtl::vectors(cfg, n, seed)?),
        params: |cfg| Ok(fxshade_model::pipeline::rtl::params_header(cfg)?.2),
        variants: &[
            ("smooth", "pipeline.path=\"smooth\""),
            ("mapped", "pipeline.path=\"mapped\""),
        ],
        count: |cfg| {
            let (p, path, _) = fxshade_model::pipeline::rtl::params_header(cfg)?;
            Ok(p.count(path)?)
        },
        blackbox: &["fxs_sincos_rom"],
        unflagged: &["index", "angle"],
        flags_overflow: false,
    },
];

/// Look a unit up by name.
pub fn unit(name: &str) -> anyhow::Result<&'static RtlUnit> {
    RTL_UNITS.iter().find(|u| u.name == name).with_context(|| {
        format!(
            "no RTL for unit `{name}`; units with RTL: {}",
            RTL_UNITS
                .iter()
                .map(|u| u.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}

/// A simulator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Sim {
    /// Verilator (primary).
    Verilator,
    /// Icarus Verilog.
    Icarus,
}

impl Sim {
    fn name(self) -> &'static str {
        match self {
            Sim::Verilator => "verilator",
            Sim::Icarus => "icarus",
        }
    }
}

/// Fail with the install command when a tool is missing.
pub fn require_tool(tool: &str, package: &str) -> anyhow::Result<()> {
    match Command::new(tool).arg("-V").output() {
        Ok(_) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
            "{tool} is not installed: install it with `sudo apt-get install {package}` \
             (Debian; ./scripts/test does it when run as root)"
        ),
        Err(e) => bail!("cannot run {tool}: {e}"),
    }
}

/// Where builds are cached: `$FXSHADE_CACHE_DIR`, else `~/.cache/fxshade`.
pub fn cache_root() -> PathBuf {
    if let Some(d) = std::env::var_os("FXSHADE_CACHE_DIR") {
        return PathBuf::from(d);
    }
    match std::env::var_os("HOME") {
        Some(h) => PathBuf::from(h).join(".cache").join("fxshade"),
        None => std::env::temp_dir().join("fxshade-cache"),
    }
}

fn run_tool(cmd: &mut Command, what: &str) -> anyhow::Result<String> {
    let out = cmd.output().with_context(|| format!("cannot run {what}"))?;
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        bail!("{what} failed ({}):\n{}", out.status, text.trim_end());
    }
    Ok(text)
}

/// Write the unit's sources and a parameter header into `dir/src`.
pub fn write_sources(u: &RtlUnit, params: &ParamsHeader, dir: &Path) -> anyhow::Result<PathBuf> {
    let src = dir.join("src");
    std::fs::create_dir_all(src.join("tb"))?;
    for (rel, text) in u.sources {
        std::fs::write(src.join(rel), text)?;
    }
    std::fs::write(src.join(&params.name), &params.text)?;
    for (name, text) in &params.extra {
        std::fs::write(src.join(name), text)?;
    }
    Ok(src)
}

/// A built simulation.
pub struct Build {
    /// The cache directory.
    pub dir: PathBuf,
    /// Seconds spent building (0 when cached).
    pub seconds: f64,
}

/// Build (or reuse) the testbench of `u` for `params` on `sim`.
pub fn build(
    u: &RtlUnit,
    params: &ParamsHeader,
    sim: Sim,
    maxn: usize,
    trace: bool,
) -> anyhow::Result<Build> {
    match sim {
        Sim::Verilator => require_tool("verilator", "verilator")?,
        Sim::Icarus => {
            require_tool("iverilog", "iverilog")?;
        }
    }
    let mut parts: Vec<&[u8]> = u.sources.iter().map(|(_, t)| t.as_bytes()).collect();
    let tag = format!("{}-{maxn}-{trace}", sim.name());
    parts.push(params.text.as_bytes());
    for (name, text) in &params.extra {
        parts.push(name.as_bytes());
        parts.push(text.as_bytes());
    }
    parts.push(tag.as_bytes());
    let key = fingerprint(&parts);
    let root = cache_root();
    let dir = root.join(format!("{}-{}-{key:016x}", u.name, sim.name()));
    if dir.join("done").is_file() {
        return Ok(Build { dir, seconds: 0.0 });
    }
    std::fs::create_dir_all(&root)
        .with_context(|| format!("cannot create the build cache {}", root.display()))?;
    let staging = root.join(format!(
        ".{}-{}-{key:016x}.{}",
        u.name,
        sim.name(),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&staging);
    std::fs::create_dir_all(&staging)?;
    let start = Instant::now();
    let src = write_sources(u, params, &staging)?;
    let files: Vec<PathBuf> = u
        .sources
        .iter()
        .filter(|(rel, _)| rel.ends_with(".v"))
        .map(|(rel, _)| src.join(rel))
        .collect();
    let result = match sim {
        Sim::Verilator => {
            let mut c = Command::new("verilator");
            c.current_dir(&staging)
                .args([
                    "--binary",
                    "-j",
                    "2",
                    "-O3",
                    "--x-assign",
                    "fast",
                    "--x-initial",
                    "fast",
                ])
                .arg("--top-module")
                .arg(u.tb_top)
                .arg(format!("-I{}", src.display()))
                .arg(format!("-I{}", src.join("tb").display()))
                .arg(format!("-GMAXN={maxn}"))
                .args(["--Mdir", "obj", "-o", "sim"]);
            if trace {
                c.arg("--trace-fst");
            }
            c.args(&files);
            run_tool(&mut c, "verilator")
        }
        Sim::Icarus => {
            let mut c = Command::new("iverilog");
            c.current_dir(&staging)
                .args(["-g2005", "-o", "sim.vvp"])
                .arg(format!("-I{}", src.display()))
                .arg(format!("-I{}", src.join("tb").display()))
                .arg(format!("-P{}.MAXN={maxn}", u.tb_top))
                .args(&files);
            run_tool(&mut c, "iverilog")
        }
    };
    if let Err(e) = result {
        let _ = std::fs::remove_dir_all(&staging);
        return Err(e);
    }
    std::fs::write(staging.join("done"), b"")?;
    if std::fs::rename(&staging, &dir).is_err() {
        // Another process built the same key meanwhile: use theirs.
        let _ = std::fs::remove_dir_all(&staging);
    }
    Ok(Build {
        dir,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The outcome of one co-simulation.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CheckResult {
    /// Unit.
    pub unit: &'static str,
    /// Simulator.
    pub sim: Sim,
    /// Vectors in the set.
    pub count: usize,
    /// Vectors whose every output bit matched.
    pub passed: u64,
    /// Vectors that did not.
    pub failed: u64,
    /// Smallest input-to-output latency seen, in cycles.
    pub latency: Option<u64>,
    /// Clock cycles simulated.
    pub cycles: Option<u64>,
    /// Seconds the simulation process ran, loading included.
    pub sim_seconds: f64,
    /// Seconds spent reading the vector files (`$readmemh`) and checking them.
    pub load_seconds: f64,
    /// Vectors per second through the simulation, once the files are loaded.
    pub vectors_per_second: f64,
    /// Vectors per second for the whole simulation process, loading included.
    pub vectors_per_second_end_to_end: f64,
    /// Seconds spent building (0 when cached).
    pub build_seconds: f64,
    /// The first mismatches, as the testbench printed them.
    pub mismatches: Vec<String>,
    /// The waveform, when traced.
    pub trace: Option<PathBuf>,
    /// The simulator's error lines, if any.
    pub errors: Vec<String>,
    /// Every output the RTL produced, in order, as hex (with `dump`).
    #[serde(skip)]
    pub outputs: Vec<String>,
}

impl CheckResult {
    /// The flow's verdict: every vector passed.
    pub fn ok(&self) -> bool {
        self.failed == 0 && self.passed == self.count as u64
    }
}

fn parse_num(line: &str, prefix: &str) -> Option<u64> {
    line.strip_prefix(prefix)?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// Run the vectors through the unit's testbench.
pub fn check(
    u: &RtlUnit,
    v: &VectorSet,
    sim: Sim,
    seed: u64,
    stall: u32,
    trace: Option<&Path>,
) -> anyhow::Result<CheckResult> {
    check_with(u, v, sim, seed, stall, trace, false)
}

/// As [`check`]; with `dump`, also read back every output the RTL produced
/// ([`CheckResult::outputs`]).
pub fn check_with(
    u: &RtlUnit,
    v: &VectorSet,
    sim: Sim,
    seed: u64,
    stall: u32,
    trace: Option<&Path>,
    dump: bool,
) -> anyhow::Result<CheckResult> {
    let maxn = (v.count() + 1).next_power_of_two();
    let b = build(u, &v.params, sim, maxn, trace.is_some())?;
    let run = b.dir.join(
        format!(
            "run-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        )
        .replace(['(', ')'], ""),
    );
    let _ = std::fs::remove_dir_all(&run);
    std::fs::create_dir_all(&run)?;
    std::fs::write(run.join("inputs.hex"), v.inputs_hex())?;
    std::fs::write(run.join("expected.hex"), v.expected_hex())?;
    for (name, text) in &v.params.extra {
        std::fs::write(run.join(name), text)?;
    }
    let mut c = match sim {
        Sim::Verilator => Command::new(b.dir.join("obj").join("sim")),
        Sim::Icarus => {
            let mut c = Command::new("vvp");
            c.arg("-n").arg(b.dir.join("sim.vvp"));
            c
        }
    };
    c.current_dir(&run)
        .arg(format!("+N={}", v.count()))
        .arg(format!("+SEED={}", seed as u32 as i32))
        .arg(format!("+STALL={stall}"));
    let trace_path = trace.map(|t| std::path::absolute(t).unwrap_or_else(|_| t.to_path_buf()));
    if let Some(t) = &trace_path {
        c.arg(format!("+TRACE={}", t.display()));
    }
    if dump {
        c.arg("+DUMP=outputs.hex");
    }
    // Stream the output to time the load and the simulation separately.
    use std::io::{BufRead, Read};
    let start = Instant::now();
    let mut child = c
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .with_context(|| format!("cannot run the {} simulation", sim.name()))?;
    let mut err_pipe = child.stderr.take().expect("piped");
    let err_thread = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err_pipe.read_to_string(&mut s);
        s
    });
    let mut loaded_at = None;
    let mut text = String::new();
    for line in std::io::BufReader::new(child.stdout.take().expect("piped")).lines() {
        let line = line.unwrap_or_default();
        if loaded_at.is_none() && line.starts_with("vectors loaded") {
            loaded_at = Some(start.elapsed().as_secs_f64());
        }
        text += &line;
        text += "\n";
    }
    let status = child.wait()?;
    let secs = start.elapsed().as_secs_f64();
    text += &err_thread.join().unwrap_or_default();
    let outputs = if dump {
        std::fs::read_to_string(run.join("outputs.hex"))
            .unwrap_or_default()
            .lines()
            .map(|l| l.trim().to_string())
            .collect()
    } else {
        Vec::new()
    };
    let _ = std::fs::remove_dir_all(&run);
    let load = loaded_at.unwrap_or(0.0);
    let mut r = CheckResult {
        unit: u.name,
        sim,
        count: v.count(),
        passed: 0,
        failed: 0,
        latency: None,
        cycles: None,
        sim_seconds: secs,
        load_seconds: load,
        vectors_per_second: v.count() as f64 / (secs - load).max(1e-9),
        vectors_per_second_end_to_end: v.count() as f64 / secs.max(1e-9),
        build_seconds: b.seconds,
        mismatches: Vec::new(),
        trace: trace_path,
        errors: Vec::new(),
        outputs,
    };
    let mut verdict = false;
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let l = line.trim();
        if let Some((p, rest)) = l.split_once(" passed, ") {
            if let (Ok(p), Some(f)) = (p.trim().parse::<u64>(), rest.strip_suffix(" failed")) {
                r.passed = p;
                r.failed = f.trim().parse().unwrap_or(u64::MAX);
                verdict = true;
            }
        } else if let Some(x) = parse_num(l, "latency ") {
            r.latency = Some(x);
        } else if let Some(x) = parse_num(l, "cycles ") {
            r.cycles = Some(x);
        } else if l.starts_with("mismatch") {
            let mut m = l.to_string();
            while let Some(next) = lines.peek() {
                if next.starts_with("  ") {
                    m += "\n";
                    m += next.trim_end();
                    lines.next();
                } else {
                    break;
                }
            }
            r.mismatches.push(m);
        } else if l.starts_with("error") || l.starts_with("%Error") || l.contains("ERROR") {
            r.errors.push(l.to_string());
        }
    }
    if !verdict {
        bail!(
            "the {} simulation ended without a `N passed, M failed` line ({}):\n{}",
            sim.name(),
            status,
            text.trim_end()
        );
    }
    Ok(r)
}
