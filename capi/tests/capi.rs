//! The C ABI: its header is cbindgen's, its results are the vector files'
//! (which the simulators check against the RTL), its errors are the
//! command line's, a C program links it (shared and static), and a
//! Verilator scoreboard through the generated DPI-C package passes on the
//! emitted RTL and fails on a mutant.

use std::ffi::{CStr, CString};
use std::path::{Path, PathBuf};
use std::process::Command;

use fxshade_capi::*;
use fxshade_model::rtl::search::Search;
use fxshade_model::rtl::unit_model::{ConfigSource, UnitModel};
use fxshade_model::rtl::units;

mod common;
use common::target_dir;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .into()
}

fn err() -> String {
    unsafe { CStr::from_ptr(fxs_last_error()) }
        .to_str()
        .unwrap()
        .to_string()
}

fn open(unit: &str, sets: &[&str]) -> *mut FxsUnit {
    let u = CString::new(unit).unwrap();
    let cs: Vec<CString> = sets.iter().map(|s| CString::new(*s).unwrap()).collect();
    let ps: Vec<*const i8> = cs.iter().map(|c| c.as_ptr()).collect();
    unsafe {
        fxs_open(
            u.as_ptr(),
            std::ptr::null(),
            std::ptr::null(),
            ps.as_ptr(),
            ps.len(),
        )
    }
}

#[test]
fn header_is_current() {
    let generated = include_str!(concat!(env!("OUT_DIR"), "/fxshade.h"));
    let committed = std::fs::read_to_string(repo().join("capi/include/fxshade.h")).unwrap();
    assert!(
        generated == committed,
        "capi/include/fxshade.h is stale: copy {}/fxshade.h over it",
        env!("OUT_DIR")
    );
    assert_eq!(fxs_abi_version(), 1);
}

/// Every unit and variant: the C ABI's outputs and flag words for the
/// inputs of `fxshade vectors` (corner cases, mutant killers of the quick
/// search and random rows) are the vector set's expected values.
#[test]
fn eval_gives_the_vector_files_values() {
    for u in units::all() {
        for (variant, set) in u.variants {
            let sets: Vec<&str> = units::overrides(set).collect();
            let h = open(u.name, &sets);
            assert!(!h.is_null(), "{} {variant}: {}", u.name, err());
            let cfg = fxshade_model::Config::resolve(
                None,
                &sets.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
            )
            .unwrap();
            // The quick killer search: its rows are inputs like any other
            // here (the full search costs a minute and a half over every
            // unit and variant, and checks nothing more of the ABI).
            let vs = units::vectors(u, &cfg, 600, 7, Search::Quick).unwrap();
            let (ni, no, nf) = unsafe { (fxs_num_inputs(h), fxs_num_outputs(h), fxs_num_flags(h)) };
            assert_eq!(ni, vs.inputs.len());
            assert_eq!(no + usize::from(nf > 0), vs.outputs.len());
            let n = vs.input_rows.len();
            let ins: Vec<i64> = vs.input_rows.iter().flatten().map(|&c| c as i64).collect();
            let mut outs = vec![0i64; n * no];
            let mut flags = vec![0u64; n];
            let r = unsafe { fxs_eval(h, n, ins.as_ptr(), outs.as_mut_ptr(), flags.as_mut_ptr()) };
            assert_eq!(r, 0, "{}", err());
            for (i, want) in vs.output_rows.iter().enumerate() {
                let mut got: Vec<i128> = Vec::new();
                if nf > 0 {
                    got.push(flags[i] as i128);
                }
                got.extend(outs[i * no..(i + 1) * no].iter().map(|&c| c as i128));
                assert_eq!(&got, want, "{} {variant} row {i}", u.name);
            }
            // The flag stages are the vector files' flag order.
            for (k, s) in vs.flags.iter().enumerate() {
                let c = unsafe { CStr::from_ptr(fxs_flag_stage(h, k)) };
                assert_eq!(c.to_str().unwrap(), s);
            }
            assert!(unsafe { fxs_flag_stage(h, nf) }.is_null());
            unsafe { fxs_close(h) };
        }
    }
}

