//! The metrics of one configuration: each unit's error analysis against
//! f64, rendered-image error on chosen meshes, and the hardware cost of the
//! generated RTL. Every figure is measured here (never typed in).
//!
//! Metric names are `unit.metric` for errors (`normalize.max_rel_err`,
//! `pipeline.max_err_levels`) and bare names for costs (`bit_products`,
//! `muls`, `adder_bits`, `table_bits`, `ff`, `latency`).

use fxshade_model::convert::to_f64;
use std::collections::BTreeMap;

use anyhow::Context;
use fxshade_model::lighting::{Lighting, LEVELS};
use fxshade_model::pipeline::Path;
use fxshade_model::render::{self, Metrics, RenderMethod};
use fxshade_model::sampling::Rng;
use fxshade_model::Config;

/// Analysis groups a point may measure.
pub const ANALYSES: [&str; 7] = [
    "normalize",
    "interp",
    "polar",
    "angles",
    "lighting",
    "pipeline",
    "cost",
];

/// Every metric name with its meaning (for `explore --list-metrics`, the
/// CSV header and the docs).
pub const METRICS: &[(&str, &str)] = &[
    ("normalize.max_rel_err", "normalizer on whole triangles meeting Θ: largest | |N'| − 1 |"),
    ("normalize.mean_rel_err", "… its mean"),
    ("normalize.rms_rel_err", "… its RMS"),
    ("normalize.max_lsb_err", "… largest component error, output LSBs"),
    ("normalize.max_diffuse_err_levels", "… largest diffuse error, 8-bit levels"),
    ("normalize.g_max_rel_err", "the g(d) stage over every d code: largest relative error"),
    ("normalize.overflows", "overflows at the normalizer's and lighting's quantizers"),
    ("interp.max_rel_err", "interpolation then normalization: largest | |N'| − 1 |"),
    ("interp.max_angle_err_deg", "… largest direction error against the exact field, degrees"),
    ("polar.max_lsb_err", "polar transform: largest component error of L', LSBs"),
    ("polar.rms_lsb_err", "… RMS component error, LSBs"),
    ("polar.max_angle_err_deg", "… largest angle error, degrees"),
    ("polar.max_diffuse_err_levels", "… largest diffuse error, 8-bit levels"),
    ("angles.max_alpha_lsb", "CORDIC angles: largest α error, output LSBs"),
    ("angles.max_beta_lsb", "… largest β error outside the polar cap, output LSBs"),
    ("angles.max_direction_deg", "… largest direction error, degrees"),
    ("lighting.max_diffuse_err_levels", "lighting on unit N, L quantized to their ports: largest diffuse error, 8-bit levels"),
    ("lighting.max_specular_err_levels", "… largest specular error (I0·km = 0), 8-bit levels"),
    ("pipeline.max_err_levels", "rendered meshes, the configured path and method against f64: largest |error|, levels (mapped: outside the polar cap)"),
    ("pipeline.mean_err_levels", "… mean |error| over every compared pixel, levels"),
    ("pipeline.psnr_db", "… smallest PSNR over the meshes, dB (999 for identical images)"),
    ("pipeline.off_by_gt1", "… largest share of pixels off by more than 1 level"),
    ("pipeline.max_rel_err", "… largest relative intensity error beyond 8-bit rounding"),
    ("pipeline.paper_bound", "… 1 when every mesh stays under the paper's 4 % bound, else 0"),
    ("bit_products", "the RTL top of the configured path: Σ a_width × b_width over its multipliers"),
    ("muls", "… its multipliers"),
    ("adder_bits", "… Σ width over adders, add/subtracts and rounding incrementers"),
    ("table_bits", "… bits stored in its ROMs"),
    ("ff", "… its flip-flops (data, flags, valid bits)"),
    ("latency", "… cycles from input to output"),
    ("dsp_est", "… DSP blocks it takes on rtl.target, estimated without synthesis by Yosys's mul2dsp rules (0 where the target has none)"),
    ("bram_est", "… block RAMs its ROMs take on rtl.target, estimated without synthesis (copies by read ports, blocks by shape)"),
    ("lut_est", "… LUT cells it takes on rtl.target, estimated without synthesis by the area model fitted to Yosys (fxshade synth calibrate --area)"),
    ("ff_est", "… flip-flops it keeps after synthesis on rtl.target, estimated by the same model (ECP5: product registers packed into DSP blocks)"),
    ("cost.normalize.bit_products", "the normalize unit's own RTL module (with the normalize analysis): Σ a_width × b_width"),
    ("cost.normalize.table_bits", "… bits in its ROMs"),
    ("cost.normalize.ff", "… its flip-flops"),
    ("cost.normalize.latency", "… its latency, cycles"),
    ("cost.interp.bit_products", "the interp unit's own RTL module (with the interp analysis): Σ a_width × b_width"),
    ("cost.interp.table_bits", "… bits in its ROMs"),
    ("cost.interp.ff", "… its flip-flops"),
    ("cost.interp.latency", "… its latency, cycles"),
    ("cost.polar.bit_products", "the polar unit's own RTL module (with the polar analysis): Σ a_width × b_width"),
    ("cost.polar.table_bits", "… bits in its sin/cos ROMs"),
    ("cost.polar.ff", "… its flip-flops"),
    ("cost.polar.latency", "… its latency, cycles"),
    ("cost.angles.bit_products", "the angles unit's own RTL module (with the angles analysis): Σ a_width × b_width"),
    ("cost.angles.table_bits", "… bits in its ROMs"),
    ("cost.angles.ff", "… its flip-flops"),
    ("cost.angles.latency", "… its latency, cycles"),
    ("cost.lighting.bit_products", "the lighting unit's own RTL module (with the lighting analysis): Σ a_width × b_width"),
    ("cost.lighting.table_bits", "… bits in its ROMs"),
    ("cost.lighting.ff", "… its flip-flops"),
    ("cost.lighting.latency", "… its latency, cycles"),
    ("lut", "with --synth: look-up tables after synthesis (fxshade synth)"),
    ("synth_ff", "with --synth: flip-flops after synthesis, the harness's own excluded"),
    ("dsp", "with --synth: DSP blocks"),
    ("bram", "with --synth: block RAMs"),
    ("fmax_mhz", "with --synth on a target with place and route: Fmax, MHz"),
];

