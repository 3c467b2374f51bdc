//! The inner kernels of the occlusion buffer's triangle rasterizer, in three forms that give
//! identical results bit for bit: scalar, SSE2 and AVX2 (chosen at run time).
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! sections 3-4: the edges of a triangle are evaluated for all scanlines of a tile row at once
//! (one SIMD lane per scanline), and a tile's 32-bit coverage mask is built from the span ends
//! of its scanlines with data-parallel operations instead of per-pixel tests. Here a lane is
//! one of the 4 scanlines of an 8x4 tile row (`__m128`), and the mask of one tile comes from
//! comparing the 32 pixel columns (one byte lane each) with the span ends, then `movemask`.
//!
//! The AVX2 kernel goes further (section 4 of the paper): triangle setup for 8 triangles in
//! the 8 lanes of `__m256` ([`setup8_avx2`]), then per triangle the spans of a block row's 8
//! scanlines in one register and the masks, depths and merges of a block's 8 tiles in one
//! register each ([`raster_blocks_avx2`]), without branches per tile.
//!
//! Bit-exactness: every kernel evaluates the same `f32` expressions in the same order (Rust
//! does not contract `a * b + c` into an FMA) and rounds them with the same integer rules, so
//! the buffers they produce are identical (checked by the tests).

use super::project::{ceil_i, floor_i};
use super::TILE_H;

/// Kernel selector as a const generic parameter (one monomorphized rasterizer per kernel).
pub(super) const SCALAR: u8 = 0;
/// See [`SCALAR`].
#[cfg(target_arch = "x86_64")]
pub(super) const SSE2: u8 = 1;
/// See [`SCALAR`].
#[cfg(target_arch = "x86_64")]
pub(super) const AVX2: u8 = 2;
/// See [`SCALAR`]: the previous AVX2 kernel (one tile per step, branchy tile merge).
#[cfg(target_arch = "x86_64")]
pub(super) const AVX2_PER_TILE: u8 = 3;
/// See [`SCALAR`]: the previous SSE2 kernel (one tile per step, branchy tile merge).
#[cfg(target_arch = "x86_64")]
pub(super) const SSE2_PER_TILE: u8 = 4;

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
    /// The previous SSE2 kernel (one tile per step), kept to measure the others against.
    Sse2PerTile,
    /// The previous AVX2 kernel (one tile per step, a whole 32-pixel tile mask in one 256-bit
    /// comparison), kept to measure the others against.
    Avx2PerTile,
}

impl Kernel {
    /// Every kernel, scalar first.
    pub const ALL: [Kernel; 5] = [
        Kernel::Scalar,
        Kernel::Sse2,
        Kernel::Avx2,
        Kernel::Sse2PerTile,
        Kernel::Avx2PerTile,
    ];

    /// The fastest kernel this CPU supports.
    pub fn detect() -> Self {
        if Kernel::Avx2.available() {
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
            Kernel::Sse2 | Kernel::Sse2PerTile => cfg!(target_arch = "x86_64"),
            Kernel::Avx2 | Kernel::Avx2PerTile => {
                #[cfg(target_arch = "x86_64")]
                {
                    std::arch::is_x86_feature_detected!("avx2")
                }
                #[cfg(not(target_arch = "x86_64"))]
                {
                    false
                }
            }
        }
    }

    /// A short name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Scalar => "scalar",
            Kernel::Sse2 => "sse2",
            Kernel::Avx2 => "avx2",
            Kernel::Sse2PerTile => "sse2_per_tile",
            Kernel::Avx2PerTile => "avx2_per_tile",
        }
    }
}

/// The triangle's edges: `x = x0 + (y - y0) * slope`; `left` edges bound spans from the left.
pub(super) struct Edges {
    pub x0: [f32; 3],
    pub y0: [f32; 3],
    pub slope: [f32; 3],
    pub left: [bool; 3],
    pub used: [bool; 3],
}

/// Clamps of span ends (pixel columns of the triangle's bounding box) and its rows.
pub(super) struct ColClamp {
    /// Span starts are clamped to `[a_lo, a_hi]` before rounding up (`a_hi` = last column + 1,
    /// so a span starting beyond the box stays empty).
    pub a_lo: f32,
    pub a_hi: f32,
    /// Span ends are clamped to `[b_lo, b_hi]` before rounding down.
    pub b_lo: f32,
    pub b_hi: f32,
    /// First and last pixel row of the triangle.
    pub row0: i32,
    pub row1: i32,
}

