//! A unit's gate-level ECP5 netlist, written for co-simulation: the checks
//! that the flow `fxshade synth --target ecp5` places (Yosys's mapping,
//! then [`crate::dsp_pack`]) still computes what the model computes.
//!
//! The netlist is the one placed: `fxshade synth` keeps the unit a module
//! of its own inside its harness (`keep_hierarchy`), packs that module's
//! registers into the MULT18X18D blocks and hands the JSON to nextpnr; this
//! module writes the unit's module of that same JSON back as Verilog (the
//! harness is not part of it, so the generated testbench drives it as it
//! drives the emitted RTL). Beside it go the simulation models of its cells:
//! Yosys's own (`cells_sim.v` of its ECP5 library: LUT4, CCU2C, PFUMX,
//! L6MUX21, TRELLIS_FF, TRELLIS_DPR16X4 and the others, only the modules
//! the netlist instantiates) and fxshade's models of MULT18X18D and DP16KD
//! (`rtl/sim/`; Yosys ships the first as a black box and the second with
//! its parameters but no behaviour).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context};
use fxshade_model::rtl::Emitted;

/// fxshade's behavioural models of the ECP5 cells Yosys ships without
/// behaviour (MULT18X18D only as a black box; DP16KD with its parameters
/// only): cell type and model.
pub const MODELS: [(&str, &str); 2] = [
    ("MULT18X18D", include_str!("../../rtl/sim/MULT18X18D.v")),
    ("DP16KD", include_str!("../../rtl/sim/DP16KD.v")),
];

/// The file of Yosys's cell models beside a netlist [`write`] wrote: a
/// design that includes it is a gate-level netlist.
pub const CELLS_FILE: &str = "fxs_ecp5_cells.v";

/// What [`write`] wrote.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Written {
    /// The netlist, `<module>.v`.
    pub netlist: PathBuf,
    /// The cell models beside it.
    pub models: Vec<PathBuf>,
    /// The registers packed into the blocks (None: `--no-dsp-pack`).
    pub packed: Option<crate::dsp_pack::PackStats>,
    /// The netlist's cells by type.
    pub cells: Vec<(String, u64)>,
}

/// Yosys's data directory, where its cell libraries are: where Yosys
/// itself looks (`share/yosys` beside its binary's directory, or `share`
/// in it), else what `yosys-config --datdir` says.
fn yosys_datdir() -> anyhow::Result<PathBuf> {
    let has_lib = |d: &Path| d.join("ecp5").join("cells_sim.v").is_file();
    let mut tried = Vec::new();
    let path = &crate::settings::get().path;
    if let Some(bin) = std::env::split_paths(path)
        .map(|d| d.join("yosys"))
        .find(|p| p.is_file())
    {
        let bin = std::fs::canonicalize(&bin).unwrap_or(bin);
        if let Some(dir) = bin.parent() {
            for d in [dir.join("../share/yosys"), dir.join("share")] {
                if has_lib(&d) {
                    return Ok(d);
                }
                tried.push(d.display().to_string());
            }
        }
    }
    if let Ok(Some(o)) = crate::proc::probe("yosys-config", "--datdir") {
        let d = PathBuf::from(o.stdout.trim());
        if o.status.success() && has_lib(&d) {
            return Ok(d);
        }
        tried.push(d.display().to_string());
    }
    bail!(
        "Yosys's ECP5 cell library (ecp5/cells_sim.v) is in none of {}: reinstall yosys (`sudo apt-get install --reinstall yosys`)",
        tried.join(", ")
    )
}

/// The modules of a Verilog library text, by name: each from its
/// `module` line to its `endmodule`.
fn library_modules(text: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut cur: Option<(String, String)> = None;
    for line in text.lines() {
        let t = line.trim_start();
        if cur.is_none() {
            if let Some(rest) = t.strip_prefix("module ") {
                let name: String = rest
                    .trim_start()
                    .chars()
                    .take_while(|c| {
                        c.is_ascii_alphanumeric() || *c == '_' || *c == '\\' || *c == '$'
                    })
                    .collect();
                cur = Some((name, String::new()));
            }
        }
        if let Some((_, body)) = cur.as_mut() {
            body.push_str(line);
            body.push('\n');
            if t.starts_with("endmodule") {
                out.push(cur.take().expect("in a module"));
            }
        }
    }
    out
}

/// The identifiers of a text.
fn words(text: &str) -> impl Iterator<Item = &str> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '$'))
        .filter(|w| !w.is_empty())
}

fn run(cmd: &mut Command, dir: &Path, what: &str) -> anyhow::Result<()> {
    let log = dir.join(format!("{what}.log"));
    crate::synth::run_logged(cmd.current_dir(dir), &log, what).map(|_| ())
}