/// Ports as the emitted module's header states them.
#[test]
fn ports_describe_the_module() {
    let h = open("normalize", &[]);
    assert!(!h.is_null(), "{}", err());
    let mut p = std::mem::MaybeUninit::<FxsPort>::uninit();
    assert_eq!(unsafe { fxs_input(h, 0, p.as_mut_ptr()) }, 0);
    let p = unsafe { p.assume_init() };
    let s = |c| unsafe { CStr::from_ptr(c) }.to_str().unwrap().to_string();
    // rtl/normalize.v: `n_x_i in I2F14 (16 bits, two's complement)`.
    assert_eq!(
        (s(p.name), s(p.format), p.is_signed, p.width, p.frac),
        ("n_x".to_string(), "I2F14".to_string(), 1, 16, 14)
    );
    assert_eq!((p.min_code, p.max_code), (-32768, 32767));
    assert_eq!(s(p.group), "");
    let mut q = std::mem::MaybeUninit::<FxsPort>::uninit();
    assert_eq!(unsafe { fxs_input(h, 3, q.as_mut_ptr()) }, -1);
    assert!(err().contains("input port 3 does not exist"), "{}", err());
    // rtl/normalize.v: four stages and the output buffer's head.
    assert_eq!(unsafe { fxs_latency(h) }, 5);
    let m: serde_json::Value =
        serde_json::from_str(unsafe { CStr::from_ptr(fxs_manifest(h)) }.to_str().unwrap()).unwrap();
    assert_eq!(m["abi_version"], 1);
    unsafe { fxs_close(h) };
    // A top's set-up fields name their port.
    let h = open("pipeline", &[]);
    assert!(!h.is_null(), "{}", err());
    let groups: Vec<String> = (0..unsafe { fxs_num_inputs(h) })
        .map(|k| {
            let mut p = std::mem::MaybeUninit::<FxsPort>::uninit();
            assert_eq!(unsafe { fxs_input(h, k, p.as_mut_ptr()) }, 0);
            s(unsafe { p.assume_init() }.group)
        })
        .collect();
    assert!(groups.iter().any(|g| g == "tri"), "{groups:?}");
    assert!(groups.iter().any(|g| g.is_empty()), "{groups:?}");
    unsafe { fxs_close(h) };
}

/// Errors are returned as text, never a panic or a wrapped code; a
/// refused configuration gives the command line's message.
#[test]
fn errors_are_the_command_lines_and_codes_are_never_wrapped() {
    assert!(open("nope", &[]).is_null());
    assert!(err().contains("unknown unit `nope`"), "{}", err());
    assert!(err().contains("normalize"), "{}", err());
    let bad = "normalize.d.format=I99F0";
    assert!(open("normalize", &[bad]).is_null());
    let msg = err();
    let cli = Command::new(target_dir().join("fxshade"))
        .args(["config", "check", "/dev/null", "--set", bad])
        .output()
        .unwrap();
    assert!(!cli.status.success());
    let cli = String::from_utf8_lossy(&cli.stderr).to_string();
    assert!(
        !msg.is_empty() && cli.contains(&msg),
        "capi: {msg}\ncli: {cli}"
    );
    let toml = CString::new("[normalize\n").unwrap();
    let unit = CString::new("normalize").unwrap();
    let name = CString::new("mine.toml").unwrap();
    let h = unsafe {
        fxs_open(
            unit.as_ptr(),
            toml.as_ptr(),
            name.as_ptr(),
            std::ptr::null(),
            0,
        )
    };
    assert!(h.is_null());
    assert!(err().contains("mine.toml:1"), "{}", err());
    let h = open("normalize", &[]);
    // n_x is I2F14: 32768 does not fit.
    let ins = [0i64, 0, 0, 100, 32768, 0];
    let mut outs = [7i64; 6];
    let r = unsafe { fxs_eval(h, 2, ins.as_ptr(), outs.as_mut_ptr(), std::ptr::null_mut()) };
    assert_eq!(r, -1);
    assert!(
        err().contains("row 1: code 32768 of input n_y lies outside I2F14"),
        "{}",
        err()
    );
    assert_eq!(outs, [7; 6], "nothing written on an error");
    unsafe { fxs_close(h) };
    // The DPI-C open refuses a package generated for other widths.
    let m = UnitModel::open("normalize", ConfigSource::Default, &[]).unwrap();
    let layout = CString::new(m.layout().replace("I2F14", "I2F13")).unwrap();
    let empty = CString::new("").unwrap();
    let h = unsafe {
        fxs_dpi_open(
            unit.as_ptr(),
            empty.as_ptr(),
            empty.as_ptr(),
            layout.as_ptr(),
        )
    };
    assert!(h.is_null());
    assert!(err().contains("regenerate it"), "{}", err());
}

