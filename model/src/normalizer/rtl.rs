//! The normalizer's RTL side: the Verilog parameter header of a
//! configuration (`rtl/normalize.v` includes it) and test vectors with
//! per-vector overflow flags.

use glam::DVec3;

use super::{from_config, Design, Method, Normalizer, DECL};
use crate::config::Config;
use crate::datapath::{Fixed, Fx};
use crate::format::Format;
use crate::quantize::{Overflow, Quant, Rounding};
use crate::sampling::{self, Rng};
use crate::vectors::{
    check_rtl_stages, header_preamble, hunt_ties, stage_params, structured_code, Field,
    ParamsHeader, RtlError, VectorSet,
};

/// The Verilog parameter header `normalize_params.vh` for a configuration.
pub fn params_header(cfg: &Config) -> Result<(Normalizer, Option<Design>, ParamsHeader), RtlError> {
    let (n, design) = from_config(cfg)?;
    if n.method != Method::Linear && n.method != Method::Quadratic {
        return Err(RtlError::Method {
            unit: "normalize",
            method: n.method.name(),
            supported: "linear and quadratic",
        });
    }
    let q = &n.q;
    check_rtl_stages(
        &n.count()?,
        &[
            ("normal", q.normal.format()),
            ("d", q.d.format()),
            ("coef", q.coef.format()),
            ("horner", q.horner.format()),
            ("g", q.g.format()),
            ("out", q.out.format()),
        ],
    )
    .map_err(|(stage, why)| RtlError::Stage {
        unit: "normalize",
        stage,
        why,
    })?;
    let mut detail = format!("Method: {}", n.method.name());
    if let Some(d) = &design {
        detail += &format!(
            ", {} fit on the {} interval [{}, {}] for Θ = {}, coefficients by {}",
            d.fit.name(),
            d.interval_kind.name(),
            d.interval.0,
            d.interval.1,
            d.theta,
            d.used
        );
    }
    let mut t = header_preamble("normalize_params.vh", "normalize", DECL.name, cfg, &detail);
    t += &format!(
        "localparam integer METHOD = {};\n",
        if n.method == Method::Linear { 1 } else { 2 }
    );
    t += &stage_params("N", &q.normal, false);
    t += &stage_params("D", &q.d, true);
    t += &stage_params("C", &q.coef, false);
    t += &stage_params("H", &q.horner, true);
    t += &stage_params("G", &q.g, true);
    t += &stage_params("O", &q.out, true);
    t += &coef_table(
        q.coef.format(),
        &[(detail_theta(&design), n.coeffs.clone())],
    )?;
    Ok((
        n,
        design,
        ParamsHeader {
            name: "normalize_params.vh".into(),
            text: t,
            extra: Vec::new(),
        },
    ))
}

fn detail_theta(d: &Option<Design>) -> String {
    d.as_ref()
        .map_or_else(|| "-".into(), |d| format!("Θ = {}", d.theta))
}

/// The coefficient table of `rtl/normalize.v`: `NSETS`, `SEL_W` and `COEFS`,
/// the sets packed `{c2, c1, c0}` each, set 0 in the low bits. `sets` holds
/// a label and the values (lowest power first, exactly representable in
/// `cf`) of each set.
pub fn coef_table(cf: Format, sets: &[(String, Vec<f64>)]) -> Result<String, RtlError> {
    let nsets = sets.len().max(1);
    // At least the pipeline's 3-bit `sel` (pipeline::SEL_BITS), so the
    // standalone header (one set) and the pipeline's agree on the port.
    let sel_w = (usize::BITS - (nsets - 1).leading_zeros()).max(crate::pipeline::SEL_BITS);
    let mut t = format!("localparam integer NSETS = {nsets}, SEL_W = {sel_w};\n");
    t += "// Coefficient sets, {c2, c1, c0} each, set 0 in the low bits:\n";
    // One "c2, c1, c0" group per set; the concatenation lists set NSETS−1
    // first, so set 0 lands in the low bits.
    let mut groups = Vec::new();
    for (k, (label, values)) in sets.iter().enumerate() {
        let mut v = values.clone();
        v.resize(3, 0.0);
        t += &format!(
            "//   set {k} ({label}): c0 = {}, c1 = {}, c2 = {}\n",
            v[0], v[1], v[2]
        );
        let words = v
            .iter()
            .rev()
            .map(|c| {
                let code = cf.from_f64(*c, Rounding::HalfEven)?;
                Ok(format!(
                    "{}'h{:0w$x}",
                    cf.width(),
                    cf.to_bits(code),
                    w = cf.hex_digits()
                ))
            })
            .collect::<Result<Vec<_>, RtlError>>()?;
        groups.push(words.join(", "));
    }
    groups.reverse();
    let ordered = groups;
    t += &format!(
        "localparam [NSETS*3*C_W-1:0] COEFS = {{{}}};\n",
        ordered.join(", ")
    );
    Ok(t)
}

