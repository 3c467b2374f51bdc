//! Spatial splits for the binary tree of `build.rs`: a node may divide its references by a
//! plane, a reference that crosses the plane going to both children as the boxes of its
//! triangle's parts on either side. Large triangles (the walls and floors of a game level, the
//! facades of a city) then stop swelling every box they pass through, and rays visit fewer
//! nodes and test fewer triangles. The split planes are binned as the object splits are: the
//! node's box is cut into equal bins per axis, each reference's triangle clipped to every bin
//! it spans, and the SAH swept over the bins with entry and exit counts.
//!
//! Based on: Stich, Friedrich, Dietrich. Spatial splits in bounding volume hierarchies. HPG
//! 2009 (sections 4.1 and 4.2: spatial bins, references clipped to them, entry and exit
//! counts; a spatial split tried only where the object split's children overlap by more than
//! `alpha` of the root's area).
//! Based on: Popov, Georgiev, Dimov, Slusallek. Object partitioning considered harmful: space
//! subdivision for BVHs. HPG 2009 (the same split, binned).

use glam::Vec3A;

use super::refs::{
    best_split, bin_in_parallel, longest_axis, share_room, summarize, Bin, Content, Corners,
    Division, Grid, Merge, PrimRef, BINS,
};

/// Stich et al.'s `alpha`: a spatial split is tried only where the object split's children
/// overlap by more than this share of the root's surface area. They suggest 1e-5; on the
/// shared scenes and the 1M city 1e-4 gives trees that visit as many nodes and packets per
/// ray, with 4 % less memory on the city and a fifth less build time (1e-3 halves the build
/// time but costs the city 1-2 % more nodes per ray; 2026-12-07).
pub(super) const MIN_OVERLAP: f32 = 1e-4;

/// Nodes of at most this many references take no spatial split. On the shared scenes and the
/// 1M city the trees then visit the same nodes and packets per ray within 1 % either way
/// (the city's the same), and build 5-13 % faster (one thread; 512 built 25 % faster but
/// cost the city 1-2 % more nodes and packets per ray; 2026-12-07).
pub(super) const MIN_REFERENCES: usize = 64;

/// Half-width of the box put around a point where a triangle's edge crosses a split plane,
/// relative to the edge's largest coordinate: the point is computed in floats, a few ulps
/// (2^-23 each) from the true one, and the box must hold the true one.
const CROSSING_SLACK: f32 = 1.0 / (1 << 18) as f32;

/// Per axis and bin: the box of the references' parts in the bin, and how many references
/// start and end there.
#[derive(Clone, Copy)]
struct SpatialBins {
    parts: [[Bin; BINS]; 3],
    entries: [[usize; BINS]; 3],
    exits: [[usize; BINS]; 3],
}

impl Merge for SpatialBins {
    fn merge(&self, o: &Self) -> Self {
        Self {
            parts: std::array::from_fn(|a| {
                std::array::from_fn(|i| self.parts[a][i].merge(&o.parts[a][i]))
            }),
            entries: std::array::from_fn(|a| {
                std::array::from_fn(|i| self.entries[a][i] + o.entries[a][i])
            }),
            exits: std::array::from_fn(|a| {
                std::array::from_fn(|i| self.exits[a][i] + o.exits[a][i])
            }),
        }
    }
}

/// Bins the references' parts on the axes of `axes`.
fn bin_references(refs: &[PrimRef], grid: &Grid, corners: Corners, axes: [bool; 3]) -> SpatialBins {
    let mut bins = SpatialBins {
        parts: [[Bin::EMPTY; BINS]; 3],
        entries: [[0; BINS]; 3],
        exits: [[0; BINS]; 3],
    };
    for r in refs {
        let (first, last) = (grid.bins(r.min), grid.bins(r.max));
        let mut triangle = None;
        for axis in (0..3).filter(|&a| grid.splits(a) && axes[a]) {
            let (first, last) = (first[axis] as usize, last[axis] as usize);
            bins.entries[axis][first] += 1;
            let parts = &mut bins.parts[axis];
            if first == last {
                parts[first].add(r.min, r.max);
                bins.exits[axis][last] += 1;
                continue;
            }
            let tri = *triangle.get_or_insert_with(|| corners(r.id));
            // The part beyond each plane, until none is left: a reference that only touches
            // a plane ends before it.
            let mut rest = *r;
            let mut end = last;
            for (bin, part) in parts.iter_mut().enumerate().take(last).skip(first) {
                let (below, above) = split_reference(&rest, &tri, axis, grid.plane(axis, bin + 1));
                if let Some(b) = below {
                    part.add(b.min, b.max);
                }
                match above {
                    Some(a) => rest = a,
                    None => {
                        end = bin;
                        break;
                    }
                }
            }
            if end == last {
                parts[last].add(rest.min, rest.max);
            }
            bins.exits[axis][end] += 1;
        }
    }
    bins
}

