//! Neighbour sampling under a budget: rays from the cell to the corners and centre of the
//! triangles that touch a found triangle but are not found yet.
//!
//! Ours, not the paper's (issue 24). Border sampling (GVS++ 4.2) explores the image-space
//! neighbourhood of a found triangle from the one origin that found it. It misses triangles
//! that show only a sliver: a face seen edge-on, or mostly hidden, whose visible part is a
//! corner next to a found neighbour. On the Quake 3 map fan, at 7 M rays, the last two misses
//! of six cells were such triangles (1 pixel each in 5 of 720 views): one was seen from 35 % of
//! the cell's surface, but only within 20 % of its extent from one corner, the other from 20 %
//! of the surface, only within 3 % of one corner; neither is seen at its centre from anywhere
//! in the cell, and border rays 3 mrad apart (3 units at that distance) pass by both. Aiming at
//! each corner pulled 2 % inwards, and at the centre, from [`ORIGINS_PER_TRIANGLE`] points
//! spread over the cell, finds such triangles with a few dozen rays. Neighbours are triangles
//! sharing a vertex position ([`VertexNeighbours`]); each is sampled once per cell. The
//! schedule by yield gives this kind its rays only while it finds triangles as well as the
//! others (`by_yield.rs`), so scenes without such slivers lose little.

use std::collections::VecDeque;
use std::sync::Arc;

use fixedbitset::FixedBitSet;
use glam::Vec3;
use rayon::prelude::*;
use sightline_core::sampling::ShiftedHalton;
use sightline_core::Ray;

use crate::adjacency::VertexNeighbours;
use crate::sampler::CellContext;
use crate::viewcell::CellSurface;

/// Origins on the cell's surface per sampled neighbour.
pub(crate) const ORIGINS_PER_TRIANGLE: usize = 8;

/// Points aimed at on each neighbour: its three corners pulled inwards, and its centre.
const TARGETS_PER_TRIANGLE: usize = 4;

/// How far the aimed-at corners are pulled towards the other two (barycentric weight of each
/// other corner).
const CORNER_PULL: f32 = 0.01;

/// One cell's neighbour sampling state.
pub(crate) struct NeighbourSampling {
    lists: Arc<VertexNeighbours>,
    /// Neighbours waiting to be sampled, oldest first.
    queue: VecDeque<u32>,
    /// Triangles that were queued once (never twice).
    queued: FixedBitSet,
    surface: CellSurface,
    halton: ShiftedHalton<3>,
    /// The next index of the origin sequence.
    next: u64,
}

impl NeighbourSampling {
    /// The state of `ctx`'s cell (the scene's lists shared between cells).
    pub fn new(ctx: &CellContext<'_>) -> Self {
        Self {
            lists: VertexNeighbours::shared(ctx.scene),
            queue: VecDeque::new(),
            queued: FixedBitSet::with_capacity(ctx.scene.triangle_count()),
            surface: CellSurface::new(ctx.cell),
            halton: ShiftedHalton::new(ctx.seed ^ 0x4e42),
            next: 0,
        }
    }

    /// Queues the neighbours of the newly found triangles `found` that were never queued
    /// (whether they are found by now is checked when they are sampled).
    pub fn found(&mut self, ctx: &CellContext<'_>, found: impl IntoIterator<Item = u32>) {
        for id in found {
            // A found triangle need not be sampled as somebody's neighbour.
            self.queued.insert(id as usize);
            let (queue, queued) = (&mut self.queue, &mut self.queued);
            self.lists.for_each_neighbour(ctx.scene, id, |n| {
                if !queued.put(n as usize) {
                    queue.push_back(n);
                }
            });
        }
    }

    /// True when neighbours wait.
    pub fn has_work(&self) -> bool {
        !self.queue.is_empty()
    }

    /// Rays per sampled neighbour (at most: origins outside the cell's free space are
    /// skipped).
    pub fn rays_per_triangle() -> usize {
        ORIGINS_PER_TRIANGLE * TARGETS_PER_TRIANGLE
    }

