//! Helpers shared by the integration tests: running the CLI, and the RTL
//! checks every unit with RTL gets (co-simulation across configurations,
//! testbench file checks, golden files, lint).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Run the `fxshade` binary.
pub fn fxshade(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fxshade"))
        .args(args)
        .output()
        .expect("runs")
}

/// [`fxshade`] with a quick killer search (`FXSHADE_SEARCH=quick`: a
/// sixteenth of the budgets, 10 ms proofs, no random rows), for checks of
/// RTL against model over many configurations.
pub fn fxshade_quick(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fxshade"))
        .args(args)
        .env("FXSHADE_SEARCH", "quick")
        .output()
        .expect("runs")
}

/// The repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// stdout and stderr together.
pub fn text(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr)
}

/// `args` plus `--config p` when a configuration file is given.
fn with_config<'a>(mut args: Vec<&'a str>, cfg: &'a Option<String>) -> Vec<&'a str> {
    if let Some(c) = cfg {
        args.extend(["--config", c.as_str()]);
    }
    args
}

/// The default configuration and the files under `tests/configs/`.
pub fn configs() -> Vec<Option<String>> {
    vec![
        None,
        Some(
            repo()
                .join("tests/configs/narrow.toml")
                .display()
                .to_string(),
        ),
        Some(repo().join("tests/configs/wide.toml").display().to_string()),
    ]
}

/// A variant's selector (`a=1; b="x"`) as `--set` flags.
pub fn sets(set: &str) -> Vec<&str> {
    set.split(';')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .flat_map(|s| ["--set", s])
        .collect()
}

/// Co-simulate `unit` on `sim` for every configuration and every variant
/// (`variants`: name, `--set` override): all vectors pass, and the latency
/// the testbench measures is the one the module's header declares. The
/// vectors come from a quick killer search ([`fxshade_quick`]): this checks
/// the RTL against the model; the mutation test scores the full search.
pub fn check_all(unit: &str, sim: &str, variants: &[(&str, &str)], cfgs: &[Option<String>]) {
    for cfg in cfgs {
        for &(name, set) in variants {
            // `rtl-check` of this unit, variant and configuration.
            let check = |extra: &[&'static str]| {
                let mut a = vec!["rtl-check", unit, "--sim", sim, "--json"];
                a.extend(extra);
                a.extend(sets(set));
                fxshade_quick(&with_config(a, cfg))
            };
            let o = check(&["--count", "2000", "--seed", "7"]);
            assert!(
                o.status.success(),
                "{unit} {sim} {cfg:?} {name}: {}",
                text(&o)
            );
            let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            assert_eq!(j["failed"], 0, "{unit} {sim} {cfg:?} {name}");
            assert_eq!(j["passed"], 2000, "{unit} {sim} {cfg:?} {name}");
            let dir = tempfile::tempdir().unwrap();
            let mut a = vec!["rtl", unit, "--json"];
            a.extend(sets(set));
            let mut args = with_config(a, cfg);
            args.extend(["--out", dir.path().to_str().unwrap()]);
            let o = fxshade(&args);
            assert!(o.status.success(), "{}", text(&o));
            let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            let module = r[0]["module"].as_str().unwrap();
            let v = std::fs::read_to_string(dir.path().join(format!("{module}.v"))).unwrap();
            // The header's latency, measured without stalls (with random
            // stalls a deep pipe rarely passes an item untouched, so the
            // smallest latency seen can exceed it).
            // The same seed: the killer search's rows are cached.
            let o = check(&["--count", "500", "--stall", "0", "--seed", "7"]);
            assert!(o.status.success(), "{unit} {name}: {}", text(&o));
            let j0: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            let declared = format!("// Latency {} cycles", j0["latency"]);
            assert!(
                v.contains(&declared),
                "{unit} {name}: measured {} cycles",
                j0["latency"]
            );
            assert!(j["latency"].as_u64() >= j0["latency"].as_u64());
        }
    }
}

/// The module a vector directory's manifest names.
pub fn module_of(vectors: &Path) -> String {
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(vectors.join("manifest.json")).unwrap()).unwrap();
    m["files"]["rtl"]
        .as_str()
        .unwrap()
        .trim_end_matches(".v")
        .to_string()
}

