//! The tile-at-a-time rasterizer of the masked occlusion buffer, shared by the scalar, SSE2
//! and per-tile AVX2 kernels: one triangle set up at a time, then for each tile row the spans
//! of its 4 scanlines, and for each tile of the row its coverage mask, its conservative depth
//! and the merge into the tile. The kernels differ only in how they compute the spans and the
//! masks ([`TileSteps`]).
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! sections 3-4: the edges of a triangle are evaluated for all scanlines of a tile row at once,
//! and a tile's 32-bit coverage mask is built from the span ends of its scanlines instead of
//! per-pixel tests; the depth of a tile is the `1/z` plane's farthest value over the tile's
//! pixel centres, which for an affine function is at a corner of it (the paper's per-tile
//! depth at the farthest corner, stepped from tile to tile), but never farther than the
//! triangle's farthest corner.
//!
//! Bit-exactness: every kernel evaluates the same `f32` expressions in the same order (Rust
//! does not contract `a * b + c` into an FMA) and rounds them with the same integer rules, so
//! the buffers they produce are identical (checked by the tests).

use glam::Vec3;

use super::constants::{TILE_H, TILE_W};
use super::project::{ceil_i, floor_i, Projector, ViewTriangle};
use super::tiles::Tiles;

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

/// An empty span: its start beyond and its end before every column.
pub(super) const EMPTY_LO: i32 = 1 << 28;
pub(super) const EMPTY_HI: i32 = -(1 << 28);

/// The inclusive pixel spans `[a, b]` of the 4 scanlines of one tile row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct TileRowSpans {
    pub a: [i32; 4],
    pub b: [i32; 4],
}

impl TileRowSpans {
    /// The first and last column of any span (`first > last` when every span is empty).
    #[inline(always)]
    pub fn extent(&self) -> (i32, i32) {
        let lo = self.a[0].min(self.a[1]).min(self.a[2].min(self.a[3]));
        let hi = self.b[0].max(self.b[1]).max(self.b[2].max(self.b[3]));
        (lo, hi)
    }
}

/// The steps in which the tile-at-a-time kernels differ.
pub(super) trait TileSteps {
    /// Whether to run one triangle behind the projection and prefetch the next triangle's
    /// tiles while drawing the current one (with scattered triangles the tile loads miss the
    /// cache and dominate otherwise; the order of rasterization is unchanged).
    const PREFETCH: bool;

    /// The spans of the 4 scanlines of tile row `ty` (rows outside the triangle hold an empty
    /// span).
    fn spans(e: &Edges, c: &ColClamp, ty: u32) -> TileRowSpans;

    /// The coverage mask of the tile starting at column `base` (bit `8 * row + column`).
    ///
    /// # Safety
    /// The CPU must support the kernel's instructions.
    unsafe fn mask(s: &TileRowSpans, base: i32) -> u32;
}

/// The `1/z` plane of a triangle over the screen, as the tile loop reads it:
/// `1/z = r0 + ra (x - x0) + rb (y - y0)` (`x0` only through `far_col`).
#[derive(Clone, Copy)]
struct DepthPlane {
    y0: f32,
    r0: f32,
    /// Zero for slivers.
    ra: f32,
    rb: f32,
    /// The farthest corner's `1/z`, a lower bound in every case.
    r_far: f32,
    /// The nearest corner's `1/z`: no tile's depth is nearer (see [`tile_depth`]).
    r_near: f32,
    /// The offset from a tile's first column to its farthest pixel centres, minus `x0` (see
    /// [`tile_column_offsets`]).
    far_col: f32,
    /// True when the plane is well conditioned (area of a pixel at least); otherwise only
    /// `r_far` is used.
    ok: bool,
}

/// Where along a tile row the plane `r0 + ra (x - x0) + ...` is farthest and nearest: the
/// offsets `(far, near)` such that, for a tile whose first column is `base`,
/// `ra * (base + far)` is the plane's `x` term at the tile's farthest pixel centres (its
/// minimum over the tile's 8 columns) and `ra * (base + near)` at the nearest ones (its
/// maximum). Every kernel computes a tile's depth as `r_rows + ra * (base + far)` and the
/// coarse cull's upper bound with `near`, in these `f32` operations, so they agree bit for bit;
/// and since rounding is monotonic the bound is never below the depth.
#[inline(always)]
pub(super) fn tile_column_offsets(ra: f32, x0: f32) -> (f32, f32) {
    let (first, last) = (0.5, (TILE_W - 1) as f32 + 0.5);
    if ra < 0.0 {
        (last - x0, first - x0)
    } else {
        (first - x0, last - x0)
    }
}

