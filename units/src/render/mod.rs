//! The renderer: rasterize a mesh with barycentric coordinates, run the
//! bit-accurate pipeline on every covered pixel, and measure the image
//! against an f64 reference.
//!
//! ## Scene
//! A [`Scene`] (defaults: [`Scene::default`]; `fxshade render --light
//! --view --tilt --normal-map`). The mesh is centred on its bounding box,
//! scaled to radius 1, turned `tilt` degrees about x (default [`TILT_DEG`],
//! so the pole of a y-axis sphere and the hole of a torus are in view), then
//! seen from the viewer direction `V` (default `+z`): the scene is rotated
//! by the shortest rotation taking `V` to `+z` and projected orthographically
//! along −z onto the image (radius 1 → 45 % of the smaller side). The light
//! `L` (default [`LIGHT`], normalized) is given in the same world frame as
//! `V`; both are constant, so `H = (L + V)/|L + V|` is too. A z-buffer keeps the nearest triangle per
//! pixel centre; a pixel on a shared edge belongs to the first triangle
//! drawn at that depth.
//!
//! ## What is compared
//! * smooth path: the reference is
//!   `255·(I0·km·max(0, N·L) + I0·ks·max(0, N·H)^n)` clipped to `[0, 255]`, with
//!   `N` the configured interpolation scheme's field at the pixel's exact
//!   barycentrics, normalized in f64 (glam's operations, computed many
//!   fragments at a time by the `lanes` module with the same results bit for
//!   bit), independent of the datapath code;
//! * mapped path, in the mesh's own (object) frame, where the implied frame
//!   a normal map is baked for is fixed by the y axis: `L` and `H` are
//!   brought there by [`Scene::unpose`]; the reference is the same lighting
//!   with the normal-map texel `n` and `L' = (L·T, L·B, L·N)` in the implied
//!   frame of the exact object-space `N` ([`crate::polar::reference`], with
//!   `α`, `β` by `asin`/`atan2` at the pixel); mapped methods are also judged
//!   outside and inside the polar cap ([`POLAR_CAP_DEG`]);
//! * beside it, in f64: the angles interpolated per vertex
//!   (`angle_interp`) and the conventional transform with per-vertex frames
//!   interpolated ([`tbn_f64`]);
//! * with an image map baked in the UV frame ([`MapFrame::Uv`]): the
//!   original map rendered in f64 with the exact UV-aligned frame
//!   ([`crate::texture::uv_frame`]), against which the mapped path on the
//!   converted map is compared ([`Frame::uv_ref`]).
//!
//! Errors are in 8-bit levels against the reference rounded to the nearest
//! level (the reference image).

use fxshade_numbers::convert::{from_f64, narrow, round_half_away, to_f64};
use glam::{DVec2, DVec3};

use crate::config::Config;
use crate::datapath::Compiled;
use crate::interp::{self, Scheme, THETA_LADDER};
use crate::mesh::Mesh;
use crate::normalizer::Method;
use crate::pipeline::{AngleSource, Columns, Path, Pipeline, PipelineError, Rows};

/// Tilt of the mesh about x, in degrees (towards the viewer at the top).
pub const TILT_DEG: f64 = 30.0;
/// The light direction (normalized before use).
pub const LIGHT: [f64; 3] = [-0.45, 0.6, 0.66];
/// The reference intensity below which the relative-error bound is not
/// judged: 12.75 levels, 5 % of full scale (one level there is already 8 %).
pub const REL_FLOOR_LEVELS: f64 = 12.75;
/// The paper's visual-identity bound on the relative intensity error.
pub const PAPER_BOUND: f64 = 0.04;

/// A method the renderer runs: a normalizer on the smooth path, the mapped
/// path with its angles of `N` by CORDIC or interpolated, or the mapped
/// path's conventional baseline (an interpolated TBN matrix and a
/// normalization).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderMethod {
    /// Smooth path with this normalizer.
    Smooth(Method),
    /// Mapped path (normal map, polar transform) with the angles of `N`
    /// from this source.
    Mapped(AngleSource),
    /// The conventional mapped path: per-vertex `T, B, N` interpolated,
    /// `L' = normalize(M·L)`, bit-accurate (no RTL).
    Tbn,
}

impl RenderMethod {
    /// Every method, smooth ones first.
    pub const ALL: [RenderMethod; 9] = [
        RenderMethod::Smooth(Method::Exact),
        RenderMethod::Smooth(Method::None),
        RenderMethod::Smooth(Method::Newton),
        RenderMethod::Smooth(Method::Taylor),
        RenderMethod::Smooth(Method::Linear),
        RenderMethod::Smooth(Method::Quadratic),
        RenderMethod::Mapped(AngleSource::Cordic),
        RenderMethod::Mapped(AngleSource::Interpolate),
        RenderMethod::Tbn,
    ];
    /// The methods the RTL top implements.
    pub const RTL: [RenderMethod; 4] = [
        RenderMethod::Smooth(Method::Linear),
        RenderMethod::Smooth(Method::Quadratic),
        RenderMethod::Mapped(AngleSource::Cordic),
        RenderMethod::Mapped(AngleSource::Interpolate),
    ];
    /// Name (`exact`, …, `quadratic`, `mapped`, `mapped-interp`, `tbn`).
    pub fn name(self) -> &'static str {
        match self {
            RenderMethod::Smooth(m) => m.name(),
            RenderMethod::Mapped(AngleSource::Cordic) => "mapped",
            RenderMethod::Mapped(AngleSource::Interpolate) => "mapped-interp",
            RenderMethod::Tbn => "tbn",
        }
    }
    /// Whether it renders the normal map (its reference is the mapped one).
    pub fn is_mapped(self) -> bool {
        !matches!(self, RenderMethod::Smooth(_))
    }
    /// Parse a name.
    pub fn from_name(s: &str) -> Option<RenderMethod> {
        Self::ALL.into_iter().find(|m| m.name() == s)
    }
    /// The path.
    pub fn path(self) -> Path {
        match self {
            RenderMethod::Smooth(_) => Path::Smooth,
            RenderMethod::Mapped(_) | RenderMethod::Tbn => Path::Mapped,
        }
    }
}

/// One covered pixel.
#[derive(Clone, Copy, Debug)]
pub struct Fragment {
    /// Pixel index `y·width + x`.
    pub pixel: usize,
    /// Triangle index.
    pub tri: usize,
    /// Exact barycentrics at the pixel centre.
    pub c: [f64; 3],
    /// Interpolated texture coordinates.
    pub uv: DVec2,
}

/// A rasterized mesh.
#[derive(Clone, Debug)]
pub struct Raster {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Covered pixels, in pixel order.
    pub fragments: Vec<Fragment>,
    /// Vertex normals after the scene transform.
    pub normals: Vec<DVec3>,
}

/// The frame an image normal map was baked in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MapFrame {
    /// The polar transform's implied frame (e.g. written by
    /// `fxshade bake-implied`): texels are used as they are.
    Implied,
    /// A UV-aligned frame ([`crate::texture::uv_frame`]): the renderer
    /// converts the map into the implied frame through the mesh's UV layout
    /// ([`crate::texture::bake_implied`]) for the mapped path, and renders
    /// the original map with the UV-frame TBN transform in f64 beside it.
    Uv,
}

/// A normal map read from an image file.
#[derive(Clone, Debug, PartialEq)]
pub struct MapImage {
    /// The file, as given.
    pub name: String,
    /// The texels.
    pub texture: crate::texture::NormalTexture,
    /// The frame it was baked in.
    pub frame: MapFrame,
    /// Its green convention (already applied to the texels).
    pub green: crate::texture::Green,
}

/// The normal map the mapped path samples.
#[derive(Clone, Debug, PartialEq)]
pub enum NormalMap {
    /// The procedural bumps of [`normal_map`].
    Bumps,
    /// `(0, 0, 1)` everywhere: the mapped path then shades the interpolated
    /// normal itself.
    Flat,
    /// An image, laid out by the mesh's texture coordinates.
    Image(std::sync::Arc<MapImage>),
}

impl serde::Serialize for NormalMap {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            NormalMap::Image(m) => {
                use serde::ser::SerializeStruct;
                let mut st = s.serialize_struct("NormalMap", 5)?;
                st.serialize_field("file", &m.name)?;
                st.serialize_field("width", &m.texture.width)?;
                st.serialize_field("height", &m.texture.height)?;
                st.serialize_field("frame", &m.frame)?;
                st.serialize_field("green", &m.green)?;
                st.end()
            }
            other => s.serialize_str(other.name()),
        }
    }
}

