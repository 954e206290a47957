//! Error analysis of the bit-accurate model against the f64 reference.
//!
//! For the normalizer ([`normalize`]): the scalar `g(d)` stage exhaustively
//! over every `d` code of the interval, and whole vectors — random triangles
//! meeting Θ with random barycentrics, points on edges, and corner cases —
//! through the compiled bit-accurate unit, against exact normalization of the
//! same (quantized) input in f64. The diffuse term `I0·km·max(0, N·L)` is
//! computed from the model's output by the bit-accurate lighting unit and
//! compared, in 8-bit levels, with the f64 value from the exact normal.

use fxshade_numbers::convert::{from_f64, narrow, to_f64};
use glam::DVec3;

use crate::config::Config;
use crate::datapath::Compiled;
use crate::lighting::{Lighting, LEVELS};
use crate::normalizer::{self, Design, DesignError, Method, Normalizer, Stats};
use crate::quantize::{Quant, Rounding};
use crate::sampling::{self, Rng};

/// Error statistics of whole output vectors.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct VectorStats {
    /// Number of input vectors.
    pub samples: u64,
    /// Largest `| |N'| − 1 |`.
    pub max_rel_err: f64,
    /// Mean of `| |N'| − 1 |`.
    pub mean_rel_err: f64,
    /// RMS of `| |N'| − 1 |`.
    pub rms_rel_err: f64,
    /// Largest component error against the exact unit vector, in output LSBs.
    pub max_lsb_err: f64,
    /// Largest error of the diffuse term, in 8-bit levels.
    pub max_diffuse_err_levels: f64,
    /// Overflows at quantization steps (normalizer and lighting).
    pub overflows: u64,
}

/// The normalizer's error report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NormalizeReport {
    /// Method.
    pub method: Method,
    /// Θ.
    pub theta: f64,
    /// The interval the coefficients were fitted on (`edge` or `triangle`).
    pub interval_kind: normalizer::Interval,
    /// `[lo, hi]` of that interval.
    pub interval: (f64, f64),
    /// The coefficient values used, highest power first.
    pub coeffs: Vec<f64>,
    /// How they were designed (linear and quadratic).
    pub design: Option<Design>,
    /// The `g(d)` stage over every `d` code of the interval.
    pub g_stage: Stats,
    /// Whole triangles meeting Θ (random barycentrics and corner cases):
    /// the headline figures, repeated at the top level of the JSON.
    pub triangles: VectorStats,
    /// Points on triangle edges only (the paper's setting).
    pub edges: VectorStats,
    /// Corner inputs outside every triangle: the largest and smallest
    /// representable components.
    pub outside: VectorStats,
    /// The proven bound on `| |N'| − 1 |` over whole triangles
    /// ([`NormalizeReport::proven_triangles`]`.length`): every quantized
    /// input whose exact vector has `|N|²` in the whole-triangle range.
    pub bound: f64,
    /// Proven bounds over whole triangles (`|N|² ∈ [(1+2Θ)/3, 1]`): length,
    /// vector and diffuse error for every input, not a sample.
    pub proven_triangles: crate::bounds::NormalizeBound,
    /// The same over triangle edges (`|N|² ∈ [(1+Θ)/2, 1]`).
    pub proven_edges: crate::bounds::NormalizeBound,
    /// Seed of the random samples.
    pub seed: u64,
}

struct Sample {
    n: DVec3,
    light: DVec3,
}

fn corners(theta: f64, rng: &mut Rng) -> Vec<DVec3> {
    let mut v = Vec::new();
    for _ in 0..16 {
        let t = sampling::equiangular(theta, rng);
        // Centroid (smallest d), vertices (d = 1), edge midpoints.
        v.push(sampling::lerp3(&t, [1.0 / 3.0; 3]));
        for i in 0..3 {
            let mut c = [0.0; 3];
            c[i] = 1.0;
            v.push(sampling::lerp3(&t, c));
            let mut m = [0.5; 3];
            m[i] = 0.0;
            v.push(sampling::lerp3(&t, m));
        }
    }
    v
}

/// Run the normalizer and the lighting unit on `samples`; accumulate.
fn measure(
    n: &Normalizer,
    prog: &Compiled,
    light: &Lighting,
    lprog: &Compiled,
    samples: &[Sample],
) -> Result<VectorStats, crate::format::ConvertError> {
    let qn = &n.q.normal;
    let mut cols: [Vec<i128>; 3] = Default::default();
    for s in samples {
        for (k, col) in cols.iter_mut().enumerate() {
            col.push(qn.apply_f64(s.n[k])?.code);
        }
    }
    let (out, ov) = prog.run_i128(&[&cols[0], &cols[1], &cols[2]]);
    let fo = n.q.out.format();
    // The normal enters the lighting unit in its own input format.
    let to_light = |c: i128| light.normal.apply(c, fo.frac()).code;
    let mut lcols: [Vec<i128>; 6] = Default::default();
    for (i, s) in samples.iter().enumerate() {
        for k in 0..3 {
            lcols[k].push(to_light(out[k][i]));
            lcols[3 + k].push(light.light.apply_f64(s.light[k])?.code);
        }
    }
    let (lv, lov) = lprog.run_i128(&[
        &lcols[0], &lcols[1], &lcols[2], &lcols[3], &lcols[4], &lcols[5],
    ]);
    let fl = light.level.format();
    let fin = qn.format();
    let mut st = VectorStats {
        samples: samples.len() as u64,
        overflows: ov.iter().chain(&lov).map(|(_, k)| k).sum(),
        ..Default::default()
    };
    let mut sum = 0.0;
    let mut sum2 = 0.0;
    for (i, s) in samples.iter().enumerate() {
        let nq = DVec3::new(
            fin.to_f64(cols[0][i]),
            fin.to_f64(cols[1][i]),
            fin.to_f64(cols[2][i]),
        );
        let exact = nq.normalize_or_zero();
        let got = DVec3::new(
            fo.to_f64(out[0][i]),
            fo.to_f64(out[1][i]),
            fo.to_f64(out[2][i]),
        );
        let e = (got.length() - 1.0).abs();
        sum += e;
        sum2 += e * e;
        st.max_rel_err = st.max_rel_err.max(e);
        let lsb = (got - exact).abs().max_element() / fo.ulp();
        st.max_lsb_err = st.max_lsb_err.max(lsb);
        let want = LEVELS * light.i0_km * exact.dot(s.light).max(0.0);
        let level = fl.to_f64(lv[0][i]);
        st.max_diffuse_err_levels = st.max_diffuse_err_levels.max((level - want).abs());
    }
    if st.samples > 0 {
        st.mean_rel_err = sum / to_f64(st.samples);
        st.rms_rel_err = (sum2 / to_f64(st.samples)).sqrt();
    }
    Ok(st)
}

