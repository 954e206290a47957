//! Method A: fast normalization of interpolated normals, `N' = N·g(d)` with
//! `d = N·N` and `g(d) ≈ 1/√d`.
//!
//! Every variant is one datapath, written once:
//!
//! ```text
//! d   = Q_d(Nx² + Ny² + Nz²)                          3 mul, 2 add
//! g   = exact     Q_g(1 / Q_sqrt(√d))                  1 sqrt, 1 div
//!       none      (no g: N' = Q_out(N))
//!       newton    Q_g((3 − d) / 2)                     1 add, a shift
//!       taylor    Q_g(((3·d − 10)·d + 15) / 8)         2 mul, 2 add, a shift
//!       linear    Q_g(k·d + p)                         1 mul, 1 add
//!       quadratic Q_g(Q_horner(a·d + b)·d + c)         2 mul, 2 add (Horner)
//! N'  = Q_out(N·g)                                     3 mul
//! ```
//!
//! The linear one costs 7 multiplications and 3 additions, the quadratic 8
//! and 4: measured by [`crate::datapath::Count`] (`fxshade ops`), not typed.
//! Integer constants (3, 10, 15, 1) are literals, exact in the smallest
//! unsigned format that holds them (`quantize::literal`: `U2F0` for 3).
//!
//! ## The interval of `d`
//! Interpolating two unit vectors at angle `φ` along an edge gives
//! `d ≥ cos²(φ/2) = (1 + cos φ)/2`; the paper fits on `[(1+Θ)/2, 1]`
//! ([`Interval::Edge`]). Inside a triangle, with barycentrics `c_i ≥ 0`,
//! `Σ c_i = 1` and unit vertex normals whose pairwise dot products are all at
//! least `Θ ≥ 0`:
//!
//! ```text
//! d = |Σ c_i N_i|² = Σ c_i² + 2 Σ_{i<j} c_i c_j (N_i·N_j)
//!   ≥ Σ c_i² + 2Θ Σ_{i<j} c_i c_j = 1 − 2(1 − Θ)·S,   S = Σ_{i<j} c_i c_j,
//! ```
//!
//! using `Σ c_i² = 1 − 2S`. `S` is largest, `1/3`, at the centroid, so
//! `d ≥ (1 + 2Θ)/3`, with equality at the centroid of a triangle whose three
//! normals are pairwise at exactly `φ = acos Θ` (such a triangle exists for
//! every `Θ ≥ −½`). And `d ≤ 1` because `|Σ c_i N_i| ≤ Σ c_i |N_i| = 1`. So
//! over whole triangles `d ∈ [(1 + 2Θ)/3, 1]` ([`Interval::Triangle`], the
//! default): at Θ = 0 that is `[1/3, 1]` against the paper's `[1/2, 1]`.

use crate::coeffs::{self, CoeffError, Fit, Poly};
use crate::config::{Config, ConfigError, FieldDecl, FieldKind, UnitDecl};
use crate::datapath::{Compiled, Count, Datapath, Trace};
use crate::format::ConvertError;
use crate::quantize::{literal, Quant};
use crate::units::{width_errors, OpReport, PaperClaim, Phase};
use fxshade_numbers::convert::{from_f64, narrow, to_f64};

pub mod rtl;

/// The `[normalize]` configuration section.
pub static DECL: UnitDecl = UnitDecl {
    name: "normalize",
    doc: "method A: N' = N·g(d), d = N·N, g ≈ 1/√d (fast normalizer)",
    fields: &[
        FieldDecl { name: "normal", kind: FieldKind::Stage, doc: "input port: components of the interpolated normal N" },
        FieldDecl { name: "d", kind: FieldKind::Stage, doc: "d = N·N after quantization" },
        FieldDecl { name: "coef", kind: FieldKind::Stage, doc: "coefficient registers (k, p or a, b, c)" },
        FieldDecl { name: "horner", kind: FieldKind::Stage, doc: "quadratic only: the Horner intermediate a·d + b" },
        FieldDecl { name: "sqrt", kind: FieldKind::Stage, doc: "exact variant only: √d" },
        FieldDecl { name: "g", kind: FieldKind::Stage, doc: "g(d) ≈ 1/√d" },
        FieldDecl { name: "out", kind: FieldKind::Stage, doc: "output port: components of N·g" },
        FieldDecl {
            name: "method",
            kind: FieldKind::Choice(&["exact", "none", "newton", "taylor", "linear", "quadratic"]),
            doc: "which g(d): exact 1/√d, none, newton (3−d)/2, taylor, linear k·d+p, quadratic a·d²+b·d+c",
        },
        FieldDecl {
            name: "theta",
            kind: FieldKind::Number { min: 0.0, max: 0.999_999 },
            doc: "convexity threshold Θ: smallest cosine between vertex normals of a triangle",
        },
        FieldDecl { name: "fit", kind: FieldKind::Choice(&["nodes", "series", "minimax"]), doc: "coefficient construction: Chebyshev nodes, Chebyshev series, minimax relative error" },
        FieldDecl { name: "interval", kind: FieldKind::Choice(&["edge", "triangle"]), doc: "fit d on the paper's edge interval [(1+Θ)/2, 1] or the whole-triangle one [(1+2Θ)/3, 1]" },
        FieldDecl { name: "coef_quant", kind: FieldKind::Choice(&["round", "search"]), doc: "coefficients: rounded to the coef format, or the best codes found by search" },
    ],
    groups: &[("normals", &["normal", "out"]), ("normalizer", &["d", "coef", "horner", "g"])],
};

