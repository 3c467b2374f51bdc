//! The conservative from-region set as a bake method (`pvs bake --method conservative`): RV's
//! from-region extension (`from_region.rs`) behind the samplers' interface, so the bake driver,
//! its checkpoints, shards and files take it like GVS++.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 8 (from-region visibility as future work); see `from_region.rs`.
//!
//! It casts no rays and has no budget: its set is every triangle that no single large convex
//! occluder hides from the whole cell, less the back faces of closed solids the cell lies
//! outside of (`sightline_region::closed_solids`) and, on Quake 3 maps, what the map's portals
//! hide (and, where their walk runs out, what the map's solid space hides, fused by shrinking):
//! a superset of what can be seen from the cell (no false negatives, by construction),
//! typically several times the aggressive set.

use std::sync::{Arc, Mutex};

use sightline_core::scene::Scene;
use sightline_core::{Aabb, TriangleSet};
use sightline_region::bsp_portals::{BspPortals, DEFAULT_FLOW_BUDGET};
use sightline_region::closed_solids::ClosedSolids;
use sightline_region::methods::{sampler, MethodError, MethodParams, METHODS};
use sightline_region::shrunk_occluders::{FusionOptions, ShrunkOccluders};
use sightline_region::{Budget, CellContext, CellResult, ConvergencePoint, Sampler};

use super::from_region::{conservative_from_region, RegionOptions};
use super::source::SceneSource;

/// `found_by` of a cell whose conservative set could not be computed (options that make no
/// sense): the set is every triangle.
pub const REFUSED: &str = "refused: every triangle";

/// The name of [`ConservativeSampler`] as a bake method.
pub const CONSERVATIVE: &str = "conservative";

/// Every bake method's name: the ray samplers' (`sightline_region::methods::METHODS`) and
/// [`CONSERVATIVE`].
pub const BAKE_METHODS: [&str; 5] = [METHODS[0], METHODS[1], METHODS[2], METHODS[3], CONSERVATIVE];

/// Why [`bake_sampler`] cannot make a sampler.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BakeMethodError {
    /// The name is none of [`BAKE_METHODS`].
    #[error("unknown method '{name}' (known: {known})", known = BAKE_METHODS.join(", "))]
    Unknown {
        /// The name as given.
        name: String,
    },
    /// The ray sampler's parameters make no sense.
    #[error(transparent)]
    Method(MethodError),
}

/// The bake method called `name` with `params` (which `conservative` does not read): what
/// `pvs bake --method` and the Python bindings' bakes run.
///
/// # Errors
/// [`BakeMethodError`] for an unknown name or parameters out of range.
pub fn bake_sampler(
    name: &str,
    params: &MethodParams,
) -> Result<Box<dyn Sampler>, BakeMethodError> {
    if name == CONSERVATIVE {
        return Ok(Box::new(ConservativeSampler::default()));
    }
    sampler(name, params).map_err(|e| match e {
        MethodError::Unknown { name } => BakeMethodError::Unknown { name },
        e => BakeMethodError::Method(e),
    })
}

/// [`bake_sampler`], where `q3_cells` says the cells are Quake 3 leaves or clusters, whose
/// viewpoints keep to the map's empty leaves: `conservative` then also goes through the map's
/// portals ([`ConservativeSampler::through_portals`]).
///
/// # Errors
/// As [`bake_sampler`].
pub fn bake_sampler_for_cells(
    name: &str,
    params: &MethodParams,
    q3_cells: bool,
) -> Result<Box<dyn Sampler>, BakeMethodError> {
    if name == CONSERVATIVE {
        return Ok(Box::new(ConservativeSampler {
            through_portals: q3_cells,
            ..ConservativeSampler::default()
        }));
    }
    bake_sampler(name, params)
}

