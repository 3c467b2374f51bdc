//! The demo's own sections of its report page (the PVS sections come from `crate::report`):
//! the steps with their timings, overview images, the from-point sets, GVS++ against RAND at
//! equal rays, and the culling camera path.

use std::fmt::Write as _;

use anyhow::Result;
use image::RgbImage;
use sightline_cull::{FrameStats, SimReport};

use sightline_eval::report::colour::hex;
use sightline_eval::report::html::{escape, img, Cell, Section, Table};
use sightline_eval::report::plot::{line_plot, series_colour, Series};
use sightline_eval::report::CellOutcome;

/// One step of the demo.
pub(crate) struct Step {
    /// What it did.
    pub name: String,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Its result in words.
    pub result: String,
}

/// The three from-point sets: `(triangles, seconds)` each.
pub(crate) struct FromPoint {
    /// Image size (square).
    pub resolution: u32,
    /// Reference rasterizer (pixel centres).
    pub sampled: (usize, f64),
    /// Analytic (exact).
    pub exact: (usize, f64),
    /// RV (conservative).
    pub conservative: (usize, f64),
    /// Triangles in the sampled set but not in the exact one.
    pub sampled_not_exact: usize,
    /// Triangles in the exact set but not in the conservative one (0 when RV is conservative).
    pub exact_not_conservative: usize,
    /// RV's peak memory.
    pub rv_peak_mib: f64,
}

/// The steps table.
pub(crate) fn steps(steps: &[Step]) -> Section {
    let mut t = Table::new("steps-table", &["step", "seconds", "result"]);
    for s in steps {
        t.row(
            vec![
                Cell::Text(s.name.clone()),
                Cell::Num(format!("{:.3}", s.seconds)),
                Cell::Text(s.result.clone()),
            ],
            &[],
        );
    }
    Section::new("steps", "Steps", t.html())
}

/// The overview (shaded and triangle ids) and the street-level cube map.
pub(crate) fn overview(overview: &[RgbImage], cube: &[RgbImage]) -> Result<Section> {
    let mut body =
        String::from("<p>Reference rasterizer: shaded, and one colour per triangle.</p>\n");
    for (im, alt) in overview
        .iter()
        .zip(["overview, shaded", "overview, triangle ids"])
    {
        body.push_str(&img(im, alt, 512)?);
        body.push('\n');
    }
    body.push_str("<h3>Cube map at street level</h3>\n");
    for (i, im) in cube.iter().enumerate() {
        body.push_str(&img(im, &format!("cube face {i}"), 180)?);
        body.push('\n');
    }
    Ok(Section::new("overview", "Overview", body))
}

/// The from-point sets table.
pub(crate) fn from_point(p: &FromPoint) -> Section {
    let mut t = Table::new(
        "from-point-table",
        &["method", "guarantee", "visible triangles", "seconds"],
    );
    for (name, guarantee, (n, s)) in [
        ("reference rasterizer", "pixel centres only", p.sampled),
        ("analytic (Auzinger 2013)", "exact", p.exact),
        (
            "RV (Ivanchenko 2021)",
            "conservative, bounded memory",
            p.conservative,
        ),
    ] {
        t.row(
            vec![
                Cell::Text(name.into()),
                Cell::Text(guarantee.into()),
                Cell::Num(n.to_string()),
                Cell::Num(format!("{s:.3}")),
            ],
            &[("triangles", n.to_string())],
        );
    }
    let body = format!(
        "<p>Triangles visible from the overview point at {r}×{r}. Sampled but not in the exact \
         set: {} (the rasterizer snaps vertices to 1/256 pixel, so a triangle seen almost \
         edge-on can cover a pixel centre it does not really cover: the ray through that centre \
         hits another triangle); exact but not in the conservative set: {} (0 when RV is \
         conservative, as it must be); RV peak memory {:.1} MiB.</p>\n{}",
        p.sampled_not_exact,
        p.exact_not_conservative,
        p.rv_peak_mib,
        t.html(),
        r = p.resolution
    );
    Section::new(
        "from-point",
        "From a point: sampled, exact, conservative",
        body,
    )
}

