//! The trait every rasterizer kernel of the masked occlusion buffer implements. A leaf: the
//! kernels (`scalar.rs`, `sse2.rs`, `avx2.rs`, `baseline.rs`) implement it from here, and only
//! `kernel.rs`, which no kernel imports, knows them all and dispatches to them.

use glam::Vec3;

use super::project::Projector;
use super::tiles::Tiles;

/// A rasterizer kernel: draws occluder triangles into the tiles.
pub(super) trait RasterKernel {
    /// Rasterizes occluder triangles, given as a flat list of world-space corners (three per
    /// triangle; a trailing incomplete triangle is ignored) seen through `proj`, in their
    /// order (the tile merge depends on it). Triangles are double-sided; non-finite and
    /// degenerate ones and those behind the near plane are skipped, those crossing the near
    /// plane or the guard band are clipped.
    ///
    /// # Safety
    /// The CPU must support the instructions the kernel is compiled for: [`render`] calls a
    /// kernel only after [`Kernel::available`] (or [`BaselineKernel::available`]) said so.
    ///
    /// [`render`]: super::kernel::render
    /// [`Kernel::available`]: super::kernel::Kernel::available
    /// [`BaselineKernel::available`]: super::kernel::BaselineKernel::available
    unsafe fn render(tiles: &mut Tiles, triangles: &[Vec3], proj: &Projector);
}
