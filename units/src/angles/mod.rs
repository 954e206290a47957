//! The polar angles of a normal by CORDIC (method B's per-pixel angles):
//! `α = atan2(y, √(x² + z²))` and `β = atan2(x, z)`, with shifts, additions
//! and one constant product — no arcsine, arctangent, square root, division
//! or normalization. Both angles are ratios, so `N` need not be unit length:
//! the interpolated normal of method C feeds the unit directly.
//!
//! ## The datapath
//! Angles are binary angle measures (fractions of a turn), as in
//! [`crate::polar`]. With `Q_xy` the micro-rotation step, `Q_θ` the angle
//! accumulator (it wraps) and `c_i = Q_θ(atan(2^−i)/2π)`:
//!
//! ```text
//! pre-rotation by ∓90° (the sign of x):        u0 = |x|,   v0 = x ≥ 0 ? −z : z,   θ0 = x ≥ 0 ? ¼ : −¼
//! vectoring, i = 0 .. n−1, σ = (v ≥ 0 ? +1 : −1):
//!         u' = Q_xy(u + σ·v·2^−i)     v' = Q_xy(v − σ·u·2^−i)     θ' = Q_θ(θ + σ·c_i)
//! β = Q_out(θ_n)                                u_n ≈ K_n·√(x² + z²)
//! second vectoring on (u_n, Q_xy(K·y)), θ0 = 0:  α = Q_out(θ_n)
//! ```
//!
//! `K_n = ∏ √(1 + 2^−2i)` is the gain of `n` micro-rotations; it is folded
//! into one constant product `K·y` (`gain` stage: the constant's format) so
//! both arguments of the second vectoring carry the same scale. With
//! `gain_mode = "shift_add"` the same product `K_q·y` (`K_q` the gain
//! code) is built from the canonical signed-digit form of `K_q`:
//! `Σ d_j·(y·2^e_j)`, `d_j = ±1`, shifts and one addition or subtraction per
//! digit after the first, no multiplier — bit-identical to `"product"`
//! ([`csd`]). The shifted
//! operand `v·2^−i` is added exactly and the sum rounded once by `Q_xy` (with
//! `trunc` that is the usual arithmetic shift right). Each micro-rotation is
//! one adder/subtracter per coordinate steered by the sign bit of `v`
//! ([`Datapath::add_signed`]).
//!
//! ## Defined results
//! * `β` wraps at ±180°: a normal with `z < 0` and `x` either side of 0 gets
//!   `β` just below or just above half a turn.
//! * At the poles (`x = z = 0`) `β` is undefined; the datapath gives
//!   `θ0 + Σ c_i` (every `σ = +1` because `v = 0` counts as non-negative):
//!   about 189.9° for 12 iterations. Any `β` is a valid frame there (the
//!   implied frame is singular at the poles); fxshade keeps the datapath's
//!   value rather than spend a zero detector on it, and the renderer reports
//!   the polar cap separately.
//! * The zero vector gives `α = Σ c_i` (about 99.9°) and `β` as at the poles.
//! * An input far enough from unit length to overflow `Q_xy` saturates and
//!   raises the unit's overflow flag; the default `I4F18` holds every input
//!   code of `I2F14` with `|N| ≤ 2.9`.

use crate::config::{Config, ConfigError, FieldDecl, FieldKind, UnitDecl};
use crate::datapath::{Compiled, Count, Datapath, Trace};
use crate::format::{ConvertError, Format};
use crate::quantize::{literal, Overflow, Quant};
use crate::units::{width_errors, OpReport, Phase};
use fxshade_numbers::convert::narrow;

pub mod rtl;

