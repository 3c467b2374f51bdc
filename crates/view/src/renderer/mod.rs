//! The viewer's GPU renderer: triangle-id images of the full scene and of the culled set, the
//! popping count as the number of pixels where they differ (a compute pass), flat Lambert
//! shading resolved from the id image, and the view-cell wireframe on top.
//!
//! # Passes of one frame
//! 1. **Full id pass**: every triangle into an `R32Uint` image (`id + 1`, 0 = background) with
//!    a reversed-Z `Depth32Float` buffer (as `sightline-gpu`: depth `near / z`, infinite far
//!    plane, compare `Greater`). Triangles are drawn in id order, so an exact depth tie goes
//!    to the lower id, the rule of the reference rasterizer.
//! 2. **Culled id pass**: only the triangles the method draws (an index buffer of the drawn
//!    ids, still in id order), skipped when the method draws everything.
//! 3. **Compare** (compute): counts the pixels whose ids differ: the popping pixels, i.e. the
//!    pixels wrong because visible geometry was culled. Both images come from the same vertex
//!    shader on the same vertices, so a triangle gets the same depth in both (Vulkan's
//!    invariance rule) and the images differ only where the full image's triangle is culled.
//! 4. **Resolve**: a full-screen pass shading each pixel's triangle (flat: its face normal,
//!    double-sided, a headlight and two fixed lights, a colour per object). Popping pixels are
//!    magenta; in x-ray mode the full image is shown with culled triangles tinted red.
//! 5. **Guides**: filled triangles, then lines (view cells, the frozen camera's frustum, the
//!    overview's cell map and eye marker), depth-tested against the shown image.
//! 6. **Overlay** (only when asked, [`Renderer::draw_overlay`]): an RGBA image, the HUD,
//!    blended over the frame's top-left corner in a submission of its own.
//!
//! The renderer takes a device and queue from its caller (tests and the window pass theirs).
//! It draws through a perspective camera or the overview's orthographic one ([`ViewCamera`]).
//!
//! # Layout
//! - `types.rs`: formats, [`Shading`], the wireframe's vertices, the camera uniform (a leaf
//!   every other file imports).
//! - `buffers.rs`: the scene upload (after the size check) and the per-frame writes.
//! - `pipelines.rs`: the four pipelines and the bind groups that do not depend on the size.
//! - `targets.rs`: the id images, depth buffers and the bind groups that read them.
//! - `frame.rs`: the passes of one frame, in order.
//! - `readback.rs`: blocking buffer and texture readback.
//! - `overlay.rs` (+ `overlay.wgsl`): the overlay pass.

use sightline_core::{Camera, Hit, Scene, TriangleSet};
use wgpu::{Device, Queue, TextureFormat};

use crate::error::ViewError;
use crate::overview::ViewCamera;

mod buffers;
mod frame;
mod overlay;
mod pipelines;
mod readback;
mod targets;
mod types;

use buffers::Buffers;
use frame::FramePasses;
use overlay::Overlay;
use pipelines::{Pipelines, SceneBinds};
use readback::read_buffer;
pub(crate) use readback::read_texture;
use targets::Targets;
use types::CameraUniform;
pub(crate) use types::LineVertex;
pub use types::Shading;

/// Which triangle-id image to read back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IdImage {
    /// Every triangle drawn.
    Full,
    /// Only the triangles of the last frame's culled set (the full image if nothing was culled).
    Culled,
}

/// What the GPU measured in one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpuFrame {
    /// Pixels whose triangle differs between the culled and the full image.
    pub popping_pixels: u32,
    /// Pixels covered by some triangle in the full image.
    pub covered_pixels: u32,
}

/// The renderer. See the module documentation.
pub struct Renderer {
    device: Device,
    queue: Queue,
    triangle_count: u32,
    /// Scene geometry, camera, counters, drawn set and wireframe.
    buffers: Buffers,
    /// Indices of the drawn set in `buffers.indices`.
    index_count: u32,
    /// Vertices of the guides' lines in `buffers.lines`.
    line_count: u32,
    /// Vertices of the guides' triangles in `buffers.fills`.
    fill_count: u32,
    pipelines: Pipelines,
    binds: SceneBinds,
    targets: Targets,
    /// Whether the last frame drew a culled set (else the culled image is the full one).
    culled_last: bool,
    /// The colour targets' format (the overlay pipeline is made for it).
    color_format: TextureFormat,
    /// The overlay pass, made when an overlay is first drawn.
    overlay: Option<Overlay>,
}

impl Renderer {
    /// A renderer of `scene` into colour targets of `color_format`, `width x height` pixels.
    ///
    /// Fails when the scene does not fit the device's buffer limits.
    pub fn new(
        device: &Device,
        queue: &Queue,
        scene: &Scene,
        color_format: TextureFormat,
        width: u32,
        height: u32,
    ) -> Result<Self, ViewError> {
        let buffers = Buffers::new(device, scene)?;
        let pipelines = Pipelines::new(device, color_format);
        let binds = SceneBinds::new(device, &pipelines, &buffers);
        let targets = Targets::new(device, &buffers, &pipelines, width, height);
        Ok(Self {
            device: device.clone(),
            queue: queue.clone(),
            triangle_count: scene.triangle_count() as u32,
            buffers,
            index_count: 0,
            line_count: 0,
            fill_count: 0,
            pipelines,
            binds,
            targets,
            culled_last: false,
            color_format,
            overlay: None,
        })
    }