/// The `[normalize]` section, typed (one field per declared field).
#[derive(Clone, Copy, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NormalizeConfig {
    /// Input port: the components of N.
    pub normal: Quant,
    /// `d = N·N`.
    pub d: Quant,
    /// The coefficient registers.
    pub coef: Quant,
    /// The Horner intermediate (quadratic).
    pub horner: Quant,
    /// `√d` (exact).
    pub sqrt: Quant,
    /// `g(d) ≈ 1/√d`.
    pub g: Quant,
    /// Output port: the components of N·g.
    pub out: Quant,
    /// Which `g(d)`.
    pub method: Method,
    /// The convexity threshold Θ.
    pub theta: f64,
    /// The coefficient construction.
    pub fit: Fit,
    /// The interval of `d` the coefficients are fitted on.
    pub interval: Interval,
    /// Rounded coefficients or the best codes found by search.
    pub coef_quant: CoefQuant,
}

impl crate::config::Section for NormalizeConfig {
    const DECL: &'static UnitDecl = &DECL;
}

/// How the coefficients become codes (`normalize.coef_quant`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CoefQuant {
    /// Each rounded to the `coef` format.
    Round,
    /// The best codes found by search around the rounded ones.
    Search,
}

crate::deserialize_by_name!(Method, Interval, Fit);

/// The fast normalizer as a registered unit.
pub struct NormalizeUnit;

crate::unit!(NormalizeUnit, decl: DECL, section: NormalizeConfig, check: check, ops: ops,
    rtl: &[&RTL]);

/// The registry entry.
pub static UNIT: NormalizeUnit = NormalizeUnit;

/// The unit's generated RTL: variants, design and input vectors.
pub static RTL: crate::rtl::units::RtlUnit = crate::rtl::units::RtlUnit {
    name: "normalize",
    doc: "method A: N·g(N·N)",
    variants: &[
        ("none", "normalize.method=\"none\""),
        ("newton", "normalize.method=\"newton\""),
        ("taylor", "normalize.method=\"taylor\""),
        ("linear", "normalize.method=\"linear\""),
        ("quadratic", "normalize.method=\"quadratic\""),
    ],
    build: crate::normalizer::rtl::design,
    inputs: crate::normalizer::rtl::inputs,
};

/// Which `g(d)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// `1/√d` (a square root and a division).
    Exact,
    /// No normalization.
    None,
    /// One Newton–Raphson step from 1: `(3 − d)/2`.
    Newton,
    /// Three Taylor terms about 1: `(15 − 10d + 3d²)/8`.
    Taylor,
    /// `k·d + p`.
    Linear,
    /// `a·d² + b·d + c`, by Horner.
    Quadratic,
}

impl Method {
    /// Every method.
    pub const ALL: [Method; 6] = [
        Method::Exact,
        Method::None,
        Method::Newton,
        Method::Taylor,
        Method::Linear,
        Method::Quadratic,
    ];
    /// Configuration name.
    pub const fn name(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::None => "none",
            Method::Newton => "newton",
            Method::Taylor => "taylor",
            Method::Linear => "linear",
            Method::Quadratic => "quadratic",
        }
    }
    /// Parse a name.
    pub fn from_name(s: &str) -> Option<Method> {
        Self::ALL.into_iter().find(|m| m.name() == s)
    }
    /// Degree of the designed polynomial, for linear and quadratic.
    pub const fn degree(self) -> Option<usize> {
        match self {
            Method::Linear => Some(1),
            Method::Quadratic => Some(2),
            _ => None,
        }
    }
}

/// Which interval of `d` the coefficients are fitted on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Interval {
    /// `[(1+Θ)/2, 1]`: the paper's, valid on triangle edges.
    Edge,
    /// `[(1+2Θ)/3, 1]`: valid over whole triangles.
    Triangle,
}

impl Interval {
    /// Configuration name.
    pub const fn name(self) -> &'static str {
        match self {
            Interval::Edge => "edge",
            Interval::Triangle => "triangle",
        }
    }
    /// Parse a name.
    pub fn from_name(s: &str) -> Option<Interval> {
        [Interval::Edge, Interval::Triangle]
            .into_iter()
            .find(|i| i.name() == s)
    }
    /// `[lo, 1]` for threshold `theta`.
    pub fn bounds(self, theta: f64) -> (f64, f64) {
        match self {
            Interval::Edge => ((1.0 + theta) / 2.0, 1.0),
            Interval::Triangle => ((1.0 + 2.0 * theta) / 3.0, 1.0),
        }
    }
}

/// The formats of the normalizer's ports and stages.
#[derive(Clone, Copy, Debug)]
pub struct Stages {
    /// Input components.
    pub normal: Quant,
    /// `d`.
    pub d: Quant,
    /// Coefficient registers.
    pub coef: Quant,
    /// Horner intermediate.
    pub horner: Quant,
    /// `√d` (exact variant).
    pub sqrt: Quant,
    /// `g`.
    pub g: Quant,
    /// Output components.
    pub out: Quant,
}

