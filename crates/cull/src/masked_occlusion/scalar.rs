//! The scalar kernel of the masked occlusion buffer: portable Rust, one scanline and one pixel
//! row at a time, through the tile-at-a-time rasterizer (`per_tile.rs`). It is the reference
//! the SIMD kernels are compared with, and the kernel of CPUs other than x86_64.
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! section 3 (span ends per scanline, turned into a tile's coverage mask by shifts).

use glam::Vec3;

use super::constants::TILE_H;
use super::per_tile::{self, ColClamp, Edges, TileRowSpans, TileSteps, EMPTY_HI, EMPTY_LO};
use super::project::{ceil_i, floor_i, Projector};
use super::raster_kernel::RasterKernel;
use super::tiles::Tiles;

/// The scalar kernel.
pub(super) struct Scalar;

impl RasterKernel for Scalar {
    unsafe fn render(tiles: &mut Tiles, triangles: &[Vec3], proj: &Projector) {
        // SAFETY: portable code, no CPU feature needed.
        unsafe { per_tile::render::<Scalar>(tiles, triangles, proj) }
    }
}

impl TileSteps for Scalar {
    // The plain reference does not prefetch (the SIMD kernels do: there the tile loads' cache
    // misses dominate).
    const PREFETCH: bool = false;

    /// One scanline at a time.
    #[inline(always)]
    fn spans(e: &Edges, c: &ColClamp, ty: u32) -> TileRowSpans {
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

    /// Each row's span as a run of bits.
    #[inline(always)]
    unsafe fn mask(s: &TileRowSpans, base: i32) -> u32 {
        let mut mask = 0u32;
        for k in 0..TILE_H as usize {
            let lo = (s.a[k] - base).clamp(0, 8);
            let hi = (s.b[k] + 1 - base).clamp(0, 8);
            if hi > lo {
                mask |= ((1u32 << hi) - (1u32 << lo)) << (k as u32 * 8);
            }
        }
        mask
    }
}
