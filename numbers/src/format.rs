//! Fixed-point formats: signedness, total width and fraction bits.
//!
//! A value in format `Format { signed, width, frac }` is stored as an integer
//! *code* `c` (two's complement when signed) and means `c · 2^−frac`.
//!
//! | format        | code range                       | value range                          |
//! |---------------|----------------------------------|--------------------------------------|
//! | signed `W,F`  | `−2^(W−1) ..= 2^(W−1) − 1`       | `−2^(W−1−F) ..= 2^(W−1−F) − 2^−F`    |
//! | unsigned `W,F`| `0 ..= 2^W − 1`                  | `0 ..= 2^(W−F) − 2^−F`               |
//!
//! Formats are written `I<int>F<frac>` (signed) or `U<int>F<frac>` (unsigned),
//! as the `fixed` crate names its types: `I2F14` is signed, 16 bits wide,
//! 14 of them fraction bits (the sign bit counts as an integer bit);
//! `U0F16` is an unsigned pure fraction; `I8F0` a signed byte. Either part may
//! be negative (`U-2F18`: 16 bits, values below 2^−2), so pure-integer and
//! pure-fraction formats, and formats whose point lies outside the word, are
//! all expressible.

use std::fmt;
use std::str::FromStr;

use crate::quantize::{Overflow, Rounding};

/// Widest storage format: codes of any format fit in 64 bits.
pub const MAX_WIDTH: u32 = 64;
/// Smallest accepted number of fraction bits.
pub const MIN_FRAC: i32 = -64;
/// Largest accepted number of fraction bits.
pub const MAX_FRAC: i32 = 128;

/// A fixed-point format. Construct with [`Format::new`] or by parsing
/// `I<int>F<frac>` / `U<int>F<frac>`; the fields are validated, so every
/// `Format` value has `1 ≤ width ≤ 64` and `−64 ≤ frac ≤ 128`.
///
/// The normals' default format, `I2F14`: 16 bits, two's complement, codes
/// `−2^15 ..= 2^15 − 1` meaning `code · 2^−14`, so values `−2 ..= 2 − 2^−14`:
///
/// ```
/// use fxshade_numbers::format::Format;
/// let f: Format = "I2F14".parse().unwrap();
/// assert_eq!(f, Format::new(true, 16, 14).unwrap());
/// assert_eq!((f.min_code(), f.max_code()), (-32768, 32767));
/// assert_eq!(f.to_f64(16384), 1.0);
/// assert_eq!(f.max_value(), 2.0 - 2f64.powi(-14));
/// // Codes travel as their two's-complement bits (vector files, Verilog).
/// assert_eq!(f.to_bits(-1), 0xffff);
/// assert_eq!(f.from_bits(0x8000), -32768);
/// assert_eq!(f.to_string(), "I2F14");
/// ```
///
/// A constant is a value in a format too: 1.0 does not fit `U0F16`, whose
/// largest value is `1 − 2^−16`; a code outside the range wraps to the low
/// `width` bits:
///
/// ```
/// use fxshade_numbers::format::Format;
/// use fxshade_numbers::quantize::Rounding;
/// let u: Format = "U0F16".parse().unwrap();
/// assert_eq!(u.ulp(), 2f64.powi(-16));
/// assert!(!u.contains(65536)); // 1.0
/// assert_eq!(u.wrap(65536), 0);
/// assert!(u.from_f64(1.0, Rounding::Trunc).is_err());
/// assert_eq!(u.from_f64(0.5, Rounding::Trunc), Ok(32768));
/// // A width outside 1..=64 is refused.
/// assert!(Format::new(false, 65, 0).is_err());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Format {
    signed: bool,
    width: u32,
    frac: i32,
}

