//! Conservative visibility from a view *region* (a convex view cell), streaming in two passes
//! in bounded memory: the thesis' future work ("extending the algorithm to compute visibility
//! from a region"), built on the exact shadow of convex occluders instead of shrunk ones.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 8 (future work: from-region visibility, prioritising large occluders); the
//! umbra of a convex occluder from a convex region after Cohen-Or, Chrysanthou, Silva, Durand.
//! A Survey of Visibility for Walkthrough Applications. 2003, section 4 (conservative
//! from-region culling with single convex occluders).
//!
//! # Why it is conservative
//! A point `x` is hidden from every point of the cell when every segment from the cell to `x`
//! passes through one convex planar occluder `O`. For a fixed `x` that holds for viewpoint `v`
//! when `v` and `x` lie strictly on opposite sides of `O`'s plane and the central projection of
//! `x` from `v` onto the plane falls inside `O`. Along a segment of viewpoints the projection
//! of `x` moves along a segment of the plane (central projection maps lines to lines), so the
//! set of viewpoints from which `x` is hidden is convex; a convex cell is the convex hull of
//! its corners, so testing the corners suffices. Conversely, for a fixed corner `c`, the points
//! hidden by `O` form a convex cone beyond `O` (the plane of `O` and one plane through `c` and
//! each edge of `O`), so a triangle is hidden from the corner when its three vertices are. A
//! triangle whose vertices are inside the cones of all corners (the occluder's *umbra*) is
//! hidden from the whole cell. Every test keeps a margin (relative to the distances from the cell) on the
//! safe side.
//!
//! # Occluders and passes
//! Pass 1 streams the scene once, keeping the `max_occluders` convex occluders that cover the
//! largest solid angle from the cell's centre: single triangles, and pairs of consecutive
//! coplanar triangles sharing an edge whose union is a convex quad (generators and most files
//! emit quads that way). Pass 2 rewinds the source and tests every triangle against them,
//! largest first. A triangle hidden only by several occluders together is kept, unless
//! occluder fusion is on ([`RegionOptions::fusion_splits`] above 0, off by default): then the
//! triangles pass 2 left visible go through `region_fusion.rs` (the same occluders, shrunk,
//! drawn into conservative cube depth maps over an adaptive split of the cell).
//!
//! Memory: the visible set (one bit per id), the occluders (about 1.2 KiB each with their
//! umbra planes and polygon: 5 MiB at the default 4,096), one input batch; with fusion, the
//! corners of the triangles pass 2 left visible (76 bytes each) and one depth map per worker
//! thread (`6 * (4 fusion_resolution)^2 * 4` bytes at the last level: 6 MiB at the default
//! 128). Pass 2 costs triangles x occluders plane tests at worst (a triangle is tested against
//! the occluders, largest first, until one hides it); fusion costs up to
//! `2^(fusion_splits + 1)` depth maps and one finer map per box of the last level.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::DVec3;
use rayon::prelude::*;
use sightline_core::TriangleSet;

use super::region_fusion::{fused_hidden, CellShape, FusionOccluder, FusionOptions};
use super::source::{SourceTriangle, TriangleSource};
use super::types::RvError;

/// Occluders kept by default: on munich's street cells 4,096 give bounds 22 % smaller than
/// 1,024 at about twice the time (docs/BENCHMARKS.md, "Two-sided bakes").
pub const DEFAULT_MAX_OCCLUDERS: usize = 4096;

/// Levels of halving of the cell in the occluder fusion by default (docs/BENCHMARKS.md,
/// "Occluder fusion").
pub const DEFAULT_FUSION_SPLITS: u32 = 0;

/// Pixels per cube-face side of the fusion's depth maps by default (the last level's second
/// map is four times finer).
pub const DEFAULT_FUSION_RESOLUTION: usize = 128;

/// The most occluders kept: each costs about 1.2 KiB per cell under way and time in
/// proportion; a million is far past any useful bound.
pub const MAX_OCCLUDERS: usize = 1 << 20;

