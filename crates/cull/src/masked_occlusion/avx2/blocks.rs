//! The AVX2 kernel's per-triangle step: one set-up triangle drawn a block of 4x2 tiles at a
//! time ([`raster_blocks`]): the spans of a block row's 8 scanlines in one register, the masks,
//! depths and merges of a block's 8 tiles in one register each, without branches per tile. A
//! scanline's coverage of a block is two shifts of all ones, and one byte shuffle turns the
//! block's 8 scanlines into its 8 tile masks ([`block_masks`]); blocks (and whole block rows)
//! whose tiles all lie behind the triangle's upper depth bound are skipped before their masks
//! are computed ([`BlockRowDepth::behind`]), which keeps the cost from growing with overdraw.
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! section 4 (the tiles of a block in the lanes of a register, coverage by shifts and a byte
//! transpose, the coarse depth cull of occluder tiles); Andersson, Hasselgren, Akenine-Möller.
//! Masked Depth Culling for Graphics Hardware. 2015, section 3 (the tile merge, here with
//! selects for 8 tiles at once in [`merge_block`]).

use std::arch::x86_64::*;

use super::super::constants::TILE_H;
use super::super::per_tile::{EMPTY_HI, EMPTY_LO};
use super::super::tiles::{Block, Tiles};
use super::setup::Setup8;

/// The block grid of a buffer, apart from its blocks (which the kernel borrows mutably).
pub(super) struct BlockGrid {
    pub(super) blocks_x: u32,
    /// Last tile column and row of the image.
    pub(super) last_tx: u32,
    pub(super) last_ty: u32,
    /// Mask bits beyond the image of the last tile column / row (see [`Tiles`]).
    pub(super) outside_x: u32,
    pub(super) outside_y: u32,
}

impl BlockGrid {
    pub(super) fn new(tiles: &Tiles) -> Self {
        BlockGrid {
            blocks_x: tiles.blocks_x,
            last_tx: tiles.tiles_x - 1,
            last_ty: tiles.tiles_y - 1,
            outside_x: tiles.outside_x,
            outside_y: tiles.outside_y,
        }
    }
}

/// One triangle (lane `l` of a [`Setup8`]): what every block reads broadcast to the 8 lanes;
/// what a block row reads once is broadcast from the setup where it is used
/// ([`Triangle::lane`]), which keeps the registers free of values used once.
struct Triangle<'a> {
    t: &'a Setup8,
    l: usize,
    /// Offsets from a tile's first column to its farthest and nearest pixel centres, minus
    /// `x0` (`per_tile::tile_column_offsets`).
    far_col: __m256,
    near_col: __m256,
    ra: __m256,
    r_far: __m256,
    r_near: __m256,
    plane_ok: bool,
    row0: i32,
    row1: i32,
    col0: i32,
    col1: i32,
}

