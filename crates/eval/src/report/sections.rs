//! The sections of a PVS report: summary, per-cell table, worst views, convergence plots and
//! the map of the cells.

use std::fmt::Write as _;

use crate::{EvalParams, ViewMode};
use sightline_core::Scene;
use sightline_region::PvsFile;

use super::error::ReportError;
use super::evaluate::{CellOutcome, WorstImage};
use super::growth;
use super::html::{escape, img, key_value_table, Cell, Section, Table};
use super::map::{floors, map_svg, MapCell, MapLayer};
use super::metadata::{budget, cell_bake, converged_cells, text};
use super::plan::Plan;
use super::plot::{band_plot, line_plot, Series};

/// "—" for a missing value.
const MISSING: &str = "—";

fn or_missing(v: Option<String>) -> String {
    v.unwrap_or_else(|| MISSING.to_string())
}

/// What the views of the evaluation were, in words.
pub(crate) fn eval_settings(params: &EvalParams) -> String {
    let views = match params.views {
        ViewMode::CubeFaces => "6 cube faces",
        ViewMode::Random => "1 random 90° view",
    };
    format!(
        "{} viewpoints per cell × {views}, {r}×{r} pixels, seed {}",
        params.viewpoints,
        params.seed,
        r = params.resolution
    )
}

/// The summary: what was baked, how, and the overall error.
pub(crate) fn summary(
    scene: &Scene,
    file: &PvsFile,
    pvs_label: &str,
    params: &EvalParams,
    outcomes: &[CellOutcome],
) -> Section {
    let m = &file.metadata;
    let n = scene.triangle_count().max(1) as f64;
    let k = outcomes.len().max(1) as f64;
    let mean = |f: &dyn Fn(&CellOutcome) -> f64| outcomes.iter().map(f).sum::<f64>() / k;
    let rows = [
        ("scene", scene.source.clone()),
        ("scene in the .pvs metadata", or_missing(text(m, "scene"))),
        (".pvs file", pvs_label.to_string()),
        ("triangles", scene.triangle_count().to_string()),
        ("method", or_missing(text(m, "method"))),
        ("seed", or_missing(text(m, "seed"))),
        ("budget per cell", or_missing(budget(m))),
        (
            "converged cells",
            or_missing(converged_cells(m, file.cells.len())),
        ),
        ("cells", file.cells.len().to_string()),
        ("objects", object_count(file)),
        (
            "bake time",
            or_missing(m["seconds"].as_f64().map(|s| format!("{s:.2} s"))),
        ),
        (
            "total rays",
            or_missing(m["total_rays"].as_u64().map(|r| r.to_string())),
        ),
        ("baked by", or_missing(text(m, "tool"))),
        (
            "mean PVS",
            format!(
                "{:.1} triangles ({:.3} %)",
                mean(&|o| o.eval.pvs_size as f64),
                100.0 * mean(&|o| o.eval.pvs_size as f64) / n
            ),
        ),
        ("mean visible objects", mean_visible_objects(file)),
        ("two sides", two_sides(file)),
        ("viewpoints not evaluated", rejected_viewpoints(outcomes)),
        (
            "mean erroneous pixels per view",
            format!("{:.3}", mean(&|o| o.eval.avg_error_pixels)),
        ),
        (
            "largest erroneous pixels in one view",
            outcomes
                .iter()
                .map(|o| o.eval.max_error_pixels)
                .max()
                .unwrap_or(0)
                .to_string(),
        ),
        (
            "seen triangles missing (all cells)",
            outcomes
                .iter()
                .map(|o| o.eval.false_negatives)
                .sum::<usize>()
                .to_string(),
        ),
        ("evaluation", eval_settings(params)),
    ];
    Section::new(
        "summary",
        "Summary",
        key_value_table("summary-table", &rows),
    )
}

/// A two-sided file's mean bound and gap, or that the file has one side.
fn two_sides(file: &PvsFile) -> String {
    if !file.has_bounds() {
        return "one: the sampled set (bake with --bound for a conservative bound per cell)".into();
    }
    let k = file.cells.len().max(1) as f64;
    let set = file
        .cells
        .iter()
        .map(|c| c.visible.count_ones(..))
        .sum::<usize>() as f64;
    let bound = file
        .cells
        .iter()
        .filter_map(|c| c.bound.as_ref())
        .map(|b| b.count_ones(..))
        .sum::<usize>() as f64;
    format!(
        "set and conservative bound: mean bound {:.1} triangles ({:.2}x the set), mean gap \
         {:.1} triangles that the set might be missing (per cell in the table)",
        bound / k,
        bound / set.max(1.0),
        (bound - set) / k
    )
}

