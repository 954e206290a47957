//! Quantization: an exact value `raw · 2^−frac` to a target [`Format`].
//!
//! This is the only place in fxshade where bits are dropped. Every datapath
//! operation is exact; a `quantize` step then applies, in this order,
//!
//! 1. **rounding** to the target's grid `2^−F` (a right shift by
//!    `S = frac − F` bits when `S > 0`; when `S ≤ 0` the value is shifted left,
//!    exactly), then
//! 2. **overflow handling** to the target's code range.
//!
//! The Verilog the RTL uses for each mode, with `x` the exact value as a
//! signed wire (width `XW`) and `S > 0` the number of dropped bits:
//!
//! | mode | meaning | Verilog |
//! |---|---|---|
//! | [`Rounding::Trunc`] | floor, toward −∞ | `r = x >>> S;` |
//! | [`Rounding::HalfUp`] | nearest, ties toward +∞ | `r = (x >>> S) + x[S-1];` |
//! | [`Rounding::HalfEven`] | nearest, ties to even | `u = (x >>> S) + x[S-1]; r = {u[..1], u[0] & ~tie};` with `tie = x[S-1] & ~\|x[S-2:0]` |
//! | [`Overflow::Wrap`] | keep the low `W` bits | `y = r[W-1:0];` |
//! | [`Overflow::Saturate`] | clamp to the range | `y = (r > MAX) ? MAX : (r < MIN) ? MIN : r[W-1:0];` |
//!
//! `r` is one bit wider than `x >>> S` so that the rounding increment cannot
//! overflow. For `S = 1`, the sticky term `|x[S-2:0]` is `1'b0`. See
//! `model/ARITHMETIC.md` for the contract as a whole.

use crate::format::Format;

/// How the bits below the target's LSB are removed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rounding {
    /// Floor: round toward −∞, i.e. drop the bits (Verilog `>>>`).
    /// `q = ⌊x⌋`. The `fixed` crate's multiplication rounds this way.
    Trunc,
    /// Round to nearest, ties toward +∞: `q = ⌊x + ½⌋`.
    HalfUp,
    /// Round to nearest, ties to the even code (convergent rounding).
    HalfEven,
}

/// What happens to a rounded code outside the target's range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Overflow {
    /// Keep the low `width` bits (two's-complement wrap-around).
    Wrap,
    /// Clamp to the smallest or largest code.
    Saturate,
}

impl Rounding {
    /// Every mode, in documentation order.
    pub const ALL: [Rounding; 3] = [Rounding::Trunc, Rounding::HalfUp, Rounding::HalfEven];
    /// The configuration name (`trunc`, `half_up`, `half_even`).
    pub const fn name(self) -> &'static str {
        match self {
            Rounding::Trunc => "trunc",
            Rounding::HalfUp => "half_up",
            Rounding::HalfEven => "half_even",
        }
    }
    /// Parse a configuration name.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|r| r.name() == s)
    }
}

impl Overflow {
    /// Every mode, in documentation order.
    pub const ALL: [Overflow; 2] = [Overflow::Wrap, Overflow::Saturate];
    /// The configuration name (`wrap`, `saturate`).
    pub const fn name(self) -> &'static str {
        match self {
            Overflow::Wrap => "wrap",
            Overflow::Saturate => "saturate",
        }
    }
    /// Parse a configuration name.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|r| r.name() == s)
    }
}

/// An integer type that holds fixed-point codes: `i64` when every exact
/// intermediate of a datapath fits in 62 bits (the fast path), `i128`
/// otherwise. The quantization logic is written once over this trait.
pub trait Raw:
    Copy
    + Ord
    + std::fmt::Debug
    + Send
    + Sync
    + 'static
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::BitAnd<Output = Self>
    + std::ops::Shr<u32, Output = Self>
    + std::ops::Shl<u32, Output = Self>
{
    /// Bits in the type.
    const BITS: u32;
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Truncating conversion (keeps the low `BITS` bits).
    fn from_i128(x: i128) -> Self;
    /// Widening conversion.
    fn to_i128(self) -> i128;
    /// Shift left, discarding bits shifted out (the shift must be `< BITS`).
    fn wrapping_shl(self, n: u32) -> Self;
    /// Logical shift right (for unsigned wrap-around).
    fn lshr(self, n: u32) -> Self;
    /// Whether shifting left by `n` loses no bits and keeps the sign.
    fn shl_fits(self, n: u32) -> bool;
    /// Product (exact when the result fits, which the counting run
    /// guarantees for the datapaths it checks).
    fn mul_raw(self, o: Self) -> Self;
    /// Sum with wrap-around.
    fn wrapping_add_raw(self, o: Self) -> Self;
    /// Whether `lo ≤ self ≤ hi`, as one unsigned comparison.
    fn in_range(self, lo: Self, hi: Self) -> bool;
}

