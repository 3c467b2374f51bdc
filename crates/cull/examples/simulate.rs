//! Runs the culling simulation on a procedural scene and prints a summary.
//!
//! `cargo run --release -p sightline-cull --example simulate -- [grid|graveyard] [frames]
//! [latency 0|1] [popping 0|1]`

use sightline_cull::scenes::{graveyard, the_grid};
use sightline_cull::{simulate, SimConfig, SoftwareBackend};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("grid", String::as_str);
    let mut config = SimConfig::default();
    if let Some(n) = args.get(2).and_then(|s| s.parse().ok()) {
        config.frames = n;
    }
    if let Some(l) = args.get(3).and_then(|s| s.parse().ok()) {
        config.latency = l;
    }
    if let Some(p) = args.get(4).and_then(|s| s.parse::<u32>().ok()) {
        config.measure_popping = p != 0;
    }
    let scene = match name {
        "graveyard" => graveyard(1, 5000),
        _ => the_grid(1, 40),
    };
    let mut backend = SoftwareBackend::new(config.width, config.height);
    match simulate(&scene, &mut backend, &config) {
        Ok(report) => println!("{name} latency {}: {}", config.latency, report.summary()),
        Err(e) => eprintln!("error: {e}"),
    }
}
