//! Property tests of the fixed-point arithmetic against two independent
//! oracles: exact rational arithmetic (`num-rational` over big integers) and
//! the `fixed` crate, for the formats it can express.

use fixed::types::{I16F16, I8F24, U0F16};
use fxshade_model::datapath::{Datapath, Fixed, Fx};
use fxshade_model::format::Format;
use fxshade_model::quantize::{Overflow, Quant, Rounding};
use num_bigint::BigInt;
use num_rational::BigRational;
use num_traits::{One, ToPrimitive, Zero};
use proptest::prelude::*;

fn pow2(e: i32) -> BigRational {
    let two = BigRational::from_integer(BigInt::from(2));
    if e >= 0 {
        num_traits::pow(two, e as usize)
    } else {
        BigRational::one() / num_traits::pow(two, (-e) as usize)
    }
}

/// Round a rational to an integer by `mode`, from first principles.
fn round_rational(x: &BigRational, mode: Rounding) -> BigInt {
    let fl = x.floor().to_integer();
    let frac = x - BigRational::from_integer(fl.clone());
    let half = BigRational::new(BigInt::one(), BigInt::from(2));
    match mode {
        Rounding::Trunc => fl,
        Rounding::HalfUp => {
            if frac >= half {
                fl + 1
            } else {
                fl
            }
        }
        Rounding::HalfEven => {
            if frac > half || (frac == half && (&fl % 2) != BigInt::zero()) {
                fl + 1
            } else {
                fl
            }
        }
    }
}

/// Range step by definition: wrap is the residue mod 2^W in the code range,
/// saturate the clamp.
fn range_step(r: BigInt, f: &Format, ov: Overflow) -> (i128, bool) {
    let min = BigInt::from(f.min_code());
    let max = BigInt::from(f.max_code());
    if r >= min && r <= max {
        return (r.to_i128().unwrap(), false);
    }
    let code = match ov {
        Overflow::Saturate => {
            if r < min {
                min
            } else {
                max
            }
        }
        Overflow::Wrap => {
            let m = BigInt::one() << f.width();
            let mut c = ((r - &min) % &m + &m) % &m + &min;
            if c > max {
                c -= m;
            }
            c
        }
    };
    (code.to_i128().unwrap(), true)
}

fn oracle_quantize(raw: i128, frac: i32, q: &Quant) -> (i128, bool) {
    let x = BigRational::from_integer(BigInt::from(raw)) * pow2(-frac);
    let scaled = x * pow2(q.format().frac());
    range_step(
        round_rational(&scaled, q.round()),
        &q.format(),
        q.overflow(),
    )
}