/// Why an analysis could not run.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// The normalizer could not be built.
    #[error(transparent)]
    Design(#[from] DesignError),
    /// A datapath is too wide.
    #[error(transparent)]
    Compile(#[from] crate::datapath::CompileError),
    /// An input could not be converted.
    #[error(transparent)]
    Convert(#[from] crate::format::ConvertError),
    /// The polar configuration is unusable.
    #[error(transparent)]
    Polar(crate::polar::PolarError),
    /// The lighting stage could not be compiled.
    #[error(transparent)]
    Lighting(#[from] crate::lighting::LightingError),
    /// The angles configuration is unusable.
    #[error(transparent)]
    Angles(crate::angles::AnglesError),
    /// The unit's RTL could not be generated for its cost figures.
    #[error("generating the RTL: {0}")]
    Rtl(String),
    /// The cache cannot be used.
    #[error("{0}")]
    Cache(String),
}

/// Analyse the normalizer a configuration describes: `count` random
/// whole-triangle samples (and a quarter as many edge samples) from `seed`,
/// plus corner cases. `progress` is called with the fraction done.
///
/// # Errors
///
/// [`AnalysisError::Design`] when the normalizer cannot be designed, its `g(d)` stage
/// analysed, or its bounds proven; [`AnalysisError::Compile`] when the normalizer, and
/// [`AnalysisError::Lighting`] when the lighting unit, cannot be compiled;
/// [`AnalysisError::Convert`] when a sample cannot be converted into an input format.
///
/// # Panics
///
/// Never: a configuration's choices are declared ones, and its Θ lies in `[0, 0.999999]`.
pub fn normalize(
    cfg: &Config,
    count: usize,
    seed: u64,
    progress: &mut dyn FnMut(f64),
) -> Result<NormalizeReport, AnalysisError> {
    let u: normalizer::NormalizeConfig = cfg.section();
    let (theta, interval_kind) = (u.theta, u.interval);
    let (n, design) = normalizer::from_config(cfg)?;
    progress(0.2);
    let (lo, hi) = design
        .as_ref()
        .map_or(interval_kind.bounds(theta), |d| d.interval);
    let g_stage = normalizer::g_stage_stats(&n, lo, hi)?;
    progress(0.3);
    let light = Lighting::from_config(cfg);
    let lprog = light.compile()?;
    let prog = n.compile()?;
    let mut rng = Rng::new(seed);

    let mut tri: Vec<Sample> = corners(theta, &mut rng)
        .into_iter()
        .map(|n| Sample { n, light: DVec3::Z })
        .collect();
    for s in &mut tri {
        s.light = rng.direction();
    }
    let chunk = 1 << 16;
    let mut triangles = VectorStats::default();
    let mut done = 0;
    while done < count || !tri.is_empty() {
        let m = chunk.min(count - done);
        for _ in 0..m {
            let t = sampling::triangle_meeting(theta, &mut rng);
            let b = rng.barycentric();
            tri.push(Sample {
                n: sampling::lerp3(&t, b),
                light: rng.direction(),
            });
        }
        done += m;
        let st = measure(&n, &prog, &light, &lprog, &tri)?;
        triangles = merge(triangles, st);
        tri.clear();
        progress(0.3 + 0.5 * to_f64(done) / to_f64(count.max(1)));
    }
    let n_edges = (count / 4).max(64);
    let mut edges = VectorStats::default();
    let mut done = 0;
    while done < n_edges {
        let m = chunk.min(n_edges - done);
        let edge_samples: Vec<Sample> = (0..m)
            .map(|_| {
                let t = sampling::triangle_meeting(theta, &mut rng);
                let s = rng.unit();
                let i = narrow::<usize, _>(rng.below(3));
                let mut c = [0.0; 3];
                c[i] = s;
                c[(i + 1) % 3] = 1.0 - s;
                Sample {
                    n: sampling::lerp3(&t, c),
                    light: rng.direction(),
                }
            })
            .collect();
        edges = merge(edges, measure(&n, &prog, &light, &lprog, &edge_samples)?);
        done += m;
    }
    progress(0.95);
    let fin = n.q.normal.format();
    let (big, small) = (fin.max_value(), fin.ulp());
    let outside_inputs = [
        DVec3::new(big, 0.0, 0.0),
        DVec3::new(fin.min_value(), 0.0, 0.0),
        DVec3::splat(big),
        DVec3::new(0.0, big, -big),
        DVec3::new(small, 0.0, 0.0),
        DVec3::new(-small, small, 0.0),
        DVec3::new(0.0, 0.0, small),
    ];
    let outside_samples: Vec<Sample> = outside_inputs
        .iter()
        .map(|&n| Sample {
            n,
            light: DVec3::new(0.0, 0.6, 0.8),
        })
        .collect();
    let outside = measure(&n, &prog, &light, &lprog, &outside_samples)?;
    let proven_triangles = crate::bounds::normalize(
        &n,
        &light,
        normalizer::Interval::Triangle.bounds(theta).0,
        1.0,
    )?;
    let proven_edges =
        crate::bounds::normalize(&n, &light, normalizer::Interval::Edge.bounds(theta).0, 1.0)?;
    progress(1.0);
    Ok(NormalizeReport {
        method: n.method,
        theta,
        interval_kind,
        interval: (lo, hi),
        coeffs: n.coeffs.iter().rev().copied().collect(),
        bound: proven_triangles.length,
        proven_triangles,
        proven_edges,
        design,
        g_stage,
        triangles,
        edges,
        outside,
        seed,
    })
}

fn merge(a: VectorStats, b: VectorStats) -> VectorStats {
    let n = a.samples + b.samples;
    if n == 0 {
        return a;
    }
    let w = |x: f64, k: u64| x * to_f64(k);
    VectorStats {
        samples: n,
        max_rel_err: a.max_rel_err.max(b.max_rel_err),
        mean_rel_err: (w(a.mean_rel_err, a.samples) + w(b.mean_rel_err, b.samples)) / to_f64(n),
        rms_rel_err: ((w(a.rms_rel_err.powi(2), a.samples) + w(b.rms_rel_err.powi(2), b.samples))
            / to_f64(n))
        .sqrt(),
        max_lsb_err: a.max_lsb_err.max(b.max_lsb_err),
        max_diffuse_err_levels: a.max_diffuse_err_levels.max(b.max_diffuse_err_levels),
        overflows: a.overflows + b.overflows,
    }
}

/// Angle statistics, in degrees.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct AngleStats {
    /// Largest angle.
    pub max_angle_err_deg: f64,
    /// Mean angle.
    pub mean_angle_err_deg: f64,
}

/// The interpolator's error report: the bit-accurate interpolator followed
/// by the bit-accurate normalizer, against exact fields.
#[derive(Clone, Debug, serde::Serialize)]
pub struct InterpReport {
    /// Interpolation scheme.
    pub scheme: crate::interp::Scheme,
    /// Θ of the sampled triangles.
    pub theta: f64,
    /// The normalizer after the interpolator.
    pub normalizer: Method,
    /// The interval the normalizer's coefficients were fitted on: the
    /// scheme's range of `d` for triangles meeting Θ.
    pub interval: (f64, f64),
    /// The normalizer's coefficients, highest power first.
    pub coeffs: Vec<f64>,
    /// The range of `d = |N|²` of the scheme, closed form.
    pub d_bound: (f64, f64),
    /// Smallest `d` of the exact scheme field over the samples.
    pub d_min: f64,
    /// Largest `d` of the exact scheme field over the samples.
    pub d_max: f64,
    /// Pixels evaluated.
    pub samples: u64,
    /// Largest `| |N'| − 1 |` of the bit-accurate output.
    pub max_rel_err: f64,
    /// Mean of it.
    pub mean_rel_err: f64,
    /// RMS of it.
    pub rms_rel_err: f64,
    /// Largest direction error against the normalized exact quadratic field.
    pub max_angle_err_deg: f64,
    /// Mean direction error against the normalized exact quadratic field.
    pub mean_angle_err_deg: f64,
    /// Direction error against normalized exact linear interpolation.
    pub vs_linear: AngleStats,
    /// `max | |N| − 1 |` of the exact scheme field with no normalization.
    pub unnormalized_max_rel_err: f64,
    /// Overflows at quantization steps.
    pub overflows: u64,
    /// Seed.
    pub seed: u64,
}

fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    let (a, b) = (a.normalize_or_zero(), b.normalize_or_zero());
    // atan2 of the cross and dot products is accurate for tiny angles.
    a.cross(b).length().atan2(a.dot(b)).to_degrees()
}

/// Analyse interpolation (`scheme`) followed by normalization (`method`)
/// for triangles meeting `theta`: `count` random pixels plus corner cases.
///
/// # Errors
///
/// [`AnalysisError::Design`] when the normalizer cannot be designed
/// ([`normalizer::design_interval`]); [`AnalysisError::Compile`] when the interpolator or the
/// normalizer cannot be compiled; [`AnalysisError::Convert`] when a barycentric or a vertex
/// component cannot be converted into its format.
///
/// # Panics
///
/// When `theta` is below −0.5 or NaN (no triangle of unit normals is equiangular at Θ),
/// unless the normalizer's design fails first. A configured Θ lies in `[0, 0.999999]`.
pub fn interp(
    cfg: &Config,
    scheme: crate::interp::Scheme,
    method: Method,
    theta: f64,
    count: usize,
    seed: u64,
    progress: &mut dyn FnMut(f64),
) -> Result<InterpReport, AnalysisError> {
    use crate::interp::{self, Interp};
    let nu: normalizer::NormalizeConfig = cfg.section();
    let ip = Interp {
        scheme,
        ..Interp::from_config(cfg)
    };
    let d_bound = interp::quadratic_d_range(theta, scheme);
    let (n, _) = normalizer::design_interval(
        method,
        Normalizer::stages(&nu),
        theta,
        nu.fit,
        normalizer::Interval::Triangle,
        d_bound,
        nu.coef_quant == normalizer::CoefQuant::Search,
    )?;
    progress(0.2);
    let iprog = ip.compile()?;
    let nprog = n.compile()?;
    let mut rng = Rng::new(seed);
    let mut pix: Vec<(interp::Triangle, [f64; 3])> = Vec::new();
    for _ in 0..8 {
        let t = interp::setup(sampling::equiangular(theta, &mut rng)).expect("unit normals");
        for c in [
            [1.0 / 3.0; 3],
            [1.0, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.25, 0.25, 0.5],
        ] {
            pix.push((t, c));
        }
    }
    let fo = n.q.out.format();
    let mut r = InterpReport {
        scheme,
        theta,
        normalizer: method,
        interval: d_bound,
        coeffs: n.coeffs.iter().rev().copied().collect(),
        d_bound,
        d_min: f64::INFINITY,
        d_max: 0.0,
        samples: 0,
        max_rel_err: 0.0,
        mean_rel_err: 0.0,
        rms_rel_err: 0.0,
        max_angle_err_deg: 0.0,
        mean_angle_err_deg: 0.0,
        vs_linear: AngleStats::default(),
        unnormalized_max_rel_err: 0.0,
        overflows: 0,
        seed,
    };
    let (mut s1, mut s2, mut sa, mut sl) = (0.0, 0.0, 0.0, 0.0);
    // The corner pixels, then the random ones a chunk at a time (memory
    // stays flat whatever the count; the samples are those of one pass).
    let mut done = 0;
    let total = count;
    loop {
        let m = SAMPLE_CHUNK.min(total - done);
        for _ in 0..m {
            let t =
                interp::setup(sampling::triangle_meeting(theta, &mut rng)).expect("unit normals");
            pix.push((t, rng.barycentric()));
        }
        done += m;
        // Inputs of the compiled interpolator: c1, c2, then 18 components.
        let code = |q: &Quant, x: f64| q.apply_f64(x).map(|r| r.code);
        let mut cols: Vec<Vec<i128>> = (0..20).map(|_| Vec::with_capacity(pix.len())).collect();
        for (t, c) in &pix {
            cols[0].push(code(&ip.bary, c[0])?);
            cols[1].push(code(&ip.bary, c[1])?);
            for (k, v) in t.n.iter().chain(t.mid.iter()).enumerate() {
                for comp in 0..3 {
                    cols[2 + 3 * k + comp].push(code(&ip.vertex, v[comp])?);
                }
            }
        }
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        let (iout, iov) = iprog.run_i128(&refs);
        // Into the normalizer's input format.
        let fi = ip.out.format();
        let ncols: Vec<Vec<i128>> = (0..3)
            .map(|k| {
                iout[k]
                    .iter()
                    .map(|&c| n.q.normal.apply(c, fi.frac()).code)
                    .collect()
            })
            .collect();
        let (nout, nov) = nprog.run_i128(&[&ncols[0], &ncols[1], &ncols[2]]);
        r.overflows += iov.iter().chain(&nov).map(|(_, k)| k).sum::<u64>();
        r.samples += pix.len() as u64;
        for (i, (t, c)) in pix.iter().enumerate() {
            let exact = interp::field(t, *c, scheme);
            let d = exact.length_squared();
            r.d_min = r.d_min.min(d);
            r.d_max = r.d_max.max(d);
            r.unnormalized_max_rel_err = r.unnormalized_max_rel_err.max((d.sqrt() - 1.0).abs());
            let got = DVec3::new(
                fo.to_f64(nout[0][i]),
                fo.to_f64(nout[1][i]),
                fo.to_f64(nout[2][i]),
            );
            let e = (got.length() - 1.0).abs();
            r.max_rel_err = r.max_rel_err.max(e);
            s1 += e;
            s2 += e * e;
            let a = angle_deg(got, interp::field(t, *c, interp::Scheme::Quadratic));
            r.max_angle_err_deg = r.max_angle_err_deg.max(a);
            sa += a;
            let l = angle_deg(got, interp::field(t, *c, interp::Scheme::Linear));
            r.vs_linear.max_angle_err_deg = r.vs_linear.max_angle_err_deg.max(l);
            sl += l;
        }
        pix.clear();
        progress(0.2 + 0.8 * to_f64(done) / to_f64(total.max(1)));
        if done >= total {
            break;
        }
    }
    let k = to_f64(r.samples.max(1));
    r.mean_rel_err = s1 / k;
    r.rms_rel_err = (s2 / k).sqrt();
    r.mean_angle_err_deg = sa / k;
    r.vs_linear.mean_angle_err_deg = sl / k;
    progress(1.0);
    Ok(r)
}

/// Error statistics of the polar transform.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct PolarStats {
    /// Transforms evaluated.
    pub samples: u64,
    /// What the samples cover: `all codes`, `all (α_L, β_L−β_N) pairs for 8
    /// α_N`, or `random`.
    pub coverage: &'static str,
    /// Largest component error of L' against the exact implied frame, in
    /// output LSBs.
    pub max_lsb_err: f64,
    /// RMS component error, in output LSBs.
    pub rms_lsb_err: f64,
    /// Largest `| |L'| − 1 |`.
    pub max_len_dev: f64,
    /// Largest angle between L' and the exact vector, degrees.
    pub max_angle_err_deg: f64,
    /// Largest diffuse error `255·I0·km·max(0, n·L')` against a tangent-space
    /// normal `n`, in 8-bit levels.
    pub max_diffuse_err_levels: f64,
    /// Overflows at quantization steps (not counting the index stage, whose
    /// wrap-around is the modular arithmetic of angles).
    pub overflows: u64,
    /// Largest `|L' − L|` (exhaustive coverage only; 0 otherwise).
    pub max_vector_err: f64,
    /// Whether [`PolarStats::max_diffuse_err_levels`] is a proven bound
    /// (exhaustive coverage) rather than the largest of the samples.
    pub diffuse_is_bound: bool,
}

