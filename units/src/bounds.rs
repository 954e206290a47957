//! Proven error bounds: where a figure cannot be measured over every input
//! code, a bound that holds for every input, derived from the
//! configuration's formats and modes and the model's own codes (never from
//! samples). A sampled maximum is a lower estimate of the true maximum; a
//! bound here is an upper one, and the true maximum lies between them.
//!
//! Each bound is the sum of the errors of the steps the datapath takes,
//! each step's error taken at its worst: the rounding of a quantization is
//! at most [`rounding_error`] (a nearest mode half an LSB, `trunc` a whole
//! one), and the part that depends on the data is computed exactly per
//! code of the quantization that decides it, over every code that can
//! occur.

use crate::lighting::Lighting;
use crate::normalizer::{DesignError, Method, Normalizer};
use crate::quantize::{Quant, Rounding};
use fxshade_numbers::convert::{from_f64, to_f64};

/// The largest error one quantization makes on an exact value it keeps in
/// range: the format's LSB for `trunc` (floor), half of it for the nearest
/// modes.
pub fn rounding_error(q: &Quant) -> f64 {
    match q.round() {
        Rounding::Trunc => q.format().ulp(),
        _ => q.format().ulp() / 2.0,
    }
}

/// A relative allowance for the f64 evaluation of a bound (square roots and
/// products of at most a few terms: far above their rounding).
const F64_SLACK: f64 = 1e-12;

/// Proven bounds on the normalizer's output error, for every input whose
/// components are codes of `normalize.normal` quantized from an exact
/// vector with `|N|²` in `[lo, hi]`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NormalizeBound {
    /// `[lo, hi]`: the range of the exact `|N|²` before the input
    /// quantization.
    pub exact_d: (f64, f64),
    /// The range of `D = |N_q|²` of the quantized inputs this covers
    /// (`[lo, hi]` widened by the input rounding).
    pub d_range: (f64, f64),
    /// `d` codes examined one by one (0 when the branch and bound of
    /// [`crate::normalizer::g_stage_max`] served instead).
    pub codes: u64,
    /// How: `every d code` or `g-stage bound`.
    pub how: &'static str,
    /// `max | √D·g(Q_d(D)) − 1 |` over every `D` of the range (the scale
    /// error before the output rounding).
    pub scale: f64,
    /// Proven bound on `| |N'| − 1 |`: `scale + √3·e_out`.
    pub length: f64,
    /// Proven bound on `|N' − N_q/|N_q||`: the same (the scale error is
    /// along `N`, the output rounding at most `√3·e_out` in any direction).
    pub vector: f64,
    /// Proven bound on the diffuse term's error in 8-bit levels against
    /// `255·I0·km·max(0, N̂·L)` with exact `N̂` and `L`:
    /// `e_level + G_q·(e_dot + (vector + √3·e_n)·(1 + √3·e_l) + √3·e_l) + |G_q − G|`
    /// (`e_n` the conversion into `lighting.normal`, `e_l` the light's
    /// quantization, `G = 255·I0·km`, `G_q` its code).
    pub diffuse_levels: f64,
    /// Of which the 8-bit output's own rounding.
    pub level_rounding: f64,
}

/// [`NormalizeBound`] of `n` for inputs quantized from vectors with
/// `|N|² ∈ [lo, hi]`, with the diffuse term of `light`.
///
/// # Errors
///
/// [`DesignError::Compile`] when the `g(d)` stage of `n` is needed and does not compile
/// ([`Normalizer::compile_g`]: an exact intermediate wider than the model holds); never for
/// [`Method::None`].
///
/// # Panics
///
/// As [`Normalizer::compile_g`], when the `g(d)` stage is needed (never for [`Method::None`]).
pub fn normalize(
    n: &Normalizer,
    light: &Lighting,
    lo: f64,
    hi: f64,
) -> Result<NormalizeBound, DesignError> {
    let e_in = rounding_error(&n.q.normal);
    let s3 = 3f64.sqrt();
    // |N_q − N| ≤ √3·e_in, so |N_q| lies within √3·e_in of |N|.
    let r_lo = (lo.sqrt() - s3 * e_in).max(0.0);
    let r_hi = hi.sqrt() + s3 * e_in;
    let (d_lo, d_hi) = (r_lo * r_lo, r_hi * r_hi);
    let (scale, codes, how) = if n.method == Method::None {
        // N' = Q_out(N): the scale is |N_q| itself.
        let s = (1.0 - r_lo).abs().max((r_hi - 1.0).abs());
        (s, 0, "no g: |N_q| itself")
    } else {
        scale_error(n, d_lo, d_hi)?
    };
    let e_out = rounding_error(&n.q.out);
    let length = (scale + s3 * e_out) * (1.0 + F64_SLACK);
    let vector = length;
    // The diffuse term (Lighting::diffuse: dot = Q_dot(N·L), level =
    // Q_level(max(dot, 0)·Q_gain(255·I0·km))).
    let fo = n.q.out.format();
    let fln = light.normal.format();
    // The conversion of the output into lighting's normal port drops bits
    // only when lighting's format has fewer fraction bits.
    let e_n = if fln.frac() < fo.frac() {
        rounding_error(&light.normal)
    } else {
        0.0
    };
    let e_l = rounding_error(&light.light);
    let e_dot = rounding_error(&light.dot);
    let g_exact = crate::lighting::LEVELS * light.i0_km;
    let g_q = light
        .gain
        .apply_f64(g_exact)
        .map_or(g_exact, |r| light.gain.format().to_f64(r.code));
    let level_rounding = rounding_error(&light.level);
    let diffuse_levels = (level_rounding
        + g_q * (e_dot + (vector + s3 * e_n) * (1.0 + s3 * e_l) + s3 * e_l)
        + (g_q - g_exact).abs())
        * (1.0 + F64_SLACK);
    Ok(NormalizeBound {
        exact_d: (lo, hi),
        d_range: (d_lo, d_hi),
        codes,
        how,
        scale,
        length,
        vector,
        diffuse_levels,
        level_rounding,
    })
}