/// Divides the node's references by the best spatial split when its cost is below `beats`
/// and the references it adds fit the node's room; `None` (references untouched) otherwise.
/// Planes are tried across the longest axis of the node's box and across `object_axis`, the
/// axis of the node's best object split, rather than across all three: clipping every
/// reference to the bins of an axis is most of a build's time, and the third axis seldom
/// holds the best plane (one build thread, against all three axes: the 1M-triangle city
/// 2.4 s → 1.4 s, czest3ctf and munich 0.07-0.08 → 0.045 s; nodes and packets per ray within
/// 1 % on the city, up to 5 % more on czest3ctf's packets and fan's and fzk_haus's nodes or
/// packets, fewer on dm4ish's and oa_dm1's; ray speed within 1 %; docs/BENCHMARKS.md,
/// 2026-12-07).
pub(super) fn divide(
    refs: &mut [PrimRef],
    content: &Content,
    corners: Corners,
    beats: f32,
    object_axis: Option<usize>,
) -> Option<Division> {
    let m = content.count;
    let grid = Grid::new(&content.bounds);
    let longest = longest_axis(content.bounds.extent());
    let axes = std::array::from_fn(|a| a == longest || Some(a) == object_axis);
    let bins = bin_in_parallel(&refs[..m], |chunk| {
        bin_references(chunk, &grid, corners, axes)
    });
    // The parts' boxes, counted where references enter them and where they leave.
    let counted = |counts: &[[usize; BINS]; 3]| -> [[Bin; BINS]; 3] {
        std::array::from_fn(|a| {
            std::array::from_fn(|i| Bin {
                count: counts[a][i],
                ..bins.parts[a][i]
            })
        })
    };
    let (entering, leaving) = (counted(&bins.entries), counted(&bins.exits));
    let split = best_split(&entering, &leaving, &grid, content.bounds.surface_area())?;
    if split.cost >= beats || split.left.count + split.right.count > refs.len() {
        return None;
    }
    let (axis, pos) = (split.axis, grid.plane(split.axis, split.bin));
    let mut left = Vec::with_capacity(split.left.count);
    let mut right = Vec::with_capacity(split.right.count);
    for r in &refs[..m] {
        if grid.bin(r.max[axis], axis) < split.bin {
            left.push(*r);
        } else if grid.bin(r.min[axis], axis) >= split.bin {
            right.push(*r);
        } else {
            let (below, above) = split_reference(r, &corners(r.id), axis, pos);
            left.extend(below);
            right.extend(above);
        }
    }
    // Parts that turned out empty can only shrink the counts; a side left empty would
    // make no progress.
    if left.is_empty() || right.is_empty() || left.len() + right.len() > refs.len() {
        return None;
    }
    let left_room = share_room(refs.len(), left.len(), right.len());
    refs[..left.len()].copy_from_slice(&left);
    refs[left_room..left_room + right.len()].copy_from_slice(&right);
    Some(Division {
        left_room,
        left: summarize(&left),
        right: summarize(&right),
    })
}

