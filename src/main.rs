//! `fxshade`: the command-line tool over the fxshade model.

// No bare numeric `as` (see fxshade-numbers).
#![warn(
    clippy::cast_lossless,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::cast_precision_loss
)]
#![cfg_attr(
    test,
    allow(
        clippy::cast_lossless,
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_possible_wrap,
        clippy::cast_precision_loss
    )
)]

mod cmd;
mod env;
mod output;
mod picture;
mod plot;
mod progress;
mod shard_args;

// The flows, by the names the commands use.
use fxshade_flows::{
    critical_path, device, explore, netlist, netlist_equiv, proc, rtl_flow, shard, smt,
};

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use fxshade_model::config::ConfigErrors;

/// fxshade — a bit-accurate fixed-point model of a per-pixel shading
/// pipeline (fast normalizer, polar tangent-space transform, quadratic normal
/// interpolation), its Verilog RTL, and the flow that proves they agree.
///
/// Widths, rounding and overflow modes are run-time choices: every command
/// that uses them takes `--config FILE` and `--set KEY=VALUE`; without them
/// the embedded default is used (`fxshade config show` prints it).
/// Commands that print figures take `--json` or `--csv`.
#[derive(Parser, Debug)]
#[command(name = "fxshade", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    cmd: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Show or validate a configuration (formats of every port and stage).
    #[command(subcommand)]
    Config(cmd::config::ConfigCmd),
    /// Operation counts of every unit and variant, measured by running the
    /// datapath in the counting context (not typed in), beside the papers'
    /// claims.
    Ops(cmd::ops::OpsArgs),
    /// The main job: the configuration, operation counts, quantization
    /// points, the paper's tables reproduced, the error analysis of the
    /// normalizer and of interpolation, and test vectors of every unit, in a
    /// directory with an index page.
    Report(cmd::report::ReportArgs),
    /// Error of the bit-accurate model against the f64 reference, per unit.
    #[command(subcommand)]
    Error(cmd::error::ErrorCmd),
    /// Design g(d) ≈ 1/√d coefficients (Chebyshev nodes, Chebyshev series or
    /// minimax), optionally quantized to a coefficient format by rounding and
    /// by search.
    Coeffs(cmd::coeffs::CoeffsArgs),
    /// The normalization paper's Tables 1–4 beside their reproduction, every
    /// entry that does not reproduce flagged with the reason.
    Paper(cmd::paper::PaperArgs),
    /// Every quantization point of every unit: stage, exact input format and
    /// width, output format, bits dropped, rounding and overflow modes — the
    /// table the RTL follows.
    Stages(cmd::ops::StagesArgs),
    /// How far the polar transform's implied tangent frame is from the
    /// UV-aligned frame normal maps are baked in, over a procedural mesh.
    PolarFrames(cmd::polar_frames::FramesArgs),
    /// Rewrite a tangent-space normal map baked in a UV-aligned frame into
    /// the polar transform's implied frame through a mesh's UV layout, and
    /// report the texels where that is impossible (seams, texels shared by
    /// triangles with different frames, the poles).
    BakeImplied(cmd::bake::BakeArgs),
    /// Write test vectors (manifest, $readmemh files) with the unit's
    /// generated Verilog and testbench for a configuration.
    Vectors(cmd::vectors::VectorsArgs),
    /// Emit a unit's Verilog (and testbench) from its traced datapath.
    Rtl(cmd::rtl::RtlArgs),
    /// Co-simulate a unit's RTL against the model with Verilator or Icarus
    /// Verilog: exit status 0 only when every vector matches bit for bit.
    RtlCheck(cmd::rtl_check::RtlCheckArgs),
    /// Mutation testing of the vectors on the RTL: every mutant (a changed
    /// rounding mode, a flipped overflow mode, an off-by-one shift, one
    /// quantizer at a time) must fail the unit's vectors; exit status 0 only
    /// when all do.
    Mutate(cmd::mutate::MutateArgs),
    /// Add up the results of `rtl-check --shard K/N` runs (files or
    /// `--result` directories): fails unless every shard of one run (one
    /// design, configuration, stream, simulator and fxshade) is there and
    /// every vector passed, and names the missing, stopped, failing or odd
    /// shards, with the line that resubmits them.
    Merge(cmd::merge::MergeArgs),
    /// Evaluate one point of `explore --launcher` (what the launcher runs).
    #[command(hide = true)]
    ExplorePoint(cmd::explore::PointArgs),
    /// Rasterize a mesh (sphere:N, torus:N or an OBJ file), run the
    /// bit-accurate pipeline on every pixel for each method (and with --rtl
    /// the simulated RTL top, which must give the same image), and write the
    /// images, error heat-maps and metrics against the f64 reference.
    Render(cmd::render::RenderArgs),
    /// Design exploration: sweep any configuration key, width group,
    /// method or table depth; measure each point's error (unit analyses,
    /// rendered images) and hardware cost; Pareto fronts and plots; with
    /// --optimize, the cheapest per-stage widths meeting goals.
    Explore(Box<cmd::explore::ExploreArgs>),
    /// Synthesize a unit's generated RTL with Yosys for a target and, where
    /// an open flow exists (nextpnr-ice40, nextpnr-ecp5), place and route it
    /// in a harness that registers every port: LUT, FF, DSP and block-RAM
    /// counts, Fmax, latency and throughput, cached per configuration.
    Synth(cmd::synth::SynthArgs),
    /// Prove the handshake properties of a unit's generated RTL (no item
    /// created, lost or duplicated; outputs held under stall; the pipeline
    /// drains) with Yosys, yosys-smtbmc and z3, by k-induction.
    Formal(cmd::formal::FormalArgs),
    /// Prove a unit's generated RTL equal to its traced datapath for every
    /// input value (Yosys's model of the Verilog against the trace's own
    /// SMT encoding, z3 or Bitwuzla): proved, a counterexample with a
    /// vector set that reproduces it, or unknown.
    Equiv(cmd::equiv::EquivArgs),
    /// Benchmarks of the model's speed.
    #[command(subcommand)]
    Bench(cmd::bench::BenchCmd),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    env::init();
    let r = match &cli.cmd {
        Command::Config(c) => cmd::config::run(c),
        Command::Ops(a) => cmd::ops::run(a),
        Command::Bench(b) => cmd::bench::run(b),
        Command::Report(a) => cmd::report::run(a),
        Command::Stages(a) => cmd::ops::run_stages(a),
        Command::Error(e) => cmd::error::run(e),
        Command::Coeffs(a) => cmd::coeffs::run(a),
        Command::Paper(a) => cmd::paper::run(a),
        Command::Vectors(a) => cmd::vectors::run(a),
        Command::PolarFrames(a) => cmd::polar_frames::run(a),
        Command::BakeImplied(a) => cmd::bake::run(a),
        Command::Rtl(a) => cmd::rtl::run(a),
        Command::RtlCheck(a) => cmd::rtl_check::run(a),
        Command::Mutate(a) => cmd::mutate::run(a),
        Command::Merge(a) => cmd::merge::run(a),
        Command::ExplorePoint(a) => explore::launch::run_point(&a.job, &a.result),
        Command::Render(a) => cmd::render::run(a),
        Command::Explore(a) => cmd::explore::run(a),
        Command::Synth(a) => cmd::synth::run(a),
        Command::Formal(a) => cmd::formal::run(a),
        Command::Equiv(a) => cmd::equiv::run(a),
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        // A reader that closed the pipe (`fxshade … | head`) wanted no more:
        // stop quietly, as `ls | head` does.
        Err(e)
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            }) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            if let Some(ce) = e.downcast_ref::<ConfigErrors>() {
                for line in ce.0.iter() {
                    eprintln!("error: {line}");
                }
                return ExitCode::from(2);
            }
            if let Some(u) = e.downcast_ref::<output::UsageError>() {
                eprintln!("error: {u}");
                return ExitCode::from(2);
            }
            // A count too large for the vectors' index or for memory is a
            // bad flag too.
            if let Some(r @ fxshade_model::vectors::RtlError::TooMany { .. }) =
                e.downcast_ref::<fxshade_model::vectors::RtlError>()
            {
                eprintln!("error: {r}");
                return ExitCode::from(2);
            }
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}
