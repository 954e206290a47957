//! Method C: the normal at any point of a triangle, by quadratic
//! interpolation over barycentric coordinates (linear interpolation as the
//! baseline).
//!
//! ## Set-up (once per triangle)
//! From unit vertex normals `N1, N2, N3`: `cos φ = min(N_i·N_j)` and the
//! largest Θ of the ladder {0, ½, ¾, ⅞, 15/16, 31/32} it meets, and the
//! unit edge-midpoint normals `N_ij = (N_i + N_j)/√(2(1 + N_i·N_j))`. The
//! paper's per-triangle constants are `M_ij = 4·N_ij`; fxshade stores `N_ij`
//! (unit, in the vertex format) and folds the 4 into the per-pixel weight as
//! a shift. The set-up uses an exact reciprocal square root in the model
//! (one square root and one division per edge, counted by `fxshade ops`).
//!
//! ## Per pixel
//! ```text
//! c3   = 1 − c1 − c2                                  (exact; 2 sub)
//! w_i  = Q_w(c_i·(2c_i − 1))        i = 1, 2, 3       (3 mul, 3 sub)
//! u_ij = Q_w(4·c_i·c_j)             ij = 12, 23, 31   (3 mul; ×4 is a shift)
//! N    = Q_out(Σ w_i·N_i + Σ u_ij·N_ij)               (18 mul, 15 add)
//! ```
//! The linear baseline is `N = Q_out(c1·N1 + c2·N2 + c3·N3)`.
//!
//! ## Degenerate input (each a defined outcome, never NaN or a panic)
//! * a vertex normal that is zero, NaN or infinite: [`SetupError`];
//! * a non-unit vertex normal: normalized first (the scheme assumes unit
//!   normals; the fallback is documented, not an error);
//! * antiparallel vertex normals (`N_i·N_j ≤ −1 + 10⁻⁹`), where `N_ij` is
//!   undefined: [`SetupError::Antiparallel`];
//! * barycentrics: the evaluator takes `c1, c2` and derives `c3 = 1 − c1 −
//!   c2`, so they sum to one by construction; [`Barycentric::new`] rejects
//!   non-finite values, values below −10⁻⁹ and sums off one by more than
//!   10⁻⁹, and the unsigned `bary` format cannot carry a negative `c1, c2`.
//!   Codes with `c1 + c2 > 1` give `c3 < 0`: the formula extrapolates off
//!   the triangle, defined and bounded, as the RTL does.
//!
//! ## The range of `d = |N|²`
//! Linear: `[(1 + 2Θ)/3, 1]` (see `normalizer`). Quadratic: the field is
//! exact (unit) at the vertices and edge midpoints; its shortest vector over
//! triangles meeting Θ is at the centroid of the equiangular triangle whose
//! normals are pairwise at exactly `φ = acos Θ` (every pairwise angle at its
//! largest: spreading the normals apart only shortens the interpolant). There
//! `Σ N_i = 3h·a` and `Σ N_ij = 6h·a/√(2(1+Θ))` along the axis `a`, with
//! `h² = (1+2Θ)/3`, and the weights are `−1/9` and `4/9`, so
//! `d_min = h²·((8/√(2(1+Θ)) − 1)/3)²` ([`quadratic_d_range`]): 0.8032 at
//! Θ = 0 against 1/3 for linear interpolation. The maximum is 1, at the
//! vertices and midpoints. Both are checked by sampling random triangles.

use glam::DVec3;

use crate::config::{Config, ConfigError, FieldDecl, FieldKind, UnitDecl};
use crate::datapath::{Compiled, Count, Datapath, Trace};
use crate::format::ConvertError;
use crate::quantize::{Overflow, Quant, Rounding};
use crate::units::{width_errors, OpReport, Phase};

pub mod rtl;

