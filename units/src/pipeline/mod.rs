//! The whole per-pixel shading pipeline: the three methods chained, with the
//! lighting unit at the end, on two paths.
//!
//! ## Smooth path (methods A and C)
//! ```text
//! set-up, per triangle: unit vertex normals -> midpoint normals (interp::setup),
//!                       cos φ -> Θ of the ladder -> coefficient set `sel`
//! per pixel:  N  = interp(c1, c2; N1, N2, N3, N12, N23, N31)      Q_interp.out
//!             N  = Q_normalize.normal(N)                         (port)
//!             N' = normalize[sel](N)                             Q_normalize.out
//!             N' = Q_lighting.normal(N')                         (port)
//!             level = shade(N', L, H)                            Q_lighting.level
//! ```
//! The normalizer's coefficient sets are designed once, one per Θ of
//! [`THETA_LADDER`], each on the range of `d` that the configured
//! interpolation scheme produces over triangles meeting that Θ
//! ([`crate::interp::quadratic_d_range`], with `normalize.interval =
//! "triangle"`), or on the paper's edge interval (`"edge"`). A triangle
//! whose `cos φ` is below every Θ of the ladder (`cos φ < 0`) uses the Θ = 0
//! set and is counted as outside the ladder.
//!
//! ## Mapped path (method B)
//! The polar transform needs the angles of N, L and H at every pixel. fxshade
//! takes them without any per-pixel arcsine or arctangent:
//!
//! * `L` (directional light) and `H = (L + V)/|L + V|` (orthographic viewer)
//!   are constant over the frame: their angles are set up once per frame;
//! * the angles of `N` are set up once per **vertex** (`α = asin y`,
//!   `β = atan2(x, z)`, in the angle format `U0F<k>`), and interpolated
//!   linearly with the barycentrics, relative to vertex 3:
//!
//! ```text
//! set-up:    Δα_i = wrap(α_i − α_3),  Δβ_i = wrap(β_i − β_3)    i = 1, 2   (I0F<k>)
//! per pixel: α = Q_angle(α_3 + c1·Δα_1 + c2·Δα_2)                           (U0F<k>, wraps)
//!            β = Q_angle(β_3 + c1·Δβ_1 + c2·Δβ_2)
//! ```
//!
//! `wrap` takes the difference modulo a turn into `[−½, ½)`: the two's
//! complement reading of the `k`-bit difference, so the wrap of `β` at ±180°
//! costs nothing and a triangle straddling the seam interpolates across it,
//! not around the long way. Then
//!
//! ```text
//!             L' = polar(α_L, β_L; α, β),  H' = polar(α_H, β_H; α, β)    Q_polar.out
//!             level = shade(n, Q_light(L'), Q_light(H'))              n: normal-map texel
//! ```
//!
//! The cost of this choice (against angles of the exactly interpolated and
//! normalized normal at every pixel) is measured by the renderer as the
//! `angle_interp` error; it is largest on triangles at the poles of the
//! y axis, where `β` is undefined and its interpolation meaningless.

use fxshade_numbers::convert::narrow;
use glam::DVec3;

use crate::angles::{Angles, AnglesError};
use crate::config::{Config, ConfigError, FieldDecl, FieldKind, UnitDecl};
use crate::datapath::{CompileError, Compiled, Count, Datapath, Trace};
use crate::format::{ConvertError, Format};
use crate::interp::{self, Interp, Scheme, SetupError, THETA_LADDER};
use crate::lighting::{Lighting, LightingError};
use crate::normalizer::{self, Design, DesignError, Interval, Method, Normalizer};
use crate::polar::{Polar, PolarError};
use crate::quantize::{Overflow, Quant, Rounding};
use crate::units::{OpReport, Phase};

pub mod columns;
pub mod rows;
pub mod rtl;

pub use columns::Columns;
pub use rows::Rows;

/// The `[pipeline]` configuration section.
pub static DECL: UnitDecl = UnitDecl {
    name: "pipeline",
    doc: "the chained pipeline: smooth path interp → normalize → lighting; mapped path angles → polar → lighting",
    fields: &[
        FieldDecl {
            name: "angle_round",
            kind: FieldKind::Choice(&["trunc", "half_up", "half_even"]),
            doc: "rounding of the interpolated polar angles of N (mapped path), in the polar angle format U0F<polar.angle_bits>, wrapping",
        },
        FieldDecl {
            name: "angles",
            kind: FieldKind::Choice(&["cordic", "interpolate"]),
            doc: "mapped path: the polar angles of N by CORDIC from the interpolated normal at every pixel (the angles unit), or interpolated from per-vertex angles (angle_interp)",
        },
        FieldDecl {
            name: "path",
            kind: FieldKind::Choice(&["smooth", "mapped"]),
            doc: "which path the RTL top implements (rtl/pipeline_smooth.v or rtl/pipeline_mapped.v) and `fxshade vectors pipeline` generates",
        },
    ],
    groups: &[],
};

/// The `[pipeline]` section, typed (one field per declared field).
#[derive(Clone, Copy, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineConfig {
    /// How the interpolated angles are rounded to the angle format.
    pub angle_round: Rounding,
    /// Where the mapped path's polar angles of N come from.
    pub angles: AngleSource,
    /// Which path the RTL top implements.
    pub path: Path,
}

impl crate::config::Section for PipelineConfig {
    const DECL: &'static UnitDecl = &DECL;
}

crate::deserialize_by_name!(Path, AngleSource);

/// The pipeline composition as a registered unit (two RTL modules: the
/// angle interpolation and the top).
pub struct PipelineUnit;

crate::unit!(PipelineUnit, decl: DECL, section: PipelineConfig, check: check, ops: ops,
    rtl: &[&ANGLE_RTL, &RTL]);

/// The registry entry.
pub static UNIT: PipelineUnit = PipelineUnit;

/// The unit's generated RTL: variants, design and input vectors.
pub static ANGLE_RTL: crate::rtl::units::RtlUnit = crate::rtl::units::RtlUnit {
    name: "angle_interp",
    doc: "polar angles of N interpolated from per-vertex set-up (mapped path)",
    variants: &[("linear", "pipeline.angle_round=\"half_even\"")],
    build: crate::pipeline::rtl::angle_design,
    inputs: crate::pipeline::rtl::angle_inputs,
};

/// The unit's generated RTL: variants, design and input vectors.
pub static RTL: crate::rtl::units::RtlUnit = crate::rtl::units::RtlUnit {
    name: "pipeline",
    doc: "the pipeline top: smooth (interp → normalize → lighting) or mapped (angles → polar → lighting)",
    variants: &[
        ("smooth", "pipeline.path=\"smooth\""),
        (
            "mapped",
            "pipeline.path=\"mapped\"; pipeline.angles=\"cordic\"",
        ),
        (
            "mapped-interp",
            "pipeline.path=\"mapped\"; pipeline.angles=\"interpolate\"",
        ),
    ],
    build: crate::pipeline::rtl::design,
    inputs: crate::pipeline::rtl::inputs,
};

