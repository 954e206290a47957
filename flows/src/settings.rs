//! What the flows are told by the program that runs them: process limits,
//! build and generator options, where to keep SMT queries, the job array's
//! variables and the search path. The CLI reads these from its environment
//! in one place (its `env` module) and [`install`]s them before any flow
//! runs; the flows never read the process environment.
//!
//! Not installed (a library user, a unit test), every value is its
//! default: no limit overrides, optimized Verilator builds, one generator
//! thread per core, no SMT dump, no job array, an empty search path.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::PathBuf;
use std::sync::OnceLock;

/// The flows' settings (see the [module](self) documentation).
#[derive(Clone, Debug, Default)]
pub struct Settings {
    /// Verilator models built without optimization (the CLI's
    /// `FXSHADE_QUICK_BUILD=1`).
    pub quick_build: bool,
    /// Vector generator threads per simulation (`FXSHADE_GEN_THREADS`);
    /// `None`: the machine's cores.
    pub gen_threads: Option<usize>,
    /// Keep every SMT query in this directory (`FXSHADE_SMT_DUMP`).
    pub smt_dump: Option<PathBuf>,
    /// Process limits in seconds by the name of the variable that set them
    /// (`FXSHADE_SYNTH_TIMEOUT` → 3600): the name is what a timeout's error
    /// tells the user to raise ([`crate::proc::Limit`]).
    pub timeouts: BTreeMap<String, u64>,
    /// The job-array variables `--shard auto` reads (`SLURM_ARRAY_*`,
    /// `LSB_JOBINDEX*`, `SGE_TASK_*`, `JOB_COMPLETION_INDEX`,
    /// `FXSHADE_SHARD*`), by name ([`crate::shard::detect`]).
    pub job_array: BTreeMap<String, String>,
    /// The program search path, where Yosys's data directory is looked for
    /// beside its binary.
    pub path: OsString,
}

static SETTINGS: OnceLock<Settings> = OnceLock::new();

/// Install the settings every later flow reads; the first installation
/// stays (a second is handed back as `Err`).
///
/// # Errors
///
/// `Err(s)` when settings were installed already.
pub fn install(s: Settings) -> Result<(), Settings> {
    SETTINGS.set(s)
}

/// The installed settings, else the defaults.
pub fn get() -> &'static Settings {
    static DEFAULT: OnceLock<Settings> = OnceLock::new();
    SETTINGS
        .get()
        .unwrap_or_else(|| DEFAULT.get_or_init(Settings::default))
}
