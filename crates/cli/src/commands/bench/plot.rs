//! The plots of `sightline bench pvs --plot`, drawn log-log as SVG files with the report's
//! plotter (`sightline_eval::report::plot::log_log_plot`): the convergence curves of every
//! method on a scene's first cell, and GVS++ against RAND at the small budgets (error against
//! seconds, the GVS++ paper's equal-time comparison).

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Result};
use sightline_eval::bench::{Convergence, PvsRow, ERROR_FLOOR};
use sightline_eval::report::plot::{log_log_plot, Series};

/// Draws `convergence` (average error against rays, log-log) as `convergence_<scene>.svg` in
/// `dir`; returns the file's path.
pub(super) fn write_convergence_plot(
    dir: &Path,
    spec: &str,
    convergence: &Convergence,
    resolution: u32,
) -> Result<PathBuf> {
    let series: Vec<Series> = convergence
        .series
        .iter()
        .map(|s| Series {
            label: s.method.to_string(),
            points: s.points.clone(),
        })
        .collect();
    let y = format!("{spec}: avg error px per {resolution}² view");
    let svg = log_log_plot(&series, "rays (RASTER: pixels)", &y, (900, 600))?;
    write_svg(dir, &format!("convergence_{}", file_stem(spec)), &svg)
}

/// Draws the GVS++ and RAND rows of `rows` at the small budgets (every row but the converged
/// comparison's) as `budgets_<scene>.svg`, average error against mean seconds per cell;
/// `None` when there are no such rows.
pub(super) fn write_budget_plot(
    dir: &Path,
    spec: &str,
    rows: &[PvsRow],
    resolution: u32,
) -> Result<Option<PathBuf>> {
    let small = |r: &&PvsRow| r.budget.ends_with(" rays") || r.budget.ends_with(" ms");
    let series: Vec<Series> = ["GVS++", "RAND"]
        .iter()
        .map(|method| {
            let mut points: Vec<(f64, f64)> = rows
                .iter()
                .filter(small)
                .filter(|r| r.method == *method)
                .map(|r| {
                    (
                        r.mean_seconds.max(1e-6),
                        r.avg_error_pixels.max(ERROR_FLOOR),
                    )
                })
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series {
                label: method.to_string(),
                points,
            }
        })
        .collect();
    if series.iter().all(|s| s.points.is_empty()) {
        return Ok(None);
    }
    let y = format!("{spec}: avg error px per {resolution}² view");
    let svg = log_log_plot(&series, "seconds per cell", &y, (900, 600))?;
    write_svg(dir, &format!("budgets_{}", file_stem(spec)), &svg).map(Some)
}

/// The last path component of a scene spec with anything but letters, digits and dots as `_`.
fn file_stem(spec: &str) -> String {
    (spec.rsplit('/').next().unwrap_or(spec).chars())
        .map(|c| match c.is_ascii_alphanumeric() || c == '.' {
            true => c,
            false => '_',
        })
        .collect()
}

/// Writes `svg` as `dir/<name>.svg` (atomically; `dir` is created).
fn write_svg(dir: &Path, name: &str, svg: &str) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).map_err(|e| anyhow!("creating {}: {e}", dir.display()))?;
    let path = dir.join(format!("{name}.svg"));
    sightline_core::atomic_file::write_atomic(&path, |w| {
        std::io::Write::write_all(w, svg.as_bytes())
    })
    .map_err(|e| anyhow!("writing {}: {e}", path.display()))?;
    Ok(path)
}