impl NormalMap {
    /// The procedural maps.
    pub const ALL: [NormalMap; 2] = [NormalMap::Bumps, NormalMap::Flat];
    /// Its name (`bumps`, `flat`, or the image's file).
    pub fn name(&self) -> &str {
        match self {
            NormalMap::Bumps => "bumps",
            NormalMap::Flat => "flat",
            NormalMap::Image(m) => &m.name,
        }
    }
    /// The texel at `uv`, as stored (an image in the UV frame is converted
    /// by [`frame_in`], not here).
    pub fn at(&self, uv: DVec2) -> DVec3 {
        match self {
            NormalMap::Bumps => normal_map(uv),
            NormalMap::Flat => DVec3::Z,
            NormalMap::Image(m) => m.texture.at(uv),
        }
    }
}

/// Where the light and the viewer are and how the mesh is posed.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Scene {
    /// Direction towards the light, world frame, unit length.
    pub light: DVec3,
    /// Direction towards the viewer, world frame, unit length.
    pub view: DVec3,
    /// Tilt of the mesh about x, in degrees, before viewing.
    pub tilt_deg: f64,
    /// The normal map of the mapped path.
    pub normal_map: NormalMap,
}

impl Default for Scene {
    /// [`LIGHT`], `V = +z`, [`TILT_DEG`], the bumps.
    fn default() -> Self {
        Scene {
            light: DVec3::from_array(LIGHT).normalize(),
            view: DVec3::Z,
            tilt_deg: TILT_DEG,
            normal_map: NormalMap::Bumps,
        }
    }
}

/// Why a scene is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// A direction that is zero or not finite.
    #[error("--{what} {x},{y},{z}: a direction needs finite components, not all zero")]
    Direction {
        /// `light` or `view`.
        what: &'static str,
        /// x.
        x: f64,
        /// y.
        y: f64,
        /// z.
        z: f64,
    },
    /// A tilt that is not finite.
    #[error("--tilt {0}: give a finite angle in degrees")]
    Tilt(f64),
}

impl Scene {
    /// A scene from raw directions (normalized here) and a tilt.
    ///
    /// # Errors
    ///
    /// [`SceneError::Tilt`] when `tilt_deg` is not finite; else [`SceneError::Direction`] naming
    /// `light` or `view` (checked in that order) when it is not finite or its length is at most
    /// 10⁻³⁰⁰.
    pub fn new(
        light: DVec3,
        view: DVec3,
        tilt_deg: f64,
        normal_map: NormalMap,
    ) -> Result<Scene, SceneError> {
        let unit = |what, v: DVec3| {
            if v.is_finite() && v.length() > 1e-300 {
                Ok(v.normalize())
            } else {
                Err(SceneError::Direction {
                    what,
                    x: v.x,
                    y: v.y,
                    z: v.z,
                })
            }
        };
        if !tilt_deg.is_finite() {
            return Err(SceneError::Tilt(tilt_deg));
        }
        Ok(Scene {
            light: unit("light", light)?,
            view: unit("view", view)?,
            tilt_deg,
            normal_map,
        })
    }
    /// The rotation taking the viewer to `+z`.
    fn camera_rotation(&self) -> glam::DQuat {
        glam::DQuat::from_rotation_arc(self.view, DVec3::Z)
    }
    /// World to camera frame for a mesh direction: tilt, then view.
    fn pose(&self, v: DVec3) -> DVec3 {
        let (s, c) = self.tilt_deg.to_radians().sin_cos();
        self.camera_rotation() * DVec3::new(v.x, c * v.y - s * v.z, s * v.y + c * v.z)
    }
    /// The light in the camera frame (the viewer is `+z` there).
    pub fn light_camera(&self) -> DVec3 {
        (self.camera_rotation() * self.light).normalize()
    }
    /// Camera frame back to the mesh's own (object) frame: the inverse of
    /// the pose (view, then tilt).
    pub fn unpose(&self, v: DVec3) -> DVec3 {
        let w = self.camera_rotation().inverse() * v;
        let (s, c) = self.tilt_deg.to_radians().sin_cos();
        DVec3::new(w.x, c * w.y + s * w.z, -s * w.y + c * w.z)
    }
}

/// Rasterize `m` at `width × height` in the default [`Scene`].
pub fn rasterize(m: &Mesh, width: usize, height: usize) -> Raster {
    rasterize_in(&Scene::default(), m, width, height)
}

/// Rasterize `m` at `width × height` (see the module page for the scene).
pub fn rasterize_in(scene: &Scene, m: &Mesh, width: usize, height: usize) -> Raster {
    let tilt = |v: DVec3| scene.pose(v);
    let (lo, hi) = m.positions.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let centre = (lo + hi) / 2.0;
    let radius = m
        .positions
        .iter()
        .map(|p| (*p - centre).length())
        .fold(0.0, f64::max)
        .max(1e-300);
    let scale = 0.45 * to_f64(width.min(height)) / radius;
    let screen: Vec<DVec3> = m
        .positions
        .iter()
        .map(|p| {
            let q = tilt(*p - centre);
            DVec3::new(
                to_f64(width) / 2.0 + q.x * scale,
                to_f64(height) / 2.0 - q.y * scale,
                q.z,
            )
        })
        .collect();
    let mut depth = vec![f64::NEG_INFINITY; width * height];
    let mut owner: Vec<Option<Fragment>> = vec![None; width * height];
    for (ti, t) in m.triangles.iter().enumerate() {
        let [p0, p1, p2] = t.map(|i| screen[i as usize]);
        let area = (p1.x - p0.x) * (p2.y - p0.y) - (p2.x - p0.x) * (p1.y - p0.y);
        if area.abs() < 1e-12 {
            continue;
        }
        let x0 = from_f64::<usize>(p0.x.min(p1.x).min(p2.x).floor().max(0.0));
        let x1 = narrow::<usize, _>(
            (from_f64::<isize>(p0.x.max(p1.x).max(p2.x).ceil()))
                .clamp(0, narrow::<isize, _>(width)),
        );
        let y0 = from_f64::<usize>(p0.y.min(p1.y).min(p2.y).floor().max(0.0));
        let y1 = narrow::<usize, _>(
            (from_f64::<isize>(p0.y.max(p1.y).max(p2.y).ceil()))
                .clamp(0, narrow::<isize, _>(height)),
        );
        for y in y0..y1 {
            for x in x0..x1 {
                let (px, py) = (to_f64(x) + 0.5, to_f64(y) + 0.5);
                let e = |a: DVec3, b: DVec3| (b.x - a.x) * (py - a.y) - (px - a.x) * (b.y - a.y);
                let w0 = e(p1, p2) / area;
                let w1 = e(p2, p0) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * p0.z + w1 * p1.z + w2 * p2.z;
                let k = y * width + x;
                if z > depth[k] {
                    depth[k] = z;
                    let uv = if m.uvs.len() == m.positions.len() {
                        m.uvs[t[0] as usize] * w0
                            + m.uvs[t[1] as usize] * w1
                            + m.uvs[t[2] as usize] * w2
                    } else {
                        DVec2::ZERO
                    };
                    owner[k] = Some(Fragment {
                        pixel: k,
                        tri: ti,
                        c: [w0, w1, w2],
                        uv,
                    });
                }
            }
        }
    }
    Raster {
        width,
        height,
        fragments: owner.into_iter().flatten().collect(),
        normals: m.normals.iter().map(|n| tilt(*n)).collect(),
    }
}

/// The procedural normal map, in the polar transform's implied tangent
/// frame (x along `T`, y along `B`): the normal of the height field
/// `h = A·sin(2π·8u)·sin(2π·4v)`, sampled at texel centres of a 256 × 128
/// texture (nearest texel, wrapping).
pub fn normal_map(uv: DVec2) -> DVec3 {
    const W: f64 = 256.0;
    const H: f64 = 128.0;
    let tu = ((uv.x * W).floor().rem_euclid(W) + 0.5) / W;
    let tv = ((uv.y * H).floor().rem_euclid(H) + 0.5) / H;
    let (a, b) = (
        std::f64::consts::TAU * 8.0 * tu,
        std::f64::consts::TAU * 4.0 * tv,
    );
    let s = 0.5;
    DVec3::new(-s * a.cos() * b.sin(), -s * a.sin() * b.cos(), 1.0).normalize()
}

/// The lighting in f64: `255·(km·max(0, n·l) + ks·max(0, n·h)^e)`, clipped.
pub fn shade_f64(cfg_light: &crate::lighting::Lighting, n: DVec3, l: DVec3, h: DVec3) -> f64 {
    let d = n.dot(l).max(0.0);
    let s = n
        .dot(h)
        .max(0.0)
        .powi(narrow::<i32, _>(cfg_light.shininess));
    (crate::lighting::LEVELS * (cfg_light.i0_km * d + cfg_light.i0_ks * s)).clamp(0.0, 255.0)
}

