//! Development aid: every node's code for one input row:
//! `cargo run --release -p fxshade-model --example point UNIT CODE… [-- override…]`.
use fxshade_model::config::Config;
use fxshade_model::datapath::Compiled;
use fxshade_model::rtl::units;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let u = units::unit(&args[1]).expect("unit");
    let split = args.iter().position(|a| a == "--").unwrap_or(args.len());
    let row: Vec<i128> = args[2..split]
        .iter()
        .map(|s| s.parse().expect("code"))
        .collect();
    let mut cfg = Config::embedded();
    for o in args.iter().skip(split + 1) {
        cfg.apply_override(o).unwrap();
    }
    let d = u.design(&cfg).unwrap();
    let t = &d.trace;
    let all: Vec<_> = (0..t.ops().len()).map(|i| t.value(i)).collect();
    let p = Compiled::compile(t, &all).unwrap();
    let cols: Vec<Vec<i128>> = row.iter().map(|&v| vec![v]).collect();
    let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
    let (out, _) = p.run_flags_i128(&refs);
    for (i, o) in out.iter().enumerate() {
        println!(
            "{i:4} {:<14} {:>14}  {:?}",
            t.stage_id(i).unwrap_or(""),
            o[0],
            t.ops()[i]
        );
    }
}
