//! The CORDIC angle unit (method B's per-pixel angles of N): `fxshade error
//! angles`, its sweep, its configuration errors and its operation counts.
//! Co-simulation, lint and golden vectors run with every unit (`rtl.rs`).

use crate::common::*;

fn json(args: &[&str]) -> serde_json::Value {
    let o = fxshade(args);
    assert!(o.status.success(), "{}", text(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn error_angles_is_within_a_least_significant_bit_of_atan2() {
    let j = json(&["error", "angles", "--count", "100000", "--json"]);
    for k in [
        "max_alpha_lsb",
        "max_beta_lsb",
        "max_beta_lsb_cap",
        "rms_lsb",
        "max_alpha_deg",
        "max_beta_deg",
        "max_direction_deg",
        "adder_bits",
        "flops",
        "latency",
    ] {
        assert!(j[k].is_number(), "missing {k}: {j}");
    }
    assert_eq!(j["coverage"], "random and corners");
    assert!(j["samples"].as_u64().unwrap() > 100_000);
    // Rounding to 11 bits alone costs ½ LSB; CORDIC's residual angle and the
    // truncated micro-rotations stay within another ½.
    assert!(j["max_alpha_lsb"].as_f64().unwrap() <= 1.0, "{j}");
    assert!(j["max_beta_lsb"].as_f64().unwrap() <= 1.0, "{j}");
    // Inside the polar cap β is ill-conditioned: reported, larger.
    assert!(j["max_beta_lsb_cap"].as_f64().unwrap() > j["max_beta_lsb"].as_f64().unwrap());
    // Another input format keeps its corner cases (poles, axes, seam).
    let o = json(&[
        "error",
        "angles",
        "--count",
        "1000",
        "--set",
        "angles.normal.format=I2F12",
        "--json",
    ]);
    assert!(o["samples"].as_u64().unwrap() > 1000, "{o}");
    // A narrow input format is covered code by code.
    let n = json(&[
        "error",
        "angles",
        "--set",
        "angles.normal.format=I2F4",
        "--json",
    ]);
    assert_eq!(n["coverage"], "all codes");
    assert_eq!(n["samples"], 64 * 64 * 64);
}

#[test]
fn the_sweep_marks_the_cheapest_setting_within_one_lsb_per_width() {
    let s = json(&["error", "angles", "--sweep", "--json"]);
    let points = s["points"].as_array().unwrap();
    assert_eq!(points.len(), 5 * 7 * 5, "widths × iterations × guard bits");
    for c in s["cheapest_within_1_lsb"].as_array().unwrap() {
        let k = c["angle_bits"].as_u64().unwrap();
        let i = c["point"]
            .as_u64()
            .expect("every width has a setting within 1 LSB") as usize;
        let p = &points[i];
        assert_eq!(p["angle_bits"].as_u64().unwrap(), k);
        let ok = |p: &serde_json::Value| {
            p["max_alpha_lsb"].as_f64().unwrap() <= 1.0
                && p["max_beta_lsb"].as_f64().unwrap() <= 1.0
        };
        assert!(ok(p), "{p}");
        for q in points.iter().filter(|q| q["angle_bits"] == k && ok(q)) {
            assert!(
                q["adder_bits"].as_u64() >= p["adder_bits"].as_u64(),
                "{q} vs {p}"
            );
        }
    }
    // More iterations never remove adders, and fewer than the output bits
    // cannot reach 1 LSB at 11 bits (atan(2^−i) halves per iteration).
    let few = points
        .iter()
        .find(|p| p["angle_bits"] == 11 && p["iterations"] == 8 && p["xy"] == "I4F19")
        .unwrap();
    assert!(few["max_alpha_lsb"].as_f64().unwrap() > 1.0, "{few}");
}

#[test]
fn bad_angle_settings_name_the_key() {
    for (set, key, why) in [
        ("angles.theta.overflow=\"saturate\"", "angles.theta", "wrap"),
        (
            "angles.out.format=\"U0F12\"",
            "angles.out",
            "polar.angle_bits = 11",
        ),
        ("angles.xy.format=\"U4F18\"", "angles.xy", "signed"),
        (
            "angles.gain.format=\"U0F16\"",
            "angles.gain",
            "does not fit",
        ),
        ("angles.iterations=0", "angles.iterations", ""),
    ] {
        let o = fxshade(&["config", "show", "--set", set]);
        assert_eq!(o.status.code(), Some(2), "{set}: {}", text(&o));
        let t = text(&o);
        assert!(t.contains(key) && t.contains(why), "{set}: {t}");
    }
}

/// The output format follows `polar.angle_bits` unless the user wrote one:
/// setting the output's rounding alone does not pin its format.
#[test]
fn the_output_format_follows_the_polar_angle_width() {
    let j = json(&[
        "error",
        "angles",
        "--count",
        "1000",
        "--set",
        "polar.angle_bits=10",
        "--set",
        "polar.table_bits=10",
        "--set",
        "angles.out.round=\"trunc\"",
        "--json",
    ]);
    assert_eq!(j["out"], "U0F10");
    assert_eq!(j["angle_bits"], 10);
}

#[test]
fn op_counts_are_additions_and_shifts_with_one_gain_product() {
    let j = json(&["ops", "--json"]);
    let all = j.as_array().unwrap();
    let a = all.iter().find(|x| x["unit"] == "angles").unwrap();
    // 12 iterations per angle: 3 add/sub each, and 3 for the pre-rotation;
    // 2 shifts per iteration; the gain K·y is the only product.
    assert_eq!(a["mul"], 1);
    assert_eq!(a["add"], 3 + 2 * 12 * 3);
    assert_eq!(a["shift"], 2 * 12 * 2);
    assert_eq!(a["table_read"], 0);
    assert_eq!(a["div"], 0);
    assert_eq!(a["sqrt"], 0);
    // The mapped path with CORDIC angles needs no normalizer, division or
    // square root; the conventional baseline does.
    let find = |v: &str| all.iter().find(|x| x["variant"] == v).unwrap();
    let c = find("mapped, cordic angles");
    assert_eq!((c["div"].as_u64(), c["sqrt"].as_u64()), (Some(0), Some(0)));
    let t = find("mapped, conventional TBN (baseline, no RTL)");
    assert_eq!((t["div"].as_u64(), t["sqrt"].as_u64()), (Some(2), Some(2)));
}
