//! The interpolator's RTL against the model: co-simulation on Verilator and
//! Icarus Verilog for three configurations and both schemes, testbench file
//! checks, golden files and lint (the netlist check covers every unit:
//! tests/normalize_rtl.rs). Real tools, never skipped.

mod common;
use common::*;

const VARIANTS: &[(&str, &str, u64)] = &[
    ("linear", "interp.scheme=\"linear\"", 3),
    ("quadratic", "interp.scheme=\"quadratic\"", 3),
];

#[test]
fn verilator_matches_the_model_bit_for_bit() {
    check_all("interp", "verilator", VARIANTS);
}

#[test]
fn icarus_matches_the_model_bit_for_bit() {
    check_all("interp", "icarus", VARIANTS);
}

#[test]
fn testbench_rejects_short_long_and_wrong_vector_files() {
    testbench_checks("interp");
}

#[test]
fn golden_vectors_and_params_regenerate_byte_for_byte() {
    golden_checks("interp");
}

#[test]
fn rtl_is_lint_clean_for_every_configuration() {
    lint_checks("interp", VARIANTS);
}
