//! RASTER: from-region visibility by rendering, the rasterization baseline of Koch & Wimmer
//! 2021 (section 6.1, after Nirenstein & Blake 2004): cube maps (the paper's hemicubes, here
//! all six faces since our cells may be boxes seen from inside) rendered from Halton points
//! on the view cell with the reference rasterizer; the PVS is the union of the triangle ids in
//! the images. As the paper found, uniform (Halton) placement instead of Nirenstein and
//! Blake's adaptive placement.
//!
//! Budget accounting: one cube map of resolution R counts as 6 R² rays, so RASTER can be
//! compared with the ray-casting samplers at equal "rays" (pixels).
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, section 6.1; Nirenstein, Blake.
//! Hardware Accelerated Visibility Preprocessing using Adaptive Sampling. EGSR 2004.

use sightline_core::raster::{Frame, Rasterizer};
use sightline_core::sampling::ShiftedHalton;
use sightline_core::{Camera, Hit};

use crate::sampler::{Budget, CellContext, CellResult, ConvergencePoint, Sampler, Tally};
use crate::viewcell::CellSurface;

/// Cube maps rendered when the budget sets no limit.
pub const DEFAULT_VIEWS: u64 = 64;

/// The RASTER sampler.
#[derive(Clone, Debug)]
pub struct RasterSampler {
    /// Cube-map face resolution (square).
    pub resolution: u32,
}

impl Default for RasterSampler {
    fn default() -> Self {
        Self { resolution: 512 }
    }
}

impl Sampler for RasterSampler {
    fn name(&self) -> &'static str {
        "raster"
    }

    fn sample(
        &self,
        ctx: &CellContext<'_>,
        budget: &Budget,
        progress: &(dyn Fn(&ConvergencePoint) + Sync),
    ) -> CellResult {
        let r = self.resolution.max(1);
        let pixels_per_view = 6 * u64::from(r) * u64::from(r);
        let budget = if budget.is_unlimited() {
            Budget::rays(DEFAULT_VIEWS * pixels_per_view)
        } else {
            *budget
        };
        let mut tally = Tally::new(ctx.scene.triangle_count(), budget);
        let surface = CellSurface::new(ctx.cell);
        let halton = ShiftedHalton::<3>::new(ctx.seed ^ 0x7261_7374);
        let near = ctx.cell.default_near(ctx.scene);
        let mut rasterizer = Rasterizer::new(ctx.scene);
        let mut frame = Frame::new(r, r);
        let mut view = 0u64;
        while !tally.exhausted() {
            let (eye, _) = surface.sample(halton.point(view));
            view += 1;
            if !ctx.origin_allowed(eye) {
                // Give up on a cell without free space rather than searching forever.
                if view > 1000 && tally.rays == 0 {
                    break;
                }
                continue;
            }
            let Ok(faces) = Camera::cube_faces(eye, r, near) else {
                break;
            };
            for face in &faces {
                rasterizer.render(face, None, &mut frame);
                for &id in &frame.ids {
                    if id != Hit::NONE {
                        tally.pvs.insert(id);
                    }
                }
            }
            tally.batch_done(pixels_per_view as usize, progress);
        }
        let found = tally.pvs.count();
        tally.finish(vec![("raster", found)])
    }
}
