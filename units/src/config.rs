//! Configuration: the formats of every unit's ports and stages, and its
//! parameters, from TOML — with an embedded default.
//!
//! Each unit declares its fields once ([`UnitDecl`]); that declaration drives
//! parsing, validation, `config show`, and the overrides given as
//! `--set unit.field=value` or `--set unit.stage.format=I2F14`. A stage is
//! written
//!
//! ```toml
//! [normalize]
//! d = { format = "U1F17", round = "half_even", overflow = "saturate" }
//! ```
//!
//! Every error names the file and line (or the flag), the key, and why.
//! After parsing, each unit runs once in the counting context with the
//! configured formats, so an exact intermediate wider than the model holds
//! ([`crate::datapath::MAX_EXACT_WIDTH`]) is rejected naming the stage it
//! came from.

use fxshade_numbers::convert::{narrow, to_f64};
use std::collections::BTreeSet;
use std::fmt;
use std::path::Path;
use std::sync::{Arc, Mutex};

use toml_edit::{ImDocument, Item, Value as TomlValue};

use crate::format::Format;
use crate::quantize::{Overflow, Quant, Rounding};

/// The embedded default configuration.
pub const DEFAULT_TOML: &str = include_str!("default.toml");

/// What kind of value a field holds.
#[derive(Clone, Copy, Debug)]
pub enum FieldKind {
    /// A quantization step: `{ format, round, overflow }`.
    Stage,
    /// A real number in `min ..= max`.
    Number {
        /// Smallest accepted value.
        min: f64,
        /// Largest accepted value.
        max: f64,
    },
    /// An integer in `min ..= max`.
    Integer {
        /// Smallest accepted value.
        min: i64,
        /// Largest accepted value.
        max: i64,
    },
    /// One of the listed names.
    Choice(&'static [&'static str]),
    /// One of the names a registry lists (read when a value is checked):
    /// `rtl.target` takes the technology families with a delay model.
    ChoiceOf(fn() -> &'static [&'static str]),
}

/// One field of a unit's configuration section.
#[derive(Clone, Copy, Debug)]
pub struct FieldDecl {
    /// Key.
    pub name: &'static str,
    /// Kind of value.
    pub kind: FieldKind,
    /// One line for people (`config show` prints it as a comment).
    pub doc: &'static str,
}

/// A unit's configuration section.
#[derive(Clone, Copy, Debug)]
pub struct UnitDecl {
    /// Section name.
    pub name: &'static str,
    /// One line for people.
    pub doc: &'static str,
    /// Its fields, in the order `config show` prints them.
    pub fields: &'static [FieldDecl],
    /// The named width groups its stage fields belong to, as
    /// `(group, fields)`: `fxshade explore --vary width.<group>=W` sets the
    /// total width of every member of the group, in every unit, to `W`
    /// bits, keeping each member's integer bits (see [`WIDTH_GROUPS`]).
    pub groups: &'static [(&'static str, &'static [&'static str])],
}

/// The width groups and what they carry, in the order `explore` lists them.
/// A group's members are declared by the units ([`UnitDecl::groups`]).
pub const WIDTH_GROUPS: &[(&str, &str)] = &[
    ("normals", "every format that carries a normal: vertex normals, the interpolated normal, the normalizer's input and output, the lighting unit's N, the CORDIC input"),
    ("light", "unit light and half vectors and their tangent-space images: lighting.light, polar.lyz, polar.out"),
    ("normalizer", "the g(d) datapath: d, the coefficients, the Horner intermediate, g"),
    ("interp", "the barycentrics and the quadratic weights"),
    ("tables", "the sin/cos table entries"),
    ("cordic", "the CORDIC coordinates and angle accumulator"),
    ("shading", "N·L, N·H and the specular power chain"),
    ("level", "the output intensity level: 8 integer bits for the 8-bit pixel, and any fraction bits beyond it (U8F0 is the pixel itself)"),
];

impl UnitDecl {
    fn field(&self, name: &str) -> Option<(usize, &'static FieldDecl)> {
        self.fields.iter().enumerate().find(|(_, f)| f.name == name)
    }
}

/// A configured value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// A quantization step.
    Stage(Quant),
    /// A real number.
    Number(f64),
    /// An integer.
    Integer(i64),
    /// A name from a choice list.
    Choice(&'static str),
}

/// Where a value came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Origin {
    /// A line of a file (or of the embedded default, named `<default>`).
    File {
        /// Path as given.
        path: Arc<str>,
        /// 1-based line.
        line: usize,
    },
    /// A `--set` flag.
    Flag(String),
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Origin::File { path, line } => write!(f, "{path}:{line}"),
            Origin::Flag(s) => write!(f, "--set {s}"),
        }
    }
}

