//! The SSE2 kernel of the masked occlusion buffer (every x86_64 CPU): the tile-at-a-time
//! rasterizer (`per_tile.rs`) with the 4 scanlines of a tile row in the 4 lanes of one
//! register and each tile's coverage mask from byte comparisons, 16 pixels per `movemask`.
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! sections 3-4: the edges of a triangle are evaluated for all scanlines of a tile row at once
//! (one SIMD lane per scanline), and a tile's 32-bit coverage mask is built from the span ends
//! of its scanlines with data-parallel operations instead of per-pixel tests. Here a lane is
//! one of the 4 scanlines of an 8x4 tile row (`__m128`), and the mask of one tile comes from
//! comparing the 32 pixel columns (one byte lane each) with the span ends, then `movemask`.

use std::arch::x86_64::*;

use glam::Vec3;

use super::constants::TILE_H;
use super::per_tile::{self, ColClamp, Edges, TileRowSpans, TileSteps, EMPTY_HI, EMPTY_LO};
use super::project::Projector;
use super::raster_kernel::RasterKernel;
use super::tiles::Tiles;

/// The SSE2 kernel.
pub(super) struct Sse2;

impl RasterKernel for Sse2 {
    unsafe fn render(tiles: &mut Tiles, triangles: &[Vec3], proj: &Projector) {
        // SAFETY: SSE2 is part of the x86_64 baseline, enabled on this target.
        unsafe { per_tile::render::<Sse2>(tiles, triangles, proj) }
    }
}

impl TileSteps for Sse2 {
    const PREFETCH: bool = true;

    /// The 4 scanlines in the 4 lanes of one register.
    #[inline(always)]
    fn spans(e: &Edges, c: &ColClamp, ty: u32) -> TileRowSpans {
        // SAFETY: SSE2 intrinsics only; SSE2 is part of the x86_64 baseline, so it is always
        // enabled on this target.
        #[allow(unused_unsafe)]
        unsafe {
            let row_base = (ty * TILE_H) as i32;
            // Same rounding as the scalar `row_base + 0.5 + k`: all terms are small integers or
            // halves, exact in f32.
            let yc = _mm_add_ps(
                _mm_set1_ps(row_base as f32 + 0.5),
                _mm_setr_ps(0.0, 1.0, 2.0, 3.0),
            );
            let mut xl = _mm_set1_ps(f32::NEG_INFINITY);
            let mut xr = _mm_set1_ps(f32::INFINITY);
            for i in 0..3 {
                if !e.used[i] {
                    continue;
                }
                let d = _mm_sub_ps(yc, _mm_set1_ps(e.y0[i]));
                let x = _mm_add_ps(_mm_set1_ps(e.x0[i]), _mm_mul_ps(d, _mm_set1_ps(e.slope[i])));
                // `maxps(x, acc)` returns `acc` when `x` is NaN, as `f32::max` does.
                if e.left[i] {
                    xl = _mm_max_ps(x, xl);
                } else {
                    xr = _mm_min_ps(x, xr);
                }
            }
            let half = _mm_set1_ps(0.5);
            let xa = _mm_min_ps(
                _mm_max_ps(_mm_sub_ps(xl, half), _mm_set1_ps(c.a_lo)),
                _mm_set1_ps(c.a_hi),
            );
            let xb = _mm_min_ps(
                _mm_max_ps(_mm_sub_ps(xr, half), _mm_set1_ps(c.b_lo)),
                _mm_set1_ps(c.b_hi),
            );
            // ceil / floor: truncate, then correct by the comparison mask (-1 where true).
            let ta = _mm_cvttps_epi32(xa);
            let a = _mm_sub_epi32(ta, _mm_castps_si128(_mm_cmpgt_ps(xa, _mm_cvtepi32_ps(ta))));
            let tb = _mm_cvttps_epi32(xb);
            let b = _mm_add_epi32(tb, _mm_castps_si128(_mm_cmplt_ps(xb, _mm_cvtepi32_ps(tb))));
            let rows = _mm_add_epi32(_mm_set1_epi32(row_base), _mm_setr_epi32(0, 1, 2, 3));
            let invalid = _mm_or_si128(
                _mm_or_si128(
                    _mm_cmplt_epi32(rows, _mm_set1_epi32(c.row0)),
                    _mm_cmpgt_epi32(rows, _mm_set1_epi32(c.row1)),
                ),
                _mm_cmpgt_epi32(a, b),
            );
            let a = _mm_or_si128(
                _mm_and_si128(invalid, _mm_set1_epi32(EMPTY_LO)),
                _mm_andnot_si128(invalid, a),
            );
            let b = _mm_or_si128(
                _mm_and_si128(invalid, _mm_set1_epi32(EMPTY_HI)),
                _mm_andnot_si128(invalid, b),
            );
            let mut s = TileRowSpans {
                a: [0; 4],
                b: [0; 4],
            };
            // SAFETY: SIMD store intrinsics into two local `[i32; 4]` (16 bytes each, unaligned
            // stores allowed).
            unsafe {
                _mm_storeu_si128(s.a.as_mut_ptr().cast(), a);
                _mm_storeu_si128(s.b.as_mut_ptr().cast(), b);
            }
            s
        }
    }

