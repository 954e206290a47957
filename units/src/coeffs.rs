//! Coefficient design for `g(d) ≈ 1/√d` on an interval `[lo, hi]`.
//!
//! Three real-valued constructions of a degree-1 or degree-2 polynomial:
//!
//! * [`Fit::Nodes`] — interpolation at the Chebyshev nodes
//!   `d_k = m + r·cos((2k+1)π / (2n+2))`, `m = (lo+hi)/2`, `r = (hi−lo)/2`
//!   (the paper's Table 1);
//! * [`Fit::Series`] — the Chebyshev series of `1/√d` truncated after `T_n`,
//!   with coefficients `c_j = (2/N) Σ_k f(d_k) T_j(t_k)` by Gauss–Chebyshev
//!   quadrature at `N = 256` nodes (the paper's Table 2);
//! * [`Fit::Minimax`] — the polynomial minimizing the maximum relative error
//!   `max |g(d)·√d − 1|`, by the Remez exchange algorithm (weight `√d`).
//!
//! The maximum relative error of a real polynomial is computed exactly
//! ([`max_rel_err`]): `e(d) = √d·g(d) − 1` has `e'(d) = 0` where
//! `(2n+1)·a_n·d^n + … + a_0 = 0` (`(2j+1)·a_j` for each power `j`), so the
//! maximum is over the interval's ends and those roots.
//!
//! Quantized coefficients ([`quantize_coeffs`]) are found two ways: plain
//! rounding of the real coefficients, and a branch-and-bound search over the
//! integer codes that is exact on a dense grid (see [`search_codes`]).

use crate::format::Format;
use crate::quantize::{Overflow, Quant, Rounding};
use fxshade_numbers::convert::{from_f64, narrow, to_f64};

/// How the real coefficients are constructed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Fit {
    /// Interpolation at the Chebyshev nodes.
    Nodes,
    /// Truncated Chebyshev series.
    Series,
    /// Minimax relative error (Remez).
    Minimax,
}

impl Fit {
    /// All fits.
    pub const ALL: [Fit; 3] = [Fit::Nodes, Fit::Series, Fit::Minimax];
    /// Configuration / CLI name.
    pub const fn name(self) -> &'static str {
        match self {
            Fit::Nodes => "nodes",
            Fit::Series => "series",
            Fit::Minimax => "minimax",
        }
    }
    /// Parse a name.
    pub fn from_name(s: &str) -> Option<Fit> {
        Self::ALL.into_iter().find(|f| f.name() == s)
    }
}

/// Why coefficients could not be designed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CoeffError {
    /// The interval must satisfy `0 < lo < hi`.
    #[error("interval [{lo}, {hi}] must satisfy 0 < lo < hi")]
    Interval {
        /// Lower end.
        lo: f64,
        /// Upper end.
        hi: f64,
    },
    /// Only degrees 1 and 2 are modelled.
    #[error("degree {0} is not modelled; use 1 (linear) or 2 (quadratic)")]
    Degree(usize),
    /// The fit came out non-finite (the interval spans too many orders of
    /// magnitude for f64 to represent its polynomial).
    #[error("the fit on [{lo}, {hi}] is not finite (coefficients {coeffs:?}): the interval spans too many orders of magnitude for f64; keep hi/lo within 1e6")]
    NotFinite {
        /// Lower end.
        lo: f64,
        /// Upper end.
        hi: f64,
        /// The coefficients found, lowest power first.
        coeffs: Vec<f64>,
    },
    /// A coefficient does not fit the coefficient format.
    #[error("coefficient {value} does not fit the coefficient format {format}")]
    Range {
        /// The coefficient.
        value: f64,
        /// The format.
        format: Format,
    },
}

/// A polynomial in `d`, coefficients lowest power first (`c[0] + c[1]·d + …`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Poly(pub Vec<f64>);

impl Poly {
    /// Value at `d` (Horner).
    pub fn eval(&self, d: f64) -> f64 {
        self.0.iter().rev().fold(0.0, |acc, &c| acc * d + c)
    }
    /// Degree.
    pub fn degree(&self) -> usize {
        self.0.len() - 1
    }
    /// Coefficients highest power first (the order the CLI prints).
    pub fn highest_first(&self) -> Vec<f64> {
        self.0.iter().rev().copied().collect()
    }
}

/// The one order fxshade shows coefficients in, everywhere (RTL headers,
/// `coeffs`, `error normalize`, the manifest's `parameters`): highest power
/// first, named as the paper writes `g(d)`: `a*d^2 + b*d + c` (linear
/// `a*d + b`).
pub const ORDER: &str = "highest power first: g(d) = a*d^2 + b*d + c (linear: a*d + b)";

/// `values` (lowest power first, as [`Poly`] holds them) in the order of
/// [`ORDER`], named: `a = 0.6083984375, b = -1.68, c = 2.07` (ASCII).
pub fn named_highest_first(values: &[f64]) -> String {
    values
        .iter()
        .rev()
        .enumerate()
        .map(|(k, v)| format!("{} = {v}", (b'a' + narrow::<u8, _>(k)) as char))
        .collect::<Vec<_>>()
        .join(", ")
}

