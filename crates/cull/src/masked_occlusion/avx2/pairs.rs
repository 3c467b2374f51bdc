//! The AVX-512 kernel's per-triangle step: what `blocks.rs` does for one block row (8
//! scanlines, the 8 tiles of a block), done for two block rows at once in 512-bit registers
//! ([`raster_pairs`]): the spans of 16 scanlines in one register, the masks, depths and merges
//! of two vertically adjacent blocks (16 tiles) in one register each. A triangle that covers
//! an odd number of block rows draws its last one with the row below it, whose scanlines lie
//! outside the triangle (empty masks, so the merge keeps its tiles); the storage has a spare
//! block row after the image for a last row that is odd. Block rows are indexed without
//! checks, after one check per triangle. The triangle setup stays the AVX2 kernel's
//! (`setup.rs`, 8 triangles at once).
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! section 4 (the SIMD layout, scaled to 16 lanes as its AVX-512 form does); Andersson,
//! Hasselgren, Akenine-Möller. Masked Depth Culling for Graphics Hardware. 2015, section 3
//! (the tile merge, [`merge_pair`]).
//!
//! Bit-exactness: lane by lane the same `f32` and integer operations as `blocks.rs` (and so as
//! the per-tile kernels), with mask registers where that file selects with blends; the buffers
//! are identical bit for bit (checked by the tests).

use std::arch::x86_64::*;
use std::mem::offset_of;

use super::super::per_tile::{EMPTY_HI, EMPTY_LO};
use super::super::tiles::Block;
use super::blocks::BlockGrid;
use super::setup::Setup8;

/// The features every function here needs.
macro_rules! avx512 {
    ($($item:item)*) => {$(
        #[target_feature(enable = "avx512f,avx512bw,avx512dq,avx512vl")]
        $item
    )*};
}

/// One triangle (lane `l` of a [`Setup8`]): what every block reads broadcast to 16 lanes;
/// what a pair of block rows reads once is broadcast from the setup where it is used
/// ([`Triangle16::lane`]), which keeps the registers free of values used once.
struct Triangle16<'a> {
    t: &'a Setup8,
    l: usize,
    /// `per_tile::tile_column_offsets`: a tile's farthest and nearest pixel centres.
    far_col: __m512,
    near_col: __m512,
    ra: __m512,
    r_far: __m512,
    r_near: __m512,
    plane_ok: bool,
    row0: i32,
    row1: i32,
    col0: i32,
    col1: i32,
}

impl<'a> Triangle16<'a> {
    avx512! {
        #[inline]
        fn new(t: &'a Setup8, l: usize) -> Self {
            let set1 = _mm512_set1_ps;
            Triangle16 {
                t,
                l,
                far_col: set1(t.far_col[l]),
                near_col: set1(t.near_col[l]),
                ra: set1(t.ra[l]),
                r_far: set1(t.r_far[l]),
                r_near: set1(t.r_near[l]),
                plane_ok: t.plane_ok[l] != 0,
                row0: t.row0[l],
                row1: t.row1[l],
                col0: t.col0[l],
                col1: t.col1[l],
            }
        }

        /// The triangle's value in `field` broadcast.
        #[inline]
        fn lane(&self, field: &[f32; 8]) -> __m512 {
            _mm512_set1_ps(field[self.l])
        }

        /// Edge `role` (`setup::store_edges`: left, right, third) as `(x0, y0, slope)`.
        #[inline]
        fn edge(&self, role: usize) -> (__m512, __m512, __m512) {
            let t = self.t;
            (self.lane(&t.ex0[role]), self.lane(&t.ey0[role]), self.lane(&t.slope[role]))
        }
    }
}

