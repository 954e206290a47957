//! `fxshade report`: the main job — everything a designer needs about a
//! configuration, in one directory with an index page.

use fxshade_model::convert::{from_f64, to_f64};
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
pub use fxshade_flows::report::*;
use fxshade_model::files::StagedDir;

use super::ConfigArgs;

/// `fxshade report`
#[derive(Args, Debug)]
pub struct ReportArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    /// Output directory (replaced as a whole when the report is complete).
    #[arg(long, short = 'o', value_name = "DIR")]
    out: PathBuf,
    /// Replace `--out` even when it holds files fxshade did not write.
    #[arg(long)]
    force: bool,
    /// Size of the rendered images.
    #[arg(long, value_name = "WxH", default_value = "256x256")]
    size: String,
    /// Also rewrite the generated "what the report found" block of this
    /// README (between its BEGIN found / END found lines) with the
    /// report's figures (`found.md`).
    #[arg(long, value_name = "FILE")]
    readme: Option<PathBuf>,
}

/// The meshes the report renders: each procedural mesh at three
/// tessellations, so Θ and the error can be seen to change with it.
pub const REPORT_MESHES: [&str; 6] = [
    "sphere:6",
    "sphere:12",
    "sphere:24",
    "torus:12",
    "torus:24",
    "torus:48",
];

/// The mapped path three ways: op counts per pixel of each variant, the
/// transforms alone, and image metrics outside and inside the polar cap.
pub fn method_b_tables(
    cfg: &fxshade_model::Config,
    renders: &[(String, super::render::RenderResult)],
) -> anyhow::Result<[crate::output::Table; 3]> {
    let ops = fxshade_model::pipeline::ops_for(cfg)?;
    let mut t = crate::output::Table::new([
        "variant",
        "mul",
        "add/sub",
        "shift",
        "table reads",
        "sqrt",
        "div",
    ])
    .titled("Operations per pixel (counting runs)");
    for r in ops.iter().filter(|r| r.variant.starts_with("mapped")) {
        let c = &r.counts;
        t.row([
            r.variant.to_string(),
            c.mul.to_string(),
            c.add.to_string(),
            c.shift.to_string(),
            c.table_read.to_string(),
            c.sqrt.to_string(),
            c.div.to_string(),
        ]);
    }
    let mut u = crate::output::Table::new([
        "unit",
        "variant",
        "mul",
        "add/sub",
        "shift",
        "table reads",
        "sqrt",
        "div",
        "paper",
    ])
    .titled("The transforms alone, per vector (L or H) and per pixel (the angles of N)");
    for r in super::ops::reports(cfg)
        .iter()
        .filter(|r| r.unit == "polar" || r.unit == "angles")
    {
        let c = &r.counts;
        u.row([
            r.unit.to_string(),
            r.variant.to_string(),
            c.mul.to_string(),
            c.add.to_string(),
            c.shift.to_string(),
            c.table_read.to_string(),
            c.sqrt.to_string(),
            c.div.to_string(),
            r.paper
                .as_ref()
                .map_or("-".into(), |p| p.source.to_string()),
        ]);
    }
    let mut m = crate::output::Table::new([
        "mesh",
        "method",
        "max |err| outside",
        "mean |err| outside",
        "max rel. err outside",
        "under 4 % outside",
        "cap pixels",
        "max |err| in cap",
    ])
    .titled(format!(
        "Against the mapped f64 reference, outside the {}° polar cap and inside it",
        fxshade_model::render::POLAR_CAP_DEG
    ));
    for (_, r) in renders {
        for mr in r.methods.iter().filter(|x| x.outside_cap.is_some()) {
            let (o, c) = (
                mr.outside_cap.as_ref().expect("filtered"),
                mr.cap.as_ref().expect("with outside_cap"),
            );
            m.row([
                r.mesh.clone(),
                mr.method.to_string(),
                o.max_abs_levels.to_string(),
                format!("{:.4}", o.mean_abs_levels),
                format!("{:.3} %", 100.0 * o.max_rel_intensity_err),
                if o.paper_bound_holds { "yes" } else { "no" }.to_string(),
                c.pixels.to_string(),
                if c.pixels == 0 {
                    "-".into()
                } else {
                    c.max_abs_levels.to_string()
                },
            ]);
        }
    }
    Ok([t, u, m])
}

