//! Procedural triangle meshes with normals and texture coordinates: a UV
//! sphere and a torus at any tessellation, about any axis.

use glam::{DVec2, DVec3};

/// A triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Unit vertex normals.
    pub normals: Vec<DVec3>,
    /// Texture coordinates.
    pub uvs: Vec<DVec2>,
    /// Triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

/// The axis a procedural mesh is built around.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    /// Around x.
    X,
    /// Around y (the polar transform's own axis).
    Y,
    /// Around z (as "Z-up" modelling tools build them).
    Z,
}

impl Axis {
    /// `(u, a, w)`: the local frame whose `a` is the axis.
    fn basis(self) -> (DVec3, DVec3, DVec3) {
        match self {
            Axis::Y => (DVec3::Z, DVec3::Y, DVec3::X),
            Axis::Z => (DVec3::X, DVec3::Z, DVec3::Y),
            Axis::X => (DVec3::Y, DVec3::X, DVec3::Z),
        }
    }
}

fn grid(n_u: u32, n_v: u32, f: impl Fn(f64, f64) -> (DVec3, DVec3), wrap_v: bool) -> Mesh {
    let mut m = Mesh::default();
    let rows = if wrap_v { n_v } else { n_v + 1 };
    for j in 0..rows {
        for i in 0..=n_u {
            let (u, v) = (i as f64 / n_u as f64, j as f64 / n_v as f64);
            let (p, n) = f(u, v);
            m.positions.push(p);
            m.normals.push(n.normalize());
            m.uvs.push(DVec2::new(u, v));
        }
    }
    let w = n_u + 1;
    for j in 0..n_v {
        let j1 = if wrap_v { (j + 1) % n_v } else { j + 1 };
        for i in 0..n_u {
            let (a, b, c, d) = (j * w + i, j * w + i + 1, j1 * w + i, j1 * w + i + 1);
            m.triangles.push([a, b, d]);
            m.triangles.push([a, d, c]);
        }
    }
    m
}

/// A UV sphere of radius 1 with `n` segments around and `n/2` from pole to
/// pole (`n ≥ 4`), built around `axis`.
pub fn sphere(n: u32, axis: Axis) -> Mesh {
    let (e1, a, e2) = axis.basis();
    let n = n.max(4);
    let mut m = grid(
        n,
        n / 2,
        |u, v| {
            let (phi, th) = (u * std::f64::consts::TAU, (v - 0.5) * std::f64::consts::PI);
            let p = (e1 * phi.cos() + e2 * phi.sin()) * th.cos() + a * th.sin();
            (p, p)
        },
        false,
    );
    // Drop the degenerate triangles at the poles.
    let pos = m.positions.clone();
    m.triangles.retain(|t| {
        let (p0, p1, p2) = (pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]);
        (p1 - p0).cross(p2 - p0).length() > 1e-12
    });
    m
}

/// A torus with major radius 1 and minor radius 0.4, `n` segments around
/// and `n/2` around the tube (`n ≥ 6`), built around `axis`.
pub fn torus(n: u32, axis: Axis) -> Mesh {
    let (e1, a, e2) = axis.basis();
    let n = n.max(6);
    grid(
        n,
        n / 2,
        |u, v| {
            let (phi, th) = (u * std::f64::consts::TAU, v * std::f64::consts::TAU);
            let radial = e1 * phi.cos() + e2 * phi.sin();
            let nrm = radial * th.cos() + a * th.sin();
            (radial + nrm * 0.4, nrm)
        },
        true,
    )
}

/// Per-vertex tangents from the texture coordinates (the usual UV-aligned
/// frame, as MikkTSpace builds it in the common case): each triangle's
/// `∂P/∂u` accumulated at its vertices, then made orthogonal to the normal.
pub fn uv_tangents(m: &Mesh) -> Vec<DVec3> {
    let mut acc = vec![DVec3::ZERO; m.positions.len()];
    for t in &m.triangles {
        let [i0, i1, i2] = t.map(|i| i as usize);
        let (e1, e2) = (
            m.positions[i1] - m.positions[i0],
            m.positions[i2] - m.positions[i0],
        );
        let (d1, d2) = (m.uvs[i1] - m.uvs[i0], m.uvs[i2] - m.uvs[i0]);
        let det = d1.x * d2.y - d2.x * d1.y;
        if det.abs() < 1e-15 {
            continue;
        }
        let tan = (e1 * d2.y - e2 * d1.y) / det;
        for i in [i0, i1, i2] {
            acc[i] += tan;
        }
    }
    acc.iter()
        .zip(&m.normals)
        .map(|(t, n)| (*t - *n * n.dot(*t)).normalize_or_zero())
        .collect()
}

/// Area of each triangle.
pub fn areas(m: &Mesh) -> Vec<f64> {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            (b - a).cross(c - a).length() / 2.0
        })
        .collect()
}