fn cc_available() -> bool {
    Command::new("cc").arg("--version").output().is_ok()
}

/// A C program against `capi/include/fxshade.h`, linked shared and
/// static, prints what the model computes.
#[test]
fn a_c_program_links_the_library_shared_and_static() {
    assert!(
        cc_available(),
        "a C compiler (cc) is needed: apt-get install gcc"
    );
    let dir = tempfile::tempdir().unwrap();
    let c = dir.path().join("use.c");
    std::fs::write(
        &c,
        r#"#include <stdio.h>
#include "fxshade.h"
/* Reads rows of three input codes on stdin, prints the outputs and flags. */
int main(void) {
  const char *sets[] = {"normalize.method=\"linear\""};
  FxsUnit *u = fxs_open("normalize", NULL, NULL, sets, 1);
  if (!u) { fprintf(stderr, "%s\n", fxs_last_error()); return 2; }
  long long a, b, c;
  while (scanf("%lld %lld %lld", &a, &b, &c) == 3) {
    int64_t in[3] = {a, b, c}, out[3];
    uint64_t flags;
    if (fxs_eval(u, 1, in, out, &flags) != 0) { fprintf(stderr, "%s\n", fxs_last_error()); return 3; }
    printf("%lld %lld %lld %llu\n", (long long)out[0], (long long)out[1], (long long)out[2],
           (unsigned long long)flags);
  }
  fxs_close(u);
  return 0;
}
"#,
    )
    .unwrap();
    // Expected: the vector set's rows (corner cases, mutant killers and
    // random rows), which the simulators check against the RTL.
    let cfg =
        fxshade_model::Config::resolve(None, &["normalize.method=\"linear\"".to_string()]).unwrap();
    let vs = units::vectors(
        units::unit("normalize").unwrap(),
        &cfg,
        300,
        11,
        Default::default(),
    )
    .unwrap();
    let stdin: String = vs
        .input_rows
        .iter()
        .map(|r| format!("{} {} {}\n", r[0], r[1], r[2]))
        .collect();
    // Output rows are `ovf` first, then the three outputs.
    let want: String = vs
        .output_rows
        .iter()
        .map(|r| format!("{} {} {} {}\n", r[1], r[2], r[3], r[0]))
        .collect();
    let lib = target_dir();
    let inc = repo().join("capi/include");
    for (kind, link) in [
        (
            "shared",
            vec![
                format!("-L{}", lib.display()),
                "-lfxshade_capi".into(),
                format!("-Wl,-rpath,{}", lib.display()),
            ],
        ),
        (
            "static",
            vec![
                lib.join("libfxshade_capi.a").display().to_string(),
                "-lpthread".into(),
                "-ldl".into(),
                "-lm".into(),
            ],
        ),
    ] {
        let exe = dir.path().join(kind);
        let o = Command::new("cc")
            .arg(&c)
            .arg(format!("-I{}", inc.display()))
            .arg("-o")
            .arg(&exe)
            .args(&link)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{kind}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let mut child = Command::new(&exe)
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        {
            use std::io::Write;
            child
                .stdin
                .take()
                .unwrap()
                .write_all(stdin.as_bytes())
                .unwrap();
        }
        let o = child.wait_with_output().unwrap();
        assert!(
            o.status.success(),
            "{kind}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert_eq!(String::from_utf8_lossy(&o.stdout), want, "{kind}");
    }
}
