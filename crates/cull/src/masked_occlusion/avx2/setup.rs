//! The AVX2 kernel's triangle setup, 8 triangles at once (one per lane): area and
//! orientation, bounding box, the `1/z` plane and the edges ([`setup8`]), from the screen
//! corners that `mod.rs` projects ([`Screen8`]) into a [`Setup8`] that `blocks.rs` draws from.
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! section 4 (triangle setup in SIMD lanes). Same `f32` operations as `per_tile.rs` does for
//! one triangle, lane by lane.

use std::arch::x86_64::*;

use super::super::constants::TILE_W;

/// Screen-space corners `[sx, sy, 1/z]` of up to 8 triangles, one per lane: `x[corner][lane]`.
#[repr(C, align(32))]
#[derive(Default)]
pub(super) struct Screen8 {
    pub(super) x: [[f32; 8]; 3],
    pub(super) y: [[f32; 8]; 3],
    pub(super) r: [[f32; 8]; 3],
}

/// The setup of up to 8 triangles, one per lane, as [`setup8`] computes it: what the per-tile
/// path computes in `per_tile.rs` (after the swap to counter-clockwise order).
#[repr(C, align(32))]
#[derive(Default)]
pub(super) struct Setup8 {
    /// `1/z = r0 + ra (x - x0) + rb (y - y0)` (`ra = rb = 0` unless `plane_ok`).
    pub(super) x0: [f32; 8],
    pub(super) y0: [f32; 8],
    pub(super) r0: [f32; 8],
    pub(super) ra: [f32; 8],
    pub(super) rb: [f32; 8],
    /// The farthest corner's `1/z`, a lower bound in every case.
    pub(super) r_far: [f32; 8],
    /// The nearest corner's `1/z`, an upper bound of every tile's depth.
    pub(super) r_near: [f32; 8],
    /// -1 when the plane is well conditioned (area of a pixel at least).
    pub(super) plane_ok: [i32; 8],
    /// The edges by role (see [`store_edges`]): `role` 0 bounds spans from the left, 1 from the
    /// right, 2 is the third edge; edge `x = ex0 + (y - ey0) * slope`.
    pub(super) ex0: [[f32; 8]; 3],
    pub(super) ey0: [[f32; 8]; 3],
    pub(super) slope: [[f32; 8]; 3],
    /// What the third edge adds to the left and right bounds (see [`store_edges`]).
    pub(super) third_bias_l: [f32; 8],
    pub(super) third_bias_r: [f32; 8],
    /// `per_tile::tile_column_offsets`: from a tile's first column to its farthest and nearest
    /// pixel centres, minus `x0`.
    pub(super) far_col: [f32; 8],
    pub(super) near_col: [f32; 8],
    /// Span clamps, see `per_tile::ColClamp`.
    pub(super) a_lo: [f32; 8],
    pub(super) a_hi: [f32; 8],
    pub(super) b_lo: [f32; 8],
    pub(super) b_hi: [f32; 8],
    /// Pixel rows and columns of the bounding box, clamped to the buffer.
    pub(super) row0: [i32; 8],
    pub(super) row1: [i32; 8],
    pub(super) col0: [i32; 8],
    pub(super) col1: [i32; 8],
}

/// Triangle setup of 8 triangles at once (Hasselgren et al. 2016, section 4: setup in SIMD
/// lanes): the same `f32` and integer operations as `per_tile.rs` does for one, lane by lane:
/// area and orientation (clockwise triangles get corners 1 and 2 swapped), bounding box in
/// pixel centres clamped to the `width x height` buffer ([`bbox8`]), the `1/z` plane and the
/// edges. Returns a bit per lane that has something to draw (non-degenerate area, bounding box
/// inside the buffer); other lanes of `out` hold garbage.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn setup8(s: &Screen8, width: u32, height: u32, out: &mut Setup8) -> u32 {
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
    st(&mut out.r_near, _mm256_max_ps(_mm256_max_ps(r0, r1), r2));
    sti(&mut out.plane_ok, _mm256_castps_si256(plane_ok));
    store_edges(out, [x0, x1, x2], [y0, y1, y2]);
    // `per_tile::tile_column_offsets` of the stored (masked) `ra`, lane by lane.
    let ra_neg = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_and_ps(ra, plane_ok), zero);
    let first = _mm256_sub_ps(_mm256_set1_ps(0.5), x0);
    let last = _mm256_sub_ps(_mm256_set1_ps((TILE_W - 1) as f32 + 0.5), x0);
    st(&mut out.far_col, _mm256_blendv_ps(first, last, ra_neg));
    st(&mut out.near_col, _mm256_blendv_ps(last, first, ra_neg));
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

