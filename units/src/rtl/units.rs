//! The registry of units with RTL: each entry names the unit, its
//! variants (and the override selecting each), how to build its traced
//! [`Design`] from a configuration, and how to draw its input vectors
//! (corner cases first); the vector flow above (`fxshade_model::rtl::units`)
//! streams, caches and checks them.

use super::Design;
use crate::config::Config;
use crate::format::Format;
use fxshade_numbers::convert::narrow;

/// Which input rows a unit's generator makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// The corner cases: a fixed list for a configuration and seed.
    Corners,
    /// `n` random rows (the random part of a vector stream is drawn in
    /// chunks, each from a seed of its own).
    Random(usize),
}

/// A unit's input generator: rows (codes in input-port order) of a part
/// of the stream, for a seed.
pub type InputsFn = fn(&Config, Part, u64) -> Result<Vec<Vec<i128>>, RtlError>;

/// A unit with RTL.
pub struct RtlUnit {
    /// Name: configuration section (or scope), module, vector directory.
    pub name: &'static str,
    /// One line for people.
    pub doc: &'static str,
    /// Variants: name and the `--set` overrides selecting it, separated by
    /// `;` (none: the empty string); [`overrides`] splits them.
    pub variants: &'static [(&'static str, &'static str)],
    /// The traced datapath of a configuration (call [`RtlUnit::design`],
    /// which also records the sections it reads).
    pub build: fn(&Config) -> Result<Design, RtlError>,
    /// Input rows (codes in the input-port order) for a seed: the corner
    /// cases, or random rows.
    pub inputs: InputsFn,
}

impl RtlUnit {
    /// The traced datapath of a configuration, its
    /// [`config_key`](Design::config_key) the sections of `cfg` that
    /// building it read ([`Config::recording`]): the generated header's
    /// hash and the core's name change with those sections only, so adding
    /// a unit (a new section) or editing one this module never reads leaves
    /// them as they are.
    ///
    /// # Errors
    ///
    /// The [`RtlError`] of the unit's `build` for `cfg`.
    pub fn design(&self, cfg: &Config) -> Result<Design, RtlError> {
        let (d, sections) = cfg.recording(|c| (self.build)(c));
        let mut d = d?;
        d.config_key = cfg.sections_toml(&sections);
        Ok(d)
    }
}

/// The `--set` overrides of a variant's selector (`a=1; b="x"`).
pub fn overrides(set: &str) -> impl Iterator<Item = &str> {
    set.split(';').map(str::trim).filter(|s| !s.is_empty())
}

/// Every unit with RTL, in pipeline order, the pipeline top last: the
/// `rtl` modules of [`crate::units::UNITS`].
pub fn all() -> impl Iterator<Item = &'static RtlUnit> {
    crate::units::UNITS
        .iter()
        .flat_map(|u| u.rtl().iter().copied())
}

/// Look a unit up by name.
pub fn unit(name: &str) -> Option<&'static RtlUnit> {
    all().find(|u| u.name == name)
}

/// The names of every unit with RTL, for messages.
pub fn names() -> String {
    all().map(|u| u.name).collect::<Vec<_>>().join(", ")
}

/// A design of `unit` for `cfg`: its source and overrides (escaped) and
/// TOML go into the generated header, its `[rtl]` section sets the
/// pipelining and the handshake.
pub fn design(
    unit: &'static str,
    variant: &str,
    trace: crate::datapath::Trace,
    cfg: &Config,
    notes: Vec<String>,
) -> Design {
    // Printable ASCII only: this goes into generated headers.
    let mut source = cfg.source.clone();
    if !cfg.overrides.is_empty() {
        let o: Vec<String> = cfg
            .overrides
            .iter()
            .map(|o| crate::escape::line(o))
            .collect();
        source += &format!(", overrides: {}", o.join(" "));
    }
    Design {
        module: unit.to_string(),
        unit,
        variant: variant.to_string(),
        trace,
        config_source: source,
        config_toml: cfg.to_toml(),
        config_key: String::new(),
        notes,
        pipelining: super::section::pipelining(cfg),
        setup: Vec::new(),
        handshake: super::section::handshake(cfg),
        parameters: serde_json::Value::Null,
    }
}