/// The most levels of halving of the cell (up to 2^13 depth maps: on munich's street cells
/// 8 levels take about 5 s, so 12 take minutes per cell; more would run for hours).
pub const MAX_FUSION_SPLITS: u32 = 12;

/// The largest cube-face side (the last level's maps are four times finer: 6 x 2048^2 f32,
/// 96 MiB, per worker thread).
pub const MAX_FUSION_RESOLUTION: usize = 512;

/// Options of [`conservative_from_region`].
#[derive(Clone, Debug, PartialEq)]
pub struct RegionOptions {
    /// Occluders kept (the largest by solid angle from the cell's centre).
    pub max_occluders: usize,
    /// Triangles per input batch.
    pub batch_triangles: usize,
    /// Occluder fusion (`region_fusion.rs`): levels of halving of the cell, each box with its
    /// own depth map of shrunk occluders; 0 turns fusion off.
    pub fusion_splits: u32,
    /// Pixels per side of each cube face of the fusion's depth maps (the last level retests
    /// what is left on a map four times finer).
    pub fusion_resolution: usize,
}

impl Default for RegionOptions {
    fn default() -> Self {
        Self {
            max_occluders: DEFAULT_MAX_OCCLUDERS,
            batch_triangles: 16384,
            fusion_splits: DEFAULT_FUSION_SPLITS,
            fusion_resolution: DEFAULT_FUSION_RESOLUTION,
        }
    }
}

/// Counters of a from-region run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RegionStats {
    /// Triangles read (per pass).
    pub triangles_streamed: u64,
    /// Occluders used.
    pub occluders: usize,
    /// Triangles found hidden from the whole cell.
    pub hidden: u64,
    /// Triangles with non-finite corners (never visible).
    pub invalid: u64,
    /// Of the hidden triangles, those only several occluders hide together (occluder fusion).
    pub fused_hidden: u64,
    /// Boxes of the cell the fusion drew a depth map for.
    pub fusion_boxes: u64,
}

/// The result of [`conservative_from_region`].
#[derive(Clone, Debug)]
pub struct RegionResult {
    /// Every triangle that may be visible from some point of the cell.
    pub visible: TriangleSet,
    /// Counters.
    pub stats: RegionStats,
}

/// Pass 2's verdict on a finite triangle: hidden by a single occluder, and its corners (for
/// the fusion pass).
type Verdict = (bool, [DVec3; 3]);

/// Margins of the plane tests, relative to the largest distance from the cell's centre
/// involved (f64 rounding is about 1e-16 of it).
const RELATIVE_MARGIN: f64 = 1e-7;

/// A convex planar occluder with its umbra from the cell: inside every plane
/// (`n · x - d > margin` for each `(n, d)`) means hidden from the whole cell.
#[derive(Clone, Debug)]
struct Occluder {
    score: f64,
    /// The polygon, for the fusion pass.
    poly: Vec<DVec3>,
    planes: Vec<(DVec3, f64)>,
    /// A cap of directions from the cell's centre that holds the occluder's umbra: a point
    /// hidden from the whole cell is hidden from the centre, so its direction from there
    /// falls inside the polygon's, which this cap bounds. One dot product rejects most
    /// triangles before the plane tests.
    cap: DirectionCap,
}

/// Directions `d` with `axis · d >= cos_radius * |d|`: a spherical cap of radius below 90
/// degrees, or every direction (`cos_radius` = -1).
#[derive(Clone, Copy, Debug)]
struct DirectionCap {
    axis: DVec3,
    cos_radius: f64,
}

