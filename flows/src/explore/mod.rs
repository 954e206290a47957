//! Design-space exploration: sweeps over configuration keys and width
//! groups ([`sweep`]), the measured metrics of each point ([`eval`]), a
//! per-configuration result cache, Pareto fronts, goals, and word-length
//! optimization ([`optimize`]).

pub mod cost_expr;
pub mod eval;
pub mod launch;
pub mod optimize;
pub mod sweep;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::OnceLock;

use anyhow::{bail, Context};
use fxshade_model::Config;
use rayon::prelude::*;

pub use eval::Options;

/// The meshes rendered when a goal or a Pareto metric needs `pipeline.*`
/// and no `--mesh` is given.
pub const DEFAULT_MESHES: [&str; 2] = ["sphere:12", "torus:24"];

/// Bumped when a metric's definition changes: cached results of older
/// definitions are not reused.
const CACHE_VERSION: u32 = 1;

/// One measured point.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Row {
    /// Position in the full sweep.
    pub index: usize,
    /// `(axis key, value)` per axis.
    pub labels: Vec<(String, String)>,
    /// The overrides that make the point's configuration from the base.
    pub overrides: Vec<String>,
    /// Hash of the effective configuration's values (its TOML without the
    /// comment lines that name its source and overrides): two routes to
    /// the same configuration have the same hash.
    pub config_hash: String,
    /// Every metric, by name.
    pub metrics: BTreeMap<String, f64>,
    /// Why the point could not be measured (the configuration is rejected,
    /// or an analysis failed).
    pub error: Option<String>,
    /// Seconds it took to measure (0 when it came from the cache).
    pub seconds: f64,
    /// Whether it came from the cache.
    pub cached: bool,
}

impl Row {
    /// The metric `name`, when measured; a cost expression
    /// ([`cost_expr`]: `2*dsp_est + lut/100`) evaluated on the metrics.
    pub fn get(&self, name: &str) -> Option<f64> {
        match self.metrics.get(name) {
            Some(v) => Some(*v),
            None if cost_expr::is_expr(name) => cost_expr::CostExpr::parse(name)
                .ok()?
                .eval(|m| self.metrics.get(m).copied()),
            None => None,
        }
    }
}

/// What identifies this build of fxshade (cached results of another build
/// are not trusted: its model may differ).
fn build_id() -> &'static str {
    static ID: OnceLock<String> = OnceLock::new();
    ID.get_or_init(|| {
        let meta = std::env::current_exe().and_then(std::fs::metadata);
        let stamp = meta
            .as_ref()
            .ok()
            .and_then(|m| m.modified().ok())
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos());
        format!(
            "{}-{}-{}-{stamp}",
            env!("CARGO_PKG_VERSION"),
            CACHE_VERSION,
            meta.map_or(0, |m| m.len())
        )
    })
}

/// The configuration as TOML without its comment lines (source, overrides):
/// two routes to the same values give the same text.
pub fn canonical(cfg: &Config) -> String {
    cfg.to_toml()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Results cached per configuration and options, one JSON file each, in
/// `<dir>/<key>.json`; written atomically, so an interrupted run leaves only
/// whole entries and a re-run computes only what is missing.
pub struct Cache {
    dir: Option<PathBuf>,
}

#[derive(serde::Serialize, serde::Deserialize)]
struct Entry {
    metrics: BTreeMap<String, f64>,
    error: Option<String>,
}

impl Cache {
    /// A cache in `dir` (`None`: no caching), created private to the user
    /// when missing and refused when someone else could write to it.
    ///
    /// # Errors
    ///
    /// The cache directory cannot be created or made private.
    pub fn new(dir: Option<PathBuf>) -> anyhow::Result<Cache> {
        if let Some(d) = &dir {
            fxshade_model::cache::ensure_private_dir(d, fxshade_model::cache::uid())
                .with_context(|| format!("cannot use the explore cache {}", d.display()))?;
        }
        Ok(Cache { dir })
    }

    /// The default: `<fxshade cache>/explore`.
    ///
    /// # Errors
    ///
    /// The cache root is not installed or cannot be resolved ([`fxshade_model::cache::root`]).
    pub fn default_dir() -> anyhow::Result<PathBuf> {
        Ok(fxshade_model::cache::subdir("explore")?)
    }

    fn key(canon: &str, o: &Options) -> u64 {
        let opts = serde_json::to_string(o).expect("serializable");
        fxshade_model::vectors::fingerprint(&[
            canon.as_bytes(),
            opts.as_bytes(),
            build_id().as_bytes(),
        ])
    }

    fn get(&self, key: u64) -> Option<Entry> {
        let p = self.dir.as_ref()?.join(format!("{key:016x}.json"));
        // The directory was checked private when the cache was opened; an
        // entry someone else wrote into it is not read.
        let bytes = fxshade_model::cache::read(&p).ok()??;
        let e: Entry = serde_json::from_slice(&bytes).ok()?;
        // An entry must hold its metrics or its error (a partial one is
        // measured again).
        (e.error.is_some() || !e.metrics.is_empty()).then_some(e)
    }

    fn put(&self, key: u64, e: &Entry) {
        if let Some(d) = &self.dir {
            // A cache that cannot be written only costs time on the next run.
            let _ = fxshade_model::cache::write(
                &d.join(format!("{key:016x}.json")),
                &serde_json::to_vec(e).expect("serializable"),
            );
        }
    }
}

/// The base of a sweep: a configuration file and overrides.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Base {
    /// `--config`.
    pub config: Option<PathBuf>,
    /// `--set`, applied before each point's overrides.
    pub set: Vec<String>,
}

