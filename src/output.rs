//! How figures leave the tool: a table for people, or CSV, or JSON.

use std::io::Write;

use clap::Args;

/// `--json` / `--csv`, on every command that prints figures.
#[derive(Args, Debug, Clone, Copy, Default)]
pub struct OutputArgs {
    /// Print JSON instead of a table.
    #[arg(long, conflicts_with = "csv")]
    pub json: bool,
    /// Print CSV instead of a table.
    #[arg(long)]
    pub csv: bool,
}

/// A table of figures: a header row and rows of cells.
#[derive(Debug, Clone, Default)]
pub struct Table {
    /// Title printed above the table for people (not in CSV).
    pub title: Option<String>,
    /// Column names.
    pub header: Vec<String>,
    /// Rows, each as long as the header.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with the given columns.
    pub fn new<S: Into<String>>(header: impl IntoIterator<Item = S>) -> Self {
        Table {
            title: None,
            header: header.into_iter().map(Into::into).collect(),
            rows: Vec::new(),
        }
    }
    /// With a title.
    pub fn titled(mut self, t: impl Into<String>) -> Self {
        self.title = Some(t.into());
        self
    }
    /// Append a row.
    pub fn row<S: ToString>(&mut self, cells: impl IntoIterator<Item = S>) {
        self.rows
            .push(cells.into_iter().map(|c| c.to_string()).collect());
    }
    /// Render for people.
    pub fn render(&self) -> String {
        let mut t = comfy_table::Table::new();
        t.load_preset(comfy_table::presets::ASCII_BORDERS_ONLY_CONDENSED);
        t.set_header(&self.header);
        for r in &self.rows {
            t.add_row(r);
        }
        for (i, c) in t.column_iter_mut().enumerate() {
            if i > 0 {
                c.set_cell_alignment(comfy_table::CellAlignment::Right);
            }
        }
        match &self.title {
            Some(title) => format!("{title}\n{t}\n"),
            None => format!("{t}\n"),
        }
    }
    /// Render as CSV (RFC 4180 quoting).
    pub fn to_csv(&self) -> anyhow::Result<String> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(&self.header)?;
        for r in &self.rows {
            w.write_record(r)?;
        }
        Ok(String::from_utf8(w.into_inner()?)?)
    }
}

/// Write `text` to standard output and flush it. A closed pipe surfaces as
/// an `io::Error` of kind `BrokenPipe` (which `main` turns into a quiet exit
/// with status 0); any other failure (a full device) is an error naming
/// standard output.
pub fn print_out(text: &str) -> anyhow::Result<()> {
    use anyhow::Context;
    let mut o = std::io::stdout().lock();
    o.write_all(text.as_bytes())
        .and_then(|_| o.flush())
        .context("cannot write to standard output")
}

/// Print `tables` for people or as CSV, or `json` as JSON.
pub fn emit(out: OutputArgs, tables: &[Table], json: &serde_json::Value) -> anyhow::Result<()> {
    let mut text = String::new();
    emit_into(&mut text, out, tables, json)?;
    print_out(&text)
}

fn emit_into(
    stdout: &mut String,
    out: OutputArgs,
    tables: &[Table],
    json: &serde_json::Value,
) -> anyhow::Result<()> {
    use std::fmt::Write;
    if out.json {
        writeln!(stdout, "{}", serde_json::to_string_pretty(json)?)?;
    } else if out.csv {
        for (i, t) in tables.iter().enumerate() {
            if i > 0 {
                writeln!(stdout)?;
            }
            write!(stdout, "{}", t.to_csv()?)?;
        }
    } else {
        for (i, t) in tables.iter().enumerate() {
            if i > 0 {
                writeln!(stdout)?;
            }
            write!(stdout, "{}", t.render())?;
        }
    }
    Ok(())
}

pub use fxshade_flows::UsageError;
