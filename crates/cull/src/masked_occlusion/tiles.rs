//! The storage of the masked occlusion buffer: 8x4-pixel tiles of two depth layers and a
//! coverage mask, kept in blocks of 4x2 tiles, and the merge of an occluder into a tile.
//!
//! Based on: Andersson, Hasselgren, Akenine-Möller. Masked Depth Culling for Graphics Hardware.
//! 2015, section 3 (the two-layer tile and its merge heuristic, [`update_tile`]); Hasselgren,
//! Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016, section 4 (the SIMD
//! layout: the fields of several tiles side by side, so that one register holds a field of
//! every tile of a block).

use super::block_storage::BlockStorage;
use super::constants::{TILE_H, TILE_W};

/// A full coverage mask: every pixel of a tile.
pub(super) const FULL: u32 = u32::MAX;

/// One 8x4 tile: reference layer, working layer and the working layer's coverage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Tile {
    /// Every pixel of the tile has `1/z >= z0` (0 = nothing drawn, infinitely far).
    pub z0: f32,
    /// Every pixel in `mask` has `1/z >= z1`; `z1 > z0` whenever `mask != 0`.
    pub z1: f32,
    /// Pixels of the working layer, bit `8 * row + column`.
    pub mask: u32,
}

#[cfg(test)]
pub(super) const CLEAR_TILE: Tile = Tile {
    z0: 0.0,
    z1: 0.0,
    mask: 0,
};

/// Tiles per block, across and down.
pub(super) const BLOCK_TX: u32 = 4;
pub(super) const BLOCK_TY: u32 = 2;

/// The storage of 4x2 tiles (32x8 pixels), one array per field with tile `4 * row + column`
/// in element `i`: the AVX2 kernel loads, merges and stores the 8 tiles of a block as three
/// 8-lane registers (the layout of Hasselgren et al. 2016, section 4).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Block {
    pub z0: [f32; 8],
    pub z1: [f32; 8],
    pub mask: [u32; 8],
}

pub(super) const CLEAR_BLOCK: Block = Block {
    z0: [0.0; 8],
    z1: [0.0; 8],
    mask: [0; 8],
};

/// The tiles of a `width x height` buffer and the geometry of their grid.
#[derive(Clone, Debug)]
pub(super) struct Tiles {
    pub width: u32,
    pub height: u32,
    pub tiles_x: u32,
    pub tiles_y: u32,
    /// Blocks across (`tiles_x / 4` rounded up); tiles beyond the image in the last block
    /// column / row are never drawn, nor is the spare block row after the last.
    pub blocks_x: u32,
    /// Mask bits of the last tile column / row that lie outside the image: they count as
    /// covered by every occluder, so that edge tiles can become full.
    pub outside_x: u32,
    pub outside_y: u32,
    pub blocks: BlockStorage<Block>,
}

impl Tiles {
    /// Cleared tiles for `width x height` pixels (both at least 1).
    pub fn new(width: u32, height: u32) -> Self {
        let tiles_x = width.div_ceil(TILE_W);
        let tiles_y = height.div_ceil(TILE_H);
        let cols_in = width - (tiles_x - 1) * TILE_W;
        let rows_in = height - (tiles_y - 1) * TILE_H;
        let row_bits = ((1u32 << TILE_W) - 1) ^ ((1u32 << cols_in) - 1);
        let outside_x = row_bits.wrapping_mul(0x0101_0101);
        let outside_y = !(((1u64 << (TILE_W * rows_in)) - 1) as u32);
        Self {
            width,
            height,
            tiles_x,
            tiles_y,
            blocks_x: tiles_x.div_ceil(BLOCK_TX),
            outside_x,
            outside_y,
            // One block row more than the image needs: the AVX-512 kernel draws block rows
            // in pairs, and a pair that starts at the last row loads and stores the spare
            // row below it unchanged (`avx2/pairs.rs`) instead of masking it off.
            blocks: BlockStorage::new(
                (tiles_x.div_ceil(BLOCK_TX) * (tiles_y.div_ceil(BLOCK_TY) + 1)) as usize,
                CLEAR_BLOCK,
            ),
        }
    }

    /// Forgets every occluder.
    pub fn clear(&mut self) {
        self.blocks.fill(CLEAR_BLOCK);
    }

