//! `sightline cull`: run-time occlusion culling along a camera path through a scene with moving
//! objects: the grid method of Seletsky 2013 (uniform grid, occlusion-order traversal, query
//! scheduling) and the baselines (frustum only, stop-and-wait per-object queries, two-phase
//! hierarchical Z) over the same frames, measured against the reference rasterizer's image:
//! objects drawn, queries, cells, culling time, popping. Prints a summary table (or JSON) and
//! optionally writes an SVG plot per frame.
//!
//! Scenes: `procedural:grid` (The Grid, `?seed=S&size=N`: N moving boxes per room, default
//! 40) and `procedural:graveyard` (Teapot Graveyard, `size` = teapots, default 5000) come with
//! their own motion and camera path; any other scene spec is loaded and animated by
//! `sightline_cull::scenes::animate` (small objects sway sideways; documented there) with a
//! default walk through its bounds; such a scene goes through the same validation as in every
//! other command (no triangles, bad indices or NaN coordinates are an error). `--path
//! camera.json` replaces the path:
//! `{"frames": [{"eye": [x, y, z], "look": [x, y, z]}, ...]}`, interpolated linearly when it
//! has fewer keyframes than frames; `--eye X,Y,Z --look X,Y,Z` (and `--fov`, as in `render`)
//! hold the camera still instead.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use glam::{Quat, Vec3};
use serde::Serialize;
use sightline_core::camera_path::{interpolate, read_camera_path};
use sightline_core::scene::{self, LoadOptions};
use sightline_core::validate::validate;
use sightline_core::{Camera, NearPlaneRule};
use sightline_cull::scenes::{animate, walk_keys, CullScene};
use sightline_cull::{
    simulate_methods_with_cameras, FrameStats, Method, SimConfig, SimReport, SoftwareBackend,
};

use crate::args::{parse_size, parse_vec3, print_load_warnings, LoadLimitArgs};
use crate::output::print_json;

/// Arguments of `sightline cull`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// `procedural:grid`, `procedural:graveyard` (each `?seed=S&size=N`) or any scene spec.
    #[arg(value_name = "SCENE", default_value = "procedural:grid")]
    scene: String,
    /// Camera path JSON: `{"frames": [{"eye": [x,y,z], "look": [x,y,z]}, ...]}`.
    #[arg(long, value_name = "FILE", conflicts_with = "eye")]
    path: Option<PathBuf>,
    /// A camera standing still at `x,y,z` for every frame (with --look), as in `render`; the
    /// objects still move. Default: the scene's own path, or a walk through its bounds.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true,
        requires = "look")]
    eye: Option<Vec3>,
    /// The point the --eye camera looks at.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true,
        requires = "eye")]
    look: Option<Vec3>,
    /// Vertical field of view in degrees.
    #[arg(long, value_name = "DEG", default_value_t = SimConfig::default().fov_y_deg)]
    fov: f32,
    /// Occlusion backend: `sw` (the software occlusion buffer) or `gpu` (wgpu, Vulkan hardware
    /// occlusion queries; needs a Vulkan driver such as Mesa's lavapipe).
    #[arg(long, default_value = "sw")]
    backend: String,
    /// Frames to simulate (30 per second of the scene's clock; at most 1,000,000).
    #[arg(long, default_value_t = 300)]
    frames: u32,
    /// Image and occlusion buffer size `WxH`.
    #[arg(long, value_name = "WxH", default_value = "640x360", value_parser = parse_size)]
    size: (u32, u32),
    /// Print JSON (summary and per-frame numbers of every method) instead of the table.
    #[arg(long)]
    json: bool,
    /// Write an SVG plot of objects drawn, queries and popping pixels per frame.
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    #[command(flatten)]
    limits: LoadLimitArgs,
}

/// Per-method summary of a run.
#[derive(Serialize, Debug)]
struct Summary {
    method: &'static str,
    frames: usize,
    drawn_mean: f64,
    drawn_max: u32,
    exact_visible_mean: f64,
    drawn_per_visible: f64,
    queries_mean: f64,
    queries_max: u32,
    cells_mean: f64,
    cells_max: u32,
    cull_ms_mean: f64,
    cull_ms_max: f64,
    popping_percent_mean: f64,
    popping_percent_max: f64,
    longest_missing_streak: usize,
}

#[derive(Serialize)]
struct Output<'a> {
    scene: &'a str,
    backend: &'a str,
    frames: u32,
    width: u32,
    height: u32,
    objects: u32,
    summaries: Vec<Summary>,
    per_frame: Vec<MethodFrames<'a>>,
}

#[derive(Serialize)]
struct MethodFrames<'a> {
    method: &'static str,
    frames: &'a [FrameStats],
}

