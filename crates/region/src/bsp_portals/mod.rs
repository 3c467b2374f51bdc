//! A conservative from-region set for Quake 3 maps from the map's own cells and portals: the
//! empty leaves of its BSP are convex cells, the openings between them portals, and what a
//! view cell sees must be seen through a sequence of portals. This is the other half of a
//! two-sided bound on indoor maps, where single convex occluders (RV's umbrae) hide little
//! from a box: a wall is many small brush faces, and no one of them hides a room from a
//! whole cell, while the portals between rooms are few and small.
//!
//! Based on: Teller, Séquin. Visibility preprocessing for interactive walkthroughs. SIGGRAPH
//! 1991; Airey, Rohlf, Brooks. I3D 1990. See `build.rs` (the portals) and `flow.rs` (the
//! flow from a box, down to triangles).
//!
//! # Files
//! - `winding.rs`: convex polygons in f64, cut by planes with a sliver kept.
//! - `build.rs`: the portal graph of a BSP tree.
//! - `flow.rs`: the triangles a box may see through it.
//! - `might.rs`: the leaves a sequence through each portal side might enter, with which the
//!   walk skips portals that can mark nothing new.
//!
//! # Memory and time
//! The graph: one polygon per portal (a few corners of 24 bytes), one list entry per portal
//! end; the triangles of each leaf: 4 bytes per (triangle, leaf) pair it touches, twice (a
//! list per leaf and its inverse); one bit per (portal side, leaf) for `might.rs`
//! (czest3ctf: 5 MB). A flow holds one bit per triangle, one count per leaf and one path of
//! portal parts, each with a bit per leaf; it visits each portal sequence that survives its
//! cuts once, which is exponential in the worst case, so it gives up after a fifth of
//! [`DEFAULT_FLOW_BUDGET`] leaf entries; the merged flow (`flow::merged_from`) then keeps one
//! part per portal side (two polygons per portal at most) and its work is bounded, at the
//! price of a looser set; and a second walk, pruned against that set, gets the whole budget
//! (on czest3ctf one of three open cells finishes this way).

mod build;
mod flow;
mod might;
mod winding;

pub(crate) use build::node_planes;
pub(crate) use winding::Plane;

use glam::DVec3;
use sightline_core::scene::Scene;
use sightline_core::{Aabb, TriangleSet};

/// Leaf entries the walk of every portal sequence may make before it gives up (about 8 s on
/// czest3ctf's open areas): the shared maps' indoor cells need far fewer (at most 53,000),
/// the first walk gets a fifth of it, and the walk pruned against the merged flow after it
/// all of it (docs/BENCHMARKS.md).
pub const DEFAULT_FLOW_BUDGET: u64 = 500_000;

/// A Quake 3 map's portal graph and the triangles of its leaves, built once per scene.
#[derive(Clone, Debug)]
pub struct BspPortals {
    graph: build::PortalGraph,
    leaf_triangles: Vec<Vec<u32>>,
    /// The leaves of each triangle (the inverse of `leaf_triangles`).
    leaves_of: Vec<Vec<u32>>,
    /// Per portal side, the leaves a sequence through it might enter (`might.rs`).
    might: Vec<fixedbitset::FixedBitSet>,
    triangles: usize,
}

