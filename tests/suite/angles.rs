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
    let j = json(&[
        "error",
        "angles",
        "--count",
        "100000",
        "--sampled",
        "--json",
    ]);
    assert!(j.get("beta_every_code").is_none(), "--sampled skips it");
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
        "--sampled",
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

/// β over every `(x, z)` code pair covers half the plane (`x ≥ 0`): a pair
/// `(−x, −z)` meets the same CORDIC core input and an angle half a turn
/// away. Checked here on 10-bit normals against both halves enumerated
/// (with the same length filter), through the model's compiled unit.
#[test]
fn beta_over_every_code_pair_is_the_maximum_over_both_halves() {
    let j = json(&[
        "error",
        "angles",
        "--count",
        "1000",
        "--set",
        "angles.normal.format=I2F8",
        "--json",
    ]);
    let b = &j["beta_every_code"];
    let (r_lo, r_hi) = (
        b["r_range"][0].as_f64().unwrap(),
        b["r_range"][1].as_f64().unwrap(),
    );
    let mut cfg = fxshade_model::Config::embedded();
    cfg.apply_override("angles.normal.format=I2F8").unwrap();
    let a = fxshade_model::angles::Angles::of(&cfg).unwrap();
    let tr = a.trace().unwrap();
    let beta = tr
        .output_ports()
        .iter()
        .find(|p| p.name == "beta")
        .unwrap()
        .value;
    let prog = fxshade_model::datapath::Compiled::compile(&tr, &[beta]).unwrap();
    let (mut xs, mut zs) = (Vec::new(), Vec::new());
    for x in -512i128..512 {
        for z in -512i128..512 {
            let r = ((x * x + z * z) as f64).sqrt() / 256.0;
            if r >= r_lo && r <= r_hi {
                xs.push(x);
                zs.push(z);
            }
        }
    }
    let ys = vec![0i128; xs.len()];
    let (out, _) = prog.run_i128(&[&xs, &ys, &zs]);
    let turn = 2048.0;
    let mut worst: f64 = 0.0;
    for i in 0..xs.len() {
        let exact = (xs[i] as f64).atan2(zs[i] as f64) / std::f64::consts::TAU;
        let e = ((out[0][i] as f64 / turn - exact + 0.5).rem_euclid(1.0) - 0.5).abs() * turn;
        worst = worst.max(e);
    }
    assert_eq!(b["covered"].as_u64().unwrap(), xs.len() as u64);
    assert!(
        (b["max_beta_lsb"].as_f64().unwrap() - worst).abs() < 1e-9,
        "half plane {} against both halves {worst}",
        b["max_beta_lsb"]
    );
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
        "--sampled",
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