/// The block grid of a buffer, for the AVX2 kernel.
pub(super) struct BlockGrid {
    pub blocks_x: u32,
    /// Last tile column and row of the image.
    pub last_tx: u32,
    pub last_ty: u32,
    /// Mask bits beyond the image of the last tile column / row (see the buffer).
    pub outside_x: u32,
    pub outside_y: u32,
}

/// Screen-space corners `[sx, sy, 1/z]` of up to 8 triangles, one per lane: `x[corner][lane]`.
#[repr(C, align(32))]
pub(super) struct Screen8 {
    pub x: [[f32; 8]; 3],
    pub y: [[f32; 8]; 3],
    pub r: [[f32; 8]; 3],
}

/// The setup of up to 8 triangles, one per lane, as [`setup8_avx2`] computes it: what the
/// per-tile path computes in `raster_triangle` (after the swap to counter-clockwise order).
#[repr(C, align(32))]
pub(super) struct Setup8 {
    /// `1/z = r0 + ra (x - x0) + rb (y - y0)` (`ra = rb = 0` unless `plane_ok`).
    x0: [f32; 8],
    y0: [f32; 8],
    r0: [f32; 8],
    ra: [f32; 8],
    rb: [f32; 8],
    /// The farthest corner's `1/z`, a lower bound in every case.
    r_far: [f32; 8],
    /// -1 when the plane is well conditioned (area of a pixel at least).
    plane_ok: [i32; 8],
    /// Edge `i`: `x = ex0 + (y - ey0) * slope`; bounds spans from the left / right (-1).
    ex0: [[f32; 8]; 3],
    ey0: [[f32; 8]; 3],
    slope: [[f32; 8]; 3],
    bound_l: [[i32; 8]; 3],
    bound_r: [[i32; 8]; 3],
    /// Span clamps, see [`ColClamp`].
    a_lo: [f32; 8],
    a_hi: [f32; 8],
    b_lo: [f32; 8],
    b_hi: [f32; 8],
    /// Pixel rows and columns of the bounding box, clamped to the buffer.
    row0: [i32; 8],
    row1: [i32; 8],
    col0: [i32; 8],
    col1: [i32; 8],
}

impl Setup8 {
    pub const ZERO: Setup8 = Setup8 {
        x0: [0.0; 8],
        y0: [0.0; 8],
        r0: [0.0; 8],
        ra: [0.0; 8],
        rb: [0.0; 8],
        r_far: [0.0; 8],
        plane_ok: [0; 8],
        ex0: [[0.0; 8]; 3],
        ey0: [[0.0; 8]; 3],
        slope: [[0.0; 8]; 3],
        bound_l: [[0; 8]; 3],
        bound_r: [[0; 8]; 3],
        a_lo: [0.0; 8],
        a_hi: [0.0; 8],
        b_lo: [0.0; 8],
        b_hi: [0.0; 8],
        row0: [0; 8],
        row1: [0; 8],
        col0: [0; 8],
        col1: [0; 8],
    };

    /// The bounding box of lane `l`: first and last pixel row and column.
    #[inline(always)]
    pub fn bbox(&self, l: usize) -> (i32, i32, i32, i32) {
        (self.row0[l], self.row1[l], self.col0[l], self.col1[l])
    }
}

/// An empty span: its start beyond and its end before every column.
const EMPTY_LO: i32 = 1 << 28;
const EMPTY_HI: i32 = -(1 << 28);

/// The inclusive pixel spans `[a, b]` of the 4 scanlines of one tile row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct TileRowSpans {
    a: [i32; 4],
    b: [i32; 4],
}

impl TileRowSpans {
    /// Scalar: one scanline at a time.
    #[inline(always)]
    pub fn scalar(e: &Edges, c: &ColClamp, ty: u32) -> Self {
        let mut s = TileRowSpans {
            a: [EMPTY_LO; 4],
            b: [EMPTY_HI; 4],
        };
        let row_base = (ty * TILE_H) as i32;
        for k in 0..TILE_H as usize {
            let row = row_base + k as i32;
            if row < c.row0 || row > c.row1 {
                continue;
            }
            let yc = row_base as f32 + 0.5 + k as f32;
            let mut xl = f32::NEG_INFINITY;
            let mut xr = f32::INFINITY;
            for i in 0..3 {
                if !e.used[i] {
                    continue;
                }
                let x = e.x0[i] + (yc - e.y0[i]) * e.slope[i];
                if e.left[i] {
                    xl = xl.max(x);
                } else {
                    xr = xr.min(x);
                }
            }
            let a = ceil_i((xl - 0.5).max(c.a_lo).min(c.a_hi));
            let b = floor_i((xr - 0.5).max(c.b_lo).min(c.b_hi));
            if a <= b {
                s.a[k] = a;
                s.b[k] = b;
            }
        }
        s
    }