/// The polar transform's error report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PolarReport {
    /// Angle bits.
    pub angle_bits: u32,
    /// Table index bits.
    pub table_bits: u32,
    /// Table entry format.
    pub table_format: String,
    /// Table organisation.
    pub organisation: crate::polar::Organisation,
    /// Bits stored per table (sin or cos).
    pub table_size_bits: u64,
    /// The error figures.
    #[serde(flatten)]
    pub stats: PolarStats,
    /// Seed of the random parts.
    pub seed: u64,
}

/// The most `(α_L, β_L − β_N, α_N)` code triples `error polar` and the
/// report cover one by one: 11-bit angles (2.15·10^9 triples, about 35
/// CPU-s, 18 s on two cores here); above, samples.
pub const POLAR_EXHAUSTIVE: u64 = 1 << 32;

/// The most triples an exploration point covers one by one (each point is
/// measured: the samples serve above).
pub const POLAR_EXHAUSTIVE_CHEAP: u64 = 1 << 22;

/// Analyse a polar transform: exhaustive over `(α_L, β_L − β_N, α_N)` (the
/// output depends on `β_L − β_N` alone) when there are at most
/// `exhaustive_up_to` such triples ([`polar_every_code`]), else `count`
/// random samples (the diffuse error then against random tangent-space
/// normals: a sampled maximum).
///
/// # Errors
///
/// Exhaustive: [`AnalysisError::Cache`] when the cache directory cannot be used or the
/// entry cannot be read safely, else as [`polar_every_code`]. Sampled:
/// [`AnalysisError::Compile`] when the transform, and [`AnalysisError::Lighting`] when the
/// lighting unit, cannot be compiled; [`AnalysisError::Convert`] when a tangent-space normal
/// cannot be converted into `lighting.normal`.
pub fn polar_stats(
    p: &crate::polar::Polar,
    light: &Lighting,
    count: usize,
    seed: u64,
    exhaustive_up_to: u64,
) -> Result<PolarStats, AnalysisError> {
    let f = p.angle.format();
    let k = f.width();
    let turn = 1i128 << k;
    let quarter = turn / 4;
    let mut rng = Rng::new(seed);
    // Elevation codes in [−¼, ¼] turn, as codes modulo a turn.
    let elev = |c: i128| c.rem_euclid(turn);
    let triples = narrow::<u64, _>(2 * quarter + 1)
        * narrow::<u64, _>(turn)
        * narrow::<u64, _>(2 * quarter + 1);
    if triples <= exhaustive_up_to {
        // Remembered: the transform is fixed by the polar and lighting
        // stages' formats, modes and tables.
        // (Not `{p:?}`: a table's Debug holds its function's address,
        // which changes from run to run.)
        let t = &p.tables;
        let key = format!(
            "{:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {light:?}",
            p.angle, p.index, p.lyz, p.out, t.sin.out, t.sin.codes, t.cos.codes, t.organisation
        );
        let r: PolarExhaustive = remembered("polar-every-code", &[key.as_bytes()], || {
            polar_every_code(p, light).map(PolarExhaustive::from)
        })?;
        return Ok(r.into());
    }
    let coverage = "random";
    let total = count;
    let prog = p.compile()?;
    let lprog = light.compile()?;
    let fo = p.out.format();
    let fl = light.level.format();
    let mut st = PolarStats {
        coverage,
        ..Default::default()
    };
    let mut sum2 = 0.0;
    // The tangent-space normals the diffuse term is judged against come
    // from a stream of their own.
    let mut nrng = Rng::new(seed ^ 0x6e6f_726d_616c);
    let mut done = 0;
    let mut chunk: Vec<[i128; 4]> = Vec::with_capacity(1 << 18);
    while done < total {
        let m = (1usize << 18).min(total - done);
        chunk.clear();
        for _ in 0..m {
            let al = -quarter + i128::from(rng.below(narrow::<u64, _>(2 * quarter + 1)));
            let an = -quarter + i128::from(rng.below(narrow::<u64, _>(2 * quarter + 1)));
            let bl = i128::from(rng.below(narrow::<u64, _>(turn)));
            let bn = i128::from(rng.below(narrow::<u64, _>(turn)));
            chunk.push([elev(al), bl, elev(an), bn]);
        }
        done += m;
        let chunk = &chunk;
        let cols: Vec<Vec<i128>> = (0..4)
            .map(|j| chunk.iter().map(|r| r[j]).collect())
            .collect();
        let (out, ov) = prog.run_i128(&[&cols[0], &cols[1], &cols[2], &cols[3]]);
        // The index stage wraps by design (angles are modulo a turn).
        st.overflows += ov
            .iter()
            .filter(|(s, _)| *s != "index")
            .map(|(_, n)| n)
            .sum::<u64>();
        // Tangent-space normals of a normal map: the upper hemisphere.
        let normals: Vec<DVec3> = chunk
            .iter()
            .map(|_| nrng.in_cone(DVec3::Z, std::f64::consts::FRAC_PI_2))
            .collect();
        let mut lcols: [Vec<i128>; 6] = Default::default();
        let mut exact_l = Vec::with_capacity(chunk.len());
        for (i, r) in chunk.iter().enumerate() {
            let t = |c: i128| to_f64(c) / to_f64(turn);
            let want = crate::polar::reference(t(r[0]), t(r[1]), t(r[2]), t(r[3]));
            exact_l.push(want);
            let got = DVec3::new(
                fo.to_f64(out[0][i]),
                fo.to_f64(out[1][i]),
                fo.to_f64(out[2][i]),
            );
            for c in 0..3 {
                let e = (got[c] - want[c]) / fo.ulp();
                st.max_lsb_err = st.max_lsb_err.max(e.abs());
                sum2 += e * e;
            }
            st.max_len_dev = st.max_len_dev.max((got.length() - 1.0).abs());
            st.max_angle_err_deg = st.max_angle_err_deg.max(angle_deg(got, want));
            for c in 0..3 {
                lcols[c].push(light.normal.apply_f64(normals[i][c])?.code);
                lcols[3 + c].push(light.light.apply(out[c][i], fo.frac()).code);
            }
        }
        let (lv, lov) = lprog.run_i128(&[
            &lcols[0], &lcols[1], &lcols[2], &lcols[3], &lcols[4], &lcols[5],
        ]);
        st.overflows += lov.iter().map(|(_, n)| n).sum::<u64>();
        for (i, l) in exact_l.iter().enumerate() {
            let want = LEVELS * light.i0_km * normals[i].dot(*l).max(0.0);
            st.max_diffuse_err_levels = st
                .max_diffuse_err_levels
                .max((fl.to_f64(lv[0][i]) - want).abs());
        }
    }
    st.samples = total as u64;
    st.rms_lsb_err = (sum2 / (3.0 * to_f64(total.max(1)))).sqrt();
    Ok(st)
}

/// The exact frames `(T, B, N)` of every `α_N`, one column per vector
/// component, for [`compare_row`]'s loop over `α_N`.
struct FrameColumns {
    /// `T.x, T.y, T.z, B.x, …, N.z`, each indexed by `α_N`.
    c: [Vec<f64>; 9],
}

impl FrameColumns {
    fn of(frames: &[(DVec3, DVec3, DVec3)]) -> Self {
        FrameColumns {
            c: std::array::from_fn(|k| {
                frames
                    .iter()
                    .map(|(t, b, n)| [t, b, n][k / 3][k % 3])
                    .collect()
            }),
        }
    }
}