/// The `[interp]` configuration section.
pub static DECL: UnitDecl = UnitDecl {
    name: "interp",
    doc: "method C: the normal inside a triangle by quadratic (or linear) interpolation",
    fields: &[
        FieldDecl {
            name: "bary",
            kind: FieldKind::Stage,
            doc: "input port: barycentric coordinates c1, c2 (c3 = 1 − c1 − c2)",
        },
        FieldDecl {
            name: "vertex",
            kind: FieldKind::Stage,
            doc: "input port: vertex normals N1..N3 and edge-midpoint normals N12, N23, N31",
        },
        FieldDecl {
            name: "weight",
            kind: FieldKind::Stage,
            doc: "quadratic weights c_i(2c_i − 1) and 4·c_i·c_j",
        },
        FieldDecl {
            name: "out",
            kind: FieldKind::Stage,
            doc: "output port: the interpolated (unnormalized) normal",
        },
        FieldDecl {
            name: "scheme",
            kind: FieldKind::Choice(&["linear", "quadratic"]),
            doc: "interpolation scheme",
        },
    ],
    groups: &[
        ("normals", &["vertex", "out"]),
        ("interp", &["bary", "weight"]),
    ],
};

/// The `[interp]` section, typed (one field per declared field).
#[derive(Clone, Copy, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InterpConfig {
    /// The barycentric coordinates.
    pub bary: Quant,
    /// The vertex (and midpoint) normals.
    pub vertex: Quant,
    /// The quadratic weights.
    pub weight: Quant,
    /// Output port: the interpolated normal.
    pub out: Quant,
    /// Linear or quadratic interpolation.
    pub scheme: Scheme,
}

impl crate::config::Section for InterpConfig {
    const DECL: &'static UnitDecl = &DECL;
}

crate::deserialize_by_name!(Scheme);

/// The normal interpolation as a registered unit.
pub struct InterpUnit;

crate::unit!(InterpUnit, decl: DECL, section: InterpConfig, check: check, ops: ops,
    rtl: &[&RTL]);

/// The registry entry.
pub static UNIT: InterpUnit = InterpUnit;

/// The unit's generated RTL: variants, design and input vectors.
pub static RTL: crate::rtl::units::RtlUnit = crate::rtl::units::RtlUnit {
    name: "interp",
    doc: "method C: linear or quadratic normal interpolation",
    variants: &[
        ("linear", "interp.scheme=\"linear\""),
        ("quadratic", "interp.scheme=\"quadratic\""),
    ],
    build: crate::interp::rtl::design,
    inputs: crate::interp::rtl::inputs,
};

/// The thresholds a triangle can be classified by.
pub const THETA_LADDER: [f64; 6] = [0.0, 0.5, 0.75, 0.875, 0.9375, 0.96875];

/// Which interpolation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Scheme {
    /// `Σ c_i N_i`.
    Linear,
    /// Quadratic Lagrange interpolation through vertices and edge midpoints.
    Quadratic,
}

impl Scheme {
    /// Configuration name.
    pub const fn name(self) -> &'static str {
        match self {
            Scheme::Linear => "linear",
            Scheme::Quadratic => "quadratic",
        }
    }
    /// Parse a name.
    pub fn from_name(s: &str) -> Option<Scheme> {
        [Scheme::Linear, Scheme::Quadratic]
            .into_iter()
            .find(|x| x.name() == s)
    }
}

/// Why a triangle could not be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SetupError {
    /// A vertex normal is NaN or infinite.
    #[error("vertex normal {vertex} is not finite")]
    NotFinite {
        /// 1, 2 or 3.
        vertex: usize,
    },
    /// A vertex normal is (nearly) zero.
    #[error("vertex normal {vertex} is zero")]
    Zero {
        /// 1, 2 or 3.
        vertex: usize,
    },
    /// Two vertex normals point in opposite directions: their midpoint
    /// normal is undefined.
    #[error("vertex normals {i} and {j} are antiparallel (N{i}·N{j} = {dot}): the midpoint normal is undefined")]
    Antiparallel {
        /// First vertex.
        i: usize,
        /// Second vertex.
        j: usize,
        /// Their dot product.
        dot: f64,
    },
}

/// Barycentric coordinates, validated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Barycentric(pub [f64; 3]);

