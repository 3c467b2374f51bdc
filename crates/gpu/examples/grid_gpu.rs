//! Runs The Grid with the GPU (hardware occlusion query) backend and, side by side, the
//! software backend, and prints both summaries plus the GPU's queries and wait per frame.
//!
//! `cargo run --release -p sightline-gpu --example grid_gpu -- [frames] [per_room] [popping 0|1]`

use sightline_cull::scenes::the_grid;
use sightline_cull::{simulate, SimConfig, SoftwareBackend};
use sightline_gpu::GpuBackend;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mut config = SimConfig::default();
    if let Some(n) = args.get(1).and_then(|s| s.parse().ok()) {
        config.frames = n;
    }
    let per_room = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(40);
    if let Some(p) = args.get(3).and_then(|s| s.parse::<u32>().ok()) {
        config.measure_popping = p != 0;
    }
    let scene = the_grid(1, per_room);
    let mut gpu = match GpuBackend::new() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let info = gpu.adapter_info().clone();
    println!(
        "The Grid, {} objects, {}x{}, {} frames, adapter {} ({:?})",
        scene.scene.objects.len(),
        config.width,
        config.height,
        config.frames,
        info.name,
        info.backend
    );
    for latency in [1, 0] {
        config.latency = latency;
        match simulate(&scene, &mut gpu, &config) {
            Ok(r) => println!("gpu latency {latency}: {}", r.summary()),
            Err(e) => eprintln!("error: {e}"),
        }
        let mut sw = SoftwareBackend::new(config.width, config.height);
        match simulate(&scene, &mut sw, &config) {
            Ok(r) => println!("sw  latency {latency}: {}", r.summary()),
            Err(e) => eprintln!("error: {e}"),
        }
    }
}