impl<'a> Triangle<'a> {
    #[inline]
    #[target_feature(enable = "avx2")]
    fn new(t: &'a Setup8, l: usize) -> Self {
        let set1 = _mm256_set1_ps;
        Triangle {
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
    #[target_feature(enable = "avx2")]
    fn lane(&self, field: &[f32; 8]) -> __m256 {
        _mm256_set1_ps(field[self.l])
    }
}

/// What [`row_spans`] reads of a triangle, broadcast once per triangle rather than once per
/// block row: AVX2 has no broadcast operands, so a broadcast in the row loop is an
/// instruction of its own, while a value held here is a register or a folded load.
struct SpanEdges {
    /// Edges by role (`setup::store_edges`), `x = x0 + (y - y0) * slope`.
    x0: [__m256; 3],
    y0: [__m256; 3],
    slope: [__m256; 3],
    third_bias_l: __m256,
    third_bias_r: __m256,
    /// Span clamps, see `per_tile::ColClamp`.
    a_lo: __m256,
    a_hi: __m256,
    b_lo: __m256,
    b_hi: __m256,
}

impl SpanEdges {
    #[inline]
    #[target_feature(enable = "avx2")]
    fn new(tri: &Triangle) -> Self {
        let t = tri.t;
        SpanEdges {
            x0: [0, 1, 2].map(|role| tri.lane(&t.ex0[role])),
            y0: [0, 1, 2].map(|role| tri.lane(&t.ey0[role])),
            slope: [0, 1, 2].map(|role| tri.lane(&t.slope[role])),
            third_bias_l: tri.lane(&t.third_bias_l),
            third_bias_r: tri.lane(&t.third_bias_r),
            a_lo: tri.lane(&t.a_lo),
            a_hi: tri.lane(&t.a_hi),
            b_lo: tri.lane(&t.b_lo),
            b_hi: tri.lane(&t.b_hi),
        }
    }
}

/// Rasterizes one triangle (already set up: edges, bounding box, depth plane) into the blocks
/// of 4x2 tiles, a block row (8 scanlines) at a time. A block row whose blocks in the bounding
/// box all lie behind the triangle ([`BlockRowDepth::behind`]) is skipped before its spans are
/// computed; otherwise the spans of its 8 scanlines ([`row_spans`]) give each block's 8 tile
/// masks ([`block_masks`]), and the tiles' conservative depths are merged ([`merge_block`]).
///
/// Every value is the one the per-tile path computes, with the same `f32` operations: spans
/// as in the SSE2 kernel, a tile's depth at its farthest pixel centres, the tile
/// merge of `update_tile`; tiles the triangle does not cover get a zero mask and are left
/// unchanged, and skipped blocks are ones the merge would leave unchanged. So the buffers are
/// identical bit for bit (checked by the tests).
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn raster_blocks(blocks: &mut [Block], g: &BlockGrid, t: &Setup8, l: usize) {
    let tri = Triangle::new(t, l);
    let (bbox_bx0, bbox_bx1) = (tri.col0 as u32 / 32, tri.col1 as u32 / 32);
    let (by0, by1) = (
        tri.row0 as u32 / (2 * TILE_H),
        tri.row1 as u32 / (2 * TILE_H),
    );
    // Every block the rows below touch lies in the buffer (the bounding box is clamped to the
    // image): checked once here, so that the loops index the rows without checks.
    assert!(bbox_bx1 < g.blocks_x && ((by1 + 1) * g.blocks_x) as usize <= blocks.len());
    let narrow = bbox_bx1 - bbox_bx0 <= 1 && by1 - by0 <= 2;
    let edges = SpanEdges::new(&tri);
    for by in by0..by1 + 1 {
        // SAFETY: row `by <= by1` is in `blocks` (asserted above), and every index into it
        // below is at most `bbox_bx1 < blocks_x` (`row_spans` keeps to the bounding box).
        let block_row = unsafe {
            std::slice::from_raw_parts_mut(
                blocks.as_mut_ptr().add((by * g.blocks_x) as usize),
                g.blocks_x as usize,
            )
        };
        if narrow {
            // A small triangle (at most two blocks wide and three block rows tall): no search
            // (its blocks are seldom behind; cachegrind counts 17 % fewer instructions on the
            // 10 px set without it); the spans first, then each block's own depth test.
            // Larger triangles keep the search: their rows are often hidden whole, and it
            // skips their spans (twentieth session: spans first cost 33-67 % at 50-100 px).
            let depth = BlockRowDepth::new(&tri, by, g);
            if let Some(spans) = row_spans(&tri, &edges, by) {
                draw_blocks(block_row, g, &tri, &depth, spans.2, spans);
            }
            continue;
        }
        // The first block of the bounding box that does not lie behind the triangle; the
        // row is done when there is none. Most blocks looked at here are behind the
        // triangle's nearest corner (a hidden triangle's are), so that test comes first, and
        // the depth plane's rows are set up only when a block needs its bound.
        let mut plane: Option<BlockRowDepth> = None;
        let first_open = 'search: {
            // A walk over pointers (cachegrind: 0.4-2.4 % fewer instructions on the frames and
            // the random sets than a `find` over block indices).
            let row = block_row.as_ptr();
            // SAFETY: `bbox_bx0 <= bbox_bx1 + 1 <= blocks_x` (asserted above): both ends are in
            // the row or one past it.
            let (mut at, end) =
                unsafe { (row.add(bbox_bx0 as usize), row.add(bbox_bx1 as usize + 1)) };
            while at < end {
                // SAFETY: `at` lies in the row; an aligned load of the 32-byte `z0` array of a
                // `#[repr(align(32))]` block.
                let z0 = unsafe { load_z0(&*at) };
                let behind_near = _mm256_cmp_ps::<_CMP_LE_OQ>(tri.r_near, z0);
                if _mm256_movemask_ps(behind_near) != 0xFF {
                    // SAFETY: `at` and `row` point into the same row.
                    let bx = unsafe { at.offset_from(row) } as u32;
                    if _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tri.r_far, z0)) != 0xFF
                        || (tri.plane_ok
                            && !plane
                                .get_or_insert_with(|| BlockRowDepth::new(&tri, by, g))
                                .plane_behind(&tri, tile_columns(bx), z0, behind_near))
                    {
                        break 'search Some(bx);
                    }
                }
                // SAFETY: at most one past the row's last block of the box (`end`).
                at = unsafe { at.add(1) };
            }
            None
        };
        let Some(first_open) = first_open else {
            continue;
        };
        let depth = plane.unwrap_or_else(|| BlockRowDepth::new(&tri, by, g));
        let Some(spans) = row_spans(&tri, &edges, by) else {
            continue;
        };
        draw_blocks(block_row, g, &tri, &depth, first_open, spans);
    }
}