/// `max | √D·g(Q_d(D)) − 1 |` over `D ∈ [d_lo, d_hi]`: every `d` code
/// whose preimage under `Q_d` meets the range, `g` its code from the
/// model, `√D` at both ends of the preimage (the product is monotonic in
/// `D` for a fixed `g`); above [`crate::normalizer::EXHAUSTIVE_CODES`]
/// codes, the g stage's proven bound with the rounding of `d`.
fn scale_error(
    n: &Normalizer,
    d_lo: f64,
    d_hi: f64,
) -> Result<(f64, u64, &'static str), DesignError> {
    let fd = n.q.d.format();
    let u = fd.ulp();
    // The preimage of code c under Q_d: [c·u − a, c·u + b].
    let (a, b) = match n.q.d.round() {
        Rounding::Trunc => (0.0, u),
        _ => (u / 2.0, u / 2.0),
    };
    let c_lo = (from_f64::<i128>(((d_lo - b) / u).floor())).max(fd.min_code());
    let c_hi = (from_f64::<i128>(((d_hi + a) / u).ceil())).min(fd.max_code());
    if c_lo > c_hi {
        return Ok((0.0, 0, "every d code"));
    }
    if c_hi - c_lo >= crate::normalizer::EXHAUSTIVE_CODES {
        // Too many codes: the g stage's proven bound B over the codes,
        // then D/d̂ within [1 − a/d̂, 1 + b/d̂].
        let dmin = (to_f64(c_lo) * u).max(u);
        let m = crate::normalizer::g_stage_max(n, to_f64(c_lo) * u, to_f64(c_hi) * u, None)?;
        let bg = m.bound.max(m.max);
        let hi_r = ((1.0 + b / dmin).sqrt() * (1.0 + bg) - 1.0).abs();
        let lo_r = (1.0 - (1.0 - a / dmin).max(0.0).sqrt() * (1.0 - bg)).abs();
        return Ok((hi_r.max(lo_r), 0, "g-stage bound"));
    }
    let prog = n.compile_g()?;
    let ug = n.q.g.format().ulp();
    let mut worst: f64 = 0.0;
    let mut codes = 0u64;
    const CHUNK: i128 = 1 << 12;
    let mut start = c_lo;
    let mut buf: Vec<i128> = Vec::with_capacity(CHUNK as usize);
    while start <= c_hi {
        let end = (start + CHUNK - 1).min(c_hi);
        buf.clear();
        buf.extend(start..=end);
        let (out, _) = prog.run_i128(&[&buf]);
        for (&c, &g) in buf.iter().zip(&out[0]) {
            let lo = (to_f64(c) * u - a).max(d_lo);
            let hi = (to_f64(c) * u + b).min(d_hi);
            if lo > hi {
                continue;
            }
            codes += 1;
            let g = to_f64(g) * ug;
            let e = (lo.sqrt() * g - 1.0).abs().max((hi.sqrt() * g - 1.0).abs());
            worst = worst.max(e);
        }
        start = end + 1;
    }
    Ok((worst, codes, "every d code"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::sampling::{self, Rng};

    /// The bound holds on every sample, and is not loose: the largest
    /// sampled error reaches most of it.
    #[test]
    fn the_normalizer_bound_holds_and_is_close() {
        let cfg = Config::embedded();
        let (n, _) = crate::normalizer::from_config(&cfg).unwrap();
        let light = Lighting::from_config(&cfg);
        let theta = cfg.section::<crate::normalizer::NormalizeConfig>().theta;
        let lo = (1.0 + 2.0 * theta) / 3.0;
        let b = normalize(&n, &light, lo, 1.0).unwrap();
        let prog = n.compile().unwrap();
        let fo = n.q.out.format();
        let mut rng = Rng::new(3);
        let mut worst: f64 = 0.0;
        for _ in 0..20 {
            let cols: [Vec<i128>; 3] = Default::default();
            let mut cols = cols;
            for _ in 0..1 << 14 {
                let t = sampling::triangle_meeting(theta, &mut rng);
                let v = sampling::lerp3(&t, rng.barycentric());
                for (k, c) in cols.iter_mut().enumerate() {
                    c.push(n.q.normal.apply_f64(v[k]).unwrap().code);
                }
            }
            let (out, _) = prog.run_i128(&[&cols[0], &cols[1], &cols[2]]);
            for ((x, y), z) in out[0].iter().zip(&out[1]).zip(&out[2]) {
                let l = [x, y, z]
                    .map(|&c| fo.to_f64(c).powi(2))
                    .iter()
                    .sum::<f64>()
                    .sqrt();
                worst = worst.max((l - 1.0).abs());
            }
        }
        assert!(
            worst <= b.length,
            "sampled {worst} above the bound {}",
            b.length
        );
        assert!(
            worst > 0.9 * b.length,
            "the bound {} is loose: sampled {worst}",
            b.length
        );
    }
}
