//! [`GpuRayCaster`]: `sightline-core`'s [`RayCaster`] in wgpu compute shaders. The BVH is the
//! CPU caster's own (binned SAH, collapsed to nodes of [`GpuRayCasterOptions::width`]
//! children, `ray_layout.rs`); `ray_cast.wgsl` traverses it one ray per invocation with a
//! stack, nearer children first, and tests leaves with the CPU's watertight triangle test.
//!
//! Based on: Aila, Laine. Understanding the efficiency of ray traversal on GPUs. HPG 2009
//! (one ray per thread, stack traversal, children's boxes in the parent).
//! Based on: Woop, Benthin, Wald. Watertight Ray/Triangle Intersection. JCGT 2(1), 2013.
//! Based on: Ize. Robust BVH ray traversal. JCGT 2(2), 2013.
//!
//! # Layout: 4-wide nodes
//! The CPU's binned-SAH tree collapsed to 4 children per node (112 bytes: the four boxes as
//! rows of lanes, then one child word each), chosen by measuring the three widths on the same
//! tree with `sightline bench trace --device gpu --gpu-width 2|4|8` on lavapipe (Mesa's
//! software Vulkan driver, 256-bit SIMD, on 2 shared cores; `docs/BENCHMARKS.md`). On the
//! 100k-triangle city, in the quieter of two runs, 4-wide nodes cast 1.05 M coherent and
//! 0.50 M incoherent rays/s, binary nodes with both children's boxes in the parent (Aila and
//! Laine's layout) 0.92 / 0.43 and 8-wide 0.89 / 0.44: wide enough that one node fetch
//! replaces two levels of the binary tree, narrow enough that an invocation does not test
//! empty lanes or sort long runs of entries on its stack (96 entries; `stack_needed` reports
//! what a scene uses). The noisier run ranked binary nodes first, so the margin is small; the
//! other widths stay selectable ([`GpuRayCasterOptions::width`]) and `scripts/gpu-check`
//! measures all three on a real GPU, where wide nodes usually win (Ylitie, Karras, Laine.
//! Efficient incoherent ray traversal on GPUs through compressed wide BVHs. HPG 2017).
//!
//! # Exactness
//! Hits equal the CPU caster's ([`sightline_core::trace::Bvh`]): the same triangle, and the
//! same `t` bits, where the adapter has `SHADER_F64` ([`GpuRayCaster::exact`]); lavapipe and
//! NVIDIA's and AMD's Vulkan drivers do. How:
//! - the ray's shear and inverse direction are computed on the CPU (WGSL division is only
//!   accurate to 2.5 ulp; `ray_layout.rs`);
//! - every product that feeds a sum is forced to be rounded on its own (`rounded` in the
//!   shader), so no driver can fuse it into a multiply-add the CPU does not make;
//! - an edge function that is exactly 0 is recomputed in f64, as on the CPU, and the final
//!   division `t_scaled / det` is made in f64 and rounded to f32, which gives the correctly
//!   rounded f32 quotient (a double result rounded to single is correctly rounded for
//!   division: 53 >= 2 * 24 + 2 bits);
//! - ties in `t` go to the lower triangle id, and boxes are culled against the CPU's slack,
//!   so the result does not depend on the traversal order.
//!
//! Without `SHADER_F64` (Metal, some mobile drivers) the division is WGSL's (2.5 ulp) and a
//! zero edge function stays zero (the ray counts as inside that edge, so rays through a shared
//! edge still hit one of its triangles): `t` within 3 ulp of the CPU's, and a different triangle
//! only where the ray passes within rounding of an edge or two hits are that close in `t`.
//!
//! Rays the CPU caster never lets hit (NaN or infinite origin or direction, zero direction,
//! `t_min > t_max` or NaN range) miss here too.
//!
//! # Streaming
//! Rays go up in chunks of [`GpuRayCasterOptions::chunk_rays`] (capped by the adapter's
//! storage-binding and buffer limits, and by one row of workgroups, so a chunk is one 1D
//! dispatch) through two sets of buffers: while the GPU casts chunk
//! `i`, the CPU prepares and uploads chunk `i + 1` and reads back chunk `i - 1`. Each call
//! takes its own pair of buffer sets from a pool, so calls from several threads (a bake's
//! cells, each casting batches of 64k rays) keep several chunks queued on the GPU at once.
//! `stream.rs` does this for both GPU casters.

use sightline_core::scene::Scene;
use sightline_core::trace::RayCaster;
use sightline_core::{Hit, Ray};
use wgpu::{AdapterInfo, Device, Queue};

use crate::device::{vulkan_device, GpuError};
use crate::ray_layout::{GpuBvh, GpuRay};
use crate::stream::{chunk_cap, or_panic, CastPipelines, ChunkShader, Streamer};

/// Bytes of one prepared ray on the GPU.
const RAY_BYTES: u64 = std::mem::size_of::<GpuRay>() as u64;
/// Ulps within which `t` equals the CPU caster's without `SHADER_F64` (WGSL's 2.5-ulp division
/// of a numerator and denominator that are otherwise the CPU's bits).
pub const APPROXIMATE_T_ULPS: u32 = 3;

