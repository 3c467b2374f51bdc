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
//!
//! # Layout
//! - `types.rs`: the answers ([`QueryOutcome`], [`MeshId`]) and what is recorded between
//!   submissions (a leaf every other file imports).
//! - `pipelines.rs`: the camera binding, the two pipelines and the unit cube, made once.
//! - `buffers.rs`: the buffers, depth target and query sets that grow with a submission, and
//!   the upload of what was recorded.
//! - `passes.rs`: the render passes of a submission and the resolve and copy of its counts.
//! - `readback.rs`: the blocking map and read of the counts.

use std::time::Instant;

use glam::Vec3;
use sightline_core::{Aabb, Camera};
use sightline_cull::OcclusionBackend;
use wgpu::util::DeviceExt;
use wgpu::{AdapterInfo, Device, Queue};

use crate::device::{vulkan_device, GpuError};

mod buffers;
mod passes;
mod pipelines;
mod readback;
mod types;

use buffers::{FrameBuffers, FrameTargets};
use passes::PassInputs;
use pipelines::{Pipelines, UnitCube};
use types::{BoxInstance, CameraUniform, Command, Recording, QUERIES_PER_SET};
pub use types::{MeshId, QueryOutcome};

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
    /// The camera uniform, its bind group and the two pipelines.
    pipelines: Pipelines,
    /// The unit cube every query box is drawn from.
    cube: UnitCube,
    /// The buffers a submission's data is uploaded into and its counts read back through.
    buffers: FrameBuffers,
    /// Uploaded meshes: vertex buffer and vertex count.
    meshes: Vec<(wgpu::Buffer, u32)>,
    /// The depth target and the query sets.
    targets: FrameTargets,

    // The frame being recorded.
    camera: Option<Camera>,
    /// The depth buffer was cleared by an earlier submission of this frame.
    depth_started: bool,
    /// Commands and data recorded since the last submission.
    recording: Recording,
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
        let pipelines = Pipelines::new(device);
        let cube = UnitCube::new(device);
        let buffers = FrameBuffers::new(device);
        Self {
            device: device.clone(),
            queue: queue.clone(),
            info,
            pipelines,
            cube,
            buffers,
            meshes: Vec::new(),
            targets: FrameTargets::new(),
            camera: None,
            depth_started: false,
            recording: Recording::new(),
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
        let instance = self.recording.translations.len() as u32;
        self.recording.translations.push(translation.to_array());
        self.recording.commands.push(Command::Mesh {
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

    /// Submits and reads back (`submit_and_read_inner`), timing the wait
    /// into the stats; on an error drops what was recorded, its queries staying `Pending`.
    fn submit_and_read(&mut self) -> Result<(), GpuError> {
        let start = Instant::now();
        let result = self.submit_and_read_inner();
        if result.is_err() {
            // Whatever was recorded is lost with the submission; its queries stay `Pending`
            // (visible).
            self.query_slots.clear();
            self.recording.clear();
        }
        self.stats.wait_ms += start.elapsed().as_secs_f64() * 1e3;
        result
    }

    /// One submission, step by step: prepare the depth target and query sets, upload the
    /// recording and the camera, encode the passes and the resolve and copy of the counts,
    /// submit, then map and read the counts into `outcomes`. Does nothing without GPU queries
    /// (occluders recorded so far stay recorded: a later query of this frame must see them).
    fn submit_and_read_inner(&mut self) -> Result<(), GpuError> {
        let n_queries = self.query_slots.len() as u32;
        if n_queries == 0 {
            return Ok(());
        }
        let Some(camera) = self.camera else {
            return Ok(());
        };
        let device = self.device.clone();
        let n_sets = n_queries.div_ceil(QUERIES_PER_SET);
        self.targets.prepare(&device, &camera, n_sets);
        let result_bytes = u64::from(n_queries) * u64::from(wgpu::QUERY_SIZE);
        self.buffers
            .upload(&device, &self.queue, &self.recording, result_bytes);
        self.queue.write_buffer(
            &self.pipelines.camera_buffer,
            0,
            bytemuck::bytes_of(&CameraUniform::new(&camera)),
        );

        let Some(depth_view) = self.targets.depth_view() else {
            return Ok(());
        };
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("sightline occlusion"),
        });
        let inputs = PassInputs {
            depth_view,
            query_sets: &self.targets.query_sets,
            pipelines: &self.pipelines,
            cube: &self.cube,
            buffers: &self.buffers,
            meshes: &self.meshes,
            commands: &self.recording.commands,
            depth_started: self.depth_started,
        };
        passes::encode_query_passes(&mut encoder, &inputs, n_sets);
        passes::encode_resolve_and_copy(
            &mut encoder,
            &self.targets.query_sets,
            &self.buffers,
            n_queries,
            result_bytes,
        );
        self.queue.submit([encoder.finish()]);
        self.depth_started = true;
        self.stats.submissions += 1;
        self.recording.clear();

        readback::read_samples(
            &device,
            &self.buffers.readback.buffer,
            result_bytes,
            &self.query_slots,
            &mut self.outcomes,
        )?;
        self.query_slots.clear();
        Ok(())
    }
}

impl OcclusionBackend for GpuBackend {
    fn begin_frame(&mut self, camera: &Camera) {
        self.camera = Some(*camera);
        self.depth_started = false;
        self.recording.clear();
        self.query_slots.clear();
        self.outcomes.clear();
        self.ready_from = 0;
        self.stats = GpuFrameStats::default();
    }

    fn draw_depth(&mut self, triangles: &[Vec3]) {
        if self.camera.is_none() {
            return;
        }
        let first = self.recording.vertices.len() as u32;
        let count = (triangles.len() / 3 * 3) as u32;
        if count == 0 {
            return;
        }
        self.recording
            .vertices
            .extend(triangles[..count as usize].iter().map(|p| p.to_array()));
        self.stats.triangles += count / 3;
        // Consecutive occluder batches become one draw.
        if let Some(Command::Depth { first: f, count: c }) = self.recording.commands.last_mut() {
            if *f + *c == first {
                *c += count;
                return;
            }
        }
        self.recording
            .commands
            .push(Command::Depth { first, count });
    }

    fn query(&mut self, tag: u32, aabb: &Aabb) {
        let Some(camera) = &self.camera else {
            // Without a camera nothing is known: conservatively visible.
            self.outcomes.push((tag, QueryOutcome::Pending));
            return;
        };
        let (mut zmin, mut zmax) = (f32::INFINITY, f32::NEG_INFINITY);
        for c in aabb.corners() {
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
        self.recording.boxes.push(BoxInstance {
            min: aabb.min.to_array(),
            max: aabb.max.to_array(),
        });
        self.recording.commands.push(Command::Query { index });
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