fn arb_format() -> impl Strategy<Value = Format> {
    (any::<bool>(), 1u32..=64, -64i32..=128).prop_map(|(s, w, f)| Format::new(s, w, f).unwrap())
}
fn arb_round() -> impl Strategy<Value = Rounding> {
    prop::sample::select(Rounding::ALL.to_vec())
}
fn arb_overflow() -> impl Strategy<Value = Overflow> {
    prop::sample::select(Overflow::ALL.to_vec())
}
fn arb_quant() -> impl Strategy<Value = Quant> {
    (arb_format(), arb_round(), arb_overflow()).prop_map(|(f, r, o)| Quant::new("p", f, r, o))
}
/// Raw values of every magnitude up to 2^125, with small ones and exact ties
/// well represented.
fn arb_raw() -> impl Strategy<Value = i128> {
    prop_oneof![
        -1000i128..1000,
        (any::<i64>(), 0u32..62).prop_map(|(m, s)| i128::from(m) << s),
        any::<i128>().prop_map(|x| x >> 3),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    #[test]
    fn quantize_agrees_with_exact_rationals(raw in arb_raw(), frac in -80i32..200, q in arb_quant()) {
        let got = q.apply(raw, frac);
        let (code, ov) = oracle_quantize(raw, frac, &q);
        prop_assert_eq!((got.code, got.overflowed), (code, ov));
    }

    #[test]
    fn from_f64_is_exact_rounding(x in any::<f64>().prop_filter("finite", |x| x.is_finite()), q in arb_quant()) {
        let got = q.apply_f64(x).unwrap();
        // Every finite f64 is a dyadic rational: BigRational::from_float is exact.
        let xr = BigRational::from_float(x).unwrap();
        let scaled = xr * pow2(q.format().frac());
        let (code, ov) = range_step(round_rational(&scaled, q.round()), &q.format(), q.overflow());
        prop_assert_eq!((got.code, got.overflowed), (code, ov));
    }

    #[test]
    fn div_is_correctly_rounded(a in -1_000_000i128..1_000_000, b in -5000i128..5000, fa in -8i32..30, fb in -8i32..30, q in arb_quant()) {
        prop_assume!(b != 0);
        let mut cx = Fixed::<i128>::new();
        let got = cx.div(Fx { raw: a, frac: fa }, Fx { raw: b, frac: fb }, &q);
        let x = BigRational::new(BigInt::from(a), BigInt::from(b)) * pow2(fb - fa) * pow2(q.format().frac());
        let (code, ov) = range_step(round_rational(&x, q.round()), &q.format(), q.overflow());
        prop_assert_eq!(got.raw, code);
        prop_assert_eq!(cx.total_overflows(), u64::from(ov));
    }

    #[test]
    fn sqrt_is_correctly_rounded(a in 0i128..(1i128 << 90), fa in -20i32..80, q in arb_quant()) {
        let mut cx = Fixed::<i128>::new();
        let got = cx.sqrt(Fx { raw: a, frac: fa }, &q);
        // X = value·2^(2F); the candidate r is right when it brackets √X:
        // trunc: r² ≤ X < (r+1)²; nearest: (r−½)² ≤ X ≤ (r+½)², ties by mode.
        let xr = BigRational::from_integer(BigInt::from(a)) * pow2(2 * q.format().frac() - fa);
        let r0 = xr.floor().to_integer().sqrt();
        let half = BigRational::new(BigInt::one(), BigInt::from(2));
        let mut best = None;
        for cand in [r0.clone(), &r0 + 1] {
            let r = BigRational::from_integer(cand.clone());
            let even = (&cand % 2u32).is_zero();
            let ok = match q.round() {
                Rounding::Trunc => &r * &r <= xr && (&r + BigRational::one()) * (&r + BigRational::one()) > xr,
                _ => {
                    let lo = &r - &half;
                    let hi = &r + &half;
                    let tie_ok = q.round() == Rounding::HalfUp || even;
                    let lo_ok = cand.is_zero() || if q.round() == Rounding::HalfUp || even { &lo * &lo <= xr } else { &lo * &lo < xr };
                    let hi_ok = if tie_ok && q.round() != Rounding::HalfUp { &hi * &hi >= xr } else { &hi * &hi > xr };
                    lo_ok && hi_ok
                }
            };
            if ok { best = Some(cand); break; }
        }
        let want = best.expect("some candidate brackets the root");
        // Documented limit: when 4X reaches 2^128 (√X ≥ 2^63) the result
        // saturates to the format's largest code in either overflow mode and
        // counts as an overflow (only U64 could have held such a root).
        let beyond = xr * BigRational::from_integer(BigInt::from(4)) >= pow2(128);
        let (code, ov) = if beyond {
            (q.format().max_code(), true)
        } else {
            range_step(want, &q.format(), q.overflow())
        };
        prop_assert_eq!(got.raw, code);
        prop_assert_eq!(cx.total_overflows(), u64::from(ov));
    }
}

// ---- the `fixed` crate as an oracle ----------------------------------------

fn fmt(s: &str) -> Format {
    s.parse().unwrap()
}

/// Multiply exactly, then quantize to the operand format with truncation:
/// `fixed`'s multiplication rounds toward −∞ the same way.
fn mul_q(a: i128, b: i128, f: Format, ov: Overflow) -> i128 {
    let mut cx = Fixed::<i128>::new();
    let q = Quant::new("m", f, Rounding::Trunc, ov);
    let p = cx.mul(Fx::from_code(a, f), Fx::from_code(b, f));
    cx.quantize(p, &q).raw
}
fn add_q(a: i128, b: i128, f: Format, sub: bool) -> i128 {
    let mut cx = Fixed::<i128>::new();
    let q = Quant::new("a", f, Rounding::Trunc, Overflow::Wrap);
    let (x, y) = (Fx::from_code(a, f), Fx::from_code(b, f));
    let s = if sub { cx.sub(x, y) } else { cx.add(x, y) };
    cx.quantize(s, &q).raw
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    #[test]
    fn i16f16_ops_agree_with_fixed(a in any::<i32>(), b in any::<i32>()) {
        let f = fmt("I16F16");
        let (x, y) = (I16F16::from_bits(a), I16F16::from_bits(b));
        prop_assert_eq!(mul_q(i128::from(a), i128::from(b), f, Overflow::Wrap), i128::from(x.wrapping_mul(y).to_bits()));
        prop_assert_eq!(mul_q(i128::from(a), i128::from(b), f, Overflow::Saturate), i128::from(x.saturating_mul(y).to_bits()));
        prop_assert_eq!(add_q(i128::from(a), i128::from(b), f, false), i128::from(x.wrapping_add(y).to_bits()));
        prop_assert_eq!(add_q(i128::from(a), i128::from(b), f, true), i128::from(x.wrapping_sub(y).to_bits()));
    }

    #[test]
    fn i8f24_ops_agree_with_fixed(a in any::<i32>(), b in any::<i32>()) {
        let f = fmt("I8F24");
        let (x, y) = (I8F24::from_bits(a), I8F24::from_bits(b));
        prop_assert_eq!(mul_q(i128::from(a), i128::from(b), f, Overflow::Wrap), i128::from(x.wrapping_mul(y).to_bits()));
        prop_assert_eq!(mul_q(i128::from(a), i128::from(b), f, Overflow::Saturate), i128::from(x.saturating_mul(y).to_bits()));
        prop_assert_eq!(add_q(i128::from(a), i128::from(b), f, true), i128::from(x.wrapping_sub(y).to_bits()));
    }

    #[test]
    fn u0f16_ops_agree_with_fixed(a in any::<u16>(), b in any::<u16>()) {
        let f = fmt("U0F16");
        let (x, y) = (U0F16::from_bits(a), U0F16::from_bits(b));
        prop_assert_eq!(mul_q(i128::from(a), i128::from(b), f, Overflow::Wrap), i128::from(x.wrapping_mul(y).to_bits()));
        prop_assert_eq!(add_q(i128::from(a), i128::from(b), f, false), i128::from(x.wrapping_add(y).to_bits()));
        prop_assert_eq!(add_q(i128::from(a), i128::from(b), f, true), i128::from(x.wrapping_sub(y).to_bits()));
    }

    #[test]
    fn format_conversions_agree_with_fixed(a in any::<i32>()) {
        // I8F24 -> I16F16 drops 8 fraction bits (toward −∞) and cannot overflow.
        let x = I8F24::from_bits(a);
        let q = Quant::new("c", fmt("I16F16"), Rounding::Trunc, Overflow::Wrap);
        prop_assert_eq!(q.apply(i128::from(a), 24).code, i128::from(I16F16::from_num(x).to_bits()));
        // I16F16 -> I8F24 may overflow: wrapping and saturating.
        let y = I16F16::from_bits(a);
        let w = Quant::new("c", fmt("I8F24"), Rounding::Trunc, Overflow::Wrap);
        let s = Quant::new("c", fmt("I8F24"), Rounding::Trunc, Overflow::Saturate);
        prop_assert_eq!(w.apply(i128::from(a), 16).code, i128::from(I8F24::wrapping_from_num(y).to_bits()));
        prop_assert_eq!(s.apply(i128::from(a), 16).code, i128::from(I8F24::saturating_from_num(y).to_bits()));
        // Round to an integer, ties to even, in I16F16.
        let e = Quant::new("c", fmt("I16F0"), Rounding::HalfEven, Overflow::Wrap);
        prop_assert_eq!(e.apply(i128::from(a), 16).code << 16, i128::from(y.wrapping_round_ties_even().to_bits()));
    }

    #[test]
    fn from_f64_agrees_with_fixed(x in -40000.0f64..40000.0) {
        // `fixed` converts floats rounding to nearest, ties to even.
        let f = fmt("I16F16");
        let ours = f.from_f64(x, Rounding::HalfEven).ok();
        let theirs = I16F16::checked_from_num(x).map(|v| i128::from(v.to_bits()));
        prop_assert_eq!(ours, theirs);
    }
}

#[test]
fn signed_zero_and_negative_edges() {
    let f = fmt("I16F16");
    assert_eq!(f.from_f64(-0.0, Rounding::Trunc), Ok(0));
    assert_eq!(
        f.from_f64(-32768.0, Rounding::Trunc).unwrap(),
        i128::from(I16F16::MIN.to_bits())
    );
}
