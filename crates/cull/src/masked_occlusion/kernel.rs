//! The rasterizer kernels of the masked occlusion buffer: the public choice among them
//! ([`Kernel`]), the ones kept only as measuring sticks ([`BaselineKernel`]), and the one place
//! where the CPU's features are detected and a kernel is dispatched to. The trait each
//! implements, [`RasterKernel`], is in `raster_kernel.rs`: the kernels take it from there and
//! never import this file, which imports them all.
//!
//! A new kernel (an AVX-512 one, say) is one new file with a unit struct implementing
//! [`RasterKernel`], built from the shared pieces ([`Projector`] for the view transform and
//! clipping, [`Tiles`] for the storage and the tile merge, `per_tile.rs` for a kernel that
//! only changes the span and mask steps), plus a variant of [`Kernel`] and its arms in
//! [`Kernel::available`], [`Kernel::detect`] and [`render`] below. Every kernel must give the
//! buffer the others give, bit for bit (`tests/kernels.rs` compares them all).

use glam::Vec3;

use super::project::Projector;
use super::raster_kernel::RasterKernel;
use super::scalar::Scalar;
use super::tiles::Tiles;
#[cfg(target_arch = "x86_64")]
use super::{
    avx2::{Avx2, Avx512},
    baseline::Avx2PerTile,
    sse2::Sse2,
};

/// Which implementation of the rasterizer's inner loops an
/// [`OcclusionBuffer`](super::OcclusionBuffer) uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Portable Rust, one scanline and one pixel row at a time.
    Scalar,
    /// SSE2 (every x86_64 CPU): 4 scanlines per instruction, masks by byte comparisons.
    Sse2,
    /// AVX2: triangle setup for 8 triangles at once (one per lane), then per triangle the
    /// masks, depths and merges of a block of 4x2 tiles at once (one tile per lane), without
    /// branches per tile.
    Avx2,
    /// AVX-512 (F, BW, DQ, VL): the AVX2 kernel's setup, then per triangle two blocks (16
    /// tiles, two block rows) at once in 512-bit registers.
    Avx512,
}

impl Kernel {
    /// Every kernel, scalar first.
    pub const ALL: [Kernel; 4] = [Kernel::Scalar, Kernel::Sse2, Kernel::Avx2, Kernel::Avx512];

    /// The fastest kernel this CPU supports.
    pub fn detect() -> Self {
        if Kernel::Avx512.available() {
            Kernel::Avx512
        } else if Kernel::Avx2.available() {
            Kernel::Avx2
        } else if Kernel::Sse2.available() {
            Kernel::Sse2
        } else {
            Kernel::Scalar
        }
    }

    /// True when this CPU can run the kernel.
    pub fn available(self) -> bool {
        match self {
            Kernel::Scalar => true,
            Kernel::Sse2 => cpu_has_sse2(),
            Kernel::Avx2 => cpu_has_avx2(),
            Kernel::Avx512 => cpu_has_avx512(),
        }
    }

    /// A short name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Scalar => "scalar",
            Kernel::Sse2 => "sse2",
            Kernel::Avx2 => "avx2",
            Kernel::Avx512 => "avx512",
        }
    }
}

/// Kernels kept only to measure the public ones against (`benches/occlusion.rs`) and to
/// check them (`tests/kernels.rs`); not part of the supported API. They give the same buffers
/// as the public kernels, bit for bit.
#[doc(hidden)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BaselineKernel {
    /// The SSE2 kernel under its bench name from before the block kernel: since that commit
    /// (d99926b) it has run the code of [`Kernel::Sse2`], so its row measures the noise.
    Sse2PerTile,
    /// The AVX2 kernel before the block kernel: one triangle set up and one tile drawn at a
    /// time, a whole 32-pixel tile mask in one 256-bit comparison (`baseline.rs`).
    Avx2PerTile,
}

impl BaselineKernel {
    /// Every baseline kernel.
    pub const ALL: [BaselineKernel; 2] = [BaselineKernel::Sse2PerTile, BaselineKernel::Avx2PerTile];

    /// True when this CPU can run the kernel.
    pub fn available(self) -> bool {
        match self {
            BaselineKernel::Sse2PerTile => cpu_has_sse2(),
            BaselineKernel::Avx2PerTile => cpu_has_avx2(),
        }
    }

    /// A short name for reports.
    pub fn name(self) -> &'static str {
        match self {
            BaselineKernel::Sse2PerTile => "sse2_per_tile",
            BaselineKernel::Avx2PerTile => "avx2_per_tile",
        }
    }
}

