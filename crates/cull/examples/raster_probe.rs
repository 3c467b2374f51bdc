//! Scratch timing loop of the occlusion raster kernels on the `bench_sets` triangles (the sets
//! `sightline bench peers` gives MOC): thread CPU time per triangle, median of rounds, each
//! round rendering every set once per kernel in turn. Also checks that the kernels' buffers
//! are identical.
//!
//! Run: `cargo run --release -p sightline-cull --example raster_probe -- [ROUNDS] [LEGS...]`

use sightline_core::cpu_time::thread_cpu_ns;
use sightline_cull::bench_sets::{self, HEIGHT as H, WIDTH as W};
use sightline_cull::{Kernel, OcclusionBuffer};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let rounds: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(7);
    let legs: Vec<f32> = if args.len() > 1 {
        args[1..].iter().map(|a| a.parse().expect("leg")).collect()
    } else {
        vec![10.0, 25.0, 50.0, 100.0]
    };
    let kernels: Vec<Kernel> = [Kernel::Avx2, Kernel::Avx512]
        .into_iter()
        .filter(|k| k.available())
        .collect();
    for leg in legs {
        let (tris, cam) = bench_sets::occluder_set(leg);
        let n = tris.len() / 3;
        let mut buffers: Vec<OcclusionBuffer> = kernels
            .iter()
            .map(|&k| {
                let mut b = OcclusionBuffer::new(W, H);
                b.set_kernel(k);
                b
            })
            .collect();
        let mut times = vec![Vec::new(); kernels.len()];
        for _ in 0..rounds {
            for (i, b) in buffers.iter_mut().enumerate() {
                let t0 = thread_cpu_ns();
                for _ in 0..5 {
                    b.clear();
                    b.render_occluders(&tris, &cam);
                }
                times[i].push((thread_cpu_ns() - t0) as f64 / 5.0 / n as f64);
            }
        }
        let mut scalar = OcclusionBuffer::new(W, H);
        scalar.set_kernel(Kernel::Scalar);
        scalar.render_occluders(&tris, &cam);
        for (i, k) in kernels.iter().enumerate() {
            times[i].sort_by(f64::total_cmp);
            println!(
                "{leg:>5} px {:>7}: {:6.2} ns/tri ({:5.1} M tris/s) same as scalar: {}",
                k.name(),
                times[i][rounds / 2],
                1e3 / times[i][rounds / 2],
                buffers[i].same_contents(&scalar)
            );
        }
    }
}
