//! `fxshade paper`: the normalization paper's Tables 1–4 beside their
//! reproduction.

use clap::Args;
use fxshade_model::paper::{self, Status};

use crate::output::{emit, OutputArgs, Table};

/// `fxshade paper`
#[derive(Args, Debug)]
pub struct PaperArgs {
    #[command(flatten)]
    out: OutputArgs,
}

/// The reproduction as a table.
pub fn table(entries: &[paper::Entry]) -> Table {
    let mut t = Table::new(["table", "Θ", "quantity", "published", "computed", "diff", "status", "reason"]).titled(
        "Normalization paper, Tables 1–4: published (model/data/paper_tables.csv) against recomputed",
    );
    for e in entries {
        t.row([
            e.table.to_string(),
            format!("{}", e.theta),
            e.quantity.to_string(),
            e.published.clone(),
            format!("{:.6}", e.computed),
            format!("{:+.2e}", e.diff),
            match e.status {
                Status::Reproduced => "reproduced",
                Status::Explained => "explained",
                Status::Close => "CLOSE",
                Status::Differs => "DIFFERS",
            }
            .to_string(),
            e.reason.clone().unwrap_or_default(),
        ]);
    }
    t
}

/// Run it.
pub fn run(a: &PaperArgs) -> anyhow::Result<()> {
    let e = paper::reproduce()?;
    emit(a.out, &[table(&e)], &serde_json::to_value(&e)?)
}