/// A normalizer: method, stage formats and (for linear and quadratic) the
/// coefficient values its registers hold.
#[derive(Clone, Debug)]
pub struct Normalizer {
    /// Which `g`.
    pub method: Method,
    /// Formats.
    pub q: Stages,
    /// Coefficient values, lowest power first (exactly representable in
    /// `q.coef`); empty for the other methods.
    pub coeffs: Vec<f64>,
}

/// The coefficient registers and literals, loaded into a context once.
#[derive(Clone, Debug)]
pub struct Consts<V> {
    coef: Vec<V>,
    one: V,
    three: V,
    ten: V,
    fifteen: V,
}

impl Normalizer {
    /// The stage formats of a `[normalize]` section.
    pub fn stages(u: &NormalizeConfig) -> Stages {
        Stages {
            normal: u.normal,
            d: u.d,
            coef: u.coef,
            horner: u.horner,
            sqrt: u.sqrt,
            g: u.g,
            out: u.out,
        }
    }

    /// Load constants into a context.
    ///
    /// # Errors
    ///
    /// The [`ConvertError`] of `cx.constant` for a coefficient that is NaN or infinite (the
    /// literals 1, 3, 10 and 15 always convert); designed coefficients never are.
    pub fn consts<C: Datapath>(&self, cx: &mut C) -> Result<Consts<C::V>, ConvertError> {
        Ok(Consts {
            coef: self
                .coeffs
                .iter()
                .map(|&c| cx.constant(c, &self.q.coef))
                .collect::<Result<_, _>>()?,
            one: cx.constant(1.0, &literal(1))?,
            three: cx.constant(3.0, &literal(3))?,
            ten: cx.constant(10.0, &literal(10))?,
            fifteen: cx.constant(15.0, &literal(15))?,
        })
    }

    /// `g(d)` for a quantized `d` (the scalar stage).
    #[inline]
    pub fn g_of_d<C: Datapath>(&self, cx: &mut C, k: &Consts<C::V>, d: C::V) -> C::V {
        let q = &self.q;
        match self.method {
            Method::Exact => {
                let s = cx.sqrt(d, &q.sqrt);
                cx.div(k.one, s, &q.g)
            }
            Method::None => cx.quantize(k.one, &q.g),
            Method::Newton => {
                let t = cx.sub(k.three, d);
                let t = cx.shl(t, -1);
                cx.quantize(t, &q.g)
            }
            Method::Taylor => {
                let t = cx.mul(k.three, d);
                let t = cx.sub(t, k.ten);
                let t = cx.mul_add(t, d, k.fifteen);
                let t = cx.shl(t, -3);
                cx.quantize(t, &q.g)
            }
            Method::Linear => {
                let t = cx.mul_add(k.coef[1], d, k.coef[0]);
                cx.quantize(t, &q.g)
            }
            Method::Quadratic => {
                let t = cx.mul_add(k.coef[2], d, k.coef[1]);
                let t = cx.quantize(t, &q.horner);
                let t = cx.mul_add(t, d, k.coef[0]);
                cx.quantize(t, &q.g)
            }
        }
    }

    /// `d = Q_d(N·N)`.
    #[inline]
    pub fn d_of<C: Datapath>(&self, cx: &mut C, n: [C::V; 3]) -> C::V {
        let d = cx.dot3(n, n);
        cx.quantize(d, &self.q.d)
    }

    /// The whole unit: `N' = Q_out(N·g(Q_d(N·N)))`.
    #[inline]
    pub fn eval<C: Datapath>(&self, cx: &mut C, k: &Consts<C::V>, n: [C::V; 3]) -> [C::V; 3] {
        cx.enter(DECL.name);
        let out = if self.method == Method::None {
            cx.quantize3(n, &self.q.out)
        } else {
            let d = self.d_of(cx, n);
            let g = self.g_of_d(cx, k, d);
            let p = [cx.mul(n[0], g), cx.mul(n[1], g), cx.mul(n[2], g)];
            cx.quantize3(p, &self.q.out)
        };
        cx.leave();
        out
    }

    /// Constants whose coefficients are chosen per vector by `sel` among
    /// `sets` (one multiplexer per coefficient; a code past the last set
    /// reads set 0). The literals are the first set's.
    pub fn select_consts<C: Datapath>(
        cx: &mut C,
        sel: C::V,
        sets: &[Consts<C::V>],
    ) -> Consts<C::V> {
        let n = sets[0].coef.len();
        let coef = (0..n)
            .map(|j| {
                let opts: Vec<C::V> = sets.iter().map(|s| s.coef[j]).collect();
                cx.select(sel, &opts)
            })
            .collect();
        Consts {
            coef,
            ..sets[0].clone()
        }
    }

    /// Run once in the counting context.
    ///
    /// # Errors
    ///
    /// A [`ConvertError`] for a NaN or infinite coefficient ([`Normalizer::consts`]).
    ///
    /// # Panics
    ///
    /// If `coeffs` holds fewer values than the method's polynomial has coefficients (2 for linear,
    /// 3 for quadratic): never for a designed normalizer.
    pub fn count(&self) -> Result<Count, ConvertError> {
        let mut cx = Count::new();
        let k = self.consts(&mut cx)?;
        let n = [cx.constant(0.0, &self.q.normal)?; 3];
        self.eval(&mut cx, &k, n);
        Ok(cx)
    }

