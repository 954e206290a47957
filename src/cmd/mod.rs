//! One module per subcommand, each thin over the model crate.

pub mod bake;
pub mod bench;
pub mod coeffs;
pub mod config;
pub mod error;
pub mod explore;
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
}