/// The metrics only `--synth` measures.
pub const SYNTH_METRICS: [&str; 5] = ["lut", "synth_ff", "dsp", "bram", "fmax_mhz"];

/// What a point measures and how.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct Options {
    /// Analysis groups ([`ANALYSES`]).
    pub analyses: Vec<String>,
    /// Meshes rendered for the `pipeline.*` metrics.
    pub meshes: Vec<String>,
    /// Their image size.
    pub size: (usize, usize),
    /// Random samples per unit analysis (`None`: each analysis at the
    /// default of its `fxshade error` command, so a point's figures are
    /// exactly what `fxshade error <unit>` prints for its configuration).
    pub samples: Option<usize>,
    /// Fingerprint of the configuration file and OBJ meshes read
    /// ([`super::inputs_fingerprint`]).
    #[serde(default)]
    pub inputs: String,
    /// `--synth`: the target and the unit synthesized.
    #[serde(default)]
    pub synth: Option<(String, String)>,
}

/// The default sample counts of `fxshade error normalize`, `interp`,
/// `polar` and `angles`, and of the lighting analysis here.
pub const DEFAULT_SAMPLES: [(&str, usize); 5] = [
    ("normalize", 200_000),
    ("interp", 200_000),
    ("polar", 500_000),
    ("angles", 500_000),
    ("lighting", 100_000),
];

impl Options {
    /// The sample count of analysis `a`.
    pub fn samples_of(&self, a: &str) -> usize {
        self.samples.unwrap_or_else(|| {
            DEFAULT_SAMPLES
                .iter()
                .find(|(n, _)| *n == a)
                .map_or(100_000, |x| x.1)
        })
    }
}

impl Options {
    /// Whether group `g` is measured.
    pub fn has(&self, g: &str) -> bool {
        self.analyses.iter().any(|a| a == g)
    }
}

/// The analysis group a metric belongs to (`cost` for bare names).
pub fn group_of(metric: &str) -> &str {
    metric.split_once('.').map_or("cost", |(g, _)| g)
}

