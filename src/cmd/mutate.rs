//! `fxshade mutate <unit>|all`: mutation testing of the vectors on the RTL.
//! Every mutant of each variant's traced datapath (a changed rounding mode,
//! a flipped overflow mode, an off-by-one shift, one quantizer at a time)
//! is built into one module beside the original logic and simulated on the
//! unit's vectors; a mutant is killed when the testbench reports a
//! mismatch. The model predicts the same outcome from the mutated trace, and
//! the two must agree.

use anyhow::Context;
use clap::Args;
use fxshade_model::rtl::{self, mutants, search};

use super::ConfigArgs;
use crate::output::{emit, OutputArgs, Table};
use crate::rtl_flow::{self, Sim};

/// `fxshade mutate`
#[derive(Args, Debug)]
pub struct MutateArgs {
    /// The unit, or `all`.
    #[arg(value_parser = super::unit_arg(&["all"]))]
    unit: String,
    #[command(flatten)]
    cfg: ConfigArgs,
    /// Only this variant (default: every variant of the unit).
    #[arg(long)]
    variant: Option<String>,
    /// Vectors per run (the default of `rtl-check` and `vectors`).
    #[arg(long, default_value_t = 10_000)]
    count: usize,
    /// Seed of the vectors.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Simulator.
    #[arg(long, value_enum, default_value_t = Sim::Verilator)]
    sim: Sim,
    /// Input boxes the branch and bound examines per surviving mutant, to
    /// prove it equivalent or find an input that kills it.
    #[arg(long, default_value_t = 20_000)]
    box_budget: usize,
    /// Boxes each branch and bound may examine to prove a surviving mutant
    /// equivalent, before z3: over the supports of its quantizer, over the
    /// input codes, over an earlier layer of quantizations (a count, not a
    /// time, so the score is the same on any machine at any load: 2^24
    /// boxes take 15-35 s here).
    #[arg(long, default_value_t = 1 << 24)]
    proof_boxes: u64,
    /// z3's resource limit per surviving mutant (its `rlimit`: a count of
    /// internal steps, deterministic where a time limit is not), for the
    /// bit-vector query "does any input meet the event that changes it";
    /// skipped when z3 is not installed.
    #[arg(long, default_value_t = SMT_RLIMIT)]
    smt_rlimit: u64,
    /// Also ask z3 and the support branch and bound about every killed
    /// mutant, and fail if either claims one equivalent, or z3 returns an
    /// input the model's own probe says misses the event: a check of the
    /// proofs, not of the vectors.
    #[arg(long)]
    smt_audit: bool,
    #[command(flatten)]
    out: OutputArgs,
}

/// One mutant's outcome.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MutantResult {
    /// Its number (`+MUTANT=k`).
    pub number: usize,
    /// What it changes.
    pub mutation: String,
    /// The RTL testbench saw a mismatch.
    pub killed: bool,
    /// The first vector that tells it apart in the model, if any.
    pub model_first_kill: Option<usize>,
    /// Why no input can kill it, when that is proven.
    pub equivalent: Option<&'static str>,
    /// For a survivor: an input that would kill it, found by the box search
    /// (the vectors missed it).
    pub killer_exists: Option<Vec<i128>>,
}

/// One variant's mutation score.
#[derive(Debug, Clone, serde::Serialize)]
pub struct VariantResult {
    /// Unit.
    pub unit: &'static str,
    /// Variant.
    pub variant: String,
    /// Vectors.
    pub count: usize,
    /// Mutants.
    pub mutants: usize,
    /// Killed on the RTL.
    pub killed: usize,
    /// Proven equivalent (no input can kill them; not in the score).
    pub equivalent: usize,
    /// `killed / (mutants − equivalent)`.
    pub score: f64,
    /// Each mutant.
    pub results: Vec<MutantResult>,
    /// Seconds (build included).
    pub seconds: f64,
}

/// z3's default resource limit per query ([`MutateArgs::smt_rlimit`]):
/// about 18 s of z3 4.8.12 here (3.3 M units a second on the lighting
/// level's tie, which needs 33 s), the 20 s it replaces.
pub const SMT_RLIMIT: u64 = 60_000_000;

