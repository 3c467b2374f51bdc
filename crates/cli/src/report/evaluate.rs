//! The pixel error of every cell of a `.pvs` file, with the GVS++ paper's metric
//! (`sightline_eval::evaluate_cell_in`), and the worst views rendered with their error pixels
//! highlighted.

use std::time::Instant;

use glam::Vec3;
use image::RgbImage;
use sightline_core::trace::Bvh;
use sightline_core::{Scene, TriangleSet};
use sightline_eval::{evaluate_cell_in, view_errors, CellEvaluation, EvalParams, ViewErrors};
use sightline_region::PvsFile;

use crate::output::shaded_image;

/// One cell's evaluation.
pub(crate) struct CellOutcome {
    /// The file's PVS.
    pub eval: CellEvaluation,
    /// Further sets of the same cell judged on the same views (e.g. a baseline method).
    pub extra: Vec<CellEvaluation>,
    /// Seconds the evaluation took.
    pub seconds: f64,
}

/// Evaluates every cell of `file`; `extra[i]` (when present) are more sets for cell `i`.
/// Cells of a Quake 3 leaf bake (`metadata["clusters"]`) take viewpoints only in their own
/// cluster, as the bake took its ray origins. `progress(cell, view, views)` reports progress.
pub(crate) fn evaluate_cells(
    scene: &Scene,
    file: &PvsFile,
    params: &EvalParams,
    extra: &[Vec<TriangleSet>],
    progress: &dyn Fn(usize, usize, usize),
) -> Vec<CellOutcome> {
    let clusters: Option<Vec<u64>> = file.metadata["clusters"]
        .as_array()
        .and_then(|a| a.iter().map(|c| c.as_u64()).collect());
    file.cells
        .iter()
        .enumerate()
        .map(|(i, cell)| {
            let start = Instant::now();
            let cluster = clusters.as_ref().and_then(|c| c.get(i).copied());
            let free = |p: Vec3| match (cluster, scene.bsp.as_deref()) {
                (Some(c), Some(bsp)) => bsp.cluster_at(p).map(u64::from) == Some(c),
                _ => true,
            };
            let mut sets: Vec<&TriangleSet> = vec![&cell.visible];
            sets.extend(extra.get(i).into_iter().flatten());
            let mut evals = evaluate_cell_in(scene, &cell.cell, &free, &sets, params, &|d, n| {
                progress(i, d, n)
            });
            let eval = evals.remove(0);
            CellOutcome {
                eval,
                extra: evals,
                seconds: start.elapsed().as_secs_f64(),
            }
        })
        .collect()
}

/// A worst view, rendered.
pub(crate) struct WorstImage {
    /// Cell index.
    pub cell: usize,
    /// Dimmed shaded render with error pixels red and snapping artefacts yellow.
    pub image: RgbImage,
    /// Erroneous pixels.
    pub errors: usize,
    /// Unconfirmed (snapping) pixels.
    pub unconfirmed: usize,
    /// Eye position.
    pub eye: [f32; 3],
    /// View direction.
    pub forward: [f32; 3],
}

/// Colour of erroneous pixels.
pub(crate) const ERROR_RED: [u8; 3] = [255, 24, 24];
/// Colour of pixels only the rasterizer calls erroneous (snapping artefacts).
pub(crate) const SNAP_YELLOW: [u8; 3] = [255, 214, 0];

/// The `count` cells with the most erroneous pixels in one view (cells without errors are
/// left out), each worst view rendered at the evaluation's resolution.
pub(crate) fn worst_views(
    scene: &Scene,
    file: &PvsFile,
    outcomes: &[CellOutcome],
    resolution: u32,
    count: usize,
) -> Vec<WorstImage> {
    let mut ranked: Vec<usize> = (0..outcomes.len())
        .filter(|&i| outcomes[i].eval.worst_view.is_some())
        .collect();
    ranked.sort_by_key(|&i| std::cmp::Reverse(outcomes[i].eval.max_error_pixels));
    ranked.truncate(count);
    if ranked.is_empty() {
        return Vec::new();
    }
    let bvh = Bvh::build(scene);
    let near = scene.bounds().diagonal().max(1e-6) * 1e-5;
    ranked
        .into_iter()
        .filter_map(|i| {
            let worst = outcomes[i].eval.worst_view?;
            let camera = worst.camera(resolution, near)?;
            let v = view_errors(scene, &bvh, &camera, &file.cells[i].visible);
            let base = shaded_image(&v.frame, scene, &camera);
            Some(WorstImage {
                cell: i,
                image: highlight(&base, &v),
                errors: v.error_count(),
                unconfirmed: v.unconfirmed_count(),
                eye: worst.eye,
                forward: worst.forward,
            })
        })
        .collect()
}

/// `base` dimmed to 45 %, with erroneous pixels red and unconfirmed ones yellow on top.
pub(crate) fn highlight(base: &RgbImage, v: &ViewErrors) -> RgbImage {
    let w = base.width();
    RgbImage::from_fn(base.width(), base.height(), |x, y| {
        let i = (y * w + x) as usize;
        if v.error.get(i).copied().unwrap_or(false) {
            image::Rgb(ERROR_RED)
        } else if v.unconfirmed.get(i).copied().unwrap_or(false) {
            image::Rgb(SNAP_YELLOW)
        } else {
            image::Rgb(base.get_pixel(x, y).0.map(|c| (c as f32 * 0.45) as u8))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::raster::Frame;

    #[test]
    fn highlight_paints_errors_red_and_snaps_yellow_and_dims_the_rest() {
        let base = RgbImage::from_pixel(3, 1, image::Rgb([200, 100, 0]));
        let v = ViewErrors {
            frame: Frame::new(3, 1),
            error: vec![true, false, false],
            unconfirmed: vec![false, true, false],
        };
        let h = highlight(&base, &v);
        assert_eq!(h.get_pixel(0, 0).0, ERROR_RED);
        assert_eq!(h.get_pixel(1, 0).0, SNAP_YELLOW);
        assert_eq!(h.get_pixel(2, 0).0, [90, 45, 0]);
    }
}