/// Inputs that make each of `stages` meet an exact rounding tie (a
/// nearest-mode quantization whose dropped bits are exactly one half: what
/// tells `half_up` from `half_even`, and what random vectors almost never
/// contain), up to `per_stage` each, among `tries` candidates from `gen`
/// (give it codes with many trailing zeros). `eval` runs one candidate in
/// the scalar fixed-point context.
pub fn hunt_ties(
    stages: &[&'static str],
    per_stage: usize,
    tries: usize,
    mut gen: impl FnMut() -> Vec<i128>,
    mut eval: impl FnMut(&mut crate::datapath::Fixed<i128>, &[i128]),
) -> Vec<Vec<i128>> {
    let mut fx = crate::datapath::Fixed::<i128>::new();
    let mut found: Vec<(&str, usize)> = stages.iter().map(|s| (*s, 0)).collect();
    let mut out = Vec::new();
    for _ in 0..tries {
        if found.iter().all(|(_, c)| *c >= per_stage) {
            break;
        }
        let cand = gen();
        fx.reset();
        eval(&mut fx, &cand);
        let mut useful = false;
        for (st, c) in found.iter_mut() {
            if *c < per_stage && fx.ties().iter().any(|(s, k)| s == st && *k > 0) {
                *c += 1;
                useful = true;
            }
        }
        if useful {
            out.push(cand);
        }
    }
    out
}

/// A random code of `f` with a random number of trailing zero bits (or
/// zero), for tie hunting.
pub fn structured_code(f: Format, rng: &mut crate::sampling::Rng) -> i128 {
    let span = narrow::<u64, _>(f.max_code() - f.min_code() + 1);
    let c = f.min_code() + i128::from(rng.below(span));
    let tz = narrow::<u32, _>(rng.below(u64::from(f.width())));
    if rng.below(3) == 0 {
        0
    } else {
        c & !((1i128 << tz) - 1)
    }
}

/// Why RTL parameters or vectors could not be generated, for any unit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RtlError {
    /// An input or constant could not be converted.
    #[error(transparent)]
    Convert(#[from] crate::format::ConvertError),
    /// The normalizer could not be designed.
    #[error(transparent)]
    Design(#[from] crate::normalizer::DesignError),
    /// The polar configuration is unusable.
    #[error(transparent)]
    Polar(#[from] crate::polar::PolarError),
    /// The angles configuration is unusable.
    #[error(transparent)]
    Angles(#[from] crate::angles::AnglesError),
    /// A variant the RTL does not implement.
    #[error("{unit}.method = \"{method}\": the RTL implements {supported} only")]
    Method {
        /// Unit.
        unit: &'static str,
        /// The configured variant.
        method: &'static str,
        /// What the RTL implements.
        supported: &'static str,
    },
    /// A stage the RTL cannot express.
    #[error("{unit}.{stage}: {why}")]
    Stage {
        /// Unit.
        unit: &'static str,
        /// Stage name.
        stage: &'static str,
        /// Why.
        why: String,
    },
    /// The design cannot be emitted.
    #[error(transparent)]
    Emit(#[from] crate::rtl::EmitError),
    /// The datapath cannot be compiled.
    #[error(transparent)]
    Compile(#[from] crate::datapath::CompileError),
    /// The pipeline cannot be built.
    #[error(transparent)]
    Pipeline(#[from] crate::pipeline::PipelineError),
    /// The lighting unit cannot be built.
    #[error(transparent)]
    Lighting(#[from] crate::lighting::LightingError),
    /// More vectors than can be made.
    #[error("--count {count}: too many vectors: {why}")]
    TooMany {
        /// The count asked for.
        count: u128,
        /// Why it is too many.
        why: String,
    },
    /// The cache cannot be used.
    #[error("{0}")]
    Cache(String),
    /// Too few vectors for the corner cases.
    #[error("--count {count} is below the {corners} corner cases every set holds")]
    Count {
        /// Requested.
        count: usize,
        /// Needed at least.
        corners: usize,
    },
}
