//! The `fxshade` command line: help, `config show`, `config check`, and the
//! errors for bad configurations (each names the file, line and key; exit
//! status 2; never a panic).

use std::path::Path;
use std::process::{Command, Output};

fn fxshade(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fxshade"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// The embedded default, as `config show` prints it.
fn default_toml() -> String {
    let o = fxshade(&["config", "show"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    text(&o.stdout)
}

/// Check `body` as a config file; return (exit code, stderr, path).
fn check(body: &str) -> (i32, String, String) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.toml");
    std::fs::write(&p, body).unwrap();
    let o = fxshade(&["config", "check", p.to_str().unwrap()]);
    let err = text(&o.stderr);
    assert!(!err.contains("panicked"), "panic: {err}");
    (o.status.code().unwrap_or(-1), err, p.display().to_string())
}

/// The 1-based line of the first line of `body` containing `needle`.
fn line_of(body: &str, needle: &str) -> usize {
    body.lines()
        .position(|l| l.contains(needle))
        .expect("needle present")
        + 1
}

#[test]
fn help_lists_every_command() {
    let o = fxshade(&["--help"]);
    assert!(o.status.success());
    let h = text(&o.stdout);
    for c in ["config", "ops", "report", "bench"] {
        assert!(h.contains(c), "--help mentions {c}:\n{h}");
    }
    let o = fxshade(&["config", "--help"]);
    assert!(text(&o.stdout).contains("show") && text(&o.stdout).contains("check"));
}

#[test]
fn show_round_trips_through_check() {
    let body = default_toml();
    assert!(body.contains("[lighting]"));
    let (code, err, _) = check(&body);
    assert_eq!(code, 0, "{err}");
    // JSON carries the same formats.
    let o = fxshade(&["config", "show", "--json"]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["lighting"]["dot"]["format"], "I2F14");
}

#[test]
fn unknown_key_names_key_and_line() {
    let body = default_toml().replace("\ndot = ", "\ndott = ");
    let (code, err, path) = check(&body);
    assert_eq!(code, 2);
    let line = line_of(&body, "dott = ");
    assert!(err.contains(&format!("{path}:{line}")), "{err}");
    assert!(err.contains("unknown key `lighting.dott`"), "{err}");
    assert!(err.contains("expected one of"), "{err}");
}

#[test]
fn unknown_section_and_stage_part() {
    let body = default_toml() + "\n[normaliser]\nx = 1\n";
    let (code, err, _) = check(&body);
    assert_eq!(code, 2);
    assert!(err.contains("unknown key `normaliser`"), "{err}");
    let body = default_toml().replace(
        "round = \"half_even\", overflow = \"saturate\" }\n# register",
        "round = \"half_even\", overflow = \"saturate\", rnd = \"x\" }\n# register",
    );
    let (code, err, _) = check(&body);
    assert_eq!(code, 2);
    assert!(err.contains("unknown key `lighting.dot.rnd`"), "{err}");
}

#[test]
fn width_zero_and_over_64_are_rejected() {
    for (fmt, why) in [
        ("I0F0", "width 0 is outside 1..=64"),
        ("I33F32", "width 65 is outside 1..=64"),
    ] {
        let body = default_toml().replace(
            "dot = { format = \"I2F14\"",
            &format!("dot = {{ format = \"{fmt}\""),
        );
        let (code, err, path) = check(&body);
        assert_eq!(code, 2, "{fmt}");
        let line = line_of(&body, &format!("\"{fmt}\""));
        assert!(err.contains(&format!("{path}:{line}")), "{err}");
        assert!(
            err.contains("`lighting.dot.format`") && err.contains(why),
            "{err}"
        );
    }
}

#[test]
fn product_wider_than_the_model_holds_is_rejected() {
    // 64-bit × 64-bit inputs: N·L needs 129 exact bits; the model holds 126.
    let body = default_toml()
        .replace(
            "normal = { format = \"I2F14\"",
            "normal = { format = \"I2F62\"",
        )
        .replace(
            "light = { format = \"I2F14\"",
            "light = { format = \"I2F62\"",
        );
    let (code, err, path) = check(&body);
    assert_eq!(code, 2);
    let line = line_of(&body, "normal = ");
    assert!(err.contains(&format!("{path}:{line}")), "{err}");
    assert!(
        err.contains("`lighting.normal`") && err.contains("bits wide") && err.contains("126"),
        "{err}"
    );
}

/// `config show` of a file (its effective configuration).
fn show(body: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("part.toml");
    std::fs::write(&p, body).unwrap();
    let o = fxshade(&["config", "show", "--config", p.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    without_source(&text(&o.stdout))
}

/// A shown configuration without its `# source:` line.
fn without_source(t: &str) -> String {
    t.lines()
        .filter(|l| !l.starts_with("# source:"))
        .map(|l| format!("{l}\n"))
        .collect()
}

#[test]
fn omitted_sections_fields_and_stage_parts_take_the_defaults() {
    // A field left out: the default's value, not an error.
    let body: String = default_toml()
        .lines()
        .filter(|l| !l.starts_with("gain = "))
        .map(|l| format!("{l}\n"))
        .collect();
    let (code, err, _) = check(&body);
    assert_eq!(code, 0, "{err}");
    assert_eq!(show(&body), without_source(&default_toml()));
    // A stage part left out: the default stage's part.
    let body = default_toml().replace(
        "round = \"half_even\", overflow = \"saturate\" }\n# register",
        "round = \"half_even\" }\n# register",
    );
    assert_eq!(show(&body), without_source(&default_toml()));
    // A file with one section and one field: everything else is the default.
    let shown = show("[normalize]\nmethod = \"linear\"\n");
    assert_eq!(
        shown,
        without_source(&default_toml()).replace("method = \"quadratic\"", "method = \"linear\"")
    );
    // An empty file is the default configuration.
    assert_eq!(show(""), without_source(&default_toml()));
    // Unknown keys are still errors, with their line.
    let (code, err, path) = check("[lighting]\ngain2 = 1\n");
    assert_eq!(code, 2);
    assert!(
        err.contains(&format!("{path}:2")) && err.contains("unknown key `lighting.gain2`"),
        "{err}"
    );
}

#[test]
fn bad_values_and_syntax() {
    let body = default_toml().replace("i0_km = 0.75", "i0_km = \"one\"");
    let (code, err, _) = check(&body);
    assert_eq!(code, 2);
    assert!(
        err.contains("`lighting.i0_km`: expected a number, found string"),
        "{err}"
    );

    let body = default_toml().replace("i0_km = 0.75", "i0_km = 1.5");
    let (_, err, _) = check(&body);
    assert!(err.contains("1.5 is outside 0..=1"), "{err}");

    let body = default_toml().replace(
        "round = \"half_even\", overflow = \"saturate\" }\n# register",
        "round = \"nearest\", overflow = \"saturate\" }\n# register",
    );
    let (_, err, _) = check(&body);
    assert!(err.contains("`nearest` is not a rounding mode"), "{err}");

    let body = default_toml().replace("[lighting]", "[lighting");
    let (code, err, path) = check(&body);
    assert_eq!(code, 2);
    assert!(
        err.contains(&format!("{path}:{}", line_of(&body, "[lighting")))
            && err.contains("not valid TOML"),
        "{err}"
    );
}

#[test]
fn several_errors_are_all_reported() {
    let body = default_toml()
        .replace("\ndot = ", "\ndott = ")
        .replace("i0_km = 0.75", "i0_km = 7");
    let (code, err, _) = check(&body);
    assert_eq!(code, 2);
    assert!(
        err.contains("lighting.dott") && err.contains("7 is outside"),
        "{err}"
    );
}

#[test]
fn missing_file_and_bad_overrides() {
    let o = fxshade(&["config", "check", "/nonexistent/fx.toml"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("/nonexistent/fx.toml: cannot read"));

    let o = fxshade(&["config", "show", "--set", "lighting.dot.format=I0F0"]);
    assert_eq!(o.status.code(), Some(2));
    let e = text(&o.stderr);
    assert!(
        e.contains("--set lighting.dot.format=I0F0") && e.contains("width 0"),
        "{e}"
    );

    let o = fxshade(&["config", "show", "--set", "lighting.nope=1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("unknown key `lighting.nope`"));

    // A good override shows up in the effective configuration.
    let o = fxshade(&[
        "config",
        "show",
        "--set",
        "lighting.dot.format=I3F13",
        "--set",
        "lighting.i0_km=0.5",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let s = text(&o.stdout);
    assert!(
        s.contains("dot = { format = \"I3F13\"") && s.contains("i0_km = 0.5"),
        "{s}"
    );

    // An override that makes an intermediate too wide is caught too.
    let o = fxshade(&[
        "ops",
        "--set",
        "lighting.normal.format=I2F62",
        "--set",
        "lighting.light.format=I2F62",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("--set lighting.normal.format=I2F62"),
        "{}",
        text(&o.stderr)
    );
}

#[test]
fn ops_is_measured_and_has_json_and_csv() {
    let o = fxshade(&["ops", "--json"]);
    assert!(o.status.success());
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let diffuse = j
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["unit"] == "lighting" && r["variant"] == "diffuse")
        .expect("the lighting unit reports");
    // N·L is 3 multiplications and 2 additions; the gain one more multiplication.
    assert_eq!(diffuse["mul"], 4);
    assert_eq!(diffuse["add"], 2);
    assert_eq!(diffuse["compare"], 1);
    assert_eq!(diffuse["stage"], "pixel");
    let o = fxshade(&["ops", "--csv"]);
    let csv = text(&o.stdout);
    assert!(csv.starts_with("unit,variant,stage,mul,add"), "{csv}");
}

#[test]
fn report_writes_an_index_and_refuses_bad_directories() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let o = fxshade(&["report", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    for f in ["index.md", "config.toml", "ops.json", "ops.csv"] {
        assert!(Path::new(&out).join(f).is_file(), "{f}");
    }
    let o = fxshade(&["report", "--out", "/nonexistent/dir/rep"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o.stderr).contains("cannot write the report"));
}

/// `width.<group>=W` is accepted by every command's `--set`, not only by
/// `explore --vary`: the README's members of `normals` (vertex normals,
/// the interpolated normal, the normalizer's input and output, the lighting
/// unit's N, the CORDIC input: `I2F14` by default) become 12 bits with
/// their two integer bits, other formats stay; `ops` and `vectors` take it;
/// a bad group, width or spelling is named.
#[test]
fn width_groups_are_accepted_by_every_set() {
    let both = |o: &Output| text(&o.stdout) + &text(&o.stderr);
    let o = fxshade(&["config", "show", "--set", "width.normals=12"]);
    assert!(o.status.success(), "{}", both(&o));
    let t = String::from_utf8_lossy(&o.stdout).to_string();
    let d = String::from_utf8_lossy(&fxshade(&["config", "show"]).stdout).to_string();
    // The stage line of `key` in section `sec`.
    let line = |t: &str, sec: &str, key: &str| -> String {
        t.lines()
            .skip_while(|l| *l != format!("[{sec}]"))
            .find(|l| l.starts_with(&format!("{key} = ")))
            .unwrap_or_else(|| panic!("[{sec}] {key}"))
            .to_string()
    };
    for (sec, key) in [
        ("interp", "vertex"),
        ("interp", "out"),
        ("normalize", "normal"),
        ("normalize", "out"),
        ("angles", "normal"),
        ("lighting", "normal"),
    ] {
        assert!(
            line(&d, sec, key).contains("\"I2F14\""),
            "default {sec}.{key}"
        );
        assert!(line(&t, sec, key).contains("\"I2F10\""), "{sec}.{key}: {t}");
    }
    assert_eq!(line(&t, "normalize", "d"), line(&d, "normalize", "d"));
    for cmd in [
        vec!["ops", "--set", "width.normals=12"],
        vec![
            "vectors",
            "normalize",
            "--count",
            "300",
            "--set",
            "width.normals=12",
            "--out",
        ],
    ] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("v");
        let mut args = cmd.clone();
        if args.last() == Some(&"--out") {
            args.push(out.to_str().unwrap());
        }
        let o = fxshade(&args);
        assert!(o.status.success(), "{args:?}: {}", both(&o));
    }
    for (set, want) in [
        ("width.nothing=12", "no width group `nothing`"),
        ("width.normals=0", "a positive number of bits"),
        ("width.normals=1", "give at least 2 bits"),
        ("width=12", "name a width group"),
    ] {
        let o = fxshade(&["ops", "--set", set]);
        assert_eq!(o.status.code(), Some(2), "{set}: {}", both(&o));
        assert!(both(&o).contains(want), "{set}: {}", both(&o));
    }
}
