//! `sightline demo`: the main job on the embedded default scene, ending in
//! `sightline-report/index.html`: it generates and validates the city, builds the ray-casting
//! BVH, renders views with the reference rasterizer, cross-checks them against ray casting,
//! computes the sampled, exact and conservative from-point sets, bakes a PVS for a few view
//! cells with GVS++ (and RAND at equal rays), measures both with the GVS++ paper's pixel error,
//! and runs a short culling camera path with moving objects. The page is built by the same
//! report builder as `sightline report` (`crate::report`), plus the demo's own sections
//! (`demo_sections.rs`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use glam::{Quat, Vec3};
use image::RgbImage;
use indicatif::{ProgressBar, ProgressStyle};
use sightline_core::atomic_file::write_atomic;
use sightline_core::raster;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::validate::validate;
use sightline_core::{Aabb, Camera, Hit, NearPlaneRule, Ray, Scene, TriangleSet};
use sightline_cull::scenes::{animate, walk_keys};
use sightline_cull::{
    simulate_methods_with_cameras, Method, SimConfig, SimReport, SoftwareBackend,
};
use sightline_eval::EvalParams;
use sightline_region::bake::{bake, cell_seed};
use sightline_region::cell_sources::random_free_cells;
use sightline_region::{
    Budget, CellContext, ConvergencePoint, GvsPlusPlus, GvsPlusPlusParams, PvsFile, RandomSampler,
    Sampler, ViewCell,
};

use super::demo_sections::{self as ds, FromPoint, Step};
use crate::args::{default_eye, SceneArgs};
use crate::output::{id_image, save_png};
use sightline_eval::report::html::{page, Section};
use sightline_eval::report::shading::shaded_image;
use sightline_eval::report::{pvs_report, CellOutcome, PvsReport, PvsReportOptions};

/// Arguments of `sightline demo`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Directory for the report.
    #[arg(short, long, default_value = "sightline-report")]
    output: PathBuf,
    /// Image size of the rendered views: square, one number (or NxN); the evaluation uses at
    /// most 256.
    #[arg(long, value_name = "PX", default_value = "512", value_parser = crate::args::parse_square_size)]
    size: u32,
    /// View cells baked.
    #[arg(long, default_value_t = 3)]
    cells: usize,
    /// GVS++ random rays per round (the paper uses 10M; the demo stays quick).
    #[arg(long, default_value_t = 500_000)]
    n_rand: u64,
    /// Viewpoints per cell of the pixel-error evaluation (six cube faces each).
    #[arg(long, default_value_t = 8)]
    views: usize,
    /// Frames of the culling camera path (30 per second; at most 1,000,000).
    #[arg(long, default_value_t = 90)]
    frames: u32,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: Args) -> Result<()> {
    prepare_output(&args)?;
    let mut log = StepLog::new();
    let scene = load_scene(&args, &mut log)?;
    let bvh = build_bvh(&scene, &mut log);
    let overview = render_overview(&args, &scene, &mut log)?;
    check_rasterizer(&bvh, &overview, &mut log);
    let cube_images = street_cube_map(&args, &scene, &overview.view, &mut log)?;
    let from_point = from_point_sets(&scene, &overview.view, &mut log)?;
    let baked = bake_pvs(&args, &scene, &bvh, &overview.view, &mut log)?;
    let pvs = evaluate_pvs(&args, &scene, &baked, &mut log)?;
    let culling = simulate_culling(&args, &scene, &overview.view, &mut log)?;
    log.progress.set_message("writing the report");
    let mut sections = vec![
        ds::steps(&log.steps),
        ds::overview(&overview.images, &cube_images)?,
        ds::from_point(&from_point),
    ];
    sections.extend(pvs.sections);
    sections.push(ds::gvspp_vs_rand(&pvs.outcomes, args.size.min(256)));
    sections.push(ds::culling(&culling)?);
    let index = write_page(&args, &scene, &sections)?;
    log.progress.finish_and_clear();
    print_summary(&args, &scene, &log.steps, &index, &baked)
}