/// Which path.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Path {
    /// Interpolated normal, normalized, lit.
    Smooth,
    /// Normal-map normal, light and half vectors by the polar transform.
    Mapped,
}

impl Path {
    /// Parse a name.
    pub fn from_name(s: &str) -> Option<Path> {
        [Path::Smooth, Path::Mapped]
            .into_iter()
            .find(|p| p.name() == s)
    }
    /// Name.
    pub const fn name(self) -> &'static str {
        match self {
            Path::Smooth => "smooth",
            Path::Mapped => "mapped",
        }
    }
}

/// Why a pipeline could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PipelineError {
    /// A normalizer could not be designed.
    #[error(transparent)]
    Design(#[from] DesignError),
    /// The polar section is unusable.
    #[error(transparent)]
    Polar(#[from] PolarError),
    /// The lighting stage failed.
    #[error(transparent)]
    Lighting(#[from] LightingError),
    /// A datapath is too wide.
    #[error(transparent)]
    Compile(#[from] CompileError),
    /// A constant could not be converted.
    #[error(transparent)]
    Convert(#[from] ConvertError),
    /// The angles unit is unusable.
    #[error(transparent)]
    Angles(#[from] AnglesError),
}

/// Where the mapped path takes the polar angles of `N` from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AngleSource {
    /// CORDIC vectoring on the interpolated normal at every pixel
    /// ([`crate::angles`]).
    Cordic,
    /// Per-vertex angles interpolated linearly ([`Pipeline::angle_of`]).
    Interpolate,
}

impl AngleSource {
    /// Parse a name.
    pub fn from_name(s: &str) -> Option<AngleSource> {
        [AngleSource::Cordic, AngleSource::Interpolate]
            .into_iter()
            .find(|p| p.name() == s)
    }
    /// Name.
    pub const fn name(self) -> &'static str {
        match self {
            AngleSource::Cordic => "cordic",
            AngleSource::Interpolate => "interpolate",
        }
    }
}

/// The pipeline of a configuration, with one normalizer per Θ of the ladder.
#[derive(Clone, Debug)]
pub struct Pipeline {
    /// The interpolator.
    pub interp: Interp,
    /// The normalizer's method.
    pub method: Method,
    /// One normalizer per Θ of [`THETA_LADDER`] (same formats; coefficients
    /// designed for that Θ where the method has any).
    pub sets: Vec<Normalizer>,
    /// How each set's coefficients were designed (`None` for rounded
    /// coefficients, which the pipeline takes without the search).
    pub designs: Vec<Option<Design>>,
    /// The polar transform.
    pub polar: Polar,
    /// The lighting unit.
    pub light: Lighting,
    /// The interpolated angle (`U0F<k>`, wraps).
    pub angle: Quant,
    /// Set-up angle differences (`I0F<k>`, wraps).
    pub delta: Quant,
    /// Where the mapped path's angles of `N` come from.
    pub angles: AngleSource,
    /// The CORDIC angle unit.
    pub cordic: Angles,
}

/// The `d` interval a set is fitted on.
fn fit_interval(kind: Interval, theta: f64, scheme: Scheme) -> (f64, f64) {
    match kind {
        Interval::Edge => kind.bounds(theta),
        Interval::Triangle => interp::quadratic_d_range(theta, scheme),
    }
}

impl Pipeline {
    /// The pipeline of `cfg` with the configured normalizer method.
    ///
    /// # Errors
    ///
    /// As [`Pipeline::with_method`].
    ///
    pub fn from_config(cfg: &Config) -> Result<Pipeline, PipelineError> {
        let m = cfg.section::<normalizer::NormalizeConfig>().method;
        Self::with_method(cfg, m)
    }

    /// The pipeline of `cfg` with normalizer method `method`. Designing six
    /// coefficient sets takes seconds for wide formats, so the result is
    /// kept for the life of the process, keyed by the configuration's text.
    ///
    /// # Errors
    ///
    /// [`PipelineError::Design`] when a coefficient set of the ladder cannot be designed or rounded
    /// to the `coef` format (linear and quadratic only); [`PipelineError::Polar`] when the
    /// `[polar]` section is unusable ([`Polar::from_config`]); [`PipelineError::Angles`] when the
    /// `[angles]` section is unusable ([`Angles::of`]). An error is not cached: the next call
    /// tries again.
    pub fn with_method(cfg: &Config, method: Method) -> Result<Pipeline, PipelineError> {
        use std::collections::HashMap;
        use std::sync::{Mutex, OnceLock};
        static CACHE: OnceLock<Mutex<HashMap<(String, &'static str), Pipeline>>> = OnceLock::new();
        let key = (cfg.to_toml(), method.name());
        let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
        if let Some(p) = cache.lock().ok().and_then(|c| c.get(&key).cloned()) {
            return Ok(p);
        }
        let p = Self::build(cfg, method)?;
        if let Ok(mut c) = cache.lock() {
            c.insert(key, p.clone());
        }
        Ok(p)
    }

    fn build(cfg: &Config, method: Method) -> Result<Pipeline, PipelineError> {
        let interp = Interp::from_config(cfg);
        let nu: normalizer::NormalizeConfig = cfg.section();
        let stages = Normalizer::stages(&nu);
        let (fit, kind) = (nu.fit, nu.interval);
        let search = nu.coef_quant == normalizer::CoefQuant::Search;
        let mut sets = Vec::new();
        let mut designs = Vec::new();
        for &theta in &THETA_LADDER {
            let (lo, hi) = fit_interval(kind, theta, interp.scheme);
            match method.degree() {
                // Rounded coefficients need no search (the search and the
                // re-ranking of its candidates are what take time).
                Some(degree) if !search => {
                    let real =
                        crate::coeffs::design(fit, lo, hi, degree).map_err(DesignError::from)?;
                    let q = crate::coeffs::round_coeffs(&real, stages.coef.format(), lo, hi)
                        .map_err(DesignError::from)?;
                    sets.push(Normalizer {
                        method,
                        q: stages,
                        coeffs: q.values,
                    });
                    designs.push(None);
                }
                _ => {
                    let (n, d) = normalizer::design_interval(
                        method,
                        stages,
                        theta,
                        fit,
                        kind,
                        (lo, hi),
                        search,
                    )?;
                    sets.push(n);
                    designs.push(d);
                }
            }
        }
        let polar = Polar::from_config(cfg)?;
        let light = Lighting::from_config(cfg);
        let want = polar.angle.format();
        let section: PipelineConfig = cfg.section();
        let round = section.angle_round;
        let angle = Quant::new("angle", want, round, Overflow::Wrap);
        let k = want.width();
        let delta = Quant::new(
            "delta",
            Format::new(true, k, narrow::<i32, _>(k)).expect("1..=24 bits"),
            Rounding::Trunc,
            Overflow::Wrap,
        );
        let angles = section.angles;
        let cordic = Angles::of(cfg)?;
        Ok(Pipeline {
            interp,
            method,
            sets,
            designs,
            polar,
            light,
            angle,
            delta,
            angles,
            cordic,
        })
    }

    /// The coefficient set for a triangle of Θ `theta` (from
    /// [`interp::setup`]); `None` (cos φ < 0) takes the Θ = 0 set.
    pub fn set_of(theta: Option<f64>) -> usize {
        theta
            .and_then(|t| THETA_LADDER.iter().position(|&x| x == t))
            .unwrap_or(0)
    }

    /// The smooth path for one pixel: `c1, c2` in the bary format, `v` the
    /// six vertex and midpoint normals in the vertex format, `l` and `h` in
    /// the lighting `light` format; `set` picks the normalizer.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn smooth<C: Datapath>(
        &self,
        cx: &mut C,
        set: usize,
        k: &SmoothConsts<C::V>,
        c1: C::V,
        c2: C::V,
        v: &[[C::V; 3]; 6],
        l: [C::V; 3],
        h: [C::V; 3],
    ) -> C::V {
        self.smooth_with(cx, &k.norm[set], k, c1, c2, v, l, h)
    }

    /// The smooth path with the normalizer constants `kn`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn smooth_with<C: Datapath>(
        &self,
        cx: &mut C,
        kn: &normalizer::Consts<C::V>,
        k: &SmoothConsts<C::V>,
        c1: C::V,
        c2: C::V,
        v: &[[C::V; 3]; 6],
        l: [C::V; 3],
        h: [C::V; 3],
    ) -> C::V {
        let nz = &self.sets[0];
        let n = self.interp.eval(cx, k.one, c1, c2, v);
        cx.enter(normalizer::DECL.name);
        let n = cx.quantize3(n, &nz.q.normal);
        cx.leave();
        let n = nz.eval(cx, kn, n);
        cx.enter(crate::lighting::DECL.name);
        let n = cx.quantize3(n, &self.light.normal);
        cx.leave();
        self.light.shade(cx, &k.light, n, l, h)
    }

    /// The smooth path with the coefficient set chosen by the
    /// code `sel` (a multiplexer per coefficient; codes past the last set
    /// read set 0): what the RTL top builds.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn smooth_sel<C: Datapath>(
        &self,
        cx: &mut C,
        sel: C::V,
        k: &SmoothConsts<C::V>,
        c1: C::V,
        c2: C::V,
        v: &[[C::V; 3]; 6],
        l: [C::V; 3],
        h: [C::V; 3],
    ) -> C::V {
        let kn = Normalizer::select_consts(cx, sel, &k.norm);
        self.smooth_with(cx, &kn, k, c1, c2, v, l, h)
    }

    /// One interpolated angle: `Q_angle(a3 + c1·Δ1 + c2·Δ2)`.
    #[inline]
    pub fn angle_of<C: Datapath>(&self, cx: &mut C, c1: C::V, c2: C::V, a: [C::V; 3]) -> C::V {
        cx.enter(ANGLE_UNIT);
        let p = cx.mul(c1, a[1]);
        let s = cx.add(a[0], p);
        let s = cx.mul_add(c2, a[2], s);
        let out = cx.quantize(s, &self.angle);
        cx.leave();
        out
    }

    /// The angle interpolation traced with named ports: inputs `c1, c2`
    /// (bary format), `a3` (angle format), `d1, d2` (delta format); output
    /// `angle`.
    pub fn trace_angle(&self) -> Trace {
        let mut tr = Trace::new();
        let c1 = tr.input_named("c1", &self.interp.bary);
        let c2 = tr.input_named("c2", &self.interp.bary);
        let a3 = tr.input_named("a3", &self.angle);
        let d1 = tr.input_named("d1", &self.delta);
        let d2 = tr.input_named("d2", &self.delta);
        let a = self.angle_of(&mut tr, c1, c2, [a3, d1, d2]);
        tr.output("angle", a);
        tr
    }

    /// The pipeline of `path` traced with named ports (the fields of
    /// [`Pipeline::fields`], in that order; `n1_x` for `n1x` and so on);
    /// output `level`.
    ///
    /// # Errors
    ///
    /// [`PipelineError::Convert`] when a constant of `path` is NaN or infinite (a normalizer
    /// coefficient, `255·i0_km` or `255·i0_ks`): never for a pipeline of a configuration.
    pub fn trace(&self, path: Path) -> Result<Trace, PipelineError> {
        let mut tr = Trace::new();
        match path {
            Path::Smooth => {
                let sel = tr.input_named("sel", &sel_quant());
                let c1 = tr.input_named("c1", &self.interp.bary);
                let c2 = tr.input_named("c2", &self.interp.bary);
                let v: [[_; 3]; 6] = std::array::from_fn(|k| {
                    tr.input3(
                        ["n1", "n2", "n3", "n12", "n23", "n31"][k],
                        &self.interp.vertex,
                    )
                });
                let l = tr.input3("l", &self.light.light);
                let h = tr.input3("h", &self.light.light);
                let k = self.smooth_consts(&mut tr)?;
                let out = self.smooth_sel(&mut tr, sel, &k, c1, c2, &v, l, h);
                tr.output("level", out);
            }
            Path::Mapped if self.angles == AngleSource::Cordic => {
                let c1 = tr.input_named("c1", &self.interp.bary);
                let c2 = tr.input_named("c2", &self.interp.bary);
                let v: [[_; 3]; 6] = std::array::from_fn(|k| {
                    tr.input3(
                        ["n1", "n2", "n3", "n12", "n23", "n31"][k],
                        &self.interp.vertex,
                    )
                });
                let lh = ["al", "bl", "ah", "bh"].map(|n| tr.input_named(n, &self.angle));
                let n = tr.input3("n", &self.light.normal);
                let k = self.mapped_consts(&mut tr)?;
                let out = self.mapped_cordic(&mut tr, &k, c1, c2, &v, lh, n);
                tr.output("level", out);
            }
            Path::Mapped => {
                let c1 = tr.input_named("c1", &self.interp.bary);
                let c2 = tr.input_named("c2", &self.interp.bary);
                let a = [
                    tr.input_named("a3", &self.angle),
                    tr.input_named("da1", &self.delta),
                    tr.input_named("da2", &self.delta),
                ];
                let b = [
                    tr.input_named("b3", &self.angle),
                    tr.input_named("db1", &self.delta),
                    tr.input_named("db2", &self.delta),
                ];
                let lh = ["al", "bl", "ah", "bh"].map(|n| tr.input_named(n, &self.angle));
                let n = tr.input3("n", &self.light.normal);
                let k = self.light.consts(&mut tr)?;
                let out = self.mapped(&mut tr, &k, c1, c2, a, b, lh, n);
                tr.output("level", out);
            }
        }
        Ok(tr)
    }

    /// The mapped path for one pixel: `c1, c2` in the bary format; `a` and
    /// `b` the set-up angles of N (`[α3, Δα1, Δα2]`, `[β3, Δβ1, Δβ2]`);
    /// `lh` the angles `[α_L, β_L, α_H, β_H]`; `n` the normal-map texel in the
    /// lighting `normal` format.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn mapped<C: Datapath>(
        &self,
        cx: &mut C,
        k: &crate::lighting::Consts<C::V>,
        c1: C::V,
        c2: C::V,
        a: [C::V; 3],
        b: [C::V; 3],
        lh: [C::V; 4],
        n: [C::V; 3],
    ) -> C::V {
        let an = self.angle_of(cx, c1, c2, a);
        let bn = self.angle_of(cx, c1, c2, b);
        let l = self.polar.transform(cx, lh[0], lh[1], an, bn);
        let h = self.polar.transform(cx, lh[2], lh[3], an, bn);
        cx.enter(crate::lighting::DECL.name);
        let l = cx.quantize3(l, &self.light.light);
        let h = cx.quantize3(h, &self.light.light);
        cx.leave();
        self.light.shade(cx, k, n, l, h)
    }

    /// The mapped path with CORDIC angles for one pixel: `c1, c2` in the
    /// bary format; `v` the six vertex and midpoint normals in the vertex
    /// format (as the smooth path); `lh` the angles `[α_L, β_L, α_H, β_H]`;
    /// `n` the normal-map texel in the lighting `normal` format.
    ///
    /// ```text
    /// N      = interp(c1, c2; N1, N2, N3, N12, N23, N31)   Q_interp.out (not normalized)
    /// N      = Q_angles.normal(N)                           (port)
    /// (α, β) = cordic(N)                                    Q_angles.out = U0F<polar.angle_bits>
    /// L' = polar(α_L, β_L; α, β),  H' = polar(α_H, β_H; α, β)
    /// level  = shade(n, Q_light(L'), Q_light(H'))
    /// ```
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn mapped_cordic<C: Datapath>(
        &self,
        cx: &mut C,
        k: &MappedConsts<C::V>,
        c1: C::V,
        c2: C::V,
        v: &[[C::V; 3]; 6],
        lh: [C::V; 4],
        n: [C::V; 3],
    ) -> C::V {
        let nn = self.interp.eval(cx, k.one, c1, c2, v);
        cx.enter(crate::angles::DECL.name);
        let nn = cx.quantize3(nn, &self.cordic.normal);
        cx.leave();
        let [an, bn] = self.cordic.eval(cx, &k.angles, nn);
        let l = self.polar.transform(cx, lh[0], lh[1], an, bn);
        let h = self.polar.transform(cx, lh[2], lh[3], an, bn);
        cx.enter(crate::lighting::DECL.name);
        let l = cx.quantize3(l, &self.light.light);
        let h = cx.quantize3(h, &self.light.light);
        cx.leave();
        self.light.shade(cx, &k.light, n, l, h)
    }

    /// The conventional baseline of the mapped path for one pixel: the
    /// per-vertex tangent frames `f[k] = [T_k, B_k, N_k]` (vertex format)
    /// interpolated linearly (`Q_interp.out`), `L' = normalize(M·L)` and
    /// `H' = normalize(M·H)` with `M = [T; B; N]` ([`crate::polar::tbn`]:
    /// 9 multiplications and 6 additions, then a correctly rounded square
    /// root and division in `Q_polar.out`), then the same lighting with the
    /// texel `n`. `l`, `h` in the lighting `light` format. No RTL: the
    /// division and square root are what method B avoids.
    #[allow(clippy::too_many_arguments)]
    pub fn mapped_tbn<C: Datapath>(
        &self,
        cx: &mut C,
        k: &crate::lighting::Consts<C::V>,
        one: C::V,
        c1: C::V,
        c2: C::V,
        f: &[[[C::V; 3]; 3]; 3],
        l: [C::V; 3],
        h: [C::V; 3],
        n: [C::V; 3],
    ) -> C::V {
        let lin = Interp {
            scheme: Scheme::Linear,
            ..self.interp
        };
        let axis = |cx: &mut C, a: usize| {
            let v = [f[0][a], f[1][a], f[2][a], f[0][a], f[0][a], f[0][a]];
            lin.eval(cx, one, c1, c2, &v)
        };
        let (t, b, nn) = (axis(cx, 0), axis(cx, 1), axis(cx, 2));
        cx.enter(crate::polar::DECL.name);
        let lp = crate::polar::tbn(cx, &self.polar.out, t, b, nn, l);
        let hp = crate::polar::tbn(cx, &self.polar.out, t, b, nn, h);
        cx.leave();
        cx.enter(crate::lighting::DECL.name);
        let lp = cx.quantize3(lp, &self.light.light);
        let hp = cx.quantize3(hp, &self.light.light);
        cx.leave();
        self.light.shade(cx, k, n, lp, hp)
    }

    /// The conventional baseline traced: inputs `c1, c2`, then `t1, b1, n1,
    /// t2, …, n3` (vertex format), `l`, `h` (light format), `n` (texel);
    /// output `level`. Compiles (division and square root included); the
    /// emitter refuses it.
    ///
    /// # Errors
    ///
    /// A [`ConvertError`] when `255·i0_km` or `255·i0_ks` is NaN or infinite
    /// ([`Lighting::consts`]).
    pub fn trace_tbn(&self) -> Result<Trace, ConvertError> {
        let mut tr = Trace::new();
        let c1 = tr.input_named("c1", &self.interp.bary);
        let c2 = tr.input_named("c2", &self.interp.bary);
        let f: [[[_; 3]; 3]; 3] = std::array::from_fn(|v| {
            std::array::from_fn(|a| {
                tr.input3(
                    &format!("{}{}", ["t", "b", "n"][a], v + 1),
                    &self.interp.vertex,
                )
            })
        });
        let l = tr.input3("l", &self.light.light);
        let h = tr.input3("h", &self.light.light);
        let n = tr.input3("tex", &self.light.normal);
        let k = self.light.consts(&mut tr)?;
        let one = Interp::one(&mut tr);
        let out = self.mapped_tbn(&mut tr, &k, one, c1, c2, &f, l, h, n);
        tr.output("level", out);
        Ok(tr)
    }

    /// Levels of the conventional baseline on rows of codes (fields as
    /// [`Pipeline::trace_tbn`]'s inputs).
    ///
    /// # Errors
    ///
    /// [`PipelineError::Convert`] as [`Pipeline::trace_tbn`]; [`PipelineError::Compile`] when the
    /// baseline does not compile ([`CompileError`]).
    ///
    /// # Panics
    ///
    /// If `rows` is not empty and its first row does not hold one code per input of
    /// [`Pipeline::trace_tbn`], or a later row holds fewer codes than the first.
    pub fn run_tbn_rows(&self, rows: &[Vec<i128>]) -> Result<Vec<i128>, PipelineError> {
        let prog = self.trace_tbn()?.compile_outputs()?;
        let width = rows.first().map_or(0, |r| r.len());
        let cols: Vec<Vec<i128>> = (0..width)
            .map(|k| rows.iter().map(|r| r[k]).collect())
            .collect();
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        if refs.is_empty() {
            return Ok(Vec::new());
        }
        let (mut res, _) = prog.run_i128(&refs);
        Ok(res.swap_remove(0))
    }

    /// Counting run of the conventional baseline, per pixel.
    ///
    /// # Errors
    ///
    /// As [`Pipeline::trace_tbn`].
    pub fn count_tbn(&self) -> Result<Count, ConvertError> {
        let mut cx = Count::new();
        let c = cx.constant(0.0, &self.interp.bary)?;
        let v = cx.constant(0.0, &self.interp.vertex)?;
        let l = [cx.constant(0.0, &self.light.light)?; 3];
        let n = [cx.constant(0.0, &self.light.normal)?; 3];
        let k = self.light.consts(&mut cx)?;
        let one = Interp::one(&mut cx);
        self.mapped_tbn(&mut cx, &k, one, c, c, &[[[v; 3]; 3]; 3], l, l, n);
        Ok(cx)
    }

    /// Constants of the mapped path with CORDIC angles in a context.
    ///
    /// # Errors
    ///
    /// The [`ConvertError`] of `cx.constant` for a NaN or infinite constant: `255·i0_km` or
    /// `255·i0_ks` (the CORDIC constants are finite).
    pub fn mapped_consts<C: Datapath>(
        &self,
        cx: &mut C,
    ) -> Result<MappedConsts<C::V>, ConvertError> {
        Ok(MappedConsts {
            one: Interp::one(cx),
            angles: self.cordic.consts(cx)?,
            light: self.light.consts(cx)?,
        })
    }

    /// Constants of the smooth path in a context.
    ///
    /// # Errors
    ///
    /// The [`ConvertError`] of `cx.constant` for a NaN or infinite constant: a normalizer
    /// coefficient, `255·i0_km` or `255·i0_ks`.
    pub fn smooth_consts<C: Datapath>(
        &self,
        cx: &mut C,
    ) -> Result<SmoothConsts<C::V>, ConvertError> {
        Ok(SmoothConsts {
            one: Interp::one(cx),
            norm: self
                .sets
                .iter()
                .map(|n| n.consts(cx))
                .collect::<Result<_, _>>()?,
            light: self.light.consts(cx)?,
        })
    }

    /// The path compiled for batches (inputs as [`Pipeline::fields`],
    /// output the level).
    ///
    /// # Errors
    ///
    /// [`PipelineError::Convert`] as [`Pipeline::trace`]; [`PipelineError::Compile`] when the trace
    /// does not compile ([`CompileError`]: an exact intermediate wider than the model holds, or
    /// more quantization stages than the overflow flags hold).
    pub fn compile(&self, path: Path) -> Result<Compiled, PipelineError> {
        Ok(self.trace(path)?.compile_outputs()?)
    }

    /// Counting runs of the two paths, per pixel.
    ///
    /// # Errors
    ///
    /// A [`ConvertError`] for a NaN or infinite constant of `path`, as [`Pipeline::trace`].
    pub fn count(&self, path: Path) -> Result<Count, ConvertError> {
        let mut cx = Count::new();
        let c = cx.constant(0.0, &self.interp.bary)?;
        match path {
            Path::Smooth => {
                let k = self.smooth_consts(&mut cx)?;
                let v = [[cx.constant(0.0, &self.interp.vertex)?; 3]; 6];
                let l = [cx.constant(0.0, &self.light.light)?; 3];
                self.smooth(&mut cx, 0, &k, c, c, &v, l, l);
            }
            Path::Mapped if self.angles == AngleSource::Cordic => {
                let k = self.mapped_consts(&mut cx)?;
                let v = [[cx.constant(0.0, &self.interp.vertex)?; 3]; 6];
                let a0 = cx.constant(0.0, &self.angle)?;
                let n = [cx.constant(0.0, &self.light.normal)?; 3];
                self.mapped_cordic(&mut cx, &k, c, c, &v, [a0; 4], n);
            }
            Path::Mapped => {
                let k = self.light.consts(&mut cx)?;
                let a0 = cx.constant(0.0, &self.angle)?;
                let d0 = cx.constant(0.0, &self.delta)?;
                let n = [cx.constant(0.0, &self.light.normal)?; 3];
                self.mapped(&mut cx, &k, c, c, [a0, d0, d0], [a0, d0, d0], [a0; 4], n);
            }
        }
        Ok(cx)
    }

    /// Set up a triangle for the smooth path: vertex and midpoint normals as
    /// vertex-format codes, the coefficient set, and the set-up triangle.
    ///
    /// # Errors
    ///
    /// The [`SetupError`] of [`interp::setup`] for the vertex normals `n`.
    pub fn setup_smooth(&self, n: [DVec3; 3]) -> Result<SmoothTri, SetupError> {
        let t = interp::setup(n)?;
        let q = &self.interp.vertex;
        let code = |x: f64| q.apply_f64(x).map(|r| r.code).unwrap_or(0);
        let all = [t.n[0], t.n[1], t.n[2], t.mid[0], t.mid[1], t.mid[2]];
        Ok(SmoothTri {
            v: all.map(|p| [code(p.x), code(p.y), code(p.z)]),
            set: Self::set_of(t.theta),
            tri: t,
        })
    }

    /// Angle codes (`U0F<k>`) of a unit vector: `(α, β)` of
    /// [`crate::polar::angles_of`], quantized and wrapped by the angle stage.
    pub fn angle_codes(&self, v: DVec3) -> (i128, i128) {
        let (a, b) = crate::polar::angles_of(v);
        let code = |x: f64| self.angle.apply_f64(x).map(|r| r.code).unwrap_or(0);
        (code(a), code(b))
    }

    /// The mapped path's input row of one pixel (fields as
    /// [`Pipeline::fields`]): `c1, c2` bary codes, the triangle set up for
    /// both paths, the angle codes `[α_L, β_L, α_H, β_H]` and the texel
    /// codes. With CORDIC angles the row carries the six normals of the
    /// smooth set-up; with interpolated angles, the angle set-up.
    pub fn mapped_row(
        &self,
        c: [i128; 2],
        st: &SmoothTri,
        mt: &MappedTri,
        lh: [i128; 4],
        tex: [i128; 3],
    ) -> Vec<i128> {
        let mut r = Vec::new();
        Self::mapped_row_into(self.angles, c, st, mt, lh, tex, &mut r);
        r
    }

    /// [`Pipeline::mapped_row`] for the angle source `src`, appended to `out`
    /// (no vector of its own): the fields of [`Pipeline::fields_of`]
    /// for [`Path::Mapped`] and `src`.
    pub fn mapped_row_into(
        src: AngleSource,
        c: [i128; 2],
        st: &SmoothTri,
        mt: &MappedTri,
        lh: [i128; 4],
        tex: [i128; 3],
        out: &mut Vec<i128>,
    ) {
        out.extend_from_slice(&c);
        match src {
            AngleSource::Cordic => {
                for v in &st.v {
                    out.extend_from_slice(v);
                }
            }
            AngleSource::Interpolate => {
                out.extend_from_slice(&mt.a);
                out.extend_from_slice(&mt.b);
            }
        }
        out.extend_from_slice(&lh);
        out.extend_from_slice(&tex);
    }

    /// Set up a triangle for the mapped path: `[α3, Δα1, Δα2]` and
    /// `[β3, Δβ1, Δβ2]` from the vertex normals' angles.
    pub fn setup_mapped(&self, n: [DVec3; 3]) -> MappedTri {
        let k = self.angle.format().width();
        let codes = n.map(|v| self.angle_codes(v));
        let wrap = |d: i128| {
            let m = 1i128 << k;
            let d = d.rem_euclid(m);
            if d >= m / 2 {
                d - m
            } else {
                d
            }
        };
        let pack = |f: fn(&(i128, i128)) -> i128| {
            let x3 = f(&codes[2]);
            [x3, wrap(f(&codes[0]) - x3), wrap(f(&codes[1]) - x3)]
        };
        MappedTri {
            a: pack(|c| c.0),
            b: pack(|c| c.1),
        }
    }
}

