//! Integration tests of sightline-gpu, one module per property. They run on whatever Vulkan
//! adapter [`sightline_gpu::vulkan_device`] picks (lavapipe in CI) and FAIL, never skip, when
//! there is none.
#![allow(clippy::unwrap_used)]

use sightline_gpu::GpuBackend;
use wgpu::{AdapterInfo, Device, Queue};

/// The adapter is Vulkan, and a missing adapter is a loud failure.
mod adapter;
/// A many-cell GVS++ bake through the cell-batching caster over the GPU caster: the per-cell
/// GPU bake's and the CPU bake's sets, in fewer batches than calls.
mod cell_batching;
/// The compute-shader ray caster against the CPU caster: same triangles, same `t` bits (with
/// `SHADER_F64`), on the bunny, a city and a Quake 3 map; unusable rays, chunks, errors.
mod ray_cast;
/// The hardware ray-query caster against the CPU caster: hits, `t` within its stated tolerance,
/// occlusion, ranges, unusable rays, chunks and threads; fails where the adapter lacks ray queries.
mod ray_query;
/// Against the reference rasterizer's exact depth test on random occluder scenes: no visible
/// box is reported occluded, except at pixel-centre edge and depth ties (tolerance stated there).
mod reference;
/// Not tests: the scenes and ray sets the two ray casters' tests share.
mod scenes;
/// The simulation of The Grid with the GPU backend, within the software backend's bounds.
mod simulation;
/// Occluded and visible boxes behind and in front of a wall; near-plane boxes; depth kept
/// across mid-frame readbacks; more queries than one query set holds.
mod wall;

/// One device shared by all tests (creating a Vulkan device on lavapipe takes a while).
fn shared_device() -> &'static (Device, Queue, AdapterInfo) {
    sightline_test_support::vulkan::shared_device("sightline-gpu")
}

/// A fresh backend on the shared device.
fn gpu() -> GpuBackend {
    let (device, queue, info) = shared_device();
    GpuBackend::with_device(device, queue, info.clone())
}