/// How a [`GpuRayCaster`] lays out its BVH and streams rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuRayCasterOptions {
    /// Children per node: 2, 4 or 8.
    pub width: usize,
    /// Rays per chunk (at least 1; capped by the adapter's limits: its storage-binding and
    /// buffer sizes, and one dispatch row of workgroups, 4,194,240 rays on most adapters).
    pub chunk_rays: usize,
    /// Use f64 for bit-exact hits where the device has `SHADER_F64` (the default). `false`
    /// takes the path of adapters without it, so that it can be tested on one with it.
    pub use_f64: bool,
}

impl Default for GpuRayCasterOptions {
    fn default() -> Self {
        Self {
            width: 4,
            chunk_rays: 1 << 20,
            use_f64: true,
        }
    }
}

/// Traversal stack entries the shader has for `width`-wide nodes. A binned SAH tree is about
/// `2 log2(n)` levels deep (36 for 10^5 triangles); the build bounds it by a median split below
/// depth 40, and [`GpuRayCaster::with_device`] checks the actual need.
fn stack_entries(width: usize) -> usize {
    match width {
        2 => 64,
        4 => 96,
        _ => 160,
    }
}

/// The shader's stack size for `width`-wide nodes, or an error when a tree needs more.
fn check_stack(needed: usize, width: usize) -> Result<usize, GpuError> {
    let available = stack_entries(width);
    if needed > available {
        return Err(GpuError::StackTooShallow { needed, available });
    }
    Ok(available)
}

/// The scene on the GPU with the pipelines that cast against it; absent when the scene has
/// nothing to hit.
struct Uploaded {
    pipelines: CastPipelines,
    nodes: wgpu::Buffer,
    triangles: wgpu::Buffer,
}

impl ChunkShader for Uploaded {
    type GpuRay = GpuRay;

    fn prepare(&self, ray: &Ray) -> GpuRay {
        GpuRay::new(ray)
    }

    fn pipelines(&self) -> &CastPipelines {
        &self.pipelines
    }

    fn scene_bindings(&self) -> Vec<wgpu::BindingResource<'_>> {
        vec![
            self.nodes.as_entire_binding(),
            self.triangles.as_entire_binding(),
        ]
    }
}

/// A [`RayCaster`] on the GPU (see the module documentation).
///
/// ```no_run
/// use glam::Vec3;
/// use sightline_core::scene::SceneBuilder;
/// use sightline_core::trace::RayCaster;
/// use sightline_core::Ray;
/// use sightline_gpu::{GpuRayCaster, GpuRayCasterOptions};
///
/// let mut b = SceneBuilder::new("one box");
/// b.add_box(Vec3::splat(1.0), Vec3::splat(2.0));
/// let gpu = GpuRayCaster::new(&b.finish(), GpuRayCasterOptions::default())?;
/// println!("on {}", gpu.adapter_info().name);
/// let hit = gpu.cast_one(&Ray::new(Vec3::new(0.0, 1.5, 1.5), Vec3::X));
/// assert_eq!(hit.t, 1.0);
/// # Ok::<(), sightline_gpu::GpuError>(())
/// ```
pub struct GpuRayCaster {
    info: AdapterInfo,
    stream: Streamer<Uploaded>,
    exact: bool,
    width: usize,
    stack_needed: usize,
}

impl GpuRayCaster {
    /// A caster for `scene` on a freshly acquired Vulkan device (see [`vulkan_device`]).
    pub fn new(scene: &Scene, options: GpuRayCasterOptions) -> Result<Self, GpuError> {
        let (device, queue, info) = vulkan_device()?;
        Self::with_device(&device, &queue, info, scene, options)
    }

    /// A caster for `scene` on a caller's device. Builds the BVH on the CPU and uploads it.
    /// Errors when the options are invalid, the tree is deeper than the shader's stack, the
    /// scene does not fit the adapter's buffer limits, or the shader does not compile.
    pub fn with_device(
        device: &Device,
        queue: &Queue,
        info: AdapterInfo,
        scene: &Scene,
        options: GpuRayCasterOptions,
    ) -> Result<Self, GpuError> {
        if options.chunk_rays == 0 {
            return Err(GpuError::ZeroChunk);
        }
        let bvh = GpuBvh::new(scene, options.width)?;
        let stack = check_stack(bvh.stack_needed, options.width)?;
        let limits = device.limits();
        let binding_limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let check = |what: &'static str, bytes: u64| {
            if bytes > binding_limit {
                Err(GpuError::BufferTooLarge {
                    what,
                    bytes,
                    limit: binding_limit,
                })
            } else {
                Ok(())
            }
        };
        let node_bytes: &[u8] = bytemuck::cast_slice(&bvh.nodes);
        let triangle_bytes: &[u8] = bytemuck::cast_slice(&bvh.triangles);
        check("BVH nodes", node_bytes.len() as u64)?;
        check("triangles", triangle_bytes.len() as u64)?;
        let chunk_rays = chunk_cap(device, options.chunk_rays, RAY_BYTES);