/// The conservative from-region sampler.
#[derive(Clone, Debug)]
pub struct ConservativeSampler {
    /// Occluders and batch size of [`conservative_from_region`].
    pub options: RegionOptions,
    /// Also cut the set by what the map's portals let through, on a Quake 3 map
    /// (`sightline_region::bsp_portals`). Only for cells whose viewpoints all lie in the map's
    /// empty leaves (Quake 3 leaf and cluster cells, whose origins keep to their cluster): the
    /// portals assume solid space opaque, and from a point inside it a ray sees through
    /// brushes whose outside faces the compiler removed (the bake of a 4x4x2 grid over
    /// q3dm6ish, whose boxes reach into the void, keeps 47-367 set triangles a cell outside
    /// the portals' set). [`bake_sampler_for_cells`] sets it.
    pub through_portals: bool,
    /// Leaf entries the portal walk may make per cell ([`DEFAULT_FLOW_BUDGET`]; see
    /// `BspPortals::visible_from_box`). Where it runs out, the map's solid space fuses
    /// occluders instead ([`ConservativeSampler::map_space`]).
    pub flow_budget: u64,
    /// Also leave out the back faces of closed solids the cell lies outside of
    /// (`sightline_region::closed_solids`; on by default: it holds for any cell).
    pub back_faces_of_solids: bool,
    /// Also leave out what the union of the closed solids, shrunk, hides from every viewpoint
    /// sample of the cell (`sightline_region::shrunk_occluders`: occluder fusion over whole
    /// blocks of buildings); needs `back_faces_of_solids`. `None`: off.
    pub solid_fusion: Option<SolidFusion>,
    /// The portal graph of the last Quake 3 map sampled, shared by the clones that bake its
    /// cells (built once per scene).
    pub portals: PortalCache,
    /// The closed solids of the last scene sampled, shared the same way.
    pub solids: SceneCache<ClosedSolids>,
    /// The shrunk union of those solids, shared the same way.
    pub shrunk: SceneCache<ShrunkOccluders>,
    /// The shrunk solid space of the last Quake 3 map whose portal walk ran out on a cell,
    /// shared the same way ([`ConservativeSampler::through_portals`]).
    pub map_space: SceneCache<ShrunkOccluders>,
}

/// How [`ConservativeSampler::solid_fusion`] shrinks the solids.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolidFusion {
    /// The shrink (scene units); `None`: [`FusionOptions::for_scene`]'s.
    pub radius: Option<f64>,
}

impl SolidFusion {
    /// The fusion options for `scene`: [`FusionOptions::for_scene`]'s, with this radius.
    fn options(self, scene: &Scene) -> FusionOptions {
        let mut options = FusionOptions::for_scene(scene);
        if let Some(r) = self.radius {
            options.radius = r;
        }
        options
    }
}

impl Default for ConservativeSampler {
    fn default() -> Self {
        Self {
            options: RegionOptions::default(),
            through_portals: false,
            flow_budget: DEFAULT_FLOW_BUDGET,
            back_faces_of_solids: true,
            solid_fusion: None,
            portals: PortalCache::default(),
            solids: SceneCache::default(),
            shrunk: SceneCache::default(),
            map_space: SceneCache::default(),
        }
    }
}

/// Something built from a scene on first use and kept for the scene it was built for, shared
/// by the clones of a sampler (the cells of a bake run on clones, one per thread).
#[derive(Debug)]
pub struct SceneCache<T>(Arc<Mutex<Option<Cached<T>>>>);

/// A map's [`BspPortals`], built once per scene.
pub type PortalCache = SceneCache<BspPortals>;

/// The scene a [`SceneCache`] was filled for, and what it holds (`None`: nothing to build).
type Cached<T> = (SceneKey, Option<Arc<T>>);

impl<T> Default for SceneCache<T> {
    fn default() -> Self {
        Self(Arc::new(Mutex::new(None)))
    }
}

impl<T> Clone for SceneCache<T> {
    fn clone(&self) -> Self {
        Self(Arc::clone(&self.0))
    }
}

/// What tells scenes apart for [`SceneCache`]: its address, source and counts.
#[derive(Clone, Debug, PartialEq)]
struct SceneKey {
    address: usize,
    source: String,
    triangles: usize,
    positions: usize,
}

impl SceneKey {
    fn of(scene: &Scene) -> Self {
        Self {
            address: scene as *const Scene as usize,
            source: scene.source.clone(),
            triangles: scene.triangle_count(),
            positions: scene.positions.len(),
        }
    }
}

