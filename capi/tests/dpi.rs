//! The SystemVerilog DPI-C route: the generated package and scoreboard,
//! built by Verilator with the C ABI library, check the emitted module
//! under random valid/ready against the model, pass on the emitted RTL and
//! fail on a mutant (one coefficient bit changed).

use std::path::Path;
use std::process::Command;

use fxshade_model::rtl::dpi;
use fxshade_model::rtl::unit_model::{ConfigSource, UnitModel};

mod common;
use common::target_dir;

/// Build `<module>_dpi_tb` from `dir` (module, package, scoreboard) and
/// run it: (exit success, output).
fn build_and_run(dir: &Path, module: &str, args: &[&str]) -> (bool, String) {
    let lib = target_dir();
    let mut c = Command::new("verilator");
    c.current_dir(dir)
        .args(["--binary", "-j", "2", "-Wno-fatal", "--top-module"])
        .arg(format!("{module}_dpi_tb"))
        .args(["--Mdir", "obj", "-o", "sim"])
        // The scoreboard's speed does not matter here: build fast.
        .args(["-MAKEFLAGS", "OPT_FAST=-O0 OPT_SLOW=-O0"])
        .arg("-LDFLAGS")
        .arg(format!(
            "-L{0} -lfxshade_capi -Wl,-rpath,{0}",
            lib.display()
        ))
        .arg(format!("{module}_dpi_pkg.sv"))
        .arg(format!("{module}.v"))
        .arg(format!("{module}_dpi_tb.sv"));
    let o = c
        .output()
        .expect("verilator is installed (scripts/test installs it)");
    assert!(
        o.status.success(),
        "verilator: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let o = Command::new(dir.join("obj/sim"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    (
        o.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        ),
    )
}

fn write(dir: &Path, m: &UnitModel) {
    let module = m.module();
    std::fs::write(dir.join(format!("{module}.v")), &m.emitted.verilog).unwrap();
    std::fs::write(
        dir.join(format!("{module}_dpi_pkg.sv")),
        dpi::package(m).unwrap(),
    )
    .unwrap();
    std::fs::write(
        dir.join(format!("{module}_dpi_tb.sv")),
        dpi::scoreboard(m).unwrap(),
    )
    .unwrap();
}

fn result_line(out: &str) -> Option<(u64, u64)> {
    out.lines().find_map(|l| {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.as_slice() {
            [p, "passed,", f, "failed"] => Some((p.parse().ok()?, f.parse().ok()?)),
            _ => None,
        }
    })
}

#[test]
fn dpi_scoreboard_passes_on_the_emitted_rtl_and_fails_on_a_mutant() {
    let m = UnitModel::open("normalize", ConfigSource::Default, &[]).unwrap();
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), &m);
    let (ok, out) = build_and_run(
        dir.path(),
        "normalize",
        &["+N=20000", "+STALL=30", "+SEED=5"],
    );
    assert!(ok, "{out}");
    assert_eq!(result_line(&out), Some((20000, 0)), "{out}");

    // A mutant: the lowest bit of the first coefficient constant flipped.
    let v = &m.emitted.verilog;
    let at = v.find("localparam signed").expect("a coefficient constant");
    let line_end = at + v[at..].find(';').unwrap();
    let line = &v[at..line_end];
    let h = line.rfind('h').unwrap();
    let digits = &line[h + 1..line.len() - 1];
    let val = u64::from_str_radix(digits, 16).unwrap() ^ 1;
    let mutated_line = format!("{}{:0w$x})", &line[..h + 1], val, w = digits.len());
    let mutated = format!("{}{}{}", &v[..at], mutated_line, &v[line_end..]);
    assert_ne!(&mutated, v);
    std::fs::write(dir.path().join("normalize.v"), mutated).unwrap();
    let _ = std::fs::remove_dir_all(dir.path().join("obj"));
    let (ok, out) = build_and_run(
        dir.path(),
        "normalize",
        &["+N=20000", "+STALL=30", "+SEED=5"],
    );
    assert!(!ok, "a mutant passed: {out}");
    let (_, failed) = result_line(&out).expect("a result line");
    assert!(failed > 0, "{out}");
    assert!(out.contains("mismatch at output"), "{out}");
}

/// A pipeline top: set-up records (frame, triangle) through the set-up
/// sequencer, every output checked against the model.
#[test]
fn dpi_scoreboard_checks_a_pipeline_top_with_set_up_ports() {
    let m = UnitModel::open("pipeline", ConfigSource::Default, &[]).unwrap();
    assert!(!m.setup().is_empty());
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), &m);
    let (ok, out) = build_and_run(dir.path(), m.module(), &["+N=3000", "+STALL=20", "+SEED=3"]);
    assert!(ok, "{out}");
    assert_eq!(result_line(&out), Some((3000, 0)), "{out}");
}