impl BspPortals {
    /// A flow from the box `bounds` (finite), with its source leaves.
    fn flow<'a>(
        &'a self,
        scene: &'a Scene,
        bsp: &'a sightline_core::scene::q3::BspData,
        bounds: &Aabb,
        budget: u64,
    ) -> (flow::Flow<'a>, Vec<usize>) {
        let (lo, hi) = (bounds.min.as_dvec3(), bounds.max.as_dvec3());
        let corners: [DVec3; 8] = std::array::from_fn(|k| {
            DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            )
        });
        let sources: Vec<usize> = bsp
            .leaves_in_box(bounds)
            .into_iter()
            .filter(|&l| build::is_empty(bsp, l))
            .collect();
        let flow = flow::Flow {
            bsp,
            scene,
            graph: &self.graph,
            leaf_triangles: &self.leaf_triangles,
            corners,
            might: &self.might,
            steps: 0,
            budget,
            marks: flow::Marks::new(self.triangles, &self.leaf_triangles, &self.leaves_of),
            on_path: vec![false; bsp.leaves.len()],
            sources: vec![false; bsp.leaves.len()],
            first_portal_cuts: true,
            prune: true,
        };
        (flow, sources)
    }

    /// The portals of `scene`'s BSP, or `None` when the scene has no BSP (not a Quake 3 map)
    /// or its tree is malformed.
    pub fn new(scene: &Scene) -> Option<Self> {
        let bsp = scene.bsp.as_deref()?;
        let planes = build::node_planes(bsp);
        let graph = build::build(bsp, &planes)?;
        let leaf_triangles = flow::leaf_triangles(bsp, &planes, scene);
        let mut leaves_of = vec![Vec::new(); scene.triangle_count()];
        for (leaf, list) in leaf_triangles.iter().enumerate() {
            for &t in list {
                leaves_of[t as usize].push(leaf as u32);
            }
        }
        let might = might::might_see(&graph, bsp.leaves.len());
        Some(Self {
            graph,
            leaf_triangles,
            leaves_of,
            might,
            triangles: scene.triangle_count(),
        })
    }

    /// Portals between empty leaves.
    pub fn portal_count(&self) -> usize {
        self.graph.portals.len()
    }

    /// Every triangle of `scene` (the scene these portals were built for) that may be seen
    /// from a point of the box `bounds` through the map's portals: every portal sequence
    /// walked while a fifth of `budget` leaf entries last; past that, every sequence walked
    /// again with the whole budget, pruned against the merged flow, or that merged flow when
    /// the budget runs out again. `None` when the scene is another (its triangle count
    /// differs) or has no BSP, or the box is not finite.
    pub fn visible_from_box(
        &self,
        scene: &Scene,
        bounds: &Aabb,
        budget: u64,
    ) -> Option<PortalView> {
        let bsp = scene.bsp.as_deref()?;
        if scene.triangle_count() != self.triangles
            || !bounds.min.is_finite()
            || !bounds.max.is_finite()
        {
            return None;
        }
        let (flow, sources) = self.flow(scene, bsp, bounds, budget);
        let (visible, every_sequence) = flow.run(&sources);
        Some(PortalView {
            visible,
            every_sequence,
        })
    }
}

