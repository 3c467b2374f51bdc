//! `canyon`: a height-field terrain with a meandering river canyon — long sight lines along
//! the canyon, strong occlusion by its walls. Z up, metres, 1000 m square.
//!
//! Height = fractal value noise (5 octaves) minus a Gaussian trench that follows a sine
//! meander. The grid of `n x n` cells (2 triangles each, diagonal alternating so that ridges do
//! not all run one way) is split into 16x16-cell chunks, one object each, in row-major order.

use glam::Vec3;

use crate::random::SplitMix64;
use crate::scene::builder::SceneBuilder;
use crate::scene::types::UpAxis;

const EXTENT: f32 = 1000.0;
const CHUNK: usize = 16;

pub(super) fn generate(b: &mut SceneBuilder, seed: u64, size: usize) {
    b.set_up(UpAxis::Z);
    let n = (((size / 2) as f64).sqrt().round() as usize).max(2);
    let noise = ValueNoise::new(seed);
    let cell = EXTENT / n as f32;
    let height_at = |i: usize, j: usize| -> f32 {
        let x = i as f32 * cell;
        let y = j as f32 * cell;
        let mut h = 0.0;
        let mut amplitude = 120.0;
        let mut frequency = 3.0 / EXTENT;
        for _ in 0..5 {
            h += amplitude * noise.at(x * frequency, y * frequency);
            amplitude *= 0.5;
            frequency *= 2.0;
        }
        let meander = EXTENT * 0.5 + EXTENT * 0.15 * (y / EXTENT * std::f32::consts::TAU).sin();
        let d = (x - meander) / (EXTENT * 0.04);
        h - 150.0 * (-d * d).exp()
    };
    // Vertices of a chunk are emitted per chunk (duplicated along chunk borders) so that each
    // object's triangles reference only its own vertices.
    let chunks = n.div_ceil(CHUNK);
    for cj in 0..chunks {
        for ci in 0..chunks {
            b.begin_object(format!("terrain{ci}_{cj}"));
            let (i0, j0) = (ci * CHUNK, cj * CHUNK);
            let (i1, j1) = ((i0 + CHUNK).min(n), (j0 + CHUNK).min(n));
            let w = (i1 - i0 + 1) as u32;
            let base = b.vertex_count();
            for j in j0..=j1 {
                for i in i0..=i1 {
                    b.add_vertex(Vec3::new(i as f32 * cell, j as f32 * cell, height_at(i, j)));
                }
            }
            for j in 0..(j1 - j0) as u32 {
                for i in 0..(i1 - i0) as u32 {
                    let a = base + j * w + i;
                    let (r, u, ur) = (a + 1, a + w, a + w + 1);
                    if (i + j) % 2 == 0 {
                        b.add_triangle([a, r, ur]);
                        b.add_triangle([a, ur, u]);
                    } else {
                        b.add_triangle([a, r, u]);
                        b.add_triangle([r, ur, u]);
                    }
                }
            }
        }
    }
}

/// 2D value noise on a 256-periodic lattice with smoothstep interpolation, in `[-1, 1]`.
struct ValueNoise {
    lattice: Vec<f32>,
}

impl ValueNoise {
    fn new(seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed ^ 0x6361_6e79_6f6e);
        Self {
            lattice: (0..256 * 256).map(|_| rng.range_f32(-1.0, 1.0)).collect(),
        }
    }

    fn at(&self, x: f32, y: f32) -> f32 {
        let (xf, yf) = (x.floor(), y.floor());
        let (tx, ty) = (x - xf, y - yf);
        let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
        let (xi, yi) = (xf as i64, yf as i64);
        let v =
            |i: i64, j: i64| self.lattice[(i.rem_euclid(256) * 256 + j.rem_euclid(256)) as usize];
        let a = v(xi, yi) + (v(xi + 1, yi) - v(xi, yi)) * sx;
        let c = v(xi, yi + 1) + (v(xi + 1, yi + 1) - v(xi, yi + 1)) * sx;
        a + (c - a) * sy
    }
}