/// The blocks of one block row that the spans `(rel_a, rel_b, bx0, bx1)` reach ([`row_spans`]):
/// masks, depths and merges, from `first_open` on (the blocks before it lie behind the
/// triangle), skipping those after it that lie behind the triangle.
#[inline]
#[target_feature(enable = "avx2")]
fn draw_blocks(
    block_row: &mut [Block],
    g: &BlockGrid,
    tri: &Triangle,
    depth: &BlockRowDepth,
    first_open: u32,
    (rel_a, rel_b, bx0, bx1): (__m256i, __m256i, u32, u32),
) {
    let all = _mm256_set1_epi32(-1);
    let zero = _mm256_setzero_si256();
    let last_bx = g.last_tx / 4;
    // A row whose spans reach fewer than three blocks seldom holds a block the triangle covers
    // whole (only where the image's edges cut the triangle): the test is skipped there, and
    // the merge gives the same result anyway (cachegrind: half the test's cost on 10-25 px).
    let may_cover = bx1 - bx0 >= 2;
    // The blocks before `first_open` lie behind the triangle: the loop starts at it, with the
    // spans moved on to it.
    let start = bx0.max(first_open);
    // Saturating 16-bit steps keep the span ends at least 0 (a span behind the block covers
    // none of it, as it would at any negative count). They fit 16 bits: a triangle drawn
    // lies in the guard band, at most 2 x 16,384 pixels wide (`project::GUARD_PX`), so
    // its span ends lie at most 32,769 columns after its first block.
    let ahead = _mm256_set1_epi32((32 * (start - bx0)) as i32);
    let (mut rel_a, mut rel_b) = (
        _mm256_subs_epu16(rel_a, ahead),
        _mm256_subs_epu16(rel_b, ahead),
    );
    // The tiles' first columns, carried from block to block (small integers: exact in f32).
    let mut columns = tile_columns(start);
    for bx in start..bx1 + 1 {
        // SAFETY: `bx0..=bx1` lies in the bounding box (`row_spans`), so in the row.
        let block = unsafe { block_row.get_unchecked_mut(bx as usize) };
        // SAFETY: as above.
        let z0 = unsafe { load_z0(block) };
        let skip = bx > first_open && depth.behind(tri, columns, z0);
        if !skip {
            let mask = block_masks(rel_a, rel_b);
            // Mask bits beyond the image count as covered in a touched tile of the last
            // tile column or row.
            let cov = if bx == last_bx || depth.last_row {
                let lane_tx = _mm256_setr_epi32(0, 1, 2, 3, 0, 1, 2, 3);
                let txv = _mm256_add_epi32(_mm256_set1_epi32((4 * bx) as i32), lane_tx);
                let outside_x = _mm256_and_si256(
                    _mm256_cmpeq_epi32(txv, _mm256_set1_epi32(g.last_tx as i32)),
                    _mm256_set1_epi32(g.outside_x as i32),
                );
                let outside = _mm256_or_si256(outside_x, depth.outside_y);
                let untouched = _mm256_cmpeq_epi32(mask, zero);
                _mm256_or_si256(mask, _mm256_andnot_si256(untouched, outside))
            } else {
                mask
            };
            // The plane's farthest value over each tile, as `per_tile.rs` computes it.
            let r = if tri.plane_ok {
                let far = _mm256_add_ps(columns, tri.far_col);
                let m = _mm256_add_ps(depth.r_rows, _mm256_mul_ps(tri.ra, far));
                // `f32::max` without a NaN select: `r_far` is never NaN (corners are
                // finite and in front of the near plane).
                _mm256_min_ps(_mm256_max_ps(m, tri.r_far), tri.r_near)
            } else {
                tri.r_far
            };
            // A block the triangle covers whole (the inside of a large triangle) takes the
            // merge's one outcome for a full mask, without its selects.
            if may_cover && _mm256_movemask_epi8(_mm256_cmpeq_epi32(cov, all)) == -1 {
                cover_block(block, z0, r);
            } else {
                merge_block(block, z0, cov, r, all);
            }
        }
        rel_a = _mm256_subs_epu16(rel_a, _mm256_set1_epi32(32));
        rel_b = _mm256_subs_epu16(rel_b, _mm256_set1_epi32(32));
        columns = _mm256_add_ps(columns, _mm256_set1_ps(32.0));
    }
}

