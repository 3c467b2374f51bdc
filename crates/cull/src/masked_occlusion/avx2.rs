//! The AVX2 kernel of the masked occlusion buffer: triangles in batches of 8, one per lane,
//! through the view transform, culling and clipping choice, projection and setup
//! ([`transform_batch`], [`setup8`]); then each triangle drawn a block of 4x2 tiles at a time,
//! the spans of a block row's 8 scanlines in one register and the masks, depths and merges of
//! a block's 8 tiles in one register each ([`raster_blocks`]), without branches per tile. A
//! scanline's coverage of a block is two shifts of all ones, and one byte shuffle turns the
//! block's 8 scanlines into its 8 tile masks ([`block_masks`]); a block whose tiles all lie
//! behind the triangle's upper depth bound is skipped before its masks are computed (the early
//! out that makes the kernel's cost grow slowly with overdraw).
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! section 4 (the AVX2 form: triangle setup in SIMD lanes, the tiles of a block in the lanes
//! of a register, coverage by shifts and a byte transpose, the coarse depth cull of tiles); Andersson, Hasselgren, Akenine-Möller. Masked Depth Culling for Graphics
//! Hardware. 2015, section 3 (the tile merge, here with selects for 8 tiles at once in
//! [`merge_block`]).
//!
//! Bit-exactness: every value is the one the tile-at-a-time kernels (`per_tile.rs`) compute,
//! with the same `f32` operations in the same order, so the buffers are identical bit for bit
//! (checked by the tests).

use std::arch::x86_64::*;

use glam::Vec3;

use super::constants::{TILE_H, TILE_W};
use super::per_tile::{EMPTY_HI, EMPTY_LO};
use super::project::{Projector, GUARD};
use super::raster_kernel::RasterKernel;
use super::tiles::{Block, Tiles};

/// The AVX2 block kernel.
pub(super) struct Avx2;

impl RasterKernel for Avx2 {
    unsafe fn render(tiles: &mut Tiles, triangles: &[Vec3], proj: &Projector) {
        // SAFETY: the CPU supports AVX2 (this function's contract).
        unsafe { render_batches(tiles, triangles, proj) }
    }
}

/// The block grid of a buffer, apart from its blocks (which the kernel borrows mutably).
struct BlockGrid {
    blocks_x: u32,
    /// Last tile column and row of the image.
    last_tx: u32,
    last_ty: u32,
    /// Mask bits beyond the image of the last tile column / row (see [`Tiles`]).
    outside_x: u32,
    outside_y: u32,
}

impl BlockGrid {
    fn new(tiles: &Tiles) -> Self {
        BlockGrid {
            blocks_x: tiles.blocks_x,
            last_tx: tiles.tiles_x - 1,
            last_ty: tiles.tiles_y - 1,
            outside_x: tiles.outside_x,
            outside_y: tiles.outside_y,
        }
    }
}

/// Screen-space corners `[sx, sy, 1/z]` of up to 8 triangles, one per lane: `x[corner][lane]`.
#[repr(C, align(32))]
#[derive(Default)]
struct Screen8 {
    x: [[f32; 8]; 3],
    y: [[f32; 8]; 3],
    r: [[f32; 8]; 3],
}

/// View-space corners of up to 8 triangles, `x[corner][lane]`, for those that need clipping.
#[derive(Default)]
struct View8 {
    x: [[f32; 8]; 3],
    y: [[f32; 8]; 3],
    z: [[f32; 8]; 3],
}

impl View8 {
    /// The view-space corners of lane `l`.
    fn triangle(&self, l: usize) -> [Vec3; 3] {
        [0, 1, 2].map(|j| Vec3::new(self.x[j][l], self.y[j][l], self.z[j][l]))
    }
}

/// The setup of up to 8 triangles, one per lane, as [`setup8`] computes it: what the per-tile
/// path computes in `per_tile.rs` (after the swap to counter-clockwise order).
#[repr(C, align(32))]
#[derive(Default)]
struct Setup8 {
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
    /// Span clamps, see `per_tile::ColClamp`.
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

/// The rasterizer: triangles in batches of 8, one per lane, through [`transform_batch`] and
/// [`setup8`]; then the batch's triangles are drawn in their order (clipped ones through
/// [`raster_clipped`]) after prefetching their first blocks. Same arithmetic as the
/// per-triangle path.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
unsafe fn render_batches(tiles: &mut Tiles, triangles: &[Vec3], proj: &Projector) {
    let grid = BlockGrid::new(tiles);
    let camera = Camera8::new(proj);
    let mut setup = Setup8::default();
    let mut s = Screen8::default();
    let mut views = View8::default();
    for batch in triangles.chunks(24) {
        let n = batch.len() / 3;
        if n == 0 {
            break;
        }
        let (skip, fast) = transform_batch(&camera, batch, &mut s, &mut views);
        let draw = setup8(&s, tiles.width, tiles.height, &mut setup) & fast;
        for l in 0..n {
            if draw & (1 << l) != 0 {
                prefetch_blocks(tiles, &setup, l);
            }
        }
        for l in 0..n {
            let bit = 1 << l;
            if draw & bit != 0 {
                raster_blocks(&mut tiles.blocks, &grid, &setup, l);
            } else if (fast | skip) & bit == 0 {
                raster_clipped(tiles, views.triangle(l), proj);
            }
        }
    }
}

/// A [`Projector`] broadcast to the 8 lanes.
struct Camera8 {
    eye: [__m256; 3],
    /// `right`, `up`, `forward`, each `(x, y, z)`.
    axes: [(__m256, __m256, __m256); 3],
    near: __m256,
    /// The guard band's half-widths per unit of depth.
    gx: __m256,
    gy: __m256,
    kx: __m256,
    /// `-ky`.
    nky: __m256,
    cx: __m256,
    cy: __m256,
}

impl Camera8 {
    #[inline]
    #[target_feature(enable = "avx2")]
    fn new(proj: &Projector) -> Self {
        let set1 = _mm256_set1_ps;
        Camera8 {
            eye: [set1(proj.eye.x), set1(proj.eye.y), set1(proj.eye.z)],
            axes: [proj.right, proj.up, proj.forward].map(|a| (set1(a.x), set1(a.y), set1(a.z))),
            near: set1(proj.near),
            gx: set1(GUARD * proj.tan_x),
            gy: set1(GUARD * proj.tan_y),
            kx: set1(proj.kx),
            nky: set1(-proj.ky),
            cx: set1(proj.cx),
            cy: set1(proj.cy),
        }
    }
}

/// The view transform, the choice between culling, clipping and the fast path (every corner
/// in front of the near plane and inside the guard band) and the projection of a batch of up
/// to 8 triangles (24 corners; lanes past the end repeat the last triangle and are never
/// drawn): the screen corners into `s`, the view corners into `views`; returns the lanes to
/// skip (behind the near plane or not finite) and the lanes of the fast path, a bit each.
/// The arithmetic of `Projector::view`, `inside_guard` and `screen`, lane by lane.
#[inline]
#[target_feature(enable = "avx2")]
fn transform_batch(c: &Camera8, batch: &[Vec3], s: &mut Screen8, views: &mut View8) -> (u32, u32) {
    let n = batch.len() / 3;
    let set1 = _mm256_set1_ps;
    let abs = |v: __m256| _mm256_andnot_ps(set1(-0.0), v);
    let inf = set1(f32::INFINITY);
    let mut wx = [_mm256_setzero_ps(); 3];
    let mut wy = [_mm256_setzero_ps(); 3];
    let mut wz = [_mm256_setzero_ps(); 3];
    for j in 0..3 {
        let corner = |l: usize| batch[3 * l.min(n - 1) + j];
        let c: [Vec3; 8] = std::array::from_fn(corner);
        wx[j] = _mm256_setr_ps(
            c[0].x, c[1].x, c[2].x, c[3].x, c[4].x, c[5].x, c[6].x, c[7].x,
        );
        wy[j] = _mm256_setr_ps(
            c[0].y, c[1].y, c[2].y, c[3].y, c[4].y, c[5].y, c[6].y, c[7].y,
        );
        wz[j] = _mm256_setr_ps(
            c[0].z, c[1].z, c[2].z, c[3].z, c[4].z, c[5].z, c[6].z, c[7].z,
        );
    }
    let mut behind = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    let mut finite = behind;
    let mut guard = behind;
    let [ex, ey, ez] = c.eye;
    for j in 0..3 {
        let (dx, dy, dz) = (
            _mm256_sub_ps(wx[j], ex),
            _mm256_sub_ps(wy[j], ey),
            _mm256_sub_ps(wz[j], ez),
        );
        // `Vec3::dot`: (x * x') + (y * y') + (z * z').
        let [v_x, v_y, v_z] = c.axes.map(|(ax, ay, az)| {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(dx, ax), _mm256_mul_ps(dy, ay)),
                _mm256_mul_ps(dz, az),
            )
        });
        behind = _mm256_and_ps(behind, _mm256_cmp_ps::<_CMP_LT_OQ>(v_z, c.near));
        for v in [v_x, v_y, v_z] {
            finite = _mm256_and_ps(finite, _mm256_cmp_ps::<_CMP_LT_OQ>(abs(v), inf));
        }
        // `Projector::inside_guard`.
        let inside = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GE_OQ>(v_z, c.near),
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_LE_OQ>(abs(v_x), _mm256_mul_ps(c.gx, v_z)),
                _mm256_cmp_ps::<_CMP_LE_OQ>(abs(v_y), _mm256_mul_ps(c.gy, v_z)),
            ),
        );
        guard = _mm256_and_ps(guard, inside);
        // `Projector::screen` (garbage in lanes that are not drawn this way).
        let r = _mm256_div_ps(set1(1.0), v_z);
        // SAFETY: stores of 8 lanes into `[f32; 8]` arrays (those of `s` aligned).
        unsafe {
            _mm256_store_ps(
                s.x[j].as_mut_ptr(),
                _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(c.kx, v_x), r), c.cx),
            );
            _mm256_store_ps(
                s.y[j].as_mut_ptr(),
                _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(c.nky, v_y), r), c.cy),
            );
            _mm256_store_ps(s.r[j].as_mut_ptr(), r);
            _mm256_storeu_ps(views.x[j].as_mut_ptr(), v_x);
            _mm256_storeu_ps(views.y[j].as_mut_ptr(), v_y);
            _mm256_storeu_ps(views.z[j].as_mut_ptr(), v_z);
        }
    }
    let skip = _mm256_movemask_ps(_mm256_or_ps(
        behind,
        _mm256_xor_ps(finite, _mm256_castsi256_ps(_mm256_set1_epi32(-1))),
    )) as u32;
    let fast = _mm256_movemask_ps(guard) as u32 & !skip;
    (skip, fast)
}

