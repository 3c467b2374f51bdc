//! Incremental rebake: after a scene edit, which cells' sets can change, and the unchanged
//! cells' sets in the new scene's triangle ids.
//!
//! Triangles are matched between the old and the new scene by exact geometry (the bit
//! patterns of their three corners, in any order: triangles are double-sided), so unchanged
//! triangles keep their sets under new ids; *removed* are old triangles without a match,
//! *added* new ones without a match (a moved object is both). A cell is rebaked when
//!
//! (a) its old set contains a removed triangle (what was behind it may now show), or
//! (b) added geometry may be visible from it. The added triangles are grouped into connected
//!     pieces (shared corners), each bounded by a box B. A point q of B visible from a point p
//!     of the cell in the new scene lies on a ray from p that, in the old scene, first hit some
//!     triangle T beyond q — T was visible from p, so it is in the old set, and q lies in the
//!     convex hull of the cell's corners and T's corners. So the cell is rebaked when B meets
//!     the cell, or the hull of the cell and some T of its old set ([`hull_intersects_box`],
//!     exact GJK, after a cheap box-overlap rejection).
//!
//! (c) a probe sees B from the cell in the old scene. Rule (b) has no T for a ray that left
//!     the old scene without hitting anything (a tower rising above the roofs, seen only
//!     against the sky), nor for a triangle behind B that sampling left out of the old set.
//!     [`plan_with_probe`] casts rays from random points on the cell's surface to random points
//!     on B's surface in the old scene; when one reaches its target unblocked (it hits nothing
//!     before it), that point of B was visible from the cell, and the cell is rebaked.
//!
//! Limits, stated honestly: (a) and (b) are exact given the old sets, but the old sets are
//! sampled, and (c) is a sampled visibility test: what both samplings miss (B seen through a
//! gap no probe ray finds, with no triangle of the old set behind it) is missed, as a sampled
//! PVS misses a few triangles (the pixel-error evaluation measures how many).

use std::collections::{BTreeMap, HashMap};

use glam::Vec3;
use rayon::prelude::*;
use sightline_core::geometry::Aabb;
use sightline_core::random::SplitMix64;
use sightline_core::trace::RayCaster;
use sightline_core::{Hit, Ray, Scene, TriangleSet};

use crate::bake::BakedCell;
use crate::hull_box::hull_intersects_box;
use crate::pvs_file::{EncodedSet, PvsFile};
use crate::viewcell::{CellSurface, ViewCell};

/// Most boxes the added triangles are grouped into (more connected pieces are merged).
pub const MAX_ADDED_BOXES: usize = 64;

/// How the triangles of two versions of a scene correspond.
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleMatching {
    /// New id of each old triangle (`None`: removed).
    pub old_to_new: Vec<Option<u32>>,
    /// Old ids without a match.
    pub removed: Vec<u32>,
    /// New ids without a match.
    pub added: Vec<u32>,
}

type TriangleKey = [[u32; 3]; 3];

fn key(scene: &Scene, t: u32) -> TriangleKey {
    let mut k = scene.triangle(t).map(|p| p.to_array().map(f32::to_bits));
    k.sort_unstable();
    k
}

impl TriangleMatching {
    /// Matches triangles by exact corner bit patterns; duplicates are matched in id order.
    pub fn new(old: &Scene, new: &Scene) -> Self {
        let mut by_key: HashMap<TriangleKey, Vec<u32>> = HashMap::new();
        for t in (0..old.triangle_count() as u32).rev() {
            by_key.entry(key(old, t)).or_default().push(t);
        }
        let mut old_to_new = vec![None; old.triangle_count()];
        let mut added = Vec::new();
        for t in 0..new.triangle_count() as u32 {
            match by_key.get_mut(&key(new, t)).and_then(Vec::pop) {
                Some(o) => old_to_new[o as usize] = Some(t),
                None => added.push(t),
            }
        }
        let removed = (0..old.triangle_count() as u32)
            .filter(|&o| old_to_new[o as usize].is_none())
            .collect();
        Self {
            old_to_new,
            removed,
            added,
        }
    }

