//! Packaged RTL a team integrates: AXI4-Stream wrappers (lint, slang,
//! co-simulation through the wrapper on both simulators, the formal proof
//! of the AXI4-Stream master rules, which a broken wrapper fails) and
//! FuseSoC cores (the `sim` target passes on the emitted RTL and reports
//! failures on a mutant; the `lint` target passes).

use std::process::Command;

use crate::common::*;

#[test]
#[ignore = "full tier: ./scripts/test --full"]
fn axis_wrappers_lint_cosimulate_and_prove() {
    let dir = tempfile::tempdir().unwrap();
    let o = fxshade(&[
        "rtl",
        "all",
        "--wrap",
        "axis",
        "--out",
        dir.path().to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let mut n = 0;
    for m in j.as_array().unwrap() {
        let module = m["module"].as_str().unwrap();
        // The layout is in the JSON: every field of the module is placed.
        let streams = m["axis"].as_array().expect("the streams' layout");
        let placed: usize = streams
            .iter()
            .map(|s| s["fields"].as_array().unwrap().len())
            .sum();
        let fields = m["inputs"].as_u64().unwrap() + m["outputs"].as_u64().unwrap();
        assert_eq!(placed as u64, fields, "{module}");
        for s in streams {
            assert_eq!(s["tdata_width"].as_u64().unwrap() % 8, 0, "{module}");
        }
        let files = [
            dir.path().join(format!("{module}.v")),
            dir.path().join(format!("{module}_axis.v")),
        ];
        let w = std::fs::read_to_string(&files[1]).unwrap();
        assert!(
            w.is_ascii() && w.lines().all(|l| l.len() <= 100),
            "{module}"
        );
        let o = Command::new("verilator")
            .args(["--lint-only", "-Wall", "--top-module"])
            .arg(format!("{module}_axis"))
            .args(&files)
            .output()
            .expect("verilator runs");
        assert!(
            o.status.success() && text(&o).trim().is_empty(),
            "verilator {module}_axis: {}",
            text(&o)
        );
        let o = Command::new(repo().join("scripts/slang-check"))
            .args(&files)
            .output()
            .expect("scripts/slang-check runs");
        assert!(
            o.status.success() && text(&o).contains("0 errors, 0 warnings"),
            "slang {module}_axis: {}",
            text(&o)
        );
        n += 1;
    }
    assert_eq!(n, 9);
    // Co-simulation through the wrapper: a unit and a top with set-up
    // streams, both simulators.
    for unit in ["normalize", "pipeline"] {
        for sim in ["verilator", "icarus"] {
            let o = fxshade_quick(&[
                "rtl-check",
                unit,
                "--wrap",
                "axis",
                "--sim",
                sim,
                "--count",
                "2000",
                "--json",
            ]);
            assert!(o.status.success(), "{unit} {sim}: {}", text(&o));
            let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            let r = if r.is_array() { r[0].clone() } else { r };
            assert_eq!(
                (r["passed"].as_u64(), r["failed"].as_u64()),
                (Some(2000), Some(0)),
                "{r}"
            );
            assert!(
                r["design_origin"].as_str().unwrap().contains("AXI4-Stream"),
                "{r}"
            );
        }
    }
    // The proof: every wrapper with its module.
    let o = fxshade(&["formal", "all", "--wrap", "axis", "--json"]);
    assert!(o.status.success(), "{}", text(&o));
    let proofs: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(proofs["ok"], true, "{proofs}");
    let proofs = proofs["modules"].as_array().unwrap();
    assert_eq!(proofs.len(), 9);
    for p in proofs {
        assert!(p["module"].as_str().unwrap().ends_with("_axis"), "{p}");
        assert_eq!(
            (p["bmc"].as_bool(), p["induction"].as_bool()),
            (Some(true), Some(true)),
            "{p}"
        );
    }
    // A design directory with its own wrapper (here the emitted one) is
    // co-simulated with it, not with a second copy.
    let o = fxshade_quick(&[
        "rtl-check",
        "normalize",
        "--wrap",
        "axis",
        "--sim",
        "icarus",
        "--count",
        "300",
        "--rtl-dir",
        dir.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    // The property has teeth: a wrapper of --rtl-dir whose tdata follows
    // tready while stalled fails the proof.
    let own = tempfile::tempdir().unwrap();
    std::fs::copy(
        dir.path().join("normalize.v"),
        own.path().join("normalize.v"),
    )
    .unwrap();
    let w = std::fs::read_to_string(dir.path().join("normalize_axis.v")).unwrap();
    let broken = w.replacen(
        "$unsigned(out_x_w),",
        "$unsigned(out_x_w) ^ {16{m_axis_tready}},",
        1,
    );
    assert_ne!(broken, w);
    std::fs::write(own.path().join("normalize_axis.v"), broken).unwrap();
    let o = fxshade(&[
        "formal",
        "normalize",
        "--wrap",
        "axis",
        "--rtl-dir",
        own.path().to_str().unwrap(),
    ]);
    assert!(
        !o.status.success(),
        "a broken wrapper was proved: {}",
        text(&o)
    );
    assert!(text(&o).contains("normalize_axis"), "{}", text(&o));
}

fn fusesoc(
    root: &std::path::Path,
    cwd: &std::path::Path,
    target: &str,
    core: &str,
) -> (bool, String) {
    let o = Command::new("fusesoc")
        .current_dir(cwd)
        .arg("--cores-root")
        .arg(root)
        .args(["run", "--target", target, core])
        .output()
        .expect("fusesoc runs (scripts/test installs it: pip install fusesoc)");
    (o.status.success(), text(&o))
}

#[test]
fn fusesoc_core_simulates_and_lints() {
    let dir = tempfile::tempdir().unwrap();
    let vec = dir.path().join("vec");
    let o = fxshade(&[
        "vectors",
        "normalize",
        "--count",
        "600",
        "--core",
        "--out",
        vec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let core = std::fs::read_to_string(vec.join("normalize.core")).unwrap();
    let name = core
        .lines()
        .find_map(|l| l.strip_prefix("name: "))
        .unwrap()
        .trim_matches('"')
        .to_string();
    // fxshade:<unit>:<variant>_<the configuration hash in the header>:<version>.
    let v = std::fs::read_to_string(vec.join("normalize.v")).unwrap();
    let hash = v.split("(hash ").nth(1).unwrap().split(')').next().unwrap();
    assert_eq!(
        name,
        format!(
            "fxshade:normalize:quadratic_{hash}:{}",
            env!("CARGO_PKG_VERSION")
        )
    );
    let (ok, out) = fusesoc(&vec, dir.path(), "sim", &name);
    assert!(ok && out.contains("600 passed, 0 failed"), "{out}");
    // The lint target, from a root holding every module's core (`rtl all
    // --core`: nine cores side by side).
    let all = dir.path().join("all");
    let o = fxshade(&["rtl", "all", "--core", "--out", all.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let (ok, out) = fusesoc(&all, dir.path(), "lint", &name);
    assert!(ok, "{out}");
    // A mutant: one coefficient bit flipped; the log says how many failed.
    let at = v.find("localparam signed").unwrap();
    let end = at + v[at..].find(';').unwrap();
    let h = v[..end].rfind('h').unwrap();
    let digits = &v[h + 1..end - 1];
    let flipped = format!(
        "{:0w$x}",
        u64::from_str_radix(digits, 16).unwrap() ^ 1,
        w = digits.len()
    );
    std::fs::write(
        vec.join("normalize.v"),
        format!("{}{flipped}{}", &v[..h + 1], &v[end - 1..]),
    )
    .unwrap();
    let (ok, out) = fusesoc(&vec, dir.path(), "sim", &name);
    assert!(!ok, "a failing run exits non-zero: {out}");
    let line = out
        .lines()
        .find(|l| l.ends_with(" failed") && l.contains(" passed, "))
        .unwrap_or_else(|| panic!("no verdict line: {out}"));
    let failed: u64 = line.split_whitespace().nth(2).unwrap().parse().unwrap();
    assert!(failed > 0, "{out}");
    // A sharded vector set is not a whole core.
    let o = fxshade(&[
        "vectors",
        "normalize",
        "--count",
        "600",
        "--core",
        "--shard",
        "0/2",
        "--out",
        dir.path().join("s").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("--core"), "{}", text(&o));
}