    /// The whole unit compiled for batches: inputs Nx, Ny, Nz; outputs the
    /// three components.
    ///
    /// # Errors
    ///
    /// [`CompileError::Width`](crate::datapath::CompileError::Width) when an exact intermediate is
    /// wider than [`MAX_EXACT_WIDTH`](crate::datapath::MAX_EXACT_WIDTH).
    ///
    /// # Panics
    ///
    /// If a coefficient is NaN or infinite, or `coeffs` holds fewer values than the method's
    /// polynomial has coefficients (2 for linear, 3 for quadratic): never for a designed
    /// normalizer.
    pub fn compile(&self) -> Result<Compiled, crate::datapath::CompileError> {
        self.trace().expect("finite constants").compile_outputs()
    }

    /// The unit traced with named ports: inputs `n_x, n_y, n_z` (normal
    /// format), outputs `out_x, out_y, out_z` (out format).
    ///
    /// # Errors
    ///
    /// As [`Normalizer::count`].
    ///
    /// # Panics
    ///
    /// As [`Normalizer::count`].
    pub fn trace(&self) -> Result<Trace, ConvertError> {
        let mut tr = Trace::new();
        let n = tr.input3("n", &self.q.normal);
        let k = self.consts(&mut tr)?;
        let out = self.eval(&mut tr, &k, n);
        tr.output3("out", out);
        Ok(tr)
    }

    /// The scalar `g(d)` stage compiled for batches: input a `d` code,
    /// output the `g` code.
    ///
    /// # Errors
    ///
    /// [`CompileError::Width`](crate::datapath::CompileError::Width) when an exact intermediate is
    /// wider than [`MAX_EXACT_WIDTH`](crate::datapath::MAX_EXACT_WIDTH).
    ///
    /// # Panics
    ///
    /// As [`Normalizer::compile`].
    pub fn compile_g(&self) -> Result<Compiled, crate::datapath::CompileError> {
        let mut tr = Trace::new();
        let d = tr.input(&self.q.d);
        let k = self.consts(&mut tr).expect("finite constants");
        let g = self.g_of_d(&mut tr, &k, d);
        Compiled::compile(&tr, &[g])
    }
}

/// How the coefficients of a linear or quadratic normalizer were obtained.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Design {
    /// Θ.
    pub theta: f64,
    /// The fit.
    pub fit: Fit,
    /// The interval kind.
    pub interval_kind: Interval,
    /// `[lo, hi]`.
    pub interval: (f64, f64),
    /// The real coefficients, lowest power first (serialized highest power
    /// first, [`coeffs::ORDER`]).
    #[serde(serialize_with = "poly_highest_first")]
    pub real: Poly,
    /// `max |g·√d − 1|` of the real coefficients (exact).
    pub real_max_rel_err: f64,
    /// Rounded to the coefficient format.
    pub rounded: CoeffChoice,
    /// The best codes found by search (re-ranked by the bit-accurate model).
    pub searched: CoeffChoice,
    /// Whether the code search was exhaustive (false: it stopped after
    /// [`coeffs::SEARCH_LEAVES`] code sets, nearest the optimum first).
    pub search_complete: bool,
    /// Which of the two the normalizer uses.
    pub used: &'static str,
}

/// A coefficient vector held lowest power first, written in the one order
/// fxshade shows ([`coeffs::ORDER`]: highest power first).
fn highest_first<S: serde::Serializer, T: serde::Serialize>(
    v: &[T],
    s: S,
) -> Result<S::Ok, S::Error> {
    s.collect_seq(v.iter().rev())
}

fn poly_highest_first<S: serde::Serializer>(p: &Poly, s: S) -> Result<S::Ok, S::Error> {
    highest_first(&p.0, s)
}

/// One quantized coefficient set and its errors.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CoeffChoice {
    /// Codes in the coefficient format, lowest power first (serialized
    /// highest power first, [`coeffs::ORDER`]).
    #[serde(serialize_with = "highest_first")]
    pub codes: Vec<i128>,
    /// Their values, lowest power first (serialized highest first).
    #[serde(serialize_with = "highest_first")]
    pub values: Vec<f64>,
    /// `max |g·√d − 1|` in real arithmetic with these values (exact).
    pub max_rel_err_real: f64,
    /// `max |g·√d − 1|` through the bit-accurate `g(d)` stage over the `d`
    /// codes in the interval: attained at a code ([`g_stage_max`]; every
    /// code up to [`EXHAUSTIVE_CODES`]).
    pub max_rel_err_model: f64,
    /// A rigorous upper bound on it (equal when every code was evaluated,
    /// within 1/64 above otherwise).
    pub max_rel_err_model_bound: f64,
}

