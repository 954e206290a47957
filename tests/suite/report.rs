//! `fxshade report`: the HTML page opens in headless Chromium with every
//! image loaded and every link resolving, it recommends, and the README's
//! generated section is what it measures.

use std::process::Command;

use crate::common::{fxshade, text};

/// Chromium's binary (Debian's `chromium`); the test fails without it.
fn chromium() -> &'static str {
    for c in ["chromium", "chromium-browser", "google-chrome"] {
        if Command::new(c).arg("--version").output().is_ok() {
            return c;
        }
    }
    panic!("no Chromium: install it with `sudo apt-get install chromium` (./scripts/test does it as root)");
}

/// Every `href="…"` and `src="…"` of a page.
fn targets(html: &str) -> Vec<String> {
    let mut v = Vec::new();
    for attr in ["href=\"", "src=\""] {
        let mut rest = html;
        while let Some(i) = rest.find(attr) {
            rest = &rest[i + attr.len()..];
            let end = rest.find('"').expect("closed attribute");
            v.push(rest[..end].replace("&amp;", "&"));
            rest = &rest[end..];
        }
    }
    v
}

#[test]
fn the_html_report_renders_in_headless_chromium_with_every_image() {
    let browser = chromium();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    // The default configuration, from a path made to inject into the page
    // (#30.7): it must show escaped.
    let nasty = dir.path().join("cfg\n<b>x</b> `y` $(z)");
    std::fs::create_dir_all(&nasty).unwrap();
    let cfg = nasty.join("default.toml");
    let shown = fxshade(&["config", "show"]);
    std::fs::write(&cfg, &shown.stdout).unwrap();
    let r = fxshade(&[
        "report",
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", text(&r));
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert!(
        !html.contains("<b>x</b>") && html.contains("&lt;b&gt;x&lt;/b&gt;"),
        "the configuration's path is escaped in the page"
    );
    let md = std::fs::read_to_string(out.join("index.md")).unwrap();
    assert!(md.contains("cfg\\n\\<b\\>x"), "escaped in Markdown: {md}");

    // The README's generated section is this report's `found.md`.
    let readme = std::fs::read_to_string(crate::common::repo().join("README.md")).unwrap();
    let begin = readme
        .find("<!-- BEGIN found")
        .expect("a BEGIN found line in README.md");
    let begin = begin + readme[begin..].find('\n').unwrap();
    let end = readme
        .find("<!-- END found -->")
        .expect("an END found line in README.md");
    let found = std::fs::read_to_string(out.join("found.md")).unwrap();
    assert!(
        readme[begin..end].trim() == found.trim(),
        "README.md's generated section differs from a fresh report's found.md: \
         run `cargo run --release -- report --out report --readme README.md`"
    );

    // Links and images: local files that exist, or anchors on the page;
    // nothing outside the report.
    let t = targets(&html);
    let images = html.matches("<img ").count();
    assert!(images > 50, "{images} images");
    for target in &t {
        if let Some(id) = target.strip_prefix('#') {
            assert!(html.contains(&format!("id=\"{id}\"")), "no anchor {target}");
            continue;
        }
        assert!(
            !target.contains("://") && !target.starts_with('/'),
            "{target} leaves the report"
        );
        assert!(out.join(target).is_file(), "{target} is missing");
    }

    // The browser: a screenshot, and the page's own count of loaded and
    // broken images after the load event.
    let shot = dir.path().join("shot.png");
    let url = format!("file://{}", out.join("index.html").display());
    let s = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
        ])
        .arg("--window-size=1280,2000")
        .arg(format!("--screenshot={}", shot.display()))
        .arg(&url)
        .output()
        .unwrap();
    assert!(s.status.success(), "{}", text(&s));
    let png = std::fs::read(&shot).expect("a screenshot");
    assert_eq!(&png[1..4], b"PNG");
    assert!(
        png.len() > 50_000,
        "a near-empty screenshot ({} bytes)",
        png.len()
    );
    let d = Command::new(browser)
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--dump-dom"])
        .arg(&url)
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&d.stdout);
    assert!(
        dom.contains(&format!("data-images-loaded=\"{images}\"")),
        "not every image loaded: {}",
        dom.split("data-images")
            .nth(1)
            .unwrap_or("no load marker")
            .chars()
            .take(400)
            .collect::<String>()
    );
    assert!(dom.contains("data-images-broken=\"\""), "broken images");

    // One judgement per method (#36 item 5): the images table's ✗ in
    // found.md and the rendered table's `under 4 %` (render.csv) are the
    // same verdict for every mesh and method, mapped methods judged
    // outside the polar cap in both, every pixel's figure beside.
    let csv = std::fs::read_to_string(out.join("render.csv")).unwrap();
    let mut judged = 0;
    let header: Vec<&str> = found
        .lines()
        .find(|l| l.starts_with("| mesh | min cos φ |"))
        .expect("the images table in found.md")
        .split('|')
        .map(str::trim)
        .collect();
    for line in found
        .lines()
        .filter(|l| l.starts_with("| sphere:") || l.starts_with("| torus:"))
    {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        for (k, method) in header.iter().enumerate().skip(3) {
            if method.is_empty() {
                continue;
            }
            let row = csv
                .lines()
                .find(|r| {
                    r.starts_with(&format!("{},", cells[1])) && r.contains(&format!(",{method},"))
                })
                .unwrap_or_else(|| panic!("{} {method} not in render.csv", cells[1]));
            let under = row.contains(",yes,");
            assert_eq!(
                !cells[k].contains('✗'),
                under,
                "{} {method}: found.md `{}` against render.csv `{row}`",
                cells[1],
                cells[k]
            );
            let mapped = ["mapped", "mapped-interp", "tbn"].contains(method);
            assert_eq!(row.contains("outside the 2° cap"), mapped, "{row}");
            judged += 1;
        }
    }
    assert!(judged >= 30, "{judged} verdicts compared");
    // The decision table carries the ECP5 estimate.
    assert!(
        found.contains("ECP5 estimate: LUT / FF / DSP / BRAM"),
        "{found}"
    );

    // It recommends, per method, with costs, and shows the plots.
    for needle in [
        "Recommended width per method",
        "<td>quadratic</td>",
        "<td>mapped</td>",
        "plots/error_vs_width.png",
        "plots/pareto.png",
        "<details>",
        "x, y, z",
    ] {
        assert!(html.contains(needle), "no {needle}");
    }
}