impl DirectionCap {
    /// The cap around the directions of `poly`'s corners from the origin (a convex polygon's
    /// directions are the spherical hull of its corners', inside any cap of radius below 90
    /// degrees that holds the corners').
    fn of(poly: &[DVec3]) -> Self {
        let everything = Self {
            axis: DVec3::X,
            cos_radius: -1.0,
        };
        let Some(axis) = poly
            .iter()
            .map(|p| p.normalize_or_zero())
            .sum::<DVec3>()
            .try_normalize()
        else {
            return everything;
        };
        let cos_radius = poly
            .iter()
            .map(|p| axis.dot(p.normalize_or_zero()))
            .fold(f64::INFINITY, f64::min);
        // Past about 85 degrees the cap is no longer a useful (or safely convex) bound; NaN
        // (a corner at the centre) bounds nothing either.
        if cos_radius.is_nan() || cos_radius <= 0.1 {
            return everything;
        }
        // Rounding of the normalisations, on the safe side.
        Self {
            axis,
            cos_radius: cos_radius - 1e-9,
        }
    }

    /// Whether `p`'s direction may be in the cap (a point at the origin may).
    #[inline]
    fn may_hold(&self, p: DVec3) -> bool {
        self.axis.dot(p) >= self.cos_radius * p.length()
    }
}

impl PartialEq for Occluder {
    fn eq(&self, o: &Self) -> bool {
        self.score == o.score
    }
}
impl Eq for Occluder {}
impl PartialOrd for Occluder {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Occluder {
    // Reversed, so the heap's top is the smallest score (the one to drop).
    fn cmp(&self, o: &Self) -> Ordering {
        o.score.total_cmp(&self.score)
    }
}

/// The umbra of convex polygon `poly` (counter-clockwise or clockwise, planar) from the cell
/// corners, or `None` when some corner is not strictly in front of its plane (the cell touches
/// or straddles it) or the polygon is degenerate.
fn umbra(poly: &[DVec3], corners: &[DVec3], margin: f64) -> Option<Vec<(DVec3, f64)>> {
    let centroid = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
    let mut normal = DVec3::ZERO;
    for i in 0..poly.len() {
        normal += (poly[i] - centroid).cross(poly[(i + 1) % poly.len()] - centroid);
    }
    let normal = normal.try_normalize()?;
    // Orient the plane so the cell is on its positive side; hidden points are beyond it.
    let side = normal.dot(corners[0] - centroid);
    let n = if side > 0.0 { -normal } else { normal };
    if corners.iter().any(|c| n.dot(*c - centroid) > -margin) {
        return None;
    }
    let mut planes = vec![(n, n.dot(centroid))];
    for c in corners {
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let mut e = (a - *c).cross(b - *c).try_normalize()?;
            // The cone's inside holds the polygon's interior.
            if e.dot(centroid - *c) < 0.0 {
                e = -e;
            }
            planes.push((e, e.dot(*c)));
        }
    }
    Some(planes)
}

/// Whether all three corners of `t` are strictly inside the umbra.
#[inline]
fn hidden_by(t: &[DVec3; 3], o: &Occluder, margin: f64) -> bool {
    o.planes
        .iter()
        .all(|(n, d)| t.iter().all(|p| n.dot(*p) - d > margin))
}

/// Solid angle (roughly: projected area over squared distance) of `poly` from `eye`.
fn solid_angle(poly: &[DVec3], eye: DVec3) -> f64 {
    let centroid = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
    let mut area = DVec3::ZERO;
    for i in 1..poly.len() - 1 {
        area += (poly[i] - poly[0]).cross(poly[i + 1] - poly[0]);
    }
    let to = centroid - eye;
    let d2 = to.length_squared().max(1e-30);
    0.5 * area.dot(to).abs() / (d2 * d2.sqrt())
}