/// Image metrics of one method against its reference.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Metrics {
    /// Covered pixels compared.
    pub pixels: usize,
    /// Covered pixels not compared: their triangle could not be set up
    /// (the reference is NaN there).
    pub skipped: usize,
    /// Largest `|image − reference image|`, in levels.
    pub max_abs_levels: u32,
    /// Mean of the same.
    pub mean_abs_levels: f64,
    /// Peak signal-to-noise ratio in dB (`None`: identical images).
    pub psnr_db: Option<f64>,
    /// Share of pixels off by exactly 0, 1 and 2 levels, and by more.
    pub off_by: [f64; 4],
    /// Largest relative intensity error beyond the 8-bit output's own
    /// rounding, `max(|image − reference| − ½, 0) / reference`, over pixels
    /// whose f64 reference is at least [`REL_FLOOR_LEVELS`] (the half level
    /// is what rounding the exact intensity to 8 bits costs by itself).
    pub max_rel_intensity_err: f64,
    /// Whether that stays under the paper's 4 % bound.
    pub paper_bound_holds: bool,
}

impl Metrics {
    /// Compare `got` (levels) with the f64 reference `want`, pixel by pixel;
    /// pixels whose reference is NaN are counted in `skipped` and left out.
    /// With no pixel compared, nothing is claimed: `paper_bound_holds` is
    /// false and `psnr_db` is `None`.
    pub fn compare(got: &[u8], want: &[f64]) -> Metrics {
        Self::compare_where(got, want, |_| true)
    }

    /// [`Metrics::compare`] over the pixels `k` with `keep(k)` only (the
    /// others are not counted at all, not even as skipped).
    pub fn compare_where(got: &[u8], want: &[f64], keep: impl Fn(usize) -> bool) -> Metrics {
        let mut m = Metrics::default();
        let sums = crate::datapath::Isa::current().run(Compare {
            got,
            want,
            keep: &keep,
        });
        m.pixels = sums.pixels.iter().map(|&n| usize_of(n)).sum();
        m.skipped = sums.skipped.iter().map(|&n| usize_of(n)).sum();
        m.max_abs_levels = sums.max_abs.iter().copied().max().unwrap_or(0);
        // The sums of integer errors, exact (as f64 sums would be below 2^53).
        let sum: u64 = sums.sum.iter().sum();
        let sq: u64 = sums.sq.iter().sum();
        let hist = sums.hist.map(|h| h.iter().sum::<u64>());
        m.max_rel_intensity_err = sums.max_rel.iter().fold(0.0, |a, &b| a.max(b));
        if m.pixels > 0 {
            let n = to_f64(m.pixels);
            m.mean_abs_levels = to_f64(sum) / n;
            m.off_by = hist.map(|h| to_f64(h) / n);
            m.psnr_db = (sq > 0).then(|| 10.0 * (255.0f64 * 255.0 / (to_f64(sq) / n)).log10());
        }
        m.paper_bound_holds = m.pixels > 0 && m.max_rel_intensity_err < PAPER_BOUND;
        m
    }
}

/// Lanes of [`Compare`]'s sums: pixel `k` goes to lane `k mod CMP_LANES`,
/// so that the lanes' chains are independent (and vectorize); the lanes
/// are then summed (integers: exact) or their maxima taken (exact, in any
/// order), so the metrics are those of one pass in pixel order.
const CMP_LANES: usize = 8;

/// Per lane: the sums and maxima of [`Metrics::compare_where`].
struct CompareSums {
    pixels: [u64; CMP_LANES],
    skipped: [u64; CMP_LANES],
    max_abs: [u32; CMP_LANES],
    sum: [u64; CMP_LANES],
    sq: [u64; CMP_LANES],
    hist: [[u64; CMP_LANES]; 4],
    max_rel: [f64; CMP_LANES],
}

/// [`Metrics::compare_where`]'s pass over the pixels, as a kernel compiled
/// for the widest instruction set ([`crate::datapath::Isa::run`]).
struct Compare<'a, K> {
    got: &'a [u8],
    want: &'a [f64],
    keep: &'a K,
}

impl<K: Fn(usize) -> bool> crate::datapath::Kernel for Compare<'_, K> {
    type Output = CompareSums;

    #[inline(always)]
    fn call(self) -> CompareSums {
        let mut s = CompareSums {
            pixels: [0; CMP_LANES],
            skipped: [0; CMP_LANES],
            max_abs: [0; CMP_LANES],
            sum: [0; CMP_LANES],
            sq: [0; CMP_LANES],
            hist: [[0; CMP_LANES]; 4],
            max_rel: [0.0; CMP_LANES],
        };
        let n = self.got.len().min(self.want.len());
        let keep = self.keep;
        // Whole groups of lanes (the inner loop unrolled over the lanes),
        // then the rest.
        let whole = n - n % CMP_LANES;
        for (c, (g, w)) in self.got[..whole]
            .chunks_exact(CMP_LANES)
            .zip(self.want[..whole].chunks_exact(CMP_LANES))
            .enumerate()
        {
            for j in 0..CMP_LANES {
                s.add(j, g[j], w[j], keep(c * CMP_LANES + j));
            }
        }
        for k in whole..n {
            s.add(k - whole, self.got[k], self.want[k], keep(k));
        }
        s
    }
}

impl CompareSums {
    /// Pixel `(g, w)` into lane `j` (when `kept`).
    #[inline(always)]
    fn add(&mut self, j: usize, g: u8, w: f64, kept: bool) {
        // Pixels whose reference is NaN are skipped, not compared.
        let valid = kept && !w.is_nan();
        self.skipped[j] += u64::from(kept && w.is_nan());
        self.pixels[j] += u64::from(valid);
        // (Selects rather than branches on the data: an invalid pixel
        // adds 0 and takes no maximum.)
        let e = from_f64::<u32>((f64::from(g) - round_half_away(w)).abs());
        let e = if valid { e } else { 0 };
        self.max_abs[j] = self.max_abs[j].max(e);
        self.sum[j] += u64::from(e);
        self.sq[j] += u64::from(e) * u64::from(e);
        for (b, h) in (0u32..).zip(self.hist.iter_mut()) {
            h[j] += u64::from(valid && e.min(3) == b);
        }
        // The error is never negative, so a pixel below the floor adds 0.
        let beyond = ((f64::from(g) - w).abs() - 0.5).max(0.0);
        let rel = if valid && w >= REL_FLOOR_LEVELS {
            beyond / w
        } else {
            0.0
        };
        self.max_rel[j] = self.max_rel[j].max(rel);
    }
}

/// A count as `usize` (it counts slice elements).
fn usize_of(n: u64) -> usize {
    narrow::<usize, _>(n)
}

/// The distribution of `cos φ` (smallest dot product of a triangle's vertex
/// normals) over a mesh's triangles.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct CosPhiStats {
    /// Triangles.
    pub triangles: usize,
    /// Triangles whose normals could not be set up (zero or antiparallel).
    pub degenerate: usize,
    /// Smallest `cos φ`.
    pub min: f64,
    /// Mean `cos φ`.
    pub mean: f64,
    /// Largest `cos φ`.
    pub max: f64,
    /// Triangles per Θ of the ladder they meet (the largest), as
    /// `(Θ, count)`, then those below every Θ (`cos φ < 0`) as `(-1, count)`.
    pub by_theta: Vec<(f64, usize)>,
}

/// `cos φ` over the triangles of a mesh.
pub fn cos_phi_stats(m: &Mesh) -> CosPhiStats {
    let mut s = CosPhiStats {
        triangles: m.triangles.len(),
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
        ..Default::default()
    };
    let mut counts = vec![0usize; THETA_LADDER.len() + 1];
    let mut sum = 0.0;
    let mut ok = 0;
    for t in &m.triangles {
        match interp::setup(t.map(|i| m.normals[i as usize])) {
            Ok(tri) => {
                ok += 1;
                sum += tri.cos_phi;
                s.min = s.min.min(tri.cos_phi);
                s.max = s.max.max(tri.cos_phi);
                match tri.theta {
                    Some(th) => counts[Pipeline::set_of(Some(th))] += 1,
                    None => counts[THETA_LADDER.len()] += 1,
                }
            }
            Err(_) => s.degenerate += 1,
        }
    }
    if ok > 0 {
        s.mean = sum / f64::from(ok);
    } else {
        (s.min, s.max) = (0.0, 0.0);
    }
    s.by_theta = THETA_LADDER
        .iter()
        .copied()
        .chain([-1.0])
        .zip(counts)
        .collect();
    s
}

