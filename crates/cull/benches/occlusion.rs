//! Throughput of the software occlusion buffer at 1920x1080: occluder triangles per second for
//! triangles with a 10x10-pixel bounding box (right triangles with 10-pixel legs, 50 px² of
//! area, at random depths 5..50 and random screen positions; every kernel), the same with 25,
//! 50 and 100-pixel legs (the default kernel; the sets are `sightline_cull::bench_sets`', which
//! `sightline bench peers` also gives Intel's MOC), and box tests per second
//! against the buffer those triangles leave plus a full-screen wall at depth 70 (boxes of about 20x20 pixels at depths 40..100).
//!
//! Run: `cargo bench -p sightline-cull --bench occlusion`. One thread. The occluder benchmark
//! runs once per rasterizer kernel the CPU supports (scalar, sse2, avx2, and the baseline
//! kernels sse2_per_tile, avx2_per_tile: the previous per-tile AVX2 kernel, and the SSE2
//! kernel again under its old name), side by side in one run.
//!
//! Times are the benchmark thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`), not wall time: the
//! machines this runs on are shared, and time spent waiting for a core is not the kernel's.

use criterion::measurement::{Measurement, ValueFormatter, WallTime};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use sightline_core::cpu_time::thread_cpu_ns;
use sightline_cull::bench_sets::{self, unproject, HEIGHT as H, LEGS_PX, TRIANGLES, WIDTH as W};
use sightline_cull::{BaselineKernel, Kernel, OcclusionBuffer};

/// Criterion measurement: CPU time of the calling thread, in nanoseconds.
struct ThreadCpuTime;

impl Measurement for ThreadCpuTime {
    type Intermediate = u64;
    type Value = u64;
    fn start(&self) -> u64 {
        thread_cpu_ns()
    }
    fn end(&self, start: u64) -> u64 {
        thread_cpu_ns() - start
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        // Values are nanoseconds, as wall time's.
        WallTime.formatter()
    }
}

fn bench_occlusion(c: &mut Criterion<ThreadCpuTime>) {
    let (tris, cam) = bench_sets::occluder_set(10.0);
    let mut group = c.benchmark_group("occlusion_1080p");
    group.sample_size(20);
    let mut buffer = OcclusionBuffer::new(W, H);
    group.throughput(Throughput::Elements(TRIANGLES as u64));
    // Every kernel this CPU supports, side by side in one run (they give identical buffers).
    for kernel in Kernel::ALL.into_iter().filter(|k| k.available()) {
        buffer.set_kernel(kernel);
        group.bench_function(format!("occluder_tris_10px/{}", kernel.name()), |b| {
            b.iter(|| {
                buffer.clear();
                buffer.render_occluders(&tris, &cam);
            });
        });
    }
    for kernel in BaselineKernel::ALL.into_iter().filter(|k| k.available()) {
        group.bench_function(format!("occluder_tris_10px/{}", kernel.name()), |b| {
            b.iter(|| {
                buffer.clear();
                buffer.render_occluders_baseline(kernel, &tris, &cam);
            });
        });
    }
    // The default kernel on the larger legs (fill bound rather than set-up bound).
    buffer.set_kernel(Kernel::detect());
    for leg in LEGS_PX.into_iter().filter(|&l| l != 10.0) {
        let (big, _) = bench_sets::occluder_set(leg);
        let name = format!("occluder_tris_{leg}px/{}", buffer.kernel().name());
        group.bench_function(name, |b| {
            b.iter(|| {
                buffer.clear();
                buffer.render_occluders(&big, &cam);
            });
        });
    }
    let queries = bench_sets::query_boxes(&cam, 100_000);
    buffer.clear();
    buffer.render_occluders(&tris, &cam);
    // A full-screen wall at depth 70 behind the small triangles: boxes beyond it are hidden.
    let wall = [
        unproject(&cam, -10.0, -10.0, 70.0),
        unproject(&cam, W as f32 + 10.0, -10.0, 70.0),
        unproject(&cam, W as f32 + 10.0, H as f32 + 10.0, 70.0),
        unproject(&cam, -10.0, H as f32 + 10.0, 70.0),
    ];
    buffer.render_occluders(
        &[wall[0], wall[1], wall[2], wall[0], wall[2], wall[3]],
        &cam,
    );
    let visible = queries.iter().filter(|q| buffer.test_box(q, &cam)).count();
    eprintln!("box tests: {visible} of {} boxes visible", queries.len());
    group.bench_function("box_tests_20px", |b| {
        b.iter(|| queries.iter().filter(|q| buffer.test_box(q, &cam)).count());
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(ThreadCpuTime);
    targets = bench_occlusion
}
criterion_main!(benches);
