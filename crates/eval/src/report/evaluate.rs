//! The pixel error of every cell of a `.pvs` file, with the GVS++ paper's metric
//! (`crate::evaluate_cell_in`), and the worst views rendered with their error pixels
//! highlighted.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, section 6 (the error measures),
//! as implemented in `crate::pixel_error`.

use std::cell::Cell;
use std::time::Instant;

use crate::{evaluate_cell_in, view_errors, CellEvaluation, EvalParams, ViewErrors};
use glam::Vec3;
use image::RgbImage;
use sightline_core::trace::Bvh;
use sightline_core::{Scene, TriangleSet};
use sightline_region::cell_sources::{inside_solid, Q3OriginRule, Q3Origins};
use sightline_region::PvsFile;

use super::error::ReportError;
use super::shading::shaded_image;

/// One cell's evaluation.
pub struct CellOutcome {
    /// The file's PVS.
    pub eval: CellEvaluation,
    /// Further sets of the same cell judged on the same views (e.g. a baseline method).
    pub extra: Vec<CellEvaluation>,
    /// Seconds the evaluation took.
    pub seconds: f64,
    /// Viewpoints skipped for lying outside the cell's cluster, for being unreachable
    /// (Quake 3 cells), or inside solid geometry (other scenes).
    pub rejected: Rejected,
}

/// Viewpoints of a cell that were not evaluated, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Rejected {
    /// Outside the cell's cluster (solid space, or another cluster in the cell's box).
    pub outside_cluster: usize,
    /// In the cluster, but not in the space reachable from the map's spawn points.
    pub unreachable: usize,
    /// Scenes without a BSP: inside closed geometry (a wall's or a pillar's volume, a sealed
    /// pocket), where no camera can be, as `cell_sources::inside_solid` decides: most rays
    /// from the point hit back faces.
    pub inside_solid: usize,
}

impl Rejected {
    /// All rejected viewpoints.
    pub fn total(&self) -> usize {
        self.outside_cluster + self.unreachable + self.inside_solid
    }
}

impl std::iter::Sum for Rejected {
    /// The counts of several cells, reason by reason.
    fn sum<I: Iterator<Item = Self>>(iter: I) -> Self {
        iter.fold(Self::default(), |a, b| Self {
            outside_cluster: a.outside_cluster + b.outside_cluster,
            unreachable: a.unreachable + b.unreachable,
            inside_solid: a.inside_solid + b.inside_solid,
        })
    }
}

/// Where the viewpoints of a file's cells may be: Quake 3 cells (`metadata["clusters"]`) take
/// them where the bake took its ray origins (the cell's cluster, and reachable space when the
/// bake recorded one); cells of other scenes anywhere in the cell outside solid geometry (a
/// view from inside a wall sees its back faces and would count them as errors of the PVS).
pub struct Viewpoints<'a> {
    rule: Option<Q3OriginRule<'a>>,
    /// Scenes without a BSP: the scene and a BVH over it, for the solid test.
    solid: Option<(&'a Scene, Bvh)>,
}

impl<'a> Viewpoints<'a> {
    /// The rule of `file` (its reachable space is rebuilt from the recorded parameters), or
    /// the rule `origins` for its Quake 3 cells when given.
    pub fn of(
        scene: &'a Scene,
        file: &PvsFile,
        origins: Option<Q3Origins>,
    ) -> Result<Self, ReportError> {
        let rule = Q3OriginRule::from_metadata(scene, &file.metadata, origins)?;
        let solid = scene.bsp.is_none().then(|| (scene, Bvh::build(scene)));
        Ok(Self { rule, solid })
    }

    /// The filter of cell `cell`.
    pub fn cell(&self, cell: usize) -> CellViewpoints<'_> {
        CellViewpoints {
            rule: self.rule.as_ref(),
            solid: self.solid.as_ref().map(|(s, b)| (*s, b)),
            cluster: self
                .rule
                .as_ref()
                .and_then(|r| r.clusters.get(cell).copied()),
            last: Cell::new(None),
            rejected: Cell::new(Rejected::default()),
        }
    }

    /// The same filter for every cell of cluster `cluster` (`pvs compare-q3`).
    pub fn cluster(&self, cluster: u32) -> CellViewpoints<'_> {
        CellViewpoints {
            rule: self.rule.as_ref(),
            solid: self.solid.as_ref().map(|(s, b)| (*s, b)),
            cluster: Some(cluster),
            last: Cell::new(None),
            rejected: Cell::new(Rejected::default()),
        }
    }
}

