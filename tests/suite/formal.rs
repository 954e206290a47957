//! The handshake proofs: `fxshade formal` proves the properties every
//! generated module carries (tests below), for the compact policy and a
//! target-pipelined configuration, and fails on modules broken by hand.

use crate::common::{fxshade, repo, text};

fn proves_all(extra: &[&str]) {
    let mut a = vec!["formal", "all", "--json"];
    a.extend(extra);
    let o = fxshade(&a);
    assert!(o.status.success(), "{extra:?}: {}", text(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["ok"], true);
    let m = j["modules"].as_array().unwrap();
    assert_eq!(m.len(), 9, "six units and three tops");
    for p in m {
        assert_eq!(p["bmc"], true, "{p}");
        assert_eq!(p["induction"], true, "{p}");
    }
}

#[test]
#[ignore = "full tier: ./scripts/test --full"]
fn every_module_proves_its_handshake_properties_compact() {
    proves_all(&[]);
}

#[test]
#[ignore = "full tier: ./scripts/test --full"]
fn every_module_proves_its_handshake_properties_target_pipelined() {
    let cfg = repo().join("tests/configs/pipelined.toml");
    proves_all(&["--config", cfg.to_str().unwrap()]);
}

/// The FIFO handshake (`rtl.handshake = "fifo"`) has properties of its
/// own: no overflow, shift, hold; with the set-up values carried through
/// the pipeline (`rtl.setup = "pixel"`, the tops' other register
/// structure). The handshake and set-up of `tests/configs/wide.toml`, on the
/// default widths: the datapath is cut, so widths do not enter the proof,
/// and that file's 4096-entry tables cost Yosys's front end 6 s a module
/// (`fxshade formal all --config tests/configs/wide.toml` proves them in
/// 28 s).
#[test]
#[ignore = "full tier: ./scripts/test --full"]
fn every_module_proves_its_handshake_properties_fifo() {
    proves_all(&[
        "--set",
        "rtl.handshake=\"fifo\"",
        "--set",
        "rtl.setup=\"pixel\"",
    ]);
}

/// Gate tier: the default normalizer (compact policy, stall handshake) and
/// the smooth pipeline top with the FIFO handshake and set-up values
/// carried with the pixels prove their properties (the full tier proves
/// every module under each policy).
#[test]
fn the_normalizer_and_the_smooth_top_prove_their_handshake_properties() {
    for (unit, extra) in [
        ("normalize", &[][..]),
        (
            "pipeline",
            &[
                "--set",
                "rtl.handshake=\"fifo\"",
                "--set",
                "rtl.setup=\"pixel\"",
            ][..],
        ),
    ] {
        let mut a = vec!["formal", unit, "--json"];
        a.extend(extra);
        let o = fxshade(&a);
        assert!(o.status.success(), "{unit}: {}", text(&o));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(j["ok"], true, "{unit}: {j}");
        let m = j["modules"].as_array().unwrap();
        assert_eq!(m.len(), 1, "{unit}: {j}");
        assert_eq!(m[0]["bmc"], true, "{unit}: {j}");
        assert_eq!(m[0]["induction"], true, "{unit}: {j}");
    }
}

/// `--jobs 0` is refused with the flag named and status 2 (a bad flag),
/// before any proof; `rtl-check` says the same.
#[test]
fn no_jobs_is_a_clear_error() {
    for cmd in ["formal", "rtl-check"] {
        let o = fxshade(&[cmd, "normalize", "--jobs", "0"]);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {}", text(&o));
        assert!(text(&o).contains("--jobs 0"), "{cmd}: {}", text(&o));
    }
}

/// A FIFO that admits one item too many can overflow when the output
/// stalls: the proof fails.
#[test]
fn an_overfull_fifo_fails_the_proof() {
    let dir = tempfile::tempdir().unwrap();
    let ok = dir.path().join("ok");
    let o = fxshade(&[
        "rtl",
        "normalize",
        "--set",
        "rtl.handshake=\"fifo\"",
        "--out",
        ok.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let v = std::fs::read_to_string(ok.join("normalize.v")).unwrap();
    // Every admission bound one higher: in the registered test (two
    // lines) and in the formal block's statement of it, so that only the
    // no-overflow properties can catch it.
    let bump = |l: &str| -> String {
        let mut out = String::new();
        let mut rest = l;
        while let Some(k) = rest.find("'d") {
            let (head, tail) = rest.split_at(k + 2);
            let digits: String = tail.chars().take_while(|c| c.is_ascii_digit()).collect();
            out += head;
            out += &(digits.parse::<u32>().unwrap() + 1).to_string();
            rest = &tail[digits.len()..];
        }
        out + rest
    };
    let mut n = 0;
    let more: String = v
        .lines()
        .scan(false, |cont, l| {
            let hit = *cont
                || l.starts_with("      ready_q <= ((f_wr")
                || l.starts_with("    assert (ready_q == ((f_count <= ");
            *cont = l.starts_with("      ready_q <= ((f_wr");
            n += usize::from(hit);
            Some(if hit { bump(l) } else { l.to_string() } + "\n")
        })
        .collect();
    assert_eq!(
        n, 3,
        "the admission test's two lines and its formal statement"
    );
    let d = dir.path().join("over");
    std::fs::create_dir(&d).unwrap();
    std::fs::write(d.join("normalize.v"), &more).unwrap();
    let o = fxshade(&["formal", "normalize", "--rtl-dir", d.to_str().unwrap()]);
    assert!(
        !o.status.success(),
        "an admission bound one higher was proved"
    );
    assert!(text(&o).contains("normalize.v:"), "{}", text(&o));
}

/// Each edit breaks the handshake in one way; the proof must fail and name
/// the property (a file and line of an assertion).
#[test]
fn broken_handshakes_fail_the_proof() {
    let dir = tempfile::tempdir().unwrap();
    let ok = dir.path().join("ok");
    let o = fxshade(&["rtl", "normalize", "--out", ok.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let v = std::fs::read_to_string(ok.join("normalize.v")).unwrap();
    let o = fxshade(&["formal", "normalize", "--rtl-dir", ok.to_str().unwrap()]);
    assert!(o.status.success(), "the unedited module: {}", text(&o));
    let edits = [
        // The stages keep moving while the skid register holds an item:
        // the item that arrives next overwrites it.
        (
            "  wire en_d = out_load | (en_q & ~out_arrive);",
            "  wire en_d = out_load | en_q;",
        ),
        // Stage 3's item is duplicated into stage 4 (stage 3's dropped).
        (
            "valid_q <= {valid_q[2:0], in_take};",
            "valid_q <= {valid_q[1], valid_q[1:0], in_take};",
        ),
        // The output registers load while stalled.
        (
            "    if (out_load & (skid_valid | out_arrive)) out_q <=",
            "    if (skid_valid | out_arrive) out_q <=",
        ),
        // Inputs accepted while the pipe cannot move.
        (
            "  assign ready_o = en;",
            "  assign ready_o = en | valid_q[1];",
        ),
    ];
    for (k, (from, to)) in edits.iter().enumerate() {
        assert!(v.contains(from), "edit {k}: `{from}` is not in normalize.v");
        let d = dir.path().join(format!("edit{k}"));
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join("normalize.v"), v.replacen(from, to, 1)).unwrap();
        let o = fxshade(&["formal", "normalize", "--rtl-dir", d.to_str().unwrap()]);
        assert!(!o.status.success(), "edit {k} ({to}) was proved");
        let t = text(&o);
        assert!(
            t.contains("the handshake properties fail") && t.contains("normalize.v:"),
            "edit {k}: {t}"
        );
    }
    // A module without properties is refused, not passed.
    let d = dir.path().join("bare");
    std::fs::create_dir(&d).unwrap();
    let bare = v.split("`ifdef FORMAL").next().unwrap().to_string() + "endmodule\n";
    std::fs::write(d.join("normalize.v"), bare).unwrap();
    let o = fxshade(&["formal", "normalize", "--rtl-dir", d.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(text(&o).contains("no `ifdef FORMAL block"), "{}", text(&o));
}

/// A set-up port that accepts a record one stage too early (an item still
/// reads the registers) fails the proof; the emitted one is proved. The
/// per-frame port waits for the pipe; the per-triangle port is
/// double-buffered, and loading the bank an item still reads fails too.
#[test]
#[ignore = "full tier: ./scripts/test --full"]
fn a_set_up_port_loading_under_a_reader_fails_the_proof() {
    let dir = tempfile::tempdir().unwrap();
    let ok = dir.path().join("ok");
    let o = fxshade(&["rtl", "pipeline", "--out", ok.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let v = std::fs::read_to_string(ok.join("pipeline_smooth.v")).unwrap();
    // The frame port: its registered ready tests the next cycle's stages
    // 1..U (`frame_busy_d`); testing one stage fewer loads the registers
    // under an item's last reading stage.
    let line = v
        .lines()
        .find(|l| l.starts_with("  wire [") && l.contains(" frame_busy_d = "))
        .expect("a held set-up port");
    let top: u32 = line
        .trim_start_matches("  wire [")
        .split(':')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(top >= 1, "{line}");
    let test = "~|frame_busy_d;";
    assert!(v.contains(test));
    let early = format!("~|frame_busy_d[{}:0];", top - 1);
    let fails = |name: &str, text_v: String, what: &str| {
        let d = dir.path().join(name);
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join("pipeline_smooth.v"), text_v).unwrap();
        let o = fxshade(&["formal", "pipeline", "--rtl-dir", d.to_str().unwrap()]);
        assert!(!o.status.success(), "{what} was proved");
        assert!(
            text(&o).contains("pipeline_smooth.v:"),
            "the failing assertion is named: {}",
            text(&o)
        );
    };
    fails("early", v.replacen(test, &early, 1), &early);
    // A port that lets an item in during the cycle it loads: the item's
    // stage 0 reads the old values, its later stages the new ones.
    let lock = "  assign setup_lock_d = frame_ready_d;";
    assert!(v.contains(lock), "items wait while the frame loads");
    fails(
        "same-cycle",
        v.replacen(lock, "  assign setup_lock_d = 1'b0;", 1),
        "no lock",
    );
    // The triangle port: a ready that ignores the items' tags (and the
    // invariant saying what it stands for, so only the banks can fail),
    // and a record written into the current bank instead of the other.
    let ready = v
        .lines()
        .find(|l| l.trim_start().starts_with("tri_ready_q <= ~|"))
        .expect("the banked port's ready");
    let inv = v
        .lines()
        .find(|l| l.trim_start().starts_with("assert (tri_ready_q == "))
        .expect("the ready's invariant");
    let blind = v.replacen(ready, "      tri_ready_q <= 1'b1;", 1).replacen(
        inv,
        "      assert (tri_ready_q);",
        1,
    );
    fails("blind", blind, "a ready blind to the tags");
    let load = "    if (tri_load & tri_cur_q) begin";
    assert!(v.contains(load));
    fails(
        "current-bank",
        v.replacen(load, "    if (tri_load & ~tri_cur_q) begin", 1),
        "a load into the current bank",
    );
}