fn check(lo: f64, hi: f64, degree: usize) -> Result<(), CoeffError> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Err(CoeffError::Interval { lo, hi });
    }
    if !(1..=2).contains(&degree) {
        return Err(CoeffError::Degree(degree));
    }
    Ok(())
}

/// `1/√d`, the function every fit approximates.
pub fn rsqrt(d: f64) -> f64 {
    1.0 / d.sqrt()
}

/// Design a polynomial of `degree` on `[lo, hi]` with `fit` (remembered
/// for the life of the process: a Remez exchange takes milliseconds, and
/// the pipeline asks for the same six fits on every set-up).
///
/// # Errors
///
/// [`CoeffError::Interval`] unless `0 < lo < hi` with `hi` finite; [`CoeffError::Degree`] for a
/// `degree` other than 1 or 2; [`CoeffError::NotFinite`] when the fitted coefficients or their
/// maximum relative error are not finite. An error is remembered like a result.
pub fn design(fit: Fit, lo: f64, hi: f64, degree: usize) -> Result<Poly, CoeffError> {
    type Memo = std::collections::HashMap<(Fit, u64, u64, usize), Result<Poly, CoeffError>>;
    static MEMO: std::sync::OnceLock<std::sync::Mutex<Memo>> = std::sync::OnceLock::new();
    let key = (fit, lo.to_bits(), hi.to_bits(), degree);
    let memo = MEMO.get_or_init(Default::default);
    if let Some(r) = memo.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return r.clone();
    }
    let r = design_uncached(fit, lo, hi, degree);
    memo.lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(key, r.clone());
    r
}

/// Intervals narrower than this, relative to their upper end, are fitted by
/// the Taylor polynomial at their midpoint ([`taylor_at`]): there every
/// fit degenerates (their linear systems lose all precision) while the
/// Taylor polynomial's error, `O((width/mid)^(degree+1))`, is below f64's
/// resolution.
pub const NARROW: f64 = 1e-6;

/// The Taylor polynomial of `1/√d` of `degree` at `m`, in monomials:
/// `m^(−1/2)·(1 − t/2 + 3t²/8)` with `t = (d − m)/m`, the quadratic term
/// for degree 2.
pub fn taylor_at(m: f64, degree: usize) -> Poly {
    let a0 = 1.0 / m.sqrt();
    let a1 = -0.5 * a0 / m;
    let a2 = if degree >= 2 {
        0.375 * a0 / (m * m)
    } else {
        0.0
    };
    let mut c = vec![a0 - a1 * m + a2 * m * m, a1 - 2.0 * a2 * m];
    if degree >= 2 {
        c.push(a2);
    }
    Poly(c)
}

fn design_uncached(fit: Fit, lo: f64, hi: f64, degree: usize) -> Result<Poly, CoeffError> {
    check(lo, hi, degree)?;
    if hi - lo < NARROW * hi {
        return Ok(taylor_at((lo + hi) / 2.0, degree));
    }
    let p = match fit {
        Fit::Nodes => chebyshev_nodes(lo, hi, degree),
        Fit::Series => chebyshev_series(lo, hi, degree),
        Fit::Minimax => remez(&|d| rsqrt(d), &|d: f64| d.sqrt(), lo, hi, degree).0,
    };
    let (err, _) = max_rel_err(&p, lo, hi);
    if p.0.iter().any(|c| !c.is_finite()) || !err.is_finite() {
        return Err(CoeffError::NotFinite {
            lo,
            hi,
            coeffs: p.0.clone(),
        });
    }
    Ok(p)
}

/// Interpolation of `1/√d` at the `n+1` Chebyshev nodes (Newton form,
/// expanded to monomials).
pub fn chebyshev_nodes(lo: f64, hi: f64, n: usize) -> Poly {
    let (m, r) = ((lo + hi) / 2.0, (hi - lo) / 2.0);
    let xs: Vec<f64> = (0..=n)
        .map(|k| m + r * (to_f64(2 * k + 1) * std::f64::consts::PI / to_f64(2 * n + 2)).cos())
        .collect();
    let ys: Vec<f64> = xs.iter().map(|&x| rsqrt(x)).collect();
    interpolate(&xs, &ys)
}

/// The polynomial through `(xs[i], ys[i])`, as monomial coefficients.
pub fn interpolate(xs: &[f64], ys: &[f64]) -> Poly {
    // Solve the Vandermonde system (n ≤ 3: Gaussian elimination is exact
    // enough and simplest).
    let n = xs.len();
    let mut a: Vec<Vec<f64>> = xs
        .iter()
        .zip(ys)
        .map(|(&x, &y)| {
            let mut row: Vec<f64> = (0..n).map(|j| x.powi(narrow::<i32, _>(j))).collect();
            row.push(y);
            row
        })
        .collect();
    Poly(solve(&mut a))
}

