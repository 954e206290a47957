//! Normal maps from image files (issue #15, item 5): `render --normal-map
//! FILE.png` with either green convention, `--normal-map-frame uv`, and
//! `fxshade bake-implied`. The maps are made here, independently of the
//! code under test: one procedural, one from a height field, both baked in
//! the mesh's UV-aligned frame.

use crate::common::*;
use std::path::Path;

/// Write `n(u, v)` (unit normals, OpenGL green) as a 16-bit RGB PNG of
/// `w × h` texels, row 0 at the top (`v` near 1), green flipped for
/// DirectX when asked.
fn write_map(path: &Path, w: usize, h: usize, directx: bool, n: impl Fn(f64, f64) -> [f64; 3]) {
    let mut data = Vec::with_capacity(w * h * 6);
    for row in 0..h {
        for x in 0..w {
            let (u, v) = (
                (x as f64 + 0.5) / w as f64,
                (h as f64 - row as f64 - 0.5) / h as f64,
            );
            let mut c = n(u, v);
            if directx {
                c[1] = -c[1];
            }
            for k in c {
                let s = (((k + 1.0) / 2.0 * 65535.0).round().clamp(0.0, 65535.0)) as u16;
                data.extend_from_slice(&s.to_be_bytes());
            }
        }
    }
    let f = std::fs::File::create(path).unwrap();
    let mut e = png::Encoder::new(std::io::BufWriter::new(f), w as u32, h as u32);
    e.set_color(png::ColorType::Rgb);
    e.set_depth(png::BitDepth::Sixteen);
    e.write_header().unwrap().write_image_data(&data).unwrap();
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}

/// Bumps: the gradient of `sin(2π·8u)·sin(2π·4v)`.
fn procedural(u: f64, v: f64) -> [f64; 3] {
    let (a, b) = (
        std::f64::consts::TAU * 8.0 * u,
        std::f64::consts::TAU * 4.0 * v,
    );
    unit([-0.5 * a.cos() * b.sin(), -0.5 * a.sin() * b.cos(), 1.0])
}

/// A height field of Gaussian blobs, differentiated by central differences
/// over a texel.
fn from_height(w: usize, h: usize) -> impl Fn(f64, f64) -> [f64; 3] {
    let blobs: Vec<(f64, f64, f64)> = (0..40)
        .map(|k| {
            let k = f64::from(k);
            (
                (k * 0.618_034).fract(),
                (k * 0.414_214).fract(),
                0.02 + 0.03 * (k * 0.3).sin().abs(),
            )
        })
        .collect();
    let height = move |u: f64, v: f64| -> f64 {
        blobs
            .iter()
            .map(|&(bu, bv, r)| {
                // Wrapping distance, so the field tiles.
                let du = (u - bu + 0.5).rem_euclid(1.0) - 0.5;
                let dv = (v - bv + 0.5).rem_euclid(1.0) - 0.5;
                (-(du * du + dv * dv) / (r * r)).exp() * r * 0.5
            })
            .sum()
    };
    move |u, v| {
        let (eu, ev) = (1.0 / w as f64, 1.0 / h as f64);
        let dhu = (height(u + eu, v) - height(u - eu, v)) / (2.0 * eu);
        let dhv = (height(u, v + ev) - height(u, v - ev)) / (2.0 * ev);
        // The UV square spans about 2π by π on the unit meshes.
        unit([-dhu / 6.0, -dhv / 3.0, 1.0])
    }
}

fn json(o: &std::process::Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", text(o));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn decode(p: &Path) -> Vec<u8> {
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
    let mut r = dec.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size()];
    let info = r.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    buf
}

/// The f64 image of the original (UV-frame) map with the UV-frame TBN
/// transform and the bit-accurate image of the converted map with the
/// polar transform agree within 2 levels away from seams and poles, for a
/// procedural map and a map made from a height field, on a sphere and on a
/// torus built about z (where the two frames differ over most of the
/// surface).
#[test]
fn converted_maps_render_like_the_originals_in_their_uv_frame() {
    let d = tempfile::tempdir().unwrap();
    let (w, h) = (512, 256);
    let proc_map = d.path().join("bumps_uv.png");
    write_map(&proc_map, w, h, false, procedural);
    let height_map = d.path().join("height_uv.png");
    write_map(&height_map, w, h, false, from_height(w, h));
    for map in [&proc_map, &height_map] {
        for mesh in ["sphere:24", "torus:24:z"] {
            let out = d.path().join("r");
            let j = json(&fxshade(&[
                "render",
                "--mesh",
                mesh,
                "--size",
                "256x256",
                "--method",
                "mapped",
                "--normal-map",
                map.to_str().unwrap(),
                "--normal-map-frame",
                "uv",
                "--out",
                out.to_str().unwrap(),
                "--force",
                "--json",
            ]));
            let c = &j["uv_frame_check"];
            let what = format!("{} on {mesh}", map.display());
            assert!(c["max_abs_levels"].as_u64().unwrap() <= 2, "{what}: {c}");
            let pixels = j["pixels"].as_u64().unwrap();
            let left_out = j["uv_frame_excluded"].as_u64().unwrap();
            assert!(c["pixels"].as_u64().unwrap() + left_out == pixels, "{what}");
            assert!(
                left_out * 10 < pixels,
                "{what}: {left_out} of {pixels} left out"
            );
            let b = &j["normal_map_bake"];
            assert!(
                b["seam"].as_u64().unwrap() > 0,
                "{what}: the u seam is flagged"
            );
            for f in ["reference_uv.png", "mapped_vs_uv_error.png"] {
                assert!(out.join(f).is_file(), "{what}: {f}");
            }
        }
    }
}

