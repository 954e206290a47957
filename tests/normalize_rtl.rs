//! The normalizer's RTL against the model: co-simulation on Verilator and
//! Icarus Verilog for three configurations and both methods, the checks a
//! testbench must make (short files, mismatches), golden files, the netlist
//! operation counts, and lint. These run the real tools and never skip: a
//! missing simulator fails them (./scripts/test installs the simulators).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fxshade(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fxshade"))
        .args(args)
        .output()
        .expect("runs")
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr)
}

/// The configurations every test covers: the default, a narrow one (12-bit,
/// truncation, wrap-around) and a wide one (24-bit, half_up).
fn configs() -> Vec<Option<PathBuf>> {
    vec![
        None,
        Some(repo().join("tests/configs/narrow.toml")),
        Some(repo().join("tests/configs/wide.toml")),
    ]
}

fn check_all(sim: &str) {
    for cfg in configs() {
        for method in ["linear", "quadratic"] {
            let count = "2000";
            let set = format!("normalize.method=\"{method}\"");
            let mut args = vec![
                "rtl-check",
                "normalize",
                "--sim",
                sim,
                "--count",
                count,
                "--seed",
                "7",
                "--set",
                &set,
                "--json",
            ];
            let c;
            if let Some(p) = &cfg {
                c = p.display().to_string();
                args.extend(["--config", &c]);
            }
            let o = fxshade(&args);
            assert!(o.status.success(), "{sim} {cfg:?} {method}: {}", text(&o));
            let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            assert_eq!(j["failed"], 0, "{sim} {cfg:?} {method}");
            assert_eq!(j["passed"], 2000, "{sim} {cfg:?} {method}");
            let latency = if method == "linear" { 4 } else { 5 };
            assert_eq!(j["latency"], latency, "{sim} {cfg:?} {method}");
        }
    }
}

#[test]
fn verilator_matches_the_model_bit_for_bit() {
    check_all("verilator");
}

#[test]
fn icarus_matches_the_model_bit_for_bit() {
    check_all("icarus");
}

/// Build the testbench directly from the repository's sources and run it on
/// a vector directory with a given `+N`.
fn run_tb(sim: &str, work: &Path, vectors: &Path, n: usize) -> String {
    let rtl = repo().join("rtl");
    let files = [
        rtl.join("fxs_quant.v"),
        rtl.join("normalize.v"),
        rtl.join("tb/normalize_tb.v"),
    ];
    let inc = |p: &Path| format!("-I{}", p.display());
    match sim {
        "icarus" => {
            let vvp = work.join("tb.vvp");
            let o = Command::new("iverilog")
                .args(["-g2005", "-o"])
                .arg(&vvp)
                .arg(inc(vectors))
                .arg(inc(&rtl.join("tb")))
                .args(&files)
                .output()
                .expect("iverilog runs (install: apt-get install iverilog)");
            assert!(o.status.success(), "{}", text(&o));
            text(
                &Command::new("vvp")
                    .arg("-n")
                    .arg(&vvp)
                    .arg(format!("+N={n}"))
                    .current_dir(vectors)
                    .output()
                    .unwrap(),
            )
        }
        _ => {
            let obj = work.join("obj");
            let o = Command::new("verilator")
                .args(["--binary", "-j", "2", "--top-module", "normalize_tb"])
                .arg(inc(vectors))
                .arg(inc(&rtl.join("tb")))
                .arg("--Mdir")
                .arg(&obj)
                .args(["-o", "sim"])
                .args(&files)
                .output()
                .expect("verilator runs (install: apt-get install verilator)");
            assert!(o.status.success(), "{}", text(&o));
            text(
                &Command::new(obj.join("sim"))
                    .arg(format!("+N={n}"))
                    .current_dir(vectors)
                    .output()
                    .unwrap(),
            )
        }
    }
}

