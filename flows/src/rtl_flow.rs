//! The RTL flow: emit a unit's Verilog and testbench from its traced
//! datapath (or take hand-edited design files from a directory), build the
//! testbench with Verilator or Icarus Verilog (cached by the sources' hash),
//! run it on vectors, and read back `N passed, M failed`.
//!
//! The units are the model's registry ([`fxshade_model::rtl::units`]); the
//! flow, the vector writer and the testbench driver
//! (`rtl/tb/fxs_vector_tb.vh`, pasted into every generated testbench) are
//! shared.

use fxshade_model::convert::{narrow, to_f64};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context};
use fxshade_model::rtl::testbench::Harness;
use fxshade_model::rtl::units::RtlUnit;
use fxshade_model::vectors::{fingerprint, RtlSources, VectorSource};

/// Look a unit up by name.
///
/// # Errors
///
/// `name` is no unit; the error lists the units.
pub fn unit(name: &str) -> anyhow::Result<&'static RtlUnit> {
    fxshade_model::rtl::units::unit(name).with_context(|| {
        format!(
            "no RTL for unit `{name}`; units with RTL: {}",
            fxshade_model::rtl::units::names()
        )
    })
}

/// The Verilog a simulation compiles: design files (name, text) and the
/// testbench's top module; `origin` says where the design came from.
#[derive(Clone, Debug)]
pub struct Sources {
    /// Design files, then the testbench file.
    pub files: Vec<(String, String)>,
    /// The testbench's top module.
    pub tb_top: String,
    /// `emitted` or the directory the design files were read from.
    pub origin: String,
    /// The testbench driven from C++, which Verilator runs instead of the
    /// Verilog testbench (`None`: the testbench on both simulators).
    pub harness: Option<Harness>,
}

impl Sources {
    /// The design fingerprint: SHA-256 over every simulated file's name and
    /// text (design files, then the testbench) and the testbench's top, as
    /// 64 hex digits. Shards of one regression share it; `fxshade merge`
    /// refuses a mix.
    pub fn fingerprint(&self) -> String {
        let mut parts: Vec<&[u8]> = Vec::new();
        for (n, t) in &self.files {
            parts.push(n.as_bytes());
            parts.push(t.as_bytes());
        }
        parts.push(self.tb_top.as_bytes());
        fxshade_model::cache::sha256_key(&parts)
    }

    /// The emitted design and testbench of a vector set.
    pub fn emitted(rtl: &RtlSources) -> Sources {
        Sources {
            files: rtl
                .files()
                .into_iter()
                .map(|(n, t)| (n, t.to_string()))
                .collect(),
            tb_top: format!("{}_tb", rtl.module),
            origin: "emitted by fxshade rtl".into(),
            harness: Some(rtl.harness.clone()),
        }
    }
    /// The same design behind its AXI4-Stream wrapper: the wrapper
    /// (`<module>_axis.v`; the design's own when its files hold one, as
    /// with `--rtl-dir`) after the design files, and the vector testbench
    /// that drives the wrapper instead of the module's.
    pub fn with_axis(mut self, unit: &str, e: &fxshade_model::rtl::Emitted) -> Sources {
        let tb = self.files.pop();
        debug_assert!(tb.is_some_and(|(n, _)| n.ends_with("_tb.v")));
        let m = &e.module;
        // A design directory that holds its own wrapper keeps it.
        let name = format!("{m}_axis.v");
        if !self.files.iter().any(|(n, _)| *n == name) {
            self.files
                .push((name, fxshade_model::rtl::axis::wrapper(unit, e)));
        }
        self.files.push((
            format!("{m}_axis_tb.v"),
            fxshade_model::rtl::axis::testbench(e),
        ));
        self.tb_top = format!("{m}_axis_tb");
        self.origin += ", behind its AXI4-Stream wrapper";
        // The wrapper's testbench is Verilog on both simulators.
        self.harness = None;
        self
    }
    /// Every `*.v` file of `dir` except testbenches (`*_tb.v`) as the
    /// design, with the vector set's generated testbench.
    ///
    /// # Errors
    ///
    /// A file the unit's RTL needs is missing from `dir` or cannot be read.
    ///
    /// # Panics
    ///
    /// Never: every path listed is a file name.
    pub fn from_dir(rtl: &RtlSources, dir: &Path) -> anyhow::Result<Sources> {
        let mut files = Vec::new();
        let rd = std::fs::read_dir(dir)
            .with_context(|| format!("cannot read --rtl-dir {}", dir.display()))?;
        let mut names: Vec<PathBuf> = rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.extension().is_some_and(|x| x == "v")
                    && !p
                        .file_name()
                        .is_some_and(|n| n.to_string_lossy().ends_with("_tb.v"))
            })
            .collect();
        names.sort();
        anyhow::ensure!(
            !names.is_empty(),
            "--rtl-dir {} holds no .v design files",
            dir.display()
        );
        for p in &names {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read {}", p.display()))?;
            files.push((
                p.file_name()
                    .expect("a file")
                    .to_string_lossy()
                    .into_owned(),
                text,
            ));
        }
        files.push((format!("{}_tb.v", rtl.module), rtl.testbench.clone()));
        Ok(Sources {
            files,
            tb_top: format!("{}_tb", rtl.module),
            harness: Some(rtl.harness.clone()),
            origin: format!(
                "{} ({})",
                dir.display(),
                names
                    .iter()
                    .map(|p| p
                        .file_name()
                        .expect("a file")
                        .to_string_lossy()
                        .into_owned())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        })
    }
}

