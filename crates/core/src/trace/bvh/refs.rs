//! What the binary build of `build.rs` sorts and sweeps, shared by its object splits and the
//! spatial splits of `spatial.rs`: references to triangles (or to their parts) with their
//! boxes, the bins the SAH sweeps, a node's content, and the SAH cost of a split.
//!
//! Based on: Wald. On fast construction of SAH-based bounding volume hierarchies. 2007
//! (bins that keep bounds and counts; the SAH over them).

use glam::Vec3A;
use rayon::prelude::*;

use crate::geometry::Aabb;

/// SAH cost of visiting an inner node (testing its two child boxes), relative to one triangle
/// test. Tuned on the 600k-triangle random-box bench scene: 1.0 gives 1-2 triangles per leaf
/// and 96 bytes per triangle; 2.0 gives 68 bytes per triangle and ~15% more incoherent
/// throughput at ~10% less coherent throughput (single thread, noisy shared machine).
const TRAVERSAL_COST: f32 = 3.0;
/// SAH cost of one watertight triangle test. Leaves and split sides are costed by the packet
/// lanes their triangles take ([`packet_lanes`]), not by their triangles: five triangles cost
/// two packets, as many as eight. Against counting triangles this took 57-61 bytes per
/// triangle instead of 61-68 on the shared scenes and 1.03 packets per incoherent ray instead
/// of 1.24 on the dragon, at the same speed within the noise (2026-12-05).
pub(super) const INTERSECT_COST: f32 = 1.0;
/// Bins per axis, for object splits (Wald 2007 finds 16 close to a full sweep in quality) and
/// spatial splits alike.
pub(super) const BINS: usize = 16;
/// Nodes with at least this many triangles bin them in parallel.
pub(super) const PARALLEL_BIN: usize = 1 << 16;
/// An `ids` slot no leaf covers.
pub(super) const UNUSED: u32 = u32::MAX;

/// The corners of a triangle by id: what a spatial split clips.
pub(super) type Corners<'a> = &'a (dyn Fn(u32) -> [Vec3A; 3] + Sync);

/// Bounds, centroid bounds and count of a set of references: a node's content.
#[derive(Clone, Copy, Debug)]
pub(super) struct Content {
    pub(super) bounds: Aabb,
    pub(super) centroids: Aabb,
    pub(super) count: usize,
}

/// One reference to a triangle, or to the part of it inside a box after spatial splits: that
/// box and the triangle's id. The build sorts these, not ids, so it reads boxes in order.
#[derive(Clone, Copy, Debug)]
pub(super) struct PrimRef {
    pub(super) min: Vec3A,
    pub(super) max: Vec3A,
    pub(super) id: u32,
}

impl PrimRef {
    /// The filler of spare room.
    pub(super) const UNUSED: PrimRef = PrimRef {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
        id: UNUSED,
    };

    pub(super) fn new(b: &Aabb, id: u32) -> Self {
        Self {
            min: b.min.into(),
            max: b.max.into(),
            id,
        }
    }

    /// The centre of the box: the same `(min + max) * 0.5` as `Aabb::center`, lane by lane.
    #[inline(always)]
    pub(super) fn centroid(&self) -> Vec3A {
        (self.min + self.max) * 0.5
    }
}

/// Bounds and count of the triangles in one bin: what the SAH sweep needs. The children's
/// centroid bounds are gathered by the partition instead, once, rather than per axis here.
/// SIMD corners (`Vec3A`), so a union is two instructions.
#[derive(Clone, Copy, Debug)]
pub(super) struct Bin {
    pub(super) min: Vec3A,
    pub(super) max: Vec3A,
    pub(super) count: usize,
}

impl Bin {
    pub(super) const EMPTY: Bin = Bin {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
        count: 0,
    };

    #[inline(always)]
    pub(super) fn add(&mut self, min: Vec3A, max: Vec3A) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
        self.count += 1;
    }

    pub(super) fn merge(&self, o: &Bin) -> Bin {
        Bin {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
            count: self.count + o.count,
        }
    }

    pub(super) fn bounds(&self) -> Aabb {
        if self.count == 0 {
            Aabb::EMPTY
        } else {
            Aabb::new(self.min.into(), self.max.into())
        }
    }
}

