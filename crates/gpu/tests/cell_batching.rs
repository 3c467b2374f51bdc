//! A many-cell GVS++ bake through the cell-batching caster over the GPU caster: the same sets
//! as the per-cell GPU bake and as the CPU bake (the same rays per cell, bit-identical hits on
//! lavapipe), with the cells' rounds cast in fewer, larger batches.

use std::sync::Arc;

use sightline_core::scene::{self, LoadOptions, Scene};
use sightline_core::trace::{Bvh, RayCaster};
use sightline_gpu::{CellBatchingCaster, CellBatchingOptions, GpuRayCaster};
use sightline_region::bake::bake_plain;
use sightline_region::{Budget, GvsPlusPlus, GvsPlusPlusParams, PvsFile, ViewCell};

use super::shared_device;

fn rooms() -> Scene {
    scene::open("procedural:rooms?seed=2&size=2000", &LoadOptions::default()).unwrap()
}

/// Eight small cells over the rooms' floor, one layer above it.
fn small_cells(scene: &Scene) -> Vec<ViewCell> {
    let b = scene.bounds();
    let up = scene.up.vector();
    let min = b.min + up * 0.5;
    let max = b.max - up * (b.max - b.min).dot(up) + up * 1.5;
    ViewCell::grid(min, max, [4, 2, 1]).unwrap()
}

fn gvspp() -> GvsPlusPlus {
    GvsPlusPlus {
        params: GvsPlusPlusParams {
            n_rand: 2000,
            ..GvsPlusPlusParams::default()
        },
    }
}

fn bake_with(scene: &Scene, caster: &dyn RayCaster, cells: &[ViewCell]) -> PvsFile {
    bake_plain(scene, caster, cells, &gvspp(), &Budget::rays(12_000), 7)
}

fn sets(file: &PvsFile) -> Vec<Vec<usize>> {
    file.cells
        .iter()
        .map(|c| c.visible.ones().collect())
        .collect()
}

#[test]
fn batched_gpu_bake_equals_per_cell_gpu_and_cpu_bakes() {
    let scene = rooms();
    let cells = small_cells(&scene);
    assert_eq!(cells.len(), 8);
    let (device, queue, info) = shared_device();
    let gpu = GpuRayCaster::with_device(device, queue, info.clone(), &scene, Default::default());
    let gpu = Arc::new(gpu.unwrap());
    let cpu = bake_with(&scene, &Bvh::build(&scene), &cells);
    let per_cell = bake_with(&scene, gpu.as_ref(), &cells);
    let options = CellBatchingOptions {
        cells: 8,
        ..CellBatchingOptions::default()
    };
    let batching = CellBatchingCaster::new(gpu, options).unwrap();
    let batched = batching.install(|| bake_with(&scene, &batching, &cells));
    let expected = sets(&cpu);
    assert!(expected.iter().all(|s| s.len() > 10), "{expected:?}");
    assert_eq!(sets(&per_cell), expected);
    assert_eq!(sets(&batched), expected);
    // Rounds of several cells went out together.
    let stats = batching.stats();
    assert!(stats.batches < stats.calls, "{stats:?}");
    let cast: u64 = (batched.metadata["cells"].as_array().unwrap().iter())
        .map(|c| c["rays"].as_u64().unwrap())
        .sum();
    assert_eq!(stats.rays, cast);
}
