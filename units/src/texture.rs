//! Tangent-space normal maps from image files, and their conversion into the
//! polar transform's implied frame.
//!
//! ## Texels
//! A normal map stores a unit vector per texel as RGB: `c = (n + 1)/2`
//! scaled to the channel's largest code (255 or 65 535). Two conventions
//! exist for green: OpenGL's (`+y` up, along the bitangent) and DirectX's
//! (`+y` down, green inverted). [`NormalTexture::from_channels`] decodes
//! either into OpenGL's; [`NormalTexture::to_channels`] encodes.
//!
//! ## Sampling
//! Nearest texel, wrapping in both directions, with `v` up: texel column
//! `⌊u·W⌋ mod W`, row `H − 1 − (⌊v·H⌋ mod H)` (row 0 is the top of the
//! image, `v` near 1).
//!
//! ## Frames
//! Maps are usually baked in a UV-aligned frame (MikkTSpace-style): `T`
//! along `∂P/∂u`, `B = s·(N × T)` with `s` the handedness of the UV layout.
//! The polar transform uses the implied frame `T = (cos β_N, 0, −sin β_N)`,
//! `B = N × T`. [`bake_implied`] rewrites every texel from the one to the
//! other through a mesh's UV layout, and flags the texels where that is not
//! possible.

use fxshade_numbers::convert::{from_f64, narrow, to_f64};
use glam::{DVec2, DVec3};

use crate::interp::{self, Scheme};
use crate::mesh::Mesh;

/// Green channel convention.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Green {
    /// `+y` up (OpenGL, Blender, glTF).
    OpenGl,
    /// `+y` down (DirectX, Unreal): green inverted.
    DirectX,
}

impl Green {
    /// Parse `opengl` or `directx`.
    pub fn from_name(s: &str) -> Option<Green> {
        match s {
            "opengl" => Some(Green::OpenGl),
            "directx" => Some(Green::DirectX),
            _ => None,
        }
    }
}

/// Why a normal map is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TextureError {
    /// Sizes disagree with the data.
    #[error("{0}")]
    Shape(String),
    /// The mesh cannot lay a map out.
    #[error("{0}")]
    Layout(String),
}

/// Texture coordinates beyond `±UV_LIMIT` are refused: a map repeats a
/// few times over a mesh, not thousands (and the texels a triangle covers
/// are enumerated).
pub const UV_LIMIT: f64 = 16.0;

/// A decoded normal map: `width × height` texels, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalTexture {
    /// Texels across.
    pub width: usize,
    /// Texels down.
    pub height: usize,
    /// The texels as decoded (OpenGL green), row by row; not renormalized.
    pub texels: Vec<DVec3>,
}

impl NormalTexture {
    /// Decode `channels`-channel samples (RGB or RGBA; alpha ignored) of
    /// largest code `max` (255 or 65 535), row by row: `n = 2·c/max − 1`,
    /// green negated for [`Green::DirectX`].
    ///
    /// # Errors
    ///
    /// [`TextureError::Shape`] when `channels` is not 3 or 4, `width` or `height` is 0, or `data`
    /// does not hold `width·height·channels` samples.
    pub fn from_channels(
        width: usize,
        height: usize,
        channels: usize,
        max: u32,
        data: &[u16],
        green: Green,
    ) -> Result<NormalTexture, TextureError> {
        if !(3..=4).contains(&channels) {
            return Err(TextureError::Shape(format!(
                "{channels} channels: a normal map needs RGB or RGBA"
            )));
        }
        if width == 0 || height == 0 || data.len() != width * height * channels {
            return Err(TextureError::Shape(format!(
                "{width}×{height}×{channels} samples expected, {} given",
                data.len()
            )));
        }
        let m = f64::from(max);
        let texels = data
            .chunks_exact(channels)
            .map(|p| {
                let c = |k: usize| 2.0 * f64::from(p[k]) / m - 1.0;
                let y = match green {
                    Green::OpenGl => c(1),
                    Green::DirectX => -c(1),
                };
                DVec3::new(c(0), y, c(2))
            })
            .collect();
        Ok(NormalTexture {
            width,
            height,
            texels,
        })
    }