/// Why barycentric coordinates were rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("barycentric coordinates {0:?}: {1}")]
pub struct BaryError(pub [f64; 3], pub &'static str);

impl Barycentric {
    /// Validate: finite, none below −10⁻⁹, summing to one within 10⁻⁹;
    /// tiny negatives are clamped to 0 and the sum renormalized.
    ///
    /// # Errors
    ///
    /// [`BaryError`] when a coordinate is not finite, one is below −10⁻⁹, or their sum is off one
    /// by more than 10⁻⁹.
    pub fn new(c: [f64; 3]) -> Result<Self, BaryError> {
        if c.iter().any(|x| !x.is_finite()) {
            return Err(BaryError(c, "not finite"));
        }
        if c.iter().any(|&x| x < -1e-9) {
            return Err(BaryError(c, "negative: the point is outside the triangle"));
        }
        let s: f64 = c.iter().sum();
        if (s - 1.0).abs() > 1e-9 {
            return Err(BaryError(c, "they do not sum to one"));
        }
        let c = c.map(|x| x.max(0.0));
        let s: f64 = c.iter().sum();
        Ok(Barycentric(c.map(|x| x / s)))
    }
}

/// A set-up triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Unit vertex normals.
    pub n: [DVec3; 3],
    /// Unit edge-midpoint normals `N12, N23, N31`.
    pub mid: [DVec3; 3],
    /// `min(N_i·N_j)`.
    pub cos_phi: f64,
    /// The largest Θ of [`THETA_LADDER`] the triangle meets, if any.
    pub theta: Option<f64>,
}

pub(crate) const PAIRS: [(usize, usize); 3] = [(0, 1), (1, 2), (2, 0)];

/// Set up a triangle from its vertex normals (f64, exact).
///
/// # Errors
///
/// For the first vertex or pair at fault: [`SetupError::NotFinite`] for a NaN or infinite vertex
/// normal, [`SetupError::Zero`] for one shorter than 10⁻¹², [`SetupError::Antiparallel`] for two
/// whose unit vectors have `N_i·N_j ≤ −1 + 10⁻⁹`.
pub fn setup(n: [DVec3; 3]) -> Result<Triangle, SetupError> {
    let mut u = [DVec3::ZERO; 3];
    for (k, v) in n.iter().enumerate() {
        if !v.is_finite() {
            return Err(SetupError::NotFinite { vertex: k + 1 });
        }
        if v.length() < 1e-12 {
            return Err(SetupError::Zero { vertex: k + 1 });
        }
        u[k] = v.normalize();
    }
    let mut mid = [DVec3::ZERO; 3];
    for (k, &(i, j)) in PAIRS.iter().enumerate() {
        let d = u[i].dot(u[j]);
        if d <= -1.0 + 1e-9 {
            return Err(SetupError::Antiparallel {
                i: i + 1,
                j: j + 1,
                dot: d,
            });
        }
        mid[k] = (u[i] + u[j]) / (2.0 * (1.0 + d)).sqrt();
    }
    let cos_phi = crate::sampling::cos_phi(&u);
    let theta = THETA_LADDER.iter().rev().copied().find(|&t| cos_phi >= t);
    Ok(Triangle {
        n: u,
        mid,
        cos_phi,
        theta,
    })
}

/// The interpolated normal in f64 (the reference field, unnormalized).
pub fn field(t: &Triangle, c: [f64; 3], scheme: Scheme) -> DVec3 {
    match scheme {
        Scheme::Linear => t.n[0] * c[0] + t.n[1] * c[1] + t.n[2] * c[2],
        Scheme::Quadratic => {
            let mut v = DVec3::ZERO;
            for (n, &ci) in t.n.iter().zip(&c) {
                v += *n * (ci * (2.0 * ci - 1.0));
            }
            for (k, &(i, j)) in PAIRS.iter().enumerate() {
                v += t.mid[k] * (4.0 * c[i] * c[j]);
            }
            v
        }
    }
}

/// The range of `d = |N|²` over triangles meeting Θ: `[(1+2Θ)/3, 1]` for
/// linear interpolation, `[h²·((8/√(2(1+Θ)) − 1)/3)², 1]` with
/// `h² = (1+2Θ)/3` for quadratic (see the module page).
pub fn quadratic_d_range(theta: f64, scheme: Scheme) -> (f64, f64) {
    let h2 = (1.0 + 2.0 * theta) / 3.0;
    match scheme {
        Scheme::Linear => (h2, 1.0),
        Scheme::Quadratic => {
            let k = (8.0 / (2.0 * (1.0 + theta)).sqrt() - 1.0) / 3.0;
            (h2 * k * k, 1.0)
        }
    }
}