/// One configuration problem.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{path}: cannot read: {reason}")]
    Read {
        /// Path.
        path: String,
        /// The OS error.
        reason: String,
    },
    /// Not TOML.
    #[error("{at}: not valid TOML: {msg}")]
    Syntax {
        /// Where.
        at: Origin,
        /// The parser's message.
        msg: String,
    },
    /// A key no unit declares.
    #[error("{at}: unknown key `{key}`; expected one of: {expected}")]
    UnknownKey {
        /// Where.
        at: Origin,
        /// The dotted key.
        key: String,
        /// The keys allowed there.
        expected: String,
    },
    /// A declared key that is absent.
    #[error("{at}: missing key `{key}` ({doc})")]
    MissingKey {
        /// The section (or file) that lacks it.
        at: Origin,
        /// The dotted key.
        key: String,
        /// What the key is for.
        doc: String,
    },
    /// A value of the wrong kind or out of range.
    #[error("{at}: `{key}`: {msg}")]
    BadValue {
        /// Where.
        at: Origin,
        /// The dotted key.
        key: String,
        /// Why.
        msg: String,
    },
}

/// All problems found in one configuration (at least one).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", .0.iter().map(|e| e.to_string()).collect::<Vec<_>>().join("\n"))]
pub struct ConfigErrors(pub Vec<ConfigError>);

/// One unit's configured values, parallel to its declaration's fields.
#[derive(Clone, Debug)]
pub struct UnitConfig {
    /// The declaration.
    pub decl: &'static UnitDecl,
    values: Vec<(Value, Origin)>,
}

impl UnitConfig {
    fn get(&self, name: &str) -> &(Value, Origin) {
        let (i, _) = self
            .decl
            .field(name)
            .unwrap_or_else(|| panic!("unit {} declares no field {name}", self.decl.name));
        &self.values[i]
    }
    /// The quantization step of stage `name` (a declared `Stage` field).
    ///
    /// # Panics
    ///
    /// If the unit declares no field `name`, or `name` is not a `Stage` field.
    pub(crate) fn stage(&self, name: &str) -> Quant {
        match self.get(name).0 {
            Value::Stage(q) => q,
            ref v => panic!("{}.{name} is {v:?}, not a stage", self.decl.name),
        }
    }
    /// This section as the typed value `S`: each field of `S` is the
    /// declared field of the same name (a stage as a [`Quant`] named after
    /// its field, a number as `f64`, an integer as any integer type that
    /// holds its declared range, a choice as an enum whose `serde` names are
    /// the declared names).
    ///
    /// # Errors
    ///
    /// When `S` and the declaration disagree (a field missing on either
    /// side, a choice `S` cannot name, an integer out of `S`'s type): a
    /// programming error, which each unit's `section_is_typed` test catches for
    /// every declared choice.
    pub fn try_typed<S: Section>(&self) -> Result<S, SectionError> {
        let mut m = serde_json::Map::new();
        for (decl, v) in self.iter() {
            let j = match v {
                Value::Stage(q) => serde_json::json!({
                    "stage": decl.name,
                    "format": q.format().to_string(),
                    "round": q.round().name(),
                    "overflow": q.overflow().name(),
                }),
                Value::Number(x) => serde_json::json!(x),
                Value::Integer(x) => serde_json::json!(x),
                Value::Choice(s) => serde_json::json!(s),
            };
            m.insert(decl.name.to_string(), j);
        }
        serde_json::from_value(serde_json::Value::Object(m)).map_err(|e| SectionError {
            section: self.decl.name,
            message: e.to_string(),
        })
    }
    /// Where the value of `name` came from.
    pub fn origin(&self, name: &str) -> &Origin {
        &self.get(name).1
    }
    /// Every field with its value.
    pub fn iter(&self) -> impl Iterator<Item = (&'static FieldDecl, &Value)> {
        self.decl
            .fields
            .iter()
            .zip(self.values.iter().map(|(v, _)| v))
    }
}

/// A unit's configuration section as one typed value, read from a
/// validated [`Config`] by [`Config::section`]: the unit's code reads
/// `cfg.section::<NormalizeConfig>().theta` instead of looking a field up by
/// its name. The declaration ([`UnitDecl`]) stays the source of the keys,
/// ranges, documentation and error positions; the struct is checked against
/// it by every unit's tests ([`crate::units::Unit::section_is_typed`]).
///
/// Implement it with `#[derive(serde::Deserialize)]` and
/// `#[serde(deny_unknown_fields)]`, one field per declared field.
pub trait Section: serde::de::DeserializeOwned {
    /// The declaration this section is read from.
    const DECL: &'static UnitDecl;

    /// The section's defaults: the embedded default configuration's values.
    ///
    /// # Panics
    ///
    /// As [`Config::section`].
    fn defaults() -> Self {
        Config::embedded().section()
    }
}

/// `serde::Deserialize` for a choice type from its `from_name(&str) ->
/// Option<Self>`: the configuration's names are the type's own, written once.
#[macro_export]
macro_rules! deserialize_by_name {
    ($($t:ty),+ $(,)?) => {$(
        impl<'de> serde::Deserialize<'de> for $t {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let s = <String as serde::Deserialize>::deserialize(d)?;
                <$t>::from_name(&s).ok_or_else(|| {
                    serde::de::Error::custom(format!("`{s}` names no {}", stringify!($t)))
                })
            }
        }
    )+};
}