    /// SSE2: the 4 scanlines in the 4 lanes of one register.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn simd(e: &Edges, c: &ColClamp, ty: u32) -> Self {
        use std::arch::x86_64::*;
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

    /// Not x86_64: the scalar kernel.
    #[cfg(not(target_arch = "x86_64"))]
    #[inline(always)]
    pub fn simd(e: &Edges, c: &ColClamp, ty: u32) -> Self {
        Self::scalar(e, c, ty)
    }

    /// The first and last column of any span (`first > last` when every span is empty).
    #[inline(always)]
    pub fn extent(&self) -> (i32, i32) {
        let lo = self.a[0].min(self.a[1]).min(self.a[2].min(self.a[3]));
        let hi = self.b[0].max(self.b[1]).max(self.b[2].max(self.b[3]));
        (lo, hi)
    }

    /// Coverage mask of the tile starting at column `base` (bit `8 * row + column`), scalar.
    #[inline(always)]
    pub fn mask_scalar(&self, base: i32) -> u32 {
        let mut mask = 0u32;
        for k in 0..TILE_H as usize {
            let lo = (self.a[k] - base).clamp(0, 8);
            let hi = (self.b[k] + 1 - base).clamp(0, 8);
            if hi > lo {
                mask |= ((1u32 << hi) - (1u32 << lo)) << (k as u32 * 8);
            }
        }
        mask
    }

    /// The span ends relative to `base`, saturated to `i8`, in bytes 0-3 (starts) and 4-7
    /// (ends) of a register (and again in bytes 8-15).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn packed_rel(&self, base: i32) -> std::arch::x86_64::__m128i {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 intrinsics only; SSE2 is part of the x86_64 baseline, so it is always
        // enabled on this target.
        #[allow(unused_unsafe)]
        unsafe {
            // SAFETY: SIMD load intrinsics from two `[i32; 4]` fields (16 bytes each, unaligned
            // loads allowed).
            let (a, b) = unsafe {
                (
                    _mm_loadu_si128(self.a.as_ptr().cast()),
                    _mm_loadu_si128(self.b.as_ptr().cast()),
                )
            };
            let bs = _mm_set1_epi32(base);
            // Saturating packs clamp far-away span ends to -128 / 127, which compare with the
            // columns 0..8 the same way as the exact values.
            let p16 = _mm_packs_epi32(_mm_sub_epi32(a, bs), _mm_sub_epi32(b, bs));
            _mm_packs_epi16(p16, p16)
        }
    }

    /// Coverage mask, SSE2: each row's span ends broadcast to its 8 byte lanes, compared with
    /// the column numbers, 16 pixels per `movemask`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn mask_sse2(&self, base: i32) -> u32 {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 intrinsics only; SSE2 is part of the x86_64 baseline, so it is always
        // enabled on this target.
        #[allow(unused_unsafe)]
        unsafe {
            let p8 = self.packed_rel(base);
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

    /// Coverage mask, AVX2: the span ends shuffled to the 32 byte lanes of one register, one
    /// comparison per side and one `movemask` for the whole tile.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn mask_avx2(&self, base: i32) -> u32 {
        use std::arch::x86_64::*;
        let p8 = _mm256_broadcastsi128_si256(self.packed_rel(base));
        // Byte lane 8k + c takes row k's start (byte k) or end (byte 4 + k); the shuffle works
        // within 128-bit halves, each of which holds all 8 bytes after the broadcast.
        let ia = _mm256_setr_epi8(
            0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 2, 2, 3, 3, 3, 3, 3,
            3, 3, 3,
        );
        let ib = _mm256_add_epi8(ia, _mm256_set1_epi8(4));
        let a = _mm256_shuffle_epi8(p8, ia);
        let b = _mm256_shuffle_epi8(p8, ib);
        let cols = _mm256_setr_epi8(
            0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4,
            5, 6, 7,
        );
        let out = _mm256_or_si256(_mm256_cmpgt_epi8(a, cols), _mm256_cmpgt_epi8(cols, b));
        !(_mm256_movemask_epi8(out) as u32)
    }
}