/// The viewpoint filter of one cell, counting what it rejects. The evaluation asks once per
/// view (six times per viewpoint for cube faces), so the last answer is kept: each viewpoint
/// is judged and counted once.
pub struct CellViewpoints<'r> {
    rule: Option<&'r Q3OriginRule<'r>>,
    solid: Option<(&'r Scene, &'r Bvh)>,
    cluster: Option<u32>,
    last: Cell<Option<(Vec3, bool)>>,
    rejected: Cell<Rejected>,
}

impl CellViewpoints<'_> {
    /// True when `eye` may be a viewpoint.
    pub fn allows(&self, eye: Vec3) -> bool {
        if let Some((p, ok)) = self.last.get() {
            if p == eye {
                return ok;
            }
        }
        let mut r = self.rejected.get();
        let ok = if let Some((scene, bvh)) = self.solid {
            let free = !inside_solid(scene, bvh, eye);
            r.inside_solid += usize::from(!free);
            free
        } else if let (Some(rule), Some(cluster)) = (self.rule, self.cluster) {
            Self::q3_allows(rule, cluster, eye, &mut r)
        } else {
            true
        };
        self.rejected.set(r);
        self.last.set(Some((eye, ok)));
        ok
    }

    /// The Quake 3 rule: in the cell's cluster and, where the bake recorded one, in reachable
    /// space.
    fn q3_allows(rule: &Q3OriginRule<'_>, cluster: u32, eye: Vec3, r: &mut Rejected) -> bool {
        if !rule.in_cluster(cluster, eye) {
            r.outside_cluster += 1;
            false
        } else if !rule.reachable(eye) {
            r.unreachable += 1;
            false
        } else {
            true
        }
    }

    /// What was rejected so far.
    pub fn rejected(&self) -> Rejected {
        self.rejected.get()
    }
}

