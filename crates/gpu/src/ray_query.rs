//! [`RayQueryCaster`]: `sightline-core`'s [`RayCaster`] with hardware ray queries (Vulkan
//! `VK_KHR_ray_query`, wgpu's `EXPERIMENTAL_RAY_QUERY`). The driver builds the acceleration
//! structure and runs the traversal and the triangle test; `ray_query.wgsl` only asks one
//! query per ray (one invocation each) and writes the committed hit.
//!
//! Based on: The Khronos Group. Vulkan 1.3 specification, `VK_KHR_acceleration_structure` and
//! `VK_KHR_ray_query`; chapter "Ray Traversal", whose watertightness requirement (a ray through
//! an edge or vertex that triangles of one geometry share intersects at least one of them) is
//! what makes the hits agree with the CPU's watertight test everywhere but within rounding of
//! edges.
//!
//! # Acceleration structure
//! One bottom-level acceleration structure (BLAS) of the whole scene: one triangle geometry,
//! `f32x3` positions and a `u32` index buffer in the scene's triangle order, flagged opaque
//! (so the traversal commits hits itself and the shader handles no candidates), built with
//! `PREFER_FAST_TRACE`. Its primitive index is therefore the scene's triangle id. Triangles the
//! CPU caster can never hit (an index out of range, a non-finite corner, zero area) get the
//! indices of one extra vertex whose `x` is NaN, which the Vulkan specification makes an
//! inactive primitive: never hit, and the ids of the others unchanged. One top-level structure
//! (TLAS) holds one instance of it with the identity transform. Both are built once, in
//! [`RayQueryCaster::with_device`], which waits for the build. A scene with nothing to hit
//! builds nothing; every ray misses.
//!
//! # Exactness
//! The driver's triangle test is not the CPU caster's ([`sightline_core::trace::Bvh`],
//! Woop et al.'s watertight test in f32): the same geometry, other roundings. So hits agree
//! with the CPU caster's except
//! - where a ray passes within rounding of an edge shared by two triangles: both tests are
//!   watertight, so each hits one of them, but not necessarily the same one (both at the same
//!   `t` up to rounding);
//! - where two triangles are hit at `t`s that tie within rounding (coplanar overlapping
//!   triangles, a ray through a shared vertex or along a crease);
//! - where a ray grazes a silhouette edge within rounding: one test hits, the other misses.
//!
//! `t` is the driver's, within [`RAY_QUERY_T_TOLERANCE`] of the CPU's (relative to the
//! coordinates involved, as stated there) on lavapipe; other drivers' rounding is not measured
//! here. `t` is in units of the ray's direction, as on the CPU (the direction goes to the
//! driver unnormalised, and Vulkan measures `t` in its units). Triangles count from both sides
//! (no culling flag). Rays the CPU caster never lets hit (NaN or infinite origin or direction,
//! zero direction, `t_min > t_max` or a NaN range) are marked dead on the CPU and never reach
//! `rayQueryInitialize`, whose arguments Vulkan requires to be finite with
//! `0 <= t_min <= t_max`. A ray with a negative `t_min` (the CPU caster accepts hits behind the
//! origin) starts where it enters the box of the scene's triangles (enlarged by 10^-4 of its
//! size), at most `-t_min` back, and the shader adds that start's `t` back: its `t` is then
//! within the tolerance with the distance moved added to the scale.
//!
//! Measured on lavapipe (Mesa 25.0, `crates/gpu/tests/ray_query.rs`): of 112,000 random,
//! camera, axis-parallel and ranged rays on the bunny, a 20k-triangle city and a Quake 3 map,
//! none grazes (hit on one side, miss on the other) and 3 of 44,000 hits tie (another
//! triangle at the same `t`: coplanar overlapping faces of the map); the same triangle's `t`
//! differs by at most 9.5e-7 of the coordinates' scale. Rays aimed exactly at the bunny's
//! vertices and edge midpoints, the worst case, tie on 4 % and graze on 6 % of the rays
//! (each within rounding of the edge, as both tests round it), with `t` within 6.1e-6.
//!
//! # Memory
//! While building: the vertex buffer (12 bytes a vertex, plus one), the index buffer (12
//! bytes a triangle) and the driver's scratch memory; they are freed once the build is done.
//! Kept: the BLAS and the TLAS, whose sizes the driver chooses ([`RayQueryCaster::memory`]
//! reads them from wgpu's allocator report, where the backend gives one). On lavapipe the
//! BLAS takes 104 bytes a triangle (1.89 MB for the 18,132 triangles of the 20k city, 10.3 MB
//! for the 98,922 of the 100k city) and the TLAS about 250 bytes: 1.8 times the compute
//! caster's 4-wide nodes and triangles (57 bytes a triangle). Compaction
//! (`ALLOW_COMPACTION`) is not asked for.
//!
//! # Streaming
//! As the compute caster's (`stream.rs`): chunks of [`RayQueryOptions::chunk_rays`] rays
//! through two buffer sets, the CPU preparing and uploading one chunk and reading back the one
//! before while the GPU casts the one between; each call takes its own pair of buffer sets
//! from a pool, so calls from several threads keep several chunks in flight.

