//! The report as one HTML page (`index.html`), readable offline with its
//! images and data files beside it: a summary that recommends, plots,
//! real tables grouped per unit, images beside the right reference, and
//! the paper reproduction collapsed.

use crate::output::Table;

/// Escape text for HTML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A page under construction.
#[derive(Default)]
pub struct Page {
    body: String,
    toc: Vec<(String, String)>,
}

/// Every number right-aligned: a cell is numeric when it parses as one
/// (after a trailing `%` or unit is dropped).
fn numeric(cell: &str) -> bool {
    let c = cell.trim().trim_end_matches('%').trim();
    !c.is_empty() && (c.parse::<f64>().is_ok() || c == "∞")
}

impl Page {
    /// A section heading (listed in the table of contents).
    pub fn h2(&mut self, id: &str, title: &str) {
        self.toc.push((id.to_string(), title.to_string()));
        self.body += &format!("<h2 id=\"{id}\">{}</h2>\n", esc(title));
    }
    /// A sub-heading.
    pub fn h3(&mut self, title: &str) {
        self.body += &format!("<h3>{}</h3>\n", esc(title));
    }
    /// A paragraph of text (escaped).
    pub fn p(&mut self, text: &str) {
        self.body += &format!("<p>{}</p>\n", esc(text));
    }
    /// Raw HTML.
    pub fn raw(&mut self, html: &str) {
        self.body += html;
    }
    /// Links to data files: `(label, relative path)`.
    pub fn files(&mut self, files: &[(&str, &str)]) {
        let l: Vec<String> = files
            .iter()
            .map(|(t, f)| format!("<a href=\"{}\">{}</a>", esc(f), esc(t)))
            .collect();
        self.body += &format!("<p class=\"files\">Data: {}</p>\n", l.join(" · "));
    }
    /// A table (its title as caption).
    pub fn table(&mut self, t: &Table) {
        self.table_rows(t.title.as_deref(), &t.header, &t.rows);
    }
    /// A table from a header and rows.
    pub fn table_rows(&mut self, caption: Option<&str>, header: &[String], rows: &[Vec<String>]) {
        let mut s = String::from("<div class=\"scroll\"><table>");
        if let Some(c) = caption {
            s += &format!("<caption>{}</caption>", esc(c));
        }
        s += "<thead><tr>";
        for h in header {
            s += &format!("<th>{}</th>", esc(h));
        }
        s += "</tr></thead><tbody>";
        for r in rows {
            s += "<tr>";
            for c in r {
                s += &format!(
                    "<td{}>{}</td>",
                    if numeric(c) { " class=\"n\"" } else { "" },
                    esc(c)
                );
            }
            s += "</tr>";
        }
        s += "</tbody></table></div>\n";
        self.body += &s;
    }
    /// A table split by the value of its first column (one sub-heading and
    /// table per value, that column dropped).
    pub fn grouped(&mut self, t: &Table, what: &str) {
        let mut keys: Vec<&String> = Vec::new();
        for r in &t.rows {
            if !keys.contains(&&r[0]) {
                keys.push(&r[0]);
            }
        }
        for k in keys {
            self.h3(&format!("{what} {k}"));
            let rows: Vec<Vec<String>> = t
                .rows
                .iter()
                .filter(|r| &r[0] == k)
                .map(|r| r[1..].to_vec())
                .collect();
            self.table_rows(None, &t.header[1..], &rows);
        }
    }
    /// Images side by side, each with a caption: `(caption, path)`.
    pub fn figures(&mut self, figs: &[(String, String)]) {
        self.body += "<div class=\"figs\">";
        for (c, f) in figs {
            self.body += &format!(
                "<figure><a href=\"{f}\"><img src=\"{f}\" alt=\"{c}\" loading=\"eager\"></a><figcaption>{c}</figcaption></figure>",
                f = esc(f),
                c = esc(c)
            );
        }
        self.body += "</div>\n";
    }
    /// A plot (PNG shown, SVG linked).
    pub fn plot(&mut self, caption: &str, stem: &str) {
        self.body += &format!(
            "<figure class=\"plot\"><img src=\"{stem}.png\" alt=\"{c}\" loading=\"eager\"><figcaption>{c} (<a href=\"{stem}.svg\">SVG</a>)</figcaption></figure>\n",
            stem = esc(stem),
            c = esc(caption)
        );
    }
    /// Open a collapsed section.
    pub fn details_open(&mut self, summary: &str) {
        self.body += &format!("<details><summary>{}</summary>\n", esc(summary));
    }
    /// Close it.
    pub fn details_close(&mut self) {
        self.body += "</details>\n";
    }
    /// The whole document.
    pub fn finish(self, title: &str) -> String {
        let toc: String = self
            .toc
            .iter()
            .map(|(id, t)| format!("<li><a href=\"#{id}\">{}</a></li>", esc(t)))
            .collect();
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{t}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{t}</h1>\n\
             <nav><ol>{toc}</ol></nav>\n{body}\
             <script>{SCRIPT}</script>\n</body>\n</html>\n",
            t = esc(title),
            body = self.body
        )
    }
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;max-width:1200px;margin:1em auto;padding:0 1em;color:#222}\
h1{font-size:1.6em}h2{margin-top:2em;border-bottom:1px solid #ccc}h3{margin-top:1.4em}\
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}th,td{border:1px solid #ccc;padding:2px 6px}\
th{background:#f0f0f0;position:sticky;top:0}td.n{text-align:right;font-variant-numeric:tabular-nums}\
caption{text-align:left;font-weight:600;padding:4px 0}.scroll{overflow-x:auto}\
.figs{display:flex;flex-wrap:wrap;gap:8px}figure{margin:0}figure img{image-rendering:pixelated;max-width:256px}\
figure.plot img{max-width:100%;image-rendering:auto}figcaption{font-size:.8em;color:#555;max-width:256px}\
figure.plot figcaption{max-width:none}.files{font-size:.85em}.rec{background:#eef7ee;padding:.5em 1em;border-left:4px solid #4a4}\
pre{background:#f7f7f7;padding:.5em;overflow-x:auto;font-size:.8em}details{margin:1em 0}summary{cursor:pointer;font-weight:600}";

/// Marks the page with how many images loaded and which did not, for the
/// headless-browser test (and shows a warning to a reader).
const SCRIPT: &str = "window.addEventListener('load',function(){var b=[],n=0;\
document.querySelectorAll('img').forEach(function(i){if(i.complete&&i.naturalWidth>0){n++}else{b.push(i.getAttribute('src'))}});\
document.body.setAttribute('data-images-loaded',n);document.body.setAttribute('data-images-broken',b.join(' '));\
if(b.length){var p=document.createElement('p');p.style.color='red';p.textContent='Images missing: '+b.join(', ');document.body.prepend(p)}});";

/// The stages table with the x/y/z rows of a vector stage folded into one
/// labelled row: consecutive identical quantization points of one stage id
/// (what `quantize3` records for the three components) read `x, y, z`, and
/// longer runs `n × (x, y, z)` or `× n`.
pub fn stages_folded(t: &Table) -> Table {
    let mut header = t.header.clone();
    header.insert(3, "components".into());
    let mut out = Table::new(header);
    out.title = t.title.clone();
    let mut i = 0;
    while i < t.rows.len() {
        let mut j = i + 1;
        while j < t.rows.len() && t.rows[j] == t.rows[i] {
            j += 1;
        }
        let n = j - i;
        let label = match n {
            1 => "1".to_string(),
            3 => "x, y, z".to_string(),
            n if n % 3 == 0 => format!("{} × (x, y, z)", n / 3),
            n => format!("× {n}"),
        };
        let mut r = t.rows[i].clone();
        r.insert(3, label);
        out.rows.push(r);
        i = j;
    }
    out
}

/// What the page shows, computed by `fxshade report`.
pub struct Data<'a> {
    /// The configuration.
    pub cfg: &'a fxshade_model::Config,
    /// Operation counts.
    pub ops: &'a Table,
    /// Quantization points.
    pub stages: &'a Table,
    /// The paper's tables reproduced.
    pub paper: &'a Table,
    /// The normalizer's error tables.
    pub normalize: &'a [Table],
    /// Interpolation error, one line.
    pub interp: &'a str,
    /// Polar transform error, one line.
    pub polar: &'a str,
    /// Implied frames against UV frames, Markdown list.
    pub frames: &'a str,
    /// CORDIC angles, one line.
    pub angles: &'a str,
    /// Rendered metrics, every mesh and method.
    pub summary: &'a Table,
    /// The renders, with their directory prefixes.
    pub renders: &'a [(String, super::render::RenderResult)],
    /// The vector sets, Markdown list.
    pub vectors: &'a str,
    /// The uniform-width sweep per method.
    pub sweeps: &'a [super::report::MethodSweep],
    /// RTL co-simulation results, or why there are none.
    pub rtl: &'a super::report::RtlChecks,
    /// Method B's tables.
    pub method_b: &'a [Table; 3],
    /// Cached synthesis results of this configuration.
    pub synth: &'a [super::synth::SynthResult],
}

/// A Markdown list line `* [`text`](link): rest` as HTML.
fn md_item(line: &str) -> String {
    let l = line.trim_start_matches("* ");
    if let Some(rest) = l.strip_prefix('[') {
        if let Some((text, more)) = rest.split_once("](") {
            if let Some((link, tail)) = more.split_once(')') {
                return format!(
                    "<li><a href=\"{}\"><code>{}</code></a>{}</li>",
                    esc(link),
                    esc(text.trim_matches('`')),
                    esc(tail)
                );
            }
        }
    }
    format!("<li>{}</li>", esc(l.trim_matches('`')))
}

/// The page.
pub fn page(d: &Data) -> String {
    let mut p = Page::default();
    // Escaped for HTML by `p`, and to one printable line first.
    p.p(&format!("Configuration: {}", d.cfg.describe()));
    p.files(&[
        ("config.toml", "config.toml"),
        ("config.json", "config.json"),
        ("the same report as Markdown", "index.md"),
    ]);

    // Summary and recommendation.
    p.h2("summary", "Summary: what to build");
    p.p(&format!(
        "For each method the RTL implements: the narrowest uniform width — every stage of a width group on \
         the method's path at that many bits, each keeping its integer bits; the output stays the 8-bit \
         pixel — that meets the paper's 4 % bound on the relative intensity error and stays within ±1 \
         level of the f64 reference on {} (128 × 128; mapped methods outside the {}° polar cap). Costs \
         are the generated RTL top's, counted from the emitted datapath; the ECP5 estimate is the area \
         model's, without synthesis (`fxshade synth calibrate --area` states its error); synthesized: \
         every cached `fxshade synth pipeline` run of that configuration (FF the top's).",
        super::explore::DEFAULT_MESHES.join(" and "),
        fxshade_model::render::POLAR_CAP_DEG
    ));
    let mut rows = Vec::new();
    for m in d.sweeps {
        match m.recommended {
            Some(k) => {
                let (w, r) = &m.points[k];
                let g = |n: &str| r.get(n).map_or("-".into(), |v| format!("{v}"));
                rows.push(vec![
                    m.method.to_string(),
                    w.to_string(),
                    g("bit_products"),
                    g("muls"),
                    g("adder_bits"),
                    g("table_bits"),
                    g("ff"),
                    g("latency"),
                    g("pipeline.max_err_levels"),
                    format!(
                        "{:.2} %",
                        100.0 * r.get("pipeline.max_rel_err").unwrap_or(f64::NAN)
                    ),
                    super::report_found::device_cells(m.device.as_ref()).0,
                    super::report_found::device_cells(m.device.as_ref()).1,
                    m.select
                        .iter()
                        .map(|o| format!("--set {o}"))
                        .collect::<Vec<_>>()
                        .join(" "),
                ]);
            }
            None => rows.push(vec![
                m.method.to_string(),
                format!(
                    "none of {}–{} bits",
                    super::report::SUMMARY_WIDTHS.start(),
                    super::report::SUMMARY_WIDTHS.end()
                ),
            ]),
        }
    }
    p.raw("<div class=\"rec\">");
    p.table_rows(
        Some("Recommended width per method"),
        &[
            "method",
            "width (bits)",
            "bit products",
            "multipliers",
            "adder bits",
            "table bits",
            "flip-flops",
            "latency",
            "max |error| (levels)",
            "max relative error",
            "ECP5 estimate: LUT / FF / DSP / BRAM",
            "synthesized (cached): LUT / FF / DSP / BRAM, Fmax",
            "selected by",
        ]
        .map(String::from),
        &rows,
    );
    p.raw("</div>");
    if let Some(best) = d
        .sweeps
        .iter()
        .filter_map(|m| Some((m, &m.points[m.recommended?].1)))
        .min_by(|a, b| {
            a.1.get("bit_products")
                .unwrap_or(f64::INFINITY)
                .total_cmp(&b.1.get("bit_products").unwrap_or(f64::INFINITY))
        })
    {
        p.p(&format!(
            "Cheapest overall in multiplier bit products: {} at {} bits. Per-stage widths can be cheaper \
             still: `fxshade explore --optimize --goal 'pipeline.max_err_levels<=1' --goal \
             'pipeline.paper_bound>=1' --minimize bit_products --out opt` searches them and checks the \
             result on both simulators.",
            best.0.method,
            best.0.points[best.0.recommended.expect("filtered")].0
        ));
    }
    p.plot(
        "Largest relative intensity error against width, per method, with the paper's 4 % bound",
        "plots/error_vs_width",
    );
    p.plot(
        "Largest error in 8-bit levels against width",
        "plots/levels_vs_width",
    );
    p.plot(
        "Multiplier bit products against width",
        "plots/cost_vs_width",
    );
    p.plot(
        "Error against cost over every method and width: the Pareto front, the recommended points ringed",
        "plots/pareto",
    );
    let mut srows = Vec::new();
    for m in d.sweeps {
        for (w, r) in &m.points {
            let g = |n: &str| r.get(n).map_or("-".into(), |v| format!("{v}"));
            srows.push(vec![
                m.method.to_string(),
                w.to_string(),
                g("pipeline.max_err_levels"),
                format!(
                    "{:.3} %",
                    100.0 * r.get("pipeline.max_rel_err").unwrap_or(f64::NAN)
                ),
                g("pipeline.paper_bound"),
                g("bit_products"),
                g("adder_bits"),
                g("ff"),
                r.error.clone().unwrap_or_default(),
            ]);
        }
    }
    p.details_open("Every point of the sweep");
    p.table_rows(
        None,
        &[
            "method",
            "width",
            "max |err| (levels)",
            "max rel. err",
            "under 4 %",
            "bit products",
            "adder bits",
            "flip-flops",
            "error",
        ]
        .map(String::from),
        &srows,
    );
    p.details_close();

    // RTL and synthesis.
    p.h2("rtl", "RTL checks and synthesis");
    match d.rtl {
        Ok(v) => {
            p.p("Every unit and the three pipeline tops, generated from this configuration, co-simulated \
                 against the model on Icarus Verilog (300 vectors each, random stalls on both handshakes). \
                 `fxshade rtl-check <unit> --sim verilator` runs the same on Verilator.");
            let rows: Vec<Vec<String>> = v
                .iter()
                .map(|(u, var, n, pa, f, eq)| {
                    vec![
                        u.clone(),
                        var.clone(),
                        n.to_string(),
                        pa.to_string(),
                        f.to_string(),
                        if *f == 0 && *pa == *n as u64 { "bit-exact" } else { "FAILS" }.to_string(),
                        eq.clone(),
                    ]
                })
                .collect();
            p.table_rows(
                None,
                &["unit", "variant", "vectors", "passed", "failed", "verdict", "equivalence"]
                    .map(String::from),
                &rows,
            );
        }
        Err(e) => p.p(&format!(
            "RTL co-simulation was not run: {e}. Install the simulators with `sudo apt-get install iverilog verilator` \
             (./scripts/test does it when run as root), then run the report again."
        )),
    }
    let synth: Vec<Vec<String>> = d
        .synth
        .iter()
        .map(|r| {
            vec![
                r.unit.clone(),
                r.device.clone(),
                r.lut.to_string(),
                (r.ff - r.harness_ff.min(r.ff)).to_string(),
                r.dsp.to_string(),
                r.bram.to_string(),
                r.fmax_mhz.map_or("-".into(), |f| format!("{f:.1}")),
                r.latency.to_string(),
            ]
        })
        .collect();
    if synth.is_empty() {
        p.p("Synthesis is not run by the report (Yosys takes from seconds to minutes per module on this \
             2-core machine). `fxshade synth <unit> --target ice40-hx8k|ice40-up5k|ecp5|xc7|generic` runs \
             Yosys and, for iCE40, nextpnr in a harness that registers every port; its results for this \
             configuration appear here once cached.");
    } else {
        p.p("Synthesis results of this configuration from the cache of `fxshade synth` (Yosys; nextpnr-ice40 \
             for iCE40, one seed at a 100 MHz goal; flip-flops without the harness's). Run `fxshade synth` \
             for the other units and targets.");
        p.table_rows(
            None,
            &[
                "unit",
                "device",
                "LUT",
                "FF",
                "DSP",
                "BRAM",
                "Fmax (MHz)",
                "latency",
            ]
            .map(String::from),
            &synth,
        );
    }

    // Op counts and quantization points.
    p.h2("ops", "Operation counts, per unit");
    p.p("Measured by running each datapath in the counting context.");
    p.files(&[("CSV", "ops.csv"), ("JSON", "ops.json")]);
    p.grouped(d.ops, "Unit");
    p.h2("stages", "Quantization points, per unit");
    p.p("Every quantization point by stage id, in datapath order. Vector stages quantize their x, y and z \
         components alike; they are one row here, labelled.");
    p.files(&[("CSV (one row per component)", "stages.csv")]);
    p.grouped(&stages_folded(d.stages), "Unit");

    // Errors.
    p.h2("errors", "Error of each unit against f64");
    p.h3("Normalizer");
    p.files(&[
        ("CSV", "error_normalize.csv"),
        ("JSON", "error_normalize.json"),
    ]);
    for t in d.normalize {
        p.table(t);
    }
    p.h3("Interpolation");
    p.files(&[("JSON", "error_interp.json")]);
    p.p(d.interp);
    p.h3("Polar transform");
    p.files(&[("JSON", "error_polar.json")]);
    p.p(d.polar);
    p.raw("<ul>");
    for l in d.frames.lines().filter(|l| !l.is_empty()) {
        p.raw(&md_item(l));
    }
    p.raw("</ul>");
    p.h3("CORDIC angles of N");
    p.files(&[("JSON", "error_angles.json")]);
    p.p(d.angles);

    // Images.
    p.h2("images", "Rendered images");
    p.p("Every pixel through the bit-accurate pipeline, beside the f64 reference of its own path: the smooth \
         methods against exact normalization, the mapped methods against the mapped reference (polar \
         angles of the exact normal). Heat-maps colour the error in 8-bit levels; each legend ends at \
         that image's largest error.");
    p.files(&[("CSV", "render.csv"), ("JSON", "render.json")]);
    p.table(d.summary);
    p.plot(
        "Share of pixels by error on torus:24, per method (mapped methods outside the polar cap)",
        "plots/error_histogram",
    );
    for (prefix, r) in d.renders {
        p.h3(&format!(
            "{} ({} triangles, min cos φ {:.3})",
            r.mesh, r.cos_phi.triangles, r.cos_phi.min
        ));
        let f = |c: &str, n: &str| (c.to_string(), format!("{prefix}{n}.png"));
        p.figures(&[
            f("smooth reference (f64)", "reference"),
            f("quadratic", "quadratic"),
            f("quadratic: error", "quadratic_error"),
            f("linear", "linear"),
            f("linear: error", "linear_error"),
        ]);
        p.figures(&[
            f("mapped reference (f64)", "reference_mapped"),
            f("mapped (CORDIC)", "mapped"),
            f("mapped: error", "mapped_error"),
            f("mapped-interp", "mapped-interp"),
            f("mapped-interp: error", "mapped-interp_error"),
        ]);
    }
    p.h2(
        "method-b",
        "Method B: three ways to the tangent-space L and H",
    );
    for t in d.method_b {
        p.table(t);
    }
    for (prefix, r) in d.renders {
        p.h3(&r.mesh);
        let f = |c: &str, n: &str| (c.to_string(), format!("{prefix}{n}.png"));
        p.figures(&[
            f("mapped reference (f64)", "reference_mapped"),
            f("tbn (interpolated TBN)", "tbn"),
            f("tbn: error", "tbn_error"),
            f("tbn in f64: error", "tbn_f64_error"),
            f(
                "angle interpolation alone (f64): error",
                "angle_interp_error",
            ),
        ]);
    }

    // Vectors and the paper.
    p.h2("vectors", "Test vectors");
    p.raw("<ul>");
    for l in d.vectors.lines().filter(|l| !l.is_empty()) {
        p.raw(&md_item(l));
    }
    p.raw("</ul>");
    p.p("Run them through the RTL with `fxshade rtl-check <unit>`.");
    p.h2("paper", "The normalization paper reproduced");
    p.files(&[("CSV", "paper.csv"), ("JSON", "paper.json")]);
    p.details_open("Tables 1–4 beside their reproduction");
    p.table(d.paper);
    p.details_close();
    p.finish("fxshade report")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vector_stages_fold_into_labelled_rows() {
        let mut t = Table::new(["unit", "variant", "stage id", "out"]);
        for _ in 0..3 {
            t.row(["n", "q", "n.out", "I2F14"]);
        }
        t.row(["n", "q", "n.g", "U1F17"]);
        for _ in 0..9 {
            t.row(["i", "q", "i.vertex", "I2F14"]);
        }
        let f = stages_folded(&t);
        let labels: Vec<&str> = f.rows.iter().map(|r| r[3].as_str()).collect();
        assert_eq!(labels, ["x, y, z", "1", "3 × (x, y, z)"]);
    }

    #[test]
    fn text_is_escaped() {
        assert_eq!(esc("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
        let mut p = Page::default();
        p.p("<script>");
        assert!(p.finish("t").contains("&lt;script&gt;"));
    }
}
