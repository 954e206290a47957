//! The CORDIC angle unit's RTL side: its traced design (the Verilog is
//! emitted from it, `crate::rtl`) and its input vectors.

use fxshade_numbers::convert::narrow;
use glam::DVec3;

use super::{Angles, DECL};
use crate::config::Config;
use crate::rtl::units::Part;
use crate::rtl::units::RtlError;
use crate::sampling::Rng;

/// The unit's traced datapath for a configuration.
///
/// # Errors
///
/// [`RtlError::Angles`] when the `[angles]` section is unusable ([`Angles::of`]);
/// [`RtlError::Convert`] as [`Angles::trace`] (never: the CORDIC constants are finite).
pub fn design(cfg: &Config) -> Result<crate::rtl::Design, RtlError> {
    let a = Angles::of(cfg)?;
    let notes = vec![format!(
        "{} micro-rotations per angle; coordinates {}, accumulator {}, gain K = {:.6} in {} ({}); outputs {}",
        a.iterations,
        a.xy.format(),
        a.theta.format(),
        super::gain(a.iterations),
        a.gain.format(),
        if a.shift_add {
            "shifts and additions of its signed digits"
        } else {
            "a constant multiplier"
        },
        a.out.format()
    )];
    Ok(crate::rtl::units::design(
        DECL.name,
        if a.shift_add { "shift_add" } else { "product" },
        a.trace()?,
        cfg,
        notes,
    ))
}

/// Input vectors: corner cases (the axes and their negations, the poles,
/// the zero vector, the β seam either side, the octant boundaries, codes a
/// few LSBs from zero, the largest and smallest codes), then random
/// normals: unit directions scaled by 0.97 ..= 1.03 (the lengths quadratic
/// interpolation produces), alternating with arbitrary codes.
///
/// # Errors
///
/// [`RtlError::Angles`] when the `[angles]` section is unusable ([`Angles::of`]).
pub fn inputs(cfg: &Config, part: Part, seed: u64) -> Result<Vec<Vec<i128>>, RtlError> {
    let a = Angles::of(cfg)?;
    let q = &a.normal;
    let f = q.format();
    let code = |x: f64| q.apply_f64(x).map(|r| r.code).unwrap_or(0);
    let row = |v: DVec3| vec![code(v.x), code(v.y), code(v.z)];
    let mut rows: Vec<Vec<i128>> = Vec::new();
    if let Part::Random(count) = part {
        let mut rng = Rng::new(seed);
        let span = narrow::<u64, _>(f.max_code() - f.min_code() + 1);
        while rows.len() < count {
            if rows.len().is_multiple_of(2) {
                let d = rng.direction() * (0.97 + 0.06 * rng.unit());
                rows.push(row(d));
            } else {
                rows.push(
                    (0..3)
                        .map(|_| f.min_code() + i128::from(rng.below(span)))
                        .collect(),
                );
            }
        }
        return Ok(rows);
    }
    let e = 1e-3;
    for v in [
        DVec3::X,
        DVec3::Y,
        DVec3::Z,
        -DVec3::X,
        -DVec3::Y,
        -DVec3::Z,
        DVec3::ZERO,
        DVec3::new(e, 0.0, -1.0),
        DVec3::new(-e, 0.0, -1.0),
        DVec3::new(e, 0.3, -1.0),
        DVec3::new(-e, -0.3, -1.0),
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(1.0, 0.0, -1.0),
        DVec3::new(-1.0, 0.0, 1.0),
        DVec3::new(-1.0, 0.0, -1.0),
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(-1.0, -1.0, -1.0),
        DVec3::new(0.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, 0.0),
    ] {
        rows.push(row(v));
    }
    // A few LSBs around the poles and the axes.
    for dx in -2i128..=2 {
        for dz in -2i128..=2 {
            rows.push(vec![dx, code(1.0), dz]);
            rows.push(vec![dx, code(-1.0), dz]);
            rows.push(vec![dx, 0, dz]);
        }
    }
    // Extreme codes.
    let (lo, hi) = (f.min_code(), f.max_code());
    for &x in &[lo, hi, 0] {
        for &y in &[lo, hi, 0] {
            for &z in &[lo, hi, 0] {
                rows.push(vec![x, y, z]);
            }
        }
    }
    Ok(rows)
}
