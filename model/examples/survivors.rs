//! Development aid: the mutants the default vectors miss, in the model
//! (no simulator), and which proof takes each (`PROOF_SECS`, default 20, bounds each;
//! `VARIANT` picks one variant):
//! `cargo run --release -p fxshade-model --example survivors [unit|all] [deep]`.
use fxshade_model::config::Config;
use fxshade_model::rtl::{mutants, search, units};

fn main() {
    let only = std::env::args().nth(1).filter(|s| s != "all");
    let deep = std::env::args().nth(2).is_some();
    let mut total = (0, 0, 0);
    for u in units::all() {
        if only.as_deref().is_some_and(|o| o != u.name) {
            continue;
        }
        for (name, set) in u.variants {
            if std::env::var("VARIANT").is_ok_and(|v| v != *name) {
                continue;
            }
            let mut cfg = Config::embedded();
            for o in units::overrides(set) {
                cfg.apply_override(o).unwrap();
            }
            let t = std::time::Instant::now();
            let v = units::vectors(u, &cfg, 10_000, 1, Default::default()).unwrap();
            let gen = t.elapsed().as_secs_f64();
            let d = u.design(&cfg).unwrap();
            let mk = mutants::model_kills(&d, &v.input_rows).unwrap();
            let mut eq = 0;
            let mut surv = Vec::new();
            for (m, first) in &mk {
                if first.is_some() {
                    continue;
                }
                if mutants::equivalent(&d, m).unwrap().is_some()
                    || matches!(
                        search::event_cut(&d, m).unwrap(),
                        search::CutOutcome::Proven(_)
                    )
                {
                    eq += 1;
                    continue;
                }
                // A budget in boxes (PROOF_BOXES, default 2^24, as mutate).
                let boxes = std::env::var("PROOF_BOXES")
                    .ok()
                    .and_then(|s| s.parse().ok())
                    .unwrap_or(1u64 << 24);
                type Proof = fn(
                    &fxshade_model::rtl::Design,
                    &fxshade_model::datapath::Mutation,
                    u64,
                ) -> Result<bool, fxshade_model::vectors::RtlError>;
                let proofs: [(Proof, &str); 4] = [
                    (fxshade_model::rtl::direction::direction_proof, "DIRECTION"),
                    (search::support_proof, "SUPPORT"),
                    (search::input_proof, "INPUT"),
                    (search::layer_proof, "LAYER"),
                ];
                let mut proven = false;
                for (proof, name) in proofs {
                    let t = std::time::Instant::now();
                    if proof(&d, m, boxes).unwrap() {
                        println!("    {name}-PROVEN {m} [{:.2}s]", t.elapsed().as_secs_f64());
                        proven = true;
                        break;
                    }
                }
                if proven {
                    eq += 1;
                    continue;
                }
                println!("    not proven {m}");
                surv.push(m.clone());
            }
            println!(
                "{} {}: {} mutants, {} equivalent (interval), {} survive  [gen {:.2}s]",
                u.name,
                name,
                mk.len(),
                eq,
                surv.len(),
                gen
            );
            let bases = v.input_rows.clone();
            for m in surv.iter().filter(|_| deep) {
                let t = std::time::Instant::now();
                let cut = search::event_cut(&d, m).unwrap();
                let desc = match &cut {
                    search::CutOutcome::Proven(c) => {
                        format!("PROVEN via cut {} range {:?}", c.node, c.range)
                    }
                    search::CutOutcome::Event(c) => {
                        format!("cut {} range {:?} {} codes", c.node, c.range, c.codes.len())
                    }
                    search::CutOutcome::NoCut => "no cut".to_string(),
                };
                let killer = match &cut {
                    search::CutOutcome::Proven(_) => None,
                    search::CutOutcome::Event(c) => {
                        search::line_search(&d, m, Some(c), &bases, 20_000, search::SWEEP_WORK, 1)
                            .unwrap()
                    }
                    search::CutOutcome::NoCut => {
                        search::line_search(&d, m, None, &bases, 20_000, search::SWEEP_WORK, 1)
                            .unwrap()
                    }
                };
                let (killer, how) = match killer {
                    Some(k) => (Some(k), "line"),
                    None => (
                        fxshade_model::rtl::witness::witness_search(
                            &d,
                            m,
                            &bases,
                            search::SWEEP_WORK,
                            1,
                        )
                        .unwrap(),
                        "witness",
                    ),
                };
                println!(
                    "    node {} {}: {} {how} killer {:?} [{:.2}s]",
                    m.node,
                    m,
                    desc,
                    killer,
                    t.elapsed().as_secs_f64()
                );
            }
            total.0 += mk.len();
            total.1 += eq;
            total.2 += surv.len();
        }
    }
    println!(
        "total {} mutants, {} equivalent, {} survive",
        total.0, total.1, total.2
    );
}
