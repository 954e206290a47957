//! The interpolator (method C): `fxshade error interp` and `fxshade ops`.

use crate::common::*;

fn json(args: &[&str]) -> serde_json::Value {
    let o = fxshade(args);
    assert!(o.status.success(), "{}", text(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn error_interp_reports_ranges_and_errors() {
    let q = json(&[
        "error",
        "interp",
        "--scheme",
        "quadratic",
        "--theta",
        "0",
        "--count",
        "20000",
        "--json",
    ]);
    for k in ["d_min", "d_max", "max_rel_err", "max_angle_err_deg"] {
        assert!(q[k].is_number(), "missing {k}");
    }
    // The measured range lies in the closed-form bound and reaches its ends.
    let (lo, hi) = (
        q["d_bound"][0].as_f64().unwrap(),
        q["d_bound"][1].as_f64().unwrap(),
    );
    let (dmin, dmax) = (q["d_min"].as_f64().unwrap(), q["d_max"].as_f64().unwrap());
    assert!(dmin >= lo - 1e-12 && dmax <= hi + 1e-12);
    assert!(
        (dmin - lo).abs() < 1e-9 && (dmax - hi).abs() < 1e-9,
        "corner cases reach the bound"
    );
    // 0.8032 at Θ = 0 (closed form in the rustdoc of model/src/interp).
    assert!((lo - 0.803196).abs() < 1e-6);
    let l = json(&[
        "error", "interp", "--scheme", "linear", "--theta", "0", "--count", "20000", "--json",
    ]);
    // Quadratic interpolation narrows d, so the same normalizer errs far less.
    assert!(q["max_rel_err"].as_f64().unwrap() * 20.0 < l["max_rel_err"].as_f64().unwrap());
    // Against its own field the quadratic scheme is off by the fixed-point
    // error only; linear interpolation points elsewhere by degrees at Θ = 0.
    assert!(q["max_angle_err_deg"].as_f64().unwrap() < 0.05);
    assert!(l["max_angle_err_deg"].as_f64().unwrap() > 1.0);
    // No normalization at all: the quadratic field is within 11 % of unit length.
    let n = json(&[
        "error",
        "interp",
        "--normalizer",
        "none",
        "--theta",
        "0",
        "--count",
        "5000",
        "--json",
    ]);
    assert!((n["max_rel_err"].as_f64().unwrap() - (1.0 - lo.sqrt())).abs() < 1e-3);
}

#[test]
fn ops_lists_setup_and_pixel_counts() {
    let j = json(&["ops", "--json"]);
    let r: Vec<_> = j
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["unit"] == "interp")
        .collect();
    let find = |v: &str, s: &str| {
        r.iter()
            .find(|x| x["variant"] == v && x["stage"] == s)
            .expect("reported")
    };
    assert_eq!(find("quadratic", "pixel")["mul"], 24);
    assert_eq!(find("linear", "pixel")["mul"], 9);
    assert_eq!(find("quadratic", "setup")["sqrt"], 3);
    assert_eq!(find("quadratic", "setup")["div"], 3);
}