/// The render method a configuration's pipeline top implements.
pub fn method_of(cfg: &Config) -> RenderMethod {
    match fxshade_model::pipeline::rtl::path_of(cfg) {
        Path::Smooth => RenderMethod::Smooth(
            cfg.section::<fxshade_model::normalizer::NormalizeConfig>()
                .method,
        ),
        Path::Mapped => RenderMethod::Mapped(
            cfg.section::<fxshade_model::pipeline::PipelineConfig>()
                .angles,
        ),
    }
}

fn put(m: &mut BTreeMap<String, f64>, k: &str, v: f64) {
    m.insert(k.to_string(), v);
}

/// Lighting on unit vectors quantized to the ports: the diffuse level
/// (I0·ks = 0) and the specular level (I0·km = 0) against f64, over `count`
/// random directions N and L (uniform on the sphere, so about half face
/// away: the clamp to 0 is exercised too) and H halfway between L and a
/// random viewer.
fn lighting(cfg: &Config, count: usize, m: &mut BTreeMap<String, f64>) -> anyhow::Result<()> {
    let base = Lighting::from_config(cfg);
    let mut rng = Rng::new(1);
    let mut cols: Vec<Vec<i128>> = (0..9).map(|_| Vec::with_capacity(count)).collect();
    let mut exact = Vec::with_capacity(count);
    for _ in 0..count {
        let n = rng.direction();
        let l = rng.direction();
        let h = (l + rng.direction()).normalize_or_zero();
        let h = if h == glam::DVec3::ZERO { l } else { h };
        for (k, (v, q)) in [(n, base.normal), (l, base.light), (h, base.light)]
            .into_iter()
            .enumerate()
        {
            for (c, x) in v.to_array().into_iter().enumerate() {
                // The port's own quantization (its rounding and overflow).
                cols[3 * k + c].push(q.apply_f64(x)?.code);
            }
        }
        exact.push((n, l, h));
    }
    let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
    for (name, km, ks) in [
        ("lighting.max_diffuse_err_levels", base.i0_km, 0.0),
        ("lighting.max_specular_err_levels", 0.0, base.i0_ks),
    ] {
        let mut li = base;
        li.i0_km = km;
        li.i0_ks = ks;
        let prog = li.compile_shade().context("compiling the lighting unit")?;
        let (out, _) = prog.run_i128(&refs);
        let fl = li.level.format();
        let worst = out[0]
            .iter()
            .zip(&exact)
            .map(|(&c, &(n, l, h))| (fl.to_f64(c) - render::shade_f64(&li, n, l, h)).abs())
            .fold(0.0, f64::max);
        put(m, name, worst);
    }
    let _ = LEVELS;
    Ok(())
}

/// Render every mesh with the configured path and method; the aggregate
/// image metrics.
fn pipeline(
    cfg: &Config,
    o: &Options,
    meshes: &[(String, fxshade_model::mesh::Mesh)],
    m: &mut BTreeMap<String, f64>,
) -> anyhow::Result<()> {
    let method = method_of(cfg);
    let scene = render::Scene::default();
    let base = fxshade_model::pipeline::Pipeline::with_method(
        cfg,
        fxshade_model::normalizer::Method::None,
    )?;
    let (mut max, mut sum, mut n, mut psnr, mut off, mut rel, mut bound) =
        (0u32, 0.0, 0usize, f64::INFINITY, 0.0f64, 0.0f64, true);
    for (spec, mesh) in meshes {
        let raster = render::rasterize_in(&scene, mesh, o.size.0, o.size.1);
        let f = render::frame_wanted(
            &scene,
            &base,
            raster,
            mesh,
            render::Wanted::methods(&[method]),
        );
        let img =
            render::run_method(cfg, &f, method).with_context(|| format!("rendering {spec}"))?;
        let mm: &Metrics = img.outside_cap.as_ref().unwrap_or(&img.metrics);
        max = max.max(mm.max_abs_levels);
        sum += mm.mean_abs_levels * to_f64(mm.pixels);
        n += mm.pixels;
        psnr = psnr.min(mm.psnr_db.unwrap_or(999.0));
        off = off.max(mm.off_by[2] + mm.off_by[3]);
        rel = rel.max(mm.max_rel_intensity_err);
        bound &= mm.paper_bound_holds;
    }
    put(m, "pipeline.max_err_levels", f64::from(max));
    put(
        m,
        "pipeline.mean_err_levels",
        if n == 0 { 0.0 } else { sum / to_f64(n) },
    );
    put(m, "pipeline.psnr_db", psnr);
    put(m, "pipeline.off_by_gt1", off);
    put(m, "pipeline.max_rel_err", rel);
    put(m, "pipeline.paper_bound", if bound { 1.0 } else { 0.0 });
    Ok(())
}

