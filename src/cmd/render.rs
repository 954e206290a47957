//! `fxshade render`: rasterize a mesh, run the bit-accurate pipeline (or the
//! simulated RTL top) on every pixel, and write the images, error heat-maps
//! and metrics against the f64 reference.

use fxshade_model::convert::{from_f64, narrow, to_f64};
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use fxshade_model::files::StagedDir;
use fxshade_model::mesh::Mesh;
use fxshade_model::pipeline::{Path, Pipeline};
use fxshade_model::render::{self, Frame, Metrics, RenderMethod};

use fxshade_model::Config;

use super::ConfigArgs;
use crate::output::{emit, OutputArgs, Table};
use crate::rtl_flow::{self, Sim};

/// `fxshade render`
#[derive(Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    /// The mesh: `sphere:N` or `torus:N` (N segments around, 4..=4096,
    /// built about y; `torus:N:z` about z), or a Wavefront OBJ file.
    #[arg(long, value_name = "PATH.obj|sphere:N|torus:N")]
    mesh: String,
    /// Image size.
    #[arg(long, value_name = "WxH", default_value = "256x256")]
    size: String,
    /// Methods, comma-separated: exact, none, newton, taylor, linear,
    /// quadratic (the normalizer on the smooth path); mapped (the normal-map
    /// path, angles of N by CORDIC), mapped-interp (angles interpolated per
    /// vertex), tbn (the conventional interpolated TBN transform with a
    /// normalization, no RTL); or all. Default: all; with --rtl, the ones
    /// the RTL implements (linear, quadratic, mapped, mapped-interp).
    #[arg(long, value_name = "M[,M…]")]
    method: Option<String>,
    /// Also run every pixel through the simulated RTL top
    /// (`rtl/pipeline_*.v`); the RTL image must equal the model's, bit for bit.
    #[arg(long)]
    rtl: bool,
    /// Simulator for --rtl.
    #[arg(long, value_enum, default_value_t = Sim::Verilator, requires = "rtl")]
    sim: Sim,
    /// Output directory (replaced as a whole when the render is complete).
    #[arg(long, short = 'o', value_name = "DIR")]
    out: PathBuf,
    /// Replace `--out` even when it holds files fxshade did not write.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    fmt: OutputArgs,
}

/// The scene flags (defaults: the module page of `fxshade_model::render`).
#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// Direction towards the light, world frame (normalized).
    #[arg(
        long,
        value_name = "X,Y,Z",
        default_value = "-0.45,0.6,0.66",
        allow_hyphen_values = true
    )]
    light: String,
    /// Direction towards the viewer, world frame (normalized); the image
    /// looks along its opposite.
    #[arg(
        long,
        value_name = "X,Y,Z",
        default_value = "0,0,1",
        allow_hyphen_values = true
    )]
    view: String,
    /// Tilt of the mesh about x before viewing, in degrees.
    #[arg(long, value_name = "DEG", default_value_t = render::TILT_DEG, allow_hyphen_values = true, value_parser = super::finite_f64)]
    tilt: f64,
    /// The mapped path's normal map: bumps (procedural), flat, or a
    /// tangent-space normal map image (RGB or RGBA PNG, 8 or 16 bits per
    /// channel) laid out by the mesh's texture coordinates.
    #[arg(long, value_name = "bumps|flat|FILE.png", default_value = "bumps")]
    normal_map: String,
    /// The frame an image map was baked in: `implied` (the polar
    /// transform's, e.g. from `fxshade bake-implied`) or `uv` (UV-aligned,
    /// MikkTSpace-style: converted for the mapped path, and the original
    /// rendered in f64 with the UV frame beside it for comparison).
    /// Default: implied.
    #[arg(long, value_name = "FRAME", value_parser = ["implied", "uv"])]
    normal_map_frame: Option<String>,
    /// Green convention of an image map: opengl (+y up) or directx (+y
    /// down). Default: opengl.
    #[arg(long, value_name = "CONV", value_parser = ["opengl", "directx"])]
    green: Option<String>,
}

fn parse_vec3(flag: &str, s: &str) -> anyhow::Result<glam::DVec3> {
    let bad = || {
        crate::output::UsageError(format!(
            "--{flag} {s}: write X,Y,Z with three finite numbers"
        ))
    };
    let v: Vec<f64> = s
        .split(',')
        .map(super::finite_f64)
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    if v.len() != 3 {
        return Err(bad().into());
    }
    Ok(glam::DVec3::new(v[0], v[1], v[2]))
}