/// The edges of 8 counter-clockwise triangles into `out`, by role, chosen per lane by selects
/// (edge roles). Edges a -> b with the interior on the left (y down): going up (dy < 0)
/// bounds spans from the left, going down from the right; horizontal edges bound nothing.
/// Every triangle with an area has an edge bounding its spans from the left (the first that
/// goes up) and one from the right (the first that goes down); the third bounds either side,
/// or neither when it is horizontal. The span loops evaluate the three edges in this order
/// and add `third_bias_l` / `third_bias_r` (0 where the third edge bounds that side, -inf /
/// +inf where it does not) to the third before the `max` / `min`, which replaces a select
/// per edge with one add (Hasselgren et al. 2016 sort the edges in their setup for the same
/// reason).
///
/// Bit-exactness: the left bound is `max(third + bias, max(left, -inf))`, the maximum of the
/// edges that bound the left side that are not NaN (an edge's `x` is NaN for a horizontal
/// edge, or a near-horizontal one whose slope overflowed), which is what the per-tile kernels
/// compute in edge order: `max` of values that are not NaN does not depend on the order, and
/// `maxps` returns its second operand when either is NaN. The same for the right bound.
#[inline]
#[target_feature(enable = "avx2")]
fn store_edges(out: &mut Setup8, xs: [__m256; 3], ys: [__m256; 3]) {
    // SAFETY: aligned stores into 32-byte arrays of the `#[repr(C, align(32))]` setup.
    let st = |a: &mut [f32; 8], v: __m256| unsafe { _mm256_store_ps(a.as_mut_ptr(), v) };
    let zero = _mm256_setzero_ps();
    let mut x = [zero; 3];
    let mut y = [zero; 3];
    let mut slope = [zero; 3];
    let mut up = [zero; 3];
    let mut down = [zero; 3];
    for i in 0..3 {
        let j = (i + 1) % 3;
        let dy = _mm256_sub_ps(ys[j], ys[i]);
        (x[i], y[i]) = (xs[i], ys[i]);
        slope[i] = _mm256_div_ps(_mm256_sub_ps(xs[j], xs[i]), dy);
        up[i] = _mm256_cmp_ps::<_CMP_LT_OQ>(dy, zero);
        down[i] = _mm256_cmp_ps::<_CMP_GT_OQ>(dy, zero);
    }
    // `pick(first, second)`: edge 0 where `first`, else edge 1 where `second`, else edge 2.
    let pick = |v: &[__m256; 3], first: __m256, second: __m256| {
        _mm256_blendv_ps(_mm256_blendv_ps(v[2], v[1], second), v[0], first)
    };
    let left0 = up[0];
    let left1 = _mm256_andnot_ps(up[0], up[1]);
    let right0 = down[0];
    let right1 = _mm256_andnot_ps(down[0], down[1]);
    // The third edge: the one neither role took.
    let third0 = _mm256_andnot_ps(
        _mm256_or_ps(left0, right0),
        _mm256_castsi256_ps(_mm256_set1_epi32(-1)),
    );
    let third1 = _mm256_andnot_ps(
        _mm256_or_ps(_mm256_or_ps(left1, right1), third0),
        _mm256_castsi256_ps(_mm256_set1_epi32(-1)),
    );
    for (role, (first, second)) in [(left0, left1), (right0, right1), (third0, third1)]
        .into_iter()
        .enumerate()
    {
        st(&mut out.ex0[role], pick(&x, first, second));
        st(&mut out.ey0[role], pick(&y, first, second));
        st(&mut out.slope[role], pick(&slope, first, second));
    }
    let third_up = pick(&up, third0, third1);
    let third_down = pick(&down, third0, third1);
    st(
        &mut out.third_bias_l,
        _mm256_andnot_ps(third_up, _mm256_set1_ps(f32::NEG_INFINITY)),
    );
    st(
        &mut out.third_bias_r,
        _mm256_andnot_ps(third_down, _mm256_set1_ps(f32::INFINITY)),
    );
}