/// GVS++ against RAND at the same number of rays per cell, on the same views.
pub(crate) fn gvspp_vs_rand(outcomes: &[CellOutcome]) -> Section {
    let mut t = Table::new(
        "rand-table",
        &[
            "cell",
            "GVS++ PVS",
            "RAND PVS",
            "GVS++ avg error px",
            "RAND avg error px",
            "GVS++ seen but missing",
            "RAND seen but missing",
        ],
    );
    for (i, o) in outcomes.iter().enumerate() {
        let Some(r) = o.extra.first() else { continue };
        t.row(
            vec![
                Cell::Num(i.to_string()),
                Cell::Num(o.eval.pvs_size.to_string()),
                Cell::Num(r.pvs_size.to_string()),
                Cell::Num(format!("{:.3}", o.eval.avg_error_pixels)),
                Cell::Num(format!("{:.3}", r.avg_error_pixels)),
                Cell::Num(o.eval.false_negatives.to_string()),
                Cell::Num(r.false_negatives.to_string()),
            ],
            &[],
        );
    }
    Section::new(
        "gvspp-vs-rand",
        "GVS++ against RAND at equal rays",
        format!(
            "<p>RAND (uniform random rays from the cell) with as many rays as GVS++ used in each \
             cell, judged on the same views.</p>\n{}",
            t.html()
        ),
    )
}

/// The culling path: a table per method and plots per frame.
pub(crate) fn culling(reports: &[SimReport]) -> Result<Section> {
    let mut t = Table::new(
        "culling-table",
        &[
            "method",
            "frames",
            "objects drawn (mean)",
            "exactly visible (mean)",
            "queries (mean)",
            "cull ms (mean)",
            "popping % (mean)",
            "popping % (max)",
            "longest missing streak",
        ],
    );
    for r in reports {
        let pixels = r.pixels.max(1) as f64;
        let max_pop = r
            .measured()
            .iter()
            .map(|f| f.popping_pixels)
            .max()
            .unwrap_or(0);
        t.row(
            vec![
                Cell::Text(r.method.name().into()),
                Cell::Num(r.measured().len().to_string()),
                Cell::Num(format!("{:.1}", r.mean(|f| f.drawn as f64))),
                Cell::Num(format!("{:.1}", r.mean(|f| f.exact_visible as f64))),
                Cell::Num(format!("{:.1}", r.mean(|f| f.queries as f64))),
                Cell::Num(format!("{:.3}", r.mean(|f| f.cull_ms))),
                Cell::Num(format!(
                    "{:.4}",
                    100.0 * r.mean(|f| f.popping_pixels as f64) / pixels
                )),
                Cell::Num(format!("{:.3}", 100.0 * max_pop as f64 / pixels)),
                Cell::Num(r.max_streak().to_string()),
            ],
            &[("method", r.method.name().into())],
        );
    }
    let mut body = format!(
        "<p>A walk through the scene with small objects swaying ({} objects), culled every frame \
         by the uniform-grid method of Seletsky 2013 and by the baselines, each measured against \
         the reference image (popping = pixels wrong because a visible object was culled).</p>\n{}",
        reports.first().map_or(0, |r| r.objects),
        t.html()
    );
    body.push_str("<p class=\"legend\">");
    for (i, r) in reports.iter().enumerate() {
        let _ = write!(
            body,
            "<span style=\"color:{}\">&#9644; {}</span> ",
            hex(series_colour(i)),
            escape(r.method.name())
        );
    }
    body.push_str("</p>\n");
    type Pick = fn(&FrameStats) -> f64;
    let panels: [(&str, Pick); 3] = [
        ("objects drawn", |f| f.drawn as f64),
        ("queries", |f| f.queries as f64),
        ("popping pixels", |f| f.popping_pixels as f64),
    ];
    for (label, pick) in panels {
        let series: Vec<Series> = reports
            .iter()
            .map(|r| Series {
                label: r.method.name().into(),
                // After the warm-up (nothing is drawn before the first query results).
                points: r
                    .frames
                    .iter()
                    .enumerate()
                    .skip(r.warmup as usize)
                    .map(|(f, s)| (f as f64, pick(s)))
                    .collect(),
            })
            .collect();
        let _ = writeln!(
            body,
            "<figure class=\"plot\">{}<figcaption>{label} per frame</figcaption></figure>",
            line_plot(&series, "frame", label, (540, 300), false)?
        );
    }
    Ok(Section::new(
        "culling",
        "Run-time culling along a camera path",
        body,
    ))
}