/// Gaussian elimination with partial pivoting on an augmented `n×(n+1)`
/// matrix; returns the solution.
fn solve(a: &mut [Vec<f64>]) -> Vec<f64> {
    let n = a.len();
    for col in 0..n {
        let piv = (col..n)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .expect("non-empty");
        a.swap(col, piv);
        let (top, rest) = a.split_at_mut(col + 1);
        let pivot = &top[col];
        for r in rest.iter_mut() {
            let f = r[col] / pivot[col];
            for (x, p) in r[col..].iter_mut().zip(&pivot[col..]) {
                *x -= f * p;
            }
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
        x[row] = (a[row][n] - s) / a[row][row];
    }
    x
}

/// The Chebyshev series of `1/√d` on `[lo, hi]`, truncated after degree `n`,
/// as monomial coefficients in `d`.
pub fn chebyshev_series(lo: f64, hi: f64, n: usize) -> Poly {
    const N: usize = 256;
    let (m, r) = ((lo + hi) / 2.0, (hi - lo) / 2.0);
    // c_j = (2/N) Σ_k f(m + r t_k) T_j(t_k), t_k = cos((k+½)π/N); c_0 halved.
    let mut c = vec![0.0; n + 1];
    for k in 0..N {
        let theta = (to_f64(k) + 0.5) * std::f64::consts::PI / to_f64(N);
        let f = rsqrt(m + r * theta.cos());
        for (j, cj) in c.iter_mut().enumerate() {
            *cj += f * (to_f64(j) * theta).cos();
        }
    }
    for cj in &mut c {
        *cj *= 2.0 / to_f64(N);
    }
    c[0] /= 2.0;
    // Σ c_j T_j(t) with t = (d − m)/r: expand T_j in t, then t in d.
    let mut t_poly = vec![0.0; n + 1]; // coefficients in t
    let cheb: [&[f64]; 3] = [&[1.0], &[0.0, 1.0], &[-1.0, 0.0, 2.0]];
    for (j, &cj) in c.iter().enumerate() {
        for (i, &tc) in cheb[j].iter().enumerate() {
            t_poly[i] += cj * tc;
        }
    }
    // t^i = ((d − m)/r)^i expanded.
    let mut d_poly = vec![0.0; n + 1];
    for (i, &ti) in t_poly.iter().enumerate() {
        // (d − m)^i / r^i = Σ_k binom(i,k) d^k (−m)^(i−k) / r^i
        for k in 0..=i {
            let binom = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 2.0, 1.0]][i][k];
            d_poly[k] +=
                ti * binom * (-m).powi(narrow::<i32, _>(i - k)) / r.powi(narrow::<i32, _>(i));
        }
    }
    Poly(d_poly)
}

/// The weighted error `w(d)·(p(d) − f(d))` of `p`.
fn werr(p: &Poly, f: &dyn Fn(f64) -> f64, w: &dyn Fn(f64) -> f64, d: f64) -> f64 {
    w(d) * (p.eval(d) - f(d))
}

/// Remez exchange: the degree-`n` polynomial minimizing
/// `max_{[lo,hi]} |w(d)·(p(d) − f(d))|`; returns it and that maximum.
///
/// The reference starts at the Chebyshev extrema; each step solves
/// `w(x_i)(p(x_i) − f(x_i)) = (−1)^i E` and exchanges the reference for the
/// alternating extrema of the error on a grid of 4097 points refined by
/// golden-section search, until the levelled error and the maximum agree to
/// 1e−12.
///
/// # Panics
///
/// Never: an extremum is dropped from the reference only while more than `n + 2` remain.
pub fn remez(
    f: &dyn Fn(f64) -> f64,
    w: &dyn Fn(f64) -> f64,
    lo: f64,
    hi: f64,
    n: usize,
) -> (Poly, f64) {
    let m = n + 2;
    let (mid, rad) = ((lo + hi) / 2.0, (hi - lo) / 2.0);
    let mut xs: Vec<f64> = (0..m)
        .map(|i| mid - rad * (to_f64(i) * std::f64::consts::PI / to_f64(m - 1)).cos())
        .collect();
    let grid: Vec<f64> = (0..=4096)
        .map(|i| lo + (hi - lo) * f64::from(i) / 4096.0)
        .collect();
    let mut best = (Poly(vec![0.0; n + 1]), f64::INFINITY);
    for _ in 0..60 {
        let mut a: Vec<Vec<f64>> = xs
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                let mut row: Vec<f64> = (0..=n)
                    .map(|j| w(x) * x.powi(narrow::<i32, _>(j)))
                    .collect();
                row.push(if i % 2 == 0 { -1.0 } else { 1.0 });
                row.push(w(x) * f(x));
                row
            })
            .collect();
        let sol = solve(&mut a);
        let p = Poly(sol[..=n].to_vec());
        let level = sol[n + 1].abs();
        let ext = extrema(&p, f, w, &grid);
        let max = ext.iter().map(|&(_, e)| e.abs()).fold(0.0, f64::max);
        if max < best.1 {
            best = (p.clone(), max);
        }
        if (max - level) <= 1e-12 * max.max(1e-300) || ext.len() < m {
            break;
        }
        // Choose m alternating extrema containing the global maximum.
        let mut e = ext;
        while e.len() > m {
            let gi = e
                .iter()
                .enumerate()
                .max_by(|a, b| a.1 .1.abs().total_cmp(&b.1 .1.abs()))
                .map(|(i, _)| i)
                .expect("non-empty");
            if gi != 0 && (e[0].1.abs() <= e[e.len() - 1].1.abs() || gi == e.len() - 1) {
                e.remove(0);
            } else {
                e.pop();
            }
        }
        xs = e.iter().map(|&(x, _)| x).collect();
    }
    best
}