/// The per-pixel input rows of both paths for a raster, and the f64
/// references.
#[derive(Clone, Debug)]
pub struct Frame {
    /// The raster.
    pub raster: Raster,
    /// Fragments whose triangle could not be set up (shaded 0 in every image,
    /// NaN in the references, excluded from the metrics).
    pub skipped: usize,
    /// Those triangles (0-based indices into the mesh), in raster order.
    pub skipped_triangles: Vec<usize>,
    /// Smooth-path input rows (one per fragment; skipped ones not live).
    pub smooth_rows: Rows,
    /// Mapped-path input rows with CORDIC angles (the six normals).
    pub mapped_rows: Rows,
    /// Mapped-path input rows with interpolated angles (the angle set-up).
    pub mapped_interp_rows: Rows,
    /// Rows of the conventional baseline: `c1, c2`, per vertex `T, B, N`,
    /// then `L`, `H` and the texel (skipped, too, where the frame is
    /// degenerate).
    pub tbn_rows: Rows,
    /// Whether the exactly interpolated normal lies within
    /// [`POLAR_CAP_DEG`] of the y axis, where `β` and the implied frame are
    /// singular.
    pub polar_cap: Vec<bool>,
    /// f64 reference level of the smooth path, per fragment.
    pub smooth_ref: Vec<f64>,
    /// f64 reference level of the mapped path (angles of the exact normal).
    pub mapped_ref: Vec<f64>,
    /// The mapped path in f64 with angles interpolated as the pipeline does.
    pub mapped_interp_ref: Vec<f64>,
    /// The conventional baseline in f64 (interpolated TBN, exact
    /// normalization).
    pub tbn_ref: Vec<f64>,
    /// With an image map in the UV frame: the original map rendered in f64
    /// with the exact UV-aligned frame at each pixel (empty otherwise).
    pub uv_ref: Vec<f64>,
    /// With such a map: pixels left out of the comparison with
    /// [`Frame::uv_ref`] (their texel could not be converted cleanly, or
    /// they lie in the polar cap).
    pub uv_excluded: Vec<bool>,
    /// With such a map: what the conversion did, texel by texel.
    pub bake: Option<crate::texture::BakeCounts>,
}

/// The polar cap: pixels whose normal is within this many degrees of the y
/// axis. There the azimuth β, and with it the implied tangent frame, is
/// singular; the mapped path's targets are judged outside it and the cap is
/// reported on its own.
pub const POLAR_CAP_DEG: f64 = 2.0;

impl Frame {
    /// The input rows of a method.
    pub fn rows(&self, method: RenderMethod) -> &Rows {
        match method {
            RenderMethod::Smooth(_) => &self.smooth_rows,
            RenderMethod::Mapped(AngleSource::Cordic) => &self.mapped_rows,
            RenderMethod::Mapped(AngleSource::Interpolate) => &self.mapped_interp_rows,
            RenderMethod::Tbn => &self.tbn_rows,
        }
    }
    /// The f64 reference a method is judged against.
    pub fn reference(&self, method: RenderMethod) -> &[f64] {
        if method.is_mapped() {
            &self.mapped_ref
        } else {
            &self.smooth_ref
        }
    }
}

/// What a frame computes: the input rows of the methods asked for, and the
/// references those methods (and the reports that go with them) read.
/// Rows are most of a frame's memory (tens of 128-bit codes per pixel and
/// method), so a method nobody renders costs nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wanted {
    /// Smooth-path rows ([`Frame::smooth_rows`]).
    pub smooth: bool,
    /// Mapped-path rows with CORDIC angles.
    pub mapped: bool,
    /// Mapped-path rows with interpolated angles.
    pub mapped_interp: bool,
    /// Rows of the conventional baseline.
    pub tbn: bool,
    /// The mapped path's references (`mapped_ref`, `mapped_interp_ref`,
    /// `tbn_ref`): read by every mapped method and the baseline.
    pub mapped_refs: bool,
}

impl Wanted {
    /// Everything (every method's rows and every reference).
    pub const ALL: Wanted = Wanted {
        smooth: true,
        mapped: true,
        mapped_interp: true,
        tbn: true,
        mapped_refs: true,
    };

    /// What `methods` need.
    pub fn methods(methods: &[RenderMethod]) -> Wanted {
        let has = |f: &dyn Fn(RenderMethod) -> bool| methods.iter().any(|&m| f(m));
        Wanted {
            smooth: has(&|m| matches!(m, RenderMethod::Smooth(_))),
            mapped: has(&|m| m == RenderMethod::Mapped(AngleSource::Cordic)),
            mapped_interp: has(&|m| m == RenderMethod::Mapped(AngleSource::Interpolate)),
            tbn: has(&|m| m == RenderMethod::Tbn),
            mapped_refs: has(&|m| m.is_mapped() || m == RenderMethod::Tbn),
        }
    }
}

/// [`frame_in`] the default [`Scene`].
pub fn frame(p: &Pipeline, raster: Raster, mesh: &Mesh) -> Frame {
    frame_in(&Scene::default(), p, raster, mesh)
}

/// [`frame_wanted`] with everything.
pub fn frame_in(scene: &Scene, p: &Pipeline, raster: Raster, mesh: &Mesh) -> Frame {
    frame_wanted(scene, p, raster, mesh, Wanted::ALL)
}

/// Set up every triangle, and build the rows and references of a raster
/// (rasterized in the same `scene`). Fragments of triangles that cannot be
/// set up (zero or antiparallel vertex normals) get skipped rows
/// ([`Rows::push_skipped`]) and NaN references: [`Metrics::compare`]
/// counts them as skipped, never as exact. Only the rows and references
/// `want` names are built (the others stay empty); those that are built
/// are the same whatever else is wanted.
pub fn frame_wanted(
    scene: &Scene,
    p: &Pipeline,
    raster: Raster,
    mesh: &Mesh,
    want: Wanted,
) -> Frame {
    let n = raster.fragments.len();
    let [ws, wm, wi, wt] = row_widths(p);
    let rows =
        |b: bool, width: usize| Store::Rows(Rows::with_capacity(width, if b { n } else { 0 }));
    let mut stores = Stores {
        smooth: rows(want.smooth, ws),
        mapped: rows(want.mapped, wm),
        mapped_interp: rows(want.mapped_interp, wi),
        tbn: rows(want.tbn, wt),
    };
    let mut f = match frame_core(scene, p, raster, mesh, want, &mut stores, None) {
        Ok(f) => f,
        Err(_) => unreachable!("no sink, so no error"),
    };
    let take = |s: Store| match s {
        Store::Rows(r) => r,
        Store::Columns(_) => unreachable!("built as rows"),
    };
    f.smooth_rows = take(stores.smooth);
    f.mapped_rows = take(stores.mapped);
    f.mapped_interp_rows = take(stores.mapped_interp);
    f.tbn_rows = take(stores.tbn);
    f
}

/// Row widths, one code per input field of the path: smooth, mapped with
/// CORDIC angles, mapped with interpolated angles (a render builds the rows
/// of both sources), the conventional baseline.
fn row_widths(p: &Pipeline) -> [usize; 4] {
    [
        p.fields(Path::Smooth).len(),
        p.fields_of(Path::Mapped, AngleSource::Cordic).len(),
        p.fields_of(Path::Mapped, AngleSource::Interpolate).len(),
        TBN_ROW,
    ]
}

mod lanes;

/// Where a frame's rows of one path go: kept whole ([`Rows`]), or written
/// chunk by chunk into a program's columns ([`Columns`]).
enum Store {
    Rows(Rows),
    Columns(Columns),
}

impl Store {
    fn push_with(&mut self, fill: impl FnOnce(&mut Vec<i128>)) {
        match self {
            Store::Rows(r) => r.push_with(fill),
            Store::Columns(c) => c.push_with(fill),
        }
    }

    /// A row given whole by `fill` and, in `pixel`, by its per-pixel
    /// codes ([`Pipeline::pixel_fields`], in field order): columns within
    /// a run take those alone.
    fn push_pixel(&mut self, pixel: &[i128], fill: impl FnOnce(&mut Vec<i128>)) {
        match self {
            Store::Columns(c) => c.push_fragment(pixel, fill),
            Store::Rows(r) => r.push_with(fill),
        }
    }

    /// Rows of one triangle's fragments, given by their per-pixel codes
    /// `pixels[k][t]` (field `k` of row `t`, as [`Store::push_pixel`]) and
    /// whole by `fill(t, row)`: columns take the first row as
    /// [`Store::push_pixel`] does and the others by their per-pixel codes
    /// alone; rows are filled one by one.
    fn push_pixels<T: Copy + Into<i128>>(
        &mut self,
        pixels: &[&[T]],
        fill: impl Fn(usize, &mut Vec<i128>),
    ) where
        i64: TryFrom<T>,
    {
        let m = pixels.first().map_or(0, |p| p.len());
        if m == 0 {
            return;
        }
        match self {
            Store::Columns(c) => {
                let first: Vec<i128> = pixels.iter().map(|p| p[0].into()).collect();
                c.push_fragment(&first, |r| fill(0, r));
                let rest: Vec<&[T]> = pixels.iter().map(|p| &p[1..]).collect();
                c.push_pixels(&rest);
            }
            Store::Rows(r) => {
                for t in 0..m {
                    r.push_with(|row| fill(t, row));
                }
            }
        }
    }

    fn push(&mut self, row: &[i128]) {
        self.push_with(|r| r.extend_from_slice(row));
    }

    fn push_skipped(&mut self) {
        match self {
            Store::Rows(r) => r.push_skipped(),
            Store::Columns(c) => c.push_skipped(),
        }
    }

