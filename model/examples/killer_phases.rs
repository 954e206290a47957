//! Development aid: where the killer search's time goes, one thread, per
//! survivor of the pool and directed searches and per phase, each phase
//! timed whatever the others found (the proofs, the line search, the
//! witness search; `search::killers` runs the line search first, then the
//! proofs, then the witnesses), and how much of the datapath each input
//! reaches (what a sweep of that input runs; `CONES=1` stops there):
//! `cargo run --release -p fxshade-model --example killer_phases UNIT [VARIANT]`.
use fxshade_model::config::Config;
use fxshade_model::rtl::search::{self, CutOutcome};
use fxshade_model::rtl::{direction, mutants, units, witness};
use std::time::Instant;

fn main() {
    let unit = std::env::args().nth(1).unwrap_or_else(|| "pipeline".into());
    let variant = std::env::args().nth(2);
    let u = units::all().find(|u| u.name == unit).expect("unit");
    let mut cfg = Config::embedded();
    if let Some(v) = &variant {
        let (_, set) = u.variants.iter().find(|(n, _)| n == v).expect("variant");
        for o in units::overrides(set) {
            cfg.apply_override(o).unwrap();
        }
    }
    let d = u.design(&cfg).unwrap();
    let formats: Vec<_> = d.trace.input_ports().iter().map(|p| p.format).collect();
    let seed = 1;
    let rows = units::unit_inputs(u, &cfg, units::Part::Corners, seed, &formats).unwrap();
    let mut pool = units::unit_inputs(
        u,
        &cfg,
        units::Part::Random(units::MUTANT_POOL / 2),
        seed ^ 0x6d75_7461_6e74,
        &formats,
    )
    .unwrap();
    let mut rng = fxshade_model::sampling::Rng::new(seed ^ 0x7469_6573);
    for _ in 0..units::MUTANT_POOL / 2 {
        pool.push(
            formats
                .iter()
                .map(|&f| fxshade_model::vectors::structured_code(f, &mut rng))
                .collect(),
        );
    }
    let (_, missed) = mutants::killers(&d, &rows, &pool).unwrap();
    let (_, missed) = mutants::directed_killers(&d, &missed, seed).unwrap();
    println!("{} survivors, {} nodes", missed.len(), d.trace.ops().len());
    reach(&d);
    if std::env::var("CONES").is_ok() {
        return;
    }
    // The line search as `search::killers` runs it.
    let line_search =
        |m: &fxshade_model::datapath::Mutation, cut: Option<&search::EventCut>, s: u64| {
            search::line_search(
                &d,
                m,
                cut,
                &pool,
                search::LINE_EVALS.min(search::LINE_WORK / d.trace.ops().len().max(1)),
                search::KILLER_SWEEP_WORK,
                s,
            )
            .unwrap()
        };
    let mut tot = [0f64; 4];
    for (i, m) in missed.iter().enumerate() {
        let t = Instant::now();
        if mutants::equivalent(&d, m).unwrap().is_some() {
            println!("{m}: equivalent [{:.3}]", t.elapsed().as_secs_f64());
            continue;
        }
        let cut = match search::event_cut(&d, m).unwrap() {
            CutOutcome::Proven(_) => {
                println!("{m}: cut-proven [{:.3}]", t.elapsed().as_secs_f64());
                continue;
            }
            CutOutcome::Event(c) => Some(c),
            CutOutcome::NoCut => None,
        };
        let t0 = t.elapsed().as_secs_f64();
        let tp = Instant::now();
        let b = search::KILLER_PROOF_BOXES;
        let mut proven = "";
        if cut.is_none() {
            for (name, f) in [
                ("direction", direction::direction_proof as fn(_, _, _) -> _),
                ("support", search::support_proof),
                ("input", search::input_proof),
                ("layer", search::layer_proof),
            ] {
                let bb = if name == "direction" {
                    search::KILLER_DIRECTION_BOXES
                } else {
                    b
                };
                let ts = Instant::now();
                let r = f(&d, m, bb).unwrap();
                print!("[{name} {:.3}]", ts.elapsed().as_secs_f64());
                if r {
                    proven = name;
                    break;
                }
            }
        }
        let proofs = tp.elapsed().as_secs_f64();
        let s = seed.wrapping_add(i as u64);
        if !proven.is_empty() {
            let tl = Instant::now();
            let _ = line_search(m, cut.as_ref(), s);
            let line = tl.elapsed().as_secs_f64();
            let tw = Instant::now();
            let _ = witness::witness_search(&d, m, &pool, search::KILLER_WITNESS_WORK, s).unwrap();
            let wit = tw.elapsed().as_secs_f64();
            println!(
                " {m}: proven by {proven}: proofs {proofs:.3} (line {line:.3} witness {wit:.3})"
            );
            tot[0] += t0 + proofs;
            continue;
        }
        let tl = Instant::now();
        let row = line_search(m, cut.as_ref(), s);
        let line = tl.elapsed().as_secs_f64();
        let tw = Instant::now();
        let w = if row.is_none() {
            witness::witness_search(&d, m, &pool, search::KILLER_WITNESS_WORK, s)
                .unwrap()
                .is_some()
        } else {
            false
        };
        let wit = tw.elapsed().as_secs_f64();
        println!(
            " {m}: cut {} prep {t0:.3} proofs {proofs:.3} line {line:.3} ({}) witness {wit:.3} ({w})",
            cut.is_some(),
            row.is_some()
        );
        tot[1] += t0 + proofs;
        tot[2] += line;
        tot[3] += wit;
    }
    println!(
        "proven {:.2} s; killable/unknown: proofs {:.2} line {:.2} witness {:.2}",
        tot[0], tot[1], tot[2], tot[3]
    );
}

/// Per input port, how many of the design's nodes it reaches.
fn reach(d: &fxshade_model::rtl::Design) {
    let t = &d.trace;
    let n = t.ops().len();
    let cones: Vec<Vec<usize>> = (0..n).map(|i| t.inputs_of(i)).collect();
    for p in t.input_ports() {
        let k = cones.iter().filter(|c| c.contains(&p.value.node())).count();
        println!("{:>12} {k:>4}/{n}", p.name);
    }
}
