//! The pipeline top's RTL against the model: co-simulation of both paths on
//! Verilator and Icarus Verilog for the three configurations, testbench
//! file checks, golden files and lint. Real tools, never skipped.

mod common;
use common::*;

const VARIANTS: &[(&str, &str, u64)] = &[
    ("smooth", "pipeline.path=\"smooth\"", 0),
    ("mapped", "pipeline.path=\"mapped\"", 0),
];

/// Latency of each path per configuration, from the units' latencies:
/// smooth = interp 3 + normalize (5 quadratic) + lighting (NB + 2),
/// mapped = angle_interp 2 + polar 4 + lighting (NB + 2), NB the bit length
/// of the shininess (16 → 5, 5 → 3, 40 → 6).
const LATENCY: [(u64, u64); 3] = [(15, 13), (13, 11), (16, 14)];

fn check(sim: &str) {
    for (cfg, lat) in configs().into_iter().zip(LATENCY) {
        for (&(name, set, _), want) in VARIANTS.iter().zip([lat.0, lat.1]) {
            let mut args = vec![
                "rtl-check",
                "pipeline",
                "--sim",
                sim,
                "--count",
                "1500",
                "--seed",
                "7",
                "--set",
                set,
                "--json",
            ];
            if let Some(c) = &cfg {
                args.extend(["--config", c.as_str()]);
            }
            let o = fxshade(&args);
            assert!(o.status.success(), "{sim} {cfg:?} {name}: {}", text(&o));
            let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            assert_eq!(j["failed"], 0, "{sim} {cfg:?} {name}");
            assert_eq!(j["passed"], 1500, "{sim} {cfg:?} {name}");
            assert_eq!(j["latency"], want, "{sim} {cfg:?} {name}");
        }
    }
}

#[test]
fn verilator_matches_the_model_bit_for_bit() {
    check("verilator");
}

#[test]
fn icarus_matches_the_model_bit_for_bit() {
    check("icarus");
}

#[test]
fn linear_normalizer_in_the_pipeline_matches_too() {
    for sim in ["verilator", "icarus"] {
        let o = fxshade(&[
            "rtl-check",
            "pipeline",
            "--sim",
            sim,
            "--count",
            "1000",
            "--set",
            "normalize.method=\"linear\"",
            "--json",
        ]);
        assert!(o.status.success(), "{sim}: {}", text(&o));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(
            (j["passed"].as_u64(), j["failed"].as_u64()),
            (Some(1000), Some(0))
        );
        assert_eq!(j["latency"], 14, "interp 3 + normalize 4 + lighting 7");
    }
}

#[test]
fn testbench_rejects_short_long_and_wrong_vector_files() {
    testbench_checks("pipeline");
}

#[test]
fn golden_vectors_and_params_regenerate_byte_for_byte() {
    golden_checks("pipeline");
    // The committed lighting header is the pipeline's.
    let a = std::fs::read(repo().join("rtl/lighting_params.vh")).unwrap();
    let b = std::fs::read(repo().join("testvectors/pipeline/lighting_params.vh")).unwrap();
    assert!(a == b, "rtl/lighting_params.vh is stale");
}

#[test]
fn rtl_is_lint_clean_for_every_configuration() {
    lint_checks("pipeline", VARIANTS);
    for m in ["lighting", "angle_interp", "fxs_side_delay"] {
        let o = std::process::Command::new("verilator")
            .args(["--lint-only", "-Wall"])
            .arg(format!("-I{}", repo().join("rtl").display()))
            .arg(repo().join(format!("rtl/{m}.v")))
            .output()
            .unwrap();
        assert!(
            o.status.success() && text(&o).trim().is_empty(),
            "{m}: {}",
            text(&o)
        );
    }
}