/// The model's hardware cost of the configured pipeline top.
/// The units whose own module's cost `cost` measures (when their
/// analysis is asked for): `cost.<unit>.*`.
pub const UNIT_COSTS: [&str; 5] = ["normalize", "interp", "polar", "angles", "lighting"];

fn cost(cfg: &Config, o: &Options, m: &mut BTreeMap<String, f64>) -> anyhow::Result<()> {
    let design = fxshade_model::pipeline::RTL.design(cfg)?;
    let e = fxshade_model::rtl::emit(&design)?;
    top_cost(
        &e,
        "",
        cfg.section::<fxshade_model::rtl::section::RtlConfig>()
            .target
            .name(),
        m,
    );
    // Each analysed unit's own module: a sweep of a unit off the
    // configured path (polar on the smooth path) sees its own cost move.
    // A unit without RTL in this configuration (the exact normalizer has
    // none) leaves its cost metrics out; the point's other figures stand.
    for u in UNIT_COSTS.iter().filter(|u| o.has(u)) {
        let Some(unit) = fxshade_model::rtl::units::unit(u) else {
            continue;
        };
        if let Ok((_, e)) = fxshade_model::rtl::units::emit_unit(unit, cfg) {
            top_cost(&e, &format!("cost.{u}."), "", m);
        }
    }
    Ok(())
}

/// The cost metrics of one emitted module, named `<prefix><metric>`
/// (`cost.<unit>.` for a unit's own; none for the top, which also
/// counts its multipliers and adders).
fn top_cost(
    e: &fxshade_model::rtl::Emitted,
    prefix: &str,
    target: &str,
    m: &mut BTreeMap<String, f64>,
) {
    let hw = &e.hardware;
    if !prefix.is_empty() {
        put(
            m,
            &format!("{prefix}bit_products"),
            hw.muls
                .iter()
                .map(|x| f64::from(x.a_width * x.b_width))
                .sum(),
        );
        put(m, &format!("{prefix}table_bits"), to_f64(hw.rom_bits));
        put(m, &format!("{prefix}ff"), to_f64(hw.flops));
        put(m, &format!("{prefix}latency"), f64::from(e.latency));
        return;
    }
    put(
        m,
        "bit_products",
        hw.muls
            .iter()
            .map(|x| f64::from(x.a_width * x.b_width))
            .sum(),
    );
    put(m, "muls", to_f64(hw.muls.len()));
    put(
        m,
        "adder_bits",
        hw.adders
            .iter()
            .chain(&hw.add_subs)
            .chain(&hw.incrementers)
            .map(|&w| f64::from(w))
            .sum(),
    );
    put(m, "table_bits", to_f64(hw.rom_bits));
    put(m, "ff", to_f64(hw.flops));
    put(m, "latency", f64::from(e.latency));
    if let Some(t) = fxshade_model::rtl::timing::Target::from_name(target) {
        put(
            m,
            "dsp_est",
            to_f64(fxshade_model::rtl::estimate::dsp_blocks(hw, t)),
        );
        put(
            m,
            "bram_est",
            to_f64(fxshade_model::rtl::estimate::bram_blocks(hw, t)),
        );
        if let Some(l) = fxshade_model::rtl::estimate::lut_cells(hw, t) {
            put(m, "lut_est", to_f64(l));
        }
        if let Some(f) = fxshade_model::rtl::estimate::flip_flops(hw, t) {
            put(m, "ff_est", to_f64(f));
        }
    }
}