use std::sync::atomic::{AtomicU64, Ordering};

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use sightline_core::scene::Scene;
use sightline_core::trace::bvh::hittable_corners;
use sightline_core::trace::RayCaster;
use sightline_core::{Aabb, Hit, Ray};
use wgpu::{AdapterInfo, Device, Queue};

use crate::device::{vulkan_device, GpuError};
use crate::ray_layout::can_hit;
use crate::stream::{chunk_cap, or_panic, CastPipelines, ChunkShader, Streamer};

/// How far the ray-query caster's `t` may lie from the CPU caster's for the same triangle,
/// relative to the coordinates that round it: `|t_gpu - t_cpu| * |dir| <= RAY_QUERY_T_TOLERANCE
/// * s`, where `|v|` is the largest absolute component of `v` and `s` the largest of
/// `|origin|`, the corners' `|corner|` and their distances along the ray, `|t_c| * |dir|` with
/// `t_c = (corner - origin) . dir / (dir . dir)`.
///
/// Not relative to `t` itself: both tests start from the corners translated to the origin, so
/// their rounding is that of the coordinates, and a short hit far from the world's origin
/// (t = 0.7 from a point at 600) differs by 2.8e-5 of `t`, under an ulp of the coordinates. On
/// lavapipe the difference is at most 9.5e-7 on random, camera, axis and ranged rays and 6.1e-6
/// on rays aimed exactly at vertices and edges (there lavapipe's `t` lies up to 7.9e-6 from
/// the exact one, the CPU's 2.5e-6); the bound is three times that, for drivers not measured
/// here. For a ray with a negative `t_min` add the distance its start moved (see the module
/// documentation) to `s`.
pub const RAY_QUERY_T_TOLERANCE: f32 = 2e-5;

/// How a [`RayQueryCaster`] streams rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RayQueryOptions {
    /// Rays per chunk (at least 1; capped by the adapter's storage-binding and buffer sizes
    /// and by one dispatch row of workgroups, as the compute caster's).
    pub chunk_rays: usize,
}

impl Default for RayQueryOptions {
    fn default() -> Self {
        Self {
            chunk_rays: 1 << 20,
        }
    }
}

/// What a [`RayQueryCaster`] holds on the GPU, in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayQueryMemory {
    /// The vertex and index buffers the BLAS was built from (freed after the build).
    pub build_input: u64,
    /// The bottom-level acceleration structure, as wgpu's allocator report gives it; `None`
    /// where the backend reports no allocations (or nothing was built).
    pub blas: Option<u64>,
    /// The top-level acceleration structure (one instance), likewise.
    pub tlas: Option<u64>,
}

