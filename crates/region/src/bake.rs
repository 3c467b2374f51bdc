//! The bake driver: one sampler over a list of view cells, giving a `.pvs` file.
//!
//! Cells are baked in parallel (rayon, one task per cell; the samplers parallelise ray batches
//! inside a cell as well). Every cell gets its own seed derived from the bake seed and its
//! *global* index, and the samplers are deterministic for a ray budget, so a cell's PVS depends
//! neither on which other cells are baked with it (shards, resumed bakes) nor on scheduling or
//! thread count. Finished cells are kept encoded ([`EncodedSet`]: the smaller of delta varints
//! and a bitset), so thousands of cells of a large scene fit in memory.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};
use std::time::Instant;

use glam::Vec3;

use rayon::prelude::*;
use serde_json::json;
use sightline_core::random::SplitMix64;
use sightline_core::trace::RayCaster;
use sightline_core::Scene;

use crate::pvs_file::{CellPvs, EncodedSet, PvsFile};
use crate::sampler::{Budget, CellContext, CellResult, ConvergencePoint, Sampler};
use crate::viewcell::ViewCell;

/// Most points of a cell's convergence curve kept in the metadata (`cells[i].convergence`).
pub const MAX_CONVERGENCE_POINTS: usize = 64;

/// The seed of cell `index` in a bake with seed `seed`.
pub fn cell_seed(seed: u64, index: usize) -> u64 {
    let mut r = SplitMix64::new(seed ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    r.next_u64()
}

/// What a bake computes: the scene, the full cell list and how each cell is sampled.
#[derive(Clone, Copy)]
pub struct BakeSetup<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Ray caster over `scene`.
    pub caster: &'a dyn RayCaster,
    /// Every cell of the bake (indices into this list are the cells' global indices).
    pub cells: &'a [ViewCell],
    /// The sampler.
    pub sampler: &'a dyn Sampler,
    /// `free_space(cell, point)`: see [`CellContext::free_space`].
    pub free_space: &'a (dyn Fn(usize, Vec3) -> bool + Sync),
    /// Budget per cell.
    pub budget: Budget,
    /// Bake seed; cell `i` samples with [`cell_seed`]`(seed, i)`.
    pub seed: u64,
}

/// One finished cell, kept encoded.
#[derive(Clone, Debug, PartialEq)]
pub struct BakedCell {
    /// Global index of the cell.
    pub index: usize,
    /// Its PVS.
    pub set: EncodedSet,
    /// Rays cast for it.
    pub rays: u64,
    /// Seconds spent on it.
    pub seconds: f64,
    /// Whether its sampler's termination rule held before the budget ran out (GVS, GVS++;
    /// `None` for other samplers), as `CellResult::converged`.
    pub converged: Option<bool>,
    /// Its statistics as compact JSON text (a parsed `serde_json::Value` with a 64-point
    /// convergence curve takes several KB; the text a tenth of that).
    stats: Box<str>,
}

impl BakedCell {
    /// A finished cell with its statistics (`rays`, `seconds`, `pvs_size`, `found_by`,
    /// `convergence`, as stored in the file's `metadata.cells`).
    pub fn new(index: usize, set: EncodedSet, stats: &serde_json::Value) -> Self {
        Self {
            index,
            set,
            rays: stats["rays"].as_u64().unwrap_or(0),
            seconds: stats["seconds"].as_f64().unwrap_or(0.0),
            converged: stats["converged"].as_bool(),
            stats: stats.to_string().into_boxed_str(),
        }
    }

    /// Its statistics.
    pub fn stats(&self) -> serde_json::Value {
        serde_json::from_str(&self.stats).unwrap_or(serde_json::Value::Null)
    }

    /// Bytes it takes in memory: the encoded set, the statistics text and the struct.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>() + self.set.payload_bytes() + self.stats.len()
    }
}

/// At most `max` points of a convergence curve as `[rays, pvs_size]` pairs: evenly spaced by
/// index, always keeping the last (the final size).
pub fn subsample_convergence(points: &[ConvergencePoint], max: usize) -> Vec<[u64; 2]> {
    let pair = |p: &ConvergencePoint| [p.rays, p.pvs_size as u64];
    if points.len() <= max {
        return points.iter().map(pair).collect();
    }
    let max = max.max(2);
    let last = points.len() - 1;
    let mut out: Vec<[u64; 2]> = (0..max)
        .map(|k| pair(&points[k * last / (max - 1)]))
        .collect();
    out.dedup();
    out
}

