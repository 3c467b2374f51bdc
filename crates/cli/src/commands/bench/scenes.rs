//! The scene and camera every `bench` subcommand starts from: a validated scene, and the
//! overview camera of `bench trace`'s coherent rays. A leaf: `bench.rs` and `peers.rs` both
//! take them from here.

use anyhow::Result;
use sightline_core::scene::{self, LoadOptions};
use sightline_core::{Camera, Scene};

use crate::args::default_eye;

/// The scene `spec`, loaded with the default options and validated.
pub(super) fn load(spec: &str) -> Result<Scene> {
    let scene = scene::open(spec, &LoadOptions::default())?;
    sightline_core::validate::validate(&scene).check()?;
    Ok(scene)
}

/// A camera of `size`² pixels looking at the scene's centre from its default eye.
pub(super) fn overview_camera(scene: &Scene, size: u32) -> Result<Camera> {
    crate::limits::check_pixels(size, size).map_err(anyhow::Error::msg)?;
    let b = scene.bounds();
    let eye = default_eye(scene, b.center(), b.diagonal());
    Ok(Camera::look_at(
        eye,
        b.center(),
        scene.up.vector(),
        60.0,
        size,
        size,
        sightline_core::default_near(scene, eye),
    )?)
}