/// Alternating extrema of the weighted error over `grid` (ends included),
/// each refined by golden-section search; consecutive same-sign extrema are
/// merged keeping the larger.
fn extrema(
    p: &Poly,
    f: &dyn Fn(f64) -> f64,
    w: &dyn Fn(f64) -> f64,
    grid: &[f64],
) -> Vec<(f64, f64)> {
    let e: Vec<f64> = grid.iter().map(|&d| werr(p, f, w, d)).collect();
    let mut out: Vec<(f64, f64)> = Vec::new();
    for i in 0..grid.len() {
        let is_ext = if i == 0 || i == grid.len() - 1 {
            true
        } else {
            (e[i].abs() >= e[i - 1].abs() && e[i].abs() >= e[i + 1].abs()) && e[i] != 0.0
        };
        if !is_ext {
            continue;
        }
        let (mut x, mut v) = (grid[i], e[i]);
        if i > 0 && i < grid.len() - 1 {
            // Golden-section refinement of |e| on [grid[i−1], grid[i+1]].
            let (mut a, mut b) = (grid[i - 1], grid[i + 1]);
            let g = 0.618_033_988_749_895;
            for _ in 0..60 {
                let c = b - g * (b - a);
                let d = a + g * (b - a);
                if werr(p, f, w, c).abs() > werr(p, f, w, d).abs() {
                    b = d;
                } else {
                    a = c;
                }
            }
            x = (a + b) / 2.0;
            v = werr(p, f, w, x);
            if v.abs() < e[i].abs() {
                x = grid[i];
                v = e[i];
            }
        }
        match out.last_mut() {
            Some(last) if last.1.signum() == v.signum() => {
                if v.abs() > last.1.abs() {
                    *last = (x, v);
                }
            }
            _ => out.push((x, v)),
        }
    }
    out
}

/// The exact maximum relative error `max_{[lo,hi]} |g(d)·√d − 1|` of a real
/// polynomial `g` of degree ≤ 2, and where it occurs.
pub fn max_rel_err(p: &Poly, lo: f64, hi: f64) -> (f64, f64) {
    let e = |d: f64| (p.eval(d) * d.sqrt() - 1.0).abs();
    // e' = 0 where Σ (2j+1)·c_j·d^j = 0.
    let q: Vec<f64> =
        p.0.iter()
            .enumerate()
            .map(|(j, &c)| to_f64(2 * j + 1) * c)
            .collect();
    let mut cands = vec![lo, hi];
    match q.len() {
        2 if q[1] != 0.0 => cands.push(-q[0] / q[1]),
        3 => {
            let (a, b, c) = (q[2], q[1], q[0]);
            if a == 0.0 {
                if b != 0.0 {
                    cands.push(-c / b);
                }
            } else {
                let disc = b * b - 4.0 * a * c;
                if disc >= 0.0 {
                    let s = disc.sqrt();
                    cands.push((-b + s) / (2.0 * a));
                    cands.push((-b - s) / (2.0 * a));
                }
            }
        }
        _ => {}
    }
    cands
        .into_iter()
        .filter(|d| d.is_finite() && *d >= lo && *d <= hi)
        .map(|d| (e(d), d))
        .fold((0.0, lo), |acc, x| if x.0 > acc.0 { x } else { acc })
}

/// Quantized coefficients: their codes in the coefficient format, the values
/// those codes stand for, and the real-arithmetic maximum relative error.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Quantized {
    /// Codes, lowest power first.
    pub codes: Vec<i128>,
    /// Values, lowest power first.
    pub values: Vec<f64>,
    /// `max |g(d)·√d − 1|` with these values, in real arithmetic (exact).
    pub max_rel_err: f64,
}

fn from_codes(codes: Vec<i128>, f: Format, lo: f64, hi: f64) -> Quantized {
    let values: Vec<f64> = codes.iter().map(|&c| f.to_f64(c)).collect();
    let max_rel_err = max_rel_err(&Poly(values.clone()), lo, hi).0;
    Quantized {
        codes,
        values,
        max_rel_err,
    }
}