impl<T> SceneCache<T> {
    /// What `build` gives for `scene`, built on the first call for this scene.
    fn of(&self, scene: &Scene, build: impl FnOnce(&Scene) -> Option<T>) -> Option<Arc<T>> {
        let key = SceneKey::of(scene);
        let mut cache = self.0.lock().unwrap_or_else(|e| e.into_inner());
        match &*cache {
            Some((k, built)) if *k == key => built.clone(),
            _ => {
                let built = build(scene).map(Arc::new);
                *cache = Some((key, built.clone()));
                built
            }
        }
    }
}

impl ConservativeSampler {
    /// `visible` (RV's set) without what the map's portals hide from the cell, on a Quake 3
    /// map (`sightline_region::bsp_portals`): both sets hold everything seen from the cell, so
    /// their intersection does too. Unchanged on other scenes, or when the flow gives up.
    fn through_portals(&self, ctx: &CellContext<'_>, visible: TriangleSet) -> TriangleSet {
        if !self.through_portals || ctx.scene.bsp.is_none() {
            return visible;
        }
        let Some(portals) = self.portals.of(ctx.scene, BspPortals::new) else {
            return visible;
        };
        let cell = ctx.cell;
        let bounds = Aabb::new(
            cell.center - cell.half_extents,
            cell.center + cell.half_extents,
        );
        match portals.visible_from_box(ctx.scene, &bounds, self.flow_budget) {
            Some(seen) => {
                let every_sequence = seen.every_sequence;
                let mut seen = seen.visible;
                seen.intersect_with(&visible);
                if every_sequence {
                    seen
                } else {
                    self.without_hidden_by_map_space(ctx, seen)
                }
            }
            None => visible,
        }
    }

    /// `visible` without what the map's solid space, shrunk, hides from every viewpoint sample
    /// of the cell (`ShrunkOccluders::of_map`: occluder fusion over the map's brushes, whose
    /// drawn faces are no closed solids), at the radius of `solid_fusion` or the scene's
    /// default. Only for cells whose viewpoints lie in the map's empty leaves, and run where
    /// the portal walk ran out (open areas, where its merged flow is loose): where the walk
    /// finishes it sees the same solid space more sharply (on the shared indoor maps fusion
    /// took off 0-2 % more, at 20-100x the time; docs/BENCHMARKS.md).
    fn without_hidden_by_map_space(
        &self,
        ctx: &CellContext<'_>,
        mut visible: TriangleSet,
    ) -> TriangleSet {
        let fusion = self.solid_fusion.unwrap_or_default();
        let shrunk = self
            .map_space
            .of(ctx.scene, |s| ShrunkOccluders::of_map(s, fusion.options(s)));
        if let Some(shrunk) = shrunk {
            shrunk.remove_hidden_in_map(ctx.scene, ctx.cell, &mut visible);
        }
        visible
    }

    /// `visible` without what the closed solids hide: the back faces of those the cell lies
    /// outside of, and, with `solid_fusion`, what their shrunk union hides from the cell.
    fn without_hidden_by_solids(
        &self,
        ctx: &CellContext<'_>,
        mut visible: TriangleSet,
    ) -> TriangleSet {
        if !self.back_faces_of_solids {
            return visible;
        }
        if let Some(solids) = self.solids.of(ctx.scene, |s| Some(ClosedSolids::new(s))) {
            solids.remove_back_faces(ctx.scene, &ctx.cell.corners(), &mut visible);
            if let Some(fusion) = self.solid_fusion {
                let shrunk = self.shrunk.of(ctx.scene, |s| {
                    ShrunkOccluders::new(s, &solids, fusion.options(s))
                });
                if let Some(shrunk) = shrunk {
                    shrunk.remove_hidden(ctx.scene, &solids, ctx.cell, &mut visible);
                }
            }
        }
        visible
    }
}

