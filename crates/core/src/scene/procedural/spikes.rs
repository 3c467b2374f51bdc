//! `spikes`: a square grid of square pyramids of varying height sharing their base edges, a
//! stress test of high depth complexity for exact visibility (after the SPIKES scene of
//! Auzinger, Wimmer, Jeschke, Analytic Visibility on the GPU, 2013, figure 5), Y up, one object per row of pyramids.

use glam::Vec3;

use crate::random::SplitMix64;
use crate::scene::builder::SceneBuilder;

pub(super) fn generate(b: &mut SceneBuilder, seed: u64, size: usize) {
    // Four triangles per pyramid, n x n pyramids.
    let n = ((size as f64 / 4.0).sqrt().round() as usize).max(1);
    let mut rng = SplitMix64::new(seed);
    let mut grid = vec![0u32; (n + 1) * (n + 1)];
    for j in 0..=n {
        for i in 0..=n {
            grid[j * (n + 1) + i] = b.add_vertex(Vec3::new(i as f32, 0.0, j as f32));
        }
    }
    for j in 0..n {
        b.begin_object(format!("row{j}"));
        for i in 0..n {
            // Heights 2..10 base widths: long, thin triangles that overlap many others.
            let h = rng.range_f32(2.0, 10.0);
            let apex = b.add_vertex(Vec3::new(i as f32 + 0.5, h, j as f32 + 0.5));
            let c = [
                grid[j * (n + 1) + i],
                grid[j * (n + 1) + i + 1],
                grid[(j + 1) * (n + 1) + i + 1],
                grid[(j + 1) * (n + 1) + i],
            ];
            for k in 0..4 {
                b.add_triangle([c[k], c[(k + 1) % 4], apex]);
            }
        }
    }
}