/// Round each real coefficient to the nearest code of `f`.
///
/// # Errors
///
/// [`CoeffError::Range`] naming the first coefficient that is NaN or infinite, or whose nearest
/// code (half to even) lies outside `f`.
pub fn round_coeffs(p: &Poly, f: Format, lo: f64, hi: f64) -> Result<Quantized, CoeffError> {
    let q = Quant::new("coef", f, Rounding::HalfEven, Overflow::Saturate);
    let codes =
        p.0.iter()
            .map(|&c| match q.apply_f64(c) {
                Ok(r) if !r.overflowed => Ok(r.code),
                _ => Err(CoeffError::Range {
                    value: c,
                    format: f,
                }),
            })
            .collect::<Result<Vec<_>, _>>()?;
    Ok(from_codes(codes, f, lo, hi))
}

/// Discrete weighted minimax: the degree-`n` polynomial minimizing
/// `max_i |w_i·(p(x_i) − f_i)|` over the given points (sorted by `x`), by the
/// single-point Remez exchange; returns the coefficients (lowest power
/// first) and that maximum. Exact on the points (up to rounding).
///
/// # Panics
///
/// If `xs` holds fewer than `n + 2` points, or `fs` or `ws` fewer values than `xs`.
pub fn discrete_minimax(xs: &[f64], fs: &[f64], ws: &[f64], n: usize) -> (Vec<f64>, f64) {
    let m = n + 2;
    let len = xs.len();
    assert!(len >= m, "need at least n + 2 points");
    let mut refs: Vec<usize> = (0..m).map(|k| k * (len - 1) / (m - 1)).collect();
    let mut best = (vec![0.0; n + 1], f64::INFINITY);
    for _ in 0..200 {
        let mut a: Vec<Vec<f64>> = refs
            .iter()
            .enumerate()
            .map(|(k, &i)| {
                let mut row: Vec<f64> = (0..=n)
                    .map(|j| ws[i] * xs[i].powi(narrow::<i32, _>(j)))
                    .collect();
                row.push(if k % 2 == 0 { -1.0 } else { 1.0 });
                row.push(ws[i] * fs[i]);
                row
            })
            .collect();
        let sol = solve(&mut a);
        let c = &sol[..=n];
        let level = sol[n + 1].abs();
        let err =
            |i: usize| ws[i] * (c.iter().rev().fold(0.0, |acc, &cj| acc * xs[i] + cj) - fs[i]);
        let (imax, emax) = (0..len)
            .map(|i| (i, err(i)))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .expect("points");
        if emax.abs() < best.1 {
            best = (c.to_vec(), emax.abs());
        }
        if emax.abs() <= level * (1.0 + 1e-12) + 1e-300 || refs.contains(&imax) {
            break;
        }
        // Insert imax keeping the signs of the error alternating.
        let sgn = |i: usize| err(i) >= 0.0;
        let pos = refs.iter().position(|&r| r > imax).unwrap_or(m);
        if pos == 0 {
            if sgn(refs[0]) == sgn(imax) {
                refs[0] = imax;
            } else {
                refs.pop();
                refs.insert(0, imax);
            }
        } else if pos == m {
            if sgn(refs[m - 1]) == sgn(imax) {
                refs[m - 1] = imax;
            } else {
                refs.remove(0);
                refs.push(imax);
            }
        } else if sgn(refs[pos - 1]) == sgn(imax) {
            refs[pos - 1] = imax;
        } else {
            refs[pos] = imax;
        }
    }
    best
}

/// The representable coefficients (codes of `f`) minimizing the maximum
/// relative error on 513 Chebyshev-spaced points of `[lo, hi]` (ends
/// included): an exact branch-and-bound search over the integer codes.
///
/// The error `E(c) = max_i |√d_i·Σ c_j d_i^j − 1|` is convex in the codes.
/// With the higher powers' codes fixed, the smallest error any real lower
/// coefficients can reach is a convex function of the current power's code,
/// computed exactly on the same points by [`discrete_minimax`] on the
/// residual; it bounds every completion. The search finds that function's
/// integer minimum, walks outward in both directions while the bound is
/// below the best error found so far (starting from rounding's), recursing
/// to the next power, and solves the constant term exactly (the level at
/// which the intervals `r_i ± T/√d_i` first intersect). A search of a few
/// ulps around the rounded coefficients misses optima lying along the long
/// axis of the error's level sets; this does not, and it never does worse
/// than rounding on these points. Returns the best `keep` candidates, best
/// first.
///
/// The search visits at most [`SEARCH_LEAVES`] complete code sets, nearest
/// the optimum first; with a fine coefficient format the error's level sets
/// are so long that an exhaustive walk takes minutes. [`search_codes_full`]
/// says whether the walk finished.
///
/// # Errors
///
/// As [`search_codes_full`].
pub fn search_codes(
    p: &Poly,
    f: Format,
    lo: f64,
    hi: f64,
    keep: usize,
) -> Result<Vec<Vec<i128>>, CoeffError> {
    Ok(search_codes_full(p, f, lo, hi, keep)?.0)
}

/// Complete code sets [`search_codes`] evaluates at most.
pub const SEARCH_LEAVES: usize = 4096;

