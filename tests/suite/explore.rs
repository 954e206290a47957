//! `fxshade explore`: sweeps, width groups, the cache, shards, bad input,
//! and word-length optimization checked by other commands.

use crate::common::{fxshade, text};
use serde_json::Value;

fn json(o: &std::process::Output) -> Value {
    assert!(o.status.success(), "{}", text(o));
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{e}: {}", text(o)))
}

fn metric(row: &Value, m: &str) -> f64 {
    row["metrics"][m]
        .as_f64()
        .unwrap_or_else(|| panic!("no {m} in {row}"))
}

/// Σ a × b over the multipliers the hardware builds, from `fxshade ops
/// --json` (the counting context's operand formats, not the emitter's).
fn ops_bit_products(sets: &[&str], variant: &str) -> f64 {
    let mut args = vec!["ops", "--json"];
    args.extend(sets);
    let ops = json(&fxshade(&args));
    let r = ops
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["unit"] == "pipeline" && r["variant"] == variant)
        .expect("pipeline variant");
    r["mul_formats"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            let hw = m["hardware"].as_str().unwrap();
            let (a, rest) = hw.split_once(" × ").unwrap();
            let b = rest.split_whitespace().next().unwrap();
            a.parse::<f64>().unwrap() * b.parse::<f64>().unwrap() * m["count"].as_f64().unwrap()
        })
        .sum()
}

/// The six formats that carry a normal, at 12 bits, written out here.
const NORMALS_12: [&str; 12] = [
    "--set",
    "interp.vertex.format=I2F10",
    "--set",
    "interp.out.format=I2F10",
    "--set",
    "normalize.normal.format=I2F10",
    "--set",
    "normalize.out.format=I2F10",
    "--set",
    "angles.normal.format=I2F10",
    "--set",
    "lighting.normal.format=I2F10",
];