macro_rules! impl_raw {
    ($t:ty, $u:ty) => {
        // The container's own two's-complement reinterpretations (the
        // unsigned comparison and logical shift of `in_range` and `lshr`),
        // and `from_i128`, which the exact-width limit keeps in range.
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            clippy::cast_possible_wrap,
            clippy::cast_lossless,
            reason = "bit reinterpretations of the container, documented per method"
        )]
        impl Raw for $t {
            const BITS: u32 = <$t>::BITS;
            const ZERO: Self = 0;
            const ONE: Self = 1;
            #[inline(always)]
            fn from_i128(x: i128) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_i128(self) -> i128 {
                self as i128
            }
            #[inline(always)]
            fn wrapping_shl(self, n: u32) -> Self {
                <$t>::wrapping_shl(self, n)
            }
            #[inline(always)]
            fn lshr(self, n: u32) -> Self {
                ((self as $u) >> n) as $t
            }
            #[inline(always)]
            fn shl_fits(self, n: u32) -> bool {
                n < <$t>::BITS - 1 && (self << n) >> n == self
            }
            #[inline(always)]
            fn mul_raw(self, o: Self) -> Self {
                self.wrapping_mul(o)
            }
            #[inline(always)]
            fn wrapping_add_raw(self, o: Self) -> Self {
                self.wrapping_add(o)
            }
            #[inline(always)]
            fn in_range(self, lo: Self, hi: Self) -> bool {
                (self.wrapping_sub(lo) as $u) <= (hi.wrapping_sub(lo) as $u)
            }
        }
    };
}
impl_raw!(i64, u64);
impl_raw!(i128, u128);

/// `⌊raw / 2^s⌋` rounded by `mode`, for `s ≥ 1` (exact integer arithmetic,
/// for `|raw| ≤ 2^(BITS−2)`, which the exact-width limit guarantees).
///
/// With `q = raw >>> s` and `rem = raw − q·2^s ∈ [0, 2^s)`:
/// * `Trunc` → `q`;
/// * `HalfUp` → `q + [rem ≥ 2^(s−1)]` = `((raw >>> (s−1)) + 1) >>> 1`;
/// * `HalfEven` → `q + [rem > 2^(s−1) ∨ (rem = 2^(s−1) ∧ q odd)]`
///   = `(raw + 2^(s−1) − 1 + raw[s]) >>> s`: the carry out of the low `s`
///   bits is 1 exactly when `rem > 2^(s−1)`, or `rem = 2^(s−1)` and `q` is odd.
#[inline(always)]
pub fn round_shift_right<R: Raw>(raw: R, s: u32, mode: Rounding) -> R {
    debug_assert!(s >= 1);
    if s >= R::BITS {
        // |raw·2^−s| ≤ ½, and = ½ only for raw = MIN, s = BITS, where both
        // nearest modes give 0 (tie up to 0, and 0 is even).
        return match mode {
            Rounding::Trunc if raw < R::ZERO => R::ZERO - R::ONE,
            _ => R::ZERO,
        };
    }
    match mode {
        Rounding::Trunc => raw >> s,
        Rounding::HalfUp => ((raw >> (s - 1)) + R::ONE) >> 1,
        Rounding::HalfEven => {
            let lsb = (raw >> s) & R::ONE;
            let bias = (R::ONE << (s - 1)) - R::ONE + lsb;
            raw.wrapping_add_raw(bias) >> s
        }
    }
}

/// A quantization step: the target format, its modes, and the stage name
/// under which overflows are counted. Built once per configuration; the code
/// range is resolved at construction so the inner loop only compares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quant {
    stage: &'static str,
    format: Format,
    round: Rounding,
    overflow: Overflow,
    min: i128,
    max: i128,
}

