//! `fxshade bench render`: the renderer's cost per covered pixel beside a
//! simple f64 shader of the same image, in one run.
//!
//! Both start from the same raster (rasterizing is timed on its own). The
//! renderer runs what `fxshade render` runs for one method without the RTL
//! ([`render::levels_streamed`]: triangle set-up, input rows quantized
//! chunk by chunk, the bit-accurate pipeline, the f64 references, then the
//! metrics); the baseline shades every fragment in f64 the plain way: the
//! vertex normals interpolated linearly by the fragment's barycentrics,
//! normalized, Blinn-Phong with the same light and lighting constants
//! ([`render::shade_f64`]), rounded to a level. Times are process CPU
//! seconds (user + system), the median of `--repeats` alternated runs;
//! the peak resident memory is the process's after the renderer ran (the
//! baseline allocates one level per fragment).

use fxshade_model::convert::{from_f64, to_f64};
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use fxshade_model::render::{self, RenderMethod};

use crate::output::{emit, OutputArgs, Table};

/// Options of `bench render`.
#[derive(Args, Debug)]
pub struct RenderBenchArgs {
    /// Mesh (as `render --mesh`).
    #[arg(long, default_value = "torus:48")]
    mesh: String,
    /// Image size WxH.
    #[arg(long, default_value = "1024x1024")]
    size: String,
    /// Method (as `render --method`).
    #[arg(long, default_value = "quadratic")]
    method: String,
    /// Alternated runs of each (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    #[command(flatten)]
    cfg: super::ConfigArgs,
    #[command(flatten)]
    out: OutputArgs,
}

/// CPU seconds of this process so far (user + system).
pub(super) fn cpu_now() -> f64 {
    // SAFETY: a zeroed rusage is a valid out-parameter.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: RUSAGE_SELF with a valid pointer.
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) };
    let tv = |t: libc::timeval| to_f64(t.tv_sec) + to_f64(t.tv_usec) * 1e-6;
    tv(ru.ru_utime) + tv(ru.ru_stime)
}

fn max_rss_mib() -> f64 {
    // SAFETY: as in `cpu_now`.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: RUSAGE_SELF with a valid pointer.
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) };
    to_f64(ru.ru_maxrss) / 1024.0
}

/// CPU and wall seconds of `f`.
fn measure<T>(f: impl FnOnce() -> T) -> (f64, f64, T) {
    let (c0, t0) = (cpu_now(), Instant::now());
    let r = f();
    (cpu_now() - c0, t0.elapsed().as_secs_f64(), r)
}

pub(super) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Run `bench render`.
pub fn run(a: &RenderBenchArgs) -> anyhow::Result<()> {
    let cfg = a.cfg.resolve()?;
    let mesh = super::render::load_mesh(&a.mesh)?;
    let (w, h) = super::render::parse_size(&a.size)?;
    let methods = super::render::parse_methods(Some(&a.method), false)?;
    anyhow::ensure!(
        methods.len() == 1,
        "--method names one method (bench render measures one)"
    );
    let method: RenderMethod = methods[0];
    let scene = render::Scene::default();
    let base = fxshade_model::pipeline::Pipeline::with_method(
        &cfg,
        fxshade_model::normalizer::Method::None,
    )?;
    let (raster_cpu, _, raster) = measure(|| render::rasterize_in(&scene, &mesh, w, h));
    let n = raster.fragments.len();
    anyhow::ensure!(n > 0, "{} covers no pixel at {w}x{h}", a.mesh);
    let l = scene.light_camera();
    let hv = (l + glam::DVec3::Z).normalize();
    let (mut fx, mut fx_wall, mut base_cpu, mut base_wall) = (vec![], vec![], vec![], vec![]);
    let mut rss = 0.0;
    let mut checksum = 0u64;
    for _ in 0..a.repeats.max(1) {
        let r = raster.clone();
        let (c, t, out) = measure(|| -> anyhow::Result<u64> {
            let (f, mut levels) = render::levels_streamed(&cfg, &scene, &base, r, &mesh, &[method])
                .context("rendering")?;
            let img = render::image_of(&f, method, std::mem::take(&mut levels[0]));
            Ok(img.levels.iter().map(|&x| u64::from(x)).sum::<u64>() + img.metrics.pixels as u64)
        });
        checksum ^= out?;
        fx.push(c);
        fx_wall.push(t);
        rss = max_rss_mib();
        let (c, t, sum) = measure(|| {
            let levels: Vec<u8> = raster
                .fragments
                .iter()
                .map(|fr| {
                    let t = mesh.triangles[fr.tri];
                    let nv = t.map(|i| raster.normals[i as usize]);
                    let nn = (nv[0] * fr.c[0] + nv[1] * fr.c[1] + nv[2] * fr.c[2]).normalize();
                    from_f64::<u8>(
                        render::shade_f64(&base.light, nn, l, hv)
                            .round()
                            .clamp(0.0, 255.0),
                    )
                })
                .collect();
            levels.iter().map(|&x| u64::from(x)).sum::<u64>()
        });
        checksum ^= std::hint::black_box(sum);
        base_cpu.push(c);
        base_wall.push(t);
    }
    std::hint::black_box(checksum);
    let ns = |s: f64| s / to_f64(n) * 1e9;
    let (fx_ns, base_ns) = (ns(median(fx)), ns(median(base_cpu)));
    let mut t = Table::new([
        "what",
        "ns per covered pixel (CPU)",
        "wall (s)",
        "× baseline",
    ])
    .titled(format!(
        "bench render: {} at {w}x{h}, {} ({n} covered pixels), median of {} (target: fxshade \
             <= 3x the baseline; peak memory {:.0} MiB)",
        a.mesh,
        method.name(),
        a.repeats.max(1),
        rss
    ));
    t.row([
        format!("fxshade render, {} (no RTL)", method.name()),
        format!("{fx_ns:.0}"),
        format!("{:.3}", median(fx_wall.clone())),
        format!("{:.2}", fx_ns / base_ns),
    ]);
    t.row([
        "f64 shader (linear normals, Blinn-Phong)".into(),
        format!("{base_ns:.0}"),
        format!("{:.3}", median(base_wall.clone())),
        "1.00".into(),
    ]);
    t.row([
        "rasterize (shared, once)".into(),
        format!("{:.0}", ns(raster_cpu)),
        "-".into(),
        "-".into(),
    ]);
    let json = serde_json::json!({
        "bench": "render",
        "mesh": a.mesh, "width": w, "height": h, "method": method.name(),
        "covered_pixels": n,
        "repeats": a.repeats.max(1),
        "fxshade_ns_per_pixel": fx_ns,
        "baseline_ns_per_pixel": base_ns,
        "ratio": fx_ns / base_ns,
        "rasterize_ns_per_pixel": ns(raster_cpu),
        "peak_rss_mib": rss,
    });
    emit(a.out, &[t], &json)
}