/// `bin_chunk` over `refs`, in parallel chunks merged bin by bin where there are many. Box
/// unions and counts are exact, so the reduction is deterministic.
pub(super) fn bin_in_parallel<B>(
    refs: &[PrimRef],
    bin_chunk: impl Fn(&[PrimRef]) -> B + Send + Sync,
) -> B
where
    B: Merge + Send,
{
    if refs.len() < PARALLEL_BIN {
        return bin_chunk(refs);
    }
    refs.par_chunks(PARALLEL_BIN / 4)
        .map(bin_chunk)
        .reduce_with(|a, b| a.merge(&b))
        .expect("at least one chunk")
}

/// The axis along which `extent` is largest (the first of equals).
pub(super) fn longest_axis(extent: glam::Vec3) -> usize {
    if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    }
}

/// Bins that add up bin by bin.
pub(super) trait Merge {
    fn merge(&self, other: &Self) -> Self;
}

/// The SAH cost of a split into children with these boxes and reference counts, relative to
/// one triangle test, for a parent of surface area `parent_area`.
pub(super) fn split_cost(
    left: &Aabb,
    left_count: usize,
    right: &Aabb,
    right_count: usize,
    parent_area: f32,
) -> f32 {
    if parent_area > 0.0 {
        let weighted = left.surface_area() * packet_lanes(left_count)
            + right.surface_area() * packet_lanes(right_count);
        TRAVERSAL_COST + INTERSECT_COST * weighted / parent_area
    } else {
        TRAVERSAL_COST + INTERSECT_COST * (left_count.max(right_count)) as f32
    }
}

/// The lanes `count` triangles take in four-wide packets: what testing them costs, since a
/// packet is tested whole (Embree's `sahBlockSize` of 4).
pub(super) fn packet_lanes(count: usize) -> f32 {
    (count.div_ceil(4) * 4) as f32
}

/// Bounds, centroid bounds and count of `refs` (parallel for big sets).
pub(super) fn summarize(refs: &[PrimRef]) -> Content {
    bin_in_parallel(refs, |chunk| {
        let (mut b, mut c) = (Bin::EMPTY, Bin::EMPTY);
        for r in chunk {
            b.add(r.min, r.max);
            let centre = r.centroid();
            c.add(centre, centre);
        }
        Content {
            bounds: b.bounds(),
            centroids: c.bounds(),
            count: b.count,
        }
    })
}

impl Merge for Content {
    fn merge(&self, o: &Self) -> Self {
        Content {
            bounds: self.bounds.union(&o.bounds),
            centroids: self.centroids.union(&o.centroids),
            count: self.count + o.count,
        }
    }
}

/// How a node's references are shared between its children: the left child's room (its
/// references, `left.count`, come first in it), and both children's contents.
pub(super) struct Division {
    pub(super) left_room: usize,
    pub(super) left: Content,
    pub(super) right: Content,
}

/// The left child's room out of `room` when the children hold `left` and `right` references:
/// its references and its share of the spare room, in proportion to its references.
pub(super) fn share_room(room: usize, left: usize, right: usize) -> usize {
    let spare = (room - left - right) as u64;
    left + (spare * left as u64 / (left + right) as u64) as usize
}

/// Equal bins over a box, per axis: the centroids' box for an object split, the node's box for
/// a spatial split.
pub(super) struct Grid {
    min: Vec3A,
    extent: Vec3A,
    /// Bins per unit length; 0 on an axis the box is flat on, which is not split.
    scale: Vec3A,
    /// Bins per axis, at most [`BINS`].
    pub(super) count: usize,
}

impl Grid {
    /// [`BINS`] bins per axis over `bounds`.
    pub(super) fn new(bounds: &Aabb) -> Self {
        Self::with_bins(bounds, BINS)
    }

    /// `count` bins per axis over `bounds` (`1 < count <= BINS`).
    pub(super) fn with_bins(bounds: &Aabb, count: usize) -> Self {
        debug_assert!(count > 1 && count <= BINS);
        let extent: Vec3A = bounds.extent().into();
        let scale = |x: f32| {
            let s = count as f32 / x;
            if x > 0.0 && s.is_finite() {
                s
            } else {
                0.0
            }
        };
        Self {
            min: bounds.min.into(),
            extent,
            scale: Vec3A::new(scale(extent.x), scale(extent.y), scale(extent.z)),
            count,
        }
    }

