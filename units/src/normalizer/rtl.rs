//! The normalizer's RTL side: its traced design (the Verilog is emitted
//! from it, `crate::rtl`) and its input vectors.

use fxshade_numbers::convert::narrow;
use glam::DVec3;

use super::{from_config, Normalizer, DECL};
use crate::config::Config;
use crate::datapath::{Fixed, Fx};
use crate::format::Format;
use crate::quantize::{Overflow, Quant, Rounding};
use crate::rtl::units::Part;
use crate::rtl::units::{hunt_ties, structured_code, RtlError};
use crate::sampling::{self, Rng};

/// The unit's traced datapath for a configuration (any method but
/// `exact`, which divides and takes a square root: [`crate::rtl::emit`]
/// refuses it).
///
/// # Errors
///
/// [`RtlError::Design`] when the configured normalizer cannot be designed ([`from_config`]);
/// [`RtlError::Convert`] as [`Normalizer::trace`] (never: designed coefficients are finite).
pub fn design(cfg: &Config) -> Result<crate::rtl::Design, RtlError> {
    let (n, design) = from_config(cfg)?;
    let mut notes = vec![format!("Method: {}", n.method.name())];
    if let Some(d) = &design {
        notes.push(format!(
            "Coefficients: {} fit on the {} interval [{}, {}] for Θ = {}, by {}",
            d.fit.name(),
            d.interval_kind.name(),
            d.interval.0,
            d.interval.1,
            d.theta,
            d.used
        ));
    }
    if !n.coeffs.is_empty() {
        notes.push(format!(
            "g(d) coefficients ({}), {}: {}",
            n.q.coef.format(),
            crate::coeffs::ORDER,
            crate::coeffs::named_highest_first(&n.coeffs)
        ));
    }
    let mut d = crate::rtl::units::design(DECL.name, n.method.name(), n.trace()?, cfg, notes);
    d.parameters = serde_json::json!({
        "method": n.method.name(),
        "coefficients": coefficients(&n),
    });
    Ok(d)
}

/// The normalizer's `g(d)` coefficients, machine-readable: the format,
/// then each coefficient in [`crate::coeffs::ORDER`] (highest power first,
/// `a`, `b`, `c`) as its code and its value (`null` for a method without
/// coefficients).
pub fn coefficients(n: &Normalizer) -> serde_json::Value {
    if n.coeffs.is_empty() {
        return serde_json::Value::Null;
    }
    let q = &n.q.coef;
    serde_json::json!({
        "order": crate::coeffs::ORDER,
        "format": q.format().to_string(),
        "codes": n.coeffs.iter().rev().map(|&c| narrow::<i64, _>(q.apply_f64(c).map_or(0, |r| r.code))).collect::<Vec<_>>(),
        "values": n.coeffs.iter().rev().collect::<Vec<_>>(),
    })
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
    // Codes outside the format (−1 of an unsigned one) are not inputs.
    v.retain(|r| {
        r.iter()
            .all(|&c| (f.min_code()..=f.max_code()).contains(&c))
    });
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

/// Input vectors for the configuration: the corner cases (known points,
/// extreme codes, and inputs meeting an exact rounding tie at each
/// nearest-mode stage), then random
/// interpolated normals of triangles meeting Θ and random codes over the
/// whole input range, alternating; `count` in all.
///
/// # Errors
///
/// [`RtlError::Design`] when the configured normalizer cannot be designed ([`from_config`]); its
/// constants never fail to convert (designed coefficients are finite).
pub fn inputs(
    cfg: &Config,
    part: crate::rtl::units::Part,
    seed: u64,
) -> Result<Vec<Vec<i128>>, RtlError> {
    let (n, _design) = from_config(cfg)?;
    let theta = cfg.section::<super::NormalizeConfig>().theta;
    let f = n.q.normal.format();
    let mut rng = Rng::new(seed);
    let Part::Random(count) = part else {
        let mut inputs = corner_inputs(theta, f, &mut rng);
        inputs.extend(tie_inputs(&n, 8, &mut rng)?);
        return Ok(inputs.into_iter().map(|c| c.to_vec()).collect());
    };
    let span = narrow::<u64, _>(f.max_code() - f.min_code() + 1);
    let mut inputs: Vec<[i128; 3]> = Vec::with_capacity(count);
    while inputs.len() < count {
        if inputs.len().is_multiple_of(2) {
            let t = sampling::triangle_meeting(theta, &mut rng);
            let p: DVec3 = sampling::lerp3(&t, rng.barycentric());
            inputs.push([0, 1, 2].map(|k| n.q.normal.apply_f64(p[k]).map(|r| r.code).unwrap_or(0)));
        } else {
            inputs.push([0; 3].map(|_| f.min_code() + i128::from(rng.below(span))));
        }
    }
    Ok(inputs.into_iter().map(|c| c.to_vec()).collect())
}
