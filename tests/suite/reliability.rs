//! Bad input and hostile output streams: a clear error or the right result,
//! never a panic (issue #13's reproduction commands that are fixed so far).

use std::process::{Command, Stdio};

use crate::common::*;

fn no_panic(o: &std::process::Output) {
    assert!(!text(o).contains("panicked"), "panic: {}", text(o));
}

/// The search mode is read from `FXSHADE_SEARCH` in one place, at the
/// CLI's edge: a value that is neither `full` nor `quick` is an error that
/// names the variable, before any vector is written (it used to mean
/// `full` silently).
#[test]
fn an_unknown_search_mode_is_refused_with_the_variable_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v");
    let o = Command::new(env!("CARGO_BIN_EXE_fxshade"))
        .args(["vectors", "normalize", "--count", "50", "--out"])
        .arg(&out)
        .env("FXSHADE_SEARCH", "quik")
        .output()
        .expect("runs");
    no_panic(&o);
    assert!(!o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("FXSHADE_SEARCH=quik: expected `full` or `quick`"),
        "{}",
        text(&o)
    );
    assert!(!out.join("inputs.hex").exists(), "vectors written anyway");
}

#[test]
fn a_very_wide_d_is_a_clear_result_not_a_panic() {
    for set in ["normalize.d.format=U1F58", "normalize.d.format=U3F60"] {
        for cmd in [&["config", "show"][..], &["config", "show", "--json"][..]] {
            let mut args = cmd.to_vec();
            args.extend(["--set", set]);
            let o = fxshade(&args);
            no_panic(&o);
            assert!(
                o.status.code() == Some(0) || o.status.code() == Some(2),
                "{args:?}: {}",
                text(&o)
            );
            if o.status.code() == Some(2) {
                assert!(text(&o).contains("normalize"), "{}", text(&o));
            }
        }
    }
}