/// Why a normalizer could not be built from a configuration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DesignError {
    /// Coefficient design failed.
    #[error(transparent)]
    Coeff(#[from] CoeffError),
    /// The datapath is too wide.
    #[error(transparent)]
    Compile(#[from] crate::datapath::CompileError),
}

/// Design linear or quadratic coefficients for `stages`, and build the
/// normalizer that uses them (`search` picks the searched set).
///
/// # Errors
///
/// For linear and quadratic only (the other methods never fail): [`DesignError::Coeff`] when the
/// coefficients cannot be designed on `interval` for `theta` ([`coeffs::design`]) or rounded to the
/// `coef` format ([`coeffs::quantize_coeffs`]); [`DesignError::Compile`] when the `g(d)` stage does
/// not compile ([`Normalizer::compile_g`]).
pub fn design(
    method: Method,
    stages: Stages,
    theta: f64,
    fit: Fit,
    interval: Interval,
    search: bool,
) -> Result<(Normalizer, Option<Design>), DesignError> {
    design_interval(
        method,
        stages,
        theta,
        fit,
        interval,
        interval.bounds(theta),
        search,
    )
}

/// As [`design`], on an explicit interval `[lo, hi]`.
///
/// Designs are remembered for the life of the process (keyed by every
/// argument, f64s by their bits): the coefficient search and the
/// bit-accurate scoring take up to seconds, and a vector stream, a render
/// or a sweep asks for the same design many times.
///
/// # Errors
///
/// As [`design`], on `[lo, hi]`. An error is remembered like a result.
pub fn design_interval(
    method: Method,
    stages: Stages,
    theta: f64,
    fit: Fit,
    interval: Interval,
    (lo, hi): (f64, f64),
    search: bool,
) -> Result<(Normalizer, Option<Design>), DesignError> {
    type Memo =
        std::collections::HashMap<String, Result<(Normalizer, Option<Design>), DesignError>>;
    static MEMO: std::sync::OnceLock<std::sync::Mutex<Memo>> = std::sync::OnceLock::new();
    let key = format!(
        "{method:?}|{stages:?}|{:x}|{fit:?}|{interval:?}|{:x}|{:x}|{search}",
        theta.to_bits(),
        lo.to_bits(),
        hi.to_bits()
    );
    let memo = MEMO.get_or_init(Default::default);
    if let Some(r) = memo.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return r.clone();
    }
    let r = design_uncached(method, stages, theta, fit, interval, (lo, hi), search);
    memo.lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(key, r.clone());
    r
}

fn design_uncached(
    method: Method,
    stages: Stages,
    theta: f64,
    fit: Fit,
    interval: Interval,
    (lo, hi): (f64, f64),
    search: bool,
) -> Result<(Normalizer, Option<Design>), DesignError> {
    let Some(degree) = method.degree() else {
        return Ok((
            Normalizer {
                method,
                q: stages,
                coeffs: Vec::new(),
            },
            None,
        ));
    };
    let real = coeffs::design(fit, lo, hi, degree)?;
    let cf = stages.coef.format();
    let (rounded, cands, search_complete) = coeffs::quantize_coeffs(&real, cf, lo, hi)?;
    // The bit-accurate error of a coefficient set; `None` when it is known
    // to exceed `stop` (the set cannot win).
    let model_err = |values: &[f64], stop: Option<f64>| -> Result<Option<GMax>, DesignError> {
        let n = Normalizer {
            method,
            q: stages,
            coeffs: values.to_vec(),
        };
        let m = g_stage_max(&n, lo, hi, stop)?;
        Ok((m.bound.is_finite()).then_some(m))
    };
    let choice = |q: &coeffs::Quantized, m: GMax| CoeffChoice {
        codes: q.codes.clone(),
        values: q.values.clone(),
        max_rel_err_real: q.max_rel_err,
        max_rel_err_model: m.max,
        max_rel_err_model_bound: m.bound,
    };
    let m = model_err(&rounded.values, None)?.expect("no stop: always measured");
    let rounded = choice(&rounded, m);
    // Re-rank the search's candidates (and rounding's) by the bit-accurate
    // model's guaranteed bound, so the searched set never does worse than
    // rounding; a candidate is dropped as soon as one of its errors exceeds
    // the best bound so far.
    let mut searched = rounded.clone();
    for c in &cands {
        if let Some(m) = model_err(&c.values, Some(searched.max_rel_err_model_bound))? {
            if m.bound < searched.max_rel_err_model_bound {
                searched = choice(c, m);
            }
        }
    }
    let used = if search { &searched } else { &rounded };
    let n = Normalizer {
        method,
        q: stages,
        coeffs: used.values.clone(),
    };
    let real_max_rel_err = coeffs::max_rel_err(&real, lo, hi).0;
    Ok((
        n,
        Some(Design {
            theta,
            fit,
            interval_kind: interval,
            interval: (lo, hi),
            real,
            real_max_rel_err,
            rounded: rounded.clone(),
            searched,
            search_complete,
            used: if search { "search" } else { "round" },
        }),
    ))
}

/// Statistics of a relative error over a set of samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Stats {
    /// Number of samples.
    pub samples: u64,
    /// Largest.
    pub max_rel_err: f64,
    /// Mean.
    pub mean_rel_err: f64,
    /// Root mean square.
    pub rms_rel_err: f64,
    /// Where (the input value) the largest occurred.
    pub worst_at: f64,
    /// Overflows counted at quantization steps.
    pub overflows: u64,
    /// When the samples are a subset of the inputs: a rigorous upper bound
    /// on the error over every input (`max_rel_err` is then the largest
    /// error found).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rel_err_bound: Option<f64>,
}

impl Stats {
    /// Accumulate one error.
    pub fn add(&mut self, e: f64, at: f64) {
        self.samples += 1;
        if e > self.max_rel_err {
            self.max_rel_err = e;
            self.worst_at = at;
        }
        self.mean_rel_err += e;
        self.rms_rel_err += e * e;
    }
    /// Turn the sums into a mean and an RMS.
    pub fn finish(mut self) -> Self {
        if self.samples > 0 {
            self.mean_rel_err /= to_f64(self.samples);
            self.rms_rel_err = (self.rms_rel_err / to_f64(self.samples)).sqrt();
        }
        self
    }
}

