//! The pipeline's RTL side: the parameter headers of `rtl/pipeline.v` and of
//! every unit it instantiates (generated together, so they agree), and test
//! vectors: pixels of small rendered meshes, random triangles, random codes.

use glam::DVec3;

use super::{Path, Pipeline, DECL, SEL_BITS};
use crate::config::Config;
use crate::interp::THETA_LADDER;
use crate::lighting::Lighting;
use crate::normalizer::Method;
use crate::quantize::Rounding;
use crate::sampling::Rng;
use crate::vectors::{
    check_rtl_stages, header_preamble, stage_params, structured_code, Field, ParamsHeader,
    RtlError, VectorSet,
};

/// `lighting_params.vh`: the formats and constants of `rtl/lighting.v`.
pub fn lighting_header(cfg: &Config, l: &Lighting) -> Result<String, RtlError> {
    check_rtl_stages(
        &l.count_shade(),
        &[
            ("normal", l.normal.format()),
            ("light", l.light.format()),
            ("dot", l.dot.format()),
            ("spec", l.spec.format()),
            ("gain", l.gain.format()),
            ("level", l.level.format()),
        ],
    )
    .map_err(|(stage, why)| RtlError::Stage {
        unit: "lighting",
        stage,
        why,
    })?;
    let mut t = header_preamble(
        "lighting_params.vh",
        "lighting",
        DECL.name,
        cfg,
        &format!(
            "Diffuse I0·km = {} and specular I0·ks = {}, exponent {}",
            l.i0_km, l.i0_ks, l.shininess
        ),
    );
    t += &stage_params("LN", &l.normal, false);
    t += &stage_params("LL", &l.light, false);
    t += &stage_params("DT", &l.dot, true);
    t += &stage_params("SP", &l.spec, true);
    t += &stage_params("GN", &l.gain, false);
    t += &stage_params("LV", &l.level, true);
    t += &format!(
        "localparam integer SHIN = {}, NB = {};\n",
        l.shininess,
        l.power_stages()
    );
    let gf = l.gain.format();
    for (name, v) in [
        ("GAIN_D", crate::lighting::LEVELS * l.i0_km),
        ("GAIN_S", crate::lighting::LEVELS * l.i0_ks),
    ] {
        let code = l.gain.apply_f64(v)?.code;
        t += &format!(
            "localparam [GN_W-1:0] {name} = {}'h{:0w$x};  // {}\n",
            gf.width(),
            gf.to_bits(code),
            gf.to_f64(code),
            w = gf.hex_digits()
        );
    }
    Ok(t)
}

/// The parameter headers for a configuration: `pipeline_params.vh`, with
/// `interp_params.vh`, `normalize_params.vh` (one coefficient set per Θ of
/// the ladder), `polar_params.vh` and its ROM images, and
/// `lighting_params.vh` as extra files.
pub fn params_header(cfg: &Config) -> Result<(Pipeline, Path, ParamsHeader), RtlError> {
    let path = Path::from_name(cfg.unit(DECL.name).choice("path")).expect("declared");
    // The mapped path does not use the normalizer, but its Verilog is
    // compiled with the rest: give it a method the RTL implements.
    let mut ncfg = cfg.clone();
    let nmethod = Method::from_name(cfg.unit(crate::normalizer::DECL.name).choice("method"))
        .expect("declared");
    if path == Path::Mapped && nmethod != Method::Linear && nmethod != Method::Quadratic {
        ncfg.apply_override("normalize.method=\"quadratic\"")
            .expect("a declared choice");
    }
    let p = Pipeline::from_config(&ncfg).map_err(pipeline_error)?;
    let (_, _, nh) = crate::normalizer::rtl::params_header(&ncfg)?;
    let sets: Vec<(String, Vec<f64>)> = p
        .sets
        .iter()
        .zip(THETA_LADDER)
        .map(|(n, th)| (format!("Θ = {th}"), n.coeffs.clone()))
        .collect();
    let cut = nh
        .text
        .find("localparam integer NSETS")
        .expect("the normalizer header ends with its coefficient table");
    let ntext = nh.text[..cut].to_string()
        + &crate::normalizer::rtl::coef_table(p.sets[0].q.coef.format(), &sets)?;
    let (_, ih) = crate::interp::rtl::params_header(cfg)?;
    let (_, ph) = crate::polar::rtl::params_header(cfg)?;
    let lh = lighting_header(cfg, &p.light)?;
    for cx in [p.count(Path::Smooth)?, p.count(Path::Mapped)?] {
        check_rtl_stages(&cx, &[("angle", p.angle.format())]).map_err(|(stage, why)| {
            RtlError::Stage {
                unit: "pipeline",
                stage,
                why,
            }
        })?;
    }
    let fields = p.fields(path);
    let pix_w: u32 = fields.iter().map(|f| f.format.width()).sum();
    let nz = &p.sets[0].q;
    let mut t = header_preamble(
        "pipeline_params.vh",
        "pipeline",
        DECL.name,
        cfg,
        &format!(
            "Path: {}; normalizer {} with {} coefficient sets (Θ = {:?})",
            path.name(),
            p.method.name(),
            THETA_LADDER.len(),
            THETA_LADDER
        ),
    );
    t += &format!(
        "localparam integer PATH = {}, PIX_W = {pix_w}, SEL_W = {SEL_BITS};\n",
        (path == Path::Mapped) as u8
    );
    t += &stage_params("B", &p.interp.bary, false);
    t += &format!(
        "localparam integer V_W = {}, LV_W = {};\n",
        p.interp.vertex.format().width(),
        p.light.level.format().width()
    );
    t += &stage_params("IO", &p.interp.out, false);
    t += &stage_params("NN", &nz.normal, true);
    t += &stage_params("NO", &nz.out, false);
    t += &stage_params("LN", &p.light.normal, true);
    t += &stage_params("LL", &p.light.light, true);
    t += &stage_params("PO", &p.polar.out, false);
    let r = match p.angle.round() {
        Rounding::Trunc => 0,
        Rounding::HalfUp => 1,
        Rounding::HalfEven => 2,
    };
    t += &format!(
        "localparam integer K = {}, A_R = {r};\n",
        p.angle.format().width()
    );
    let mut extra = vec![
        ("interp_params.vh".to_string(), ih.text),
        ("normalize_params.vh".to_string(), ntext),
        ("polar_params.vh".to_string(), ph.text),
        ("lighting_params.vh".to_string(), lh),
    ];
    extra.extend(ph.extra);
    Ok((
        p,
        path,
        ParamsHeader {
            name: "pipeline_params.vh".into(),
            text: t,
            extra,
        },
    ))
}

