//! The hardware-occlusion-query backend: occluders rendered into a depth buffer by a depth-only
//! render pipeline, cell or object boxes tested by a second pipeline with colour and depth
//! writes off, each box inside its own `QueryType::Occlusion` query; the sample counts are
//! resolved into a buffer and read back once per frame, and used by the caller in the next
//! frame.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, sections 2.4 (an occlusion query counts the samples of a bounding box that pass
//! the depth test; colour and depth writes are off while the box is drawn), 2.4.1 (CPU stalls
//! when results are read too early) and 4.3.2 (the depth pre-pass of last frame's visible cells
//! interleaved with the queries in traversal order; cell query results queued and gathered for
//! the next frame with a blocking read, which the thesis accepts).
//!
//! # Conventions
//! - The camera of [`sightline_core::camera`]: pixel `(x, y)` is sampled at its centre (Vulkan
//!   samples single-sample targets at pixel centres), image `+y` points down (wgpu's NDC `+y`
//!   is up and its framebuffer `+y` down, so the shader's mapping is exactly
//!   `Camera::view_to_screen`), no far plane.
//! - Depth is **reversed-Z with an infinite far plane** in `Depth32Float`: the stored value is
//!   `near / z` for view depth `z`, 1 at the near plane and 0 at infinity, cleared to 0, larger
//!   is nearer. Floats are densest near 0, which balances the `1/z` distribution, so relative
//!   depth precision is about 2^-24 at every distance. Occluders pass with `Greater`; query
//!   boxes with `GreaterEqual`, so a box face exactly at an occluder's depth (an object on its
//!   cell's boundary) counts as visible.
//! - Both pipelines draw double-sided triangles (no face culling), like the reference
//!   rasterizer.
//!
//! # Geometry upload
//! - Query boxes: the unit cube is uploaded once; per query only its box (two `vec3`s) is an
//!   instance.
//! - Static occluders (and dynamic ones that move rigidly): [`GpuBackend::upload_mesh`] uploads
//!   a mesh once; [`GpuBackend::draw_mesh`] draws it with a per-draw translation, an instance
//!   attribute of 12 bytes. Translations are the motion the culling scenes have (objects move by
//!   offsets); rotations would need a matrix per instance in the same place.
//! - [`OcclusionBackend::draw_depth`] receives world-space triangles of objects that may have
//!   moved and does not say which are static, so those vertices are re-uploaded each frame (one
//!   `write_buffer` per submission into a buffer that only grows). The simulation of
//!   `sightline-cull` uses this path.
//!
//! # Latency and readback
//! Commands are recorded on the CPU during the frame and submitted as one command buffer when
//! results are asked for ([`OcclusionBackend::take_results`], or [`GpuBackend::finish_frame`]).
//! That call waits for the GPU and maps the resolved counts, so results of frame `n` are
//! returned at the end of frame `n` and used by the scheduler in frame `n + 1` (the simulation's
//! `latency = 1`, as in the thesis). Asked for after every query (`latency = 0`), each query is
//! its own submission: the stop-and-wait baseline. The wait at the end of the frame is the
//! thesis' blocking read moved forward by the colour pass: a renderer that submits its colour
//! pass in between would rather wait at the start of frame `n + 1`, which the trait cannot
//! express yet (one `take_results` call does both submission and readback).
//!
//! # Boxes at the near plane
//! A box with a corner nearer than the near plane (view depth `< near`) and one beyond it is
//! reported visible without a query (the camera may be inside it, and its clipped faces could
//! miss samples), and a box entirely nearer than the near plane (behind the camera) hidden, as
//! the software backend does.

use std::sync::mpsc;
use std::time::Instant;

use glam::Vec3;
use sightline_core::{Aabb, Camera};
use sightline_cull::OcclusionBackend;
use wgpu::util::DeviceExt;
use wgpu::{AdapterInfo, Device, Queue};

use crate::device::{vulkan_device, GpuError};

/// Queries per query set: wgpu's limit. Frames with more queries use several query sets, one
/// render pass each, the depth buffer carried from pass to pass.
const QUERIES_PER_SET: u32 = wgpu::QUERY_SET_MAX_QUERIES;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

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
struct CameraUniform {
    eye: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    forward: [f32; 4],
    /// `(1 / tan_half_x, 1 / tan_half_y, near, 0)`.
    projection: [f32; 4],
}