/// The convex quad of two triangles that share an edge and lie in one plane, if their union is
/// convex.
fn quad_of(a: &[DVec3; 3], b: &[DVec3; 3], eps: f64) -> Option<[DVec3; 4]> {
    // The vertex of `b` not shared with `a`, and the order of `a` that puts the shared edge
    // last (a0 a1 a2 with a2-a0 shared).
    let shared = |p: &DVec3| a.contains(p);
    let extra: Vec<&DVec3> = b.iter().filter(|p| !shared(p)).collect();
    let [&x] = extra[..] else {
        return None;
    };
    let k = (0..3).find(|&k| !b.contains(&a[k]))?;
    let (p0, p1, p2) = (a[k], a[(k + 1) % 3], a[(k + 2) % 3]);
    let quad = [p0, p1, x, p2];
    let n = (p1 - p0).cross(p2 - p0);
    let scale = n.length();
    if scale == 0.0 || n.dot(x - p0).abs() > eps * scale.sqrt() {
        return None;
    }
    // Convex: every corner turns the same way about the normal.
    let turns = (0..4).map(|i| {
        let (u, v, w) = (quad[i], quad[(i + 1) % 4], quad[(i + 2) % 4]);
        (v - u).cross(w - v).dot(n)
    });
    let turns: Vec<f64> = turns.collect();
    (turns.iter().all(|&t| t > 0.0) || turns.iter().all(|&t| t < 0.0)).then_some(quad)
}

fn to_f64(t: &SourceTriangle) -> Option<[DVec3; 3]> {
    t.corners
        .iter()
        .all(|c| c.is_finite())
        .then(|| t.corners.map(|c| c.as_dvec3()))
}

/// Computes a conservative set of the triangles visible from some point of the convex cell
/// with corners `cell_corners` (all corners of the cell, e.g. the 8 of a box; a flat cell may
/// repeat points), streaming `source` twice.
///
/// # Errors
/// [`RvError::BadOption`] for no corners, non-finite corners, zero options, or a source that
/// cannot rewind; source errors are passed on.
pub fn conservative_from_region(
    source: &mut (dyn TriangleSource + Send),
    cell_corners: &[glam::Vec3],
    options: &RegionOptions,
) -> Result<RegionResult, RvError> {
    check_options(cell_corners, options)?;
    let corners: Vec<DVec3> = cell_corners.iter().map(|c| c.as_dvec3()).collect();
    let centre = corners.iter().copied().sum::<DVec3>() / corners.len() as f64;
    let bound = source.id_bound();
    let mut stats = RegionStats::default();

    // Coordinates are taken relative to the cell's centre, so rounding scales with distances
    // from the cell, and margins are relative to those distances.
    let corners: Vec<DVec3> = corners.iter().map(|c| *c - centre).collect();
    let cell_extent = corners
        .iter()
        .map(|c| c.abs().max_element())
        .fold(0.0f64, f64::max);
    let to_local = |t: &SourceTriangle| to_f64(t).map(|v| v.map(|p| p - centre));

    // Pass 1: the largest occluders.
    let mut batch = Vec::with_capacity(options.batch_triangles);
    let mut heap: BinaryHeap<Occluder> = BinaryHeap::new();
    let offer = |poly: &[DVec3], heap: &mut BinaryHeap<Occluder>| {
        let score = solid_angle(poly, DVec3::ZERO);
        if score.is_nan() || score <= 0.0 {
            return;
        }
        if heap.len() == options.max_occluders
            && heap.peek().is_some_and(|smallest| smallest.score >= score)
        {
            return;
        }
        let reach = poly
            .iter()
            .map(|p| p.abs().max_element())
            .fold(cell_extent, f64::max);
        if let Some(planes) = umbra(poly, &corners, RELATIVE_MARGIN * reach) {
            let cap = DirectionCap::of(poly);
            heap.push(Occluder {
                score,
                poly: poly.to_vec(),
                planes,
                cap,
            });
            if heap.len() > options.max_occluders {
                heap.pop();
            }
        }
    };
    let mut previous: Option<[DVec3; 3]> = None;
    loop {
        batch.clear();
        if source.next_batch(options.batch_triangles, &mut batch)? == 0 {
            break;
        }
        for t in &batch {
            stats.triangles_streamed += 1;
            let Some(v) = to_local(t) else {
                previous = None;
                continue;
            };
            offer(&v, &mut heap);
            if let Some(p) = previous {
                if let Some(q) = quad_of(&p, &v, 1e-9) {
                    offer(&q, &mut heap);
                }
            }
            previous = Some(v);
        }
    }
    let mut occluders = heap.into_vec();
    occluders.sort_by(|a, b| b.score.total_cmp(&a.score));
    stats.occluders = occluders.len();

    // Pass 2: every triangle against the occluders, largest first.
    if !source.rewind()? {
        return Err(RvError::BadOption("the source stopped rewinding".into()));
    }
    let mut visible = TriangleSet::with_capacity(bound as usize);
    // What single occluders leave visible, with its corners for the fusion pass.
    let fusion = options.fusion_splits > 0;
    let (mut candidate_ids, mut candidates): (Vec<u32>, Vec<[DVec3; 3]>) = (Vec::new(), Vec::new());
    loop {
        batch.clear();
        if source.next_batch(options.batch_triangles, &mut batch)? == 0 {
            break;
        }
        let verdicts = single_occluder_verdicts(&batch, &occluders, centre, cell_extent);
        for (id, hidden) in verdicts {
            if id >= bound {
                return Err(RvError::IdOutOfRange { id, bound });
            }
            match hidden {
                None => stats.invalid += 1,
                Some((true, _)) => stats.hidden += 1,
                Some((false, v)) => {
                    visible.insert(id as usize);
                    if fusion {
                        candidate_ids.push(id);
                        candidates.push(v);
                    }
                }
            }
        }
    }
    if fusion && !candidates.is_empty() {
        fuse(
            &occluders,
            &candidate_ids,
            &candidates,
            &corners,
            options,
            &mut visible,
            &mut stats,
        );
    }
    Ok(RegionResult { visible, stats })
}