    /// `set` (old ids) in new ids, dropping removed triangles.
    pub fn remap(&self, set: &TriangleSet, new_triangles: usize) -> TriangleSet {
        let mut out = TriangleSet::with_capacity(new_triangles);
        for o in set.ones() {
            if let Some(Some(n)) = self.old_to_new.get(o) {
                out.insert(*n as usize);
            }
        }
        out
    }
}

/// Boxes around the connected pieces of `added` (triangles sharing a corner position), at
/// most `max_boxes` (pieces are merged in order along x beyond that), each grown by `margin`.
pub fn added_boxes(scene: &Scene, added: &[u32], max_boxes: usize, margin: f32) -> Vec<Aabb> {
    // Union-find over the added triangles, joined through shared corner positions.
    let mut parent: Vec<usize> = (0..added.len()).collect();
    fn find(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut by_corner: HashMap<[u32; 3], usize> = HashMap::new();
    for (k, &t) in added.iter().enumerate() {
        for p in scene.triangle(t) {
            let c = p.to_array().map(f32::to_bits);
            let other = *by_corner.entry(c).or_insert(k);
            let (a, b) = (find(&mut parent, k), find(&mut parent, other));
            parent[a] = b;
        }
    }
    let mut boxes: HashMap<usize, Aabb> = HashMap::new();
    for (k, &t) in added.iter().enumerate() {
        let root = find(&mut parent, k);
        let b = boxes.entry(root).or_insert(Aabb::EMPTY);
        for p in scene.triangle(t) {
            b.grow(p);
        }
    }
    let mut boxes: Vec<Aabb> = boxes.into_values().collect();
    boxes.sort_by(|a, b| (a.min.x + a.max.x).total_cmp(&(b.min.x + b.max.x)));
    let max_boxes = max_boxes.max(1);
    if boxes.len() > max_boxes {
        let per = boxes.len().div_ceil(max_boxes);
        boxes = boxes
            .chunks(per)
            .map(|c| c.iter().fold(Aabb::EMPTY, |u, b| u.union(b)))
            .collect();
    }
    for b in &mut boxes {
        b.min -= Vec3::splat(margin);
        b.max += Vec3::splat(margin);
    }
    boxes
}

/// Why a cell is rebaked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RebakeReason {
    /// Its old set holds a removed triangle.
    Removed,
    /// Added geometry meets the cell itself.
    AddedInCell,
    /// Added geometry lies between the cell and a triangle of its old set.
    AddedInView,
    /// A probe ray from the cell reached a point of added geometry unblocked in the old scene.
    AddedSeenByProbe,
}

/// True when one of `rays` rays from random points on the surface of `cell` to random points
/// on the surface of `b` reaches its target without hitting anything of the old scene before
/// it. Surfaces suffice: if a point inside the cell sees a point of `b`, the segment between
/// them leaves the cell and enters `b` through their surfaces, and that part is unblocked too.
/// Rays aim at their target with `t = 1`.
fn probe_sees_box(
    cell: &ViewCell,
    b: &Aabb,
    caster: &dyn RayCaster,
    rays: usize,
    seed: u64,
) -> bool {
    let mut rng = SplitMix64::new(seed);
    let mut unit = || [rng.next_f32(), rng.next_f32(), rng.next_f32()];
    let from = CellSurface::new(cell);
    // A box flat in two axes has no area; then sample its volume (a segment) instead.
    let to = ViewCell::aabb(b.min, b.max)
        .ok()
        .filter(|v| v.area() > 0.0)
        .map(|v| CellSurface::new(&v));
    let size = b.max - b.min;
    let batch: Vec<Ray> = (0..rays)
        .map(|_| {
            let origin = if cell.area() > 0.0 {
                from.sample(unit()).0
            } else {
                cell.interior_point(unit())
            };
            let target = match &to {
                Some(surface) => surface.sample(unit()).0,
                None => b.min + size * Vec3::from_array(unit()),
            };
            Ray::new(origin, target - origin)
        })
        .filter(|r| r.dir.length_squared() > 0.0)
        .collect();
    let mut hits = vec![Hit::MISS; batch.len()];
    caster.cast(&batch, &mut hits);
    // A hit at t within a hair of 1 is the target's own surface in the old scene (e.g. the
    // ground a new box stands on), not something in front of it.
    hits.iter().any(|h| !h.is_hit() || h.t >= 1.0 - 1e-4)
}

