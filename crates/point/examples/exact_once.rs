//! One exact visibility run, for profiling and instruction counts (`perf stat`), which are
//! repeatable on a loaded machine where wall times are not:
//! `cargo run --release -p sightline-point --example exact_once -- SCENE [--no-preculling | --load-only]`.
//! The camera is the analytic bench's bunny view (front, 2.4 radii away, 45°, 1024²).

use glam::Vec3;
use sightline_core::scene::{open, LoadOptions};
use sightline_core::Camera;
use sightline_point::analytic::{visible_fragments, AnalyticOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let spec = args
        .first()
        .ok_or("usage: exact_once SCENE [--no-preculling]")?;
    let scene = open(spec, &LoadOptions::default())?;
    if args.iter().any(|a| a == "--load-only") {
        // For subtracting the loading cost from a whole-process CPU time.
        println!("{} triangles loaded", scene.triangle_count());
        return Ok(());
    }
    let b = scene.bounds();
    let r = 0.5 * b.diagonal();
    let cam = Camera::look_at(
        b.center() + Vec3::new(0.0, 0.0, 2.4 * r),
        b.center(),
        Vec3::Y,
        45.0,
        1024,
        1024,
        0.01 * r,
    )?;
    let options = AnalyticOptions {
        depth_preculling: !args.iter().any(|a| a == "--no-preculling"),
        ..AnalyticOptions::default()
    };
    let result = visible_fragments(&scene, &cam, &options)?;
    let s = &result.stats;
    println!(
        "{} visible of {} in frustum, {} pre-culled in {:?}, {} overlaps, visibility {:?}",
        result.visible.count_ones(..),
        s.triangles_in_frustum,
        s.preculled,
        s.precull_time,
        s.intersections,
        s.visibility_time
    );
    Ok(())
}