    /// Whether `axis` has bins to split between.
    pub(super) fn splits(&self, axis: usize) -> bool {
        self.scale[axis] > 0.0
    }

    /// The bin of `p` on each axis. `as u32` saturates (NaN and below the box give 0), so the
    /// bins are always in range; [`Grid::bin`] gives the same lane by lane.
    #[inline(always)]
    pub(super) fn bins(&self, p: Vec3A) -> glam::UVec3 {
        ((p - self.min) * self.scale)
            .as_uvec3()
            .min(glam::UVec3::splat(self.count as u32 - 1))
    }

    /// The bin of coordinate `x` on `axis`.
    #[inline(always)]
    pub(super) fn bin(&self, x: f32, axis: usize) -> usize {
        (((x - self.min[axis]) * self.scale[axis]) as u32).min(self.count as u32 - 1) as usize
    }

    /// The plane between bins `i - 1` and `i` on `axis`.
    pub(super) fn plane(&self, axis: usize, i: usize) -> f32 {
        self.min[axis] + self.extent[axis] * (i as f32 / self.count as f32)
    }
}

/// The cheapest split plane over the bins of every axis a grid splits.
pub(super) struct Split {
    pub(super) axis: usize,
    /// The plane between bins `bin - 1` and `bin`.
    pub(super) bin: usize,
    pub(super) cost: f32,
    /// The left side: the union of bins `< bin` of `entering` (its count, the references
    /// there).
    pub(super) left: Bin,
    /// The right side: the union of bins `>= bin` of `leaving`.
    pub(super) right: Bin,
}

/// The SAH sweep: per axis, every plane between bins, the left side counted by the bins where
/// references enter and the right side by those where they leave (the same bins for an object
/// split; a spatial split's references may span several).
pub(super) fn best_split(
    entering: &[[Bin; BINS]; 3],
    leaving: &[[Bin; BINS]; 3],
    grid: &Grid,
    parent_area: f32,
) -> Option<Split> {
    let mut best: Option<Split> = None;
    for axis in (0..3).filter(|&a| grid.splits(a)) {
        // Sweep from the right, keeping the accumulated right side for every plane.
        let mut right_acc = [Bin::EMPTY; BINS];
        let mut acc = Bin::EMPTY;
        for i in (1..grid.count).rev() {
            acc = acc.merge(&leaving[axis][i]);
            right_acc[i] = acc;
        }
        let mut left = Bin::EMPTY;
        for plane in 1..grid.count {
            left = left.merge(&entering[axis][plane - 1]);
            let right = right_acc[plane];
            if left.count == 0 || right.count == 0 {
                continue;
            }
            let cost = split_cost(
                &left.bounds(),
                left.count,
                &right.bounds(),
                right.count,
                parent_area,
            );
            if cost.is_finite() && best.as_ref().is_none_or(|b| cost < b.cost) {
                best = Some(Split {
                    axis,
                    bin: plane,
                    cost,
                    left,
                    right,
                });
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A grid of fewer bins than [`BINS`] keeps every point of its box (the far corner, points
    /// beyond it and NaN included) in its own bins, and its planes split the box evenly: a
    /// bin past its count would fall outside the sweep and lose its references.
    #[test]
    fn grids_of_fewer_bins_keep_points_in_their_bins() {
        let bounds = Aabb::new(Vec3::new(-1.0, 2.0, 0.0), Vec3::new(3.0, 6.0, 8.0));
        for count in [2, 8, BINS] {
            let grid = Grid::with_bins(&bounds, count);
            assert_eq!(grid.count, count);
            for p in [
                bounds.min,
                bounds.max,
                bounds.max * 2.0,
                Vec3::NAN,
                bounds.center(),
            ] {
                let at = grid.bins(p.into());
                for axis in 0..3 {
                    assert!((at[axis] as usize) < count, "{count} bins: {p} in {at}");
                    assert_eq!(grid.bin(p[axis], axis), at[axis] as usize);
                }
            }
            assert_eq!(
                grid.bins(bounds.max.into()),
                glam::UVec3::splat(count as u32 - 1)
            );
            assert_eq!(grid.plane(0, count / 2), 1.0);
            assert_eq!(grid.plane(2, count), 8.0);
        }
    }
}