/// The interpolator's formats.
#[derive(Clone, Copy, Debug)]
pub struct Interp {
    /// Scheme.
    pub scheme: Scheme,
    /// Barycentric input format.
    pub bary: Quant,
    /// Vertex and midpoint normal format.
    pub vertex: Quant,
    /// Weight format.
    pub weight: Quant,
    /// Output format.
    pub out: Quant,
}

/// Setup literals: exact small integers.
const LITERAL: Quant = Quant::new(
    "literal",
    crate::format::Format::signed_int(8),
    Rounding::Trunc,
    Overflow::Saturate,
);

impl Interp {
    /// From the `[interp]` section.
    pub fn from_section(u: &InterpConfig) -> Self {
        Interp {
            scheme: u.scheme,
            bary: u.bary,
            vertex: u.vertex,
            weight: u.weight,
            out: u.out,
        }
    }

    /// From the `[interp]` section of `cfg`.
    pub fn from_config(cfg: &Config) -> Self {
        Self::from_section(&cfg.section())
    }

    /// The per-triangle set-up on the datapath (for counting; the model's
    /// own set-up is [`setup`], in exact arithmetic): midpoint normals
    /// `(N_i + N_j) · 1/√(2(1 + N_i·N_j))`, each quantized to the vertex
    /// format.
    ///
    /// # Errors
    ///
    /// The [`ConvertError`] of `cx.constant` for the literal 1, which the contexts of `fxshade-ir`
    /// never return (it is finite).
    pub fn setup_datapath<C: Datapath>(
        &self,
        cx: &mut C,
        n: [[C::V; 3]; 3],
    ) -> Result<[[C::V; 3]; 3], ConvertError> {
        let one = cx.constant(1.0, &crate::quantize::literal(1))?;
        let r_q = self.vertex.with_stage("setup_rsqrt");
        let mut mids = [[one; 3]; 3];
        for (k, &(i, j)) in PAIRS.iter().enumerate() {
            let d = cx.dot3(n[i], n[j]);
            let t = cx.add(one, d);
            let t = cx.shl(t, 1);
            let s = cx.sqrt(t, &r_q);
            let r = cx.div(one, s, &r_q);
            for c in 0..3 {
                let sum = cx.add(n[i][c], n[j][c]);
                let m = cx.mul(sum, r);
                mids[k][c] = cx.quantize(m, &self.vertex);
            }
        }
        Ok(mids)
    }

    /// The per-pixel evaluation: `c1, c2` in the bary format, `v` the six
    /// vectors `N1, N2, N3, N12, N23, N31` in the vertex format, `one` the
    /// constant 1 in the bary format.
    #[inline]
    pub fn eval<C: Datapath>(
        &self,
        cx: &mut C,
        one: C::V,
        c1: C::V,
        c2: C::V,
        v: &[[C::V; 3]; 6],
    ) -> [C::V; 3] {
        cx.enter(DECL.name);
        let t = cx.sub(one, c1);
        let c3 = cx.sub(t, c2);
        let c = [c1, c2, c3];
        let mut w = [one; 6];
        let n_terms = match self.scheme {
            Scheme::Linear => {
                w[..3].copy_from_slice(&c);
                3
            }
            Scheme::Quadratic => {
                for (wi, &ci) in w.iter_mut().zip(&c) {
                    let two_c = cx.shl(ci, 1);
                    let e = cx.sub(two_c, one);
                    let p = cx.mul(ci, e);
                    *wi = cx.quantize(p, &self.weight);
                }
                for (k, &(i, j)) in PAIRS.iter().enumerate() {
                    let p = cx.mul(c[i], c[j]);
                    let p = cx.shl(p, 2);
                    w[3 + k] = cx.quantize(p, &self.weight);
                }
                6
            }
        };
        let out = std::array::from_fn(|comp| {
            let mut acc = cx.mul(w[0], v[0][comp]);
            for k in 1..n_terms {
                acc = cx.mul_add(w[k], v[k][comp], acc);
            }
            cx.quantize(acc, &self.out)
        });
        cx.leave();
        out
    }

