//! sightline-gpu: the GPU paths of sightline. Two: a hardware-occlusion-query backend
//! ([`GpuBackend`]) for the run-time culling of `sightline-cull`, implementing its
//! [`OcclusionBackend`](sightline_cull::OcclusionBackend) trait with `wgpu` on Vulkan; and a
//! compute-shader ray caster ([`GpuRayCaster`]) implementing `sightline-core`'s
//! [`RayCaster`](sightline_core::trace::RayCaster), with hits equal to the CPU caster's (and,
//! where the adapter has hardware ray queries, [`RayQueryCaster`], the same interface on the
//! driver's acceleration structures, with hits equal up to rounding at edges and ties).
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, sections 2.4 (hardware occlusion queries) and 4.3.2 (depth pre-pass and
//! queries in traversal order).
//!
//! Modules, one concern each:
//! - `device.rs`: [`vulkan_device`] acquires a Vulkan device and checks the backend
//!   ([`check_vulkan`]); errors are [`GpuError`].
//! - `occlusion_query/` (+ `occlusion_query.wgsl`): [`GpuBackend`], working on any device
//!   passed to [`GpuBackend::with_device`] (tests pass their own); one file per step (its
//!   pipelines, its growing buffers, the passes of a submission, the readback).
//! - `ray_cast.rs` (+ `ray_cast.wgsl`): [`GpuRayCaster`], closest-hit and any-hit casting of
//!   ray batches streamed in double-buffered chunks, on any device passed to
//!   [`GpuRayCaster::with_device`]; its exactness against the CPU caster, the node width
//!   chosen and why are in its module documentation. `sightline bench trace --device gpu`
//!   measures it beside the CPU casters, `sightline pvs bake --device gpu` bakes with it.
//! - `ray_query.rs` (+ `ray_query.wgsl`): [`RayQueryCaster`], the same queries with hardware
//!   ray queries (Vulkan `VK_KHR_ray_query`, wgpu's `EXPERIMENTAL_RAY_QUERY`) where the
//!   adapter has them: the driver's acceleration structure and triangle test, so hits agree
//!   with the CPU caster's up to ties and edges within rounding and `t` within
//!   [`RAY_QUERY_T_TOLERANCE`]; its module documentation states what and why.
//! - `caster_choice.rs`: [`AnyGpuCaster`], the caster a bake or benchmark uses
//!   ([`GpuCasterKind`]: ray queries where the adapter has them, else compute; `--gpu-caster`).
//! - `stream.rs`: what both ray casters share, streaming ray batches through their compute
//!   pipelines in double-buffered chunks from a pool of buffer sets.
//! - `cell_batching.rs`: [`CellBatchingCaster`], which runs many cells of a bake at once and
//!   casts their rounds' rays as one batch (any caster inside; the GPU's in `pvs bake
//!   --device gpu`), with the per-cell bake's results.
//! - `ray_layout.rs`: the CPU BVH (`sightline_core::trace::bvh::FlatBvh`) and rays in the
//!   shader's layout; the traversal-stack depth check.
//!
//! # Adapter requirements
//! - **Vulkan only** (`wgpu` is built with just its `vulkan` and `wgsl` features). wgpu's GL
//!   fallback is never used: GL occlusion queries as wgpu exposes them are booleans, and the
//!   thesis' algorithm is tested here on Vulkan's exact sample counts. [`vulkan_device`]
//!   returns [`GpuError::NotVulkan`] if the adapter is not Vulkan and
//!   [`GpuError::NoVulkanAdapter`] if none exists.
//! - No required feature or raised limit: occlusion queries, `Depth32Float`, depth-only
//!   pipelines and compute shaders are core WebGPU; any Vulkan 1.x driver that wgpu supports
//!   works. `SHADER_F64` is requested where the adapter has it: with it the ray caster's hits
//!   are bit-exact with the CPU's, without it `t` is within [`APPROXIMATE_T_ULPS`].
//!   `EXPERIMENTAL_RAY_QUERY` is requested where the adapter has it (with its
//!   acceleration-structure limits), for [`RayQueryCaster`]; lavapipe has it from Mesa 24.1
//!   (Debian 12: `mesa-vulkan-drivers` from bookworm-backports).
//! - Without a GPU (CI, servers): Mesa's lavapipe, `apt-get install -y mesa-vulkan-drivers`.
//!   The tests of this crate **fail** (they do not skip) when no Vulkan adapter is found.
//!
//! # Running on a real GPU
//! Install the vendor's Vulkan driver (Debian: `mesa-vulkan-drivers` also holds the AMD
//! `radv` and Intel `anv` drivers; NVIDIA's proprietary driver ships its own ICD) and check it
//! with `vulkaninfo --summary`. [`vulkan_device`] prefers a discrete GPU, then an integrated
//! one, and a CPU device (lavapipe) last. To pick one explicitly set `SIGHTLINE_GPU_ADAPTER` to
//! part of its name (`SIGHTLINE_GPU_ADAPTER=llvmpipe` forces lavapipe), or restrict the Vulkan
//! loader with `VK_ICD_FILENAMES=/usr/share/vulkan/icd.d/radeon_icd.x86_64.json`. Then
//! `cargo test -p sightline-gpu` runs the same tests on that GPU, and
//! `cargo run --release -p sightline-gpu --example grid_gpu` times The Grid on it.
//!
//! ```no_run
//! use sightline_cull::{scenes::the_grid, simulate, SimConfig};
//! use sightline_gpu::GpuBackend;
//!
//! let mut gpu = GpuBackend::new()?; // acquires the Vulkan device
//! println!("on {}", gpu.adapter_info().name);
//! let report = simulate(&the_grid(1, 8), &mut gpu, &SimConfig::default()).unwrap();
//! println!("{}", report.summary());
//! # Ok::<(), sightline_gpu::GpuError>(())
//! ```
#![deny(missing_docs)]

mod caster_choice;
mod cell_batching;
mod device;
mod occlusion_query;
mod ray_cast;
mod ray_layout;
mod ray_query;
mod stream;

pub use caster_choice::{AnyGpuCaster, GpuCasterKind};
pub use cell_batching::{CellBatchingCaster, CellBatchingOptions, CellBatchingStats};
pub use device::{check_vulkan, pick_adapter, vulkan_device, GpuError};
pub use occlusion_query::{GpuBackend, GpuFrameStats, MeshId, QueryOutcome};
pub use ray_cast::{GpuRayCaster, GpuRayCasterOptions, APPROXIMATE_T_ULPS};
pub use ray_query::{RayQueryCaster, RayQueryMemory, RayQueryOptions, RAY_QUERY_T_TOLERANCE};