/// The mapped path three ways, side by side, as Markdown.
fn method_b_section(
    cfg: &fxshade_model::Config,
    renders: &[(String, super::render::RenderResult)],
) -> anyhow::Result<String> {
    let [t, u, m] = method_b_tables(cfg, renders)?;
    let mut s = String::from(
        "`mapped`: per-pixel angles of the interpolated normal by CORDIC (the default, \
         `pipeline.angles = \"cordic\"`); `mapped-interp`: per-vertex angles interpolated \
         (`\"interpolate\"`); `tbn`: the conventional transform, per-vertex tangent frames \
         interpolated, `L' = normalize(M·L)` with a square root and a division (no RTL).\n\n```text\n",
    );
    s += &t.render();
    s += "```\n\n```text\n";
    s += &u.render();
    s += "```\n\n```text\n";
    s += &m.render();
    s += "```\n\n| mesh | mapped reference | mapped (CORDIC) | its error | mapped-interp | its error | tbn | its error | tbn in f64: error |\n\
          |---|---|---|---|---|---|---|---|---|\n";
    for (prefix, r) in renders {
        s += &format!(
            "| {} | ![]({prefix}reference_mapped.png) | ![]({prefix}mapped.png) | ![]({prefix}mapped_error.png) \
             | ![]({prefix}mapped-interp.png) | ![]({prefix}mapped-interp_error.png) | ![]({prefix}tbn.png) \
             | ![]({prefix}tbn_error.png) | ![]({prefix}tbn_f64_error.png) |\n",
            r.mesh
        );
    }
    Ok(s)
}

/// The summary's recommendation as Markdown.
fn summary_markdown(sweeps: &[MethodSweep]) -> String {
    format!(
        "## Summary\n\n{}\n",
        super::report_found::recommendation(sweeps)
    )
}