/// Whether the missing-z3 warning was printed.
static WARNED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// What z3 says about a mutant's event.
enum Smt {
    /// No input meets it: the mutant is equivalent.
    Unsat,
    /// This input meets it.
    Sat(Vec<i128>),
    /// Unknown, timed out, or not encodable.
    Unknown,
    /// z3 is not installed.
    Missing,
}

/// A branch and bound that proves a mutant equivalent within its box
/// budget.
type Proof = fn(
    &rtl::Design,
    &fxshade_model::datapath::Mutation,
    u64,
) -> Result<bool, fxshade_model::vectors::RtlError>;

/// The branch and bound proofs tried on a survivor, in order: the proof,
/// its name, and what a success says.
const PROOFS: [(Proof, &str, &str); 4] = [
    (
        rtl::direction::direction_proof,
        "direction",
        rtl::direction::WHY,
    ),
    (
        search::support_proof,
        "support",
        "equivalent: a branch and bound over the codes of the quantizations its operand is computed from (taken as independent) finds none where the mutant changes what leaves their region",
    ),
    (
        search::input_proof,
        "input",
        "equivalent: a branch and bound over boxes of the input codes finds none where the mutant changes an output or a flag",
    ),
    (
        search::layer_proof,
        "layer",
        "equivalent: a branch and bound over the codes of an earlier layer of quantizations (a CORDIC rotation's inputs) finds none where the mutant changes what leaves their region",
    ),
];

/// Ask z3 (if installed) whether any input meets the event of `m`.
fn smt(d: &rtl::Design, m: &fxshade_model::datapath::Mutation, rlimit: u64) -> Smt {
    let Some(script) = d.trace.smt_event(m) else {
        return Smt::Unknown;
    };
    // FXSHADE_SMT_DUMP=DIR keeps each query, to rerun it with `z3 FILE`.
    if let Some(dir) = &crate::env::get().flows.smt_dump {
        let _ = std::fs::write(
            dir.join(format!("node{}-{:?}.smt2", m.node, m.kind)),
            &script,
        );
    }
    if !crate::proc::has("z3", "--version") {
        return Smt::Missing;
    }
    match crate::smt::Solver::Z3.check_limited(&script, 0, rlimit) {
        Ok(crate::smt::Reply::Unsat) => Smt::Unsat,
        Ok(crate::smt::Reply::Sat(values)) => {
            let formats: Vec<_> = d.trace.input_ports().iter().map(|p| p.format).collect();
            let mut row = Vec::new();
            for (slot, f) in formats.iter().enumerate() {
                let name = format!("in{slot}");
                let bits = values
                    .iter()
                    .find(|(t, _)| t.atom() == Some(name.as_str()))
                    .and_then(|(_, v)| v.bits());
                match bits {
                    Some((b, w)) if w == f.width() => row.push(f.from_bits(b as u64)),
                    _ => return Smt::Unknown,
                }
            }
            Smt::Sat(row)
        }
        _ => Smt::Unknown,
    }
}