/// `bake-implied` writes the converted map; rendering that file as an
/// implied-frame map gives the image of the in-memory conversion (up to
/// the 16-bit file's rounding); DirectX green gives the same images as
/// OpenGL green for the same normals.
#[test]
fn bake_implied_writes_the_converted_map_and_green_conventions_agree() {
    let d = tempfile::tempdir().unwrap();
    let (w, h) = (256, 128);
    let gl = d.path().join("gl.png");
    let dx = d.path().join("dx.png");
    write_map(&gl, w, h, false, procedural);
    write_map(&dx, w, h, true, procedural);
    let baked = d.path().join("baked.png");
    let flags = d.path().join("flags.png");
    let j = json(&fxshade(&[
        "bake-implied",
        "--mesh",
        "torus:24:z",
        "--normal-map",
        gl.to_str().unwrap(),
        "--out",
        baked.to_str().unwrap(),
        "--flags",
        flags.to_str().unwrap(),
        "--json",
    ]));
    let c = &j["counts"];
    let sum: u64 = ["converted", "seam", "ambiguous", "pole", "unused"]
        .iter()
        .map(|k| c[k].as_u64().unwrap())
        .sum();
    assert_eq!(sum, (w * h) as u64);
    assert!(baked.is_file() && flags.is_file());
    let render = |map: &Path, frame: &str, green: &str, name: &str| {
        let out = d.path().join(name);
        json(&fxshade(&[
            "render",
            "--mesh",
            "torus:24:z",
            "--size",
            "96x96",
            "--method",
            "mapped",
            "--normal-map",
            map.to_str().unwrap(),
            "--normal-map-frame",
            frame,
            "--green",
            green,
            "--out",
            out.to_str().unwrap(),
            "--json",
        ]));
        decode(&out.join("mapped.png"))
    };
    let mem = render(&gl, "uv", "opengl", "a");
    let file = render(&baked, "implied", "opengl", "b");
    let differ = mem.iter().zip(&file).filter(|(a, b)| a != b).count();
    let worst = mem
        .iter()
        .zip(&file)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    assert!(
        worst <= 1 && differ * 100 < mem.len(),
        "{differ} pixels, worst {worst}"
    );
    assert_eq!(render(&dx, "uv", "directx", "c"), mem, "DirectX green");
    // A DirectX map read as OpenGL is a different map.
    assert_ne!(render(&dx, "uv", "opengl", "e"), mem);
}

#[test]
fn bad_normal_map_files_are_named() {
    let d = tempfile::tempdir().unwrap();
    let grey = d.path().join("grey.png");
    {
        let f = std::fs::File::create(&grey).unwrap();
        let mut e = png::Encoder::new(std::io::BufWriter::new(f), 4, 4);
        e.set_color(png::ColorType::Grayscale);
        e.write_header()
            .unwrap()
            .write_image_data(&[0u8; 16])
            .unwrap();
    }
    let junk = d.path().join("junk.png");
    std::fs::write(&junk, b"not a png").unwrap();
    let out = d.path().join("r");
    for (map, want) in [
        ("missing.png", "no such file"),
        (grey.to_str().unwrap(), "RGB or RGBA"),
        (junk.to_str().unwrap(), "not a PNG file"),
    ] {
        let o = fxshade(&[
            "render",
            "--mesh",
            "sphere:6",
            "--size",
            "8x8",
            "--normal-map",
            map,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(!o.status.success(), "{map}");
        assert!(text(&o).contains(want), "{map}: {}", text(&o));
        assert!(!text(&o).contains("panicked"), "{map}: {}", text(&o));
    }
    // A mesh without texture coordinates cannot lay a map out.
    let good = d.path().join("good.png");
    write_map(&good, 8, 4, false, procedural);
    let obj = d.path().join("novt.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",
    )
    .unwrap();
    for args in [
        vec![
            "render",
            "--mesh",
            obj.to_str().unwrap(),
            "--size",
            "8x8",
            "--normal-map",
            good.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        vec![
            "bake-implied",
            "--mesh",
            obj.to_str().unwrap(),
            "--normal-map",
            good.to_str().unwrap(),
            "--out",
            d.path().join("b.png").to_str().unwrap(),
        ],
    ] {
        let o = fxshade(&args);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            text(&o).contains("no texture coordinates"),
            "{args:?}: {}",
            text(&o)
        );
    }
    assert!(!d.path().join("b.png").exists());
    // Image-map flags on a procedural map, and a UV-frame comparison
    // without the method it compares, are refused.
    for (args, want) in [
        (
            vec!["--normal-map", "bumps", "--green", "directx"],
            "procedural",
        ),
        (
            vec![
                "--normal-map",
                good.to_str().unwrap(),
                "--normal-map-frame",
                "uv",
                "--method",
                "quadratic",
            ],
            "include mapped",
        ),
    ] {
        let mut a = vec![
            "render",
            "--mesh",
            "sphere:6",
            "--size",
            "8x8",
            "--out",
            out.to_str().unwrap(),
        ];
        a.extend(args);
        let o = fxshade(&a);
        assert!(
            !o.status.success() && text(&o).contains(want),
            "{a:?}: {}",
            text(&o)
        );
    }
    let o = fxshade(&[
        "bake-implied",
        "--mesh",
        "sphere:6",
        "--normal-map",
        grey.to_str().unwrap(),
        "--out",
        d.path().join("o.png").to_str().unwrap(),
    ]);
    assert!(
        !o.status.success() && text(&o).contains("RGB or RGBA"),
        "{}",
        text(&o)
    );
    assert!(!d.path().join("o.png").exists(), "nothing half-written");
}
