//! Runs the culling simulation on a procedural scene and prints a summary per method.
//!
//! `cargo run --release -p sightline-cull --example simulate -- [grid|graveyard] [frames]
//! [latency 0|1] [popping 0|1] [tight boxes 0|1] [object tests 0|1] [grid|all]
//! [triangle tests 0|1] [larger pre-pass cap for tested objects 0|1] [sort cell objects 0|1]
//! [retest 0|1]`; `DIAG=1` breaks the drawn objects that are not visible down by
//! cause.

use sightline_cull::scenes::{graveyard, the_grid};
use sightline_cull::{simulate_methods, Method, SimConfig, SoftwareBackend};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("grid", String::as_str);
    let flag = |i: usize| args.get(i).and_then(|s| s.parse::<u32>().ok());
    let mut config = SimConfig::default();
    if let Some(n) = flag(2) {
        config.frames = n;
    }
    if let Some(l) = flag(3) {
        config.latency = l;
    }
    if let Some(p) = flag(4) {
        config.measure_popping = p != 0;
    }
    if let Some(p) = flag(5) {
        config.tight_query_boxes = p != 0;
    }
    if let Some(p) = flag(6) {
        config.object_tests = p != 0;
    }
    if let Some(p) = flag(8) {
        config.triangle_tests = p != 0;
    }
    if let Some(p) = flag(9) {
        if p == 0 {
            config.tested_prepass_cap = 0;
        }
    }
    if let Some(p) = flag(10) {
        config.sort_cell_objects = p != 0;
    }
    if let Some(p) = flag(11) {
        config.retest = p != 0;
    }
    // DIAG=1: break the drawn objects that are not visible down by cause.
    config.diagnose = std::env::var("DIAG").is_ok_and(|v| v == "1");
    let methods: &[Method] = match args.get(7).map(String::as_str) {
        Some("grid") => &[Method::Grid],
        _ => &Method::ALL,
    };
    let mut scene = match name {
        "graveyard" => graveyard(1, 5000),
        _ => the_grid(1, 40),
    };
    // Tuning experiments: CELL=x,y,z (grid cell size), VIS=frames (visible duration), CAP=objects
    // (depth pre-pass cap).
    if let Ok(c) = std::env::var("CELL") {
        let v: Vec<f32> = c.split(',').filter_map(|s| s.parse().ok()).collect();
        if let [x, y, z] = v[..] {
            scene.cell_size = glam::Vec3::new(x, y, z);
        }
    }
    if let Some(v) = std::env::var("CAP").ok().and_then(|s| s.parse().ok()) {
        config.scheduler.depth_prepass_cap = v;
    }
    if let Some(v) = std::env::var("VIS").ok().and_then(|s| s.parse().ok()) {
        config.scheduler.visible_duration = v;
    }
    let mut backend = SoftwareBackend::new(config.width, config.height);
    match simulate_methods(&scene, &mut backend, &config, methods) {
        Ok(reports) => {
            for r in reports {
                println!("{name} latency {}: {}", config.latency, r.summary());
                let visible = r.mean(|f| f64::from(f.exact_visible));
                if visible > 0.0 {
                    println!(
                        "  drawn per exactly visible {:.3}",
                        r.mean(|f| f64::from(f.drawn)) / visible
                    );
                }
                if config.diagnose {
                    let causes: Vec<String> = r
                        .extra_means()
                        .iter()
                        .map(|(n, v)| format!("{n} {v:.2}"))
                        .collect();
                    println!("  not visible but drawn, by cause: {}", causes.join(", "));
                }
            }
        }
        Err(e) => eprintln!("error: {e}"),
    }
}