/// The statistics of one cell as stored in the metadata.
pub fn cell_stats(result: &CellResult) -> serde_json::Value {
    let mut stats = json!({
        "rays": result.rays,
        "seconds": result.seconds,
        "pvs_size": result.visible.count_ones(..),
        "found_by": result.found_by.iter().map(|(k, v)| json!([k, v])).collect::<Vec<_>>(),
        "convergence": subsample_convergence(&result.convergence, MAX_CONVERGENCE_POINTS),
    });
    if let Some(converged) = result.converged {
        stats["converged"] = json!(converged);
    }
    stats
}

/// Asks `free_space` about cell `index` once, at its centre, so that a test that prepares
/// itself lazily per cell (`occupancy::BakeOccupancy` tests a cell's voxels on first use, in
/// parallel, under a `OnceLock`) does so here, outside the sampler's parallel batches. Prepared
/// from inside a batch, the preparing thread can steal a sibling task of the same batch while
/// it waits for its own parallel work, and that task then waits on the lock the thread itself
/// holds: a deadlock (seen in a GPU bake from Python, possible on the CPU).
pub fn touch_free_space(
    free_space: &(dyn Fn(usize, Vec3) -> bool + Sync),
    index: usize,
    cell: &ViewCell,
) {
    let _ = free_space(index, cell.center);
}

/// Samples cell `index` of `setup`.
pub fn bake_one(
    setup: &BakeSetup<'_>,
    index: usize,
    on_progress: &(dyn Fn(usize, &ConvergencePoint) + Sync),
) -> CellResult {
    touch_free_space(setup.free_space, index, &setup.cells[index]);
    let inside = |p: Vec3| (setup.free_space)(index, p);
    let ctx = CellContext {
        scene: setup.scene,
        caster: setup.caster,
        cell: &setup.cells[index],
        seed: cell_seed(setup.seed, index),
        free_space: Some(&inside),
    };
    setup
        .sampler
        .sample(&ctx, &setup.budget, &|p| on_progress(index, p))
}

/// What [`bake_cells`] hands every finished cell to.
pub type CellSink<'a, E> = dyn FnMut(BakedCell, &CellResult) -> Result<(), E> + Send + 'a;

