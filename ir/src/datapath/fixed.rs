//! The bit-accurate fixed-point context.

use super::{Datapath, Table};
use crate::format::{ConvertError, Format};
use crate::quantize::{Quant, Quantized, Raw, Rounding};

/// An exact fixed-point value `raw · 2^−frac`. Between quantizations the
/// binary point moves with the operations (`mul` adds fraction bits, `add`
/// aligns to the finer operand); only [`Datapath::quantize`] drops bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fx<R = i128> {
    /// The integer code.
    pub raw: R,
    /// Fraction bits: the value is `raw · 2^−frac`.
    pub frac: i32,
}

impl<R: Raw> Fx<R> {
    /// A value from a code in `format` (as read from a vector file).
    pub fn from_code(code: i128, format: Format) -> Self {
        Fx {
            raw: R::from_i128(code),
            frac: format.frac(),
        }
    }
    /// The code, widened.
    pub fn code(self) -> i128 {
        self.raw.to_i128()
    }
    /// The value as f64 (rounded to nearest when `raw` has more than 53
    /// significant bits).
    pub fn to_f64(self) -> f64 {
        super::batch::code_value(self.raw.to_i128(), self.frac)
    }
}

/// Bit-accurate fixed-point arithmetic on integer codes of type `R`.
///
/// Exactness holds while every intermediate fits in the code type: 126 bits
/// for `i128` ([`super::MAX_EXACT_WIDTH`]), 62 bits for `i64`. Configuration
/// validation runs each unit in [`super::Count`] first, which measures the
/// widest intermediate ([`super::Count::fits_i64`] picks the fast `i64` path),
/// so the inner loop does integer arithmetic with no per-operation checks.
/// Overflows at quantization steps are counted per stage name (see
/// [`Fixed::overflows`]).
#[derive(Clone, Debug)]
pub struct Fixed<R = i128> {
    overflows: Vec<(&'static str, u64)>,
    ties: Vec<(&'static str, u64)>,
    _raw: std::marker::PhantomData<R>,
}

impl<R> Default for Fixed<R> {
    fn default() -> Self {
        Fixed {
            overflows: Vec::new(),
            ties: Vec::new(),
            _raw: std::marker::PhantomData,
        }
    }
}

impl<R: Raw> Fixed<R> {
    /// A context with no overflows counted.
    pub fn new() -> Self {
        Self::default()
    }
    /// Overflows counted so far, per stage, in order of first occurrence.
    pub fn overflows(&self) -> &[(&'static str, u64)] {
        &self.overflows
    }
    /// Total overflows counted so far.
    pub fn total_overflows(&self) -> u64 {
        self.overflows.iter().map(|(_, n)| n).sum()
    }
    /// Exact rounding ties met so far (a nearest-mode quantization whose
    /// dropped bits were exactly one half), per stage: the cases that tell
    /// `half_up` from `half_even`, which test vectors must contain.
    pub fn ties(&self) -> &[(&'static str, u64)] {
        &self.ties
    }
    /// Forget the counted overflows and ties.
    pub fn reset(&mut self) {
        self.overflows.clear();
        self.ties.clear();
    }
    /// Add another context's counts to this one's (for parallel batches).
    pub fn merge<S>(&mut self, other: &Fixed<S>) {
        for &(stage, n) in &other.overflows {
            self.count(stage, n);
        }
    }
    #[cold]
    fn count(&mut self, stage: &'static str, n: u64) {
        match self.overflows.iter_mut().find(|(s, _)| *s == stage) {
            Some((_, c)) => *c += n,
            None => self.overflows.push((stage, n)),
        }
    }
    #[inline(always)]
    fn finish(&mut self, r: Quantized<R>, q: &Quant) -> Fx<R> {
        if r.overflowed {
            self.count(q.stage(), 1);
        }
        Fx {
            raw: r.code,
            frac: q.format().frac(),
        }
    }
    #[inline(always)]
    fn finish_wide(&mut self, r: Quantized, q: &Quant) -> Fx<R> {
        self.finish(
            Quantized {
                code: R::from_i128(r.code),
                overflowed: r.overflowed,
            },
            q,
        )
    }
    #[inline(always)]
    fn align(a: Fx<R>, b: Fx<R>) -> (R, R, i32) {
        if a.frac >= b.frac {
            (a.raw, b.raw << (a.frac - b.frac).unsigned_abs(), a.frac)
        } else {
            (a.raw << (b.frac - a.frac).unsigned_abs(), b.raw, b.frac)
        }
    }
}

/// `⌊num·2^k / den⌋` for `den > 0`: its low 128 bits (exact modulo 2^128,
/// which is all wrap-around needs), whether a remainder was left, and whether
/// the quotient's magnitude reached `2^100` (outside every format).
fn div_scaled_floor(num: i128, den: i128, k: i32) -> (i128, bool, bool) {
    const LIMIT: u128 = 1 << 100;
    let neg = num < 0;
    let mag = num.unsigned_abs();
    let d = den.unsigned_abs(); // den > 0
    let ku = k.unsigned_abs();
    let (q, sticky, huge) = if k >= 0 && ku < 127 && mag.leading_zeros() > ku + 1 {
        let n = mag << k;
        (n / d, !n.is_multiple_of(d), n / d >= LIMIT)
    } else {
        // Restoring division over the bits of |num|·2^k (k ≥ 0) or
        // ⌊|num|/2^−k⌋ (k < 0; the bits shifted out go into `sticky`).
        let (n, mut sticky, extra) = if k >= 0 {
            (mag, false, ku)
        } else if -k < 128 {
            let sh = ku;
            (mag >> sh, mag & ((1u128 << sh) - 1) != 0, 0)
        } else {
            (0, mag != 0, 0)
        };
        let (mut r, mut q, mut huge) = (0u128, 0u128, false);
        for i in 0..128 + extra {
            let bit = if i < 128 { (n >> (127 - i)) & 1 } else { 0 };
            // r < d ≤ 2^127, so 2r + 1 fits in a u128.
            r = (r << 1) | bit;
            huge |= q >= LIMIT;
            q <<= 1;
            if r >= d {
                r -= d;
                q |= 1;
            }
        }
        sticky |= r != 0;
        (q, sticky, huge || q >= LIMIT)
    };
    // The low 128 bits, as documented: wrap-around reads no more.
    let q = q.cast_signed();
    // ⌊−x⌋ = −⌈x⌉.
    let f = if neg {
        q.wrapping_neg().wrapping_sub(i128::from(sticky))
    } else {
        q
    };
    (f, sticky, huge)
}

/// Round `f·2^−G` (with more nonzero bits below when `sticky`) to an
/// integer under `mode`, where `f` is a floor with `G = 2` guard bits.
fn round_guarded(f: i128, sticky: bool, mode: Rounding) -> i128 {
    let q = f >> 2;
    // (wrapping: `f` may be the low bits of a huge quotient)
    let round_bit = (f >> 1) & 1 == 1;
    let below = f & 1 == 1 || sticky;
    let up = match mode {
        Rounding::Trunc => false,
        Rounding::HalfUp => round_bit,
        Rounding::HalfEven => round_bit && (below || q & 1 == 1),
    };
    q.wrapping_add(i128::from(up))
}

fn overflowed(code: i128) -> Quantized {
    Quantized {
        code,
        overflowed: true,
    }
}

impl<R: Raw> Datapath for Fixed<R> {
    type V = Fx<R>;

    fn constant(&mut self, x: f64, q: &Quant) -> Result<Fx<R>, ConvertError> {
        let r = q.apply_f64(x)?;
        Ok(self.finish_wide(r, q))
    }
    #[inline(always)]
    fn mul(&mut self, a: Fx<R>, b: Fx<R>) -> Fx<R> {
        Fx {
            raw: a.raw.mul_raw(b.raw),
            frac: a.frac + b.frac,
        }
    }
    #[inline(always)]
    fn add(&mut self, a: Fx<R>, b: Fx<R>) -> Fx<R> {
        let (x, y, frac) = Self::align(a, b);
        Fx { raw: x + y, frac }
    }
    #[inline(always)]
    fn sub(&mut self, a: Fx<R>, b: Fx<R>) -> Fx<R> {
        let (x, y, frac) = Self::align(a, b);
        Fx { raw: x - y, frac }
    }
    #[inline(always)]
    fn shl(&mut self, a: Fx<R>, n: i32) -> Fx<R> {
        Fx {
            raw: a.raw,
            frac: a.frac - n,
        }
    }
    #[inline(always)]
    fn max(&mut self, a: Fx<R>, b: Fx<R>) -> Fx<R> {
        let (x, y, frac) = Self::align(a, b);
        Fx {
            raw: x.max(y),
            frac,
        }
    }
    #[inline(always)]
    fn add_signed(&mut self, a: Fx<R>, b: Fx<R>, s: Fx<R>, flip: bool) -> Fx<R> {
        let (x, y, frac) = Self::align(a, b);
        let neg = (s.raw < R::ZERO) != flip;
        Fx {
            raw: if neg { x - y } else { x + y },
            frac,
        }
    }
    #[inline(always)]
    fn quantize(&mut self, a: Fx<R>, q: &Quant) -> Fx<R> {
        let s = a.frac - q.format().frac();
        let su = s.unsigned_abs();
        if s > 0 && q.round() != Rounding::Trunc && su < R::BITS {
            let low = a.raw & ((R::ONE << su) - R::ONE);
            if low == R::ONE << (su - 1) {
                match self.ties.iter_mut().find(|(st, _)| *st == q.stage()) {
                    Some((_, c)) => *c += 1,
                    None => self.ties.push((q.stage(), 1)),
                }
            }
        }
        let r = q.apply_raw(a.raw, a.frac);
        self.finish(r, q)
    }
    #[inline]
    fn table(&mut self, t: &Table, index: Fx<R>) -> Fx<R> {
        debug_assert_eq!(index.frac, t.index.frac(), "table {} index format", t.name);
        let addr = super::batch::table_slot(t.index.to_bits(index.raw.to_i128()), t.depth() - 1);
        Fx {
            raw: R::from_i128(t.codes[addr]),
            frac: t.out.format().frac(),
        }
    }
    fn div(&mut self, a: Fx<R>, b: Fx<R>, q: &Quant) -> Fx<R> {
        let r = div_exact(a.raw.to_i128(), a.frac, b.raw.to_i128(), b.frac, q);
        self.finish_wide(r, q)
    }
    fn sqrt(&mut self, a: Fx<R>, q: &Quant) -> Fx<R> {
        let r = sqrt_exact(a.raw.to_i128(), a.frac, q);
        self.finish_wide(r, q)
    }
    fn select(&mut self, sel: Fx<R>, options: &[Fx<R>]) -> Fx<R> {
        debug_assert_eq!(sel.frac, 0, "select code is an integer");
        let frac = options.iter().map(|o| o.frac).max().expect("an option");
        let s = sel.raw.to_i128();
        let o = if let Some(&o) = usize::try_from(s).ok().and_then(|i| options.get(i)) {
            o
        } else {
            options[0]
        };
        Fx {
            raw: o.raw << super::batch::align(frac, o.frac),
            frac,
        }
    }
}

/// `(a_raw·2^−a_frac) / (b_raw·2^−b_frac)` correctly rounded to `q`
/// (division by zero saturates and overflows).
pub fn div_exact(a_raw: i128, a_frac: i32, b_raw: i128, b_frac: i32, q: &Quant) -> Quantized {
    let f = q.format();
    let (mut num, mut den) = (a_raw, b_raw);
    if den == 0 {
        let code = if num < 0 { f.min_code() } else { f.max_code() };
        return overflowed(code);
    }
    if den < 0 {
        // |den| ≤ 2^126 because codes come from formats of ≤ 126 bits.
        num = -num;
        den = -den;
    }
    // a/b·2^F = num·2^e / den with e = F + fb − fa; two guard bits.
    let e = f.frac() + b_frac - a_frac;
    let (g, sticky, huge) = div_scaled_floor(num, den, e + 2);
    let code = round_guarded(g, sticky, q.round());
    if huge {
        let code = match q.overflow() {
            crate::quantize::Overflow::Wrap => f.wrap(code),
            crate::quantize::Overflow::Saturate if num < 0 => f.min_code(),
            crate::quantize::Overflow::Saturate => f.max_code(),
        };
        return overflowed(code);
    }
    // `code` is on the target grid already: only the range step remains.
    q.apply(code, f.frac())
}

/// `√(raw·2^−frac)` correctly rounded to `q` (a negative input gives 0 and
/// overflows; a root of 2^63 or more saturates and overflows).
pub fn sqrt_exact(raw: i128, frac: i32, q: &Quant) -> Quantized {
    let f = q.format();
    if raw < 0 {
        return overflowed(0);
    }
    // √(ra·2^−fa)·2^F = √x with x = ra·2^e, e = 2F − fa. With
    // m = ⌊4x⌋ and t = isqrt(m) = ⌊2√x⌋: ⌊√x⌋ = t >> 1,
    // ⌊√x + ½⌋ = (t + 1) >> 1, and √x + ½ is an integer (a tie) exactly
    // when 4x is an integer and the square of the odd number t.
    let ra = raw.unsigned_abs(); // raw ≥ 0
    let k = 2 * f.frac() - frac + 2;
    let ku = k.unsigned_abs();
    let (m, exact) = if k >= 0 {
        if k >= 128 || (ra != 0 && ra.leading_zeros() < ku) {
            // 4x ≥ 2^128: √x ≥ 2^63, beyond every signed format.
            return overflowed(f.max_code());
        }
        (ra << k, true)
    } else if -k < 128 {
        let sh = ku;
        (ra >> sh, ra & ((1u128 << sh) - 1) == 0)
    } else {
        (0, ra == 0)
    };
    let t = m.isqrt();
    let code = match q.round() {
        Rounding::Trunc => t >> 1,
        Rounding::HalfUp => (t + 1) >> 1,
        Rounding::HalfEven => {
            let tie = exact && t & 1 == 1 && t * t == m;
            let up = (t + 1) >> 1;
            if tie && up & 1 == 1 {
                up - 1
            } else {
                up
            }
        }
    };
    // t < 2^64 (the root of a u128): the reinterpretation is the value.
    q.apply(code.cast_signed(), f.frac())
}
