//! The normalizer (method A): coefficient search against rounding, the
//! stated error bound, and the `error normalize`, `coeffs` and `paper`
//! commands.

use std::process::Command;
use std::sync::OnceLock;

use fxshade_model::coeffs::Fit;
use fxshade_model::datapath::{Datapath, Fixed};
use fxshade_model::normalizer::{self, Interval, Method, Normalizer};
use fxshade_model::sampling::{self, Rng};
use fxshade_model::{Config, Format};
use proptest::prelude::*;

fn fxshade(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_fxshade"))
        .args(args)
        .output()
        .expect("runs")
}

fn stages() -> normalizer::Stages {
    Normalizer::stages(&Config::embedded().section())
}

#[test]
fn search_never_loses_to_rounding_and_beats_it_somewhere() {
    let mut strictly_better = Vec::new();
    for theta in [0.0, 0.5, 0.75, 0.875, 0.9375, 0.96875] {
        for method in [Method::Linear, Method::Quadratic] {
            for fmt in ["I3F15", "I3F13", "I3F11"] {
                let mut st = stages();
                st.coef = st.coef.with_format(fmt.parse::<Format>().unwrap());
                st.horner = st.horner.with_format(fmt.parse::<Format>().unwrap());
                let (_, d) =
                    normalizer::design(method, st, theta, Fit::Minimax, Interval::Triangle, true)
                        .unwrap();
                let d = d.unwrap();
                // Both as evaluated by the bit-accurate g(d) stage.
                assert!(
                    d.searched.max_rel_err_model <= d.rounded.max_rel_err_model,
                    "Θ {theta} {method:?} {fmt}: search {} > rounding {}",
                    d.searched.max_rel_err_model,
                    d.rounded.max_rel_err_model
                );
                if d.searched.max_rel_err_model < 0.8 * d.rounded.max_rel_err_model {
                    strictly_better.push((theta, method, fmt));
                }
            }
        }
    }
    // 16-bit coefficients (I3F13) on a fine mesh: rounding loses real bits.
    assert!(
        strictly_better
            .iter()
            .any(|&(t, m, f)| t >= 0.875 && m == Method::Quadratic && f == "I3F13"),
        "{strictly_better:?}"
    );
}

/// Θ, method, the normalizer, the interval's lower end, the stated bound.
type Case = (f64, Method, Normalizer, f64, f64);