impl serde::Serialize for Quant {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("Quant", 3)?;
        st.serialize_field("format", &self.format)?;
        st.serialize_field("round", &self.round)?;
        st.serialize_field("overflow", &self.overflow)?;
        st.end()
    }
}

/// Read from `{ stage, format, round, overflow }` (the stage name is
/// optional and defaults to `""`): what [`Quant::new`] takes. A stage name
/// read this way is interned, so it is leaked once per distinct name, never
/// once per value.
impl<'de> serde::Deserialize<'de> for Quant {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Fields {
            #[serde(default)]
            stage: String,
            format: Format,
            round: Rounding,
            overflow: Overflow,
        }
        let f = Fields::deserialize(d)?;
        Ok(Quant::new(intern(&f.stage), f.format, f.round, f.overflow))
    }
}

/// One `&'static str` per distinct stage name read by [`Quant`]'s
/// `Deserialize` (stage names come from a fixed set of declared fields).
fn intern(name: &str) -> &'static str {
    use std::collections::BTreeSet;
    use std::sync::Mutex;
    static NAMES: Mutex<BTreeSet<&'static str>> = Mutex::new(BTreeSet::new());
    let mut names = NAMES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(n) = names.get(name) {
        return n;
    }
    let n: &'static str = Box::leak(name.to_owned().into_boxed_str());
    names.insert(n);
    n
}

/// The result of one quantization.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quantized<R = i128> {
    /// The code in the target format.
    pub code: R,
    /// Whether the rounded value lay outside the target range (and was wrapped
    /// or saturated).
    pub overflowed: bool,
}

