//! `city`: a street grid of boxy buildings on a ground plane — an urban canyon, the typical
//! scene of from-region visibility papers (Koch & Wimmer 2021 use city models). Z up, metres.
//!
//! Layout: `B x B` blocks of `LOTS x LOTS` lots separated by streets; every lot holds one
//! building (a box, and with some probability a narrower tower on top of it), heights drawn
//! from a heavy-tailed distribution so a few towers stick out. The ground is one quad per block
//! plus the streets around it. `B` is chosen so the triangle count is close to `size`.

use glam::Vec3;

use super::shapes::{add_box_on_floor, add_quad};
use crate::random::SplitMix64;
use crate::scene::builder::{SceneBuilder, TriangleSink};
use crate::scene::types::UpAxis;

const LOTS: usize = 4;
const LOT: f32 = 20.0;
const STREET: f32 = 12.0;
const BLOCK: f32 = LOTS as f32 * LOT;
const PITCH: f32 = BLOCK + STREET;
/// Expected triangles per block: ground quad + buildings of 10 triangles, 40% with a tower.
const TRIANGLES_PER_BLOCK: f64 = 2.0 + (LOTS * LOTS) as f64 * 14.0;

pub(super) fn generate(b: &mut SceneBuilder, seed: u64, size: usize) {
    let mut city = City::new(seed, size);
    city.begin(b);
    while city.next_block(b) {}
}

/// The `city` generator as an iterator over blocks, so a consumer can stream a city of any
/// size block by block (O(1) state: the random generator and the next block's index).
/// Generating every block into a [`SceneBuilder`] gives exactly `procedural:city?seed&size`.
#[derive(Clone, Debug)]
pub struct City {
    blocks: usize,
    rng: SplitMix64,
    next: usize,
}

impl City {
    /// Most triangles one block emits: its ground quad and every lot with a tower.
    pub const MAX_TRIANGLES_PER_BLOCK: usize = 2 + LOTS * LOTS * 20;
    /// Most vertices one block emits (4 per quad, 8 per box).
    pub const MAX_VERTICES_PER_BLOCK: usize = 4 + LOTS * LOTS * 16;

    /// The city of `procedural:city?seed={seed}&size={size}` (about `size` triangles).
    pub fn new(seed: u64, size: usize) -> Self {
        let blocks = ((size as f64 / TRIANGLES_PER_BLOCK).sqrt().round() as usize).max(1);
        Self {
            blocks,
            rng: SplitMix64::new(seed),
            next: 0,
        }
    }

    /// Blocks per side.
    pub fn blocks(&self) -> usize {
        self.blocks
    }

    /// Half the city's extent in x and y (it is centred on the origin), in metres.
    pub fn half_extent(&self) -> f32 {
        0.5 * self.blocks as f32 * PITCH
    }

    /// Scene-wide settings (the up axis); call once before the first block.
    pub fn begin<S: TriangleSink + ?Sized>(&self, sink: &mut S) {
        sink.set_up(UpAxis::Z);
    }

    /// Generates the next block (its ground tile, then its buildings) into `sink`; false, with
    /// nothing generated, once every block is done. Blocks go row by row.
    pub fn next_block<S: TriangleSink + ?Sized>(&mut self, sink: &mut S) -> bool {
        if self.next >= self.blocks * self.blocks {
            return false;
        }
        let (by, bx) = (self.next / self.blocks, self.next % self.blocks);
        self.next += 1;
        let origin = -0.5 * self.blocks as f32 * PITCH;
        let x0 = origin + bx as f32 * PITCH;
        let y0 = origin + by as f32 * PITCH;
        // Ground tile: the block and the street on its -x/-y side and, on the last
        // row/column, nothing more (the city ends at its last block).
        sink.begin_object(format_args!("ground{bx}_{by}"));
        let g0 = Vec3::new(x0 - STREET * 0.5, y0 - STREET * 0.5, 0.0);
        let g1 = Vec3::new(x0 + BLOCK + STREET * 0.5, y0 + BLOCK + STREET * 0.5, 0.0);
        add_quad(
            sink,
            g0,
            Vec3::new(g1.x, g0.y, 0.0),
            g1,
            Vec3::new(g0.x, g1.y, 0.0),
        );
        for ly in 0..LOTS {
            for lx in 0..LOTS {
                sink.begin_object(format_args!("building{bx}_{by}_{lx}_{ly}"));
                add_building(
                    sink,
                    &mut self.rng,
                    x0 + lx as f32 * LOT,
                    y0 + ly as f32 * LOT,
                );
            }
        }
        true
    }
}

fn add_building<S: TriangleSink + ?Sized>(b: &mut S, rng: &mut SplitMix64, x: f32, y: f32) {
    let inset = rng.range_f32(0.5, 3.0);
    // Heavy tail: most buildings 8-30 m, a few up to ~150 m.
    let u = rng.next_f32();
    let height = 8.0 + 22.0 * rng.next_f32() + 120.0 * u * u * u * u;
    let min = Vec3::new(x + inset, y + inset, 0.0);
    let max = Vec3::new(x + LOT - inset, y + LOT - inset, height);
    add_box_on_floor(b, min, max);
    if rng.next_f32() < 0.4 {
        let shrink = (max.x - min.x) * rng.range_f32(0.15, 0.35);
        let tower_height = height * rng.range_f32(0.2, 0.8);
        add_box_on_floor(
            b,
            Vec3::new(min.x + shrink, min.y + shrink, height),
            Vec3::new(max.x - shrink, max.y - shrink, height + tower_height),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_stay_within_their_bounds_and_sum_to_the_scene() {
        let mut city = City::new(4, 5_000);
        let mut total = 0;
        let mut blocks = 0;
        loop {
            let mut c = crate::scene::builder::CountingSink::default();
            if !city.next_block(&mut c) {
                break;
            }
            blocks += 1;
            assert!(c.triangles <= City::MAX_TRIANGLES_PER_BLOCK);
            assert!(c.vertices as usize <= City::MAX_VERTICES_PER_BLOCK);
            assert_eq!(c.objects, 1 + LOTS * LOTS);
            total += c.triangles;
        }
        assert_eq!(blocks, city.blocks() * city.blocks());
        let mut b = SceneBuilder::new("city");
        generate(&mut b, 4, 5_000);
        assert_eq!(b.finish().triangle_count(), total);
    }
}
