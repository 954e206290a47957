//! Development aid: how often the witness search finds a killer for the
//! rounding and shift mutants of one node, over seeds, and how long it takes:
//! `cargo run --release -p fxshade-model --example witness UNIT NODE [override…]`
//! (`WORK=29` sets the budget to 2^29 lane·operations, `SEEDS=8` the runs;
//! `PROBE=1` runs the random probe instead).
use fxshade_model::config::Config;
use fxshade_model::datapath::MutationKind;
use fxshade_model::rtl::{probe, units, witness};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let u = units::unit(&args[1]).expect("unit");
    let node: usize = args[2].parse().expect("node");
    let mut cfg = Config::embedded();
    for o in &args[3..] {
        cfg.apply_override(o).unwrap();
    }
    let env = |k: &str, v: u32| std::env::var(k).map_or(v, |s| s.parse().expect(k));
    let work = 1usize << env("WORK", 29);
    let d = u.design(&cfg).unwrap();
    let roots: Vec<_> = d.trace.output_ports().iter().map(|p| p.value).collect();
    for m in d
        .trace
        .mutations(&roots)
        .into_iter()
        .filter(|m| m.node == node)
    {
        if matches!(m.kind, MutationKind::Overflow(_)) {
            continue;
        }
        for seed in 0..env("SEEDS", 8) as u64 {
            let t = std::time::Instant::now();
            let r = if std::env::var_os("PROBE").is_some() {
                probe::random_probe(&d, &m, work, seed).unwrap()
            } else {
                witness::witness_search(&d, &m, &[], work, seed).unwrap()
            };
            println!(
                "{m} seed {seed}: {} [{:.2}s]",
                if r.is_some() { "found" } else { "none" },
                t.elapsed().as_secs_f64()
            );
        }
    }
}
