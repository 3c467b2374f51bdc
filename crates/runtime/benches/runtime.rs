//! Run-time queries of a baked `.pvs` (issue 15's targets): cell lookup and visible-object
//! iteration on a 64x64x4-cell bake of the 1M-triangle procedural city, and load time and
//! memory of a 10,000-cell (100x100x1) bake of the same city.
//!
//! The bakes are real (RAND, 256 rays per cell, so the sets are smaller than a production
//! bake's); the 10,000-object iteration runs on a cell of a third file whose set is 10,000 of
//! the city's objects. Bakes are cached under `target/runtime-bench/`.
//!
//! `cargo bench -p sightline-runtime --bench runtime`

#![allow(clippy::unwrap_used)]

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use glam::Vec3;
use sightline_core::scene::{self, LoadOptions};
use sightline_core::trace::Bvh;
use sightline_core::{Scene, TriangleSet};
use sightline_region::bake::BakeSetup;
use sightline_region::checkpoint::{fingerprint, ResumableBake};
use sightline_region::pvs_file::CellPvs;
use sightline_region::{Budget, PvsFile, RandomSampler, ViewCell};
use sightline_runtime::Pvs;

fn cache_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/runtime-bench");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn city() -> Scene {
    scene::open("procedural:city?size=1000000", &LoadOptions::default()).unwrap()
}

/// A street-level grid of `n` cells over the city (0.5 m to 12.5 m above the ground).
fn grid(scene: &Scene, n: [u32; 3]) -> Vec<ViewCell> {
    let b = scene.bounds();
    ViewCell::grid(
        Vec3::new(b.min.x, b.min.y, b.min.z + 0.5),
        Vec3::new(b.max.x, b.max.y, b.min.z + 12.5),
        n,
    )
    .unwrap()
}

/// Bakes `cells` with RAND (256 rays a cell) into `name` unless it is there already.
fn baked(scene: &Scene, name: &str, n: [u32; 3]) -> PathBuf {
    let path = cache_dir().join(name);
    if let Ok(p) = Pvs::open(&path) {
        if p.scene_hash() == scene.geometry_hash() && p.version() == 2 {
            return path;
        }
    }
    let cells = grid(scene, n);
    let bvh = Bvh::build(scene);
    let setup = BakeSetup {
        scene,
        caster: &bvh,
        cells: &cells,
        sampler: &RandomSampler,
        free_space: &|_, _| true,
        budget: Budget::rays(256),
        seed: 1,
    };
    let fp = fingerprint(&setup, "rand", serde_json::Value::Null);
    let job = ResumableBake::new(setup, fp);
    let start = Instant::now();
    let progress = job.run(&|_, _| {}, &mut |_, _| {}).unwrap();
    job.write_output(&path, &progress, serde_json::Value::Null)
        .unwrap();
    eprintln!(
        "baked {} cells into {} in {:.1?}",
        cells.len(),
        path.display(),
        start.elapsed()
    );
    path
}

/// One cell that sees every triangle of 10,000 of the city's objects (every fifth one).
fn ten_thousand_objects(scene: &Scene) -> Pvs {
    let mut file = PvsFile::for_scene(scene, serde_json::Value::Null);
    let mut visible = TriangleSet::with_capacity(scene.triangle_count());
    let mut chosen = 0;
    let mut last = u32::MAX;
    for (t, &o) in scene.object_of_triangle.iter().enumerate() {
        if o % 5 == 0 && chosen <= 10_000 {
            if o != last {
                chosen += 1;
                last = o;
            }
            if chosen <= 10_000 {
                visible.insert(t);
            }
        }
    }
    file.cells.push(CellPvs {
        cell: grid(scene, [1, 1, 1])[0],
        visible,
        bound: None,
    });
    let mut bytes = Vec::new();
    file.write(&mut bytes).unwrap();
    let pvs = Pvs::from_bytes(bytes).unwrap();
    assert_eq!(pvs.visible_object_count(0).unwrap(), 10_000);
    pvs
}