/// A typed section that does not match its declaration (see
/// [`UnitConfig::try_typed`]).
#[derive(Debug, Clone, thiserror::Error)]
#[error("the typed [{section}] section does not match its declaration: {message}")]
pub struct SectionError {
    /// The section.
    pub section: &'static str,
    /// What serde reported.
    pub message: String,
}

/// A validated configuration: every declared unit, every field.
#[derive(Clone, Debug)]
pub struct Config {
    /// Where it came from: a path (escaped to one printable line by
    /// [`crate::escape::line`], as it appears in errors and generated
    /// files), or `<default>`.
    pub source: String,
    /// The `--set` overrides applied, in order.
    pub overrides: Vec<String>,
    units: Vec<UnitConfig>,
    /// While [`Config::recording`] runs: the names of the sections read
    /// through [`Config::unit`] (shared by the clones made meanwhile).
    reads: Option<Arc<Mutex<BTreeSet<&'static str>>>>,
}

fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

struct Parser<'a> {
    text: &'a str,
    path: Arc<str>,
    errors: Vec<ConfigError>,
    /// Where omitted sections, fields and stage parts come from (`None`
    /// while parsing the embedded default itself, which must be complete).
    defaults: Option<&'a Config>,
}

impl Parser<'_> {
    fn at(&self, span: Option<std::ops::Range<usize>>) -> Origin {
        Origin::File {
            path: self.path.clone(),
            line: span.map_or(1, |s| line_of(self.text, s.start)),
        }
    }
}

fn kind_name(v: &TomlValue) -> &'static str {
    v.type_name()
}

/// Parse one stage part (`format`, `round`, `overflow`) from a TOML value.
fn stage_part(part: &str, v: &TomlValue, q: &mut Quant) -> Result<(), String> {
    let s = v
        .as_str()
        .ok_or_else(|| format!("expected a string, found {}", kind_name(v)))?;
    match part {
        "format" => *q = q.with_format(s.parse::<Format>().map_err(|e| e.to_string())?),
        "round" => {
            *q = q.with_round(Rounding::from_name(s).ok_or_else(|| {
                format!("`{s}` is not a rounding mode; expected one of: trunc, half_up, half_even")
            })?)
        }
        "overflow" => {
            *q = q.with_overflow(Overflow::from_name(s).ok_or_else(|| {
                format!("`{s}` is not an overflow mode; expected one of: wrap, saturate")
            })?)
        }
        _ => unreachable!("caller checks the part name"),
    }
    Ok(())
}

const STAGE_PARTS: [&str; 3] = ["format", "round", "overflow"];

/// Parse a scalar field's value.
fn scalar(decl: &FieldDecl, v: &TomlValue) -> Result<Value, String> {
    match decl.kind {
        FieldKind::Stage => unreachable!("stages are tables"),
        FieldKind::Number { min, max } => {
            let x = match v {
                TomlValue::Float(f) => *f.value(),
                TomlValue::Integer(i) => to_f64(*i.value()),
                other => return Err(format!("expected a number, found {}", kind_name(other))),
            };
            if !(x >= min && x <= max) {
                return Err(format!("{x} is outside {min}..={max}"));
            }
            Ok(Value::Number(x))
        }
        FieldKind::Integer { min, max } => {
            let x = v
                .as_integer()
                .ok_or_else(|| format!("expected an integer, found {}", kind_name(v)))?;
            if !(min..=max).contains(&x) {
                return Err(format!("{x} is outside {min}..={max}"));
            }
            Ok(Value::Integer(x))
        }
        FieldKind::Choice(names) => choice(names, v),
        FieldKind::ChoiceOf(list) => choice(list(), v),
    }
}

/// A choice field's value: one of `names`.
fn choice(names: &'static [&'static str], v: &TomlValue) -> Result<Value, String> {
    let s = v
        .as_str()
        .ok_or_else(|| format!("expected a string, found {}", kind_name(v)))?;
    names
        .iter()
        .find(|n| **n == s)
        .map(|n| Value::Choice(n))
        .ok_or_else(|| format!("`{s}` is not one of: {}", names.join(", ")))
}

impl Config {
    /// The embedded default (parsed once per process).
    ///
    /// # Panics
    ///
    /// Never: [`DEFAULT_TOML`] is a complete, valid configuration, as the tests that read it
    /// confirm.
    pub fn embedded() -> Config {
        static DEFAULT: std::sync::OnceLock<Config> = std::sync::OnceLock::new();
        DEFAULT
            .get_or_init(|| {
                Self::parse_with(DEFAULT_TOML, "<default>", None)
                    .expect("the embedded default configuration is valid")
            })
            .clone()
    }

