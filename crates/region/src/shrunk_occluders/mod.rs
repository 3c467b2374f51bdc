//! Occluder fusion from a view cell by shrinking occluders and sampling viewpoints: the
//! conservative bound's rule for what several solids hide together (a street's houses hide
//! the next street although none of them does alone).
//!
//! Based on: Wonka, Wimmer, Schmalstieg. Visibility Preprocessing with Occluder Fusion for
//! Urban Walkthroughs. Eurographics Workshop on Rendering 2000, sections 3-4. Their theorem:
//! a point hidden from viewpoint `p` by occluders shrunk by `e` is hidden by the full
//! occluders from every viewpoint within `e` of `p` (the segment from a moved viewpoint runs
//! within `e` of the original one, so it passes through the full occluder wherever the
//! original passed through the shrunk one). Point visibility from enough samples, with
//! occluders shrunk by the samples' spacing, is then visibility from the whole cell, and the
//! fusion of occluders comes free with each point's depth buffer.
//!
//! # What the occluders are
//! The union of the scene's closed solids (`crate::closed_solids`), not each solid: terraced
//! houses share walls, and shrinking each house alone would open a gap between every pair.
//! `columns.rs` finds the union as spans over square columns along the up axis (a shared wall
//! is crossed when the faces of the two solids cover each other); `erosion.rs` shrinks it and
//! cuts it into boxes. Solids open other than at their bottom are left out. On a Quake 3 map
//! ([`ShrunkOccluders::of_map`]) the union is the map's solid space instead, as the BSP tree
//! gives it (`bsp_columns.rs`): its drawn faces are no closed solids, but every point lies in
//! a leaf that is either empty or solid.
//!
//! # Why it is conservative
//! Per axis, not per ball: for a viewpoint `v` of the cell outside every solid, a sample `p`
//! whose sub-box of the cell holds `v` (so `|v - p|` is at most the sub-box's half-extent `h`
//! along each world axis), and a target point `x` whose pixel's centre ray from `p` enters a
//! shrunk box at depth `d` before `x`'s depth: the ray from `p` to `x` passes within
//! `d * sqrt(2) / resolution` (`cube_depth.rs`) of that entry at depth `d`, and the segment from
//! `v` to `x` runs beside it displaced by `(1 - t) (v - p)`, at most `h` along each axis. So
//! it passes through the union wherever that is shrunk, along each axis, by `h` plus the
//! pixels' reach at that depth, strictly before `x`: it enters a solid through one of its faces
//! before reaching `x`. Sideways the boxes are shrunk by the level's radius (`erosion.rs`, a
//! square window: per axis too), and depths are rendered only up to the `max_depth` where that
//! covers `h` and the pixels' reach. Along the up axis the boxes are shrunk by the samples'
//! half-height and, per pixel, by the pixels' reach at the depth where that pixel's ray leaves
//! the box: a flat cell's view over near roofs loses centimetres, not the radius (roofs seen at
//! a grazing angle from a cell at their height are what most of a city's far view hides
//! behind). Open bottoms are faces too only for viewpoints above them: boxes near a solid
//! whose open bottom lies above the cell's lowest corner are not used. Viewpoints inside a
//! solid see only that solid and what lies within its box: where the cell reaches into a
//! solid, those triangles are kept.
//!
//! # Memory and time
//! Built once per scene and radius: 8 bytes per column plus 16 per span while the columns are
//! found (a 1.5 x 1.2 km city at 1 m columns: 1.8 M columns, ~40 MB), then 56 bytes per box.
//! A Quake 3 map's solid space is found per level on first use, on columns of a quarter of the
//! level's shrink (half for the first level): every column holds spans there (the rock under
//! the floors at least), so a fine grid is large (czest3ctf, 6.3 x 4.0 km units: 1.8 M
//! columns at the first level; its bound's peak memory went from 180 to 400 MB), while a
//! large cell starts at a coarse level (fan.bsp's cluster cells at the fifth: 5,000 columns).
//! Per cell and thread: a depth cube of `6 * resolution^2` f32 (6 MB at 512), rendered once per
//! sample; each target triangle is tested against each sample's cube until one sees it.

mod bsp_columns;
mod columns;
mod cube_depth;
mod erosion;
mod polygon;

use std::sync::OnceLock;

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use sightline_core::{Scene, TriangleSet};

