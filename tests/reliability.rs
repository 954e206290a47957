//! Bad input and hostile output streams: a clear error or the right result,
//! never a panic (issue #13's reproduction commands that are fixed so far).

mod common;
use std::process::{Command, Stdio};

use common::*;

fn no_panic(o: &std::process::Output) {
    assert!(!text(o).contains("panicked"), "panic: {}", text(o));
}

#[test]
fn a_very_wide_d_is_a_clear_result_not_a_panic() {
    for set in ["normalize.d.format=U1F58", "normalize.d.format=U3F60"] {
        // (`ops` and `stages` design coefficients over every d code: hours at U1F58,
        // issue #13 item 2, not fixed yet.)
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
