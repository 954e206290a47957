//! Word-length optimization: the cheapest per-stage widths that meet every
//! goal, against a measured cost.
//!
//! The variables are the total widths of the stages in width groups on the
//! configured path (each keeps its signedness and integer bits). The search,
//! in the manner of MATLAB's `fxpopt` but against the chosen cost:
//!
//! 1. **Uniform baseline.** Every variable at one width `W`, for `W` from
//!    [`UNIFORM_MIN`] to [`UNIFORM_MAX`] (measured in parallel); the
//!    smallest `W` meeting every goal is the baseline, and the safe start.
//! 2. **Greedy narrowing.** Each variable in turn is narrowed as far as the
//!    goals allow with the others fixed (bisection, assuming error grows as
//!    a width shrinks; every accepted step is measured, so a wrong guess
//!    costs only optimality, never a goal).
//! 3. **Local refinement.** For each variable: widen it by one bit, then
//!    narrow every other by one bit where the goals still hold; kept when
//!    the cost falls. Repeated until nothing improves or the evaluation
//!    budget is spent.
//!
//! **Discrete knobs** (`--knob KEY=SPEC`: table sizes, angle bits, CORDIC
//! iterations, methods; any key but a width) are searched before step 2
//! (at the baseline widths, so a small budget still searches them) and
//! after it: each knob in turn takes every value of its SPEC with the
//! widths found (measured in parallel), the cheapest point meeting the
//! goals wins, and when a knob moved, step 2 narrows the widths again;
//! repeated until no knob moves (at most [`KNOB_ROUNDS`] rounds after
//! step 2). A knob starts at its configured value
//! when SPEC holds it, else at SPEC's last value. Step 3 keeps the knobs.
//!
//! Costs compare lexicographically: the chosen cost, then the total of
//! `bit_products + adder_bits + table_bits + ff`, so a narrowing that the
//! chosen cost does not see is still taken when it saves hardware.

use anyhow::bail;
use fxshade_model::convert::narrow;
use fxshade_model::Config;
use rayon::prelude::*;

use super::sweep::Point;
use super::{Base, Cache, Goal, Options, Row};

/// Narrowest uniform width tried.
pub const UNIFORM_MIN: u32 = 8;
/// Widest uniform width tried.
pub const UNIFORM_MAX: u32 = 26;

/// Most rounds of knob passes and re-narrowing.
pub const KNOB_ROUNDS: usize = 3;

/// The index of each knob's starting value: the value the configuration
/// has (applying it changes nothing), else the last.
pub fn knob_start(cfg: &Config, knobs: &[super::sweep::Axis]) -> Vec<usize> {
    let here = super::canonical(cfg);
    knobs
        .iter()
        .map(|k| {
            k.values
                .iter()
                .position(|v| {
                    let mut c = cfg.clone();
                    v.overrides.iter().all(|o| c.apply_override(o).is_ok())
                        && super::canonical(&c) == here
                })
                .unwrap_or(k.values.len().saturating_sub(1))
        })
        .collect()
}

/// One variable: a stage's total width.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Var {
    /// `unit.field`.
    pub key: String,
    /// Signed format.
    pub signed: bool,
    /// Integer bits kept (sign included).
    pub int_bits: i32,
}

impl Var {
    /// Narrowest width tried: the integer part alone (no fraction bits),
    /// and at least two bits.
    pub fn min_width(&self) -> u32 {
        narrow::<u32, _>(self.int_bits.max(2))
    }
    fn format(&self, w: u32) -> Option<fxshade_model::format::Format> {
        fxshade_model::format::Format::new(self.signed, w, narrow::<i32, _>(w) - self.int_bits).ok()
    }
}

/// The units the configured pipeline path runs through.
fn path_units(cfg: &Config) -> &'static [&'static str] {
    match super::eval::method_of(cfg) {
        fxshade_model::render::RenderMethod::Smooth(_) => &["interp", "normalize", "lighting"],
        fxshade_model::render::RenderMethod::Mapped(
            fxshade_model::pipeline::AngleSource::Cordic,
        ) => &["interp", "angles", "polar", "lighting"],
        _ => &["polar", "lighting"],
    }
}

