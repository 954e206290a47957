//! Procedural triangle meshes with normals and texture coordinates: a UV
//! sphere and a torus at any tessellation, about any axis.

use fxshade_numbers::convert::narrow;
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
    /// The texture coordinates were made up (an OBJ file without `vt`:
    /// [`spherical_uvs`]), not given: no normal map can be laid out by them.
    pub uvs_generated: bool,
    /// Triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// For a mesh read from a file: the 1-based line of the face each
    /// triangle came from (empty for procedural meshes).
    pub source_lines: Vec<usize>,
}

impl Mesh {
    /// How to name triangle `t` (0-based) in a message: its file line when
    /// known, else its 1-based index.
    pub fn describe_triangle(&self, t: usize) -> String {
        match self.source_lines.get(t) {
            Some(l) => format!("triangle {} (face on line {l})", t + 1),
            None => format!("triangle {}", t + 1),
        }
    }
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

/// A `n_u × n_v` grid of quads over `(u, v) ∈ [0, 1]²`, two triangles each;
/// the vertices of `u = 1` and `v = 1` are separate from those of 0 (UV seams).
fn grid(n_u: u32, n_v: u32, f: impl Fn(f64, f64) -> (DVec3, DVec3)) -> Mesh {
    let mut m = Mesh::default();
    let rows = n_v + 1;
    for j in 0..rows {
        for i in 0..=n_u {
            let (u, v) = (f64::from(i) / f64::from(n_u), f64::from(j) / f64::from(n_v));
            let (p, n) = f(u, v);
            m.positions.push(p);
            m.normals.push(n.normalize());
            m.uvs.push(DVec2::new(u, v));
        }
    }
    let w = n_u + 1;
    for j in 0..n_v {
        let j1 = j + 1;
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
    let mut m = grid(n, n / 2, |u, v| {
        let (phi, th) = (u * std::f64::consts::TAU, (v - 0.5) * std::f64::consts::PI);
        let p = (e1 * phi.cos() + e2 * phi.sin()) * th.cos() + a * th.sin();
        (p, p)
    });
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
    grid(n, n / 2, |u, v| {
        let (phi, th) = (u * std::f64::consts::TAU, v * std::f64::consts::TAU);
        let radial = e1 * phi.cos() + e2 * phi.sin();
        let nrm = radial * th.cos() + a * th.sin();
        // The closing band of triangles gets its own row of vertices at
        // v = 1, so its texture coordinates run on to 1 instead of
        // jumping back across the whole map (a UV seam, like u's).
        (radial + nrm * 0.4, nrm)
    })
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

/// Why an OBJ file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ObjError {
    /// The file could not be opened or read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The parser rejected a line.
    #[error("{path}:{line}: {what} (`{text}`)")]
    Parse {
        /// The file.
        path: String,
        /// 1-based line number.
        line: usize,
        /// The parser's reason.
        what: String,
        /// The line's text.
        text: String,
    },
    /// The file parsed but holds no usable triangle.
    #[error("{path}: {why}")]
    Content {
        /// The file.
        path: String,
        /// Why.
        why: String,
    },
}

/// A line of the file as an error shows it: escaped to printable ASCII
/// and at most 80 characters.
fn shown(line: &str) -> String {
    let s = crate::escape::line(line.trim());
    if s.chars().count() > 80 {
        s.chars().take(77).collect::<String>() + "..."
    } else {
        s
    }
}

/// A reader that counts the lines its consumer has taken, so a parse error
/// can name the line it happened on.
struct LineCounter<R> {
    inner: R,
    newlines: usize,
    /// The last byte taken was a newline (or nothing was taken yet).
    at_line_start: bool,
}

impl<R> LineCounter<R> {
    fn took(&mut self, b: &[u8]) {
        self.newlines += b.iter().filter(|&&c| c == b'\n').count();
        if let Some(&last) = b.last() {
            self.at_line_start = last == b'\n';
        }
    }
    /// The 1-based number of the line being read.
    fn line(&self) -> usize {
        if self.at_line_start {
            self.newlines.max(1)
        } else {
            self.newlines + 1
        }
    }
}

impl<R: std::io::BufRead> std::io::Read for LineCounter<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.took(&buf[..n]);
        Ok(n)
    }
}