impl CameraUniform {
    fn new(c: &Camera) -> Self {
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
struct BoxInstance {
    min: [f32; 3],
    max: [f32; 3],
}

/// A mesh uploaded once with [`GpuBackend::upload_mesh`], drawn with [`GpuBackend::draw_mesh`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MeshId(u32);

/// A recorded command, replayed in order into the render pass(es).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Command {
    /// Occluder vertices `first..first + count` of this submission (translation slot 0, zero).
    Depth { first: u32, count: u32 },
    /// An uploaded mesh with translation slot `instance` of this submission.
    Mesh { mesh: u32, instance: u32 },
    /// Query number `index` of this submission (its box is instance `index`).
    Query { index: u32 },
}

/// Unit-cube corners (each coordinate 0 or 1) and its 12 triangles.
const CUBE_CORNERS: [[f32; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [1.0, 1.0, 1.0],
];
const CUBE_INDICES: [u16; 36] = [
    0, 2, 1, 1, 2, 3, // z = 0
    4, 5, 6, 5, 7, 6, // z = 1
    0, 1, 4, 1, 5, 4, // y = 0
    2, 6, 3, 3, 6, 7, // y = 1
    0, 4, 2, 2, 4, 6, // x = 0
    1, 3, 5, 3, 7, 5, // x = 1
];

/// A buffer that grows (to the next power of two) when a submission needs more room.
struct GrowBuffer {
    buffer: wgpu::Buffer,
    capacity: u64,
    usage: wgpu::BufferUsages,
    label: &'static str,
}

impl GrowBuffer {
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

    fn reserve(&mut self, device: &Device, bytes: u64) {
        if bytes > self.capacity {
            *self = Self::new(device, self.label, self.usage, bytes);
        }
    }
}

/// The hardware-occlusion-query backend. See the module documentation for its conventions.
///
/// ```no_run
/// use glam::Vec3;
/// use sightline_core::{Aabb, Camera};
/// use sightline_cull::OcclusionBackend;
/// use sightline_gpu::GpuBackend;
///
/// let mut gpu = GpuBackend::new()?;
/// let cam = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 128, 128, 0.1).unwrap();
/// gpu.begin_frame(&cam);
/// let (a, b, c, d) = (
///     Vec3::new(-50.0, -50.0, -5.0), Vec3::new(50.0, -50.0, -5.0),
///     Vec3::new(50.0, 50.0, -5.0), Vec3::new(-50.0, 50.0, -5.0),
/// );
/// gpu.draw_depth(&[a, b, c, a, c, d]);
/// gpu.query(1, &Aabb::new(Vec3::new(-1.0, -1.0, -12.0), Vec3::new(1.0, 1.0, -10.0)));
/// gpu.query(2, &Aabb::new(Vec3::new(-1.0, -1.0, -4.0), Vec3::new(1.0, 1.0, -3.0)));
/// let mut results = Vec::new();
/// gpu.take_results(&mut results);
/// assert_eq!(results, vec![(1, false), (2, true)]);
/// # Ok::<(), sightline_gpu::GpuError>(())
/// ```
pub struct GpuBackend {
    device: Device,
    queue: Queue,
    info: AdapterInfo,
    camera_buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    depth_pipeline: wgpu::RenderPipeline,
    query_pipeline: wgpu::RenderPipeline,
    cube_corners: wgpu::Buffer,
    cube_indices: wgpu::Buffer,
    vertex_buffer: GrowBuffer,
    translation_buffer: GrowBuffer,
    box_buffer: GrowBuffer,
    /// Uploaded meshes: vertex buffer and vertex count.
    meshes: Vec<(wgpu::Buffer, u32)>,
    resolve_buffer: GrowBuffer,
    readback_buffer: GrowBuffer,
    query_sets: Vec<wgpu::QuerySet>,
    depth: Option<(u32, u32, wgpu::TextureView)>,

    // The frame being recorded.
    camera: Option<Camera>,
    /// The depth buffer was cleared by an earlier submission of this frame.
    depth_started: bool,
    vertices: Vec<[f32; 3]>,
    /// Per-draw translations of this submission; slot 0 is zero, for `draw_depth` triangles.
    translations: Vec<[f32; 3]>,
    boxes: Vec<BoxInstance>,
    commands: Vec<Command>,
    /// Slot in `outcomes` of each GPU query of this submission, by query index.
    query_slots: Vec<usize>,
    /// Answers of this frame so far, in issue order (`Pending` until read back).
    outcomes: Vec<(u32, QueryOutcome)>,
    /// Results not yet taken by [`OcclusionBackend::take_results`].
    ready_from: usize,

    stats: GpuFrameStats,
}

/// Counters of the last frame, for reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuFrameStats {
    /// Queries sent to the GPU.
    pub gpu_queries: u32,
    /// Queries answered on the CPU (boxes at or behind the near plane).
    pub cpu_answers: u32,
    /// Occluder triangles drawn.
    pub triangles: u32,
    /// Command-buffer submissions (1 per frame with `latency = 1`).
    pub submissions: u32,
    /// Milliseconds spent in submission and readback waits.
    pub wait_ms: f64,
}

impl GpuBackend {
    /// A backend on a freshly acquired Vulkan device (see [`vulkan_device`]).
    pub fn new() -> Result<Self, GpuError> {
        let (device, queue, info) = vulkan_device()?;
        Ok(Self::with_device(&device, &queue, info))
    }