impl SceneArgs {
    /// The scene the flags describe.
    pub fn scene(&self) -> anyhow::Result<render::Scene> {
        // A light or view the scene cannot use is a bad flag (status 2).
        render::Scene::new(
            parse_vec3("light", &self.light)?,
            parse_vec3("view", &self.view)?,
            self.tilt,
            self.map()?,
        )
        .map_err(|e| crate::output::UsageError(e.to_string()).into())
    }
    fn map(&self) -> anyhow::Result<render::NormalMap> {
        if let Some(m) = render::NormalMap::ALL
            .iter()
            .find(|m| m.name() == self.normal_map)
        {
            if self.normal_map_frame.is_some() || self.green.is_some() {
                bail!(
                    "--normal-map-frame and --green describe an image map; --normal-map {} is procedural",
                    self.normal_map
                );
            }
            return Ok(m.clone());
        }
        let path = std::path::Path::new(&self.normal_map);
        if !path.exists() {
            bail!(
                "--normal-map {}: no such file; give bumps, flat or a PNG file",
                self.normal_map
            );
        }
        let green =
            fxshade_model::texture::Green::from_name(self.green.as_deref().unwrap_or("opengl"))
                .expect("clap checked");
        let texture = crate::picture::read_normal_map(path, green)?;
        Ok(render::NormalMap::Image(std::sync::Arc::new(
            render::MapImage {
                name: self.normal_map.clone(),
                texture,
                frame: if self.normal_map_frame.as_deref() == Some("uv") {
                    render::MapFrame::Uv
                } else {
                    render::MapFrame::Implied
                },
                green,
            },
        )))
    }
}

pub use fxshade_flows::scene::load_mesh;

/// `WxH`.
pub fn parse_size(s: &str) -> anyhow::Result<(usize, usize)> {
    let bad = || format!("--size {s}: write WxH with W and H whole numbers in 1..=4096");
    let (w, h) = s.split_once(['x', 'X']).with_context(bad)?;
    let w: usize = w
        .trim()
        .parse()
        .ok()
        .filter(|v| (1..=4096).contains(v))
        .with_context(bad)?;
    let h: usize = h
        .trim()
        .parse()
        .ok()
        .filter(|v| (1..=4096).contains(v))
        .with_context(bad)?;
    Ok((w, h))
}

/// The methods of `--method`.
pub fn parse_methods(s: Option<&str>, rtl: bool) -> anyhow::Result<Vec<RenderMethod>> {
    let Some(s) = s.filter(|s| *s != "all") else {
        return Ok(if rtl {
            RenderMethod::RTL.to_vec()
        } else {
            RenderMethod::ALL.to_vec()
        });
    };
    let names = || {
        RenderMethod::ALL
            .iter()
            .map(|m| m.name())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut v = Vec::new();
    for name in s.split(',').map(str::trim) {
        let m = RenderMethod::from_name(name)
            .with_context(|| format!("--method {name}: unknown; methods: {}, all", names()))?;
        if rtl && !RenderMethod::RTL.contains(&m) {
            bail!(
                "--method {name} with --rtl: the RTL implements linear, quadratic, mapped and mapped-interp only"
            );
        }
        if !v.contains(&m) {
            v.push(m);
        }
    }
    Ok(v)
}

/// What the RTL run of one method gave.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RtlOutcome {
    /// Simulator.
    pub sim: Sim,
    /// The RTL image equals the model image, pixel for pixel.
    pub identical: bool,
    /// Pixels that differ.
    pub differing_pixels: usize,
    /// The testbench's own verdict against the model's levels.
    pub passed: u64,
    /// The same, failed.
    pub failed: u64,
    /// Seconds simulating (build included).
    pub seconds: f64,
    /// Clock cycles the simulation took for every pixel (no stalls; with
    /// set-up ports, each triangle's set-up transfer and its drain
    /// included): cycles per pixel is the top's throughput on this mesh.
    pub cycles: Option<u64>,
}

/// One method's result.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MethodResult {
    /// Method name.
    pub method: &'static str,
    /// Path.
    pub path: Path,
    /// Metrics against the reference of its path.
    #[serde(flatten)]
    pub metrics: Metrics,
    /// Mapped methods: the metrics outside the polar cap (pixels whose
    /// normal is more than `polar_cap_deg` from the y axis).
    pub outside_cap: Option<Metrics>,
    /// Mapped methods: the metrics inside the polar cap alone.
    pub cap: Option<Metrics>,
    /// The image file.
    pub image: String,
    /// The heat-map file.
    pub heatmap: String,
    /// The RTL run, with --rtl.
    pub rtl: Option<RtlOutcome>,
}