/// The object table's size, or why there is none.
fn object_count(file: &PvsFile) -> String {
    match &file.objects {
        Some(table) => table.objects.len().to_string(),
        None => "none (a version 1 file: triangle sets only; bake again for objects)".into(),
    }
}

/// The mean size of the cells' visible-object sets (what an engine draws), or "—".
fn mean_visible_objects(file: &PvsFile) -> String {
    let Some(table) = &file.objects else {
        return MISSING.into();
    };
    let total = table.objects.len().max(1) as f64;
    let cells = file.cells.len().max(1) as f64;
    let mean = (0..file.cells.len())
        .filter_map(|i| file.visible_objects(i))
        .map(|set| set.count_ones(..) as f64)
        .sum::<f64>()
        / cells;
    format!("{mean:.1} objects ({:.2} %)", 100.0 * mean / total)
}

/// The viewpoints the evaluation left out, by reason.
fn rejected_viewpoints(outcomes: &[CellOutcome]) -> String {
    let total: super::evaluate::Rejected = outcomes.iter().map(|o| o.rejected).sum();
    if total.total() == 0 {
        return "none".into();
    }
    let parts: Vec<String> = [
        (total.inside_solid, "inside solid geometry"),
        (total.outside_cluster, "outside their cell's cluster"),
        (total.unreachable, "unreachable from the spawn points"),
    ]
    .iter()
    .filter(|(n, _)| *n > 0)
    .map(|(n, why)| format!("{n} {why}"))
    .collect();
    parts.join(", ")
}

/// The cells from the worst down: the largest average error first, then the largest single
/// view's error, then the file's order.
pub(crate) fn worst_first(outcomes: &[CellOutcome]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..outcomes.len()).collect();
    order.sort_by(|&a, &b| {
        let (ea, eb) = (&outcomes[a].eval, &outcomes[b].eval);
        eb.avg_error_pixels
            .total_cmp(&ea.avg_error_pixels)
            .then(eb.max_error_pixels.cmp(&ea.max_error_pixels))
            .then(a.cmp(&b))
    });
    order
}

