//! The renderer end to end: the model's image equals the simulated RTL
//! top's on both simulators, the exact-normalization image is within one
//! level of the f64 reference, the report runs on the default configuration
//! at a tiny resolution, and bad input (a malformed OBJ file, an unwritable
//! output directory, unknown methods and sizes) gets a clear error.

use crate::common::*;

fn decode(p: &std::path::Path) -> (usize, usize, Vec<u8>) {
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
    let mut r = dec.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size()];
    let info = r.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (info.width as usize, info.height as usize, buf)
}

fn render(args: &[&str]) -> (std::process::Output, tempfile::TempDir) {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("r");
    let mut a = vec!["render"];
    a.extend_from_slice(args);
    a.extend(["--out", out.to_str().unwrap()]);
    (fxshade(&a), d)
}

#[test]
fn rtl_images_equal_model_images_on_both_simulators() {
    for sim in ["verilator", "icarus"] {
        let (o, d) = render(&[
            "--mesh", "sphere:6", "--size", "20x16", "--rtl", "--sim", sim, "--json",
        ]);
        assert!(o.status.success(), "{sim}: {}", text(&o));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let methods = j["methods"].as_array().unwrap();
        assert_eq!(methods.len(), 4, "linear, quadratic, mapped, mapped-interp");
        for m in methods {
            assert_eq!(m["rtl"]["identical"], true, "{sim} {m}");
            assert_eq!(m["rtl"]["failed"], 0, "{sim} {m}");
            let name = m["method"].as_str().unwrap();
            let a = decode(&d.path().join(format!("r/{name}.png")));
            let b = decode(&d.path().join(format!("r/{name}_rtl.png")));
            assert_eq!(a, b, "{sim} {name}");
            assert!(a.2.iter().any(|&x| x > 0), "{sim} {name}: the image is lit");
        }
    }
}

/// Issue #15's targets at the default configuration, 256 × 256: the mapped
/// path with CORDIC angles is within 2 levels of the f64 reference and
/// under the paper's 4 % bound on every pixel more than 2° from the y axis,
/// on four meshes; the polar cap is reported apart; interpolated angles and
/// the interpolated TBN baseline, measured beside it, miss both.
#[test]
fn mapped_path_with_cordic_angles_meets_the_targets() {
    for mesh in ["sphere:12", "sphere:24", "torus:24", "torus:48"] {
        let (o, d) = render(&[
            "--mesh",
            mesh,
            "--size",
            "256x256",
            "--method",
            "mapped,mapped-interp,tbn",
            "--json",
        ]);
        assert!(o.status.success(), "{mesh}: {}", text(&o));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let m = &j["methods"];
        assert_eq!(m[0]["method"], "mapped");
        let out = &m[0]["outside_cap"];
        assert!(
            out["max_abs_levels"].as_u64().unwrap() <= 2,
            "{mesh}: {out}"
        );
        assert_eq!(out["paper_bound_holds"], true, "{mesh}: {out}");
        let cap = &m[0]["cap"];
        assert_eq!(cap["pixels"], j["polar_cap_pixels"], "{mesh}");
        assert_eq!(
            out["pixels"].as_u64().unwrap() + cap["pixels"].as_u64().unwrap(),
            m[0]["pixels"].as_u64().unwrap(),
            "{mesh}: the cap and the rest partition the pixels"
        );
        for k in [1, 2] {
            let o = &m[k]["outside_cap"];
            assert!(o["max_abs_levels"].as_u64().unwrap() > 2, "{mesh} {}", m[k]);
            assert_eq!(o["paper_bound_holds"], false, "{mesh} {}", m[k]);
        }
        assert!(j["tbn_f64"]["max_abs_levels"].is_number());
        for f in [
            "mapped.png",
            "mapped-interp.png",
            "tbn.png",
            "tbn_f64_error.png",
        ] {
            assert!(d.path().join("r").join(f).is_file(), "{mesh}: {f}");
        }
    }
}

#[test]
fn exact_normalization_is_within_one_level_of_the_f64_reference() {
    for mesh in ["sphere:6", "sphere:24", "torus:12", "torus:48"] {
        let (o, d) = render(&[
            "--mesh", mesh, "--size", "96x80", "--method", "exact", "--json",
        ]);
        assert!(o.status.success(), "{mesh}: {}", text(&o));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert!(
            j["methods"][0]["max_abs_levels"].as_u64().unwrap() <= 1,
            "{mesh}: {j}"
        );
        // Pixel by pixel from the PNGs, too.
        let (w, h, a) = decode(&d.path().join("r/exact.png"));
        let (_, _, b) = decode(&d.path().join("r/reference.png"));
        assert_eq!((w, h), (96, 80));
        let worst = a
            .iter()
            .zip(&b)
            .map(|(&x, &y)| x.abs_diff(y))
            .max()
            .unwrap();
        assert!(worst <= 1, "{mesh}: {worst}");
        assert!(
            j["pixels"].as_u64().unwrap() > 1000,
            "{mesh}: the mesh covers the image"
        );
    }
}