/// The reference layer of a block's 8 tiles.
///
/// # Safety
/// The CPU must support AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn load_z0(block: &Block) -> __m256 {
    // SAFETY: an aligned load of the 32-byte `z0` array of a `#[repr(align(32))]` block.
    unsafe { _mm256_load_ps(block.z0.as_ptr()) }
}

/// What a block row's tiles need of the triangle's depth plane: per lane (tile row `lane / 4`
/// of the block row) the plane's minimum over the tile row's scanlines, as the per-tile path
/// computes it, and its maximum; and the mask bits beyond the image of the last tile row.
struct BlockRowDepth {
    r_rows: __m256,
    r_rows_max: __m256,
    outside_y: __m256i,
    /// Whether the block row holds the image's last tile row.
    last_row: bool,
}

impl BlockRowDepth {
    #[inline]
    #[target_feature(enable = "avx2")]
    fn new(tri: &Triangle, by: u32, g: &BlockGrid) -> Self {
        let lane_ty = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
        let tyv = _mm256_add_epi32(_mm256_set1_epi32((2 * by) as i32), lane_ty);
        let ya = _mm256_add_ps(
            _mm256_cvtepi32_ps(_mm256_slli_epi32::<2>(tyv)),
            _mm256_set1_ps(0.5),
        );
        let yb = _mm256_add_ps(ya, _mm256_set1_ps((TILE_H - 1) as f32));
        let (rb, y0, r0) = (
            tri.lane(&tri.t.rb),
            tri.lane(&tri.t.y0),
            tri.lane(&tri.t.r0),
        );
        let da = _mm256_mul_ps(rb, _mm256_sub_ps(ya, y0));
        let db = _mm256_mul_ps(rb, _mm256_sub_ps(yb, y0));
        BlockRowDepth {
            r_rows: _mm256_add_ps(r0, min_like_f32(da, db)),
            r_rows_max: _mm256_add_ps(r0, _mm256_max_ps(da, db)),
            outside_y: _mm256_and_si256(
                _mm256_cmpeq_epi32(tyv, _mm256_set1_epi32(g.last_ty as i32)),
                _mm256_set1_epi32(g.outside_y as i32),
            ),
            last_row: g.last_ty / 2 == by,
        }
    }