pub(crate) fn run(args: Args) -> Result<()> {
    if args.backend != "sw" && args.backend != "gpu" {
        bail!("unknown backend {:?}: use `sw` (software occlusion buffer) or `gpu` (Vulkan occlusion queries)", args.backend);
    }
    if args.backend == "gpu" {
        crate::features::require_gpu("--backend gpu")?;
    }
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    if !(args.fov.is_finite() && args.fov > 0.0 && args.fov < 180.0) {
        bail!("--fov {}: expected degrees between 0 and 180", args.fov);
    }
    crate::limits::check_frames(u64::from(args.frames), "--frames")?;
    if let Some(plot) = &args.plot {
        let mut inputs = vec![std::path::Path::new(&args.scene)];
        inputs.extend(args.path.as_deref());
        crate::output::refuse_overwriting_inputs(&[plot], &inputs)?;
    }
    let (width, height) = args.size;
    let scene = load_scene(
        &args.scene,
        &args
            .limits
            .options(LoadOptions::default().patch_subdivisions),
    )?;
    let config = SimConfig {
        frames: args.frames,
        width,
        height,
        // The software backend answers at once, but the thesis' design reads results a frame
        // later (as hardware queries must); keep its latency so the popping is the design's.
        latency: 1,
        fov_y_deg: args.fov,
        ..SimConfig::default()
    };
    let source = match (&args.path, args.eye.zip(args.look)) {
        (Some(path), _) => CameraSource::Path(path),
        (None, Some(pose)) => CameraSource::Fixed(pose),
        (None, None) => CameraSource::Default,
    };
    let cameras = cameras(&args.scene, source, &scene, &config)?;
    // On the GPU every stop-and-wait query is its own submission (hundreds of ms per frame on
    // a software Vulkan driver), so the GPU run has the grid method and frustum culling only.
    let (mut backend, methods): (Box<dyn sightline_cull::OcclusionBackend>, &[Method]) =
        if args.backend == "gpu" {
            (gpu_backend()?, &[Method::Grid, Method::Frustum])
        } else {
            (Box::new(SoftwareBackend::new(width, height)), &Method::ALL)
        };
    let reports = simulate_with_progress(&scene, &cameras, &mut *backend, &config, methods)
        .with_context(|| format!("simulating {}", args.scene))?;
    let summaries: Vec<Summary> = reports.iter().map(summarize).collect();
    if let Some(plot) = &args.plot {
        write_plot(plot, &reports, &args.scene)?;
    }
    if args.json {
        return print_json(&Output {
            scene: &args.scene,
            backend: &args.backend,
            frames: args.frames,
            width,
            height,
            objects: reports.first().map_or(0, |r| r.objects),
            per_frame: reports
                .iter()
                .map(|r| MethodFrames {
                    method: r.method.name(),
                    frames: &r.frames,
                })
                .collect(),
            summaries,
        });
    }
    outln!(
        "{}: {} objects, {} frames at {width}x{height}, backend {}",
        args.scene,
        reports.first().map_or(0, |r| r.objects),
        args.frames,
        args.backend
    );
    outln!(
        "| method | drawn mean | drawn max | exact visible | drawn/visible | queries mean | \
         queries max | cells mean | cells max | cull ms mean | cull ms max | popping % mean | \
         popping % max | longest missing streak |"
    );
    outln!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for s in &summaries {
        outln!(
            "| {} | {:.1} | {} | {:.1} | {:.2} | {:.1} | {} | {:.1} | {} | {:.3} | {:.3} | {:.4} | \
             {:.3} | {} |",
            s.method,
            s.drawn_mean,
            s.drawn_max,
            s.exact_visible_mean,
            s.drawn_per_visible,
            s.queries_mean,
            s.queries_max,
            s.cells_mean,
            s.cells_max,
            s.cull_ms_mean,
            s.cull_ms_max,
            s.popping_percent_mean,
            s.popping_percent_max,
            s.longest_missing_streak
        );
    }
    if let Some(plot) = &args.plot {
        outln!("plot: {}", plot.display());
    }
    Ok(())
}

/// Simulates `methods` along `cameras` with a progress bar of the frames on stderr (every
/// method culls each frame before the next one starts). Returns one report per method.
fn simulate_with_progress(
    scene: &CullScene,
    cameras: &[Camera],
    backend: &mut dyn sightline_cull::OcclusionBackend,
    config: &SimConfig,
    methods: &[Method],
) -> Result<Vec<SimReport>, sightline_cull::GridError> {
    let bar = crate::progress::bar(
        u64::from(config.frames),
        &crate::progress::template("frames"),
    );
    bar.set_message(format!("{} methods each", methods.len()));
    // The simulation asks for frame f's camera once, when the frame starts.
    let camera_of = |f: u32| {
        bar.set_position(u64::from(f));
        cameras.get(f as usize).copied()
    };
    let reports = simulate_methods_with_cameras(scene, &camera_of, backend, config, methods);
    bar.finish_and_clear();
    reports
}

