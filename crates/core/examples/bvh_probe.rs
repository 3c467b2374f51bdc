//! Where our BVH's ray-casting time goes, per scene: build time, memory, SAH cost and the
//! nodes, leaves and packets a ray visits (counts, which a loaded machine does not disturb),
//! and with `--time` the single-thread speed of ours and (with `--features embree`) Embree on
//! the same rays, alternating rounds as `sightline bench trace` does.
//!
//! Run: `RAYON_NUM_THREADS=1 cargo run --release -p sightline-core --features embree --example
//! bvh_probe -- [--time] SCENE...` (scene specs as `sightline` takes them).
//!
//! For counting instructions (cachegrind, which a loaded machine does not disturb either):
//! `bvh_probe --cast=ours|embree --set=coherent|incoherent|outside --rays=N --repeat=K SCENE` builds
//! only that caster and casts the first `N` rays of the set `K` times, with no timing loop;
//! the difference between `K = 3` and `K = 1`, over `2 N`, is the instructions per ray.
//!
//! Based on: Aila, Laine. Understanding the efficiency of ray traversal on GPUs. HPG 2009
//! (primary = coherent, random = incoherent ray sets). Based on: Aila, Karras, Laine. On
//! quality metrics of bounding volume hierarchies. HPG 2013 (SAH cost beside measured counts).

use std::time::Instant;

use glam::Vec3;
use sightline_core::cpu_time::thread_cpu_ns;
use sightline_core::geometry::{Aabb, Hit, Ray};
use sightline_core::scene::{self, LoadOptions, Scene};
use sightline_core::trace::measure::{coherent_rays, incoherent_rays};
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::Camera;

/// Rays counted per set (counting is slower than casting).
const COUNTED: usize = 200_000;
/// Incoherent rays timed per set (as many as `sightline bench trace` casts).
const TIMED: usize = 1_000_000;

/// The overview camera of `sightline bench trace`.
fn camera(scene: &Scene) -> Camera {
    let b = scene.bounds();
    let up = scene.up.vector();
    let side = if up == Vec3::Z {
        Vec3::new(-0.55, -0.75, 0.0)
    } else {
        Vec3::new(-0.55, 0.0, 0.75)
    };
    let eye = b.center() + (side + up * 0.45) * b.diagonal() * 0.75;
    let near = sightline_core::default_near(scene, eye);
    Camera::look_at(eye, b.center(), up, 60.0, 1024, 1024, near).expect("valid camera")
}