/// Run `prog` on `n` rows of `width` codes (`row(i)` is row `i`): the
/// rows are transposed into the columns the program takes, in its own code
/// type, then run; the first output's codes, in row order.
fn run_columns<'a>(
    prog: &Compiled,
    width: usize,
    n: usize,
    row: impl Fn(usize) -> &'a [i128],
) -> Vec<i128> {
    // Row after row (each read once, front to back), each code to its
    // column. Columns lie `stride` codes apart, a little more than `n`: at
    // a power-of-two distance every column's current line would fall in
    // the same cache set.
    fn columns<'a, R: Copy + Default>(
        width: usize,
        n: usize,
        row: &impl Fn(usize) -> &'a [i128],
        f: impl Fn(i128) -> R,
    ) -> (Vec<R>, usize) {
        let stride = n + 8;
        let mut cols = vec![R::default(); width * stride];
        for i in 0..n {
            for (k, &v) in row(i)[..width].iter().enumerate() {
                cols[k * stride + i] = f(v);
            }
        }
        (cols, stride)
    }
    if n == 0 {
        return Vec::new();
    }
    match prog {
        Compiled::Narrow(p) => {
            // The program was compiled narrow: every input code fits.
            let (cols, stride) = columns(width, n, &row, narrow::<i64, _>);
            let refs: Vec<&[i64]> = cols.chunks_exact(stride).map(|c| &c[..n]).collect();
            let (mut res, _) = p.run(&refs);
            res.swap_remove(0).into_iter().map(i128::from).collect()
        }
        Compiled::Wide(p) => {
            let (cols, stride) = columns(width, n, &row, |v| v);
            let refs: Vec<&[i128]> = cols.chunks_exact(stride).map(|c| &c[..n]).collect();
            let (mut res, _) = p.run(&refs);
            res.swap_remove(0)
        }
    }
}