    /// Encode as RGB samples of `bits` (8 or 16) per channel, rounding to
    /// nearest: `c = round((n + 1)/2 · max)`, clipped.
    pub fn to_channels(&self, bits: u32, green: Green) -> Vec<u16> {
        let m = f64::from((1u32 << bits) - 1);
        let q = |x: f64| from_f64::<u16>(((x + 1.0) / 2.0 * m).round().clamp(0.0, m));
        self.texels
            .iter()
            .flat_map(|n| {
                let y = match green {
                    Green::OpenGl => n.y,
                    Green::DirectX => -n.y,
                };
                [q(n.x), q(y), q(n.z)]
            })
            .collect()
    }

    /// The texel `(column, row)` of texture coordinates `uv` (nearest,
    /// wrapping, `v` up).
    pub fn texel_of(&self, uv: DVec2) -> (usize, usize) {
        let (w, h) = (to_f64(self.width), to_f64(self.height));
        let x = from_f64::<usize>((uv.x * w).floor().rem_euclid(w));
        let r = from_f64::<usize>((uv.y * h).floor().rem_euclid(h));
        (
            x.min(self.width - 1),
            self.height - 1 - r.min(self.height - 1),
        )
    }

    /// The texture coordinates of the centre of texel `(x, y)`.
    pub fn uv_of(&self, x: usize, y: usize) -> DVec2 {
        DVec2::new(
            (to_f64(x) + 0.5) / to_f64(self.width),
            (to_f64(self.height) - to_f64(y) - 0.5) / to_f64(self.height),
        )
    }

    /// The unit normal at `uv` (nearest texel; a zero texel reads `+z`).
    pub fn at(&self, uv: DVec2) -> DVec3 {
        let (x, y) = self.texel_of(uv);
        let n = self.texels[y * self.width + x];
        if n.length() > 1e-12 {
            n.normalize()
        } else {
            DVec3::Z
        }
    }
}

/// A texel whose implied frame turns by more than this many degrees
/// against the UV frame from its neighbour is flagged [`TexelFlag::Pole`].
pub const FRAME_TURN_DEG: f64 = 2.0;

/// What [`bake_implied`] could do with a texel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TexelFlag {
    /// Converted.
    Converted,
    /// No triangle covers its centre in UV space: copied unchanged.
    Unused,
    /// Within a texel of a UV seam (an edge of one triangle only): converted
    /// from the one side, but a sample near it may land across the seam.
    Seam,
    /// Several triangles cover it with frames more than 1° apart: one
    /// texel cannot hold both; converted for the first.
    Ambiguous,
    /// Near a pole of the implied frame: the surface normal is within
    /// [`crate::render::POLAR_CAP_DEG`] of the y axis, or the frame turns by
    /// more than [`FRAME_TURN_DEG`] against the UV frame from this texel to
    /// a neighbour (it spins around the pole faster than the texels
    /// resolve); converted anyway.
    Pole,
}

/// Counts of each [`TexelFlag`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct BakeCounts {
    /// Texels in the map.
    pub texels: usize,
    /// Converted cleanly.
    pub converted: usize,
    /// Not covered by any triangle.
    pub unused: usize,
    /// Next to a UV seam.
    pub seam: usize,
    /// Covered by triangles whose frames disagree.
    pub ambiguous: usize,
    /// Near a pole of the implied frame.
    pub pole: usize,
}

/// A map converted into the implied frame, with a flag per texel.
#[derive(Clone, Debug)]
pub struct Baked {
    /// The converted map.
    pub texture: NormalTexture,
    /// Per texel, row by row.
    pub flags: Vec<TexelFlag>,
    /// The counts.
    pub counts: BakeCounts,
}

