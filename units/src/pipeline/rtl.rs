//! The pipeline's RTL side: the traced designs of the pipeline top (one
//! datapath: every unit chained, with the conversions between them) and of
//! the angle interpolation, and their input vectors: pixels of small
//! rendered meshes, random triangles, random codes.

use fxshade_numbers::convert::narrow;
use glam::DVec3;

use super::{Path, Pipeline, DECL};
use crate::config::Config;
use crate::interp::THETA_LADDER;
use crate::normalizer::Method;
use crate::rtl::units::Part;
use crate::rtl::units::{structured_code, RtlError};
use crate::sampling::Rng;

/// The configured path of `cfg`.
pub fn path_of(cfg: &Config) -> Path {
    cfg.section::<super::PipelineConfig>().path
}

/// The pipeline top's traced datapath for the configured path.
///
/// # Errors
///
/// [`RtlError::Pipeline`] with the error of [`Pipeline::from_config`] (or of [`Pipeline::trace`],
/// never for a configuration).
pub fn design(cfg: &Config) -> Result<crate::rtl::Design, RtlError> {
    let path = path_of(cfg);
    let p = Pipeline::from_config(cfg)?;
    let mut notes = vec![format!("Path: {}", path.name())];
    if path == Path::Smooth {
        notes.push(format!(
            "Normalizer {} with {} coefficient sets, chosen by sel, a per-triangle value (Θ = {:?}; codes past the last read set 0)",
            p.method.name(),
            p.sets.len(),
            THETA_LADDER
        ));
        for (k, (n, th)) in p.sets.iter().zip(THETA_LADDER).enumerate() {
            if !n.coeffs.is_empty() {
                notes.push(format!("  set {k} (Θ = {th}): {:?}", n.coeffs));
            }
        }
    }
    let variant = match path {
        Path::Smooth => format!("smooth ({} g)", p.method.name()),
        Path::Mapped => format!("mapped ({} angles)", p.angles.name()),
    };
    let mut d = crate::rtl::units::design(DECL.name, &variant, p.trace(path)?, cfg, notes);
    if path == Path::Smooth {
        d.parameters = serde_json::json!({
            "method": p.method.name(),
            "coefficient_sets": p.sets.iter().zip(THETA_LADDER).enumerate().map(|(k, (n, th))| serde_json::json!({
                "sel": k,
                "theta": th,
                "coefficients": crate::normalizer::rtl::coefficients(n),
            })).collect::<Vec<_>>(),
            "sel_past_the_last": 0,
        });
    }
    use crate::rtl::section::{RtlConfig, Setup};
    match cfg.section::<RtlConfig>().setup {
        Setup::Port => d.setup = setup_groups(path, p.angles, true),
        Setup::Hold => d.setup = setup_groups(path, p.angles, false),
        Setup::Pixel => {}
    }
    d.module = match (path, p.angles) {
        (Path::Mapped, super::AngleSource::Interpolate) => "pipeline_mapped_interp".into(),
        _ => format!("pipeline_{}", path.name()),
    };
    Ok(d)
}

/// The set-up ports of a pipeline top: the light and half vectors (or
/// their angles) per frame; the vertex and midpoint normals, the
/// coefficient set (or the angle set-up) per triangle, double-buffered
/// with `banked` (`rtl.setup = "port"`; `"hold"`: one register a field).
/// The barycentrics and the texel travel with each pixel.
pub fn setup_groups(
    path: Path,
    angles: super::AngleSource,
    banked: bool,
) -> Vec<crate::rtl::SetupGroup> {
    let xyz = |v: &[&str]| -> Vec<String> {
        v.iter()
            .flat_map(|n| ["x", "y", "z"].map(|c| format!("{n}_{c}")))
            .collect()
    };
    let normals = xyz(&["n1", "n2", "n3", "n12", "n23", "n31"]);
    let angles_lh: Vec<String> = ["al", "bl", "ah", "bh"].map(String::from).to_vec();
    let (frame, tri, frame_doc, tri_doc) = match (path, angles) {
        (Path::Smooth, _) => (
            xyz(&["l", "h"]),
            std::iter::once("sel".to_string()).chain(normals).collect(),
            "the light and half vectors L and H, per frame",
            "the coefficient set and the vertex and midpoint normals, per triangle",
        ),
        (Path::Mapped, super::AngleSource::Cordic) => (
            angles_lh,
            normals,
            "the polar angles of L and H, per frame",
            "the vertex and midpoint normals, per triangle",
        ),
        (Path::Mapped, super::AngleSource::Interpolate) => (
            angles_lh,
            ["a3", "da1", "da2", "b3", "db1", "db2"]
                .map(String::from)
                .to_vec(),
            "the polar angles of L and H, per frame",
            "the angle set-up (the third vertex's angles and the deltas), per triangle",
        ),
    };
    vec![
        crate::rtl::SetupGroup {
            name: "frame",
            doc: frame_doc,
            fields: frame,
            banked: false,
        },
        crate::rtl::SetupGroup {
            name: "tri",
            doc: tri_doc,
            fields: tri,
            banked,
        },
    ]
}