#[test]
fn testbench_rejects_short_long_and_wrong_vector_files() {
    for sim in ["icarus", "verilator"] {
        let work = tempfile::tempdir().unwrap();
        let vec_dir = work.path().join("v");
        let o = fxshade(&[
            "vectors",
            "normalize",
            "--count",
            "300",
            "--out",
            vec_dir.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        // As written: all pass.
        let out = run_tb(sim, work.path(), &vec_dir, 300);
        assert!(out.contains("300 passed, 0 failed"), "{sim}: {out}");
        // The manifest says more vectors than the files hold.
        let out = run_tb(sim, work.path(), &vec_dir, 310);
        assert!(
            out.contains("must hold exactly 310 vectors") && out.contains("0 passed, 310 failed"),
            "{sim}: {out}"
        );
        // Fewer: the files hold more than the manifest says.
        let out = run_tb(sim, work.path(), &vec_dir, 290);
        assert!(
            out.contains("must hold exactly 290 vectors"),
            "{sim}: {out}"
        );
        // A truncated expected.hex.
        let exp = vec_dir.join("expected.hex");
        let full = std::fs::read_to_string(&exp).unwrap();
        let short: String = full.lines().take(250).map(|l| format!("{l}\n")).collect();
        std::fs::write(&exp, short).unwrap();
        let out = run_tb(sim, work.path(), &vec_dir, 300);
        assert!(out.contains("0 passed, 300 failed"), "{sim}: {out}");
        // One wrong expected bit: exactly one failure, decoded.
        let mut lines: Vec<String> = full.lines().map(String::from).collect();
        let last = lines[200].pop().unwrap();
        let flipped = char::from_digit(last.to_digit(16).unwrap() ^ 1, 16).unwrap();
        lines[200].push(flipped);
        std::fs::write(&exp, lines.join("\n") + "\n").unwrap();
        let out = run_tb(sim, work.path(), &vec_dir, 300);
        assert!(
            out.contains("299 passed, 1 failed") && out.contains("mismatch at vector 200"),
            "{sim}: {out}"
        );
    }
}

#[test]
fn golden_vectors_and_params_regenerate_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("normalize");
    let o = fxshade(&[
        "vectors",
        "normalize",
        "--count",
        "256",
        "--seed",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let golden = repo().join("testvectors/normalize");
    for f in [
        "manifest.json",
        "inputs.hex",
        "expected.hex",
        "normalize_params.vh",
        "config.toml",
    ] {
        let a = std::fs::read(golden.join(f)).unwrap();
        let b = std::fs::read(out.join(f)).unwrap();
        assert!(
            a == b,
            "testvectors/normalize/{f} differs from what the model generates now"
        );
    }
    let committed = std::fs::read(repo().join("rtl/normalize_params.vh")).unwrap();
    assert!(
        committed == std::fs::read(out.join("normalize_params.vh")).unwrap(),
        "rtl/normalize_params.vh is stale"
    );
    // The same seed gives identical files; another seed does not.
    let again = dir.path().join("again");
    fxshade(&[
        "vectors",
        "normalize",
        "--count",
        "256",
        "--seed",
        "1",
        "--out",
        again.to_str().unwrap(),
    ]);
    assert_eq!(
        std::fs::read(again.join("inputs.hex")).unwrap(),
        std::fs::read(out.join("inputs.hex")).unwrap()
    );
    let other = dir.path().join("other");
    fxshade(&[
        "vectors",
        "normalize",
        "--count",
        "256",
        "--seed",
        "2",
        "--out",
        other.to_str().unwrap(),
    ]);
    assert_ne!(
        std::fs::read(other.join("inputs.hex")).unwrap(),
        std::fs::read(out.join("inputs.hex")).unwrap()
    );
    // The manifest names the count and the fields.
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["count"], 256);
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
    for cfg in configs() {
        let mut args = vec!["ops", "--rtl", "--json"];
        let c;
        if let Some(p) = &cfg {
            c = p.display().to_string();
            args.extend(["--config", &c]);
        }
        let o = fxshade(&args);
        assert!(o.status.success(), "{cfg:?}: {}", text(&o));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let rtl = j["rtl"].as_array().unwrap();
        assert_eq!(rtl.len(), 2);
        for r in rtl {
            assert_eq!(r["agree"], true, "{r}");
            assert_eq!(
                r["netlist_mul"],
                if r["variant"] == "linear" { 7 } else { 8 }
            );
        }
    }
}

#[test]
fn rtl_is_lint_clean_for_every_configuration() {
    let dir = tempfile::tempdir().unwrap();
    for (i, cfg) in configs().into_iter().enumerate() {
        for method in ["linear", "quadratic"] {
            let out = dir.path().join(format!("{i}-{method}"));
            let set = format!("normalize.method=\"{method}\"");
            let mut args = vec![
                "vectors",
                "normalize",
                "--count",
                "200",
                "--set",
                &set,
                "--out",
                out.to_str().unwrap(),
            ];
            let c;
            if let Some(p) = &cfg {
                c = p.display().to_string();
                args.extend(["--config", &c]);
            }
            assert!(fxshade(&args).status.success());
            let o = Command::new("verilator")
                .args(["--lint-only", "-Wall"])
                .arg(format!("-I{}", out.display()))
                .arg(repo().join("rtl/fxs_quant.v"))
                .arg(repo().join("rtl/normalize.v"))
                .output()
                .expect("verilator runs");
            assert!(
                o.status.success() && text(&o).trim().is_empty(),
                "{cfg:?} {method}: {}",
                text(&o)
            );
        }
    }
    // Each design file alone, as committed (the default header beside it).
    for f in ["fxs_quant.v", "normalize.v"] {
        let o = Command::new("verilator")
            .args(["--lint-only", "-Wall"])
            .arg(format!("-I{}", repo().join("rtl").display()))
            .arg(repo().join("rtl").join(f))
            .output()
            .unwrap();
        assert!(
            o.status.success() && text(&o).trim().is_empty(),
            "{f}: {}",
            text(&o)
        );
    }
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