/// Codes of `d` up to which the `g(d)` stage is analysed code by code; above
/// it, [`g_stage_max`] bounds the maximum by interval branch-and-bound and
/// [`g_stage_stats`] takes the mean and RMS from an even subsample.
pub const EXHAUSTIVE_CODES: i128 = 1 << 22;

/// The largest error `|g·√d − 1|` of the bit-accurate `g(d)` stage over the
/// `d` codes of an interval.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct GMax {
    /// The largest error found at a code (attained: it is an actual code's
    /// error).
    pub max: f64,
    /// The `d` value where it occurs.
    pub at: f64,
    /// A rigorous upper bound on every code's error (`== max` when every
    /// code was evaluated).
    pub bound: f64,
    /// Whether every code was evaluated.
    pub exhaustive: bool,
}

/// The codes of `d` in `[lo, hi]`.
fn d_codes(n: &Normalizer, lo: f64, hi: f64) -> (i128, i128) {
    let fd = n.q.d.format();
    let c_lo = (from_f64::<i128>((lo / fd.ulp()).ceil())).max(fd.min_code());
    let c_hi = (from_f64::<i128>((hi / fd.ulp()).floor())).min(fd.max_code());
    (c_lo, c_hi)
}

/// Largest error of the `g(d)` stage over the `d` codes in `[lo, hi]`.
///
/// Up to [`EXHAUSTIVE_CODES`] codes every code is evaluated. Above, a
/// branch-and-bound over ranges of codes: each range's outputs are bounded by
/// [`Compiled::run_interval`] (rigorous: every quantization is monotonic),
/// which bounds `g·√d − 1` over the range; ranges whose bound cannot exceed
/// the largest error found so far are dropped, the others split (and
/// enumerated once they hold at most 4096 codes). It stops when no range's
/// bound exceeds the largest error found by more than 1/64 of it, so
/// `max ≤ true maximum ≤ bound ≤ max·(1 + 1/64)` (plus a relative 10⁻¹²
/// for the f64 evaluation of the bound).
///
/// With `stop_above`, returns as soon as an error above it is found (the
/// caller only needs to know the set is worse than that): `max` is then
/// that error, and `bound` is `f64::INFINITY`.
///
/// # Errors
///
/// [`DesignError::Compile`] when the `g(d)` stage of `n` does not compile
/// ([`Normalizer::compile_g`]).
///
/// # Panics
///
/// As [`Normalizer::compile_g`].
pub fn g_stage_max(
    n: &Normalizer,
    lo: f64,
    hi: f64,
    stop_above: Option<f64>,
) -> Result<GMax, DesignError> {
    let prog = n.compile_g()?;
    let (c_lo, c_hi) = d_codes(n, lo, hi);
    let (ud, ug) = (n.q.d.format().ulp(), n.q.g.format().ulp());
    let stop = stop_above.unwrap_or(f64::INFINITY);
    let err = |c: i128, g: i128| {
        let d = to_f64(c) * ud;
        ((to_f64(g) * ug) * d.sqrt() - 1.0).abs()
    };
    let mut best = GMax {
        max: 0.0,
        at: lo,
        bound: 0.0,
        exhaustive: true,
    };
    // The errors of `codes` into `best`; false when one is above `stop`.
    let score = |codes: &[i128], best: &mut GMax| -> bool {
        let (out, _) = prog.run_i128(&[codes]);
        for (&c, &g) in codes.iter().zip(&out[0]) {
            let e = err(c, g);
            if e > best.max {
                best.max = e;
                best.at = to_f64(c) * ud;
            }
        }
        best.max <= stop
    };
    // Every code of [a, b]; false when it found an error above `stop`.
    let enumerate = |a: i128, b: i128, best: &mut GMax| -> bool {
        const CHUNK: i128 = 1 << 12;
        let mut codes: Vec<i128> = Vec::with_capacity(CHUNK as usize);
        let mut start = a;
        while start <= b {
            let end = (start + CHUNK - 1).min(b);
            codes.clear();
            codes.extend(start..=end);
            if !score(&codes, best) {
                return false;
            }
            start = end + 1;
        }
        true
    };
    if c_lo > c_hi {
        return Ok(best);
    }
    if c_hi - c_lo < EXHAUSTIVE_CODES {
        if !enumerate(c_lo, c_hi, &mut best) {
            best.bound = f64::INFINITY;
            return Ok(best);
        }
        best.bound = best.max;
        return Ok(best);
    }
    // Branch and bound.
    let range_bound = |a: i128, b: i128| -> Option<f64> {
        let (g0, g1) = prog.run_interval(&[(a, b)])?[0];
        let (s0, s1) = ((to_f64(a) * ud).sqrt(), (to_f64(b) * ud).sqrt());
        let (g0, g1) = (to_f64(g0) * ug, to_f64(g1) * ug);
        let p = [g0 * s0, g0 * s1, g1 * s0, g1 * s1];
        let pmin = p.iter().cloned().fold(f64::INFINITY, f64::min);
        let pmax = p.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        Some((pmin - 1.0).abs().max((pmax - 1.0).abs()) * (1.0 + 1e-12))
    };
    #[derive(PartialEq)]
    struct Range(f64, i128, i128);
    impl Eq for Range {}
    impl PartialOrd for Range {
        fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(o))
        }
    }
    impl Ord for Range {
        fn cmp(&self, o: &Self) -> std::cmp::Ordering {
            self.0.total_cmp(&o.0)
        }
    }
    let mut heap = std::collections::BinaryHeap::new();
    let split = |a: i128,
                 b: i128,
                 best: &mut GMax,
                 heap: &mut std::collections::BinaryHeap<Range>|
     -> bool {
        const WAYS: i128 = 16;
        let step = ((b - a + 1) + WAYS - 1) / WAYS;
        let mut bounds = Vec::new();
        let mut x = a;
        while x <= b {
            let y = (x + step - 1).min(b);
            bounds.push((x, y));
            x = y + 1;
        }
        // Exact errors at the ends of every part: the attained maximum.
        let ends: Vec<i128> = bounds.iter().flat_map(|&(x, y)| [x, y]).collect();
        if !score(&ends, best) {
            return false;
        }
        for (x, y) in bounds {
            if y - x < 4096 {
                heap.push(Range(f64::INFINITY, x, y));
            } else {
                heap.push(Range(range_bound(x, y).unwrap_or(f64::INFINITY), x, y));
            }
        }
        true
    };
    if !split(c_lo, c_hi, &mut best, &mut heap) {
        best.bound = f64::INFINITY;
        best.exhaustive = false;
        return Ok(best);
    }
    best.exhaustive = false;
    while let Some(Range(u, a, b)) = heap.pop() {
        if u <= best.max * (1.0 + 1.0 / 64.0) {
            best.bound = u.max(best.max);
            return Ok(best);
        }
        let ok = if b - a < 4096 {
            enumerate(a, b, &mut best)
        } else {
            split(a, b, &mut best, &mut heap)
        };
        if !ok {
            best.bound = f64::INFINITY;
            return Ok(best);
        }
    }
    // Every range was enumerated.
    best.bound = best.max;
    best.exhaustive = true;
    Ok(best)
}