avx512! {
    /// Rasterizes one triangle (lane `l` of `t`) into the blocks, two block rows at a time:
    /// block rows `by` (lanes 0-7) and `by + 1` (lanes 8-15). As `blocks::raster_blocks`: a
    /// pair of rows whose bounding-box blocks all lie behind the triangle is skipped before its
    /// spans, a block pair behind it before its masks.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F, BW, DQ and VL.
    #[inline]
    pub(super) unsafe fn raster_pairs(blocks: &mut [Block], g: &BlockGrid, t: &Setup8, l: usize) {
        let tri = Triangle16::new(t, l);
        let (by0, by1) = (tri.row0 as u32 / 8, tri.row1 as u32 / 8);
        // Every block a pair below touches lies in the buffer (the bounding box is clamped to
        // the image, and the storage has a block row beyond it, see `Tiles::new`): checked
        // once here, so that the block loops index without checks.
        assert!(
            (tri.col1 as u32 / 32) < g.blocks_x
                && ((by1 + 2) * g.blocks_x) as usize <= blocks.len()
        );
        for by in (by0..by1 + 1).step_by(2) {
            // SAFETY: rows `by` and `by + 1` are in the storage (asserted above).
            unsafe { pair_row(blocks, g, &tri, by, by < by1) };
        }
    }

    /// Block rows `by` (lanes 0-7) and `by + 1` (lanes 8-15) of a triangle, the second only
    /// when `both` (else it is loaded and stored unchanged: its scanlines lie outside the
    /// triangle, so their masks are empty and the merge keeps its tiles).
    ///
    /// # Safety
    /// Block rows `by` and `by + 1` lie in `blocks`, and so does block column
    /// `tri.col1 / 32`.
    #[inline]
    unsafe fn pair_row(blocks: &mut [Block], g: &BlockGrid, tri: &Triangle16, by: u32, both: bool) {
        // Lanes of the rows the triangle reaches (the depth tests ignore the others).
        let lanes: __mmask16 = if both { 0xFFFF } else { 0x00FF };
        let (bbox_bx0, bbox_bx1) = (tri.col0 as u32 / 32, tri.col1 as u32 / 32);
        let last_bx = g.last_tx / 4;
        let row = blocks.as_mut_ptr().wrapping_add((by * g.blocks_x) as usize);
        let pair = |bx: u32| PairPtrs::new(row, g.blocks_x, bx);
        // The first block not behind the triangle. Most blocks looked at here are behind its
        // nearest corner (a hidden triangle's are), so that test comes first, and the depth
        // plane's rows are set up only when a block needs its bound.
        let mut plane: Option<PairDepth> = None;
        let first_open = (bbox_bx0..bbox_bx1 + 1).find(|&bx| {
            // SAFETY: `bx` is in the bounding box (this function's contract).
            let z0 = unsafe { pair(bx).load_z0() };
            let behind_near = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(tri.r_near, z0) | !lanes;
            if behind_near == 0xFFFF {
                return false;
            }
            let behind_far = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(tri.r_far, z0) | !lanes;
            if behind_far != 0xFFFF {
                return true;
            }
            tri.plane_ok
                && !plane
                    .get_or_insert_with(|| PairDepth::new(tri, by, g))
                    .plane_behind(tri, bx, z0, behind_near)
        });
        let Some(first_open) = first_open else {
            return;
        };
        let depth = plane.unwrap_or_else(|| PairDepth::new(tri, by, g));
        let Some((rel_a, rel_b, bx0, bx1)) = pair_spans(tri, by) else {
            return;
        };
        // A pair row whose spans reach fewer than three blocks seldom holds a block pair the
        // triangle covers whole (only where the image's edges cut the triangle): the test is
        // skipped there, and the merge gives the same result anyway.
        let may_cover = bx1 - bx0 >= 2;
        // The block pairs before `first_open` lie behind the triangle: the loop starts at it,
        // with the spans moved on to it.
        let start = bx0.max(first_open);
        let ahead = _mm512_set1_epi32((32 * (start - bx0)) as i32);
        let (mut rel_a, mut rel_b) = (_mm512_sub_epi32(rel_a, ahead), _mm512_sub_epi32(rel_b, ahead));
        for bx in start..bx1 + 1 {
            let blocks = pair(bx);
            // SAFETY: `bx0..=bx1` lies in the bounding box (`pair_spans`).
            let z0 = unsafe { blocks.load_z0() };
            let skip = bx > first_open && depth.behind(tri, bx, z0, lanes);
            if !skip {
                let mask = pair_masks(rel_a, rel_b);
                let cov = if bx == last_bx || depth.last_row {
                    let outside_x = _mm512_maskz_mov_epi32(
                        _mm512_cmpeq_epi32_mask(
                            _mm512_add_epi32(
                                _mm512_set1_epi32((4 * bx) as i32),
                                _mm512_setr_epi32(0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3),
                            ),
                            _mm512_set1_epi32(g.last_tx as i32),
                        ),
                        _mm512_set1_epi32(g.outside_x as i32),
                    );
                    let outside = _mm512_or_si512(outside_x, depth.outside_y);
                    let touched = _mm512_test_epi32_mask(mask, mask);
                    _mm512_mask_or_epi32(mask, touched, mask, outside)
                } else {
                    mask
                };
                // The plane's farthest value over each tile, as `per_tile.rs` computes it.
                let r = if tri.plane_ok {
                    let far = _mm512_add_ps(tile_columns(bx), tri.far_col);
                    let m = _mm512_add_ps(depth.r_rows, _mm512_mul_ps(tri.ra, far));
                    // `f32::max` without a NaN select: `r_far` is never NaN.
                    _mm512_min_ps(_mm512_max_ps(m, tri.r_far), tri.r_near)
                } else {
                    tri.r_far
                };
                // SAFETY: as for the load.
                unsafe {
                    // A pair the triangle covers whole (the inside of a large triangle) takes
                    // the merge's one outcome for a full mask, without its selects.
                    if may_cover && _mm512_cmpeq_epi32_mask(cov, _mm512_set1_epi32(-1)) == 0xFFFF {
                        cover_pair(blocks, z0, r);
                    } else {
                        merge_pair(blocks, z0, cov, r);
                    }
                };
            }
            rel_a = _mm512_sub_epi32(rel_a, _mm512_set1_epi32(32));
            rel_b = _mm512_sub_epi32(rel_b, _mm512_set1_epi32(32));
        }
    }

    /// The first column of each lane's tile in block column `bx`, as `f32`.
    #[inline]
    fn tile_columns(bx: u32) -> __m512 {
        let lane_x = _mm512_setr_ps(
            0.0, 8.0, 16.0, 24.0, 0.0, 8.0, 16.0, 24.0, 0.0, 8.0, 16.0, 24.0, 0.0, 8.0, 16.0, 24.0,
        );
        _mm512_add_ps(_mm512_set1_ps((32 * bx) as f32), lane_x)
    }

}