    /// The constant 1 the evaluation takes, in the format that holds it
    /// exactly (`U1F0`).
    ///
    /// # Panics
    ///
    /// If `cx.constant` rejects the literal 1: never in the contexts of `fxshade-ir`, which reject
    /// only NaN and ±∞.
    pub fn one<C: Datapath>(cx: &mut C) -> C::V {
        cx.constant(1.0, &crate::quantize::literal(1))
            .expect("1 is finite")
    }

    /// The unit traced with named ports: inputs `c1, c2` (bary format),
    /// then `n1, n2, n3, n12, n23, n31` (`_x, _y, _z` each, vertex format);
    /// outputs `out_x, out_y, out_z`.
    pub fn trace(&self) -> Trace {
        let mut tr = Trace::new();
        let c1 = tr.input_named("c1", &self.bary);
        let c2 = tr.input_named("c2", &self.bary);
        let v: [[_; 3]; 6] = std::array::from_fn(|k| {
            tr.input3(["n1", "n2", "n3", "n12", "n23", "n31"][k], &self.vertex)
        });
        let one = Self::one(&mut tr);
        let out = self.eval(&mut tr, one, c1, c2, &v);
        tr.output3("out", out);
        tr
    }

    /// The per-pixel evaluation compiled for batches: inputs c1, c2, then the
    /// 18 vector components (N1..N31, x y z each); outputs x, y, z.
    ///
    /// # Errors
    ///
    /// [`CompileError::Width`](crate::datapath::CompileError::Width) when an exact intermediate is
    /// wider than [`MAX_EXACT_WIDTH`](crate::datapath::MAX_EXACT_WIDTH).
    pub fn compile(&self) -> Result<Compiled, crate::datapath::CompileError> {
        self.trace().compile_outputs()
    }

    /// Counting runs: (set-up, per pixel). The set-up of both schemes
    /// classifies the triangle (`cos φ`: three dot products, two
    /// comparisons); the quadratic one also computes the midpoint normals
    /// (whose dot products it shares).
    ///
    /// # Errors
    ///
    /// A [`ConvertError`] only for a NaN or infinite constant; its constants are 0 and 1, so it
    /// never returns one.
    pub fn count(&self) -> Result<(Count, Count), ConvertError> {
        let mut s = Count::new();
        let n = [[s.constant(0.0, &self.vertex)?; 3]; 3];
        let z = s.constant(0.0, &LITERAL)?;
        match self.scheme {
            Scheme::Quadratic => {
                self.setup_datapath(&mut s, n)?;
            }
            Scheme::Linear => {
                for &(i, j) in &PAIRS {
                    s.dot3(n[i], n[j]);
                }
            }
        }
        let m = s.max(z, z);
        s.max(m, z);
        let mut p = Count::new();
        let one = Self::one(&mut p);
        let c = p.constant(0.0, &self.bary)?;
        let v = [[p.constant(0.0, &self.vertex)?; 3]; 6];
        self.eval(&mut p, one, c, c, &v);
        Ok((s, p))
    }
}

fn check(cfg: &Config) -> Result<(), Vec<ConfigError>> {
    let u = cfg.unit(DECL.name);
    let i = Interp::from_config(cfg);
    for scheme in [Scheme::Linear, Scheme::Quadratic] {
        let (_, p) = Interp { scheme, ..i }
            .count()
            .map_err(|e| vec![crate::config::field_error(u, "bary", e.to_string())])?;
        width_errors(&p, u)?;
    }
    Ok(())
}

