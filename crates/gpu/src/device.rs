//! Getting a Vulkan device: adapter selection and the check that the backend really is Vulkan.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, section 2.4 (occlusion queries return the number of samples that passed the
//! depth test; the algorithm needs that count, or at least its exactness, to be trusted).
//!
//! wgpu can fall back to its GL backend, whose occlusion queries are only booleans and whose
//! drivers (llvmpipe, ANGLE) differ from the Vulkan path tested here. So only Vulkan adapters
//! are accepted and the adapter's reported backend is checked again after selection.

use wgpu::{Adapter, AdapterInfo, Backend, Backends, Device, DeviceType, Queue};

/// Why no usable GPU device was obtained, or why GPU work failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No Vulkan adapter is present (no driver, or no ICD file).
    #[error(
        "no Vulkan adapter found: install a Vulkan driver (for CI and machines without a GPU: \
         `apt-get install -y mesa-vulkan-drivers`, Mesa's lavapipe software driver)"
    )]
    NoVulkanAdapter,
    /// The adapter found runs on another backend (e.g. GL, whose queries are only booleans).
    #[error("adapter {name:?} runs on the {backend:?} backend, not Vulkan")]
    NotVulkan {
        /// The adapter's name.
        name: String,
        /// The backend it runs on.
        backend: Backend,
    },
    /// The adapter refused to create a device.
    #[error("requesting a device from the Vulkan adapter failed: {0}")]
    RequestDevice(#[from] wgpu::RequestDeviceError),
    /// Waiting for the GPU failed (device lost, timeout).
    #[error("waiting for the GPU failed: {0}")]
    Poll(#[from] wgpu::PollError),
    /// A [`MeshId`](crate::MeshId) that this backend did not upload.
    #[error("mesh {0} was not uploaded to this backend")]
    UnknownMesh(u32),
    /// Mapping a readback buffer (occlusion query results, ray hits) failed.
    #[error("reading GPU results back failed: {0}")]
    Readback(String),
    /// A ray caster's node width other than 2, 4 or 8.
    #[error("BVH node width {0} is not supported on the GPU (2, 4 or 8)")]
    UnsupportedWidth(usize),
    /// A ray caster's chunk of zero rays.
    #[error("rays per chunk must be at least 1")]
    ZeroChunk,
    /// The BVH is deeper than the ray-casting shader's fixed traversal stack.
    #[error(
        "the BVH needs a traversal stack of {needed} entries; the GPU shader has {available} \
         (try another node width)"
    )]
    StackTooShallow {
        /// Entries the tree needs.
        needed: usize,
        /// Entries the shader has.
        available: usize,
    },
    /// More triangles or nodes than the GPU layout's 28-bit indices address.
    #[error("{triangles} triangles in {nodes} BVH nodes do not fit the GPU layout (2^28 each)")]
    SceneTooLarge {
        /// Triangles the BVH holds.
        triangles: usize,
        /// Its nodes.
        nodes: usize,
    },
    /// A buffer larger than the adapter binds.
    #[error("{what} take {bytes} bytes; this adapter binds at most {limit}")]
    BufferTooLarge {
        /// What the buffer holds.
        what: &'static str,
        /// Its size.
        bytes: u64,
        /// The adapter's limit.
        limit: u64,
    },
    /// The output slice of a ray query is not as long as its rays.
    #[error("{rays} rays but {out} output slots")]
    LengthMismatch {
        /// Rays given.
        rays: usize,
        /// Output slots given.
        out: usize,
    },
    /// A shader or pipeline failed to compile or validate (a bug, or a driver's).
    #[error("GPU shader failed: {0}")]
    Shader(String),
    /// A cell-batching caster for zero cells at once.
    #[error("cells batched at once must be at least 1")]
    ZeroCells,
    /// Starting the threads of a cell-batching caster failed.
    #[error("starting the batching threads failed: {0}")]
    Threads(String),
    /// The ray-query caster on a device without `EXPERIMENTAL_RAY_QUERY` (the adapter has no
    /// `VK_KHR_ray_query`, or the device was requested without the feature).
    #[error(
        "adapter {adapter:?} offers no hardware ray queries (Vulkan VK_KHR_ray_query and \
         acceleration structures, wgpu's EXPERIMENTAL_RAY_QUERY); Mesa's lavapipe has them \
         from Mesa 24.1 (Debian 12: from bookworm-backports), or use the compute-shader caster"
    )]
    NoRayQuery {
        /// The adapter's name.
        adapter: String,
    },
    /// The driver refused to build an acceleration structure (a bug, or a driver's).
    #[error("building the acceleration structures failed: {0}")]
    AccelerationStructure(String),
    /// More triangles than one bottom-level acceleration structure of the adapter holds.
    #[error(
        "{triangles} triangles; this adapter's acceleration structures hold at most {limit} \
         (max_blas_primitive_count)"
    )]
    TooManyTriangles {
        /// Triangles the scene has.
        triangles: usize,
        /// The adapter's limit.
        limit: u32,
    },
}

/// Checks that `info` describes a Vulkan adapter.
///
/// ```
/// use sightline_gpu::{check_vulkan, GpuError};
/// // What wgpu reports when it falls back to GL on Mesa's llvmpipe.
/// let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Gl);
/// info.name = "llvmpipe".into();
/// assert!(matches!(check_vulkan(&info), Err(GpuError::NotVulkan { .. })));
/// info.backend = wgpu::Backend::Vulkan;
/// assert!(check_vulkan(&info).is_ok());
/// ```
pub fn check_vulkan(info: &AdapterInfo) -> Result<(), GpuError> {
    if info.backend == Backend::Vulkan {
        Ok(())
    } else {
        Err(GpuError::NotVulkan {
            name: info.name.clone(),
            backend: info.backend,
        })
    }
}