/// Evaluates every cell of `file`; `extra[i]` (when present) are more sets for cell `i`.
/// Cells of a Quake 3 bake take viewpoints only where the bake took its ray origins, cells of
/// other scenes only outside solid geometry ([`Viewpoints`]). `progress(cell, view, views)` reports progress.
pub(crate) fn evaluate_cells(
    scene: &Scene,
    file: &PvsFile,
    params: &EvalParams,
    extra: &[Vec<&TriangleSet>],
    progress: &dyn Fn(usize, usize, usize),
) -> Result<Vec<CellOutcome>, ReportError> {
    let viewpoints = Viewpoints::of(scene, file, None)?;
    Ok(file
        .cells
        .iter()
        .enumerate()
        .map(|(i, cell)| {
            let start = Instant::now();
            let filter = viewpoints.cell(i);
            let mut sets: Vec<&TriangleSet> = vec![&cell.visible];
            sets.extend(extra.get(i).into_iter().flatten().copied());
            let mut evals = evaluate_cell_in(
                scene,
                &cell.cell,
                &|p| filter.allows(p),
                &sets,
                params,
                &|d, n| progress(i, d, n),
            );
            let eval = evals.remove(0);
            CellOutcome {
                eval,
                extra: evals,
                seconds: start.elapsed().as_secs_f64(),
                rejected: filter.rejected(),
            }
        })
        .collect())
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
    ranked
        .into_iter()
        .filter_map(|i| {
            let worst = outcomes[i].eval.worst_view?;
            // The near plane the evaluation rendered the view with.
            let camera = worst.camera(resolution, file.cells[i].cell.default_near(scene))?;
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

/// Pixels within this distance (Chebyshev) of an erroneous pixel are tinted red, so that a
/// few scattered error pixels can be found in a large image.
pub(crate) const HALO_PX: usize = 3;

/// `mask` grown by `r` pixels in every direction (square neighbourhood; separable: rows, then
/// columns).
pub(crate) fn dilate(mask: &[bool], width: usize, height: usize, r: usize) -> Vec<bool> {
    debug_assert_eq!(mask.len(), width * height);
    let mut rows = vec![false; mask.len()];
    for y in 0..height {
        for x in 0..width {
            let (lo, hi) = (x.saturating_sub(r), (x + r).min(width.saturating_sub(1)));
            rows[y * width + x] = (lo..=hi).any(|k| mask[y * width + k]);
        }
    }
    let mut out = vec![false; mask.len()];
    for y in 0..height {
        let (lo, hi) = (y.saturating_sub(r), (y + r).min(height.saturating_sub(1)));
        for x in 0..width {
            out[y * width + x] = (lo..=hi).any(|k| rows[k * width + x]);
        }
    }
    out
}

/// `base` dimmed to 45 %, with erroneous pixels red, a red tint within [`HALO_PX`] of them,
/// and unconfirmed pixels yellow.
pub(crate) fn highlight(base: &RgbImage, v: &ViewErrors) -> RgbImage {
    let (w, h) = (base.width() as usize, base.height() as usize);
    let halo = if v.error.len() == w * h {
        dilate(&v.error, w, h, HALO_PX)
    } else {
        vec![false; w * h]
    };
    RgbImage::from_fn(base.width(), base.height(), |x, y| {
        let i = y as usize * w + x as usize;
        let dim = base.get_pixel(x, y).0.map(|c| c as f32 * 0.45);
        if v.error.get(i).copied().unwrap_or(false) {
            image::Rgb(ERROR_RED)
        } else if v.unconfirmed.get(i).copied().unwrap_or(false) {
            image::Rgb(SNAP_YELLOW)
        } else if halo[i] {
            image::Rgb([0, 1, 2].map(|k| (0.5 * dim[k] + 0.5 * ERROR_RED[k] as f32) as u8))
        } else {
            image::Rgb(dim.map(|c| c as u8))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::raster::Frame;

    #[test]
    fn viewpoints_inside_solid_geometry_are_rejected_and_counted() {
        // A solid pillar (a closed box, faces outward) on a floor, and open space around it.
        let mut b = sightline_core::scene::SceneBuilder::new("pillar");
        b.add_box(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 3.0));
        b.add_box(Vec3::new(-10.0, -10.0, -0.5), Vec3::new(10.0, 10.0, 0.0));
        let scene = b.finish();
        let file = PvsFile::for_scene(&scene, serde_json::Value::Null);
        let viewpoints = Viewpoints::of(&scene, &file, None).unwrap();
        let filter = viewpoints.cell(0);
        let inside = Vec3::new(0.2, -0.3, 1.5);
        let outside = [Vec3::new(3.0, 0.0, 1.5), Vec3::new(-2.0, 4.0, 0.5)];
        assert!(!filter.allows(inside));
        // Asked again for the next face of the same cube map: judged and counted once.
        assert!(!filter.allows(inside));
        for p in outside {
            assert!(filter.allows(p), "{p}");
        }
        // Inside the floor slab too.
        assert!(!filter.allows(Vec3::new(5.0, 5.0, -0.25)));
        let r = filter.rejected();
        assert_eq!((r.inside_solid, r.total()), (2, 2));
    }

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
        // Within the halo of the error pixel: half dimmed colour, half red.
        assert_eq!(h.get_pixel(2, 0).0, [172, 34, 12]);
    }

    #[test]
    fn far_from_errors_pixels_are_only_dimmed() {
        let w = 2 * HALO_PX as u32 + 3;
        let base = RgbImage::from_pixel(w, 1, image::Rgb([200, 100, 0]));
        let mut error = vec![false; w as usize];
        error[0] = true;
        let v = ViewErrors {
            frame: Frame::new(w, 1),
            error,
            unconfirmed: vec![false; w as usize],
        };
        assert_eq!(highlight(&base, &v).get_pixel(w - 1, 0).0, [90, 45, 0]);
    }

    #[test]
    fn dilate_of_empty_mask_is_empty() {
        assert!(dilate(&[], 0, 0, 3).is_empty());
        assert!(dilate(&[false; 12], 4, 3, 1).iter().all(|&b| !b));
    }

    #[test]
    fn dilate_grows_a_pixel_into_a_square_clipped_at_the_border() {
        let mut m = vec![false; 25];
        m[0] = true; // (0, 0)
        let d = dilate(&m, 5, 5, 1);
        let on: Vec<usize> = (0..25).filter(|&i| d[i]).collect();
        assert_eq!(on, vec![0, 1, 5, 6]);
        let mut m = vec![false; 25];
        m[12] = true; // centre
        assert_eq!(dilate(&m, 5, 5, 1).iter().filter(|&&b| b).count(), 9);
    }
}