/// Prefetches the blocks of the first block column of lane `l`'s bounding box (up to two
/// block rows: 16 scanlines).
#[inline(always)]
fn prefetch_blocks(tiles: &Tiles, setup: &Setup8, l: usize) {
    let (row0, row1, col0) = (setup.row0[l], setup.row1[l], setup.col0[l]);
    let ty0 = row0 as u32 / TILE_H;
    tiles.prefetch_block_rows(col0 as u32 / TILE_W, ty0, row1 as u32 / TILE_H);
}

/// Clips a view-space triangle to the near plane and the guard band, then draws its fan, each
/// triangle through the batched setup alone in lane 0 (the same results as a batch).
#[target_feature(enable = "avx2")]
fn raster_clipped(tiles: &mut Tiles, v: [Vec3; 3], proj: &Projector) {
    let grid = BlockGrid::new(tiles);
    proj.clipped_fan(v, |p| {
        let mut s = Screen8::default();
        for (j, c) in p.iter().enumerate() {
            (s.x[j][0], s.y[j][0], s.r[j][0]) = (c[0], c[1], c[2]);
        }
        let mut setup = Setup8::default();
        // The closure inherits AVX2 from `raster_clipped`.
        if setup8(&s, tiles.width, tiles.height, &mut setup) & 1 != 0 {
            raster_blocks(&mut tiles.blocks, &grid, &setup, 0);
        }
        false
    });
}