/// Analysis of the scalar stage over the `d` codes in `[lo, hi]` through
/// the bit-accurate `g(d)`, error `|g·√d − 1|` with `d` the code's exact
/// value. Up to [`EXHAUSTIVE_CODES`] codes, every code; above, the mean and
/// RMS come from every k-th code (an even subsample of about
/// [`EXHAUSTIVE_CODES`] codes, `samples` says how many) and the maximum from
/// [`g_stage_max`] (`max_rel_err` attained, `max_rel_err_bound` rigorous).
///
/// # Errors
///
/// [`DesignError::Compile`] when the `g(d)` stage of `n` does not compile
/// ([`Normalizer::compile_g`]).
///
/// # Panics
///
/// As [`Normalizer::compile_g`].
pub fn g_stage_stats(n: &Normalizer, lo: f64, hi: f64) -> Result<Stats, DesignError> {
    let (c_lo, c_hi) = d_codes(n, lo, hi);
    let fd = n.q.d.format();
    let prog = n.compile_g()?;
    let fg = n.q.g.format();
    let mut st = Stats::default();
    let stride = ((c_hi - c_lo + 1) / EXHAUSTIVE_CODES).max(1);
    // In chunks: a wide `d` format has tens of millions of codes.
    // Codes of at most 64 bits convert to f64 through i64 (exactly as
    // `Format::to_f64` does for them, and far faster than from i128).
    const CHUNK: i128 = 1 << 12;
    let (ud, ug) = (fd.ulp(), fg.ulp());
    let mut codes: Vec<i128> = Vec::with_capacity(CHUNK as usize);
    let mut start = c_lo;
    while start <= c_hi {
        codes.clear();
        let mut c = start;
        while c <= c_hi && codes.len() < CHUNK as usize {
            codes.push(c);
            c += stride;
        }
        let (out, ov) = prog.run_i128(&[&codes]);
        for (&c, &g) in codes.iter().zip(&out[0]) {
            let d = to_f64(narrow::<i64, _>(c)) * ud;
            st.add((to_f64(narrow::<i64, _>(g)) * ug * d.sqrt() - 1.0).abs(), d);
        }
        st.overflows += ov.iter().map(|(_, k)| k).sum::<u64>();
        start = c;
    }
    let mut st = st.finish();
    if stride > 1 {
        let m = g_stage_max(n, lo, hi, None)?;
        if m.max >= st.max_rel_err {
            st.max_rel_err = m.max;
            st.worst_at = m.at;
        }
        st.max_rel_err_bound = Some(m.bound.max(st.max_rel_err));
    }
    Ok(st)
}

/// The normalizer a configuration describes (with its design, for linear and
/// quadratic).
///
/// # Errors
///
/// As [`design`] for the `[normalize]` section of `cfg`.
pub fn from_config(cfg: &Config) -> Result<(Normalizer, Option<Design>), DesignError> {
    let u: NormalizeConfig = cfg.section();
    design(
        u.method,
        Normalizer::stages(&u),
        u.theta,
        u.fit,
        u.interval,
        u.coef_quant == CoefQuant::Search,
    )
}

/// A normalizer of `method` with the configured stages, and stand-in
/// coefficients (for counting and width checks, which do not depend on the
/// values).
fn with_method(u: &NormalizeConfig, method: Method) -> Normalizer {
    Normalizer {
        method,
        q: Normalizer::stages(u),
        coeffs: vec![0.0; method.degree().map_or(0, |d| d + 1)],
    }
}