/// Bits of the coefficient-set index `sel` (enough for [`THETA_LADDER`]).
pub const SEL_BITS: u32 = 3;

/// The scope (stage-id prefix) of the angle interpolation.
pub const ANGLE_UNIT: &str = "angle_interp";

/// The `sel` port: an unsigned `SEL_BITS`-bit code.
///
/// # Panics
///
/// Never: `U3F0` is a valid format.
pub fn sel_quant() -> Quant {
    Quant::new(
        "sel",
        Format::new(false, SEL_BITS, 0).expect("valid"),
        Rounding::Trunc,
        Overflow::Saturate,
    )
}

impl Pipeline {
    /// The per-pixel input fields of `path`, in the order of the rows
    /// [`Pipeline::run_rows`] takes and the RTL top's input port packs,
    /// most significant first.
    ///
    /// # Panics
    ///
    /// Never: `U3F0` (the `sel` field) is a valid format.
    pub fn fields(&self, path: Path) -> Vec<crate::rtl::record::Field> {
        self.fields_of(path, self.angles)
    }

    /// [`Pipeline::fields`] with the mapped path's angles from `src`
    /// rather than the configured source (a render builds the rows of
    /// both).
    ///
    /// # Panics
    ///
    /// Never, as [`Pipeline::fields`].
    pub fn fields_of(&self, path: Path, src: AngleSource) -> Vec<crate::rtl::record::Field> {
        use crate::rtl::record::Field;
        let fb = self.interp.bary.format();
        let mut f = Vec::new();
        match path {
            Path::Smooth => {
                f.push(Field::new(
                    "sel",
                    Format::new(false, SEL_BITS, 0).expect("valid"),
                ));
                f.push(Field::new("c1", fb));
                f.push(Field::new("c2", fb));
                let fv = self.interp.vertex.format();
                for v in ["n1", "n2", "n3", "n12", "n23", "n31"] {
                    for c in ["x", "y", "z"] {
                        f.push(Field::new(&format!("{v}{c}"), fv));
                    }
                }
                let fl = self.light.light.format();
                for v in ["l", "h"] {
                    for c in ["x", "y", "z"] {
                        f.push(Field::new(&format!("{v}{c}"), fl));
                    }
                }
            }
            Path::Mapped if src == AngleSource::Cordic => {
                f.push(Field::new("c1", fb));
                f.push(Field::new("c2", fb));
                let fv = self.interp.vertex.format();
                for v in ["n1", "n2", "n3", "n12", "n23", "n31"] {
                    for c in ["x", "y", "z"] {
                        f.push(Field::new(&format!("{v}{c}"), fv));
                    }
                }
                let fa = self.angle.format();
                for v in ["al", "bl", "ah", "bh"] {
                    f.push(Field::new(v, fa));
                }
                let fnm = self.light.normal.format();
                for c in ["x", "y", "z"] {
                    f.push(Field::new(&format!("n{c}"), fnm));
                }
            }
            Path::Mapped => {
                f.push(Field::new("c1", fb));
                f.push(Field::new("c2", fb));
                let (fa, fd) = (self.angle.format(), self.delta.format());
                for v in ["a", "b"] {
                    f.push(Field::new(&format!("{v}3"), fa));
                    f.push(Field::new(&format!("d{v}1"), fd));
                    f.push(Field::new(&format!("d{v}2"), fd));
                }
                for v in ["al", "bl", "ah", "bh"] {
                    f.push(Field::new(v, fa));
                }
                let fnm = self.light.normal.format();
                for c in ["x", "y", "z"] {
                    f.push(Field::new(&format!("n{c}"), fnm));
                }
            }
        }
        f
    }