/// Which cells of an old bake to rebake after an edit.
#[derive(Clone, Debug)]
pub struct RebakePlan {
    /// The triangle correspondence.
    pub matching: TriangleMatching,
    /// Boxes around the added geometry.
    pub boxes: Vec<Aabb>,
    /// Per cell of the old file: why it must be rebaked (`None`: its remapped set stands).
    pub reasons: Vec<Option<RebakeReason>>,
    /// Per cell: true when it must be rebaked.
    pub rebake: Vec<bool>,
}

/// Plans the rebake of `old_file` (baked on `old`) for the edited scene `new` from the old
/// sets alone (rules (a) and (b); no probe).
pub fn plan(old: &Scene, new: &Scene, old_file: &PvsFile) -> RebakePlan {
    plan_impl(old, new, old_file, None)
}

/// [`plan`] plus rule (c): `probe_rays` rays per cell and added box, cast with `old_caster` (a
/// ray caster over `old`), look for a point of the box visible from the cell.
pub fn plan_with_probe(
    old: &Scene,
    new: &Scene,
    old_file: &PvsFile,
    old_caster: &dyn RayCaster,
    probe_rays: usize,
) -> RebakePlan {
    plan_impl(old, new, old_file, Some((old_caster, probe_rays)))
}

fn plan_impl(
    old: &Scene,
    new: &Scene,
    old_file: &PvsFile,
    probe: Option<(&dyn RayCaster, usize)>,
) -> RebakePlan {
    let matching = TriangleMatching::new(old, new);
    let margin = 1e-5 * new.bounds().union(&old.bounds()).diagonal();
    let boxes = added_boxes(new, &matching.added, MAX_ADDED_BOXES, margin);
    let mut removed = TriangleSet::with_capacity(old.triangle_count());
    for &o in &matching.removed {
        removed.insert(o as usize);
    }
    let reasons: Vec<Option<RebakeReason>> = old_file
        .cells
        .par_iter()
        .enumerate()
        .map(|(index, c)| {
            if !c.visible.is_disjoint(&removed) {
                return Some(RebakeReason::Removed);
            }
            if boxes.is_empty() {
                return None;
            }
            let corners = c.cell.distinct_corners();
            let cell_box = Aabb::from_points(corners.iter().copied());
            if boxes.iter().any(|b| hull_intersects_box(&corners, b)) {
                return Some(RebakeReason::AddedInCell);
            }
            // Early out: every hull(cell, T) lies in the hull of the cell and the box around
            // all of the old set's triangles; boxes missing that need no per-triangle test.
            let all =
                c.visible
                    .ones()
                    .flat_map(|t| old.triangle(t as u32))
                    .fold(cell_box, |mut b, p| {
                        b.grow(p);
                        b
                    });
            let outer: Vec<Vec3> = corners.iter().copied().chain(box_corners(&all)).collect();
            let near: Vec<&Aabb> = boxes
                .iter()
                .filter(|b| hull_intersects_box(&outer, b))
                .collect();
            let mut hull = corners.clone();
            for t in c.visible.ones() {
                if near.is_empty() {
                    break;
                }
                let tri = old.triangle(t as u32);
                let mut reach = cell_box;
                tri.iter().for_each(|p| reach.grow(*p));
                hull.truncate(corners.len());
                hull.extend_from_slice(&tri);
                let hit = near
                    .iter()
                    .any(|b| overlaps(&reach, b) && hull_intersects_box(&hull, b));
                if hit {
                    return Some(RebakeReason::AddedInView);
                }
            }
            if let Some((caster, rays)) = probe {
                for (k, b) in boxes.iter().enumerate() {
                    let seed = (index as u64)
                        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
                        .wrapping_add(k as u64);
                    if probe_sees_box(&c.cell, b, caster, rays, seed) {
                        return Some(RebakeReason::AddedSeenByProbe);
                    }
                }
            }
            None
        })
        .collect();
    let rebake = reasons.iter().map(Option::is_some).collect();
    RebakePlan {
        matching,
        boxes,
        reasons,
        rebake,
    }
}

