//! Development aid: time [`direction_proof`] on every mutant of one node:
//! `cargo run --release -p fxshade-model --example direction UNIT NODE [override…]`.
use fxshade_model::config::Config;
use fxshade_model::rtl::{direction, units};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let u = units::unit(&args[1]).expect("unit");
    let node: usize = args[2].parse().expect("node");
    let mut cfg = Config::embedded();
    for o in &args[3..] {
        cfg.apply_override(o).unwrap();
    }
    let d = u.design(&cfg).unwrap();
    let roots: Vec<_> = d.trace.output_ports().iter().map(|p| p.value).collect();
    for m in d
        .trace
        .mutations(&roots)
        .into_iter()
        .filter(|m| m.node == node)
    {
        let t = std::time::Instant::now();
        let r = direction::direction_proof(&d, &m, 1 << 26).unwrap();
        println!("{m}: {r} [{:.2}s]", t.elapsed().as_secs_f64());
    }
}