use crate::closed_solids::ClosedSolids;
use crate::viewcell::ViewCell;
use columns::Columns;
use cube_depth::{BoxGroups, CubeDepth, DepthBox, Footprints};
use erosion::{shrunk_boxes, OccluderBox};

/// Column grids larger than this are not built (the rule is then not used).
pub const MAX_COLUMNS: usize = 1 << 24;

/// Viewpoint samples per cell at most: a cell that would need more at the first level's
/// shrink starts at a coarser level.
pub const MAX_SAMPLES: usize = 1024;

/// Depth (relative to the radius) from which the boxes are rendered: nearer, a box's
/// projection grows without bound, and what is that close to a sample is seen anyway.
const RENDER_NEAR: f64 = 0.02;

/// Distance (relative to the radius) within which a triangle counts as seen from a sample.
const SEEN_NEAR: f64 = 1e-3;

/// The side of the cubes whose boxes are drawn as a group (relative to the radius): a
/// group the tiles still to draw do not reach is skipped whole.
const GROUP_SIZE: f64 = 16.0;

/// The most shrink levels ([`FusionOptions::levels`]).
pub const MAX_LEVELS: usize = 8;

/// The part of the first level's sideways shrink spent on the pixel sampling (the rest on
/// the viewpoints').
const PIXEL_SHARE: f64 = 0.4;

/// How the occluders are shrunk and the cells sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FusionOptions {
    /// How far the union of solids is shrunk (scene units): the viewpoints' spacing and the
    /// pixels' reach share it. Larger: fewer samples, thinner occluders.
    pub radius: f64,
    /// Pixels along the side of each face of the depth cubes.
    pub resolution: usize,
    /// Shrink levels a cell uses: level `k` shrinks by `radius * 2^k` and is rendered up to
    /// the depth where that covers the pixels' reach, so far blocks still hide what lies
    /// behind them. A cell starts at the first level whose shrink needs at most
    /// [`MAX_SAMPLES`] viewpoint samples (a large cell at a coarser one).
    pub levels: usize,
}

impl FusionOptions {
    /// Options for `scene`: a shrink of 1/1000 of its diagonal (1.9 m on the 1.9 km Munich
    /// scene), 256 pixels a face.
    pub fn for_scene(scene: &Scene) -> Self {
        let b = scene.bounds();
        Self {
            radius: 1e-3 * f64::from((b.max - b.min).length()),
            resolution: 256,
            levels: 4,
        }
    }

    /// Level `k`'s shrink.
    fn radius_of(&self, level: usize) -> f64 {
        self.radius * (1u64 << level.min(30)) as f64
    }

    /// The depth up to which level `k`'s occluders are rendered for samples starting at level
    /// `first`: where the pixels' reach uses up what the viewpoints leave of its shrink.
    fn max_depth(&self, level: usize, first: usize) -> f64 {
        (self.radius_of(level) - self.sample_reach(first)) * self.resolution as f64
            / std::f64::consts::SQRT_2
            / 1.001
    }

    /// How far a sample may be from the viewpoints it stands for along each world axis,
    /// starting at level `first`.
    fn sample_reach(&self, first: usize) -> f64 {
        (1.0 - PIXEL_SHARE) * self.radius_of(first) / 1.001
    }
}

/// The shrunk union of a scene's closed solids (see the module documentation).
#[derive(Clone, Debug)]
pub struct ShrunkOccluders {
    options: FusionOptions,
    union: Union,
    /// Per level (up to [`MAX_LEVELS`]), its boxes, made on first use.
    levels: Vec<OnceLock<Vec<OccluderBox>>>,
}

/// The union the levels' boxes are shrunk from.
#[derive(Clone, Debug)]
enum Union {
    /// Closed solids, as columns of half the first level's shrink, for every level.
    Solids(Columns),
    /// A Quake 3 map's solid space, as columns made per level from the BSP tree (the scene's,
    /// given to each use): a quarter of the level's shrink (half of it for the first level),
    /// so that a level of large shrink, which a large cell starts at, is found on a grid of
    /// few columns with a window of few columns.
    Map,
}

/// What [`ShrunkOccluders::remove_hidden`] did for one cell.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FusionReport {
    /// Viewpoint samples used (0: the cell was left as it was).
    pub samples: usize,
    /// Occluder boxes within reach of the cell.
    pub boxes: usize,
    /// Triangles removed.
    pub removed: usize,
}