/// A simulator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Sim {
    /// Verilator (primary).
    Verilator,
    /// Icarus Verilog.
    Icarus,
}

impl Sim {
    /// `verilator` or `icarus`.
    pub fn name(self) -> &'static str {
        match self {
            Sim::Verilator => "verilator",
            Sim::Icarus => "icarus",
        }
    }

    /// The simulator's version line (`Verilator 5.006 2023-01-22`,
    /// `Icarus Verilog version 11.0 (stable) ()`), probed once per process;
    /// `unknown` when it does not answer.
    pub fn version(self) -> &'static str {
        static V: std::sync::OnceLock<[String; 2]> = std::sync::OnceLock::new();
        let v = V.get_or_init(|| {
            [
                crate::proc::version("verilator", "--version").unwrap_or_else(|| "unknown".into()),
                crate::proc::version("iverilog", "-V").unwrap_or_else(|| "unknown".into()),
            ]
        });
        &v[self as usize]
    }
}

/// Fail with the install command when a tool is missing (or hangs).
///
/// # Errors
///
/// `tool` is not installed; the error names the Debian package.
pub fn require_tool(tool: &str, package: &str) -> anyhow::Result<()> {
    crate::proc::require(
        tool,
        "-V",
        &format!(
            "install it with `sudo apt-get install {package}` \
             (Debian; ./scripts/test does it when run as root)"
        ),
    )
}

/// Whether Verilator models are compiled without optimization
/// (`FXSHADE_QUICK_BUILD=1`, which the test suite sets: hundreds of builds,
/// each run on a few thousand vectors).
fn quick_build() -> bool {
    crate::settings::get().quick_build
}

/// Run a build tool under [`crate::proc::Limit::build`]: on timeout the
/// whole group (make, the C++ compiler) is killed.
///
/// # Errors
///
/// The tool cannot be started, runs past the build limit, or exits non-zero (its output in the
/// error).
pub fn run_tool(cmd: &mut Command, what: &str) -> anyhow::Result<String> {
    crate::proc::run_ok(cmd, what, crate::proc::Limit::build())
}

/// Write the sources into `dir`; the paths of the files.
///
/// # Errors
///
/// A file cannot be written to `dir`.
pub fn write_sources(src: &Sources, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let mut paths = Vec::new();
    for (name, text) in &src.files {
        let p = dir.join(name);
        std::fs::write(&p, text).with_context(|| format!("cannot write {}", p.display()))?;
        paths.push(p);
    }
    Ok(paths)
}

/// A built simulation.
pub struct Build {
    /// The cache directory.
    pub dir: PathBuf,
    /// Seconds spent building (0 when cached).
    pub seconds: f64,
}

impl Build {
    /// The program a Verilator build runs (`obj/sim`), or the file `vvp`
    /// loads for Icarus.
    pub fn binary(&self, sim: Sim) -> PathBuf {
        self.dir.join(binary_rel(sim))
    }
}

/// The file of a build that is run: the Verilator executable, or the
/// Icarus program `vvp` loads.
fn binary_rel(sim: Sim) -> &'static str {
    match sim {
        Sim::Verilator => "obj/sim",
        Sim::Icarus => "sim.vvp",
    }
}

/// Build (or reuse) the testbench of `sources` on `sim`.
///
/// Builds are cached in the user's private cache ([`fxshade_model::cache`])
/// under a key of the sources, the simulator and the build options. An
/// entry is used only when its seal verifies: it is the user's own and its
/// binary still hashes to what was recorded when it was complete; anything
/// else is rebuilt. A build is staged, its binary synced and hashed, and
/// the seal written last, so a full file system or a killed build leaves no
/// entry that looks complete.
///
/// # Errors
///
/// The simulator is missing, the cache cannot be used, or the build fails (its log in the
/// error).
pub fn build(name: &str, sources: &Sources, sim: Sim, trace: bool) -> anyhow::Result<Build> {
    build_with(name, sources, sim, trace, false)
}