/// Rasterizes one triangle (already set up: edges, bounding box, depth plane) into the blocks
/// of 4x2 tiles, AVX2. For each block row (8 scanlines, one per lane) the span ends are
/// computed at once; for each block (8 tiles, one per lane) the coverage masks, the
/// conservative depths and the merge with the tiles.
///
/// Every value is the one the per-tile path computes, with the same `f32` operations: spans
/// as in [`TileRowSpans::simd`], a tile's depth from the lowest and highest covered column,
/// the tile merge of `update_tile`; tiles the triangle does not cover get a zero mask and
/// are left unchanged. So the buffers are identical bit for bit (checked by the tests).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn raster_blocks_avx2(
    blocks: &mut [super::Block],
    g: &BlockGrid,
    t: &Setup8,
    l: usize,
) {
    use std::arch::x86_64::*;
    let neg_inf = _mm256_set1_ps(f32::NEG_INFINITY);
    let pos_inf = _mm256_set1_ps(f32::INFINITY);
    // Edges without branches: an edge that does not bound a side contributes -inf to the
    // left bound (+inf to the right one), which `max` / `min` ignore.
    let edge = |i: usize| {
        (
            _mm256_set1_ps(t.ex0[i][l]),
            _mm256_set1_ps(t.ey0[i][l]),
            _mm256_set1_ps(t.slope[i][l]),
            _mm256_castsi256_ps(_mm256_set1_epi32(t.bound_l[i][l])),
            _mm256_castsi256_ps(_mm256_set1_epi32(t.bound_r[i][l])),
        )
    };
    let edges = [edge(0), edge(1), edge(2)];
    let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    // Tile column / row of each lane within a block.
    let lane_tx = _mm256_setr_epi32(0, 1, 2, 3, 0, 1, 2, 3);
    let lane_ty = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
    let half = _mm256_set1_ps(0.5);
    let all = _mm256_set1_epi32(-1);
    let zero = _mm256_setzero_si256();
    let (x0, ra, r_far) = (
        _mm256_set1_ps(t.x0[l]),
        _mm256_set1_ps(t.ra[l]),
        _mm256_set1_ps(t.r_far[l]),
    );
    let plane_ok = t.plane_ok[l] != 0;
    let (row0, row1) = (t.row0[l], t.row1[l]);
    let by0 = row0 as u32 / (2 * TILE_H);
    let by1 = row1 as u32 / (2 * TILE_H);
    for by in by0..=by1 {
        let row_base = (by * 2 * TILE_H) as i32;
        // Scanline centres, exact in f32 (small integers plus a half), as in the SSE2 kernel.
        let yc = _mm256_add_ps(
            _mm256_set1_ps(row_base as f32 + 0.5),
            _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0),
        );
        let mut xl = neg_inf;
        let mut xr = pos_inf;
        for &(ex0, ey0, slope, bound_l, bound_r) in &edges {
            let x = _mm256_add_ps(ex0, _mm256_mul_ps(_mm256_sub_ps(yc, ey0), slope));
            // `maxps(x, acc)` returns `acc` when `x` is NaN, as `f32::max` does.
            xl = _mm256_max_ps(_mm256_blendv_ps(neg_inf, x, bound_l), xl);
            xr = _mm256_min_ps(_mm256_blendv_ps(pos_inf, x, bound_r), xr);
        }
        let xa = _mm256_min_ps(
            _mm256_max_ps(_mm256_sub_ps(xl, half), _mm256_set1_ps(t.a_lo[l])),
            _mm256_set1_ps(t.a_hi[l]),
        );
        let xb = _mm256_min_ps(
            _mm256_max_ps(_mm256_sub_ps(xr, half), _mm256_set1_ps(t.b_lo[l])),
            _mm256_set1_ps(t.b_hi[l]),
        );
        let ta = _mm256_cvttps_epi32(xa);
        let a = _mm256_sub_epi32(
            ta,
            _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(xa, _mm256_cvtepi32_ps(ta))),
        );
        let tb = _mm256_cvttps_epi32(xb);
        let b = _mm256_add_epi32(
            tb,
            _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(xb, _mm256_cvtepi32_ps(tb))),
        );
        let rows = _mm256_add_epi32(_mm256_set1_epi32(row_base), lane);
        let invalid = _mm256_or_si256(
            _mm256_or_si256(
                _mm256_cmpgt_epi32(_mm256_set1_epi32(row0), rows),
                _mm256_cmpgt_epi32(rows, _mm256_set1_epi32(row1)),
            ),
            _mm256_cmpgt_epi32(a, b),
        );
        let a = _mm256_blendv_epi8(a, _mm256_set1_epi32(EMPTY_LO), invalid);
        let b = _mm256_blendv_epi8(b, _mm256_set1_epi32(EMPTY_HI), invalid);
        let lo_all = hmin_epi32(a);
        let hi_all = hmax_epi32(b);
        if lo_all > hi_all {
            continue;
        }
        // Lane `4 j + i` (tile row j of the block) takes scanline `4 j + k` for row k.
        let pick = |k: i32| _mm256_setr_epi32(k, k, k, k, 4 + k, 4 + k, 4 + k, 4 + k);
        let span_a = [
            _mm256_permutevar8x32_epi32(a, pick(0)),
            _mm256_permutevar8x32_epi32(a, pick(1)),
            _mm256_permutevar8x32_epi32(a, pick(2)),
            _mm256_permutevar8x32_epi32(a, pick(3)),
        ];
        let span_b = [
            _mm256_permutevar8x32_epi32(b, pick(0)),
            _mm256_permutevar8x32_epi32(b, pick(1)),
            _mm256_permutevar8x32_epi32(b, pick(2)),
            _mm256_permutevar8x32_epi32(b, pick(3)),
        ];
        let tyv = _mm256_add_epi32(_mm256_set1_epi32((2 * by) as i32), lane_ty);
        // The plane's minimum over each tile row's scanlines, as the per-tile path.
        let r_rows = {
            let ya = _mm256_add_ps(_mm256_cvtepi32_ps(_mm256_slli_epi32::<2>(tyv)), half);
            let yb = _mm256_add_ps(ya, _mm256_set1_ps((TILE_H - 1) as f32));
            let (rb, y0) = (_mm256_set1_ps(t.rb[l]), _mm256_set1_ps(t.y0[l]));
            _mm256_add_ps(
                _mm256_set1_ps(t.r0[l]),
                min_like_f32(
                    _mm256_mul_ps(rb, _mm256_sub_ps(ya, y0)),
                    _mm256_mul_ps(rb, _mm256_sub_ps(yb, y0)),
                ),
            )
        };
        let outside_y = _mm256_and_si256(
            _mm256_cmpeq_epi32(tyv, _mm256_set1_epi32(g.last_ty as i32)),
            _mm256_set1_epi32(g.outside_y as i32),
        );
        let block_row = (by * g.blocks_x) as usize;
        for bx in lo_all as u32 / 32..=hi_all as u32 / 32 {
            let txv = _mm256_add_epi32(_mm256_set1_epi32((4 * bx) as i32), lane_tx);
            let base = _mm256_slli_epi32::<3>(txv);
            let base7 = _mm256_add_epi32(base, _mm256_set1_epi32(7));
            let mut mask = zero;
            let mut cmin = _mm256_set1_epi32(i32::MAX);
            let mut cmax = _mm256_set1_epi32(i32::MIN);
            macro_rules! row {
                ($k:literal) => {{
                    // The span clipped to the tile's columns; empty when it ends first.
                    let lo = _mm256_max_epi32(span_a[$k], base);
                    let hi = _mm256_min_epi32(span_b[$k], base7);
                    let empty = _mm256_cmpgt_epi32(lo, hi);
                    // Bits lo..=hi: (2 << hi) - (1 << lo), relative to the tile; shift counts
                    // outside 0..32 (empty rows only) give 0, and empty rows are masked off.
                    let bits = _mm256_sub_epi32(
                        _mm256_sllv_epi32(_mm256_set1_epi32(2), _mm256_sub_epi32(hi, base)),
                        _mm256_sllv_epi32(_mm256_set1_epi32(1), _mm256_sub_epi32(lo, base)),
                    );
                    let bits = _mm256_andnot_si256(empty, bits);
                    mask = _mm256_or_si256(mask, _mm256_slli_epi32::<{ 8 * $k }>(bits));
                    cmin =
                        _mm256_min_epi32(cmin, _mm256_or_si256(lo, _mm256_srli_epi32::<1>(empty)));
                    cmax = _mm256_max_epi32(cmax, _mm256_andnot_si256(empty, hi));
                }};
            }
            row!(0);
            row!(1);
            row!(2);
            row!(3);
            let untouched = _mm256_cmpeq_epi32(mask, zero);
            let outside_x = _mm256_and_si256(
                _mm256_cmpeq_epi32(txv, _mm256_set1_epi32(g.last_tx as i32)),
                _mm256_set1_epi32(g.outside_x as i32),
            );
            let cov = _mm256_or_si256(
                mask,
                _mm256_andnot_si256(untouched, _mm256_or_si256(outside_x, outside_y)),
            );
            let r = if plane_ok {
                let xa = _mm256_sub_ps(_mm256_add_ps(_mm256_cvtepi32_ps(cmin), half), x0);
                let xb = _mm256_sub_ps(_mm256_add_ps(_mm256_cvtepi32_ps(cmax), half), x0);
                let m = min_like_f32(_mm256_mul_ps(ra, xa), _mm256_mul_ps(ra, xb));
                max_like_f32(_mm256_add_ps(r_rows, m), r_far)
            } else {
                r_far
            };
            merge_block_avx2(&mut blocks[block_row + bx as usize], cov, r, all);
        }
    }
}