/// The boxes of the parts of `r`'s triangle (corners `tri`) below and above the plane at
/// `pos` on `axis`, each within `r`'s box; `None` for a side without a part. Each box holds
/// the triangle's points on its side that lie in `r`'s box, so the references of a triangle
/// together cover every point of it that the reference covered.
pub(super) fn split_reference(
    r: &PrimRef,
    tri: &[Vec3A; 3],
    axis: usize,
    pos: f32,
) -> (Option<PrimRef>, Option<PrimRef>) {
    let (mut below, mut above) = (Bin::EMPTY, Bin::EMPTY);
    for k in 0..3 {
        let (a, b) = (tri[k], tri[(k + 1) % 3]);
        let (da, db) = (a[axis], b[axis]);
        if da <= pos {
            below.add(a, a);
        }
        if da >= pos {
            above.add(a, a);
        }
        if (da < pos && pos < db) || (db < pos && pos < da) {
            let t = (pos - da) / (db - da);
            let p = a + (b - a) * t;
            let slack = a.abs().max(b.abs()).max_element() * CROSSING_SLACK + f32::MIN_POSITIVE;
            let (lo, hi) = (p - Vec3A::splat(slack), p + Vec3A::splat(slack));
            below.add(lo, hi);
            above.add(lo, hi);
        }
    }
    let within = |part: Bin, lo: Vec3A, hi: Vec3A| {
        let (min, max) = (part.min.max(lo), part.max.min(hi));
        (part.count > 0 && min.cmple(max).all()).then_some(PrimRef { min, max, id: r.id })
    };
    // The plane bounds the parts on its axis (a select rather than a write to one lane,
    // which goes through memory).
    let on_axis = glam::BVec3A::new(axis == 0, axis == 1, axis == 2);
    let below_max = r
        .max
        .min(Vec3A::select(on_axis, Vec3A::splat(pos), Vec3A::INFINITY));
    let above_min = r.min.max(Vec3A::select(
        on_axis,
        Vec3A::splat(pos),
        Vec3A::NEG_INFINITY,
    ));
    match (
        within(below, r.min, below_max),
        within(above, above_min, r.max),
    ) {
        // A part that only touches the plane (a corner or an edge on it, or the whole
        // triangle in it) holds nothing the other part's box does not: the points on the
        // plane go to both. Keeping it would add a reference, and a leaf, for nothing.
        (Some(b), Some(a)) if b.min[axis] >= pos => (None, Some(a)),
        (Some(b), Some(a)) if a.max[axis] <= pos => (Some(b), None),
        parts => parts,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::SplitMix64;

    fn point(rng: &mut SplitMix64, scale: f32) -> Vec3A {
        Vec3A::new(
            rng.range_f32(-scale, scale),
            rng.range_f32(-scale, scale),
            rng.range_f32(-scale, scale),
        )
    }

    fn holds(r: &PrimRef, p: Vec3A) -> bool {
        r.min.cmple(p).all() && p.cmple(r.max).all()
    }

    #[test]
    fn split_parts_hold_every_point_of_the_triangle_on_their_side() {
        let mut rng = SplitMix64::new(5);
        for case in 0..2000 {
            // Coordinates far from the origin too, where the crossing points round most.
            let scale = [1.0, 1000.0, 1e6][case % 3];
            let tri = [0; 3].map(|_| point(&mut rng, scale));
            let whole = PrimRef {
                min: tri[0].min(tri[1]).min(tri[2]),
                max: tri[0].max(tri[1]).max(tri[2]),
                id: 7,
            };
            let axis = case % 3;
            let cut = |rng: &mut SplitMix64, r: &PrimRef| {
                let t = rng.next_f32();
                r.min[axis] + (r.max[axis] - r.min[axis]) * t
            };
            // Split once, then split the part below again: parts of parts stay conservative.
            let pos = cut(&mut rng, &whole);
            let (below, above) = split_reference(&whole, &tri, axis, pos);
            let (below, above) = (below.expect("a part below"), above.expect("a part above"));
            let pos2 = cut(&mut rng, &below);
            let (low, mid) = split_reference(&below, &tri, axis, pos2);
            for part in [&below, &above]
                .into_iter()
                .chain(low.iter())
                .chain(mid.iter())
            {
                assert!(
                    holds(&whole, part.min) && holds(&whole, part.max),
                    "case {case}"
                );
                assert_eq!(part.id, 7);
            }
            // Where the edges cross the plane, computed in f64: the points that bound the
            // parts across it.
            for k in 0..3 {
                let (a, b) = (tri[k].as_dvec3(), tri[(k + 1) % 3].as_dvec3());
                let (da, db, x) = (a[axis], b[axis], f64::from(pos));
                if (da < x && x < db) || (db < x && x < da) {
                    let p = a + (b - a) * ((x - da) / (db - da));
                    for part in [&below, &above] {
                        let (lo, hi) = (part.min.as_dvec3(), part.max.as_dvec3());
                        // The plane's own coordinate: the f64 point may round past it.
                        let mut q = p;
                        q[axis] = x;
                        assert!(lo.cmple(q).all() && q.cmple(hi).all(), "case {case}: {q:?}");
                    }
                }
            }
            for _ in 0..200 {
                let (u, v) = (rng.next_f32(), rng.next_f32());
                let (u, v) = if u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                // In f64, so the sample is a point of the triangle and not of its rounding.
                let p = tri[0].as_dvec3()
                    + (tri[1] - tri[0]).as_dvec3() * f64::from(u)
                    + (tri[2] - tri[0]).as_dvec3() * f64::from(v);
                let x = p[axis];
                let inside = |r: &PrimRef| {
                    r.min.as_dvec3().cmple(p).all() && p.cmple(r.max.as_dvec3()).all()
                };
                if x <= f64::from(pos) {
                    assert!(inside(&below), "case {case}: {p:?} not below {pos}");
                    if x <= f64::from(pos2) {
                        assert!(low.as_ref().is_some_and(inside), "case {case}: {p:?}");
                    } else {
                        assert!(mid.as_ref().is_some_and(inside), "case {case}: {p:?}");
                    }
                }
                if x >= f64::from(pos) {
                    assert!(inside(&above), "case {case}: {p:?} not above {pos}");
                }
            }
        }
    }

    #[test]
    fn a_triangle_on_one_side_has_no_part_on_the_other() {
        let tri = [Vec3A::ZERO, Vec3A::X, Vec3A::Y];
        let whole = PrimRef {
            min: Vec3A::ZERO,
            max: Vec3A::new(1.0, 1.0, 0.0),
            id: 0,
        };
        let (below, above) = split_reference(&whole, &tri, 0, 2.0);
        assert!(below.is_some() && above.is_none());
        let (below, above) = split_reference(&whole, &tri, 2, -1.0);
        assert!(below.is_none() && above.is_some());
        // A plane through a corner: the corner alone would be the part on its far side, and
        // the part on the near side holds it.
        let (below, above) = split_reference(&whole, &tri, 0, 1.0);
        assert!(above.is_none());
        let below = below.expect("the whole triangle");
        assert_eq!((below.min, below.max), (whole.min, whole.max));
        // A triangle in the plane is kept once.
        let (below, above) = split_reference(&whole, &tri, 2, 0.0);
        assert_eq!(
            usize::from(below.is_some()) + usize::from(above.is_some()),
            1
        );
    }
}