    /// Each row's span ends broadcast to its 8 byte lanes, compared with
    /// the column numbers, 16 pixels per `movemask`.
    #[inline(always)]
    unsafe fn mask(s: &TileRowSpans, base: i32) -> u32 {
        // SAFETY: SSE2 intrinsics only; SSE2 is part of the x86_64 baseline, so it is always
        // enabled on this target.
        #[allow(unused_unsafe)]
        unsafe {
            let p8 = packed_rel(s, base);
            let t = _mm_unpacklo_epi8(p8, p8); // a0 a0 a1 a1 a2 a2 a3 a3 b0 b0 .. b3 b3
            let ua = _mm_unpacklo_epi16(t, t); // a0 x4, a1 x4, a2 x4, a3 x4
            let ub = _mm_unpackhi_epi16(t, t);
            let a01 = _mm_unpacklo_epi32(ua, ua); // a0 x8, a1 x8
            let a23 = _mm_unpackhi_epi32(ua, ua);
            let b01 = _mm_unpacklo_epi32(ub, ub);
            let b23 = _mm_unpackhi_epi32(ub, ub);
            let cols = _mm_setr_epi8(0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7);
            // A pixel is outside when its column is before the start or after the end.
            let out01 = _mm_or_si128(_mm_cmpgt_epi8(a01, cols), _mm_cmpgt_epi8(cols, b01));
            let out23 = _mm_or_si128(_mm_cmpgt_epi8(a23, cols), _mm_cmpgt_epi8(cols, b23));
            let m01 = !(_mm_movemask_epi8(out01) as u32) & 0xFFFF;
            let m23 = !(_mm_movemask_epi8(out23) as u32) & 0xFFFF;
            m01 | m23 << 16
        }
    }
}

/// The span ends relative to `base`, saturated to `i8`, in bytes 0-3 (starts) and 4-7
/// (ends) of a register (and again in bytes 8-15).
#[inline(always)]
pub(super) fn packed_rel(s: &TileRowSpans, base: i32) -> __m128i {
    // SAFETY: SSE2 intrinsics only; SSE2 is part of the x86_64 baseline, so it is always
    // enabled on this target.
    #[allow(unused_unsafe)]
    unsafe {
        // SAFETY: SIMD load intrinsics from two `[i32; 4]` fields (16 bytes each, unaligned
        // loads allowed).
        let (a, b) = unsafe {
            (
                _mm_loadu_si128(s.a.as_ptr().cast()),
                _mm_loadu_si128(s.b.as_ptr().cast()),
            )
        };
        let bs = _mm_set1_epi32(base);
        // Saturating packs clamp far-away span ends to -128 / 127, which compare with the
        // columns 0..8 the same way as the exact values.
        let p16 = _mm_packs_epi32(_mm_sub_epi32(a, bs), _mm_sub_epi32(b, bs));
        _mm_packs_epi16(p16, p16)
    }
}
