//! The free segment of a ray and what it shows: both end triangles are visible from every
//! point of the empty segment between a ray's backward and forward hits, so each cell the
//! segment crosses gets them, from a point of the crossing in its free space.
//!
//! Based on: Bittner, Mattausch, Wonka, Havran, Wimmer. Adaptive Global Visibility Sampling.
//! ACM TOG 28(3), 2009 (a ray contributes to all view cells it intersects).

use glam::Vec3;
use sightline_core::{Hit, Ray};

use crate::rays::Discovery;
use crate::segment_cells::{Crossing, SegmentCells};

/// A triangle seen from a point of a cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Contribution {
    pub cell: u32,
    /// True when the cell cast the ray itself.
    pub own: bool,
    pub discovery: Discovery,
}

/// The triangles that `ray`'s free segment shows to its owner (from the ray's origin) and to
/// every cell it crosses (from a point of the crossing in the cell's free space), skipping those
/// `known(cell, triangle, own)` says the cell needs no more; appended to `out`. The segment runs from the
/// backward hit (the origin without `backward`) to the forward hit (infinity on a miss).
#[allow(clippy::too_many_arguments)]
pub(super) fn ray_contributions(
    index: &SegmentCells,
    free_space: &(dyn Fn(usize, Vec3) -> bool + Sync),
    known: &dyn Fn(u32, u32, bool) -> bool,
    owner: u32,
    ray: &Ray,
    forward: Hit,
    backward: Option<Hit>,
    scratch: &mut Vec<u32>,
    crossings: &mut Vec<Crossing>,
    out: &mut Vec<Contribution>,
) {
    let (o, d) = (ray.origin, ray.dir);
    // The free segment: (t_back, t_fwd) along the ray, with its end triangles.
    let t_fwd = forward.t;
    let t_back = match backward {
        Some(b) => -b.t,
        None => 0.0,
    };
    let fwd_end = forward.triangle().map(|t| (t, o + d * t_fwd));
    let back_end = backward.and_then(|b| b.triangle().map(|t| (t, o - d * b.t)));
    let mut push = |cell: u32, own: bool, origin: Vec3, end: (u32, Vec3)| {
        if !known(cell, end.0, own) {
            out.push(Contribution {
                cell,
                own,
                discovery: Discovery {
                    triangle: end.0,
                    origin,
                    hit_point: end.1,
                },
            });
        }
    };
    for end in [fwd_end, back_end].into_iter().flatten() {
        push(owner, true, o, end);
    }
    crossings.clear();
    if index.is_regular() && t_fwd.is_finite() && t_back.is_finite() {
        // Both ends inside the owner's box: the segment crosses no other cell of a grid.
        let cell = &index.cells()[owner as usize];
        if cell.contains(o + d * t_fwd) && cell.contains(o + d * t_back) {
            return;
        }
    }
    index.crossings(o, d, t_back, t_fwd, scratch, crossings);
    for c in crossings.iter() {
        if c.cell == owner {
            continue;
        }
        let fwd_new = fwd_end.filter(|e| !known(c.cell, e.0, false));
        let back_new = back_end.filter(|e| !known(c.cell, e.0, false));
        if fwd_new.is_none() && back_new.is_none() {
            // Nothing new for this cell: skip the free-space test (it may cost rays).
            continue;
        }
        // A point of the crossing in the cell's free space: its middle, else a quarter in.
        let Some(t) = [0.5f32, 0.25, 0.75].iter().find_map(|&f| {
            let t = c.t_enter + (c.t_exit - c.t_enter) * f;
            (t.is_finite() && free_space(c.cell as usize, o + d * t)).then_some(t)
        }) else {
            continue;
        };
        let p = o + d * t;
        if let Some(end) = fwd_new.filter(|_| t < t_fwd) {
            push(c.cell, false, p, end);
        }
        if let Some(end) = back_new.filter(|_| t > t_back) {
            push(c.cell, false, p, end);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray_sharing::fixtures::{city_cells, small_city};
    use crate::rays::cast;
    use sightline_core::random::SplitMix64;
    use sightline_core::trace::Bvh;

    #[test]
    fn every_shared_triangle_is_seen_from_its_crossing_point() {
        let scene = small_city();
        let bvh = Bvh::build(&scene);
        let cells = city_cells(&scene, 8);
        let index = SegmentCells::new(&cells);
        let mut rng = SplitMix64::new(21);
        let rays: Vec<(u32, Ray)> = (0..4000)
            .map(|_| {
                let owner = (rng.next_u64() % cells.len() as u64) as u32;
                let o = cells[owner as usize].interior_point([
                    rng.next_f32(),
                    rng.next_f32(),
                    rng.next_f32(),
                ]);
                let z = rng.range_f32(-1.0, 1.0);
                let phi = rng.range_f32(0.0, std::f32::consts::TAU);
                let r = (1.0 - z * z).sqrt();
                (
                    owner,
                    Ray::new(o, Vec3::new(r * phi.cos(), r * phi.sin(), z)),
                )
            })
            .collect();
        let plain: Vec<Ray> = rays.iter().map(|(_, r)| *r).collect();
        let forward = cast(&bvh, &plain);
        let reversed: Vec<Ray> = plain.iter().map(|r| Ray::new(r.origin, -r.dir)).collect();
        let backward = cast(&bvh, &reversed);
        let (mut scratch, mut crossings, mut out) = (Vec::new(), Vec::new(), Vec::new());
        for (k, (owner, ray)) in rays.iter().enumerate() {
            ray_contributions(
                &index,
                &|_, _| true,
                &|_, _, _| false,
                *owner,
                ray,
                forward[k],
                Some(backward[k]),
                &mut scratch,
                &mut crossings,
                &mut out,
            );
        }
        let shared: Vec<&Contribution> = out.iter().filter(|c| !c.own).collect();
        assert!(
            shared.len() > 1000,
            "only {} shared contributions",
            shared.len()
        );
        // Check each one: the point is in the cell, and a ray from it toward the hit point
        // finds the triangle there. Where it finds another triangle, the hit point lies on an
        // edge shared with it (same point, within rounding).
        let checks: Vec<Ray> = shared
            .iter()
            .map(|c| {
                Ray::new(
                    c.discovery.origin,
                    c.discovery.hit_point - c.discovery.origin,
                )
            })
            .collect();
        let hits = cast(&bvh, &checks);
        let mut on_edges = 0;
        for (c, h) in shared.iter().zip(&hits) {
            assert!(cells[c.cell as usize].contains(c.discovery.origin));
            assert!(
                h.is_hit(),
                "{c:?}: nothing between the cell and the hit point"
            );
            let length = c.discovery.hit_point.distance(c.discovery.origin);
            assert!(
                ((1.0 - h.t) * length).abs() < 1e-3 * length.max(1.0),
                "{c:?}: hit at t = {} instead of 1",
                h.t
            );
            on_edges += usize::from(h.triangle != c.discovery.triangle);
        }
        assert!(
            on_edges * 100 <= shared.len(),
            "{on_edges} of {} checks found another triangle",
            shared.len()
        );
    }
}
