//! Development aid: print a unit's traced datapath, one node per line:
//! `cargo run --release -p fxshade-model --example dump_trace UNIT [override…]`.
use fxshade_model::config::Config;
use fxshade_model::rtl::units;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let u = units::unit(&args[1]).expect("unit");
    let mut cfg = Config::embedded();
    for o in &args[2..] {
        cfg.apply_override(o).unwrap();
    }
    let d = u.design(&cfg).unwrap();
    let t = &d.trace;
    let roots: Vec<_> = t.output_ports().iter().map(|p| p.value).collect();
    let prog = fxshade_model::datapath::Compiled::compile(t, &roots).unwrap();
    let full: Vec<(i128, i128)> = t
        .input_ports()
        .iter()
        .map(|p| (p.format.min_code(), p.format.max_code()))
        .collect();
    let iv = prog.run_interval(&full);
    for p in t.input_ports() {
        println!("in  {} node {} {:?}", p.name, p.value.node(), p.format);
    }
    for p in t.output_ports() {
        println!("out {} node {} {:?}", p.name, p.value.node(), p.format);
    }
    for (i, op) in t.ops().iter().enumerate() {
        let r = iv.as_ref().map(|v| v.get(i).copied());
        println!(
            "{i:4} {:<20} {:?} frac? range {:?}",
            t.stage_id(i).unwrap_or(""),
            op,
            r
        );
    }
}