/// Why a format or a conversion was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FormatError {
    /// Width outside `1..=64`.
    #[error("width {0} is outside 1..=64")]
    Width(i64),
    /// Fraction bits outside `-64..=128`.
    #[error("{0} fraction bits is outside -64..=128")]
    Frac(i64),
    /// The text is not `I<int>F<frac>` or `U<int>F<frac>`.
    #[error("`{0}` is not a format; write I<int>F<frac> (signed) or U<int>F<frac> (unsigned), e.g. I2F14 or U0F16")]
    Syntax(String),
}

/// Why an f64 could not be converted to a code.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConvertError {
    /// The input was NaN.
    #[error("NaN has no fixed-point value")]
    NaN,
    /// The input was ±∞.
    #[error("{0} has no fixed-point value")]
    Infinite(f64),
    /// The rounded value lies outside the format's range.
    #[error("{value} is outside the range of {format} [{min}, {max}]")]
    OutOfRange {
        /// The input.
        value: f64,
        /// The target format.
        format: Format,
        /// Smallest representable value.
        min: f64,
        /// Largest representable value.
        max: f64,
    },
}

/// `2^e` as an f64: exact for `−1074 ≤ e ≤ 1023` (subnormals included),
/// `0` below and `+∞` above.
pub fn exp2i(e: i32) -> f64 {
    if (-1022..=1023).contains(&e) {
        // `e + 1023` is in `1..=2046` here: the biased exponent field.
        f64::from_bits(u64::from((e + 1023).unsigned_abs()) << 52)
    } else if (-1074..-1022).contains(&e) {
        f64::from_bits(1u64 << (e + 1074))
    } else if e < 0 {
        0.0
    } else {
        f64::INFINITY
    }
}

impl Format {
    /// A validated format: `signed`, `width` total bits (sign included),
    /// `frac` fraction bits.
    ///
    /// # Errors
    ///
    /// [`FormatError::Width`] for a width outside `1..=64`,
    /// [`FormatError::Frac`] for fraction bits outside `MIN_FRAC..=MAX_FRAC`.
    pub fn new(signed: bool, width: u32, frac: i32) -> Result<Self, FormatError> {
        if width == 0 || width > MAX_WIDTH {
            return Err(FormatError::Width(i64::from(width)));
        }
        if !(MIN_FRAC..=MAX_FRAC).contains(&frac) {
            return Err(FormatError::Frac(i64::from(frac)));
        }
        Ok(Format {
            signed,
            width,
            frac,
        })
    }

    /// A signed integer format of `width` bits (`I<width>F0`), usable in
    /// constants; panics at compile time for a width outside `1..=64`.
    ///
    /// # Panics
    ///
    /// For a width outside `1..=64` (at compile time in a constant).
    pub const fn signed_int(width: u32) -> Self {
        assert!(width >= 1 && width <= MAX_WIDTH, "width outside 1..=64");
        Format {
            signed: true,
            width,
            frac: 0,
        }
    }

