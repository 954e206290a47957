//! `fxshade config show|check`.

use std::path::PathBuf;

use clap::Subcommand;
use fxshade_model::config::Config;

use super::ConfigArgs;

/// `fxshade config ...`
#[derive(Subcommand, Debug)]
pub enum ConfigCmd {
    /// Print the effective configuration (the embedded default, or --config
    /// FILE, with --set overrides applied), with a comment on every field.
    Show {
        #[command(flatten)]
        cfg: ConfigArgs,
        /// Print JSON instead of TOML.
        #[arg(long)]
        json: bool,
    },
    /// Validate a configuration file: every unknown key, missing key, bad
    /// value and too-wide intermediate is reported with its line; exit
    /// status 2 when anything is wrong.
    Check {
        /// The file to check.
        file: PathBuf,
        /// Overrides to apply before checking.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
}

/// Run it.
pub fn run(cmd: &ConfigCmd) -> anyhow::Result<()> {
    match cmd {
        ConfigCmd::Show { cfg, json } => {
            let c = cfg.resolve()?;
            if *json {
                crate::output::print_out(&(serde_json::to_string_pretty(&c.to_json())? + "\n"))?;
            } else {
                crate::output::print_out(&c.to_toml())?;
            }
        }
        ConfigCmd::Check { file, set } => {
            let c = Config::resolve(Some(file), set)?;
            let stages: usize = c
                .units()
                .iter()
                .map(|u| {
                    u.iter()
                        .filter(|(_, v)| matches!(v, fxshade_model::config::Value::Stage(_)))
                        .count()
                })
                .sum();
            crate::output::print_out(&format!(
                "{}: ok ({} units, {stages} stages)\n",
                file.display(),
                c.units().len()
            ))?;
        }
    }
    Ok(())
}
