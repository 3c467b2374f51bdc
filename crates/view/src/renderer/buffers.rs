//! The renderer's buffers: the scene's vertices and per-triangle shading data (uploaded once,
//! after checking that they fit the device), the camera uniform, the popping counters and
//! their readback copy, and the drawn set (bits and index list) and the guides (lines and
//! filled triangles), written when they change.

use sightline_core::{Scene, TriangleSet};
use wgpu::{Device, Queue};

use super::types::{CameraUniform, LineVertex};
use crate::error::ViewError;

/// Every buffer of the renderer.
pub(super) struct Buffers {
    /// Corners expanded per triangle (triangle id = vertex index / 3).
    pub(super) vertices: wgpu::Buffer,
    /// Per triangle: face normal and object id, for the flat shading (read by the resolve
    /// pass's scene bind group).
    pub(super) triangles: wgpu::Buffer,
    /// One bit per triangle: drawn by the method this frame (for the x-ray tint).
    pub(super) drawn_bits: wgpu::Buffer,
    /// The [`CameraUniform`].
    pub(super) camera: wgpu::Buffer,
    /// The compare pass's counters: popping pixels, covered pixels.
    pub(super) counters: wgpu::Buffer,
    /// The mappable copy of `counters`.
    pub(super) counters_read: wgpu::Buffer,
    /// Index list of the drawn triangles (the culled id pass); grows.
    pub(super) indices: wgpu::Buffer,
    /// The guides' [`LineVertex`] pairs; grows.
    pub(super) lines: wgpu::Buffer,
    /// The guides' filled triangles, three [`LineVertex`] each; grows.
    pub(super) fills: wgpu::Buffer,
}

impl Buffers {
    /// Checks that `scene` fits the device's limits, then uploads its geometry and makes the
    /// other buffers at their initial sizes.
    pub(super) fn new(device: &Device, scene: &Scene) -> Result<Self, ViewError> {
        check_fits(device, scene.triangle_count())?;
        let (corners, info) = scene_geometry(scene);
        Ok(Self::create(
            device,
            &corners,
            &info,
            scene.triangle_count(),
        ))
    }

    /// Makes every buffer: `corners` and `info` uploaded, the others sized for `n` triangles
    /// or at their smallest.
    fn create(device: &Device, corners: &[[f32; 3]], info: &[[f32; 4]], n: usize) -> Self {
        use wgpu::util::DeviceExt;
        use wgpu::BufferUsages as U;
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("view vertices"),
            contents: bytemuck::cast_slice(corners),
            usage: U::VERTEX,
        });
        let triangles = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("view triangles"),
            contents: bytemuck::cast_slice(info),
            usage: U::STORAGE,
        });
        let empty = |label, size, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        Self {
            vertices,
            triangles,
            drawn_bits: empty(
                "view drawn bits",
                (n.div_ceil(32).max(1) * 4) as u64,
                U::STORAGE | U::COPY_DST,
            ),
            camera: empty(
                "view camera",
                std::mem::size_of::<CameraUniform>() as u64,
                U::UNIFORM | U::COPY_DST,
            ),
            counters: empty("view counters", 16, U::STORAGE | U::COPY_DST | U::COPY_SRC),
            counters_read: empty("view counters readback", 16, U::MAP_READ | U::COPY_DST),
            indices: empty("view culled indices", 4, U::INDEX | U::COPY_DST),
            lines: empty(
                "view guide lines",
                std::mem::size_of::<LineVertex>() as u64,
                U::VERTEX | U::COPY_DST,
            ),
            fills: empty(
                "view guide fills",
                std::mem::size_of::<LineVertex>() as u64,
                U::VERTEX | U::COPY_DST,
            ),
        }
    }

    /// Writes the drawn set of `n` triangles (`None`: all) as bits and, when culled, as an
    /// index list (growing the index buffer), and zeroes the counters. Returns the number of
    /// indices of the culled pass (0 when nothing is culled).
    pub(super) fn upload_drawn(
        &mut self,
        device: &Device,
        queue: &Queue,
        drawn: Option<&TriangleSet>,
        n: usize,
    ) -> u32 {
        let mut bits = vec![0u32; n.div_ceil(32).max(1)];
        let index_count = match drawn {
            Some(set) => {
                let mut index_data: Vec<u32> = Vec::with_capacity(set.count_ones(..) * 3);
                for t in set.ones().filter(|&t| t < n) {
                    bits[t / 32] |= 1 << (t % 32);
                    let v = t as u32 * 3;
                    index_data.extend([v, v + 1, v + 2]);
                }
                self.write_indices(device, queue, &index_data);
                index_data.len() as u32
            }
            None => {
                for t in 0..n {
                    bits[t / 32] |= 1 << (t % 32);
                }
                0
            }
        };
        queue.write_buffer(&self.drawn_bits, 0, bytemuck::cast_slice(&bits));
        queue.write_buffer(&self.counters, 0, &[0u8; 16]);
        index_count
    }

    /// Writes `index_data` into the index buffer, first growing it (to the next power of two)
    /// when it is too small.
    fn write_indices(&mut self, device: &Device, queue: &Queue, index_data: &[u32]) {
        let bytes = (index_data.len() * 4) as u64;
        if bytes > self.indices.size() {
            self.indices = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("view culled indices"),
                size: bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
        }
        if !index_data.is_empty() {
            queue.write_buffer(&self.indices, 0, bytemuck::cast_slice(index_data));
        }
    }

    /// Writes the guides' `lines` and filled triangles `fills`.
    pub(super) fn write_guides(
        &mut self,
        device: &Device,
        queue: &Queue,
        lines: &[LineVertex],
        fills: &[LineVertex],
    ) {
        write_vertices(device, queue, &mut self.lines, "view guide lines", lines);
        write_vertices(device, queue, &mut self.fills, "view guide fills", fills);
    }
}