/// One row per cell: PVS size, bake cost, pixel error; the worst cells first, the
/// `shown` worst visible and the rest behind a toggle (a file of 400 cells would otherwise
/// push everything below it off the page), with a filter box. Row `i` has the id
/// `cell-row-{i}`, which the map and the worst views link to.
pub(crate) fn cell_table(
    scene: &Scene,
    file: &PvsFile,
    outcomes: &[CellOutcome],
    shown: usize,
) -> Section {
    let n = scene.triangle_count().max(1) as f64;
    let two_sided = file.has_bounds();
    // Two-sided files: the bound and the gap (triangles the set might be missing) after the
    // set's columns.
    let bound_headers: &[&str] = if two_sided {
        &["bound triangles", "gap: might be missing"]
    } else {
        &[]
    };
    let headers: Vec<&str> = ["cell", "centre", "half extents", "PVS triangles", "PVS %"]
        .into_iter()
        .chain(bound_headers.iter().copied())
        .chain([
            "PVS objects",
            "rays",
            "bake s",
            "converged",
            "avg error px",
            "max error px",
            "avg unconfirmed px",
            "avg error regions",
            "max region px",
            "seen",
            "seen but missing",
            "views",
            "eval s",
        ])
        .collect();
    let mut t = Table::new("cell-table", &headers);
    for (rank, &i) in worst_first(outcomes).iter().enumerate() {
        let (c, o) = (&file.cells[i], &outcomes[i]);
        let bake = cell_bake(&file.metadata, i);
        let pvs = c.visible.count_ones(..);
        let objects = file.visible_objects(i).map(|set| set.count_ones(..));
        let e = &o.eval;
        let v3 = |v: glam::Vec3| format!("{:.2}, {:.2}, {:.2}", v.x, v.y, v.z);
        let row_id = format!("cell-row-{i}");
        let mut attrs = vec![("id", row_id.as_str())];
        if rank >= shown {
            attrs.push(("class", "rest"));
        }
        let bound = c.bound.as_ref().map(|b| b.count_ones(..));
        let bound_cells = bound
            .into_iter()
            .flat_map(|b| [Cell::Num(b.to_string()), Cell::Num((b - pvs).to_string())]);
        let mut data = vec![
            ("cell", i.to_string()),
            ("pvs", pvs.to_string()),
            ("max-error", e.max_error_pixels.to_string()),
            ("rank", rank.to_string()),
        ];
        if let Some(b) = bound {
            data.push(("gap", (b - pvs).to_string()));
        }
        t.row_with(
            [
                Cell::Num(i.to_string()),
                Cell::Text(v3(c.cell.center)),
                Cell::Text(v3(c.cell.half_extents)),
                Cell::Num(pvs.to_string()),
                Cell::Num(format!("{:.3}", 100.0 * pvs as f64 / n)),
            ]
            .into_iter()
            .chain(bound_cells)
            .chain([
                Cell::Num(or_missing(objects.map(|k| k.to_string()))),
                Cell::Num(or_missing(bake.rays.map(|r| r.to_string()))),
                Cell::Num(or_missing(bake.seconds.map(|s| format!("{s:.3}")))),
                Cell::Text(or_missing(
                    bake.converged
                        .map(|c| if c { "yes" } else { "no: budget" }.to_string()),
                )),
                Cell::Num(format!("{:.3}", e.avg_error_pixels)),
                Cell::Num(e.max_error_pixels.to_string()),
                Cell::Num(format!("{:.3}", e.avg_unconfirmed_pixels)),
                Cell::Num(format!("{:.3}", e.avg_error_regions)),
                Cell::Num(e.max_error_region_size.to_string()),
                Cell::Num(e.ground_truth_size.to_string()),
                Cell::Num(e.false_negatives.to_string()),
                Cell::Num(e.images.to_string()),
                Cell::Num(format!("{:.2}", o.seconds)),
            ])
            .collect(),
            &data,
            &attrs,
        );
    }
    let n_cells = file.cells.len();
    let toggle = if n_cells > shown {
        format!(
            "<input type=\"checkbox\" id=\"cell-table-all\"><label for=\"cell-table-all\">show all \
             {n_cells} cells (the {shown} worst are shown)</label>"
        )
    } else {
        String::new()
    };
    let body = format!(
        "<p>Error pixels as the GVS++ paper counts them: pixels whose triangle in the full-scene \
         render is missing from the PVS, confirmed by casting the ray through the pixel centre; \
         <em>unconfirmed</em> pixels are those the rasterizer alone calls wrong (vertex snapping \
         artefacts of the reference). The worst cells come first; click a column to sort, type \
         in the filter to find cells (any text of a row, e.g. <code>no: budget</code>).</p>\n\
         <div class=\"controls\"><label>filter <input type=\"search\" id=\"cell-table-filter\" \
         placeholder=\"text in any column\"></label></div>\n{toggle}\n{}",
        t.html()
    );
    Section::new("cells", "Cells", body)
}

/// The worst views as images.
pub(crate) fn worst_views(images: &[WorstImage], shown: usize) -> Result<Section, ReportError> {
    let mut body = String::new();
    if shown == 0 {
        body.push_str("<p class=\"note\">No worst views requested.</p>\n");
    } else if images.is_empty() {
        body.push_str(
            "<p class=\"note\">No view of any cell has an erroneous pixel: nothing to show.</p>\n",
        );
    } else {
        let _ = writeln!(
            body,
            "<p>The {} cells with the most erroneous pixels in one view, each in its worst view: \
             the scene dimmed, <span style=\"color:#d00\">erroneous pixels red</span> with a faint \
             red halo (so that a few scattered pixels can be found), snapping artefacts \
             yellow.</p>",
            images.len().min(shown)
        );
    }
    for w in images {
        let caption = format!(
            "cell {}: {} erroneous pixels, {} unconfirmed; eye ({:.2}, {:.2}, {:.2}) looking \
             ({:.2}, {:.2}, {:.2})",
            w.cell,
            w.errors,
            w.unconfirmed,
            w.eye[0],
            w.eye[1],
            w.eye[2],
            w.forward[0],
            w.forward[1],
            w.forward[2]
        );
        let _ = writeln!(
            body,
            "<figure class=\"worst\" data-cell=\"{}\" data-errors=\"{}\">{}<figcaption>{} \
             <a href=\"#cell-row-{}\">its row in the cell table</a></figcaption></figure>",
            w.cell,
            w.errors,
            img(&w.image, &caption, w.image.width().clamp(320, 400))?,
            escape(&caption),
            w.cell
        );
    }
    Ok(Section::new("worst-views", "Worst views", body))
}