    /// The set a `sel` code reads: codes past the last set read set 0, as
    /// the RTL's padded coefficient table does.
    pub fn set_code(&self, sel: i128) -> usize {
        if (0..self.sets.len() as i128).contains(&sel) {
            narrow::<usize, _>(sel)
        } else {
            0
        }
    }

    /// Run the bit-accurate pipeline on rows of input codes (fields as
    /// [`Pipeline::fields`]); the levels, in row order. One compiled
    /// program serves every row: the smooth path selects its coefficient
    /// set by the row's `sel` code, as the RTL does.
    ///
    /// # Errors
    ///
    /// As [`Pipeline::compile`] for `path`.
    ///
    /// # Panics
    ///
    /// If a row holds fewer codes than `path` has fields ([`Pipeline::fields`]).
    pub fn run_rows(&self, path: Path, rows: &[Vec<i128>]) -> Result<Vec<i128>, PipelineError> {
        Ok(self.run_rows_compiled(path, &self.compile(path)?, rows))
    }

    /// [`Pipeline::run_rows`] on `path`'s program compiled already
    /// (`prog`, from [`Pipeline::compile`]): the pixel codes of `rows`.
    ///
    /// # Panics
    ///
    /// If a row holds fewer codes than `path` has fields.
    pub fn run_rows_compiled(&self, path: Path, prog: &Compiled, rows: &[Vec<i128>]) -> Vec<i128> {
        let width = self.fields(path).len();
        run_columns(prog, width, rows.len(), |i| &rows[i][..width])
    }