/// Running extremes of [`polar_every_code`], one per `α_N` (reduced once
/// per `α_L` row: element-wise updates vectorize, reductions would not).
struct Extremes {
    /// Largest component error.
    e: Vec<f64>,
    /// Smallest `|L'|²`.
    g2min: Vec<f64>,
    /// Largest `|L'|²`.
    g2max: Vec<f64>,
    /// Largest sin² of the angle between `L'` and `L`.
    sin2: Vec<f64>,
    /// Largest `|L' − L|²`.
    e2: Vec<f64>,
}

impl Extremes {
    fn new(n: usize) -> Self {
        Extremes {
            e: vec![0.0; n],
            g2min: vec![f64::INFINITY; n],
            g2max: vec![0.0; n],
            sin2: vec![0.0; n],
            e2: vec![0.0; n],
        }
    }
}

/// One `(α_L, Δβ)` row of [`polar_every_code`] against every `α_N`: the
/// exact `L` (`l`) in each exact frame `f`, `L' = got·ulp`, and per lane
/// `j` `|L' − L|²` into `e2s[j]` and the extremes of `ext` updated. The
/// same operations in the same order as `DVec3`'s `dot`, `cross` and
/// `length_squared` (so the same values), written lane-wise so that the
/// loop vectorizes ([`crate::datapath::Isa::run`]).
struct CompareRow<'a> {
    l: DVec3,
    ulp: f64,
    f: &'a FrameColumns,
    got: [&'a [i64]; 3],
    ext: &'a mut Extremes,
    e2s: &'a mut [f64],
}

impl crate::datapath::Kernel for CompareRow<'_> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        let CompareRow {
            l,
            ulp,
            f,
            got,
            ext,
            e2s,
        } = self;
        compare_row(l, ulp, f, got, ext, e2s);
    }
}

#[inline(always)]
fn compare_row(
    l: DVec3,
    ulp: f64,
    f: &FrameColumns,
    got: [&[i64]; 3],
    ext: &mut Extremes,
    e2s: &mut [f64],
) {
    let n = e2s.len();
    let [tx, ty, tz, bx, by, bz, nx, ny, nz] = std::array::from_fn(|k| &f.c[k][..n]);
    let (ox, oy, oz) = (&got[0][..n], &got[1][..n], &got[2][..n]);
    let (em, g2lo, g2hi) = (&mut ext.e[..n], &mut ext.g2min[..n], &mut ext.g2max[..n]);
    let (s2m, e2m) = (&mut ext.sin2[..n], &mut ext.e2[..n]);
    for j in 0..n {
        let wx = (l.x * tx[j]) + (l.y * ty[j]) + (l.z * tz[j]);
        let wy = (l.x * bx[j]) + (l.y * by[j]) + (l.z * bz[j]);
        let wz = (l.x * nx[j]) + (l.y * ny[j]) + (l.z * nz[j]);
        let gx = to_f64(ox[j]) * ulp;
        let gy = to_f64(oy[j]) * ulp;
        let gz = to_f64(oz[j]) * ulp;
        let (ex, ey, ez) = (gx - wx, gy - wy, gz - wz);
        let e2 = (ex * ex) + (ey * ey) + (ez * ez);
        e2s[j] = e2;
        em[j] = em[j].max(ex.abs().max(ey.abs().max(ez.abs())));
        let g2 = (gx * gx) + (gy * gy) + (gz * gz);
        g2lo[j] = g2lo[j].min(g2);
        g2hi[j] = g2hi[j].max(g2);
        let w2 = (wx * wx) + (wy * wy) + (wz * wz);
        let cx = gy * wz - wy * gz;
        let cy = gz * wx - wz * gx;
        let cz = gx * wy - wx * gy;
        // sin² of the angle between them (its maximum gives the largest
        // angle, for angles below 90°); none for a zero vector.
        let s2 = ((cx * cx) + (cy * cy) + (cz * cz)) / (g2 * w2);
        s2m[j] = s2m[j].max(if g2 > 0.0 && w2 > 0.0 { s2 } else { 0.0 });
        e2m[j] = e2m[j].max(e2);
    }
}

/// [`PolarStats`] of [`polar_every_code`], as the cache keeps it.
#[derive(serde::Serialize, serde::Deserialize)]
struct PolarExhaustive {
    samples: u64,
    max_lsb_err: f64,
    rms_lsb_err: f64,
    max_len_dev: f64,
    max_angle_err_deg: f64,
    max_diffuse_err_levels: f64,
    overflows: u64,
    max_vector_err: f64,
}

impl From<PolarStats> for PolarExhaustive {
    fn from(s: PolarStats) -> Self {
        PolarExhaustive {
            samples: s.samples,
            max_lsb_err: s.max_lsb_err,
            rms_lsb_err: s.rms_lsb_err,
            max_len_dev: s.max_len_dev,
            max_angle_err_deg: s.max_angle_err_deg,
            max_diffuse_err_levels: s.max_diffuse_err_levels,
            overflows: s.overflows,
            max_vector_err: s.max_vector_err,
        }
    }
}

impl From<PolarExhaustive> for PolarStats {
    fn from(s: PolarExhaustive) -> Self {
        PolarStats {
            samples: s.samples,
            coverage: "every code (exhaustive)",
            max_lsb_err: s.max_lsb_err,
            rms_lsb_err: s.rms_lsb_err,
            max_len_dev: s.max_len_dev,
            max_angle_err_deg: s.max_angle_err_deg,
            max_diffuse_err_levels: s.max_diffuse_err_levels,
            overflows: s.overflows,
            max_vector_err: s.max_vector_err,
            diffuse_is_bound: true,
        }
    }
}