/// The `[angles]` configuration section.
pub static DECL: UnitDecl = UnitDecl {
    name: "angles",
    doc: "polar angles α, β of the (un-normalized) normal by CORDIC vectoring: shifts and additions only (method B's per-pixel angles)",
    fields: &[
        FieldDecl {
            name: "iterations",
            kind: FieldKind::Integer { min: 1, max: 40 },
            doc: "micro-rotations per angle (each one adder/subtracter per coordinate and one arctangent constant)",
        },
        FieldDecl { name: "normal", kind: FieldKind::Stage, doc: "input port: the normal's components (any length)" },
        FieldDecl { name: "xy", kind: FieldKind::Stage, doc: "micro-rotation coordinates u, v and K·y: each sum rounded once (trunc = arithmetic shift right)" },
        FieldDecl { name: "gain", kind: FieldKind::Stage, doc: "the CORDIC gain K_n = ∏ √(1 + 2^−2i), a constant multiplying y so both vectorings see the same scale (its format sets the constant's precision)" },
        FieldDecl {
            name: "gain_mode",
            kind: FieldKind::Choice(&["product", "shift_add"]),
            doc: "K·y by a constant multiplier, or by shifts and additions of K's canonical signed digits (the same value, no multiplier)",
        },
        FieldDecl { name: "theta", kind: FieldKind::Stage, doc: "angle accumulator and arctangent constants, a fraction of a turn (unsigned, 0 integer bits; must wrap)" },
        FieldDecl { name: "out", kind: FieldKind::Stage, doc: "output angles α, β, a fraction of a turn: rounding (format U0F<polar.angle_bits>, the polar transform's angle format; must wrap)" },
    ],
    groups: &[("normals", &["normal"]), ("cordic", &["xy", "theta"])],
};

/// The `[angles]` section, typed (one field per declared field).
#[derive(Clone, Copy, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnglesConfig {
    /// Micro-rotations.
    pub iterations: u32,
    /// Input port: the normal's components.
    pub normal: Quant,
    /// The micro-rotation coordinates.
    pub xy: Quant,
    /// The CORDIC gain `K_n`.
    pub gain: Quant,
    /// How the gain is applied.
    pub gain_mode: GainMode,
    /// The angle accumulator and arctangent constants.
    pub theta: Quant,
    /// The output angles (format follows `polar.angle_bits`).
    pub out: Quant,
}

impl crate::config::Section for AnglesConfig {
    const DECL: &'static UnitDecl = &DECL;
}

/// How the CORDIC gain is applied (`angles.gain_mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GainMode {
    /// One product by `K_n` in the `gain` format.
    Product,
    /// Shifts and adds of `K_n`'s nonzero digits.
    ShiftAdd,
}

/// The CORDIC angles as a registered unit.
pub struct AnglesUnit;

crate::unit!(AnglesUnit, decl: DECL, section: AnglesConfig, check: check, ops: ops,
    rtl: &[&RTL]);

/// The registry entry.
pub static UNIT: AnglesUnit = AnglesUnit;

/// The unit's generated RTL: variants, design and input vectors.
pub static RTL: crate::rtl::units::RtlUnit = crate::rtl::units::RtlUnit {
    name: "angles",
    doc: "polar angles α, β of the normal by CORDIC vectoring (method B's per-pixel angles)",
    variants: &[
        ("product", "angles.gain_mode=\"product\""),
        ("shift_add", "angles.gain_mode=\"shift_add\""),
    ],
    build: crate::angles::rtl::design,
    inputs: crate::angles::rtl::inputs,
};

/// Why an angles configuration is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AnglesError {
    /// A stage's format or mode does not suit an angle.
    #[error("angles.{key}: {why}")]
    Config {
        /// The field.
        key: &'static str,
        /// Why.
        why: String,
    },
    /// A constant could not be converted.
    #[error(transparent)]
    Convert(#[from] ConvertError),
}

/// The CORDIC angle unit of a configuration.
#[derive(Clone, Debug)]
pub struct Angles {
    /// Micro-rotations per angle.
    pub iterations: u32,
    /// Input step (the port format).
    pub normal: Quant,
    /// Micro-rotation coordinates.
    pub xy: Quant,
    /// Format of the gain constant.
    pub gain: Quant,
    /// `K·y` by a multiplier (`false`) or by shifts and additions of the
    /// signed digits of `K_q` (`true`).
    pub shift_add: bool,
    /// Angle accumulator.
    pub theta: Quant,
    /// Output angles.
    pub out: Quant,
}

/// The constants of the datapath in a context.
#[derive(Clone, Debug)]
pub struct Consts<V> {
    /// 0 (a `U1F0` literal): the pre-rotation negates against it.
    pub zero: V,
    /// A quarter turn in the `theta` format.
    pub quarter: V,
    /// `c_i = atan(2^−i)/2π` in the `theta` format.
    pub atan: Vec<V>,
    /// `K_n` in the `gain` format.
    pub gain: V,
}

