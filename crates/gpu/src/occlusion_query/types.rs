//! Shared records of the occlusion-query backend: the answers ([`QueryOutcome`], [`MeshId`]),
//! what the CPU records between submissions ([`Recording`], [`Command`], [`BoxInstance`]), the
//! camera as the shader reads it, the unit cube and the constants every step uses.
//!
//! A leaf module: it imports none of its siblings, so all of them (and the module face) can
//! import it without an import circle.

use glam::Vec3;
use sightline_core::Camera;

/// Queries per query set: wgpu's limit. Frames with more queries use several query sets, one
/// render pass each, the depth buffer carried from pass to pass.
pub(super) const QUERIES_PER_SET: u32 = wgpu::QUERY_SET_MAX_QUERIES;
/// The depth format of both pipelines and of the depth target (reversed-Z, see the module
/// documentation).
pub(super) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The answer to one query.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QueryOutcome {
    /// Samples of the box that passed the depth test on the GPU (visible when > 0).
    Samples(u64),
    /// The box reaches in front of the near plane: visible, not sent to the GPU.
    NearPlane,
    /// The box lies entirely in front of the near plane (behind the camera): hidden.
    BehindCamera,
    /// Not answered (yet, or the GPU failed): visible, conservatively.
    Pending,
}

impl QueryOutcome {
    /// Whether the box counts as visible.
    pub fn is_visible(self) -> bool {
        match self {
            QueryOutcome::Samples(n) => n > 0,
            QueryOutcome::NearPlane | QueryOutcome::Pending => true,
            QueryOutcome::BehindCamera => false,
        }
    }
}

/// The camera as the shader reads it (`Camera` in `occlusion_query.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct CameraUniform {
    eye: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    forward: [f32; 4],
    /// `(1 / tan_half_x, 1 / tan_half_y, near, 0)`.
    projection: [f32; 4],
}

impl CameraUniform {
    /// The uniform block of camera `c`.
    pub(super) fn new(c: &Camera) -> Self {
        let v4 = |v: Vec3| [v.x, v.y, v.z, 0.0];
        Self {
            eye: v4(c.eye),
            right: v4(c.right),
            up: v4(c.up),
            forward: v4(c.forward),
            projection: [1.0 / c.tan_half_x(), 1.0 / c.tan_half_y(), c.near, 0.0],
        }
    }
}

/// One query box as a vertex-shader instance.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct BoxInstance {
    pub(super) min: [f32; 3],
    pub(super) max: [f32; 3],
}

/// A mesh uploaded once with [`GpuBackend::upload_mesh`], drawn with [`GpuBackend::draw_mesh`].
///
/// [`GpuBackend::upload_mesh`]: crate::GpuBackend::upload_mesh
/// [`GpuBackend::draw_mesh`]: crate::GpuBackend::draw_mesh
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MeshId(pub(super) u32);

/// A recorded command, replayed in order into the render pass(es).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Command {
    /// Occluder vertices `first..first + count` of this submission (translation slot 0, zero).
    Depth { first: u32, count: u32 },
    /// An uploaded mesh with translation slot `instance` of this submission.
    Mesh { mesh: u32, instance: u32 },
    /// Query number `index` of this submission (its box is instance `index`).
    Query { index: u32 },
}

/// Unit-cube corners (each coordinate 0 or 1) and its 12 triangles.
pub(super) const CUBE_CORNERS: [[f32; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [1.0, 1.0, 1.0],
];
/// Indices into [`CUBE_CORNERS`], two triangles per face.
pub(super) const CUBE_INDICES: [u16; 36] = [
    0, 2, 1, 1, 2, 3, // z = 0
    4, 5, 6, 5, 7, 6, // z = 1
    0, 1, 4, 1, 5, 4, // y = 0
    2, 6, 3, 3, 6, 7, // y = 1
    0, 4, 2, 2, 4, 6, // x = 0
    1, 3, 5, 3, 7, 5, // x = 1
];

/// What was recorded since the last submission: the commands in order and the data they draw.
/// Kept apart from the backend's GPU objects so that the upload and the passes read one value.
pub(super) struct Recording {
    /// Occluder corners of [`Command::Depth`] draws, three per triangle.
    pub(super) vertices: Vec<[f32; 3]>,
    /// Per-draw translations of this submission; slot 0 is zero, for `draw_depth` triangles.
    pub(super) translations: Vec<[f32; 3]>,
    /// Query boxes, one instance per [`Command::Query`].
    pub(super) boxes: Vec<BoxInstance>,
    /// The commands, replayed in this order.
    pub(super) commands: Vec<Command>,
}

impl Recording {
    /// An empty recording (translation slot 0 already holds the zero translation).
    pub(super) fn new() -> Self {
        Self {
            vertices: Vec::new(),
            translations: vec![[0.0; 3]],
            boxes: Vec::new(),
            commands: Vec::new(),
        }
    }

    /// Forgets the recorded commands and their data (after a submission or a new frame).
    pub(super) fn clear(&mut self) {
        self.vertices.clear();
        self.translations.clear();
        self.translations.push([0.0; 3]);
        self.boxes.clear();
        self.commands.clear();
    }
}
