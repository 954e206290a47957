//! Mutation testing of the vectors on the RTL. Every mutant of each
//! variant's traced datapath (a changed rounding mode, a flipped overflow
//! mode, an off-by-one shift, one quantizer at a time) is built into one
//! module beside the original logic and simulated on the unit's vectors;
//! a mutant is killed when the testbench reports a mismatch. The model
//! predicts the same outcome from the mutated trace, and the two must
//! agree.

use anyhow::Context;
use fxshade_model::convert::{narrow, to_f64};
use fxshade_model::rtl::{self, mutants, search};

use crate::rtl_flow::{self, Sim};

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

/// z3's default resource limit per query ([`Options::smt_rlimit`]):
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
    if let Some(dir) = &crate::settings::get().smt_dump {
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
                    Some((b, w)) if w == f.width() => row.push(f.from_bits(narrow::<u64, _>(b))),
                    _ => return Smt::Unknown,
                }
            }
            Smt::Sat(row)
        }
        _ => Smt::Unknown,
    }
}

/// How a mutation run is made: the vectors, the simulator and the
/// budgets of the equivalence proofs and killer searches (counts, never
/// times, so a score is the same on any machine at any load).
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Vectors per run.
    pub count: usize,
    /// Seed of the vectors and of the searches.
    pub seed: u64,
    /// Simulator.
    pub sim: Sim,
    /// Input boxes the branch and bound examines per surviving mutant.
    pub box_budget: usize,
    /// Boxes each equivalence branch and bound may examine.
    pub proof_boxes: u64,
    /// z3's resource limit per surviving mutant ([`SMT_RLIMIT`]).
    pub smt_rlimit: u64,
    /// Also ask z3 and the support branch and bound about every killed
    /// mutant, and fail when either contradicts the simulation.
    pub smt_audit: bool,
    /// How the vectors' mutant killers are searched.
    pub search: search::Search,
}

/// Score the vectors of `u`'s `variant` under `cfg`: every mutant of its
/// traced datapath simulated (one module holding them all), the outcome
/// checked against the mutated model's, survivors proved equivalent or
/// given a killing input. `progress` is told the mutant being simulated;
/// `warn` gets a warning once per process (z3 missing).
///
/// # Errors
///
/// The design, vectors or schema cannot be built; a simulation fails to
/// run; the schema with no mutant fails its vectors; the RTL and the
/// mutated model disagree on a mutant; an audit finds a proof wrong.
pub fn run_variant(
    u: &'static rtl::units::RtlUnit,
    variant: &str,
    cfg: &fxshade_model::Config,
    a: &Options,
    progress: &dyn Fn(&str),
    warn: &dyn Fn(&str),
) -> anyhow::Result<VariantResult> {
    let start = std::time::Instant::now();
    let d = u.design(cfg)?;
    let v = rtl::units::vectors(u, cfg, a.count, a.seed, a.search)?;
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
        progress(&format!("{} ({variant}) mutant {k}/{}", u.name, muts.len()));
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
                        warn(
                            "z3 is not installed (`sudo apt-get install z3`): surviving mutants are not checked for equivalence",
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
            to_f64(killed) / to_f64(live)
        },
        results,
        seconds: start.elapsed().as_secs_f64(),
    })
}
