//! Throughput of the software occlusion buffer at 1920x1080: occluder triangles per second for
//! triangles with a 10x10-pixel bounding box (right triangles with 10-pixel legs, 50 px² of
//! area, at random depths 5..50 and random screen positions), and box tests per second
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
use glam::Vec3;
use sightline_core::cpu_time::thread_cpu_ns;
use sightline_core::random::SplitMix64;
use sightline_core::{Aabb, Camera};
use sightline_cull::{BaselineKernel, Kernel, OcclusionBuffer};

const W: u32 = 1920;
const H: u32 = 1080;

fn camera() -> Camera {
    Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, W, H, 0.1).expect("bench camera")
}

/// The world point seen at screen `(sx, sy)` at view depth `z` (camera at the origin looking
/// down -Z with +Y up).
fn unproject(cam: &Camera, sx: f32, sy: f32, z: f32) -> Vec3 {
    let u = (2.0 * sx / W as f32 - 1.0) * cam.tan_half_x();
    let v = (1.0 - 2.0 * sy / H as f32) * cam.tan_half_y();
    Vec3::new(u * z, v * z, -z)
}

fn triangles(cam: &Camera, n: usize) -> Vec<Vec3> {
    let mut rng = SplitMix64::new(1);
    let mut out = Vec::with_capacity(3 * n);
    for _ in 0..n {
        let sx = rng.range_f32(0.0, W as f32 - 10.0);
        let sy = rng.range_f32(0.0, H as f32 - 10.0);
        let z = rng.range_f32(5.0, 50.0);
        out.push(unproject(cam, sx, sy, z));
        out.push(unproject(cam, sx + 10.0, sy, z * 1.001));
        out.push(unproject(cam, sx, sy + 10.0, z * 0.999));
    }
    out
}

fn boxes(cam: &Camera, n: usize) -> Vec<Aabb> {
    let mut rng = SplitMix64::new(2);
    (0..n)
        .map(|_| {
            let sx = rng.range_f32(0.0, W as f32 - 20.0);
            let sy = rng.range_f32(0.0, H as f32 - 20.0);
            let z = rng.range_f32(40.0, 100.0);
            let a = unproject(cam, sx, sy, z);
            let b = unproject(cam, sx + 20.0, sy + 20.0, z + 1.0);
            Aabb::new(a.min(b), a.max(b))
        })
        .collect()
}

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
    let cam = camera();
    let mut group = c.benchmark_group("occlusion_1080p");
    group.sample_size(20);
    let tris = triangles(&cam, 100_000);
    let mut buffer = OcclusionBuffer::new(W, H);
    group.throughput(Throughput::Elements(100_000));
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
    buffer.set_kernel(Kernel::detect());
    let queries = boxes(&cam, 100_000);
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