/// As [`search_codes`], and whether the search was exhaustive (it stopped
/// on its bound, not on [`SEARCH_LEAVES`]).
///
/// # Errors
///
/// [`CoeffError::Range`] as [`round_coeffs`]: the search starts from the rounded coefficients.
pub fn search_codes_full(
    p: &Poly,
    f: Format,
    lo: f64,
    hi: f64,
    keep: usize,
) -> Result<(Vec<Vec<i128>>, bool), CoeffError> {
    let rounded = round_coeffs(p, f, lo, hi)?;
    let n = p.degree();
    let grid = search_grid(lo, hi);
    let sq: Vec<f64> = grid.iter().map(|d| d.sqrt()).collect();
    let rs: Vec<f64> = grid.iter().map(|&d| rsqrt(d)).collect();
    let pows: Vec<Vec<f64>> = (0..=n)
        .map(|k| grid.iter().map(|d| d.powi(narrow::<i32, _>(k))).collect())
        .collect();
    let mut s = Search {
        grid: &grid,
        sq: &sq,
        rs: &rs,
        pows: &pows,
        h: f.ulp(),
        f,
        keep: keep.max(1),
        best: Vec::new(),
        leaves: 0,
        ulp_err: f.ulp() * hi.sqrt() * (0..=n).map(|j| hi.powi(narrow::<i32, _>(j))).sum::<f64>(),
    };
    let e0 = s.error(&rounded.codes);
    s.offer(rounded.codes.clone(), e0);
    let mut fixed = vec![0i128; n + 1];
    s.descend(n, &mut fixed);
    let complete = s.leaves <= SEARCH_LEAVES;
    Ok((s.best.into_iter().map(|(c, _)| c).collect(), complete))
}

/// The 513 Chebyshev-spaced points of `[lo, hi]` (ends included) the search
/// minimizes over: dense near the ends, where the error peaks.
pub fn search_grid(lo: f64, hi: f64) -> Vec<f64> {
    (0..=512)
        .map(|i| {
            let t = (f64::from(i) * std::f64::consts::PI / 512.0).cos();
            (lo + hi) / 2.0 - (hi - lo) / 2.0 * t
        })
        .collect()
}

/// `max |√d·g(d) − 1|` over `grid` for the coefficient codes of format `f`
/// (lowest power first): the search's objective.
pub fn grid_rel_err(codes: &[i128], f: Format, grid: &[f64]) -> f64 {
    let h = f.ulp();
    grid.iter()
        .map(|&d| {
            let g = codes
                .iter()
                .rev()
                .fold(0.0, |acc, &c| acc * d + to_f64(c) * h);
            (d.sqrt() * g - 1.0).abs()
        })
        .fold(0.0, f64::max)
}

struct Search<'a> {
    grid: &'a [f64],
    sq: &'a [f64],
    /// `1/√d` at every point of the grid.
    rs: &'a [f64],
    /// `pows[k][i]` = `d_i^k` (`powi`) at every point, for every power.
    pows: &'a [Vec<f64>],
    h: f64,
    f: Format,
    keep: usize,
    best: Vec<(Vec<i128>, f64)>,
    /// How much one ulp of every coefficient can move the error:
    /// `h·√hi·Σ_j hi^j`.
    ulp_err: f64,
    /// Complete code sets evaluated so far.
    leaves: usize,
}