impl Quant {
    /// A quantization step for `stage`.
    pub const fn new(
        stage: &'static str,
        format: Format,
        round: Rounding,
        overflow: Overflow,
    ) -> Self {
        Quant {
            stage,
            format,
            round,
            overflow,
            min: format.min_code(),
            max: format.max_code(),
        }
    }
    /// The stage (configuration key within its unit).
    pub const fn stage(&self) -> &'static str {
        self.stage
    }
    /// Target format.
    pub const fn format(&self) -> Format {
        self.format
    }
    /// Rounding mode.
    pub const fn round(&self) -> Rounding {
        self.round
    }
    /// Overflow mode.
    pub const fn overflow(&self) -> Overflow {
        self.overflow
    }
    /// The same step with another format.
    pub const fn with_format(self, f: Format) -> Self {
        Self::new(self.stage, f, self.round, self.overflow)
    }
    /// The same step with another rounding mode.
    pub const fn with_round(self, r: Rounding) -> Self {
        Self::new(self.stage, self.format, r, self.overflow)
    }
    /// The same step with another overflow mode.
    pub const fn with_overflow(self, o: Overflow) -> Self {
        Self::new(self.stage, self.format, self.round, o)
    }
    /// The same step under another stage name.
    pub const fn with_stage(self, stage: &'static str) -> Self {
        Self::new(stage, self.format, self.round, self.overflow)
    }

    /// Quantize the exact value `raw · 2^−frac` to this step's format.
    ///
    /// Exact for every `raw` and `frac`: rounding by [`round_shift_right`]
    /// when bits are dropped, an exact left shift otherwise, then wrap or
    /// saturate. `overflowed` is set when the rounded value lay outside the
    /// format's range, in either overflow mode.
    ///
    /// Every rounding mode on every half-integer and quarter of
    /// `−4 ..= 3.75` into the signed integer format `I4F0`, against f64's
    /// `floor`, `floor(x + ½)` and `round_ties_even` (independent
    /// computations of the three modes; ties included):
    ///
    /// ```
    /// use fxshade_numbers::format::Format;
    /// use fxshade_numbers::quantize::{Overflow, Quant, Rounding};
    /// let f: Format = "I4F0".parse().unwrap();
    /// for (round, want) in [
    ///     (Rounding::Trunc, f64::floor as fn(f64) -> f64),
    ///     (Rounding::HalfUp, |x: f64| (x + 0.5).floor()),
    ///     (Rounding::HalfEven, f64::round_ties_even),
    /// ] {
    ///     let q = Quant::new("x", f, round, Overflow::Saturate);
    ///     for raw in -16i128..16 {
    ///         // raw · 2^−2: quarters, so both ties and non-ties.
    ///         let x = raw as f64 / 4.0;
    ///         let r = q.apply(raw, 2);
    ///         assert_eq!(r.code as f64, want(x), "{round:?} {x}");
    ///         assert!(!r.overflowed);
    ///     }
    /// }
    /// // The three at the ties ±2.5 (raw 5 or −5 with one fraction bit).
    /// let at = |round, raw| Quant::new("x", f, round, Overflow::Wrap).apply(raw, 1).code;
    /// assert_eq!([at(Rounding::Trunc, 5), at(Rounding::HalfUp, 5), at(Rounding::HalfEven, 5)], [2, 3, 2]);
    /// assert_eq!([at(Rounding::Trunc, -5), at(Rounding::HalfUp, -5), at(Rounding::HalfEven, -5)], [-3, -2, -2]);
    /// ```
    ///
    /// Overflow: 9 does not fit `I4F0` (`−8 ..= 7`); wrapped it keeps the
    /// low 4 bits (`9 − 16 = −7`), saturated it is clamped; either way
    /// `overflowed` is set. A value that rounds into range does not
    /// overflow (7.4 truncates to 7):
    ///
    /// ```
    /// use fxshade_numbers::format::Format;
    /// use fxshade_numbers::quantize::{Overflow, Quant, Quantized, Rounding};
    /// let f: Format = "I4F0".parse().unwrap();
    /// let wrap = Quant::new("x", f, Rounding::Trunc, Overflow::Wrap);
    /// let sat = wrap.with_overflow(Overflow::Saturate);
    /// assert_eq!(wrap.apply(9, 0), Quantized { code: -7, overflowed: true });
    /// assert_eq!(sat.apply(9, 0), Quantized { code: 7, overflowed: true });
    /// assert_eq!(sat.apply(-9, 0), Quantized { code: -8, overflowed: true });
    /// // 7.4 ≈ 947 · 2^−7, floored to 7: in range.
    /// assert_eq!(sat.apply(947, 7), Quantized { code: 7, overflowed: false });
    /// // More fraction bits in the target: an exact left shift. In I2F2
    /// // (4 bits, values −2 ..= 1.75) 3.0 is code 12, which wraps to 12 − 16.
    /// let g = wrap.with_format("I2F2".parse().unwrap());
    /// assert_eq!(g.apply(3, 0).code, -4);
    /// assert_eq!(g.with_overflow(Overflow::Saturate).apply(1, 0).code, 4);
    /// ```
    #[inline]
    pub fn apply(&self, raw: i128, frac: i32) -> Quantized {
        self.apply_raw(raw, frac)
    }

    /// [`Quant::apply`] on any code type. With `i64` an unsigned format must
    /// be at most 63 bits wide (the counting run picks `i64` only then).
    #[inline(always)]
    pub fn apply_raw<R: Raw>(&self, raw: R, frac: i32) -> Quantized<R> {
        self.step(frac).apply::<R>(raw, self.round, self.overflow)
    }

    /// The step resolved for inputs with `frac` fraction bits: the shift and
    /// the code range, ready for a loop over many values.
    #[inline(always)]
    pub fn step(&self, frac: i32) -> Step {
        Step {
            shift: frac - self.format.frac(),
            width: self.format.width(),
            signed: self.format.signed(),
            min: self.min,
            max: self.max,
        }
    }
}

/// A quantization resolved for one input binary point: everything but the
/// modes, which are passed separately so loops can be specialized on them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    /// Bits dropped (`> 0`) or added (`< 0`): input frac − target frac.
    pub shift: i32,
    /// Target width.
    pub width: u32,
    /// Target signedness.
    pub signed: bool,
    /// Smallest code.
    pub min: i128,
    /// Largest code.
    pub max: i128,
}