fn pipeline_error(e: super::PipelineError) -> RtlError {
    use super::PipelineError as E;
    match e {
        E::Design(d) => RtlError::Design(d),
        E::Polar(p) => RtlError::Polar(p),
        E::Convert(c) => RtlError::Convert(c),
        other => RtlError::Stage {
            unit: "pipeline",
            stage: "datapath",
            why: other.to_string(),
        },
    }
}

/// Input rows of `path` for the pixels of a small render of `mesh`.
pub fn render_rows(
    p: &Pipeline,
    path: Path,
    mesh: &crate::mesh::Mesh,
    size: usize,
) -> Vec<Vec<i128>> {
    let r = crate::render::rasterize(mesh, size, size);
    let f = crate::render::frame(p, r, mesh);
    let rows = match path {
        Path::Smooth => f.smooth_rows,
        Path::Mapped => f.mapped_rows,
    };
    rows.into_iter().filter(|r| !r.is_empty()).collect()
}

/// Test vectors of the configured path: the pixels of a 12 × 12 render of a
/// sphere and of a torus (the corner cases: real triangles, every Θ they
/// meet, the poles and the seam), then random triangles meeting a random Θ
/// with random barycentrics and random light directions, alternating with
/// random codes in every field.
pub fn vectors(cfg: &Config, count: usize, seed: u64) -> Result<VectorSet, RtlError> {
    let (p, path, params) = params_header(cfg)?;
    let mut rng = Rng::new(seed);
    let mut rows = Vec::new();
    for m in [
        crate::mesh::sphere(8, crate::mesh::Axis::Y),
        crate::mesh::torus(12, crate::mesh::Axis::Y),
    ] {
        rows.extend(render_rows(&p, path, &m, 12));
    }
    let corners = rows.len();
    if count < corners {
        return Err(RtlError::Count { count, corners });
    }
    let fields = p.fields(path);
    let light_code = |v: DVec3| {
        v.to_array()
            .map(|x| p.light.light.apply_f64(x).map_or(0, |r| r.code))
    };
    while rows.len() < count {
        if rows.len() % 2 == 0 {
            let theta = THETA_LADDER[rng.below(THETA_LADDER.len() as u64) as usize];
            let n = crate::sampling::triangle_meeting(theta, &mut rng);
            let c = rng.barycentric();
            let qb = |x: f64| p.interp.bary.apply_f64(x).map_or(0, |r| r.code);
            let l = rng.direction();
            let h = (l + rng.direction()).normalize_or(DVec3::Z);
            let row = match path {
                Path::Smooth => {
                    let Ok(st) = p.setup_smooth(n) else { continue };
                    let mut r = vec![st.set as i128, qb(c[0]), qb(c[1])];
                    for v in &st.v {
                        r.extend_from_slice(v);
                    }
                    r.extend_from_slice(&light_code(l));
                    r.extend_from_slice(&light_code(h));
                    r
                }
                Path::Mapped => {
                    let mt = p.setup_mapped(n);
                    let mut r = vec![qb(c[0]), qb(c[1])];
                    r.extend_from_slice(&mt.a);
                    r.extend_from_slice(&mt.b);
                    let (al, bl) = p.angle_codes(l);
                    let (ah, bh) = p.angle_codes(h);
                    r.extend_from_slice(&[al, bl, ah, bh]);
                    let t = rng.in_cone(DVec3::Z, 0.6);
                    r.extend(
                        t.to_array()
                            .map(|x| p.light.normal.apply_f64(x).map_or(0, |r| r.code)),
                    );
                    r
                }
            };
            rows.push(row);
        } else {
            rows.push(
                fields
                    .iter()
                    .map(|f| structured_code(f.format, &mut rng))
                    .collect(),
            );
        }
    }
    let levels = p.run_rows(path, &rows).map_err(pipeline_error)?;
    Ok(VectorSet {
        unit: DECL.name,
        variant: match path {
            Path::Smooth => format!("smooth ({} g)", p.method.name()),
            Path::Mapped => "mapped".into(),
        },
        config_source: cfg.source.clone(),
        config_toml: cfg.to_toml(),
        seed,
        inputs: fields,
        outputs: vec![Field::new("level", p.light.level.format())],
        output_rows: levels.into_iter().map(|l| vec![l]).collect(),
        input_rows: rows,
        params,
        corner_cases: corners,
    })
}