/// [`polar_stats`] over every code triple `(α_L, β_L − β_N, α_N)` (`α` in
/// `[−¼, ¼]` turn, `β_N = 0`), on every core: the largest component error
/// in output LSBs, the RMS, `| |L'| − 1 |` and the angle are exact maxima
/// over every input the transform can get. The diffuse error, which
/// depends on a continuous tangent-space normal too, is a proven bound
/// from the exhaustive vector error: `e_level + G_q·(e_dot +
/// √3·e_n·(1 + v) + v + √3·e_c) + |G_q − G|`, `v = max |L' − L|`, `e_n` the
/// normal's quantization into `lighting.normal`, `e_c` the conversion of
/// `L'` into `lighting.light`.
///
/// The transform runs as its two parts ([`crate::polar::Polar::terms_trace`],
/// [`crate::polar::Polar::tilt_trace`]): the terms of each `(α_L, Δβ)` and
/// of each `α_N` once, the tilt on every triple; the codes and overflow
/// counts are the whole transform's (a quantization of the first part
/// counts once per `α_N`).
///
/// # Errors
///
/// [`AnalysisError::Compile`] when either part cannot be compiled.
///
/// # Panics
///
/// Never: a worker only runs the compiled parts (four inputs, five and two outputs) on
/// columns of one length and reads their outputs, and every row is run.
pub fn polar_every_code(
    p: &crate::polar::Polar,
    light: &Lighting,
) -> Result<PolarStats, AnalysisError> {
    let f = p.angle.format();
    let k = f.width();
    let turn = 1i128 << k;
    let quarter = turn / 4;
    // The transform as its two parts (`Polar::terms_trace`, then
    // `Polar::tilt_trace`): the terms of each (α_L, Δβ) and of each α_N are
    // computed once, and only the tilt runs on every triple. The codes and
    // the overflow counts are those of the whole transform: every value
    // passed between the parts is a quantized code.
    let front = crate::datapath::Trace::compile_outputs(&p.terms_trace())?;
    let tilt = crate::datapath::Trace::compile_outputs(&p.tilt_trace())?;
    let fo = p.out.format();
    let ulp = fo.ulp();
    let t = |c: i128| to_f64(c) / to_f64(turn);
    // The exact frames of every α_N (β_N = 0), and the exact L of every
    // (α_L, Δβ) row, from the one reference (polar::vector_of, frame).
    let frames: Vec<(DVec3, DVec3, DVec3)> = (-quarter..=quarter)
        .map(|an| crate::polar::frame(crate::polar::vector_of(t(an), 0.0), 0.0))
        .collect();
    let elevs = frames.len();
    let cols = FrameColumns::of(&frames);
    let isa = crate::datapath::Isa::current();
    let rows = (-quarter..=quarter).collect::<Vec<i128>>();
    // One α_L at a time: (max LSB, sum of squares, min and max |L'|², max
    // sin² of the angle, max |L' − L|², overflows). Squares, not lengths:
    // the square roots are taken once, of the extremes.
    type Acc = (f64, f64, f64, f64, f64, f64, u64);
    // Δβ rows run BLOCK at a time (one batch of BLOCK·elevs lanes), on i64
    // codes where the program is narrow.
    const BLOCK: i64 = 64;
    let turn64 = narrow::<i64, _>(turn);
    let a_n1: Vec<i64> = (-quarter..=quarter)
        .map(|c| narrow::<i64, _>(c.rem_euclid(turn)))
        .collect();
    // Runs `prog` with its outputs into `out` (its vectors reused from
    // block to block); returns the overflows but of the index stage.
    let run = |prog: &Compiled, cols: &[&[i64]], out: &mut Vec<Vec<i64>>, n_out: usize| -> u64 {
        let ov_of = |ov: Vec<(&'static str, u64)>| {
            ov.iter()
                .filter(|(s, _)| *s != "index")
                .map(|(_, n)| n)
                .sum::<u64>()
        };
        match prog {
            Compiled::Narrow(p) => {
                out.resize_with(n_out, Vec::new);
                ov_of(p.run_into(cols, out))
            }
            Compiled::Wide(p) => {
                let c: Vec<Vec<i128>> = cols
                    .iter()
                    .map(|c| c.iter().map(|&x| i128::from(x)).collect())
                    .collect();
                let r: Vec<&[i128]> = c.iter().map(|v| v.as_slice()).collect();
                let (o, ov) = p.run(&r);
                *out = o
                    .into_iter()
                    .map(|v| v.into_iter().map(|x| narrow::<i64, _>(x)).collect())
                    .collect();
                ov_of(ov)
            }
        }
    };
    // The reads of every α_N, repeated for a block. (The run's other
    // quantizations, of α_L = Δβ = 0, are counted with the rows.)
    let zeros = vec![0i64; narrow::<usize, _>(turn64).max(elevs)];
    let full = narrow::<usize, _>(BLOCK) * elevs;
    let (c_an, s_an) = {
        let mut o = Vec::new();
        run(
            &front,
            &[&zeros[..elevs], &zeros[..elevs], &a_n1, &zeros[..elevs]],
            &mut o,
            5,
        );
        let rep = |v: &[i64]| -> Vec<i64> { (0..BLOCK).flat_map(|_| v.iter().copied()).collect() };
        (rep(&o[3]), rep(&o[4]))
    };
    let deltas: Vec<i64> = (0..turn64).collect();
    let one_row = |al: i128| -> Acc {
        let mut acc: Acc = (0.0, 0.0, f64::INFINITY, 0.0, 0.0, 0.0, 0);
        let n_d = deltas.len();
        // The terms of every Δβ of this α_L; their quantizations happen
        // once per (α_L, Δβ), so once per α_N in the whole transform.
        let a_l = vec![narrow::<i64, _>(al.rem_euclid(turn)); n_d];
        let mut terms = Vec::new();
        let ov = run(
            &front,
            &[&a_l, &deltas, &zeros[..n_d], &zeros[..n_d]],
            &mut terms,
            5,
        );
        acc.6 += ov * (elevs as u64);
        // The columns of a whole block, built once per row (sin α_L and
        // the α_N reads do not change from block to block; lyz and x are
        // rewritten).
        let s_al = vec![terms[0][0]; full];
        let mut lyz = vec![0i64; full];
        let mut x = vec![0i64; full];
        let mut out = Vec::new();
        let mut ext = Extremes::new(elevs);
        let mut e2s = vec![0.0; elevs];
        let mut d0 = 0i64;
        while d0 < turn64 {
            let ds: Vec<i64> = (d0..(d0 + BLOCK).min(turn64)).collect();
            d0 += BLOCK;
            let lanes = ds.len() * elevs;
            for ((lc, xc), &d) in lyz.chunks_mut(elevs).zip(x.chunks_mut(elevs)).zip(&ds) {
                let d = narrow::<usize, _>(d);
                lc.fill(terms[1][d]);
                xc.fill(terms[2][d]);
            }
            let ov = run(
                &tilt,
                &[
                    &s_al[..lanes],
                    &lyz[..lanes],
                    &c_an[..lanes],
                    &s_an[..lanes],
                ],
                &mut out,
                2,
            );
            acc.6 += ov;
            for (r, &d) in ds.iter().enumerate() {
                let l = crate::polar::vector_of(t(al), t(i128::from(d)));
                let lane = r * elevs..(r + 1) * elevs;
                let got = [&x[lane.clone()], &out[0][lane.clone()], &out[1][lane]];
                isa.run(CompareRow {
                    l,
                    ulp,
                    f: &cols,
                    got,
                    ext: &mut ext,
                    e2s: &mut e2s,
                });
                // Summed in lane order, one lane after another (the
                // extremes do not depend on the order; a sum does).
                for &e2 in &e2s {
                    acc.1 += e2;
                }
            }
        }
        acc.0 = ext.e.iter().fold(acc.0, |m, &x| m.max(x));
        acc.2 = ext.g2min.iter().fold(acc.2, |m, &x| m.min(x));
        acc.3 = ext.g2max.iter().fold(acc.3, |m, &x| m.max(x));
        acc.4 = ext.sin2.iter().fold(acc.4, |m, &x| m.max(x));
        acc.5 = ext.e2.iter().fold(acc.5, |m, &x| m.max(x));
        acc
    };
    let results = crate::parallel::map_in_order(&rows, |_, &al| one_row(al));
    // Combined in row order, so the sums do not depend on the threads.
    let mut st = PolarStats {
        coverage: "every code (exhaustive)",
        samples: (rows.len() * narrow::<usize, _>(turn) * elevs) as u64,
        ..Default::default()
    };
    let (mut sum2, mut sin2, mut e2max) = (0.0, 0.0f64, 0.0f64);
    let (mut g2min, mut g2max) = (f64::INFINITY, 0.0f64);
    for a in results {
        st.max_lsb_err = st.max_lsb_err.max(a.0 / ulp);
        sum2 += a.1;
        g2min = g2min.min(a.2);
        g2max = g2max.max(a.3);
        sin2 = sin2.max(a.4);
        e2max = e2max.max(a.5);
        st.overflows += a.6;
    }
    let vec_err = e2max.sqrt();
    st.max_len_dev = (g2max.sqrt() - 1.0).max(1.0 - g2min.sqrt());
    st.rms_lsb_err = (sum2 / (3.0 * to_f64(st.samples))).sqrt() / ulp;
    st.max_angle_err_deg = sin2.sqrt().min(1.0).asin().to_degrees();
    st.max_vector_err = vec_err;
    let s3 = 3f64.sqrt();
    let b = |q: &Quant| crate::bounds::rounding_error(q);
    let e_c = if light.light.format().frac() < fo.frac() {
        b(&light.light)
    } else {
        0.0
    };
    let g_exact = LEVELS * light.i0_km;
    let g_q = light
        .gain
        .apply_f64(g_exact)
        .map_or(g_exact, |r| light.gain.format().to_f64(r.code));
    st.max_diffuse_err_levels = b(&light.level)
        + g_q * (b(&light.dot) + s3 * b(&light.normal) * (1.0 + vec_err) + vec_err + s3 * e_c)
        + (g_q - g_exact).abs();
    st.diffuse_is_bound = true;
    Ok(st)
}

/// A deterministic analysis `f` remembered in the user's cache
/// ([`crate::cache`], `analyses/`) under a key of `parts`, the hash of
/// the running executable ([`crate::cache::program_fingerprint`]: any
/// rebuild recomputes), the source of the analyses and fxshade's version: the
/// exhaustive runs take a minute and the report asks for them every time.
/// A cache that cannot be written only costs the next run its time; one
/// someone else could write is an error.
fn remembered<T: serde::Serialize + serde::de::DeserializeOwned>(
    what: &str,
    parts: &[&[u8]],
    f: impl FnOnce() -> Result<T, AnalysisError>,
) -> Result<T, AnalysisError> {
    let Some(program) = crate::cache::program_fingerprint() else {
        return f();
    };
    let mut all: Vec<&[u8]> = vec![
        program.as_bytes(),
        crate::vectors::GENERATOR.as_bytes(),
        include_str!("analysis.rs").as_bytes(),
        fxshade_units::sources::ANGLES.as_bytes(),
        fxshade_units::sources::POLAR.as_bytes(),
        fxshade_units::sources::LIGHTING.as_bytes(),
        fxshade_ir::sources::BATCH.as_bytes(),
        fxshade_numbers::QUANTIZE_SOURCE.as_bytes(),
        what.as_bytes(),
    ];
    all.extend_from_slice(parts);
    let key = crate::cache::sha256_key(&all);
    let dir = match crate::cache::subdir("analyses") {
        Ok(d) => d,
        // No cache installed (a library caller): compute.
        Err(crate::cache::CacheError::NotInstalled) => return f(),
        Err(e) => return Err(AnalysisError::Cache(e.to_string())),
    };
    let path = dir.join(format!("{what}-{}.json", &key[..32]));
    if let Some(bytes) =
        crate::cache::read(&path).map_err(|e| AnalysisError::Cache(e.to_string()))?
    {
        if let Ok(v) = serde_json::from_slice::<T>(&bytes) {
            return Ok(v);
        }
    }
    // Another fxshade computing the same entry (parallel tests, a sweep's
    // workers): wait for it rather than compute twice. The lock is advisory
    // and only saves time; without it everything still comes out right.
    let lock = {
        use std::os::unix::fs::OpenOptionsExt;
        std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .mode(0o600)
            .open(path.with_extension("lock"))
            .ok()
            .filter(|l| {
                use std::os::fd::AsRawFd;
                // SAFETY: flock on a descriptor this function owns; the lock
                // is released when the file is closed.
                unsafe { libc::flock(l.as_raw_fd(), libc::LOCK_EX) == 0 }
            })
    };
    if lock.is_some() {
        if let Ok(Some(bytes)) = crate::cache::read(&path) {
            if let Ok(v) = serde_json::from_slice::<T>(&bytes) {
                return Ok(v);
            }
        }
    }
    let v = f()?;
    let bytes = serde_json::to_vec(&v).expect("serializable");
    match crate::cache::write(&path, &bytes) {
        Ok(())
        | Err(crate::cache::CacheError::Full { .. } | crate::cache::CacheError::Io { .. }) => Ok(v),
        Err(e) => Err(AnalysisError::Cache(e.to_string())),
    }
}

/// The polar report for a configuration: every code triple where there
/// are at most `exhaustive_up_to` of them ([`polar_every_code`]), else
/// `count` random samples (or the α_N subsets of [`polar_stats`]).
///
/// # Errors
///
/// [`AnalysisError::Polar`] when the polar configuration is unusable; then as
/// [`polar_stats`].
pub fn polar(
    cfg: &Config,
    count: usize,
    seed: u64,
    exhaustive_up_to: u64,
) -> Result<PolarReport, AnalysisError> {
    let p = crate::polar::Polar::from_config(cfg).map_err(AnalysisError::Polar)?;
    let light = Lighting::from_config(cfg);
    let stats = polar_stats(&p, &light, count, seed, exhaustive_up_to)?;
    Ok(PolarReport {
        angle_bits: p.angle.format().width(),
        table_bits: p.index.format().width(),
        table_format: p.tables.sin.out.format().to_string(),
        organisation: p.tables.organisation,
        table_size_bits: p.tables.stored_bits(),
        stats,
        seed,
    })
}