/// What [`BspPortals::visible_from_box`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct PortalView {
    /// The triangles the box may see.
    pub visible: TriangleSet,
    /// True when every portal sequence was walked within the budget; false when the set is
    /// the merged flow's (one part per portal side, looser).
    pub every_sequence: bool,
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use sightline_core::scene::{open, LoadOptions, SceneBuilder};
    use sightline_core::trace::{Bvh, RayCaster};
    use sightline_core::Ray;

    use super::*;
    use crate::cell_sources::q3_cluster_cells;

    fn map() -> Scene {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/q3dm6ish.bsp");
        open(path, &LoadOptions::default()).unwrap()
    }

    /// Five clusters players reach, one leaf each (docs/BENCHMARKS.md, "Portals").
    const CLUSTERS: [u32; 5] = [5, 20, 35, 65, 80];

    fn boxes(scene: &Scene) -> Vec<(u32, Aabb)> {
        let bsp = scene.bsp.as_deref().unwrap();
        let cells = q3_cluster_cells(bsp, Some(&CLUSTERS));
        let to_box = |c: &crate::viewcell::ViewCell| {
            Aabb::new(c.center - c.half_extents, c.center + c.half_extents)
        };
        cells.iter().map(|(k, c)| (*k, to_box(c))).collect()
    }

    #[test]
    fn portals_lie_on_their_planes_between_two_empty_leaves() {
        let scene = map();
        let bsp = scene.bsp.as_deref().unwrap();
        let p = BspPortals::new(&scene).unwrap();
        assert!(p.portal_count() > 100, "{}", p.portal_count());
        // Just in front of a portal's centre is its front leaf, just behind it its back leaf
        // (all but slivers narrower than the step off the plane).
        let mut astray = 0;
        for portal in &p.graph.portals {
            assert_ne!(portal.front, portal.back);
            assert!(build::is_empty(bsp, portal.front) && build::is_empty(bsp, portal.back));
            let w = &portal.winding;
            assert!(w.iter().all(|&c| portal.plane.distance(c).abs() < 1e-6));
            let centre = w.iter().copied().sum::<DVec3>() / w.len() as f64;
            let step = portal.plane.normal * 0.01;
            let front = bsp.leaf_at((centre + step).as_vec3());
            let back = bsp.leaf_at((centre - step).as_vec3());
            // Slivers (about as wide as the cuts' growth) may be the growth alone.
            let perimeter: f64 = (0..w.len())
                .map(|i| (w[(i + 1) % w.len()] - w[i]).length())
                .sum();
            let sliver = winding::double_area(w) / perimeter < 4.0 * build::GROW;
            if !sliver && (front, back) != (portal.front, portal.back) {
                astray += 1;
            }
        }
        assert_eq!(astray, 0, "portals not between their leaves");
        // Every empty leaf a player reaches opens onto another.
        for (_, b) in boxes(&scene) {
            for l in bsp.leaves_in_box(&b) {
                if build::is_empty(bsp, l) {
                    assert!(!p.graph.of_leaf[l].is_empty(), "leaf {l} has no portal");
                }
            }
        }
    }

    #[test]
    fn a_sequences_first_portal_cuts_the_flow_tighter_than_the_box_alone() {
        // The box lets through segments that no point of the portal a sequence starts with
        // sends: cutting by that portal's separating planes too keeps a subset, and on
        // q3dm6ish's clusters a smaller one (the dense-sampling test below shows it still
        // holds what the cluster sees).
        let scene = map();
        let bsp = scene.bsp.as_deref().unwrap();
        let p = BspPortals::new(&scene).unwrap();
        let (mut with, mut without) = (0, 0);
        for (cluster, b) in boxes(&scene) {
            let (flow, sources) = p.flow(&scene, bsp, &b, DEFAULT_FLOW_BUDGET);
            let (tight, walked) = flow.run(&sources);
            assert!(walked);
            let (mut flow, sources) = p.flow(&scene, bsp, &b, DEFAULT_FLOW_BUDGET);
            flow.first_portal_cuts = false;
            let (loose, walked) = flow.run(&sources);
            assert!(walked);
            assert!(tight.is_subset(&loose), "cluster {cluster}");
            with += tight.count_ones(..);
            without += loose.count_ones(..);
        }
        // 3,741 against 3,899 when this test was written.
        assert!(with * 100 < without * 97, "{with} against {without}");
    }

    #[test]
    fn a_walk_pruned_against_the_merged_flow_marks_what_the_whole_walk_marks() {
        // With a budget whose fifth is too small for the first walk, the second walk (pruned
        // against the merged flow) finishes on some clusters: its set is the one the walk of
        // every sequence finds. And pruning changes no set where the first walk finishes.
        let scene = map();
        let bsp = scene.bsp.as_deref().unwrap();
        let p = BspPortals::new(&scene).unwrap();
        let mut second_walks = 0;
        for (cluster, b) in boxes(&scene) {
            let whole = p.visible_from_box(&scene, &b, DEFAULT_FLOW_BUDGET).unwrap();
            assert!(whole.every_sequence, "cluster {cluster}");
            let (mut flow, sources) = p.flow(&scene, bsp, &b, DEFAULT_FLOW_BUDGET);
            flow.prune = false;
            let (unpruned, walked) = flow.run(&sources);
            assert!(walked);
            assert_eq!(unpruned, whole.visible, "cluster {cluster}");
            // Past the first walk's budget (600 leaf entries) on every cluster here.
            let (mut flow, sources) = p.flow(&scene, bsp, &b, 3_000);
            flow.budget = 3_000 / flow::FIRST_WALK_SHARE;
            let (_, first_alone) = flow.run_first_walk(&sources);
            assert!(!first_alone, "cluster {cluster}");
            let small = p.visible_from_box(&scene, &b, 3_000).unwrap();
            if small.every_sequence {
                assert_eq!(small.visible, whole.visible, "cluster {cluster}");
                second_walks += 1;
            }
        }
        // Clusters 35 and 65 when this test was written.
        assert!(second_walks >= 2, "{second_walks}");
    }

    #[test]
    fn the_flow_holds_every_triangle_dense_sampling_sees() {
        // 100,000 rays a cell from random points of the cell's cluster, in random directions:
        // every triangle they hit first is in the cell's portal set, which is well below the
        // map (the flow culls).
        let scene = map();
        let bsp = scene.bsp.as_deref().unwrap();
        let p = BspPortals::new(&scene).unwrap();
        let bvh = Bvh::build(&scene);
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        for (cluster, b) in boxes(&scene) {
            let walk = p.visible_from_box(&scene, &b, DEFAULT_FLOW_BUDGET).unwrap();
            assert!(walk.every_sequence);
            let seen = walk.visible;
            // A budget of 0: the merged flow from the cell's own portals.
            let merged = p.visible_from_box(&scene, &b, 0).unwrap();
            assert!(!merged.every_sequence);
            let merged = merged.visible;
            // A budget of a few leaves: both walks stop early, and the set is the merged
            // flow's.
            let cut = p.visible_from_box(&scene, &b, 3).unwrap();
            assert!(!cut.every_sequence);
            let cut = cut.visible;
            // A budget too small for the first walk (a fifth of it) on some clusters: the
            // second walk, pruned against the merged flow, finishes or not.
            let second = p.visible_from_box(&scene, &b, 3_000).unwrap().visible;
            let size = seen.count_ones(..);
            assert!(
                size * 2 < scene.triangle_count(),
                "cluster {cluster}: {size}"
            );
            let merged_size = merged.count_ones(..);
            assert!(
                merged_size * 10 < scene.triangle_count() * 7,
                "{merged_size}"
            );
            let mut rays = Vec::new();
            while rays.len() < 100_000 {
                let o = b.min + b.extent() * Vec3::new(next(), next(), next());
                if bsp.cluster_at(o) != Some(cluster) {
                    continue;
                }
                let d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                if d.length_squared() > 1e-4 {
                    rays.push(Ray::new(o, d));
                }
            }
            let mut hits = vec![sightline_core::Hit::default(); rays.len()];
            bvh.cast(&rays, &mut hits);
            let hit: std::collections::BTreeSet<u32> = hits
                .iter()
                .filter(|h| h.triangle != sightline_core::Hit::NONE)
                .map(|h| h.triangle)
                .collect();
            assert!(hit.len() > 50, "cluster {cluster}: {} hit", hit.len());
            for (name, set) in [
                ("walk", &seen),
                ("merged", &merged),
                ("cut", &cut),
                ("second walk", &second),
            ] {
                let missed: Vec<u32> = hit
                    .iter()
                    .copied()
                    .filter(|&t| !set.contains(t as usize))
                    .collect();
                assert!(
                    missed.is_empty(),
                    "{name}: cluster {cluster} misses {missed:?}"
                );
            }
        }
    }

    #[test]
    fn other_scenes_and_boxes_give_no_set() {
        let scene = map();
        let p = BspPortals::new(&scene).unwrap();
        let (_, b) = boxes(&scene)[0];
        let nan = Aabb::new(Vec3::splat(f32::NAN), Vec3::ONE);
        assert!(p
            .visible_from_box(&scene, &nan, DEFAULT_FLOW_BUDGET)
            .is_none());
        let mut builder = SceneBuilder::new("box");
        builder.add_box(Vec3::ZERO, Vec3::ONE);
        let plain = builder.finish();
        assert!(BspPortals::new(&plain).is_none());
        assert!(p
            .visible_from_box(&plain, &b, DEFAULT_FLOW_BUDGET)
            .is_none());
    }
}