/// Plots of the summary sweep (`plots/`) and the error histogram.
fn write_summary_plots(
    dir: &StagedDir,
    sweeps: &[MethodSweep],
    renders: &[(String, super::render::RenderResult)],
) -> anyhow::Result<()> {
    use crate::plot::{plot, Frame, Series};
    let series = |metric: &str, scale: f64| -> Vec<Series> {
        sweeps
            .iter()
            .map(|m| {
                (
                    m.method.to_string(),
                    m.points
                        .iter()
                        .filter_map(|(w, r)| Some((f64::from(*w), scale * r.get(metric)?)))
                        .collect(),
                )
            })
            .collect()
    };
    let w0 = f64::from(*SUMMARY_WIDTHS.start());
    let w1 = f64::from(*SUMMARY_WIDTHS.end());
    let mut rel = series("pipeline.max_rel_err", 100.0);
    rel.push(("the paper's 4 % bound".into(), vec![(w0, 4.0), (w1, 4.0)]));
    let mut out = vec![
        (
            "plots/error_vs_width",
            plot(
                &Frame {
                    title: "Largest relative intensity error against uniform width",
                    x: "width of every stage (bits)",
                    y: "max relative error (%)",
                    log_y: true,
                },
                &rel,
                &[],
                &[],
            )?,
        ),
        (
            "plots/levels_vs_width",
            plot(
                &Frame {
                    title: "Largest error in levels against uniform width",
                    x: "width of every stage (bits)",
                    y: "max |error| (levels)",
                    log_y: true,
                },
                &series("pipeline.max_err_levels", 1.0),
                &[],
                &[],
            )?,
        ),
        (
            "plots/cost_vs_width",
            plot(
                &Frame {
                    title: "Multiplier bit products against uniform width",
                    x: "width of every stage (bits)",
                    y: "bit products",
                    log_y: false,
                },
                &series("bit_products", 1.0),
                &[],
                &[],
            )?,
        ),
    ];
    let rows: Vec<crate::explore::Row> = sweeps
        .iter()
        .flat_map(|m| m.points.iter().map(|(_, r)| r.clone()))
        .collect();
    let front = crate::explore::pareto(&rows, "pipeline.max_rel_err", "bit_products");
    let pt = |r: &crate::explore::Row| {
        Some((
            r.get("bit_products")?,
            100.0 * r.get("pipeline.max_rel_err")?,
        ))
    };
    let all: Vec<(f64, f64)> = rows.iter().filter_map(pt).collect();
    let line: Vec<(f64, f64)> = front.iter().filter_map(|&i| pt(&rows[i])).collect();
    let marks: Vec<(String, f64, f64)> = sweeps
        .iter()
        .filter_map(|m| {
            let (w, r) = &m.points[m.recommended?];
            let (x, y) = pt(r)?;
            Some((format!("recommended: {} at {w} bits", m.method), x, y))
        })
        .collect();
    out.push((
        "plots/pareto",
        plot(
            &Frame {
                title: "Error against cost, every method and width",
                x: "bit products",
                y: "max relative error (%)",
                log_y: true,
            },
            &[("Pareto front".into(), line)],
            &all,
            &marks,
        )?,
    ));
    if let Some((_, r)) = renders.iter().find(|(_, r)| r.mesh == "torus:24") {
        let hist: Vec<(String, Vec<u64>)> = r
            .methods
            .iter()
            .filter(|m| {
                ["linear", "quadratic", "mapped", "mapped-interp", "tbn"].contains(&m.method)
            })
            .map(|m| {
                let mm = m.outside_cap.as_ref().unwrap_or(&m.metrics);
                (
                    m.method.to_string(),
                    mm.off_by
                        .iter()
                        .map(|&f| from_f64::<u64>((f * to_f64(mm.pixels)).round()))
                        .collect(),
                )
            })
            .collect();
        out.push((
            "plots/error_histogram",
            crate::plot::histogram(
                "Pixels by error on torus:24 (0, 1, 2, more than 2 levels)",
                "|error| in levels (3 = more than 2)",
                &hist,
            )?,
        ));
    }
    for (stem, (png, svg)) in out {
        dir.write(&format!("{stem}.png"), &png)?;
        dir.write(&format!("{stem}.svg"), svg.as_bytes())?;
    }
    Ok(())
}