impl<R: std::io::BufRead> std::io::BufRead for LineCounter<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.inner.fill_buf()
    }
    fn consume(&mut self, amt: usize) {
        if let Ok(b) = self.inner.fill_buf() {
            let taken = b[..amt.min(b.len())].to_vec();
            self.took(&taken);
        }
        self.inner.consume(amt);
    }
}

/// Check what the `tobj` parser accepts silently or reports on the wrong
/// line, naming the line: faces of fewer than three vertices, vertex,
/// texture or normal indices that are zero or outside the file's elements,
/// non-finite positions, and normals (`vn`) that are not finite or have zero
/// length (one such normal would otherwise make the loader discard every
/// normal of the file). Returns, for each triangle the fan triangulation of
/// the faces yields (in file order), its face's line.
fn prescan_obj(path: &str, text: &str) -> Result<Vec<usize>, ObjError> {
    let lines: Vec<&str> = text.lines().collect();
    let count = |kw: &str| {
        narrow::<i64, _>(
            lines
                .iter()
                .filter(|l| l.split_whitespace().next() == Some(kw))
                .count(),
        )
    };
    let totals = [count("v"), count("vt"), count("vn")];
    let mut seen = [0i64; 3];
    let mut face_lines = Vec::new();
    for (i, raw) in lines.iter().enumerate() {
        let line = i + 1;
        let err = |what: String| ObjError::Parse {
            path: path.to_string(),
            line,
            what,
            text: shown(raw),
        };
        let mut tok = raw.split_whitespace();
        let Some(kw) = tok.next() else { continue };
        let nums = |tok: std::str::SplitWhitespace| -> Vec<Option<f64>> {
            tok.take(3).map(|x| x.parse::<f64>().ok()).collect()
        };
        match kw {
            "v" | "vn" => {
                let v = nums(tok);
                let k = if kw == "v" { 0 } else { 2 };
                seen[k] += 1;
                if v.len() < 3 || v.iter().any(|x| x.is_none()) {
                    continue; // tobj names these itself
                }
                let v: Vec<f64> = v.into_iter().flatten().collect();
                if v.iter().any(|x| !x.is_finite()) {
                    return Err(err(format!("{kw}: components must be finite")));
                }
                if kw == "vn" && v.iter().all(|&x| x == 0.0) {
                    return Err(err(
                        "vn: a zero-length normal has no direction; give a unit normal, or leave the file's normals out to have them computed".into(),
                    ));
                }
            }
            "vt" => seen[1] += 1,
            "f" => {
                let verts: Vec<&str> = tok.collect();
                if verts.len() < 3 {
                    return Err(err(format!(
                        "a face needs at least 3 vertices; this one has {}",
                        verts.len()
                    )));
                }
                for v in &verts {
                    for (k, part) in v.split('/').enumerate().take(3) {
                        if part.is_empty() {
                            continue;
                        }
                        let what = ["vertex", "texture coordinate", "normal"][k];
                        let Ok(idx) = part.parse::<i64>() else {
                            return Err(err(format!(
                                "`{v}`: the {what} index `{part}` is not an integer"
                            )));
                        };
                        let ok = if idx > 0 {
                            idx <= totals[k]
                        } else {
                            idx < 0 && seen[k] + idx >= 0
                        };
                        if !ok {
                            return Err(err(format!(
                                "`{v}`: {what} index {idx} does not exist ({} {what}s {})",
                                if idx > 0 { totals[k] } else { seen[k] },
                                if idx > 0 {
                                    "in the file"
                                } else {
                                    "before this line"
                                }
                            )));
                        }
                    }
                }
                face_lines.extend(std::iter::repeat_n(line, verts.len() - 2));
            }
            _ => {}
        }
    }
    Ok(face_lines)
}

