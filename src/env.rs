//! Every environment variable fxshade reads, read here, once, when the
//! program starts ([`init`]): the rest of the program is handed the values
//! ([`get`]) and never asks the process. The model crates read none.
//!
//! | variable | what it sets | read into |
//! |---|---|---|
//! | `FXSHADE_CACHE_DIR`, `XDG_CACHE_HOME`, `HOME` (and the password database) | the cache root, installed into [`fxshade_model::cache`] | [`ProcessEnv::cache`] |
//! | `FXSHADE_SEARCH` | `full` or `quick` mutant-killer search | [`ProcessEnv::search`] |
//! | `FXSHADE_QUICK_BUILD=1` | Verilator models built without optimization | [`Settings::quick_build`] |
//! | `FXSHADE_GEN_THREADS` | vector generator threads per simulation | [`Settings::gen_threads`] |
//! | `FXSHADE_SMT_DUMP=DIR` | keep every SMT query in `DIR` | [`Settings::smt_dump`] |
//! | `FXSHADE_{PROBE,BUILD,FORMAL,SYNTH,LAUNCH,SIM_IDLE}_TIMEOUT` | process limits in seconds | [`Settings::timeouts`] |
//! | `FXSHADE_SHARD`, `FXSHADE_SHARDS`, `SLURM_ARRAY_*`, `LSB_JOBINDEX*`, `SGE_TASK_*`, `JOB_COMPLETION_INDEX` | `--shard auto` | [`Settings::job_array`] |
//! | `PATH` | where Yosys's data directory is looked for | [`Settings::path`] |
//!
//! Empty values count as unset. No value here changes a result silently:
//! the search mode is part of every cache key, and timeouts only stop work
//! with an error that names their variable.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::PathBuf;
use std::sync::OnceLock;

use fxshade_flows::settings::Settings;

/// The variables of [`self`], as read at start-up.
#[derive(Clone, Debug)]
pub struct ProcessEnv {
    /// What the cache root is resolved from.
    pub cache: fxshade_model::cache::Env,
    /// `FXSHADE_SEARCH` as given (parsed by [`crate::cmd::search_mode`],
    /// which names the variable when the value is wrong).
    pub search: Option<OsString>,
    /// What the flows are told ([`fxshade_flows::settings`]): the quick
    /// build, generator threads, SMT dump, timeouts, job array and `PATH`.
    pub flows: Settings,
}

static ENV: OnceLock<ProcessEnv> = OnceLock::new();

/// Read the environment (once), install the cache it names into the
/// model ([`fxshade_model::cache::install`]) and the flows' settings
/// ([`fxshade_flows::settings::install`]).
pub fn init() -> &'static ProcessEnv {
    let e = get();
    fxshade_model::cache::install(e.cache.clone());
    // A second installation keeps the first, which came from here too.
    let _ = fxshade_flows::settings::install(e.flows.clone());
    e
}

/// The environment read at start-up (read now if [`init`] has not run:
/// the CLI's unit tests).
pub fn get() -> &'static ProcessEnv {
    ENV.get_or_init(read)
}

fn read() -> ProcessEnv {
    let os = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty());
    let path = |k: &str| os(k).map(PathBuf::from);
    let text = |k: &str| os(k).and_then(|v| v.into_string().ok());
    let uid = fxshade_model::cache::uid();
    let cache = fxshade_model::cache::Env {
        fxshade_cache_dir: path("FXSHADE_CACHE_DIR"),
        xdg_cache_home: path("XDG_CACHE_HOME"),
        home: path("HOME"),
        passwd_home: fxshade_model::cache::passwd_home(uid),
        temp_dir: std::env::temp_dir(),
        uid,
    };
    let mut timeouts = BTreeMap::new();
    let mut job_array = BTreeMap::new();
    for (k, v) in std::env::vars_os() {
        let (Some(k), Some(v)) = (k.to_str(), v.to_str()) else {
            continue;
        };
        if k.starts_with("FXSHADE_") && k.ends_with("_TIMEOUT") {
            if let Some(s) = v.trim().parse::<u64>().ok().filter(|&s| s > 0) {
                timeouts.insert(k.to_string(), s);
            }
        }
        if k.starts_with("SLURM_ARRAY_")
            || k.starts_with("LSB_JOBINDEX")
            || k.starts_with("SGE_TASK_")
            || k == "JOB_COMPLETION_INDEX"
            || k.starts_with("FXSHADE_SHARD")
        {
            job_array.insert(k.to_string(), v.to_string());
        }
    }
    ProcessEnv {
        cache,
        search: os("FXSHADE_SEARCH"),
        flows: Settings {
            quick_build: text("FXSHADE_QUICK_BUILD").is_some_and(|v| v == "1"),
            gen_threads: text("FXSHADE_GEN_THREADS")
                .and_then(|s| s.parse::<usize>().ok())
                .filter(|&n| n >= 1),
            smt_dump: path("FXSHADE_SMT_DUMP"),
            timeouts,
            job_array,
            path: std::env::var_os("PATH").unwrap_or_default(),
        },
    }
}