    /// The rows since the last call were of one triangle.
    fn end_run(&mut self) {
        if let Store::Columns(c) = self {
            c.end_run();
        }
    }

    fn clear(&mut self) {
        match self {
            Store::Rows(r) => r.clear(),
            Store::Columns(c) => c.clear(),
        }
    }

    /// The levels of `method` (pipeline `p`, its program `prog` unless it
    /// is the baseline) on these rows; skipped rows are 0.
    fn levels(
        &self,
        p: &Pipeline,
        method: RenderMethod,
        prog: Option<&Compiled>,
    ) -> Result<Vec<u8>, PipelineError> {
        match (self, prog) {
            (Store::Rows(r), Some(prog)) => Ok(levels_with(p, method.path(), prog, r)),
            (Store::Rows(r), None) => method_levels(p, method, r),
            (Store::Columns(c), Some(prog)) => Ok(levels_of_columns(p, prog, c)),
            (Store::Columns(_), None) => unreachable!("the baseline's rows are kept as rows"),
        }
    }
}

/// The stores of a frame's four row kinds.
struct Stores {
    smooth: Store,
    mapped: Store,
    mapped_interp: Store,
    tbn: Store,
}

impl Stores {
    fn of(&self, method: RenderMethod) -> &Store {
        match method {
            RenderMethod::Smooth(_) => &self.smooth,
            RenderMethod::Mapped(AngleSource::Cordic) => &self.mapped,
            RenderMethod::Mapped(AngleSource::Interpolate) => &self.mapped_interp,
            RenderMethod::Tbn => &self.tbn,
        }
    }

    fn each(&mut self) -> [&mut Store; 4] {
        [
            &mut self.smooth,
            &mut self.mapped,
            &mut self.mapped_interp,
            &mut self.tbn,
        ]
    }
}

/// The levels of a program run on columns (skipped rows are 0).
fn levels_of_columns(p: &Pipeline, prog: &Compiled, c: &Columns) -> Vec<u8> {
    let cols: Vec<&[i64]> = (0..c.width()).map(|k| c.column(k)).collect();
    let fl = p.light.level.format();
    let mut levels = vec![0u8; c.len()];
    let mut put = |codes: &mut dyn Iterator<Item = i128>| {
        for (i, code) in (0..c.len()).filter(|&i| c.is_live(i)).zip(codes) {
            levels[i] = pixel_of(fl, code);
        }
    };
    match prog {
        Compiled::Narrow(pr) => {
            let (res, _) = pr.run(&cols);
            put(&mut res[0].iter().map(|&v| i128::from(v)));
        }
        Compiled::Wide(pr) => {
            let wide: Vec<Vec<i128>> = cols
                .iter()
                .map(|col| col.iter().map(|&v| i128::from(v)).collect())
                .collect();
            let refs: Vec<&[i128]> = wide.iter().map(Vec::as_slice).collect();
            let (res, _) = pr.run(&refs);
            put(&mut res[0].iter().copied());
        }
    }
    levels
}

/// Codes in a row of the conventional baseline: `c1, c2`, per vertex
/// `T, B, N`, then `L`, `H` and the texel (the inputs of
/// [`Pipeline::trace_tbn`]; a unit test holds them equal).
const TBN_ROW: usize = 2 + 3 * 3 * 3 + 3 * 3;

/// Fragments per chunk of [`levels_streamed`].
pub const CHUNK: usize = 1024;

/// A sink for a frame's rows: called every `CHUNK` fragments
/// (and once for the rest) with the stores holding the rows of the
/// fragments since the previous call only, and those fragments' indices;
/// the stores are emptied after it.
type Sink<'a> = &'a mut SinkFn<'a>;

/// What a [`Sink`] is: the stores, and the fragments (indices into the
/// raster) whose rows they hold, in row order.
type SinkFn<'a> = dyn FnMut(&Stores, &[usize]) -> Result<(), PipelineError> + 'a;

