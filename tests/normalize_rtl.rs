//! The normalizer's RTL against the model: co-simulation on Verilator and
//! Icarus Verilog for three configurations and both methods, the checks a
//! testbench must make (short files, mismatches), golden files, the netlist
//! operation counts, and lint. These run the real tools and never skip: a
//! missing simulator fails them (./scripts/test installs the simulators).

mod common;
use common::*;

const VARIANTS: &[(&str, &str, u64)] = &[
    ("linear", "normalize.method=\"linear\"", 4),
    ("quadratic", "normalize.method=\"quadratic\"", 5),
];

#[test]
fn verilator_matches_the_model_bit_for_bit() {
    check_all("normalize", "verilator", VARIANTS);
}

#[test]
fn icarus_matches_the_model_bit_for_bit() {
    check_all("normalize", "icarus", VARIANTS);
}

#[test]
fn testbench_rejects_short_long_and_wrong_vector_files() {
    testbench_checks("normalize");
}

#[test]
fn golden_vectors_and_params_regenerate_byte_for_byte() {
    golden_checks("normalize");
    let m: serde_json::Value = serde_json::from_slice(
        &std::fs::read(repo().join("testvectors/normalize/manifest.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(m["inputs"]["fields"][0]["name"], "nx");
    assert_eq!(m["expected"]["width"], 4 + 3 * 16);
}

#[test]
fn vectors_refuse_bad_requests_without_leaving_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v");
    let o = fxshade(&[
        "vectors",
        "normalize",
        "--count",
        "10",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("corner cases"), "{}", text(&o));
    assert!(!out.exists());
    let o = fxshade(&[
        "vectors",
        "normalize",
        "--set",
        "normalize.method=\"exact\"",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        text(&o).contains("the RTL implements linear and quadratic only"),
        "{}",
        text(&o)
    );
    assert!(!out.exists());
    let o = fxshade(&["rtl-check", "polarr"]);
    assert!(
        text(&o).contains("no RTL for unit `polarr`"),
        "{}",
        text(&o)
    );
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "nothing half-written"
    );
}

#[test]
fn netlist_operation_counts_agree_with_the_model() {
    netlist_checks();
}

#[test]
fn rtl_is_lint_clean_for_every_configuration() {
    lint_checks("normalize", VARIANTS);
    for f in ["rtl/fxs_quant.v", "rtl/fxs_pipe_ctrl.v"] {
        let o = std::process::Command::new("verilator")
            .args(["--lint-only", "-Wall"])
            .arg(repo().join(f))
            .output()
            .unwrap();
        assert!(
            o.status.success() && text(&o).trim().is_empty(),
            "{f}: {}",
            text(&o)
        );
    }
    let o = std::process::Command::new("verilator")
        .args(["--lint-only", "-Wall"])
        .arg(repo().join("rtl/fxs_quant.v"))
        .output()
        .unwrap();
    assert!(
        o.status.success() && text(&o).trim().is_empty(),
        "{}",
        text(&o)
    );
}

#[test]
fn trace_writes_a_waveform() {
    let dir = tempfile::tempdir().unwrap();
    for (sim, ext) in [("icarus", "vcd"), ("verilator", "fst")] {
        let w = dir.path().join(format!("wave.{ext}"));
        let o = fxshade(&[
            "rtl-check",
            "normalize",
            "--sim",
            sim,
            "--count",
            "200",
            "--trace",
            w.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{sim}: {}", text(&o));
        assert!(
            std::fs::metadata(&w)
                .map(|m| m.len() > 1000)
                .unwrap_or(false),
            "{sim}: no waveform"
        );
    }
}
