//! The meshes a `--mesh` names: `sphere:N` and `torus:N` (with an axis,
//! `torus:24:z`), built by [`fxshade_model::mesh`], or an `.obj` file.

use anyhow::{bail, Context};
use fxshade_model::mesh::{self, Axis, Mesh};

/// Parse `sphere:N` / `torus:N`.
///
/// # Errors
///
/// `spec` is not `sphere:N` or `torus:N` with N in 4..=4096.
pub fn procedural(spec: &str, axis: Axis) -> anyhow::Result<Mesh> {
    let (kind, n) = spec
        .split_once(':')
        .with_context(|| format!("--mesh {spec}: write sphere:N or torus:N"))?;
    if kind != "sphere" && kind != "torus" {
        bail!("--mesh {spec}: unknown mesh `{kind}`; write sphere:N or torus:N");
    }
    let n: u32 = n
        .parse()
        .ok()
        .filter(|&n| (4..=4096).contains(&n))
        .with_context(|| format!("--mesh {spec}: N must be a whole number in 4..=4096"))?;
    Ok(if kind == "sphere" {
        mesh::sphere(n, axis)
    } else {
        mesh::torus(n, axis)
    })
}

/// The mesh named by `--mesh`.
///
/// # Errors
///
/// `spec` is not a procedural mesh ([`procedural`], with an axis x, y or z) nor a readable
/// `.obj` file.
pub fn load_mesh(spec: &str) -> anyhow::Result<Mesh> {
    if spec.starts_with("sphere:") || spec.starts_with("torus:") {
        // `torus:24:z` builds it about another axis (default y).
        let mut parts = spec.splitn(3, ':');
        let (kind, n, axis) = (parts.next(), parts.next(), parts.next());
        let axis = match axis {
            None | Some("y") => mesh::Axis::Y,
            Some("x") => mesh::Axis::X,
            Some("z") => mesh::Axis::Z,
            Some(a) => bail!("--mesh {spec}: axis `{a}`; give x, y or z"),
        };
        return procedural(&format!("{}:{}", kind.unwrap_or(""), n.unwrap_or("")), axis);
    }
    let p = std::path::Path::new(spec);
    if !p.exists() {
        bail!("--mesh {spec}: no such file; give sphere:N, torus:N or an .obj file");
    }
    Ok(mesh::load_obj(p)?)
}