impl Base {
    /// The configuration of a point (the base's overrides, then its own).
    ///
    /// # Errors
    ///
    /// `Err` with the configuration error of the base or of an override.
    pub fn resolve(&self, overrides: &[String]) -> Result<Config, String> {
        let all: Vec<String> = self.set.iter().chain(overrides).cloned().collect();
        Config::resolve(self.config.as_deref(), &all).map_err(|e| e.to_string())
    }
}

/// Load the meshes of `o`.
///
/// # Errors
///
/// A mesh spec is not `sphere:N`, `torus:N` or a readable `.obj` ([`crate::scene::load_mesh`]).
pub fn load_meshes(o: &Options) -> anyhow::Result<Vec<(String, fxshade_model::mesh::Mesh)>> {
    o.meshes
        .iter()
        .map(|s| Ok((s.clone(), crate::scene::load_mesh(s)?)))
        .collect()
}

/// Measure `points` in parallel (rayon, all cores), from the cache where
/// it can (two points with the same configuration may both be measured
/// when they run at once); `tick` is called after each point.
pub fn measure(
    base: &Base,
    points: &[sweep::Point],
    o: &Options,
    meshes: &[(String, fxshade_model::mesh::Mesh)],
    cache: &Cache,
    tick: &(dyn Fn() + Sync),
) -> Vec<Row> {
    points
        .par_iter()
        .map(|p| {
            let row = measure_one(base, p, o, meshes, cache);
            tick();
            row
        })
        .collect()
}

/// Measure one point.
pub fn measure_one(
    base: &Base,
    p: &sweep::Point,
    o: &Options,
    meshes: &[(String, fxshade_model::mesh::Mesh)],
    cache: &Cache,
) -> Row {
    let start = std::time::Instant::now();
    let mut row = Row {
        index: p.index,
        labels: p.labels.clone(),
        overrides: p.overrides.clone(),
        config_hash: String::new(),
        metrics: BTreeMap::new(),
        error: None,
        seconds: 0.0,
        cached: false,
    };
    let cfg = match base.resolve(&p.overrides) {
        Ok(c) => c,
        Err(e) => {
            row.error = Some(e.trim().replace('\n', "; "));
            return row;
        }
    };
    let canon = canonical(&cfg);
    row.config_hash = format!(
        "{:016x}",
        fxshade_model::vectors::fingerprint(&[canon.as_bytes()])
    );
    let key = Cache::key(&canon, o);
    if let Some(e) = cache.get(key) {
        row.metrics = e.metrics;
        row.error = e.error;
        row.cached = true;
        return row;
    }
    let verdict = match launch::get() {
        None => eval::evaluate(&cfg, o, meshes).map_err(|e| format!("{e:#}")),
        Some(l) => match l.evaluate(&cfg, o) {
            Ok(v) => v,
            Err(e) => {
                // A failed launch says nothing about the point: not cached,
                // and the run fails at the end.
                launch::record_failure(format!("point {}: {e:#}", p.index));
                row.error = Some(format!("{e:#}"));
                row.seconds = start.elapsed().as_secs_f64();
                return row;
            }
        },
    };
    match verdict {
        Ok(m) => row.metrics = m,
        Err(e) => row.error = Some(e),
    }
    cache.put(
        key,
        &Entry {
            metrics: row.metrics.clone(),
            error: row.error.clone(),
        },
    );
    row.seconds = start.elapsed().as_secs_f64();
    row
}