impl RebakePlan {
    /// The cells of `old_file` that need no rebake, their sets remapped to the new scene's
    /// `new_triangles` ids, keyed by cell index; their statistics are the old ones with
    /// `"kept": true` and `"rays": 0` (no ray was cast for them).
    pub fn kept_cells(
        &self,
        old_file: &PvsFile,
        new_triangles: usize,
    ) -> BTreeMap<usize, BakedCell> {
        let mut kept = BTreeMap::new();
        for (i, c) in old_file.cells.iter().enumerate() {
            if self.rebake[i] {
                continue;
            }
            let set = self.matching.remap(&c.visible, new_triangles);
            let mut stats = old_file.metadata["cells"][i].clone();
            if stats.is_object() {
                stats["kept"] = serde_json::json!(true);
                stats["rays"] = serde_json::json!(0);
            }
            kept.insert(
                i,
                BakedCell::new(i, EncodedSet::encode(&set, new_triangles), &stats),
            );
        }
        kept
    }
}

fn box_corners(b: &Aabb) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        )
    })
}

fn overlaps(a: &Aabb, b: &Aabb) -> bool {
    a.min.cmple(b.max).all() && b.min.cmple(a.max).all()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pvs_file::CellPvs;
    use crate::viewcell::ViewCell;
    use sightline_core::scene::SceneBuilder;

    fn scene(extra_box: Option<(Vec3, Vec3)>, moved: f32) -> Scene {
        let mut b = SceneBuilder::new("t");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        b.add_box(
            Vec3::new(10.0 + moved, 0.0, 0.0),
            Vec3::new(11.0 + moved, 1.0, 1.0),
        );
        if let Some((lo, hi)) = extra_box {
            b.add_box(lo, hi);
        }
        b.finish()
    }

    #[test]
    fn a_tower_seen_only_against_the_sky_is_caught_by_the_probe() {
        use sightline_core::trace::Bvh;
        // A wall in front of the cell (x 5..6) and, in `room`, a closed room around it all.
        let build = |tower: Option<f32>, room: bool| {
            let mut b = SceneBuilder::new("sky");
            b.add_box(Vec3::new(5.0, -10.0, 0.0), Vec3::new(6.0, 10.0, 4.0));
            if room {
                b.add_box(Vec3::splat(-40.0), Vec3::splat(40.0));
            }
            if let Some(x) = tower {
                b.add_box(Vec3::new(x, -1.0, 0.0), Vec3::new(x + 1.0, 1.0, 30.0));
            }
            b.finish()
        };
        let cell = ViewCell::aabb(Vec3::new(0.0, -1.0, 1.0), Vec3::new(1.0, 1.0, 2.0)).unwrap();
        // Open scene: a tower behind the wall rising above it, seen against the sky. Closed
        // room: a tower outside the room, which no ray from the cell can reach.
        for (room, tower_x, expected) in [
            (false, 10.0, Some(RebakeReason::AddedSeenByProbe)),
            (true, 50.0, None),
        ] {
            let old = build(None, room);
            let new = build(Some(tower_x), room);
            // The old set: the wall's face towards the cell and the room's walls.
            let mut visible = TriangleSet::with_capacity(old.triangle_count());
            for t in 0..old.triangle_count() {
                if old.triangle(t as u32).iter().all(|p| p.x == 5.0) || t >= 12 {
                    visible.insert(t);
                }
            }
            let mut file = PvsFile::for_scene(&old, serde_json::Value::Null);
            file.cells.push(CellPvs::new(cell, visible));
            // No old triangle lies behind the tower: the old sets alone cannot see it.
            assert_eq!(plan(&old, &new, &file).reasons, vec![None], "room: {room}");
            let bvh = Bvh::build(&old);
            let probed = plan_with_probe(&old, &new, &file, &bvh, 4096);
            assert_eq!(probed.reasons, vec![expected], "room: {room}");
        }
    }

    #[test]
    fn matching_finds_moved_and_added_triangles() {
        let old = scene(None, 0.0);
        let new = scene(Some((Vec3::splat(20.0), Vec3::splat(21.0))), 0.5);
        let m = TriangleMatching::new(&old, &new);
        assert_eq!(m.removed, (12..24).collect::<Vec<u32>>());
        assert_eq!(m.added, (12..36).collect::<Vec<u32>>());
        assert!((0..12).all(|t| m.old_to_new[t] == Some(t as u32)));
        let mut s = TriangleSet::with_capacity(24);
        s.insert(3);
        s.insert(15);
        let r = m.remap(&s, 36);
        assert_eq!(r.ones().collect::<Vec<_>>(), vec![3]);
        let boxes = added_boxes(&new, &m.added, 8, 0.0);
        assert_eq!(boxes.len(), 2);
        assert_eq!(added_boxes(&new, &m.added, 1, 0.0).len(), 1);
    }

    #[test]
    fn only_cells_that_can_see_the_edit_are_rebaked() {
        let old = scene(None, 0.0);
        // A box added at x 8..9: a cell at x -4..-3 looking at box 1 (x 0..1) cannot see it; a
        // cell at x 6..7 looks at box 2 (x 10..11) through it.
        let new = scene(
            Some((Vec3::new(8.0, 0.0, 0.0), Vec3::new(9.0, 1.0, 1.0))),
            0.0,
        );
        let left = ViewCell::aabb(Vec3::new(-4.0, 0.0, 0.0), Vec3::new(-3.0, 1.0, 1.0)).unwrap();
        let right = ViewCell::aabb(Vec3::new(6.0, 0.0, 0.0), Vec3::new(7.0, 1.0, 1.0)).unwrap();
        let inside = ViewCell::aabb(Vec3::new(8.5, 0.0, 0.0), Vec3::new(8.7, 1.0, 1.0)).unwrap();
        let set = |ids: &[usize]| {
            let mut s = TriangleSet::with_capacity(24);
            ids.iter().for_each(|&i| s.insert(i));
            s
        };
        let mut file = PvsFile::for_scene(&old, serde_json::Value::Null);
        // The left cell sees box 1's -x face only; the right cell sees box 2's -x face and
        // box 1's +x face (behind it, away from the new box).
        let minus_x: Vec<usize> = (0..12)
            .filter(|&t| old.triangle(t as u32).iter().all(|p| p.x == 0.0))
            .collect();
        let plus_x_far: Vec<usize> = (12..24)
            .filter(|&t| old.triangle(t as u32).iter().all(|p| p.x == 10.0))
            .collect();
        let plus_x_near: Vec<usize> = (0..12)
            .filter(|&t| old.triangle(t as u32).iter().all(|p| p.x == 1.0))
            .collect();
        assert_eq!(minus_x.len(), 2);
        file.cells.push(CellPvs::new(left, set(&minus_x)));
        file.cells.push(CellPvs::new(
            right,
            set(&[plus_x_far.clone(), plus_x_near.clone()].concat()),
        ));
        file.cells.push(CellPvs::new(inside, set(&plus_x_far)));
        // A cell that sees only box 1's +x face from the right: the new box is behind it.
        file.cells.push(CellPvs::new(right, set(&plus_x_near)));
        let p = plan(&old, &new, &file);
        assert_eq!(
            p.reasons,
            vec![
                None,
                Some(RebakeReason::AddedInView),
                Some(RebakeReason::AddedInCell),
                None
            ]
        );
        // Moving box 2 rebakes the cells that saw it.
        let moved = scene(None, 0.5);
        let p = plan(&old, &moved, &file);
        assert_eq!(p.reasons[0], None);
        assert_eq!(p.reasons[1], Some(RebakeReason::Removed));
        assert_eq!(p.reasons[2], Some(RebakeReason::Removed));
        assert_eq!(p.reasons[3], None);
    }
}