    /// Whether every tile of a block (tiles starting at pixel columns `columns`, reference
    /// layers `z0`) lies behind the triangle: an upper bound of the depth the merge would
    /// compute for each tile, the plane at the tile's nearest pixel centres instead of its
    /// farthest (f32 rounding is monotonic, so it bounds the merge's depth exactly, see
    /// `per_tile::tile_column_offsets`), is not nearer than the tile's reference layer. The
    /// merge leaves such tiles unchanged (its `r > z0` fails), so skipping them changes
    /// nothing; this is the coarse cull of occluder tiles of Hasselgren et al. 2016, section 4,
    /// with a tighter bound than the triangle's nearest corner.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn behind(&self, tri: &Triangle, columns: __m256, z0: __m256) -> bool {
        let behind_far = _mm256_cmp_ps::<_CMP_LE_OQ>(tri.r_far, z0);
        // Most tiles a triangle reaches are not behind even its farthest corner: decide those
        // before the plane's bound.
        if _mm256_movemask_ps(behind_far) != 0xFF {
            return false;
        }
        if !tri.plane_ok {
            return true;
        }
        // Behind where the nearest corner is (Hasselgren et al.'s test: the merge's depth is
        // never nearer, see `per_tile::tile_depth`), or else the plane's bound is.
        let behind_near = _mm256_cmp_ps::<_CMP_LE_OQ>(tri.r_near, z0);
        _mm256_movemask_ps(behind_near) == 0xFF || self.plane_behind(tri, columns, z0, behind_near)
    }

    /// Whether every tile of a block (tiles starting at pixel columns `columns`, reference
    /// layers `z0`) that is not in `behind_near` lies behind the triangle's depth plane: its
    /// bound at the tile's nearest pixel centres, which is never below the merge's depth (f32
    /// rounding is monotonic, see `per_tile::tile_column_offsets`), is not nearer than `z0`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn plane_behind(
        &self,
        tri: &Triangle,
        columns: __m256,
        z0: __m256,
        behind_near: __m256,
    ) -> bool {
        let near = _mm256_add_ps(columns, tri.near_col);
        let bound = _mm256_add_ps(self.r_rows_max, _mm256_mul_ps(tri.ra, near));
        let behind = _mm256_or_ps(behind_near, _mm256_cmp_ps::<_CMP_LE_OQ>(bound, z0));
        _mm256_movemask_ps(behind) == 0xFF
    }
}