/// The UV-aligned (MikkTSpace-style) frame at a point of triangle `t` of
/// `m`: the surface normal `N` of the configured interpolation `scheme`,
/// normalized; `T` the vertex tangents `tangents` (from
/// [`crate::mesh::uv_tangents`]) interpolated linearly and made orthogonal
/// to `N`; `B = s·(N × T)` with `s = sign((N × T)·∂P/∂v)`, the handedness
/// of the UV layout (as MikkTSpace's bitangent sign; it does not depend on
/// the triangle's winding). `None` where the triangle cannot be set up or
/// its UVs are degenerate.
pub fn uv_frame(
    m: &Mesh,
    tangents: &[DVec3],
    t: usize,
    c: [f64; 3],
    scheme: Scheme,
) -> Option<(DVec3, DVec3, DVec3)> {
    let idx = m.triangles[t].map(|i| i as usize);
    let tri = interp::setup(idx.map(|i| m.normals[i])).ok()?;
    let n = interp::field(&tri, c, scheme).normalize_or_zero();
    let tv = idx
        .iter()
        .zip(c)
        .map(|(&i, ci)| tangents[i] * ci)
        .sum::<DVec3>();
    let tan = (tv - n * n.dot(tv)).normalize_or_zero();
    let (d1, d2) = (m.uvs[idx[1]] - m.uvs[idx[0]], m.uvs[idx[2]] - m.uvs[idx[0]]);
    let (e1, e2) = (
        m.positions[idx[1]] - m.positions[idx[0]],
        m.positions[idx[2]] - m.positions[idx[0]],
    );
    let det = d1.x * d2.y - d2.x * d1.y;
    if n == DVec3::ZERO || tan == DVec3::ZERO || det.abs() < 1e-18 {
        return None;
    }
    let dpdv = (e2 * d1.x - e1 * d2.x) / det;
    let b = n.cross(tan);
    Some((tan, if b.dot(dpdv) < 0.0 { -b } else { b }, n))
}

