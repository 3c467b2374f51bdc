//! Measures the GPU ray caster's node widths (2, 4, 8) side by side on one scene: million
//! incoherent and coherent (camera) rays per second, best of 3 alternating rounds. The
//! measurement behind the layout choice in `src/ray_cast.rs`.
//!
//! `cargo run --release -p sightline-gpu --example trace_widths -- [SCENE] [rays]`

use std::time::Instant;

use glam::Vec3;
use sightline_core::scene::{self, LoadOptions};
use sightline_core::trace::measure;
use sightline_core::Camera;
use sightline_gpu::{vulkan_device, GpuRayCaster, GpuRayCasterOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let spec = args
        .next()
        .unwrap_or_else(|| "procedural:city?size=100000".into());
    let n: usize = args.next().map_or(Ok(200_000), |a| a.parse())?;
    let scene = scene::open(&spec, &LoadOptions::default())?;
    let b = scene.bounds();
    let eye = b.center() + Vec3::new(0.6, 0.35, 0.8) * b.diagonal();
    let cam = Camera::look_at(eye, b.center(), scene.up.vector(), 60.0, 512, 512, 0.01)?;
    let coherent = measure::coherent_rays(&cam);
    let incoherent = measure::incoherent_rays(b, n, 7);
    let (device, queue, info) = vulkan_device()?;
    println!(
        "{spec}: {} triangles on {}",
        scene.triangle_count(),
        info.name
    );
    let mut casters = Vec::new();
    for width in [2, 4, 8] {
        let t = Instant::now();
        let options = GpuRayCasterOptions {
            width,
            ..Default::default()
        };
        let c = GpuRayCaster::with_device(&device, &queue, info.clone(), &scene, options)?;
        println!(
            "width {width}: built and uploaded in {:.2} s, stack {}",
            t.elapsed().as_secs_f64(),
            c.stack_needed()
        );
        casters.push(c);
    }
    let mut best = vec![(0.0f64, 0.0f64); casters.len()];
    for _ in 0..3 {
        for (c, b) in casters.iter().zip(&mut best) {
            b.0 = b.0.max(measure::rays_per_second(c, &incoherent, 0.5));
            b.1 = b.1.max(measure::rays_per_second(c, &coherent, 0.5));
        }
    }
    for (c, (inc, coh)) in casters.iter().zip(best) {
        println!(
            "width {}: incoherent {:.2} Mrays/s, coherent {:.2} Mrays/s",
            c.width(),
            inc / 1e6,
            coh / 1e6
        );
    }
    Ok(())
}