/// The spans of block row `by`'s 8 scanlines (one per lane), as the SSE2 kernel computes them,
/// relative to the first block they touch: `(rel_a, rel_b, bx0, bx1)` with columns
/// `rel_a..rel_b` (`rel_b` exclusive, empty for scanlines outside the triangle) counted from
/// column `32 bx0`, and the block columns `bx0..=bx1` the spans touch; `None` when none does.
/// Scanline centres are exact in f32 (small integers plus a half).
#[inline]
#[target_feature(enable = "avx2")]
fn row_spans(tri: &Triangle, e: &SpanEdges, by: u32) -> Option<(__m256i, __m256i, u32, u32)> {
    let half = _mm256_set1_ps(0.5);
    let neg_inf = _mm256_set1_ps(f32::NEG_INFINITY);
    let pos_inf = _mm256_set1_ps(f32::INFINITY);
    let row_base = (by * 2 * TILE_H) as i32;
    let yc = _mm256_add_ps(
        _mm256_set1_ps(row_base as f32 + 0.5),
        _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0),
    );
    let [left, right, third] = [0, 1, 2].map(|role| {
        _mm256_add_ps(
            e.x0[role],
            _mm256_mul_ps(_mm256_sub_ps(yc, e.y0[role]), e.slope[role]),
        )
    });
    // See `setup::store_edges` for why this is the per-tile kernels' maximum and minimum.
    let xl = _mm256_max_ps(
        _mm256_add_ps(third, e.third_bias_l),
        _mm256_max_ps(left, neg_inf),
    );
    let xr = _mm256_min_ps(
        _mm256_add_ps(third, e.third_bias_r),
        _mm256_min_ps(right, pos_inf),
    );
    let xa = _mm256_sub_ps(xl, half);
    let xa = _mm256_min_ps(_mm256_max_ps(xa, e.a_lo), e.a_hi);
    let xb = _mm256_sub_ps(xr, half);
    let xb = _mm256_min_ps(_mm256_max_ps(xb, e.b_lo), e.b_hi);
    // `ceil_i` / `floor_i` of the clamped (finite, small) values: exact either way.
    let a = _mm256_cvttps_epi32(_mm256_round_ps::<
        { _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC },
    >(xa));
    let b = _mm256_cvttps_epi32(_mm256_round_ps::<
        { _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC },
    >(xb));
    let rows = _mm256_add_epi32(
        _mm256_set1_epi32(row_base),
        _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
    );
    let invalid = _mm256_or_si256(
        _mm256_or_si256(
            _mm256_cmpgt_epi32(_mm256_set1_epi32(tri.row0), rows),
            _mm256_cmpgt_epi32(rows, _mm256_set1_epi32(tri.row1)),
        ),
        _mm256_cmpgt_epi32(a, b),
    );
    let (bx0, bx1) = if tri.col1 / 32 - tri.col0 / 32 <= 2 {
        // A bounding box at most three blocks wide: its blocks, unless every scanline is
        // empty (a block no span reaches gets empty masks, which the merge keeps; finding
        // the spans' extent costs more than drawing it).
        if _mm256_movemask_ps(_mm256_castsi256_ps(invalid)) == 0xFF {
            return None;
        }
        (tri.col0 as u32 / 32, tri.col1 as u32 / 32)
    } else {
        // The extent of the spans of scanlines in the triangle's rows.
        let (lo_all, hi_all) = (
            hmin_epi32(_mm256_blendv_epi8(a, _mm256_set1_epi32(EMPTY_LO), invalid)),
            hmax_epi32(_mm256_blendv_epi8(b, _mm256_set1_epi32(EMPTY_HI), invalid)),
        );
        if lo_all > hi_all {
            return None;
        }
        (lo_all as u32 / 32, hi_all as u32 / 32)
    };
    // Relative to the first block, every span's ends are at least 0 (`bx0` is at or before
    // every valid span's start), and an empty span is `0..0`: the draw loop then keeps them
    // at least 0 by saturating steps, and the masks need no clamp (see [`block_masks`]).
    let block0 = _mm256_set1_epi32((32 * bx0) as i32);
    let rel_a = _mm256_andnot_si256(invalid, _mm256_sub_epi32(a, block0));
    let rel_b = _mm256_andnot_si256(
        invalid,
        _mm256_sub_epi32(_mm256_add_epi32(b, _mm256_set1_epi32(1)), block0),
    );
    Some((rel_a, rel_b, bx0, bx1))
}

/// The coverage masks of the 8 tiles of a block (one per lane) from the spans of the block
/// row's 8 scanlines (one per lane, columns `rel_a..rel_b` relative to the block, `rel_b`
/// exclusive, `0 <= rel_a <= rel_b`; empty when they are equal).
///
/// Hasselgren et al. 2016, section 4: a scanline's 32 pixels of coverage are two shifts of all
/// ones; a byte transpose then turns 8 scanlines of 4 tiles' bytes into 8 tile masks.
#[inline]
#[target_feature(enable = "avx2")]
fn block_masks(rel_a: __m256i, rel_b: __m256i) -> __m256i {
    let ones = _mm256_set1_epi32(-1);
    // `sllv` gives 0 for counts of 32 and more: spans past the block cover nothing, spans
    // that start before it (count 0) everything. `from_b` lies within `from_a`, so the
    // scanline's pixels are `from_a & !from_b`, which is `from_a ^ from_b`. (Written as that
    // `andnot` with the counts clamped to 0 here, as before, LLVM added a compare and a select
    // to each shift: 4 instructions a block.)
    let from_a = _mm256_sllv_epi32(ones, rel_a);
    let from_b = _mm256_sllv_epi32(ones, rel_b);
    let rows = _mm256_xor_si256(from_a, from_b);
    // Lane `j` holds scanline `j`, byte `i` its pixels of tile column `i`; tile `(i, j / 4)`
    // wants byte `i` of scanlines `4 (j / 4) + k` as its byte `k`: a 4x4 byte transpose in each
    // 128-bit half (tile row 0 in the low half, row 1 in the high half).
    let transpose = _mm256_setr_epi8(
        0, 4, 8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15, //
        0, 4, 8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15,
    );
    _mm256_shuffle_epi8(rows, transpose)
}