/// A render's results.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RenderResult {
    /// The mesh spec.
    pub mesh: String,
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Covered pixels.
    pub pixels: usize,
    /// Pixels of triangles whose normals could not be set up (black, and
    /// left out of every metric).
    pub skipped_pixels: usize,
    /// Those triangles (1-based, with the OBJ line of their face).
    pub skipped_triangles: Vec<String>,
    /// The scene.
    pub scene: render::Scene,
    /// `cos φ` over the mesh's triangles.
    pub cos_phi: render::CosPhiStats,
    /// Per method.
    pub methods: Vec<MethodResult>,
    /// What interpolating the polar angles costs (mapped path, f64 both).
    pub angle_interp: Option<Metrics>,
    /// The conventional baseline (interpolated TBN, exact normalization) in
    /// f64 against the mapped reference.
    pub tbn_f64: Option<Metrics>,
    /// With an image map in the UV frame: what converting it into the
    /// implied frame did, texel by texel.
    pub normal_map_bake: Option<fxshade_model::texture::BakeCounts>,
    /// With such a map: the mapped path (bit-accurate, converted map, polar
    /// transform) against the original map rendered in f64 with the exact
    /// UV-aligned frame, over the pixels whose texel converted cleanly and
    /// that lie outside the polar cap.
    pub uv_frame_check: Option<Metrics>,
    /// Pixels that comparison leaves out (seams, ambiguous or unused
    /// texels, the polar cap).
    pub uv_frame_excluded: usize,
    /// The polar cap's half-angle, degrees.
    pub polar_cap_deg: f64,
    /// Pixels inside the polar cap.
    pub polar_cap_pixels: usize,
    /// Reference images written.
    pub references: Vec<String>,
    /// Seconds.
    pub seconds: f64,
}

