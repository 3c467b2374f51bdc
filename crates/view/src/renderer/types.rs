//! Shared records of the renderer: the image formats, what the resolve pass shows
//! ([`Shading`]), the wireframe's vertices and the camera as `renderer.wgsl` reads it.
//!
//! A leaf module of the renderer: it imports none of its siblings, so all of them (and the module face) can
//! import it without an import circle.

use glam::Vec3;
use wgpu::TextureFormat;

use crate::overview::ViewCamera;

/// The triangle-id images: `id + 1` per pixel, 0 for background.
pub(super) const ID_FORMAT: TextureFormat = TextureFormat::R32Uint;
/// The depth buffers (reversed-Z, infinite far plane, as `sightline-gpu`).
pub(super) const DEPTH_FORMAT: TextureFormat = TextureFormat::Depth32Float;

/// What the resolve pass shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Shading {
    /// Show the full image with the culled triangles tinted red instead of hiding them.
    pub xray: bool,
    /// Paint popping pixels magenta (ignored in x-ray mode, where they are tinted red).
    pub mark_popping: bool,
}

/// A vertex of the guides drawn over the scene (cell wireframe, frustum, overview cells and
/// marker): lines take them in pairs, filled quads in triangles.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct LineVertex {
    pub position: [f32; 3],
    pub colour: [f32; 4],
}

/// The camera as the shader reads it (`Camera` in `renderer.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct CameraUniform {
    eye: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    forward: [f32; 4],
    /// Perspective: `(1 / tan_half_x, 1 / tan_half_y, near, 0)`; orthographic:
    /// `(1 / half_width, 1 / half_height, near, 1)`.
    projection: [f32; 4],
    /// `(width, height, flags, far)`, flags bit 0 x-ray, bit 1 mark popping; `far` only for
    /// the orthographic camera (the perspective one has none).
    screen: [f32; 4],
}

impl CameraUniform {
    /// The uniform block of camera `view` with the `shading` flags.
    pub(super) fn new(view: &ViewCamera, shading: Shading) -> Self {
        let v4 = |v: Vec3| [v.x, v.y, v.z, 0.0];
        let flags = (u32::from(shading.xray) | (u32::from(shading.mark_popping) << 1)) as f32;
        match view {
            ViewCamera::Perspective(c) => Self {
                eye: v4(c.eye),
                right: v4(c.right),
                up: v4(c.up),
                forward: v4(c.forward),
                projection: [1.0 / c.tan_half_x(), 1.0 / c.tan_half_y(), c.near, 0.0],
                screen: [c.width as f32, c.height as f32, flags, 0.0],
            },
            ViewCamera::Orthographic(o) => Self {
                eye: v4(o.eye),
                right: v4(o.right),
                up: v4(o.up),
                forward: v4(o.forward),
                projection: [1.0 / o.half_width, 1.0 / o.half_height, o.near, 1.0],
                screen: [o.width as f32, o.height as f32, flags, o.far],
            },
        }
    }
}
