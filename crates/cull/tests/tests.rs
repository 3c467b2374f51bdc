//! Integration tests of sightline-cull, one module per property.
#![allow(clippy::unwrap_used)]

/// The bench's occluder sets have the asked leg lengths and stay on screen.
mod bench_sets;
/// The software occlusion buffer never culls a box (nor, with the triangle test, an object)
/// that the exact depth test shows visible.
mod conservative;
/// The SIMD and scalar rasterizer kernels produce identical buffers.
mod kernels;
/// The scheduler's durations, cap, growth, jitter and exemptions behave as configured.
mod scheduler_numbers;
/// The simulation loop: immediate results with one-frame durations never pop; reports add up.
mod simulation;
/// The grid traversal visits cells in occlusion order, each once, covering the frustum.
mod traversal_order;