/// Triangle setup of 8 triangles at once, AVX2 (Hasselgren et al. 2016, section 4: setup in
/// SIMD lanes): the same `f32` and integer operations as `raster_triangle` does for one,
/// lane by lane: area and orientation (clockwise triangles get corners 1 and 2 swapped),
/// bounding box in pixel centres clamped to the `width x height` buffer, the `1/z` plane and
/// the edges. Returns a bit per lane that has something to draw (non-degenerate area, bounding
/// box inside the buffer); other lanes of `out` hold garbage.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn setup8_avx2(s: &Screen8, width: u32, height: u32, out: &mut Setup8) -> u32 {
    use std::arch::x86_64::*;
    // SAFETY (all blocks below): aligned loads and stores of 32-byte arrays of
    // `#[repr(C, align(32))]` structs (every field is a multiple of 32 bytes).
    let ld = |a: &[f32; 8]| unsafe { _mm256_load_ps(a.as_ptr()) };
    let st = |a: &mut [f32; 8], v: __m256| unsafe { _mm256_store_ps(a.as_mut_ptr(), v) };
    let sti =
        |a: &mut [i32; 8], v: __m256i| unsafe { _mm256_store_si256(a.as_mut_ptr().cast(), v) };
    let (x0, mut x1, mut x2) = (ld(&s.x[0]), ld(&s.x[1]), ld(&s.x[2]));
    let (y0, mut y1, mut y2) = (ld(&s.y[0]), ld(&s.y[1]), ld(&s.y[2]));
    let (r0, mut r1, mut r2) = (ld(&s.r[0]), ld(&s.r[1]), ld(&s.r[2]));
    let zero = _mm256_setzero_ps();
    let area = _mm256_sub_ps(
        _mm256_mul_ps(_mm256_sub_ps(x1, x0), _mm256_sub_ps(y2, y0)),
        _mm256_mul_ps(_mm256_sub_ps(y1, y0), _mm256_sub_ps(x2, x0)),
    );
    // Not zero and not NaN.
    let valid = _mm256_cmp_ps::<_CMP_NEQ_OQ>(area, zero);
    let cw = _mm256_cmp_ps::<_CMP_LT_OQ>(area, zero);
    (x1, x2) = (_mm256_blendv_ps(x1, x2, cw), _mm256_blendv_ps(x2, x1, cw));
    (y1, y2) = (_mm256_blendv_ps(y1, y2, cw), _mm256_blendv_ps(y2, y1, cw));
    (r1, r2) = (_mm256_blendv_ps(r1, r2, cw), _mm256_blendv_ps(r2, r1, cw));
    let area = _mm256_andnot_ps(_mm256_set1_ps(-0.0), area);
    // Bounding box: pixel centres in [min, max]: first = ceil(min - 0.5), last = floor(max - 0.5).
    let half = _mm256_set1_ps(0.5);
    let ceil_i = |v: __m256| {
        let t = _mm256_cvttps_epi32(v);
        _mm256_sub_epi32(
            t,
            _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(v, _mm256_cvtepi32_ps(t))),
        )
    };
    let floor_i = |v: __m256| {
        let t = _mm256_cvttps_epi32(v);
        _mm256_add_epi32(
            t,
            _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(v, _mm256_cvtepi32_ps(t))),
        )
    };
    let ymin = _mm256_min_ps(_mm256_min_ps(y0, y1), y2);
    let ymax = _mm256_max_ps(_mm256_max_ps(y0, y1), y2);
    let xmin = _mm256_min_ps(_mm256_min_ps(x0, x1), x2);
    let xmax = _mm256_max_ps(_mm256_max_ps(x0, x1), x2);
    let izero = _mm256_setzero_si256();
    let row0 = _mm256_max_epi32(ceil_i(_mm256_sub_ps(ymin, half)), izero);
    let row1 = _mm256_min_epi32(
        floor_i(_mm256_sub_ps(ymax, half)),
        _mm256_set1_epi32(height as i32 - 1),
    );
    let col0 = _mm256_max_epi32(ceil_i(_mm256_sub_ps(xmin, half)), izero);
    let col1 = _mm256_min_epi32(
        floor_i(_mm256_sub_ps(xmax, half)),
        _mm256_set1_epi32(width as i32 - 1),
    );
    let empty = _mm256_or_si256(
        _mm256_cmpgt_epi32(row0, row1),
        _mm256_cmpgt_epi32(col0, col1),
    );
    let draw = _mm256_andnot_si256(empty, _mm256_castps_si256(valid));
    // The `1/z` plane; for slivers (less than a pixel of area) only the farthest corner.
    let plane_ok = _mm256_cmp_ps::<_CMP_GE_OQ>(area, _mm256_set1_ps(1.0));
    let (d1x, d1y, d1r) = (
        _mm256_sub_ps(x1, x0),
        _mm256_sub_ps(y1, y0),
        _mm256_sub_ps(r1, r0),
    );
    let (d2x, d2y, d2r) = (
        _mm256_sub_ps(x2, x0),
        _mm256_sub_ps(y2, y0),
        _mm256_sub_ps(r2, r0),
    );
    let ra = _mm256_div_ps(
        _mm256_sub_ps(_mm256_mul_ps(d1r, d2y), _mm256_mul_ps(d2r, d1y)),
        area,
    );
    let rb = _mm256_div_ps(
        _mm256_sub_ps(_mm256_mul_ps(d2r, d1x), _mm256_mul_ps(d1r, d2x)),
        area,
    );
    st(&mut out.x0, x0);
    st(&mut out.y0, y0);
    st(&mut out.r0, r0);
    st(&mut out.ra, _mm256_and_ps(ra, plane_ok));
    st(&mut out.rb, _mm256_and_ps(rb, plane_ok));
    st(&mut out.r_far, _mm256_min_ps(_mm256_min_ps(r0, r1), r2));
    sti(&mut out.plane_ok, _mm256_castps_si256(plane_ok));
    // Edges a -> b with the interior on the left (y down): going up (dy < 0) bounds spans
    // from the left, going down from the right; horizontal edges bound nothing.
    let xs = [x0, x1, x2];
    let ys = [y0, y1, y2];
    for i in 0..3 {
        let j = (i + 1) % 3;
        let dy = _mm256_sub_ps(ys[j], ys[i]);
        st(&mut out.ex0[i], xs[i]);
        st(&mut out.ey0[i], ys[i]);
        st(
            &mut out.slope[i],
            _mm256_div_ps(_mm256_sub_ps(xs[j], xs[i]), dy),
        );
        sti(
            &mut out.bound_l[i],
            _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(dy, zero)),
        );
        sti(
            &mut out.bound_r[i],
            _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(dy, zero)),
        );
    }
    let one = _mm256_set1_epi32(1);
    st(&mut out.a_lo, _mm256_cvtepi32_ps(col0));
    st(
        &mut out.a_hi,
        _mm256_cvtepi32_ps(_mm256_add_epi32(col1, one)),
    );
    st(
        &mut out.b_lo,
        _mm256_cvtepi32_ps(_mm256_sub_epi32(col0, one)),
    );
    st(&mut out.b_hi, _mm256_cvtepi32_ps(col1));
    sti(&mut out.row0, row0);
    sti(&mut out.row1, row1);
    sti(&mut out.col0, col0);
    sti(&mut out.col1, col1);
    _mm256_movemask_ps(_mm256_castsi256_ps(draw)) as u32
}