/// Rewrite a map baked in the UV-aligned frame of `m` ([`uv_frame`]) into
/// the implied frame of the surface normal at each texel centre:
/// `n_implied = (w·T_i, w·B_i, w·N_i)` with `w = T·n.x + B·n.y + N·n.z`.
/// Texels no triangle covers are copied unchanged; see [`TexelFlag`] for
/// what is flagged. Refused: a mesh whose texture coordinates were made up
/// ([`Mesh::uvs_generated`]) or reach beyond [`UV_LIMIT`].
///
/// # Errors
///
/// [`TextureError::Layout`] as [`check_layout`].
pub fn bake_implied(m: &Mesh, map: &NormalTexture, scheme: Scheme) -> Result<Baked, TextureError> {
    check_layout(m)?;
    let tangents = crate::mesh::uv_tangents(m);
    let (w, h) = (map.width, map.height);
    let mut out = map.clone();
    let mut flags = vec![TexelFlag::Unused; w * h];
    let mut first: Vec<Option<DVec3>> = vec![None; w * h];
    // The angle from the UV tangent to the implied one about N, per texel.
    let mut psi: Vec<Option<f64>> = vec![None; w * h];
    let cap = crate::render::POLAR_CAP_DEG.to_radians().cos();
    // Edges used by one triangle only: UV seams and open borders.
    let mut edges: std::collections::HashMap<(u32, u32), usize> = Default::default();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    for (ti, t) in m.triangles.iter().enumerate() {
        let uv = t.map(|i| m.uvs[i as usize]);
        // Texel centres in the UV bounding box, barycentrics by area.
        let (lo, hi) = (uv[0].min(uv[1]).min(uv[2]), uv[0].max(uv[1]).max(uv[2]));
        let den = (uv[1] - uv[0]).perp_dot(uv[2] - uv[0]);
        if den.abs() < 1e-18 {
            continue;
        }
        let x0 = from_f64::<i64>((lo.x * to_f64(w) - 0.5).floor());
        let x1 = from_f64::<i64>((hi.x * to_f64(w) - 0.5).ceil());
        let r0 = from_f64::<i64>((lo.y * to_f64(h) - 0.5).floor());
        let r1 = from_f64::<i64>((hi.y * to_f64(h) - 0.5).ceil());
        for r in r0..=r1 {
            for x in x0..=x1 {
                let p = DVec2::new((to_f64(x) + 0.5) / to_f64(w), (to_f64(r) + 0.5) / to_f64(h));
                let c1 = (uv[2] - p).perp_dot(uv[0] - p) / den;
                let c2 = (uv[0] - p).perp_dot(uv[1] - p) / den;
                let c0 = 1.0 - c1 - c2;
                let eps = -1e-9;
                if c0 < eps || c1 < eps || c2 < eps {
                    continue;
                }
                let col = narrow::<usize, _>(x.rem_euclid(narrow::<i64, _>(w)));
                let row = h - 1 - narrow::<usize, _>(r.rem_euclid(narrow::<i64, _>(h)));
                let k = row * w + col;
                let Some((tu, bu, nu)) = uv_frame(m, &tangents, ti, [c0, c1, c2], scheme) else {
                    continue;
                };
                let src = map.texels[k];
                let world = tu * src.x + bu * src.y + nu * src.z;
                let (_, beta) = crate::polar::angles_of(nu);
                let (ti_, bi, ni) = crate::polar::frame(nu, beta);
                let imp = DVec3::new(world.dot(ti_), world.dot(bi), world.dot(ni));
                match first[k] {
                    None => {
                        first[k] = Some(imp);
                        psi[k] = Some(tu.cross(ti_).dot(nu).atan2(tu.dot(ti_)));
                        out.texels[k] = imp;
                        flags[k] = if nu.y.abs() >= cap {
                            TexelFlag::Pole
                        } else {
                            TexelFlag::Converted
                        };
                    }
                    Some(f) => {
                        let ang = f.normalize_or_zero().dot(imp.normalize_or_zero());
                        if ang < (1f64).to_radians().cos() {
                            flags[k] = TexelFlag::Ambiguous;
                        }
                    }
                }
            }
        }
    }
    // Near a pole the implied frame turns quickly: where it turns by more
    // than FRAME_TURN_DEG from one texel to the next (relative to the UV
    // frame), one texel cannot stand for its whole footprint.
    let turn = FRAME_TURN_DEG.to_radians();
    let mut fast = vec![false; w * h];
    for row in 0..h {
        for col in 0..w {
            let k = row * w + col;
            let Some(a) = psi[k] else { continue };
            for (c2, r2) in [((col + 1) % w, row), (col, (row + 1) % h)] {
                let k2 = r2 * w + c2;
                if let Some(b) = psi[k2] {
                    let d = (a - b + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                        - std::f64::consts::PI;
                    if d.abs() > turn {
                        fast[k] = true;
                        fast[k2] = true;
                    }
                }
            }
        }
    }
    for (f, &x) in flags.iter_mut().zip(&fast) {
        if x && *f == TexelFlag::Converted {
            *f = TexelFlag::Pole;
        }
    }
    // Texels within one texel of a seam edge (in UV space).
    let texel = DVec2::new(1.0 / to_f64(w), 1.0 / to_f64(h));
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if edges[&(a.min(b), a.max(b))] != 1 {
                continue;
            }
            let (pa, pb) = (m.uvs[a as usize], m.uvs[b as usize]);
            let steps =
                (from_f64::<usize>(((pb - pa) / texel).abs().max_element().ceil())).max(1) * 2;
            for s in 0..=steps {
                let p = pa + (pb - pa) * (to_f64(s) / to_f64(steps));
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        let q = p + DVec2::new(to_f64(dx), to_f64(dy)) * texel;
                        let (col, row) = map.texel_of(q);
                        let k = row * w + col;
                        if matches!(flags[k], TexelFlag::Converted) {
                            flags[k] = TexelFlag::Seam;
                        }
                    }
                }
            }
        }
    }
    let mut counts = BakeCounts {
        texels: w * h,
        ..Default::default()
    };
    for f in &flags {
        match f {
            TexelFlag::Converted => counts.converted += 1,
            TexelFlag::Unused => counts.unused += 1,
            TexelFlag::Seam => counts.seam += 1,
            TexelFlag::Ambiguous => counts.ambiguous += 1,
            TexelFlag::Pole => counts.pole += 1,
        }
    }
    Ok(Baked {
        texture: out,
        flags,
        counts,
    })
}