#[test]
fn twelve_against_sixteen_bit_normals_in_one_command() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x");
    let r = json(&fxshade(&[
        "explore",
        "--vary",
        "width.normals=12,16",
        "--analyses",
        "normalize,interp,cost",
        "--samples",
        "20000",
        "--no-cache",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]));
    let rows = r["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0]["labels"][0][1], "12");
    assert_eq!(rows[1]["labels"][0][1], "16");
    // The 12-bit point is the configuration the six flags make: the
    // `error interp` command on it prints the same figures.
    let mut args = vec!["error", "interp", "--count", "20000", "--json"];
    args.extend(NORMALS_12);
    let e = json(&fxshade(&args));
    assert_eq!(
        e["max_angle_err_deg"].as_f64().unwrap(),
        metric(&rows[0], "interp.max_angle_err_deg")
    );
    // Fewer bits: more error, fewer bit products.
    assert!(
        metric(&rows[0], "interp.max_angle_err_deg") > metric(&rows[1], "interp.max_angle_err_deg")
    );
    // The emitter's bit products equal the counting context's.
    assert_eq!(
        metric(&rows[1], "bit_products"),
        ops_bit_products(&[], "smooth, quadratic g")
    );
    assert_eq!(
        metric(&rows[0], "bit_products"),
        ops_bit_products(&NORMALS_12, "smooth, quadratic g")
    );
    assert!(metric(&rows[0], "bit_products") < metric(&rows[1], "bit_products"));
    // Files: one CSV row per point with the metrics as numbers, a Pareto
    // front, and plots.
    let csv = std::fs::read_to_string(out.join("points.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "bit_products").unwrap();
    let first: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(
        first[col].parse::<f64>().unwrap(),
        metric(&rows[0], "bit_products")
    );
    for f in [
        "pareto.csv",
        "pareto.png",
        "pareto.svg",
        "error_vs_axis.png",
        "explore.json",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // Each point's configuration file reproduces it in another command,
    // and its flags are the sweep's spelling.
    let pc = &r["point_configs"][0];
    assert_eq!(pc["index"], 0, "{pc}");
    assert_eq!(pc["flags"], "--set width.normals=12", "{pc}");
    let file = out.join(pc["file"].as_str().unwrap());
    let e = json(&fxshade(&[
        "error",
        "interp",
        "--count",
        "20000",
        "--json",
        "--config",
        file.to_str().unwrap(),
    ]));
    assert_eq!(
        e["max_angle_err_deg"].as_f64().unwrap(),
        metric(&rows[0], "interp.max_angle_err_deg")
    );
    assert!(out.join("points").join("point_0001.toml").is_file());
}

fn sweep(cache: &std::path::Path, out: &std::path::Path, vary: &str, extra: &[&str]) -> Value {
    let mut args = vec![
        "explore",
        "--vary",
        vary,
        "--analyses",
        "polar,cost",
        "--samples",
        "5000",
        "--cache",
        cache.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--force",
        "--json",
    ];
    args.extend(extra);
    json(&fxshade(&args))
}

#[test]
fn an_extended_sweep_computes_only_the_new_points() {
    let dir = tempfile::tempdir().unwrap();
    let (cache, out) = (dir.path().join("cache"), dir.path().join("out"));
    let a = sweep(&cache, &out, "polar.table_bits=8..9", &[]);
    assert!(a["rows"]
        .as_array()
        .unwrap()
        .iter()
        .all(|r| r["cached"] == false));
    let b = sweep(&cache, &out, "polar.table_bits=8..10", &[]);
    let rows = b["rows"].as_array().unwrap();
    let cached: Vec<bool> = rows
        .iter()
        .map(|r| r["cached"].as_bool().unwrap())
        .collect();
    assert_eq!(cached, [true, true, false]);
    // The cached points are what measuring them again gives.
    let fresh = sweep(&cache, &out, "polar.table_bits=8..10", &["--no-cache"]);
    for k in 0..3 {
        assert_eq!(fresh["rows"][k]["metrics"], rows[k]["metrics"], "point {k}");
        assert_eq!(fresh["rows"][k]["cached"], false);
    }
    // Deeper tables: a smaller polar error.
    assert!(
        metric(&rows[0], "polar.max_angle_err_deg") > metric(&rows[2], "polar.max_angle_err_deg")
    );
}

#[test]
fn shards_merge_into_the_whole_sweep_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let d = |n: &str| dir.path().join(n);
    let vary = "polar.table_bits=8..10";
    let whole = sweep(&cache, &d("whole"), vary, &["--no-cache"]);
    let s0 = sweep(&cache, &d("s0"), vary, &["--shard", "0/2"]);
    let s1 = sweep(&cache, &d("s1"), vary, &["--shard", "1/2"]);
    assert_eq!(s0["rows"].as_array().unwrap().len(), 2);
    assert_eq!(s1["rows"].as_array().unwrap().len(), 1);
    let merged = json(&fxshade(&[
        "explore",
        "--merge",
        d("s0").to_str().unwrap(),
        d("s1").to_str().unwrap(),
        "--out",
        d("m").to_str().unwrap(),
        "--json",
    ]));
    let (m, w) = (
        merged["rows"].as_array().unwrap(),
        whole["rows"].as_array().unwrap(),
    );
    assert_eq!(m.len(), 3);
    for (a, b) in m.iter().zip(w) {
        assert_eq!(a["index"], b["index"]);
        assert_eq!(a["metrics"], b["metrics"]);
    }
    // A missing shard, a repeated one, and shards of another sweep fail,
    // and write nothing.
    let other = sweep(
        &cache,
        &d("o1"),
        "polar.table_bits=8..11",
        &["--shard", "1/2"],
    );
    assert_eq!(other["rows"].as_array().unwrap().len(), 2);
    for (shards, says) in [
        (vec!["s0"], "missing 1/2: run again with --shard 1/2"),
        (vec!["s0", "s0"], "twice"),
        (vec!["s0", "o1"], "different sweeps"),
    ] {
        let out = d("refused");
        let mut args = vec!["explore".to_string(), "--merge".into()];
        args.extend(shards.iter().map(|s| d(s).display().to_string()));
        args.extend(["--out".into(), out.display().to_string()]);
        let a: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
        let r = fxshade(&a);
        assert!(
            !r.status.success() && text(&r).contains(says),
            "{shards:?}: {}",
            text(&r)
        );
        assert!(!out.exists(), "{shards:?} wrote {}", out.display());
    }
}

#[test]
fn bad_sweeps_are_refused_with_the_flag_or_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o");
    let o = out.to_str().unwrap();
    for (args, says) in [
        (vec!["--vary", "normalize.nothing=1,2"], "nothing"),
        (
            vec!["--vary", "normalize.d.format=U1F13..I1F17"],
            "keeps the sign",
        ),
        (
            vec!["--vary", "width.hands=10..12"],
            "no width group `hands`",
        ),
        (vec!["--vary", "normalize.theta=0.3..0.6"], "needs a step"),
        (vec!["--goal", "nothing<=1"], "no metric `nothing`"),
        (vec!["--pareto", "normalize.max_rel_err"], "ERR:COST"),
        (vec!["--optimize"], "needs at least one --goal"),
        (vec!["--freeze", "width.interp"], "give --optimize too"),
        (vec!["--close-on", "ecp5"], "--optimize"),
        (
            vec!["--knob", "polar.table_bits=8..10"],
            "give --optimize too",
        ),
        (
            vec!["--minimize", "2*dsp_est*lut"],
            "--minimize `2*dsp_est*lut`: `dsp_est` and `lut` multiplied",
        ),
        (
            vec!["--minimize", "dsp_est + pipeline.psnr_db"],
            "--minimize `pipeline.psnr_db`: not a cost",
        ),
        // A standard-cell target has no LUTs to estimate.
        (
            vec![
                "--optimize",
                "--goal",
                "normalize.max_diffuse_err_levels<=0.75",
                "--minimize",
                "lut",
                "--set",
                "rtl.target=\"asic\"",
            ],
            "`lut_est` needs an area model for rtl.target asic, which has no LUT cells",
        ),
        (
            vec![
                "--optimize",
                "--goal",
                "pipeline.max_err_levels<=1",
                "--knob",
                "width.normals=8..10",
            ],
            "--knob width.normals: a width",
        ),
        (
            vec![
                "--optimize",
                "--goal",
                "pipeline.max_err_levels<=1",
                "--knob",
                "rtl.clock_ns=8,10",
            ],
            "--knob rtl.clock_ns: not searchable",
        ),
        (
            vec![
                "--optimize",
                "--goal",
                "pipeline.max_err_levels<=1",
                "--close-on",
                "xc7",
            ],
            "--close-on xc7: give a target with a delay model and a place and route",
        ),
        (
            vec![
                "--optimize",
                "--goal",
                "pipeline.max_err_levels<=1",
                "--freeze",
                "width.nothing",
            ],
            "--freeze width.nothing: no width group",
        ),
        (
            vec![
                "--optimize",
                "--goal",
                "pipeline.max_err_levels<=1",
                "--free",
                "polar.table",
            ],
            "--free polar.table: no stage",
        ),
        (vec!["--analyses", "everything"], "--analyses `everything`"),
        (vec!["--synth", "ice41"], "ice41"),
        (
            vec![
                "--vary",
                "width.normals=12",
                "--vary",
                "normalize.out.format=I2F12",
            ],
            "both set normalize.out",
        ),
        (vec!["--minimize", "pipeline.psnr_db"], "not a cost"),
        (vec!["--vary", "width.level=4"], "give at least 8 bits"),
    ] {
        let mut a = vec!["explore", "--out", o];
        a.extend(args.iter());
        let r = fxshade(&a);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {}", text(&r));
        assert!(text(&r).contains(says), "{args:?}: {}", text(&r));
        assert!(!out.exists(), "{args:?} wrote {o}");
    }
    let f = dir.path().join("sweep.toml");
    std::fs::write(
        &f,
        "vary = [\"polar.table_bits=8..9\"]\nmeshes = [\"sphere:12\"]\n",
    )
    .unwrap();
    let r = fxshade(&["explore", "--sweep", f.to_str().unwrap(), "--out", o]);
    assert_eq!(r.status.code(), Some(2), "{}", text(&r));
    assert!(
        text(&r).contains("sweep.toml:2") && text(&r).contains("unknown key `meshes`"),
        "{}",
        text(&r)
    );
    std::fs::write(
        &f,
        "vary = [\n  \"polar.table_bits=8..9\",\n  \"polar.angle_bits=8..x\",\n]\n",
    )
    .unwrap();
    let r = fxshade(&["explore", "--sweep", f.to_str().unwrap(), "--out", o]);
    assert_eq!(r.status.code(), Some(2), "{}", text(&r));
    assert!(
        text(&r).contains("sweep.toml:3"),
        "the entry's own line: {}",
        text(&r)
    );
    std::fs::write(
        &f,
        "goal = [\"pipeline.max_err_levels<=1\", \"nothing<=2\"]\n",
    )
    .unwrap();
    let r = fxshade(&["explore", "--sweep", f.to_str().unwrap(), "--out", o]);
    assert_eq!(r.status.code(), Some(2), "{}", text(&r));
    assert!(
        text(&r).contains("sweep.toml:1") && text(&r).contains("nothing"),
        "{}",
        text(&r)
    );
    std::fs::write(&f, "vary = [\"polar.table_bits=8..x\"]\n").unwrap();
    let r = fxshade(&["explore", "--sweep", f.to_str().unwrap(), "--out", o]);
    assert_eq!(r.status.code(), Some(2), "{}", text(&r));
    assert!(text(&r).contains("sweep.toml:1"), "{}", text(&r));
}

#[test]
fn a_shard_with_no_points_writes_an_empty_result() {
    let dir = tempfile::tempdir().unwrap();
    let r = json(&fxshade(&[
        "explore",
        "--vary",
        "polar.table_bits=8..9",
        "--analyses",
        "polar,cost",
        "--samples",
        "1000",
        "--shard",
        "2/3",
        "--no-cache",
        "--json",
        "--out",
        dir.path().join("s").to_str().unwrap(),
    ]));
    assert_eq!(r["rows"].as_array().unwrap().len(), 0);
    assert_eq!(r["total"], 2);
}

#[test]
fn a_sweep_file_gives_the_same_points_as_flags() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("sweep.toml");
    std::fs::write(
        &f,
        "vary = [\"normalize.method=linear,quadratic\"]\nanalyses = [\"normalize\", \"cost\"]\nsamples = 5000\n",
    )
    .unwrap();
    let a = json(&fxshade(&[
        "explore",
        "--sweep",
        f.to_str().unwrap(),
        "--no-cache",
        "--out",
        dir.path().join("a").to_str().unwrap(),
        "--json",
    ]));
    let b = json(&fxshade(&[
        "explore",
        "--vary",
        "normalize.method=linear,quadratic",
        "--analyses",
        "normalize,cost",
        "--samples",
        "5000",
        "--no-cache",
        "--out",
        dir.path().join("b").to_str().unwrap(),
        "--json",
    ]));
    assert_eq!(a["rows"].as_array().unwrap().len(), 2);
    for k in 0..2 {
        assert_eq!(a["rows"][k]["metrics"], b["rows"][k]["metrics"]);
    }
    // The linear normalizer errs more than the quadratic one.
    assert!(
        metric(&a["rows"][0], "normalize.max_rel_err")
            > metric(&a["rows"][1], "normalize.max_rel_err")
    );
}

