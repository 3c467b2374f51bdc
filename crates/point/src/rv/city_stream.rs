//! A streaming `city` generator: the street grid of boxy buildings of
//! `sightline_core::scene::procedural` (`procedural:city?seed=S&size=N`), produced triangle by
//! triangle so a city of any size streams through RV without ever being in memory.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 2 (the input is a stream whose size is not known to the visibility stage).
//!
//! It replays the core generator's random sequence and emission order exactly, so triangle `i`
//! here is triangle `i` of the materialised scene (a test checks this): small cities can be
//! checked against the reference rasterizer, large ones streamed in a few kilobytes.

use glam::Vec3;
use sightline_core::random::SplitMix64;

use super::source::{SourceTriangle, TriangleSource};
use super::RvError;

const LOTS: usize = 4;
const LOT: f32 = 20.0;
const STREET: f32 = 12.0;
const BLOCK: f32 = LOTS as f32 * LOT;
const PITCH: f32 = BLOCK + STREET;
/// Expected triangles per block, as in the core generator (it picks the block count from it).
const TRIANGLES_PER_BLOCK: f64 = 2.0 + (LOTS * LOTS) as f64 * 14.0;
/// Most triangles one block can emit: ground quad + every lot with a tower.
const MAX_TRIANGLES_PER_BLOCK: usize = 2 + LOTS * LOTS * 20;

/// The streaming city (see the module documentation). Holds O(1) state: the random generator,
/// the next block and the few triangles of the current lot not yet handed out.
#[derive(Clone, Debug)]
pub struct StreamingCity {
    blocks: usize,
    rng: SplitMix64,
    next_block: usize,
    next_id: u32,
    pending: Vec<[Vec3; 3]>,
    pending_at: usize,
}

impl StreamingCity {
    /// The city of `procedural:city?seed={seed}&size={size}` (about `size` triangles).
    pub fn new(seed: u64, size: usize) -> Self {
        let blocks = ((size as f64 / TRIANGLES_PER_BLOCK).sqrt().round() as usize).max(1);
        Self {
            blocks,
            rng: SplitMix64::new(seed),
            next_block: 0,
            next_id: 0,
            pending: Vec::with_capacity(MAX_TRIANGLES_PER_BLOCK),
            pending_at: 0,
        }
    }

    /// Blocks per side.
    pub fn blocks(&self) -> usize {
        self.blocks
    }

    /// The city's extent in x and y (centred on the origin), in metres.
    pub fn half_extent(&self) -> f32 {
        0.5 * self.blocks as f32 * PITCH
    }

    /// Generates the next block into `pending`.
    fn generate_block(&mut self) {
        self.pending.clear();
        self.pending_at = 0;
        let (by, bx) = (self.next_block / self.blocks, self.next_block % self.blocks);
        self.next_block += 1;
        let origin = -0.5 * self.blocks as f32 * PITCH;
        let x0 = origin + bx as f32 * PITCH;
        let y0 = origin + by as f32 * PITCH;
        let g0 = Vec3::new(x0 - STREET * 0.5, y0 - STREET * 0.5, 0.0);
        let g1 = Vec3::new(x0 + BLOCK + STREET * 0.5, y0 + BLOCK + STREET * 0.5, 0.0);
        let q = [
            g0,
            Vec3::new(g1.x, g0.y, 0.0),
            g1,
            Vec3::new(g0.x, g1.y, 0.0),
        ];
        self.pending.push([q[0], q[1], q[2]]);
        self.pending.push([q[0], q[2], q[3]]);
        for ly in 0..LOTS {
            for lx in 0..LOTS {
                self.add_building(x0 + lx as f32 * LOT, y0 + ly as f32 * LOT);
            }
        }
    }

    fn add_building(&mut self, x: f32, y: f32) {
        let rng = &mut self.rng;
        let inset = rng.range_f32(0.5, 3.0);
        let u = rng.next_f32();
        let height = 8.0 + 22.0 * rng.next_f32() + 120.0 * u * u * u * u;
        let min = Vec3::new(x + inset, y + inset, 0.0);
        let max = Vec3::new(x + LOT - inset, y + LOT - inset, height);
        let tower = if rng.next_f32() < 0.4 {
            let shrink = (max.x - min.x) * rng.range_f32(0.15, 0.35);
            let tower_height = height * rng.range_f32(0.2, 0.8);
            Some((
                Vec3::new(min.x + shrink, min.y + shrink, height),
                Vec3::new(max.x - shrink, max.y - shrink, height + tower_height),
            ))
        } else {
            None
        };
        self.add_box_on_floor(min, max);
        if let Some((a, b)) = tower {
            self.add_box_on_floor(a, b);
        }
    }

    /// The core generator's `add_box_on_floor`: sides and top, corner bits x = 1, y = 2, z = 4.
    fn add_box_on_floor(&mut self, min: Vec3, max: Vec3) {
        let corner = |i: u32| {
            let pick = |bit: u32, lo: f32, hi: f32| if i & bit != 0 { hi } else { lo };
            Vec3::new(
                pick(1, min.x, max.x),
                pick(2, min.y, max.y),
                pick(4, min.z, max.z),
            )
        };
        const SIDES_AND_TOP: [[u32; 4]; 5] = [
            [0, 4, 6, 2],
            [1, 3, 7, 5],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [4, 5, 7, 6],
        ];
        for [p, q, r, s] in SIDES_AND_TOP {
            self.pending.push([corner(p), corner(q), corner(r)]);
            self.pending.push([corner(p), corner(r), corner(s)]);
        }
    }
}

impl TriangleSource for StreamingCity {
    fn id_bound(&self) -> u32 {
        u32::try_from(self.blocks * self.blocks * MAX_TRIANGLES_PER_BLOCK).unwrap_or(u32::MAX)
    }

    fn next_batch(&mut self, max: usize, out: &mut Vec<SourceTriangle>) -> Result<usize, RvError> {
        let mut n = 0;
        while n < max {
            if self.pending_at == self.pending.len() {
                if self.next_block == self.blocks * self.blocks {
                    break;
                }
                self.generate_block();
            }
            out.push(SourceTriangle {
                id: self.next_id,
                corners: self.pending[self.pending_at],
            });
            self.pending_at += 1;
            self.next_id += 1;
            n += 1;
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::{open, LoadOptions};

    #[test]
    fn matches_materialised_city() {
        let scene =
            open("procedural:city?seed=5&size=3000", &LoadOptions::default()).expect("city");
        let mut s = StreamingCity::new(5, 3000);
        let mut out = Vec::new();
        while s.next_batch(97, &mut out).ok() > Some(0) {}
        assert_eq!(out.len(), scene.triangle_count());
        for t in &out {
            assert_eq!(t.corners, scene.triangle(t.id));
        }
        assert!(s.id_bound() as usize >= out.len());
    }

    #[test]
    fn zero_max_yields_nothing() {
        let mut s = StreamingCity::new(1, 100);
        let mut out = Vec::new();
        assert_eq!(s.next_batch(0, &mut out).ok(), Some(0));
    }
}
