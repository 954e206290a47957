//! Normal maps and the implied frame.
//!
//! The polar transform works in the frame fixed by the normal alone,
//! `T = (cos β_N, 0, −sin β_N)`, `B = N × T`. Normal maps are usually baked
//! in a UV-aligned frame (MikkTSpace): [`uv_to_implied`] converts a
//! tangent-space normal between the two, and [`compare`] reports how far
//! the frames differ over a mesh, so a designer can judge the method on
//! real content.

use glam::DVec3;

use super::{angles_of, frame};
use crate::mesh::{self, Mesh};

/// A tangent-space normal `n` in the UV-aligned frame `(t, b, n_geo)` (not
/// necessarily orthonormal: it is the frame the map was baked in),
/// expressed in the implied frame of `n_geo`.
pub fn uv_to_implied(n_ts: DVec3, t: DVec3, b: DVec3, n_geo: DVec3) -> DVec3 {
    let world = t * n_ts.x + b * n_ts.y + n_geo * n_ts.z;
    let (_, beta) = angles_of(n_geo);
    let (ti, bi, ni) = frame(n_geo.normalize(), beta);
    DVec3::new(world.dot(ti), world.dot(bi), world.dot(ni))
}

/// The signed angle, in degrees, from the UV tangent to the implied tangent
/// about the normal.
pub fn frame_angle_deg(t_uv: DVec3, n: DVec3) -> f64 {
    let (_, beta) = angles_of(n);
    let (ti, _, _) = frame(n, beta);
    t_uv.cross(ti).dot(n).atan2(t_uv.dot(ti)).to_degrees()
}

/// How far the implied frame is from the UV-aligned one over a mesh.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrameComparison {
    /// Triangles.
    pub triangles: usize,
    /// Share of the surface (by area) where the frames differ by more than
    /// 10° about the normal.
    pub share_over_10_deg: f64,
    /// Area-weighted mean difference, degrees.
    pub mean_deg: f64,
    /// Largest difference, degrees.
    pub max_deg: f64,
    /// Share of the surface within 1° of a pole (β undefined there).
    pub share_near_poles: f64,
}

/// Compare the frames over `m`: per triangle, the difference at its
/// centroid (mean of the vertex normals and of the UV tangents).
pub fn compare(m: &Mesh) -> FrameComparison {
    let t = mesh::uv_tangents(m);
    let areas = mesh::areas(m);
    let total: f64 = areas.iter().sum();
    let (mut over, mut mean, mut max, mut poles) = (0.0, 0.0, 0.0f64, 0.0);
    for (tri, &a) in m.triangles.iter().zip(&areas) {
        let idx = tri.map(|i| i as usize);
        let n = idx
            .iter()
            .map(|&i| m.normals[i])
            .sum::<DVec3>()
            .normalize_or_zero();
        let tu = idx.iter().map(|&i| t[i]).sum::<DVec3>();
        let tu = (tu - n * n.dot(tu)).normalize_or_zero();
        if n == DVec3::ZERO || tu == DVec3::ZERO {
            continue;
        }
        if n.y.abs() > (89f64).to_radians().sin() {
            poles += a;
        }
        let d = frame_angle_deg(tu, n).abs();
        if d > 10.0 {
            over += a;
        }
        mean += d * a;
        max = max.max(d);
    }
    FrameComparison {
        triangles: m.triangles.len(),
        share_over_10_deg: over / total,
        mean_deg: mean / total,
        max_deg: max,
        share_near_poles: poles / total,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{sphere, torus, Axis};

    #[test]
    fn conversion_preserves_the_world_normal() {
        let mut rng = crate::sampling::Rng::new(9);
        for _ in 0..200 {
            let n = rng.direction();
            let (u, _) = n.any_orthonormal_pair();
            let t = u;
            let b = n.cross(t);
            let ts = rng.in_cone(DVec3::Z, 1.0);
            let imp = uv_to_implied(ts, t, b, n);
            let (_, beta) = angles_of(n);
            let (ti, bi, ni) = frame(n, beta);
            let world = t * ts.x + b * ts.y + n * ts.z;
            assert!((ti * imp.x + bi * imp.y + ni * imp.z - world).length() < 1e-12);
        }
    }

    #[test]
    fn frames_agree_on_a_y_sphere_and_differ_elsewhere() {
        // A sphere built around y: u runs along β, so the frames coincide.
        let c = compare(&sphere(32, Axis::Y));
        assert!(
            c.share_over_10_deg <= c.share_near_poles + 1e-9 && c.mean_deg < 1.0,
            "{c:?}"
        );
        // A torus around y: its inner half's normals face the axis, so their
        // azimuth — and the implied tangent — is turned by 180°. The inner
        // half of a torus with radii 1 and 0.4 holds (1 − 2·0.4/π)/2 of its
        // area.
        let c = compare(&torus(64, Axis::Y));
        let inner = (1.0 - 2.0 * 0.4 / std::f64::consts::PI) / 2.0;
        assert!(
            (c.share_over_10_deg - inner).abs() < 0.03,
            "{c:?} vs {inner}"
        );
        assert!(c.max_deg > 170.0);
        // Built Z-up, both differ over most of the surface.
        for m in [sphere(32, Axis::Z), torus(32, Axis::Z)] {
            let c = compare(&m);
            assert!(c.share_over_10_deg > 0.3, "{c:?}");
        }
    }
}