/// A ray as `ray_query.wgsl` reads it (see its `Ray`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
struct QueryRay {
    origin: [f32; 3],
    t_min: f32,
    dir: [f32; 3],
    t_max: f32,
    t_offset: f32,
    live: u32,
    pad: [u32; 2],
}

/// Relative enlargement of the scene's box where a ray with a negative `t_min` starts.
const BOX_MARGIN: f32 = 1e-4;

impl QueryRay {
    /// A ray that hits nothing (never passed to `rayQueryInitialize`).
    const DEAD: QueryRay = QueryRay {
        origin: [0.0; 3],
        t_min: 0.0,
        dir: [0.0; 3],
        t_max: 0.0,
        t_offset: 0.0,
        live: 0,
        pad: [0; 2],
    };

    /// `ray` for the shader (see the module documentation): dead where the CPU caster never
    /// lets it hit; with a negative `t_min`, moved back to where it enters `bounds` (the box
    /// of the triangles that can be hit, already enlarged).
    fn new(ray: &Ray, bounds: &Aabb) -> Self {
        if !can_hit(ray) {
            return Self::DEAD;
        }
        let d = ray.dir;
        let live = |origin: Vec3, t_max: f32, t_offset: f32| {
            if !origin.is_finite() || t_max < 0.0 {
                return Self::DEAD;
            }
            Self {
                origin: origin.to_array(),
                t_min: 0.0,
                dir: d.to_array(),
                t_max: t_max.min(f32::MAX),
                t_offset,
                live: 1,
                pad: [0; 2],
            }
        };
        if ray.t_min >= 0.0 {
            // A -0.0 `t_min` goes as +0.0.
            let t_min = if ray.t_min == 0.0 { 0.0 } else { ray.t_min };
            return Self {
                t_min,
                ..live(ray.origin, ray.t_max, 0.0)
            };
        }
        // Vulkan's queries start at t >= 0. Nothing is hit outside the box: start where the
        // ray enters it, or at `t_min` if that is later.
        let Some(enter) = entry(bounds, ray.origin, d) else {
            return Self::DEAD;
        };
        let start = ray.t_min.max(enter);
        if start >= 0.0 {
            live(ray.origin, ray.t_max, 0.0)
        } else {
            live(ray.origin + d * start, ray.t_max - start, start)
        }
    }
}

/// The `t` at which the line `origin + t * dir` enters `bounds`, `None` if it misses it.
fn entry(bounds: &Aabb, origin: Vec3, dir: Vec3) -> Option<f32> {
    let (mut enter, mut exit) = (f32::NEG_INFINITY, f32::INFINITY);
    for a in 0..3 {
        let (lo, hi, o) = (bounds.min[a], bounds.max[a], origin[a]);
        if dir[a] == 0.0 {
            if o < lo || o > hi {
                return None;
            }
        } else {
            let (t0, t1) = ((lo - o) / dir[a], (hi - o) / dir[a]);
            enter = enter.max(t0.min(t1));
            exit = exit.min(t0.max(t1));
        }
    }
    (enter <= exit).then_some(enter)
}

/// The BLAS's build input: positions with one NaN vertex after them, indices (unusable
/// triangles pointing at the NaN vertex three times), and the box of the usable triangles
/// (empty when there is none).
fn geometry(scene: &Scene) -> (Vec<[f32; 3]>, Vec<u32>, Aabb) {
    let nan = scene.positions.len() as u32;
    let mut positions: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
    positions.push([f32::NAN; 3]);
    let mut bounds = Aabb::EMPTY;
    let mut indices = Vec::with_capacity(scene.triangles.len() * 3);
    for t in &scene.triangles {
        match hittable_corners(scene, t) {
            Some(corners) => {
                corners.into_iter().for_each(|c| bounds.grow(c));
                indices.extend_from_slice(t);
            }
            None => indices.extend_from_slice(&[nan; 3]),
        }
    }
    (positions, indices, bounds)
}