    /// Read and validate a file.
    ///
    /// # Errors
    ///
    /// [`ConfigErrors`] holding one [`ConfigError::Read`] when the file cannot be read
    /// ([`read_text_limited`](crate::input::read_text_limited): it cannot be opened or read, is a
    /// directory, is larger than [`MAX_TEXT_INPUT`](crate::input::MAX_TEXT_INPUT) or is not
    /// UTF-8); else those of [`Config::parse`].
    pub fn load(path: &Path) -> Result<Config, ConfigErrors> {
        let text = crate::input::read_text_limited(path).map_err(|reason| {
            ConfigErrors(vec![ConfigError::Read {
                path: crate::escape::line(&path.display().to_string()),
                reason,
            }])
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    /// Read `path` if given, else the embedded default; then apply `--set`
    /// overrides and validate the result.
    ///
    /// # Errors
    ///
    /// Those of [`Config::load`] for `path`, else those of [`Config::with_overrides`].
    pub fn resolve(path: Option<&Path>, overrides: &[String]) -> Result<Config, ConfigErrors> {
        let cfg = match path {
            Some(p) => Self::load(p)?,
            None => Self::embedded(),
        };
        cfg.with_overrides(overrides)
    }

    /// Parse TOML `text` (named `name` in errors), then apply `--set`
    /// overrides and validate the result, as [`Config::resolve`] does for a
    /// file.
    ///
    /// # Errors
    ///
    /// Those of [`Config::parse`] for `text`, else those of [`Config::with_overrides`].
    pub fn resolve_text(
        text: &str,
        name: &str,
        overrides: &[String],
    ) -> Result<Config, ConfigErrors> {
        Self::parse(text, name)?.with_overrides(overrides)
    }

    /// This configuration with `--set` overrides applied in order, then
    /// validated: every override's error and then every unit's.
    ///
    /// # Errors
    ///
    /// [`ConfigErrors`] listing the error of every override that fails
    /// ([`Config::apply_override`]); when all apply, the errors of the units' checks, as in
    /// [`Config::parse`].
    pub fn with_overrides(self, overrides: &[String]) -> Result<Config, ConfigErrors> {
        let mut cfg = self;
        let mut errors = Vec::new();
        for o in overrides {
            if let Err(e) = cfg.apply_override(o) {
                errors.push(e);
            }
        }
        if errors.is_empty() {
            errors = cfg.check_units();
        }
        if errors.is_empty() {
            Ok(cfg)
        } else {
            Err(ConfigErrors(errors))
        }
    }

    /// Parse and validate TOML text; `path` names it in errors. A section,
    /// field or stage part the text omits takes the embedded default's
    /// value, so a file written for an older fxshade (or listing only what
    /// it changes) stays valid when units and fields are added.
    ///
    /// # Errors
    ///
    /// [`ConfigErrors`] holding one [`ConfigError::Syntax`] when `text` is not TOML; else every
    /// [`ConfigError::UnknownKey`] (a section, field or stage part no unit declares) and
    /// [`ConfigError::BadValue`] (a section that is not a table, a value of the wrong kind or out
    /// of range; a stage's first bad part only); else the [`ConfigError::BadValue`]s of the units'
    /// checks (an exact intermediate wider than
    /// [`MAX_EXACT_WIDTH`](crate::datapath::MAX_EXACT_WIDTH), a format or mode a unit cannot use),
    /// each naming the field at fault.
    pub fn parse(text: &str, path: &str) -> Result<Config, ConfigErrors> {
        let defaults = Self::embedded();
        Self::parse_with(text, path, Some(&defaults))
    }

    fn parse_with(
        text: &str,
        path: &str,
        defaults: Option<&Config>,
    ) -> Result<Config, ConfigErrors> {
        // The path as it appears in errors and generated files: escaped,
        // so a newline in it cannot end a comment there.
        let path = crate::escape::line(path);
        let path = path.as_str();
        let mut p = Parser {
            text,
            path: Arc::from(path),
            errors: Vec::new(),
            defaults,
        };
        let doc = match ImDocument::parse(text) {
            Ok(d) => d,
            Err(e) => {
                let msg = e.message().trim().to_string();
                return Err(ConfigErrors(vec![ConfigError::Syntax {
                    at: p.at(e.span()),
                    msg,
                }]));
            }
        };
        let root = doc.as_table();
        let units = crate::units::UNITS;
        let unit_names = units
            .iter()
            .map(|u| u.name())
            .collect::<Vec<_>>()
            .join(", ");
        let mut parsed: Vec<Option<UnitConfig>> = vec![None; units.len()];
        for (key, item) in root.iter() {
            let key_span = root.key(key).and_then(|k| k.span());
            let Some(ui) = units.iter().position(|u| u.name() == key) else {
                p.errors.push(ConfigError::UnknownKey {
                    at: p.at(key_span),
                    key: key.to_string(),
                    expected: unit_names.clone(),
                });
                continue;
            };
            parsed[ui] = p.unit(units[ui].decl(), item, key_span);
        }
        for (parsed, u) in parsed.iter_mut().zip(units.iter()) {
            let present = root.contains_key(u.name());
            if !present {
                match p.defaults {
                    Some(d) => *parsed = Some(d.unit(u.name()).clone()),
                    None => p.errors.push(ConfigError::MissingKey {
                        at: p.at(None),
                        key: format!("[{}]", u.name()),
                        doc: u.decl().doc.to_string(),
                    }),
                }
            } else if parsed.is_none() && p.errors.is_empty() {
                unreachable!("a unit that failed to parse reported an error");
            }
        }
        if !p.errors.is_empty() {
            return Err(ConfigErrors(p.errors));
        }
        let cfg = Config {
            reads: None,
            source: path.to_string(),
            overrides: Vec::new(),
            units: parsed
                .into_iter()
                .map(|u| u.expect("checked above"))
                .collect(),
        };
        let errors = cfg.check_units();
        if errors.is_empty() {
            Ok(cfg)
        } else {
            Err(ConfigErrors(errors))
        }
    }

    /// Run every unit's own check (exact widths in the counting context).
    fn check_units(&self) -> Vec<ConfigError> {
        let mut errors = Vec::new();
        for u in crate::units::UNITS {
            if let Err(e) = u.check(self) {
                errors.extend(e);
            }
        }
        errors
    }

    /// Apply one `unit.field=value` or `unit.stage.part=value` override
    /// (not yet re-checked: [`Config::resolve`] does that).
    ///
    /// # Errors
    ///
    /// [`ConfigError::UnknownKey`] for a unit, field or stage part no unit declares;
    /// [`ConfigError::BadValue`] for a `spec` holding a control character or no `=`, a value of the
    /// wrong kind or out of range, a stage given neither whole (an inline table with all three
    /// parts) nor by one part, a non-stage field given parts, or a `width.<group>=BITS` whose form,
    /// width or group is unusable ([`Config::group_overrides`]).
    ///
    /// # Panics
    ///
    /// Never: `I1F0` is a valid format, a stage field always holds a stage, and every width group
    /// names stage fields.
    pub fn apply_override(&mut self, spec: &str) -> Result<(), ConfigError> {
        let at = Origin::Flag(spec.to_string());
        let bad = |key: &str, msg: String| ConfigError::BadValue {
            at: at.clone(),
            key: key.to_string(),
            msg,
        };
        if let Some(c) = crate::escape::control_char(spec) {
            return Err(ConfigError::BadValue {
                at: Origin::Flag(crate::escape::line(spec)),
                key: crate::escape::line(spec.split('=').next().unwrap_or(spec)),
                msg: format!(
                    "holds the control character {:?}; a configuration value never does",
                    c
                ),
            });
        }
        let Some((key, text)) = spec.split_once('=') else {
            return Err(bad(
                spec,
                "expected KEY=VALUE, e.g. normalize.d.format=U1F17".into(),
            ));
        };
        let key = key.trim();
        let text = text.trim();
        let value: TomlValue = text
            .parse()
            .unwrap_or_else(|_| TomlValue::from(text.to_string()));
        let parts: Vec<&str> = key.split('.').collect();
        if parts[0] == "width" {
            // A width group: every member's format at that total width,
            // each keeping its signedness and integer bits (as `explore
            // --vary width.<group>=W` does), recorded as the one override.
            let Some(group) = parts.get(1).filter(|_| parts.len() == 2) else {
                return Err(bad(
                    key,
                    "name a width group: width.<group>=BITS, e.g. width.normals=12".into(),
                ));
            };
            let w: u32 = text
                .parse()
                .ok()
                .filter(|&w| w > 0)
                .ok_or_else(|| bad(key, "a width is a positive number of bits".into()))?;
            let sets = self.group_overrides(group, w).map_err(|m| bad(key, m))?;
            let before = self.overrides.len();
            for o in &sets {
                self.apply_override(o)?;
            }
            self.overrides.truncate(before);
            self.overrides.push(spec.to_string());
            return Ok(());
        }
        let unit_names = || {
            crate::units::UNITS
                .iter()
                .map(|u| u.name())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let Some(unit) = self.units.iter_mut().find(|u| u.decl.name == parts[0]) else {
            return Err(ConfigError::UnknownKey {
                at,
                key: parts[0].to_string(),
                expected: unit_names(),
            });
        };
        let field_names = unit
            .decl
            .fields
            .iter()
            .map(|f| f.name)
            .collect::<Vec<_>>()
            .join(", ");
        let Some((i, decl)) = parts.get(1).and_then(|f| unit.decl.field(f)) else {
            return Err(ConfigError::UnknownKey {
                at,
                key: key.to_string(),
                expected: field_names,
            });
        };
        let new = match (decl.kind, parts.len()) {
            (FieldKind::Stage, 3) => {
                let part = parts[2];
                if !STAGE_PARTS.contains(&part) {
                    return Err(ConfigError::UnknownKey {
                        at,
                        key: key.to_string(),
                        expected: STAGE_PARTS.join(", "),
                    });
                }
                let Value::Stage(mut q) = unit.values[i].0 else {
                    unreachable!("stage fields hold stages")
                };
                stage_part(part, &value, &mut q).map_err(|m| bad(key, m))?;
                Value::Stage(q)
            }
            (FieldKind::Stage, 2) => {
                let t = value.as_inline_table().ok_or_else(|| {
                    bad(
                        key,
                        "expected { format = .., round = .., overflow = .. }".into(),
                    )
                })?;
                let mut q = Quant::new(
                    decl.name,
                    Format::new(true, 1, 0).expect("valid"),
                    Rounding::Trunc,
                    Overflow::Wrap,
                );
                for part in STAGE_PARTS {
                    let v = t
                        .get(part)
                        .ok_or_else(|| bad(key, format!("missing `{part}`")))?;
                    stage_part(part, v, &mut q).map_err(|m| bad(key, m))?;
                }
                Value::Stage(q)
            }
            (FieldKind::Stage, _) => {
                return Err(bad(
                    key,
                    "name a stage part: format, round or overflow".into(),
                ))
            }
            (_, 2) => scalar(decl, &value).map_err(|m| bad(key, m))?,
            _ => return Err(bad(key, format!("`{}` has no parts", parts[..2].join(".")))),
        };
        unit.values[i] = (new, at);
        self.overrides.push(spec.to_string());
        Ok(())
    }

    /// The members of width group `group` ([`WIDTH_GROUPS`]) as
    /// `unit.field` keys with their configured stages, in registry order;
    /// `None` for a group no unit declares.
    pub fn group_members(&self, group: &str) -> Option<Vec<(String, Quant)>> {
        let members: Vec<(String, Quant)> = self
            .units
            .iter()
            .flat_map(|u| {
                u.decl
                    .groups
                    .iter()
                    .filter(|(g, _)| *g == group)
                    .flat_map(|(_, fields)| fields.iter())
                    .map(move |f| (format!("{}.{f}", u.decl.name), u.stage(f)))
            })
            .collect();
        (!members.is_empty()).then_some(members)
    }

    /// The `--set` overrides that give every member of `group` a total
    /// width of `width` bits: each member keeps its signedness and integer
    /// bits (`I2F14` at 12 bits is `I2F10`). An error names a member whose
    /// integer bits leave no room (or a group no unit declares).
    ///
    /// # Errors
    ///
    /// A message naming a group no unit declares (and listing the groups), or the first member
    /// whose integer bits exceed `width` or whose format cannot be `width` bits wide (0 or above
    /// 64).
    pub fn group_overrides(&self, group: &str, width: u32) -> Result<Vec<String>, String> {
        let members = self.group_members(group).ok_or_else(|| {
            format!(
                "no width group `{group}`; the groups are {}",
                WIDTH_GROUPS
                    .iter()
                    .map(|(g, _)| *g)
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        members
            .iter()
            .map(|(key, q)| {
                let f = q.format();
                let frac = narrow::<i32, _>(width) - f.int_bits();
                if frac < 0 {
                    return Err(format!(
                        "width.{group}={width}: {key} ({f}) has {} integer bits: give at least {} bits",
                        f.int_bits(),
                        f.int_bits()
                    ));
                }
                Format::new(f.signed(), width, frac)
                    .map(|nf| format!("{key}.format={nf}"))
                    .map_err(|e| {
                        format!(
                            "width.{group}={width}: {key} ({f}) cannot keep its integer bits: {e}"
                        )
                    })
            })
            .collect()
    }

    /// The section of the unit declared by `decl`.
    ///
    /// # Panics
    ///
    /// If no registered unit is named `name`.
    pub fn unit(&self, name: &str) -> &UnitConfig {
        let u = self
            .units
            .iter()
            .find(|u| u.decl.name == name)
            .unwrap_or_else(|| panic!("no unit {name} is registered"));
        if let Some(r) = &self.reads {
            r.lock()
                .unwrap_or_else(|e| e.into_inner())
                .insert(u.decl.name);
        }
        u
    }

    /// The section `S` as its typed value (recorded as read, as
    /// [`Config::unit`]).
    ///
    /// # Panics
    ///
    /// If `S` does not match its declaration ([`UnitConfig::try_typed`]): a
    /// programming error that the unit's `section_is_typed` test reports, never
    /// a property of the configuration (a validated configuration holds
    /// only declared values).
    pub fn section<S: Section>(&self) -> S {
        self.unit(S::DECL.name)
            .try_typed()
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// Runs `f` on this configuration and returns its result with the
    /// names of the sections `f` read (through [`Config::unit`], on this
    /// configuration or a clone of it), in registry order: what a design
    /// depends on, so its header's hash covers those sections only
    /// ([`Config::sections_toml`]).
    pub fn recording<T>(&self, f: impl FnOnce(&Config) -> T) -> (T, Vec<&'static str>) {
        let rec = Arc::new(Mutex::new(BTreeSet::new()));
        let view = Config {
            reads: Some(rec.clone()),
            ..self.clone()
        };
        let out = f(&view);
        let read = rec.lock().unwrap_or_else(|e| e.into_inner()).clone();
        let names = self
            .units
            .iter()
            .map(|u| u.decl.name)
            .filter(|n| read.contains(n))
            .collect();
        (out, names)
    }

    /// The sections `names` of the effective configuration as TOML, in
    /// registry order, without the source and override comments of
    /// [`Config::to_toml`]: the same values give the same text whichever
    /// file or flags they came from.
    pub fn sections_toml(&self, names: &[&str]) -> String {
        let mut out = String::new();
        for u in self.units.iter().filter(|u| names.contains(&u.decl.name)) {
            out += &format!("[{}]\n", u.decl.name);
            for (decl, v) in u.iter() {
                out += &format!("{} = {}\n", decl.name, toml_value(v));
            }
        }
        out
    }

    /// Where the configuration came from, with its overrides, as one
    /// printable line (`<default>`, `my.toml with --set a=1 --set b=2`).
    pub fn describe(&self) -> String {
        let mut s = self.source.clone();
        for o in &self.overrides {
            s += &format!(" --set {}", crate::escape::line(o));
        }
        if !self.overrides.is_empty() {
            s = s.replacen(" --set ", " with --set ", 1);
        }
        s
    }

    /// Every unit's section, in registry order.
    pub fn units(&self) -> &[UnitConfig] {
        if let Some(r) = &self.reads {
            r.lock()
                .unwrap_or_else(|e| e.into_inner())
                .extend(self.units.iter().map(|u| u.decl.name));
        }
        &self.units
    }

    /// The effective configuration as TOML, with each field's doc as a
    /// comment; parsing it gives the same configuration.
    pub fn to_toml(&self) -> String {
        let mut out = String::from("# fxshade configuration\n");
        out += &format!("# source: {}\n", self.source);
        for o in &self.overrides {
            out += &format!("# override: --set {}\n", crate::escape::line(o));
        }
        for u in &self.units {
            out += &format!("\n# {}\n[{}]\n", u.decl.doc, u.decl.name);
            for (decl, v) in u.iter() {
                out += &format!("# {}\n{} = {}\n", decl.doc, decl.name, toml_value(v));
            }
        }
        out
    }

    /// The effective configuration as JSON: `{ unit: { field: value } }`,
    /// stages as `{ "format": "I2F14", "round": .., "overflow": .. }`.
    ///
    /// # Panics
    ///
    /// Never: a [`Quant`] always serializes to JSON.
    pub fn to_json(&self) -> serde_json::Value {
        let mut root = serde_json::Map::new();
        for u in &self.units {
            let mut m = serde_json::Map::new();
            for (decl, v) in u.iter() {
                let j = match v {
                    Value::Stage(q) => serde_json::to_value(q).expect("serializable"),
                    Value::Number(x) => serde_json::json!(x),
                    Value::Integer(x) => serde_json::json!(x),
                    Value::Choice(s) => serde_json::json!(s),
                };
                m.insert(decl.name.to_string(), j);
            }
            root.insert(u.decl.name.to_string(), serde_json::Value::Object(m));
        }
        serde_json::Value::Object(root)
    }
}

fn toml_value(v: &Value) -> String {
    match v {
        Value::Stage(q) => format!(
            "{{ format = \"{}\", round = \"{}\", overflow = \"{}\" }}",
            q.format(),
            q.round().name(),
            q.overflow().name()
        ),
        Value::Number(x) => {
            let s = format!("{x:?}");
            s
        }
        Value::Integer(x) => x.to_string(),
        Value::Choice(s) => format!("\"{s}\""),
    }
}

impl Parser<'_> {
    fn unit(
        &mut self,
        decl: &'static UnitDecl,
        item: &Item,
        key_span: Option<std::ops::Range<usize>>,
    ) -> Option<UnitConfig> {
        let Some(table) = item.as_table_like() else {
            self.errors.push(ConfigError::BadValue {
                at: self.at(key_span),
                key: decl.name.to_string(),
                msg: "expected a table [".to_string() + decl.name + "]",
            });
            return None;
        };
        let before = self.errors.len();
        let mut values: Vec<Option<(Value, Origin)>> = vec![None; decl.fields.len()];
        let expected = decl
            .fields
            .iter()
            .map(|f| f.name)
            .collect::<Vec<_>>()
            .join(", ");
        for (key, item) in table.iter() {
            let span = table.key(key).and_then(|k| k.span());
            let at = self.at(span.clone());
            let dotted = format!("{}.{key}", decl.name);
            let Some((i, f)) = decl.field(key) else {
                self.errors.push(ConfigError::UnknownKey {
                    at,
                    key: dotted,
                    expected: expected.clone(),
                });
                continue;
            };
            let v = match f.kind {
                FieldKind::Stage => self.stage(f, item, &dotted, &at),
                _ => match item.as_value() {
                    Some(v) => scalar(f, v).map_err(|msg| ConfigError::BadValue {
                        at: at.clone(),
                        key: dotted.clone(),
                        msg,
                    }),
                    None => Err(ConfigError::BadValue {
                        at: at.clone(),
                        key: dotted.clone(),
                        msg: "expected a value, found a table".into(),
                    }),
                },
            };
            match v {
                Ok(v) => values[i] = Some((v, at)),
                Err(e) => self.errors.push(e),
            }
        }
        let section_at = self.at(key_span);
        if let Some(d) = self.defaults {
            for (f, v) in decl.fields.iter().zip(values.iter_mut()) {
                if v.is_none()
                    && !self.errors[before..]
                        .iter()
                        .any(|e| error_key(e) == format!("{}.{}", decl.name, f.name))
                {
                    *v = Some(d.unit(decl.name).get(f.name).clone());
                }
            }
        }
        for (f, v) in decl.fields.iter().zip(&values) {
            if v.is_none()
                && !self.errors[before..]
                    .iter()
                    .any(|e| error_key(e) == format!("{}.{}", decl.name, f.name))
            {
                self.errors.push(ConfigError::MissingKey {
                    at: section_at.clone(),
                    key: format!("{}.{}", decl.name, f.name),
                    doc: f.doc.to_string(),
                });
            }
        }
        if self.errors.len() > before {
            return None;
        }
        Some(UnitConfig {
            decl,
            values: values.into_iter().map(|v| v.expect("checked")).collect(),
        })
    }

    fn stage(
        &self,
        f: &'static FieldDecl,
        item: &Item,
        dotted: &str,
        at: &Origin,
    ) -> Result<Value, ConfigError> {
        let bad = |at: Origin, key: String, msg: String| ConfigError::BadValue { at, key, msg };
        let Some(t) = item.as_table_like() else {
            return Err(bad(
                at.clone(),
                dotted.to_string(),
                "expected { format = \"I2F14\", round = \"half_even\", overflow = \"saturate\" }"
                    .into(),
            ));
        };
        let mut q = Quant::new(
            f.name,
            Format::new(true, 1, 0).expect("valid"),
            Rounding::Trunc,
            Overflow::Wrap,
        );
        for (k, v) in t.iter() {
            let span = t.key(k).and_then(|k| k.span());
            let key = format!("{dotted}.{k}");
            if !STAGE_PARTS.contains(&k) {
                return Err(ConfigError::UnknownKey {
                    at: self.at(span),
                    key,
                    expected: STAGE_PARTS.join(", "),
                });
            }
            let Some(v) = v.as_value() else {
                return Err(bad(self.at(span), key, "expected a string".into()));
            };
            stage_part(k, v, &mut q).map_err(|m| bad(self.at(span.clone()), key.clone(), m))?;
        }
        for part in STAGE_PARTS {
            if !t.contains_key(part) {
                if let Some(d) = self.defaults {
                    // The default stage's part.
                    let def = d.unit(dotted.split('.').next().unwrap_or("")).stage(f.name);
                    q = match part {
                        "format" => q.with_format(def.format()),
                        "round" => Quant::new(f.name, q.format(), def.round(), q.overflow()),
                        _ => Quant::new(f.name, q.format(), q.round(), def.overflow()),
                    };
                    continue;
                }
                return Err(ConfigError::MissingKey {
                    at: at.clone(),
                    key: format!("{dotted}.{part}"),
                    doc: match part {
                        "format" => "the stage's fixed-point format, e.g. I2F14",
                        "round" => "trunc, half_up or half_even",
                        _ => "wrap or saturate",
                    }
                    .to_string(),
                });
            }
        }
        Ok(Value::Stage(q))
    }
}

fn error_key(e: &ConfigError) -> String {
    match e {
        ConfigError::UnknownKey { key, .. }
        | ConfigError::MissingKey { key, .. }
        | ConfigError::BadValue { key, .. } => key.split('.').take(2).collect::<Vec<_>>().join("."),
        _ => String::new(),
    }
}

/// Build the error for a unit check: `msg` about field `field` of `unit`.
pub fn field_error(cfg: &UnitConfig, field: &str, msg: String) -> ConfigError {
    match cfg.decl.field(field) {
        Some(_) => ConfigError::BadValue {
            at: cfg.origin(field).clone(),
            key: format!("{}.{field}", cfg.decl.name),
            msg,
        },
        // A step of the datapath that is not a configuration key (an integer
        // literal, say): the embedded default is valid, so a value given
        // by a flag is the likeliest cause (the last one), then a value of
        // the file; else the section, where its first field stands.
        None => {
            let given = |flag: bool| {
                cfg.decl
                    .fields
                    .iter()
                    .zip(&cfg.values)
                    .rev()
                    .find(|(_, (_, o))| match o {
                        Origin::Flag(_) => flag,
                        Origin::File { path, .. } => !flag && &**path != "<default>",
                    })
                    .map(|(f, (_, o))| (f.name, o.clone()))
            };
            match given(true).or_else(|| given(false)) {
                Some((name, at)) => ConfigError::BadValue {
                    at,
                    key: format!("{}.{name}", cfg.decl.name),
                    msg,
                },
                None => ConfigError::BadValue {
                    at: cfg
                        .values
                        .first()
                        .map(|(_, o)| o.clone())
                        .unwrap_or(Origin::Flag(String::new())),
                    key: cfg.decl.name.to_string(),
                    msg,
                },
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `recording` names the sections read, through a clone too, in
    /// registry order; `units()` reads them all; a configuration not
    /// recording records nothing.
    #[test]
    fn recording_names_the_sections_read() {
        let cfg = Config::embedded();
        let ((), read) = cfg.recording(|c| {
            let _ = c.unit("rtl");
            let c2 = c.clone();
            let _ = c2.unit("normalize");
        });
        assert_eq!(read, vec!["normalize", "rtl"]);
        let ((), all) = cfg.recording(|c| {
            let _ = c.units();
        });
        assert_eq!(all.len(), cfg.units().len());
        let ((), none) = cfg.recording(|_| ());
        assert!(none.is_empty());
        assert!(cfg.reads.is_none());
        let text = cfg.sections_toml(&["rtl"]);
        assert!(text.starts_with("[rtl]\n"), "{text}");
        assert_eq!(text.matches('[').count(), 1, "{text}");
    }
}
