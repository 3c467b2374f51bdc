#![allow(clippy::unwrap_used)]
//! Integration tests of sightline-view, one module per property. They run on whatever Vulkan
//! adapter `sightline_gpu::vulkan_device` picks (lavapipe in CI) and FAIL, never skip, when
//! there is none.

use glam::Vec3;
use sightline_core::scene::{self, LoadOptions};
use sightline_core::{Camera, Scene};
use wgpu::{AdapterInfo, Device, Queue};

/// Headless frames: PNGs of the right size, not blank; `frames.json` with one record a frame.
mod headless;
/// The HUD in headless frames: only its top-left panel changes, and it holds text; without it
/// the frame is the plain render.
mod hud;
/// The popping counter: 0 for a PVS that is exactly the visible set, the removed triangle's
/// pixels when one visible triangle is taken out; the culling methods measured.
mod popping;
/// The no-culling id image against the reference rasterizer's (tolerance stated there).
mod reference;

/// One device shared by all tests (creating a Vulkan device on lavapipe takes a while).
fn shared_device() -> &'static (Device, Queue, AdapterInfo) {
    sightline_test_support::vulkan::shared_device("sightline-view")
}

/// A small procedural scene.
fn small_scene(spec: &str) -> Scene {
    scene::open(spec, &LoadOptions::default()).unwrap()
}

/// A three-quarter view from outside the scene's bounds (as the CLI's default camera).
fn outside_camera(scene: &Scene, width: u32, height: u32) -> Camera {
    let b = scene.bounds();
    let look = b.center();
    let eye = look + Vec3::new(-0.55, -0.75, 0.45) * b.diagonal() * 0.75;
    Camera::look_at(eye, look, Vec3::Z, 60.0, width, height, b.diagonal() * 1e-4).unwrap()
}

/// A street-level camera inside the city, looking along a street (lots of occlusion).
fn street_camera(scene: &Scene, width: u32, height: u32) -> Camera {
    let b = scene.bounds();
    let c = b.center();
    let eye = Vec3::new(b.min.x + 0.1 * b.extent().x, c.y + 1.0, b.min.z + 2.0);
    let look = Vec3::new(b.max.x, c.y + 0.1 * b.extent().y, b.min.z + 2.0);
    Camera::look_at(eye, look, Vec3::Z, 70.0, width, height, 0.05).unwrap()
}
