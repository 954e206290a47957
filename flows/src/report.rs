//! The figures `fxshade report` gathers that run a flow: each method's
//! uniform-width sweep through the explore cache, the recommended top's
//! device cost, cached synthesis and the RTL co-simulation of every unit.

/// The methods the report's summary recommends a width for, with the
/// overrides that select each (the RTL tops).
pub const SUMMARY_METHODS: [(&str, &str); 4] = [
    (
        "quadratic",
        "pipeline.path=smooth; normalize.method=quadratic",
    ),
    ("linear", "pipeline.path=smooth; normalize.method=linear"),
    ("mapped", "pipeline.path=mapped; pipeline.angles=cordic"),
    (
        "mapped-interp",
        "pipeline.path=mapped; pipeline.angles=interpolate",
    ),
];

/// The uniform widths the summary sweeps.
pub const SUMMARY_WIDTHS: std::ops::RangeInclusive<u32> = 9..=18;

/// One method's uniform-width sweep.
pub struct MethodSweep {
    /// Method name.
    pub method: &'static str,
    /// The overrides selecting it.
    pub select: Vec<String>,
    /// `(width, point)` per width.
    pub points: Vec<(u32, crate::explore::Row)>,
    /// The smallest width meeting both goals.
    pub recommended: Option<usize>,
    /// The recommended point's pipeline top on the device: estimated for
    /// ECP5 without synthesis, and any cached synthesis of it.
    pub device: Option<DeviceCost>,
}

/// A pipeline top's cost on the device: the area and block estimates for
/// ECP5 ([`fxshade_model::rtl::estimate`]) and what cached `fxshade synth`
/// runs (one seed, 100 MHz goal) measured, per target.
#[derive(Clone, Debug, Default)]
pub struct DeviceCost {
    /// ECP5 estimates: LUT4, flip-flops, MULT18X18D, DP16KD.
    pub ecp5_estimate: Option<(u64, u64, u64, u64)>,
    /// Cached synthesis results of the top, by target.
    pub synthesized: Vec<crate::synth::SynthResult>,
}

impl DeviceCost {
    /// The cost of the pipeline top of `cfg`; cached synthesis is read
    /// only (nothing is synthesized here).
    pub fn of(cfg: &fxshade_model::Config) -> Option<DeviceCost> {
        use fxshade_model::rtl::estimate as est;
        use fxshade_model::rtl::targets::Target;
        let design = fxshade_model::pipeline::RTL.design(cfg).ok()?;
        let e = fxshade_model::rtl::emit(&design).ok()?;
        let hw = &e.hardware;
        let ecp5 = Target::from_name("ecp5")?;
        let ecp5_estimate = match (est::lut_cells(hw, ecp5), est::flip_flops(hw, ecp5)) {
            (Some(l), Some(f)) => {
                Some((l, f, est::dsp_blocks(hw, ecp5), est::bram_blocks(hw, ecp5)))
            }
            _ => None,
        };
        let synthesized = if crate::proc::has("yosys", "-V") {
            // Every device family's cached synthesis (not the generic LUT
            // mapping, which is no device).
            Target::synthesized()
                .iter()
                .filter(|t| crate::synth::timing(**t).is_some())
                .filter_map(|t| crate::synth::lookup("pipeline", cfg, *t))
                .collect()
        } else {
            Vec::new()
        };
        Some(DeviceCost {
            ecp5_estimate,
            synthesized,
        })
    }
}

/// Whether a point meets the summary's goals: the paper's 4 % bound and
/// ±1 level on every mesh.
pub fn meets_summary_goals(r: &crate::explore::Row) -> bool {
    r.error.is_none()
        && r.get("pipeline.paper_bound") == Some(1.0)
        && r.get("pipeline.max_err_levels").is_some_and(|v| v <= 1.0)
}

/// Sweep every stage of a width group on each method's path (the output
/// level stays the 8-bit pixel) over [`SUMMARY_WIDTHS`], measured on the
/// explore command's default meshes, through the explore cache.
///
/// # Errors
///
/// The meshes cannot be built, the explore cache cannot be opened, or a method's overrides do
/// not apply.
pub fn summary_sweep(base: &crate::explore::Base) -> anyhow::Result<Vec<MethodSweep>> {
    use crate::explore::{self, optimize, sweep::Point, Cache, Options};
    let o = Options {
        analyses: vec!["pipeline".into(), "cost".into()],
        meshes: crate::explore::DEFAULT_MESHES
            .iter()
            .map(|s| s.to_string())
            .collect(),
        size: (128, 128),
        samples: None,
        inputs: crate::explore::inputs_fingerprint(
            base.config.as_deref(),
            &crate::explore::DEFAULT_MESHES.map(String::from),
        )?,
        synth: None,
    };
    let meshes = explore::load_meshes(&o)?;
    let cache = Cache::new(Some(Cache::default_dir()?))?;
    let mut plan = Vec::new();
    let mut points = Vec::new();
    for (method, sel) in SUMMARY_METHODS {
        let select: Vec<String> = fxshade_model::rtl::units::overrides(sel)
            .map(str::to_string)
            .collect();
        let cfg = base
            .resolve(&select)
            .map_err(|e| anyhow::anyhow!("{method}: {e}"))?;
        let (vars, _) = optimize::vars(&cfg);
        let vars: Vec<optimize::Var> = vars
            .into_iter()
            .filter(|v| v.key != "lighting.level")
            .collect();
        for w in SUMMARY_WIDTHS {
            let widths: Vec<u32> = vars.iter().map(|v| w.max(v.min_width())).collect();
            let mut overrides = select.clone();
            overrides.extend(
                optimize::overrides(&vars, &widths)
                    .ok_or_else(|| anyhow::anyhow!("{method}: a stage cannot take {w} bits"))?,
            );
            points.push(Point {
                index: points.len(),
                labels: vec![
                    ("method".into(), method.into()),
                    ("width".into(), w.to_string()),
                ],
                overrides,
            });
        }
        plan.push((method, select));
    }
    let rows = explore::measure(base, &points, &o, &meshes, &cache, &|| {});
    let n = SUMMARY_WIDTHS.count();
    Ok(plan
        .into_iter()
        .enumerate()
        .map(|(k, (method, select))| {
            let pts: Vec<(u32, crate::explore::Row)> = SUMMARY_WIDTHS
                .zip(rows[k * n..(k + 1) * n].iter().cloned())
                .collect();
            let recommended = pts.iter().position(|(_, r)| meets_summary_goals(r));
            let device = recommended.and_then(|k| {
                base.resolve(&pts[k].1.overrides)
                    .ok()
                    .and_then(|c| DeviceCost::of(&c))
            });
            MethodSweep {
                method,
                select,
                points: pts,
                recommended,
                device,
            }
        })
        .collect())
}