/// The demo's steps so far, and the progress bar that counts them.
struct StepLog {
    progress: ProgressBar,
    steps: Vec<Step>,
}

impl StepLog {
    /// Nine steps: load, BVH, overview, cross-check, cube map, from-point, bake, evaluation
    /// and culling (writing the page is not one).
    fn new() -> Self {
        let progress = ProgressBar::new(9).with_style(
            ProgressStyle::with_template("{spinner} [{bar:30}] {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        Self {
            progress,
            steps: Vec::new(),
        }
    }

    /// Starts a step: shows `message` and returns its start time.
    fn start(&self, message: &'static str) -> Instant {
        self.progress.set_message(message);
        Instant::now()
    }

    /// Records a finished step that began at `start`.
    fn finish(&mut self, name: &str, start: Instant, result: String) {
        self.progress.inc(1);
        self.steps.push(Step {
            name: name.into(),
            seconds: start.elapsed().as_secs_f64(),
            result,
        });
    }
}

/// Refuses bad sizes and outputs that would overwrite the scene, then creates the directory.
fn prepare_output(args: &Args) -> Result<()> {
    if args.size == 0 || args.size > 4096 || args.frames == 0 || args.views == 0 {
        anyhow::bail!("--size must be in 1..=4096, --frames and --views at least 1");
    }
    crate::limits::check_frames(u64::from(args.frames), "--frames")?;
    crate::output::refuse_overwriting_inputs(
        &[&args.output, &args.output.join("demo.pvs")],
        &[std::path::Path::new(&args.scene.scene)],
    )?;
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("creating {}", args.output.display()))
}

/// Loads the scene and validates it (the warnings are counted, not fatal).
fn load_scene(args: &Args, log: &mut StepLog) -> Result<Scene> {
    let t = log.start("loading scene");
    let scene = args.scene.load()?;
    let report = validate(&scene);
    log.finish(
        "load + validate",
        t,
        format!(
            "{} triangles, {} objects, {} warnings",
            scene.triangle_count(),
            scene.objects.len(),
            report.warnings().len()
        ),
    );
    Ok(scene)
}

/// The ray-casting BVH every later ray-based step shares.
fn build_bvh(scene: &Scene, log: &mut StepLog) -> Bvh {
    let t = log.start("building BVH");
    let bvh = Bvh::build(scene);
    log.finish("BVH build", t, "SAH BVH over all triangles".into());
    bvh
}

/// Where the demo looks from: the overview eye above the scene, and the near-plane rule the
/// later steps apply to their own eyes.
struct View<'a> {
    bounds: Aabb,
    up: Vec3,
    center: Vec3,
    eye: Vec3,
    near_rule: NearPlaneRule<'a>,
    /// The near plane at `eye`.
    near: f32,
}

/// The overview camera's render, shaded and as triangle ids.
struct Overview<'a> {
    view: View<'a>,
    camera: Camera,
    ids: Vec<u32>,
    images: [RgbImage; 2],
}

/// Renders the overview (saved as `overview.png` and `overview_ids.png`) and fixes the view.
fn render_overview<'a>(args: &Args, scene: &'a Scene, log: &mut StepLog) -> Result<Overview<'a>> {
    let t = log.start("rendering overview");
    let bounds = scene.bounds();
    let up = scene.up.vector();
    let center = bounds.center();
    let eye = default_eye(scene, center, bounds.diagonal());
    let near_rule = NearPlaneRule::new(scene);
    let near = near_rule.at(eye);
    let camera = Camera::look_at(eye, center, up, 60.0, args.size, args.size, near)?;
    let frame = raster::render(scene, &camera);
    let images = [shaded_image(&frame, scene, &camera), id_image(&frame)];
    save_png(&images[0], &args.output.join("overview.png"))?;
    save_png(&images[1], &args.output.join("overview_ids.png"))?;
    let visible = visible_set(&frame.ids, scene.triangle_count());
    log.finish(
        "render overview",
        t,
        format!(
            "{} triangles visible from the overview camera",
            visible.count_ones(..)
        ),
    );
    Ok(Overview {
        view: View {
            bounds,
            up,
            center,
            eye,
            near_rule,
            near,
        },
        camera,
        ids: frame.ids,
        images,
    })
}