impl Step {
    /// Round and range-limit one code (`round` and `overflow` are constants
    /// in specialized loops, so the `match`es fold away).
    #[inline(always)]
    pub fn apply<R: Raw>(&self, raw: R, round: Rounding, overflow: Overflow) -> Quantized<R> {
        let s = self.shift;
        let (rounded, huge) = if s > 0 {
            (round_shift_right(raw, s.unsigned_abs(), round), false)
        } else if s == 0 {
            (raw, false)
        } else {
            let l = s.unsigned_abs();
            if raw.shl_fits(l) {
                (raw << l, false)
            } else if raw == R::ZERO {
                (raw, false)
            } else {
                // |raw·2^l| exceeds the code type: outside every format. Its
                // low bits are still right for wrapping (zero when l ≥ BITS).
                (
                    if l >= R::BITS {
                        R::ZERO
                    } else {
                        raw.wrapping_shl(l)
                    },
                    true,
                )
            }
        };
        let (min, max) = (R::from_i128(self.min), R::from_i128(self.max));
        // Branch-free from here, so loops over many codes vectorize.
        let ok = !huge & rounded.in_range(min, max);
        let fix = match overflow {
            Overflow::Wrap => {
                let sh = R::BITS - self.width;
                if self.signed {
                    (rounded << sh) >> sh
                } else {
                    (rounded << sh).lshr(sh)
                }
            }
            Overflow::Saturate => {
                if raw < R::ZERO {
                    min
                } else {
                    max
                }
            }
        };
        Quantized {
            code: if ok { rounded } else { fix },
            overflowed: !ok,
        }
    }
}

impl Quant {
    /// Quantize an f64 with this step's rounding and overflow modes; errors
    /// only for NaN and ±∞. Used to bring real inputs and coefficients into
    /// the datapath with the same semantics as [`Quant::apply`].
    ///
    /// # Errors
    ///
    /// [`ConvertError::NaN`](crate::format::ConvertError::NaN) or
    /// [`ConvertError::Infinite`](crate::format::ConvertError::Infinite); a value
    /// outside the format is not an error but wraps or saturates (`overflowed`).
    pub fn apply_f64(&self, x: f64) -> Result<Quantized, crate::format::ConvertError> {
        use crate::format::ConvertError;
        if x.is_nan() {
            return Err(ConvertError::NaN);
        }
        if x.is_infinite() {
            return Err(ConvertError::Infinite(x));
        }
        // An f64 is exactly m·2^e with |m| < 2^53: quantize that.
        let (m, e) = decompose(x);
        if self.format.width() <= 62 {
            // The mantissa fits an `i64`, and so does every code of the
            // format: the `i64` run gives the same code and flag, without
            // 128-bit arithmetic.
            let q = self.apply_raw::<i64>(crate::convert::narrow(m), -e);
            return Ok(Quantized {
                code: i128::from(q.code),
                overflowed: q.overflowed,
            });
        }
        Ok(self.apply(m, -e))
    }
}

impl Quant {
    /// [`Quant::apply_f64`]'s code of every value of `xs`, into `out`
    /// (`or` for a NaN or infinite value): the same codes, from a loop
    /// specialized on the rounding and overflow modes (for a format of at
    /// most 62 bits, [`Quant::codes_f64_i64`]'s).
    ///
    /// # Panics
    ///
    /// If `out` is shorter than `xs`.
    pub fn codes_f64(&self, xs: &[f64], or: i128, out: &mut [i128]) {
        let out = &mut out[..xs.len()];
        if self.format.width() <= 62 {
            let mut codes = [0i64; 64];
            for (xs, out) in xs.chunks(64).zip(out.chunks_mut(64)) {
                let codes = &mut codes[..xs.len()];
                // (`or` only stands in for NaN and infinities; the i64
                // run's placeholder is replaced here.)
                self.codes_f64_i64(xs, 0, codes);
                for ((o, &c), &x) in out.iter_mut().zip(&*codes).zip(xs) {
                    *o = if x.is_finite() { i128::from(c) } else { or };
                }
            }
            return;
        }
        for (o, &x) in out.iter_mut().zip(xs) {
            *o = self.apply_f64(x).map_or(or, |q| q.code);
        }
    }