/// Inputs with known answers: equiangular triangles (centroid: smallest d;
/// vertices: d = 1; edge midpoints) and extreme codes.
fn corner_inputs(theta: f64, f: Format, rng: &mut Rng) -> Vec<[i128; 3]> {
    let mut v = Vec::new();
    let q = Quant::new("normal", f, Rounding::HalfEven, Overflow::Saturate);
    let code = |x: f64| q.apply_f64(x).map(|r| r.code).unwrap_or(0);
    for _ in 0..8 {
        let t = sampling::equiangular(theta, rng);
        let mut pts = vec![sampling::lerp3(&t, [1.0 / 3.0; 3])];
        for i in 0..3 {
            let mut c = [0.0; 3];
            c[i] = 1.0;
            pts.push(sampling::lerp3(&t, c));
            let mut m = [0.5; 3];
            m[i] = 0.0;
            pts.push(sampling::lerp3(&t, m));
        }
        v.extend(pts.into_iter().map(|p| [code(p.x), code(p.y), code(p.z)]));
    }
    let (mx, mn) = (f.max_code(), f.min_code());
    v.extend([
        [mx, 0, 0],
        [mn, 0, 0],
        [mx, mx, mx],
        [mn, mn, mn],
        [0, 0, 0],
        [1, 0, 0],
        [-1, 0, 0],
        [0, mx, mn],
    ]);
    v
}

/// Inputs that make each nearest-mode stage meet an exact rounding tie.
fn tie_inputs(n: &Normalizer, per_stage: usize, rng: &mut Rng) -> Result<Vec<[i128; 3]>, RtlError> {
    let f = n.q.normal.format();
    let mut fx = Fixed::<i128>::new();
    let k = n.consts(&mut fx)?;
    let points = n.count()?;
    let stages: Vec<&'static str> = points
        .quant_points()
        .iter()
        .filter(|p| p.round != Rounding::Trunc && p.dropped_bits > 0)
        .map(|p| p.stage)
        .collect();
    let found = hunt_ties(
        &stages,
        per_stage,
        200_000,
        || (0..3).map(|_| structured_code(f, rng)).collect(),
        |fx, c| {
            n.eval(fx, &k, [0, 1, 2].map(|i| Fx::from_code(c[i], f)));
        },
    );
    Ok(found.into_iter().map(|c| [c[0], c[1], c[2]]).collect())
}

/// The expected outputs of one input: `[ovf, x, y, z]`, with `ovf` the
/// overflow flags `{d, horner, g, out}` of this vector alone.
fn expected(
    n: &Normalizer,
    fx: &mut Fixed<i128>,
    k: &super::Consts<Fx>,
    codes: [i128; 3],
) -> Vec<i128> {
    fx.reset();
    let f = n.q.normal.format();
    let out = n.eval(fx, k, codes.map(|c| Fx::from_code(c, f)));
    let flag = |s: &str| fx.overflows().iter().any(|(st, c)| *st == s && *c > 0) as i128;
    let ovf = (flag("d") << 3) | (flag("horner") << 2) | (flag("g") << 1) | flag("out");
    vec![ovf, out[0].code(), out[1].code(), out[2].code()]
}

/// Test vectors for the configuration: the corner cases (known points,
/// extreme codes, and inputs meeting an exact rounding tie at each
/// nearest-mode stage), then random
/// interpolated normals of triangles meeting Θ and random codes over the
/// whole input range, alternating; `count` in all.
pub fn vectors(cfg: &Config, count: usize, seed: u64) -> Result<VectorSet, RtlError> {
    let (n, _design, params) = params_header(cfg)?;
    let theta = cfg.unit(DECL.name).number("theta");
    let f = n.q.normal.format();
    let mut rng = Rng::new(seed);
    let mut inputs = corner_inputs(theta, f, &mut rng);
    inputs.extend(tie_inputs(&n, 8, &mut rng)?);
    let corners = inputs.len();
    if count < corners {
        return Err(RtlError::Count { count, corners });
    }
    let span = (f.max_code() - f.min_code() + 1) as u64;
    while inputs.len() < count {
        if inputs.len() % 2 == 0 {
            let t = sampling::triangle_meeting(theta, &mut rng);
            let p: DVec3 = sampling::lerp3(&t, rng.barycentric());
            inputs.push([0, 1, 2].map(|k| n.q.normal.apply_f64(p[k]).map(|r| r.code).unwrap_or(0)));
        } else {
            inputs.push([0; 3].map(|_| f.min_code() + rng.below(span) as i128));
        }
    }
    let mut fx = Fixed::<i128>::new();
    let k = n.consts(&mut fx)?;
    let output_rows = inputs
        .iter()
        .map(|&c| expected(&n, &mut fx, &k, c))
        .collect();
    let fo = n.q.out.format();
    let flags = Format::new(false, 4, 0).expect("valid");
    Ok(VectorSet {
        unit: DECL.name,
        variant: n.method.name().to_string(),
        config_source: cfg.source.clone(),
        config_toml: cfg.to_toml(),
        seed,
        inputs: vec![
            Field::new("nx", f),
            Field::new("ny", f),
            Field::new("nz", f),
        ],
        outputs: vec![
            Field::new("ovf", flags),
            Field::new("ox", fo),
            Field::new("oy", fo),
            Field::new("oz", fo),
        ],
        input_rows: inputs.into_iter().map(|c| c.to_vec()).collect(),
        output_rows,
        params,
        corner_cases: corners,
    })
}