/// Build the generated testbench of a vector directory and run it with a
/// given `+N`.
pub fn run_tb(sim: &str, work: &Path, vectors: &Path, n: usize) -> String {
    let module = module_of(vectors);
    let files = [
        vectors.join(format!("{module}.v")),
        vectors.join(format!("{module}_tb.v")),
    ];
    match sim {
        "icarus" => {
            let vvp = work.join("tb.vvp");
            let o = Command::new("iverilog")
                .args(["-g2005", "-o"])
                .arg(&vvp)
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
        "verilator-cpp" => {
            // The C++ harness `vectors` writes beside the testbench, built
            // as its manifest says (once per work directory: only the
            // vector files change between runs).
            let obj = work.join("objcpp");
            if !obj.join("sim").exists() {
                let o = Command::new("verilator")
                    .args(["--cc", "--exe", "--build", "--no-timing", "-j", "2"])
                    .arg("--top-module")
                    .arg(format!("{module}_shell"))
                    .arg("--Mdir")
                    .arg(&obj)
                    .args(["-o", "sim"])
                    .arg(&files[0])
                    .arg(vectors.join(format!("{module}_shell.v")))
                    .arg(vectors.join(format!("{module}_main.cpp")))
                    .output()
                    .expect("verilator runs (install: apt-get install verilator)");
                assert!(o.status.success(), "{}", text(&o));
            }
            text(
                &Command::new(obj.join("sim"))
                    .arg(format!("+N={n}"))
                    .current_dir(vectors)
                    .output()
                    .unwrap(),
            )
        }
        _ => {
            let obj = work.join("obj");
            let o = Command::new("verilator")
                .args([
                    "--binary",
                    "-j",
                    "2",
                    "--top-module",
                    &format!("{module}_tb"),
                ])
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

/// The testbench of `unit` passes its own vectors and fails on vector files
/// that hold more or fewer vectors than `+N`, a truncated expected file, and
/// one flipped bit (decoded in the report).
pub fn testbench_checks(unit: &str) {
    let mut decoded = Vec::new();
    for sim in ["icarus", "verilator", "verilator-cpp"] {
        let work = tempfile::tempdir().unwrap();
        let vec_dir = work.path().join("v");
        let o = fxshade(&[
            "vectors",
            unit,
            "--count",
            "300",
            "--out",
            vec_dir.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        let out = run_tb(sim, work.path(), &vec_dir, 300);
        assert!(out.contains("300 passed, 0 failed"), "{unit} {sim}: {out}");
        let out = run_tb(sim, work.path(), &vec_dir, 310);
        assert!(
            out.contains("inputs.bin holds 300 of the 310 vectors") && out.contains("failed"),
            "{unit} {sim}: {out}"
        );
        let out = run_tb(sim, work.path(), &vec_dir, 290);
        assert!(
            out.contains("holds more than 290 vectors"),
            "{unit} {sim}: {out}"
        );
        let exp = vec_dir.join("expected.bin");
        let full = std::fs::read(&exp).unwrap();
        let rb = full.len() / 300;
        std::fs::write(&exp, &full[..250 * rb]).unwrap();
        let out = run_tb(sim, work.path(), &vec_dir, 300);
        assert!(
            out.contains("expected.bin holds 250 of the 300 vectors")
                && out.contains("250 passed, 50 failed"),
            "{unit} {sim}: {out}"
        );
        let mut flipped = full.clone();
        flipped[200 * rb + rb - 1] ^= 1;
        std::fs::write(&exp, &flipped).unwrap();
        let out = run_tb(sim, work.path(), &vec_dir, 300);
        assert!(
            out.contains("299 passed, 1 failed") && out.contains("mismatch at vector 200"),
            "{unit} {sim}: {out}"
        );
        // The mismatch decoded field by field: the C++ driver's lines are
        // the Verilog testbench's `$display` lines.
        let lines: Vec<&str> = out
            .lines()
            .skip_while(|l| !l.starts_with("mismatch at vector 200"))
            .take(4)
            .collect();
        assert_eq!(lines.len(), 4, "{unit} {sim}: {out}");
        decoded.push((sim, lines.join("\n")));
    }
    for (sim, d) in &decoded[1..] {
        assert_eq!(
            d, &decoded[0].1,
            "{unit}: {sim} decodes a mismatch as icarus does not"
        );
    }
}

/// `testvectors/<unit>/` is what the model generates now (256 vectors,
/// seed 1, default configuration): vectors, manifest, configuration, the
/// emitted module and its testbench; the same seed gives identical files,
/// another seed different ones.
pub fn golden_checks(unit: &str) {
    let dir = tempfile::tempdir().unwrap();
    let gen = |name: &str, seed: &str| {
        let out = dir.path().join(name);
        let o = fxshade(&[
            "vectors",
            unit,
            "--count",
            "256",
            "--seed",
            seed,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        out
    };
    let out = gen("a", "1");
    let module = module_of(&out);
    let golden = repo().join("testvectors").join(unit);
    for f in [
        "manifest.json".to_string(),
        "inputs.hex".into(),
        "expected.hex".into(),
        "inputs.bin".into(),
        "expected.bin".into(),
        format!("{module}.v"),
        format!("{module}_tb.v"),
        format!("{module}_shell.v"),
        format!("{module}_main.cpp"),
        "config.toml".into(),
    ] {
        let a = std::fs::read(golden.join(&f)).unwrap();
        assert!(
            a == std::fs::read(out.join(&f)).unwrap(),
            "testvectors/{unit}/{f} differs from what the model generates now"
        );
    }
    let again = gen("b", "1");
    assert_eq!(
        std::fs::read(again.join("inputs.hex")).unwrap(),
        std::fs::read(out.join("inputs.hex")).unwrap()
    );
    let other = gen("c", "2");
    assert_ne!(
        std::fs::read(other.join("inputs.hex")).unwrap(),
        std::fs::read(out.join("inputs.hex")).unwrap()
    );
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["count"], 256);
}

/// `ops --rtl` agrees with the model for every unit, variant and
/// configuration.
pub fn netlist_checks() {
    for cfg in configs() {
        let o = fxshade(&with_config(vec!["ops", "--rtl", "--json"], &cfg));
        assert!(o.status.success(), "{cfg:?}: {}", text(&o));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        for r in j["rtl"].as_array().unwrap() {
            assert_eq!(r["agree"], true, "{r}");
        }
    }
}