impl ShrunkOccluders {
    /// The shrunk union of `solids` (found in `scene`), or `None` when the scene has no usable
    /// solids, the options make no sense or the grid would be too large.
    pub fn new(scene: &Scene, solids: &ClosedSolids, options: FusionOptions) -> Option<Self> {
        Self::valid(&options)?;
        // Columns of half the radius: the first level's shrink rounds up to two of them.
        let columns = Columns::new(scene, solids, options.radius / 2.0, MAX_COLUMNS)?;
        Some(Self::with_union(options, Union::Solids(columns)))
    }

    /// The shrunk solid space of a Quake 3 map (`scene`, with its BSP tree: see
    /// `bsp_columns.rs`), or `None` when the scene has no BSP or the options make no sense.
    /// Only for cells whose viewpoints all lie in the map's empty leaves
    /// ([`ShrunkOccluders::remove_hidden_in_map`], with the same scene); each level's columns
    /// are made on its first use (a level whose grid would be too large hides nothing).
    pub fn of_map(scene: &Scene, options: FusionOptions) -> Option<Self> {
        scene.bsp.as_deref()?;
        Self::valid(&options)?;
        Some(Self::with_union(options, Union::Map))
    }

    /// `Some` when the options make sense.
    fn valid(options: &FusionOptions) -> Option<()> {
        (options.radius.is_finite()
            && options.radius > 0.0
            && options.resolution > 0
            && (1..=MAX_LEVELS).contains(&options.levels))
        .then_some(())
    }

    /// The union with no level's boxes made yet.
    fn with_union(options: FusionOptions, union: Union) -> Self {
        Self {
            options,
            union,
            levels: (0..MAX_LEVELS).map(|_| OnceLock::new()).collect(),
        }
    }

    /// Level `k`'s boxes (`scene`: the one the union was made from).
    fn level(&self, k: usize, scene: &Scene) -> &[OccluderBox] {
        self.levels[k].get_or_init(|| {
            let radius = self.options.radius_of(k);
            match &self.union {
                Union::Solids(columns) => shrunk_boxes(columns, radius, columns.size),
                Union::Map => {
                    let size = radius / if k == 0 { 2.0 } else { 4.0 };
                    scene
                        .bsp
                        .as_deref()
                        .and_then(|bsp| Columns::from_bsp(scene, bsp, size, MAX_COLUMNS))
                        .map_or_else(Vec::new, |columns| shrunk_boxes(&columns, radius, size))
                }
            }
        })
    }

    /// Removes from `visible` the triangles that the shrunk union hides from every sample of
    /// `cell`; `solids` and `scene` must be those it was built from.
    pub fn remove_hidden(
        &self,
        scene: &Scene,
        solids: &ClosedSolids,
        cell: &ViewCell,
        visible: &mut TriangleSet,
    ) -> FusionReport {
        self.remove_hidden_keeping(scene, cell, visible, |corners| {
            Some(kept_for(scene, solids, corners))
        })
    }

    /// [`ShrunkOccluders::remove_hidden`] for the shrunk solid space of a Quake 3 map
    /// ([`ShrunkOccluders::of_map`], from `scene`), for a cell whose viewpoints all lie in
    /// the map's empty leaves (its leaf and cluster cells): none of them is inside the
    /// union, so no triangle needs keeping for being in reach of one.
    pub fn remove_hidden_in_map(
        &self,
        scene: &Scene,
        cell: &ViewCell,
        visible: &mut TriangleSet,
    ) -> FusionReport {
        self.remove_hidden_keeping(scene, cell, visible, |_| None)
    }