/// Block `bx` of a block row and the block below it: where [`pair_row`] loads and stores a
/// field of 16 tiles (lanes 0-7 from the first block, 8-15 from the second).
#[derive(Clone, Copy)]
struct PairPtrs {
    lo: *mut Block,
    hi: *mut Block,
}

impl PairPtrs {
    /// Block `bx` of the row starting at `row`, and the one `blocks_x` further on.
    #[inline(always)]
    fn new(row: *mut Block, blocks_x: u32, bx: u32) -> Self {
        let lo = row.wrapping_add(bx as usize);
        PairPtrs {
            lo,
            hi: lo.wrapping_add(blocks_x as usize),
        }
    }

    /// The field at byte offset `field` of block `b`, as `f32` lanes.
    #[inline(always)]
    fn at(b: *mut Block, field: usize) -> *mut f32 {
        b.cast::<u8>().wrapping_add(field).cast()
    }

    avx512! {
        /// Field `field` (a byte offset in [`Block`]) of the pair's 16 tiles.
        ///
        /// # Safety
        /// `lo` and `hi` point to blocks of the storage, with no other reference to them
        /// alive.
        #[inline]
        unsafe fn load(self, field: usize) -> __m512 {
            // SAFETY: aligned 32-byte loads of a field of `#[repr(align(32))]` blocks (every
            // field is 32 bytes at an offset that is a multiple of 32), in the buffer (this
            // function's contract).
            unsafe {
                let v = _mm512_castps256_ps512(_mm256_load_ps(Self::at(self.lo, field)));
                _mm512_insertf32x8::<1>(v, _mm256_load_ps(Self::at(self.hi, field)))
            }
        }

        /// The reference layers of the pair.
        ///
        /// # Safety
        /// As [`PairPtrs::load`].
        #[inline]
        unsafe fn load_z0(self) -> __m512 {
            // SAFETY: this function's contract.
            unsafe { self.load(offset_of!(Block, z0)) }
        }

        /// Stores `v` into field `field` of the pair.
        ///
        /// # Safety
        /// As [`PairPtrs::load`].
        #[inline]
        unsafe fn store(self, field: usize, v: __m512) {
            // SAFETY: as in `load`.
            unsafe {
                _mm256_store_ps(Self::at(self.lo, field), _mm512_castps512_ps256(v));
                _mm256_store_ps(Self::at(self.hi, field), _mm512_extractf32x8_ps::<1>(v));
            }
        }
    }
}