/// [`frame_wanted`] with the rows written to `stores`, and with a `sink`
/// handed to it every [`CHUNK`] fragments. The returned frame holds no
/// rows.
fn frame_core(
    scene: &Scene,
    p: &Pipeline,
    raster: Raster,
    mesh: &Mesh,
    want: Wanted,
    stores: &mut Stores,
    mut sink: Option<Sink<'_>>,
) -> Result<Frame, PipelineError> {
    // The smooth path shades in the camera frame. The mapped path works in
    // the mesh's own frame, where the implied tangent frame (fixed by the
    // y axis) is the one a normal map is baked for: L and H are brought
    // there once per frame.
    let l = scene.light_camera();
    let h = (l + DVec3::Z).normalize();
    let lo = scene.unpose(l).normalize();
    let ho = scene.unpose(h).normalize();
    let lq = |v: DVec3| {
        v.to_array()
            .map(|x| p.light.light.apply_f64(x).map_or(0, |r| r.code))
    };
    let (lc, hc) = (lq(l), lq(h));
    let (loc, hoc) = (lq(lo), lq(ho));
    let (al, bl) = p.angle_codes(lo);
    let (ah, bh) = p.angle_codes(ho);
    let (al_f, bl_f) = crate::polar::angles_of(lo);
    let (ah_f, bh_f) = crate::polar::angles_of(ho);
    type Tri = (
        crate::pipeline::SmoothTri,
        crate::pipeline::SmoothTri,
        Option<crate::pipeline::MappedTri>,
    );
    // Fragments come in raster order, in runs of one triangle.
    let mut runs: Vec<(usize, std::ops::Range<usize>)> = Vec::new();
    for (i, fr) in raster.fragments.iter().enumerate() {
        match runs.last_mut() {
            Some((t, r)) if *t == fr.tri => r.end = i + 1,
            _ => runs.push((fr.tri, i..i + 1)),
        }
    }
    // Only the triangles some pixel shows are set up (a fine mesh in a
    // small image has millions of triangles and a few thousand pixels):
    // one entry per run, then sorted.
    let mut shown: Vec<usize> = runs.iter().map(|(t, _)| *t).collect();
    shown.sort_unstable();
    shown.dedup();
    let tris: std::collections::HashMap<usize, Option<Tri>> = shown
        .into_iter()
        .map(|ti| {
            let t = mesh.triangles[ti];
            let n = t.map(|i| raster.normals[i as usize]);
            let no = t.map(|i| mesh.normals[i as usize]);
            let setup = (|| {
                let s = p.setup_smooth(n).ok()?;
                let so = p.setup_smooth(no).ok()?;
                // The mapped set-up only for the mapped rows.
                let mapped = (want.mapped || want.mapped_interp).then(|| p.setup_mapped(no));
                Some((s, so, mapped))
            })();
            (ti, setup)
        })
        .collect();
    let scheme = p.interp.scheme;
    // An image map in the UV frame: converted for the mapped path, the
    // original kept for the UV-frame reference.
    let image = match &scene.normal_map {
        NormalMap::Image(m) => Some(m.clone()),
        _ => None,
    };
    let baked = image
        .as_ref()
        .filter(|m| m.frame == MapFrame::Uv)
        .and_then(|m| crate::texture::bake_implied(mesh, &m.texture, scheme).ok());
    let tangents = if baked.is_some() {
        crate::mesh::uv_tangents(mesh)
    } else {
        Vec::new()
    };
    let qn = |x: f64| p.light.normal.apply_f64(x).map_or(0, |r| r.code);
    let qv = |x: f64| p.interp.vertex.apply_f64(x).map_or(0, |r| r.code);
    let wrap = |d: f64| d - d.round();
    let n = raster.fragments.len();
    let cap_if = |b: bool| if b { n } else { 0 };
    let [ws, wm, wi, wt] = row_widths(p);
    let mut f = Frame {
        skipped: 0,
        skipped_triangles: Vec::new(),
        smooth_rows: Rows::new(ws),
        mapped_rows: Rows::new(wm),
        mapped_interp_rows: Rows::new(wi),
        tbn_rows: Rows::new(wt),
        // Per fragment, at its index; a skipped fragment keeps these.
        polar_cap: vec![false; n],
        tbn_ref: vec![f64::NAN; cap_if(want.mapped_refs)],
        smooth_ref: vec![f64::NAN; n],
        mapped_ref: vec![f64::NAN; cap_if(want.mapped_refs)],
        mapped_interp_ref: vec![f64::NAN; cap_if(want.mapped_refs)],
        uv_ref: vec![f64::NAN; cap_if(baked.is_some())],
        uv_excluded: vec![true; cap_if(baked.is_some())],
        bake: baked.as_ref().map(|b| b.counts),
        raster: Raster {
            width: raster.width,
            height: raster.height,
            fragments: Vec::new(),
            normals: raster.normals.clone(),
        },
    };
    let cap = (POLAR_CAP_DEG.to_radians()).cos();
    // Triangles that cannot be set up, in raster order.
    for (t, _) in &runs {
        if matches!(tris.get(t), Some(None)) && !f.skipped_triangles.contains(t) {
            f.skipped_triangles.push(*t);
        }
    }
    // The rows kept in a frame are in raster order; with a sink, fragments
    // are taken triangle by triangle (the runs stably sorted by triangle),
    // so that the per-triangle work is done once per triangle rather than
    // once per run, and each result is stored at its fragment's index.
    // (Copying the fragments into that order instead cost more than it
    // saved: a fresh buffer of the raster's size per frame, its pages
    // faulted in.)
    if sink.is_some() {
        runs.sort_by_key(|(t, _)| *t);
    }
    // The fragments in that order, and the groups of consecutive ones of
    // one triangle in it: (triangle, end position).
    let mut order: Vec<usize> = Vec::with_capacity(n);
    let mut groups: Vec<(usize, usize)> = Vec::new();
    for (t, r) in runs {
        order.extend(r);
        match groups.last_mut() {
            Some((g, end)) if *g == t => *end = order.len(),
            _ => groups.push((t, order.len())),
        }
    }
    let mut in_chunk = 0usize;
    let flush = |stores: &mut Stores, chunk: &[usize], sink: &mut SinkFn<'_>| {
        for s in stores.each() {
            s.end_run();
        }
        sink(stores, chunk)?;
        for s in stores.each() {
            s.clear();
        }
        Ok::<(), PipelineError>(())
    };
    // A group's triangle set-up is looked up once, at its first fragment.
    let (mut next_group, mut group_end) = (0, 0);
    let mut setup: Option<&Tri> = None;
    let textured = want.mapped || want.mapped_interp || want.tbn || want.mapped_refs;
    // The f64 work of a batch (up to LANES fragments of one triangle) at
    // once, in `lanes`.
    let shade = lanes::Shade::new(&p.light, l, h);
    let mut lanes = lanes::Lanes::new();
    let mut bary = [[0i128; lanes::LANES]; 2];
    // The barycentrics are quantized in the lane kernel when their format
    // fits its i64 codes.
    let narrow_bary = (p.interp.bary.format().width() <= 62).then_some(&p.interp.bary);
    let mut pos = 0;
    while pos < n {
        if let Some(sink) = sink.as_deref_mut() {
            if in_chunk == CHUNK {
                flush(stores, &order[pos - in_chunk..pos], sink)?;
                in_chunk = 0;
            }
        }
        if pos == group_end {
            for s in stores.each() {
                s.end_run();
            }
            let (t, end) = groups[next_group];
            (next_group, group_end) = (next_group + 1, end);
            setup = tris.get(&t).and_then(|t| t.as_ref());
        }
        let Some((st, so, mt)) = setup else {
            f.skipped += 1;
            if want.smooth {
                stores.smooth.push_skipped();
            }
            if want.mapped {
                stores.mapped.push_skipped();
            }
            if want.mapped_interp {
                stores.mapped_interp.push_skipped();
            }
            if want.tbn {
                stores.tbn.push_skipped();
            }
            in_chunk += 1;
            pos += 1;
            continue;
        };
        // A batch of fragments of one triangle: up to LANES, ending with
        // its group, and before the chunk is flushed.
        let room = if sink.is_some() {
            CHUNK - in_chunk
        } else {
            usize::MAX
        };
        let len = (group_end - pos).min(lanes::LANES).min(room);
        let batch = &order[pos..pos + len];
        for (j, &g) in batch.iter().enumerate() {
            for (k, c) in raster.fragments[g].c.iter().enumerate() {
                lanes.c[k][j] = *c;
            }
        }
        lanes.len = len;
        lanes.run(scheme, &st.tri, &so.tri, shade, narrow_bary);
        for ((q, c), codes) in bary.iter_mut().zip(&lanes.c).zip(&lanes.codes) {
            if narrow_bary.is_some() {
                for (q, &code) in q[..len].iter_mut().zip(codes) {
                    *q = i128::from(code);
                }
            } else {
                p.interp.bary.codes_f64(&c[..len], 0, q);
            }
        }
        in_chunk += len;
        pos += len;
        // The batch's smooth rows: sel, c1, c2, the six normals, L, H.
        if want.smooth {
            let fill = |t: usize, r: &mut Vec<i128>| {
                r.extend_from_slice(&[st.set as i128, bary[0][t], bary[1][t]]);
                for v in &st.v {
                    r.extend_from_slice(v);
                }
                r.extend_from_slice(&lc);
                r.extend_from_slice(&hc);
            };
            // The lane kernel's i64 codes as they are, when it made them.
            if narrow_bary.is_some() {
                let pixels = [&lanes.codes[0][..len], &lanes.codes[1][..len]];
                stores.smooth.push_pixels(&pixels, fill);
            } else {
                let pixels = [&bary[0][..len], &bary[1][..len]];
                stores.smooth.push_pixels(&pixels, fill);
            }
        }
        // The normal interpolated exactly and shaded (lanes::Lanes is
        // interp::field, normalize and shade_f64 over the lanes), and
        // whether the mesh-frame normal is in the polar cap.
        for (j, &i) in batch.iter().enumerate() {
            f.smooth_ref[i] = lanes.smooth_ref[j];
            f.polar_cap[i] = lanes.n_obj[1][j].abs() >= cap;
        }
        // The smooth path alone reads no texture.
        if !(textured || baked.is_some()) {
            continue;
        }
        for (j, &i) in batch.iter().enumerate() {
            let fr = &raster.fragments[i];
            // The quantized barycentrics, from the batch.
            let (c1, c2) = (bary[0][j], bary[1][j]);
            // Mapped rows (object frame): c1, c2, the normals (CORDIC) or
            // the angle set-up (interpolated angles), angles of L and H,
            // the texel.
            let n_obj = DVec3::new(lanes.n_obj[0][j], lanes.n_obj[1][j], lanes.n_obj[2][j]);
            let in_cap = f.polar_cap[i];
            let (tex, texel_ok) = match &baked {
                Some(b) => {
                    let (x, y) = b.texture.texel_of(fr.uv);
                    (
                        b.texture.at(fr.uv),
                        b.flags[y * b.texture.width + x] == crate::texture::TexelFlag::Converted,
                    )
                }
                None => (scene.normal_map.at(fr.uv), true),
            };
            let texc = tex.to_array().map(qn);
            let lh = [al, bl, ah, bh];
            for (wanted, src, rows) in [
                (want.mapped, AngleSource::Cordic, &mut stores.mapped),
                (
                    want.mapped_interp,
                    AngleSource::Interpolate,
                    &mut stores.mapped_interp,
                ),
            ] {
                if wanted {
                    let pixel = [c1, c2, texc[0], texc[1], texc[2]];
                    rows.push_pixel(&pixel, |r| {
                        let mt = mt.as_ref().expect("set up for the mapped rows");
                        Pipeline::mapped_row_into(src, [c1, c2], so, mt, lh, texc, r);
                    });
                }
            }
            if !(want.tbn || want.mapped_refs || baked.is_some()) {
                continue;
            }
            // The conventional baseline: a frame per vertex (the implied one, or
            // for a UV-frame map the UV one with the original texel).
            let orig = image.as_ref().map(|m| m.texture.at(fr.uv));
            let (frames, tbn_tex) = match (&baked, orig) {
                (Some(_), Some(o)) => {
                    let fr3: Option<Vec<_>> = (0..3)
                        .map(|k| {
                            let mut c = [0.0; 3];
                            c[k] = 1.0;
                            crate::texture::uv_frame(mesh, &tangents, fr.tri, c, scheme)
                        })
                        .collect();
                    match fr3 {
                        Some(v) => ([v[0], v[1], v[2]], o),
                        // No UV frame on this triangle (degenerate UVs): the
                        // baseline has nothing to transform with.
                        None => {
                            let z = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
                            ([z, z, z], o)
                        }
                    }
                }
                _ => (
                    so.tri.n.map(|nv| {
                        let (_, b) = crate::polar::angles_of(nv);
                        crate::polar::frame(nv, b)
                    }),
                    tex,
                ),
            };
            let mut r = vec![c1, c2];
            for (t, b, n) in &frames {
                for v in [t, b, n] {
                    r.extend(v.to_array().map(qv));
                }
            }
            r.extend_from_slice(&loc);
            r.extend_from_slice(&hoc);
            r.extend_from_slice(&tbn_tex.to_array().map(qn));
            let degenerate = frames[0].2 == DVec3::ZERO;
            if want.tbn {
                if degenerate {
                    stores.tbn.push_skipped();
                } else {
                    stores.tbn.push(&r);
                }
            }
            if want.mapped_refs {
                if !degenerate {
                    f.tbn_ref[i] = tbn_f64(&p.light, frames, fr.c, lo, ho, tbn_tex);
                }
                let (an, bn) = crate::polar::angles_of(n_obj);
                let lp = crate::polar::reference(al_f, bl_f, an, bn);
                let hp = crate::polar::reference(ah_f, bh_f, an, bn);
                f.mapped_ref[i] = shade_f64(&p.light, tex, lp, hp);
            }
            // The original map in its UV frame, exactly.
            if let (Some(_), Some(o)) = (&baked, orig) {
                let uvf = crate::texture::uv_frame(mesh, &tangents, fr.tri, fr.c, scheme);
                // Without a UV frame the fragment keeps NaN, excluded.
                if let Some((t, b, nn)) = uvf {
                    let ts = |v: DVec3| DVec3::new(v.dot(t), v.dot(b), v.dot(nn));
                    f.uv_ref[i] = shade_f64(&p.light, o, ts(lo), ts(ho));
                    f.uv_excluded[i] = in_cap || !texel_ok;
                }
            }
            if !want.mapped_refs {
                continue;
            }
            // The same with the angles interpolated (f64).
            let va = so.tri.n.map(crate::polar::angles_of);
            let ai = va[2].0 + fr.c[0] * (va[0].0 - va[2].0) + fr.c[1] * (va[1].0 - va[2].0);
            let bi =
                va[2].1 + fr.c[0] * wrap(va[0].1 - va[2].1) + fr.c[1] * wrap(va[1].1 - va[2].1);
            let lp = crate::polar::reference(al_f, bl_f, ai, bi);
            let hp = crate::polar::reference(ah_f, bh_f, ai, bi);
            f.mapped_interp_ref[i] = shade_f64(&p.light, tex, lp, hp);
        }
    }
    match sink {
        Some(sink) => flush(stores, &order[order.len() - in_chunk..], sink)?,
        None => {
            for s in stores.each() {
                s.end_run();
            }
        }
    }
    f.raster.fragments = raster.fragments;
    Ok(f)
}