fn queries(c: &mut Criterion) {
    let scene = city();
    let big = Pvs::open(baked(&scene, "city1m-64x64x4.pvs", [64, 64, 4])).unwrap();
    let ten_k_path = baked(&scene, "city1m-100x100x1.pvs", [100, 100, 1]);
    let dense = ten_thousand_objects(&scene);
    let b = scene.bounds();
    eprintln!(
        "64x64x4 file: {} cells, {} objects, {} triangles, {} bytes",
        big.cell_count(),
        big.object_count(),
        big.triangle_count(),
        big.as_bytes().len()
    );

    // Lookup: 4096 positions spread over the city (nearly all inside some cell).
    let positions: Vec<[f32; 3]> = (0..4096u32)
        .map(|i| {
            let h = sightline_core::random::mix64(u64::from(i));
            let u = |k: u32| ((h >> (16 * k)) & 0xffff) as f32 / 65535.0;
            [
                b.min.x + u(0) * (b.max.x - b.min.x),
                b.min.y + u(1) * (b.max.y - b.min.y),
                b.min.z + 0.5 + u(2) * 12.0,
            ]
        })
        .collect();
    let found = positions
        .iter()
        .filter(|p| big.cell_at(**p).is_some())
        .count();
    eprintln!(
        "lookup: {found} of {} positions inside a cell",
        positions.len()
    );
    lookup_against_a_scan(&big, &positions);
    let mut k = 0;
    c.bench_function("cell_at (64x64x4 cells)", |bench| {
        bench.iter(|| {
            k = (k + 1) % positions.len();
            black_box(big.cell_at(black_box(positions[k])))
        })
    });

    let largest = (0..big.cell_count())
        .max_by_key(|&c| big.visible_object_count(c).unwrap())
        .unwrap();
    let mut ids = Vec::new();
    eprintln!(
        "largest cell set of the bake: {} objects",
        big.visible_object_count(largest).unwrap()
    );
    c.bench_function("visible_objects_into (largest cell of the bake)", |bench| {
        bench.iter(|| {
            big.visible_objects_into(black_box(largest), &mut ids)
                .unwrap();
            black_box(ids.len())
        })
    });
    c.bench_function("visible_objects_into (10,000 objects)", |bench| {
        bench.iter(|| {
            dense.visible_objects_into(black_box(0), &mut ids).unwrap();
            black_box(ids.len())
        })
    });

    let bytes = std::fs::read(&ten_k_path).unwrap();
    let loaded = Pvs::from_bytes(bytes.clone()).unwrap();
    eprintln!(
        "10,000-cell file: {} bytes on disk; in memory {} bytes of file + {} bytes of index ({:.3}x the file)",
        bytes.len(),
        loaded.as_bytes().len(),
        loaded.index_heap_bytes(),
        (loaded.as_bytes().len() + loaded.index_heap_bytes()) as f64 / bytes.len() as f64
    );
    c.bench_function("open from bytes (10,000 cells)", |bench| {
        bench.iter_batched(
            || bytes.clone(),
            |b| black_box(Pvs::from_bytes(b).unwrap().cell_count()),
            BatchSize::LargeInput,
        )
    });
    c.bench_function("open from file (10,000 cells)", |bench| {
        bench.iter(|| black_box(Pvs::open(&ten_k_path).unwrap().cell_count()))
    });
}

/// The index against the baseline a user would write first, a scan of every cell for the
/// lowest index that holds the position (the documented policy, with the same containment
/// test): both answer every position alike, and their CPU times are measured alternately,
/// round by round, on this thread.
fn lookup_against_a_scan(pvs: &Pvs, positions: &[[f32; 3]]) {
    use sightline_core::cpu_time::thread_cpu_ns;
    let cells: Vec<_> = (0..pvs.cell_count())
        .map(|c| pvs.cell(c).unwrap())
        .collect();
    let scan = |p: [f32; 3]| (0..cells.len() as u32).find(|&c| cells[c as usize].contains(p));
    let sample = &positions[..256];
    for &p in sample {
        assert_eq!(
            pvs.cell_at(p),
            scan(p),
            "the index and the scan disagree at {p:?}"
        );
    }
    let (mut indexed, mut scanned) = (Vec::new(), Vec::new());
    for _ in 0..9 {
        let t = thread_cpu_ns();
        for &p in sample {
            black_box(pvs.cell_at(black_box(p)));
        }
        indexed.push((thread_cpu_ns() - t) as f64 / sample.len() as f64);
        let t = thread_cpu_ns();
        for &p in sample {
            black_box(scan(black_box(p)));
        }
        scanned.push((thread_cpu_ns() - t) as f64 / sample.len() as f64);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (i, s) = (median(&mut indexed), median(&mut scanned));
    eprintln!(
        "cell_at against a scan of {} cells, 9 alternated rounds of {} positions, thread CPU \
         time: index {i:.0} ns, scan {s:.0} ns per lookup ({:.0}x), same answers",
        cells.len(),
        sample.len(),
        s / i
    );
}

criterion_group!(benches, queries);
criterion_main!(benches);