/// `bounds` enlarged by [`BOX_MARGIN`] of its size and of its coordinates' magnitude, so that
/// a point computed on its face with rounding still lies outside it.
fn enlarged(bounds: Aabb) -> Aabb {
    let scale = bounds
        .extent()
        .max_element()
        .max(bounds.min.abs().max_element())
        .max(bounds.max.abs().max_element());
    let margin = Vec3::splat(scale * BOX_MARGIN + f32::MIN_POSITIVE);
    Aabb::new(bounds.min - margin, bounds.max + margin)
}

/// The scene's acceleration structures with the pipelines that query them.
struct Accelerated {
    pipelines: CastPipelines,
    tlas: wgpu::Tlas,
    /// Where rays with a negative `t_min` start (enlarged box of the usable triangles).
    bounds: Aabb,
}

impl ChunkShader for Accelerated {
    type GpuRay = QueryRay;

    fn prepare(&self, ray: &Ray) -> QueryRay {
        QueryRay::new(ray, &self.bounds)
    }

    fn pipelines(&self) -> &CastPipelines {
        &self.pipelines
    }

    fn scene_bindings(&self) -> Vec<wgpu::BindingResource<'_>> {
        vec![self.tlas.as_binding()]
    }
}

/// A [`RayCaster`] with hardware ray queries (see the module documentation).
///
/// ```no_run
/// use glam::Vec3;
/// use sightline_core::scene::SceneBuilder;
/// use sightline_core::trace::RayCaster;
/// use sightline_core::Ray;
/// use sightline_gpu::RayQueryCaster;
///
/// let mut b = SceneBuilder::new("one box");
/// b.add_box(Vec3::splat(1.0), Vec3::splat(2.0));
/// let gpu = RayQueryCaster::new(&b.finish())?; // GpuError::NoRayQuery without ray queries
/// println!("on {}", gpu.adapter_info().name);
/// let hit = gpu.cast_one(&Ray::new(Vec3::new(0.0, 1.5, 1.5), Vec3::X));
/// assert!((hit.t - 1.0).abs() <= 1e-5);
/// # Ok::<(), sightline_gpu::GpuError>(())
/// ```
pub struct RayQueryCaster {
    info: AdapterInfo,
    stream: Streamer<Accelerated>,
    memory: RayQueryMemory,
}

impl RayQueryCaster {
    /// True when `device` was created with `EXPERIMENTAL_RAY_QUERY` ([`vulkan_device`]
    /// requests it where the adapter has it).
    pub fn supported(device: &Device) -> bool {
        device
            .features()
            .contains(wgpu::Features::EXPERIMENTAL_RAY_QUERY)
    }

    /// A caster for `scene` on a freshly acquired Vulkan device (see [`vulkan_device`]).
    pub fn new(scene: &Scene) -> Result<Self, GpuError> {
        let (device, queue, info) = vulkan_device()?;
        Self::with_device(&device, &queue, info, scene)
    }

    /// A caster for `scene` on a caller's device, with the default [`RayQueryOptions`].
    /// Builds the acceleration structures and waits for them. Errors:
    /// [`GpuError::NoRayQuery`] when the device lacks `EXPERIMENTAL_RAY_QUERY`,
    /// [`GpuError::TooManyTriangles`] over the adapter's `max_blas_primitive_count`,
    /// [`GpuError::BufferTooLarge`] when the vertex or index buffer exceeds its buffer size,
    /// [`GpuError::Shader`] or [`GpuError::AccelerationStructure`] when the driver refuses the
    /// shader or the build.
    pub fn with_device(
        device: &Device,
        queue: &Queue,
        info: AdapterInfo,
        scene: &Scene,
    ) -> Result<Self, GpuError> {
        Self::with_options(device, queue, info, scene, RayQueryOptions::default())
    }

