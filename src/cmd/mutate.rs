//! `fxshade mutate <unit>|all`: the arguments and the printed scores of
//! the mutation testing of the vectors ([`fxshade_flows::mutate`] runs it).

use clap::Args;
use fxshade_flows::mutate::{self, SMT_RLIMIT};
use fxshade_model::rtl;

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
    let opts = mutate::Options {
        count: a.count,
        seed: a.seed,
        sim: a.sim,
        box_budget: a.box_budget,
        proof_boxes: a.proof_boxes,
        smt_rlimit: a.smt_rlimit,
        smt_audit: a.smt_audit,
        search: super::search_mode()?,
    };
    let bar = crate::progress::bar(jobs.len() as u64, "mutate");
    let mut out = Vec::new();
    for (u, name, set) in jobs {
        let mut cfg = base.clone();
        for o in rtl::units::overrides(set) {
            cfg.apply_override(o)?;
        }
        out.push(mutate::run_variant(
            u,
            name,
            &cfg,
            &opts,
            &|m| bar.set_message(m.to_string()),
            &|w| bar.suspend(|| eprintln!("warning: {w}")),
        )?);
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