#[test]
#[ignore = "full tier: ./scripts/test --full"]
fn optimize_meets_both_goals_beats_the_uniform_width_and_passes_the_rtl() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("opt");
    let r = json(&fxshade(&[
        "explore",
        "--optimize",
        "--goal",
        "pipeline.max_err_levels<=1",
        "--goal",
        "normalize.max_diffuse_err_levels<=0.75",
        "--minimize",
        "bit_products",
        "--mesh",
        "sphere:12",
        "--mesh",
        "torus:24",
        "--size",
        "64x64",
        "--samples",
        "20000",
        "--max-evals",
        "120",
        // The interpolator's widths stay as configured, as does the output
        // level (the pixel, U8F0) without being named.
        "--freeze",
        "width.interp",
        "--rtl-count",
        "300",
        // No wall-clock limit: a loaded machine must not make it unknown.
        "--equiv-timeout",
        "0",
        "--cache",
        dir.path().join("cache").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]));
    let o = &r["outcome"];
    let (base, win) = (&o["baseline"], &o["winner"]);
    assert!(
        metric(win, "bit_products") < metric(base, "bit_products"),
        "{o}"
    );
    // Frozen stages keep the default configuration's formats and are never
    // part of a point's overrides.
    let frozen: Vec<(String, String)> = serde_json::from_value(o["frozen"].clone()).unwrap();
    for kept in [
        ("lighting.level", "U8F0"),
        ("interp.bary", "U1F15"),
        ("interp.weight", "I2F16"),
    ] {
        assert!(
            frozen.contains(&(kept.0.to_string(), kept.1.to_string())),
            "{kept:?} not in {frozen:?}"
        );
    }
    for row in [base, win] {
        for ov in row["overrides"].as_array().unwrap() {
            let ov = ov.as_str().unwrap();
            assert!(
                !["lighting.level", "interp.bary", "interp.weight"]
                    .iter()
                    .any(|k| ov.starts_with(&format!("{k}."))),
                "a frozen stage searched: {ov}"
            );
        }
    }
    assert!(o["saving"].as_f64().unwrap() > 0.0);
    for c in r["rtl_check"].as_array().unwrap() {
        assert_eq!(c["ok"], true, "{c}");
    }
    // The winner's pipeline top is proved to compute its model.
    let eq = r["equivalence"].as_array().expect("the winner is proved");
    assert_eq!(eq.len(), 1, "{eq:?}");
    assert_eq!(eq[0]["module"], "pipeline_smooth", "{eq:?}");
    assert_eq!(eq[0]["verdict"], "proved", "{eq:?}");
    // Measured again without the cache, through the width groups: the
    // baseline's uniform width meets both goals and one bit less does not.
    let w = o["baseline_width"].as_u64().unwrap();
    assert!(w > 8, "baseline at the narrowest width tried: {o}");
    let uniform = |w: u64| {
        let mut args: Vec<String> = [
            "explore",
            "--goal",
            "pipeline.max_err_levels<=1",
            "--goal",
            "normalize.max_diffuse_err_levels<=0.75",
            "--mesh",
            "sphere:12",
            "--mesh",
            "torus:24",
            "--size",
            "64x64",
            "--samples",
            "20000",
            "--analyses",
            "normalize,pipeline,cost",
            "--no-cache",
            "--json",
            "--out",
        ]
        .map(String::from)
        .to_vec();
        args.push(dir.path().join(format!("u{w}")).display().to_string());
        // The search's variables: every group on the smooth path but the
        // frozen interpolator and output level.
        for g in ["normals", "light", "normalizer", "shading"] {
            args.push("--vary".into());
            args.push(format!("width.{g}={w}"));
        }
        let a: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
        json(&fxshade(&a))
    };
    let at = uniform(w);
    assert_eq!(at["cheapest_meeting_goals"], 0, "{at}");
    assert_eq!(
        metric(&at["rows"][0], "bit_products"),
        metric(base, "bit_products")
    );
    let below = uniform(w - 1);
    assert!(below["cheapest_meeting_goals"].is_null(), "{below}");
    // The written configuration meets the goals by the error command and a
    // render (its RTL passed both simulators above, `rtl_check`).
    let cfg = out.join("optimized.toml");
    let c = cfg.to_str().unwrap();
    let e = json(&fxshade(&[
        "error",
        "normalize",
        "--config",
        c,
        "--count",
        "20000",
        "--json",
    ]));
    assert!(
        e["triangles"]["max_diffuse_err_levels"].as_f64().unwrap() <= 0.75,
        "{e}"
    );
    for mesh in ["sphere:12", "torus:24"] {
        let img = dir.path().join(mesh.replace(':', "_"));
        let rj = json(&fxshade(&[
            "render",
            "--mesh",
            mesh,
            "--size",
            "64x64",
            "--method",
            "quadratic",
            "--config",
            c,
            "--out",
            img.to_str().unwrap(),
            "--json",
        ]));
        assert!(
            rj["methods"][0]["max_abs_levels"].as_u64().unwrap() <= 1,
            "{mesh}: {rj}"
        );
    }
}