    /// [`RayQueryCaster::with_device`] with `options`; [`GpuError::ZeroChunk`] for chunks of
    /// zero rays.
    pub fn with_options(
        device: &Device,
        queue: &Queue,
        info: AdapterInfo,
        scene: &Scene,
        options: RayQueryOptions,
    ) -> Result<Self, GpuError> {
        if !Self::supported(device) {
            return Err(GpuError::NoRayQuery { adapter: info.name });
        }
        if options.chunk_rays == 0 {
            return Err(GpuError::ZeroChunk);
        }
        let chunk_rays = chunk_cap(
            device,
            options.chunk_rays,
            std::mem::size_of::<QueryRay>() as u64,
        );
        let (accelerated, memory) = match build(device, queue, scene)? {
            Some((a, m)) => (Some(a), m),
            None => (None, RayQueryMemory::default()),
        };
        Ok(Self {
            info,
            stream: Streamer::new(device, queue, accelerated, chunk_rays),
            memory,
        })
    }

    /// The adapter this caster runs on.
    pub fn adapter_info(&self) -> &AdapterInfo {
        &self.info
    }

    /// Rays per chunk, after the adapter's limits.
    pub fn chunk_rays(&self) -> usize {
        self.stream.chunk_rays()
    }

    /// What the caster holds on the GPU (see the module documentation).
    pub fn memory(&self) -> RayQueryMemory {
        self.memory
    }

    /// [`RayCaster::cast`], with GPU failures (device lost, readback failed) as errors.
    pub fn try_cast(&self, rays: &[Ray], hits: &mut [Hit]) -> Result<(), GpuError> {
        self.stream.cast(rays, hits)
    }

    /// [`RayCaster::occluded`], with GPU failures as errors.
    pub fn try_occluded(&self, rays: &[Ray], out: &mut [bool]) -> Result<(), GpuError> {
        self.stream.occluded(rays, out)
    }
}

impl RayCaster for RayQueryCaster {
    /// # Panics
    /// If `hits.len() != rays.len()` (as the CPU caster), or the GPU fails (device lost); use
    /// [`RayQueryCaster::try_cast`] to get those as errors.
    fn cast(&self, rays: &[Ray], hits: &mut [Hit]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        or_panic(self.try_cast(rays, hits));
    }

    /// # Panics
    /// As [`RayQueryCaster::cast`].
    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "one output slot per ray");
        or_panic(self.try_occluded(rays, out));
    }
}

/// Tells the acceleration structures of different casters apart in the allocator report.
static NEXT_LABEL: AtomicU64 = AtomicU64::new(0);

