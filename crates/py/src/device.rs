//! The `device` and `gpu_caster` arguments of `bake`: `"cpu"` casts with the scene's BVH,
//! `"gpu"` with one of sightline-gpu's ray casters behind its cell-batching caster, as
//! `sightline pvs bake --device gpu --gpu-caster C` does (16 cells at once, their ray batches
//! cast together). `gpu_caster="auto"` takes hardware ray queries where the adapter has them,
//! else the compute caster; `"compute"`'s hits are bit-identical to the CPU's on adapters with
//! `SHADER_F64`, so the same sets. The GPU parts are the cargo feature `gpu`,
//! on in the package's build (`pyproject.toml`); a build without it refuses `"gpu"` with a
//! `RuntimeError` naming the feature, as it refuses a missing Vulkan adapter.

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::Scene;

use crate::convert::value_error;

/// Where a bake casts its rays.
pub(crate) enum BakeCaster {
    /// The scene's BVH.
    Cpu,
    /// The GPU caster, batched across cells.
    #[cfg(feature = "gpu")]
    Gpu(sightline_gpu::CellBatchingCaster),
}

impl BakeCaster {
    /// The caster for `device` over `scene`. Errors: `ValueError` for another name,
    /// `RuntimeError` for `"gpu"` without the GPU parts or without a Vulkan adapter.
    pub(crate) fn new(
        py: Python<'_>,
        device: &str,
        gpu_caster: &str,
        scene: &Scene,
    ) -> PyResult<Self> {
        if !GPU_CASTERS.contains(&gpu_caster) {
            return Err(value_error(format!(
                "gpu_caster must be \"auto\", \"compute\" or \"ray-query\", not {gpu_caster:?}"
            )));
        }
        match device {
            "cpu" => Ok(Self::Cpu),
            "gpu" => gpu(py, gpu_caster, scene),
            other => Err(value_error(format!(
                "device must be \"cpu\" or \"gpu\", not {other:?}"
            ))),
        }
    }

    /// The caster to bake with (`bvh`, the scene's, on the CPU).
    pub(crate) fn caster<'a>(&'a self, bvh: &'a Bvh) -> &'a dyn RayCaster {
        match self {
            Self::Cpu => bvh,
            #[cfg(feature = "gpu")]
            Self::Gpu(g) => g,
        }
    }

    /// Runs `work` where the bake's cells should run: as called on the CPU, on the GPU
    /// caster's pool of cell threads (so that many cells' rays meet in one batch).
    pub(crate) fn install<R: Send>(&self, work: impl FnOnce() -> R + Send) -> R {
        match self {
            Self::Cpu => work(),
            #[cfg(feature = "gpu")]
            Self::Gpu(g) => g.install(work),
        }
    }
}

/// The names `gpu_caster` takes (`sightline_gpu::GpuCasterKind`'s, which the GPU-less build
/// checks too).
const GPU_CASTERS: [&str; 3] = ["auto", "compute", "ray-query"];

#[cfg(feature = "gpu")]
fn gpu(py: Python<'_>, gpu_caster: &str, scene: &Scene) -> PyResult<BakeCaster> {
    let runtime =
        |e: sightline_gpu::GpuError| PyRuntimeError::new_err(format!("device=\"gpu\": {e}"));
    // `new` checked the name against the same list.
    let kind = sightline_gpu::GpuCasterKind::from_name(gpu_caster).unwrap_or_default();
    let caster = py
        .detach(|| sightline_gpu::AnyGpuCaster::new(scene, kind, Default::default()))
        .map_err(runtime)?;
    if matches!(caster.kind(), sightline_gpu::GpuCasterKind::Compute) && !caster.exact() {
        let category = py.get_type::<pyo3::exceptions::PyRuntimeWarning>();
        let text = "device=\"gpu\": this adapter has no SHADER_F64: hit distances may differ \
                    from the CPU caster's in the last bits, and the sets slightly from a CPU bake's";
        py.import("warnings")?
            .call_method1("warn", (text, category, 2))?;
    }
    let batching = sightline_gpu::CellBatchingCaster::new(
        std::sync::Arc::new(caster),
        sightline_gpu::CellBatchingOptions::default(),
    );
    Ok(BakeCaster::Gpu(batching.map_err(runtime)?))
}

#[cfg(not(feature = "gpu"))]
fn gpu(_py: Python<'_>, _gpu_caster: &str, _scene: &Scene) -> PyResult<BakeCaster> {
    Err(PyRuntimeError::new_err(
        "device=\"gpu\" needs sightline built with the cargo feature `gpu` (the package's \
         default build has it; this one was built without it)",
    ))
}