impl Pipeline {
    /// Per input field of `path` (in the order of [`Pipeline::fields`]):
    /// whether it changes from pixel to pixel. The others are the top's
    /// per-frame and per-triangle values, its set-up ports
    /// ([`setup_groups`]): one code for every pixel of a triangle.
    ///
    /// # Errors
    ///
    /// As [`Pipeline::trace`].
    pub fn pixel_fields(&self, path: Path) -> Result<Vec<bool>, super::PipelineError> {
        let groups = setup_groups(path, self.angles, true);
        let set_up = |name: &str| groups.iter().any(|g| g.fields.iter().any(|f| f == name));
        Ok(self
            .trace(path)?
            .input_ports()
            .iter()
            .map(|port| !set_up(&port.name))
            .collect())
    }
}

/// The angle interpolation's traced datapath (`c1, c2, a3, d1, d2 → angle`).
///
/// # Errors
///
/// [`RtlError::Pipeline`] when the `[polar]` or `[angles]` section is unusable
/// ([`Pipeline::with_method`] without `g`, which designs no coefficients).
pub fn angle_design(cfg: &Config) -> Result<crate::rtl::Design, RtlError> {
    let p = Pipeline::with_method(cfg, Method::None)?;
    let mut d = crate::rtl::units::design(
        DECL.name,
        "linear",
        p.trace_angle(),
        cfg,
        vec![format!(
            "Angle {} (wraps), deltas {}",
            p.angle.format(),
            p.delta.format()
        )],
    );
    d.module = super::ANGLE_UNIT.into();
    d.unit = super::ANGLE_UNIT;
    Ok(d)
}

/// Input vectors of the angle interpolation: extreme and zero codes, then
/// structured random codes (many trailing zeros, so rounding ties occur).
///
/// # Errors
///
/// [`RtlError::Pipeline`] when the `[polar]` or `[angles]` section is unusable
/// ([`Pipeline::with_method`] without `g`, which designs no coefficients).
pub fn angle_inputs(
    cfg: &Config,
    part: crate::rtl::units::Part,
    seed: u64,
) -> Result<Vec<Vec<i128>>, RtlError> {
    let p = Pipeline::with_method(cfg, Method::None)?;
    let (fb, fa, fd) = (p.interp.bary.format(), p.angle.format(), p.delta.format());
    let mut rows = Vec::new();
    // 0, the largest code, and 1.0 where the port holds it.
    for c in [
        0,
        fb.max_code(),
        (1i128 << fb.frac().max(0)).min(fb.max_code()),
    ] {
        for a in [0, fa.max_code()] {
            for d in [fd.min_code(), 0, fd.max_code()] {
                rows.push(vec![c, c, a, d, d]);
                rows.push(vec![c, 0, a, d, -d.max(fd.min_code() + 1)]);
            }
        }
    }
    let Part::Random(count) = part else {
        return Ok(rows);
    };
    rows.clear();
    let mut rng = Rng::new(seed);
    while rows.len() < count {
        rows.push(vec![
            structured_code(fb, &mut rng),
            structured_code(fb, &mut rng),
            structured_code(fa, &mut rng),
            structured_code(fd, &mut rng),
            structured_code(fd, &mut rng),
        ]);
    }
    Ok(rows)
}

/// Input rows of `path` for the pixels of a small render of `mesh`.
pub fn render_rows(
    p: &Pipeline,
    path: Path,
    mesh: &crate::mesh::Mesh,
    size: usize,
) -> Vec<Vec<i128>> {
    let r = crate::render::rasterize(mesh, size, size);
    let want = crate::render::Wanted {
        smooth: path == Path::Smooth,
        mapped: path == Path::Mapped && p.angles == super::AngleSource::Cordic,
        mapped_interp: path == Path::Mapped && p.angles == super::AngleSource::Interpolate,
        tbn: false,
        mapped_refs: false,
    };
    let f = crate::render::frame_wanted(&crate::render::Scene::default(), p, r, mesh, want);
    let rows = match path {
        Path::Smooth => f.smooth_rows,
        Path::Mapped => match p.angles {
            super::AngleSource::Cordic => f.mapped_rows,
            super::AngleSource::Interpolate => f.mapped_interp_rows,
        },
    };
    rows.live_vecs()
}