    /// The size of the images, `(width, height)`.
    pub fn size(&self) -> (u32, u32) {
        (self.targets.width, self.targets.height)
    }

    /// Resizes the id and depth images (a no-op at the current size).
    pub fn resize(&mut self, width: u32, height: u32) {
        if (width.max(1), height.max(1)) == self.size() {
            return;
        }
        self.targets = Targets::new(&self.device, &self.buffers, &self.pipelines, width, height);
        self.culled_last = false;
    }

    /// Sets the guides: `lines`, pairs of line endpoints, and `fills`, triples of triangle
    /// corners, with their colours.
    pub(crate) fn set_guides(&mut self, lines: &[LineVertex], fills: &[LineVertex]) {
        self.buffers
            .write_guides(&self.device, &self.queue, lines, fills);
        self.line_count = lines.len() as u32;
        self.fill_count = (fills.len() - fills.len() % 3) as u32;
    }

    /// Renders one frame from `camera` (whose size must be the renderer's) into `target`, a
    /// view of a texture of the colour format given at creation and the renderer's size.
    /// `drawn` is the set of triangles the method draws; `None` draws everything.
    /// Blocks until the GPU has counted the popping pixels.
    ///
    /// Steps: write the camera and the drawn set, encode the passes (`frame.rs`), copy
    /// the counters, submit, read the counters back.
    pub fn render(
        &mut self,
        camera: &Camera,
        drawn: Option<&TriangleSet>,
        shading: Shading,
        target: &wgpu::TextureView,
    ) -> Result<GpuFrame, ViewError> {
        self.render_view(&ViewCamera::Perspective(*camera), drawn, shading, target)
    }

    /// [`Renderer::render`] through either camera: the overview draws through its
    /// orthographic one. The popping count compares the two id images of that camera.
    pub fn render_view(
        &mut self,
        camera: &ViewCamera,
        drawn: Option<&TriangleSet>,
        shading: Shading,
        target: &wgpu::TextureView,
    ) -> Result<GpuFrame, ViewError> {
        if camera.size() != self.size() {
            return Err(ViewError::SizeMismatch {
                camera: camera.size(),
                renderer: self.size(),
            });
        }
        self.queue.write_buffer(
            &self.buffers.camera,
            0,
            bytemuck::bytes_of(&CameraUniform::new(camera, shading)),
        );
        // The drawn set as bits (for the x-ray tint) and as an index list (for the culled pass).
        self.index_count = self.buffers.upload_drawn(
            &self.device,
            &self.queue,
            drawn,
            self.triangle_count as usize,
        );
        let culled = drawn.is_some();
        self.culled_last = culled;

        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("view frame"),
            });
        let passes = FramePasses {
            pipelines: &self.pipelines,
            binds: &self.binds,
            buffers: &self.buffers,
            targets: &self.targets,
            triangle_count: self.triangle_count,
            index_count: self.index_count,
            line_count: self.line_count,
            fill_count: self.fill_count,
        };
        passes.encode(&mut encoder, target, culled, shading.xray);
        let buffers = &self.buffers;
        encoder.copy_buffer_to_buffer(&buffers.counters, 0, &buffers.counters_read, 0, 16);
        self.queue.submit([encoder.finish()]);
        let counts = read_buffer(&self.device, &buffers.counters_read, 16)?;
        let word = |i: usize| {
            let mut b = [0u8; 4];
            b.copy_from_slice(&counts[i * 4..i * 4 + 4]);
            u32::from_ne_bytes(b)
        };
        Ok(GpuFrame {
            popping_pixels: if culled { word(0) } else { 0 },
            covered_pixels: if culled { word(1) } else { 0 },
        })
    }

    /// Blends `rgba` (`size.0 x size.1` pixels of 8-bit RGBA, straight alpha, row-major with
    /// the top row first) over the top-left corner of `target`, a colour target as in
    /// [`Renderer::render`] that holds a rendered frame: the HUD. Opaque pixels replace the
    /// frame's; what lies outside `target` is clipped. Submits its own pass.
    ///
    /// # Panics
    /// In debug builds, when `rgba` does not hold `size.0 * size.1` pixels.
    pub fn draw_overlay(&mut self, target: &wgpu::TextureView, rgba: &[u8], size: (u32, u32)) {
        let overlay = self
            .overlay
            .get_or_insert_with(|| Overlay::new(&self.device, self.color_format));
        overlay.draw(&self.device, &self.queue, target, rgba, size);
    }

    /// Reads back an id image of the last frame: per pixel, row-major, top row first, the
    /// triangle id or [`Hit::NONE`] for background (the convention of
    /// [`sightline_core::raster::Frame::ids`]).
    pub fn read_ids(&self, which: IdImage) -> Result<Vec<u32>, ViewError> {
        let texture = match which {
            IdImage::Culled if self.culled_last => &self.targets.ids_culled,
            _ => &self.targets.ids_full,
        };
        let raw = read_texture(&self.device, &self.queue, texture, 4)?;
        Ok(raw
            .chunks_exact(4)
            .map(|b| {
                let v = u32::from_ne_bytes([b[0], b[1], b[2], b[3]]);
                if v == 0 {
                    Hit::NONE
                } else {
                    v - 1
                }
            })
            .collect())
    }
}