/// Pass 2's verdicts on a batch (`None` for a triangle with non-finite corners): each
/// triangle against the occluders, largest first, until one hides it.
fn single_occluder_verdicts(
    batch: &[SourceTriangle],
    occluders: &[Occluder],
    centre: DVec3,
    cell_extent: f64,
) -> Vec<(u32, Option<Verdict>)> {
    batch
        .par_iter()
        .map(|t| {
            let hidden = to_f64(t).map(|v| {
                let v = v.map(|p| p - centre);
                let reach = v
                    .iter()
                    .map(|p| p.abs().max_element())
                    .fold(cell_extent, f64::max);
                let margin = RELATIVE_MARGIN * reach;
                let hidden = occluders
                    .iter()
                    .any(|o| o.cap.may_hold(v[0]) && hidden_by(&v, o, margin));
                (hidden, v)
            });
            (t.id, hidden)
        })
        .collect()
}

/// Refuses a cell without finite corners and options out of range.
fn check_options(cell_corners: &[glam::Vec3], options: &RegionOptions) -> Result<(), RvError> {
    if cell_corners.is_empty() || cell_corners.iter().any(|c| !c.is_finite()) {
        return Err(RvError::BadOption(
            "the view cell needs finite corners".into(),
        ));
    }
    options.validate()
}

impl RegionOptions {
    /// Refuses options out of range: no occluders or more than [`MAX_OCCLUDERS`], empty
    /// batches, more than [`MAX_FUSION_SPLITS`] levels, a resolution outside
    /// `1..=`[`MAX_FUSION_RESOLUTION`] with fusion on.
    ///
    /// # Errors
    /// [`RvError::BadOption`] naming the option.
    pub fn validate(&self) -> Result<(), RvError> {
        if !(1..=MAX_OCCLUDERS).contains(&self.max_occluders) {
            return Err(RvError::BadOption(format!(
                "max_occluders {} is not in 1..={MAX_OCCLUDERS}",
                self.max_occluders
            )));
        }
        if self.batch_triangles == 0 {
            return Err(RvError::BadOption(
                "batch_triangles must be at least 1".into(),
            ));
        }
        if self.fusion_splits > MAX_FUSION_SPLITS {
            return Err(RvError::BadOption(format!(
                "fusion_splits {} is more than {MAX_FUSION_SPLITS} (2^splits boxes per cell)",
                self.fusion_splits
            )));
        }
        if self.fusion_splits > 0 && !(1..=MAX_FUSION_RESOLUTION).contains(&self.fusion_resolution)
        {
            return Err(RvError::BadOption(format!(
                "fusion_resolution {} is not in 1..={MAX_FUSION_RESOLUTION}",
                self.fusion_resolution
            )));
        }
        Ok(())
    }
}

