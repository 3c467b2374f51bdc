//! sightline-view: the viewer of `sightline view`. A wgpu (Vulkan) renderer that draws a scene
//! with flat shading, culled per frame by one of several visibility methods (none, the PVS of
//! the current view cell, chunked software occlusion culling, the exact visible set of the
//! reference rasterizer at reduced resolution), and counts the **popping pixels** of every
//! frame on the GPU: the pixels that differ between the culled and the full image.
//!
//! Modules, one concern each:
//! - `renderer/` (+ `renderer.wgsl`): [`Renderer`], working on any device and queue passed to
//!   [`Renderer::new`]: id images, popping count, shading, cell wireframe; one file per job
//!   (buffers, pipelines, size-dependent targets, the passes of a frame, readback).
//! - `viewer.rs`: [`Viewer`], the methods ([`Method`]) and the per-frame numbers.
//! - `occlusion.rs`: [`OcclusionCuller`], per-frame occlusion culling of scene chunks with
//!   `sightline_cull::OcclusionBuffer`.
//! - `fly_camera.rs`: [`FlyCamera`], the camera controller (keys, mouse, scroll).
//! - `cell_pick.rs`: which cell the pvs method uses (picked with `[` / `]`, or the eye's).
//! - `frustum.rs`: the frozen camera's frustum as corners and edges, its far plane clamped to
//!   the scene.
//! - `overview.rs`: [`OrthoCamera`], the top-down overview's camera, and [`ViewCamera`], the
//!   camera the renderer draws through.
//! - `guides.rs`: the lines and quads drawn over the scene (cell wireframe, frozen frustum,
//!   the overview's cell map coloured as the report's and its eye marker).
//! - `hud/`: the on-screen numbers (method, cell, triangles, objects, popping, fps) as 8x8
//!   bitmap text on the CPU (`hud/text.rs`), blended over the frame by the renderer.
//! - `controls.rs`: [`CONTROLS`], the one table of the window's keys and mouse inputs that the
//!   key handler, `--help` and the HUD's help lines all read.
//! - `headless.rs`: [`run_headless`], PNG frames and `frames.json` without a window.
//! - `window.rs`: [`run_window`], the interactive window (winit).
//!
//! Devices: the headless driver and the tests take a device from
//! `sightline_gpu::vulkan_device` (Vulkan only, Mesa's lavapipe in CI); the window asks for a
//! Vulkan adapter compatible with its surface and checks it with `sightline_gpu::check_vulkan`.
//!
//! ```no_run
//! use glam::Vec3;
//! use sightline_core::{scene, Camera};
//! use sightline_view::{Method, Offscreen, Viewer, ViewerOptions};
//!
//! let scene = scene::open("procedural:city", &Default::default()).unwrap();
//! let camera = Camera::look_at(Vec3::new(-300.0, -20.0, 2.0), Vec3::new(0.0, -20.0, 5.0),
//!     Vec3::Z, 60.0, 320, 180, 0.05).unwrap();
//! let (device, queue, _) = sightline_gpu::vulkan_device().unwrap();
//! let mut viewer = Viewer::new(scene, None, ViewerOptions::default()).unwrap();
//! viewer.set_method(Method::Occlusion);
//! let mut offscreen = Offscreen::new(&device, &queue, &viewer, 320, 180).unwrap();
//! let frame = offscreen.frame(&mut viewer, &camera).unwrap();
//! println!("{} triangles drawn, {} popping pixels", frame.triangles_drawn, frame.popping_pixels);
//! offscreen.read_rgba().unwrap().save("frame.png").unwrap();
//! ```
#![deny(missing_docs)]

mod cell_pick;
mod controls;
mod error;
mod fly_camera;
mod frustum;
mod guides;
mod headless;
mod hud;
mod occlusion;
mod overview;
mod renderer;
mod viewer;
mod window;

// Camera paths live in core (the culling simulation and headless builds read them too).
pub use cell_pick::{cell_in_use, step_cell, CellSource};
pub use controls::{action_of, help_lines, Action, Control, Direction, CONTROLS};
pub use error::ViewError;
pub use fly_camera::{FlyCamera, Movement};
pub use frustum::{clamped_far, frustum_corners, frustum_edges};
pub use headless::{run_headless, HeadlessOptions, HeadlessReport, Offscreen, HEADLESS_FORMAT};
pub use hud::{hud_height, HUD_TEXT};
pub use occlusion::{OcclusionCuller, OcclusionStats, TRIANGLES_PER_CHUNK};
pub use overview::{OrthoCamera, ViewCamera};
pub use renderer::{GpuFrame, IdImage, Renderer, Shading};
pub use sightline_core::camera_path::{
    interpolate, orbit, read_camera_path, CameraPathError, Keyframe,
};
pub use viewer::{FrameRecord, Frozen, Method, PoppingStats, Viewer, ViewerOptions};
pub use window::{run_window, Lens};