    /// True when both have the same size and identical tiles (masks and depths).
    pub fn same_contents(&self, other: &Self) -> bool {
        self.width == other.width
            && self.height == other.height
            && self.blocks[..] == other.blocks[..]
    }

    /// Block index and lane of tile `(tx, ty)`.
    #[inline(always)]
    pub fn slot(&self, tx: u32, ty: u32) -> (usize, usize) {
        let block = (ty / BLOCK_TY) * self.blocks_x + tx / BLOCK_TX;
        let lane = (ty % BLOCK_TY) * BLOCK_TX + tx % BLOCK_TX;
        (block as usize, lane as usize)
    }

    /// Tile `(tx, ty)` (inside the buffer).
    #[inline(always)]
    pub fn tile(&self, tx: u32, ty: u32) -> Tile {
        let (b, l) = self.slot(tx, ty);
        let b = &self.blocks[b];
        Tile {
            z0: b.z0[l],
            z1: b.z1[l],
            mask: b.mask[l],
        }
    }

    /// Merges coverage `cov` at `1/z` value `r` into tile `(tx, ty)` with [`update_tile`].
    #[inline(always)]
    pub fn update(&mut self, tx: u32, ty: u32, cov: u32, r: f32) {
        let (b, l) = self.slot(tx, ty);
        let b = &mut self.blocks[b];
        let mut t = Tile {
            z0: b.z0[l],
            z1: b.z1[l],
            mask: b.mask[l],
        };
        update_tile(&mut t, cov, r);
        (b.z0[l], b.z1[l], b.mask[l]) = (t.z0, t.z1, t.mask);
    }

    /// Prefetches the first tile of each tile row a screen triangle's bounding box touches:
    /// with scattered triangles the tile loads miss the cache and dominate otherwise.
    #[inline(always)]
    pub fn prefetch_triangle(&self, p: &[[f32; 3]; 3]) {
        let ymin = p[0][1].min(p[1][1]).min(p[2][1]);
        let ymax = p[0][1].max(p[1][1]).max(p[2][1]);
        let xmin = p[0][0].min(p[1][0]).min(p[2][0]);
        // Saturating float-to-int casts, clamped into the buffer: only valid tiles.
        let clamp_x = |v: f32| (v as i32).clamp(0, self.width as i32 - 1) as u32;
        let clamp_y = |v: f32| (v as i32).clamp(0, self.height as i32 - 1) as u32;
        let ty0 = clamp_y(ymin) / TILE_H;
        self.prefetch_block_rows(clamp_x(xmin) / TILE_W, ty0, clamp_y(ymax) / TILE_H);
    }

    /// Prefetches the blocks holding tile column `tx` of tile rows `ty0..=ty1`, at most the
    /// first four rows (two blocks).
    #[inline(always)]
    pub fn prefetch_block_rows(&self, tx: u32, ty0: u32, ty1: u32) {
        for by in ty0 / BLOCK_TY..=ty1.min(ty0 + 3) / BLOCK_TY {
            if let Some(block) = self.blocks.get(self.slot(tx, by * BLOCK_TY).0) {
                sightline_core::prefetch::prefetch(block);
            }
        }
    }
}

/// Merges an occluder's coverage `cov` at conservative `1/z` value `r` into a tile.
///
/// Andersson et al. 2015, section 3: when the new triangle is much nearer than the working
/// layer (farther from it than the working layer is from the reference layer), the working
/// layer is dropped and restarted from the triangle, otherwise the triangle joins it at the
/// farther of the two depths. A full working mask becomes the new reference layer. This is
/// also the "quick mask" update of Hasselgren et al. 2016, section 3 (Intel's MOC builds it
/// by default, `QUICK_MASK 1`).
///
/// A triangle that covers the whole tile drops the working layer too (as MOC does): every
/// pixel then lies at `r` or nearer, so the tile's reference layer becomes `r` itself, where
/// joining would make it the farther of `r` and the working layer's depth.
///
/// While the reference layer is still clear (`z0 = 0`: nothing known), the working layer is
/// never dropped for a triangle that leaves a pixel of the tile uncovered (one that covers
/// them all forgets nothing): dropping it would forget the pixels it covers, with no
/// reference layer to fall back to, and with `z0 = 0` the distance test drops it whenever the
/// new triangle is twice as near (in `1/z`), which on scattered small occluders lost a quarter
/// of the covered pixels. (Masked Software Occlusion Culling, 2016, gets the same effect by
/// clearing its reference layer to a value beyond infinity.)
#[inline(always)]
pub(super) fn update_tile(tile: &mut Tile, cov: u32, r: f32) {
    if r.is_nan() || r <= tile.z0 {
        // Nothing nearer than what every pixel already has.
        return;
    }
    if tile.mask == 0 || cov == FULL || (tile.z0 > 0.0 && r - tile.z1 > tile.z1 - tile.z0) {
        tile.z1 = r;
        tile.mask = cov;
    } else {
        tile.z1 = tile.z1.min(r);
        tile.mask |= cov;
    }
    if tile.mask == FULL {
        tile.z0 = tile.z1;
        tile.z1 = 0.0;
        tile.mask = 0;
    }
}

