//! Ray-casting throughput of our BVH and (with `--features embree`) Embree, side by side on
//! one synthetic scene: coherent camera rays and incoherent random rays.
//!
//! Run: `cargo bench -p sightline-core --features embree --bench trace`. Before the criterion
//! groups it prints a one-line summary per ray set with Mrays/s and the Embree/ours ratio,
//! measured with `trace::measure::rays_per_second` (the same loop as `sightline bench trace`).

use std::time::Instant;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::Vec3;
use sightline_core::geometry::{Aabb, Hit, Ray};
use sightline_core::scene::{Scene, SceneBuilder};
use sightline_core::trace::measure::{coherent_rays, incoherent_rays, rays_per_second};
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::Camera;

/// Number of boxes (12 triangles each): 600k triangles, a mid-sized game level.
const BOXES: usize = 50_000;
/// Side of the cube the boxes are scattered in.
const WORLD: f32 = 200.0;
/// Rays per set: one 512x512 view.
const SIDE: u32 = 512;

/// Random boxes of 0.2 to 4 units in a `WORLD`-sized cube (fixed seed): dense enough that most
/// rays hit after a few boxes, like a city block seen from inside.
fn random_boxes() -> Scene {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut unit = move || {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        ((state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32) / (1u32 << 24) as f32
    };
    let mut b = SceneBuilder::new(format!("bench: {BOXES} random boxes"));
    b.reserve(BOXES * 8, BOXES * 12);
    for _ in 0..BOXES {
        let min = Vec3::new(unit(), unit(), unit()) * WORLD;
        let size = Vec3::new(unit(), unit(), unit()) * 3.8 + 0.2;
        b.add_box(min, min + size);
    }
    b.finish()
}

fn camera(bounds: &Aabb) -> Camera {
    let eye = bounds.min + bounds.extent() * Vec3::new(0.1, 0.15, 0.2);
    Camera::look_at(eye, bounds.center(), Vec3::Z, 60.0, SIDE, SIDE, 0.01)
        .expect("the bench camera is valid")
}

struct Caster {
    name: &'static str,
    caster: Box<dyn RayCaster>,
}

fn casters(scene: &Scene) -> Vec<Caster> {
    let start = Instant::now();
    let bvh = Bvh::build(scene);
    eprintln!(
        "build ours:   {:.3} s for {} triangles ({:.1} bytes/triangle)",
        start.elapsed().as_secs_f64(),
        scene.triangle_count(),
        bvh.memory_bytes() as f64 / bvh.triangle_count().max(1) as f64
    );
    #[allow(unused_mut)]
    let mut out = vec![Caster {
        name: "ours",
        caster: Box::new(bvh),
    }];
    #[cfg(feature = "embree")]
    {
        let start = Instant::now();
        let embree =
            sightline_core::trace::EmbreeCaster::build(scene).expect("embree builds the scene");
        eprintln!("build embree: {:.3} s", start.elapsed().as_secs_f64());
        out.push(Caster {
            name: "embree",
            caster: Box::new(embree),
        });
    }
    out
}

fn summary(casters: &[Caster], sets: &[(&str, Vec<Ray>)]) {
    for (set, rays) in sets {
        let mut hits = vec![Hit::MISS; rays.len()];
        casters[0].caster.cast(rays, &mut hits);
        let hit_rate = hits.iter().filter(|h| h.is_hit()).count() as f64 / rays.len() as f64;
        // Best of three interleaved rounds: the machine is shared, and the best round is the
        // one least disturbed by other work.
        let mut rates = vec![0f64; casters.len()];
        for _ in 0..3 {
            for (rate, c) in rates.iter_mut().zip(casters) {
                *rate = rate.max(rays_per_second(c.caster.as_ref(), rays, 1.0));
            }
        }
        let mut line = format!("{set:>10} ({:.0}% hit):", hit_rate * 100.0);
        for (c, r) in casters.iter().zip(&rates) {
            line += &format!("  {} {:.2} Mrays/s", c.name, r / 1e6);
        }
        if rates.len() > 1 {
            line += &format!("  embree/ours {:.2}x", rates[1] / rates[0]);
        }
        eprintln!("{line}");
    }
}

fn bench_trace(c: &mut Criterion) {
    let start = Instant::now();
    let scene = random_boxes();
    eprintln!(
        "scene: {} triangles generated in {:.3} s",
        scene.triangle_count(),
        start.elapsed().as_secs_f64()
    );
    let bounds = scene.bounds();
    let casters = casters(&scene);
    let sets = [
        ("coherent", coherent_rays(&camera(&bounds))),
        (
            "incoherent",
            incoherent_rays(bounds, (SIDE * SIDE) as usize, 42),
        ),
    ];
    summary(&casters, &sets);

    for (set, rays) in &sets {
        let mut group = c.benchmark_group(format!("trace/{set}"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(rays.len() as u64));
        let mut hits = vec![Hit::MISS; rays.len()];
        for caster in &casters {
            group.bench_function(BenchmarkId::from_parameter(caster.name), |b| {
                b.iter(|| caster.caster.cast(rays, &mut hits))
            });
        }
        group.finish();
    }

    let mut group = c.benchmark_group("build");
    group.sample_size(10);
    group.throughput(Throughput::Elements(scene.triangle_count() as u64));
    group.bench_function("ours", |b| b.iter(|| Bvh::build(&scene)));
    group.finish();
}

criterion_group!(benches, bench_trace);
criterion_main!(benches);