/// Bakes the cells `todo` (global indices) in parallel. `on_cell` receives every finished cell
/// (one call at a time, in completion order); an error from it stops the bake (cells under way
/// complete but are dropped) and is returned. `max_cells` stops starting new cells after that
/// many (a way to interrupt a bake at a known point, e.g. to test resuming).
pub fn bake_cells<E: Send>(
    setup: &BakeSetup<'_>,
    todo: &[usize],
    max_cells: Option<usize>,
    on_progress: &(dyn Fn(usize, &ConvergencePoint) + Sync),
    on_cell: &mut CellSink<'_, E>,
) -> Result<(), E> {
    let n = setup.scene.triangle_count();
    let started = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let sink: Mutex<(&mut CellSink<'_, E>, Option<E>)> = Mutex::new((on_cell, None));
    todo.par_iter().with_max_len(1).for_each(|&index| {
        if failed.load(Ordering::Relaxed) {
            return;
        }
        if max_cells.is_some_and(|m| started.fetch_add(1, Ordering::SeqCst) >= m) {
            return;
        }
        let result = bake_one(setup, index, on_progress);
        let baked = BakedCell::new(
            index,
            EncodedSet::encode(&result.visible, n),
            &cell_stats(&result),
        );
        let mut guard = sink.lock().unwrap_or_else(PoisonError::into_inner);
        if guard.1.is_none() {
            if let Err(e) = (guard.0)(baked, &result) {
                guard.1 = Some(e);
                failed.store(true, Ordering::Relaxed);
            }
        }
    });
    match sink.into_inner().unwrap_or_else(PoisonError::into_inner).1 {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// The file metadata of a bake: tool, scene, method, seed, budget, totals and the per-cell
/// statistics `cells` (in file order), with `extra` merged in.
#[allow(clippy::too_many_arguments)]
pub fn bake_metadata(
    scene: &Scene,
    method: &str,
    seed: u64,
    budget: &Budget,
    total_rays: u64,
    seconds: f64,
    cells: Vec<serde_json::Value>,
    extra: serde_json::Value,
) -> serde_json::Value {
    let mut metadata = json!({
        "tool": format!("sightline {}", env!("CARGO_PKG_VERSION")),
        "scene": scene.source,
        "method": method,
        "seed": seed,
        "budget": budget,
        "total_rays": total_rays,
        "seconds": seconds,
        "cells": cells,
    });
    if let (Some(m), serde_json::Value::Object(extra)) = (metadata.as_object_mut(), extra) {
        m.extend(extra);
    }
    metadata
}

/// [`bake`] of plain cells (all space free) without progress reports or extra metadata: what
/// examples, tests and embedders that only want the file call.
pub fn bake_plain(
    scene: &Scene,
    caster: &dyn RayCaster,
    cells: &[ViewCell],
    sampler: &dyn Sampler,
    budget: &Budget,
    seed: u64,
) -> PvsFile {
    bake(
        scene,
        caster,
        cells,
        sampler,
        &|_, _| true,
        budget,
        seed,
        serde_json::Value::Null,
        &|_, _| {},
        &mut |_, _| {},
    )
}

/// Bakes `cells` (all of them, in parallel) into a file in memory. `free_space(cell, point)`
/// tells whether a point of cell `cell` is empty space (see [`CellContext::free_space`]; pass
/// `&|_, _| true` for plain cells). `on_progress(cell, point)` is called after every batch;
/// `on_cell(cell, result)` after every cell, in completion order. `extra_metadata` is merged
/// into the file's metadata.
#[allow(clippy::too_many_arguments)]
pub fn bake(
    scene: &Scene,
    caster: &dyn RayCaster,
    cells: &[ViewCell],
    sampler: &dyn Sampler,
    free_space: &(dyn Fn(usize, Vec3) -> bool + Sync),
    budget: &Budget,
    seed: u64,
    extra_metadata: serde_json::Value,
    on_progress: &(dyn Fn(usize, &ConvergencePoint) + Sync),
    on_cell: &mut (dyn FnMut(usize, &CellResult) + Send),
) -> PvsFile {
    let done = try_bake::<std::convert::Infallible>(
        scene,
        caster,
        cells,
        sampler,
        free_space,
        budget,
        seed,
        extra_metadata,
        on_progress,
        &mut |index, result| {
            on_cell(index, result);
            Ok(())
        },
    );
    let Ok(file) = done;
    file
}

/// [`bake`] that can be stopped: an error from `on_cell` stops starting new cells (those
/// under way complete and are dropped) and is returned instead of the file. This is the
/// cancellation hook of embedders (e.g. Ctrl-C in the Python bindings): `on_cell` returns an
/// error once a stop was asked for.
#[allow(clippy::too_many_arguments)]
pub fn try_bake<E: Send>(
    scene: &Scene,
    caster: &dyn RayCaster,
    cells: &[ViewCell],
    sampler: &dyn Sampler,
    free_space: &(dyn Fn(usize, Vec3) -> bool + Sync),
    budget: &Budget,
    seed: u64,
    extra_metadata: serde_json::Value,
    on_progress: &(dyn Fn(usize, &ConvergencePoint) + Sync),
    on_cell: &mut (dyn FnMut(usize, &CellResult) -> Result<(), E> + Send),
) -> Result<PvsFile, E> {
    let start = Instant::now();
    let setup = BakeSetup {
        scene,
        caster,
        cells,
        sampler,
        free_space,
        budget: *budget,
        seed,
    };
    let mut results: Vec<Option<(CellPvs, serde_json::Value, u64)>> = vec![None; cells.len()];
    let all: Vec<usize> = (0..cells.len()).collect();
    bake_cells::<E>(&setup, &all, None, on_progress, &mut |baked, result| {
        on_cell(baked.index, result)?;
        results[baked.index] = Some((
            CellPvs::new(cells[baked.index], result.visible.clone()),
            baked.stats(),
            result.rays,
        ));
        Ok(())
    })?;
    let mut file = PvsFile::for_scene(scene, serde_json::Value::Null);
    let mut stats = Vec::with_capacity(cells.len());
    let mut total_rays = 0;
    for (cell, s, rays) in results.into_iter().flatten() {
        file.cells.push(cell);
        stats.push(s);
        total_rays += rays;
    }
    file.metadata = bake_metadata(
        scene,
        sampler.name(),
        seed,
        budget,
        total_rays,
        start.elapsed().as_secs_f64(),
        stats,
        extra_metadata,
    );
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rand::RandomSampler;
    use sightline_core::scene::SceneBuilder;
    use sightline_core::trace::Bvh;

    /// A unit box and its BVH.
    fn unit_box() -> (Scene, Bvh) {
        let mut b = SceneBuilder::new("box");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        let scene = b.finish();
        let bvh = Bvh::build(&scene);
        (scene, bvh)
    }

    #[test]
    fn cell_seeds_differ_and_repeat() {
        assert_ne!(cell_seed(1, 0), cell_seed(1, 1));
        assert_eq!(cell_seed(5, 3), cell_seed(5, 3));
    }

    #[test]
    fn convergence_is_subsampled_keeping_the_last_point() {
        let points: Vec<ConvergencePoint> = (1..=1000)
            .map(|i| ConvergencePoint {
                rays: i * 10,
                seconds: 0.0,
                pvs_size: i as usize / 3,
            })
            .collect();
        let c = subsample_convergence(&points, 64);
        assert!(c.len() <= 64 && c.len() > 32, "{}", c.len());
        assert_eq!(c[0], [10, 0]);
        assert_eq!(*c.last().unwrap(), [10_000, 333]);
        assert!(c.windows(2).all(|w| w[0][0] < w[1][0]));
        assert_eq!(subsample_convergence(&points[..5], 64).len(), 5);
    }

    /// The free-space test of every cell is first asked at the cell's centre, before the
    /// sampler's parallel batches ask it (what keeps a lazily prepared test from deadlocking:
    /// `touch_free_space`).
    #[test]
    fn each_cell_free_space_is_first_asked_before_sampling() {
        let (scene, bvh) = unit_box();
        let cells: Vec<ViewCell> = (0..4)
            .map(|i| {
                let x = 3.0 + i as f32;
                ViewCell::aabb(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 1.0, 1.0)).unwrap()
            })
            .collect();
        let first: Vec<std::sync::OnceLock<Vec3>> =
            cells.iter().map(|_| std::sync::OnceLock::new()).collect();
        let calls = AtomicUsize::new(0);
        let free_space = |cell: usize, p: Vec3| {
            first[cell].get_or_init(|| p);
            calls.fetch_add(1, Ordering::Relaxed);
            true
        };
        let sampler = crate::GvsPlusPlus::default();
        let f = bake(
            &scene,
            &bvh,
            &cells,
            &sampler,
            &free_space,
            &Budget::rays(20_000),
            3,
            serde_json::Value::Null,
            &|_, _| {},
            &mut |_, _| {},
        );
        assert_eq!(f.cells.len(), 4);
        assert!(
            calls.load(Ordering::Relaxed) > 1000,
            "the sampler asks per origin"
        );
        for (c, p) in cells.iter().zip(&first) {
            assert_eq!(p.get(), Some(&c.center));
        }
    }

    #[test]
    fn bake_of_no_cells_is_empty_file() {
        let (scene, bvh) = unit_box();
        let f = bake_plain(&scene, &bvh, &[], &RandomSampler, &Budget::rays(10), 1);
        assert!(f.cells.is_empty());
        assert!(f.check_scene(&scene).is_ok());
        assert_eq!(f.metadata["method"], "rand");
    }

    #[test]
    fn a_cell_beside_a_box_sees_part_of_it_and_results_repeat() {
        let (scene, bvh) = unit_box();
        let cells = [ViewCell::aabb(Vec3::new(3.0, 0.0, 0.0), Vec3::new(4.0, 1.0, 1.0)).unwrap()];
        let run = || {
            bake(
                &scene,
                &bvh,
                &cells,
                &RandomSampler,
                &|_, _| true,
                &Budget::rays(100_000),
                9,
                serde_json::json!({"note": "test"}),
                &|_, _| {},
                &mut |_, _| {},
            )
        };
        let f = run();
        // The +x face (2 triangles) is visible; the -x face is not.
        let visible = &f.cells[0].visible;
        assert_eq!(visible.count_ones(..), 2);
        assert_eq!(f.cells, run().cells);
        assert_eq!(f.metadata["note"], "test");
        let curve = f.metadata["cells"][0]["convergence"].as_array().unwrap();
        assert!(!curve.is_empty() && curve.len() <= MAX_CONVERGENCE_POINTS);
        assert_eq!(curve.last().unwrap()[1], 2);
    }

    #[test]
    fn an_error_from_on_cell_stops_the_bake() {
        let (scene, bvh) = unit_box();
        let cell = ViewCell::aabb(Vec3::new(3.0, 0.0, 0.0), Vec3::new(4.0, 1.0, 1.0)).unwrap();
        let cells = vec![cell; 64];
        let mut finished = 0;
        let r = try_bake(
            &scene,
            &bvh,
            &cells,
            &RandomSampler,
            &|_, _| true,
            &Budget::rays(1_000),
            9,
            serde_json::Value::Null,
            &|_, _| {},
            &mut |_, _| {
                finished += 1;
                Err("stop")
            },
        );
        assert_eq!(r.err(), Some("stop"));
        // Cells already under way on other threads may finish, but no new ones start.
        assert!(finished <= rayon::current_num_threads(), "{finished}");
    }
}