    /// Removes from `visible` the triangles, but those `keep` gives for the cell's corners
    /// (`None`: none kept, without a flag per triangle), that the shrunk union hides from
    /// every sample of `cell`.
    fn remove_hidden_keeping(
        &self,
        scene: &Scene,
        cell: &ViewCell,
        visible: &mut TriangleSet,
        keep: impl FnOnce(&[DVec3]) -> Option<Vec<bool>>,
    ) -> FusionReport {
        let corners: Vec<DVec3> = cell.corners().iter().map(|c| c.as_dvec3()).collect();
        if corners.iter().any(|c| !c.is_finite()) {
            return FusionReport::default();
        }
        let keep = keep(&corners);
        let Some((first, (samples, half))) = (0..MAX_LEVELS)
            .find_map(|k| samples_of(cell, self.options.sample_reach(k)).map(|s| (k, s)))
        else {
            return FusionReport::default();
        };
        let (lo, hi) = bounds_of(&corners);
        let up = scene.up.index();
        let boxes = self.boxes_for(scene, lo, hi, up, first, half[up]);
        // The triangles in doubt, with their corners and lowest point along the up axis (found
        // once for all samples).
        let mut targets: Vec<(u32, [DVec3; 3], f64)> = visible
            .ones()
            .filter(|&t| {
                !keep
                    .as_ref()
                    .is_some_and(|k| k.get(t).copied().unwrap_or(true))
            })
            .map(|t| {
                let corners = scene.triangle(t as u32).map(|p| p.as_dvec3());
                let lowest = corners[0][up].min(corners[1][up]).min(corners[2][up]);
                (t as u32, corners, lowest)
            })
            .collect();
        // In groups of neighbours, nearest the cell first: the samples lie within it, and
        // near boxes drawn first let the pixels' depths skip the far ones.
        let boxes = BoxGroups::new(
            boxes,
            cell.center.as_dvec3(),
            GROUP_SIZE * self.options.radius,
        );
        let near = SEEN_NEAR * self.options.radius;
        let batch = rayon::current_num_threads().max(1);
        let mut cubes: Vec<(CubeDepth, Footprints)> = (0..batch)
            .map(|_| {
                (
                    CubeDepth::new(self.options.resolution),
                    Footprints::default(),
                )
            })
            .collect();
        for chunk in samples.chunks(batch) {
            if targets.is_empty() {
                break;
            }
            let seen: Vec<Vec<bool>> = chunk
                .par_iter()
                .zip(cubes.par_iter_mut())
                .map(|(&eye, (cube, footprints))| {
                    // Only where the triangles still in doubt may be seen.
                    cube.footprints(eye, targets.iter().map(|(_, t, _)| t), near, footprints);
                    let mut needed = cube.no_tiles();
                    cube.mark(footprints, &mut needed);
                    cube.render(
                        eye,
                        &boxes,
                        up,
                        RENDER_NEAR * self.options.radius,
                        Some(&needed),
                    );
                    targets
                        .iter()
                        .enumerate()
                        .map(|(k, &(_, _, lowest))| !cube.hides(footprints, k, lowest, lo[up]))
                        .collect()
                })
                .collect();
            let mut k = 0;
            targets.retain(|_| {
                let any = seen.iter().any(|s| s[k]);
                k += 1;
                !any
            });
        }
        for &(t, _, _) in &targets {
            visible.set(t as usize, false);
        }
        FusionReport {
            samples: samples.len(),
            boxes: boxes.len(),
            removed: targets.len(),
        }
    }
}

impl ShrunkOccluders {
    /// The boxes to render for a cell spanning `lo..hi`, with their heights: a box whose span
    /// starts below every viewpoint reaches down (a segment between points above the span's
    /// bottom never passes below it, so for such segments the column may as well be solid
    /// there; the box keeps that bottom as its cap for the targets); otherwise a box resting
    /// on a closed floor is shrunk at both ends, and one resting on an open bottom is not used
    /// (a viewpoint below it might look in from beneath).
    fn boxes_for(
        &self,
        scene: &Scene,
        lo: DVec3,
        hi: DVec3,
        up: usize,
        first: usize,
        viewpoints_up: f64,
    ) -> Vec<DepthBox> {
        let lowest = lo[up];
        let margin = 1e-9 * lowest.abs().max(self.options.radius);
        // Along the up axis the boxes shrink by the viewpoints' reach that way (the samples'
        // half-height), here, and by the pixels' reach at each pixel's depth as the cube
        // renders them; sideways by the level's radius, which covers both up to `max_depth`.
        let vertical = viewpoints_up * (1.0 + 1e-6) + margin;
        let mut out = Vec::new();
        for level in first..(first + self.options.levels).min(MAX_LEVELS) {
            let boxes = self.level(level, scene);
            let r = self.options.radius_of(level);
            let max_depth = self.options.max_depth(level, first);
            let reach = max_depth * 3f64.sqrt();
            let deepest = lowest - max_depth - r;
            out.extend(boxes.iter().filter_map(|b| {
                let (bottom, cap, reach_ends) = if b.span.lo < lowest - margin {
                    // The span's bottom lies a rounding margin above the face it rests on
                    // (`columns.rs`); a target standing on that face is above it too.
                    let cap = b.span.lo - 1e-6 * b.span.lo.abs().max(r);
                    (deepest, cap, [true, false])
                } else if !b.span.open {
                    (b.span.lo + vertical, f64::NEG_INFINITY, [true, true])
                } else {
                    return None;
                };
                let top = b.span.hi - vertical;
                let (mut min, mut max) = (b.min, b.max);
                min[up] = bottom;
                max[up] = top;
                let near = (min - hi).max_element() <= reach && (lo - max).max_element() <= reach;
                (top > bottom && near).then_some(DepthBox {
                    min,
                    max,
                    cap,
                    max_depth,
                    reach_ends,
                })
            }));
        }
        out
    }
}