/// Random samples an analysis draws and measures at a time: memory stays
/// flat whatever the count.
pub const SAMPLE_CHUNK: usize = 1 << 16;

/// The most random samples an analysis takes (`--count`, `explore
/// --samples`): 2^32, hours of work; more is refused before any work.
pub const MAX_SAMPLES: usize = 1 << 32;

/// Refuse a sample count above [`MAX_SAMPLES`], naming `flag`.
///
/// # Errors
///
/// A message naming `flag` when `count` exceeds [`MAX_SAMPLES`].
pub fn check_samples(flag: &str, count: usize) -> Result<(), String> {
    if count > MAX_SAMPLES {
        return Err(format!(
            "{flag} {count}: at most {MAX_SAMPLES} (2^32) random samples; the figures of \
             every analysis are stable long before that"
        ));
    }
    Ok(())
}

/// Inputs shorter than this are reported apart by [`angles`]: quadratic
/// interpolation at Θ = 0 never makes a normal shorter than √0.803 ≈ 0.9.
pub const SHORTEST_NORMAL: f64 = 0.25;

/// The CORDIC angle unit's error figures over a set of input normals.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct AnglesStats {
    /// Normals evaluated.
    pub samples: u64,
    /// `all codes` or `random and corners`.
    pub coverage: &'static str,
    /// Largest `|α − asin(y/|N|)|`, output LSBs (over inputs at least
    /// [`SHORTEST_NORMAL`] long, as every figure but the last three).
    pub max_alpha_lsb: f64,
    /// Largest `|β − atan2(x, z)|` (wrapped), output LSBs, over normals
    /// outside the polar cap (more than [`crate::render::POLAR_CAP_DEG`]
    /// from the y axis).
    pub max_beta_lsb: f64,
    /// Largest β error inside the cap (the zero vector and exact poles
    /// excluded: β is undefined there).
    pub max_beta_lsb_cap: f64,
    /// RMS of the α and β errors (outside the cap), LSBs.
    pub rms_lsb: f64,
    /// Largest α error in degrees.
    pub max_alpha_deg: f64,
    /// Largest β error outside the cap, degrees.
    pub max_beta_deg: f64,
    /// Largest angle between the direction `(α, β)` names and the exact
    /// normal, degrees: the error the polar transform sees (β's error
    /// shrinks by `cos α` towards the poles). Over the inputs of the other
    /// figures (at least [`SHORTEST_NORMAL`] long, no overflow), the polar
    /// cap included.
    pub max_direction_deg: f64,
    /// Non-zero inputs shorter than [`SHORTEST_NORMAL`] (extreme and
    /// near-zero codes, not normals any interpolation produces), left out
    /// of the figures above.
    pub short_inputs: u64,
    /// Their largest α or β error (β outside the cap), LSBs.
    pub max_short_lsb: f64,
    /// Normals whose coordinates overflowed `xy` (left out of the error
    /// figures: their angles are not defined by the arithmetic). The
    /// accumulator and the outputs wrap by design and are not counted.
    pub overflows: u64,
}

/// The lengths of the normals the angle analyses cover: from the shortest
/// to the longest normal quadratic interpolation produces at Θ = 0,
/// `[√d_min, √d_max]`.
pub fn angles_length_range() -> (f64, f64) {
    let (dlo, dhi) = crate::interp::quadratic_d_range(0.0, crate::interp::Scheme::Quadratic);
    (dlo.sqrt(), dhi.sqrt())
}

/// β over every input code: [`angles_beta_every_code`].
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct BetaExhaustive {
    /// `(x, z)` code pairs run, `x ≥ 0` (a pair `(−x, −z)` gives the same
    /// core input and an angle half a turn away, exactly: the same error).
    pub pairs: u64,
    /// `(x, z)` code pairs of the whole domain this covers: the pairs run,
    /// those with `x > 0` twice (their mirrors lie in the format: the
    /// domain is far from its most negative code).
    pub covered: u64,
    /// The range of `√(x² + z²)` covered: every pair whose normal can be
    /// more than the cap from the y axis with a length in `[lo, hi]`.
    pub r_range: (f64, f64),
    /// Largest `|β − atan2(x, z)|` (wrapped), output LSBs: an exhaustive
    /// maximum.
    pub max_beta_lsb: f64,
    /// In degrees.
    pub max_beta_deg: f64,
    /// Where: the `(x, z)` codes.
    pub worst: (i64, i64),
    /// Pairs whose coordinates overflowed `xy` (left out).
    pub overflows: u64,
}

/// β of the CORDIC angles unit over every `(x, z)` input code pair whose
/// normal can lie more than [`crate::render::POLAR_CAP_DEG`] from the y
/// axis with a length in `[lo, hi]` (`√(x² + z²) ∈ [sin(cap)·lo', hi']`,
/// `lo'`, `hi'` widened by the input rounding: a superset), on every core.
/// β depends on `x` and `z` alone, so this is its exhaustive maximum over
/// every such normal; `x < 0` needs no run of its own (see
/// [`BetaExhaustive::pairs`]).
///
/// # Errors
///
/// [`AnalysisError::Angles`] when the angles configuration is unusable or its trace cannot
/// be built; [`AnalysisError::Cache`] when the cache directory cannot be used or the entry
/// cannot be read safely; [`AnalysisError::Compile`] when the `beta` output cannot be
/// compiled.
pub fn angles_beta_every_code(
    cfg: &Config,
    lo: f64,
    hi: f64,
) -> Result<BetaExhaustive, AnalysisError> {
    let a = crate::angles::Angles::of(cfg).map_err(AnalysisError::Angles)?;
    // Remembered: β is fixed by the unit's stages and the range.
    let key = format!("{a:?} {lo:?} {hi:?}");
    remembered("angles-beta-every-code", &[key.as_bytes()], || {
        beta_every_code(&a, lo, hi, true).map(|(b, _)| b)
    })
}

/// [`angles_beta_every_code`] uncached, and how many pairs' exact angles
/// it took: with `screen`, only where [`atan2_screen`] cannot rule out a
/// new maximum; without, every pair's.
fn beta_every_code(
    a: &crate::angles::Angles,
    lo: f64,
    hi: f64,
    screen: bool,
) -> Result<(BetaExhaustive, u64), AnalysisError> {
    let tr = a.trace().map_err(|e| AnalysisError::Angles(e.into()))?;
    let beta = tr
        .output_ports()
        .iter()
        .find(|p| p.name == "beta")
        .expect("the unit's beta port")
        .value;
    let prog = crate::datapath::Compiled::compile(&tr, &[beta])?;
    let f = a.normal.format();
    let (ulp, k) = (f.ulp(), a.out.format().width());
    let turn = to_f64(1u64 << k);
    let e_in = crate::bounds::rounding_error(&a.normal);
    let cap = crate::render::POLAR_CAP_DEG.to_radians().sin();
    let r_lo = (cap * (lo - 3f64.sqrt() * e_in)).max(0.0);
    let r_hi = hi + 3f64.sqrt() * e_in;
    let xy_stage = format!("{}.{}", crate::angles::DECL.name, a.xy.stage());
    let nf = prog.flag_stages().len();
    let xy_flag = prog
        .flag_stages()
        .iter()
        .position(|s| *s == xy_stage)
        .map_or(0, |k| 1u64 << (nf - 1 - k));
    let (c_lo, c_hi) = (r_lo / ulp, r_hi / ulp);
    let x_max = (from_f64::<i128>(c_hi.floor())).min(f.max_code());
    // Codes as i64 (a normal's code and its square fit; the conversions to
    // f64 give the same values as from i128, without the software
    // conversion), run on the narrow program where there is one.
    let (min_code, max_code) = (
        narrow::<i64, _>(f.min_code()),
        narrow::<i64, _>(f.max_code()),
    );
    let run = |cols: [&[i64]; 3]| -> (Vec<i64>, Vec<u64>) {
        match &prog {
            Compiled::Narrow(p) => {
                let (mut out, flags) = p.run_flags(&cols);
                (out.swap_remove(0), flags)
            }
            Compiled::Wide(p) => {
                let c: Vec<Vec<i128>> = cols
                    .iter()
                    .map(|c| c.iter().map(|&x| i128::from(x)).collect())
                    .collect();
                let (out, flags) = p.run_flags(&[&c[0], &c[1], &c[2]]);
                (out[0].iter().map(|&x| narrow::<i64, _>(x)).collect(), flags)
            }
        }
    };
    // (max error, worst x, worst z, pairs, overflows, covered, exact
    // angles taken) of one x.
    type Acc = (f64, i64, i64, u64, u64, u64, u64);
    let isa = crate::datapath::Isa::current();
    // How far a screened error can lie below the exact one, in output
    // LSBs: the screen's angle error over a turn, and a part in 10^12 of
    // the turn for the roundings of either computation (each well below).
    let margin = if screen {
        turn * (ATAN2_SCREEN_ERROR / std::f64::consts::TAU + 1e-12)
    } else {
        f64::INFINITY
    };
    let one_x = |x: i128| -> Acc {
        let mut acc: Acc = (0.0, 0, 0, 0, 0, 0, 0);
        let x = narrow::<i64, _>(x);
        let xf = to_f64(x);
        let zmax = from_f64::<i64>((c_hi * c_hi - xf * xf).max(0.0).sqrt().floor());
        let zmin = from_f64::<i64>((c_lo * c_lo - xf * xf).max(0.0).sqrt().ceil());
        let keep = |z: i64| {
            let r2 = xf * xf + to_f64(z * z);
            (min_code..=max_code).contains(&z) && r2 >= c_lo * c_lo && r2 <= c_hi * c_hi
        };
        // The codes of each half that `keep` holds for are one run (its
        // radius test is monotonic in |z|, exactly: integers below 2^53;
        // the code range is one run): found from the ends.
        let run_of = |a: i64, b: i64| {
            let (mut a, mut b) = (a, b);
            while a <= b && !keep(a) {
                a += 1;
            }
            while a <= b && !keep(b) {
                b -= 1;
            }
            a..=b
        };
        let zs: Vec<i64> = run_of(-zmax, -zmin).chain(run_of(zmin, zmax)).collect();
        // (zmin = 0 puts z = 0 in both halves: once only.)
        let zs: Vec<i64> = {
            let mut v = zs;
            v.dedup();
            v
        };
        let xs = vec![x; zs.len().min(1 << 15)];
        let ys = vec![0i64; xs.len()];
        let mut screened = Vec::new();
        for chunk in zs.chunks(1 << 15) {
            let n = chunk.len();
            let (out, flags) = run([&xs[..n], &ys[..n], chunk]);
            // Each pair's error first from `atan2_screen` (vectorized), the
            // exact one only where that cannot rule out a new maximum: the
            // same maximum and the same first pair attaining it.
            screened.resize(n, 0.0);
            isa.run(BetaScreen {
                x: xf,
                zs: chunk,
                got: &out,
                turn,
                e: &mut screened,
            });
            for (i, &z) in chunk.iter().enumerate() {
                if flags[i] & xy_flag != 0 {
                    acc.4 += 1;
                    continue;
                }
                acc.3 += 1;
                acc.5 += if x == 0 { 1 } else { 2 };
                if screened[i] + margin <= acc.0 {
                    continue;
                }
                acc.6 += 1;
                let exact = xf.atan2(to_f64(z)) / std::f64::consts::TAU;
                let got = to_f64(out[i]) / turn;
                let e = ((got - exact + 0.5).rem_euclid(1.0) - 0.5).abs() * turn;
                if e > acc.0 {
                    (acc.0, acc.1, acc.2) = (e, x, z);
                }
            }
        }
        acc
    };
    let xs: Vec<i128> = (0..=x_max).collect();
    let rows = crate::parallel::map_in_order(&xs, |_, &x| one_x(x));
    let mut b = BetaExhaustive {
        r_range: (r_lo, r_hi),
        ..Default::default()
    };
    let mut exact = 0u64;
    for a in rows {
        if a.0 > b.max_beta_lsb {
            b.max_beta_lsb = a.0;
            b.worst = (a.1, a.2);
        }
        b.pairs += a.3;
        b.overflows += a.4;
        b.covered += a.5;
        exact += a.6;
    }
    b.max_beta_deg = b.max_beta_lsb * 360.0 / turn;
    Ok((b, exact))
}