#[test]
fn skipping_normalization_on_a_coarse_sphere_breaks_the_paper_bound() {
    // The metrics can fail: with no normalization, linear interpolation on a
    // 6-segment sphere (cos φ down to 1/8) darkens the middle of each triangle.
    let (o, _d) = render(&[
        "--mesh",
        "sphere:6",
        "--size",
        "96x96",
        "--method",
        "none,quadratic",
        "--json",
        "--set",
        "interp.scheme=\"linear\"",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["methods"][0]["method"], "none");
    assert_eq!(j["methods"][0]["paper_bound_holds"], false, "{j}");
    assert!(j["methods"][0]["max_abs_levels"].as_u64().unwrap() > 10);
    let shares: f64 = j["methods"][0]["off_by"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .sum();
    assert!((shares - 1.0).abs() < 1e-9);
}

#[test]
fn report_runs_end_to_end_at_a_tiny_resolution() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("rep");
    let o = fxshade(&["report", "--size", "24x24", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let index = std::fs::read_to_string(out.join("index.md")).unwrap();
    for s in [
        "## Rendered images",
        "render/torus_48/mapped_error.png",
        "angle_interp",
        "## Test vectors",
    ] {
        assert!(index.contains(s), "index.md lacks {s}");
    }
    for f in [
        "render/sphere_6/reference.png",
        "render/sphere_6/quadratic_error.png",
        "render/torus_24/mapped.png",
        "vectors/pipeline/manifest.json",
        "render.csv",
        "render.json",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let (w, h, _) = decode(&out.join("render/sphere_12/exact.png"));
    assert_eq!((w, h), (24, 24));
}

#[test]
fn an_obj_file_renders_and_reports_cos_phi() {
    let d = tempfile::tempdir().unwrap();
    let obj = d.path().join("oct.obj");
    // An octahedron without normals: smooth normals are computed.
    std::fs::write(
        &obj,
        "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n\
         f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n",
    )
    .unwrap();
    let (o, _r) = render(&["--mesh", obj.to_str().unwrap(), "--size", "32x32", "--json"]);
    assert!(o.status.success(), "{}", text(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["cos_phi"]["triangles"], 8);
    // Vertex normals of an octahedron point along the axes: every pair in a
    // face is orthogonal, cos φ = 0 exactly.
    assert!(j["cos_phi"]["min"].as_f64().unwrap().abs() < 1e-12, "{j}");
    assert_eq!(j["cos_phi"]["by_theta"][0][1], 8, "{j}");
}

#[test]
fn a_malformed_obj_file_is_named_with_its_line() {
    let d = tempfile::tempdir().unwrap();
    let obj = d.path().join("bad.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n").unwrap();
    let (o, r) = render(&["--mesh", obj.to_str().unwrap(), "--size", "8x8"]);
    assert_eq!(o.status.code(), Some(1));
    let e = text(&o);
    assert!(e.contains("bad.obj:3:") && e.contains("v 0 1 zero"), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    assert!(!r.path().join("r").exists(), "no output on error");
    let (o, _) = render(&["--mesh", d.path().join("none.obj").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("no such file"), "{}", text(&o));
}

#[test]
fn an_unwritable_output_directory_is_a_clear_error() {
    let d = tempfile::tempdir().unwrap();
    let file = d.path().join("plain-file");
    std::fs::write(&file, "x").unwrap();
    let out = file.join("images");
    let o = fxshade(&[
        "render",
        "--mesh",
        "sphere:6",
        "--size",
        "8x8",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let e = text(&o);
    assert!(
        e.contains("cannot write the render to") && e.contains("plain-file"),
        "{e}"
    );
    assert!(!e.contains("panicked"), "{e}");
}

#[test]
fn bad_methods_and_sizes_are_named() {
    let cases: [(&[&str], &str); 4] = [
        (
            &["--mesh", "sphere:6", "--method", "cubic"],
            "--method cubic: unknown",
        ),
        (
            &["--mesh", "sphere:6", "--method", "exact", "--rtl"],
            "the RTL implements linear, quadratic, mapped and mapped-interp only",
        ),
        (
            &["--mesh", "sphere:6", "--size", "64"],
            "--size 64: write WxH",
        ),
        (&["--mesh", "cube:3"], "no such file"),
    ];
    for (args, want) in cases {
        let (o, _d) = render(args);
        assert!(!o.status.success(), "{args:?}");
        assert!(text(&o).contains(want), "{args:?}: {}", text(&o));
    }
}

#[test]
fn a_level_format_with_fraction_bits_is_shown_by_value() {
    // U8F2 codes run to 1023: the image shows their value, not a clipped code.
    let (o, d) = render(&[
        "--mesh",
        "sphere:12",
        "--size",
        "48x48",
        "--method",
        "exact",
        "--json",
        "--set",
        "lighting.level.format=\"U8F2\"",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        j["methods"][0]["max_abs_levels"].as_u64().unwrap() <= 1,
        "{j}"
    );
    let (_, _, a) = decode(&d.path().join("r/exact.png"));
    assert!(
        a.iter().any(|&x| (100..250).contains(&x)),
        "mid-range levels present"
    );
}

fn obj(dir: &std::path::Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// Two triangles of one square; the first has antiparallel vertex normals.
const ANTIPARALLEL: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
vn 0 0 1\nvn 0 0 -1\nvn 0 0 1\nvn 0 0 1\n\
f 1//1 2//2 3//3\nf 2//4 4//4 3//3\n";

/// Pixels of a triangle that cannot be set up are counted, named and left
/// out of every metric; with none left, nothing is claimed.
#[test]
fn skipped_pixels_are_counted_and_excluded_not_exact() {
    let d = tempfile::tempdir().unwrap();
    let half = obj(d.path(), "half.obj", ANTIPARALLEL);
    let (o, _t) = render(&[
        "--mesh",
        &half,
        "--size",
        "32x32",
        "--method",
        "quadratic",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("triangle 1 (face on line 9)"),
        "{}",
        text(&o)
    );
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (total, skipped) = (
        j["pixels"].as_u64().unwrap(),
        j["skipped_pixels"].as_u64().unwrap(),
    );
    let m = &j["methods"][0];
    assert!(skipped > 0 && skipped < total, "{j}");
    assert_eq!(m["skipped"].as_u64().unwrap(), skipped);
    assert_eq!(
        m["pixels"].as_u64().unwrap(),
        total - skipped,
        "only set-up pixels compared"
    );
    // Every triangle degenerate: no pixel compared, no claim.
    let all = obj(
        d.path(),
        "all.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 -1\nvn 0 0 1\nf 1//1 2//2 3//3\n",
    );
    let (o, _t) = render(&["--mesh", &all, "--size", "32x32", "--method", "quadratic"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("no pixel compared") && !text(&o).contains(" yes "),
        "{}",
        text(&o)
    );
    let (o, _t) = render(&[
        "--mesh",
        &all,
        "--size",
        "32x32",
        "--method",
        "quadratic",
        "--json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["methods"][0]["pixels"], 0);
    assert_eq!(j["methods"][0]["paper_bound_holds"], false);
}

/// Bad OBJ content is refused with the line that holds it: a zero-length
/// normal, a face of two vertices, an index past the end (named on its own
/// line, not at the end of the file).
#[test]
fn bad_obj_lines_are_named() {
    let d = tempfile::tempdir().unwrap();
    let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n";
    for (body, line, what) in [
        ("vn 0 0 0\nf 1//1 2//2 3//1\n", 5, "zero-length"),
        ("f 1 2\n", 5, "at least 3 vertices"),
        ("f 1 2 3\nf 1 2 4\n# end\n", 6, "vertex index 4"),
    ] {
        let p = obj(d.path(), "bad.obj", &format!("{base}{body}"));
        let (o, _t) = render(&["--mesh", &p, "--size", "16x16"]);
        assert_eq!(o.status.code(), Some(1), "{body:?}: {}", text(&o));
        assert!(
            text(&o).contains(&format!("bad.obj:{line}:")) && text(&o).contains(what),
            "{body:?}: {}",
            text(&o)
        );
    }
}

/// The scene is flags: the light, the viewer, the tilt and the normal map
/// change the image; a zero direction is refused by name.
#[test]
fn the_scene_is_flags_with_defaults() {
    let img = |extra: &[&str]| {
        let mut a = vec![
            "--mesh", "sphere:8", "--size", "24x24", "--method", "mapped",
        ];
        a.extend_from_slice(extra);
        let (o, t) = render(&a);
        assert!(o.status.success(), "{extra:?}: {}", text(&o));
        decode(&t.path().join("r").join("mapped.png")).2
    };
    let default = img(&[]);
    assert_eq!(
        default,
        img(&[
            "--light",
            "-0.45,0.6,0.66",
            "--view",
            "0,0,1",
            "--tilt",
            "30"
        ])
    );
    for extra in [
        &["--light", "0,0,1"][..],
        &["--view", "0.3,0,1"][..],
        &["--tilt", "-20"][..],
        &["--normal-map", "flat"][..],
    ] {
        assert_ne!(default, img(extra), "{extra:?} changes the image");
    }
    for (flag, v) in [
        ("--light", "0,0,0"),
        ("--view", "1,2"),
        ("--light", "nan,0,1"),
    ] {
        let (o, _t) = render(&["--mesh", "sphere:8", "--size", "8x8", flag, v]);
        // A bad flag value: status 2, as every usage error.
        assert_eq!(o.status.code(), Some(2), "{flag} {v}: {}", text(&o));
        assert!(text(&o).contains(flag), "{flag} {v}: {}", text(&o));
    }
}

/// `render` without the RTL shades its rows a chunk at a time and drops
/// them: the levels and metrics are those of every method run on the whole
/// frame (the path `--rtl` and the report's earlier renders took), across
/// chunk boundaries (a 256 × 256 torus covers more than one chunk) and with
/// every method at once, and a frame built for some methods leaves the
/// others' rows empty.
#[test]
fn streamed_rendering_gives_the_whole_frame_levels() {
    use fxshade_model::render::{self, RenderMethod};
    let cfg = fxshade_model::Config::embedded();
    let mesh = fxshade_model::mesh::torus(48, fxshade_model::mesh::Axis::Y);
    let scene = render::Scene::default();
    let base = fxshade_model::pipeline::Pipeline::with_method(
        &cfg,
        fxshade_model::normalizer::Method::None,
    )
    .unwrap();
    let raster = render::rasterize_in(&scene, &mesh, 256, 256);
    assert!(raster.fragments.len() > render::CHUNK, "one chunk only");
    let methods: Vec<RenderMethod> = ["quadratic", "linear", "mapped", "mapped-interp", "tbn"]
        .iter()
        .map(|m| RenderMethod::from_name(m).unwrap())
        .collect();
    let whole = render::frame_in(&scene, &base, raster.clone(), &mesh);
    let (f, levels) =
        render::levels_streamed(&cfg, &scene, &base, raster.clone(), &mesh, &methods).unwrap();
    assert!(f.smooth_rows.is_empty() && f.mapped_rows.is_empty() && f.tbn_rows.is_empty());
    for (m, got) in methods.iter().zip(levels) {
        let want = render::run_method(&cfg, &whole, *m).unwrap();
        assert_eq!(got, want.levels, "{}", m.name());
        let img = render::image_of(&f, *m, got);
        assert_eq!(
            format!("{:?}", img.metrics),
            format!("{:?}", want.metrics),
            "{}",
            m.name()
        );
    }
    let only = render::frame_wanted(
        &scene,
        &base,
        raster,
        &mesh,
        render::Wanted::methods(&methods[..1]),
    );
    assert_eq!(only.smooth_rows, whole.smooth_rows);
    assert!(only.mapped_rows.is_empty() && only.tbn_rows.is_empty());
    assert_eq!(only.smooth_ref, whole.smooth_ref);
}

/// `bench render` times the renderer and the f64 baseline on the same
/// raster and says how many pixels it shaded; two methods at once are
/// refused (it measures one).
#[test]
fn bench_render_measures_one_method_beside_the_baseline() {
    let o = fxshade(&[
        "bench",
        "render",
        "--mesh",
        "sphere:8",
        "--size",
        "64x64",
        "--repeats",
        "1",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(j["covered_pixels"].as_u64().unwrap() > 1000, "{j}");
    for k in [
        "fxshade_ns_per_pixel",
        "baseline_ns_per_pixel",
        "ratio",
        "peak_rss_mib",
    ] {
        assert!(j[k].as_f64().is_some_and(|x| x > 0.0), "{k}: {j}");
    }
    let o = fxshade(&["bench", "render", "--method", "quadratic,linear"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("one method"), "{}", text(&o));
}

/// Issue #37's throughput on a small mesh: the smooth top pipelined for
/// ECP5 at 7 ns (latency over 80) renders sphere:12 at 64 × 64, under ten
/// pixels a triangle, at no more than 1.1 clock cycles a pixel (set-up
/// transfers and the drain included), with the model's image. A top whose
/// triangle port waited for the pipe took 1.92 here.
#[test]
fn the_smooth_top_shades_about_one_pixel_per_clock_on_small_triangles() {
    let (o, _d) = render(&[
        "--mesh",
        "sphere:12",
        "--size",
        "64x64",
        "--method",
        "quadratic",
        "--rtl",
        "--set",
        "rtl.pipeline=\"target\"",
        "--set",
        "rtl.target=\"ecp5\"",
        "--set",
        "rtl.clock_ns=7",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let pixels = j["pixels"].as_u64().unwrap();
    let m = &j["methods"][0];
    assert_eq!(m["rtl"]["identical"], true, "{m}");
    let cycles = m["rtl"]["cycles"].as_u64().unwrap();
    assert!(
        cycles * 10 <= pixels * 11,
        "{cycles} cycles for {pixels} pixels"
    );
}
