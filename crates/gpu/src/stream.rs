//! Streaming ray batches through a compute shader in double-buffered chunks, the part the two
//! GPU ray casters share: the compute-shader caster (`ray_cast.rs`) and the hardware ray-query
//! caster (`ray_query.rs`) differ only in how a ray is laid out for their shader, in the
//! shader itself and in what the scene's bind-group entries are ([`ChunkShader`]); both
//! shaders have the entry points `cast_closest` and `cast_any` ([`CastPipelines`]).
//!
//! Rays go up in chunks (capped by the adapter's storage-binding and buffer limits, and by one
//! row of workgroups, so a chunk is one 1D dispatch) through two sets of buffers: while the GPU
//! casts chunk `i`, the CPU prepares and uploads chunk `i + 1` and reads back chunk `i - 1`.
//! Each call takes its own pair of buffer sets from a pool, so calls from several threads (a
//! bake's cells, each casting batches of 64k rays) keep several chunks queued on the GPU at
//! once. A shader writes one hit per ray as two words, the triangle id and the bits of `t`
//! (`[Hit::NONE, +inf bits]` for a miss).

use std::sync::mpsc;
use std::sync::Mutex;

use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;
use sightline_core::{Hit, Ray};
use wgpu::{Device, Queue};

use crate::device::GpuError;

/// Invocations per workgroup (`@workgroup_size` of both casters' shaders).
pub(crate) const WORKGROUP: u32 = 64;
/// Bytes of one hit on the GPU: triangle id and `t` bits.
const HIT_BYTES: u64 = 8;

/// The uniform block both shaders read at binding 0 (`Params` in the `.wgsl` files).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct Params {
    /// Rays in this chunk.
    count: u32,
    /// Always 0 (`ray_cast.wgsl` XORs it into products to keep them from being fused).
    zero: u32,
    pad: [u32; 2],
}

/// What a caster streams rays through: its shader's ray layout, its pipelines and the
/// scene's resources in its bind group.
pub(crate) trait ChunkShader: Sync {
    /// A ray as the shader reads it.
    type GpuRay: Pod + Send;

    /// `ray` in the shader's layout.
    fn prepare(&self, ray: &Ray) -> Self::GpuRay;

    /// The shader's layout and pipelines.
    fn pipelines(&self) -> &CastPipelines;

    /// The scene's resources, bound from binding 1 on in this order (as
    /// [`CastPipelines::new`]'s `scene` types).
    fn scene_bindings(&self) -> Vec<wgpu::BindingResource<'_>>;
}

/// A caster's bind group layout and its two compute pipelines, one per kind of query; made
/// once per caster, apart from its checks and uploads.
pub(crate) struct CastPipelines {
    /// Group 0: the parameters (uniform, binding 0), the scene's resources (from binding 1 on),
    /// the rays (read-only storage) and the hits (written storage).
    bind_layout: wgpu::BindGroupLayout,
    /// `cast_closest`: the nearest hit per ray.
    closest: wgpu::ComputePipeline,
    /// `cast_any`: whether anything is hit, stopping at the first hit.
    any_hit: wgpu::ComputePipeline,
}

impl CastPipelines {
    /// Makes the layout and both pipelines from the compiled `module` (inside the caller's
    /// validation error scope, which reports a shader that does not compile), with the scene's
    /// resources of types `scene` from binding 1 on.
    pub(crate) fn new(
        device: &Device,
        module: &wgpu::ShaderModule,
        scene: &[wgpu::BindingType],
    ) -> Self {
        let buffer = |ty| wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let storage = |read_only| buffer(wgpu::BufferBindingType::Storage { read_only });
        let types: Vec<wgpu::BindingType> =
            std::iter::once(buffer(wgpu::BufferBindingType::Uniform))
                .chain(scene.iter().copied())
                .chain([storage(true), storage(false)])
                .collect();
        let entries: Vec<wgpu::BindGroupLayoutEntry> = types
            .into_iter()
            .enumerate()
            .map(|(binding, ty)| wgpu::BindGroupLayoutEntry {
                binding: binding as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty,
                count: None,
            })
            .collect();
        let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sightline ray cast"),
            entries: &entries,
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("sightline ray cast"),
            bind_group_layouts: &[Some(&bind_layout)],
            immediate_size: 0,
        });
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("sightline ray cast"),
                layout: Some(&layout),
                module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let closest = pipeline("cast_closest");
        let any_hit = pipeline("cast_any");
        Self {
            bind_layout,
            closest,
            any_hit,
        }
    }
}

/// Rays per chunk: `requested`, capped by the device's storage-binding and buffer sizes for
/// rays of `ray_bytes`, and by one row of workgroups (at least 65,535 workgroups of 64, 4.19M
/// rays). `requested` is at least 1.
pub(crate) fn chunk_cap(device: &Device, requested: usize, ray_bytes: u64) -> usize {
    let limits = device.limits();
    let binding_limit = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let groups = u64::from(limits.max_compute_workgroups_per_dimension);
    (requested as u64)
        .min(binding_limit / ray_bytes)
        .min(groups * u64::from(WORKGROUP))
        .max(1) as usize
}