    /// [`Pipeline::run_rows_compiled`] on rows stored flat: `codes` holds
    /// one row of `path`'s fields after another ([`Rows::live_codes`]).
    ///
    /// # Panics
    ///
    /// If `codes.len()` is not a multiple of the number of `path`'s fields.
    pub fn run_flat_compiled(&self, path: Path, prog: &Compiled, codes: &[i128]) -> Vec<i128> {
        let width = self.fields(path).len();
        assert_eq!(codes.len() % width, 0, "rows of {width} codes");
        let n = codes.len() / width;
        run_columns(prog, width, n, |i| &codes[i * width..(i + 1) * width])
    }

    /// The scalar fixed-point run of one row (the readable specification the
    /// compiled run is tested against).
    ///
    /// # Errors
    ///
    /// [`PipelineError::Convert`] as [`Pipeline::trace`].
    ///
    /// # Panics
    ///
    /// If `row` holds fewer codes than `path` has fields ([`Pipeline::fields`]).
    pub fn eval_row(&self, path: Path, row: &[i128]) -> Result<i128, PipelineError> {
        use crate::datapath::{Fixed, Fx};
        let mut fx = Fixed::<i128>::new();
        let f = self.fields(path);
        let v = |k: usize| Fx::<i128>::from_code(row[k], f[k].format);
        Ok(match path {
            Path::Smooth => {
                let k = self.smooth_consts(&mut fx)?;
                let set = self.set_code(row[0]);
                let vv: [[Fx; 3]; 6] =
                    std::array::from_fn(|i| std::array::from_fn(|c| v(3 + 3 * i + c)));
                let l = [v(21), v(22), v(23)];
                let h = [v(24), v(25), v(26)];
                self.smooth(&mut fx, set, &k, v(1), v(2), &vv, l, h).code()
            }
            Path::Mapped if self.angles == AngleSource::Cordic => {
                let k = self.mapped_consts(&mut fx)?;
                let vv: [[Fx; 3]; 6] =
                    std::array::from_fn(|i| std::array::from_fn(|c| v(2 + 3 * i + c)));
                self.mapped_cordic(
                    &mut fx,
                    &k,
                    v(0),
                    v(1),
                    &vv,
                    [v(20), v(21), v(22), v(23)],
                    [v(24), v(25), v(26)],
                )
                .code()
            }
            Path::Mapped => {
                let k = self.light.consts(&mut fx)?;
                self.mapped(
                    &mut fx,
                    &k,
                    v(0),
                    v(1),
                    [v(2), v(3), v(4)],
                    [v(5), v(6), v(7)],
                    [v(8), v(9), v(10), v(11)],
                    [v(12), v(13), v(14)],
                )
                .code()
            }
        })
    }
}

