//! Handshake proofs: the properties every generated module carries in its
//! `ifdef FORMAL` block (no item created, lost or duplicated; `valid_o`
//! and the outputs held under stall; the pipeline drains), proved with
//! Yosys, yosys-smtbmc and z3.
//!
//! The datapath is abstracted: every combinational datapath wire's driver
//! becomes a cut point (Yosys's `cutpoint`: a free value each cycle). The
//! properties do not read the data, and an abstraction admits every
//! behaviour of the real logic and more, so a proof of the abstracted
//! module is a proof of the module; registers, the valid chain, the stall
//! and the outputs stay exactly as emitted. Each module is checked by
//! bounded model checking from reset (`depth` cycles) and k-induction (the
//! same depth): both passing is an unbounded proof. With `cover`, a cover
//! run must also reach an output transfer from reset.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context};

/// The tools the proofs run, each named with how to install it when
/// missing.
///
/// # Errors
///
/// Yosys, yosys-smtbmc or z3 is not installed.
pub fn require_tools() -> anyhow::Result<()> {
    crate::rtl_flow::require_tool("yosys", "yosys")?;
    if !crate::proc::has("yosys-smtbmc", "-h") {
        bail!("yosys-smtbmc is not installed: it comes with Debian's yosys (`sudo apt-get install yosys`)");
    }
    if !crate::proc::has("z3", "--version") {
        bail!("z3 is not installed: install it with `sudo apt-get install z3` (./scripts/test does it when run as root)");
    }
    Ok(())
}

/// One module's result.
#[derive(Debug, serde::Serialize)]
pub struct Proof {
    /// The module proved.
    pub module: String,
    /// Its latency, cycles.
    pub latency: u32,
    /// Bounded model checking from reset passed.
    pub bmc: bool,
    /// k-induction passed.
    pub induction: bool,
    /// The cover run reached an output transfer (`None`: not asked).
    pub cover: Option<bool>,
    /// Seconds the three runs took (reported, never compared).
    pub seconds: f64,
    /// The first failing property or the tool's error, when one failed.
    pub failure: Option<String>,
}

impl Proof {
    /// Bounded, inductive and (when asked) covered: an unbounded proof.
    pub fn ok(&self) -> bool {
        self.bmc && self.induction && self.cover != Some(false)
    }
}

