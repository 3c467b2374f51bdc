//! Scratch timing loop of the occlusion raster kernels on the `bench_sets` triangles (the sets
//! `sightline bench peers` gives MOC): thread CPU time per triangle, median of rounds, each
//! round rendering every set once per kernel in turn. Also checks that the kernels' buffers
//! are identical.
//!
//! Run: `cargo run --release -p sightline-cull --example raster_probe -- [ROUNDS] [LEGS...]`
//! (`RASTER_PROBE_SCALE=2`: a 3840x2160 image with four times the triangles).

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
        // `RASTER_PROBE_SCALE=k`: a k-times wider and taller image with k² times the
        // triangles (the same density), for buffers beyond the caches.
        let scale: u32 = std::env::var("RASTER_PROBE_SCALE")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(1);
        let mut cam = bench_sets::camera();
        (cam.width, cam.height) = (W * scale, H * scale);
        let count = bench_sets::TRIANGLES * (scale * scale) as usize;
        let tris = bench_sets::right_triangles(&cam, count, leg, 1);
        let n = tris.len() / 3;
        let mut buffers: Vec<OcclusionBuffer> = kernels
            .iter()
            .map(|&k| {
                let mut b = OcclusionBuffer::new(cam.width, cam.height);
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
        if std::env::var("RASTER_PROBE_AGREE").is_ok() {
            agreement(&tris, &cam);
        }
        let mut scalar = OcclusionBuffer::new(cam.width, cam.height);
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

/// `RASTER_PROBE_AGREE=1`: which kernels give identical buffers, and the first pixels where
/// the scalar and AVX2 kernels differ.
fn agreement(tris: &[glam::Vec3], cam: &sightline_core::Camera) {
    let render = |k: Kernel| {
        let mut b = OcclusionBuffer::new(cam.width, cam.height);
        assert!(b.set_kernel(k));
        b.render_occluders(tris, cam);
        b
    };
    let all: Vec<(Kernel, OcclusionBuffer)> = Kernel::ALL
        .into_iter()
        .filter(|k| k.available())
        .map(|k| (k, render(k)))
        .collect();
    for (k, b) in &all {
        let same: Vec<&str> = all
            .iter()
            .filter(|(_, o)| o.same_contents(b))
            .map(|(k2, _)| k2.name())
            .collect();
        println!("{} agrees with {:?}", k.name(), same);
    }
    let mut diff = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            if all[0].1.depth_at(x, y) != all[2].1.depth_at(x, y) {
                if diff < 5 {
                    println!(
                        "pixel {x},{y}: scalar {:?} avx2 {:?}",
                        all[0].1.depth_at(x, y),
                        all[2].1.depth_at(x, y)
                    );
                }
                diff += 1;
            }
        }
    }
    println!("{diff} pixels differ");
}