/// Constants of the mapped path with CORDIC angles.
#[derive(Clone, Debug)]
pub struct MappedConsts<V> {
    /// 1 in the bary format.
    pub one: V,
    /// The CORDIC constants.
    pub angles: crate::angles::Consts<V>,
    /// The lighting constants.
    pub light: crate::lighting::Consts<V>,
}

/// Constants of the smooth path.
#[derive(Clone, Debug)]
pub struct SmoothConsts<V> {
    /// 1 in the bary format.
    pub one: V,
    /// Each set's normalizer constants.
    pub norm: Vec<normalizer::Consts<V>>,
    /// The lighting constants.
    pub light: crate::lighting::Consts<V>,
}

/// A triangle set up for the smooth path.
#[derive(Clone, Copy, Debug)]
pub struct SmoothTri {
    /// `N1, N2, N3, N12, N23, N31` as vertex-format codes.
    pub v: [[i128; 3]; 6],
    /// The coefficient set (index into [`THETA_LADDER`]).
    pub set: usize,
    /// The exact set-up.
    pub tri: interp::Triangle,
}

/// A triangle set up for the mapped path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MappedTri {
    /// `[α3, Δα1, Δα2]`: an angle code and two delta codes.
    pub a: [i128; 3],
    /// `[β3, Δβ1, Δβ2]`.
    pub b: [i128; 3],
}

fn check(_cfg: &Config) -> Result<(), Vec<ConfigError>> {
    // Widths: every stage of the chained datapath belongs to a unit whose
    // own check measures it; the conversions between units only quantize,
    // and the angle stage takes the polar angle format.
    Ok(())
}

fn ops(cfg: &Config) -> Vec<OpReport> {
    ops_for(cfg).unwrap_or_default()
}

