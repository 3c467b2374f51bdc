//! The bake driver: one sampler over a list of view cells, giving a `.pvs` file.
//!
//! Cells are baked one after the other, each using all cores inside the sampler (ray batches
//! are parallel); every cell gets its own seed derived from the bake seed and its index, so a
//! cell's PVS does not depend on which other cells are baked with it.

use std::time::Instant;

use glam::Vec3;

use serde_json::json;
use sightline_core::random::SplitMix64;
use sightline_core::trace::RayCaster;
use sightline_core::Scene;

use crate::pvs_file::{CellPvs, PvsFile};
use crate::sampler::{Budget, CellContext, CellResult, ConvergencePoint, Sampler};
use crate::viewcell::ViewCell;

/// The seed of cell `index` in a bake with seed `seed`.
pub fn cell_seed(seed: u64, index: usize) -> u64 {
    let mut r = SplitMix64::new(seed ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    r.next_u64()
}

/// Bakes `cells`. `free_space(cell, point)` tells whether a point of cell `cell` is empty space
/// (see [`CellContext::free_space`]; pass `&|_, _| true` for plain cells). `on_progress(cell,
/// point)` is called after every batch; `on_cell(cell, result)` after every cell.
/// `extra_metadata` is merged into the file's metadata.
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
    on_cell: &mut dyn FnMut(usize, &CellResult),
) -> PvsFile {
    let start = Instant::now();
    let mut file = PvsFile::for_scene(scene, serde_json::Value::Null);
    let mut stats = Vec::with_capacity(cells.len());
    let mut total_rays = 0u64;
    for (i, cell) in cells.iter().enumerate() {
        let inside = |p: Vec3| free_space(i, p);
        let ctx = CellContext {
            scene,
            caster,
            cell,
            seed: cell_seed(seed, i),
            free_space: Some(&inside),
        };
        let result = sampler.sample(&ctx, budget, &|p| on_progress(i, p));
        total_rays += result.rays;
        stats.push(json!({
            "rays": result.rays,
            "seconds": result.seconds,
            "pvs_size": result.visible.count_ones(..),
            "found_by": result.found_by.iter().map(|(k, v)| json!([k, v])).collect::<Vec<_>>(),
        }));
        on_cell(i, &result);
        file.cells.push(CellPvs {
            cell: *cell,
            visible: result.visible,
        });
    }
    let mut metadata = json!({
        "tool": format!("sightline {}", env!("CARGO_PKG_VERSION")),
        "scene": scene.source,
        "method": sampler.name(),
        "seed": seed,
        "budget": budget,
        "total_rays": total_rays,
        "seconds": start.elapsed().as_secs_f64(),
        "cells": stats,
    });
    if let (Some(m), serde_json::Value::Object(extra)) = (metadata.as_object_mut(), extra_metadata)
    {
        m.extend(extra);
    }
    file.metadata = metadata;
    file
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rand::RandomSampler;
    use sightline_core::scene::SceneBuilder;
    use sightline_core::trace::Bvh;

    #[test]
    fn cell_seeds_differ_and_repeat() {
        assert_ne!(cell_seed(1, 0), cell_seed(1, 1));
        assert_eq!(cell_seed(5, 3), cell_seed(5, 3));
    }

    #[test]
    fn bake_of_no_cells_is_empty_file() {
        let mut b = SceneBuilder::new("box");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        let scene = b.finish();
        let bvh = Bvh::build(&scene);
        let f = bake(
            &scene,
            &bvh,
            &[],
            &RandomSampler,
            &|_, _| true,
            &Budget::rays(10),
            1,
            serde_json::Value::Null,
            &|_, _| {},
            &mut |_, _| {},
        );
        assert!(f.cells.is_empty());
        assert!(f.check_scene(&scene).is_ok());
        assert_eq!(f.metadata["method"], "rand");
    }

    #[test]
    fn a_cell_beside_a_box_sees_part_of_it_and_results_repeat() {
        let mut b = SceneBuilder::new("box");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        let scene = b.finish();
        let bvh = Bvh::build(&scene);
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
    }
}