/// Writes `data` into the vertex buffer `buffer`, first growing it (to the next power of two)
/// when it is too small.
fn write_vertices(
    device: &Device,
    queue: &Queue,
    buffer: &mut wgpu::Buffer,
    label: &str,
    data: &[LineVertex],
) {
    let bytes = std::mem::size_of_val(data) as u64;
    if bytes > buffer.size() {
        *buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.next_power_of_two(),
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
    }
    if !data.is_empty() {
        queue.write_buffer(buffer, 0, bytemuck::cast_slice(data));
    }
}

/// Errors when `n` triangles do not fit the device: their expanded corners (36 bytes each) in
/// one buffer, their shading data (16 bytes each) in one storage binding, their vertex
/// indices in a `u32`.
fn check_fits(device: &Device, n: usize) -> Result<(), ViewError> {
    let limits = device.limits();
    let vertex_bytes = n as u64 * 36;
    let info_bytes = n as u64 * 16;
    if n > (u32::MAX / 3) as usize
        || vertex_bytes > limits.max_buffer_size
        || info_bytes > limits.max_storage_buffer_binding_size
    {
        return Err(ViewError::SceneTooLarge {
            triangles: n,
            max_buffer_bytes: limits.max_buffer_size,
        });
    }
    Ok(())
}

/// Corners expanded per triangle (id = vertex index / 3), and per triangle its face normal and
/// object id for the flat shading. Neither is empty (a zero entry stands in for an empty scene:
/// wgpu buffers and bindings may not be empty).
fn scene_geometry(scene: &Scene) -> (Vec<[f32; 3]>, Vec<[f32; 4]>) {
    let n = scene.triangle_count();
    let mut corners: Vec<[f32; 3]> = Vec::with_capacity(n * 3);
    let mut info: Vec<[f32; 4]> = Vec::with_capacity(n.max(1));
    for t in 0..n {
        let [a, b, c] = scene.triangle(t as u32);
        corners.extend([a.to_array(), b.to_array(), c.to_array()]);
        let normal = (b - a).cross(c - a).normalize_or_zero();
        let object = scene.object_of_triangle.get(t).copied().unwrap_or(0);
        info.push([normal.x, normal.y, normal.z, f32::from_bits(object)]);
    }
    if info.is_empty() {
        info.push([0.0; 4]);
    }
    if corners.is_empty() {
        corners.push([0.0; 3]);
    }
    (corners, info)
}