/// `procedural:grid` / `procedural:graveyard` with `?seed=&size=`, or any scene spec animated
/// (loaded with `options` and validated as every command does).
pub(crate) fn load_scene(spec: &str, options: &LoadOptions) -> Result<CullScene> {
    if let Some(ours) = crate::cull_scenes::procedural(spec) {
        return ours;
    }
    let loaded = scene::open(spec, options).with_context(|| format!("loading scene {spec}"))?;
    print_load_warnings(spec, &loaded);
    // The check of `SceneArgs::load`: NaN coordinates or bad indices would reach the
    // rasterizer and the grid otherwise.
    if let Err(e) = validate(&loaded).check() {
        bail!("{spec}: {e}");
    }
    Ok(animate(loaded))
}

/// The camera of every frame: from `--path`, else the procedural scene's own path, else a
/// walk through the scene's bounds.
/// The GPU occlusion backend (Vulkan occlusion queries).
#[cfg(feature = "gpu")]
fn gpu_backend() -> Result<Box<dyn sightline_cull::OcclusionBackend>> {
    crate::headless::quiet_vulkan_layers();
    Ok(Box::new(
        sightline_gpu::GpuBackend::new().context("--backend gpu")?,
    ))
}

/// A headless build has no GPU backend (`run` refuses `--backend gpu` before loading).
#[cfg(not(feature = "gpu"))]
fn gpu_backend() -> Result<Box<dyn sightline_cull::OcclusionBackend>> {
    Err(crate::features::not_built("gpu", "--backend gpu"))
}

/// Where `cull`'s cameras come from.
#[derive(Clone, Copy, Debug)]
pub(crate) enum CameraSource<'a> {
    /// A camera path file (`--path`).
    Path(&'a Path),
    /// One camera for every frame (`--eye`, `--look`).
    Fixed((Vec3, Vec3)),
    /// The procedural scene's own path, else a walk through the bounds.
    Default,
}

/// (`sightline bench peers` takes the same cameras for its real occluder sets.)
pub(crate) fn cameras(
    spec: &str,
    source: CameraSource<'_>,
    scene: &CullScene,
    config: &SimConfig,
) -> Result<Vec<Camera>> {
    let up = scene.scene.up.vector();
    let (w, h, fov) = (config.width, config.height, config.fov_y_deg);
    let bounds = scene.scene.bounds();
    let n = config.frames as usize;
    // (eye, look) per frame.
    let poses: Vec<(Vec3, Vec3)> = if let CameraSource::Fixed(pose) = source {
        vec![pose; n]
    } else if let CameraSource::Path(path) = source {
        // The viewer reads the same path files (`sightline view --path`).
        let keys = read_camera_path(path)?;
        (0..n).map(|f| interpolate(&keys, f, n)).collect()
    } else if scene.scene.source.starts_with("procedural:grid")
        || scene.scene.source.starts_with("procedural:graveyard")
    {
        return (0..config.frames)
            .map(|f| {
                scene
                    .path
                    .camera(f as f32 / config.fps, w, h, fov)
                    .context("the scene's camera path gave no camera")
            })
            .collect();
    } else {
        // A walk through the bounds, looking around (see `animate`).
        let (start, end) = walk_keys(&bounds, up);
        let dir = (end - start).normalize_or(Vec3::X);
        (0..n)
            .map(|f| {
                let t = f as f32 / config.fps;
                let s = if n > 1 {
                    f as f32 / (n - 1) as f32
                } else {
                    0.0
                };
                let eye = start.lerp(end, s);
                let yaw = 40f32.to_radians() * (std::f32::consts::TAU * t / 8.0).sin();
                (eye, eye + Quat::from_axis_angle(up, yaw) * dir)
            })
            .collect()
    };
    let near = if spec.starts_with("procedural:grid") || spec.starts_with("procedural:graveyard") {
        // These scenes' own scale (a person-height camera on a street), kept for a --path.
        0.1
    } else {
        // One near plane for the whole path, by the default rule at every eye on it.
        let eyes: Vec<Vec3> = poses.iter().map(|&(eye, _)| eye).collect();
        NearPlaneRule::new(&scene.scene).along(&eyes)
    };
    poses
        .into_iter()
        .enumerate()
        .map(|(f, (eye, look))| {
            Camera::look_at(eye, look, up, fov, w, h, near).with_context(|| match source {
                CameraSource::Path(path) => format!(
                    "{}: frame {f}: no camera from eye {eye} looking at {look} (eye equal to \
                     look, or looking along the up axis?)",
                    path.display()
                ),
                CameraSource::Fixed(_) => format!(
                    "--eye {eye} --look {look}: no camera (the same point, or looking along the \
                     scene's up axis?)"
                ),
                CameraSource::Default => "default camera path".to_string(),
            })
        })
        .collect()
}