    /// Signed (two's complement) or unsigned.
    pub const fn signed(&self) -> bool {
        self.signed
    }
    /// Total width in bits, sign included.
    pub const fn width(&self) -> u32 {
        self.width
    }
    /// Number of fraction bits `F`: a code `c` means `c · 2^−F`.
    pub const fn frac(&self) -> i32 {
        self.frac
    }
    /// Integer bits, sign included: `width − frac` (may be negative).
    pub const fn int_bits(&self) -> i32 {
        // `width ≤ 64`: the reinterpretation is the value.
        self.width.cast_signed() - self.frac
    }
    /// Smallest code: `−2^(W−1)` signed, `0` unsigned.
    pub const fn min_code(&self) -> i128 {
        if self.signed {
            -(1i128 << (self.width - 1))
        } else {
            0
        }
    }
    /// Largest code: `2^(W−1) − 1` signed, `2^W − 1` unsigned.
    pub const fn max_code(&self) -> i128 {
        if self.signed {
            (1i128 << (self.width - 1)) - 1
        } else {
            (1i128 << self.width) - 1
        }
    }
    /// The weight of one LSB, `2^−frac`.
    pub fn ulp(&self) -> f64 {
        exp2i(-self.frac)
    }
    /// Smallest representable value.
    pub fn min_value(&self) -> f64 {
        self.to_f64(self.min_code())
    }
    /// Largest representable value.
    pub fn max_value(&self) -> f64 {
        self.to_f64(self.max_code())
    }
    /// The value of a code, `code · 2^−frac` (exact when the code has at most
    /// 53 significant bits, otherwise rounded to nearest as `i128 as f64` does).
    #[allow(
        clippy::cast_precision_loss,
        reason = "the documented rounding: i128 to the nearest f64"
    )]
    pub fn to_f64(&self, code: i128) -> f64 {
        // The same rounding from `i64` (a hardware conversion) as from
        // `i128` (a software one) for every code that fits.
        let c = match i64::try_from(code) {
            Ok(c) => c as f64,
            Err(_) => code as f64,
        };
        c * exp2i(-self.frac)
    }
    /// Whether a code lies in `min_code ..= max_code`.
    pub const fn contains(&self, code: i128) -> bool {
        code >= self.min_code() && code <= self.max_code()
    }
    /// Two's-complement wrap of any integer into the format: keeps the low
    /// `width` bits and sign-extends them when signed (Verilog: `y = x[W-1:0]`).
    pub const fn wrap(&self, code: i128) -> i128 {
        let sh = 128 - self.width;
        if self.signed {
            (code << sh) >> sh
        } else {
            (code.cast_unsigned() << sh >> sh).cast_signed()
        }
    }
    /// The code as `width` raw bits (what a `$readmemh` file holds).
    #[allow(
        clippy::cast_possible_truncation,
        reason = "masked to width ≤ 64 bits first: the value fits u64"
    )]
    pub const fn to_bits(&self, code: i128) -> u64 {
        (code.cast_unsigned() & ((1u128 << self.width) - 1)) as u64
    }
    /// The code from `width` raw bits (sign-extended when signed); bits above
    /// `width` are ignored.
    pub const fn from_bits(&self, bits: u64) -> i128 {
        self.wrap(bits as i128)
    }
    /// Hex digits needed for `width` bits.
    pub const fn hex_digits(&self) -> usize {
        self.width.div_ceil(4) as usize
    }

    /// Convert an f64 to the nearest code under `round` (on the grid
    /// `2^−frac`), with an error for NaN, ±∞ or a result outside the range.
    /// `Trunc` takes the floor, `HalfUp` rounds ties toward +∞, `HalfEven`
    /// rounds ties to the even code. Exact: no double rounding.
    ///
    /// # Errors
    ///
    /// [`ConvertError::NaN`], [`ConvertError::Infinite`], or
    /// [`ConvertError::OutOfRange`] when the rounded value is outside the format.
    pub fn from_f64(&self, x: f64, round: Rounding) -> Result<i128, ConvertError> {
        let q = crate::quantize::Quant::new("from_f64", *self, round, Overflow::Saturate);
        let r = q.apply_f64(x)?;
        if r.overflowed {
            return Err(ConvertError::OutOfRange {
                value: x,
                format: *self,
                min: self.min_value(),
                max: self.max_value(),
            });
        }
        Ok(r.code)
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = if self.signed { 'I' } else { 'U' };
        write!(f, "{s}{}F{}", self.int_bits(), self.frac)
    }
}

