//! The caster of `pvs bake --device gpu`: the GPU ray caster behind the cell-batching caster
//! (`sightline_gpu::CellBatchingCaster`), which runs `--gpu-cells` cells at once and casts
//! their rounds' rays in one batch (`--gpu-cells 1`: the GPU caster alone, each cell's rounds
//! their own batches). A headless build has neither; [`GpuCaster`] is then an empty type that
//! `gpu_caster` never makes (the command refuses `--device gpu` first).

use anyhow::Result;
use sightline_core::trace::RayCaster;
use sightline_core::Scene;

use super::args::BakeArgs;

/// The GPU caster of a bake: alone (`--gpu-cells 1`: each cell's rounds are their own
/// batches, cells on the bake's threads) or behind the cell-batching caster.
#[cfg(feature = "gpu")]
pub(super) enum GpuCaster {
    Alone(Box<sightline_gpu::AnyGpuCaster>),
    Batched(sightline_gpu::CellBatchingCaster),
}

#[cfg(feature = "gpu")]
impl GpuCaster {
    pub(super) fn caster(&self) -> &dyn RayCaster {
        match self {
            Self::Alone(c) => c.as_ref(),
            Self::Batched(c) => c,
        }
    }

    /// Runs `work` (the bake) where its cells should run: on the batching caster's threads.
    pub(super) fn install<R: Send>(&self, work: impl FnOnce() -> R + Send) -> R {
        match self {
            Self::Alone(_) => work(),
            Self::Batched(c) => c.install(work),
        }
    }

    /// A line on stderr with how the bake's rays were batched.
    pub(super) fn report_batches(&self) {
        if let Self::Batched(c) = self {
            let s = c.stats();
            let mean = s.rays as f64 / s.batches.max(1) as f64;
            eprintln!(
                "GPU: {} rays in {} batches ({mean:.0} rays each) from {} calls",
                s.rays, s.batches, s.calls
            );
        }
    }
}

/// The GPU caster for a bake (`--gpu-caster`), `--gpu-cells` cells at once, with lines on
/// stderr naming the caster and the adapter.
#[cfg(feature = "gpu")]
pub(super) fn gpu_caster(scene: &Scene, args: &BakeArgs) -> Result<GpuCaster> {
    let kind = args.gpu_caster.kind();
    let caster = sightline_gpu::AnyGpuCaster::new(scene, kind, Default::default())?;
    let cells = usize::from(args.gpu_cells);
    let batching = match cells {
        1 => "each cell's rounds alone".to_string(),
        n => format!("the rounds of {n} cells at once in one batch"),
    };
    eprintln!("casting rays with the GPU {}", caster.describe());
    eprintln!("GPU batches: {batching}");
    if cells == 1 {
        return Ok(GpuCaster::Alone(Box::new(caster)));
    }
    let options = sightline_gpu::CellBatchingOptions {
        cells,
        ..Default::default()
    };
    let batching = sightline_gpu::CellBatchingCaster::new(std::sync::Arc::new(caster), options);
    Ok(GpuCaster::Batched(batching?))
}

/// No GPU in a headless build: a type without values.
#[cfg(not(feature = "gpu"))]
pub(super) enum GpuCaster {}

#[cfg(not(feature = "gpu"))]
impl GpuCaster {
    pub(super) fn caster(&self) -> &dyn RayCaster {
        match *self {}
    }

    pub(super) fn install<R: Send>(&self, _: impl FnOnce() -> R + Send) -> R {
        match *self {}
    }

    pub(super) fn report_batches(&self) {
        match *self {}
    }
}

/// A headless build has no GPU caster (`bake_command` refuses `--device gpu` before loading).
#[cfg(not(feature = "gpu"))]
pub(super) fn gpu_caster(_scene: &Scene, _args: &BakeArgs) -> Result<GpuCaster> {
    Err(crate::features::not_built("gpu", "--device gpu"))
}