fn run_variant(
    u: &'static rtl::units::RtlUnit,
    variant: &str,
    cfg: &fxshade_model::Config,
    a: &MutateArgs,
    bar: &indicatif::ProgressBar,
) -> anyhow::Result<VariantResult> {
    let start = std::time::Instant::now();
    let d = u.design(cfg)?;
    let v = rtl::units::vectors(u, cfg, a.count, a.seed, super::search_mode()?)?;
    let model = mutants::model_kills(&d, &v.input_rows)?;
    let muts: Vec<_> = model.iter().map(|(m, _)| m.clone()).collect();
    let schema = rtl::emit_mutants(&d, &muts)?;
    let sources = rtl_flow::Sources {
        files: vec![
            (format!("{}.v", schema.module), schema.verilog.clone()),
            (format!("{}_tb.v", schema.module), schema.testbench.clone()),
        ],
        tb_top: format!("{}_tb", schema.module),
        origin: format!("mutation schema of {} ({variant})", u.name),
        harness: Some(schema.harness.clone()),
    };
    let mut results = Vec::new();
    // Mutant 0 is the design itself: it must pass.
    for k in 0..=muts.len() {
        bar.set_message(format!("{} ({variant}) mutant {k}/{}", u.name, muts.len()));
        let r = rtl_flow::check_with_args(
            &v,
            &sources,
            a.sim,
            a.seed,
            20,
            None,
            false,
            &[format!("+MUTANT={k}")],
        )
        .with_context(|| format!("{} ({variant}), mutant {k}", u.name))?;
        if k == 0 {
            anyhow::ensure!(
                r.ok(),
                "{} ({variant}): the mutation schema with no mutant selected fails its vectors ({} failed)",
                u.name,
                r.failed
            );
            continue;
        }
        let (m, first) = &model[k - 1];
        let killed = !r.ok();
        anyhow::ensure!(
            killed == first.is_some(),
            "{} ({variant}) mutant {k} ({m}): the RTL {} it but the mutated model {}",
            u.name,
            if killed { "catches" } else { "misses" },
            if first.is_some() {
                "differs"
            } else {
                "does not"
            }
        );
        if a.smt_audit {
            match smt(&d, m, a.smt_rlimit) {
                Smt::Unsat => anyhow::ensure!(
                    !killed,
                    "{} ({variant}) mutant {k} ({m}): z3 says no input meets its event, yet the vectors kill it: the encoding is wrong",
                    u.name
                ),
                Smt::Sat(r) => anyhow::ensure!(
                    mutants::meets_event(&d, m, &r)?,
                    "{} ({variant}) mutant {k} ({m}): z3's input {r:?} does not meet the event in the model: the encoding is wrong",
                    u.name
                ),
                Smt::Missing => anyhow::bail!(
                    "--smt-audit needs z3: install it with `sudo apt-get install z3` (Debian; ./scripts/test does it when run as root)"
                ),
                Smt::Unknown => {}
            }
        }
        let mut equivalent = mutants::equivalent(&d, m)?;
        let mut killer = None;
        let mut cut = None;
        if equivalent.is_none() {
            match search::event_cut(&d, m)? {
                search::CutOutcome::Proven(_) => {
                    equivalent = Some(
                        "equivalent: its operand depends on the inputs through one quantization only, and on no code of it does the mutant change what leaves that quantization's region (exhaustive)",
                    )
                }
                search::CutOutcome::Event(c) => cut = Some(c),
                search::CutOutcome::NoCut => {}
            }
        }
        let budget = || a.proof_boxes;
        if a.smt_audit && killed {
            // The proofs are checked too: none may claim a killed mutant.
            for (proof, name, _) in PROOFS {
                anyhow::ensure!(
                    !proof(&d, m, budget())?,
                    "{} ({variant}) mutant {k} ({m}): the {name} branch and bound proves it equivalent, yet the vectors kill it",
                    u.name
                );
            }
        }
        if !killed && equivalent.is_none() {
            // A survivor: prove it equivalent, or search every input box
            // for one that kills it.
            for (proof, _, why) in PROOFS {
                if proof(&d, m, budget())? {
                    equivalent = Some(why);
                    break;
                }
            }
        }
        if !killed && equivalent.is_none() {
            match smt(&d, m, a.smt_rlimit) {
                Smt::Unsat => {
                    equivalent = Some(
                        "equivalent: z3 proves no input meets the event that changes it (bit-vector encoding of the trace)",
                    )
                }
                Smt::Sat(r) => {
                    if mutants::tells_apart(&d, m, &r)? {
                        killer = Some(r);
                    }
                }
                Smt::Missing => {
                    if !WARNED.swap(true, std::sync::atomic::Ordering::SeqCst) {
                        eprintln!(
                            "warning: z3 is not installed (`sudo apt-get install z3`): surviving mutants are not checked for equivalence"
                        );
                    }
                }
                Smt::Unknown => {}
            }
            if equivalent.is_none() && killer.is_none() {
                killer = search::line_search(
                    &d,
                    m,
                    cut.as_ref(),
                    &v.input_rows,
                    a.box_budget,
                    search::SWEEP_WORK,
                    a.seed,
                )?;
            }
            if equivalent.is_none() && killer.is_none() {
                match mutants::box_search(&d, m, a.box_budget, a.seed)? {
                    mutants::BoxOutcome::Proven => {
                        equivalent = Some(
                            "equivalent: interval branch and bound over every input code finds no input meeting the event that changes it",
                        )
                    }
                    mutants::BoxOutcome::Killer(r) => killer = Some(r),
                    mutants::BoxOutcome::Unknown => {}
                }
            }
        }
        anyhow::ensure!(
            !(killed && equivalent.is_some()),
            "{} ({variant}) mutant {k} ({m}) is killed though proven equivalent",
            u.name
        );
        results.push(MutantResult {
            number: k,
            mutation: m.to_string(),
            killed,
            model_first_kill: *first,
            equivalent,
            killer_exists: killer,
        });
    }
    let killed = results.iter().filter(|r| r.killed).count();
    let equivalent = results.iter().filter(|r| r.equivalent.is_some()).count();
    let live = muts.len() - equivalent;
    Ok(VariantResult {
        unit: u.name,
        variant: variant.to_string(),
        count: v.count(),
        mutants: muts.len(),
        killed,
        equivalent,
        score: if live == 0 {
            1.0
        } else {
            killed as f64 / live as f64
        },
        results,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Run it; exit status 0 only when every mutant is killed.
pub fn run(a: &MutateArgs) -> anyhow::Result<()> {
    let base = a.cfg.resolve()?;
    let units: Vec<&'static rtl::units::RtlUnit> = if a.unit == "all" {
        rtl::units::all().collect()
    } else {
        vec![rtl_flow::unit(&a.unit)?]
    };
    let mut jobs = Vec::new();
    for u in &units {
        for (name, set) in u.variants {
            if a.variant.as_deref().is_some_and(|v| v != *name) {
                continue;
            }
            jobs.push((*u, *name, *set));
        }
    }
    anyhow::ensure!(
        !jobs.is_empty(),
        "--variant {}: no such variant of {}",
        a.variant.as_deref().unwrap_or(""),
        a.unit
    );
    let bar = crate::progress::bar(jobs.len() as u64, "mutate");
    let mut out = Vec::new();
    for (u, name, set) in jobs {
        let mut cfg = base.clone();
        for o in rtl::units::overrides(set) {
            cfg.apply_override(o)?;
        }
        out.push(run_variant(u, name, &cfg, a, &bar)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let mut t = Table::new([
        "unit",
        "variant",
        "vectors",
        "mutants",
        "equivalent",
        "killed",
        "score",
        "s",
    ])
    .titled(format!("mutation score on {:?}", a.sim).to_lowercase());
    let mut s = Table::new(["unit", "variant", "mutant", "survives", "an input kills it"])
        .titled("surviving mutants");
    for r in &out {
        t.row([
            r.unit.to_string(),
            r.variant.clone(),
            r.count.to_string(),
            r.mutants.to_string(),
            r.equivalent.to_string(),
            r.killed.to_string(),
            format!("{:.1} %", 100.0 * r.score),
            format!("{:.1}", r.seconds),
        ]);
        for m in r
            .results
            .iter()
            .filter(|m| !m.killed && m.equivalent.is_none())
        {
            s.row([
                r.unit.to_string(),
                r.variant.clone(),
                m.number.to_string(),
                m.mutation.clone(),
            ]);
        }
    }
    let tables = if s.rows.is_empty() {
        vec![t]
    } else {
        vec![t, s]
    };
    emit(a.out, &tables, &serde_json::to_value(&out)?)?;
    let survivors: usize = out
        .iter()
        .map(|r| r.mutants - r.killed - r.equivalent)
        .sum();
    anyhow::ensure!(survivors == 0, "{survivors} mutants survive the vectors");
    Ok(())
}