impl Search<'_> {
    fn error(&self, codes: &[i128]) -> f64 {
        // Each coefficient's value once, not once per point (the same
        // products, so the same sums).
        let vals: Vec<f64> = codes.iter().map(|&c| to_f64(c) * self.h).collect();
        self.grid
            .iter()
            .zip(self.sq)
            .map(|(&d, &s)| {
                let g = vals.iter().rev().fold(0.0, |acc, &v| acc * d + v);
                (s * g - 1.0).abs()
            })
            .fold(0.0, f64::max)
    }
    /// Errors at or above this cannot enter the kept list.
    fn bound(&self) -> f64 {
        if self.best.len() < self.keep {
            // Candidates within a quarter of the best error, but no more
            // than 16 ulps of every coefficient away from it: with a fine
            // format, the quarter would hold millions of code sets.
            self.best.first().map_or(f64::INFINITY, |b| {
                (b.1 * 1.25).min(b.1 + 16.0 * self.ulp_err) + 1e-15
            })
        } else {
            self.best.last().map_or(f64::INFINITY, |b| b.1)
        }
    }
    fn offer(&mut self, codes: Vec<i128>, err: f64) {
        if self.best.iter().any(|b| b.0 == codes) {
            return;
        }
        self.best.push((codes, err));
        self.best.sort_by(|a, b| a.1.total_cmp(&b.1));
        self.best.truncate(self.keep);
    }
    /// `1/√d − Σ_{k ≥ j} c_k·h·d^k` at every point: what the powers below
    /// `j` must approximate once powers ≥ `j` are fixed.
    fn residual(&self, fixed: &[i128], j: usize) -> Vec<f64> {
        // `c_k·h` once per call and `1/√d`, `d^k` once per search: the
        // same values, summed in the same order.
        let ch: Vec<f64> = fixed[j..].iter().map(|&c| to_f64(c) * self.h).collect();
        let pows = &self.pows[j..fixed.len()];
        (0..self.grid.len())
            .map(|i| self.rs[i] - ch.iter().zip(pows).map(|(&c, p)| c * p[i]).sum::<f64>())
            .collect()
    }
    /// The smallest error reachable with powers ≥ j fixed (`fixed[j]` set)
    /// and real lower powers.
    fn lower_bound(&self, fixed: &[i128], j: usize) -> f64 {
        let r = self.residual(fixed, j);
        if j == 0 {
            return r
                .iter()
                .zip(self.sq)
                .map(|(ri, s)| (s * ri).abs())
                .fold(0.0, f64::max);
        }
        discrete_minimax(self.grid, &r, self.sq, j - 1).1
    }
    fn descend(&mut self, j: usize, fixed: &mut [i128]) {
        if self.leaves > SEARCH_LEAVES {
            return;
        }
        if j == 0 {
            self.leaves += 1;
            // Constant term: the smallest T for which all c·h ∈ [r_i − T/s_i,
            // r_i + T/s_i] intersect, by bisection; then the codes around it.
            let r = self.residual(fixed, 1);
            let hull = |t: f64| -> (f64, f64) {
                r.iter()
                    .zip(self.sq)
                    .fold((f64::NEG_INFINITY, f64::INFINITY), |(a, b), (ri, s)| {
                        (a.max(ri - t / s), b.min(ri + t / s))
                    })
            };
            let (mut t_lo, mut t_hi) = (0.0, 1.0);
            while hull(t_hi).0 > hull(t_hi).1 {
                t_hi *= 2.0;
            }
            for _ in 0..70 {
                let t = (t_lo + t_hi) / 2.0;
                let (a, b) = hull(t);
                if a <= b {
                    t_hi = t;
                } else {
                    t_lo = t;
                }
            }
            let (a, b) = hull(t_hi);
            let centre = (a + b) / 2.0 / self.h;
            for c in [
                from_f64::<i128>(centre.floor()),
                from_f64::<i128>(centre.ceil()),
            ] {
                if self.f.contains(c) {
                    fixed[0] = c;
                    let e = self.error(fixed);
                    if e < self.bound() {
                        self.offer(fixed.to_vec(), e);
                    }
                }
            }
            return;
        }
        // The integer minimum of the convex bound, by ternary search around
        // the real optimum's code.
        let real = {
            let r = self.residual(fixed, j + 1);
            discrete_minimax(self.grid, &r, self.sq, j).0[j] / self.h
        };
        // The bound is convex in the code and smallest at `real`, so its
        // integer minimum is next to it; a window around `real` that grows
        // while the minimum sits on its edge absorbs the exchange
        // algorithm's rounding.
        let lb = |code: i128, fixed: &mut [i128]| {
            fixed[j] = code;
            self.lower_bound(fixed, j)
        };
        let clamp = |c: i128| c.clamp(self.f.min_code(), self.f.max_code());
        let mut w = 2i128;
        let start = loop {
            let (a, b) = (
                clamp(from_f64::<i128>(real.floor()) - w),
                clamp(from_f64::<i128>(real.ceil()) + w),
            );
            // Each code's bound once (the comparison would evaluate it
            // twice); the first of equal minima, as `min_by` picks.
            let bounds: Vec<(i128, f64)> = (a..=b).map(|c| (c, lb(c, fixed))).collect();
            let best = bounds
                .iter()
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .expect("non-empty")
                .0;
            let on_edge =
                (best == a && a > self.f.min_code()) || (best == b && b < self.f.max_code());
            if !on_edge || w > 1 << 20 {
                break best;
            }
            w *= 4;
        };
        // Walk right, then left, while the bound can still beat the best.
        for dir in [1i128, -1] {
            let mut code = if dir == 1 { start } else { start - 1 };
            while self.f.contains(code) && self.leaves <= SEARCH_LEAVES {
                fixed[j] = code;
                if self.lower_bound(fixed, j) >= self.bound() {
                    break;
                }
                self.descend(j - 1, fixed);
                code += dir;
            }
        }
    }
}