    /// [`Quant::codes_f64`] into `i64` codes, for a format of at most 62
    /// bits: the same codes (`or` for a NaN or infinite value). Inlined
    /// into its caller, so that a caller compiled for a wider instruction
    /// set (an `fxshade_ir` kernel) runs it in vector instructions.
    ///
    /// For `0 ≤ frac ≤ 62`, `y = x·2^frac` is exact (a power-of-two
    /// scaling of a finite value that stays finite), and for `|y| < 2^62`
    /// its rounding is read off `t = trunc(y)` (the conversion to `i64`)
    /// and `d = y − t`, which is exact too (the fraction bits of `y`):
    /// `⌊y⌋ = t − [d < 0]`, and the fraction `y − ⌊y⌋` is at least, above
    /// or at ½ exactly when `d` is at least, above or at `±½` (`−½` for a
    /// negative `d`, whose fraction is `1 + d`). The rounded code goes
    /// through [`Step::apply`] at shift 0 for the range. That loop has no
    /// branch on the data; the values outside it (and every value of a
    /// format with `frac` outside `0..=62`) are then redone one by one by
    /// [`Quant::apply_f64`].
    ///
    /// # Panics
    ///
    /// If the format is wider than 62 bits, or `out` is shorter than `xs`.
    #[inline(always)]
    pub fn codes_f64_i64(&self, xs: &[f64], or: i64, out: &mut [i64]) {
        use Overflow::{Saturate, Wrap};
        use Rounding::{HalfEven, HalfUp, Trunc};
        assert!(self.format.width() <= 62, "a format of at most 62 bits");
        let out = &mut out[..xs.len()];
        match (self.round, self.overflow) {
            (Trunc, Wrap) => self.codes_with(xs, out, Trunc, Wrap),
            (Trunc, Saturate) => self.codes_with(xs, out, Trunc, Saturate),
            (HalfUp, Wrap) => self.codes_with(xs, out, HalfUp, Wrap),
            (HalfUp, Saturate) => self.codes_with(xs, out, HalfUp, Saturate),
            (HalfEven, Wrap) => self.codes_with(xs, out, HalfEven, Wrap),
            (HalfEven, Saturate) => self.codes_with(xs, out, HalfEven, Saturate),
        }
        let (scaled, scale) = self.f64_path();
        let outside = |x: f64| {
            let y = (x * scale).abs();
            !scaled | y.is_nan() | (y >= F64_PATH_LIMIT)
        };
        // Whether any value is outside, without a branch per value (the
        // usual answer is no); then those values one by one.
        if !xs.iter().fold(false, |any, &x| any | outside(x)) {
            return;
        }
        for (o, &x) in out.iter_mut().zip(xs) {
            if outside(x) {
                *o = self
                    .apply_f64(x)
                    .map_or(or, |q| crate::convert::narrow(q.code));
            }
        }
    }

    /// Whether [`Quant::codes_f64_i64`]'s f64 path applies (`0 ≤ frac ≤
    /// 62`), and its scale `2^frac`.
    #[inline(always)]
    fn f64_path(&self) -> (bool, f64) {
        let frac = self.format.frac();
        ((0..=62).contains(&frac), crate::format::exp2i(frac))
    }

    /// [`Quant::codes_f64_i64`]'s f64 path with the modes as constants of
    /// the caller, for every value (those outside it are redone).
    #[inline(always)]
    fn codes_with(&self, xs: &[f64], out: &mut [i64], round: Rounding, ov: Overflow) {
        let (_, scale) = self.f64_path();
        let at_zero = self.step(self.format.frac());
        for (o, &x) in out.iter_mut().zip(xs) {
            let y = x * scale;
            // Toward zero, exactly where |y| < 2^62 (saturated elsewhere,
            // and redone).
            let t = crate::convert::from_f64::<i64>(y);
            let d = y - crate::convert::to_f64(t);
            let neg = d < 0.0;
            let floor = t - i64::from(neg);
            let half = if neg { -0.5 } else { 0.5 };
            // (Bitwise, not short-circuit: no branch on the data.)
            let up = match round {
                Rounding::Trunc => false,
                Rounding::HalfUp => d >= half,
                Rounding::HalfEven => (d > half) | ((d == half) & (floor & 1 == 1)),
            };
            *o = at_zero.apply::<i64>(floor + i64::from(up), round, ov).code;
        }
    }
}

/// `2^62`: [`Quant::codes_f64_i64`]'s f64 path takes `|x·2^frac|` below it.
const F64_PATH_LIMIT: f64 = 4_611_686_018_427_387_904.0;

