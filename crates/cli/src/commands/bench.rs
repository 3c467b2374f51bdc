//! `sightline bench`: whole-algorithm throughput, measured side by side in one run so that
//! ratios stay meaningful on shared, noisy machines. Prints a Markdown table (or JSON) ready for
//! `docs/BENCHMARKS.md`.

use std::time::Instant;

use anyhow::Result;
use clap::Subcommand;
use serde::Serialize;
use sightline_core::raster::{Frame, Rasterizer};
use sightline_core::scene::{self, LoadOptions};
use sightline_core::trace::{measure, Bvh, RayCaster};
use sightline_core::{Camera, Scene};

use crate::args::default_eye;
use crate::output::print_json;

/// Arguments of `sightline bench`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(Subcommand, Debug)]
enum What {
    /// Ray casting: our BVH (and Embree, when built with `--features embree`), coherent camera
    /// rays and incoherent random rays, million rays per second.
    Trace(TraceArgs),
    /// Reference rasterizer: frame time and triangles per second at a given resolution.
    Raster(RasterArgs),
}

/// Arguments of `sightline bench trace`.
#[derive(clap::Args, Debug)]
struct TraceArgs {
    /// Scenes to measure (default: the procedural city at 1M triangles).
    #[arg(value_name = "SCENE")]
    scenes: Vec<String>,
    /// Incoherent rays per measurement.
    #[arg(long, default_value_t = 1_000_000)]
    rays: usize,
    /// Camera resolution (square) for the coherent rays.
    #[arg(long, default_value_t = 1024)]
    size: u32,
    /// Minimum seconds per measurement (each is repeated until this much time has passed).
    #[arg(long, default_value_t = 1.0)]
    seconds: f64,
    /// Print JSON instead of a Markdown table.
    #[arg(long)]
    json: bool,
}

/// Arguments of `sightline bench raster`.
#[derive(clap::Args, Debug)]
struct RasterArgs {
    /// Scenes to measure (default: the procedural city at 100k and at 1M triangles).
    #[arg(value_name = "SCENE")]
    scenes: Vec<String>,
    /// Image size (square).
    #[arg(long, default_value_t = 1024)]
    size: u32,
    /// Frames per measurement (the median is reported).
    #[arg(long, default_value_t = 10)]
    frames: usize,
    /// Print JSON instead of a Markdown table.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: Args) -> Result<()> {
    match args.what {
        What::Trace(a) => trace(a),
        What::Raster(a) => raster(a),
    }
}

fn load(spec: &str) -> Result<Scene> {
    let scene = scene::open(spec, &LoadOptions::default())?;
    sightline_core::validate::validate(&scene).check()?;
    Ok(scene)
}

fn overview_camera(scene: &Scene, size: u32) -> Result<Camera> {
    let b = scene.bounds();
    let eye = default_eye(scene, b.center(), b.diagonal());
    Ok(Camera::look_at(
        eye,
        b.center(),
        scene.up.vector(),
        60.0,
        size,
        size,
        b.diagonal() * 1e-4,
    )?)
}

#[derive(Serialize)]
struct TraceRow {
    scene: String,
    triangles: usize,
    backend: String,
    build_seconds: f64,
    coherent_mrays: f64,
    incoherent_mrays: f64,
}