fn ops(cfg: &Config) -> Vec<OpReport> {
    let i = Interp::from_config(cfg);
    let mut v = Vec::new();
    for scheme in [Scheme::Linear, Scheme::Quadratic] {
        if let Ok((s, p)) = (Interp { scheme, ..i }).count() {
            v.push(OpReport::from_count(
                DECL.name,
                scheme.name(),
                Phase::Setup,
                &s,
                None,
            ));
            v.push(OpReport::from_count(
                DECL.name,
                scheme.name(),
                Phase::Pixel,
                &p,
                None,
            ));
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{self, Rng};

    #[test]
    fn exact_at_vertices_and_midpoints() {
        let mut rng = Rng::new(5);
        for _ in 0..100 {
            let t = setup(sampling::triangle_meeting(0.3, &mut rng)).unwrap();
            for i in 0..3 {
                let mut c = [0.0; 3];
                c[i] = 1.0;
                assert!((field(&t, c, Scheme::Quadratic) - t.n[i]).length() < 1e-12);
            }
            for (k, &(i, j)) in PAIRS.iter().enumerate() {
                let mut c = [0.0; 3];
                c[i] = 0.5;
                c[j] = 0.5;
                assert!((field(&t, c, Scheme::Quadratic) - t.mid[k]).length() < 1e-12);
                assert!((t.mid[k].length() - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn d_range_holds_by_sampling_and_is_reached() {
        let mut rng = Rng::new(11);
        for &theta in &THETA_LADDER {
            for scheme in [Scheme::Linear, Scheme::Quadratic] {
                let (lo, hi) = quadratic_d_range(theta, scheme);
                // Reached: the centroid of the equiangular triangle.
                let t = setup(sampling::equiangular(theta, &mut rng)).unwrap();
                let d = field(&t, [1.0 / 3.0; 3], scheme).length_squared();
                assert!((d - lo).abs() < 1e-12, "{theta} {scheme:?}: {d} vs {lo}");
                for _ in 0..20_000 {
                    let t = setup(sampling::triangle_meeting(theta, &mut rng)).unwrap();
                    let d = field(&t, rng.barycentric(), scheme).length_squared();
                    assert!(
                        d >= lo - 1e-12 && d <= hi + 1e-12,
                        "{theta} {scheme:?}: {d} outside [{lo}, {hi}]"
                    );
                }
            }
        }
    }

    #[test]
    fn degenerate_input_has_defined_outcomes() {
        let x = DVec3::X;
        assert_eq!(
            setup([x, -x, DVec3::Y]),
            Err(SetupError::Antiparallel {
                i: 1,
                j: 2,
                dot: -1.0
            })
        );
        assert_eq!(
            setup([x, DVec3::ZERO, DVec3::Y]),
            Err(SetupError::Zero { vertex: 2 })
        );
        assert_eq!(
            setup([x, DVec3::Y, DVec3::new(f64::NAN, 0.0, 0.0)]),
            Err(SetupError::NotFinite { vertex: 3 })
        );
        // Non-unit normals are normalized.
        let t = setup([x * 3.0, DVec3::Y * 0.5, DVec3::Z]).unwrap();
        assert!((t.n[0] - x).length() < 1e-15 && t.theta == Some(0.0));
        assert!(Barycentric::new([0.5, 0.6, -0.1]).is_err());
        assert!(Barycentric::new([0.5, 0.6, 0.1]).is_err());
        assert!(Barycentric::new([f64::NAN, 0.0, 1.0]).is_err());
        assert_eq!(
            Barycentric::new([0.25, 0.25, 0.5]).unwrap().0,
            [0.25, 0.25, 0.5]
        );
    }

    #[test]
    fn counts() {
        let cfg = Config::embedded();
        let r = ops(&cfg);
        let get = |v: &str, s: Phase| r.iter().find(|x| x.variant == v && x.stage == s).unwrap();
        let q = &get("quadratic", Phase::Pixel).counts;
        assert_eq!((q.mul, q.add), (24, 20));
        let l = &get("linear", Phase::Pixel).counts;
        assert_eq!((l.mul, l.add), (9, 8));
        let s = &get("quadratic", Phase::Setup).counts;
        assert_eq!((s.sqrt, s.div, s.mul, s.compare), (3, 3, 18, 2));
        let s = &get("linear", Phase::Setup).counts;
        assert_eq!((s.sqrt, s.div, s.mul, s.compare), (0, 0, 9, 2));
    }
}
