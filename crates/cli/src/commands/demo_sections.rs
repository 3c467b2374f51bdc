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

/// Pixels of a 1920x1080 frame.
const FULL_HD: f64 = 1920.0 * 1080.0;

/// What an average error of `avg_px` erroneous pixels per `resolution`² view means on a
/// player's screen: the same share of a 1920x1080 frame, and what such pixels look like.
pub(crate) fn error_for_a_player(avg_px: f64, resolution: u32) -> String {
    let frame = avg_px * FULL_HD / (resolution as f64 * resolution as f64);
    let feel = if frame < 1.0 {
        "less than one pixel per frame: a player will hardly ever see it"
    } else if frame < 20.0 {
        "a few pixels per frame, usually thin slivers along edges seen through gaps: visible as \
         a brief flicker when a player looks for it"
    } else {
        "enough to show as holes that flicker while the player moves: bake with more rays (or no \
         budget, so that every cell converges) before shipping"
    };
    format!(
        "For a player: an average of {avg_px:.3} erroneous pixels per {resolution}×{resolution} \
         view is the same share of a 1920×1080 frame as {frame:.1} pixels, {feel}. An erroneous \
         pixel is a hole: a triangle that should be seen is missing from the PVS, and whatever \
         lies behind it shows through."
    )
}

/// GVS++ against RAND at the same number of rays per cell, on the same views (`resolution`²
/// pixels each).
pub(crate) fn gvspp_vs_rand(outcomes: &[CellOutcome], resolution: u32) -> Section {
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
             cell, judged on the same views.</p>\n{}<p id=\"error-for-a-player\">{}</p>\n",
            t.html(),
            escape(&error_for_a_player(mean_error(outcomes), resolution))
        ),
    )
}

/// GVS++'s average erroneous pixels per view over all cells.
fn mean_error(outcomes: &[CellOutcome]) -> f64 {
    outcomes
        .iter()
        .map(|o| o.eval.avg_error_pixels)
        .sum::<f64>()
        / outcomes.len().max(1) as f64
}

/// Which culling method to ship on this path, and why: of the methods that never culled a
/// visible object (no popping pixel in any measured frame), the one that draws the fewest
/// objects (then the fastest); when every method popped, the one that popped least, said so.
pub(crate) fn culling_advice(reports: &[SimReport]) -> String {
    let max_pop = |r: &SimReport| {
        r.measured()
            .iter()
            .map(|f| f.popping_pixels)
            .max()
            .unwrap_or(0)
    };
    let drawn = |r: &SimReport| r.mean(|f| f.drawn as f64);
    let by_cost = |a: &&SimReport, b: &&SimReport| {
        drawn(a)
            .total_cmp(&drawn(b))
            .then(r_ms(a).total_cmp(&r_ms(b)))
    };
    let clean: Vec<&SimReport> = reports.iter().filter(|r| max_pop(r) == 0).collect();
    let mut text = match clean.iter().min_by(|a, b| by_cost(a, b)) {
        Some(best) => format!(
            "Which to ship: {} — it never culled a visible object on this path (no popping pixel \
             in any frame) and draws {:.1} objects per frame on average, the fewest of the methods \
             that never popped, in {:.3} ms of culling per frame.",
            best.method.name(),
            drawn(best),
            r_ms(best)
        ),
        None => {
            let least = reports
                .iter()
                .min_by(|a, b| mean_pop(a).total_cmp(&mean_pop(b)));
            match least {
                Some(l) => format!(
                    "Every method culled a visible object at least once on this path; {} popped \
                     least ({:.4} % of the pixels per frame on average): judge whether that is \
                     visible in your game before shipping it.",
                    l.method.name(),
                    100.0 * mean_pop(l) / l.pixels.max(1) as f64
                ),
                None => String::new(),
            }
        }
    };
    if let Some(r) = reports.iter().find(|r| r.warmup > 0) {
        text.push_str(&format!(
            " The means leave out the first {} frame(s) of each method: the {} method draws from \
             the previous frame's occlusion queries, so before their first results arrive it has \
             nothing to go on and draws nothing (every cell starts invisible, as in Seletsky's \
             thesis). A game primes it by drawing that first frame with frustum culling alone.",
            r.warmup,
            r.method.name()
        ));
    }
    text
}

fn r_ms(r: &SimReport) -> f64 {
    r.mean(|f| f.cull_ms)
}

fn mean_pop(r: &SimReport) -> f64 {
    r.mean(|f| f.popping_pixels as f64)
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
         the reference image (popping = pixels wrong because a visible object was culled).</p>\n{}\
         <p id=\"culling-advice\">{}</p>\n",
        reports.first().map_or(0, |r| r.objects),
        t.html(),
        escape(&culling_advice(reports))
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

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_cull::{FrameStats, Method, SimReport};

    #[test]
    fn errors_are_scaled_to_a_full_hd_frame() {
        // 0.5 px of a 256² view is 0.5 * 1920 * 1080 / 65536 = 15.8 px of a 1080p frame.
        let t = error_for_a_player(0.5, 256);
        assert!(t.contains("as 15.8 pixels"), "{t}");
        assert!(t.contains("brief flicker"), "{t}");
        assert!(error_for_a_player(0.001, 256).contains("hardly ever"));
        assert!(error_for_a_player(5.0, 256).contains("bake with more rays"));
    }

    fn report(method: Method, drawn: u32, popping: u32, warmup: u32) -> SimReport {
        let frame = FrameStats {
            drawn,
            popping_pixels: popping,
            cull_ms: 0.1,
            ..FrameStats::default()
        };
        SimReport {
            method,
            frames: vec![frame; 5],
            pixels: 1000,
            warmup,
            ..SimReport::default()
        }
    }

    #[test]
    fn advice_ships_the_cheapest_method_that_never_popped_and_explains_the_warmup() {
        let reports = [
            report(Method::Frustum, 90, 0, 0),
            report(Method::Grid, 20, 0, 1),
            report(Method::TwoPhaseHzb, 10, 3, 0),
        ];
        let t = culling_advice(&reports);
        // The HZB draws least but pops; of the two that never pop the grid draws less.
        assert!(t.starts_with("Which to ship: grid"), "{t}");
        assert!(t.contains("20.0 objects"), "{t}");
        assert!(
            t.contains("first 1 frame(s)") && t.contains("frustum culling alone"),
            "{t}"
        );
        let popping = [
            report(Method::Grid, 20, 5, 0),
            report(Method::Frustum, 90, 2, 0),
        ];
        let t = culling_advice(&popping);
        assert!(t.starts_with("Every method culled a visible object"), "{t}");
        assert!(t.contains("frustum popped least"), "{t}");
        assert!(!t.contains("first 1 frame"), "{t}");
    }
}