/// `x = m · 2^e` exactly, with `m` an integer of at most 53 bits.
#[inline]
pub fn decompose(x: f64) -> (i128, i32) {
    if x == 0.0 {
        return (0, 0);
    }
    let bits = x.to_bits();
    let sign = if bits >> 63 != 0 { -1 } else { 1 };
    #[allow(
        clippy::cast_possible_truncation,
        reason = "11 bits: the biased exponent field"
    )]
    let exp = ((bits >> 52) & 0x7ff) as i32;
    let frac = bits & ((1u64 << 52) - 1);
    let (m, e) = if exp == 0 {
        (frac, -1074)
    } else {
        (frac | (1u64 << 52), exp - 1075)
    };
    (sign * i128::from(m), e)
}

/// The exact format of a non-negative integer literal `n`: `U<b>F0` with `b`
/// the bit length of `n` (at least 1), so `1` is `U1F0` and `15` is `U4F0`.
/// A constant is a value in a format too; this one holds it exactly.
///
/// # Panics
///
/// Never: the bit length of a `u64` is `1..=64`, a valid width.
pub fn literal(n: u64) -> Quant {
    let bits = (64 - n.leading_zeros()).max(1);
    Quant::new(
        "literal",
        crate::format::Format::new(false, bits, 0).expect("1..=64 bits"),
        Rounding::Trunc,
        Overflow::Saturate,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::exp2i;

    /// `codes_f64` gives `apply_f64`'s code of each value (`or` for NaN
    /// and infinities), for every mode and a narrow and a wide format.
    #[test]
    fn codes_f64_are_apply_f64_codes() {
        let xs = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            0.25,
            1.5,
            -2.5,
            0.999_99,
            1.0,
            7.3,
            -7.3,
            1e300,
            -1e-310,
            3.0e-5,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.123_456_789,
            2.0 / 3.0,
        ];
        // Values near the codes' ties at every scale the formats below
        // take the f64 path at (`k/2^s` and one ulp either side), and
        // random bit patterns.
        let mut xs = xs.to_vec();
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        for _ in 0..4000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let k = i64::from_ne_bytes(state.to_ne_bytes()) >> 40;
            let s = i32::try_from(state % 64).unwrap();
            let x = crate::convert::to_f64(k) * exp2i(-s);
            xs.extend([x, x.next_up(), x.next_down(), f64::from_bits(state)]);
        }
        for (signed, width, frac) in [
            (false, 16, 15),
            (true, 12, 4),
            (true, 64, 40),
            (true, 62, 30),
            (false, 20, 0),
            (true, 40, 62),
            (true, 10, -3),
        ] {
            let f = crate::format::Format::new(signed, width, frac).unwrap();
            for round in Rounding::ALL {
                for ov in [Overflow::Wrap, Overflow::Saturate] {
                    let q = Quant::new("t", f, round, ov);
                    let mut out = vec![0; xs.len()];
                    q.codes_f64(&xs, -1, &mut out);
                    for (x, got) in xs.iter().zip(&out) {
                        let want = q.apply_f64(*x).map_or(-1, |r| r.code);
                        assert_eq!(*got, want, "{x} {f:?} {round:?} {ov:?}");
                    }
                }
            }
        }
    }

    /// `apply_f64` takes an `i64` path for formats up to 62 bits; it must
    /// give the code and flag of the 128-bit quantization of the same exact
    /// value `m·2^e`, for every mode, at every width, on values from
    /// subnormal to huge, ties and out of range included.
    #[test]
    fn apply_f64_agrees_with_the_128_bit_quantization() {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            state
        };
        let mut values = vec![
            0.0, -0.0, 0.5, -0.5, 1.5, -2.5, 1e300, -1e300, 5e-324, -1e-310,
        ];
        for _ in 0..400 {
            let bits = next();
            let x = f64::from_bits(bits);
            if x.is_finite() {
                values.push(x);
            }
            // Values near the formats' ranges: a few bits of integer part.
            let m = crate::convert::to_f64(i64::try_from(next() >> 40).unwrap());
            let e = i32::try_from(next() % 40).unwrap() - 20;
            values.push(m * exp2i(e) * if next() & 1 == 0 { 1.0 } else { -1.0 });
        }
        let rounds = [Rounding::Trunc, Rounding::HalfUp, Rounding::HalfEven];
        let overflows = [Overflow::Wrap, Overflow::Saturate];
        for width in 1..=64u32 {
            for signed in [false, true] {
                for frac in [-3, 0, 5, 17, 40] {
                    let Ok(fmt) = Format::new(signed, width, frac) else {
                        continue;
                    };
                    for (&round, &overflow) in rounds
                        .iter()
                        .flat_map(|r| overflows.iter().map(move |o| (r, o)))
                    {
                        let q = Quant::new("t", fmt, round, overflow);
                        for &x in &values {
                            let (m, e) = decompose(x);
                            assert_eq!(
                                q.apply_f64(x).unwrap(),
                                q.apply(m, -e),
                                "{x:e} into {fmt:?} {round:?} {overflow:?}"
                            );
                        }
                    }
                }
            }
        }
    }

    fn q(fmt: &str, round: Rounding, overflow: Overflow) -> Quant {
        Quant::new("t", fmt.parse().unwrap(), round, overflow)
    }

    #[test]
    fn rounding_modes_on_ties() {
        // raw/4 for raw = -6..=6 to an integer format: ties at ±2, ±6 (x.5).
        let cases: [(i128, i128, i128, i128); 6] = [
            // raw, trunc, half_up, half_even
            (6, 1, 2, 2),     // 1.5
            (2, 0, 1, 0),     // 0.5
            (-2, -1, 0, 0),   // -0.5
            (-6, -2, -1, -2), // -1.5
            (3, 0, 1, 1),     // 0.75
            (-3, -1, -1, -1), // -0.75
        ];
        for (raw, t, u, e) in cases {
            assert_eq!(
                q("I8F0", Rounding::Trunc, Overflow::Wrap)
                    .apply(raw, 2)
                    .code,
                t,
                "{raw}"
            );
            assert_eq!(
                q("I8F0", Rounding::HalfUp, Overflow::Wrap)
                    .apply(raw, 2)
                    .code,
                u,
                "{raw}"
            );
            assert_eq!(
                q("I8F0", Rounding::HalfEven, Overflow::Wrap)
                    .apply(raw, 2)
                    .code,
                e,
                "{raw}"
            );
        }
    }

    #[test]
    fn overflow_modes() {
        let w = q("I4F0", Rounding::Trunc, Overflow::Wrap);
        let s = q("I4F0", Rounding::Trunc, Overflow::Saturate);
        assert_eq!(
            w.apply(9, 0),
            Quantized {
                code: -7,
                overflowed: true
            }
        );
        assert_eq!(
            s.apply(9, 0),
            Quantized {
                code: 7,
                overflowed: true
            }
        );
        assert_eq!(
            s.apply(-9, 0),
            Quantized {
                code: -8,
                overflowed: true
            }
        );
        assert_eq!(
            s.apply(7, 0),
            Quantized {
                code: 7,
                overflowed: false
            }
        );
        // Left shift far beyond the width.
        assert_eq!(
            s.apply(1, -200),
            Quantized {
                code: 7,
                overflowed: true
            }
        );
        assert_eq!(
            w.apply(1, -200),
            Quantized {
                code: 0,
                overflowed: true
            }
        );
        // Rounding up into overflow: 7.5 half-up is 8.
        let su = q("I4F0", Rounding::HalfUp, Overflow::Saturate);
        assert_eq!(
            su.apply(15, 1),
            Quantized {
                code: 7,
                overflowed: true
            }
        );
        assert_eq!(
            s.apply(15, 1),
            Quantized {
                code: 7,
                overflowed: false
            }
        );
    }

    #[test]
    fn huge_right_shifts() {
        let t = q("I8F0", Rounding::Trunc, Overflow::Wrap);
        assert_eq!(t.apply(-1, 300).code, -1);
        assert_eq!(t.apply(i128::MAX, 300).code, 0);
        let u = q("I8F0", Rounding::HalfUp, Overflow::Wrap);
        assert_eq!(u.apply(i128::MIN, 128).code, 0);
        assert_eq!(u.apply(i128::MIN, 127).code, -1);
    }

    #[test]
    fn decompose_is_exact() {
        for x in [1.0, -0.1, 3.5e-310, 1e300, -7.25] {
            let (m, e) = decompose(x);
            assert_eq!(m as f64 * crate::format::exp2i(e), x);
        }
    }
}