/// One of the two sets of per-chunk buffers.
struct Slot {
    capacity: u64,
    params: wgpu::Buffer,
    rays: wgpu::Buffer,
    readback: wgpu::Buffer,
    hits: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

/// A chunk submitted and not yet read back.
struct Pending {
    slot: usize,
    offset: usize,
    len: usize,
    submission: wgpu::SubmissionIndex,
    mapped: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

/// Streams batches of rays through a [`ChunkShader`]; `shader` is `None` for a scene with
/// nothing to hit (every ray misses, nothing goes to the GPU).
pub(crate) struct Streamer<S: ChunkShader> {
    device: Device,
    queue: Queue,
    shader: Option<S>,
    /// Idle pairs of per-chunk buffer sets: a call takes one (or makes one) and gives it back,
    /// so calls from several threads (the cells of a bake) have their chunks in flight at once.
    idle: Mutex<Vec<Vec<Slot>>>,
    chunk_rays: usize,
}

impl<S: ChunkShader> Streamer<S> {
    /// A streamer of chunks of `chunk_rays` rays (already capped, see [`chunk_cap`]).
    pub(crate) fn new(
        device: &Device,
        queue: &Queue,
        shader: Option<S>,
        chunk_rays: usize,
    ) -> Self {
        Self {
            device: device.clone(),
            queue: queue.clone(),
            shader,
            idle: Mutex::new(Vec::new()),
            chunk_rays,
        }
    }

    /// Rays per chunk.
    pub(crate) fn chunk_rays(&self) -> usize {
        self.chunk_rays
    }

    /// `RayCaster::cast`, with GPU failures (device lost, readback failed) as errors.
    pub(crate) fn cast(&self, rays: &[Ray], hits: &mut [Hit]) -> Result<(), GpuError> {
        if rays.len() != hits.len() {
            return Err(GpuError::LengthMismatch {
                rays: rays.len(),
                out: hits.len(),
            });
        }
        self.run(rays, false, |offset, words| {
            for (h, w) in hits[offset..].iter_mut().zip(words) {
                *h = Hit {
                    triangle: w[0],
                    t: f32::from_bits(w[1]),
                };
            }
        })
    }

    /// `RayCaster::occluded`, with GPU failures as errors.
    pub(crate) fn occluded(&self, rays: &[Ray], out: &mut [bool]) -> Result<(), GpuError> {
        if rays.len() != out.len() {
            return Err(GpuError::LengthMismatch {
                rays: rays.len(),
                out: out.len(),
            });
        }
        self.run(rays, true, |offset, words| {
            for (o, w) in out[offset..].iter_mut().zip(words) {
                *o = w[0] != Hit::NONE;
            }
        })
    }

    /// Casts `rays` chunk by chunk, double-buffered, and hands each chunk's `[id, t bits]`
    /// words to `sink` with the chunk's offset.
    fn run(
        &self,
        rays: &[Ray],
        any_hit: bool,
        mut sink: impl FnMut(usize, &[[u32; 2]]),
    ) -> Result<(), GpuError> {
        let Some(shader) = &self.shader else {
            // Nothing to hit.
            let miss = vec![[Hit::NONE, f32::INFINITY.to_bits()]; rays.len()];
            sink(0, &miss);
            return Ok(());
        };
        if rays.is_empty() {
            return Ok(());
        }
        let idle = || self.idle.lock().unwrap_or_else(|e| e.into_inner());
        let mut slots = idle().pop().unwrap_or_default();
        self.run_on(&mut slots, shader, rays, any_hit, &mut sink)?;
        // After an error the buffers may be left mapped: they are dropped, not reused.
        idle().push(slots);
        Ok(())
    }

