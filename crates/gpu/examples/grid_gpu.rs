//! Runs The Grid with the GPU (hardware occlusion query) backend and, side by side, the
//! software backend, and prints both summaries plus the GPU's queries and wait per frame; the
//! GPU runs with the grid method's object queries and without them (cell queries only).
//!
//! `cargo run --release -p sightline-gpu --example grid_gpu -- [frames] [per_room] [popping 0|1]`

use glam::Vec3;
use sightline_core::{Aabb, Camera};
use sightline_cull::scenes::the_grid;
use sightline_cull::{simulate, OcclusionBackend, SimConfig, SoftwareBackend};
use sightline_gpu::{GpuBackend, GpuFrameStats};

/// Forwards to the GPU backend and sums its per-frame counters (read at each new frame, since
/// `begin_frame` resets them).
struct Counted<'a> {
    gpu: &'a mut GpuBackend,
    frames: u32,
    sum: GpuFrameStats,
}

impl Counted<'_> {
    fn collect(&mut self) {
        let s = self.gpu.stats();
        self.sum.gpu_queries += s.gpu_queries;
        self.sum.cpu_answers += s.cpu_answers;
        self.sum.triangles += s.triangles;
        self.sum.submissions += s.submissions;
        self.sum.wait_ms += s.wait_ms;
    }

    fn per_frame(&mut self) -> String {
        self.collect();
        let n = self.frames.max(1) as f64;
        format!(
            "per frame: {:.0} GPU queries, {:.1} CPU answers, {:.0} occluder triangles, \
             {:.1} submissions, {:.2} ms submit + wait",
            self.sum.gpu_queries as f64 / n,
            self.sum.cpu_answers as f64 / n,
            self.sum.triangles as f64 / n,
            self.sum.submissions as f64 / n,
            self.sum.wait_ms / n
        )
    }
}

impl OcclusionBackend for Counted<'_> {
    fn begin_frame(&mut self, camera: &Camera) {
        if self.frames > 0 {
            self.collect();
        }
        self.frames += 1;
        self.gpu.begin_frame(camera);
    }
    fn draw_depth(&mut self, triangles: &[Vec3]) {
        self.gpu.draw_depth(triangles);
    }
    fn query(&mut self, tag: u32, aabb: &Aabb) {
        self.gpu.query(tag, aabb);
    }
    fn take_results(&mut self, out: &mut Vec<(u32, bool)>) {
        self.gpu.take_results(out);
    }
    fn name(&self) -> &'static str {
        "gpu"
    }
}

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
        // With the grid method's object queries (the default) and without (cells only).
        for object_queries in [true, false] {
            let cfg = SimConfig {
                object_queries,
                ..config
            };
            let mut counted = Counted {
                gpu: &mut gpu,
                frames: 0,
                sum: GpuFrameStats::default(),
            };
            let label = if object_queries { "on" } else { "off" };
            match simulate(&scene, &mut counted, &cfg) {
                Ok(r) => println!(
                    "gpu latency {latency}, object queries {label}: {}\n  object queries {:.0}/frame; {}",
                    r.summary(),
                    r.mean(|f| f64::from(f.object_queries)),
                    counted.per_frame()
                ),
                Err(e) => eprintln!("error: {e}"),
            }
        }
        let mut sw = SoftwareBackend::new(config.width, config.height);
        match simulate(&scene, &mut sw, &config) {
            Ok(r) => println!("sw  latency {latency}: {}", r.summary()),
            Err(e) => eprintln!("error: {e}"),
        }
    }
}
