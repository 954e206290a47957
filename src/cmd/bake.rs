//! `fxshade bake-implied`: rewrite a tangent-space normal map baked in a
//! UV-aligned frame into the polar transform's implied frame, through a
//! mesh's UV layout, and report the texels where that is not possible.

use fxshade_model::convert::to_f64;
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use fxshade_model::texture::{bake_implied, Green};

use super::ConfigArgs;
use crate::output::{emit, OutputArgs, Table};

/// `fxshade bake-implied`
#[derive(Args, Debug)]
pub struct BakeArgs {
    #[command(flatten)]
    cfg: ConfigArgs,
    /// The mesh whose texture coordinates lay the map out: `sphere:N`,
    /// `torus:N` (`:x`/`:z` for another axis) or an OBJ file with `vt`.
    #[arg(long, value_name = "PATH.obj|sphere:N|torus:N")]
    mesh: String,
    /// The map, baked in the mesh's UV-aligned frame (RGB or RGBA PNG, 8 or
    /// 16 bits per channel).
    #[arg(long, value_name = "IN.png")]
    normal_map: PathBuf,
    /// Green convention of the input and the output: opengl or directx.
    #[arg(long, value_name = "CONV", default_value = "opengl", value_parser = ["opengl", "directx"])]
    green: String,
    /// Bits per channel of the output.
    #[arg(long, default_value = "16", value_parser = ["8", "16"])]
    bits: String,
    /// The converted map (written atomically).
    #[arg(long, short = 'o', value_name = "OUT.png")]
    out: PathBuf,
    /// Also write the texel flags as a picture: converted grey, unused
    /// black, seams yellow, ambiguous red, poles blue.
    #[arg(long, value_name = "FLAGS.png")]
    flags: Option<PathBuf>,
    #[command(flatten)]
    fmt: OutputArgs,
}

/// Run it.
pub fn run(a: &BakeArgs) -> anyhow::Result<()> {
    let cfg = a.cfg.resolve()?;
    // No output may overwrite the input or the other output.
    let same = fxshade_model::files::same_file;
    let clash = |what: &str, x: &std::path::Path, y: &std::path::Path| {
        crate::output::UsageError(format!(
            "{what}: {} and {} are the same file; nothing was written (name another)",
            x.display(),
            y.display()
        ))
    };
    if same(&a.out, &a.normal_map) {
        return Err(clash("--out and --normal-map", &a.out, &a.normal_map).into());
    }
    if let Some(f) = &a.flags {
        if same(f, &a.out) {
            return Err(clash("--flags and --out", f, &a.out).into());
        }
        if same(f, &a.normal_map) {
            return Err(clash("--flags and --normal-map", f, &a.normal_map).into());
        }
    }
    let mesh = super::render::load_mesh(&a.mesh)?;
    let green = Green::from_name(&a.green).expect("clap checked");
    let map = crate::picture::read_normal_map(&a.normal_map, green)?;
    let scheme = fxshade_model::render::scheme_of(&cfg);
    let bar = crate::progress::bar(1, "bake-implied");
    let b =
        bake_implied(&mesh, &map, scheme).map_err(|e| anyhow::anyhow!("--mesh {}: {e}", a.mesh))?;
    bar.finish_and_clear();
    let bits: u32 = a.bits.parse().expect("clap checked");
    // Both pictures are encoded before either is written.
    let png = crate::picture::normal_map_png(&b.texture, bits, green)?;
    let flags = match &a.flags {
        Some(f) => Some((
            f,
            crate::picture::flags_png(map.width, map.height, &b.flags)?,
        )),
        None => None,
    };
    fxshade_model::files::write_atomic(&a.out, &png)
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    if let Some((f, p)) = flags {
        fxshade_model::files::write_atomic(f, &p)
            .with_context(|| format!("cannot write {}", f.display()))?;
    }
    let c = b.counts;
    let pct = |n: usize| format!("{:.2} %", 100.0 * to_f64(n) / to_f64(c.texels.max(1)));
    let mut t = Table::new(["texels", "count", "share", "what"]).titled(format!(
        "{} ({}×{}) on {} into the implied frame → {}",
        a.normal_map.display(),
        map.width,
        map.height,
        a.mesh,
        a.out.display()
    ));
    for (name, n, what) in [
        ("converted", c.converted, "rewritten in the implied frame"),
        ("seam", c.seam, "within a texel of a UV seam: converted from one side; a sample near it may land across the seam"),
        ("ambiguous", c.ambiguous, "covered by several triangles whose frames differ by more than 1°: one texel cannot hold both"),
        ("pole", c.pole, "near a pole of the implied frame: normal within 2° of the y axis, or the frame turning more than 2° from one texel to the next"),
        ("unused", c.unused, "no triangle covers it: copied unchanged"),
    ] {
        t.row([name.to_string(), n.to_string(), pct(n), what.to_string()]);
    }
    emit(
        a.fmt,
        &[t],
        &serde_json::json!({
            "mesh": a.mesh,
            "input": a.normal_map,
            "output": a.out,
            "width": map.width,
            "height": map.height,
            "bits": bits,
            "counts": c,
        }),
    )
}