fn trace(args: TraceArgs) -> Result<()> {
    let specs = if args.scenes.is_empty() {
        vec!["procedural:city?size=1000000".to_string()]
    } else {
        args.scenes.clone()
    };
    let mut rows = Vec::new();
    for spec in &specs {
        let scene = load(spec)?;
        let camera = overview_camera(&scene, args.size)?;
        let coherent = measure::coherent_rays(&camera);
        let incoherent = measure::incoherent_rays(scene.bounds(), args.rays, 7);
        let mut casters: Vec<(String, f64, Box<dyn RayCaster>)> = Vec::new();
        let t = Instant::now();
        let bvh = Bvh::build(&scene);
        casters.push((
            "sightline BVH".into(),
            t.elapsed().as_secs_f64(),
            Box::new(bvh),
        ));
        #[cfg(feature = "embree")]
        {
            let t = Instant::now();
            let embree = sightline_core::trace::embree::EmbreeCaster::build(&scene)?;
            casters.push((
                "Embree 3".into(),
                t.elapsed().as_secs_f64(),
                Box::new(embree),
            ));
        }
        // Interleave the backends per ray set so both see the same machine load.
        let mut coherent_rates = vec![0.0; casters.len()];
        let mut incoherent_rates = vec![0.0; casters.len()];
        for (i, (_, _, c)) in casters.iter().enumerate() {
            coherent_rates[i] = measure::rays_per_second(c.as_ref(), &coherent, args.seconds);
        }
        for (i, (_, _, c)) in casters.iter().enumerate() {
            incoherent_rates[i] = measure::rays_per_second(c.as_ref(), &incoherent, args.seconds);
        }
        for (i, (name, build, _)) in casters.iter().enumerate() {
            rows.push(TraceRow {
                scene: spec.clone(),
                triangles: scene.triangle_count(),
                backend: name.clone(),
                build_seconds: *build,
                coherent_mrays: coherent_rates[i] / 1e6,
                incoherent_mrays: incoherent_rates[i] / 1e6,
            });
        }
    }
    if args.json {
        return print_json(&rows);
    }
    println!(
        "| scene | triangles | backend | build s | coherent Mrays/s | incoherent Mrays/s | ratio to first (coh / incoh) |"
    );
    println!("|---|---:|---|---:|---:|---:|---:|");
    let mut first: Option<(String, f64, f64)> = None;
    for r in &rows {
        if first.as_ref().is_none_or(|f| f.0 != r.scene) {
            first = Some((r.scene.clone(), r.coherent_mrays, r.incoherent_mrays));
        }
        let (_, fc, fi) = first.clone().unwrap_or_default();
        println!(
            "| `{}` | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} / {:.2} |",
            r.scene,
            r.triangles,
            r.backend,
            r.build_seconds,
            r.coherent_mrays,
            r.incoherent_mrays,
            r.coherent_mrays / fc,
            r.incoherent_mrays / fi
        );
    }
    Ok(())
}

#[derive(Serialize)]
struct RasterRow {
    scene: String,
    triangles: usize,
    size: u32,
    median_ms: f64,
    mtriangles_per_second: f64,
    visible_pixels: usize,
}

fn raster(args: RasterArgs) -> Result<()> {
    let specs = if args.scenes.is_empty() {
        vec![
            "procedural:city?size=100000".to_string(),
            "procedural:city?size=1000000".to_string(),
        ]
    } else {
        args.scenes.clone()
    };
    let mut rows = Vec::new();
    for spec in &specs {
        let scene = load(spec)?;
        let camera = overview_camera(&scene, args.size)?;
        let mut rasterizer = Rasterizer::new(&scene);
        let mut frame = Frame::new(args.size, args.size);
        let mut times = Vec::with_capacity(args.frames.max(1));
        for _ in 0..args.frames.max(1) {
            let t = Instant::now();
            rasterizer.render(&camera, None, &mut frame);
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        let median = times[times.len() / 2];
        rows.push(RasterRow {
            scene: spec.clone(),
            triangles: scene.triangle_count(),
            size: args.size,
            median_ms: median * 1e3,
            mtriangles_per_second: scene.triangle_count() as f64 / median / 1e6,
            visible_pixels: frame
                .ids
                .iter()
                .filter(|&&id| id != sightline_core::Hit::NONE)
                .count(),
        });
    }
    if args.json {
        return print_json(&rows);
    }
    println!("| scene | triangles | size | median ms/frame | Mtriangles/s | covered pixels |");
    println!("|---|---:|---:|---:|---:|---:|");
    for r in &rows {
        println!(
            "| `{}` | {} | {}² | {:.1} | {:.1} | {} |",
            r.scene, r.triangles, r.size, r.median_ms, r.mtriangles_per_second, r.visible_pixels
        );
    }
    Ok(())
}