/// Whether a larger value of `metric` is better (PSNR, the paper-bound
/// flag, Fmax); every other metric is minimized.
pub fn higher_is_better(metric: &str) -> bool {
    metric.ends_with("psnr_db") || metric.ends_with("paper_bound") || metric.ends_with("fmax_mhz")
}

/// The Pareto front of `rows` over an error and a cost metric (both
/// minimized, or maximized where [`higher_is_better`]): the indices into
/// `rows` of every measured point no other point beats on one metric
/// without losing on the other, by increasing cost.
pub fn pareto(rows: &[Row], err: &str, cost: &str) -> Vec<usize> {
    let key = |r: &Row, m: &str| {
        r.get(m)
            .filter(|v| v.is_finite())
            .map(|v| if higher_is_better(m) { -v } else { v })
    };
    let mut pts: Vec<(usize, f64, f64)> = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r.error.is_none())
        .filter_map(|(i, r)| Some((i, key(r, cost)?, key(r, err)?)))
        .collect();
    pts.sort_by(|a, b| {
        a.1.total_cmp(&b.1)
            .then(a.2.total_cmp(&b.2))
            .then(a.0.cmp(&b.0))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for (i, _, e) in pts {
        if e < best {
            best = e;
            front.push(i);
        }
    }
    front
}

/// A goal: `metric<=value` (also `<`, `>=`, `>`).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct Goal {
    /// The metric.
    pub metric: String,
    /// `<=`, `<`, `>=` or `>`.
    pub op: String,
    /// The bound.
    pub value: f64,
}

impl Goal {
    /// Parse `metric<=value`; the error names where it came from (`at`:
    /// `--goal`, or a sweep file's `file:line`).
    ///
    /// # Errors
    ///
    /// `s` is not `METRIC<=V` or `METRIC>=V` with a known metric and a number (`at` names the
    /// flag).
    pub fn parse(s: &str, at: &str) -> anyhow::Result<Goal> {
        for op in ["<=", ">=", "<", ">"] {
            if let Some((m, v)) = s.split_once(op) {
                let metric = m.trim().to_string();
                if !eval::METRICS.iter().any(|(n, _)| *n == metric) {
                    bail!(
                        "{at} `{s}`: no metric `{metric}`; `fxshade explore --list-metrics` lists them"
                    );
                }
                let value: f64 = v
                    .trim()
                    .parse()
                    .ok()
                    .filter(|x: &f64| x.is_finite())
                    .with_context(|| format!("{at} `{s}`: `{}` is not a number", v.trim()))?;
                return Ok(Goal {
                    metric,
                    op: op.to_string(),
                    value,
                });
            }
        }
        bail!("{at} `{s}`: write METRIC<=VALUE (or <, >=, >), e.g. pipeline.max_err_levels<=1")
    }

    /// Whether `row` meets it (a point without the metric does not).
    pub fn met(&self, row: &Row) -> bool {
        let Some(v) = row.get(&self.metric).filter(|_| row.error.is_none()) else {
            return false;
        };
        match self.op.as_str() {
            "<=" => v <= self.value,
            "<" => v < self.value,
            ">=" => v >= self.value,
            _ => v > self.value,
        }
    }
}

impl std::fmt::Display for Goal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}{}{}", self.metric, self.op, self.value)
    }
}

/// A fingerprint of the files a sweep reads besides its flags: the
/// configuration file and every OBJ mesh (procedural meshes are named by
/// their spec alone). Part of the cache key and the sweep's identity, so an
/// edited file is measured again.
///
/// # Errors
///
/// The configuration file or an `.obj` mesh cannot be read.
pub fn inputs_fingerprint(
    config: Option<&std::path::Path>,
    meshes: &[String],
) -> anyhow::Result<String> {
    let mut parts: Vec<Vec<u8>> = Vec::new();
    if let Some(c) = config {
        parts.push(
            std::fs::read(c)
                .with_context(|| format!("cannot read the configuration {}", c.display()))?,
        );
    }
    for m in meshes {
        if !(m.starts_with("sphere:") || m.starts_with("torus:")) {
            parts.push(std::fs::read(m).with_context(|| format!("cannot read the mesh {m}"))?);
        }
    }
    let refs: Vec<&[u8]> = parts.iter().map(|p| p.as_slice()).collect();
    Ok(format!(
        "{:016x}",
        fxshade_model::vectors::fingerprint(&refs)
    ))
}

/// Check a metric name given on the command line.
///
/// # Errors
///
/// `m` is not a metric explore measures (`flag` names where it was given).
pub fn check_metric(flag: &str, m: &str) -> anyhow::Result<()> {
    if eval::METRICS.iter().any(|(n, _)| *n == m) {
        Ok(())
    } else {
        bail!("{flag} `{m}`: no such metric; `fxshade explore --list-metrics` lists them")
    }
}

