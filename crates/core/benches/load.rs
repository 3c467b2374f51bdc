//! Loader throughput: a binary little-endian PLY of 1M triangles (a 1000 x 500 vertex grid,
//! the layout of the shared PLY scenes: `float x, y, z` + `list uchar int`) written to a temp
//! file, then loaded through `scene::open` (file read + parse + scene build).

use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;
use sightline_core::scene::{self, LoadOptions, SceneBuilder};

/// A `w x h` vertex grid: `2 (w - 1) (h - 1)` triangles.
fn grid(w: u32, h: u32) -> sightline_core::Scene {
    let mut b = SceneBuilder::new("grid");
    b.begin_object("grid");
    for y in 0..h {
        for x in 0..w {
            b.add_vertex(Vec3::new(
                x as f32,
                y as f32,
                ((x * 7 + y * 13) % 17) as f32 * 0.1,
            ));
        }
    }
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            let i = y * w + x;
            b.add_triangle([i, i + 1, i + w]);
            b.add_triangle([i + 1, i + w + 1, i + w]);
        }
    }
    b.finish()
}

fn load_ply_1m(c: &mut Criterion) {
    // 1001 x 501 vertices = 1000 * 500 * 2 = 1,000,000 triangles.
    let scene = grid(1001, 501);
    assert_eq!(scene.triangle_count(), 1_000_000);
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("grid_1m.ply");
    let mut file = std::io::BufWriter::new(std::fs::File::create(&path).expect("create"));
    scene::ply::write(&scene, &mut file).expect("write");
    drop(file);
    let spec = path.to_string_lossy().into_owned();
    let mut group = c.benchmark_group("load");
    group.sample_size(20);
    group.bench_function("ply_binary_1m_triangles", |b| {
        b.iter(|| {
            let s = scene::open(&spec, &LoadOptions::default()).expect("load");
            assert_eq!(s.triangle_count(), 1_000_000);
            s
        })
    });
    group.finish();
}

criterion_group!(benches, load_ply_1m);
criterion_main!(benches);