/// `update_tile` for the 8 tiles of a block at once, with selects; lanes with a zero `cov`
/// are left unchanged.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn merge_block_avx2(
    block: &mut super::Block,
    cov: std::arch::x86_64::__m256i,
    r: std::arch::x86_64::__m256,
    all: std::arch::x86_64::__m256i,
) {
    use std::arch::x86_64::*;
    // SAFETY: aligned loads of the three 32-byte arrays of a `#[repr(align(32))]` block.
    let (z0, z1, m) = unsafe {
        (
            _mm256_load_ps(block.z0.as_ptr()),
            _mm256_load_ps(block.z1.as_ptr()),
            _mm256_load_si256(block.mask.as_ptr().cast()),
        )
    };
    let zero = _mm256_setzero_si256();
    // Unchanged: nothing covered, or not nearer than the reference layer (or NaN).
    let nearer = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(r, z0));
    let keep = _mm256_or_si256(_mm256_cmpeq_epi32(cov, zero), _mm256_xor_si256(nearer, all));
    let discard = _mm256_or_si256(
        _mm256_cmpeq_epi32(m, zero),
        _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(
            _mm256_sub_ps(r, z1),
            _mm256_sub_ps(z1, z0),
        )),
    );
    let z1n = _mm256_blendv_ps(min_like_f32(z1, r), r, _mm256_castsi256_ps(discard));
    let mn = _mm256_blendv_epi8(_mm256_or_si256(m, cov), cov, discard);
    let full = _mm256_cmpeq_epi32(mn, all);
    let z0n = _mm256_blendv_ps(z0, z1n, _mm256_castsi256_ps(full));
    let z1n = _mm256_andnot_ps(_mm256_castsi256_ps(full), z1n);
    let mn = _mm256_andnot_si256(full, mn);
    // Byte blends with the old values: with `blendv_ps` LLVM turns blend-and-store into a
    // masked store (`vmaskmovps`), which is slow on AMD CPUs.
    let z0n = _mm256_blendv_epi8(_mm256_castps_si256(z0n), _mm256_castps_si256(z0), keep);
    let z1n = _mm256_blendv_epi8(_mm256_castps_si256(z1n), _mm256_castps_si256(z1), keep);
    // SAFETY: aligned stores into the same three arrays.
    unsafe {
        _mm256_store_si256(block.z0.as_mut_ptr().cast(), z0n);
        _mm256_store_si256(block.z1.as_mut_ptr().cast(), z1n);
        _mm256_store_si256(
            block.mask.as_mut_ptr().cast(),
            _mm256_blendv_epi8(mn, m, keep),
        );
    }
}