/// The first pixel column of each lane's tile in block column `bx`, as `f32` (exact).
#[inline]
#[target_feature(enable = "avx2")]
fn tile_columns(bx: u32) -> __m256 {
    let lane_x = _mm256_setr_ps(0.0, 8.0, 16.0, 24.0, 0.0, 8.0, 16.0, 24.0);
    _mm256_add_ps(_mm256_set1_ps((32 * bx) as f32), lane_x)
}

/// `update_tile` for the 8 tiles of a block at once, with selects; lanes with a zero `cov`
/// are left unchanged. `z0` is the block's reference layer, already loaded.
#[inline]
#[target_feature(enable = "avx2")]
fn merge_block(block: &mut Block, z0: __m256, cov: __m256i, r: __m256, all: __m256i) {
    // SAFETY: aligned loads of two 32-byte arrays of a `#[repr(align(32))]` block.
    let (z1, m) = unsafe {
        (
            _mm256_load_ps(block.z1.as_ptr()),
            _mm256_load_si256(block.mask.as_ptr().cast()),
        )
    };
    let zero = _mm256_setzero_si256();
    // Unchanged: nothing covered, or not nearer than the reference layer (or NaN).
    let nearer = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(r, z0));
    let keep = _mm256_or_si256(_mm256_cmpeq_epi32(cov, zero), _mm256_xor_si256(nearer, all));
    // Dropped: no working layer, the triangle covers the whole tile, or (with a reference
    // layer) it is much nearer than the working layer (`tiles::update_tile`).
    let much_nearer = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_GT_OQ>(z0, _mm256_setzero_ps()),
        _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_sub_ps(r, z1), _mm256_sub_ps(z1, z0)),
    );
    let discard = _mm256_or_si256(
        _mm256_or_si256(_mm256_cmpeq_epi32(m, zero), _mm256_cmpeq_epi32(cov, all)),
        _mm256_castps_si256(much_nearer),
    );
    // `min` without a NaN select: neither `z1` nor `r` is NaN in a lane that changes.
    let z1n = _mm256_blendv_ps(_mm256_min_ps(z1, r), r, _mm256_castsi256_ps(discard));
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

/// [`merge_block`] for a triangle that covers all 8 tiles (`cov` all ones in every lane):
/// a tile it is nearer than (`r > z0`) gets `r` as its reference layer and loses its working
/// layer (`tiles::update_tile` with a full mask), the others stay. `z0` is the block's
/// reference layer, already loaded.
#[inline]
#[target_feature(enable = "avx2")]
fn cover_block(block: &mut Block, z0: __m256, r: __m256) {
    let nearer = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(r, z0));
    if _mm256_testz_si256(nearer, nearer) != 0 {
        return;
    }
    // SAFETY: aligned loads and stores of the 32-byte arrays of a `#[repr(align(32))]` block.
    unsafe {
        let z1 = _mm256_load_si256(block.z1.as_ptr().cast());
        let m = _mm256_load_si256(block.mask.as_ptr().cast());
        // `max(r, z0)` is `r` where `r > z0` and `z0` elsewhere, NaN `r` included.
        _mm256_store_ps(block.z0.as_mut_ptr(), _mm256_max_ps(r, z0));
        _mm256_store_si256(
            block.z1.as_mut_ptr().cast(),
            _mm256_andnot_si256(nearer, z1),
        );
        _mm256_store_si256(
            block.mask.as_mut_ptr().cast(),
            _mm256_andnot_si256(nearer, m),
        );
    }
}