/// Render `m` into `dir` under `prefix` (e.g. `render/sphere_16/`).
#[allow(clippy::too_many_arguments)]
pub fn render_into(
    cfg: &Config,
    scene: &render::Scene,
    spec: &str,
    m: &Mesh,
    (w, h): (usize, usize),
    methods: &[RenderMethod],
    rtl: Option<Sim>,
    dir: &StagedDir,
    prefix: &str,
    progress: &mut dyn FnMut(&str),
) -> anyhow::Result<RenderResult> {
    let start = Instant::now();
    progress("rasterizing");
    let base = Pipeline::with_method(cfg, fxshade_model::normalizer::Method::None)?;
    let raster = render::rasterize_in(scene, m, w, h);
    // Without the RTL, rows are made and shaded a chunk at a time and never
    // kept (memory in proportion to the image); the RTL needs them whole.
    let (f, mut streamed) = if rtl.is_none() {
        let (f, levels) = render::levels_streamed(cfg, scene, &base, raster, m, methods)?;
        (f, Some(levels))
    } else {
        let want = render::Wanted::methods(methods);
        (render::frame_wanted(scene, &base, raster, m, want), None)
    };
    let png = |name: &str, levels: &[u8]| -> anyhow::Result<String> {
        let img = render::to_image(&f.raster, levels, 0u8);
        let file = format!("{prefix}{name}.png");
        dir.write(&file, &crate::picture::gray_png(w, h, &img)?)?;
        Ok(file)
    };
    let heat = |name: &str, got: &[u8], want: &[f64]| -> anyhow::Result<String> {
        let errs: Vec<Option<u32>> = got
            .iter()
            .zip(want)
            .map(|(&g, &r)| {
                (!r.is_nan()).then(|| from_f64::<u32>((f64::from(g) - r.round()).abs()))
            })
            .collect();
        let img = render::to_image(&f.raster, &errs, None);
        let file = format!("{prefix}{name}.png");
        dir.write(&file, &crate::picture::heatmap_png(w, h, &img)?)?;
        Ok(file)
    };
    let mut references = vec![png("reference", &render::reference_levels(&f.smooth_ref))?];
    let mut angle_interp = None;
    let mut tbn_f64 = None;
    if methods.iter().any(|m| m.is_mapped()) {
        references.push(png(
            "reference_mapped",
            &render::reference_levels(&f.mapped_ref),
        )?);
        let li = render::reference_levels(&f.mapped_interp_ref);
        angle_interp = Some(Metrics::compare(&li, &f.mapped_ref));
        references.push(heat("angle_interp_error", &li, &f.mapped_ref)?);
        let lt = render::reference_levels(&f.tbn_ref);
        tbn_f64 = Some(Metrics::compare(&lt, &f.mapped_ref));
        references.push(heat("tbn_f64_error", &lt, &f.mapped_ref)?);
    }
    let mut uv_frame_check = None;
    if !f.uv_ref.is_empty() {
        references.push(png("reference_uv", &render::reference_levels(&f.uv_ref))?);
    }
    let mut results = Vec::new();
    for (k, &method) in methods.iter().enumerate() {
        progress(method.name());
        let img = match &mut streamed {
            Some(levels) => render::image_of(&f, method, std::mem::take(&mut levels[k])),
            None => render::run_method(cfg, &f, method)?,
        };
        let want = f.reference(method);
        let image = png(method.name(), &img.levels)?;
        if method == RenderMethod::Mapped(fxshade_model::pipeline::AngleSource::Cordic)
            && !f.uv_ref.is_empty()
        {
            uv_frame_check = Some(Metrics::compare_where(&img.levels, &f.uv_ref, |k| {
                !f.uv_excluded[k]
            }));
            let masked: Vec<f64> = f
                .uv_ref
                .iter()
                .zip(&f.uv_excluded)
                .map(|(&r, &x)| if x { f64::NAN } else { r })
                .collect();
            references.push(heat("mapped_vs_uv_error", &img.levels, &masked)?);
        }
        let heatmap = heat(&format!("{}_error", method.name()), &img.levels, want)?;
        let rtl = match rtl {
            None => None,
            Some(sim) => {
                progress(&format!("{} on {sim:?}", method.name()).to_lowercase());
                let (out, levels) = run_rtl(cfg, &f, method, sim)?;
                png(&format!("{}_rtl", method.name()), &levels)?;
                Some(out)
            }
        };
        results.push(MethodResult {
            method: method.name(),
            path: method.path(),
            metrics: img.metrics,
            outside_cap: img.outside_cap,
            cap: img.cap,
            image,
            heatmap,
            rtl,
        });
    }
    Ok(RenderResult {
        mesh: spec.to_string(),
        width: w,
        height: h,
        pixels: f.raster.fragments.len(),
        skipped_pixels: f.skipped,
        skipped_triangles: f
            .skipped_triangles
            .iter()
            .map(|&t| m.describe_triangle(t))
            .collect(),
        scene: scene.clone(),
        cos_phi: render::cos_phi_stats(m),
        methods: results,
        angle_interp,
        tbn_f64,
        normal_map_bake: f.bake,
        uv_frame_check,
        uv_frame_excluded: f.uv_excluded.iter().filter(|&&x| x).count(),
        polar_cap_deg: render::POLAR_CAP_DEG,
        polar_cap_pixels: f.polar_cap.iter().filter(|&&c| c).count(),
        references,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Run a method's pixels through the simulated RTL top; the outcome and the
/// RTL's levels per fragment.
fn run_rtl(
    cfg: &Config,
    f: &Frame,
    method: RenderMethod,
    sim: Sim,
) -> anyhow::Result<(RtlOutcome, Vec<u8>)> {
    let start = Instant::now();
    let mut c = cfg.clone();
    let path = method.path();
    c.apply_override(&format!("pipeline.path=\"{}\"", path.name()))?;
    match method {
        RenderMethod::Smooth(m) => {
            c.apply_override(&format!("normalize.method=\"{}\"", m.name()))?;
        }
        RenderMethod::Mapped(src) => {
            c.apply_override(&format!("pipeline.angles=\"{}\"", src.name()))?;
        }
        RenderMethod::Tbn => bail!("the conventional baseline (tbn) has no RTL"),
    }
    let p = fxshade_model::pipeline::Pipeline::from_config(&c)?;
    let design = fxshade_model::pipeline::RTL.design(&c)?;
    let emitted = fxshade_model::rtl::emit(&design)?;
    let rows = f.rows(method);
    let live: Vec<usize> = (0..rows.len()).filter(|&i| rows.is_live(i)).collect();
    if live.is_empty() {
        bail!("no pixel of the mesh could be shaded: nothing to simulate");
    }
    // With set-up ports, pixels of one triangle go together (the raster
    // order interleaves triangles), so the testbench sends each triangle's
    // set-up once.
    let setup_cols: Vec<usize> = emitted
        .inputs
        .iter()
        .enumerate()
        .filter(|(_, f)| emitted.setup.iter().any(|g| g.fields.contains(&f.name)))
        .map(|(k, _)| k)
        .collect();
    let mut live = live;
    // Every index in `live` is a live row.
    let row = |i: usize| rows.get(i).unwrap_or_default();
    if !setup_cols.is_empty() {
        live.sort_by_key(|&i| setup_cols.iter().map(|&k| row(i)[k]).collect::<Vec<_>>());
    }
    let input_rows: Vec<Vec<i128>> = live.iter().map(|&i| row(i).to_vec()).collect();
    // The model's level codes (not pixels: the comparison is bit for bit in
    // the level format).
    let model = p.run_rows(path, &input_rows)?;
    let fl = p.light.level.format();
    let v = fxshade_model::rtl::units::vector_set(&design, &emitted, input_rows, 0, 1)?;
    anyhow::ensure!(
        v.output_rows
            .iter()
            .zip(&model)
            .all(|(r, m)| r.last() == Some(m)),
        "the compiled trace and the pipeline model disagree"
    );
    let r = rtl_flow::check_with(
        &v,
        &rtl_flow::Sources::emitted(&v.rtl),
        sim,
        1,
        0,
        None,
        true,
    )?;
    let mut levels = vec![0u8; rows.len()];
    let mut differing = live.len().abs_diff(r.outputs.len());
    for (k, &i) in live.iter().enumerate() {
        // A line with x or z bits does not parse: it differs.
        let got = r
            .outputs
            .get(k)
            .and_then(|h| u128::from_str_radix(h, 16).ok())
            .map(|b| fl.from_bits(narrow::<u64, _>(b & ((1u128 << fl.width()) - 1))));
        match got {
            Some(g) => {
                levels[i] = render::pixel_of(fl, g);
                if g != model[k] {
                    differing += 1;
                }
            }
            None => differing += 1,
        }
    }
    Ok((
        RtlOutcome {
            sim,
            identical: differing == 0,
            differing_pixels: differing,
            passed: r.passed,
            failed: r.failed,
            seconds: start.elapsed().as_secs_f64(),
            cycles: r.cycles,
        },
        levels,
    ))
}

/// The metrics table of a render.
pub fn table(r: &RenderResult) -> Table {
    let mut t = Table::new([
        "method",
        "path",
        "max |err| (levels)",
        "mean |err|",
        "PSNR (dB)",
        "off by 0",
        "1",
        "2",
        "more",
        "max rel. err",
        "under 4 %",
        "RTL image",
    ])
    .titled(format!(
        "{} at {}×{}: {} pixels{}; cos φ over {} triangles: min {:.4}, mean {:.4}",
        r.mesh,
        r.width,
        r.height,
        r.pixels,
        if r.skipped_pixels > 0 {
            format!(
                " ({} skipped: triangles whose vertex normals cannot be interpolated, left out of every metric)",
                r.skipped_pixels
            )
        } else {
            String::new()
        },
        r.cos_phi.triangles,
        r.cos_phi.min,
        r.cos_phi.mean
    ));
    let pct = |x: f64| format!("{:.2} %", 100.0 * x);
    let mut row = |name: &str, path: &str, m: &Metrics, rtl: String| {
        t.row([
            name.to_string(),
            path.to_string(),
            m.max_abs_levels.to_string(),
            format!("{:.4}", m.mean_abs_levels),
            if m.pixels == 0 {
                "-".into()
            } else {
                m.psnr_db.map_or("∞".into(), |p| format!("{p:.2}"))
            },
            pct(m.off_by[0]),
            pct(m.off_by[1]),
            pct(m.off_by[2]),
            pct(m.off_by[3]),
            format!("{:.3} %", 100.0 * m.max_rel_intensity_err),
            if m.pixels == 0 {
                "no pixel compared"
            } else if m.paper_bound_holds {
                "yes"
            } else {
                "no"
            }
            .to_string(),
            rtl,
        ]);
    };
    for m in &r.methods {
        let rtl = match &m.rtl {
            None => "-".to_string(),
            Some(o) if o.identical => format!("identical ({:?})", o.sim).to_lowercase(),
            Some(o) => format!("{} pixels differ ({:?})", o.differing_pixels, o.sim).to_lowercase(),
        };
        row(m.method, m.path.name(), &m.metrics, rtl.clone());
        if let (Some(o), Some(c)) = (&m.outside_cap, &m.cap) {
            row(
                &format!("  {}, outside the {}° polar cap", m.method, r.polar_cap_deg),
                "mapped",
                o,
                "-".into(),
            );
            row(
                &format!("  {}, inside the cap ({} px)", m.method, r.polar_cap_pixels),
                "mapped",
                c,
                "-".into(),
            );
        }
    }
    if let Some(a) = &r.angle_interp {
        row("angle_interp (f64)", "mapped", a, "-".into());
    }
    if let Some(a) = &r.tbn_f64 {
        row("tbn (f64)", "mapped", a, "-".into());
    }
    if let Some(a) = &r.uv_frame_check {
        row(
            &format!(
                "mapped vs the UV-frame original (f64; {} px left out)",
                r.uv_frame_excluded
            ),
            "mapped",
            a,
            "-".into(),
        );
    }
    t
}

/// The `cos φ` distribution table.
pub fn cos_phi_table(r: &RenderResult) -> Table {
    let mut t = Table::new(["Θ met (largest)", "triangles", "share"]).titled(format!(
        "{}: cos φ per triangle (min {:.4}, mean {:.4}, max {:.4}; {} degenerate)",
        r.mesh, r.cos_phi.min, r.cos_phi.mean, r.cos_phi.max, r.cos_phi.degenerate
    ));
    let n = to_f64(r.cos_phi.triangles.max(1));
    for &(th, k) in &r.cos_phi.by_theta {
        t.row([
            if th < 0.0 {
                "none (cos φ < 0)".to_string()
            } else {
                format!("{th}")
            },
            k.to_string(),
            format!("{:.1} %", 100.0 * to_f64(k) / n),
        ]);
    }
    t
}

/// Run it.
pub fn run(a: &RenderArgs) -> anyhow::Result<()> {
    let cfg = a.cfg.resolve()?;
    let size = parse_size(&a.size)?;
    let methods = parse_methods(a.method.as_deref(), a.rtl)?;
    let scene = a.scene.scene()?;
    let m = load_mesh(&a.mesh)?;
    if let render::NormalMap::Image(img) = &scene.normal_map {
        fxshade_model::texture::check_layout(&m).map_err(|e| {
            anyhow::anyhow!("--mesh {} with --normal-map {}: {e}", a.mesh, img.name)
        })?;
        if img.frame == render::MapFrame::Uv
            && !methods.contains(&RenderMethod::Mapped(
                fxshade_model::pipeline::AngleSource::Cordic,
            ))
        {
            bail!("--normal-map-frame uv compares the mapped method with the UV-frame original: include mapped in --method");
        }
    }
    let dir = if a.force {
        StagedDir::new_forced(&a.out)
    } else {
        StagedDir::new(&a.out)
    }
    .with_context(|| format!("cannot write the render to {}", a.out.display()))?;
    let bar = crate::progress::bar(methods.len() as u64 * (1 + u64::from(a.rtl)) + 1, "render");
    let r = render_into(
        &cfg,
        &scene,
        &a.mesh,
        &m,
        size,
        &methods,
        a.rtl.then_some(a.sim),
        &dir,
        "",
        &mut |what| {
            bar.set_message(what.to_string());
            bar.inc(1);
        },
    )?;
    bar.finish_and_clear();
    if !r.skipped_triangles.is_empty() {
        let list: Vec<&str> = r
            .skipped_triangles
            .iter()
            .take(10)
            .map(|t| t.as_str())
            .collect();
        eprintln!(
            "warning: {} pixels of {} triangle(s) skipped, and left out of every metric (vertex normals antiparallel: they cannot be interpolated): {}{}",
            r.skipped_pixels,
            r.skipped_triangles.len(),
            list.join(", "),
            if r.skipped_triangles.len() > 10 { ", …" } else { "" }
        );
    }
    let t = table(&r);
    let ct = cos_phi_table(&r);
    dir.write("render.json", serde_json::to_string_pretty(&r)?.as_bytes())?;
    dir.write("metrics.csv", t.to_csv()?.as_bytes())?;
    dir.write("cos_phi.csv", ct.to_csv()?.as_bytes())?;
    let out = dir.commit()?;
    emit(a.fmt, &[t, ct], &serde_json::to_value(&r)?)?;
    if !a.fmt.json && !a.fmt.csv {
        crate::output::print_out(&format!("images written to {}\n", out.display()))?;
    }
    if let Some(bad) = r
        .methods
        .iter()
        .find(|m| m.rtl.as_ref().is_some_and(|o| !o.identical))
    {
        let o = bad.rtl.as_ref().expect("checked");
        bail!(
            "the RTL image of {} differs from the model's in {} pixels",
            bad.method,
            o.differing_pixels
        );
    }
    Ok(())
}