/// `K_n = ∏_{i<n} √(1 + 2^−2i)`, the length gain of `n` micro-rotations.
pub fn gain(n: u32) -> f64 {
    (0..n)
        .map(|i| (1.0 + (-2.0 * f64::from(i)).exp2()).sqrt())
        .product()
}

/// The canonical signed-digit form of `code`: `(d, e)` pairs with
/// `code = Σ d·2^e`, `d = ±1`, no two exponents adjacent, most significant
/// first (the fewest non-zero digits of any signed-digit form).
pub fn csd(code: i128) -> Vec<(i8, u32)> {
    let mut v = Vec::new();
    let (mut c, mut e) = (code, 0u32);
    while c != 0 {
        if c & 1 == 1 {
            // 01 → +1; 11 → −1 and carry.
            let d: i8 = if c & 3 == 3 { -1 } else { 1 };
            v.push((d, e));
            c -= i128::from(d);
        }
        c >>= 1;
        e += 1;
    }
    v.reverse();
    v
}

/// `atan(2^−i)` as a fraction of a turn.
pub fn atan_turns(i: u32) -> f64 {
    (-f64::from(i)).exp2().atan() / std::f64::consts::TAU
}

fn require_angle(key: &'static str, q: &Quant) -> Result<(), AnglesError> {
    let f = q.format();
    if f.signed() || f.int_bits() != 0 || f.width() > 32 {
        return Err(AnglesError::Config {
            key,
            why: format!("format {f} must be U0F<k> with k ≤ 32: an angle is a fraction of a turn"),
        });
    }
    if q.overflow() != Overflow::Wrap {
        return Err(AnglesError::Config {
            key,
            why: "overflow must be \"wrap\": angles wrap around a turn".into(),
        });
    }
    Ok(())
}

impl Angles {
    /// From the `[angles]` section, with `angle_bits`-bit output angles
    /// (`polar.angle_bits` in a whole configuration).
    ///
    /// # Errors
    ///
    /// [`AnglesError::Config`] naming `theta` or `out` when its overflow mode is not `wrap`,
    /// `theta` also when its format is not `U0F<k>` with `k ≤ 32` (the `out` format is set to
    /// `U0F<angle_bits>`, `angle_bits` clamped to `1..=32`); naming `xy` when its format is
    /// unsigned; naming `gain` when `K_n` of `iterations` micro-rotations overflows the `gain`
    /// format. ([`AnglesError::Convert`] cannot arise: `K_n` is finite.)
    ///
    /// # Panics
    ///
    /// Never: `k` is clamped to `1..=32`, a valid unsigned width.
    pub fn from_config(u: &AnglesConfig, angle_bits: u32) -> Result<Angles, AnglesError> {
        let k = angle_bits.clamp(1, 32);
        let a = Angles {
            iterations: u.iterations,
            normal: u.normal,
            xy: u.xy,
            gain: u.gain,
            shift_add: u.gain_mode == GainMode::ShiftAdd,
            theta: u.theta,
            out: u
                .out
                .with_format(Format::new(false, k, narrow::<i32, _>(k)).expect("1..=32 bits")),
        };
        require_angle("theta", &a.theta)?;
        require_angle("out", &a.out)?;
        if !a.xy.format().signed() {
            return Err(AnglesError::Config {
                key: "xy",
                why: format!(
                    "format {} must be signed: v swings either side of 0",
                    a.xy.format()
                ),
            });
        }
        let k = gain(a.iterations);
        let r = a.gain.apply_f64(k)?;
        if r.overflowed {
            return Err(AnglesError::Config {
                key: "gain",
                why: format!(
                    "the gain K = {k:.6} of {} iterations does not fit {}",
                    a.iterations,
                    a.gain.format()
                ),
            });
        }
        Ok(a)
    }

    /// From a whole configuration: the output format is the polar angle
    /// format `U0F<polar.angle_bits>`.
    ///
    /// # Errors
    ///
    /// As [`Angles::from_config`] on the `[angles]` section of `cfg`, with `polar.angle_bits`
    /// output bits.
    pub fn of(cfg: &Config) -> Result<Angles, AnglesError> {
        let k = cfg.section::<crate::polar::PolarConfig>().angle_bits;
        Self::from_config(&cfg.section(), k)
    }

