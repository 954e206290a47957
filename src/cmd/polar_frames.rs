//! `fxshade polar-frames`: how far the polar transform's implied tangent
//! frame is from the UV-aligned frame normal maps are baked in, over a mesh.

use clap::Args;
use fxshade_model::mesh::Axis;
use fxshade_model::polar::frames;

use crate::output::{emit, OutputArgs, Table};

/// `fxshade polar-frames`
#[derive(Args, Debug)]
pub struct FramesArgs {
    /// sphere:N or torus:N (N segments around).
    #[arg(long, default_value = "torus:64")]
    mesh: String,
    /// The axis the mesh is built around: y (the transform's own axis), z
    /// (Z-up modelling) or x.
    #[arg(long, default_value = "z", value_parser = parse_axis)]
    axis: Axis,
    #[command(flatten)]
    out: OutputArgs,
}

fn parse_axis(s: &str) -> Result<Axis, String> {
    match s {
        "x" => Ok(Axis::X),
        "y" => Ok(Axis::Y),
        "z" => Ok(Axis::Z),
        _ => Err(format!("`{s}` is not x, y or z")),
    }
}

/// Run it.
pub fn run(a: &FramesArgs) -> anyhow::Result<()> {
    let m = fxshade_flows::scene::procedural(&a.mesh, a.axis)?;
    let c = frames::compare(&m);
    let mut t = Table::new([
        "mesh",
        "triangles",
        "surface > 10° apart",
        "mean (°)",
        "max (°)",
        "near the poles",
    ])
    .titled("Implied tangent frame against the UV-aligned frame, about the normal, area-weighted");
    t.row([
        format!("{} about {:?}", a.mesh, a.axis).to_lowercase(),
        c.triangles.to_string(),
        format!("{:.1} %", 100.0 * c.share_over_10_deg),
        format!("{:.2}", c.mean_deg),
        format!("{:.2}", c.max_deg),
        format!("{:.1} %", 100.0 * c.share_near_poles),
    ]);
    emit(a.out, &[t], &serde_json::to_value(&c)?)
}