/// Cells up to which the convergence plot draws one line per cell; beyond, the distribution.
const CURVES_PER_CELL_UP_TO: usize = 12;
/// Why a file has no convergence plot: its cells carry statistics without curves, or no
/// per-cell statistics at all. Names what is absent; does not guess which tool wrote it.
fn no_convergence_note(metadata: &serde_json::Value) -> String {
    let why = if metadata["cells"].as_array().is_some_and(|c| !c.is_empty()) {
        "its cells' statistics (<code>metadata.cells</code>) have no <code>convergence</code> \
         curves"
    } else {
        "it has no per-cell statistics (<code>metadata.cells</code>): e.g. a file written by \
         another tool, or by a sightline bake before they were recorded"
    };
    format!(
        "<p class=\"note\" id=\"no-convergence\">No convergence plot: {why}. Bakes by \
         <code>sightline pvs bake</code>, the Python bindings and the Ray driver record \
         them.</p>\n"
    )
}

/// Worst cells drawn as lines over the distribution.
const WORST_LINES: usize = 5;

/// PVS size against rays, from `metadata["cells"][i]["convergence"]`: one line per cell for a
/// few cells; for more, the distribution over all cells (percentile band and median of the
/// fraction of its final PVS each cell had found) with the worst cells (`worst`: the cells with
/// erroneous pixels, worst first) as labelled lines.
pub(crate) fn convergence(file: &PvsFile, worst: &[usize]) -> Result<Section, ReportError> {
    let curves: Vec<(usize, Vec<(u64, u64)>)> = (0..file.cells.len())
        .filter_map(|i| Some((i, cell_bake(&file.metadata, i).convergence?)))
        .collect();
    let mut body = if curves.is_empty() {
        no_convergence_note(&file.metadata)
    } else if curves.len() <= CURVES_PER_CELL_UP_TO {
        let series: Vec<Series> = curves
            .iter()
            .map(|(i, points)| Series {
                label: format!("cell {i}"),
                points: std::iter::once((0.0, 0.0))
                    .chain(points.iter().map(|&(r, p)| (r as f64, p as f64)))
                    .collect(),
            })
            .collect();
        format!(
            "<p>PVS size after each batch of rays, one line per cell.</p>\n\
             <div id=\"convergence-plot\">{}</div>\n",
            line_plot(&series, "rays", "PVS size (triangles)", (900, 420), true)?
        )
    } else {
        convergence_distribution(&curves, worst)?
    };
    if curves.len() < file.cells.len() && !curves.is_empty() {
        let _ = writeln!(
            body,
            "<p class=\"note\">{} of {} cells have no convergence data.</p>",
            file.cells.len() - curves.len(),
            file.cells.len()
        );
    }
    Ok(Section::new("convergence", "Convergence", body))
}

/// The distribution plot of [`convergence`] for many cells.
fn convergence_distribution(
    curves: &[(usize, Vec<(u64, u64)>)],
    worst: &[usize],
) -> Result<String, ReportError> {
    let fractions: Vec<(usize, Vec<(f64, f64)>)> = curves
        .iter()
        .filter_map(|(i, c)| Some((*i, growth::growth_fraction(c)?)))
        .collect();
    let all: Vec<Vec<(f64, f64)>> = fractions.iter().map(|(_, f)| f.clone()).collect();
    let Some(band) = growth::growth_band(&all, 60) else {
        return Ok(
            "<p class=\"note\" id=\"no-convergence\">The cells' convergence data are \
                   empty.</p>\n"
                .to_string(),
        );
    };
    let lines: Vec<Series> = worst
        .iter()
        .filter_map(|w| fractions.iter().find(|(i, _)| i == w))
        .take(WORST_LINES)
        .map(|(i, f)| Series {
            label: format!(
                "cell {i} (worst #{})",
                worst.iter().position(|w| w == i).unwrap_or(0) + 1
            ),
            points: f.clone(),
        })
        .collect();
    let labels: Vec<String> = lines.iter().map(|l| escape(&l.label)).collect();
    let named = if lines.is_empty() {
        "no cell has erroneous pixels, so none is drawn on its own".to_string()
    } else {
        format!(
            "the {} cells with the largest pixel error are drawn on their own ({})",
            lines.len(),
            labels.join(", ")
        )
    };
    Ok(format!(
        "<p>How the {} cells converged: the fraction of its final PVS each cell had found after \
         each batch of rays; the band holds the middle 80 % of the cells, the dark line is the \
         median cell, and {named}. A cell whose curve is still rising at its last batch \
         stopped before it converged. (The bake records PVS size per batch, not pixel error; \
         the error is the final set's.)</p>\n\
         <div id=\"convergence-plot\" data-cells=\"{}\" data-lines=\"{}\">{}</div>\n",
        all.len(),
        all.len(),
        lines.len(),
        band_plot(
            &band.rays,
            (&band.low, &band.median, &band.high),
            &lines,
            ("rays", "fraction of the final PVS"),
            (900, 420),
        )?
    ))
}