        let exact = options.use_f64 && device.features().contains(wgpu::Features::SHADER_F64);
        let source = shader_source(options.width, stack, exact);
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("sightline ray cast"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        // Group 0: the parameters, the BVH nodes and triangles (read-only storage), the rays
        // and the hits.
        let read_only = wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let pipelines = CastPipelines::new(device, &module, &[read_only, read_only]);
        let upload = |label: &str, bytes: &[u8]| {
            use wgpu::util::DeviceExt;
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let uploaded = (bvh.node_count() > 0).then(|| Uploaded {
            pipelines,
            nodes: upload("sightline BVH nodes", node_bytes),
            triangles: upload("sightline BVH triangles", triangle_bytes),
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader(e.to_string()));
        }
        Ok(Self {
            info,
            stream: Streamer::new(device, queue, uploaded, chunk_rays),
            exact,
            width: options.width,
            stack_needed: bvh.stack_needed,
        })
    }

    /// The adapter this caster runs on.
    pub fn adapter_info(&self) -> &AdapterInfo {
        &self.info
    }

    /// True when hits are bit-exact with the CPU caster's (the adapter has `SHADER_F64`); else
    /// `t` is within [`APPROXIMATE_T_ULPS`] (see the module documentation).
    pub fn exact(&self) -> bool {
        self.exact
    }

    /// Rays per chunk, after the adapter's limits.
    pub fn chunk_rays(&self) -> usize {
        self.stream.chunk_rays()
    }

    /// Children per BVH node.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Traversal stack entries this scene's tree needs (at most the shader's).
    pub fn stack_needed(&self) -> usize {
        self.stack_needed
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

impl RayCaster for GpuRayCaster {
    /// # Panics
    /// If `hits.len() != rays.len()` (as the CPU caster), or the GPU fails (device lost); use
    /// [`GpuRayCaster::try_cast`] to get those as errors.
    fn cast(&self, rays: &[Ray], hits: &mut [Hit]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        or_panic(self.try_cast(rays, hits));
    }

    /// # Panics
    /// As [`GpuRayCaster::cast`].
    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "one output slot per ray");
        or_panic(self.try_occluded(rays, out));
    }
}

/// `ray_cast.wgsl` with its constants, and the f64 or f32 versions of the two functions that
/// need f64 for exactness. Assembled as text (not `include_wgsl!`) because WGSL has no
/// preprocessor and an f64 function must not appear in a module for an adapter without it.
fn shader_source(width: usize, stack: usize, f64: bool) -> String {
    // `gamma(n)` of Pharr et al., as the CPU traversal computes it (traverse.rs).
    let gamma = |n: f32| {
        let eps = f32::EPSILON * 0.5;
        n * eps / (1.0 - n * eps)
    };
    let robust_far = 1.0 + 2.0 * gamma(3.0);
    let cull_slack = 16.0 * gamma(3.0);
    let functions = if f64 {
        "// Products of f32s are exact in f64 (so a fused multiply-add changes nothing).
fn exact_edges(ax: f32, ay: f32, bx: f32, by: f32, cx: f32, cy: f32, e: vec3<f32>) -> vec3<f32> {
    let u = f64(cx) * f64(by) - f64(cy) * f64(bx);
    let v = f64(ax) * f64(cy) - f64(ay) * f64(cx);
    let w = f64(bx) * f64(ay) - f64(by) * f64(ax);
    return vec3<f32>(f32(u), f32(v), f32(w));
}

// Correctly rounded: the f64 quotient of two f32s rounded to f32.
fn divide(n: f32, d: f32) -> f32 {
    return f32(f64(n) / f64(d));
}
"
    } else {
        "fn exact_edges(ax: f32, ay: f32, bx: f32, by: f32, cx: f32, cy: f32, e: vec3<f32>) -> vec3<f32> {
    return e;
}

fn divide(n: f32, d: f32) -> f32 {
    return n / d;
}
"
    };
    format!(
        "const WIDTH: u32 = {width}u;\nconst STACK: u32 = {stack}u;\n\
         const ROBUST_FAR: f32 = {robust_far:e};\nconst CULL_SLACK: f32 = {cull_slack:e};\n\n{}\n{functions}",
        include_str!("ray_cast.wgsl")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shader_constants_print_exactly() {
        // `{:e}` prints the shortest decimal that reads back as the same f32.
        let s = shader_source(4, 96, false);
        let line = s.lines().find(|l| l.contains("ROBUST_FAR:")).unwrap();
        let value: f32 = line
            .trim_start_matches("const ROBUST_FAR: f32 = ")
            .trim_end_matches(';')
            .parse()
            .unwrap();
        assert!(value > 1.0 && value < 1.000_001);
    }

    #[test]
    fn deeper_tree_than_the_stack_is_an_error() {
        assert_eq!(check_stack(64, 2).unwrap(), 64);
        assert!(matches!(
            check_stack(65, 2),
            Err(GpuError::StackTooShallow {
                needed: 65,
                available: 64
            })
        ));
    }

    #[test]
    fn stack_grows_with_width() {
        assert!(stack_entries(2) < stack_entries(4));
        assert!(stack_entries(4) < stack_entries(8));
    }
}
