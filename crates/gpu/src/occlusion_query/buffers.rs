//! GPU memory sized by what a submission holds: the buffers the recorded occluders, translations
//! and query boxes are uploaded into, the buffers the sample counts are resolved and read back
//! through, and the depth target and query sets (Seletsky 2013, sections 2.4 and 4.3.2). All of
//! them grow when a submission needs more and are kept from frame to frame.

use sightline_core::Camera;
use wgpu::{Device, Queue};

use super::types::{Recording, DEPTH_FORMAT, QUERIES_PER_SET};

/// A buffer that grows (to the next power of two) when a submission needs more room.
pub(super) struct GrowBuffer {
    /// The buffer itself, `capacity` bytes.
    pub(super) buffer: wgpu::Buffer,
    capacity: u64,
    usage: wgpu::BufferUsages,
    label: &'static str,
}

impl GrowBuffer {
    /// A buffer of at least `bytes` (and at least 256) bytes, rounded up to a power of two.
    fn new(device: &Device, label: &'static str, usage: wgpu::BufferUsages, bytes: u64) -> Self {
        let capacity = bytes.max(256).next_power_of_two();
        Self {
            buffer: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: capacity,
                usage,
                mapped_at_creation: false,
            }),
            capacity,
            usage,
            label,
        }
    }

    /// Replaces the buffer by a larger one (contents not kept) when `bytes` do not fit.
    fn reserve(&mut self, device: &Device, bytes: u64) {
        if bytes > self.capacity {
            *self = Self::new(device, self.label, self.usage, bytes);
        }
    }
}

/// The per-submission buffers.
pub(super) struct FrameBuffers {
    /// Occluder corners of `draw_depth` (re-uploaded each submission).
    pub(super) vertices: GrowBuffer,
    /// Per-draw translations (slot 0 zero).
    pub(super) translations: GrowBuffer,
    /// Query boxes, one instance each.
    pub(super) boxes: GrowBuffer,
    /// Where the query sets resolve their sample counts.
    pub(super) resolve: GrowBuffer,
    /// The mappable copy of `resolve`.
    pub(super) readback: GrowBuffer,
}

impl FrameBuffers {
    /// Empty (256-byte) buffers of each kind.
    pub(super) fn new(device: &Device) -> Self {
        use wgpu::BufferUsages as U;
        Self {
            vertices: GrowBuffer::new(device, "sightline occluders", U::VERTEX | U::COPY_DST, 0),
            translations: GrowBuffer::new(
                device,
                "sightline translations",
                U::VERTEX | U::COPY_DST,
                0,
            ),
            boxes: GrowBuffer::new(device, "sightline boxes", U::VERTEX | U::COPY_DST, 0),
            resolve: GrowBuffer::new(
                device,
                "sightline resolve",
                U::QUERY_RESOLVE | U::COPY_SRC,
                0,
            ),
            readback: GrowBuffer::new(device, "sightline readback", U::MAP_READ | U::COPY_DST, 0),
        }
    }

    /// Grows the buffers to what `recording` and `result_bytes` of sample counts need, and
    /// queues the writes of the recorded vertices, translations and boxes.
    pub(super) fn upload(
        &mut self,
        device: &Device,
        queue: &Queue,
        recording: &Recording,
        result_bytes: u64,
    ) {
        self.resolve.reserve(device, result_bytes);
        self.readback.reserve(device, result_bytes);
        let vertex_bytes: &[u8] = bytemuck::cast_slice(&recording.vertices);
        self.vertices.reserve(device, vertex_bytes.len() as u64);
        let translation_bytes: &[u8] = bytemuck::cast_slice(&recording.translations);
        self.translations
            .reserve(device, translation_bytes.len() as u64);
        queue.write_buffer(&self.translations.buffer, 0, translation_bytes);
        let box_bytes: &[u8] = bytemuck::cast_slice(&recording.boxes);
        self.boxes.reserve(device, box_bytes.len() as u64);
        if !vertex_bytes.is_empty() {
            queue.write_buffer(&self.vertices.buffer, 0, vertex_bytes);
        }
        queue.write_buffer(&self.boxes.buffer, 0, box_bytes);
    }
}

/// The depth target (of the camera's size) and the occlusion query sets.
pub(super) struct FrameTargets {
    /// Width, height and view of the depth target, once made.
    depth: Option<(u32, u32, wgpu::TextureView)>,
    /// Query sets of [`QUERIES_PER_SET`] queries each, as many as a submission has needed.
    pub(super) query_sets: Vec<wgpu::QuerySet>,
}

impl FrameTargets {
    /// No depth target and no query sets yet.
    pub(super) fn new() -> Self {
        Self {
            depth: None,
            query_sets: Vec::new(),
        }
    }

    /// Makes the depth target again when `camera`'s size differs from it, and adds query sets
    /// until there are `n_sets`.
    pub(super) fn prepare(&mut self, device: &Device, camera: &Camera, n_sets: u32) {
        let (w, h) = (camera.width.max(1), camera.height.max(1));
        if !matches!(&self.depth, Some((dw, dh, _)) if *dw == w && *dh == h) {
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("sightline depth"),
                size: wgpu::Extent3d {
                    width: w,
                    height: h,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: DEPTH_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            });
            self.depth = Some((w, h, texture.create_view(&Default::default())));
        }
        while self.query_sets.len() < n_sets as usize {
            self.query_sets
                .push(device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("sightline occlusion queries"),
                    ty: wgpu::QueryType::Occlusion,
                    count: QUERIES_PER_SET,
                }));
        }
    }

    /// The depth target's view, once [`FrameTargets::prepare`] has made it.
    pub(super) fn depth_view(&self) -> Option<&wgpu::TextureView> {
        self.depth.as_ref().map(|(_, _, view)| view)
    }
}