/// Render `methods` without keeping their input rows: the frame is built
/// [`CHUNK`] fragments at a time, each chunk's rows run through every
/// method's pipeline and dropped, so memory grows with the image (a level
/// per fragment and method, the references) and not with the rows. The
/// levels are those of [`run_method`] on a whole frame (the pipeline is
/// per row); the frame returned holds no rows. A path whose methods all
/// run narrow programs writes its rows straight into the programs' input
/// columns ([`Columns`]): within a run of fragments of one triangle only
/// the per-pixel fields ([`Pipeline::pixel_fields`]) are written per
/// fragment, the per-frame and per-triangle ones filled once per run.
///
/// # Errors
///
/// The [`PipelineError`] of building a method's pipeline ([`Pipeline::with_method`]) or of
/// compiling it for a chunk's rows ([`Pipeline::compile`], or [`Pipeline::trace_tbn`] for the
/// baseline).
pub fn levels_streamed(
    cfg: &Config,
    scene: &Scene,
    base: &Pipeline,
    raster: Raster,
    mesh: &Mesh,
    methods: &[RenderMethod],
) -> Result<(Frame, Vec<Vec<u8>>), PipelineError> {
    let pipes: Vec<Pipeline> = methods
        .iter()
        .map(|&m| method_pipeline(cfg, m))
        .collect::<Result<_, _>>()?;
    // Each method's program is compiled once for every chunk.
    let progs: Vec<Option<Compiled>> = methods
        .iter()
        .zip(&pipes)
        .map(|(&m, p)| {
            (m != RenderMethod::Tbn)
                .then(|| p.compile(m.path()))
                .transpose()
        })
        .collect::<Result<_, _>>()?;
    let n = raster.fragments.len();
    let mut levels: Vec<Vec<u8>> = methods.iter().map(|_| vec![0; n]).collect();
    let want = Wanted::methods(methods);
    // A path's rows go straight into columns when every method reading
    // them runs a narrow program (whose input codes fit i64 lanes).
    let [ws, wm, wi, wt] = row_widths(base);
    let store = |kind: &dyn Fn(RenderMethod) -> bool, width: usize| {
        let users: Vec<usize> = (0..methods.len()).filter(|&i| kind(methods[i])).collect();
        let narrow = users
            .iter()
            .all(|&i| matches!(progs[i], Some(Compiled::Narrow(_))));
        // (One flag per field, as a unit test holds; rows otherwise.)
        let pixel = match users.first() {
            Some(&i) if narrow => Some(pipes[i].pixel_fields(methods[i].path())?),
            _ => None,
        };
        Ok::<_, PipelineError>(match pixel {
            Some(pixel) if pixel.len() == width => Store::Columns(Columns::new(pixel, CHUNK)),
            _ => Store::Rows(Rows::with_capacity(width, CHUNK)),
        })
    };
    let mut stores = Stores {
        smooth: store(&|m| matches!(m, RenderMethod::Smooth(_)), ws)?,
        mapped: store(&|m| m == RenderMethod::Mapped(AngleSource::Cordic), wm)?,
        mapped_interp: store(&|m| m == RenderMethod::Mapped(AngleSource::Interpolate), wi)?,
        tbn: Store::Rows(Rows::with_capacity(wt, CHUNK)),
    };
    // A chunk's rows are those of the fragments `idx` (not in raster order).
    let mut sink = |s: &Stores, idx: &[usize]| {
        for (((&m, p), prog), out) in methods
            .iter()
            .zip(&pipes)
            .zip(&progs)
            .zip(levels.iter_mut())
        {
            let chunk = s.of(m).levels(p, m, prog.as_ref())?;
            for (&i, level) in idx.iter().zip(chunk) {
                out[i] = level;
            }
        }
        Ok(())
    };
    let f = frame_core(
        scene,
        base,
        raster,
        mesh,
        want,
        &mut stores,
        Some(&mut sink),
    )?;
    Ok((f, levels))
}

/// The pipeline a method runs.
fn method_pipeline(cfg: &Config, method: RenderMethod) -> Result<Pipeline, PipelineError> {
    let mut p = match method {
        RenderMethod::Smooth(m) => Pipeline::with_method(cfg, m)?,
        _ => Pipeline::with_method(cfg, Method::None)?,
    };
    if let RenderMethod::Mapped(src) = method {
        p.angles = src;
    }
    Ok(p)
}

/// The levels of `rows` (skipped rows are 0).
fn method_levels(
    p: &Pipeline,
    method: RenderMethod,
    rows: &Rows,
) -> Result<Vec<u8>, PipelineError> {
    if method != RenderMethod::Tbn {
        return levels_of(p, method.path(), rows);
    }
    let idx: Vec<usize> = (0..rows.len()).filter(|&i| rows.is_live(i)).collect();
    let out = p.run_tbn_rows(&rows.live_vecs())?;
    let fl = p.light.level.format();
    let mut levels = vec![0u8; rows.len()];
    for (k, &i) in idx.iter().enumerate() {
        levels[i] = pixel_of(fl, out[k]);
    }
    Ok(levels)
}

/// The conventional baseline in f64: `M = Σ c_k·[T_k; B_k; N_k]`,
/// `L' = M·L / |M·L|`, `H'` likewise, then [`shade_f64`].
pub fn tbn_f64(
    light: &crate::lighting::Lighting,
    frames: [(DVec3, DVec3, DVec3); 3],
    c: [f64; 3],
    l: DVec3,
    h: DVec3,
    tex: DVec3,
) -> f64 {
    let mut m = [DVec3::ZERO; 3];
    for (k, (t, b, n)) in frames.iter().enumerate() {
        m[0] += *t * c[k];
        m[1] += *b * c[k];
        m[2] += *n * c[k];
    }
    let xf = |v: DVec3| DVec3::new(m[0].dot(v), m[1].dot(v), m[2].dot(v)).normalize_or_zero();
    shade_f64(light, tex, xf(l), xf(h))
}

/// One method's image.
#[derive(Clone, Debug)]
pub struct MethodImage {
    /// The method.
    pub method: RenderMethod,
    /// Level per fragment (0 for skipped fragments).
    pub levels: Vec<u8>,
    /// Against the reference of its path.
    pub metrics: Metrics,
    /// Mapped methods: the same outside the polar cap (the targets).
    pub outside_cap: Option<Metrics>,
    /// Mapped methods: inside the polar cap alone.
    pub cap: Option<Metrics>,
}

/// Run the bit-accurate pipeline of `method` over a frame.
///
/// # Errors
///
/// The [`PipelineError`] of building the method's pipeline ([`Pipeline::with_method`]) or of
/// compiling it ([`Pipeline::compile`], or [`Pipeline::trace_tbn`] for the baseline).
///
/// # Panics
///
/// If `f` holds no row per fragment for `method` (a frame built without them, [`Wanted`], or by
/// [`levels_streamed`]), or no reference per fragment for its path.
pub fn run_method(
    cfg: &Config,
    f: &Frame,
    method: RenderMethod,
) -> Result<MethodImage, PipelineError> {
    let p = method_pipeline(cfg, method)?;
    let rows = f.rows(method);
    assert!(
        rows.len() == f.raster.fragments.len(),
        "the frame was built without the rows of {}",
        method.name()
    );
    let levels = method_levels(&p, method, rows)?;
    Ok(image_of(f, method, levels))
}