/// Write the unit's module of the ECP5 netlist `placed` (the harness
/// netlist [`crate::synth`] hands to nextpnr, the unit a module of
/// its own, registers packed as `packed` says) and its cell models into
/// `out` (which must exist); `work` is a scratch directory for Yosys's
/// files and logs. Nothing is written into `out` until every file's text
/// is ready, and each file is replaced atomically.
///
/// # Errors
///
/// Yosys or its cell library is missing, the placed JSON has no module of the unit, or Yosys
/// cannot write the netlist.
pub fn write(
    e: &Emitted,
    placed: &Path,
    packed: Option<crate::dsp_pack::PackStats>,
    work: &Path,
    out: &Path,
) -> anyhow::Result<Written> {
    crate::rtl_flow::require_tool("yosys", "yosys")?;
    let datdir = yosys_datdir()?;
    let m = &e.module;
    let text = std::fs::read(placed)
        .with_context(|| format!("cannot read the placed netlist {}", placed.display()))?;
    let netlist: serde_json::Value =
        serde_json::from_slice(&text).context("the placed netlist is not JSON")?;
    if !crate::dsp_pack::has_body(&netlist, m) {
        bail!(
            "the placed netlist {} holds no module {m} of its own",
            placed.display()
        );
    }
    let cells = crate::dsp_pack::cell_counts(&netlist, m);
    std::fs::write(work.join("placed.json"), &text)?;
    std::fs::write(
        work.join("write.ys"),
        format!(
            "read_json placed.json\nhierarchy -top {m}\nwrite_verilog -noattr -noexpr netlist.v\n"
        ),
    )?;
    run(
        Command::new("yosys").args(["-q", "-s", "write.ys"]),
        work,
        "yosys_write",
    )?;
    let pack = packed.is_some();
    let body = std::fs::read_to_string(work.join("netlist.v"))
        .context("yosys wrote no Verilog netlist")?;
    let netlist_path = out.join(format!("{m}.v"));
    let pipelining = match e.pipelining {
        fxshade_model::rtl::timing::Pipelining::Compact => "compact pipelining".to_string(),
        fxshade_model::rtl::timing::Pipelining::Target { target, clock_ns } => {
            format!("pipelined for {target} at {clock_ns} ns")
        }
    };
    let header = format!(
        "// Gate-level ECP5 netlist of `{m}` ({pipelining}, latency {}),\n\
         // written by `fxshade synth --target ecp5 --netlist`: Yosys's synth_ecp5\n\
         // {},\n\
         // the unit's module of the netlist placed in the synthesis harness.\n\
         // Simulate it with the cell models beside it.\n",
        e.latency,
        if pack {
            "then fxshade's register packing into MULT18X18D"
        } else {
            "(no register packing)"
        }
    );
    let netlist_text = header + &body;
    // The cell models the netlist needs.
    let types: BTreeSet<&str> = cells.iter().map(|(t, _)| t.as_str()).collect();
    let lib = std::fs::read_to_string(datdir.join("ecp5").join("cells_sim.v"))
        .context("cannot read Yosys's ECP5 cells_sim.v")?;
    let mut text = format!(
        "// Simulation models of the ECP5 cells `{m}.v` instantiates, taken\n\
         // from Yosys's {}.\n`default_nettype wire\n\n",
        datdir.join("ecp5").join("cells_sim.v").display()
    );
    // The modules the netlist instantiates, and those they instantiate
    // (CCU2C is built of LUT2s), in the library's order.
    let lib = library_modules(&lib);
    let mut found: BTreeSet<String> = BTreeSet::new();
    let ours = |t: &str| MODELS.iter().any(|(n, _)| *n == t);
    let mut want: BTreeSet<String> = types
        .iter()
        .filter(|t| !ours(t))
        .map(|t| t.to_string())
        .collect();
    while let Some(next) = want.iter().find(|w| !found.contains(*w)).cloned() {
        found.insert(next.clone());
        if let Some((_, body)) = lib.iter().find(|(n, _)| *n == next) {
            for (n, _) in &lib {
                if !found.contains(n) && !ours(n) && words(body).any(|w| w == n) {
                    want.insert(n.clone());
                }
            }
        }
    }
    for (name, body) in &lib {
        if found.contains(name) {
            text.push_str(body);
            text.push('\n');
        }
    }
    found.retain(|n| lib.iter().any(|(l, _)| l == n));
    let ours_used: Vec<(&str, &str)> = MODELS
        .into_iter()
        .filter(|(name, _)| types.contains(name))
        .collect();
    found.extend(ours_used.iter().map(|(name, _)| name.to_string()));
    let missing: Vec<&str> = types
        .iter()
        .filter(|t| !found.contains(**t))
        .copied()
        .collect();
    if !missing.is_empty() {
        bail!(
            "no simulation model for the cell type{} {} of the netlist (neither in Yosys's ecp5/cells_sim.v nor fxshade's)",
            if missing.len() == 1 { "" } else { "s" },
            missing.join(", ")
        );
    }
    let mut models = vec![out.join(CELLS_FILE)];
    fxshade_model::files::write_atomic(&models[0], text.as_bytes())?;
    for (name, model) in ours_used {
        let p = out.join(format!("{name}.v"));
        fxshade_model::files::write_atomic(&p, model.as_bytes())?;
        models.push(p);
    }
    fxshade_model::files::write_atomic(&netlist_path, netlist_text.as_bytes())?;
    Ok(Written {
        netlist: netlist_path,
        models,
        packed,
        cells,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn library_modules_are_cut_at_module_and_endmodule() {
        let lib = "// c\nmodule A(input x);\nendmodule\n`ifdef Y\n(* a *)\n`endif\nmodule B_2 #(parameter P = 1) (output y);\n  assign y = 1;\nendmodule\n";
        let m = library_modules(lib);
        assert_eq!(m.len(), 2);
        assert_eq!(m[0].0, "A");
        assert_eq!(m[0].1, "module A(input x);\nendmodule\n");
        assert_eq!(m[1].0, "B_2");
        assert!(m[1].1.ends_with("endmodule\n"));
    }
}