/// Smallest lane.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn hmin_epi32(v: std::arch::x86_64::__m256i) -> i32 {
    use std::arch::x86_64::*;
    let m = _mm_min_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256::<1>(v));
    let m = _mm_min_epi32(m, _mm_shuffle_epi32::<0b01_00_11_10>(m));
    let m = _mm_min_epi32(m, _mm_shuffle_epi32::<0b10_11_00_01>(m));
    _mm_cvtsi128_si32(m)
}

/// Largest lane.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn hmax_epi32(v: std::arch::x86_64::__m256i) -> i32 {
    use std::arch::x86_64::*;
    let m = _mm_max_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256::<1>(v));
    let m = _mm_max_epi32(m, _mm_shuffle_epi32::<0b01_00_11_10>(m));
    let m = _mm_max_epi32(m, _mm_shuffle_epi32::<0b10_11_00_01>(m));
    _mm_cvtsi128_si32(m)
}

/// `a.min(b)` of `f32` lane by lane (the non-NaN operand when one is NaN), as the scalar code.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn min_like_f32(
    a: std::arch::x86_64::__m256,
    b: std::arch::x86_64::__m256,
) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    // `minps(a, b)` returns `b` when either is NaN: take `a` where `b` is NaN.
    _mm256_blendv_ps(_mm256_min_ps(a, b), a, _mm256_cmp_ps::<_CMP_UNORD_Q>(b, b))
}

/// `a.max(b)` of `f32` lane by lane, see [`min_like_f32`].
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn max_like_f32(
    a: std::arch::x86_64::__m256,
    b: std::arch::x86_64::__m256,
) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    _mm256_blendv_ps(_mm256_max_ps(a, b), a, _mm256_cmp_ps::<_CMP_UNORD_Q>(b, b))
}

#[cfg(test)]
mod tests {
    use super::*;

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
                    let m = s.mask_scalar(8);
                    #[cfg(target_arch = "x86_64")]
                    {
                        assert_eq!(s.mask_sse2(8), m, "{s:?}");
                        if Kernel::Avx2.available() {
                            // SAFETY: AVX2 support was just checked.
                            assert_eq!(unsafe { s.mask_avx2(8) }, m, "{s:?}");
                        }
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