/// Measure one configuration. `meshes` are the loaded `o.meshes`.
/// An analysis that fails makes the whole point fail, with its name.
///
/// # Errors
///
/// A mesh cannot be rendered, a unit analysis fails, or an asked synthesis fails or names a
/// target without a synthesis flow.
pub fn evaluate(
    cfg: &Config,
    o: &Options,
    meshes: &[(String, fxshade_model::mesh::Mesh)],
) -> anyhow::Result<BTreeMap<String, f64>> {
    let mut m = BTreeMap::new();
    let n = |a: &str| o.samples_of(a).max(1);
    if o.has("normalize") {
        let r = fxshade_model::analysis::normalize(cfg, n("normalize"), 1, &mut |_| {})
            .context("normalize analysis")?;
        let t = &r.triangles;
        put(&mut m, "normalize.max_rel_err", t.max_rel_err);
        put(&mut m, "normalize.mean_rel_err", t.mean_rel_err);
        put(&mut m, "normalize.rms_rel_err", t.rms_rel_err);
        put(&mut m, "normalize.max_lsb_err", t.max_lsb_err);
        put(
            &mut m,
            "normalize.max_diffuse_err_levels",
            t.max_diffuse_err_levels,
        );
        put(&mut m, "normalize.g_max_rel_err", r.g_stage.max_rel_err);
        put(&mut m, "normalize.overflows", to_f64(t.overflows));
    }
    if o.has("interp") {
        let r = fxshade_model::analysis::interp(
            cfg,
            render::scheme_of(cfg),
            cfg.section::<fxshade_model::normalizer::NormalizeConfig>()
                .method,
            cfg.section::<fxshade_model::normalizer::NormalizeConfig>()
                .theta,
            n("interp"),
            1,
            &mut |_| {},
        )
        .context("interp analysis")?;
        put(&mut m, "interp.max_rel_err", r.max_rel_err);
        put(&mut m, "interp.max_angle_err_deg", r.max_angle_err_deg);
    }
    if o.has("polar") {
        let r = fxshade_model::analysis::polar(
            cfg,
            n("polar"),
            1,
            fxshade_model::analysis::POLAR_EXHAUSTIVE_CHEAP,
        )
        .context("polar analysis")?;
        put(&mut m, "polar.max_lsb_err", r.stats.max_lsb_err);
        put(&mut m, "polar.rms_lsb_err", r.stats.rms_lsb_err);
        put(&mut m, "polar.max_angle_err_deg", r.stats.max_angle_err_deg);
        put(
            &mut m,
            "polar.max_diffuse_err_levels",
            r.stats.max_diffuse_err_levels,
        );
    }
    if o.has("angles") {
        let r = fxshade_model::analysis::angles(cfg, n("angles"), 1).context("angles analysis")?;
        put(&mut m, "angles.max_alpha_lsb", r.stats.max_alpha_lsb);
        put(&mut m, "angles.max_beta_lsb", r.stats.max_beta_lsb);
        put(
            &mut m,
            "angles.max_direction_deg",
            r.stats.max_direction_deg,
        );
    }
    if o.has("lighting") {
        lighting(cfg, n("lighting"), &mut m).context("lighting analysis")?;
    }
    if o.has("pipeline") && !meshes.is_empty() {
        pipeline(cfg, o, meshes, &mut m)?;
    }
    if o.has("cost") {
        cost(cfg, o, &mut m).context("generating the RTL top for its cost")?;
    }
    if let Some((target, unit)) = &o.synth {
        let t = crate::synth::synth_target(target).ok_or_else(|| {
            anyhow::anyhow!(
                "--synth {target}: not a synthesis target (one of {})",
                crate::synth::synth_targets_where(|_| true)
            )
        })?;
        let (r, _) = crate::synth::cached(
            unit,
            cfg,
            t,
            crate::synth::Flow::DEFAULT,
            None,
            true,
            &|_| {},
        )
        .with_context(|| format!("synthesizing {unit} for {target}"))?;
        put(&mut m, "lut", to_f64(r.lut));
        put(&mut m, "synth_ff", to_f64(r.ff - r.harness_ff.min(r.ff)));
        put(&mut m, "dsp", to_f64(r.dsp));
        put(&mut m, "bram", to_f64(r.bram));
        if let Some(f) = r.fmax_mhz {
            put(&mut m, "fmax_mhz", f);
        }
    }
    Ok(m)
}