/// A bound on `|atan2_screen(x, z) − atan2(x, z)|`, radians.
///
/// The series `atan u = u − u³/3 + u⁵/5 − …` alternates with terms
/// decreasing in magnitude for `|u| ≤ tan(π/8) < 0.41422`, so stopping
/// after `u²¹/21` errs by at most the next term, `0.41422²³/23 < 7·10⁻¹¹`;
/// the f64 roundings of the reduction and of the eleven-term sum add a few
/// times 10⁻¹⁶. Taken as 10⁻⁹.
pub const ATAN2_SCREEN_ERROR: f64 = 1e-9;

/// `atan2(x, z)` for `x ≥ 0` within [`ATAN2_SCREEN_ERROR`], written so that
/// it vectorizes (no call, no branch): `t = min/max` of `x` and `|z|`,
/// reduced to `|u| ≤ tan(π/8)` by `atan t = π/4 + atan((t − 1)/(t + 1))`,
/// the series to `u²¹`, then reflected to the octant. At `x = z = 0` it
/// gives NaN (where `atan2` gives 0), which never screens a pair out.
#[inline(always)]
pub fn atan2_screen(x: f64, z: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let b = z.abs();
    let (lo, hi) = if x > b { (b, x) } else { (x, b) };
    let t = lo / hi;
    let big = t > 0.414_213_562_373_095_1;
    let u = if big { (t - 1.0) / (t + 1.0) } else { t };
    let u2 = u * u;
    // Σ (−1)^k u^(2k) / (2k + 1), k = 0..=10, by Horner's rule in u².
    let mut p = 1.0 / 21.0;
    for k in (0..10u32).rev() {
        let c = 1.0 / f64::from(2 * k + 1);
        p = if k % 2 == 0 { c } else { -c } + u2 * p;
    }
    let r = u * p + if big { FRAC_PI_4 } else { 0.0 };
    let r = if x > b { FRAC_PI_2 - r } else { r };
    if z < 0.0 {
        PI - r
    } else {
        r
    }
}

/// One chunk of [`angles_beta_every_code`]'s pairs `(x, z)`, `z` in `zs`,
/// `got` the β codes: each pair's error in output LSBs with
/// [`atan2_screen`] for the exact angle, into `e`.
struct BetaScreen<'a> {
    x: f64,
    zs: &'a [i64],
    got: &'a [i64],
    turn: f64,
    e: &'a mut [f64],
}

impl crate::datapath::Kernel for BetaScreen<'_> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        let n = self.e.len();
        let (zs, got) = (&self.zs[..n], &self.got[..n]);
        for j in 0..n {
            let exact = atan2_screen(self.x, to_f64(zs[j])) / std::f64::consts::TAU;
            let d = to_f64(got[j]) / self.turn - exact;
            self.e[j] = (d - fxshade_numbers::convert::round_half_away(d)).abs() * self.turn;
        }
    }
}

/// The CORDIC angle unit's error report for one configuration.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AnglesReport {
    /// Micro-rotations per angle.
    pub iterations: u32,
    /// Coordinate format.
    pub xy: String,
    /// Accumulator format.
    pub theta: String,
    /// Output format.
    pub out: String,
    /// Output angle bits.
    pub angle_bits: u32,
    /// Bits of the generated RTL's adders and add/subtracters (its hardware
    /// summary; each add/subtracter once).
    pub adder_bits: u64,
    /// Flip-flops of the generated RTL.
    pub flops: u64,
    /// Latency of the generated RTL, cycles.
    pub latency: u32,
    /// The error figures.
    #[serde(flatten)]
    pub stats: AnglesStats,
    /// Seed of the random part.
    pub seed: u64,
}

/// Input normals for the angle analysis, in the `normal` format's codes:
/// every code when `3·width ≤ 21`, else corner cases (axes, poles, the
/// zero vector, the β seam either side, octant boundaries, a few LSBs
/// around the poles, the extreme codes) and `count` random directions with
/// lengths from the shortest to the longest normal quadratic interpolation
/// produces at Θ = 0 (`[√d_min, √d_max]`). Drawn a chunk at a time
/// ([`AnglesInputs::next_chunk`]), so memory does not grow with the count.
pub struct AnglesInputs {
    fixed: Vec<[i128; 3]>,
    fixed_done: bool,
    random: usize,
    drawn: usize,
    rng: Rng,
    normal: Quant,
    lo: f64,
    hi: f64,
    /// What the inputs cover: `all codes`, `random and corners` or `none`.
    pub coverage: &'static str,
}

impl AnglesInputs {
    /// The inputs of the analysis of `cfg`.
    ///
    /// # Panics
    ///
    /// Never: the stand-in format `I2F0` is valid.
    pub fn new(cfg: &Config, count: usize, seed: u64) -> AnglesInputs {
        let (dlo, dhi) = crate::interp::quadratic_d_range(0.0, crate::interp::Scheme::Quadratic);
        let mut me = AnglesInputs {
            fixed: Vec::new(),
            fixed_done: false,
            random: 0,
            drawn: 0,
            rng: Rng::new(seed),
            normal: Quant::new(
                "normal",
                crate::format::Format::new(true, 2, 0).expect("valid"),
                Rounding::Trunc,
                crate::quantize::Overflow::Saturate,
            ),
            lo: dlo.sqrt(),
            hi: dhi.sqrt(),
            coverage: "none",
        };
        let Ok(a) = crate::angles::Angles::of(cfg) else {
            return me;
        };
        me.normal = a.normal;
        let f = a.normal.format();
        if 3 * f.width() <= 21 {
            for x in f.min_code()..=f.max_code() {
                for y in f.min_code()..=f.max_code() {
                    for z in f.min_code()..=f.max_code() {
                        me.fixed.push([x, y, z]);
                    }
                }
            }
            me.coverage = "all codes";
            return me;
        }
        // The unit's own corner cases, in the configured input format.
        me.fixed = crate::angles::rtl::inputs(cfg, crate::rtl::units::Part::Corners, 0)
            .unwrap_or_default()
            .into_iter()
            .filter(|r| r.len() == 3)
            .map(|r| [r[0], r[1], r[2]])
            .collect();
        me.random = count;
        me.coverage = "random and corners";
        me
    }

    /// The next chunk of inputs into `out` (cleared first); `false` when
    /// there are none left.
    pub fn next_chunk(&mut self, out: &mut Vec<[i128; 3]>) -> bool {
        out.clear();
        if !self.fixed_done {
            self.fixed_done = true;
            out.append(&mut self.fixed);
            if !out.is_empty() {
                return true;
            }
        }
        let m = SAMPLE_CHUNK.min(self.random - self.drawn);
        let code = |q: &Quant, x: f64| q.apply_f64(x).map_or(0, |r| r.code);
        for k in self.drawn..self.drawn + m {
            let d = self.rng.direction();
            let len = if k % 4 == 0 {
                [self.lo, self.hi][k / 4 % 2]
            } else {
                self.lo + (self.hi - self.lo) * self.rng.unit()
            };
            let v = d * len;
            out.push([
                code(&self.normal, v.x),
                code(&self.normal, v.y),
                code(&self.normal, v.z),
            ]);
        }
        self.drawn += m;
        !out.is_empty()
    }
}