fn check(cfg: &Config) -> Result<(), Vec<ConfigError>> {
    let u = cfg.unit(DECL.name);
    let s: NormalizeConfig = cfg.section();
    for m in Method::ALL {
        let cx = with_method(&s, m)
            .count()
            .map_err(|e| vec![crate::config::field_error(u, "coef", e.to_string())])?;
        width_errors(&cx, u)?;
    }
    coefficients_fit(cfg)
}

/// The linear and quadratic coefficients every command may design — for
/// the configured Θ on its interval, and for each Θ of the pipeline's ladder
/// on the range the configured interpolation produces — must be finite and
/// fit `normalize.coef.format` once rounded (the search starts there). Cheap:
/// the real fits and one rounding, no bit-accurate scoring.
fn coefficients_fit(cfg: &Config) -> Result<(), Vec<ConfigError>> {
    use crate::config::field_error;
    let u = cfg.unit(DECL.name);
    let s: NormalizeConfig = cfg.section();
    let (fit, kind, theta) = (s.fit, s.interval, s.theta);
    let scheme = cfg.section::<crate::interp::InterpConfig>().scheme;
    let cf = s.coef.format();
    let mut cases = vec![(theta, kind.bounds(theta))];
    for &t in &crate::interp::THETA_LADDER {
        let range = match kind {
            Interval::Edge => kind.bounds(t),
            Interval::Triangle => crate::interp::quadratic_d_range(t, scheme),
        };
        cases.push((t, range));
    }
    for degree in [1usize, 2] {
        let what = if degree == 1 { "linear" } else { "quadratic" };
        for &(t, (lo, hi)) in &cases {
            let real = coeffs::design(fit, lo, hi, degree).map_err(|e| {
                vec![field_error(
                    u,
                    "theta",
                    format!("the {what} g(d) for Θ = {t} on [{lo}, {hi}]: {e}"),
                )]
            })?;
            coeffs::round_coeffs(&real, cf, lo, hi).map_err(|e| {
                vec![field_error(
                    u,
                    "coef",
                    format!(
                        "the {what} g(d) for Θ = {t}: {e}; widen the integer part of the format"
                    ),
                )]
            })?;
        }
    }
    Ok(())
}

/// The paper's claims (methods.md, section A).
fn claim(m: Method) -> Option<PaperClaim> {
    let c = |mul, add, div, sqrt, source| {
        Some(PaperClaim {
            mul: Some(mul),
            add: Some(add),
            div: Some(div),
            sqrt: Some(sqrt),
            table_read: Some(0),
            source,
        })
    };
    match m {
        Method::Linear => c(7, 3, 0, 0, "normalization paper: 7 mul, 3 add"),
        Method::Quadratic => c(8, 4, 0, 0, "normalization paper: 8 mul, 4 add (Horner)"),
        Method::Newton => c(
            9,
            3,
            1,
            0,
            "paper's count for Hast et al.'s full formula, not (3−d)/2",
        ),
        Method::Exact => Some(PaperClaim {
            mul: None,
            add: None,
            div: Some(1),
            sqrt: Some(1),
            table_read: Some(0),
            source: "normalization paper: one square root and one division",
        }),
        _ => None,
    }
}

fn ops(cfg: &Config) -> Vec<OpReport> {
    let u: NormalizeConfig = cfg.section();
    Method::ALL
        .into_iter()
        .filter_map(|m| {
            let cx = with_method(&u, m).count().ok()?;
            Some(OpReport::from_count(
                DECL.name,
                m.name(),
                Phase::Pixel,
                &cx,
                claim(m),
            ))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_match_the_paper_for_linear_and_quadratic() {
        let cfg = Config::embedded();
        let r = ops(&cfg);
        let get = |v: &str| r.iter().find(|x| x.variant == v).unwrap();
        assert_eq!((get("linear").counts.mul, get("linear").counts.add), (7, 3));
        assert_eq!(
            (get("quadratic").counts.mul, get("quadratic").counts.add),
            (8, 4)
        );
        assert_eq!((get("exact").counts.sqrt, get("exact").counts.div), (1, 1));
        assert_eq!(get("none").counts.mul, 0);
    }

    #[test]
    fn triangle_interval_holds_by_sampling() {
        // Equiangular triangles at exactly Θ reach (1+2Θ)/3 at the centroid;
        // random triangles meeting Θ never go below it.
        let mut rng = crate::sampling::Rng::new(7);
        for &theta in &[0.0, 0.5, 0.75, 0.875, 0.9375, 0.96875] {
            let lo = Interval::Triangle.bounds(theta).0;
            let tri = crate::sampling::equiangular(theta, &mut rng);
            let c = crate::sampling::lerp3(&tri, [1.0 / 3.0; 3]);
            assert!((c.length_squared() - lo).abs() < 1e-12, "{theta}");
            let mut min: f64 = 1.0;
            for _ in 0..20_000 {
                let t = crate::sampling::triangle_meeting(theta, &mut rng);
                let b = rng.barycentric();
                let d = crate::sampling::lerp3(&t, b).length_squared();
                assert!(d >= lo - 1e-12 && d <= 1.0 + 1e-12, "{theta}: {d}");
                min = min.min(d);
            }
            // Sampling gets close to the bound, and the edge bound is beaten.
            assert!(
                min < Interval::Edge.bounds(theta).0 || theta > 0.9,
                "{theta}: {min}"
            );
        }
    }
}