impl FromStr for Format {
    type Err = FormatError;
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let syntax = || FormatError::Syntax(text.to_string());
        let t = text.trim();
        let signed = match t.chars().next() {
            Some('I') | Some('i') => true,
            Some('U') | Some('u') => false,
            _ => return Err(syntax()),
        };
        let rest = &t[1..];
        let (int, frac) = rest.split_once(['F', 'f']).ok_or_else(syntax)?;
        let int: i64 = int.parse().map_err(|_| syntax())?;
        let frac: i64 = frac.parse().map_err(|_| syntax())?;
        if !(i64::from(MIN_FRAC)..=i64::from(MAX_FRAC)).contains(&frac) {
            return Err(FormatError::Frac(frac));
        }
        let width = int + frac;
        if !(1..=i64::from(MAX_WIDTH)).contains(&width) {
            return Err(FormatError::Width(width));
        }
        // Both range-checked above: `1..=MAX_WIDTH` and `MIN_FRAC..=MAX_FRAC`.
        let width = u32::try_from(width).map_err(|_| FormatError::Width(width))?;
        let frac = i32::try_from(frac).map_err(|_| FormatError::Frac(frac))?;
        Format::new(signed, width, frac)
    }
}

impl serde::Serialize for Format {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// Read from the text [`FromStr`] accepts (`"I1F14"`, `"U0F16"`), with its
/// [`FormatError`] as the error message.
impl<'de> serde::Deserialize<'de> for Format {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = <std::borrow::Cow<'de, str>>::deserialize(d)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_and_print_round_trip() {
        for t in [
            "I2F14", "U0F16", "I8F0", "U-2F18", "I20F-4", "U64F0", "I1F63",
        ] {
            let f: Format = t.parse().unwrap();
            assert_eq!(f.to_string(), t);
        }
        let f: Format = "I2F14".parse().unwrap();
        assert_eq!((f.signed(), f.width(), f.frac()), (true, 16, 14));
        assert_eq!((f.min_value(), f.max_value()), (-2.0, 2.0 - 1.0 / 16384.0));
    }

    #[test]
    fn rejects_bad_formats() {
        assert_eq!("I0F0".parse::<Format>(), Err(FormatError::Width(0)));
        assert_eq!("U33F32".parse::<Format>(), Err(FormatError::Width(65)));
        assert!(matches!(
            "Q1.15".parse::<Format>(),
            Err(FormatError::Syntax(_))
        ));
        assert!(matches!(
            "I2F".parse::<Format>(),
            Err(FormatError::Syntax(_))
        ));
    }

    #[test]
    fn bits_round_trip_and_wrap() {
        let f: Format = "I4F0".parse().unwrap();
        assert_eq!(f.to_bits(-1), 0xf);
        assert_eq!(f.from_bits(0xf), -1);
        assert_eq!(f.wrap(8), -8);
        assert_eq!(f.wrap(-9), 7);
        let u: Format = "U4F0".parse().unwrap();
        assert_eq!(u.wrap(17), 1);
        assert_eq!(u.wrap(-1), 15);
    }

    #[test]
    fn from_f64_errors_instead_of_silent_values() {
        let f: Format = "I2F14".parse().unwrap();
        assert_eq!(
            f.from_f64(f64::NAN, Rounding::Trunc),
            Err(ConvertError::NaN)
        );
        assert!(matches!(
            f.from_f64(f64::INFINITY, Rounding::Trunc),
            Err(ConvertError::Infinite(_))
        ));
        assert!(matches!(
            f.from_f64(2.0, Rounding::Trunc),
            Err(ConvertError::OutOfRange { .. })
        ));
        assert_eq!(f.from_f64(-2.0, Rounding::Trunc), Ok(-32768));
        // Below half an ulp under the maximum: HalfUp would carry out of range.
        let below_top = 2.0 - 0.75 / 16384.0;
        assert_eq!(f.from_f64(below_top, Rounding::Trunc), Ok(32767));
        assert!(f
            .from_f64(below_top + 0.5 / 16384.0, Rounding::HalfUp)
            .is_err());
        // A negative value far below one ulp floors to −1 ulp.
        assert_eq!(f.from_f64(-1e-300, Rounding::Trunc), Ok(-1));
        assert_eq!(f.from_f64(-1e-300, Rounding::HalfEven), Ok(0));
    }
}