/// The variables of a configuration: every width-group member of the units
/// on its path, and their current widths.
pub fn vars(cfg: &Config) -> (Vec<Var>, Vec<u32>) {
    let units = path_units(cfg);
    let mut v = Vec::new();
    let mut w = Vec::new();
    for (g, _) in fxshade_model::config::WIDTH_GROUPS {
        for (key, q) in cfg.group_members(g).unwrap_or_default() {
            let unit = key.split('.').next().unwrap_or("");
            if units.contains(&unit) && !v.iter().any(|x: &Var| x.key == key) {
                let f = q.format();
                v.push(Var {
                    key,
                    signed: f.signed(),
                    int_bits: f.int_bits(),
                });
                w.push(f.width());
            }
        }
    }
    (v, w)
}

/// The variables (`unit.field` keys of `vars`) a key names: `width.<group>`
/// its members, `unit.field` or any key under it (`unit.field.format`)
/// that stage; an error names a key that is neither.
///
/// # Errors
///
/// `Err` when `key` names no width variable of `cfg` (a `unit.field` or `width.<group>`).
pub fn keys_named(cfg: &Config, vars: &[Var], key: &str) -> Result<Vec<String>, String> {
    let key = key.split('=').next().unwrap_or(key).trim();
    let named: Vec<String> = if let Some(group) = key.strip_prefix("width.") {
        let members = cfg.group_members(group).ok_or_else(|| {
            format!(
                "no width group {group:?} (groups: {})",
                fxshade_model::config::WIDTH_GROUPS
                    .iter()
                    .map(|(g, _)| *g)
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        vars.iter()
            .filter(|v| members.iter().any(|(k, _)| *k == v.key))
            .map(|v| v.key.clone())
            .collect()
    } else {
        vars.iter()
            .filter(|v| key == v.key || key.starts_with(&format!("{}.", v.key)))
            .map(|v| v.key.clone())
            .collect()
    };
    Ok(named)
}

/// Which stages the search keeps as configured: every variable the user's
/// `--set` keys name (the designer's choice is not searched), each
/// `--freeze` key, and the output level (the pixel: width group `level`),
/// less those a `--free` key names. Errors name the flag and the key.
///
/// # Errors
///
/// `Err` when a `--freeze` or `--free` key names no width variable.
pub fn frozen(
    cfg: &Config,
    user_sets: &[String],
    freeze: &[String],
    free: &[String],
) -> Result<Vec<String>, String> {
    let (vars, _) = vars(cfg);
    let mut out: Vec<String> = Vec::new();
    let mut add = |ks: Vec<String>| {
        for k in ks {
            if !out.contains(&k) {
                out.push(k);
            }
        }
    };
    for s in user_sets {
        add(keys_named(cfg, &vars, s).unwrap_or_default());
    }
    add(keys_named(cfg, &vars, "width.level")?);
    // The stages a --freeze or --free key names; none is an error.
    let named = |flag: &str, k: &str| -> Result<Vec<String>, String> {
        let ks = keys_named(cfg, &vars, k).map_err(|e| format!("{flag} {k}: {e}"))?;
        if ks.is_empty() {
            return Err(format!(
                "{flag} {k}: no stage the search varies on the configured path (it varies {})",
                vars.iter()
                    .map(|v| v.key.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        Ok(ks)
    };
    for k in freeze {
        add(named("--freeze", k)?);
    }
    for k in free {
        let ks = named("--free", k)?;
        out.retain(|x| !ks.contains(x));
    }
    Ok(out)
}

/// The overrides that give the variables these widths.
pub fn overrides(vars: &[Var], widths: &[u32]) -> Option<Vec<String>> {
    vars.iter()
        .zip(widths)
        .map(|(v, &w)| Some(format!("{}.format={}", v.key, v.format(w)?)))
        .collect()
}

/// What the search found.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Outcome {
    /// The goals.
    pub goals: Vec<Goal>,
    /// The cost minimized.
    pub minimize: String,
    /// The variables.
    pub vars: Vec<Var>,
    /// The stages kept as configured ([`frozen`]), with their formats.
    pub frozen: Vec<(String, String)>,
    /// Every uniform width tried, with whether it met the goals and its cost.
    pub uniform: Vec<(u32, bool, Option<f64>)>,
    /// The smallest uniform width meeting every goal.
    pub baseline_width: u32,
    /// Its point.
    pub baseline: Row,
    /// The cheapest point found: per-variable widths.
    pub widths: Vec<u32>,
    /// Its point.
    pub winner: Row,
    /// `1 − cost(winner) / cost(baseline)`.
    pub saving: f64,
    /// Points measured (cache hits included).
    pub evaluations: usize,
    /// Each knob: key, its value in the baseline, its value in the winner.
    pub knobs: Vec<(String, String, String)>,
}

/// The search state: measures points and keeps count.
struct Search<'a> {
    base: &'a Base,
    o: &'a Options,
    meshes: &'a [(String, fxshade_model::mesh::Mesh)],
    cache: &'a Cache,
    goals: &'a [Goal],
    minimize: &'a str,
    vars: &'a [Var],
    knobs: &'a [super::sweep::Axis],
    evaluations: std::sync::atomic::AtomicUsize,
    tick: &'a (dyn Fn(&str) + Sync),
}

impl Search<'_> {
    /// The point of these widths and knob values (indices into each
    /// knob's values).
    fn measure_k(&self, widths: &[u32], knobs: &[usize], label: &str) -> Option<Row> {
        let mut overrides = overrides(self.vars, widths)?;
        for (k, &i) in self.knobs.iter().zip(knobs) {
            overrides.extend(k.values[i].overrides.iter().cloned());
        }
        let p = Point {
            index: self
                .evaluations
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            labels: vec![("point".into(), label.to_string())],
            overrides,
        };
        let r = super::measure_one(self.base, &p, self.o, self.meshes, self.cache);
        (self.tick)(label);
        Some(r)
    }
    /// Step 2: each variable narrowed as far as the goals allow (see the
    /// module docs), from `cur` and its point `best`.
    fn narrow(
        &self,
        cur: &mut [u32],
        kc: &[usize],
        best: &mut Row,
        budget: &dyn Fn(&Search) -> bool,
    ) {
        let vars = self.vars;
        for i in 0..vars.len() {
            let (mut lo, mut hi) = (vars[i].min_width(), cur[i]);
            let mut hi_row = best.clone();
            while lo < hi && budget(self) {
                let mid = (lo + hi) / 2;
                let mut t = cur.to_vec();
                t[i] = mid;
                match self.measure_k(&t, kc, &format!("narrow {} to {mid}", vars[i].key)) {
                    Some(r) if self.feasible(&r) && self.not_dearer(&r, &hi_row) => {
                        hi = mid;
                        hi_row = r;
                    }
                    _ => lo = mid + 1,
                }
            }
            if hi < cur[i] && self.cheaper(&hi_row, best) {
                cur[i] = hi;
                *best = hi_row;
            }
        }
    }
    /// One pass over the knobs: each takes every value of its SPEC with the
    /// widths `cur` (in parallel); the cheapest point meeting the goals is
    /// kept. True when a knob moved.
    fn knob_pass(
        &self,
        cur: &[u32],
        kc: &mut [usize],
        best: &mut Row,
        budget: &dyn Fn(&Search) -> bool,
    ) -> bool {
        let mut moved = false;
        for i in 0..self.knobs.len() {
            if !budget(self) {
                break;
            }
            let k = &self.knobs[i];
            let tried: Vec<(usize, Option<Row>)> = (0..k.values.len())
                .into_par_iter()
                .filter(|&v| v != kc[i])
                .map(|v| {
                    let mut t = kc.to_vec();
                    t[i] = v;
                    let label = format!("knob {} = {}", k.key, k.values[v].label);
                    (v, self.measure_k(cur, &t, &label))
                })
                .collect();
            for (v, r) in tried {
                if let Some(r) = r {
                    if self.feasible(&r) && self.cheaper(&r, best) {
                        kc[i] = v;
                        *best = r;
                        moved = true;
                    }
                }
            }
        }
        moved
    }
    fn feasible(&self, r: &Row) -> bool {
        r.error.is_none() && self.goals.iter().all(|g| g.met(r))
    }
    fn cost(&self, r: &Row) -> (f64, f64) {
        let total = ["bit_products", "adder_bits", "table_bits", "ff"]
            .iter()
            .map(|m| r.get(m).unwrap_or(0.0))
            .sum();
        (r.get(self.minimize).unwrap_or(f64::INFINITY), total)
    }
    fn cheaper(&self, a: &Row, b: &Row) -> bool {
        let (x, y) = (self.cost(a), self.cost(b));
        x.0 < y.0 || (x.0 == y.0 && x.1 < y.1)
    }
    fn not_dearer(&self, a: &Row, b: &Row) -> bool {
        !self.cheaper(b, a)
    }
}

/// Run the search. `tick` reports each measured point.
///
/// # Errors
///
/// The baseline cannot be evaluated, no uniform width meets the goals, or an evaluation fails
/// for a reason other than the point itself.
#[allow(clippy::too_many_arguments)]
pub fn run(
    base: &Base,
    cfg: &Config,
    goals: &[Goal],
    minimize: &str,
    o: &Options,
    meshes: &[(String, fxshade_model::mesh::Mesh)],
    cache: &Cache,
    max_evals: usize,
    frozen: &[String],
    knobs: &[super::sweep::Axis],
    tick: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<Outcome> {
    let k0 = knob_start(cfg, knobs);
    let (all, widths) = vars(cfg);
    let mut kept = Vec::new();
    let mut vars = Vec::new();
    for (v, w) in all.into_iter().zip(widths) {
        if frozen.contains(&v.key) {
            kept.push((v, w));
        } else {
            vars.push(v);
        }
    }
    if vars.is_empty() {
        bail!(
            "the configured path has no width-group stage to optimize{}",
            if kept.is_empty() {
                String::new()
            } else {
                format!(
                    " (frozen: {})",
                    kept.iter()
                        .map(|(v, _)| v.key.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        );
    }
    let frozen: Vec<(String, String)> = kept
        .iter()
        .map(|(v, w)| {
            let f = v.format(*w).map(|f| f.to_string()).unwrap_or_default();
            (v.key.clone(), f)
        })
        .collect();
    let s = Search {
        base,
        o,
        meshes,
        cache,
        goals,
        minimize,
        vars: &vars,
        knobs,
        evaluations: 0.into(),
        tick,
    };
    // 1. Uniform widths, in parallel.
    let tried: Vec<(u32, Option<Row>)> = (UNIFORM_MIN..=UNIFORM_MAX)
        .into_par_iter()
        .map(|w| {
            let widths: Vec<u32> = vars.iter().map(|v| w.max(v.min_width())).collect();
            (w, s.measure_k(&widths, &k0, &format!("uniform {w}")))
        })
        .collect();
    let uniform: Vec<(u32, bool, Option<f64>)> = tried
        .iter()
        .map(|(w, r)| {
            (
                *w,
                r.as_ref().is_some_and(|r| s.feasible(r)),
                r.as_ref().and_then(|r| r.get(minimize)),
            )
        })
        .collect();
    let Some((bw, Some(brow))) = tried
        .iter()
        .find(|(_, r)| r.as_ref().is_some_and(|r| s.feasible(r)))
        .cloned()
    else {
        let why = tried
            .last()
            .and_then(|(_, r)| r.as_ref())
            .map(|r| match &r.error {
                Some(e) => e.clone(),
                None => goals
                    .iter()
                    .filter(|g| !g.met(r))
                    .map(|g| format!("{} = {}", g.metric, r.get(&g.metric).unwrap_or(f64::NAN)))
                    .collect::<Vec<_>>()
                    .join(", "),
            })
            .unwrap_or_default();
        bail!(
            "no uniform width from {UNIFORM_MIN} to {UNIFORM_MAX} bits meets every goal (at {UNIFORM_MAX}: {why})"
        );
    };
    let mut cur: Vec<u32> = vars.iter().map(|v| bw.max(v.min_width())).collect();
    let mut best = brow.clone();
    let budget = |s: &Search| s.evaluations.load(std::sync::atomic::Ordering::Relaxed) < max_evals;

    // 2. Greedy narrowing, one variable at a time, by bisection; then the
    // knobs, and the widths again after a knob moved.
    let mut kc = k0.clone();
    if !knobs.is_empty() {
        s.knob_pass(&cur, &mut kc, &mut best, &budget);
    }
    s.narrow(&mut cur, &kc, &mut best, &budget);
    for _ in 0..KNOB_ROUNDS {
        if knobs.is_empty() || !budget(&s) || !s.knob_pass(&cur, &mut kc, &mut best, &budget) {
            break;
        }
        s.narrow(&mut cur, &kc, &mut best, &budget);
    }

    // 3. Local refinement: widen one, narrow the others.
    let mut improved = true;
    while improved && budget(&s) {
        improved = false;
        for i in 0..vars.len() {
            if !budget(&s) {
                break;
            }
            let mut t = cur.clone();
            t[i] += 1;
            let mut t_row = None;
            let mut narrowed = false;
            for j in (0..vars.len()).filter(|&j| j != i) {
                if t[j] <= vars[j].min_width() || !budget(&s) {
                    continue;
                }
                let mut u = t.clone();
                u[j] -= 1;
                if let Some(r) = s.measure_k(
                    &u,
                    &kc,
                    &format!("refine {} +1, {} −1", vars[i].key, vars[j].key),
                ) {
                    if s.feasible(&r) {
                        t = u;
                        t_row = Some(r);
                        narrowed = true;
                    }
                }
            }
            if let (true, Some(r)) = (narrowed, t_row) {
                if s.cheaper(&r, &best) {
                    cur = t;
                    best = r;
                    improved = true;
                }
            }
        }
    }
    let (bc, wc) = (s.cost(&brow).0, s.cost(&best).0);
    Ok(Outcome {
        goals: goals.to_vec(),
        minimize: minimize.to_string(),
        uniform,
        baseline_width: bw,
        baseline: brow,
        widths: cur,
        winner: best,
        saving: if bc > 0.0 { 1.0 - wc / bc } else { 0.0 },
        evaluations: s.evaluations.load(std::sync::atomic::Ordering::Relaxed),
        vars,
        frozen,
        knobs: knobs
            .iter()
            .enumerate()
            .map(|(i, k)| {
                (
                    k.key.clone(),
                    k.values[k0[i]].label.clone(),
                    k.values[kc[i]].label.clone(),
                )
            })
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sets(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    /// The stages kept: a `--set`'s, `--freeze`'s, the output level by
    /// default, less `--free`'s; keys named as the README names them (the
    /// smooth path's groups: interp, normals, normalizer, shading, level).
    #[test]
    fn frozen_stages_are_the_designers_choices() {
        let base = sets(&["lighting.spec.format=U1F17"]);
        let cfg = Config::resolve(None, &base).unwrap();
        let f = frozen(&cfg, &base, &[], &[]).unwrap();
        assert_eq!(f, ["lighting.spec", "lighting.level"]);
        let f = frozen(
            &cfg,
            &base,
            &sets(&["width.interp"]),
            &sets(&["width.level"]),
        )
        .unwrap();
        assert_eq!(f, ["lighting.spec", "interp.bary", "interp.weight"]);
        // A width group given with --set freezes its members on the path.
        let g = sets(&["width.normalizer=18"]);
        let cfg = Config::resolve(None, &g).unwrap();
        let f = frozen(&cfg, &g, &[], &sets(&["lighting.level.format"])).unwrap();
        assert_eq!(
            f,
            [
                "normalize.d",
                "normalize.coef",
                "normalize.horner",
                "normalize.g"
            ]
        );
        // A --set off the searched stages freezes nothing more.
        let o = sets(&["lighting.i0_km=0.8"]);
        let cfg = Config::resolve(None, &o).unwrap();
        assert_eq!(frozen(&cfg, &o, &[], &[]).unwrap(), ["lighting.level"]);
        // Keys that name no searched stage are errors that say which flag.
        let e = frozen(&cfg, &[], &sets(&["width.nothing"]), &[]).unwrap_err();
        assert!(
            e.starts_with("--freeze width.nothing: no width group"),
            "{e}"
        );
        let e = frozen(&cfg, &[], &sets(&["polar.table"]), &[]).unwrap_err();
        assert!(e.starts_with("--freeze polar.table: no stage"), "{e}");
        let e = frozen(&cfg, &[], &[], &sets(&["interp.nothing"])).unwrap_err();
        assert!(e.starts_with("--free interp.nothing: no stage"), "{e}");
    }
}
