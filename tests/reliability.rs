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