/// Triangle setup of 8 triangles at once (Hasselgren et al. 2016, section 4: setup in SIMD
/// lanes): the same `f32` and integer operations as `per_tile.rs` does for one, lane by lane:
/// area and orientation (clockwise triangles get corners 1 and 2 swapped), bounding box in
/// pixel centres clamped to the `width x height` buffer ([`bbox8`]), the `1/z` plane and the
/// edges. Returns a bit per lane that has something to draw (non-degenerate area, bounding box
/// inside the buffer); other lanes of `out` hold garbage.
#[inline]
#[target_feature(enable = "avx2")]
fn setup8(s: &Screen8, width: u32, height: u32, out: &mut Setup8) -> u32 {
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
    let [row0, row1, col0, col1] = bbox8([x0, x1, x2], [y0, y1, y2], width, height);
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
    store_edges(out, [x0, x1, x2], [y0, y1, y2]);
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

/// The bounding boxes of 8 screen triangles in pixel centres, clamped to the buffer:
/// `[row0, row1, col0, col1]` (first = `ceil(min - 0.5)`, last = `floor(max - 0.5)`, as
/// `project::ceil_i` / `floor_i` round).
#[inline]
#[target_feature(enable = "avx2")]
fn bbox8(xs: [__m256; 3], ys: [__m256; 3], width: u32, height: u32) -> [__m256i; 4] {
    let [x0, x1, x2] = xs;
    let [y0, y1, y2] = ys;
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
    [row0, row1, col0, col1]
}

/// The edges of 8 counter-clockwise triangles into `out`: edges a -> b with the interior on
/// the left (y down): going up (dy < 0) bounds spans from the left, going down from the
/// right; horizontal edges bound nothing.
#[inline]
#[target_feature(enable = "avx2")]
fn store_edges(out: &mut Setup8, xs: [__m256; 3], ys: [__m256; 3]) {
    // SAFETY (both): aligned stores into 32-byte arrays of the `#[repr(C, align(32))]` setup.
    let st = |a: &mut [f32; 8], v: __m256| unsafe { _mm256_store_ps(a.as_mut_ptr(), v) };
    let sti =
        |a: &mut [i32; 8], v: __m256i| unsafe { _mm256_store_si256(a.as_mut_ptr().cast(), v) };
    let zero = _mm256_setzero_ps();
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
}

/// One edge of lane `l` broadcast: `(x0, y0, slope, bounds left, bounds right)`.
type Edge8 = (__m256, __m256, __m256, __m256, __m256);

/// Rasterizes one triangle (already set up: edges, bounding box, depth plane) into the blocks
/// of 4x2 tiles. For each block row (8 scanlines, one per lane) the span ends are computed at
/// once; for each block (8 tiles, one per lane) the coverage masks ([`block_masks`]), the
/// conservative depths and the merge with the tiles ([`merge_block`]). (The span step stays
/// in this function: as a function of its own, even inlined, it cost 3 % more instructions.)
///
/// Every value is the one the per-tile path computes, with the same `f32` operations: spans
/// as in the SSE2 kernel, a tile's depth from the lowest and highest covered column, the tile
/// merge of `update_tile`; tiles the triangle does not cover get a zero mask and are left
/// unchanged. So the buffers are identical bit for bit (checked by the tests).
#[inline]
#[target_feature(enable = "avx2")]
fn raster_blocks(blocks: &mut [Block], g: &BlockGrid, t: &Setup8, l: usize) {
    let edges = edges8(t, l);
    let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let neg_inf = _mm256_set1_ps(f32::NEG_INFINITY);
    let pos_inf = _mm256_set1_ps(f32::INFINITY);
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
        // The spans of the block row's 8 scanlines (one per lane), as the SSE2 kernel computes
        // them; scanlines outside the triangle get an empty span. Scanline centres are exact
        // in f32 (small integers plus a half).
        let row_base = (by * 2 * TILE_H) as i32;
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
                _mm256_cmpgt_epi32(_mm256_set1_epi32(t.row0[l]), rows),
                _mm256_cmpgt_epi32(rows, _mm256_set1_epi32(t.row1[l])),
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
        let tyv = _mm256_add_epi32(_mm256_set1_epi32((2 * by) as i32), lane_ty);
        // The plane's minimum over each tile row's scanlines, as the per-tile path, and its
        // maximum (for the early out below).
        let (r_rows, r_rows_max) = {
            let ya = _mm256_add_ps(_mm256_cvtepi32_ps(_mm256_slli_epi32::<2>(tyv)), half);
            let yb = _mm256_add_ps(ya, _mm256_set1_ps((TILE_H - 1) as f32));
            let (rb, y0) = (_mm256_set1_ps(t.rb[l]), _mm256_set1_ps(t.y0[l]));
            let (da, db) = (
                _mm256_mul_ps(rb, _mm256_sub_ps(ya, y0)),
                _mm256_mul_ps(rb, _mm256_sub_ps(yb, y0)),
            );
            let r0 = _mm256_set1_ps(t.r0[l]);
            (
                _mm256_add_ps(r0, min_like_f32(da, db)),
                _mm256_add_ps(r0, _mm256_max_ps(da, db)),
            )
        };
        let outside_y = _mm256_and_si256(
            _mm256_cmpeq_epi32(tyv, _mm256_set1_epi32(g.last_ty as i32)),
            _mm256_set1_epi32(g.outside_y as i32),
        );
        let block_row = (by * g.blocks_x) as usize;
        let (bx0, bx1) = (lo_all as u32 / 32, hi_all as u32 / 32);
        // Span ends relative to the block's first column (`b` exclusive), one scanline per
        // lane; stepped by a block width per block.
        let block0 = _mm256_set1_epi32((32 * bx0) as i32);
        let mut rel_a = _mm256_sub_epi32(a, block0);
        let mut rel_b = _mm256_sub_epi32(_mm256_add_epi32(b, _mm256_set1_epi32(1)), block0);
        for bx in bx0..=bx1 {
            let block = &mut blocks[block_row + bx as usize];
            let txv = _mm256_add_epi32(_mm256_set1_epi32((4 * bx) as i32), lane_tx);
            let base = _mm256_cvtepi32_ps(_mm256_slli_epi32::<3>(txv));
            // Early out (as Hasselgren et al. 2016, section 4, cull occluder tiles that lie
            // behind the reference layer): an upper bound of the depth the merge below would
            // compute for each tile, from the tile's first and last column instead of the
            // covered ones (f32 rounding is monotonic, so it bounds them exactly). When no tile
            // of the block would pass the merge's `r > z0`, the block is left as it is, which
            // is what the merge would do.
            // SAFETY: an aligned load of the 32-byte `z0` array of a `#[repr(align(32))]` block.
            let z0 = unsafe { _mm256_load_ps(block.z0.as_ptr()) };
            let behind_far = _mm256_cmp_ps::<_CMP_LE_OQ>(r_far, z0);
            let behind = if plane_ok {
                let xa = _mm256_sub_ps(_mm256_add_ps(base, half), x0);
                let xb = _mm256_sub_ps(_mm256_add_ps(base, _mm256_set1_ps(7.5)), x0);
                let m = _mm256_max_ps(_mm256_mul_ps(ra, xa), _mm256_mul_ps(ra, xb));
                let bound = _mm256_add_ps(r_rows_max, m);
                _mm256_and_ps(behind_far, _mm256_cmp_ps::<_CMP_LE_OQ>(bound, z0))
            } else {
                behind_far
            };
            let skip = _mm256_movemask_ps(behind) == 0xFF;
            if !skip {
                let (mask, cmin, cmax) = block_masks(rel_a, rel_b, base);
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
                    let xa = _mm256_sub_ps(_mm256_add_ps(cmin, half), x0);
                    let xb = _mm256_sub_ps(_mm256_add_ps(cmax, half), x0);
                    let m = min_like_f32(_mm256_mul_ps(ra, xa), _mm256_mul_ps(ra, xb));
                    max_like_f32(_mm256_add_ps(r_rows, m), r_far)
                } else {
                    r_far
                };
                merge_block(block, z0, cov, r, all);
            }
            rel_a = _mm256_sub_epi32(rel_a, _mm256_set1_epi32(32));
            rel_b = _mm256_sub_epi32(rel_b, _mm256_set1_epi32(32));
        }
    }
}