/// Radio buttons that show one floor of stacked cells at a time (`map::floors`), or nothing
/// when no cell lies above another.
fn floor_controls(scene: &Scene, file: &PvsFile) -> String {
    let boxes: Vec<_> = file.cells.iter().map(|c| c.cell).collect();
    let Some(floor_of) = floors(&boxes, &Plan::new(scene.up)) else {
        return String::new();
    };
    let n = floor_of.iter().copied().max().unwrap_or(1);
    let mut html = String::from(
        " &nbsp; floor (cells stacked above each other): \
         <input type=\"radio\" name=\"map-floor\" id=\"floor-all\" checked>\
         <label for=\"floor-all\">all</label>",
    );
    for k in 1..=n {
        let cells = floor_of.iter().filter(|&&f| f == k).count();
        let _ = write!(
            html,
            "<input type=\"radio\" name=\"map-floor\" id=\"floor-{k}\">\
             <label for=\"floor-{k}\">{k} ({cells} cells)</label>"
        );
    }
    html
}

/// The map of the cells, coloured by PVS size or by pixel error (radio buttons switch, without
/// script), cells whose PVS missed triangles outlined in red.
pub(crate) fn cell_map(
    scene: &Scene,
    file: &PvsFile,
    outcomes: &[CellOutcome],
) -> Result<Section, ReportError> {
    let n = scene.triangle_count().max(1) as f64;
    let pvs_sizes: Vec<f64> = file
        .cells
        .iter()
        .map(|c| c.visible.count_ones(..) as f64)
        .collect();
    let errors: Vec<f64> = outcomes.iter().map(|o| o.eval.avg_error_pixels).collect();
    let cells: Vec<MapCell> = file
        .cells
        .iter()
        .zip(outcomes)
        .enumerate()
        .map(|(i, (c, o))| {
            let pvs = pvs_sizes[i];
            let objects = file.visible_objects(i).map_or(String::new(), |set| {
                format!(", {} objects", set.count_ones(..))
            });
            let e = &o.eval;
            MapCell {
                cell: c.cell,
                title: format!(
                    "cell {i}: PVS {pvs} triangles ({:.3} %){objects}; error {:.3} px per view \
                     (max {}), {} triangles seen but missing",
                    100.0 * pvs / n,
                    e.avg_error_pixels,
                    e.max_error_pixels,
                    e.false_negatives
                ),
                flagged: e.false_negatives > 0,
            }
        })
        .collect();
    let flagged = cells.iter().filter(|c| c.flagged).count();
    let layers = [
        MapLayer {
            class: "by-pvs",
            label: "PVS size (triangles)",
            values: pvs_sizes,
        },
        MapLayer {
            class: "by-error",
            label: "error (pixels per view)",
            values: errors,
        },
    ];
    let body = format!(
        "<p>The scene from above (grey: higher is darker) with the view cells; {flagged} of {} \
         cells, outlined in red, missed triangles that were seen from them. Hover a cell for its \
         numbers, click it for its row in the cell table.</p>\n\
         colour by: <input type=\"radio\" name=\"map-colour\" id=\"map-by-pvs\" checked>\
         <label for=\"map-by-pvs\">PVS size</label>\n\
         <input type=\"radio\" name=\"map-colour\" id=\"map-by-error\">\
         <label for=\"map-by-error\">pixel error</label>{}<br>\n{}",
        cells.len(),
        floor_controls(scene, file),
        map_svg(scene, &cells, &layers, 900)?
    );
    Ok(Section::new("map", "Map of the view cells", body))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use sightline_region::{CellPvs, ViewCell};

    /// A file of `n` cells whose bakes recorded convergence curves: cell `i` reaches 100
    /// triangles after `1000 (i + 1)` rays.
    fn file_with_curves(n: usize) -> PvsFile {
        let mut b = sightline_core::scene::SceneBuilder::new("box");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        let scene = b.finish();
        let cells: Vec<serde_json::Value> = (0..n)
            .map(|i| {
                let end = 1000 * (i as u64 + 1);
                serde_json::json!({"rays": end, "convergence": [[end / 2, 60], [end, 100]]})
            })
            .collect();
        let mut file = PvsFile::for_scene(&scene, serde_json::json!({ "cells": cells }));
        for i in 0..n {
            let x = i as f32;
            file.cells.push(CellPvs {
                cell: ViewCell::aabb(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 1.0, 1.0)).unwrap(),
                visible: sightline_core::TriangleSet::with_capacity(scene.triangle_count()),
                bound: None,
            });
        }
        file
    }

    #[test]
    fn few_cells_get_a_line_each_many_cells_a_band_with_the_worst_named() {
        let few = convergence(&file_with_curves(3), &[2, 0, 1]).unwrap().body;
        assert!(few.contains("one line per cell") && few.contains("cell 2"));
        let n = 30;
        let worst: Vec<usize> = (0..n).rev().collect();
        let many = convergence(&file_with_curves(n), &worst).unwrap().body;
        assert!(many.contains(&format!("data-cells=\"{n}\" data-lines=\"{WORST_LINES}\"")));
        // The five worst cells (29, 28, ...) are labelled, the others are not.
        for (rank, cell) in [29, 28, 27, 26, 25].iter().enumerate() {
            assert!(
                many.contains(&format!("cell {cell} (worst #{})", rank + 1)),
                "{cell}"
            );
        }
        assert!(!many.contains("cell 24 (worst"));
        assert!(many.contains("10th-90th percentile") && many.contains("median cell"));
        assert!(many.contains("<polygon"), "the band is drawn");
        // Without erroneous cells no line is singled out, and the legend still explains the band.
        let clean = convergence(&file_with_curves(n), &[]).unwrap().body;
        assert!(clean.contains("data-lines=\"0\"") && clean.contains("none is drawn"));
        assert!(clean.contains("median cell") && !clean.contains("(worst #"));
    }

    #[test]
    fn files_without_curves_say_so() {
        let mut file = file_with_curves(2);
        file.metadata = serde_json::Value::Null;
        let s = convergence(&file, &[0, 1]).unwrap().body;
        assert!(s.contains("id=\"no-convergence\""));
        assert!(s.contains("no per-cell statistics"), "{s}");
        // Statistics without curves are named as such, not blamed on an old version.
        file.metadata = serde_json::json!({"cells": [{"rays": 5}, {"rays": 7}]});
        let s = convergence(&file, &[0, 1]).unwrap().body;
        assert!(s.contains("have no <code>convergence</code>"), "{s}");
    }

    #[test]
    fn two_sided_files_show_the_bound_and_the_gap_per_cell() {
        let mut file = file_with_curves(2);
        let scene = {
            let mut b = sightline_core::scene::SceneBuilder::new("box");
            b.add_box(Vec3::ZERO, Vec3::ONE);
            b.finish()
        };
        let outcome = || CellOutcome {
            eval: crate::CellEvaluation {
                images: 1,
                resolution: 8,
                avg_error_pixels: 0.0,
                avg_unconfirmed_pixels: 0.0,
                max_error_pixels: 0,
                avg_error_regions: 0.0,
                max_error_region_size: 0,
                pvs_size: 0,
                ground_truth_size: 0,
                false_negatives: 0,
                false_positives: 0,
                worst_view: None,
            },
            extra: Vec::new(),
            seconds: 0.0,
            rejected: Default::default(),
        };
        let outcomes = [outcome(), outcome()];
        let one_sided = cell_table(&scene, &file, &outcomes, 10).body;
        assert!(!one_sided.contains("might be missing"));
        assert!(two_sides(&file).starts_with("one:"));
        // Cell 0: set {0, 1}, bound adds 3; cell 1: empty set, bound adds 7 triangles.
        for (c, (set, extra)) in file.cells.iter_mut().zip([(&[0, 1][..], 3), (&[][..], 7)]) {
            set.iter().for_each(|&t| c.visible.insert(t));
            let mut bound = c.visible.clone();
            (4..4 + extra).for_each(|t| bound.insert(t));
            c.bound = Some(bound);
        }
        let table = cell_table(&scene, &file, &outcomes, 10).body;
        assert!(table.contains("<th>gap: might be missing</th>"), "{table}");
        assert!(table.contains("data-gap=\"3\"") && table.contains("data-gap=\"7\""));
        let summary = two_sides(&file);
        // Mean bound (5 + 7) / 2 = 6, 6x the mean set of 1, mean gap 5.
        assert!(
            summary.contains("mean bound 6.0 triangles (6.00x the set), mean gap 5.0"),
            "{summary}"
        );
    }
}