/// A method's image from its levels: the metrics against its path's
/// reference (and, for mapped methods, outside and inside the polar cap).
///
/// # Panics
///
/// If `levels` and the reference of `method`'s path in `f` differ in length (a frame built without
/// that reference, [`Wanted`]).
pub fn image_of(f: &Frame, method: RenderMethod, levels: Vec<u8>) -> MethodImage {
    let want = f.reference(method);
    assert!(
        want.len() == levels.len(),
        "the frame was built without the references of {}",
        method.name()
    );
    let metrics = Metrics::compare(&levels, want);
    let (outside_cap, cap) = if method.is_mapped() {
        (
            Some(Metrics::compare_where(&levels, want, |k| !f.polar_cap[k])),
            Some(Metrics::compare_where(&levels, want, |k| f.polar_cap[k])),
        )
    } else {
        (None, None)
    };
    MethodImage {
        method,
        levels,
        metrics,
        outside_cap,
        cap,
    }
}

/// The 8-bit pixel of a code in the `level` format: its value rounded to
/// the nearest level and clipped to `0 ..= 255`. With the default `U8F0`
/// the pixel is the code; a level format with fraction bits, or wider or
/// signed, is shown by value rather than by its raw code. Model and RTL
/// images both go through this.
pub fn pixel_of(level: crate::format::Format, code: i128) -> u8 {
    if level.frac() == 0 {
        // An integer level is its code: rounding leaves it, clipping is
        // the same on the code.
        return narrow::<u8, _>(code.clamp(0, 255));
    }
    from_f64::<u8>(round_half_away(level.to_f64(code)).clamp(0.0, 255.0))
}

/// Levels of a path's rows (skipped rows are 0).
///
/// # Errors
///
/// As [`Pipeline::run_rows`].
///
/// # Panics
///
/// If the rows do not hold one code per field of `path` ([`Pipeline::fields`]).
pub fn levels_of(p: &Pipeline, path: Path, rows: &Rows) -> Result<Vec<u8>, PipelineError> {
    Ok(levels_with(p, path, &p.compile(path)?, rows))
}

/// [`levels_of`] with the path's program compiled already
/// ([`Pipeline::compile`]).
///
/// # Panics
///
/// If the rows do not hold one code per field of `path`.
pub fn levels_with(p: &Pipeline, path: Path, prog: &Compiled, rows: &Rows) -> Vec<u8> {
    // Rows are copied only when some are skipped.
    let out = p.run_flat_compiled(path, prog, &rows.live_codes());
    let fl = p.light.level.format();
    let mut levels = vec![0u8; rows.len()];
    let live = (0..rows.len()).filter(|&i| rows.is_live(i));
    for (i, &code) in live.zip(&out) {
        levels[i] = pixel_of(fl, code);
    }
    levels
}

/// Round an f64 reference to levels.
pub fn reference_levels(r: &[f64]) -> Vec<u8> {
    r.iter()
        .map(|x| from_f64::<u8>(round_half_away(*x).clamp(0.0, 255.0)))
        .collect()
}

/// Place per-fragment values into a full image (`background` elsewhere).
pub fn to_image<T: Copy>(raster: &Raster, v: &[T], background: T) -> Vec<T> {
    let mut img = vec![background; raster.width * raster.height];
    for (fr, &x) in raster.fragments.iter().zip(v) {
        img[fr.pixel] = x;
    }
    img
}

/// Which interpolation scheme a frame's references use.
pub fn scheme_of(cfg: &Config) -> Scheme {
    interp::Interp::from_config(cfg).scheme
}

#[cfg(test)]
mod tests {
    use super::{pixel_of, Metrics, TBN_ROW};
    use crate::format::Format;

    /// Metrics of five pixels worked by hand: errors 0, 2, 1 and 15 levels
    /// and a NaN reference (skipped); the relative error is the last
    /// pixel's `(15 − ½)/20`, the others' references being under the
    /// floor; then the same with the last pixel left out.
    #[test]
    fn metrics_of_five_pixels_are_the_hand_worked_ones() {
        let got = [10u8, 12, 200, 0, 5];
        let want = [10.4, 10.0, f64::NAN, 0.6, 20.0];
        let m = Metrics::compare(&got, &want);
        assert_eq!((m.pixels, m.skipped, m.max_abs_levels), (4, 1, 15));
        assert_eq!(m.mean_abs_levels, 4.5);
        assert_eq!(m.off_by, [0.25; 4]);
        let psnr = 10.0 * (255.0f64 * 255.0 / (230.0 / 4.0)).log10();
        assert_eq!(m.psnr_db, Some(psnr));
        assert_eq!(m.max_rel_intensity_err, 14.5 / 20.0);
        assert!(!m.paper_bound_holds);
        let m = Metrics::compare_where(&got, &want, |k| k != 4);
        assert_eq!((m.pixels, m.skipped, m.max_abs_levels), (3, 1, 2));
        assert_eq!(m.max_rel_intensity_err, 0.0);
        assert!(m.paper_bound_holds);
    }

    /// The metrics' lanes sum and take maxima exactly: on 10 007 pixels
    /// (NaN, far and tied references among them, a mask), the same
    /// figures as one plain pass in pixel order, written out here.
    #[test]
    fn metrics_in_lanes_are_one_pass_in_order() {
        use fxshade_numbers::convert::to_f64;
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let n = 10_007;
        let (mut got, mut want) = (Vec::new(), Vec::new());
        for k in 0..n {
            let r = next();
            got.push(u8::try_from(r % 256).unwrap());
            want.push(match k % 97 {
                0 => f64::NAN,
                1 => 1.0e6,
                2 => to_f64(i32::try_from(r % 255).unwrap()) + 0.5,
                _ => to_f64(i32::try_from(r % 25_600).unwrap()) / 100.0,
            });
        }
        let keep = |k: usize| k % 5 != 3;
        // One pass in pixel order.
        let (mut pixels, mut skipped, mut max_abs, mut sum, mut sq) = (0, 0, 0u32, 0u64, 0u64);
        let (mut hist, mut max_rel) = ([0usize; 4], 0.0f64);
        for k in (0..n).filter(|&k| keep(k)) {
            let (g, w) = (f64::from(got[k]), want[k]);
            if w.is_nan() {
                skipped += 1;
                continue;
            }
            pixels += 1;
            let e = (g - w.round()).abs() as u32;
            max_abs = max_abs.max(e);
            sum += u64::from(e);
            sq += u64::from(e) * u64::from(e);
            hist[(e as usize).min(3)] += 1;
            if w >= super::REL_FLOOR_LEVELS {
                let rel = ((g - w).abs() - 0.5).max(0.0) / w;
                if rel > max_rel {
                    max_rel = rel;
                }
            }
        }
        let m = Metrics::compare_where(&got, &want, keep);
        assert_eq!(
            (m.pixels, m.skipped, m.max_abs_levels),
            (pixels, skipped, max_abs)
        );
        assert_eq!(m.mean_abs_levels, to_f64(sum) / to_f64(pixels));
        assert_eq!(m.off_by, hist.map(|h| to_f64(h) / to_f64(pixels)));
        let psnr = 10.0 * (255.0f64 * 255.0 / (to_f64(sq) / to_f64(pixels))).log10();
        assert_eq!(m.psnr_db, Some(psnr));
        assert_eq!(m.max_rel_intensity_err.to_bits(), max_rel.to_bits());
        assert!(max_abs > 900_000 && max_rel > 0.0 && hist.iter().all(|&h| h > 0));
    }

    /// A baseline row holds one code per input of the baseline's trace.
    #[test]
    fn a_baseline_row_holds_one_code_per_input_of_its_trace() {
        let cfg = crate::config::Config::embedded();
        let p = crate::pipeline::Pipeline::from_config(&cfg).unwrap();
        assert_eq!(p.trace_tbn().unwrap().input_ports().len(), TBN_ROW);
    }

    /// The pixel of a code is its value rounded to the nearest level and
    /// clipped, computed here in f64 from the code's value (`code·2^-frac`)
    /// for integer and fractional, signed and unsigned level formats.
    #[test]
    fn pixel_of_is_the_rounded_clipped_value() {
        for (signed, width, frac) in [
            (false, 8, 0),
            (true, 10, 0),
            (false, 12, 0),
            (false, 12, 4),
            (true, 9, 1),
        ] {
            let f = Format::new(signed, width, frac).unwrap();
            for code in f.min_code()..=f.max_code() {
                let value = fxshade_numbers::convert::to_f64(i32::try_from(code).unwrap())
                    / f64::from(1u32 << frac);
                let want = value.round().clamp(0.0, 255.0);
                assert_eq!(f64::from(pixel_of(f, code)), want, "{code} in {f:?}");
            }
        }
    }
}