/// [`build`]; with `fresh`, the cached entry (if any) is removed first.
fn build_with(
    name: &str,
    sources: &Sources,
    sim: Sim,
    trace: bool,
    fresh: bool,
) -> anyhow::Result<Build> {
    use fxshade_model::cache::{self, Seal};
    match sim {
        Sim::Verilator => require_tool("verilator", "verilator")?,
        Sim::Icarus => {
            require_tool("iverilog", "iverilog")?;
            require_tool("vvp", "iverilog")?;
        }
    }
    let mut parts: Vec<&[u8]> = Vec::new();
    for (n, t) in &sources.files {
        parts.push(n.as_bytes());
        parts.push(t.as_bytes());
    }
    let quick = quick_build();
    let harness = match sim {
        Sim::Verilator => sources.harness.as_ref().map(Harness::files),
        Sim::Icarus => None,
    };
    for (n, t) in harness.iter().flatten() {
        parts.push(n.as_bytes());
        parts.push(t.as_bytes());
    }
    // A new simulator version builds anew.
    let tag = format!(
        "{}-{}-stream-{trace}-{quick}-{}-O2",
        sim.name(),
        sim.version(),
        if harness.is_some() { "cpp" } else { "tb" }
    );
    parts.push(tag.as_bytes());
    let key = fingerprint(&parts);
    let root = cache::root()?;
    let dir = root.join(format!("{name}-{}-{key:016x}", sim.name()));
    if fresh {
        remove_entry(&dir)?;
    } else if dir.exists() {
        if Seal::verify(&dir)? {
            return Ok(Build { dir, seconds: 0.0 });
        }
        // Not sealed, or its binary changed since: build it again.
        remove_entry(&dir)?;
    }
    let staging = root.join(format!(
        ".{name}-{}-{key:016x}.{}",
        sim.name(),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&staging);
    cache::ensure_private_dir(&staging, cache::uid())?;
    let start = Instant::now();
    let result = (|| -> anyhow::Result<()> {
        let mut files = write_sources(sources, &staging.join("src"))?;
        match sim {
            Sim::Verilator => {
                let mut c = Command::new("verilator");
                c.current_dir(&staging);
                let top = match (&harness, &sources.harness) {
                    (Some(h), Some(hs)) => {
                        // The design files, the shell and the C++ driver
                        // instead of the Verilog testbench: no timing
                        // scheduler, records read in bulk.
                        let tb = staging.join("src").join(format!("{}.v", sources.tb_top));
                        files.retain(|p| *p != tb);
                        for (n, t) in h {
                            let p = staging.join("src").join(n);
                            std::fs::write(&p, t)
                                .with_context(|| format!("cannot write {}", p.display()))?;
                            files.push(p);
                        }
                        c.args(["--cc", "--exe", "--build", "--no-timing"]);
                        hs.top()
                    }
                    _ => {
                        c.arg("--binary");
                        sources.tb_top.clone()
                    }
                };
                c.args([
                    "-j",
                    "2",
                    "-O3",
                    "--x-assign",
                    "fast",
                    "--x-initial",
                    "fast",
                ])
                .arg("--top-module")
                .arg(&top)
                .args(["--Mdir", "obj", "-o", "sim"]);
                if trace {
                    c.arg("--trace-fst");
                }
                // A gate-level netlist (`synth --netlist`: its cell models
                // beside it): cells with unused pins, carry chains through
                // cell boundaries (combinational loops at the bit level
                // only), the models' own width casts and the LUT-RAM
                // model's initial non-blocking assignments are what a
                // netlist is, not faults of the design; Verilator would
                // stop on them.
                if files.iter().any(|f| {
                    f.file_name()
                        .is_some_and(|n| n == crate::netlist::CELLS_FILE)
                }) {
                    c.args([
                        "-Wno-PINMISSING",
                        "-Wno-UNOPTFLAT",
                        "-Wno-WIDTH",
                        "-Wno-INITIALDLY",
                    ]);
                }
                // ccache, when installed, keeps Verilator's runtime library
                // and unchanged model files compiled across builds (half the
                // time of a small unit's build).
                if crate::proc::has("ccache", "--version") {
                    c.args(["-MAKEFLAGS", "OBJCACHE=ccache"]);
                }
                if quick {
                    // Compile the model without optimization: a quarter less
                    // build time, a slower simulation (for many short runs).
                    c.args(["-MAKEFLAGS", "OPT_FAST=-O0 OPT_SLOW=-O0"]);
                } else {
                    // The model's per-cycle code and the driver at -O2
                    // (Verilator's default is -Os).
                    c.args(["-MAKEFLAGS", "OPT_FAST=-O2"]);
                }
                c.args(&files);
                run_tool(&mut c, "verilator")?;
            }
            Sim::Icarus => {
                let mut c = Command::new("iverilog");
                c.current_dir(&staging)
                    .args(["-g2005", "-o", "sim.vvp"])
                    .args(&files);
                run_tool(&mut c, "iverilog")?;
            }
        }
        // A tool that ran out of space may still exit 0 with a truncated
        // output: a full file system is an error, never an entry.
        check_space(&staging)?;
        let bin = staging.join(binary_rel(sim));
        if let Err(why) = binary_complete(sim, &bin) {
            return Err(fxshade_model::cache::CacheError::Full { path: bin.clone() })
                .with_context(|| format!("{} is incomplete ({why})", bin.display()));
        }
        Seal::write(&staging, &[binary_rel(sim)])?;
        Ok(())
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_dir_all(&staging);
        return Err(e);
    }
    if std::fs::rename(&staging, &dir).is_err() {
        // Another process built the same key meanwhile: use theirs if it
        // verifies.
        let _ = std::fs::remove_dir_all(&staging);
        anyhow::ensure!(
            Seal::verify(&dir)?,
            "the cached build {} appeared while building and does not verify",
            dir.display()
        );
    }
    Ok(Build {
        dir,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Whether a built simulator is whole: for Verilator an ELF file whose
/// section header table (the last thing the linker writes) lies inside
/// it; for Icarus a program that ends with its whole `:file_names N;`
/// table.
///
/// # Errors
///
/// `Err` saying why the binary at `path` is not a complete build of `sim` (missing, truncated,
/// not an executable).
///
/// # Panics
///
/// Never: the header slice read is checked to be 8 bytes long.
pub fn binary_complete(sim: Sim, path: &Path) -> Result<(), String> {
    let b = std::fs::read(path).map_err(|e| e.to_string())?;
    match sim {
        Sim::Verilator => {
            if b.len() < 64 || &b[..4] != b"\x7fELF" || b[4] != 2 {
                return Err("not a 64-bit ELF file".into());
            }
            let le = b[5] == 1;
            let u16_at = |o: usize| {
                let a = [b[o], b[o + 1]];
                if le {
                    u16::from_le_bytes(a)
                } else {
                    u16::from_be_bytes(a)
                }
            };
            let a: [u8; 8] = b[0x28..0x30].try_into().expect("8 bytes");
            let shoff = if le {
                u64::from_le_bytes(a)
            } else {
                u64::from_be_bytes(a)
            };
            let end = shoff + u64::from(u16_at(0x3a)) * u64::from(u16_at(0x3c));
            if shoff == 0 || end > b.len() as u64 {
                return Err(format!(
                    "its section headers end at byte {end}, the file at {}",
                    b.len()
                ));
            }
            Ok(())
        }
        Sim::Icarus => {
            let text = String::from_utf8_lossy(&b);
            let Some(pos) = text.rfind("\n:file_names ") else {
                return Err("no file name table".into());
            };
            let mut lines = text[pos + 1..].lines();
            let n: usize = lines
                .next()
                .and_then(|l| l.strip_prefix(":file_names "))
                .and_then(|l| l.strip_suffix(';'))
                .and_then(|l| l.trim().parse().ok())
                .ok_or("a malformed file name table")?;
            let names = lines
                .filter(|l| l.trim_start().starts_with('"') && l.ends_with("\";"))
                .count();
            if names != n || !text.ends_with('\n') {
                return Err(format!("{names} of its {n} file names"));
            }
            Ok(())
        }
    }
}

/// Remove a cache entry (an error names it when it cannot be removed).
fn remove_entry(dir: &Path) -> anyhow::Result<()> {
    match std::fs::remove_dir_all(dir) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e).with_context(|| {
            format!(
                "the cached build {} must be rebuilt and cannot be removed",
                dir.display()
            )
        }),
    }
}

/// Fail when the file system holding `dir` has no free block left (a
/// build there may have been cut short without an error).
fn check_space(dir: &Path) -> anyhow::Result<()> {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(dir.as_os_str().as_bytes())?;
    // SAFETY: a zeroed statvfs is a valid out-parameter for statvfs.
    let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
    // SAFETY: a valid C string and out-pointer.
    let ok = unsafe { libc::statvfs(c.as_ptr(), &mut st) } == 0;
    // Blocks this user may still write (root may use the reserved ones).
    let free = if fxshade_model::cache::uid() == 0 {
        st.f_bfree
    } else {
        st.f_bavail
    };
    if ok && free == 0 {
        return Err(fxshade_model::cache::CacheError::Full {
            path: dir.to_path_buf(),
        }
        .into());
    }
    Ok(())
}

/// Whether the FST file at `path` is whole: a sequence of blocks, each a
/// type byte and a big-endian 64-bit length that counts itself (the format
/// of GTKWave's `fstapi`, which Verilator and Icarus both use), ending
/// exactly at the end of the file, with no block left unfinished (type
/// 255, `FST_BL_SKIP`).
///
/// # Errors
///
/// `Err` saying why the FST trace at `path` is incomplete (missing, truncated, a block that
/// runs past the end).
///
/// # Panics
///
/// Never: each length read is a checked 8-byte slice.
pub fn fst_complete(path: &Path) -> Result<(), String> {
    let b = std::fs::read(path).map_err(|e| e.to_string())?;
    if b.first() != Some(&0) {
        return Err("no FST header block".into());
    }
    let mut pos = 0usize;
    let mut blocks = 0;
    while pos < b.len() {
        let Some(len) = b.get(pos + 1..pos + 9) else {
            return Err(format!("a block header cut short at byte {pos}"));
        };
        let len = u64::from_be_bytes(len.try_into().expect("8 bytes"));
        if b[pos] == 255 {
            return Err(format!("an unfinished block at byte {pos}"));
        }
        let end = (pos as u64 + 1).checked_add(len).filter(|_| len >= 8);
        match end {
            Some(e) if e <= b.len() as u64 => pos = narrow::<usize, _>(e),
            _ => {
                return Err(format!(
                    "block {blocks} at byte {pos} claims {len} bytes, the file ends at {}",
                    b.len()
                ))
            }
        }
        blocks += 1;
    }
    if blocks < 2 {
        return Err("no value-change block".into());
    }
    Ok(())
}

/// The outcome of one co-simulation.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CheckResult {
    /// Unit.
    pub unit: &'static str,
    /// Where the simulated design came from.
    pub design: String,
    /// Simulator.
    pub sim: Sim,
    /// Vectors in the run.
    pub count: usize,
    /// Index of the first vector in the whole stream (a shard's start).
    pub first: usize,
    /// Vectors whose every output bit matched.
    pub passed: u64,
    /// Vectors that did not.
    pub failed: u64,
    /// Smallest input-to-output latency seen, in cycles.
    pub latency: Option<u64>,
    /// Clock cycles simulated.
    pub cycles: Option<u64>,
    /// Wall-clock seconds from the start of streaming to the simulation's
    /// end (generation and simulation overlap).
    pub seconds: f64,
    /// CPU seconds of the simulator process (user + system): simulation,
    /// reading the records and checking them, without waiting for them.
    pub sim_cpu_seconds: f64,
    /// Seconds the generator spent making and encoding vectors.
    pub generate_seconds: f64,
    /// Vectors per simulator CPU second: the simulation-only rate.
    pub vectors_per_second: f64,
    /// Vectors per wall-clock second, generation included (end to end).
    pub vectors_per_second_end_to_end: f64,
    /// Seconds spent building (0 when cached).
    pub build_seconds: f64,
    /// Peak resident memory of the simulator process, in KiB.
    pub sim_max_rss_kib: u64,
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

/// Run the vectors through the testbench of `sources`; with `dump`, also
/// read back every output the RTL produced ([`CheckResult::outputs`]).
///
/// # Errors
///
/// The build fails, the simulation cannot run or runs past its limits, or its output cannot be
/// read; mismatches are counted in the result, not errors.
pub fn check_with(
    v: &dyn VectorSource,
    sources: &Sources,
    sim: Sim,
    seed: u64,
    stall: u32,
    trace: Option<&Path>,
    dump: bool,
) -> anyhow::Result<CheckResult> {
    check_with_args(v, sources, sim, seed, stall, trace, dump, &[])
}

/// Remove the run directories (named pipes, dumps) of killed checks: a
/// `run-<pid>-…` whose process no longer exists.
fn remove_dead_runs(dir: &Path) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = name
            .strip_prefix("run-")
            .and_then(|r| r.split('-').next())
            .and_then(|p| p.parse::<i32>().ok())
        else {
            continue;
        };
        // SAFETY: signal 0 only asks whether the process exists.
        let gone = unsafe { libc::kill(pid, 0) } != 0
            && std::io::Error::last_os_error().raw_os_error() == Some(libc::ESRCH);
        if gone {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// Vectors per generated chunk.
const CHUNK: usize = 8192;

/// What the generators of every running check tell of the vectors they
/// hand to the simulation (set by long `rtl-check` runs: a progress bar).
pub type Advance = Box<dyn Fn(u64) + Send>;

/// The [`Advance`] of the running checks, if any.
pub static PROGRESS: std::sync::Mutex<Option<Advance>> = std::sync::Mutex::new(None);

/// Threads generating vectors for one simulation: `$FXSHADE_GEN_THREADS`,
/// else the machine's cores (the simulator takes one; generation usually
/// costs more per vector than simulation).
fn generator_workers() -> usize {
    crate::settings::get()
        .gen_threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .min(16)
}

/// Open a named pipe for writing without blocking forever: retry while no
/// reader has opened it, give up once `gone` is set (the simulation ended
/// without opening it).
fn open_fifo(p: &Path, gone: &std::sync::atomic::AtomicBool) -> Option<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    use std::os::unix::io::AsRawFd;
    loop {
        match std::fs::OpenOptions::new()
            .write(true)
            .custom_flags(libc::O_NONBLOCK)
            .open(p)
        {
            Ok(f) => {
                // SAFETY: fcntl on a descriptor we own.
                unsafe {
                    let fl = libc::fcntl(f.as_raw_fd(), libc::F_GETFL);
                    libc::fcntl(f.as_raw_fd(), libc::F_SETFL, fl & !libc::O_NONBLOCK);
                }
                return Some(f);
            }
            Err(e) if e.raw_os_error() == Some(libc::ENXIO) => {
                if gone.load(std::sync::atomic::Ordering::SeqCst) {
                    return None;
                }
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            Err(_) => return None,
        }
    }
}

/// As [`check_with`], passing `extra` plusargs to the simulation.
///
/// The vectors are streamed: a generator thread draws them chunk by chunk
/// from `v` and encodes the binary records, two writer threads feed them
/// through named pipes to the testbench's `$fread`, and the simulation runs
/// meanwhile. Memory stays bounded whatever the count, and nothing is
/// written to disk.
///
/// # Errors
///
/// As [`check_with`].
#[allow(clippy::too_many_arguments)]
pub fn check_with_args(
    v: &dyn VectorSource,
    sources: &Sources,
    sim: Sim,
    seed: u64,
    stall: u32,
    trace: Option<&Path>,
    dump: bool,
    extra: &[String],
) -> anyhow::Result<CheckResult> {
    anyhow::ensure!(
        v.len() < (1 << 31),
        "{} vectors in one run: at most 2^31 − 1 (split the run with --shard)",
        v.len()
    );
    let b = build(v.unit(), sources, sim, trace.is_some())?;
    match run_built(v, sources, sim, seed, stall, trace, dump, extra, &b) {
        // A cached simulator that does not load (a file cut short before
        // its entry was sealed by an older fxshade, say): build it again,
        // once.
        Err(e) if b.seconds == 0.0 && e.downcast_ref::<NoVerdict>().is_some() => {
            let b = build_with(v.unit(), sources, sim, trace.is_some(), true)?;
            run_built(v, sources, sim, seed, stall, trace, dump, extra, &b)
        }
        r => r,
    }
}

/// A simulation that ended without its verdict line.
#[derive(Debug)]
pub struct NoVerdict(pub String);

impl std::fmt::Display for NoVerdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for NoVerdict {}

/// Milliseconds since `t0`, at least 1 (0 means "not set").
fn ms_since(t0: Instant) -> u64 {
    narrow::<u64, _>(t0.elapsed().as_millis()) + 1
}

/// [`check_with_args`] on a built simulator.
#[allow(clippy::too_many_arguments)]
fn run_built(
    v: &dyn VectorSource,
    sources: &Sources,
    sim: Sim,
    seed: u64,
    stall: u32,
    trace: Option<&Path>,
    dump: bool,
    extra: &[String],
    b: &Build,
) -> anyhow::Result<CheckResult> {
    use std::io::{BufRead, Read, Write};
    use std::os::unix::process::CommandExt;
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
    remove_dead_runs(&b.dir);
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
    // Removed however this function returns (a killed process's is removed
    // by the next check, [`remove_dead_runs`]).
    struct RunDir(PathBuf);
    impl Drop for RunDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
    let _run_dir = RunDir(run.clone());
    let (fin, fexp) = (run.join("inputs.bin"), run.join("expected.bin"));
    for f in [&fin, &fexp] {
        let c = std::ffi::CString::new(f.as_os_str().as_encoded_bytes()).expect("no NUL");
        // SAFETY: a valid C string; mkfifo touches no memory of ours.
        if unsafe { libc::mkfifo(c.as_ptr(), 0o600) } != 0 {
            bail!(
                "cannot create the pipe {}: {}",
                f.display(),
                std::io::Error::last_os_error()
            );
        }
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
        .arg(format!("+N={}", v.len()))
        .arg(format!("+FIRST={}", narrow::<u32, _>(v.first())))
        .arg(format!("+IN={}", fin.display()))
        .arg(format!("+EXP={}", fexp.display()))
        // The seed's low 32 bits, as the testbench's signed 32-bit `$random` seed.
        .arg(format!(
            "+SEED={}",
            narrow::<u32, _>(seed & u64::from(u32::MAX)).cast_signed()
        ))
        .arg(format!("+STALL={stall}"))
        .args(extra);
    let trace_path = trace.map(|t| std::path::absolute(t).unwrap_or_else(|_| t.to_path_buf()));
    if let Some(t) = &trace_path {
        // Simulators only warn when they cannot open the waveform: check first.
        let parent = t.parent().unwrap_or(Path::new("/"));
        anyhow::ensure!(
            parent.is_dir(),
            "cannot write the waveform to {}: {} is not a directory",
            t.display(),
            parent.display()
        );
        // Only a waveform is replaced: any other file there is the user's.
        if std::fs::metadata(t).is_ok_and(|m| m.len() > 0) && fst_complete(t).is_err() {
            return Err(crate::UsageError(format!(
                "--trace {}: the file exists and is not an FST waveform; nothing was written \
                 (name another file)",
                t.display()
            ))
            .into());
        }
        std::fs::write(t, b"")
            .with_context(|| format!("cannot write the waveform to {}", t.display()))?;
        if sim == Sim::Icarus {
            // Icarus writes VCD unless told otherwise: FST on both
            // simulators, so one check tells a whole waveform.
            c.arg("-fst");
        }
        c.arg(format!("+TRACE={}", t.display()));
    }
    if dump {
        c.arg("+DUMP=outputs.hex");
    }
    let start = Instant::now();
    let mut child = c
        .process_group(0)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .with_context(|| format!("cannot run the {} simulation", sim.name()))?;
    let pid = narrow::<i32, _>(child.id());
    let group = crate::proc::Group::watch(child.id());
    let idle = crate::proc::Limit::sim_idle();
    let gone = AtomicBool::new(false);
    // When each writer began the write it is blocked in (0: none), and
    // when both had written everything: a simulation that takes nothing
    // for `idle` while vectors wait for it is stuck, and is stopped.
    let blocked: [AtomicU64; 2] = [AtomicU64::new(0), AtomicU64::new(0)];
    let finished = [AtomicU64::new(0), AtomicU64::new(0)];
    let stuck = AtomicBool::new(false);
    let (in_rb, out_rb) = (
        fxshade_model::vectors::record_bytes(v.input_fields()),
        fxshade_model::vectors::record_bytes(v.output_fields()),
    );
    let mut text = String::new();
    let mut gen_result: anyhow::Result<f64> = Ok(0.0);
    let mut rusage: libc::rusage = unsafe { std::mem::zeroed() };
    let mut status = 0i32;
    // Generator workers: chunk k is made by worker k mod W; the writers
    // take the chunks back in order.
    let workers = generator_workers();
    std::thread::scope(|s| {
        let mut rx_ins = Vec::new();
        let mut rx_exps = Vec::new();
        let mut generators = Vec::new();
        // Written buffers go back to the worker that filled them (fresh
        // buffers per chunk cost page faults: the heap's top is trimmed).
        let (mut back_ins, mut back_exps) = (Vec::new(), Vec::new());
        for w in 0..workers {
            let (tx_in, rx_in) = std::sync::mpsc::sync_channel::<Vec<u8>>(2);
            let (tx_exp, rx_exp) = std::sync::mpsc::sync_channel::<Vec<u8>>(2);
            let (back_in, spent_in) = std::sync::mpsc::channel::<Vec<u8>>();
            let (back_exp, spent_exp) = std::sync::mpsc::channel::<Vec<u8>>();
            rx_ins.push(rx_in);
            rx_exps.push(rx_exp);
            back_ins.push(back_in);
            back_exps.push(back_exp);
            generators.push(s.spawn(move || -> anyhow::Result<f64> {
                let mut busy = 0.0;
                let mut start = w * CHUNK;
                let reuse = |spent: &std::sync::mpsc::Receiver<Vec<u8>>, cap: usize| {
                    let mut b = spent.try_recv().unwrap_or_default();
                    b.clear();
                    b.reserve(cap);
                    b
                };
                while start < v.len() {
                    let t0 = Instant::now();
                    let len = CHUNK.min(v.len() - start);
                    let mut bi = reuse(&spent_in, len * in_rb);
                    let mut be = reuse(&spent_exp, len * out_rb);
                    v.records(start, len, &mut bi, &mut be)?;
                    busy += t0.elapsed().as_secs_f64();
                    if let Some(b) = PROGRESS.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
                        b(len as u64);
                    }
                    if tx_in.send(bi).is_err() || tx_exp.send(be).is_err() {
                        break;
                    }
                    start += workers * CHUNK;
                }
                Ok(busy)
            }));
        }
        let gone = &gone;
        let (blocked, finished, stuck, group) = (&blocked, &finished, &stuck, &group);
        let writer = |path: PathBuf,
                      rxs: Vec<std::sync::mpsc::Receiver<Vec<u8>>>,
                      backs: Vec<std::sync::mpsc::Sender<Vec<u8>>>,
                      w: usize| {
            move || {
                let Some(mut f) = open_fifo(&path, gone) else {
                    return;
                };
                // Chunks in order: worker 0, 1, …, W−1, 0, …
                for k in 0.. {
                    let Ok(buf) = rxs[k % rxs.len()].recv() else {
                        finished[w].store(ms_since(start), Ordering::SeqCst);
                        return;
                    };
                    // A simulation that stopped reading (it ended early)
                    // closes the pipe: stop writing.
                    blocked[w].store(ms_since(start), Ordering::SeqCst);
                    let r = f.write_all(&buf);
                    blocked[w].store(0, Ordering::SeqCst);
                    if r.is_err() {
                        return;
                    }
                    // The worker may have finished: then the buffer is dropped.
                    let _ = backs[k % backs.len()].send(buf);
                }
            }
        };
        s.spawn(writer(fin.clone(), rx_ins, back_ins, 0));
        s.spawn(writer(fexp.clone(), rx_exps, back_exps, 1));
        let (done_tx, done_rx) = std::sync::mpsc::channel::<()>();
        s.spawn(move || {
            let limit = narrow::<u64, _>(idle.time.as_millis());
            while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                done_rx.recv_timeout(std::time::Duration::from_millis(500))
            {
                let now = ms_since(start);
                let waited = |a: &AtomicU64| {
                    let t = a.load(Ordering::SeqCst);
                    t != 0 && now.saturating_sub(t) > limit
                };
                let all_written = finished.iter().all(|f| f.load(Ordering::SeqCst) != 0);
                if blocked.iter().any(waited) || (all_written && finished.iter().all(waited)) {
                    stuck.store(true, Ordering::SeqCst);
                    group.kill();
                    return;
                }
            }
        });
        let mut err_pipe = child.stderr.take().expect("piped");
        let err_thread = s.spawn(move || {
            let mut s = String::new();
            let _ = err_pipe.read_to_string(&mut s);
            s
        });
        for line in std::io::BufReader::new(child.stdout.take().expect("piped")).lines() {
            text += &line.unwrap_or_default();
            text += "\n";
        }
        // SAFETY: reaping our own child, with out-pointers to locals.
        unsafe {
            libc::wait4(pid, &mut status, 0, &mut rusage);
        }
        let _ = done_tx.send(());
        gone.store(true, Ordering::SeqCst);
        text += &err_thread.join().unwrap_or_default();
        gen_result = generators.into_iter().try_fold(0.0, |acc, g| {
            Ok(acc
                + g.join()
                    .unwrap_or_else(|_| Err(anyhow::anyhow!("the vector generator panicked")))?)
        });
    });
    let secs = start.elapsed().as_secs_f64();
    let cpu = to_f64(rusage.ru_utime.tv_sec)
        + to_f64(rusage.ru_utime.tv_usec) * 1e-6
        + to_f64(rusage.ru_stime.tv_sec)
        + to_f64(rusage.ru_stime.tv_usec) * 1e-6;
    let generate_seconds = gen_result?;
    let outputs = if dump {
        std::fs::read_to_string(run.join("outputs.hex"))
            .unwrap_or_default()
            .lines()
            .map(|l| l.trim().to_string())
            .collect()
    } else {
        Vec::new()
    };
    let n = v.len();
    let mut r = CheckResult {
        unit: v.unit(),
        design: sources.origin.clone(),
        sim,
        count: n,
        first: v.first(),
        passed: 0,
        failed: 0,
        latency: None,
        cycles: None,
        seconds: secs,
        sim_cpu_seconds: cpu,
        generate_seconds,
        vectors_per_second: to_f64(n) / cpu.max(1e-9),
        vectors_per_second_end_to_end: to_f64(n) / secs.max(1e-9),
        build_seconds: b.seconds,
        sim_max_rss_kib: narrow::<u64, _>(rusage.ru_maxrss),
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
        } else if l.starts_with("error")
            || l.starts_with("protocol error")
            || l.starts_with("%Error")
            || l.contains("ERROR")
        {
            r.errors.push(l.to_string());
        }
    }
    if stuck.load(Ordering::SeqCst) {
        bail!(
            "the {} simulation read no vector for {} s and was stopped (set {} to allow more)",
            sim.name(),
            idle.time.as_secs(),
            idle.var
        );
    }
    if !verdict {
        return Err(NoVerdict(format!(
            "the {} simulation ended without a `N passed, M failed` line (wait status {status}):\n{}",
            sim.name(),
            text.trim_end()
        ))
        .into());
    }
    if let Some(t) = &r.trace {
        // A simulator that cannot open the waveform file only warns.
        let size = std::fs::metadata(t).map(|m| m.len()).unwrap_or(0);
        anyhow::ensure!(
            size > 0,
            "the {} simulation wrote no waveform to {} (is the directory writable, is the disk full?)",
            sim.name(),
            t.display()
        );
        // Simulators do not report a failed write to the waveform either (a
        // full file system cuts it short): check its structure.
        if let Err(why) = fst_complete(t) {
            let _ = std::fs::remove_file(t);
            bail!(
                "the waveform {} is incomplete ({why}) and was removed: is the file system full?",
                t.display()
            );
        }
    }
    Ok(r)
}

/// `rtl.*` overrides for a pipelining policy, a target and a period; a
/// target or a period alone implies `rtl.pipeline = "target"`.
pub fn pipeline_overrides(
    pipeline: Option<&str>,
    target: Option<&str>,
    clock_ns: Option<f64>,
) -> Vec<String> {
    let mut o = Vec::new();
    if let Some(t) = target {
        o.push(format!("rtl.target=\"{t}\""));
    }
    if let Some(c) = clock_ns {
        o.push(format!("rtl.clock_ns={c:?}"));
    }
    match pipeline {
        Some(p) => o.push(format!("rtl.pipeline=\"{p}\"")),
        None if target.is_some() || clock_ns.is_some() => o.push("rtl.pipeline=\"target\"".into()),
        None => {}
    }
    o
}

/// The units and configurations of `fxshade rtl all`: every unit with `cfg`,
/// and the pipeline top with each variant's overrides applied.
///
/// # Errors
///
/// A pipeline variant's overrides do not apply to `cfg`.
pub fn configs_all(
    cfg: &fxshade_model::Config,
) -> anyhow::Result<
    Vec<(
        &'static fxshade_model::rtl::units::RtlUnit,
        fxshade_model::Config,
    )>,
> {
    let mut out = Vec::new();
    for u in fxshade_model::rtl::units::all() {
        if u.name == "pipeline" {
            for (_, set) in u.variants {
                let mut c = cfg.clone();
                for o in fxshade_model::rtl::units::overrides(set) {
                    c.apply_override(o)?;
                }
                out.push((u, c));
            }
        } else {
            out.push((u, cfg.clone()));
        }
    }
    Ok(out)
}