/// What a pair of block rows needs of the triangle's depth plane, per lane (tile row
/// `lane / 4` of the pair): the plane's minimum over the tile row's scanlines, as the per-tile
/// path computes it, and its maximum; the mask bits beyond the image of the last tile row.
struct PairDepth {
    r_rows: __m512,
    r_rows_max: __m512,
    outside_y: __m512i,
    /// Whether the pair holds the image's last tile row.
    last_row: bool,
}

impl PairDepth {
    avx512! {
        #[inline]
        fn new(tri: &Triangle16, by: u32, g: &BlockGrid) -> Self {
            let lane_ty = _mm512_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3);
            let tyv = _mm512_add_epi32(_mm512_set1_epi32((2 * by) as i32), lane_ty);
            let ya = _mm512_add_ps(
                _mm512_cvtepi32_ps(_mm512_slli_epi32::<2>(tyv)),
                _mm512_set1_ps(0.5),
            );
            let yb = _mm512_add_ps(ya, _mm512_set1_ps(3.0));
            let (rb, y0, r0) = (tri.lane(&tri.t.rb), tri.lane(&tri.t.y0), tri.lane(&tri.t.r0));
            let da = _mm512_mul_ps(rb, _mm512_sub_ps(ya, y0));
            let db = _mm512_mul_ps(rb, _mm512_sub_ps(yb, y0));
            PairDepth {
                r_rows: _mm512_add_ps(r0, min_like(da, db)),
                r_rows_max: _mm512_add_ps(r0, _mm512_max_ps(da, db)),
                outside_y: _mm512_maskz_mov_epi32(
                    _mm512_cmpeq_epi32_mask(tyv, _mm512_set1_epi32(g.last_ty as i32)),
                    _mm512_set1_epi32(g.outside_y as i32),
                ),
                last_row: g.last_ty / 2 == by || g.last_ty / 2 == by + 1,
            }
        }

        /// Whether every tile of block column `bx` in the pair's `lanes` (reference layers
        /// `z0`) lies behind the triangle: `blocks::BlockRowDepth::behind` for 16 tiles.
        #[inline]
        fn behind(&self, tri: &Triangle16, bx: u32, z0: __m512, lanes: __mmask16) -> bool {
            let behind_far = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(tri.r_far, z0) | !lanes;
            if behind_far != 0xFFFF {
                return false;
            }
            if !tri.plane_ok {
                return true;
            }
            // Behind where the nearest corner is (the merge's depth is never nearer, see
            // `per_tile::tile_depth`), or else the plane's bound is.
            let behind_near = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(tri.r_near, z0) | !lanes;
            behind_near == 0xFFFF || self.plane_behind(tri, bx, z0, behind_near)
        }