/// Input vectors of the configured path: the pixels of a 12 × 12 render of a
/// sphere and of a torus (the corner cases: real triangles, every Θ they
/// meet, the poles and the seam), then random triangles meeting a random Θ
/// with a random light, four pixels each at random barycentrics, alternating
/// (four and four) with random codes in every field.
///
/// # Errors
///
/// [`RtlError::Pipeline`] with the error of [`Pipeline::from_config`].
pub fn inputs(
    cfg: &Config,
    part: crate::rtl::units::Part,
    seed: u64,
) -> Result<Vec<Vec<i128>>, RtlError> {
    let path = path_of(cfg);
    // Building the pipeline (six coefficient sets, tables) costs more than
    // a chunk of random rows: keep the last one.
    type Last = Option<(String, std::sync::Arc<Pipeline>)>;
    static LAST: std::sync::Mutex<Last> = std::sync::Mutex::new(None);
    let key = cfg.to_toml();
    let cached = LAST
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .as_ref()
        .filter(|(k, _)| *k == key)
        .map(|(_, p)| p.clone());
    let p = match cached {
        Some(p) => p,
        None => {
            let p = std::sync::Arc::new(Pipeline::from_config(cfg)?);
            *LAST.lock().unwrap_or_else(|e| e.into_inner()) = Some((key, p.clone()));
            p
        }
    };
    let mut rng = Rng::new(seed);
    let mut rows = Vec::new();
    let Part::Random(count) = part else {
        for m in [
            crate::mesh::sphere(8, crate::mesh::Axis::Y),
            crate::mesh::torus(12, crate::mesh::Axis::Y),
        ] {
            rows.extend(render_rows(&p, path, &m, 12));
        }
        return Ok(rows);
    };
    let fields = p.fields(path);
    let light_code = |v: DVec3| {
        v.to_array()
            .map(|x| p.light.light.apply_f64(x).map_or(0, |r| r.code))
    };
    // As a renderer feeds it: a triangle (its set-up done once) and a light
    // for a few pixels, then as many random codes in every field.
    const PIXELS: usize = 4;
    let qb = |x: f64| p.interp.bary.apply_f64(x).map_or(0, |r| r.code);
    while rows.len() < count {
        let theta = THETA_LADDER[narrow::<usize, _>(rng.below(THETA_LADDER.len() as u64))];
        let n = crate::sampling::triangle_meeting(theta, &mut rng);
        let l = rng.direction();
        let h = (l + rng.direction()).normalize_or(DVec3::Z);
        match path {
            Path::Smooth => {
                let Ok(st) = p.setup_smooth(n) else { continue };
                let mut tail = Vec::with_capacity(24);
                for v in &st.v {
                    tail.extend_from_slice(v);
                }
                tail.extend_from_slice(&light_code(l));
                tail.extend_from_slice(&light_code(h));
                for _ in 0..PIXELS {
                    let c = rng.barycentric();
                    let mut r = vec![st.set as i128, qb(c[0]), qb(c[1])];
                    r.extend_from_slice(&tail);
                    rows.push(r);
                }
            }
            Path::Mapped => {
                let Ok(st) = p.setup_smooth(n) else { continue };
                let mt = p.setup_mapped(n);
                let (al, bl) = p.angle_codes(l);
                let (ah, bh) = p.angle_codes(h);
                for _ in 0..PIXELS {
                    let c = rng.barycentric();
                    let t = rng.in_cone(DVec3::Z, 0.6);
                    let tex = t
                        .to_array()
                        .map(|x| p.light.normal.apply_f64(x).map_or(0, |r| r.code));
                    rows.push(p.mapped_row([qb(c[0]), qb(c[1])], &st, &mt, [al, bl, ah, bh], tex));
                }
            }
        }
        for _ in 0..PIXELS {
            rows.push(
                fields
                    .iter()
                    .map(|f| structured_code(f.format, &mut rng))
                    .collect(),
            );
        }
    }
    rows.truncate(count);
    Ok(rows)
}
