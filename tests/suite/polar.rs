//! The polar transform (method B): `fxshade error polar`, `polar-frames`
//! and `ops`.

use crate::common::*;

fn json(args: &[&str]) -> serde_json::Value {
    let o = fxshade(args);
    assert!(o.status.success(), "{}", text(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn error_polar_reports_the_figures_and_covers_small_spaces() {
    let j = json(&[
        "error",
        "polar",
        "--set",
        "polar.angle_bits=10",
        "--set",
        "polar.table_bits=10",
        "--sampled",
        "--json",
    ]);
    for k in [
        "max_lsb_err",
        "rms_lsb_err",
        "max_len_dev",
        "max_angle_err_deg",
        "max_diffuse_err_levels",
        "table_size_bits",
    ] {
        assert!(j[k].is_number(), "missing {k}");
    }
    // Samples when asked for.
    assert_eq!(j["coverage"], "random");
    // 7-bit angles: every code.
    let j7 = json(&[
        "error",
        "polar",
        "--set",
        "polar.angle_bits=7",
        "--set",
        "polar.table_bits=7",
        "--json",
    ]);
    assert_eq!(j7["coverage"], "every code (exhaustive)");
    assert_eq!(j7["samples"], 65 * 128 * 65);
    // A rotation keeps |L'| near 1: within a few output LSBs.
    assert!(j["max_len_dev"].as_f64().unwrap() < 5.0 / 16384.0);
    // The quarter-wave table stores 2^t/4 + 1 entries.
    assert_eq!(j["table_size_bits"], (1024 / 4 + 1) * 16);
    // Coarser tables err more: the sweep is monotone in depth at a fixed width.
    let s = json(&["error", "polar", "--sweep", "--json"]);
    let at = |tb: u64| {
        s.as_array()
            .unwrap()
            .iter()
            .find(|r| r["table_bits"] == tb && r["table_format"] == "I2F14")
            .unwrap()["max_angle_err_deg"]
            .as_f64()
            .unwrap()
    };
    assert!(at(6) > at(8) && at(8) > at(10));
}

#[test]
fn frames_differ_where_they_should() {
    let y = json(&[
        "polar-frames",
        "--mesh",
        "sphere:32",
        "--axis",
        "y",
        "--json",
    ]);
    assert!(y["share_over_10_deg"].as_f64().unwrap() < 1e-9);
    let z = json(&[
        "polar-frames",
        "--mesh",
        "torus:32",
        "--axis",
        "z",
        "--json",
    ]);
    assert!(z["share_over_10_deg"].as_f64().unwrap() > 0.5);
    let o = fxshade(&["polar-frames", "--mesh", "cube:3"]);
    assert!(!o.status.success() && text(&o).contains("unknown mesh `cube`"));
}

#[test]
fn ops_shows_the_transform_and_the_baseline() {
    let j = json(&["ops", "--json"]);
    let r = j.as_array().unwrap();
    let p = r
        .iter()
        .find(|x| x["unit"] == "polar" && x["variant"] == "polar")
        .unwrap();
    assert_eq!(
        (
            p["mul"].as_u64(),
            p["add"].as_u64(),
            p["table_read"].as_u64()
        ),
        (Some(6), Some(3), Some(6))
    );
    assert_eq!(p["paper"]["mul"], 6);
    let b = r
        .iter()
        .find(|x| x["unit"] == "polar" && x["variant"] == "tbn_baseline")
        .unwrap();
    assert!(b["mul"].as_u64().unwrap() > 9 && b["sqrt"] == 1 && b["div"] == 1);
}

#[test]
fn bad_polar_configurations_are_clear_errors() {
    let o = fxshade(&[
        "error",
        "polar",
        "--set",
        "polar.table_bits=12",
        "--set",
        "polar.angle_bits=10",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o).contains("table_bits = 12 exceeds polar.angle_bits = 10"),
        "{}",
        text(&o)
    );
    let o = fxshade(&["error", "polar", "--set", "polar.index.overflow=saturate"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("must be \"wrap\""), "{}", text(&o));
}
