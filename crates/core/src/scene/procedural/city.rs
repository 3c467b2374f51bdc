//! `city`: a street grid of boxy buildings on a ground plane — an urban canyon, the typical
//! scene of from-region visibility papers (Koch & Wimmer 2021 use city models). Z up, metres.
//!
//! Layout: `B x B` blocks of `LOTS x LOTS` lots separated by streets; every lot holds one
//! building (a box, and with some probability a narrower tower on top of it), heights drawn
//! from a heavy-tailed distribution so a few towers stick out. The ground is one quad per block
//! plus the streets around it. `B` is chosen so the triangle count is close to `size`.

use glam::Vec3;

use super::{add_box_on_floor, add_quad};
use crate::random::SplitMix64;
use crate::scene::{SceneBuilder, UpAxis};

const LOTS: usize = 4;
const LOT: f32 = 20.0;
const STREET: f32 = 12.0;
const BLOCK: f32 = LOTS as f32 * LOT;
const PITCH: f32 = BLOCK + STREET;
/// Expected triangles per block: ground quad + buildings of 10 triangles, 40% with a tower.
const TRIANGLES_PER_BLOCK: f64 = 2.0 + (LOTS * LOTS) as f64 * 14.0;

pub(super) fn generate(b: &mut SceneBuilder, seed: u64, size: usize) {
    b.set_up(UpAxis::Z);
    let blocks = ((size as f64 / TRIANGLES_PER_BLOCK).sqrt().round() as usize).max(1);
    let mut rng = SplitMix64::new(seed);
    let origin = -0.5 * blocks as f32 * PITCH;
    for by in 0..blocks {
        for bx in 0..blocks {
            let x0 = origin + bx as f32 * PITCH;
            let y0 = origin + by as f32 * PITCH;
            // Ground tile: the block and the street on its -x/-y side and, on the last
            // row/column, nothing more (the city ends at its last block).
            b.begin_object(format!("ground{bx}_{by}"));
            let g0 = Vec3::new(x0 - STREET * 0.5, y0 - STREET * 0.5, 0.0);
            let g1 = Vec3::new(x0 + BLOCK + STREET * 0.5, y0 + BLOCK + STREET * 0.5, 0.0);
            add_quad(
                b,
                g0,
                Vec3::new(g1.x, g0.y, 0.0),
                g1,
                Vec3::new(g0.x, g1.y, 0.0),
            );
            for ly in 0..LOTS {
                for lx in 0..LOTS {
                    b.begin_object(format!("building{bx}_{by}_{lx}_{ly}"));
                    add_building(b, &mut rng, x0 + lx as f32 * LOT, y0 + ly as f32 * LOT);
                }
            }
        }
    }
}

fn add_building(b: &mut SceneBuilder, rng: &mut SplitMix64, x: f32, y: f32) {
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
