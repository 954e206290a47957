//! Development aid: brute force the mutants the default vectors miss with
//! many random rows (uniform codes, and a share at the format's extremes):
//! `cargo run --release -p fxshade-model --example probe UNIT [ROWS]`.
use fxshade_model::config::Config;
use fxshade_model::datapath::Compiled;
use fxshade_model::rtl::{mutants, units};

fn main() {
    let unit = std::env::args().nth(1).expect("unit");
    let rows: usize = std::env::args()
        .nth(2)
        .map_or(1 << 20, |s| s.parse().expect("rows"));
    let u = units::unit(&unit).expect("unit");
    for (name, set) in u.variants {
        let mut cfg = Config::embedded();
        for o in units::overrides(set) {
            cfg.apply_override(o).unwrap();
        }
        let v = units::vectors(u, &cfg, 10_000, 1, Default::default()).unwrap();
        let d = u.design(&cfg).unwrap();
        let ports = d.trace.input_ports();
        let mut s = 0x9e3779b97f4a7c15u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let cols: Vec<Vec<i128>> = ports
            .iter()
            .map(|p| {
                let (lo, hi) = (p.format.min_code(), p.format.max_code());
                (0..rows)
                    .map(|i| {
                        let r = next();
                        if i % 4 == 0 {
                            // Near an end.
                            if r & 1 == 0 {
                                lo + (r >> 1) as i128 % 64
                            } else {
                                hi - (r >> 1) as i128 % 64
                            }
                        } else {
                            lo + (r as i128).rem_euclid(hi - lo + 1)
                        }
                    })
                    .collect()
            })
            .collect();
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        let roots: Vec<_> = d.trace.output_ports().iter().map(|p| p.value).collect();
        let want = Compiled::compile(&d.trace, &roots)
            .unwrap()
            .run_flags_i128(&refs);
        for (m, first) in mutants::model_kills(&d, &v.input_rows).unwrap() {
            if first.is_some() || mutants::equivalent(&d, &m).unwrap().is_some() {
                continue;
            }
            let got = Compiled::compile(&d.trace.mutated(&m), &roots)
                .unwrap()
                .run_flags_i128(&refs);
            let kill = (0..rows).find(|&i| {
                want.1[i] != got.1[i] || want.0.iter().zip(&got.0).any(|(a, b)| a[i] != b[i])
            });
            let n = (0..rows)
                .filter(|&i| {
                    want.1[i] != got.1[i] || want.0.iter().zip(&got.0).any(|(a, b)| a[i] != b[i])
                })
                .count();
            // Rows where the mutated node itself differs (the event).
            let node = [d.trace.value(m.node)];
            let a = Compiled::compile(&d.trace, &node)
                .unwrap()
                .run_flags_i128(&refs);
            let b = Compiled::compile(&d.trace.mutated(&m), &node)
                .unwrap()
                .run_flags_i128(&refs);
            let ev = (0..rows).filter(|&i| a.0[0][i] != b.0[0][i]).count();
            let ex = (0..rows).find(|&i| a.0[0][i] != b.0[0][i]);
            println!(
                "  event at the node on {ev} rows{}",
                ex.map_or(String::new(), |i| format!(
                    ", e.g. {:?}",
                    cols.iter().map(|c| c[i]).collect::<Vec<_>>()
                ))
            );
            println!(
                "{} {name}: {m}: {n} of {rows} rows kill{}",
                u.name,
                kill.map_or(String::new(), |i| format!(
                    ", e.g. {:?}",
                    cols.iter().map(|c| c[i]).collect::<Vec<_>>()
                ))
            );
        }
    }
}