/// One ray per overview pixel centre: the rasterizer and ray casting should see the same
/// triangle almost everywhere.
fn check_rasterizer(bvh: &Bvh, overview: &Overview<'_>, log: &mut StepLog) {
    let t = log.start("cross-checking rasterizer with ray casting");
    let (agree, total) = cross_check(bvh, &overview.camera, &overview.ids);
    log.finish(
        "rasterizer vs ray casting",
        t,
        format!(
            "{agree} of {total} pixel centres agree ({:.3}%)",
            100.0 * agree as f64 / total.max(1) as f64
        ),
    );
}

/// Six half-size views from street level at the scene's centre: their images.
fn street_cube_map(
    args: &Args,
    scene: &Scene,
    view: &View<'_>,
    log: &mut StepLog,
) -> Result<Vec<RgbImage>> {
    let t = log.start("cube map from street level");
    let street_eye = view.center + view.up * (view.bounds.extent().dot(view.up) * 0.02 + 1.7);
    let mut cube_visible = TriangleSet::with_capacity(scene.triangle_count());
    let mut cube_images = Vec::new();
    let near = view.near_rule.at(street_eye);
    for (i, face) in Camera::cube_faces(street_eye, args.size / 2, near)?
        .iter()
        .enumerate()
    {
        let f = raster::render(scene, face);
        cube_visible.union_with(&visible_set(&f.ids, scene.triangle_count()));
        let img = shaded_image(&f, scene, face);
        save_png(&img, &args.output.join(format!("cube{i}.png")))?;
        cube_images.push(img);
    }
    log.finish(
        "cube map at street level",
        t,
        format!(
            "{} of {} triangles visible ({:.2}%)",
            cube_visible.count_ones(..),
            scene.triangle_count(),
            100.0 * cube_visible.count_ones(..) as f64 / scene.triangle_count().max(1) as f64
        ),
    );
    Ok(cube_images)
}

/// The sampled, exact and conservative sets from the overview eye at 256², each timed.
fn from_point_sets(scene: &Scene, view: &View<'_>, log: &mut StepLog) -> Result<FromPoint> {
    let t = log.start("exact and conservative visible sets from the overview point");
    let small = Camera::look_at(view.eye, view.center, view.up, 60.0, 256, 256, view.near)?;
    let ts = Instant::now();
    let sampled = visible_set(&raster::render(scene, &small).ids, scene.triangle_count());
    let sampled_s = ts.elapsed().as_secs_f64();
    let te = Instant::now();
    let exact = sightline_point::analytic::visible_fragments(
        scene,
        &small,
        &sightline_point::analytic::AnalyticOptions::default(),
    )?;
    let exact_s = te.elapsed().as_secs_f64();
    let tc = Instant::now();
    let rv = sightline_point::rv::conservative_visible(
        &mut sightline_point::rv::SceneSource::new(scene),
        &small,
        &sightline_point::rv::RvOptions::default(),
    )?;
    let rv_s = tc.elapsed().as_secs_f64();
    let from_point = FromPoint {
        resolution: 256,
        sampled: (sampled.count_ones(..), sampled_s),
        exact: (exact.visible.count_ones(..), exact_s),
        conservative: (rv.visible.count_ones(..), rv_s),
        sampled_not_exact: sampled.difference(&exact.visible).count(),
        exact_not_conservative: exact.visible.difference(&rv.visible).count(),
        rv_peak_mib: rv.peak_memory_bytes as f64 / 1048576.0,
    };
    log.finish(
        "from-point: sampled / exact / conservative",
        t,
        format!(
            "{} / {} / {} triangles at 256² (exact ⊆ conservative: {}; RV peak memory {:.1} MiB)",
            from_point.sampled.0,
            from_point.exact.0,
            from_point.conservative.0,
            from_point.exact_not_conservative == 0,
            from_point.rv_peak_mib
        ),
    );
    Ok(from_point)
}