/// Builds the BLAS and TLAS of `scene` and the pipelines, and waits for the build; `None`
/// when the scene has nothing to hit.
fn build(
    device: &Device,
    queue: &Queue,
    scene: &Scene,
) -> Result<Option<(Accelerated, RayQueryMemory)>, GpuError> {
    let limit = device.limits().max_blas_primitive_count;
    if scene.triangles.len() > limit as usize {
        return Err(GpuError::TooManyTriangles {
            triangles: scene.triangles.len(),
            limit,
        });
    }
    let (positions, indices, bounds) = geometry(scene);
    if bounds.is_empty() {
        return Ok(None);
    }
    let vertex_bytes: &[u8] = bytemuck::cast_slice(&positions);
    let index_bytes: &[u8] = bytemuck::cast_slice(&indices);
    let buffer_limit = device.limits().max_buffer_size;
    for (what, bytes) in [
        ("vertices", vertex_bytes),
        ("triangle indices", index_bytes),
    ] {
        if bytes.len() as u64 > buffer_limit {
            return Err(GpuError::BufferTooLarge {
                what,
                bytes: bytes.len() as u64,
                limit: buffer_limit,
            });
        }
    }

    let pipelines = pipelines(device)?;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let upload = |label: &str, contents: &[u8]| {
        use wgpu::util::DeviceExt;
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: wgpu::BufferUsages::BLAS_INPUT,
        })
    };
    let vertices = upload("sightline BLAS vertices", vertex_bytes);
    let index_buffer = upload("sightline BLAS indices", index_bytes);
    let size = wgpu::BlasTriangleGeometrySizeDescriptor {
        vertex_format: wgpu::VertexFormat::Float32x3,
        vertex_count: positions.len() as u32,
        index_format: Some(wgpu::IndexFormat::Uint32),
        index_count: Some(indices.len() as u32),
        flags: wgpu::AccelerationStructureGeometryFlags::OPAQUE,
    };
    let id = NEXT_LABEL.fetch_add(1, Ordering::Relaxed);
    let blas_label = format!("sightline scene BLAS {id}");
    let tlas_label = format!("sightline scene TLAS {id}");
    let blas = device.create_blas(
        &wgpu::CreateBlasDescriptor {
            label: Some(&blas_label),
            flags: wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE,
            update_mode: wgpu::AccelerationStructureUpdateMode::Build,
        },
        wgpu::BlasGeometrySizeDescriptors::Triangles {
            descriptors: vec![size.clone()],
        },
    );
    let mut tlas = device.create_tlas(&wgpu::CreateTlasDescriptor {
        label: Some(&tlas_label),
        max_instances: 1,
        flags: wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE,
        update_mode: wgpu::AccelerationStructureUpdateMode::Build,
    });
    // 3x4 row-major: the identity, so the BLAS's coordinates are the scene's.
    let identity = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    tlas[0] = Some(wgpu::TlasInstance::new(&blas, identity, 0, 0xff));
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("sightline acceleration structures"),
    });
    encoder.build_acceleration_structures(
        [&wgpu::BlasBuildEntry {
            blas: &blas,
            geometry: wgpu::BlasGeometries::TriangleGeometries(vec![wgpu::BlasTriangleGeometry {
                size: &size,
                vertex_buffer: &vertices,
                first_vertex: 0,
                vertex_stride: 12,
                index_buffer: Some(&index_buffer),
                first_index: Some(0),
                transform_buffer: None,
                transform_buffer_offset: None,
            }]),
        }],
        [&tlas],
    );
    let submission = queue.submit([encoder.finish()]);
    device.poll(wgpu::PollType::Wait {
        submission_index: Some(submission),
        timeout: None,
    })?;
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(GpuError::AccelerationStructure(e.to_string()));
    }
    let memory = RayQueryMemory {
        build_input: (vertex_bytes.len() + index_bytes.len()) as u64,
        blas: allocated(device, &blas_label),
        tlas: allocated(device, &tlas_label),
    };
    // The TLAS instance keeps the BLAS alive; the build input is no longer needed.
    drop((vertices, index_buffer, blas));
    let accelerated = Accelerated {
        pipelines,
        tlas,
        bounds: enlarged(bounds),
    };
    Ok(Some((accelerated, memory)))
}

/// Compiles `ray_query.wgsl` and makes its pipelines, with the TLAS at binding 1.
fn pipelines(device: &Device) -> Result<CastPipelines, GpuError> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::include_wgsl!("ray_query.wgsl"));
    let acceleration_structure = wgpu::BindingType::AccelerationStructure {
        vertex_return: false,
    };
    let pipelines = CastPipelines::new(device, &module, &[acceleration_structure]);
    match pollster::block_on(scope.pop()) {
        Some(e) => Err(GpuError::Shader(e.to_string())),
        None => Ok(pipelines),
    }
}