/// Error of the CORDIC angles of `cfg` against `asin`/`atan2` of the exact
/// (input) normal.
///
/// # Errors
///
/// [`AnalysisError::Angles`] when the angles configuration is unusable or the unit cannot be
/// compiled; [`AnalysisError::Rtl`] when its RTL cannot be built or emitted (for the cost
/// figures).
pub fn angles(cfg: &Config, count: usize, seed: u64) -> Result<AnglesReport, AnalysisError> {
    let a = crate::angles::Angles::of(cfg).map_err(AnalysisError::Angles)?;
    let prog = a.compile().map_err(AnalysisError::Angles)?;
    let f = a.normal.format();
    let mut inputs = AnglesInputs::new(cfg, count, seed);
    let coverage = inputs.coverage;
    let k = a.out.format().width();
    let turn = to_f64(1u64 << k);
    let mut st = AnglesStats {
        coverage,
        ..Default::default()
    };
    let cap = crate::render::POLAR_CAP_DEG.to_radians().sin();
    let xy_stage = format!("{}.{}", crate::angles::DECL.name, a.xy.stage());
    let xy_flag = prog
        .flag_stages()
        .iter()
        .position(|s| *s == xy_stage)
        .map_or(0, |k| 1u64 << (prog.flag_stages().len() - 1 - k));
    let mut sq = 0.0;
    let mut nsq = 0u64;
    let mut buf = Vec::new();
    while inputs.next_chunk(&mut buf) {
        let chunk = &buf;
        let cols: [Vec<i128>; 3] = std::array::from_fn(|c| chunk.iter().map(|r| r[c]).collect());
        let (out, flags) = prog.run_flags_i128(&[&cols[0], &cols[1], &cols[2]]);
        for (i, r) in chunk.iter().enumerate() {
            st.samples += 1;
            // The accumulator and the outputs wrap by design (angles are
            // taken modulo a turn): only the coordinates can overflow.
            if flags[i] & xy_flag != 0 {
                st.overflows += 1;
                continue;
            }
            let n = DVec3::new(f.to_f64(r[0]), f.to_f64(r[1]), f.to_f64(r[2]));
            if n.length() == 0.0 {
                continue;
            }
            let (ea, eb) = crate::angles::Angles::exact(n);
            if n.length() < SHORTEST_NORMAL {
                // A few LSBs long: truncation of the shifted operands
                // dominates; reported apart.
                let (ga, gb) = (to_f64(out[0][i]) / turn, to_f64(out[1][i]) / turn);
                let wrap = |d: f64| (d + 0.5).rem_euclid(1.0) - 0.5;
                st.short_inputs += 1;
                st.max_short_lsb = st.max_short_lsb.max(wrap(ga - ea).abs() * turn);
                if n.x.hypot(n.z) / n.length() >= cap {
                    st.max_short_lsb = st.max_short_lsb.max(wrap(gb - eb).abs() * turn);
                }
                continue;
            }
            let (ga, gb) = (to_f64(out[0][i]) / turn, to_f64(out[1][i]) / turn);
            let wrap = |d: f64| (d + 0.5).rem_euclid(1.0) - 0.5;
            let da = wrap(ga - ea).abs() * turn;
            st.max_alpha_lsb = st.max_alpha_lsb.max(da);
            sq += da * da;
            nsq += 1;
            let r_xz = n.x.hypot(n.z) / n.length();
            if r_xz > 0.0 {
                let db = wrap(gb - eb).abs() * turn;
                if r_xz >= cap {
                    st.max_beta_lsb = st.max_beta_lsb.max(db);
                    sq += db * db;
                    nsq += 1;
                } else {
                    st.max_beta_lsb_cap = st.max_beta_lsb_cap.max(db);
                }
            }
            let dir = crate::polar::vector_of(ga, gb);
            let ang = dir.dot(n.normalize()).clamp(-1.0, 1.0).acos().to_degrees();
            st.max_direction_deg = st.max_direction_deg.max(ang);
        }
    }
    st.rms_lsb = if nsq > 0 {
        (sq / to_f64(nsq)).sqrt()
    } else {
        0.0
    };
    st.max_alpha_deg = st.max_alpha_lsb * 360.0 / turn;
    st.max_beta_deg = st.max_beta_lsb * 360.0 / turn;
    let design = crate::angles::RTL
        .design(cfg)
        .map_err(|e| AnalysisError::Rtl(e.to_string()))?;
    let em = crate::rtl::emit(&design).map_err(|e| AnalysisError::Rtl(e.to_string()))?;
    let hw = &em.hardware;
    Ok(AnglesReport {
        iterations: a.iterations,
        xy: a.xy.format().to_string(),
        theta: a.theta.format().to_string(),
        out: a.out.format().to_string(),
        angle_bits: k,
        adder_bits: hw
            .adders
            .iter()
            .chain(&hw.add_subs)
            .map(|&w| u64::from(w))
            .sum::<u64>(),
        flops: hw.flops,
        latency: em.latency,
        stats: st,
        seed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The screen against libm's `atan2` near every octant boundary, at
    /// the axes, and on random points of every sign and scale: within its
    /// stated error. (The bound itself is the alternating series', in
    /// [`ATAN2_SCREEN_ERROR`]'s documentation; this checks the code.)
    #[test]
    fn atan2_screen_is_within_its_error() {
        let mut rng = Rng::new(5);
        let mut pts = vec![
            (1.0, 0.0),
            (1.0, -0.0),
            (0.0, 1.0),
            (0.0, -1.0),
            (3.0, -3.0),
        ];
        let t8 = (std::f64::consts::PI / 8.0).tan();
        for k in -40..=40 {
            let t = t8 + f64::from(k) * 1e-12;
            pts.extend([(t, 1.0), (1.0, t), (t, -1.0), (1.0, -t)]);
        }
        for _ in 0..200_000 {
            let x = rng.uniform(0.0, 2f64.powi(20)).floor();
            let z = rng.uniform(-2f64.powi(20), 2f64.powi(20));
            pts.push((x, z.floor()));
            pts.push((rng.uniform(0.0, 1.0), rng.uniform(-0.5, 0.5)));
        }
        for (x, z) in pts {
            let (got, want) = (atan2_screen(x, z), x.atan2(z));
            assert!(
                (got - want).abs() <= ATAN2_SCREEN_ERROR,
                "({x}, {z}): {got} against {want}"
            );
        }
        assert!(atan2_screen(0.0, 0.0).is_nan());
    }

    /// β over every code pair with the screen gives the same maximum, the
    /// same worst pair and the same counts as taking every pair's exact
    /// angle, on a 9-bit fraction (about 800 000 pairs) and a truncating
    /// output; and it takes far fewer exact angles.
    #[test]
    fn the_screened_beta_maximum_is_the_exact_one() {
        for out_round in ["half_even", "trunc"] {
            let mut cfg = Config::embedded();
            cfg.apply_override("angles.normal.format=\"I2F9\"").unwrap();
            cfg.apply_override(&format!("angles.out.round=\"{out_round}\""))
                .unwrap();
            let a = crate::angles::Angles::of(&cfg).unwrap();
            let (lo, hi) = angles_length_range();
            let (s, n_s) = beta_every_code(&a, lo, hi, true).unwrap();
            let (e, n_e) = beta_every_code(&a, lo, hi, false).unwrap();
            assert_eq!(s.max_beta_lsb.to_bits(), e.max_beta_lsb.to_bits());
            assert_eq!(
                (s.worst, s.pairs, s.covered, s.overflows),
                (e.worst, e.pairs, e.covered, e.overflows)
            );
            assert_eq!(n_e, e.pairs);
            assert!(n_s * 20 < n_e, "{n_s} exact angles of {n_e}");
        }
    }

    /// The exhaustive polar figures against the whole transform run on
    /// every code triple and compared with `polar::reference` lane by lane:
    /// 6-bit angles, once on the default formats and once on outputs of
    /// ±½ that overflow.
    #[test]
    fn polar_every_code_is_the_whole_transform_on_every_triple() {
        let mut cfg = Config::embedded();
        for (k, v) in [("polar.angle_bits", "6"), ("polar.table_bits", "6")] {
            cfg.apply_override(&format!("{k}={v}")).unwrap();
        }
        let mut narrow = cfg.clone();
        narrow.apply_override("polar.out.format=\"I0F8\"").unwrap();
        for (cfg, must_overflow) in [(cfg, false), (narrow, true)] {
            let p = crate::polar::Polar::from_config(&cfg).unwrap();
            let light = Lighting::from_config(&cfg);
            let got = polar_every_code(&p, &light).unwrap();
            let turn = 1i128 << p.angle.format().width();
            let q = turn / 4;
            let mut cols: [Vec<i128>; 4] = Default::default();
            for al in -q..=q {
                for d in 0..turn {
                    for an in -q..=q {
                        for (c, v) in cols.iter_mut().zip([al, d, an, 0]) {
                            c.push(v.rem_euclid(turn));
                        }
                    }
                }
            }
            let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
            let (out, ov) = p.compile().unwrap().run_i128(&refs);
            let overflows: u64 = ov
                .iter()
                .filter(|(s, _)| *s != "index")
                .map(|(_, n)| n)
                .sum();
            let fo = p.out.format();
            let t = |c: i128| to_f64(c) / to_f64(turn);
            let mut max_lsb = 0.0f64;
            for i in 0..cols[0].len() {
                let at = |c: usize| {
                    if cols[c][i] >= turn / 2 {
                        cols[c][i] - turn
                    } else {
                        cols[c][i]
                    }
                };
                let want = crate::polar::reference(t(at(0)), t(cols[1][i]), t(at(2)), 0.0);
                for c in 0..3 {
                    max_lsb = max_lsb.max(((fo.to_f64(out[c][i]) - want[c]) / fo.ulp()).abs());
                }
            }
            assert_eq!(got.samples, cols[0].len() as u64);
            assert_eq!(got.overflows, overflows);
            assert_eq!(overflows > 0, must_overflow);
            assert!(
                (got.max_lsb_err - max_lsb).abs() < 1e-9,
                "{} against {max_lsb}",
                got.max_lsb_err
            );
        }
    }
}