/// Random tile states and merges for the kernels' tests.
#[cfg(test)]
pub(super) mod test_states {
    use super::{update_tile, Tile, CLEAR_TILE, FULL};
    use sightline_core::random::SplitMix64;

    /// Depths from a small set so that ties, equal layers and NaN all occur.
    const DEPTHS: [f32; 7] = [0.0, 0.1, 0.25, 0.5, 0.75, 1.0, f32::NAN];
    const MASKS: [u32; 7] = [0, 1, 0x0000_FFFF, 0xFFFF_0000, 0xF0F0_F0F0, FULL >> 1, FULL];

    fn pick(rng: &mut SplitMix64, n: usize) -> usize {
        rng.below(n as u64) as usize
    }

    /// A tile after a random history of up to three merges: a state the buffer can reach.
    pub(crate) fn reachable_tile(rng: &mut SplitMix64) -> Tile {
        let mut tile = CLEAR_TILE;
        for _ in 0..pick(rng, 4) {
            let (m, z) = (MASKS[pick(rng, 6) + 1], DEPTHS[pick(rng, 6) + 1]);
            update_tile(&mut tile, m, z);
        }
        tile
    }

    /// A random coverage (possibly empty or full) and depth (possibly NaN) to merge.
    pub(crate) fn random_merge(rng: &mut SplitMix64) -> (u32, f32) {
        (MASKS[pick(rng, 7)], DEPTHS[pick(rng, 7)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tile_update_keeps_farther_depth_of_merged_layer() {
        let mut t = CLEAR_TILE;
        update_tile(&mut t, 0x0000_FFFF, 0.5);
        update_tile(&mut t, 0xFFFF_0000, 0.4);
        // Full: the reference layer is the farther of the two.
        assert_eq!(t.mask, 0);
        assert_eq!(t.z0, 0.4);
    }

    #[test]
    fn tile_update_discards_far_working_layer_for_near_triangle() {
        let mut t = CLEAR_TILE;
        // A reference layer first.
        update_tile(&mut t, FULL, 0.05);
        assert_eq!((t.z0, t.mask), (0.05, 0));
        update_tile(&mut t, 0x0000_00FF, 0.1);
        update_tile(&mut t, 0x0000_FF00, 0.9);
        assert_eq!((t.mask, t.z1), (0x0000_FF00, 0.9));
    }

    #[test]
    fn tile_update_takes_a_whole_tile_triangle_as_reference_layer() {
        let mut t = CLEAR_TILE;
        update_tile(&mut t, FULL, 0.05);
        // A far working layer over half the tile, then a nearer triangle over all of it, not
        // much nearer: joining would make the reference layer the working layer's 0.1.
        update_tile(&mut t, 0x0000_FFFF, 0.1);
        update_tile(&mut t, FULL, 0.12);
        assert_eq!((t.z0, t.z1, t.mask), (0.12, 0.0, 0));
        // A partial triangle at that depth still joins (the reference layer stays).
        update_tile(&mut t, 0x0000_FFFF, 0.2);
        update_tile(&mut t, 0xFFFF_0000, 0.15);
        assert_eq!((t.z0, t.mask), (0.15, 0));
    }

    #[test]
    fn tile_update_keeps_working_layer_while_reference_layer_is_clear() {
        let mut t = CLEAR_TILE;
        update_tile(&mut t, 0x0000_00FF, 0.1);
        // Much nearer, but with nothing behind the working layer it is merged, not dropped.
        update_tile(&mut t, 0x0000_FF00, 0.9);
        assert_eq!((t.mask, t.z1, t.z0), (0x0000_FFFF, 0.1, 0.0));
    }
}