/// Load a Wavefront OBJ file with the `tobj` crate: every object merged,
/// polygons triangulated. Normals missing from the file (or not given for
/// every vertex) are computed as area-weighted averages of the faces
/// around each vertex; texture coordinates, when missing, are a spherical
/// projection about the bounding-box centre. Errors name the file, and for
/// a parse error the line and its text.
///
/// # Errors
///
/// [`ObjError::Read`] when the file's metadata or contents cannot be read; [`ObjError::Content`]
/// when it is not a regular file, holds a NUL byte, is not UTF-8, has no face, or has a vertex with
/// a non-finite position; [`ObjError::Parse`], naming the line and its text, for a `v` or `vn` with
/// a non-finite component, a `vn` of zero length, a face of fewer than three vertices, an index
/// that is not an integer or names no element, or a line the `tobj` parser rejects.
pub fn load_obj(path: &std::path::Path) -> Result<Mesh, ObjError> {
    let name = crate::escape::line(&path.display().to_string());
    // A regular file only (a device such as /dev/zero never ends).
    let meta = std::fs::metadata(path).map_err(|source| ObjError::Read {
        path: name.clone(),
        source,
    })?;
    if !meta.is_file() {
        return Err(ObjError::Content {
            path: name,
            why: "not a regular file".into(),
        });
    }
    let bytes = std::fs::read(path).map_err(|source| ObjError::Read {
        path: name.clone(),
        source,
    })?;
    // An OBJ is text: a binary file is named, not printed.
    if let Some(at) = bytes.iter().position(|&b| b == 0) {
        return Err(ObjError::Content {
            path: name,
            why: format!("not a text OBJ file (byte {at} is NUL)"),
        });
    }
    if let Err(e) = std::str::from_utf8(&bytes) {
        return Err(ObjError::Content {
            path: name,
            why: format!(
                "not a text OBJ file (byte {} is not UTF-8)",
                e.valid_up_to()
            ),
        });
    }
    let face_lines = prescan_obj(&name, &String::from_utf8_lossy(&bytes))?;
    let mut rd = LineCounter {
        inner: std::io::BufReader::new(&bytes[..]),
        newlines: 0,
        at_line_start: true,
    };
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut rd, &opts, |_| Err(tobj::LoadError::OpenFileFailed))
        .map_err(|e| {
            // The line being parsed is the last one consumed (or the first one
            // not yet ended by a newline).
            let text = String::from_utf8_lossy(&bytes);
            let lines: Vec<&str> = text.lines().collect();
            let line = rd.line().min(lines.len().max(1));
            ObjError::Parse {
                path: name.clone(),
                line,
                what: e.to_string(),
                text: shown(lines.get(line - 1).unwrap_or(&"")),
            }
        })?;
    let mut m = Mesh::default();
    let mut all_normals = true;
    let mut all_uvs = true;
    for model in &models {
        let me = &model.mesh;
        let base = narrow::<u32, _>(m.positions.len());
        let nv = me.positions.len() / 3;
        for k in 0..nv {
            m.positions.push(DVec3::new(
                f64::from(me.positions[3 * k]),
                f64::from(me.positions[3 * k + 1]),
                f64::from(me.positions[3 * k + 2]),
            ));
        }
        if me.normals.len() == me.positions.len() {
            for k in 0..nv {
                m.normals.push(DVec3::new(
                    f64::from(me.normals[3 * k]),
                    f64::from(me.normals[3 * k + 1]),
                    f64::from(me.normals[3 * k + 2]),
                ));
            }
        } else {
            all_normals = false;
        }
        if me.texcoords.len() / 2 == nv {
            for k in 0..nv {
                m.uvs.push(DVec2::new(
                    f64::from(me.texcoords[2 * k]),
                    f64::from(me.texcoords[2 * k + 1]),
                ));
            }
        } else {
            all_uvs = false;
        }
        for t in me.indices.chunks_exact(3) {
            m.triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if m.triangles.is_empty() {
        return Err(ObjError::Content {
            path: name,
            why: "no faces: an OBJ mesh needs `f` lines".into(),
        });
    }
    if let Some(p) = m.positions.iter().position(|p| !p.is_finite()) {
        return Err(ObjError::Content {
            path: name,
            why: format!("vertex {} has a non-finite position", p + 1),
        });
    }
    if m.triangles.len() == face_lines.len() {
        m.source_lines = face_lines;
    }
    if !all_normals
        || m.normals
            .iter()
            .any(|n| !n.is_finite() || n.length() < 1e-12)
    {
        // Normals missing for some vertex (every given `vn` was checked
        // above): computed for all, as the loader's documentation says.
        m.normals = smooth_normals(&m);
    } else {
        for n in &mut m.normals {
            *n = n.normalize();
        }
    }
    if !all_uvs {
        m.uvs = spherical_uvs(&m);
        m.uvs_generated = true;
    }
    Ok(m)
}

/// Area-weighted vertex normals: the sum of the (unnormalized) face normals
/// around each vertex, normalized; a vertex with no area around it gets +z.
pub fn smooth_normals(m: &Mesh) -> Vec<DVec3> {
    let mut acc = vec![DVec3::ZERO; m.positions.len()];
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let f = (b - a).cross(c - a);
        for &i in t {
            acc[i as usize] += f;
        }
    }
    acc.into_iter()
        .map(|n| n.try_normalize().unwrap_or(DVec3::Z))
        .collect()
}