/// The datapath's combinational wires of an emitted module: every `wire
/// NAME = …;` between its `// Datapath.` and `// Pipeline registers` lines.
pub fn datapath_wires(verilog: &str) -> Vec<String> {
    let (Some(a), Some(b)) = (
        verilog.find("  // Datapath."),
        verilog.find("  // Pipeline registers"),
    ) else {
        return Vec::new();
    };
    verilog[a..b]
        .lines()
        .filter_map(|l| {
            let l = l.trim_start().strip_prefix("wire ")?;
            let (lhs, _) = l.split_once(" = ")?;
            lhs.split_whitespace()
                .last()
                .filter(|n| n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
                .map(str::to_string)
        })
        .collect()
}

/// The Yosys script that reads `file` (module `top`) with its formal
/// properties, cuts the datapath and writes `out` for yosys-smtbmc.
pub fn yosys_script(file: &str, top: &str, wires: &[String], out: &str) -> String {
    let mut s = format!("read_verilog -formal -sv {file}\nprep -top {top}\n");
    if !wires.is_empty() {
        // The drivers of the datapath wires (never a register, a memory or
        // a port: those stay as emitted).
        let sel: Vec<String> = wires.iter().map(|w| format!("w:{w}")).collect();
        s += &format!("select -set dpw {}\n", sel.join(" "));
        s += "cutpoint @dpw %ci1 w:* %d t:$dff %d t:$adff %d t:$mem* %d\n";
        s += "opt_clean\n";
    }
    s += &format!("async2sync\ndffunmap\nwrite_smt2 {out}\n");
    s
}

/// Run yosys-smtbmc with z3 on `args` in `dir`: whether it passed, and
/// the failing property (or the verdict) when it did not.
fn smtbmc(dir: &Path, args: &[&str], what: &str) -> anyhow::Result<(bool, String)> {
    let mut c = Command::new("yosys-smtbmc");
    c.current_dir(dir).args(["-s", "z3", "--unroll"]).args(args);
    let text = crate::proc::run(&mut c, what, crate::proc::Limit::formal(), None)?.text();
    let status = text
        .lines()
        .rev()
        .find(|l| l.contains("Status:"))
        .map(|l| l.contains("PASSED"));
    match status {
        Some(ok) => {
            // The failing property (its source line), else the verdict.
            let pick = |pat: &str| {
                text.lines()
                    .find(|l| l.contains(pat))
                    .map(|l| l.split("  ").last().unwrap_or(l).trim().to_string())
            };
            let why = pick("Assert failed")
                .or_else(|| pick("Unreached"))
                .or_else(|| pick("failed"))
                .unwrap_or_default();
            Ok((ok, why))
        }
        None => bail!(
            "{what} gave no status; its output:\n{}",
            text.lines()
                .rev()
                .take(15)
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect::<Vec<_>>()
                .join("\n")
        ),
    }
}

/// Prove one emitted module in `dir` (a scratch directory).
///
/// # Errors
///
/// The module cannot be written, Yosys cannot build its formal model, or
/// yosys-smtbmc gives no verdict.
pub fn prove(
    module: &str,
    verilog: &str,
    latency: u32,
    depth: u32,
    cover: bool,
    dir: &Path,
) -> anyhow::Result<Proof> {
    let t0 = Instant::now();
    let file = format!("{module}.v");
    std::fs::write(dir.join(&file), verilog).context("cannot write the module")?;
    let smt = format!("{module}.smt2");
    let ys = yosys_script(&file, module, &datapath_wires(verilog), &smt);
    let o = crate::proc::yosys_script(dir, "formal.ys", &ys, "yosys (formal model)")?;
    let text = o.text();
    if !o.status.success() {
        bail!("yosys could not build the formal model of {module}:\n{text}");
    }
    let d = depth.to_string();
    let (bmc, w1) = smtbmc(dir, &["-t", &d, &smt], "yosys-smtbmc (bounded)")?;
    let (ind, w2) = smtbmc(dir, &["-i", "-t", &d, &smt], "yosys-smtbmc (induction)")?;
    let (cov, w3) = if cover {
        let cd = (latency + 4).to_string();
        let (c, w) = smtbmc(dir, &["-c", "-t", &cd, &smt], "yosys-smtbmc (cover)")?;
        (Some(c), w)
    } else {
        (None, String::new())
    };
    let failure = [(bmc, w1), (ind, w2), (cov != Some(false), w3)]
        .into_iter()
        .find(|(ok, _)| !ok)
        .map(|(_, w)| w);
    Ok(Proof {
        module: module.to_string(),
        latency,
        bmc,
        induction: ind,
        cover: cov,
        seconds: t0.elapsed().as_secs_f64(),
        failure,
    })
}

/// A module to prove: its top's name, its Verilog (the wrapper appended
/// when the top is a wrapper) and its latency.
#[derive(Clone, Debug)]
pub struct Module {
    /// The top module's name.
    pub top: String,
    /// The Verilog text with its `ifdef FORMAL` block.
    pub text: String,
    /// The latency, cycles (the cover run's depth is this plus 4).
    pub latency: u32,
}

/// Prove `modules` with `jobs` at once, each in a scratch directory of its
/// own; the proofs in the modules' order. `done` is told each top's name
/// as its proof ends.
///
/// # Errors
///
/// No temporary directory or worker threads, or a proof's own error
/// ([`prove`]). A property that fails is a [`Proof`], not an error.
pub fn prove_all(
    modules: &[Module],
    depth: u32,
    cover: bool,
    jobs: usize,
    done: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<Vec<Proof>> {
    crate::proc::in_scratch_dirs("fxshade-formal-", jobs, modules, |m, sub| {
        let p = prove(&m.top, &m.text, m.latency, depth, cover, sub)?;
        done(&m.top);
        Ok(p)
    })
}