/// Whether `m`'s texture coordinates can lay a normal map out.
///
/// # Errors
///
/// [`TextureError::Layout`] when the texture coordinates were made up ([`Mesh::uvs_generated`]),
/// are not one per vertex, or one is not finite or lies beyond ±[`UV_LIMIT`].
pub fn check_layout(m: &Mesh) -> Result<(), TextureError> {
    if m.uvs_generated {
        return Err(TextureError::Layout(
            "the mesh has no texture coordinates (`vt`): a normal map cannot be laid out on it"
                .into(),
        ));
    }
    if m.uvs.len() != m.positions.len() {
        return Err(TextureError::Layout(format!(
            "{} texture coordinates for {} vertices",
            m.uvs.len(),
            m.positions.len()
        )));
    }
    if let Some((i, uv)) = m
        .uvs
        .iter()
        .enumerate()
        .find(|(_, uv)| !uv.is_finite() || uv.abs().max_element() > UV_LIMIT)
    {
        return Err(TextureError::Layout(format!(
            "texture coordinate {} of vertex {} is beyond ±{UV_LIMIT}",
            uv,
            i + 1
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{sphere, torus, Axis};

    #[test]
    fn channels_round_trip_and_green_flips() {
        let data: Vec<u16> = vec![255, 128, 255, 0, 0, 128];
        let t = NormalTexture::from_channels(2, 1, 3, 255, &data, Green::OpenGl).unwrap();
        assert!((t.texels[0] - DVec3::new(1.0, 1.0 / 255.0, 1.0)).length() < 1e-12);
        let d = NormalTexture::from_channels(2, 1, 3, 255, &data, Green::DirectX).unwrap();
        assert_eq!(d.texels[1].y, -t.texels[1].y);
        assert_eq!(t.to_channels(8, Green::OpenGl), data);
        assert_eq!(d.to_channels(8, Green::DirectX), data);
        assert!(NormalTexture::from_channels(2, 1, 2, 255, &data, Green::OpenGl).is_err());
        assert!(NormalTexture::from_channels(3, 1, 3, 255, &data, Green::OpenGl).is_err());
    }

    #[test]
    fn sampling_is_nearest_wrapping_with_v_up() {
        let t = NormalTexture {
            width: 4,
            height: 2,
            texels: vec![DVec3::Z; 8],
        };
        assert_eq!(t.texel_of(DVec2::new(0.0, 0.0)), (0, 1));
        assert_eq!(t.texel_of(DVec2::new(0.99, 0.99)), (3, 0));
        assert_eq!(t.texel_of(DVec2::new(1.1, -0.1)), (0, 0));
        for y in 0..2 {
            for x in 0..4 {
                assert_eq!(t.texel_of(t.uv_of(x, y)), (x, y));
            }
        }
    }

    /// The conversion keeps every world-space normal: the converted texel in
    /// the implied frame and the original in the UV frame name the same
    /// vector at each texel centre (an independent recomputation of both
    /// frames with f64 geometry).
    /// On a torus about z the UV frame and the implied frame have closed
    /// forms: `P = R(φ)(1 + 0.4 cos θ) + 0.4 sin θ·z`, `T_uv = ∂P/∂φ`
    /// normalized `= (−sin φ, cos φ, 0)`, `B_uv = ∂N/∂θ = −R(φ) sin θ +
    /// z cos θ`, `N = R(φ) cos θ + z sin θ`; the implied frame is
    /// `T = (cos β, 0, −sin β)`, `β = atan2(N_x, N_z)`, `B = N × T`. Every
    /// cleanly converted texel must be the texel rotated between the two
    /// (within the mesh's own discretization: 1.5°, reached next to the
    /// u seam where the vertex tangents average one side only).
    #[test]
    fn baking_matches_the_closed_form_frames_of_a_torus() {
        let m = torus(48, Axis::Z);
        let (w, h) = (256, 128);
        let src = DVec3::new(0.35, -0.25, 0.9).normalize();
        let map = NormalTexture {
            width: w,
            height: h,
            texels: vec![src; w * h],
        };
        let b = bake_implied(&m, &map, Scheme::Quadratic).unwrap();
        let mut checked = 0;
        for y in 0..h {
            for x in 0..w {
                let k = y * w + x;
                if b.flags[k] != TexelFlag::Converted {
                    continue;
                }
                let uv = map.uv_of(x, y);
                let (phi, th) = (uv.x * std::f64::consts::TAU, uv.y * std::f64::consts::TAU);
                let r = DVec3::new(phi.cos(), phi.sin(), 0.0);
                let n = r * th.cos() + DVec3::Z * th.sin();
                let t_uv = DVec3::new(-phi.sin(), phi.cos(), 0.0);
                let b_uv = -r * th.sin() + DVec3::Z * th.cos();
                let world = t_uv * src.x + b_uv * src.y + n * src.z;
                let beta = n.x.atan2(n.z);
                let ti = DVec3::new(beta.cos(), 0.0, -beta.sin());
                let bi = n.cross(ti);
                let want = DVec3::new(world.dot(ti), world.dot(bi), world.dot(n));
                let got = b.texture.texels[k];
                let err = got
                    .normalize()
                    .dot(want)
                    .clamp(-1.0, 1.0)
                    .acos()
                    .to_degrees();
                assert!(err < 1.5, "texel ({x}, {y}): {got} vs {want} ({err}°)");
                checked += 1;
            }
        }
        assert!(checked > w * h / 2, "{checked}");
    }

    #[test]
    fn baking_keeps_the_world_normal_and_flags_seams_and_poles() {
        for m in [sphere(24, Axis::Y), torus(24, Axis::Z)] {
            // Fine enough that the frames turn slowly between texels away
            // from the poles.
            let (w, h) = (512, 256);
            let mut rng = crate::sampling::Rng::new(2);
            let map = NormalTexture {
                width: w,
                height: h,
                texels: (0..w * h).map(|_| rng.in_cone(DVec3::Z, 0.7)).collect(),
            };
            let b = bake_implied(&m, &map, Scheme::Quadratic).unwrap();
            let c = b.counts;
            assert_eq!(
                c.converted + c.unused + c.seam + c.ambiguous + c.pole,
                w * h
            );
            assert!(c.converted > w * h / 2, "{c:?}");
            // Every converted texel has unit length (a rotation).
            for (k, f) in b.flags.iter().enumerate() {
                if *f == TexelFlag::Converted {
                    let a = b.texture.texels[k].length();
                    assert!((a - map.texels[k].length()).abs() < 1e-9);
                }
            }
            // The UV sphere's u = 0 / 1 seam is flagged.
            assert!(c.seam > 0, "{c:?}");
        }
        // On a y-axis sphere the frames agree: the conversion is the
        // identity away from the poles and seams (within a degree).
        let m = sphere(32, Axis::Y);
        // Rows fine enough that the first lies within 2° of the poles.
        let map = NormalTexture {
            width: 64,
            height: 128,
            texels: vec![DVec3::new(0.3, 0.2, 0.93).normalize(); 64 * 128],
        };
        let b = bake_implied(&m, &map, Scheme::Quadratic).unwrap();
        for (k, f) in b.flags.iter().enumerate() {
            if *f == TexelFlag::Converted {
                let d = b.texture.texels[k]
                    .dot(map.texels[k])
                    .clamp(-1.0, 1.0)
                    .acos();
                assert!(d.to_degrees() < 2.0, "texel {k}: {}°", d.to_degrees());
            }
        }
        // A torus about z turns its normal through ±y inside triangles:
        // those texels are flagged as poles.
        let m = torus(24, Axis::Z);
        let map = NormalTexture {
            width: 128,
            height: 256,
            texels: vec![DVec3::Z; 128 * 256],
        };
        assert!(
            bake_implied(&m, &map, Scheme::Quadratic)
                .unwrap()
                .counts
                .pole
                > 0
        );
    }
}