    /// The constants in a context.
    ///
    /// # Errors
    ///
    /// The [`ConvertError`] of `cx.constant` for a NaN or infinite constant: the quarter turn, the
    /// arctangents and `K_n` are finite, so the contexts of `fxshade-ir` never return one.
    pub fn consts<C: Datapath>(&self, cx: &mut C) -> Result<Consts<C::V>, ConvertError> {
        Ok(Consts {
            zero: cx.constant(0.0, &literal(0))?,
            quarter: cx.constant(0.25, &self.theta)?,
            atan: (0..self.iterations)
                .map(|i| cx.constant(atan_turns(i), &self.theta))
                .collect::<Result<_, _>>()?,
            gain: cx.constant(gain(self.iterations), &self.gain)?,
        })
    }

    /// `n` micro-rotations driving `v` to 0 from the angle `t`; returns
    /// `(u_n, θ_n)`.
    fn vectoring<C: Datapath>(
        &self,
        cx: &mut C,
        k: &Consts<C::V>,
        mut u: C::V,
        mut v: C::V,
        mut t: C::V,
    ) -> (C::V, C::V) {
        for i in 0..self.iterations {
            let du = cx.shl(v, -(narrow::<i32, _>(i)));
            let dv = cx.shl(u, -(narrow::<i32, _>(i)));
            let u2 = cx.add_signed(u, du, v, false);
            let v2 = cx.add_signed(v, dv, v, true);
            let t2 = cx.add_signed(t, k.atan[i as usize], v, false);
            u = cx.quantize(u2, &self.xy);
            v = cx.quantize(v2, &self.xy);
            t = cx.quantize(t2, &self.theta);
        }
        (u, t)
    }

    /// `[α, β]` of the normal `n` (components in the `normal` format, any
    /// length), in the `out` format.
    #[inline]
    pub fn eval<C: Datapath>(&self, cx: &mut C, k: &Consts<C::V>, n: [C::V; 3]) -> [C::V; 2] {
        cx.enter(DECL.name);
        let [x, y, z] = n;
        // Pre-rotation by −90° (x ≥ 0) or +90° (x < 0): (z, x) → (|x|, ∓z).
        let u = cx.add_signed(k.zero, x, x, false);
        let v = cx.add_signed(k.zero, z, x, true);
        let t = cx.add_signed(k.zero, k.quarter, x, false);
        let u = cx.quantize(u, &self.xy);
        let v = cx.quantize(v, &self.xy);
        let t = cx.quantize(t, &self.theta);
        let (r, beta) = self.vectoring(cx, k, u, v, t);
        let ky = if self.shift_add {
            // Σ d_j·y·2^e_j over the signed digits of the gain code.
            let f = self.gain.format();
            let code = self
                .gain
                .apply_f64(gain(self.iterations))
                .map_or(0, |r| r.code);
            let mut acc: Option<C::V> = None;
            for (d, e) in csd(code) {
                let t = cx.shl(y, narrow::<i32, _>(e) - f.frac());
                acc = Some(match acc {
                    None if d > 0 => t,
                    None => cx.sub(k.zero, t),
                    Some(a) if d > 0 => cx.add(a, t),
                    Some(a) => cx.sub(a, t),
                });
            }
            acc.unwrap_or(k.zero)
        } else {
            cx.mul(k.gain, y)
        };
        let ky = cx.quantize(ky, &self.xy);
        let t0 = cx.quantize(k.zero, &self.theta);
        let (_, alpha) = self.vectoring(cx, k, r, ky, t0);
        let a = cx.quantize(alpha, &self.out);
        let b = cx.quantize(beta, &self.out);
        cx.leave();
        [a, b]
    }

    /// The unit traced with named ports: inputs `n_x, n_y, n_z` (normal
    /// format), outputs `alpha`, `beta` (out format).
    ///
    /// # Errors
    ///
    /// A [`ConvertError`] only for a NaN or infinite constant ([`Angles::consts`]), which the
    /// CORDIC constants never are.
    pub fn trace(&self) -> Result<Trace, ConvertError> {
        let mut tr = Trace::new();
        let n = tr.input3("n", &self.normal);
        let k = self.consts(&mut tr)?;
        let [a, b] = self.eval(&mut tr, &k, n);
        tr.output("alpha", a);
        tr.output("beta", b);
        Ok(tr)
    }

