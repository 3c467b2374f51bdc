//! The per-tile AVX2 kernel of the masked occlusion buffer, the AVX2 kernel before the block
//! kernel (`avx2.rs`): the tile-at-a-time rasterizer (`per_tile.rs`) compiled with AVX2, the
//! spans of the SSE2 kernel and a whole 32-pixel tile mask in one 256-bit comparison. Kept only
//! as a baseline ([`BaselineKernel::Avx2PerTile`](super::BaselineKernel::Avx2PerTile)) that
//! the bench measures the block kernel against and the tests compare it with.
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! sections 3-4 (a tile's coverage mask from its scanlines' span ends, data-parallel).

use std::arch::x86_64::*;

use glam::Vec3;

use super::per_tile::{self, ColClamp, Edges, TileRowSpans, TileSteps};
use super::project::Projector;
use super::raster_kernel::RasterKernel;
use super::sse2::{packed_rel, Sse2};
use super::tiles::Tiles;

/// The per-tile AVX2 kernel.
pub(super) struct Avx2PerTile;

impl RasterKernel for Avx2PerTile {
    unsafe fn render(tiles: &mut Tiles, triangles: &[Vec3], proj: &Projector) {
        // SAFETY: the CPU supports AVX2 (this function's contract).
        unsafe { render_avx2(tiles, triangles, proj) }
    }
}

/// The entry point: the tile-at-a-time rasterizer compiled with AVX2 enabled, so that its
/// `#[inline(always)]` body and the AVX2 mask are inlined into one function.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
unsafe fn render_avx2(tiles: &mut Tiles, triangles: &[Vec3], proj: &Projector) {
    // SAFETY: this function requires AVX2.
    unsafe { per_tile::render::<Avx2PerTile>(tiles, triangles, proj) }
}

impl TileSteps for Avx2PerTile {
    const PREFETCH: bool = true;

    /// The SSE2 kernel's spans (compiled here with the VEX encoding: the same results).
    #[inline(always)]
    fn spans(e: &Edges, c: &ColClamp, ty: u32) -> TileRowSpans {
        Sse2::spans(e, c, ty)
    }

    #[inline(always)]
    unsafe fn mask(s: &TileRowSpans, base: i32) -> u32 {
        // SAFETY: the CPU supports AVX2 (this function's contract).
        unsafe { mask_avx2(s, base) }
    }
}

/// Coverage mask, AVX2: the span ends shuffled to the 32 byte lanes of one register, one
/// comparison per side and one `movemask` for the whole tile.
#[inline]
#[target_feature(enable = "avx2")]
fn mask_avx2(s: &TileRowSpans, base: i32) -> u32 {
    let p8 = _mm256_broadcastsi128_si256(packed_rel(s, base));
    // Byte lane 8k + c takes row k's start (byte k) or end (byte 4 + k); the shuffle works
    // within 128-bit halves, each of which holds all 8 bytes after the broadcast.
    let ia = _mm256_setr_epi8(
        0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 3, 3, 3, 3, 3, 3,
        3, 3,
    );
    let ib = _mm256_add_epi8(ia, _mm256_set1_epi8(4));
    let a = _mm256_shuffle_epi8(p8, ia);
    let b = _mm256_shuffle_epi8(p8, ib);
    let cols = _mm256_setr_epi8(
        0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5,
        6, 7,
    );
    let out = _mm256_or_si256(_mm256_cmpgt_epi8(a, cols), _mm256_cmpgt_epi8(cols, b));
    !(_mm256_movemask_epi8(out) as u32)
}