/// The demo's PVS: the GVS++ file (saved as `demo.pvs`) and RAND's sets at equal rays.
struct BakedPvs {
    file: PvsFile,
    path: PathBuf,
    /// RAND's set of each cell (one extra set per cell for the evaluation).
    rand_sets: Vec<Vec<TriangleSet>>,
    /// `{"gvspp_rays", "rand_rays"}` per cell.
    equal_rays: Vec<serde_json::Value>,
}

fn bake_pvs(
    args: &Args,
    scene: &Scene,
    bvh: &Bvh,
    view: &View<'_>,
    log: &mut StepLog,
) -> Result<BakedPvs> {
    let t = log.start("baking a PVS with GVS++ and RAND");
    let half = view.bounds.diagonal() * 0.004;
    let cells = random_free_cells(scene, bvh, args.cells, half, 1);
    let (file, per_cell) = bake_gvspp(args, scene, bvh, &cells);
    let rand_results = rand_at_equal_rays(scene, bvh, &cells, &per_cell);
    let equal_rays: Vec<serde_json::Value> = per_cell
        .iter()
        .zip(&rand_results)
        .map(|(g, r)| serde_json::json!({"gvspp_rays": g.0, "rand_rays": r.0}))
        .collect();
    let rand_sets: Vec<Vec<TriangleSet>> =
        rand_results.into_iter().map(|(_, set)| vec![set]).collect();
    let path = args.output.join("demo.pvs");
    file.save(&path)?;
    let mean_pvs = file
        .cells
        .iter()
        .map(|c| c.visible.count_ones(..))
        .sum::<usize>() as f64
        / file.cells.len().max(1) as f64;
    log.finish(
        "PVS bake (GVS++, RAND)",
        t,
        format!(
            "{} view cells, mean PVS {:.0} triangles ({:.2}%), {:.0} rays per cell on average",
            file.cells.len(),
            mean_pvs,
            100.0 * mean_pvs / scene.triangle_count().max(1) as f64,
            per_cell.iter().map(|c| c.0 as f64).sum::<f64>() / per_cell.len().max(1) as f64
        ),
    );
    Ok(BakedPvs {
        file,
        path,
        rand_sets,
        equal_rays,
    })
}

/// Seed of the demo's bakes (GVS++ and RAND alike).
const BAKE_SEED: u64 = 1;

/// Bakes `cells` with GVS++: the file, and per cell its rays and convergence curve.
fn bake_gvspp(
    args: &Args,
    scene: &Scene,
    bvh: &Bvh,
    cells: &[ViewCell],
) -> (PvsFile, Vec<(u64, Vec<ConvergencePoint>)>) {
    let gvspp = GvsPlusPlus {
        params: GvsPlusPlusParams {
            n_rand: args.n_rand,
            ..GvsPlusPlusParams::default()
        },
    };
    // Indexed by cell: `bake` reports cells in completion order, so RAND must look its
    // ray count up by the cell's index, not by the order the cells finished in.
    let mut per_cell = vec![(0u64, Vec::new()); cells.len()];
    let mut file = bake(
        scene,
        bvh,
        cells,
        &gvspp,
        &|_, _| true,
        &Budget::default(),
        BAKE_SEED,
        serde_json::json!({"parameters": format!("{:?}", gvspp.params)}),
        &|_, _| {},
        &mut |i, r| {
            if let Some(slot) = per_cell.get_mut(i) {
                *slot = (r.rays, r.convergence.clone());
            }
        },
    );
    // Record the convergence curves where the bake did not (older bake drivers).
    for (i, (_, curve)) in per_cell.iter().enumerate() {
        let record = &mut file.metadata["cells"][i];
        if record.get("convergence").is_none() && record.is_object() {
            record["convergence"] = curve
                .iter()
                .map(|p| serde_json::json!([p.rays, p.pvs_size]))
                .collect();
        }
    }
    (file, per_cell)
}