/// Preference among adapters: a real GPU first, Mesa's lavapipe (a CPU device) last, so the
/// same code runs on a workstation's GPU and in CI.
fn rank(kind: DeviceType) -> u8 {
    match kind {
        DeviceType::DiscreteGpu => 0,
        DeviceType::IntegratedGpu => 1,
        DeviceType::VirtualGpu => 2,
        DeviceType::Other => 3,
        DeviceType::Cpu => 4,
    }
}

/// Picks the Vulkan adapter to use: the one whose name contains the environment variable
/// `SIGHTLINE_GPU_ADAPTER` (case-insensitive) if set and matched, else the best ranked.
fn pick(adapters: Vec<Adapter>) -> Option<Adapter> {
    let wanted = std::env::var("SIGHTLINE_GPU_ADAPTER")
        .ok()
        .map(|s| s.to_lowercase());
    let mut adapters: Vec<(AdapterInfo, Adapter)> =
        adapters.into_iter().map(|a| (a.get_info(), a)).collect();
    if let Some(w) = wanted {
        if let Some(i) = adapters
            .iter()
            .position(|(info, _)| info.name.to_lowercase().contains(&w))
        {
            return Some(adapters.swap_remove(i).1);
        }
    }
    adapters.sort_by_key(|(info, _)| rank(info.device_type));
    adapters.into_iter().next().map(|(_, a)| a)
}

/// Picks among `adapters` as [`vulkan_device`] does: the one named by `SIGHTLINE_GPU_ADAPTER`,
/// else a real GPU before a CPU device (lavapipe). For callers that filter the adapters first,
/// e.g. by support of a window's surface. `None` when `adapters` is empty.
pub fn pick_adapter(adapters: Vec<Adapter>) -> Option<Adapter> {
    pick(adapters)
}

/// Acquires a Vulkan device and its queue (blocking), with the adapter's description.
///
/// Only `Backends::VULKAN` is enumerated and the chosen adapter's backend is checked with
/// [`check_vulkan`]. Occlusion queries are part of core WebGPU, so no optional feature or
/// raised limit is required and any conformant Vulkan 1.x driver works. Where the adapter has
/// them, `SHADER_F64` (exact hits of [`GpuRayCaster`](crate::GpuRayCaster)) and
/// `EXPERIMENTAL_RAY_QUERY` with the adapter's acceleration-structure limits
/// ([`RayQueryCaster`](crate::RayQueryCaster)) are requested, and the adapter's buffer-size
/// limits. Set `SIGHTLINE_GPU_ADAPTER` to part of an adapter's name to choose among several.
pub fn vulkan_device() -> Result<(Device, Queue, AdapterInfo), GpuError> {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = Backends::VULKAN;
    let instance = wgpu::Instance::new(desc);
    let adapters = pollster::block_on(instance.enumerate_adapters(Backends::VULKAN));
    let adapter = pick(adapters).ok_or(GpuError::NoVulkanAdapter)?;
    let info = adapter.get_info();
    check_vulkan(&info)?;
    // Optional: f64 makes the ray caster's hits bit-exact (`ray_cast.rs`), and the adapter's
    // own buffer limits let it hold large scenes. Neither changes the occlusion queries.
    let adapter_limits = adapter.limits();
    let mut required_limits = wgpu::Limits {
        max_storage_buffer_binding_size: adapter_limits.max_storage_buffer_binding_size,
        max_buffer_size: adapter_limits.max_buffer_size,
        ..Default::default()
    };
    // Optional too: hardware ray queries for `ray_query.rs`, with the adapter's own
    // acceleration-structure limits (the defaults are 0, which allow no BLAS at all).
    let ray_query = adapter
        .features()
        .contains(wgpu::Features::EXPERIMENTAL_RAY_QUERY);
    let mut experimental_features = wgpu::ExperimentalFeatures::disabled();
    if ray_query {
        required_limits.max_blas_primitive_count = adapter_limits.max_blas_primitive_count;
        required_limits.max_blas_geometry_count = adapter_limits.max_blas_geometry_count;
        required_limits.max_tlas_instance_count = adapter_limits.max_tlas_instance_count;
        required_limits.max_acceleration_structures_per_shader_stage =
            adapter_limits.max_acceleration_structures_per_shader_stage;
        // SAFETY: wgpu asks callers of its EXPERIMENTAL_* features to accept that their
        // implementation may still have bugs. Only `ray_query.rs` uses the feature: one
        // opaque triangle BLAS and one TLAS, built once and only read afterwards, the path
        // wgpu's own ray-query examples and tests take.
        experimental_features = unsafe { wgpu::ExperimentalFeatures::enabled() };
    }
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("sightline-gpu"),
        required_features: adapter.features()
            & (wgpu::Features::SHADER_F64 | wgpu::Features::EXPERIMENTAL_RAY_QUERY),
        required_limits,
        experimental_features,
        ..Default::default()
    }))?;
    Ok((device, queue, info))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rank_prefers_real_gpus_over_cpu() {
        assert!(rank(DeviceType::DiscreteGpu) < rank(DeviceType::IntegratedGpu));
        assert!(rank(DeviceType::IntegratedGpu) < rank(DeviceType::Cpu));
    }

    #[test]
    fn pick_of_no_adapters_is_none() {
        assert!(pick(Vec::new()).is_none());
    }
}