    /// A backend on a caller's device (tests share one; a renderer passes its own).
    pub fn with_device(device: &Device, queue: &Queue, info: AdapterInfo) -> Self {
        let shader = device.create_shader_module(wgpu::include_wgsl!("occlusion_query.wgsl"));
        let camera_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sightline camera"),
            size: std::mem::size_of::<CameraUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sightline camera"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sightline camera"),
            layout: &bind_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: camera_buffer.as_entire_binding(),
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("sightline occlusion"),
            bind_group_layouts: &[Some(&bind_layout)],
            immediate_size: 0,
        });
        let vec3_at = |location: u32, offset: u64| wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset,
            shader_location: location,
        };
        let position_attr = [vec3_at(0, 0)];
        let translation_attr = [vec3_at(1, 0)];
        let box_attrs = [vec3_at(1, 0), vec3_at(2, 12)];
        let triangles_layout = wgpu::VertexBufferLayout {
            array_stride: 12,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &position_attr,
        };
        let boxes_layout = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<BoxInstance>() as u64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &box_attrs,
        };
        let pipeline = |label, entry, buffers: &[Option<wgpu::VertexBufferLayout>], write, cmp| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(write),
                    depth_compare: Some(cmp),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                // No fragment stage and no colour target: depth-only. Occlusion queries count
                // samples passing the depth test, which needs no fragment shader.
                fragment: None,
                multiview_mask: None,
                cache: None,
            })
        };
        let depth_pipeline = pipeline(
            "sightline depth pre-pass",
            "vs_depth",
            &[
                Some(triangles_layout),
                Some(wgpu::VertexBufferLayout {
                    array_stride: 12,
                    step_mode: wgpu::VertexStepMode::Instance,
                    attributes: &translation_attr,
                }),
            ],
            true,
            wgpu::CompareFunction::Greater,
        );
        let query_pipeline = pipeline(
            "sightline query boxes",
            "vs_box",
            &[
                Some(wgpu::VertexBufferLayout {
                    array_stride: 12,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &position_attr,
                }),
                Some(boxes_layout),
            ],
            false,
            wgpu::CompareFunction::GreaterEqual,
        );
        let cube_corners = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("sightline unit cube"),
            contents: bytemuck::cast_slice(&CUBE_CORNERS),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let cube_indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("sightline unit cube indices"),
            contents: bytemuck::cast_slice(&CUBE_INDICES),
            usage: wgpu::BufferUsages::INDEX,
        });
        use wgpu::BufferUsages as U;
        Self {
            vertex_buffer: GrowBuffer::new(
                device,
                "sightline occluders",
                U::VERTEX | U::COPY_DST,
                0,
            ),
            translation_buffer: GrowBuffer::new(
                device,
                "sightline translations",
                U::VERTEX | U::COPY_DST,
                0,
            ),
            box_buffer: GrowBuffer::new(device, "sightline boxes", U::VERTEX | U::COPY_DST, 0),
            meshes: Vec::new(),
            resolve_buffer: GrowBuffer::new(
                device,
                "sightline resolve",
                U::QUERY_RESOLVE | U::COPY_SRC,
                0,
            ),
            readback_buffer: GrowBuffer::new(
                device,
                "sightline readback",
                U::MAP_READ | U::COPY_DST,
                0,
            ),
            device: device.clone(),
            queue: queue.clone(),
            info,
            camera_buffer,
            bind_group,
            depth_pipeline,
            query_pipeline,
            cube_corners,
            cube_indices,
            query_sets: Vec::new(),
            depth: None,
            camera: None,
            depth_started: false,
            vertices: Vec::new(),
            translations: vec![[0.0; 3]],
            boxes: Vec::new(),
            commands: Vec::new(),
            query_slots: Vec::new(),
            outcomes: Vec::new(),
            ready_from: 0,
            stats: GpuFrameStats::default(),
        }
    }

    /// The adapter this backend runs on.
    pub fn adapter_info(&self) -> &AdapterInfo {
        &self.info
    }

    /// Counters of the current (or, after [`OcclusionBackend::begin_frame`], the last) frame.
    pub fn stats(&self) -> GpuFrameStats {
        self.stats
    }

    /// Uploads occluder triangles (three world-space corners each; a trailing partial triangle
    /// is ignored) once, for drawing in any later frame with [`GpuBackend::draw_mesh`].
    pub fn upload_mesh(&mut self, triangles: &[Vec3]) -> MeshId {
        let count = triangles.len() / 3 * 3;
        let corners: Vec<[f32; 3]> = triangles[..count].iter().map(|p| p.to_array()).collect();
        // An empty mesh still gets a (4-byte) buffer so that ids stay dense.
        let contents: &[u8] = if corners.is_empty() {
            &[0; 4]
        } else {
            bytemuck::cast_slice(&corners)
        };
        let buffer = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("sightline mesh"),
                contents,
                usage: wgpu::BufferUsages::VERTEX,
            });
        self.meshes.push((buffer, count as u32));
        MeshId(self.meshes.len() as u32 - 1)
    }

    /// Draws an uploaded mesh, moved by `translation`, into the depth buffer (like
    /// [`OcclusionBackend::draw_depth`], in order with the queries).
    pub fn draw_mesh(&mut self, mesh: MeshId, translation: Vec3) -> Result<(), GpuError> {
        let Some(&(_, count)) = self.meshes.get(mesh.0 as usize) else {
            return Err(GpuError::UnknownMesh(mesh.0));
        };
        if self.camera.is_none() || count == 0 {
            return Ok(());
        }
        let instance = self.translations.len() as u32;
        self.translations.push(translation.to_array());
        self.commands.push(Command::Mesh {
            mesh: mesh.0,
            instance,
        });
        self.stats.triangles += count / 3;
        Ok(())
    }

    /// Submits what was recorded since the last submission, waits for the query results and
    /// returns every answer of this frame so far, `(tag, outcome)` in issue order. Answers are
    /// also kept for [`OcclusionBackend::take_results`].
    pub fn finish_frame(&mut self) -> Result<&[(u32, QueryOutcome)], GpuError> {
        self.submit_and_read()?;
        Ok(&self.outcomes)
    }

    /// Forgets the recorded commands and their data (after a submission or a new frame).
    fn clear_recorded(&mut self) {
        self.vertices.clear();
        self.translations.clear();
        self.translations.push([0.0; 3]);
        self.boxes.clear();
        self.commands.clear();
    }

    fn submit_and_read(&mut self) -> Result<(), GpuError> {
        let start = Instant::now();
        let result = self.submit_and_read_inner();
        if result.is_err() {
            // Whatever was recorded is lost with the submission; its queries stay `Pending`
            // (visible).
            self.query_slots.clear();
            self.clear_recorded();
        }
        self.stats.wait_ms += start.elapsed().as_secs_f64() * 1e3;
        result
    }

    fn submit_and_read_inner(&mut self) -> Result<(), GpuError> {
        let n_queries = self.query_slots.len() as u32;
        if n_queries == 0 {
            // Nothing to answer. Occluders recorded so far stay recorded: a later query of this
            // frame must see them.
            return Ok(());
        }
        let Some(camera) = self.camera else {
            return Ok(());
        };
        let device = self.device.clone();
        // Depth target of the camera's size.
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
        let n_sets = n_queries.div_ceil(QUERIES_PER_SET);
        while self.query_sets.len() < n_sets as usize {
            self.query_sets
                .push(device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("sightline occlusion queries"),
                    ty: wgpu::QueryType::Occlusion,
                    count: QUERIES_PER_SET,
                }));
        }
        let result_bytes = u64::from(n_queries) * u64::from(wgpu::QUERY_SIZE);
        self.resolve_buffer.reserve(&device, result_bytes);
        self.readback_buffer.reserve(&device, result_bytes);
        let vertex_bytes: &[u8] = bytemuck::cast_slice(&self.vertices);
        self.vertex_buffer
            .reserve(&device, vertex_bytes.len() as u64);
        let translation_bytes: &[u8] = bytemuck::cast_slice(&self.translations);
        self.translation_buffer
            .reserve(&device, translation_bytes.len() as u64);
        self.queue
            .write_buffer(&self.translation_buffer.buffer, 0, translation_bytes);
        let box_bytes: &[u8] = bytemuck::cast_slice(&self.boxes);
        self.box_buffer.reserve(&device, box_bytes.len() as u64);
        if !vertex_bytes.is_empty() {
            self.queue
                .write_buffer(&self.vertex_buffer.buffer, 0, vertex_bytes);
        }
        self.queue
            .write_buffer(&self.box_buffer.buffer, 0, box_bytes);
        self.queue.write_buffer(
            &self.camera_buffer,
            0,
            bytemuck::bytes_of(&CameraUniform::new(&camera)),
        );

        let Some((_, _, depth_view)) = &self.depth else {
            return Ok(());
        };
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("sightline occlusion"),
        });
        let mut next = 0;
        for set in 0..n_sets {
            let load = if self.depth_started || set > 0 {
                wgpu::LoadOp::Load
            } else {
                // Reversed-Z: 0 is infinitely far.
                wgpu::LoadOp::Clear(0.0)
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("sightline occlusion"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load,
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: Some(&self.query_sets[set as usize]),
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.bind_group, &[]);
            // What is bound, to skip redundant state changes between consecutive draws.
            #[derive(PartialEq)]
            enum Bound {
                Nothing,
                Triangles,
                Mesh(u32),
                Boxes,
            }
            let mut bound = Bound::Nothing;
            while let Some(&command) = self.commands.get(next) {
                match command {
                    Command::Depth { .. } | Command::Mesh { .. } => {
                        if matches!(bound, Bound::Nothing | Bound::Boxes) {
                            pass.set_pipeline(&self.depth_pipeline);
                            pass.set_vertex_buffer(1, self.translation_buffer.buffer.slice(..));
                        }
                        match command {
                            Command::Depth { first, count } => {
                                if bound != Bound::Triangles {
                                    pass.set_vertex_buffer(0, self.vertex_buffer.buffer.slice(..));
                                    bound = Bound::Triangles;
                                }
                                pass.draw(first..first + count, 0..1);
                            }
                            Command::Mesh { mesh, instance } => {
                                // Ids were checked in `draw_mesh`; meshes are never removed.
                                if let Some((buffer, count)) = self.meshes.get(mesh as usize) {
                                    if bound != Bound::Mesh(mesh) {
                                        pass.set_vertex_buffer(0, buffer.slice(..));
                                        bound = Bound::Mesh(mesh);
                                    }
                                    pass.draw(0..*count, instance..instance + 1);
                                }
                            }
                            Command::Query { .. } => {}
                        }
                    }
                    Command::Query { index } => {
                        if index / QUERIES_PER_SET != set {
                            break;
                        }
                        if bound != Bound::Boxes {
                            pass.set_pipeline(&self.query_pipeline);
                            pass.set_vertex_buffer(0, self.cube_corners.slice(..));
                            pass.set_vertex_buffer(1, self.box_buffer.buffer.slice(..));
                            pass.set_index_buffer(
                                self.cube_indices.slice(..),
                                wgpu::IndexFormat::Uint16,
                            );
                            bound = Bound::Boxes;
                        }
                        pass.begin_occlusion_query(index % QUERIES_PER_SET);
                        pass.draw_indexed(0..CUBE_INDICES.len() as u32, 0, index..index + 1);
                        pass.end_occlusion_query();
                    }
                }
                next += 1;
            }
        }
        for set in 0..n_sets {
            let first = set * QUERIES_PER_SET;
            let count = (n_queries - first).min(QUERIES_PER_SET);
            encoder.resolve_query_set(
                &self.query_sets[set as usize],
                0..count,
                &self.resolve_buffer.buffer,
                u64::from(first) * u64::from(wgpu::QUERY_SIZE),
            );
        }
        encoder.copy_buffer_to_buffer(
            &self.resolve_buffer.buffer,
            0,
            &self.readback_buffer.buffer,
            0,
            result_bytes,
        );
        self.queue.submit([encoder.finish()]);
        self.depth_started = true;
        self.stats.submissions += 1;
        self.clear_recorded();

        let slice = self.readback_buffer.buffer.slice(..result_bytes);
        let (tx, rx) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            // The receiver waits below; if it is gone there is nobody to tell.
            let _ = tx.send(r);
        });
        device.poll(wgpu::PollType::wait_indefinitely())?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(GpuError::Readback(e.to_string())),
            Err(e) => return Err(GpuError::Readback(e.to_string())),
        }
        let mapped = slice.get_mapped_range().map(|view| {
            // Resolved occlusion results are native-endian u64 sample counts. Read them bytewise
            // rather than casting: the mapped pointer's alignment is not promised to be 8.
            for (&slot, bytes) in self.query_slots.iter().zip(view.chunks_exact(8)) {
                let mut count = [0u8; 8];
                count.copy_from_slice(bytes);
                if let Some((_, outcome)) = self.outcomes.get_mut(slot) {
                    *outcome = QueryOutcome::Samples(u64::from_ne_bytes(count));
                }
            }
        });
        self.readback_buffer.buffer.unmap();
        mapped.map_err(|e| GpuError::Readback(e.to_string()))?;
        self.query_slots.clear();
        Ok(())
    }
}