/// RAND at each cell's own GVS++ ray count (`per_cell[i].0`): (rays, set) per cell.
fn rand_at_equal_rays(
    scene: &Scene,
    bvh: &Bvh,
    cells: &[ViewCell],
    per_cell: &[(u64, Vec<ConvergencePoint>)],
) -> Vec<(u64, TriangleSet)> {
    cells
        .iter()
        .enumerate()
        .map(|(i, cell)| {
            let ctx = CellContext {
                scene,
                caster: bvh,
                cell,
                seed: cell_seed(BAKE_SEED, i),
                free_space: None,
            };
            let rays = per_cell[i].0.max(1);
            let r = RandomSampler.sample(&ctx, &Budget::rays(rays), &|_| {});
            (r.rays, r.visible)
        })
        .collect()
}

/// The pixel-error evaluation of GVS++ and RAND on the same views, with its report sections.
fn evaluate_pvs(
    args: &Args,
    scene: &Scene,
    baked: &BakedPvs,
    log: &mut StepLog,
) -> Result<PvsReport> {
    let t = log.start("evaluating the PVS (pixel error)");
    let options = PvsReportOptions {
        params: EvalParams {
            viewpoints: args.views,
            resolution: args.size.min(256),
            ..EvalParams::default()
        },
        worst_views: args.cells.min(6),
        cell_rows: 20,
    };
    let pvs = pvs_report(
        scene,
        &baked.file,
        &baked.path.display().to_string(),
        &options,
        &baked.rand_sets,
        None,
        &|_, _, _| {},
    )?;
    let k = pvs.outcomes.len().max(1) as f64;
    let mean_err = |f: &dyn Fn(&CellOutcome) -> f64| pvs.outcomes.iter().map(f).sum::<f64>() / k;
    log.finish(
        "PVS pixel error (GVS++ vs RAND, equal rays)",
        t,
        format!(
            "avg erroneous pixels per {r}² view: GVS++ {:.2}, RAND {:.2}; missed seen triangles {} vs {}",
            mean_err(&|o| o.eval.avg_error_pixels),
            mean_err(&|o| o.extra.first().map_or(0.0, |e| e.avg_error_pixels)),
            pvs.outcomes.iter().map(|o| o.eval.false_negatives).sum::<usize>(),
            pvs.outcomes
                .iter()
                .map(|o| o.extra.first().map_or(0, |e| e.false_negatives))
                .sum::<usize>(),
            r = options.params.resolution
        ),
    );
    Ok(pvs)
}