/// The fusion pass (`region_fusion.rs`) over what single occluders left visible: removes what
/// the occluders hide together from `visible` and counts it in `stats`.
fn fuse(
    occluders: &[Occluder],
    ids: &[u32],
    candidates: &[[DVec3; 3]],
    corners: &[DVec3],
    options: &RegionOptions,
    visible: &mut TriangleSet,
    stats: &mut RegionStats,
) {
    let fusers: Vec<FusionOccluder> = occluders
        .iter()
        .filter_map(|o| FusionOccluder::new(&o.poly))
        .collect();
    let fused = fused_hidden(
        &fusers,
        candidates,
        CellShape::of(corners),
        FusionOptions {
            splits: options.fusion_splits,
            resolution: options.fusion_resolution,
        },
    );
    for (id, hidden) in ids.iter().zip(&fused.hidden) {
        if *hidden {
            visible.set(*id as usize, false);
            stats.hidden += 1;
            stats.fused_hidden += 1;
        }
    }
    stats.fusion_boxes = fused.boxes;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rv::source::SceneSource;
    use glam::Vec3;
    use sightline_core::scene::SceneBuilder;

    fn cell(min: Vec3, max: Vec3) -> Vec<Vec3> {
        (0..8)
            .map(|k| {
                Vec3::new(
                    if k & 1 == 0 { min.x } else { max.x },
                    if k & 2 == 0 { min.y } else { max.y },
                    if k & 4 == 0 { min.z } else { max.z },
                )
            })
            .collect()
    }

    #[test]
    fn empty_scene_sees_nothing() {
        let scene = sightline_core::Scene::default();
        let r = conservative_from_region(
            &mut SceneSource::new(&scene),
            &cell(Vec3::ZERO, Vec3::ONE),
            &RegionOptions::default(),
        )
        .expect("runs");
        assert_eq!(r.visible.count_ones(..), 0);
    }

    #[test]
    fn bad_cell_and_options_are_errors() {
        let scene = sightline_core::Scene::default();
        let mut src = SceneSource::new(&scene);
        assert!(conservative_from_region(&mut src, &[], &RegionOptions::default()).is_err());
        let nan = [Vec3::NAN; 8];
        assert!(conservative_from_region(&mut src, &nan, &RegionOptions::default()).is_err());
        let zero = RegionOptions {
            max_occluders: 0,
            ..RegionOptions::default()
        };
        assert!(conservative_from_region(&mut src, &cell(Vec3::ZERO, Vec3::ONE), &zero).is_err());
    }

    /// A wall at x = 5 spanning `-half_width..half_width` in y and -10..10 in z (two
    /// triangles forming a quad, ids 0 and 1), with a small box behind it (ids 2..14).
    fn wall_and_box(half_width: f32) -> SceneBuilder {
        let mut b = SceneBuilder::new("wall");
        let w = [
            b.add_vertex(Vec3::new(5.0, -half_width, -10.0)),
            b.add_vertex(Vec3::new(5.0, half_width, -10.0)),
            b.add_vertex(Vec3::new(5.0, half_width, 10.0)),
            b.add_vertex(Vec3::new(5.0, -half_width, 10.0)),
        ];
        b.add_triangle([w[0], w[1], w[2]]);
        b.add_triangle([w[0], w[2], w[3]]);
        b.add_box(Vec3::new(8.0, -0.5, -0.5), Vec3::new(9.0, 0.5, 0.5));
        b
    }

    #[test]
    fn big_wall_hides_a_box_behind_it_but_not_one_beside_it() {
        // A 20 x 20 wall, the box behind it and a small box far to the side, seen past the
        // wall's edge.
        let mut b = wall_and_box(10.0);
        b.add_box(Vec3::new(8.0, 30.0, -0.5), Vec3::new(9.0, 31.0, 0.5));
        let scene = b.finish();
        let r = conservative_from_region(
            &mut SceneSource::new(&scene),
            &cell(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0)),
            &RegionOptions::default(),
        )
        .expect("runs");
        // The wall is visible; the hidden box's 12 triangles are not; the side box's front
        // faces are (the set keeps all 12 of it: only the wall occludes).
        assert!(r.visible.contains(0) && r.visible.contains(1));
        assert!((2..14).all(|t| !r.visible.contains(t)));
        assert!((14..26).all(|t| r.visible.contains(t)));
        assert_eq!(r.stats.hidden, 12);
    }

    #[test]
    fn the_direction_cap_holds_every_point_behind_its_polygon() {
        let polygons: [&[DVec3]; 3] = [
            &[
                DVec3::new(5.0, -3.0, -2.0),
                DVec3::new(5.0, 4.0, -2.0),
                DVec3::new(6.0, 4.0, 3.0),
            ],
            // Wide and near: about 80 degrees across.
            &[
                DVec3::new(1.0, -0.8, -0.8),
                DVec3::new(1.0, 0.8, -0.8),
                DVec3::new(1.0, 0.8, 0.8),
                DVec3::new(1.0, -0.8, 0.8),
            ],
            // Around the origin's side: no useful cap, every direction may hold.
            &[
                DVec3::new(1.0, -50.0, -50.0),
                DVec3::new(1.0, 50.0, -50.0),
                DVec3::new(1.0, 0.0, 50.0),
            ],
        ];
        let mut rng = sightline_core::random::SplitMix64::new(7);
        for poly in polygons {
            let cap = DirectionCap::of(poly);
            for _ in 0..2000 {
                // A point of the polygon (a convex combination of its corners) pushed away from
                // the origin: inside the shadow of the polygon from there.
                let w: Vec<f64> = poly
                    .iter()
                    .map(|_| f64::from(rng.next_f32()) + 1e-3)
                    .collect();
                let sum: f64 = w.iter().sum();
                let on = poly
                    .iter()
                    .zip(&w)
                    .map(|(p, w)| *p * (w / sum))
                    .sum::<DVec3>();
                let behind = on * (1.0 + 100.0 * f64::from(rng.next_f32()));
                assert!(cap.may_hold(behind), "{poly:?}: {behind}");
            }
            // A direction well outside is rejected by the caps that bound something.
            if cap.cos_radius > 0.0 {
                assert!(!cap.may_hold(-poly[0]));
            }
        }
    }

    #[test]
    fn a_wall_split_in_two_triangles_hides_via_its_quad() {
        // Without merging the two triangles into a quad, a box behind the diagonal is hidden by
        // neither triangle alone.
        let scene = wall_and_box(10.0).finish();
        let r = conservative_from_region(
            &mut SceneSource::new(&scene),
            &cell(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0)),
            &RegionOptions {
                max_occluders: 1,
                ..RegionOptions::default()
            },
        )
        .expect("runs");
        assert_eq!(r.stats.occluders, 1);
        assert_eq!(r.stats.hidden, 12);
    }

    #[test]
    fn a_cell_reaching_past_the_wall_edge_sees_behind_it() {
        let scene = wall_and_box(2.0).finish();
        // From y = 3..4 the box is seen past the wall's edge (y = 2).
        let r = conservative_from_region(
            &mut SceneSource::new(&scene),
            &cell(Vec3::new(-1.0, 3.0, -1.0), Vec3::new(1.0, 4.0, 1.0)),
            &RegionOptions::default(),
        )
        .expect("runs");
        assert!(r.visible.count_ones(..) >= 4);
        assert!(r.stats.hidden < 12);
    }
}