/// Rays from outside the bounds toward a random point inside them (origins on the bounding
/// sphere), as a renderer's secondary rays into an object from its surroundings.
fn outside_rays(bounds: Aabb, n: usize) -> Vec<Ray> {
    let inside = incoherent_rays(bounds, n, 11);
    let radius = bounds.diagonal();
    inside
        .iter()
        .map(|r| {
            let origin = bounds.center() - r.dir * radius;
            Ray::new(origin, (r.origin - origin).normalize())
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let option = |name: &str| {
        args.iter()
            .find_map(|a| a.strip_prefix(&format!("--{name}=")))
            .map(str::to_owned)
    };
    if let Some(caster) = option("cast") {
        let set = option("set").unwrap_or_else(|| "incoherent".into());
        let number = |name: &str, default: usize| {
            option(name).map_or(default, |v| v.parse().expect("a whole number"))
        };
        let (rays, repeat) = (number("rays", 100_000), number("repeat", 1));
        for spec in args.iter().filter(|a| !a.starts_with("--")) {
            cast_only(spec, &caster, &set, rays, repeat);
        }
        return;
    }
    let time = args.iter().any(|a| a == "--time");
    for spec in args.iter().filter(|a| !a.starts_with("--")) {
        let scene = scene::open(spec, &LoadOptions::default()).expect("scene loads");
        let start = Instant::now();
        let bvh = Bvh::build(&scene);
        let build = start.elapsed().as_secs_f64();
        let t = bvh.tree_stats();
        println!(
            "{spec}: {} tris, build {build:.3} s, {:.1} B/tri, {} nodes, {} leaves, {} packets \
             ({:.2} refs/packet, {:.3} refs/tri), SAH {:.2} nodes + {:.2} packets",
            bvh.triangle_count(),
            t.bytes_per_triangle,
            t.nodes,
            t.leaves,
            t.packets,
            t.references as f64 / t.packets as f64,
            t.references as f64 / bvh.triangle_count() as f64,
            t.sah_nodes,
            t.sah_packets,
        );
        #[cfg(feature = "embree")]
        let embree = time.then(|| {
            // Embree on one build thread: compare with ours under `RAYON_NUM_THREADS=1`.
            let start = Instant::now();
            let e = sightline_core::trace::EmbreeCaster::build_with_threads(&scene, 1)
                .expect("embree builds");
            println!("  Embree build {:.3} s", start.elapsed().as_secs_f64());
            e
        });
        #[cfg(feature = "embree")]
        let peer = embree.as_ref().map(|e| e as &dyn RayCaster);
        #[cfg(not(feature = "embree"))]
        let peer: Option<&dyn RayCaster> = None;
        let sets = [
            ("coherent", coherent_rays(&camera(&scene))),
            ("incoherent", incoherent_rays(scene.bounds(), TIMED, 7)),
            ("outside", outside_rays(scene.bounds(), TIMED)),
            (
                "null",
                incoherent_rays(scene.bounds(), TIMED, 7)
                    .into_iter()
                    .map(|r| Ray::new(r.origin + Vec3::splat(1e9), r.dir))
                    .collect(),
            ),
        ];
        for (name, rays) in &sets {
            // Every k-th ray, so a camera's sample spans the whole image.
            let step = (rays.len() / COUNTED).max(1);
            let sample: Vec<Ray> = rays.iter().step_by(step).copied().collect();
            let s = bvh.traversal_stats(&sample);
            print!(
                "  {name:>10}: {:6.2} nodes {:5.2} leaves {:6.2} packets per ray, {:.0}% hit",
                s.nodes,
                s.leaves,
                s.packets,
                s.hit_rate * 100.0
            );
            if time {
                print!("{}", timings(&bvh, peer, rays));
            }
            println!();
        }
    }
}

/// Mrays/s of ours and Embree on `rays`, best of 5 alternating rounds of about 0.3 s each, in
/// CPU time of one thread (a one-thread pool, so the casts run on the timed thread): other
/// tenants of a shared machine take wall time, not this thread's CPU time.
fn timings(bvh: &Bvh, peer: Option<&dyn RayCaster>, rays: &[Ray]) -> String {
    let mut casters: Vec<&dyn RayCaster> = vec![bvh];
    casters.extend(peer);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    let mut best = vec![0.0f64; casters.len()];
    let mut hits = vec![Hit::MISS; rays.len()];
    pool.install(|| {
        for _ in 0..5 {
            for (b, c) in best.iter_mut().zip(&casters) {
                let start = thread_cpu_ns();
                let mut cast = 0;
                while thread_cpu_ns() - start < 300_000_000 {
                    c.cast(rays, &mut hits);
                    cast += rays.len();
                }
                let seconds = (thread_cpu_ns() - start) as f64 * 1e-9;
                *b = b.max(cast as f64 / seconds / 1e6);
            }
        }
    });
    let ratio = best
        .get(1)
        .map_or(String::new(), |e| format!(" x{:.2}", e / best[0]));
    let rates: Vec<String> = best.iter().map(|r| format!("{r:.2}")).collect();
    format!("  Mrays/s {}{ratio}", rates.join(" / "))
}

/// The `--cast` mode: casts the first `rays` rays of `set` on `spec` `repeat` times with one
/// caster, and prints the hits (so the casts are not optimised away).
fn cast_only(spec: &str, caster: &str, set: &str, rays: usize, repeat: usize) {
    let scene = scene::open(spec, &LoadOptions::default()).expect("scene loads");
    let rays: Vec<Ray> = match set {
        "coherent" => {
            // Every k-th camera ray, so the sample spans the whole image.
            let all = coherent_rays(&camera(&scene));
            let step = (all.len() / rays.max(1)).max(1);
            all.into_iter().step_by(step).take(rays).collect()
        }
        "incoherent" => incoherent_rays(scene.bounds(), rays, 7),
        "outside" => outside_rays(scene.bounds(), rays),
        other => panic!("--set={other}: coherent, incoherent or outside"),
    };
    let caster: Box<dyn RayCaster> = match caster {
        "ours" => Box::new(Bvh::build(&scene)),
        #[cfg(feature = "embree")]
        "embree" => Box::new(
            sightline_core::trace::EmbreeCaster::build_with_threads(&scene, 1)
                .expect("embree builds"),
        ),
        other => panic!("--cast={other}: ours, or embree with --features embree"),
    };
    let mut hits = vec![Hit::MISS; rays.len()];
    let mut hit = 0;
    for _ in 0..repeat {
        caster.cast(&rays, &mut hits);
        hit += hits.iter().filter(|h| h.is_hit()).count();
    }
    println!(
        "{spec}: {hit} hits in {repeat} casts of {} rays",
        rays.len()
    );
}