    /// The rays of up to `n` waiting neighbours that `is_found` does not know yet.
    pub fn rays(
        &mut self,
        ctx: &CellContext<'_>,
        n: usize,
        is_found: impl Fn(u32) -> bool,
    ) -> Vec<Ray> {
        let mut chosen = Vec::with_capacity(n);
        while chosen.len() < n {
            let Some(id) = self.queue.pop_front() else {
                break;
            };
            if !is_found(id) {
                chosen.push((id, self.next));
                self.next += ORIGINS_PER_TRIANGLE as u64;
            }
        }
        let (surface, halton) = (&self.surface, &self.halton);
        chosen
            .par_iter()
            .flat_map_iter(|&(id, first)| {
                let [a, b, c] = ctx.scene.triangle(id);
                let targets = targets(a, b, c);
                (0..ORIGINS_PER_TRIANGLE as u64).flat_map(move |k| {
                    let origin = surface.sample(halton.point(first + k)).0;
                    let allowed = ctx.origin_allowed(origin);
                    targets.into_iter().filter_map(move |t| {
                        let dir = t - origin;
                        (allowed && dir.length_squared() > 0.0).then(|| Ray::new(origin, dir))
                    })
                })
            })
            .collect()
    }
}

/// The points aimed at on triangle `a b c`.
fn targets(a: Vec3, b: Vec3, c: Vec3) -> [Vec3; TARGETS_PER_TRIANGLE] {
    let main = 1.0 - 2.0 * CORNER_PULL;
    let corner = |p: Vec3, q: Vec3, r: Vec3| p * main + (q + r) * CORNER_PULL;
    [
        corner(a, b, c),
        corner(b, c, a),
        corner(c, a, b),
        (a + b + c) / 3.0,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;
    use sightline_core::trace::Bvh;

    use crate::viewcell::ViewCell;

    #[test]
    fn neighbours_are_queued_once_and_aimed_at_from_spread_origins() {
        // A strip of three triangles in a row at x = 5, each touching the next.
        let mut b = SceneBuilder::new("strip");
        let v: Vec<u32> = (0..5)
            .map(|i| b.add_vertex(Vec3::new(5.0, i as f32, (i % 2) as f32)))
            .collect();
        for i in 0..3 {
            b.add_triangle([v[i], v[i + 1], v[i + 2]]);
        }
        let scene = b.finish();
        let bvh = Bvh::build(&scene);
        let cell = ViewCell::aabb(Vec3::splat(-0.5), Vec3::splat(0.5)).unwrap();
        let ctx = CellContext {
            scene: &scene,
            caster: &bvh,
            cell: &cell,
            seed: 3,
            free_space: None,
        };
        let mut s = NeighbourSampling::new(&ctx);
        s.found(&ctx, [0]);
        // Triangle 0's neighbours are 1 and 2 (2 shares vertex 2): queued once each.
        assert_eq!(s.queue, VecDeque::from([1, 2]));
        s.found(&ctx, [1]);
        assert_eq!(s.queue, VecDeque::from([1, 2]));
        // Triangle 1 is found by now: only 2 is sampled, from 8 origins at its 4 points.
        let rays = s.rays(&ctx, 10, |id| id <= 1);
        assert_eq!(rays.len(), NeighbourSampling::rays_per_triangle());
        assert!(!s.has_work());
        let [a, bb, c] = scene.triangle(2);
        let aims = targets(a, bb, c);
        for r in &rays {
            assert!(cell.contains(r.origin));
            let at = r.origin + r.dir;
            assert!(aims.iter().any(|t| t.distance(at) < 1e-4), "{at}");
        }
        let origins: std::collections::BTreeSet<[u32; 3]> = rays
            .iter()
            .map(|r| r.origin.to_array().map(f32::to_bits))
            .collect();
        assert_eq!(origins.len(), ORIGINS_PER_TRIANGLE);
        // Every corner target lies inside the triangle, near its corner.
        for (t, corner) in aims.iter().zip([a, bb, c]) {
            assert!(t.distance(corner) < 0.05 * (a.distance(bb) + bb.distance(c)));
        }
    }
}