impl OcclusionBackend for GpuBackend {
    fn begin_frame(&mut self, camera: &Camera) {
        self.camera = Some(*camera);
        self.depth_started = false;
        self.clear_recorded();
        self.query_slots.clear();
        self.outcomes.clear();
        self.ready_from = 0;
        self.stats = GpuFrameStats::default();
    }

    fn draw_depth(&mut self, triangles: &[Vec3]) {
        if self.camera.is_none() {
            return;
        }
        let first = self.vertices.len() as u32;
        let count = (triangles.len() / 3 * 3) as u32;
        if count == 0 {
            return;
        }
        self.vertices
            .extend(triangles[..count as usize].iter().map(|p| p.to_array()));
        self.stats.triangles += count / 3;
        // Consecutive occluder batches become one draw.
        if let Some(Command::Depth { first: f, count: c }) = self.commands.last_mut() {
            if *f + *c == first {
                *c += count;
                return;
            }
        }
        self.commands.push(Command::Depth { first, count });
    }

    fn query(&mut self, tag: u32, aabb: &Aabb) {
        let Some(camera) = &self.camera else {
            // Without a camera nothing is known: conservatively visible.
            self.outcomes.push((tag, QueryOutcome::Pending));
            return;
        };
        let (mut zmin, mut zmax) = (f32::INFINITY, f32::NEG_INFINITY);
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 != 0 { aabb.max.x } else { aabb.min.x },
                if i & 2 != 0 { aabb.max.y } else { aabb.min.y },
                if i & 4 != 0 { aabb.max.z } else { aabb.min.z },
            );
            let z = (c - camera.eye).dot(camera.forward);
            zmin = zmin.min(z);
            zmax = zmax.max(z);
        }
        let on_cpu = if !(zmin.is_finite() && zmax.is_finite()) {
            Some(QueryOutcome::NearPlane)
        } else if zmax < camera.near {
            Some(QueryOutcome::BehindCamera)
        } else if zmin < camera.near {
            Some(QueryOutcome::NearPlane)
        } else {
            None
        };
        if let Some(outcome) = on_cpu {
            self.stats.cpu_answers += 1;
            self.outcomes.push((tag, outcome));
            return;
        }
        let index = self.query_slots.len() as u32;
        self.query_slots.push(self.outcomes.len());
        self.boxes.push(BoxInstance {
            min: aabb.min.to_array(),
            max: aabb.max.to_array(),
        });
        self.commands.push(Command::Query { index });
        self.outcomes.push((tag, QueryOutcome::Pending));
        self.stats.gpu_queries += 1;
    }

    fn take_results(&mut self, out: &mut Vec<(u32, bool)>) {
        if let Err(e) = self.submit_and_read() {
            // The trait has no error path. Unanswered queries stay `Pending`, i.e. visible: a
            // lost device costs culling, never a missing object.
            eprintln!("sightline-gpu: occlusion queries failed, treating boxes as visible: {e}");
        }
        out.extend(
            self.outcomes[self.ready_from..]
                .iter()
                .map(|&(tag, o)| (tag, o.is_visible())),
        );
        self.ready_from = self.outcomes.len();
    }

    fn name(&self) -> &'static str {
        "gpu"
    }
}