/// `--knob` and `--close-on`, in one search (one search's time in the
/// suite). The knob: on the mapped path with a loose goal on the polar
/// transform's diffuse error, the sin/cos table shrinks from its
/// configured 2^11 entries; checked by a sweep of the knob over the
/// winner's own configuration: the winner's value meets the goal, one
/// index bit fewer does not. The closure: the winner's `angle_interp` on
/// the iCE40 HX8K (a few seconds a run) meets 125 MHz, its pipelining is
/// in optimized.toml; a clock out of reach fails the command after
/// writing the files.
#[test]
#[ignore = "full tier: ./scripts/test --full"]
fn optimize_searches_a_discrete_knob_and_closes_the_winners_timing() {
    let dir = tempfile::tempdir().unwrap();
    let run = |freq: &str, out: &std::path::Path| {
        fxshade(&[
            "explore",
            "--optimize",
            "--set",
            "pipeline.path=\"mapped\"",
            "--goal",
            "polar.max_diffuse_err_levels<=4",
            // A weighted sum of cost metrics.
            "--minimize",
            "cost.polar.table_bits + bit_products/100",
            "--analyses",
            "polar,cost",
            "--knob",
            "polar.table_bits=6..11",
            "--max-evals",
            "40",
            "--no-rtl-check",
            "--no-equiv",
            "--close-on",
            "ice40-hx8k",
            "--synth-unit",
            "angle_interp",
            "--freq",
            freq,
            "--cache",
            dir.path().join("cache").to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--json",
        ])
    };
    let out = dir.path().join("k");
    let r = json(&run("125", &out));
    let o = &r["outcome"];
    assert_eq!(o["minimize"], "cost.polar.table_bits + bit_products/100");
    // The saving is of the weighted sum, computed here from the metrics.
    let cost =
        |row: &Value| metric(row, "cost.polar.table_bits") + metric(row, "bit_products") / 100.0;
    let saving = 1.0 - cost(&o["winner"]) / cost(&o["baseline"]);
    assert!((o["saving"].as_f64().unwrap() - saving).abs() < 1e-9, "{o}");
    let knobs = &o["knobs"];
    assert_eq!(knobs[0][0], "polar.table_bits", "{knobs}");
    assert_eq!(knobs[0][1], "11", "starts at the configured value: {knobs}");
    let t: u32 = knobs[0][2].as_str().unwrap().parse().unwrap();
    assert!(t < 11, "the table did not shrink: {knobs}");
    let cfg = out.join("optimized.toml");
    let toml = std::fs::read_to_string(&cfg).unwrap();
    assert!(toml.contains(&format!("polar.table_bits = {t}")), "{toml}");
    assert!(toml.contains(&format!("\ntable_bits = {t}\n")), "{toml}");
    // The winner's widths with the knob at t and at t - 1, measured anew.
    let v = json(&fxshade(&[
        "explore",
        "--config",
        cfg.to_str().unwrap(),
        "--vary",
        &format!("polar.table_bits={},{t}", t - 1),
        "--analyses",
        "polar,cost",
        "--no-cache",
        "--out",
        dir.path().join("v").to_str().unwrap(),
        "--json",
    ]));
    let err = |k: usize| metric(&v["rows"][k], "polar.max_diffuse_err_levels");
    assert!(err(0) > 4.0, "one bit fewer meets the goal too: {}", err(0));
    assert!(err(1) <= 4.0, "the winner misses the goal: {}", err(1));
    // The closure: met, and the configuration written is the one closed.
    let c = &r["closure"];
    assert_eq!(c["outcome"], "met", "{c}");
    let res = &c["result"];
    assert!(res["fmax_mhz"].as_f64().unwrap() >= 125.0, "{c}");
    assert!(
        toml.contains("# timing of angle_interp: met 125.0 MHz"),
        "{toml}"
    );
    // The [rtl] section written holds the closing run's pipelining.
    let doc: toml_edit::DocumentMut = toml.parse().unwrap();
    let shown = &c["runs"][c["shown_run"].as_u64().unwrap() as usize - 1];
    assert_eq!(doc["rtl"]["pipeline"].as_str(), Some("target"), "{toml}");
    assert_eq!(doc["rtl"]["target"].as_str(), Some("ice40-hx8k"), "{toml}");
    assert_eq!(
        doc["rtl"]["clock_ns"].as_float(),
        shown["clock_ns"].as_f64(),
        "{toml}"
    );
    // The design placed is the written configuration's: its latency.
    let rtl = dir.path().join("rtl");
    let o = fxshade(&[
        "rtl",
        "angle_interp",
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        rtl.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let verilog = std::fs::read_to_string(rtl.join("angle_interp.v")).unwrap();
    assert!(
        verilog.contains(&format!("// Latency {} cycles", res["latency"])),
        "not the design placed: {}",
        verilog.lines().take(12).collect::<Vec<_>>().join("\n")
    );
    // Out of reach: the closure stops and the command fails, files written
    // (the search from the cache).
    let out = dir.path().join("missed");
    let o = run("400", &out);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("the winner's timing is not closed: 400.0 MHz not met"),
        "{}",
        text(&o)
    );
    assert!(out.join("optimized.toml").is_file());
}

/// A two-axis sweep: each shown metric as a grid (first axis down, second
/// across) in a CSV whose every cell is the point with those two values,
/// and as a heat map; a one-axis sweep has none.
#[test]
fn a_two_axis_sweep_gives_grids() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g");
    let r = json(&fxshade(&[
        "explore",
        "--vary",
        "width.normals=10,12,14",
        "--vary",
        "normalize.method=linear,quadratic",
        "--analyses",
        "normalize,cost",
        "--samples",
        "5000",
        "--no-cache",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]));
    let grids = r["grids"].as_array().unwrap();
    assert!(!grids.is_empty(), "{r}");
    let g = &grids[0];
    let m = g["metric"].as_str().unwrap();
    let csv = std::fs::read_to_string(out.join(g["csv"].as_str().unwrap())).unwrap();
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(head[1..], ["linear", "quadratic"], "{csv}");
    let mut cells = 0;
    for (line, width) in lines.zip(["10", "12", "14"]) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f[0], width, "{csv}");
        for (k, method) in ["linear", "quadratic"].iter().enumerate() {
            let row = r["rows"]
                .as_array()
                .unwrap()
                .iter()
                .find(|x| x["labels"][0][1] == width && x["labels"][1][1] == *method)
                .unwrap();
            assert_eq!(f[k + 1].parse::<f64>().unwrap(), metric(row, m));
            cells += 1;
        }
    }
    assert_eq!(cells, 6);
    let png = std::fs::read(out.join(g["png"].as_str().unwrap())).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // One axis: no grid.
    let one = json(&fxshade(&[
        "explore",
        "--vary",
        "width.normals=10,12",
        "--analyses",
        "normalize,cost",
        "--samples",
        "5000",
        "--no-cache",
        "--out",
        dir.path().join("one").to_str().unwrap(),
        "--json",
    ]));
    assert!(one["grids"].as_array().unwrap().is_empty(), "{one}");
}