#[test]
fn a_full_device_is_a_clear_error() {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .expect("/dev/full exists on Linux");
    for args in [
        &["config", "show"][..],
        &["ops", "--json"][..],
        &["rtl", "list"][..],
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_fxshade"))
            .args(args)
            .stdout(full.try_clone().unwrap())
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains("cannot write to standard output") && err.contains("No space left"),
            "{args:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn a_closed_pipe_ends_quietly_with_status_0() {
    for args in [
        &["config", "show"][..],
        &["ops"][..],
        &["stages", "--csv"][..],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_fxshade"))
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // The reader goes away before reading anything (as `| head -0`).
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {err}");
        assert!(err.trim().is_empty(), "{args:?}: {err}");
    }
}

#[test]
fn coefficient_fits_that_are_not_finite_are_refused() {
    for (lo, hi) in [("1e-20", "1"), ("0.5", "1e20")] {
        let o = fxshade(&[
            "coeffs", "--lo", lo, "--hi", hi, "--degree", "2", "--fit", "minimax", "--json",
        ]);
        no_panic(&o);
        assert_eq!(o.status.code(), Some(1), "[{lo}, {hi}]: {}", text(&o));
        assert!(text(&o).contains("not finite"), "{}", text(&o));
        assert!(o.stdout.is_empty(), "no figures printed: {}", text(&o));
    }
}

#[test]
fn a_users_directory_is_never_deleted() {
    let dir = tempfile::tempdir().unwrap();
    let mine = dir.path().join("mytb");
    std::fs::create_dir_all(&mine).unwrap();
    std::fs::write(mine.join("tb.sv"), b"module tb; endmodule\n").unwrap();
    std::fs::write(mine.join("notes.txt"), b"mine").unwrap();
    for args in [
        vec!["vectors", "normalize", "--count", "200"],
        vec!["render", "--mesh", "sphere:4", "--size", "16x16"],
    ] {
        let mut a = args.clone();
        a.extend(["--out", mine.to_str().unwrap()]);
        let o = fxshade(&a);
        assert_eq!(o.status.code(), Some(1), "{a:?}: {}", text(&o));
        assert!(
            text(&o).contains("not written by fxshade") && text(&o).contains("--force"),
            "{}",
            text(&o)
        );
        assert_eq!(std::fs::read(mine.join("notes.txt")).unwrap(), b"mine");
        assert_eq!(std::fs::read_dir(&mine).unwrap().count(), 2);
    }
    // No staging directory was left beside it.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    // --force replaces it; from then on it is fxshade's and needs no flag.
    let o = fxshade(&[
        "vectors",
        "normalize",
        "--count",
        "200",
        "--force",
        "--out",
        mine.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!mine.join("notes.txt").exists() && mine.join("inputs.hex").is_file());
    let o = fxshade(&[
        "vectors",
        "interp",
        "--count",
        "200",
        "--out",
        mine.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(mine.join("interp.v").is_file() && !mine.join("normalize.v").exists());
}

#[test]
fn waveforms_that_cannot_be_written_are_errors_and_trace_alone_takes_the_default_name() {
    let dir = tempfile::tempdir().unwrap();
    for sim in ["verilator", "icarus"] {
        let bad = dir.path().join("no/such/dir/t.fst");
        let o = fxshade(&[
            "rtl-check",
            "normalize",
            "--count",
            "200",
            "--sim",
            sim,
            "--trace",
            bad.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(1), "{sim}: {}", text(&o));
        assert!(
            text(&o).contains("cannot write the waveform") && text(&o).contains("no/such/dir"),
            "{sim}: {}",
            text(&o)
        );
    }
    // `--trace` with no file name: <unit>.fst in the working directory.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_fxshade"))
        .args(["rtl-check", "normalize", "--count", "200", "--trace"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(dir.path().join("normalize.fst").is_file());
}

#[test]
fn a_relative_cache_dir_and_a_cache_entry_without_its_simulator_work() {
    let dir = tempfile::tempdir().unwrap();
    let run = |envdir: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_fxshade"))
            .args([
                "rtl-check",
                "angle_interp",
                "--count",
                "100",
                "--sim",
                "icarus",
                "--json",
            ])
            .current_dir(dir.path())
            .env("FXSHADE_CACHE_DIR", envdir)
            .output()
            .unwrap()
    };
    let o = run("rel-cache");
    assert!(o.status.success(), "{}", text(&o));
    let cache = dir.path().join("rel-cache");
    // Delete the simulator of the entry just built: the next run rebuilds.
    for e in std::fs::read_dir(&cache).unwrap() {
        let _ = std::fs::remove_file(e.unwrap().path().join("sim.vvp"));
    }
    let o = run("rel-cache");
    assert!(o.status.success(), "{}", text(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(j["build_seconds"].as_f64().unwrap() > 0.0, "rebuilt: {j}");
}

/// Emit normalize into a directory, apply `edit` to its Verilog, and run
/// `rtl-check --rtl-dir` on it with `extra` flags.
fn check_edited(edit: impl Fn(&str) -> String, extra: &[&str]) -> std::process::Output {
    let dir = tempfile::tempdir().unwrap();
    let o = fxshade(&["rtl", "normalize", "--out", dir.path().to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let f = dir.path().join("normalize.v");
    let v = std::fs::read_to_string(&f).unwrap();
    let e = edit(&v);
    assert_ne!(v, e, "the edit changed nothing");
    std::fs::write(&f, e).unwrap();
    let mut args = vec![
        "rtl-check",
        "normalize",
        "--count",
        "500",
        "--jobs",
        "1",
        "--rtl-dir",
    ];
    args.push(dir.path().to_str().unwrap());
    args.extend_from_slice(extra);
    let out = fxshade(&args);
    drop(dir);
    out
}

#[test]
fn the_testbench_catches_data_changing_under_stall_and_extra_outputs() {
    // Output data that is wrong while stalled and right by the transfer.
    let o = check_edited(
        |v| {
            let line = v
                .lines()
                .find(|l| l.starts_with("  assign out_x_o = "))
                .unwrap();
            v.replace(
                line,
                &format!("{} ^ {{15'b0, ~ready_i}};", line.trim_end_matches(';')),
            )
        },
        &[],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("data changed while valid_o && !ready_i"),
        "{}",
        text(&o)
    );
    // Valid that sticks high: with no input bubbles every vector matches,
    // then outputs keep coming after the last one.
    let o = check_edited(
        |v| {
            v.replacen(
                "valid_q[2:0], in_take}",
                "valid_q[2:0], in_take | valid_q[0]}",
                1,
            )
        },
        &["--stall", "0"],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("an output beyond the 500 vectors"),
        "{}",
        text(&o)
    );
}

/// The streamed records are checked one by one: an extra record (even one
/// of all ones), a record with a wrong pad or index (what a shifted or
/// corrupted file gives), and a missing tail are errors on both simulators.
#[test]
fn the_testbench_catches_extra_wrong_and_missing_records() {
    let dir = tempfile::tempdir().unwrap();
    let v = dir.path().join("v");
    let o = fxshade(&[
        "vectors",
        "normalize",
        "--count",
        "300",
        "--out",
        v.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let exp = v.join("expected.bin");
    let good = std::fs::read(&exp).unwrap();
    let rb = good.len() / 300;
    for sim in ["icarus", "verilator", "verilator-cpp"] {
        // An extra record of all ones.
        std::fs::write(&exp, [good.clone(), vec![0xff; rb]].concat()).unwrap();
        let out = run_tb(sim, dir.path(), &v, 300);
        assert!(
            out.contains("holds more than 300 vectors") && out.contains("299 passed, 1 failed"),
            "{sim}: {out}"
        );
        // One byte more at the start: every record shifts (pad and index wrong).
        std::fs::write(&exp, [vec![0u8], good.clone()].concat()).unwrap();
        let out = run_tb(sim, dir.path(), &v, 300);
        assert!(
            out.contains("index or pad wrong") && out.contains(" passed, 30"),
            "{sim}: {out}"
        );
        // Record 17's index changed.
        // The index's lowest bit sits just above the W data bits.
        let m: serde_json::Value =
            serde_json::from_slice(&std::fs::read(v.join("manifest.json")).unwrap()).unwrap();
        let w = m["expected"]["width"].as_u64().unwrap() as usize;
        let mut bad = good.clone();
        bad[17 * rb + rb - 1 - w / 8] ^= 1 << (w % 8);
        std::fs::write(&exp, &bad).unwrap();
        let out = run_tb(sim, dir.path(), &v, 300);
        assert!(
            out.contains("record 17: index or pad wrong"),
            "{sim}: {out}"
        );
        // The last 10 records missing.
        std::fs::write(&exp, &good[..290 * rb]).unwrap();
        let out = run_tb(sim, dir.path(), &v, 300);
        assert!(out.contains("holds 290 of the 300 vectors"), "{sim}: {out}");
        std::fs::write(&exp, &good).unwrap();
        let out = run_tb(sim, dir.path(), &v, 300);
        assert!(out.contains("300 passed, 0 failed"), "{sim}: {out}");
    }
}

/// Run fxshade with a hang guard: `timeout` kills it after `secs`.
fn fxshade_within(secs: u32, args: &[&str]) -> std::process::Output {
    let mut c = Command::new("timeout");
    c.arg(secs.to_string())
        .arg(env!("CARGO_BIN_EXE_fxshade"))
        .args(args);
    // Vectors with a quick killer search: what this checks is the
    // coefficient design, which both searches share (the full one adds
    // bounded budgets of witnesses and random rows for the mutants it can
    // neither kill nor prove: up to 17 s a run here).
    if args.first() == Some(&"vectors") {
        c.env("FXSHADE_SEARCH", "quick");
    }
    c.output().expect("runs")
}

/// Configurations `config check` accepts whose coefficient design used to
/// score every `d` code (hours at U1F40) or walk millions of coefficient
/// codes (95 s at I3F24) finish every command. The limit is a hang guard,
/// far above the seconds they take (BENCHMARKS.md, "Wide accepted
/// configurations", has the times).
#[test]
#[ignore = "full tier: ./scripts/test --full"]
fn wide_accepted_configurations_finish() {
    let out = tempfile::tempdir().unwrap();
    for set in [
        "normalize.d.format=U1F32",
        "normalize.d.format=U1F58",
        "normalize.coef.format=I3F24",
    ] {
        let o = fxshade(&["config", "check", "/dev/null", "--set", set]);
        assert_eq!(o.status.code(), Some(0), "{set}: {}", text(&o));
        let dir = out.path().join(set.replace(['.', '='], "_"));
        let dir = dir.to_str().unwrap();
        for args in [
            &[
                "vectors",
                "normalize",
                "--count",
                "200",
                "--out",
                dir,
                "--force",
            ][..],
            &[
                "vectors", "pipeline", "--count", "200", "--out", dir, "--force",
            ][..],
            &["ops"][..],
            &["stages"][..],
            &["error", "normalize", "--count", "2000"][..],
        ] {
            let mut a = args.to_vec();
            a.extend(["--set", set]);
            let o = fxshade_within(120, &a);
            no_panic(&o);
            assert_eq!(o.status.code(), Some(0), "{a:?}: {}", text(&o));
        }
    }
    // With a wide d the maximum is bounded, and the table says so.
    let o = fxshade(&[
        "error",
        "normalize",
        "--count",
        "2000",
        "--set",
        "normalize.d.format=U1F32",
    ]);
    assert!(
        text(&o).contains("branch and bound") && text(&o).contains("(≤ "),
        "{}",
        text(&o)
    );
}

/// Quick and full killer searches are cached apart: the co-simulation
/// tests' quick search (`FXSHADE_SEARCH=quick`) finds fewer rows for the
/// `angles` unit, and a full run after it in the same cache still writes
/// the golden vectors byte for byte.
#[test]
fn quick_and_full_searches_are_cached_apart() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let run = |out: &str, quick: bool| -> std::path::PathBuf {
        let out = dir.path().join(out);
        let mut c = Command::new(env!("CARGO_BIN_EXE_fxshade"));
        c.args([
            "vectors", "angles", "--count", "256", "--seed", "1", "--out",
        ])
        .arg(&out)
        .env("FXSHADE_CACHE_DIR", &cache);
        if quick {
            c.env("FXSHADE_SEARCH", "quick");
        }
        let o = c.output().unwrap();
        no_panic(&o);
        assert!(o.status.success(), "{}", text(&o));
        out
    };
    let golden = repo().join("testvectors/angles");
    let read = |d: &std::path::Path, f: &str| std::fs::read(d.join(f)).unwrap();
    let quick = run("quick", true);
    assert_ne!(
        read(&quick, "inputs.hex"),
        read(&golden, "inputs.hex"),
        "the quick search found every row the full one does"
    );
    let full = run("full", false);
    for f in std::fs::read_dir(&golden).unwrap() {
        let name = f.unwrap().file_name();
        let name = name.to_str().unwrap();
        assert!(
            read(&full, name) == read(&golden, name),
            "{name}: the full run took the quick run's rows"
        );
    }
}

/// The inputs searched for mutant killers are cached (`$FXSHADE_CACHE_DIR
/// /corners`): a second run reads them and writes the same vectors, and an
/// entry that is cut short or garbled is ignored and rewritten whole.
#[test]
fn searched_rows_are_cached_and_a_bad_entry_is_recomputed() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let run = |out: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_fxshade"))
            .args([
                "vectors",
                "normalize",
                "--set",
                "normalize.method=\"linear\"",
                "--count",
                "300",
                "--out",
                dir.path().join(out).to_str().unwrap(),
            ])
            .env("FXSHADE_CACHE_DIR", &cache)
            .output()
            .unwrap();
        no_panic(&o);
        assert!(o.status.success(), "{}", text(&o));
        std::fs::read(dir.path().join(out).join("inputs.hex")).unwrap()
    };
    let entries = || -> Vec<std::path::PathBuf> {
        std::fs::read_dir(cache.join("corners"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect()
    };
    let first = run("a");
    let files = entries();
    assert_eq!(files.len(), 1, "{files:?}");
    let whole = std::fs::read_to_string(&files[0]).unwrap();
    assert!(whole.starts_with("fxshade searched rows 1\n") && whole.ends_with("end\n"));
    assert_eq!(run("b"), first, "read from the cache");
    // A first row whose first code is far outside its input format.
    let lines: Vec<&str> = whole.lines().collect();
    let row = lines[1].split_once(' ').map_or("", |(_, rest)| rest);
    let huge = format!(
        "{}\n99999999999 {row}\n{}\n",
        lines[0],
        lines[2..].join("\n")
    );
    for bad in [
        whole.trim_end_matches("end\n").to_string(),
        whole.replacen(' ', " x", 1),
        huge,
        String::new(),
    ] {
        std::fs::write(&files[0], &bad).unwrap();
        assert_eq!(
            run("c"),
            first,
            "recomputed past {:?}",
            &bad[..bad.len().min(40)]
        );
        std::fs::remove_dir_all(dir.path().join("c")).unwrap();
        assert_eq!(
            std::fs::read_to_string(&files[0]).unwrap(),
            whole,
            "rewritten"
        );
    }
}