/// Every cached `fxshade synth` result (one seed, 100 MHz goal, place and
/// route where it exists) of this configuration's units and pipeline tops.
pub fn cached_synthesis(cfg: &fxshade_model::Config) -> Vec<crate::synth::SynthResult> {
    use crate::synth::{lookup, Target};
    if !crate::proc::has("yosys", "-V") {
        return Vec::new();
    }
    let mut out = Vec::new();
    for u in fxshade_model::rtl::units::all() {
        for t in Target::synthesized() {
            out.extend(lookup(u.name, cfg, *t));
        }
    }
    out
}

/// RTL co-simulation results: `(unit, variant, vectors, passed, failed,
/// equivalence)` per module, or why none were run; `equivalence` is what
/// `fxshade equiv` recorded for this Verilog and model (the report does not
/// run the proofs: `fxshade equiv all` does, two to three minutes).
pub type RtlChecks = Result<Vec<(String, String, usize, u64, u64, String)>, String>;

/// Co-simulate every unit and the three pipeline tops on Icarus Verilog
/// (300 vectors each, random stalls; killers searched as `search` says): `(unit, variant, count, passed,
/// failed)`, or why not.
///
/// # Errors
///
/// `Err` with why no co-simulation was run (Icarus missing, an override that does not apply) or
/// the first that failed to run.
pub fn rtl_checks(
    cfg: &fxshade_model::Config,
    search: fxshade_model::rtl::search::Search,
) -> RtlChecks {
    use crate::rtl_flow;
    rtl_flow::require_tool("iverilog", "iverilog").map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    let mut jobs: Vec<(
        &'static fxshade_model::rtl::units::RtlUnit,
        fxshade_model::Config,
    )> = Vec::new();
    for u in fxshade_model::rtl::units::all() {
        if u.name == "pipeline" {
            for (_, sel) in u.variants {
                let mut c = cfg.clone();
                for o in fxshade_model::rtl::units::overrides(sel) {
                    c.apply_override(o).map_err(|e| e.to_string())?;
                }
                jobs.push((u, c));
            }
        } else {
            jobs.push((u, cfg.clone()));
        }
    }
    // One co-simulation per core at a time (each is one Icarus process and
    // its generator), the pipeline tops (the longest) first; results kept
    // in the units' order.
    let check = |(u, c): &(
        &'static fxshade_model::rtl::units::RtlUnit,
        fxshade_model::Config,
    )| {
        let equivalence = fxshade_model::rtl::units::emit_unit(u, c)
            .ok()
            .map(|(design, emitted)| crate::equiv::Module {
                text: emitted.verilog.clone(),
                design,
                emitted,
            })
            .and_then(|m| crate::equiv::recorded(&m))
            .map_or_else(
                || "not proved (run `fxshade equiv all`)".to_string(),
                |v| format!("proved ({:.1} s)", v["seconds"].as_f64().unwrap_or(0.0)),
            );
        let run = || -> anyhow::Result<(String, usize, u64, u64)> {
            let stream = fxshade_model::rtl::units::VectorStream::new(u, c, 300, 1, None, search)?;
            let sources = rtl_flow::Sources::emitted(&stream.rtl());
            let r =
                rtl_flow::check_with(&stream, &sources, rtl_flow::Sim::Icarus, 1, 20, None, false)?;
            Ok((stream.design.variant.clone(), r.count, r.passed, r.failed))
        };
        run()
            .map(|(v, n, p, f)| (u.name.to_string(), v, n, p, f, equivalence))
            .map_err(|e| format!("{}: {e:#}", u.name))
    };
    let longest_first: Vec<usize> = (0..jobs.len()).rev().collect();
    let mut results =
        fxshade_model::parallel::map_in_order(&longest_first, |_, &i| check(&jobs[i]));
    results.reverse();
    for r in results {
        out.push(r?);
    }
    Ok(out)
}