/// The depth a triangle gives a tile whose first column is `base` (`r_rows`: the plane's
/// `y` part, its minimum over the tile row): the plane's farthest value over the tile (see
/// [`tile_column_offsets`]), never farther than the farthest corner and never nearer than the
/// nearest one. The exact plane never leaves that range where the triangle covers a pixel;
/// the clamp to the nearest corner keeps its `f32` rounding from doing so either, so that a
/// triangle whose nearest corner lies behind every tile of its bounding box changes nothing,
/// which is what lets the block kernels test a block against the nearest corner alone.
#[inline(always)]
fn tile_depth(plane: &DepthPlane, r_rows: f32, base: i32) -> f32 {
    if plane.ok {
        (r_rows + plane.ra * (base as f32 + plane.far_col))
            .max(plane.r_far)
            .min(plane.r_near)
    } else {
        plane.r_far
    }
}

/// The occluder loop of the tile-at-a-time kernels (see [`RasterKernel::render`]): view
/// transform, culling, clipping, then [`raster_triangle`] per screen triangle.
///
/// # Safety
/// The CPU must support `T`'s instructions.
///
/// [`RasterKernel::render`]: super::raster_kernel::RasterKernel::render
#[inline(always)]
pub(super) unsafe fn render<T: TileSteps>(tiles: &mut Tiles, triangles: &[Vec3], proj: &Projector) {
    let mut queued: Option<[[f32; 3]; 3]> = None;
    for t in triangles.chunks_exact(3) {
        match proj.triangle(t) {
            ViewTriangle::NotFinite | ViewTriangle::Behind => {}
            ViewTriangle::Inside(s) => {
                if !T::PREFETCH {
                    // SAFETY: the CPU supports `T` (this function's contract).
                    unsafe { raster_triangle::<T>(tiles, s) };
                    continue;
                }
                tiles.prefetch_triangle(&s);
                if let Some(q) = queued.replace(s) {
                    // SAFETY: as above.
                    unsafe { raster_triangle::<T>(tiles, q) };
                }
            }
            ViewTriangle::Clip(v) if proj.beside_view(&v) => {}
            ViewTriangle::Clip(v) => {
                if let Some(q) = queued.take() {
                    // SAFETY: as above.
                    unsafe { raster_triangle::<T>(tiles, q) };
                }
                // SAFETY: as above.
                unsafe { raster_clipped::<T>(tiles, v, proj) };
            }
        }
    }
    if let Some(q) = queued {
        // SAFETY: as above.
        unsafe { raster_triangle::<T>(tiles, q) };
    }
}

/// Clips a view-space triangle to the near plane and the guard band, then draws its fan.
///
/// # Safety
/// The CPU must support `T`'s instructions.
unsafe fn raster_clipped<T: TileSteps>(tiles: &mut Tiles, v: [Vec3; 3], proj: &Projector) {
    proj.clipped_fan(v, |s| {
        // SAFETY: the CPU supports `T` (this function's contract).
        unsafe { raster_triangle::<T>(tiles, s) };
        false
    });
}

