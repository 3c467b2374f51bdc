//! The Markdown tables of `sightline bench`, ready for `docs/BENCHMARKS.md`: one printer per
//! benchmark, over the rows `sightline_eval::bench` returns.

use anyhow::Result;
use sightline_eval::bench::{
    equal_budget_pairs, PvsBenchOptions, PvsRow, RasterRow, RvBenchOptions, RvRow,
    ShareBenchOptions, ShareReport, TraceRow,
};

/// `bench rv`.
pub(super) fn rv(rows: &[RvRow], o: &RvBenchOptions) -> Result<()> {
    let threads = o.threads;
    outln!(
        "RV streaming a procedural city of {} triangles, {}² px, {threads} workers + {threads} \
         geometry threads, {} rounds (median; fastest-slowest)\n",
        o.triangles,
        o.size,
        o.rounds
    );
    outln!("| view | passes | streamed | on screen | visible (first pass) | seconds (fastest-slowest) | M triangles/s | peak MiB |");
    outln!("|---|---|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let passes = if r.retest_pass {
            "two (re-test)"
        } else {
            "one (thesis)"
        };
        outln!(
            "| {} | {passes} | {} | {} | {} ({}) | {:.3} ({:.3}-{:.3}) | {:.1} | {:.1} |",
            r.view,
            r.triangles_streamed,
            r.on_screen,
            r.visible,
            r.first_pass_visible,
            r.median_seconds,
            r.min_seconds,
            r.max_seconds,
            r.mtriangles_per_second,
            r.peak_memory_mib
        );
    }
    Ok(())
}

/// `bench trace`: each backend's speed relative to the first backend of its scene.
pub(super) fn trace(rows: &[TraceRow]) -> Result<()> {
    outln!(
        "| scene | triangles | backend | build s | coherent Mrays/s | incoherent Mrays/s | speed relative to the first backend (coherent / incoherent) |"
    );
    outln!("|---|---:|---|---:|---:|---:|---:|");
    let mut first: Option<(String, f64, f64)> = None;
    for r in rows {
        if first.as_ref().is_none_or(|f| f.0 != r.scene) {
            first = Some((r.scene.clone(), r.coherent_mrays, r.incoherent_mrays));
        }
        let (_, fc, fi) = first.clone().unwrap_or_default();
        outln!(
            "| `{}` | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} / {:.2} |",
            r.scene,
            r.triangles,
            r.backend,
            r.build_seconds,
            r.coherent_mrays,
            r.incoherent_mrays,
            r.coherent_mrays / fc,
            r.incoherent_mrays / fi
        );
    }
    Ok(())
}

/// `bench raster`.
pub(super) fn raster(rows: &[RasterRow]) -> Result<()> {
    outln!("| scene | triangles | size | median ms/frame | Mtriangles/s | covered pixels |");
    outln!("|---|---:|---:|---:|---:|---:|");
    for r in rows {
        outln!(
            "| `{}` | {} | {}² | {:.1} | {:.1} | {} |",
            r.scene,
            r.triangles,
            r.size,
            r.median_ms,
            r.mtriangles_per_second,
            r.visible_pixels
        );
    }
    Ok(())
}

