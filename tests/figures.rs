//! The figures and the report page of a real run, as a reader receives them: the
//! silentblock experiment (the paper's Figs. 6 and 7) written as SVG, PNG and PDF, tick
//! labels for people, the truth drawn on top, wrong models clipped with a mark, and
//! `report.html` holding every table and figure. (CI opens the page in Chromium as well:
//! tests/browser/check_report.py.)

use std::path::Path;
use std::process::Command;

/// The texts of an SVG's `<text>` elements.
fn texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let body = &t[t.find('>')? + 1..];
            Some(body[..body.find("</text>")?].to_string())
        })
        .collect()
}

fn silentblock_run(dir: &Path) {
    let src = std::fs::read_to_string("scenarios/silentblock.toml").unwrap();
    let src = src.replace("record_length = 312.5", "record_length = 40.0");
    let scenario = dir.join("silentblock.toml");
    std::fs::write(&scenario, src).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_fpkbench"))
        .args(["run", scenario.to_str().unwrap(), "--out", dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.code().is_some_and(|c| c <= 1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn silentblock_writes_the_papers_figures_in_three_formats_and_one_page() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    silentblock_run(dir);
    for stem in [
        "characteristics",
        "compare",
        "spectrum",
        "densities",
        "response_spectra",
    ] {
        let svg = std::fs::read_to_string(dir.join(format!("{stem}.svg"))).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "{stem}");
        let png = std::fs::read(dir.join(format!("{stem}.png"))).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{stem}.png");
        let pdf = std::fs::read(dir.join(format!("{stem}.pdf"))).unwrap();
        assert!(pdf.starts_with(b"%PDF-") && pdf.len() > 2000, "{stem}.pdf");
        // Tick labels and legends for people: no float artefacts, no negative zero.
        for t in texts(&svg) {
            assert!(!t.contains("00000000") && !t.contains("99999999"), "{stem}: {t:?}");
            assert!(!["-0", "−0", "-0.0", "−0.0"].contains(&t.as_str()), "{stem}: {t:?}");
        }
        // Coordinates below a pixel; no integer staircase.
        assert!(
            svg.contains(".25") || svg.contains(".5") || svg.contains(".75"),
            "{stem}"
        );
    }
    // Fig. 6: log–log with decade and sub-decade labels on both axes.
    let spectrum = std::fs::read_to_string(dir.join("spectrum.svg")).unwrap();
    let labels = texts(&spectrum);
    for want in ["10", "100", "20", "50", "200"] {
        assert!(
            labels.iter().any(|t| t == want),
            "Fig. 6 has no ω label {want}: {labels:?}"
        );
    }
    assert!(spectrum.contains("fitted (3.20)") && spectrum.contains("true: A = 250"));
    // Fig. 7: the cubic against the equivalent-linear model, formulas in the legend.
    let compare = std::fs::read_to_string(dir.join("compare.svg")).unwrap();
    assert!(
        compare.contains("weak [linear]: K(u) = ") && compare.contains(" u³"),
        "Fig. 7 legend"
    );
    // Captions are text in the page, not pixels in the image.
    assert!(
        !compare.contains("equivalent-linear model"),
        "Fig. 7's caption belongs to the page"
    );
    assert!(
        !spectrum.contains("The paper's Fig. 6"),
        "Fig. 6's caption belongs to the page"
    );
    // The characteristics: the truth is the last curve drawn (on top of the estimates);
    // the naive white-noise model leaves the range and is marked; the damping is known.
    let ch = std::fs::read_to_string(dir.join("characteristics.svg")).unwrap();
    let first_panel = &ch[..ch.find("</g>").unwrap()];
    let last_curve = first_panel.rfind("<path d=").unwrap();
    assert!(
        first_panel[last_curve..].contains("stroke=\"#000000\""),
        "truth not on top"
    );
    assert!(ch.contains("weak-white-naive") && ch.contains("off scale ▲▼"));
    assert!(ch.contains("known, not identified"));
    // Under the identified stiffness, the residual of each FPK estimate with its band.
    assert!(ch.contains("K\u{302}(u) − K(u)"), "residual panel");
    assert!(!ch.contains("stroke=\"#000000\" stroke-width=\"3"), "the truth is thin");
    // The page: every table a table, every figure inline, the diagnostics folded.
    let html = std::fs::read_to_string(dir.join("report.html")).unwrap();
    assert_eq!(html.matches("<figure id=\"figure-").count(), 5, "five figures inline");
    assert_eq!(html.matches("<svg").count(), 5);
    assert!(html.matches("<table>").count() >= 8);
    assert!(html.contains("<details><summary>diagnostics of weak</summary>"));
    assert!(
        !html.contains("<script") && !html.contains("src=\"http"),
        "self-contained"
    );
    // report.md is real markdown linking the same figures.
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    for f in ["characteristics.svg", "compare.svg", "spectrum.svg", "densities.svg"] {
        assert!(md.contains(&format!("]({f})")), "{f} not linked");
    }
    assert!(md.contains("|---|"));
    assert!(
        md.contains("the equivalent-linear model") && md.contains("The paper's Fig. 6"),
        "captions in the page"
    );
    assert!(html.contains("<figcaption>") && html.contains("the equivalent-linear model"));
}
