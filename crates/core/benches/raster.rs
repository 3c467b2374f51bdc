//! Frame time and triangle throughput of the reference rasterizer at 1024² on random-box
//! scenes of 100k and 1M triangles (`SceneBuilder::add_box`, fixed seed).
//!
//! Run: `cargo bench -p sightline-core --bench raster`. Throughput is reported as scene
//! triangles per second (every triangle goes through transform, clipping and setup; most are
//! culled by setup or hidden).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use sightline_core::raster::{Frame, Rasterizer};
use sightline_core::scene::SceneBuilder;
use sightline_core::{Camera, Scene};

/// `triangles / 12` random boxes in a 200-unit cube, sizes 0.2..3 (SplitMix64, seed 1).
fn random_boxes(triangles: usize) -> Scene {
    let mut state = 1u64;
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut b = SceneBuilder::new("bench boxes");
    for _ in 0..triangles / 12 {
        let c = Vec3::new(next(), next(), next()) * 200.0 - 100.0;
        let h = Vec3::new(next(), next(), next()) * 1.4 + 0.1;
        b.add_box(c - h, c + h);
    }
    b.finish()
}

fn bench_raster(c: &mut Criterion) {
    let mut group = c.benchmark_group("raster_1024");
    group.sample_size(10);
    for (label, n) in [("100k", 100_000), ("1M", 1_000_000)] {
        let scene = random_boxes(n);
        // From outside the box field, looking at its centre: the whole field is in view.
        let cam = Camera::look_at(
            Vec3::new(30.0, 40.0, 260.0),
            Vec3::ZERO,
            Vec3::Y,
            60.0,
            1024,
            1024,
            0.1,
        )
        .expect("bench camera");
        let mut raster = Rasterizer::new(&scene);
        let mut frame = Frame::new(1024, 1024);
        group.throughput(Throughput::Elements(scene.triangle_count() as u64));
        group.bench_function(label, |b| {
            b.iter(|| raster.render(&cam, None, &mut frame));
        });
        // Inside the field: many triangles cross the near plane or lie behind the eye.
        let inside = Camera::look_at(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.2, -0.5),
            Vec3::Y,
            90.0,
            1024,
            1024,
            0.1,
        )
        .expect("bench camera");
        group.bench_function(format!("{label}_inside"), |b| {
            b.iter(|| raster.render(&inside, None, &mut frame));
        });
    }
    group.finish();
}

criterion_group!(benches, bench_raster);
criterion_main!(benches);