/// Smallest lane.
#[inline]
#[target_feature(enable = "avx2")]
fn hmin_epi32(v: __m256i) -> i32 {
    let m = _mm_min_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256::<1>(v));
    let m = _mm_min_epi32(m, _mm_shuffle_epi32::<0b01_00_11_10>(m));
    let m = _mm_min_epi32(m, _mm_shuffle_epi32::<0b10_11_00_01>(m));
    _mm_cvtsi128_si32(m)
}

/// Largest lane.
#[inline]
#[target_feature(enable = "avx2")]
fn hmax_epi32(v: __m256i) -> i32 {
    let m = _mm_max_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256::<1>(v));
    let m = _mm_max_epi32(m, _mm_shuffle_epi32::<0b01_00_11_10>(m));
    let m = _mm_max_epi32(m, _mm_shuffle_epi32::<0b10_11_00_01>(m));
    _mm_cvtsi128_si32(m)
}

/// `a.min(b)` of `f32` lane by lane (the non-NaN operand when one is NaN), as the scalar code.
#[inline]
#[target_feature(enable = "avx2")]
fn min_like_f32(a: __m256, b: __m256) -> __m256 {
    // `minps(a, b)` returns `b` when either is NaN: take `a` where `b` is NaN.
    _mm256_blendv_ps(_mm256_min_ps(a, b), a, _mm256_cmp_ps::<_CMP_UNORD_Q>(b, b))
}

#[cfg(test)]
mod tests {
    use super::super::super::tiles::test_states::{random_merge, reachable_tile};
    use super::super::super::tiles::{update_tile, CLEAR_BLOCK, FULL};
    use super::*;

    #[test]
    fn block_merge_and_cover_equal_tile_update() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 on this CPU: the block merge cannot run");
            return;
        }
        let mut rng = sightline_core::random::SplitMix64::new(5);
        let (mut changed, mut covered_changed) = (0, 0);
        for case in 0..6_000 {
            // Every third block covered whole: `cover_block` must then agree as well.
            let whole = case % 3 == 0;
            let mut block = CLEAR_BLOCK;
            let mut want = CLEAR_BLOCK;
            let (mut cov, mut r) = ([0u32; 8], [0f32; 8]);
            for l in 0..8 {
                let mut tile = reachable_tile(&mut rng);
                (block.z0[l], block.z1[l], block.mask[l]) = (tile.z0, tile.z1, tile.mask);
                let (c, z) = random_merge(&mut rng);
                (cov[l], r[l]) = (if whole { FULL } else { c }, z);
                if cov[l] != 0 {
                    update_tile(&mut tile, cov[l], r[l]);
                }
                (want.z0[l], want.z1[l], want.mask[l]) = (tile.z0, tile.z1, tile.mask);
            }
            let before = block;
            let mut covered = block;
            // SAFETY: AVX2 support was checked above; unaligned loads of local arrays.
            unsafe {
                let c = _mm256_loadu_si256(cov.as_ptr().cast());
                let z = _mm256_loadu_ps(r.as_ptr());
                let z0 = _mm256_load_ps(block.z0.as_ptr());
                merge_block(&mut block, z0, c, z, _mm256_set1_epi32(-1));
                if whole {
                    cover_block(&mut covered, z0, z);
                }
            }
            let bits = |b: &Block| (b.z0.map(f32::to_bits), b.z1.map(f32::to_bits), b.mask);
            assert_eq!(bits(&block), bits(&want), "{before:?} + {cov:x?}, {r:?}");
            if whole {
                assert_eq!(bits(&covered), bits(&want), "{before:?} covered at {r:?}");
                covered_changed += usize::from(want != before);
            }
            changed += usize::from(want != before);
        }
        assert!(
            changed > 3_000 && covered_changed > 1_000,
            "{changed}, {covered_changed}"
        );
    }
}