impl Sampler for ConservativeSampler {
    fn name(&self) -> &'static str {
        CONSERVATIVE
    }

    /// The cell's conservative set. The budget and the free-space predicate do not apply (the
    /// set holds for every point of the cell). Should the computation refuse (only for options
    /// that make no sense), the set is every triangle, which is conservative too, and
    /// `found_by` says so ([`REFUSED`], which the file's statistics keep).
    fn sample(
        &self,
        ctx: &CellContext<'_>,
        _budget: &Budget,
        progress: &(dyn Fn(&ConvergencePoint) + Sync),
    ) -> CellResult {
        let start = std::time::Instant::now();
        let n = ctx.scene.triangle_count();
        let (visible, found_by) = match conservative_from_region(
            &mut SceneSource::new(ctx.scene),
            &ctx.cell.corners(),
            &self.options,
        ) {
            Ok(r) => {
                let visible = self.through_portals(ctx, r.visible);
                (self.without_hidden_by_solids(ctx, visible), Vec::new())
            }
            Err(_) => {
                let mut all = TriangleSet::with_capacity(n);
                all.insert_range(..);
                (all, vec![(REFUSED, n)])
            }
        };
        let point = ConvergencePoint {
            rays: 0,
            seconds: start.elapsed().as_secs_f64(),
            pvs_size: visible.count_ones(..),
        };
        progress(&point);
        CellResult {
            visible,
            rays: 0,
            seconds: start.elapsed().as_secs_f64(),
            convergence: Vec::new(),
            found_by,
            converged: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bake_methods_name_their_samplers() {
        let params = MethodParams::default();
        // Every ray sampler is a bake method (a method added to region's list fails here until
        // it is added to BAKE_METHODS).
        assert_eq!(&BAKE_METHODS[..METHODS.len()], &METHODS[..]);
        for name in BAKE_METHODS {
            assert_eq!(bake_sampler(name, &params).unwrap().name(), name);
        }
        let e = bake_sampler("nope", &params).err().unwrap();
        assert!(
            e.to_string()
                .contains("known: gvs++, gvs, rand, raster, conservative"),
            "{e}"
        );
    }

    #[test]
    fn a_refused_computation_gives_every_triangle_and_says_so() {
        let mut b = sightline_core::scene::SceneBuilder::new("box");
        b.add_box(glam::Vec3::ZERO, glam::Vec3::ONE);
        let scene = b.finish();
        let bvh = sightline_core::trace::Bvh::build(&scene);
        let cell = sightline_region::ViewCell::aabb(
            glam::Vec3::new(3.0, 0.0, 0.0),
            glam::Vec3::new(4.0, 1.0, 1.0),
        )
        .unwrap();
        let ctx = CellContext {
            scene: &scene,
            caster: &bvh,
            cell: &cell,
            seed: 1,
            free_space: None,
        };
        let sample = |max_occluders| {
            let sampler = ConservativeSampler {
                options: RegionOptions {
                    max_occluders,
                    ..RegionOptions::default()
                },
                ..Default::default()
            };
            sampler.sample(&ctx, &Budget::default(), &|_| {})
        };
        let refused = sample(0);
        assert_eq!(refused.visible.count_ones(..), 12);
        assert_eq!(refused.found_by, [(REFUSED, 12)]);
        let computed = sample(16);
        // Computed, not refused: the box's face towards the cell is in the set.
        assert!(computed.found_by.is_empty());
        assert!(computed.visible.count_ones(..) > 0);
    }

    #[test]
    fn on_a_quake_map_the_portals_cut_the_bound_and_keep_the_sampled_set() {
        // A cluster cell of q3dm6ish: RV's umbrae alone keep most of the map, the portals
        // leave well under half of it, and a GVS++ bake's set stays inside.
        with_cluster_cell(5, |ctx| {
            let sampler = ConservativeSampler {
                through_portals: true,
                ..ConservativeSampler::default()
            };
            let bound = sampler.sample(ctx, &Budget::default(), &|_| {}).visible;
            // Without the switch (cells whose viewpoints may lie in solid space) RV's set alone
            // (and without the back faces of closed solids, which leave out a few more).
            let plain = ConservativeSampler {
                back_faces_of_solids: false,
                ..ConservativeSampler::default()
            };
            let with_solids = ConservativeSampler::default()
                .sample(ctx, &Budget::default(), &|_| {})
                .visible;
            let umbrae_only = plain.sample(ctx, &Budget::default(), &|_| {}).visible;
            let umbrae = conservative_from_region(
                &mut SceneSource::new(ctx.scene),
                &ctx.cell.corners(),
                &RegionOptions::default(),
            )
            .unwrap()
            .visible;
            assert_eq!(umbrae_only, umbrae);
            assert!(with_solids.is_subset(&umbrae));
            let (bound_size, umbrae_size) = (bound.count_ones(..), umbrae.count_ones(..));
            assert!(bound.is_subset(&umbrae));
            assert!(
                umbrae_size * 2 > ctx.scene.triangle_count(),
                "{umbrae_size}"
            );
            assert!(bound_size * 3 < ctx.scene.triangle_count(), "{bound_size}");
            assert_holds_a_gvspp_set(ctx, &bound);
            // The portal graph is built once for the sampler and its clones.
            let again = sampler
                .clone()
                .sample(ctx, &Budget::default(), &|_| {})
                .visible;
            assert_eq!(again, bound);
            assert!(sampler.portals.0.lock().unwrap().is_some());
            // The walk finished: the map's solid space was not needed.
            assert!(sampler.map_space.0.lock().unwrap().is_none());
        });
    }

    #[test]
    fn where_the_portal_walk_runs_out_the_maps_solid_space_cuts_the_merged_flow() {
        // A budget of 0 leaf entries: the walk gives up at once, as it does in czest3ctf's
        // open areas, and the set is the merged flow's (one part per portal side) cut by
        // what the map's shrunk solid space hides from the cell's viewpoint samples.
        with_cluster_cell(35, |ctx| {
            let sampler = ConservativeSampler {
                through_portals: true,
                flow_budget: 0,
                back_faces_of_solids: false,
                solid_fusion: Some(SolidFusion { radius: Some(8.0) }),
                ..ConservativeSampler::default()
            };
            let bound = sampler.sample(ctx, &Budget::default(), &|_| {}).visible;
            let mut merged = BspPortals::new(ctx.scene)
                .unwrap()
                .visible_from_box(
                    ctx.scene,
                    &Aabb::new(
                        ctx.cell.center - ctx.cell.half_extents,
                        ctx.cell.center + ctx.cell.half_extents,
                    ),
                    0,
                )
                .unwrap()
                .visible;
            merged.intersect_with(
                &conservative_from_region(
                    &mut SceneSource::new(ctx.scene),
                    &ctx.cell.corners(),
                    &RegionOptions::default(),
                )
                .unwrap()
                .visible,
            );
            assert!(sampler.map_space.0.lock().unwrap().is_some());
            assert!(bound.is_subset(&merged));
            let (size, merged_size) = (bound.count_ones(..), merged.count_ones(..));
            assert!(size < merged_size, "{size} of {merged_size}");
            assert_holds_a_gvspp_set(ctx, &bound);
        });
    }

    /// Runs `test` with the context of a cluster cell of q3dm6ish whose free space is the
    /// cluster's points.
    fn with_cluster_cell(cluster: u32, test: impl FnOnce(&CellContext<'_>)) {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/q3dm6ish.bsp");
        let scene = sightline_core::scene::open(path, &Default::default()).unwrap();
        let bsp = scene.bsp.as_deref().unwrap();
        let bvh = sightline_core::trace::Bvh::build(&scene);
        let (cluster, cell) =
            sightline_region::cell_sources::q3_cluster_cells(bsp, Some(&[cluster]))
                .pop()
                .unwrap();
        let in_cluster = |p: glam::Vec3| bsp.cluster_at(p) == Some(cluster);
        test(&CellContext {
            scene: &scene,
            caster: &bvh,
            cell: &cell,
            seed: 1,
            free_space: Some(&in_cluster),
        });
    }

    /// Asserts that a GVS++ bake of the cell (1 M rays) finds over 100 triangles, all in
    /// `bound`.
    fn assert_holds_a_gvspp_set(ctx: &CellContext<'_>, bound: &TriangleSet) {
        let gvspp = sightline_region::methods::sampler("gvs++", &Default::default()).unwrap();
        let budget = Budget {
            max_rays: Some(1_000_000),
            max_time: None,
        };
        let set = gvspp.sample(ctx, &budget, &|_| {}).visible;
        assert!(set.count_ones(..) > 100);
        assert!(
            set.is_subset(bound),
            "{:?}",
            set.difference(bound).collect::<Vec<_>>()
        );
    }
}