    /// Compiled for batches: inputs `n_x, n_y, n_z` codes; outputs α, β.
    ///
    /// # Errors
    ///
    /// [`AnglesError::Config`] naming `xy`, with the
    /// [`CompileError`](crate::datapath::CompileError) as its reason, when the trace does not
    /// compile (an exact intermediate wider than
    /// [`MAX_EXACT_WIDTH`](crate::datapath::MAX_EXACT_WIDTH), or more quantization stages than the
    /// overflow flags hold); [`AnglesError::Convert`] as [`Angles::trace`].
    pub fn compile(&self) -> Result<Compiled, AnglesError> {
        self.trace()?
            .compile_outputs()
            .map_err(|e| AnglesError::Config {
                key: "xy",
                why: e.to_string(),
            })
    }

    /// One counting run.
    ///
    /// # Errors
    ///
    /// As [`Angles::trace`].
    pub fn count(&self) -> Result<Count, ConvertError> {
        let mut cx = Count::new();
        let n = cx.constant(0.0, &self.normal)?;
        let k = self.consts(&mut cx)?;
        self.eval(&mut cx, &k, [n; 3]);
        Ok(cx)
    }

    /// The exact angles `(α, β)` in turns of a vector of any non-zero length
    /// (`α ∈ [−¼, ¼]`, `β ∈ (−½, ½]`): `atan2(y, √(x² + z²))` and
    /// `atan2(x, z)`, as [`crate::polar::angles_of`] but without its pole
    /// convention.
    pub fn exact(n: glam::DVec3) -> (f64, f64) {
        let t = std::f64::consts::TAU;
        (
            n.y.atan2((n.x * n.x + n.z * n.z).sqrt()) / t,
            n.x.atan2(n.z) / t,
        )
    }
}

fn check(cfg: &Config) -> Result<(), Vec<ConfigError>> {
    let u = cfg.unit(DECL.name);
    // The output format follows polar.angle_bits; one written by the user
    // (a file or a flag) must agree with it.
    let k = cfg.section::<crate::polar::PolarConfig>().angle_bits;
    let want = Format::new(false, k, narrow::<i32, _>(k)).expect("1..=24 bits");
    let given = cfg.section::<AnglesConfig>().out.format();
    // Only a format the user wrote counts: the embedded default's, or a flag
    // that sets another field of the stage (`angles.out.round=…`), follows.
    let follows = match u.origin("out") {
        crate::config::Origin::File { path, .. } => &**path == "<default>",
        crate::config::Origin::Flag(f) => !f.contains("format"),
    };
    if given != want && !follows {
        return Err(vec![crate::config::field_error(
            u,
            "out",
            format!(
                "format {given} must be {want}, the polar angle format (polar.angle_bits = {k})"
            ),
        )]);
    }
    let a = Angles::of(cfg).map_err(|e| match e {
        AnglesError::Config { key, why } => vec![crate::config::field_error(u, key, why)],
        AnglesError::Convert(c) => vec![crate::config::field_error(u, "theta", c.to_string())],
    })?;
    let cx = a
        .count()
        .map_err(|e| vec![crate::config::field_error(u, "theta", e.to_string())])?;
    width_errors(&cx, u)
}