/// The smallest and largest corner.
fn bounds_of(corners: &[DVec3]) -> (DVec3, DVec3) {
    corners
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), c| {
            (lo.min(*c), hi.max(*c))
        })
}

/// Viewpoint samples of `cell`, the centres of a grid of sub-boxes, with the half-extents along
/// the world axes of each sub-box's bounding box: a viewpoint of a sub-box is within those of
/// its centre along each axis. Each half-extent is at most `reach`; `None` when more than
/// [`MAX_SAMPLES`] samples would be needed.
fn samples_of(cell: &ViewCell, reach: f64) -> Option<(Vec<DVec3>, DVec3)> {
    let extents = (cell.half_extents * 2.0).as_dvec3();
    let axes = cell.axes.map(|a| a.as_dvec3());
    let mut counts = [1usize; 3];
    let half_of = |counts: &[usize; 3]| {
        (0..3).fold(DVec3::ZERO, |h, k| {
            h + axes[k].abs() * (0.5 * extents[k] / counts[k] as f64)
        })
    };
    while half_of(&counts).max_element() > reach {
        let k = (0..3)
            .max_by(|&a, &b| {
                (extents[a] / counts[a] as f64).total_cmp(&(extents[b] / counts[b] as f64))
            })
            .unwrap_or(0);
        counts[k] += 1;
        if counts.iter().product::<usize>() > MAX_SAMPLES {
            return None;
        }
    }
    let centre = cell.center.as_dvec3();
    let mut samples = Vec::with_capacity(counts.iter().product());
    for i in 0..counts[0] {
        for j in 0..counts[1] {
            for k in 0..counts[2] {
                let at = |n: usize, c: usize, e: f64| ((n as f64 + 0.5) / c as f64 - 0.5) * e;
                samples.push(
                    centre
                        + axes[0] * at(i, counts[0], extents[0])
                        + axes[1] * at(j, counts[1], extents[1])
                        + axes[2] * at(k, counts[2], extents[2]),
                );
            }
        }
    }
    Some((spread(samples), half_of(&counts)))
}

/// `points` reordered so that each comes as far as possible from those before it (the
/// first batches see most of what the cell sees, and later ones test little).
fn spread(mut points: Vec<DVec3>) -> Vec<DVec3> {
    let mut order = Vec::with_capacity(points.len());
    let mut nearest = vec![f64::INFINITY; points.len()];
    let mut next = 0;
    while !points.is_empty() {
        let p = points.swap_remove(next);
        nearest.swap_remove(next);
        order.push(p);
        next = 0;
        for (k, q) in points.iter().enumerate() {
            nearest[k] = nearest[k].min(q.distance_squared(p));
            if nearest[k] > nearest[next] {
                next = k;
            }
        }
    }
    order
}

/// Per triangle, whether the rule must keep it for the cell with `corners`: the triangles of
/// solids the cell is not wholly outside of, and every triangle whose box meets such a solid's
/// box (a viewpoint inside a solid sees it and what lies within it).
fn kept_for(scene: &Scene, solids: &ClosedSolids, corners: &[DVec3]) -> Vec<bool> {
    let outside = solids.outside_for(scene, corners);
    let mut keep = vec![false; scene.triangle_count()];
    let mut reached: Vec<(Vec3, Vec3)> = Vec::new();
    for (s, &out) in outside.iter().enumerate() {
        if out {
            continue;
        }
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &t in solids.solid(s).triangles {
            keep[t as usize] = true;
            for p in scene.triangle(t) {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        reached.push((lo, hi));
    }
    if !reached.is_empty() {
        for (t, k) in keep.iter_mut().enumerate() {
            let c = scene.triangle(t as u32);
            let lo = c[0].min(c[1]).min(c[2]);
            let hi = c[0].max(c[1]).max(c[2]);
            if reached
                .iter()
                .any(|(a, b)| lo.cmple(*b).all() && hi.cmpge(*a).all())
            {
                *k = true;
            }
        }
    }
    keep
}

#[cfg(test)]
mod tests;