/// `bench pvs`: the rows, then one line per scene and small budget comparing GVS++ with RAND.
pub(super) fn pvs(rows: &[PvsRow], options: &PvsBenchOptions) -> Result<()> {
    outln!(
        "| scene | method | budget | mean rays | mean s | M rays/s | avg err px | max err px | avg err regions | max region px | avg snapping px | PVS % | false neg (sum) |"
    );
    outln!("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let mrays = if r.mean_seconds > 0.0 {
            r.mean_rays / r.mean_seconds / 1e6
        } else {
            0.0
        };
        outln!(
            "| `{}` | {} | {} | {:.3e} | {:.2} | {:.2} | {:.2} | {} | {:.2} | {} | {:.2} | {:.2} | {} |",
            r.scene,
            r.method,
            r.budget,
            r.mean_rays,
            r.mean_seconds,
            mrays,
            r.avg_error_pixels,
            r.max_error_pixels,
            r.avg_error_regions,
            r.max_error_region_size,
            r.avg_unconfirmed_pixels,
            r.pvs_percent,
            r.false_negatives
        );
    }
    // The second caster's rows: how many cells' sets differ from the CPU's, and its speed.
    for r in rows.iter().filter(|r| r.differing_cells.is_some()) {
        let cpu = rows
            .iter()
            .find(|x| x.scene == r.scene && x.method == "GVS++" && x.budget == r.budget);
        let speed = match cpu {
            Some(c) if r.mean_seconds > 0.0 => {
                format!(
                    ", {:.2}x the CPU's time per cell",
                    r.mean_seconds / c.mean_seconds
                )
            }
            _ => String::new(),
        };
        outln!(
            "`{}` {} {}: {} of {} cells' sets differ from the CPU's{speed}",
            r.scene,
            r.method,
            r.budget,
            r.differing_cells.unwrap_or(0),
            r.cells
        );
    }
    // The equal-time comparison in one line per scene and budget: how many times fewer
    // erroneous pixels GVS++ leaves than RAND.
    for (r, rand) in equal_budget_pairs(rows, options) {
        let ratio = if r.avg_error_pixels > 0.0 {
            format!("{:.1}x", rand.avg_error_pixels / r.avg_error_pixels)
        } else if rand.avg_error_pixels > 0.0 {
            "GVS++ has no error".to_string()
        } else {
            "both have no error".to_string()
        };
        outln!(
            "`{}` at {}: RAND {:.2} avg err px, GVS++ {:.2}: {ratio}",
            r.scene,
            r.budget,
            rand.avg_error_pixels,
            r.avg_error_pixels
        );
    }
    outln!(
        "({} cells per scene, {} viewpoints x 6 cube faces at {}² each)",
        options.cells,
        options.viewpoints,
        options.resolution
    );
    Ok(())
}

/// `bench share`: the bakes, then the speed-ups at equal error. `layer` as the user gave it.
pub(super) fn share(report: &ShareReport, o: &ShareBenchOptions, layer: &str) -> Result<()> {
    outln!(
        "`{}` ({} triangles), {} cells (grid {}x{}x{}, one layer {}), pixel error on {} cells x {} viewpoints x 6 faces at {}²",
        report.scene,
        report.triangles,
        report.cells,
        o.grid[0],
        o.grid[1],
        o.grid[2],
        layer,
        report.evaluated_cells.len(),
        o.viewpoints,
        o.resolution
    );
    outln!();
    outln!("| method | rays/cell budget | total rays | s | avg err px | max err px | false neg (sum) | PVS % | first found via another cell's ray % |");
    outln!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &report.rows {
        outln!(
            "| {} | {} | {:.3e} | {:.1} | {:.3} | {} | {} | {:.2} | {:.1} |",
            r.method,
            r.budget_per_cell,
            r.total_rays as f64,
            r.seconds,
            r.avg_error_pixels,
            r.max_error_pixels,
            r.false_negatives,
            r.pvs_percent,
            r.shared_percent
        );
    }
    outln!();
    outln!("| independent rays/cell | its avg err px | shared rays for that error | speed-up (rays) | speed-up (time) |");
    outln!("|---:|---:|---:|---:|---:|");
    for s in &report.speedups {
        let prefix = if s.bound == "at least" { ">= " } else { "" };
        let fmt =
            |v: Option<f64>| v.map_or_else(|| s.bound.to_string(), |v| format!("{prefix}{v:.1}x"));
        outln!(
            "| {} | {:.3} | {} | {} | {} |",
            s.budget_per_cell,
            s.avg_error_pixels,
            s.shared_rays
                .map_or_else(|| s.bound.to_string(), |v| format!("{v:.3e}")),
            fmt(s.rays_speedup),
            fmt(s.time_speedup)
        );
    }
    Ok(())
}
