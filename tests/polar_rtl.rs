//! The polar transform's RTL against the model: co-simulation on Verilator
//! and Icarus Verilog for three configurations (10-bit angles and
//! quarter-wave tables by default, 8 → 6 bits truncating and wrapping, 14 →
//! 12 bits half_up with full tables) and both table organisations,
//! testbench file checks, golden files and lint. Real tools, never skipped.

mod common;
use common::*;

const VARIANTS: &[(&str, &str, u64)] = &[
    ("quarter", "polar.organisation=\"quarter\"", 4),
    ("full", "polar.organisation=\"full\"", 4),
];

#[test]
fn verilator_matches_the_model_bit_for_bit() {
    check_all("polar", "verilator", VARIANTS);
}

#[test]
fn icarus_matches_the_model_bit_for_bit() {
    check_all("polar", "icarus", VARIANTS);
}

#[test]
fn testbench_rejects_short_long_and_wrong_vector_files() {
    testbench_checks("polar");
}

#[test]
fn golden_vectors_and_params_regenerate_byte_for_byte() {
    golden_checks("polar");
}

#[test]
fn rtl_is_lint_clean_for_every_configuration() {
    lint_checks("polar", VARIANTS);
    let o = std::process::Command::new("verilator")
        .args(["--lint-only", "-Wall"])
        .arg(repo().join("rtl/fxs_sincos_rom.v"))
        .output()
        .unwrap();
    assert!(
        o.status.success() && text(&o).trim().is_empty(),
        "{}",
        text(&o)
    );
}