/// Designs for each Θ, built once (the search takes a moment).
fn designs() -> &'static Vec<Case> {
    static D: OnceLock<Vec<Case>> = OnceLock::new();
    D.get_or_init(|| {
        let mut v = Vec::new();
        for theta in [0.0, 0.5, 0.75, 0.875, 0.96875] {
            for m in [Method::Linear, Method::Quadratic] {
                let (n, d) =
                    normalizer::design(m, stages(), theta, Fit::Minimax, Interval::Triangle, true)
                        .unwrap();
                let (lo, _) = d.unwrap().interval;
                let light = fxshade_model::lighting::Lighting::from_config(&Config::embedded());
                // The proven bound for inputs quantized from |N|² in [lo, 1].
                let bound = fxshade_model::bounds::normalize(&n, &light, lo, 1.0)
                    .unwrap()
                    .length;
                v.push((theta, m, n, lo, bound));
            }
        }
        v
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    /// The scalar fixed-point context (not the compiled path the analysis
    /// used) stays within the bound the analysis states, for random inputs
    /// whose d lies in the interval.
    #[test]
    fn output_within_the_stated_bound(which in 0usize..10, seed in any::<u64>()) {
        let (theta, _m, n, lo, bound) = &designs()[which];
        let mut rng = Rng::new(seed);
        let t = sampling::triangle_meeting(*theta, &mut rng);
        let v = sampling::lerp3(&t, rng.barycentric());
        let mut cx = Fixed::<i128>::new();
        let k = n.consts(&mut cx).unwrap();
        let inp = [0, 1, 2].map(|i| cx.constant(v[i], &n.q.normal).unwrap());
        let fin = n.q.normal.format();
        let d: f64 = inp.iter().map(|x| fin.to_f64(x.code()).powi(2)).sum();
        prop_assume!(d >= *lo && d <= 1.0);
        let out = n.eval(&mut cx, &k, inp);
        let fo = n.q.out.format();
        let len = out.iter().map(|x| fo.to_f64(x.code()).powi(2)).sum::<f64>().sqrt();
        prop_assert!((len - 1.0).abs() <= *bound, "Θ {}: |N'| = {} bound {}", theta, len, bound);
        prop_assert_eq!(cx.total_overflows(), 0);
    }
}

#[test]
fn error_normalize_json_has_the_keys_and_respects_its_bound() {
    let o = fxshade(&["error", "normalize", "--count", "20000", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for k in [
        "max_rel_err",
        "mean_rel_err",
        "rms_rel_err",
        "max_lsb_err",
        "max_diffuse_err_levels",
        "overflows",
        "samples",
    ] {
        assert!(j.get(k).is_some(), "missing {k}");
    }
    assert!(j["max_rel_err"].as_f64().unwrap() <= j["bound"].as_f64().unwrap());
    assert!(
        j["g_stage"]["samples"].as_u64().unwrap() > 10_000,
        "exhaustive over d codes"
    );
    // Edge-fitted coefficients at Θ = 0 are much worse over whole triangles
    // than on edges: the paper's interval holds on edges only.
    let o = fxshade(&[
        "error",
        "normalize",
        "--theta",
        "0",
        "--interval",
        "edge",
        "--count",
        "20000",
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        j["triangles"]["max_rel_err"].as_f64().unwrap()
            > 3.0 * j["edges"]["max_rel_err"].as_f64().unwrap()
    );
    // A bad method is a clear error naming the flag's key.
    let o = fxshade(&["error", "normalize", "--method", "cubic"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("`cubic` is not one of"));
}

#[test]
fn coeffs_json_matches_the_paper_and_quantizes() {
    let o = fxshade(&[
        "coeffs",
        "--theta",
        "0",
        "--degree",
        "1",
        "--fit",
        "nodes",
        "--interval",
        "edge",
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let c = j["coeffs"].as_array().unwrap();
    // Table 1, Θ = 0: −0.798·d + 1.778, 2.475 %.
    assert!(
        (c[0].as_f64().unwrap() + 0.798).abs() < 5e-4
            && (c[1].as_f64().unwrap() - 1.778).abs() < 5e-4
    );
    assert!((j["max_rel_err"].as_f64().unwrap() - 0.02475).abs() < 5e-6);
    assert_eq!(j["interval"][0].as_f64(), Some(0.5));
    let o = fxshade(&[
        "coeffs",
        "--theta",
        "0.96875",
        "--degree",
        "2",
        "--coef-format",
        "I3F13",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (r, s) = (
        j["rounded"]["max_rel_err"].as_f64().unwrap(),
        j["searched"]["max_rel_err"].as_f64().unwrap(),
    );
    assert!(s < r, "search {s} rounding {r}");
    let o = fxshade(&[
        "coeffs", "--lo", "0.6", "--hi", "1.0", "--degree", "2", "--json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["interval"][0].as_f64(), Some(0.6));
    let o = fxshade(&["coeffs", "--degree", "3"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("degree 3 is not modelled"));
}

#[test]
fn paper_flags_what_does_not_reproduce() {
    let o = fxshade(&["paper", "--json"]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let e = j.as_array().unwrap();
    assert_eq!(e.len(), 78);
    for x in e {
        let reproduced = x["status"] == "reproduced";
        assert!(reproduced || x["reason"].is_string(), "unflagged: {x}");
    }
}

/// Above `EXHAUSTIVE_CODES` the maximum comes from interval branch and
/// bound: the attained maximum and the bound enclose the maximum over every
/// code, enumerated here one by one through the scalar context (a wholly
/// separate path from the compiled program the bound uses).
#[test]
fn branch_and_bound_encloses_the_exhaustive_maximum() {
    for (d, g) in [("U1F27", "U2F16"), ("U1F28", "U2F22")] {
        let mut st = stages();
        st.d = st.d.with_format(d.parse::<Format>().unwrap());
        st.g = st.g.with_format(g.parse::<Format>().unwrap());
        let (n, des) = normalizer::design(
            Method::Quadratic,
            st,
            0.5,
            Fit::Minimax,
            Interval::Triangle,
            false,
        )
        .unwrap();
        let (lo, hi) = des.unwrap().interval;
        let m = normalizer::g_stage_max(&n, lo, hi, None).unwrap();
        assert!(!m.exhaustive, "{d}: more codes than EXHAUSTIVE_CODES");
        // Every code, through the compiled program in one pass (the
        // exhaustive path's own loop is what is replaced, so use run_i128
        // on all codes and the f64 error directly).
        let fd = n.q.d.format();
        let prog = n.compile_g().unwrap();
        let (c_lo, c_hi) = (
            (lo / fd.ulp()).ceil() as i128,
            (hi / fd.ulp()).floor() as i128,
        );
        let mut truth = 0.0f64;
        let mut c = c_lo;
        while c <= c_hi {
            let codes: Vec<i128> = (c..=(c + 65535).min(c_hi)).collect();
            let (out, _) = prog.run_i128(&[&codes]);
            for (&x, &y) in codes.iter().zip(&out[0]) {
                let e = (n.q.g.format().to_f64(y) * fd.to_f64(x).sqrt() - 1.0).abs();
                truth = truth.max(e);
            }
            c += 65536;
        }
        assert!(
            m.max <= truth && truth <= m.bound,
            "{d}: {} ≤ {truth} ≤ {}",
            m.max,
            m.bound
        );
        assert!(
            m.bound <= truth * (1.0 + 1.0 / 64.0) * (1.0 + 1e-9),
            "{d}: bound {} vs {truth}",
            m.bound
        );
        // Stopping early: an error above the threshold is reported at once.
        let s = normalizer::g_stage_max(&n, lo, hi, Some(truth / 2.0)).unwrap();
        assert!(s.max > truth / 2.0 && s.bound.is_infinite());
    }
}

/// One coefficient order everywhere, stated: the RTL header, the vector
/// manifest, `error normalize --json` and `coeffs --json` all give g(d)'s
/// coefficients highest power first (`a*d^2 + b*d + c`), the same values,
/// and in that order they evaluate to about 1/sqrt(d) (a closed form, not
/// the code's own order) on the default's interval.
#[test]
fn coefficients_are_highest_power_first_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v");
    let o = fxshade(&[
        "vectors",
        "normalize",
        "--count",
        "300",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    let c = &m["parameters"]["coefficients"];
    assert!(
        c["order"]
            .as_str()
            .unwrap()
            .starts_with("highest power first"),
        "{c}"
    );
    let v: Vec<f64> = c["values"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(v.len(), 3, "{c}");
    for d in [0.7f64, 0.85, 1.0] {
        let g = v[0] * d * d + v[1] * d + v[2];
        assert!((g - 1.0 / d.sqrt()).abs() < 2e-3, "g({d}) = {g}: {c}");
    }
    let header = std::fs::read_to_string(out.join("normalize.v")).unwrap();
    // The header's coefficient note, its continuation lines (`//   `, the
    // writer wraps at 100 columns) joined.
    let lines: Vec<&str> = header.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.contains("g(d) coefficients"))
        .expect("the coefficients in the header");
    let mut line = lines[at].to_string();
    for l in lines[at + 1..]
        .iter()
        .map_while(|l| l.strip_prefix("//   "))
    {
        line = format!("{line} {l}");
    }
    assert!(line.contains("highest power first"), "{line}");
    assert!(
        line.contains(&format!("a = {}, b = {}, c = {}", v[0], v[1], v[2])),
        "{line}"
    );
    let o = fxshade(&["error", "normalize", "--count", "300", "--json"]);
    let e: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let ev: Vec<f64> = e["coeffs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(ev, v, "{e}");
    assert_eq!(e["coeffs_order"], c["order"]);
    let o = fxshade(&["coeffs", "--json"]);
    let k: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(k["coeffs_order"], c["order"]);
}