/// Texture coordinates by spherical projection about the bounding-box
/// centre: `u` the azimuth about y, `v` the elevation, both in `[0, 1]`.
pub fn spherical_uvs(m: &Mesh) -> Vec<DVec2> {
    let (lo, hi) = m.positions.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let c = (lo + hi) / 2.0;
    m.positions
        .iter()
        .map(|p| {
            let d = (*p - c).try_normalize().unwrap_or(DVec3::Y);
            DVec2::new(
                d.x.atan2(d.z) / std::f64::consts::TAU + 0.5,
                d.y.clamp(-1.0, 1.0).asin() / std::f64::consts::PI + 0.5,
            )
        })
        .collect()
}

#[cfg(test)]
mod obj_tests {
    use super::*;

    fn load(text: &str) -> Result<Mesh, ObjError> {
        let d = std::env::temp_dir().join(format!("fxshade-obj-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join(format!(
            "{:x}.obj",
            crate::rtl::record::fingerprint(&[text.as_bytes()])
        ));
        std::fs::write(&p, text).unwrap();
        let r = load_obj(&p);
        let _ = std::fs::remove_file(&p);
        r
    }

    #[test]
    fn a_tetrahedron_without_normals_gets_outward_smooth_normals() {
        let m = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
            .unwrap();
        assert_eq!(m.triangles.len(), 4);
        assert_eq!(m.normals.len(), 4);
        // Vertex 4 (0,0,1): its faces' normals average to a direction with
        // positive z; vertex 1 at the origin points into the negative octant.
        assert!(m.normals[3].z > 0.5, "{:?}", m.normals[3]);
        assert!(m.normals[0].x < 0.0 && m.normals[0].y < 0.0 && m.normals[0].z < 0.0);
        for n in &m.normals {
            assert!((n.length() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_bad_line_is_named_with_its_number_and_text() {
        let e = load("v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n").unwrap_err();
        let s = e.to_string();
        assert!(s.contains(":3:") && s.contains("v 0 x 0"), "{s}");
        let e = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap_err();
        let s = e.to_string();
        assert!(s.contains(":4:") && s.contains("f 1 2 7"), "{s}");
        let e = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 q\nv 1 1 1").unwrap_err();
        assert!(e.to_string().contains(":4:"), "{e}");
        let e = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 1 y 1").unwrap_err();
        assert!(e.to_string().contains(":5:"), "{e}");
        let e = load("v 0 0 0\n").unwrap_err();
        assert!(e.to_string().contains("no faces"), "{e}");
    }

    #[test]
    fn short_faces_bad_normals_and_bad_indices_name_their_line() {
        let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\n";
        for (body, line, what) in [
            ("f 1 2\n", 6, "at least 3 vertices"),
            ("f 1\n", 6, "at least 3 vertices"),
            ("vn 0 0 0\nf 1//1 2//2 3//3\n", 6, "zero-length"),
            ("vn nan 0 1\nf 1//1 2//2 3//3\n", 6, "finite"),
            ("f 1 2 3\nf 1 2 9\n# end\n# more\n", 7, "vertex index 9"),
            ("f 1//1 2//7 3//1\n# end\n", 6, "normal index 7"),
            ("f 1 2 0\n", 6, "vertex index 0"),
            ("f -1 -2 -4\n", 6, "vertex index -4"),
        ] {
            let e = load(&format!("{tri}{body}")).unwrap_err().to_string();
            assert!(
                e.contains(&format!(":{line}:")) && e.contains(what),
                "{body:?}: {e}"
            );
        }
        // Relative indices and quads are fine, and each triangle knows its line.
        let m = load(&format!("{tri}v 1 1 0\nf -4 -3 -1 -2\nf 1 2 3\n")).unwrap();
        assert_eq!(m.source_lines, vec![7, 7, 8]);
    }
}
