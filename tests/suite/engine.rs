//! The bit-accurate engine on every instruction set this CPU has (issue
//! #35, item 2): the same codes and overflow counts on each path.

use fxshade_model::datapath::{Compiled, Isa};
use fxshade_model::rtl::units::{self, Part};

use crate::common::*;

/// Every unit with RTL and each of its variants, on its corner cases and
/// 3 000 random rows: the outputs and the per-stage overflow counts of
/// every available path equal the portable path's, code for code. On this
/// x86-64 machine that is portable (SSE2), AVX2 and AVX-512; the test
/// fails rather than skips if the machine it was measured on lost a path
/// (`FXSHADE_EXPECT_ISA`, set by `./scripts/test` from `/proc/cpuinfo`).
#[test]
fn every_instruction_set_computes_the_same_codes() {
    let paths: Vec<Isa> = Isa::ALL.into_iter().filter(|i| i.available()).collect();
    if let Ok(want) = std::env::var("FXSHADE_EXPECT_ISA") {
        for name in want.split(',').filter(|s| !s.is_empty()) {
            assert!(
                paths.iter().any(|i| i.name() == name),
                "{name} is expected on this machine but not detected"
            );
        }
    }
    let mut compared = 0usize;
    for u in units::all() {
        for (variant, set) in u.variants {
            let sets: Vec<String> = units::overrides(set).map(str::to_string).collect();
            let cfg = fxshade_model::Config::resolve(None, &sets).unwrap();
            let d = u.design(&cfg).unwrap();
            let mut rows = (u.inputs)(&cfg, Part::Corners, 7).unwrap();
            rows.extend((u.inputs)(&cfg, Part::Random(3000), 7).unwrap());
            let ports = d.trace.input_ports();
            let cols: Vec<Vec<i128>> = (0..ports.len())
                .map(|k| rows.iter().map(|r| r[k]).collect())
                .collect();
            let refs: Vec<&[i128]> = cols.iter().map(Vec::as_slice).collect();
            let outs: Vec<_> = d.trace.output_ports().iter().map(|p| p.value).collect();
            let prog = Compiled::compile(&d.trace, &outs).unwrap();
            let base = prog.run_i128_on(Isa::Portable, &refs);
            for &isa in &paths[1..] {
                let got = prog.run_i128_on(isa, &refs);
                assert!(
                    got == base,
                    "{} {variant}: {} differs from the portable path",
                    u.name,
                    isa.name()
                );
                compared += 1;
            }
        }
    }
    if paths.len() > 1 {
        assert!(compared >= 8, "{compared} unit variants compared");
    }
}

/// `bench engine`'s C baseline computes the engine's codes and overflow
/// counts on every lane (the bench refuses to report a time otherwise), in
/// the default configuration and the test configurations (other widths,
/// every rounding mode, wrapping stages), and on a normalizer whose output
/// wraps often. The C is compiled by the system's C compiler.
#[test]
fn the_c_baseline_computes_the_engines_codes() {
    let mut runs: Vec<Vec<String>> = configs()
        .into_iter()
        .map(|c| {
            c.map(|c| vec!["--config".to_string(), c])
                .unwrap_or_default()
        })
        .collect();
    runs.push(
        [
            "--set",
            "normalize.d.round=\"half_up\"",
            "--set",
            "normalize.g.round=\"trunc\"",
            "--set",
            "normalize.out.format=\"I1F9\"",
            "--set",
            "normalize.out.overflow=\"wrap\"",
        ]
        .map(str::to_string)
        .to_vec(),
    );
    for extra in runs {
        let mut a = vec![
            "bench",
            "engine",
            "--inputs",
            "3000",
            "--seconds",
            "0.001",
            "--repeats",
            "1",
            "--json",
        ];
        a.extend(extra.iter().map(String::as_str));
        let o = fxshade(&a);
        assert!(o.status.success(), "{a:?}: {}", text(&o));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let w = j["workloads"].as_array().unwrap();
        assert!(w.len() >= 5, "{a:?}: {} workloads", w.len());
        for r in w {
            assert!(r["outputs_checked"].as_u64().unwrap() >= 3000, "{r}");
            assert!(r["c_ns"].as_f64().unwrap() > 0.0, "{r}");
        }
    }
}