/// Both quantizations of `p`'s coefficients to format `f`: plain rounding
/// and the searched best codes (by real-arithmetic error; the caller may
/// re-rank the returned candidates with the bit-accurate model).
/// The `bool` says whether the search was exhaustive ([`search_codes_full`]).
///
/// # Errors
///
/// [`CoeffError::Range`] as [`round_coeffs`].
pub fn quantize_coeffs(
    p: &Poly,
    f: Format,
    lo: f64,
    hi: f64,
) -> Result<(Quantized, Vec<Quantized>, bool), CoeffError> {
    let rounded = round_coeffs(p, f, lo, hi)?;
    let (cands, complete) = search_codes_full(p, f, lo, hi, 8)?;
    let cands = cands
        .into_iter()
        .map(|c| from_codes(c, f, lo, hi))
        .collect();
    Ok((rounded, cands, complete))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_theta_0_values() {
        // methods.md: nodes, Θ = 0: −0.7978·d + 1.7781, 2.4746 %.
        let p = chebyshev_nodes(0.5, 1.0, 1);
        assert!(
            (p.0[1] + 0.7978).abs() < 5e-5 && (p.0[0] - 1.7781).abs() < 5e-5,
            "{p:?}"
        );
        assert!((max_rel_err(&p, 0.5, 1.0).0 * 100.0 - 2.4746).abs() < 5e-4);
        // series, Θ = 0: 0.8381·d² − 2.0702·d + 2.2354, ≈ 0.326 %.
        let q = chebyshev_series(0.5, 1.0, 2);
        assert!(
            (q.0[2] - 0.8381).abs() < 5e-5
                && (q.0[1] + 2.0702).abs() < 5e-5
                && (q.0[0] - 2.2354).abs() < 5e-5,
            "{q:?}"
        );
        // minimax linear, Θ = 0: about 2.23 %.
        let m = design(Fit::Minimax, 0.5, 1.0, 1).unwrap();
        let e = max_rel_err(&m, 0.5, 1.0).0;
        assert!((e * 100.0 - 2.23).abs() < 0.01, "{e}");
    }

    #[test]
    fn minimax_is_no_worse_than_either_chebyshev_fit() {
        for theta in [0.0, 0.5, 0.75, 0.875, 0.9375, 0.96875] {
            for lo in [(1.0 + theta) / 2.0, (1.0 + 2.0 * theta) / 3.0] {
                for deg in [1, 2] {
                    let e = |f| max_rel_err(&design(f, lo, 1.0, deg).unwrap(), lo, 1.0).0;
                    let (m, n, s) = (e(Fit::Minimax), e(Fit::Nodes), e(Fit::Series));
                    assert!(
                        m <= n * (1.0 + 1e-9) && m <= s * (1.0 + 1e-9),
                        "Θ {theta} lo {lo} deg {deg}: {m} {n} {s}"
                    );
                }
            }
        }
    }

    #[test]
    fn max_rel_err_matches_dense_sampling() {
        for fit in Fit::ALL {
            for deg in [1, 2] {
                let p = design(fit, 0.4, 1.0, deg).unwrap();
                let exact = max_rel_err(&p, 0.4, 1.0).0;
                let sampled = (0..=100_000)
                    .map(|i| 0.4 + 0.6 * i as f64 / 100_000.0)
                    .map(|d| (p.eval(d) * d.sqrt() - 1.0).abs())
                    .fold(0.0, f64::max);
                assert!(
                    exact >= sampled && exact - sampled < 1e-9,
                    "{fit:?} {deg}: {exact} {sampled}"
                );
            }
        }
    }

    /// Brute force over a box of codes around the rounded ones must not find
    /// anything better than the branch-and-bound search (same objective).
    #[test]
    fn search_matches_brute_force() {
        for (theta, fmt, deg, r) in [
            (0.5, "I3F7", 2, 12i128),
            (0.0, "I3F9", 1, 150),
            (0.875, "I3F9", 2, 12),
        ] {
            let lo = (1.0 + theta) / 2.0;
            let p = design(Fit::Minimax, lo, 1.0, deg).unwrap();
            let f: Format = fmt.parse().unwrap();
            let grid = search_grid(lo, 1.0);
            let found = search_codes(&p, f, lo, 1.0, 1).unwrap().remove(0);
            let best = grid_rel_err(&found, f, &grid);
            let rounded = round_coeffs(&p, f, lo, 1.0).unwrap().codes;
            assert!(best <= grid_rel_err(&rounded, f, &grid));
            let mut brute = f64::INFINITY;
            let mut codes = rounded.clone();
            let ranges: Vec<_> = rounded.iter().map(|&c| (c - r)..=(c + r)).collect();
            for a in ranges[0].clone() {
                codes[0] = a;
                for b in ranges[1].clone() {
                    codes[1] = b;
                    if deg == 2 {
                        for c in ranges[2].clone() {
                            codes[2] = c;
                            brute = brute.min(grid_rel_err(&codes, f, &grid));
                        }
                    } else {
                        brute = brute.min(grid_rel_err(&codes, f, &grid));
                    }
                }
            }
            assert!(
                best <= brute * (1.0 + 1e-12),
                "{theta} {fmt}: search {best} brute {brute}"
            );
        }
    }

    #[test]
    fn minimax_equioscillates() {
        let p = design(Fit::Minimax, 0.5, 1.0, 2).unwrap();
        let e = max_rel_err(&p, 0.5, 1.0).0;
        // Degree 2: four alternating extrema of equal size, ends included.
        let at = |d: f64| p.eval(d) * d.sqrt() - 1.0;
        assert!((at(0.5).abs() - e).abs() < 1e-9 * e.max(1e-12) + 1e-12);
        assert!((at(1.0).abs() - e).abs() < 1e-9 * e.max(1e-12) + 1e-12);
        assert!(at(0.5).signum() != at(1.0).signum());
    }
}