/// A sweep of a unit off the configured path reports that unit's own cost
/// (the smooth top holds no polar table, so the top's `table_bits` cannot
/// move): the polar module's ROM doubles with each table bit while the
/// top's stays 0, and the printed table names the top's costs `[top]`.
#[test]
fn a_unit_sweep_reports_the_units_own_cost() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p");
    let o = fxshade(&[
        "explore",
        "--vary",
        "polar.table_bits=8..10",
        "--analyses",
        "polar,cost",
        "--samples",
        "2000",
        "--pareto",
        "polar.max_lsb_err:bit_products",
        "--no-cache",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("bit_products [top]"), "{}", text(&o));
    let r: Value =
        serde_json::from_slice(&std::fs::read(out.join("explore.json")).unwrap()).unwrap();
    let rows = r["rows"].as_array().unwrap();
    let bits: Vec<f64> = rows
        .iter()
        .map(|x| metric(x, "cost.polar.table_bits"))
        .collect();
    assert!(bits[0] > 0.0, "{bits:?}");
    assert_eq!(bits[1], 2.0 * bits[0], "{bits:?}");
    assert_eq!(bits[2], 2.0 * bits[1], "{bits:?}");
    for x in rows {
        assert_eq!(metric(x, "table_bits"), 0.0, "the smooth top has no table");
    }
    // Minimizing a unit's own cost measures that unit although its
    // analysis was not asked for.
    let m = json(&fxshade(&[
        "explore",
        "--vary",
        "polar.table_bits=8..9",
        "--analyses",
        "normalize",
        "--minimize",
        "cost.polar.table_bits",
        "--samples",
        "2000",
        "--no-cache",
        "--json",
        "--out",
        dir.path().join("m").to_str().unwrap(),
    ]));
    for x in m["rows"].as_array().unwrap() {
        assert!(metric(x, "cost.polar.table_bits") > 0.0, "{x}");
    }
    // A unit without RTL (the exact normalizer) leaves its own cost out
    // and keeps the point.
    let e = json(&fxshade(&[
        "explore",
        "--set",
        "pipeline.path=\"mapped\"",
        "--vary",
        "normalize.method=exact,linear",
        "--analyses",
        "normalize,cost",
        "--samples",
        "2000",
        "--no-cache",
        "--json",
        "--out",
        dir.path().join("e").to_str().unwrap(),
    ]));
    let rows = e["rows"].as_array().unwrap();
    assert!(rows.iter().all(|x| x["error"].is_null()), "{e}");
    assert!(rows[0]["metrics"]["cost.normalize.ff"].is_null(), "{e}");
    assert!(metric(&rows[1], "cost.normalize.ff") > 0.0, "{e}");
}