/// The edges of lane `l` broadcast, without branches: an edge that does not bound a side
/// contributes -inf to the left bound (+inf to the right one), which `max` / `min` ignore.
#[inline]
#[target_feature(enable = "avx2")]
fn edges8(t: &Setup8, l: usize) -> [Edge8; 3] {
    let edge = |i: usize| {
        (
            _mm256_set1_ps(t.ex0[i][l]),
            _mm256_set1_ps(t.ey0[i][l]),
            _mm256_set1_ps(t.slope[i][l]),
            _mm256_castsi256_ps(_mm256_set1_epi32(t.bound_l[i][l])),
            _mm256_castsi256_ps(_mm256_set1_epi32(t.bound_r[i][l])),
        )
    };
    [edge(0), edge(1), edge(2)]
}

/// The coverage masks of the 8 tiles of a block (one per lane) from the spans of the block
/// row's 8 scanlines (one per lane, columns `rel_a..rel_b` relative to the block, `rel_b`
/// exclusive; empty when `rel_a >= rel_b`), with the lowest and highest covered column of each
/// tile as `f32` (meaningless for a tile with nothing covered: its zero mask leaves it
/// unchanged); `base` is each tile's first column.
///
/// Hasselgren et al. 2016, section 4: a scanline's 32 pixels of coverage are two shifts of all
/// ones; a byte transpose then turns 8 scanlines of 4 tiles' bytes into 8 tile masks.
#[inline]
#[target_feature(enable = "avx2")]
fn block_masks(rel_a: __m256i, rel_b: __m256i, base: __m256) -> (__m256i, __m256, __m256) {
    let zero = _mm256_setzero_si256();
    let ones = _mm256_set1_epi32(-1);
    // `sllv` gives 0 for counts of 32 and more: spans past the block cover nothing, spans
    // before it (negative counts, clamped to 0) everything.
    let from_a = _mm256_sllv_epi32(ones, _mm256_max_epi32(rel_a, zero));
    let from_b = _mm256_sllv_epi32(ones, _mm256_max_epi32(rel_b, zero));
    let rows = _mm256_andnot_si256(from_b, from_a);
    // Lane `j` holds scanline `j`, byte `i` its pixels of tile column `i`; tile `(i, j / 4)`
    // wants byte `i` of scanlines `4 (j / 4) + k` as its byte `k`: a 4x4 byte transpose in each
    // 128-bit half (tile row 0 in the low half, row 1 in the high half).
    let transpose = _mm256_setr_epi8(
        0, 4, 8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15, //
        0, 4, 8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15,
    );
    let mask = _mm256_shuffle_epi8(rows, transpose);
    // The covered columns of each tile, a bit each, and the lowest and highest of them from
    // the exponent of their value as f32 (exact below 2^24).
    let cols = _mm256_or_si256(mask, _mm256_srli_epi32::<16>(mask));
    let cols = _mm256_or_si256(cols, _mm256_srli_epi32::<8>(cols));
    let cols = _mm256_and_si256(cols, _mm256_set1_epi32(0xFF));
    let lowest = _mm256_and_si256(cols, _mm256_sub_epi32(zero, cols));
    let log2 = |v: __m256i| {
        let e = _mm256_srli_epi32::<23>(_mm256_castps_si256(_mm256_cvtepi32_ps(v)));
        _mm256_cvtepi32_ps(_mm256_sub_epi32(e, _mm256_set1_epi32(127)))
    };
    let cmin = _mm256_add_ps(base, log2(lowest));
    let cmax = _mm256_add_ps(base, log2(cols));
    (mask, cmin, cmax)
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

/// `a.max(b)` of `f32` lane by lane, see [`min_like_f32`].
#[inline]
#[target_feature(enable = "avx2")]
fn max_like_f32(a: __m256, b: __m256) -> __m256 {
    _mm256_blendv_ps(_mm256_max_ps(a, b), a, _mm256_cmp_ps::<_CMP_UNORD_Q>(b, b))
}

#[cfg(test)]
mod tests {
    use super::super::tiles::{update_tile, CLEAR_BLOCK, CLEAR_TILE, FULL};
    use super::*;

    #[test]
    fn block_merge_equals_tile_update() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 on this CPU: the block merge cannot run");
            return;
        }
        let mut rng = sightline_core::random::SplitMix64::new(5);
        // Depths from a small set so that ties, equal layers and NaN all occur.
        let depths = [0.0, 0.1, 0.25, 0.5, 0.75, 1.0, f32::NAN];
        let masks = [0, 1, 0x0000_FFFF, 0xFFFF_0000, 0xF0F0_F0F0, FULL >> 1, FULL];
        let pick =
            |rng: &mut sightline_core::random::SplitMix64, n: usize| rng.below(n as u64) as usize;
        let mut changed = 0;
        for _ in 0..5_000 {
            let mut block = CLEAR_BLOCK;
            let mut want = CLEAR_BLOCK;
            let (mut cov, mut r) = ([0u32; 8], [0f32; 8]);
            for l in 0..8 {
                let mut tile = CLEAR_TILE;
                // A random history of merges gives reachable tile states.
                for _ in 0..pick(&mut rng, 4) {
                    let (m, z) = (masks[pick(&mut rng, 6) + 1], depths[pick(&mut rng, 6) + 1]);
                    update_tile(&mut tile, m, z);
                }
                (block.z0[l], block.z1[l], block.mask[l]) = (tile.z0, tile.z1, tile.mask);
                (cov[l], r[l]) = (masks[pick(&mut rng, 7)], depths[pick(&mut rng, 7)]);
                if cov[l] != 0 {
                    update_tile(&mut tile, cov[l], r[l]);
                }
                (want.z0[l], want.z1[l], want.mask[l]) = (tile.z0, tile.z1, tile.mask);
            }
            let before = block;
            // SAFETY: AVX2 support was checked above; unaligned loads of local arrays.
            unsafe {
                let c = _mm256_loadu_si256(cov.as_ptr().cast());
                let z = _mm256_loadu_ps(r.as_ptr());
                let z0 = _mm256_load_ps(block.z0.as_ptr());
                merge_block(&mut block, z0, c, z, _mm256_set1_epi32(-1));
            }
            let bits = |b: &Block| (b.z0.map(f32::to_bits), b.z1.map(f32::to_bits), b.mask);
            assert_eq!(bits(&block), bits(&want), "{before:?} + {cov:x?}, {r:?}");
            changed += usize::from(want != before);
        }
        assert!(changed > 2_500, "{changed}");
    }
}