/// Bytes of the allocations called `label` in the device's allocator report.
fn allocated(device: &Device, label: &str) -> Option<u64> {
    let report = device.generate_allocator_report()?;
    let sizes = report.allocations.iter().filter(|a| a.name == label);
    let (count, bytes) = sizes.fold((0, 0), |(n, b), a| (n + 1, b + a.size));
    (count > 0).then_some(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;

    fn unit_box() -> Aabb {
        Aabb::new(Vec3::ZERO, Vec3::ONE)
    }

    #[test]
    fn unusable_rays_are_dead() {
        let o = Vec3::splat(0.5);
        let b = unit_box();
        for ray in [
            Ray::new(o, Vec3::ZERO),
            Ray::new(Vec3::splat(f32::NAN), Vec3::X),
            Ray::new(o, Vec3::new(f32::INFINITY, 0.0, 1.0)),
            Ray::new(o, Vec3::X).with_range(2.0, 1.0),
            Ray::new(o, Vec3::X).with_range(f32::NAN, 1.0),
            Ray::new(o, Vec3::X).with_range(0.0, f32::NAN),
            Ray::new(o, Vec3::X).with_range(f32::INFINITY, f32::INFINITY),
        ] {
            assert_eq!(QueryRay::new(&ray, &b), QueryRay::DEAD, "{ray:?}");
        }
    }

    #[test]
    fn ordinary_ray_goes_as_it_is() {
        let ray = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::new(2.0, 0.0, 0.0));
        let q = QueryRay::new(&ray.with_range(-0.0, f32::INFINITY), &unit_box());
        assert_eq!(q.live, 1);
        assert_eq!(q.dir, [2.0, 0.0, 0.0], "not normalised");
        assert_eq!(q.t_min.to_bits(), 0, "+0.0");
        assert_eq!(q.t_max, f32::MAX);
        assert_eq!(q.t_offset, 0.0);
    }

    #[test]
    fn negative_t_min_starts_at_the_box() {
        // From x = 3 along +x, looking back to t = -inf: the box is entered at t = -3.
        let ray = Ray::new(Vec3::new(3.0, 0.5, 0.5), Vec3::X);
        let q = QueryRay::new(&ray.with_range(f32::NEG_INFINITY, 10.0), &unit_box());
        assert_eq!(q.live, 1);
        assert_eq!(q.t_offset, -3.0);
        assert_eq!(q.origin, [0.0, 0.5, 0.5]);
        assert_eq!(q.t_max, 13.0);
        // A t_min after the entry is kept.
        let q = QueryRay::new(&ray.with_range(-2.5, -1.0), &unit_box());
        assert_eq!((q.t_offset, q.t_max), (-2.5, 1.5));
        // Ending before the box: nothing to hit.
        let q = QueryRay::new(&ray.with_range(-10.0, -5.0), &unit_box());
        assert_eq!(q, QueryRay::DEAD);
        // Entering the box ahead of the origin: no need to move.
        let ray = Ray::new(Vec3::new(-3.0, 0.5, 0.5), Vec3::X).with_range(-1.0, 10.0);
        let q = QueryRay::new(&ray, &unit_box());
        assert_eq!((q.t_offset, q.t_min, q.t_max), (0.0, 0.0, 10.0));
        // Missing the box: nothing to hit.
        let ray = Ray::new(Vec3::new(3.0, 5.0, 0.5), Vec3::X).with_range(-10.0, 10.0);
        assert_eq!(QueryRay::new(&ray, &unit_box()), QueryRay::DEAD);
    }

    #[test]
    fn unusable_triangles_point_at_the_nan_vertex() {
        let mut b = SceneBuilder::new("mixed");
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X * 2.0].map(|p| b.add_vertex(p));
        b.add_triangle([v[0], v[1], v[2]]);
        b.add_triangle([v[0], v[1], v[3]]); // zero area
        let mut scene = b.finish();
        scene.triangles.push([0, 1, 99]); // index out of range
        let (positions, indices, bounds) = geometry(&scene);
        assert_eq!(positions.len(), 5);
        assert!(positions[4][0].is_nan());
        assert_eq!(indices, [0, 1, 2, 4, 4, 4, 4, 4, 4]);
        assert_eq!(bounds, Aabb::new(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)));
        let (_, _, none) = geometry(&Scene::default());
        assert!(none.is_empty());
    }

    #[test]
    fn enlarged_box_contains_the_box() {
        let b = enlarged(Aabb::new(Vec3::splat(100.0), Vec3::splat(101.0)));
        assert!(b.min.x < 100.0 && b.min.x > 99.9);
        assert!(b.max.x > 101.0 && b.max.x < 101.1);
    }
}