/// `--minimize lut` searches on the area model's estimate (no synthesis
/// per point), says so, and synthesizes the winner's top for rtl.target
/// (ECP5 here) to set Yosys's count beside the estimate: the estimate the
/// search used is the one synthesis reports for that module, the winner's
/// is no larger than the baseline's, and the count is Yosys's own.
#[test]
#[ignore = "full tier: ./scripts/test --full"]
fn optimize_minimizes_luts_on_the_estimate_and_confirms_the_winner_by_synthesis() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let run = |out: &str, json: bool| {
        let out = dir.path().join(out);
        let mut args = vec![
            "explore",
            "--optimize",
            "--set",
            "rtl.target=\"ecp5\"",
            "--goal",
            "normalize.max_diffuse_err_levels<=0.75",
            "--minimize",
            "lut",
            "--analyses",
            "normalize,cost",
            "--samples",
            "20000",
            "--max-evals",
            "40",
            "--no-rtl-check",
            "--no-equiv",
            "--cache",
            cache.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        if json {
            args.push("--json");
        }
        fxshade(&args)
    };
    let o = run("lut", true);
    assert!(
        text(&o).contains("`lut` as `lut_est`"),
        "the substitution is said: {}",
        text(&o)
    );
    let r = json(&o);
    let oc = &r["outcome"];
    assert_eq!(oc["minimize"], "lut_est", "{oc}");
    let (base, win) = (&oc["baseline"], &oc["winner"]);
    assert!(metric(win, "lut_est") <= metric(base, "lut_est"), "{oc}");
    let c = &r["confirmed"];
    assert_eq!(c["target"], "ecp5", "{c}");
    assert_eq!(c["module"], "pipeline_smooth", "{c}");
    assert_eq!(
        c["lut_estimate"].as_f64(),
        Some(metric(win, "lut_est")),
        "the search's estimate is synthesis's: {c}"
    );
    let lut = c["lut"].as_u64().unwrap();
    assert!(lut > 100, "Yosys counted the top's LUTs: {c}");
    // The table sets the count beside the estimate with its error.
    let t = run("lut2", false);
    assert!(t.status.success(), "{}", text(&t));
    let s = String::from_utf8_lossy(&t.stdout);
    assert!(
        s.contains("as synthesized for ECP5") && s.contains("| LUT4 ") && s.contains(" %)"),
        "{s}"
    );
}