fn summarize(r: &SimReport) -> Summary {
    let frames = r.measured();
    let pixels = r.pixels.max(1) as f64;
    let max_u = |g: fn(&FrameStats) -> u32| frames.iter().map(g).max().unwrap_or(0);
    let drawn_mean = r.mean(|f| f.drawn as f64);
    let exact = r.mean(|f| f.exact_visible as f64);
    Summary {
        method: r.method.name(),
        frames: frames.len(),
        drawn_mean,
        drawn_max: max_u(|f| f.drawn),
        exact_visible_mean: exact,
        drawn_per_visible: if exact > 0.0 { drawn_mean / exact } else { 0.0 },
        queries_mean: r.mean(|f| f.queries as f64),
        queries_max: max_u(|f| f.queries),
        cells_mean: r.mean(|f| f.cells as f64),
        cells_max: max_u(|f| f.cells),
        cull_ms_mean: r.mean(|f| f.cull_ms),
        cull_ms_max: frames.iter().map(|f| f.cull_ms).fold(0.0, f64::max),
        popping_percent_mean: r.mean(|f| f.popping_pixels as f64) / pixels * 100.0,
        popping_percent_max: max_u(|f| f.popping_pixels) as f64 / pixels * 100.0,
        longest_missing_streak: r.max_streak(),
    }
}

/// Three panels over the frames: objects drawn, queries, popping pixels; one line per method.
fn write_plot(path: &Path, reports: &[SimReport], title: &str) -> Result<()> {
    use plotters::prelude::*;

    type Pick = fn(&FrameStats) -> f64;
    let panels: [(&str, Pick); 3] = [
        ("objects drawn", |f| f.drawn as f64),
        ("queries", |f| f.queries as f64),
        ("popping pixels", |f| f.popping_pixels as f64),
    ];
    let colours = [RED, BLUE, GREEN, MAGENTA, CYAN];
    let root = SVGBackend::new(path, (1000, 900)).into_drawing_area();
    let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
        root.fill(&WHITE)?;
        let areas = root.split_evenly((3, 1));
        let n = reports
            .iter()
            .map(|r| r.frames.len())
            .max()
            .unwrap_or(1)
            .max(2);
        for (i, (area, (label, pick))) in areas.iter().zip(panels).enumerate() {
            let ymax = reports
                .iter()
                .flat_map(|r| r.frames.iter().map(pick))
                .fold(1.0, f64::max);
            let caption = if i == 0 {
                format!("{title}: {label}")
            } else {
                label.to_string()
            };
            let mut chart = ChartBuilder::on(area)
                .caption(caption, ("sans-serif", 18))
                .margin(8)
                .x_label_area_size(28)
                .y_label_area_size(60)
                .build_cartesian_2d(0..n, 0.0..ymax * 1.05)?;
            chart.configure_mesh().x_desc("frame").draw()?;
            for (r, colour) in reports.iter().zip(colours.iter().cycle()) {
                chart
                    .draw_series(LineSeries::new(
                        r.frames.iter().enumerate().map(|(f, s)| (f, pick(s))),
                        colour,
                    ))?
                    .label(r.method.name())
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()?;
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| anyhow::anyhow!("writing plot {}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::camera_path::Keyframe;

    fn key(x: f32) -> Keyframe {
        Keyframe {
            eye: [x, 0.0, 1.0],
            look: [x + 1.0, 0.0, 1.0],
        }
    }

    #[test]
    fn interpolation_spreads_keyframes_over_frames() {
        let keys = [key(0.0), key(10.0)];
        assert_eq!(interpolate(&keys, 0, 11).0.x, 0.0);
        assert!((interpolate(&keys, 5, 11).0.x - 5.0).abs() < 1e-5);
        assert_eq!(interpolate(&keys, 10, 11).0.x, 10.0);
        assert_eq!(interpolate(&[key(3.0)], 7, 11).0.x, 3.0);
    }

    fn load_scene(spec: &str) -> Result<CullScene> {
        super::load_scene(spec, &LoadOptions::default())
    }

    #[test]
    fn procedural_specs_parse_and_reject_bad_parameters() {
        assert!(load_scene("procedural:grid?seed=2&size=1").is_ok());
        assert!(load_scene("procedural:grid?size=x").is_err());
        assert!(load_scene("procedural:grid?colour=red").is_err());
        assert!(load_scene("procedural:graveyard?size=99999999").is_err());
    }

    #[test]
    fn nan_vertex_scene_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("nan.obj");
        std::fs::write(&p, "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n").unwrap();
        let e = load_scene(&p.to_string_lossy()).err().unwrap();
        assert!(format!("{e:#}").contains("NaN"), "{e:#}");
    }
}
