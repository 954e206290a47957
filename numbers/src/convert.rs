//! Named numeric conversions, for the places where a conversion is not
//! lossless (`From`) and a bare `as` would hide what it does. Each states
//! its exact behaviour, so a reader knows what happens at the edges:
//!
//! * [`to_f64`] — an integer (a count, a code, a sum) as the nearest `f64`;
//! * [`from_f64`] — an `f64` (a rounded coordinate, a floored bound) as an
//!   integer, toward zero and saturating, as Rust's `as` does;
//! * [`narrow`] — an integer into a narrower or differently signed type
//!   when its value fits by construction; checked, so a broken invariant
//!   is a panic naming the value instead of a silently wrapped number.
//!
//! Deliberate bit reinterpretations (a two's-complement pattern read as
//! unsigned, the low bits of a word) are not here: they are written as
//! `cast_unsigned`, `cast_signed`, masks, or an `as` allowed where it
//! stands with its reason.
//!
//! ```
//! use fxshade_numbers::convert::{from_f64, narrow, to_f64};
//! assert_eq!(to_f64(3_usize), 3.0);
//! assert_eq!(to_f64((1_u64 << 53) + 1), 9_007_199_254_740_992.0); // ties to even
//! assert_eq!(from_f64::<u8>(255.9), 255);
//! assert_eq!(from_f64::<u8>(300.0), 255); // saturates
//! assert_eq!(from_f64::<i64>(-2.7), -2); // toward zero
//! assert_eq!(from_f64::<u32>(f64::NAN), 0);
//! assert_eq!(narrow::<u32, usize>(7), 7_u32);
//! ```

/// An integer type with a nearest-`f64` value ([`to_f64`]).
pub trait ToF64: Copy {
    /// `self` rounded to the nearest `f64`, ties to even (exact when
    /// `|self| ≤ 2^53`).
    fn to_f64(self) -> f64;
}

/// An integer type an `f64` converts into by [`from_f64`].
pub trait FromF64: Copy {
    /// `x` rounded toward zero and saturated to the type's range; NaN
    /// gives 0.
    fn from_f64(x: f64) -> Self;
}

macro_rules! float_conversions {
    ($($t:ty),*) => {$(
        impl ToF64 for $t {
            #[allow(clippy::cast_precision_loss, reason = "the documented rounding to nearest")]
            #[allow(clippy::cast_lossless, reason = "one body for every width")]
            fn to_f64(self) -> f64 {
                self as f64
            }
        }
        impl FromF64 for $t {
            #[allow(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "the documented saturating conversion toward zero"
            )]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
        }
    )*};
}

float_conversions!(u8, u16, u32, u64, u128, usize, i8, i16, i32, i64, i128, isize);

/// `x` as the nearest `f64`, ties to even: exact for `|x| ≤ 2^53` (every
/// count and code fxshade converts is far below), else the nearest.
pub fn to_f64<T: ToF64>(x: T) -> f64 {
    x.to_f64()
}

/// `x` rounded to the nearest integer, ties away from zero: the value of
/// [`f64::round`], sign of zero included, NaN and ±∞ returned as they are.
/// Written with a conversion to `i64` (`|x| < 2^52`, where `x − trunc(x)`
/// is exact) so that it inlines on every x86-64 (`f64::round` is a call
/// into libm without SSE4.1); a unit test holds it equal to `f64::round`.
/// Branch-free (a select, not an early return), so that a loop over it
/// vectorizes.
#[inline]
pub fn round_half_away(x: f64) -> f64 {
    // (For NaN and |x| ≥ 2^63 the conversion saturates and the sum below
    // wraps; both are discarded by the select.)
    let t = from_f64::<i64>(x);
    let d = x - to_f64(t);
    let up = t
        .wrapping_add(i64::from(d >= 0.5))
        .wrapping_sub(i64::from(d <= -0.5));
    let r = to_f64(up).copysign(x);
    // 2^52: at and above it every f64 is an integer.
    if x.is_nan() || x.abs() >= 4_503_599_627_370_496.0 {
        x
    } else {
        r
    }
}

/// `x` rounded toward zero, saturated to `T`'s range, NaN as 0 (Rust's
/// `as`): round first (`x.round()`, `x.floor()`) for another rounding.
pub fn from_f64<T: FromF64>(x: f64) -> T {
    T::from_f64(x)
}

/// `x` as a `T` when its value fits, which the caller knows by
/// construction (a width of at most 128 as an `i32`, a non-negative index
/// as a `usize`).
///
/// # Panics
///
/// When `x` does not fit `T`, naming the value: an invariant the caller
/// relied on is broken.
#[track_caller]
pub fn narrow<T, U>(x: U) -> T
where
    U: Copy + std::fmt::Display,
    T: TryFrom<U>,
{
    match T::try_from(x) {
        Ok(v) => v,
        Err(_) => panic!("{x} does not fit {}", std::any::type_name::<T>()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `round_half_away` is `f64::round`, bit for bit (the sign of zero
    /// too), at ties, one ulp either side of them, around 2^52, for NaN,
    /// infinities and random bit patterns.
    #[test]
    fn round_half_away_is_f64_round() {
        let mut xs = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            0.499_999_999_999_999_94,
            -0.499_999_999_999_999_94,
            2.5,
            -2.5,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            9.0e18,
            -9.3e18,
            1e300,
            f64::MIN_POSITIVE,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        for k in -3000..3000 {
            let x = f64::from(k) * 0.25;
            xs.extend([x, x.next_up(), x.next_down()]);
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            xs.push(f64::from_bits(state));
            xs.push(f64::from_bits(state) * 1e-300);
        }
        for x in xs {
            let (got, want) = (round_half_away(x), x.round());
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "{x:e}: {got:e} against {want:e}"
            );
        }
        assert!(round_half_away(f64::NAN).is_nan());
    }

    #[test]
    fn each_conversion_behaves_as_documented_at_its_edges() {
        assert_eq!(to_f64(i128::MIN), -(2f64.powi(127)));
        assert_eq!(to_f64(-5_i64), -5.0);
        assert_eq!(from_f64::<i128>(-1e40), i128::MIN);
        assert_eq!(from_f64::<usize>(-3.0), 0);
        assert_eq!(from_f64::<u16>(f64::INFINITY), u16::MAX);
        assert_eq!(narrow::<i32, u32>(128), 128);
        assert_eq!(narrow::<usize, i128>(0), 0);
    }

    #[test]
    #[should_panic(expected = "-1 does not fit usize")]
    fn narrowing_a_value_that_does_not_fit_panics_with_it() {
        let _: usize = narrow(-1_i64);
    }
}
