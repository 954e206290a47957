//! `fxshade vectors <unit>`: test vectors, with the unit's generated
//! Verilog and testbench, for a configuration.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use super::ConfigArgs;

/// `fxshade vectors`
#[derive(Args, Debug)]
pub struct VectorsArgs {
    /// The unit (interp, normalize, polar, lighting, angle_interp, pipeline).
    unit: String,
    #[command(flatten)]
    cfg: ConfigArgs,
    /// Number of vectors (corner cases first, then random).
    #[arg(long, default_value_t = 10_000)]
    count: usize,
    /// Seed of the random vectors: the same seed gives identical files.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output directory (replaced as a whole when the set is complete; a
    /// non-empty directory fxshade did not write is refused).
    #[arg(long, short = 'o', value_name = "DIR")]
    out: PathBuf,
    /// Replace `--out` even when it holds files fxshade did not write.
    #[arg(long)]
    force: bool,
}

/// Run it.
pub fn run(a: &VectorsArgs) -> anyhow::Result<()> {
    let u = crate::rtl_flow::unit(&a.unit)?;
    let cfg = a.cfg.resolve()?;
    let start = std::time::Instant::now();
    let v = fxshade_model::rtl::units::vectors(u, &cfg, a.count, a.seed)?;
    let gen = start.elapsed().as_secs_f64();
    v.write(&a.out, a.force)
        .with_context(|| format!("cannot write the vectors to {}", a.out.display()))?;
    crate::output::print_out(&format!(
        "{} vectors ({} corner cases) of {} ({}) written to {} in {:.2} s ({:.0} vectors/s generated)\n",
        v.count(),
        v.corner_cases,
        v.unit,
        v.variant,
        a.out.display(),
        start.elapsed().as_secs_f64(),
        v.count() as f64 / gen.max(1e-9)
    ))
}