        /// Whether every tile of block column `bx` (reference layers `z0`) that is not in
        /// `behind_near` lies behind the triangle's depth plane: its bound at the tile's nearest
        /// pixel centres, which is never below the merge's depth (f32 rounding is monotonic,
        /// see `per_tile::tile_column_offsets`), is not nearer than `z0`.
        #[inline]
        fn plane_behind(&self, tri: &Triangle16, bx: u32, z0: __m512, behind_near: __mmask16) -> bool {
            let near = _mm512_add_ps(tile_columns(bx), tri.near_col);
            let bound = _mm512_add_ps(self.r_rows_max, _mm512_mul_ps(tri.ra, near));
            (_mm512_cmp_ps_mask::<_CMP_LE_OQ>(bound, z0) | behind_near) == 0xFFFF
        }
    }
}

avx512! {
    /// The spans of the 16 scanlines of block rows `by` and `by + 1` (one per lane), as
    /// `blocks::row_spans` computes those of 8: `(rel_a, rel_b, bx0, bx1)`.
    #[inline]
    fn pair_spans(tri: &Triangle16, by: u32) -> Option<(__m512i, __m512i, u32, u32)> {
        let half = _mm512_set1_ps(0.5);
        let row_base = (by * 8) as i32;
        let lane_f = _mm512_setr_ps(
            0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 15.0,
        );
        let yc = _mm512_add_ps(_mm512_set1_ps(row_base as f32 + 0.5), lane_f);
        let x_of = |(ex0, ey0, slope): (__m512, __m512, __m512)| {
            _mm512_add_ps(ex0, _mm512_mul_ps(_mm512_sub_ps(yc, ey0), slope))
        };
        let [left, right, third] = [0, 1, 2].map(|role| x_of(tri.edge(role)));
        let t = tri.t;
        // See `setup::store_edges` for why this is the per-tile kernels' maximum and minimum.
        let xl = _mm512_max_ps(
            _mm512_add_ps(third, tri.lane(&t.third_bias_l)),
            _mm512_max_ps(left, _mm512_set1_ps(f32::NEG_INFINITY)),
        );
        let xr = _mm512_min_ps(
            _mm512_add_ps(third, tri.lane(&t.third_bias_r)),
            _mm512_min_ps(right, _mm512_set1_ps(f32::INFINITY)),
        );
        let xa = _mm512_sub_ps(xl, half);
        let xa = _mm512_min_ps(_mm512_max_ps(xa, tri.lane(&t.a_lo)), tri.lane(&t.a_hi));
        let xb = _mm512_sub_ps(xr, half);
        let xb = _mm512_min_ps(_mm512_max_ps(xb, tri.lane(&t.b_lo)), tri.lane(&t.b_hi));
        // Ceiling of `xa`, floor of `xb`, as `blocks::row_spans` rounds them.
        let a = _mm512_cvt_roundps_epi32::<{ _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC }>(xa);
        let b = _mm512_cvt_roundps_epi32::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(xb);
        let rows = _mm512_add_epi32(
            _mm512_set1_epi32(row_base),
            _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
        );
        let invalid = _mm512_cmpgt_epi32_mask(_mm512_set1_epi32(tri.row0), rows)
            | _mm512_cmpgt_epi32_mask(rows, _mm512_set1_epi32(tri.row1))
            | _mm512_cmpgt_epi32_mask(a, b);
        if invalid == 0xFFFF {
            return None;
        }
        let a = _mm512_mask_mov_epi32(a, invalid, _mm512_set1_epi32(EMPTY_LO));
        let b = _mm512_mask_mov_epi32(b, invalid, _mm512_set1_epi32(EMPTY_HI));
        let (bx0, bx1) = if tri.col1 / 32 - tri.col0 / 32 <= 2 {
            // At most three blocks wide: the bounding box's blocks (a block no span reaches
            // gets empty masks, which the merge keeps).
            (tri.col0 as u32 / 32, tri.col1 as u32 / 32)
        } else {
            (
                _mm512_reduce_min_epi32(a) as u32 / 32,
                _mm512_reduce_max_epi32(b) as u32 / 32,
            )
        };
        let block0 = _mm512_set1_epi32((32 * bx0) as i32);
        let rel_a = _mm512_sub_epi32(a, block0);
        let rel_b = _mm512_sub_epi32(_mm512_add_epi32(b, _mm512_set1_epi32(1)), block0);
        Some((rel_a, rel_b, bx0, bx1))
    }

    /// The coverage masks of the 16 tiles of a block pair (one per lane) from the spans of
    /// its 16 scanlines: `blocks::block_masks` for two blocks (the byte transpose works
    /// within each 128-bit quarter: one tile row of 4 tiles).
    #[inline]
    fn pair_masks(rel_a: __m512i, rel_b: __m512i) -> __m512i {
        let zero = _mm512_setzero_si512();
        let ones = _mm512_set1_epi32(-1);
        let from_a = _mm512_sllv_epi32(ones, _mm512_max_epi32(rel_a, zero));
        let from_b = _mm512_sllv_epi32(ones, _mm512_max_epi32(rel_b, zero));
        let rows = _mm512_andnot_si512(from_b, from_a);
        let transpose = _mm512_broadcast_i32x4(_mm_setr_epi8(
            0, 4, 8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15,
        ));
        _mm512_shuffle_epi8(rows, transpose)
    }

    /// `blocks::merge_block` for the block pair (lanes 0-7 and 8-15), with mask registers for
    /// its selects; `z0` is their reference layers, already loaded.
    ///
    /// # Safety
    /// As [`PairPtrs::load_z0`].
    #[inline]
    unsafe fn merge_pair(p: PairPtrs, z0: __m512, cov: __m512i, r: __m512) {
        // SAFETY: the blocks are in the buffer (this function's contract).
        let (z1, m) = unsafe { (p.load(offset_of!(Block, z1)), p.load(offset_of!(Block, mask))) };
        let m = _mm512_castps_si512(m);
        let all = _mm512_set1_epi32(-1);
        // Changed: covered, and nearer than the reference layer (not NaN). The other lanes
        // keep their three fields, which every select below does by masking with `update`.
        let update = _mm512_mask_cmp_ps_mask::<_CMP_GT_OQ>(_mm512_test_epi32_mask(cov, cov), r, z0);
        // Dropped: no working layer, the triangle covers the whole tile, or (with a reference
        // layer) it is much nearer than the working layer (`tiles::update_tile`).
        let much_nearer = _mm512_mask_cmp_ps_mask::<_CMP_GT_OQ>(
            _mm512_cmp_ps_mask::<_CMP_GT_OQ>(z0, _mm512_setzero_ps()),
            _mm512_sub_ps(r, z1),
            _mm512_sub_ps(z1, z0),
        );
        let discard = _mm512_testn_epi32_mask(m, m)
            | _mm512_cmpeq_epi32_mask(cov, all)
            | much_nearer;
        // `min` without a NaN select: neither `z1` nor `r` is NaN in a lane that changes.
        let z1n = _mm512_mask_mov_ps(_mm512_min_ps(z1, r), discard, r);
        let mn = _mm512_mask_or_epi32(cov, !discard, m, cov);
        let full = _mm512_mask_cmpeq_epi32_mask(update, mn, all);
        // A full working layer becomes the reference layer, and the working layer restarts.
        let z0n = _mm512_mask_mov_ps(z0, full, z1n);
        let z1n = _mm512_mask_mov_ps(_mm512_mask_mov_ps(z1, update, z1n), full, _mm512_setzero_ps());
        let mn = _mm512_maskz_mov_epi32(!full, _mm512_mask_mov_epi32(m, update, mn));
        // SAFETY: as above.
        unsafe {
            p.store(offset_of!(Block, z0), z0n);
            p.store(offset_of!(Block, z1), z1n);
            p.store(offset_of!(Block, mask), _mm512_castsi512_ps(mn));
        }
    }

    /// [`merge_pair`] for a triangle that covers all 16 tiles (`cov` all ones in every lane):
    /// a tile it is nearer than (`r > z0`) gets `r` as its reference layer and loses its
    /// working layer (`tiles::update_tile` with a full mask), the others stay; their working
    /// layers are not even loaded. `z0` is the pair's reference layers, already loaded.
    ///
    /// # Safety
    /// As [`PairPtrs::load_z0`].
    #[inline]
    unsafe fn cover_pair(p: PairPtrs, z0: __m512, r: __m512) {
        let nearer = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(r, z0);
        if nearer == 0 {
            return;
        }
        // SAFETY: the blocks are in the buffer (this function's contract); masked stores of
        // zeros into the lanes of `nearer` of the aligned 32-byte fields.
        unsafe {
            // `max(r, z0)` is `r` where `r > z0` and `z0` elsewhere, NaN `r` included.
            p.store(offset_of!(Block, z0), _mm512_max_ps(r, z0));
            let zero = _mm256_setzero_ps();
            let (lo, hi) = (nearer as __mmask8, (nearer >> 8) as __mmask8);
            for field in [offset_of!(Block, z1), offset_of!(Block, mask)] {
                _mm256_mask_store_ps(PairPtrs::at(p.lo, field), lo, zero);
                _mm256_mask_store_ps(PairPtrs::at(p.hi, field), hi, zero);
            }
        }
    }

    /// `a.min(b)` of `f32` lane by lane (the non-NaN operand when one is NaN), as
    /// `blocks::min_like_f32`.
    #[inline]
    fn min_like(a: __m512, b: __m512) -> __m512 {
        _mm512_mask_mov_ps(_mm512_min_ps(a, b), _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(b, b), a)
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::tiles::test_states::{random_merge, reachable_tile};
    use super::super::super::tiles::{update_tile, CLEAR_BLOCK, FULL};
    use super::*;

    #[test]
    fn pair_cover_equals_tile_update_with_full_masks() {
        use std::arch::is_x86_feature_detected as has;
        if !(has!("avx512f") && has!("avx512bw") && has!("avx512dq") && has!("avx512vl")) {
            eprintln!("no AVX-512 on this CPU: the pair cover cannot run");
            return;
        }
        let mut rng = sightline_core::random::SplitMix64::new(9);
        let mut changed = 0;
        for _ in 0..3_000 {
            // Two blocks a row apart, as `pair_row` reaches them (a row of one block).
            let mut blocks = [CLEAR_BLOCK; 2];
            let mut want = blocks;
            let mut r = [0f32; 16];
            for (lane, r) in r.iter_mut().enumerate() {
                let (b, l) = (lane / 8, lane % 8);
                let mut tile = reachable_tile(&mut rng);
                (blocks[b].z0[l], blocks[b].z1[l], blocks[b].mask[l]) =
                    (tile.z0, tile.z1, tile.mask);
                *r = random_merge(&mut rng).1;
                update_tile(&mut tile, FULL, *r);
                (want[b].z0[l], want[b].z1[l], want[b].mask[l]) = (tile.z0, tile.z1, tile.mask);
            }
            let before = blocks;
            let pair = PairPtrs::new(blocks.as_mut_ptr(), 1, 0);
            // SAFETY: AVX-512 support was checked above; the pair is the two local blocks,
            // which no reference points to while it is covered.
            unsafe {
                let z0 = pair.load_z0();
                cover_pair(pair, z0, _mm512_loadu_ps(r.as_ptr()));
            }
            let bits = |b: &[Block; 2]| {
                b.map(|b| (b.z0.map(f32::to_bits), b.z1.map(f32::to_bits), b.mask))
            };
            assert_eq!(bits(&blocks), bits(&want), "{before:?} covered at {r:?}");
            changed += usize::from(want != before);
        }
        assert!(changed > 1_500, "{changed}");
    }
}