/// Every metric name measured by any row, in a stable order (the declared
/// order of [`eval::METRICS`], then any other).
pub fn metric_columns(rows: &[Row]) -> Vec<String> {
    let mut seen: std::collections::BTreeSet<&str> = std::collections::BTreeSet::new();
    for r in rows {
        seen.extend(r.metrics.keys().map(|k| k.as_str()));
    }
    let mut cols: Vec<String> = eval::METRICS
        .iter()
        .filter(|(n, _)| seen.contains(n))
        .map(|(n, _)| n.to_string())
        .collect();
    for s in seen {
        if !cols.iter().any(|c| c == s) {
            cols.push(s.to_string());
        }
    }
    cols
}

/// The rows as CSV: index, one column per axis, `error`, every metric (as
/// numbers), `config_hash`, `seconds`, `cached`.
///
/// # Errors
///
/// The CSV writer fails (a value it cannot write).
pub fn to_csv(axes: &[String], rows: &[Row]) -> anyhow::Result<String> {
    let cols = metric_columns(rows);
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["index".to_string()];
    header.extend(axes.iter().cloned());
    header.push("error".into());
    header.extend(cols.iter().cloned());
    header.extend(["config_hash".into(), "seconds".into(), "cached".into()]);
    w.write_record(&header)?;
    for r in rows {
        let mut rec = vec![r.index.to_string()];
        for a in axes {
            rec.push(
                r.labels
                    .iter()
                    .find(|(k, _)| k == a)
                    .map_or(String::new(), |(_, v)| v.clone()),
            );
        }
        rec.push(r.error.clone().unwrap_or_default());
        for c in &cols {
            rec.push(r.get(c).map_or(String::new(), |v| format!("{v}")));
        }
        rec.push(r.config_hash.clone());
        rec.push(format!("{:.3}", r.seconds));
        rec.push(r.cached.to_string());
        w.write_record(&rec)?;
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

/// The numeric x of an axis label: the width of a format (`U1F15` → 16),
/// else the number itself.
pub fn axis_x(label: &str) -> Option<f64> {
    if let Ok(f) = label.parse::<fxshade_model::format::Format>() {
        return Some(f64::from(f.width()));
    }
    label.parse::<f64>().ok().filter(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(i: usize, err: f64, cost: f64) -> Row {
        Row {
            index: i,
            labels: vec![],
            overrides: vec![],
            config_hash: String::new(),
            metrics: [("e".to_string(), err), ("c".to_string(), cost)].into(),
            error: None,
            seconds: 0.0,
            cached: false,
        }
    }

    #[test]
    fn pareto_front_keeps_exactly_the_undominated_points() {
        // (err, cost): 0 (5, 1) and 2 (1, 5) and 4 (2, 3) are undominated;
        // 1 (5, 2) loses to 0; 3 (3, 4) loses to 4; 5 is a duplicate of 4
        // with a later index; 6 failed.
        let mut rows = vec![
            row(0, 5.0, 1.0),
            row(1, 5.0, 2.0),
            row(2, 1.0, 5.0),
            row(3, 3.0, 4.0),
            row(4, 2.0, 3.0),
            row(5, 2.0, 3.0),
            row(6, 0.0, 0.0),
        ];
        rows[6].error = Some("rejected".into());
        assert_eq!(pareto(&rows, "e", "c"), [0, 4, 2]);
    }

    #[test]
    fn goals_parse_and_compare() {
        let g = Goal::parse("pipeline.max_err_levels<=1", "--goal").unwrap();
        assert!(g.met(&Row {
            metrics: [("pipeline.max_err_levels".to_string(), 1.0)].into(),
            ..row(0, 0.0, 0.0)
        }));
        assert!(!g.met(&Row {
            metrics: [("pipeline.max_err_levels".to_string(), 1.5)].into(),
            ..row(0, 0.0, 0.0)
        }));
        // A point without the metric does not meet it.
        assert!(!g.met(&row(0, 0.0, 0.0)));
        let g = Goal::parse("pipeline.psnr_db > 40", "--goal").unwrap();
        assert_eq!((g.op.as_str(), g.value), (">", 40.0));
        assert!(Goal::parse("nothing<=1", "--goal").is_err());
        assert!(Goal::parse("pipeline.max_err_levels=1", "--goal").is_err());
        assert!(Goal::parse("pipeline.max_err_levels<=x", "--goal").is_err());
    }
}