/// Rasterizes one triangle given as `[sx, sy, 1/z]` per corner, all inside the guard band:
/// area and orientation (clockwise triangles get corners 1 and 2 swapped), bounding box in
/// pixel centres clamped to the buffer, the `1/z` plane and the edges, then the tile rows.
///
/// # Safety
/// The CPU must support `T`'s instructions.
#[inline(always)]
pub(super) unsafe fn raster_triangle<T: TileSteps>(tiles: &mut Tiles, mut p: [[f32; 3]; 3]) {
    let area =
        (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
    if area == 0.0 || area.is_nan() {
        return;
    }
    if area < 0.0 {
        p.swap(1, 2);
    }
    let area = area.abs();
    let ymin = p[0][1].min(p[1][1]).min(p[2][1]);
    let ymax = p[0][1].max(p[1][1]).max(p[2][1]);
    let xmin = p[0][0].min(p[1][0]).min(p[2][0]);
    let xmax = p[0][0].max(p[1][0]).max(p[2][0]);
    // Pixel centres inside [min, max]: first = ceil(min - 0.5), last = floor(max - 0.5).
    let row0 = ceil_i(ymin - 0.5).max(0);
    let row1 = floor_i(ymax - 0.5).min(tiles.height as i32 - 1);
    let col0 = ceil_i(xmin - 0.5).max(0);
    let col1 = floor_i(xmax - 0.5).min(tiles.width as i32 - 1);
    if row0 > row1 || col0 > col1 {
        return;
    }

    // 1/z over the screen: r = r0 + ra (x - x0) + rb (y - y0). For slivers (less than a
    // pixel of area) the gradient is ill-conditioned: use the farthest corner only.
    let r_far = p[0][2].min(p[1][2]).min(p[2][2]);
    let r_near = p[0][2].max(p[1][2]).max(p[2][2]);
    let (ra, rb) = if area >= 1.0 {
        let (d1x, d1y, d1r) = (p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]);
        let (d2x, d2y, d2r) = (p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]);
        (
            (d1r * d2y - d2r * d1y) / area,
            (d2r * d1x - d1r * d2x) / area,
        )
    } else {
        (0.0, 0.0)
    };
    let plane = DepthPlane {
        y0: p[0][1],
        r0: p[0][2],
        ra,
        rb,
        r_far,
        r_near,
        far_col: tile_column_offsets(ra, p[0][0]).0,
        ok: area >= 1.0,
    };

    // Edges a -> b with the interior on the left of (b - a) in y-down screen space: an edge
    // going up (dy < 0) bounds the span from the left, one going down from the right.
    let mut x0 = [0.0f32; 3];
    let mut y0 = [0.0f32; 3];
    let mut slope = [0.0f32; 3];
    let mut left = [false; 3];
    let mut used = [false; 3];
    for i in 0..3 {
        let (a, b) = (p[i], p[(i + 1) % 3]);
        let dy = b[1] - a[1];
        if dy != 0.0 {
            used[i] = true;
            x0[i] = a[0];
            y0[i] = a[1];
            slope[i] = (b[0] - a[0]) / dy;
            left[i] = dy < 0.0;
        }
    }
    // Built in arrays of their own, then moved: written field by field into `Edges` they cost
    // 2 % more instructions in the SSE2 kernel.
    let edges = Edges {
        x0,
        y0,
        slope,
        left,
        used,
    };
    let clamp = ColClamp {
        a_lo: col0 as f32,
        a_hi: (col1 + 1) as f32,
        b_lo: (col0 - 1) as f32,
        b_hi: col1 as f32,
        row0,
        row1,
    };
    for ty in row0 as u32 / TILE_H..=row1 as u32 / TILE_H {
        // SAFETY: the CPU supports `T` (this function's contract).
        unsafe { raster_tile_row::<T>(tiles, plane, &edges, &clamp, ty) };
    }
}

/// The tiles of tile row `ty` that the triangle covers: mask, depth, merge.
///
/// # Safety
/// The CPU must support `T`'s instructions.
#[inline(always)]
unsafe fn raster_tile_row<T: TileSteps>(
    tiles: &mut Tiles,
    plane: DepthPlane,
    edges: &Edges,
    clamp: &ColClamp,
    ty: u32,
) {
    // Spans of the up to four rows of this tile row, in pixels, inclusive; rows outside the
    // triangle hold an empty span.
    let spans = T::spans(edges, clamp, ty);
    let (lo_all, hi_all) = spans.extent();
    if lo_all > hi_all {
        return;
    }
    let ya = (ty * TILE_H) as f32 + 0.5;
    let yb = ya + (TILE_H - 1) as f32;
    let r_rows = plane.r0 + (plane.rb * (ya - plane.y0)).min(plane.rb * (yb - plane.y0));
    let tx_first = lo_all as u32 / TILE_W;
    let tx_last = hi_all as u32 / TILE_W;
    for tx in tx_first..=tx_last {
        let base = (tx * TILE_W) as i32;
        // SAFETY: the CPU supports `T` (this function's contract).
        let mut mask = unsafe { T::mask(&spans, base) };
        if mask == 0 {
            continue;
        }
        if tx == tiles.tiles_x - 1 {
            mask |= tiles.outside_x;
        }
        if ty == tiles.tiles_y - 1 {
            mask |= tiles.outside_y;
        }
        tiles.update(tx, ty, mask, tile_depth(&plane, r_rows, base));
    }
}