/// Run it.
pub fn run(a: &ReportArgs) -> anyhow::Result<()> {
    let cfg = a.cfg.resolve()?;
    let search = super::search_mode()?;
    let size = super::render::parse_size(&a.size)?;
    // Every input is checked before minutes of work: the README to splice
    // the findings into must be readable, writable and have the markers.
    let readme_text = match &a.readme {
        Some(p) => {
            let text = fxshade_model::files::read_text_limited(p).map_err(|e| {
                crate::output::UsageError(format!("--readme {}: cannot read: {e}", p.display()))
            })?;
            super::report_found::splice(&text, "")
                .map_err(|e| crate::output::UsageError(format!("--readme {}: {e}", p.display())))?;
            std::fs::OpenOptions::new()
                .append(true)
                .open(p)
                .map_err(|e| {
                    crate::output::UsageError(format!(
                        "--readme {}: cannot be written: {e}",
                        p.display()
                    ))
                })?;
            Some(text)
        }
        None => None,
    };
    let dir = if a.force {
        StagedDir::new_forced(&a.out)
    } else {
        StagedDir::new(&a.out)
    }
    .with_context(|| format!("cannot write the report to {}", a.out.display()))?;
    let bar = crate::progress::bar(9 + REPORT_MESHES.len() as u64, "report");

    bar.set_message("configuration");
    dir.write("config.toml", cfg.to_toml().as_bytes())?;
    dir.write(
        "config.json",
        serde_json::to_string_pretty(&cfg.to_json())?.as_bytes(),
    )?;
    bar.inc(1);

    bar.set_message("operation counts");
    let ops = super::ops::reports(&cfg);
    let table = super::ops::table(&ops);
    dir.write("ops.txt", table.render().as_bytes())?;
    dir.write("ops.csv", table.to_csv()?.as_bytes())?;
    dir.write("ops.json", serde_json::to_string_pretty(&ops)?.as_bytes())?;
    let stages = super::ops::stages_table(&ops);
    dir.write("stages.txt", stages.render().as_bytes())?;
    dir.write("stages.csv", stages.to_csv()?.as_bytes())?;
    bar.inc(1);

    bar.set_message("paper tables");
    let paper = fxshade_model::paper::reproduce()?;
    let ptable = super::paper::table(&paper);
    dir.write("paper.txt", ptable.render().as_bytes())?;
    dir.write("paper.csv", ptable.to_csv()?.as_bytes())?;
    dir.write(
        "paper.json",
        serde_json::to_string_pretty(&paper)?.as_bytes(),
    )?;
    bar.inc(1);

    bar.set_message("normalizer error analysis");
    let nerr = fxshade_model::analysis::normalize(&cfg, 100_000, 1, &mut |_| {})?;
    let ntables = super::error::tables(&nerr);
    let ntext: String = ntables.iter().map(|t| t.render() + "\n").collect();
    dir.write("error_normalize.txt", ntext.as_bytes())?;
    dir.write("error_normalize.csv", ntables[0].to_csv()?.as_bytes())?;
    dir.write(
        "error_normalize.json",
        serde_json::to_string_pretty(&nerr)?.as_bytes(),
    )?;
    bar.inc(1);

    bar.set_message("interpolation error analysis");
    let nu: fxshade_model::normalizer::NormalizeConfig = cfg.section();
    let ierr = fxshade_model::analysis::interp(
        &cfg,
        cfg.section::<fxshade_model::interp::InterpConfig>().scheme,
        nu.method,
        nu.theta,
        50_000,
        1,
        &mut |_| {},
    )?;
    dir.write(
        "error_interp.json",
        serde_json::to_string_pretty(&ierr)?.as_bytes(),
    )?;
    let itext = format!(
        "scheme {}, normalizer {}, Θ = {}: d ∈ [{:.6}, {:.6}] (bound [{:.6}, {:.6}]), max |N'| error {:.3e}, \
         max angle {:.4}° against the exact quadratic field, {:.4}° against linear interpolation; \
         {:.3e} with no normalization\n",
        ierr.scheme.name(),
        ierr.normalizer.name(),
        ierr.theta,
        ierr.d_min,
        ierr.d_max,
        ierr.d_bound.0,
        ierr.d_bound.1,
        ierr.max_rel_err,
        ierr.max_angle_err_deg,
        ierr.vs_linear.max_angle_err_deg,
        ierr.unnormalized_max_rel_err
    );

    bar.set_message("polar transform error analysis");
    let perr = fxshade_model::analysis::polar(
        &cfg,
        200_000,
        1,
        fxshade_model::analysis::POLAR_EXHAUSTIVE,
    )?;
    dir.write(
        "error_polar.json",
        serde_json::to_string_pretty(&perr)?.as_bytes(),
    )?;
    let frames: Vec<String> = [
        ("sphere:32", fxshade_model::mesh::Axis::Y),
        ("torus:64", fxshade_model::mesh::Axis::Y),
        ("torus:64", fxshade_model::mesh::Axis::Z),
    ]
    .iter()
    .map(|&(m, axis)| -> anyhow::Result<String> {
        let c = fxshade_model::polar::frames::compare(&fxshade_flows::scene::procedural(m, axis)?);
        Ok(format!(
            "* {m} about {axis:?}: {:.1} % of the surface more than 10° apart (mean {:.1}°)\n",
            100.0 * c.share_over_10_deg,
            c.mean_deg
        ))
    })
    .collect::<anyhow::Result<_>>()?;
    let ptext = format!(
        "{}-bit angles, {}-bit {} tables of {} ({} bits each), {} transforms ({}): max {:.2} LSB, rms {:.3} LSB, \
         max | |L'| − 1 | {:.2e}, max angle {:.4}°, max diffuse error {:.2} levels, {} overflows\n",
        perr.angle_bits,
        perr.table_bits,
        format!("{:?}", perr.organisation).to_lowercase(),
        perr.table_format,
        perr.table_size_bits,
        perr.stats.samples,
        perr.stats.coverage,
        perr.stats.max_lsb_err,
        perr.stats.rms_lsb_err,
        perr.stats.max_len_dev,
        perr.stats.max_angle_err_deg,
        perr.stats.max_diffuse_err_levels,
        perr.stats.overflows
    );
    bar.inc(1);

    bar.set_message("CORDIC angle error analysis");
    let aerr = fxshade_model::analysis::angles(&cfg, 200_000, 1)?;
    let beta_lengths = fxshade_model::analysis::angles_length_range();
    let beta =
        fxshade_model::analysis::angles_beta_every_code(&cfg, beta_lengths.0, beta_lengths.1)?;
    let mut aj = serde_json::to_value(&aerr)?;
    aj["beta_every_code"] = serde_json::to_value(&beta)?;
    dir.write(
        "error_angles.json",
        serde_json::to_string_pretty(&aj)?.as_bytes(),
    )?;
    let atext = format!(
 "{} iterations, coordinates {}, accumulator {}, angles {} (sampled: {} normals, {}): max α error {:.3} LSB ({:.4}°), max β error {:.3} LSB ({:.4}°) more than {}° from the y axis, {:.2} LSB inside; direction error at most {:.4}°; β over every (x, z) code pair (exhaustive): {:.3} LSB; generated RTL: {} adder bits, {} flip-flops, latency {} cycles\n",
        aerr.iterations,
        aerr.xy,
        aerr.theta,
        aerr.out,
        aerr.stats.samples,
        aerr.stats.coverage,
        aerr.stats.max_alpha_lsb,
        aerr.stats.max_alpha_deg,
        aerr.stats.max_beta_lsb,
        aerr.stats.max_beta_deg,
        fxshade_model::render::POLAR_CAP_DEG,
        aerr.stats.max_beta_lsb_cap,
        aerr.stats.max_direction_deg,
        beta.max_beta_lsb,
        aerr.adder_bits,
        aerr.flops,
        aerr.latency
    );

    let mut renders = Vec::new();
    let mut summary = crate::output::Table::new([
        "mesh",
        "triangles",
        "min cos φ",
        "method",
        "max |err| (levels)",
        "mean |err|",
        "PSNR (dB)",
        "off by >1",
        "under 4 %",
        "judged on",
        "max |err|, every pixel",
    ])
    .titled(format!(
        "Rendered at {}×{}, bit-accurate pipeline against the f64 reference (mapped methods judged \
         outside the {}° polar cap, as the summary judges them; every pixel's largest error beside)",
        size.0,
        size.1,
        fxshade_model::render::POLAR_CAP_DEG
    ));
    for spec in REPORT_MESHES {
        bar.set_message(format!("render {spec}"));
        let m = super::render::load_mesh(spec)?;
        let prefix = format!("render/{}/", spec.replace(':', "_"));
        let r = super::render::render_into(
            &cfg,
            &fxshade_model::render::Scene::default(),
            spec,
            &m,
            size,
            &fxshade_model::render::RenderMethod::ALL,
            None,
            &dir,
            &prefix,
            &mut |_| {},
        )?;
        dir.write(
            &format!("{prefix}metrics.csv"),
            super::render::table(&r).to_csv()?.as_bytes(),
        )?;
        // One judgement per method: the figures the summary judges by
        // (outside the polar cap for mapped methods), every pixel beside.
        let rows = r
            .methods
            .iter()
            .map(|mr| (mr.method, mr.outside_cap.as_ref(), &mr.metrics))
            .chain(
                r.angle_interp
                    .as_ref()
                    .map(|a| ("angle_interp (f64)", None, a)),
            )
            .chain(r.tbn_f64.as_ref().map(|a| ("tbn (f64)", None, a)));
        for (method, outside, all) in rows {
            let mm = outside.unwrap_or(all);
            summary.row([
                spec.to_string(),
                r.cos_phi.triangles.to_string(),
                format!("{:.4}", r.cos_phi.min),
                method.to_string(),
                mm.max_abs_levels.to_string(),
                format!("{:.4}", mm.mean_abs_levels),
                mm.psnr_db.map_or("∞".into(), |p| format!("{p:.2}")),
                format!("{:.2} %", 100.0 * (mm.off_by[2] + mm.off_by[3])),
                if mm.paper_bound_holds { "yes" } else { "no" }.to_string(),
                if outside.is_some() {
                    format!("outside the {}° cap", fxshade_model::render::POLAR_CAP_DEG)
                } else {
                    "every pixel".to_string()
                },
                all.max_abs_levels.to_string(),
            ]);
        }
        renders.push((prefix, r));
        bar.inc(1);
    }
    dir.write("render.csv", summary.to_csv()?.as_bytes())?;
    let rjson: Vec<&super::render::RenderResult> = renders.iter().map(|(_, r)| r).collect();
    dir.write(
        "render.json",
        serde_json::to_string_pretty(&rjson)?.as_bytes(),
    )?;

    bar.set_message("test vectors");
    let mut vector_lines = String::new();
    // One unit per core at a time (each search is parallel inside, but not
    // throughout), the pipeline top (the longest) first; written in the
    // units' order.
    let units: Vec<_> = fxshade_model::rtl::units::all().collect();
    let mut order: Vec<usize> = (0..units.len()).collect();
    order.sort_by_key(|&i| units[i].name != "pipeline");
    let mut made: Vec<_> = fxshade_model::parallel::map_in_order(&order, |_, &i| {
        (
            i,
            fxshade_model::rtl::units::vectors(units[i], &cfg, 1000, 1, search),
        )
    });
    made.sort_by_key(|(i, _)| *i);
    for (u, (_, v)) in units.iter().zip(made) {
        match v {
            Ok(v) => {
                v.write_into_dir(&dir, &format!("vectors/{}", u.name))?;
                vector_lines += &format!(
                    "* [`vectors/{0}/`](vectors/{0}/manifest.json): {1} vectors ({2} corner cases), variant {3}\n",
                    u.name,
                    v.count(),
                    v.corner_cases,
                    v.variant
                );
            }
            Err(e) => {
                vector_lines += &format!("* {}: no vectors for this configuration: {e}\n", u.name)
            }
        }
    }
    bar.inc(1);

    bar.set_message("width sweep per method");
    let base = crate::explore::Base {
        config: a.cfg.config.clone(),
        set: a.cfg.set.clone(),
    };
    let sweeps = summary_sweep(&base)?;
    write_summary_plots(&dir, &sweeps, &renders)?;
    bar.inc(1);

    bar.set_message("RTL checks on Icarus Verilog");
    let rtl = rtl_checks(&cfg, super::search_mode()?);
    bar.inc(1);

    let found = super::report_found::section(&super::report_found::Inputs {
        beta: &beta,
        beta_lengths,
        cfg: &cfg,
        normalize: &nerr,
        interp: &ierr,
        polar: &perr,
        angles: &aerr,
        paper: &paper,
        ops: &ops,
        renders: &renders,
        sweeps: &sweeps,
    })?;
    dir.write("found.md", found.as_bytes())?;
    let readme = match (&a.readme, &readme_text) {
        (Some(p), Some(text)) => Some((
            p,
            super::report_found::splice(text, &found)
                .map_err(|e| anyhow::anyhow!("--readme {}: {e}", p.display()))?,
        )),
        _ => None,
    };

    let html = super::report_html::page(&super::report_html::Data {
        cfg: &cfg,
        ops: &table,
        stages: &stages,
        paper: &ptable,
        normalize: &ntables,
        interp: &itext,
        polar: &ptext,
        frames: &frames.concat(),
        angles: &atext,
        summary: &summary,
        renders: &renders,
        vectors: &vector_lines,
        sweeps: &sweeps,
        rtl: &rtl,
        method_b: &method_b_tables(&cfg, &renders)?,
        synth: &cached_synthesis(&cfg),
    });
    dir.write("index.html", html.as_bytes())?;

    let mut index = String::new();
    index += "# fxshade report\n\n";
    index += "The same report as an HTML page, with plots and a recommendation: [index.html](index.html).\n\n";
    index += &summary_markdown(&sweeps);
    index += &format!(
        "Configuration: {}",
        fxshade_model::escape::markdown(&cfg.describe())
    );
    index += " — full text in [config.toml](config.toml) ([JSON](config.json)).\n\n";
    index += "## Operation counts\n\nMeasured by running each datapath in the counting context \
              ([CSV](ops.csv), [JSON](ops.json)).\n\n```text\n";
    index += &table.render();
    index += "```\n\n## Quantization points\n\nThe stages the RTL quantizes at ([CSV](stages.csv)).\n\n```text\n";
    index += &stages.render();
    index += "```\n\n## Test vectors\n\n";
    index += &vector_lines;
    index += "\nRun them through the RTL with `fxshade rtl-check <unit>`.\n";
    index += "\n## Normalizer error (bit-accurate model against exact f64)\n\n\
              ([CSV](error_normalize.csv), [JSON](error_normalize.json))\n\n```text\n";
    index += &ntext;
    index += "```\n\n## Interpolation error ([JSON](error_interp.json))\n\n";
    index += &itext;
    index += "\n## Polar transform error ([JSON](error_polar.json))\n\n";
    index += &ptext;
    index += "\nImplied tangent frame against the UV-aligned frame normal maps are baked in:\n\n";
    index += &frames.concat();
    index += "\n## CORDIC angles of N ([JSON](error_angles.json))\n\n";
    index += &atext;
    index += "\n## Method B: three ways to the tangent-space L and H\n\n";
    index += &method_b_section(&cfg, &renders)?;
    index += "\n## Rendered images\n\n";
    index += "Every pixel through the bit-accurate pipeline; the reference is the same scene in f64 \
              (exact normalization, polar angles of the exact normal by `asin`/`atan2`). Heat-maps: \
              error in 8-bit levels. `angle_interp` is what interpolating the polar angles per pixel \
              (the pipeline's choice, no per-pixel `asin`/`atan2`) costs by itself, in f64 \
              ([CSV](render.csv), [JSON](render.json)).\n\n```text\n";
    index += &summary.render();
    index += "```\n\n";
    index += "| mesh | reference | quadratic | its error | mapped | its error | angle interpolation error |\n\
              |---|---|---|---|---|---|---|\n";
    for (prefix, r) in &renders {
        index += &format!(
            "| {} ({} triangles, min cos φ {:.3}) | ![]({prefix}reference.png) | ![]({prefix}quadratic.png) \
             | ![]({prefix}quadratic_error.png) | ![]({prefix}mapped.png) | ![]({prefix}mapped_error.png) \
             | ![]({prefix}angle_interp_error.png) |\n",
            r.mesh, r.cos_phi.triangles, r.cos_phi.min
        );
    }
    index += "\nEvery method's image, heat-map and metrics are in each mesh's directory under `render/`.\n";
    index += "\n## The normalization paper reproduced\n\n([CSV](paper.csv), [JSON](paper.json))\n\n```text\n";
    index += &ptable.render();
    index += "```\n";
    dir.write("index.md", index.as_bytes())?;
    bar.finish_and_clear();
    let out = dir.commit()?;
    if let Some((p, text)) = readme {
        fxshade_model::files::write_atomic(p, text.as_bytes())
            .with_context(|| format!("cannot write --readme {}", p.display()))?;
    }
    crate::output::print_out(&format!(
        "report written to {0}/index.html (and {0}/index.md)\n",
        out.display()
    ))
}