/// Every culling method along `sightline cull`'s default walk, with moving objects.
fn simulate_culling(
    args: &Args,
    scene: &Scene,
    view: &View<'_>,
    log: &mut StepLog,
) -> Result<Vec<SimReport>> {
    let t = log.start("culling along a camera path");
    let cull_scene = animate(scene.clone());
    let config = SimConfig {
        frames: args.frames,
        width: 320,
        height: 180,
        // The thesis' design reads query results a frame late, as hardware queries must.
        latency: 1,
        ..SimConfig::default()
    };
    let up = view.up;
    let (start, end) = walk_keys(&view.bounds, up);
    let dir = (end - start).normalize_or(Vec3::X);
    let frames = args.frames;
    // The default walk of `sightline cull` (start to end, looking around), in `frames` frames,
    // with its near plane: the default rule at every eye on the walk.
    let walk_eye = |f: u32| {
        let s = if frames > 1 {
            f as f32 / (frames - 1) as f32
        } else {
            0.0
        };
        start.lerp(end, s)
    };
    let walk_near = view
        .near_rule
        .along(&(0..frames).map(walk_eye).collect::<Vec<_>>());
    let camera_of = |f: u32| {
        let eye = walk_eye(f);
        let yaw = 40f32.to_radians() * (std::f32::consts::TAU * f as f32 / 30.0 / 8.0).sin();
        let look = eye + Quat::from_axis_angle(up, yaw) * dir;
        Camera::look_at(eye, look, up, config.fov_y_deg, 320, 180, walk_near).ok()
    };
    let mut backend = SoftwareBackend::new(config.width, config.height);
    let culling =
        simulate_methods_with_cameras(&cull_scene, &camera_of, &mut backend, &config, &Method::ALL)
            .context("culling simulation")?;
    let grid = &culling[0];
    log.finish(
        "culling path (grid + baselines)",
        t,
        format!(
            "{} frames, {} objects: grid draws {:.0} (exact {:.0}) with {:.0} queries, popping {:.4}% of pixels",
            grid.frames.len(),
            grid.objects,
            grid.mean(|f| f.drawn as f64),
            grid.mean(|f| f.exact_visible as f64),
            grid.mean(|f| f.queries as f64),
            100.0 * grid.mean(|f| f.popping_pixels as f64) / grid.pixels.max(1) as f64
        ),
    );
    Ok(culling)
}

/// Writes `index.html` with `sections`; returns its path.
fn write_page(args: &Args, scene: &Scene, sections: &[Section]) -> Result<PathBuf> {
    let html = page(
        "sightline demo",
        &format!(
            "The end-to-end job on {} ({} triangles).",
            scene.source,
            scene.triangle_count()
        ),
        sections,
    );
    let index = args.output.join("index.html");
    write_atomic(&index, |w| std::io::Write::write_all(w, html.as_bytes()))
        .with_context(|| format!("writing {}", index.display()))?;
    Ok(index)
}

/// The steps with their timings, as JSON (`--json`) or a table.
fn print_summary(
    args: &Args,
    scene: &Scene,
    steps: &[Step],
    index: &Path,
    baked: &BakedPvs,
) -> Result<()> {
    if args.json {
        let steps: Vec<_> = steps
            .iter()
            .map(|s| serde_json::json!({"step": s.name, "seconds": s.seconds, "result": s.result}))
            .collect();
        return crate::output::print_json(&serde_json::json!({
            "scene": scene.source,
            "report": index,
            "pvs": baked.path,
            "steps": steps,
            "equal_rays": baked.equal_rays,
        }));
    }
    outln!("sightline demo on {}", scene.source);
    for s in steps {
        outln!("  {:<44} {:>8.3} s  {}", s.name, s.seconds, s.result);
    }
    outln!("report: {}", index.display());
    Ok(())
}

fn visible_set(ids: &[u32], n: usize) -> TriangleSet {
    let mut set = TriangleSet::with_capacity(n);
    for &id in ids {
        if (id as usize) < n {
            set.insert(id as usize);
        }
    }
    set
}

/// Casts one ray per pixel centre and counts pixels where ray casting and the rasterizer see
/// the same triangle.
fn cross_check(caster: &dyn RayCaster, camera: &Camera, ids: &[u32]) -> (usize, usize) {
    let rays: Vec<Ray> = (0..camera.height)
        .flat_map(|y| (0..camera.width).map(move |x| camera.pixel_ray(x, y)))
        .collect();
    let mut hits = vec![Hit::MISS; rays.len()];
    caster.cast(&rays, &mut hits);
    let agree = hits
        .iter()
        .zip(ids)
        .filter(|(h, &id)| h.triangle == id)
        .count();
    (agree, rays.len())
}