/// SSE2 is part of the x86_64 baseline: there is nothing to detect.
fn cpu_has_sse2() -> bool {
    cfg!(target_arch = "x86_64")
}

fn cpu_has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

fn cpu_has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        has!("avx512f") && has!("avx512bw") && has!("avx512dq") && has!("avx512vl")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Draws the triangles with `kernel`.
///
/// # Safety
/// `kernel` must be available on this CPU ([`Kernel::available`]).
pub(super) unsafe fn render(
    kernel: Kernel,
    tiles: &mut Tiles,
    triangles: &[Vec3],
    proj: &Projector,
) {
    match kernel {
        // SAFETY: the kernel is available (this function's contract), i.e. the CPU has AVX2.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { Avx2::render(tiles, triangles, proj) },
        // SAFETY: the kernel is available, i.e. the CPU has AVX-512 F, BW, DQ and VL.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { Avx512::render(tiles, triangles, proj) },
        // SAFETY: SSE2 is part of the x86_64 baseline, enabled on this target.
        #[cfg(target_arch = "x86_64")]
        Kernel::Sse2 => unsafe { Sse2::render(tiles, triangles, proj) },
        // SAFETY: the scalar kernel is portable Rust. (Elsewhere than x86_64 the SIMD kernels
        // are never available, so they never reach this arm.)
        _ => unsafe { Scalar::render(tiles, triangles, proj) },
    }
}

/// Draws the triangles with a baseline kernel; false (and nothing drawn) when this CPU cannot
/// run it.
pub(super) fn render_baseline(
    kernel: BaselineKernel,
    tiles: &mut Tiles,
    triangles: &[Vec3],
    proj: &Projector,
) -> bool {
    if !kernel.available() {
        return false;
    }
    match kernel {
        // SAFETY: SSE2 is part of the x86_64 baseline, enabled on this target.
        #[cfg(target_arch = "x86_64")]
        BaselineKernel::Sse2PerTile => unsafe { Sse2::render(tiles, triangles, proj) },
        // SAFETY: `available` just saw `is_x86_feature_detected!("avx2")`.
        #[cfg(target_arch = "x86_64")]
        BaselineKernel::Avx2PerTile => unsafe { Avx2PerTile::render(tiles, triangles, proj) },
        // Elsewhere no baseline is available (returned above).
        #[cfg(not(target_arch = "x86_64"))]
        _ => {
            let _ = (tiles, triangles, proj);
        }
    }
    true
}

#[cfg(test)]
mod tests {
    // The tile-at-a-time kernels' mask steps, compared here where every kernel is known (in
    // `per_tile.rs` the test would make the kernels and their shared rasterizer import each
    // other).
    use super::super::per_tile::{TileRowSpans, TileSteps, EMPTY_HI, EMPTY_LO};
    use super::*;

    /// The masks of every kernel on the same spans, on x86_64 (SSE2 always, AVX2 where the CPU
    /// has it).
    fn simd_masks(s: &TileRowSpans, base: i32) -> Vec<u32> {
        #[allow(unused_mut)]
        let mut out = Vec::new();
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: SSE2 is part of the x86_64 baseline.
            out.push(unsafe { Sse2::mask(s, base) });
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 support was just checked.
                out.push(unsafe { Avx2PerTile::mask(s, base) });
            }
        }
        out
    }

    #[test]
    fn masks_agree_on_every_span_pair() {
        // Every start/end pair around one tile, in every row, through each kernel.
        for a in -10..20 {
            for b in -10..20 {
                for k in 0..4 {
                    let mut s = TileRowSpans {
                        a: [EMPTY_LO; 4],
                        b: [EMPTY_HI; 4],
                    };
                    s.a[k] = a;
                    s.b[k] = b;
                    s.a[(k + 1) % 4] = 3;
                    s.b[(k + 1) % 4] = 12;
                    // SAFETY: the scalar kernel is portable.
                    let m = unsafe { Scalar::mask(&s, 8) };
                    for simd in simd_masks(&s, 8) {
                        assert_eq!(simd, m, "{s:?}");
                    }
                    // Against a per-pixel evaluation of the same spans.
                    let mut expect = 0u32;
                    for (row, (&lo, &hi)) in s.a.iter().zip(&s.b).enumerate() {
                        for c in 0..8 {
                            if lo <= 8 + c && 8 + c <= hi {
                                expect |= 1 << (8 * row as i32 + c);
                            }
                        }
                    }
                    assert_eq!(m, expect, "{s:?}");
                }
            }
        }
    }
}