    /// [`Streamer::run`] on one pair of buffer sets.
    fn run_on(
        &self,
        slots: &mut Vec<Slot>,
        shader: &S,
        rays: &[Ray],
        any_hit: bool,
        mut sink: impl FnMut(usize, &[[u32; 2]]),
    ) -> Result<(), GpuError> {
        let mut pending: Option<Pending> = None;
        let mut words = Vec::new();
        for (i, chunk) in rays.chunks(self.chunk_rays).enumerate() {
            let slot = i % 2;
            self.reserve(slots, slot, chunk.len(), shader);
            let prepared: Vec<S::GpuRay> = chunk.par_iter().map(|r| shader.prepare(r)).collect();
            let s = &slots[slot];
            // `chunk_rays` keeps this within the adapter's workgroups per dimension.
            let groups = (chunk.len() as u32).div_ceil(WORKGROUP);
            let params = Params {
                count: chunk.len() as u32,
                zero: 0,
                pad: [0; 2],
            };
            self.queue
                .write_buffer(&s.params, 0, bytemuck::bytes_of(&params));
            self.queue
                .write_buffer(&s.rays, 0, bytemuck::cast_slice(&prepared));
            let mut encoder = self
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("sightline ray cast"),
                });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("sightline ray cast"),
                    timestamp_writes: None,
                });
                let pipelines = shader.pipelines();
                pass.set_pipeline(if any_hit {
                    &pipelines.any_hit
                } else {
                    &pipelines.closest
                });
                pass.set_bind_group(0, &s.bind_group, &[]);
                pass.dispatch_workgroups(groups, 1, 1);
            }
            let bytes = chunk.len() as u64 * HIT_BYTES;
            encoder.copy_buffer_to_buffer(&s.hits, 0, &s.readback, 0, bytes);
            let submission = self.queue.submit([encoder.finish()]);
            let (tx, rx) = mpsc::channel();
            s.readback
                .slice(..bytes)
                .map_async(wgpu::MapMode::Read, move |r| {
                    // The receiver waits in `finish`; if it is gone nobody needs to know.
                    let _ = tx.send(r);
                });
            if let Some(p) = pending.take() {
                self.finish(slots, p, &mut words, &mut sink)?;
            }
            pending = Some(Pending {
                slot,
                offset: i * self.chunk_rays,
                len: chunk.len(),
                submission,
                mapped: rx,
            });
        }
        if let Some(p) = pending {
            self.finish(slots, p, &mut words, &mut sink)?;
        }
        Ok(())
    }

    /// Waits for chunk `p`, copies its hits out to `sink` and unmaps its readback buffer.
    fn finish(
        &self,
        slots: &[Slot],
        p: Pending,
        words: &mut Vec<[u32; 2]>,
        sink: &mut impl FnMut(usize, &[[u32; 2]]),
    ) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::Wait {
            submission_index: Some(p.submission),
            timeout: None,
        })?;
        match p.mapped.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(GpuError::Readback(e.to_string())),
            Err(e) => return Err(GpuError::Readback(e.to_string())),
        }
        let readback = &slots[p.slot].readback;
        let bytes = p.len as u64 * HIT_BYTES;
        {
            let view = readback
                .slice(..bytes)
                .get_mapped_range()
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            words.clear();
            // Read word by word: the mapped pointer's alignment is not promised.
            words.extend(view.chunks_exact(8).map(|b| {
                let word = |i: usize| u32::from_ne_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
                [word(0), word(4)]
            }));
        }
        readback.unmap();
        sink(p.offset, words);
        Ok(())
    }

    /// Makes slot `slot` hold at least `rays` rays (growing to the chunk size at once, so a
    /// stream of chunks allocates once).
    fn reserve(&self, slots: &mut Vec<Slot>, slot: usize, rays: usize, shader: &S) {
        while slots.len() <= slot {
            slots.push(self.new_slot(1, shader));
        }
        if slots[slot].capacity < rays as u64 {
            let capacity = if rays > 1 << 16 {
                self.chunk_rays as u64
            } else {
                rays.next_power_of_two() as u64
            };
            slots[slot] = self.new_slot(capacity, shader);
        }
    }

    fn new_slot(&self, capacity: u64, shader: &S) -> Slot {
        use wgpu::BufferUsages as U;
        let buffer = |label: &str, size: u64, usage: U| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let ray_bytes = std::mem::size_of::<S::GpuRay>() as u64;
        let params = buffer(
            "sightline ray cast params",
            std::mem::size_of::<Params>() as u64,
            U::UNIFORM | U::COPY_DST,
        );
        let rays = buffer(
            "sightline rays",
            capacity * ray_bytes,
            U::STORAGE | U::COPY_DST,
        );
        let hits = buffer(
            "sightline hits",
            capacity * HIT_BYTES,
            U::STORAGE | U::COPY_SRC,
        );
        let readback = buffer(
            "sightline hits readback",
            capacity * HIT_BYTES,
            U::MAP_READ | U::COPY_DST,
        );
        let resources: Vec<wgpu::BindingResource> = std::iter::once(params.as_entire_binding())
            .chain(shader.scene_bindings())
            .chain([rays.as_entire_binding(), hits.as_entire_binding()])
            .collect();
        let entries: Vec<wgpu::BindGroupEntry> = resources
            .into_iter()
            .enumerate()
            .map(|(binding, resource)| wgpu::BindGroupEntry {
                binding: binding as u32,
                resource,
            })
            .collect();
        let bind_group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sightline ray cast"),
            layout: &shader.pipelines().bind_layout,
            entries: &entries,
        });
        Slot {
            capacity,
            params,
            rays,
            hits,
            readback,
            bind_group,
        }
    }
}

/// The panicking face of `try_cast` and `try_occluded` in the casters' [`RayCaster`]
/// implementations.
///
/// [`RayCaster`]: sightline_core::trace::RayCaster
pub(crate) fn or_panic(result: Result<(), GpuError>) {
    if let Err(e) = result {
        panic!("GPU ray casting failed: {e}");
    }
}
