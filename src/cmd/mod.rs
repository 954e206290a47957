//! One module per subcommand, each thin over the model crate.

pub mod bake;
pub mod bench;
pub mod bench_cosim;
pub mod bench_engine;
pub mod bench_render;
pub mod coeffs;
pub mod config;
pub mod equiv;
pub mod error;
pub mod explore;
pub mod formal;
pub mod merge;
pub mod mutate;
pub mod ops;
pub mod paper;
pub mod polar_frames;
pub mod render;
pub mod report;
pub mod report_found;
pub mod report_html;
pub mod rtl;
pub mod rtl_check;
pub mod synth;
pub mod vectors;

use std::path::PathBuf;

use clap::Args;
use fxshade_model::config::{Config, ConfigErrors};

/// The unit names of the registry ([`fxshade_model::rtl::units::all`]),
/// and `extra` words, as a flag's possible values: `--help` lists them and
/// a wrong name is refused with them, so a new unit appears everywhere.
pub fn unit_arg(extra: &'static [&'static str]) -> clap::builder::PossibleValuesParser {
    let mut v: Vec<clap::builder::PossibleValue> = fxshade_model::rtl::units::all()
        .map(|u| clap::builder::PossibleValue::new(u.name).help(u.doc))
        .collect();
    v.extend(extra.iter().map(|e| clap::builder::PossibleValue::new(*e)));
    clap::builder::PossibleValuesParser::new(v)
}

/// A finite number for a flag (clap names the flag when this refuses one:
/// `nan` and `inf` parse as `f64` but mean nothing to any flag).
pub fn finite_f64(s: &str) -> Result<f64, String> {
    let x: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))?;
    if !x.is_finite() {
        return Err(format!("`{s}` is not a finite number"));
    }
    Ok(x)
}

/// `--wrap`: an interface wrapper around an emitted module.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// AXI4-Stream: `s_axis_*` in (a stream per set-up port of a pipeline
    /// top), `m_axis_*` out, `m_axis_tuser` the overflow flags; byte-aligned
    /// `tdata` (`fxshade_model::rtl::axis`).
    Axis,
}

/// `--config FILE` and `--set KEY=VALUE`, on every command that uses a
/// configuration.
#[derive(Args, Debug, Clone, Default)]
pub struct ConfigArgs {
    /// Configuration file (TOML); the embedded default when absent.
    #[arg(long, short = 'c', value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Override one value, e.g. `--set normalize.d.format=U1F17` or
    /// `--set lighting.i0_km=0.8` (repeatable; applied in order).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

impl ConfigArgs {
    /// The effective configuration.
    pub fn resolve(&self) -> Result<Config, ConfigErrors> {
        Config::resolve(self.config.as_deref(), &self.set)
    }

    /// The effective configuration with `extra` overrides after `--set`'s.
    pub fn resolve_with(&self, extra: &[String]) -> Result<Config, ConfigErrors> {
        let mut all = self.set.clone();
        all.extend(extra.iter().cloned());
        Config::resolve(self.config.as_deref(), &all)
    }
}

/// How the generated RTL is pipelined: shorthands for the `[rtl]` section.
#[derive(Args, Debug, Clone, Default)]
pub struct PipelineArgs {
    /// `compact`: a register after every quantization and table read;
    /// `target`: registers where the delay model of `--target` needs them
    /// for `--clock-ns` (sets `rtl.pipeline`).
    #[arg(long, value_parser = ["compact", "target"])]
    pub pipeline: Option<String>,
    /// The technology whose delay model places the registers (sets
    /// `rtl.target`; implies `--pipeline target`).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(
        fxshade_model::rtl::targets::Target::pipelined_names()
    ))]
    pub target: Option<String>,
    /// The requested clock period in ns (sets `rtl.clock_ns`; implies
    /// `--pipeline target`).
    #[arg(long = "clock-ns", value_name = "NS", value_parser = finite_f64)]
    pub clock_ns: Option<f64>,
}

impl PipelineArgs {
    /// The flags as configuration overrides, applied after `--set`.
    pub fn overrides(&self) -> Vec<String> {
        pipeline_overrides(
            self.pipeline.as_deref(),
            self.target.as_deref(),
            self.clock_ns,
        )
    }
}

pub use fxshade_flows::rtl_flow::pipeline_overrides;

/// How thoroughly vectors' mutant killers are searched
/// ([`fxshade_model::rtl::search::Search`]): `FXSHADE_SEARCH=quick` or
/// `full` (the default, when unset), read here, at the CLI's edge, and
/// passed into the model; any other value is an error naming the variable.
pub fn search_mode() -> anyhow::Result<fxshade_model::rtl::search::Search> {
    use fxshade_model::rtl::search::Search;
    match &crate::env::get().search {
        None => Ok(Search::Full),
        Some(v) => v.to_str().and_then(Search::from_name).ok_or_else(|| {
            anyhow::anyhow!(
                "FXSHADE_SEARCH={}: expected `full` or `quick`",
                v.to_string_lossy()
            )
        }),
    }
}