/// Counting runs, per pixel: the smooth path with each normalizer the RTL
/// implements (linear and quadratic `g`), and the mapped path.
///
/// # Errors
///
/// The [`PipelineError`] of [`Pipeline::with_method`] for the linear, quadratic or no-`g` pipeline
/// of `cfg`; the counting runs' [`PipelineError::Convert`] cannot arise from a configuration.
pub fn ops_for(cfg: &Config) -> Result<Vec<OpReport>, PipelineError> {
    let mut v = Vec::new();
    let smooth_methods = [Method::Linear, Method::Quadratic];
    for m in smooth_methods {
        let p = Pipeline::with_method(cfg, m)?;
        let cx = p.count(Path::Smooth)?;
        let name = if m == Method::Linear {
            "smooth, linear g"
        } else {
            "smooth, quadratic g"
        };
        v.push(OpReport::from_count(
            DECL.name,
            name,
            Phase::Pixel,
            &cx,
            None,
        ));
    }
    for (src, name) in [
        (AngleSource::Cordic, "mapped, cordic angles"),
        (AngleSource::Interpolate, "mapped, interpolated angles"),
    ] {
        let mut p = Pipeline::with_method(cfg, Method::None)?;
        p.angles = src;
        v.push(OpReport::from_count(
            DECL.name,
            name,
            Phase::Pixel,
            &p.count(Path::Mapped)?,
            None,
        ));
    }
    let p = Pipeline::with_method(cfg, Method::None)?;
    v.push(OpReport::from_count(
        DECL.name,
        "mapped, conventional TBN (baseline, no RTL)",
        Phase::Pixel,
        &p.count_tbn()?,
        None,
    ));
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn cfg(path: &str) -> Config {
        Config::resolve(None, &[format!("pipeline.path=\"{path}\"")]).unwrap()
    }

    #[test]
    fn compiled_rows_equal_the_scalar_fixed_point_run() {
        for path in ["smooth", "mapped"] {
            let c = cfg(path);
            let mut rows = rtl::inputs(&c, crate::rtl::units::Part::Corners, 3).unwrap();
            rows.extend(rtl::inputs(&c, crate::rtl::units::Part::Random(400), 3).unwrap());
            let p = Pipeline::from_config(&c).unwrap();
            let pth = Path::from_name(path).unwrap();
            let got = p.run_rows(pth, &rows).unwrap();
            for (row, g) in rows.iter().zip(&got) {
                assert_eq!(*g, p.eval_row(pth, row).unwrap(), "{path} {row:?}");
            }
        }
    }

    /// The per-pixel fields are the barycentrics and, on the mapped path,
    /// the texel: named here by the vector fields ([`Pipeline::fields`]),
    /// not by the trace's ports that `pixel_fields` reads.
    #[test]
    fn pixel_fields_are_the_barycentrics_and_the_texel() {
        for (path, src, want) in [
            (Path::Smooth, AngleSource::Cordic, &["c1", "c2"][..]),
            (
                Path::Mapped,
                AngleSource::Cordic,
                &["c1", "c2", "nx", "ny", "nz"],
            ),
            (
                Path::Mapped,
                AngleSource::Interpolate,
                &["c1", "c2", "nx", "ny", "nz"],
            ),
        ] {
            let mut p = Pipeline::from_config(&Config::embedded()).unwrap();
            p.angles = src;
            let fields = p.fields(path);
            let pixel = p.pixel_fields(path).unwrap();
            assert_eq!(pixel.len(), fields.len(), "{path:?} {src:?}");
            let got: Vec<&str> = fields
                .iter()
                .zip(&pixel)
                .filter(|(_, &v)| v)
                .map(|(f, _)| f.name.as_str())
                .collect();
            assert_eq!(got, want, "{path:?} {src:?}");
        }
    }

    #[test]
    fn the_power_chain_squares_and_multiplies_as_the_exponent_says() {
        for n in [1u32, 2, 5, 16, 40, 255] {
            let c = Config::resolve(None, &[format!("lighting.shininess={n}")]).unwrap();
            let l = Lighting::from_config(&c);
            let base = l.count().counts().mul;
            let shade = l.count_shade().counts().mul;
            // shade = N·L and N·H (6), two gains (2), squarings and products.
            let squarings = 31 - n.leading_zeros();
            let products = n.count_ones() - 1;
            assert_eq!(shade as u32, 6 + 2 + squarings + products, "n = {n}");
            assert_eq!(base, 4);
            // In f64 the chain is x^n.
            let mut rf = crate::datapath::Reference;
            let x = 0.9;
            assert!((l.power(&mut rf, x) - x.powi(n as i32)).abs() < 1e-12);
        }
    }

    #[test]
    fn shading_in_fixed_point_tracks_the_closed_form() {
        let c = Config::embedded();
        let l = Lighting::from_config(&c);
        let prog = l.compile_shade().unwrap();
        let mut rng = Rng::new(5);
        let q = |x: f64, s: &Quant| s.apply_f64(x).unwrap().code;
        let mut cols: [Vec<i128>; 9] = Default::default();
        let mut want = Vec::new();
        for _ in 0..2000 {
            let (n, lv) = (rng.direction(), rng.direction());
            let h = (lv + DVec3::Z).normalize();
            for k in 0..3 {
                cols[k].push(q(n[k], &l.normal));
                cols[3 + k].push(q(lv[k], &l.light));
                cols[6 + k].push(q(h[k], &l.light));
            }
            want.push(crate::render::shade_f64(&l, n, lv, h));
        }
        let refs: Vec<&[i128]> = cols.iter().map(|c| c.as_slice()).collect();
        let (out, _) = prog.run_i128(&refs);
        for (g, w) in out[0].iter().zip(&want) {
            assert!((*g as f64 - w).abs() <= 1.0, "{g} vs {w}");
        }
    }

    #[test]
    fn angles_interpolate_across_the_seam_not_around_it() {
        let p = Pipeline::from_config(&cfg("mapped")).unwrap();
        // Normals either side of β = ±180° (x ≈ 0, z < 0).
        let n = [
            DVec3::new(0.05, 0.0, -1.0),
            DVec3::new(-0.05, 0.0, -1.0),
            DVec3::new(0.0, 0.05, -1.0),
        ];
        let t = p.setup_mapped(n);
        let k = p.angle.format().width();
        // The deltas are small, not near a half turn.
        for d in [t.b[1], t.b[2]] {
            assert!(d.abs() < 1 << (k - 5), "{t:?}");
        }
        let mut fx = crate::datapath::Fixed::<i128>::new();
        let v = |code: i128, f: Format| crate::datapath::Fx::<i128>::from_code(code, f);
        let fb = p.interp.bary.format();
        let c = p.interp.bary.apply_f64(0.5).unwrap().code;
        let b = p.angle_of(
            &mut fx,
            v(c, fb),
            v(c, fb),
            [
                v(t.b[0], p.angle.format()),
                v(t.b[1], p.delta.format()),
                v(t.b[2], p.delta.format()),
            ],
        );
        // Halfway between the first two vertices: β = ½ turn.
        let turns = b.code() as f64 / (1u64 << k) as f64;
        assert!((turns - 0.5).abs() < 2.0 / (1u64 << k) as f64, "{turns}");
    }

    #[test]
    fn triangles_pick_the_coefficient_set_of_their_theta() {
        let p = Pipeline::from_config(&Config::embedded()).unwrap();
        let mut rng = Rng::new(9);
        for (i, &th) in THETA_LADDER.iter().enumerate() {
            let n = crate::sampling::equiangular(th + 1e-9, &mut rng);
            assert_eq!(p.setup_smooth(n).unwrap().set, i, "Θ = {th}");
        }
        // Sets differ where the intervals differ.
        assert_ne!(p.sets[0].coeffs, p.sets[5].coeffs);
        assert_eq!(p.set_code(6), 0);
        assert_eq!(p.set_code(7), 0);
    }
}