fn ops(cfg: &Config) -> Vec<OpReport> {
    let Ok(a) = Angles::of(cfg) else {
        return Vec::new();
    };
    let Ok(cx) = a.count() else {
        return Vec::new();
    };
    let r = OpReport::from_count(
        DECL.name,
        if a.shift_add {
            "cordic, gain by shifts and additions"
        } else {
            "cordic, gain by a multiplier"
        },
        Phase::Pixel,
        &cx,
        None,
    );
    // The last step's coordinates are dead (only the next step would read
    // them): marked so `fxshade stages` says they are not in the RTL.
    vec![match a.trace() {
        Ok(t) => r.with_liveness(&t),
        Err(_) => r,
    }]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datapath::{Fixed, Fx, Reference};
    use glam::DVec3;

    fn unit() -> Angles {
        Angles::of(&Config::embedded()).unwrap()
    }

    /// Turn difference wrapped into [−½, ½).
    fn dturn(a: f64, b: f64) -> f64 {
        (a - b + 0.5).rem_euclid(1.0) - 0.5
    }

    #[test]
    fn signed_digits_sum_to_the_code_and_are_never_adjacent() {
        for c in [0i128, 1, 2, 3, 7, 215_847, 0b1011_0111, 65_535] {
            let d = csd(c);
            assert_eq!(
                d.iter()
                    .map(|&(s, e)| s as i128 * (1i128 << e))
                    .sum::<i128>(),
                c
            );
            assert!(d.windows(2).all(|w| w[0].1 > w[1].1 + 1), "{c}: {d:?}");
        }
        // 7 = 8 − 1: two digits, not three.
        assert_eq!(csd(7), vec![(1, 3), (-1, 0)]);
    }

    #[test]
    fn shift_add_gain_is_bit_identical_to_the_product_and_needs_no_multiplier() {
        let c = Config::resolve(None, &["angles.gain_mode=\"shift_add\"".into()]).unwrap();
        let sa = Angles::of(&c).unwrap();
        let pr = unit();
        let counts = sa.count().unwrap().counts();
        assert_eq!(counts.mul, 0);
        let f = pr.gain.format();
        let code = pr.gain.apply_f64(gain(pr.iterations)).unwrap().code;
        let digits = csd(code).len() as u64;
        let n = pr.iterations as u64;
        assert_eq!(counts.add, 3 + 6 * n + digits - 1, "{f}");
        let (ps, ss) = (pr.compile().unwrap(), sa.compile().unwrap());
        let mut rng = crate::sampling::Rng::new(12);
        let q = |x: f64| pr.normal.apply_f64(x).unwrap().code;
        let mut cols: [Vec<i128>; 3] = Default::default();
        for _ in 0..20_000 {
            let d = rng.direction() * (0.9 + 0.2 * rng.unit());
            for k in 0..3 {
                cols[k].push(q(d[k]));
            }
        }
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        assert_eq!(ps.run_i128(&refs).0, ss.run_i128(&refs).0);
    }

    #[test]
    fn the_gain_is_the_product_of_the_micro_rotation_lengths() {
        // K_∞ = 1.646760258…, a closed form's limit.
        assert!((gain(40) - 1.646_760_258_121_065_6).abs() < 1e-12);
        assert_eq!(gain(1), 2f64.sqrt());
        // atan(1) is an eighth of a turn.
        assert!((atan_turns(0) - 0.125).abs() < 1e-15);
    }

    #[test]
    fn in_f64_the_datapath_converges_to_atan2() {
        let a = unit();
        let k = a.consts(&mut Reference).unwrap();
        let mut rng = crate::sampling::Rng::new(4);
        let bound = atan_turns(a.iterations - 1) * 2.0;
        for _ in 0..2000 {
            let d = rng.direction() * (0.5 + rng.unit());
            let [al, be] = a.eval(&mut Reference, &k, d.to_array());
            let (ea, eb) = Angles::exact(d);
            assert!(dturn(al, ea).abs() <= bound, "{d} α {al} vs {ea}");
            assert!(dturn(be, eb).abs() <= bound, "{d} β {be} vs {eb}");
        }
    }

    fn run(a: &Angles, n: DVec3) -> (f64, f64, i128, i128) {
        let mut fx = Fixed::<i128>::new();
        let k = a.consts(&mut fx).unwrap();
        let f = a.normal.format();
        let c = |x: f64| Fx::<i128>::from_code(a.normal.apply_f64(x).unwrap().code, f);
        let [al, be] = a.eval(&mut fx, &k, [c(n.x), c(n.y), c(n.z)]);
        let turn = (1u64 << a.out.format().width()) as f64;
        (
            al.code() as f64 / turn,
            be.code() as f64 / turn,
            al.code(),
            be.code(),
        )
    }

    #[test]
    fn bit_accurate_angles_are_within_a_least_significant_bit() {
        let a = unit();
        let lsb = 1.0 / (1u64 << a.out.format().width()) as f64;
        let mut rng = crate::sampling::Rng::new(8);
        for _ in 0..5000 {
            let d = rng.direction() * (0.97 + 0.06 * rng.unit());
            let (al, be, _, _) = run(&a, d);
            let (ea, eb) = Angles::exact(d);
            assert!(dturn(al, ea).abs() <= lsb, "{d}: α {al} vs {ea}");
            let far_from_pole = d.x.hypot(d.z) > 0.02;
            if far_from_pole {
                assert!(dturn(be, eb).abs() <= lsb, "{d}: β {be} vs {eb}");
            }
        }
    }

    #[test]
    fn defined_results_at_the_seam_the_poles_and_zero() {
        let a = unit();
        let kk = a.out.format().width();
        let half = 1i128 << (kk - 1);
        // β wraps at ±180°: just either side of half a turn.
        let (_, _, _, b1) = run(&a, DVec3::new(1e-3, 0.0, -1.0));
        let (_, _, _, b2) = run(&a, DVec3::new(-1e-3, 0.0, -1.0));
        assert!(
            (b1 - half).abs() <= 1 && (b2 - half).abs() <= 1,
            "{b1} {b2}"
        );
        // Axes.
        let q = 1i128 << (kk - 2);
        assert_eq!(run(&a, DVec3::Z).3, 0);
        assert_eq!(run(&a, DVec3::X).3, q);
        assert_eq!(run(&a, -DVec3::X).3, 3 * q);
        assert_eq!(run(&a, -DVec3::Z).3, 2 * q);
        assert_eq!(run(&a, DVec3::Z).2, 0);
        // Poles: α = ±¼ exactly; β = ¼ + Σ c_i (every σ = +1), in turns.
        let sum: f64 = 0.25 + (0..a.iterations).map(atan_turns).sum::<f64>();
        let want_b = || {
            let t = a.theta.format();
            let codes: i128 = (0..a.iterations)
                .map(|i| a.theta.apply_f64(atan_turns(i)).unwrap().code)
                .sum::<i128>()
                + a.theta.apply_f64(0.25).unwrap().code;
            let turn_t = 1i128 << t.width();
            a.out.apply(codes.rem_euclid(turn_t), t.frac()).code
        };
        for y in [1.0, -1.0] {
            let (_, _, ac, bc) = run(&a, DVec3::new(0.0, y, 0.0));
            assert_eq!(ac, if y > 0.0 { q } else { 3 * q });
            assert_eq!(bc, want_b());
            assert!((bc as f64 / (4 * q) as f64 - sum.rem_euclid(1.0)).abs() < 1e-3);
        }
        // The zero vector: α = Σ c_i, β as at the poles.
        let (_, _, ac, bc) = run(&a, DVec3::ZERO);
        let t = a.theta.format();
        let asum: i128 = (0..a.iterations)
            .map(|i| a.theta.apply_f64(atan_turns(i)).unwrap().code)
            .sum();
        assert_eq!(ac, a.out.apply(asum, t.frac()).code);
        assert_eq!(bc, want_b());
    }

    #[test]
    fn counts_are_shifts_and_additions_with_one_constant_product() {
        let a = unit();
        let c = a.count().unwrap().counts();
        let n = a.iterations as u64;
        assert_eq!(c.mul, 1);
        assert_eq!(c.add, 3 + 6 * n);
        assert_eq!(c.shift, 4 * n);
        assert_eq!((c.div, c.sqrt, c.table_read), (0, 0, 0));
    }

    #[test]
    fn config_check_names_the_key() {
        let bad = Config::resolve(None, &["angles.theta.overflow=\"saturate\"".into()]);
        let e = bad.unwrap_err().to_string();
        assert!(e.contains("angles.theta") && e.contains("wrap"), "{e}");
        let bad = Config::resolve(None, &["angles.out.format=\"U0F12\"".into()]);
        let e = bad.unwrap_err().to_string();
        assert!(e.contains("angles.out") && e.contains("polar"), "{e}");
        let bad = Config::resolve(None, &["angles.gain.format=\"U0F16\"".into()]);
        let e = bad.unwrap_err().to_string();
        assert!(e.contains("angles.gain"), "{e}");
    }
}
