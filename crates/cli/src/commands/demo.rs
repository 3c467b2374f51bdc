//! `sightline demo`: the main job on the embedded default scene, ending in
//! `sightline-report/index.html`: it generates and validates the city, builds the ray-casting
//! BVH, renders views with the reference rasterizer, cross-checks them against ray casting,
//! computes the sampled, exact and conservative from-point sets, bakes a PVS for a few view
//! cells with GVS++ (and RAND at equal rays), measures both with the GVS++ paper's pixel error,
//! and runs a short culling camera path with moving objects. The page is built by the same
//! report builder as `sightline report` (`crate::report`), plus the demo's own sections
//! (`demo_sections.rs`).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use glam::{Quat, Vec3};
use indicatif::{ProgressBar, ProgressStyle};
use sightline_core::atomic_file::write_atomic;
use sightline_core::raster;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::validate::validate;
use sightline_core::{Camera, Hit, NearPlaneRule, Ray, TriangleSet};
use sightline_cull::scenes::{animate, walk_keys};
use sightline_cull::{simulate_methods_with_cameras, Method, SimConfig, SoftwareBackend};
use sightline_eval::EvalParams;
use sightline_region::bake::{bake, cell_seed};
use sightline_region::cell_sources::random_free_cells;
use sightline_region::{
    Budget, CellContext, GvsPlusPlus, GvsPlusPlusParams, RandomSampler, Sampler,
};

use super::demo_sections::{self as ds, FromPoint, Step};
use crate::args::{default_eye, SceneArgs};
use crate::output::{id_image, save_png, shaded_image};
use crate::report::html::page;
use crate::report::{pvs_report, PvsReportOptions};

/// Arguments of `sightline demo`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Directory for the report.
    #[arg(short, long, default_value = "sightline-report")]
    output: PathBuf,
    /// Image size (square) of the rendered views (the evaluation uses at most 256).
    #[arg(long, default_value_t = 512)]
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
    if args.size == 0 || args.size > 4096 || args.frames == 0 || args.views == 0 {
        anyhow::bail!("--size must be in 1..=4096, --frames and --views at least 1");
    }
    crate::limits::check_frames(u64::from(args.frames), "--frames")?;
    crate::output::refuse_overwriting_inputs(
        &[&args.output, &args.output.join("demo.pvs")],
        &[std::path::Path::new(&args.scene.scene)],
    )?;
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("creating {}", args.output.display()))?;
    let progress = ProgressBar::new(9).with_style(
        ProgressStyle::with_template("{spinner} [{bar:30}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut steps = Vec::new();
    let mut step = |name: &str, start: Instant, result: String| {
        progress.inc(1);
        steps.push(Step {
            name: name.into(),
            seconds: start.elapsed().as_secs_f64(),
            result,
        });
    };

    progress.set_message("loading scene");
    let t = Instant::now();
    let scene = args.scene.load()?;
    let report = validate(&scene);
    step(
        "load + validate",
        t,
        format!(
            "{} triangles, {} objects, {} warnings",
            scene.triangle_count(),
            scene.objects.len(),
            report.warnings().len()
        ),
    );

    progress.set_message("building BVH");
    let t = Instant::now();
    let bvh = Bvh::build(&scene);
    step("BVH build", t, "SAH BVH over all triangles".into());

    progress.set_message("rendering overview");
    let t = Instant::now();
    let bounds = scene.bounds();
    let up = scene.up.vector();
    let center = bounds.center();
    let eye = default_eye(&scene, center, bounds.diagonal());
    let near_rule = NearPlaneRule::new(&scene);
    let near = near_rule.at(eye);
    let overview = Camera::look_at(eye, center, up, 60.0, args.size, args.size, near)?;
    let frame = raster::render(&scene, &overview);
    let overview_images = [shaded_image(&frame, &scene, &overview), id_image(&frame)];
    save_png(&overview_images[0], &args.output.join("overview.png"))?;
    save_png(&overview_images[1], &args.output.join("overview_ids.png"))?;
    let visible = visible_set(&frame.ids, scene.triangle_count());
    step(
        "render overview",
        t,
        format!(
            "{} triangles visible from the overview camera",
            visible.count_ones(..)
        ),
    );

    progress.set_message("cross-checking rasterizer with ray casting");
    let t = Instant::now();
    let (agree, total) = cross_check(&bvh, &overview, &frame.ids);
    step(
        "rasterizer vs ray casting",
        t,
        format!(
            "{agree} of {total} pixel centres agree ({:.3}%)",
            100.0 * agree as f64 / total.max(1) as f64
        ),
    );

    progress.set_message("cube map from street level");
    let t = Instant::now();
    let street_eye = center + up * (bounds.extent().dot(up) * 0.02 + 1.7);
    let mut cube_visible = TriangleSet::with_capacity(scene.triangle_count());
    let mut cube_images = Vec::new();
    for (i, face) in Camera::cube_faces(street_eye, args.size / 2, near_rule.at(street_eye))?
        .iter()
        .enumerate()
    {
        let f = raster::render(&scene, face);
        cube_visible.union_with(&visible_set(&f.ids, scene.triangle_count()));
        let img = shaded_image(&f, &scene, face);
        save_png(&img, &args.output.join(format!("cube{i}.png")))?;
        cube_images.push(img);
    }
    step(
        "cube map at street level",
        t,
        format!(
            "{} of {} triangles visible ({:.2}%)",
            cube_visible.count_ones(..),
            scene.triangle_count(),
            100.0 * cube_visible.count_ones(..) as f64 / scene.triangle_count().max(1) as f64
        ),
    );

    progress.set_message("exact and conservative visible sets from the overview point");
    let t = Instant::now();
    let small = Camera::look_at(eye, center, up, 60.0, 256, 256, near)?;
    let ts = Instant::now();
    let sampled = visible_set(&raster::render(&scene, &small).ids, scene.triangle_count());
    let sampled_s = ts.elapsed().as_secs_f64();
    let te = Instant::now();
    let exact = sightline_point::analytic::visible_fragments(
        &scene,
        &small,
        &sightline_point::analytic::AnalyticOptions::default(),
    )?;
    let exact_s = te.elapsed().as_secs_f64();
    let tc = Instant::now();
    let rv = sightline_point::rv::conservative_visible(
        &mut sightline_point::rv::SceneSource::new(&scene),
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
    step(
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

    progress.set_message("baking a PVS with GVS++ and RAND");
    let t = Instant::now();
    let half = bounds.diagonal() * 0.004;
    let cells = random_free_cells(&scene, &bvh, args.cells, half, 1);
    let gvspp = GvsPlusPlus {
        params: GvsPlusPlusParams {
            n_rand: args.n_rand,
            ..GvsPlusPlusParams::default()
        },
    };
    let seed = 1;
    // Indexed by cell: `bake` reports cells in completion order, so RAND must look its
    // ray count up by the cell's index, not by the order the cells finished in.
    let mut per_cell = vec![(0u64, Vec::new()); cells.len()];
    let mut file = bake(
        &scene,
        &bvh,
        &cells,
        &gvspp,
        &|_, _| true,
        &Budget::default(),
        seed,
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
    // RAND at each cell's own GVS++ ray count: (rays, set) per cell.
    let rand_results: Vec<(u64, TriangleSet)> = cells
        .iter()
        .enumerate()
        .map(|(i, cell)| {
            let ctx = CellContext {
                scene: &scene,
                caster: &bvh,
                cell,
                seed: cell_seed(seed, i),
                free_space: None,
            };
            let rays = per_cell[i].0.max(1);
            let r = RandomSampler.sample(&ctx, &Budget::rays(rays), &|_| {});
            (r.rays, r.visible)
        })
        .collect();
    let equal_rays: Vec<serde_json::Value> = per_cell
        .iter()
        .zip(&rand_results)
        .map(|(g, r)| serde_json::json!({"gvspp_rays": g.0, "rand_rays": r.0}))
        .collect();
    let rand_sets: Vec<Vec<TriangleSet>> =
        rand_results.into_iter().map(|(_, set)| vec![set]).collect();
    let pvs_path = args.output.join("demo.pvs");
    file.save(&pvs_path)?;
    let mean_pvs = file
        .cells
        .iter()
        .map(|c| c.visible.count_ones(..))
        .sum::<usize>() as f64
        / file.cells.len().max(1) as f64;
    step(
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

    progress.set_message("evaluating the PVS (pixel error)");
    let t = Instant::now();
    let options = PvsReportOptions {
        params: EvalParams {
            viewpoints: args.views,
            resolution: args.size.min(256),
            ..EvalParams::default()
        },
        worst_views: args.cells.min(6),
    };
    let pvs = pvs_report(
        &scene,
        &file,
        &pvs_path.display().to_string(),
        &options,
        &rand_sets,
        &|_, _, _| {},
    )?;
    let k = pvs.outcomes.len().max(1) as f64;
    let mean_err = |f: &dyn Fn(&crate::report::CellOutcome) -> f64| {
        pvs.outcomes.iter().map(f).sum::<f64>() / k
    };
    step(
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

    progress.set_message("culling along a camera path");
    let t = Instant::now();
    let cull_scene = animate(scene.clone());
    let config = SimConfig {
        frames: args.frames,
        width: 320,
        height: 180,
        // The thesis' design reads query results a frame late, as hardware queries must.
        latency: 1,
        ..SimConfig::default()
    };
    let (start, end) = walk_keys(&bounds, up);
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
    let walk_near = near_rule.along(&(0..frames).map(walk_eye).collect::<Vec<_>>());
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
    step(
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

    progress.set_message("writing the report");
    let mut sections = vec![
        ds::steps(&steps),
        ds::overview(&overview_images, &cube_images)?,
        ds::from_point(&from_point),
    ];
    sections.extend(pvs.sections);
    sections.push(ds::gvspp_vs_rand(&pvs.outcomes));
    sections.push(ds::culling(&culling)?);
    let html = page(
        "sightline demo",
        &format!(
            "The end-to-end job on {} ({} triangles).",
            scene.source,
            scene.triangle_count()
        ),
        &sections,
    );
    let index = args.output.join("index.html");
    write_atomic(&index, |w| std::io::Write::write_all(w, html.as_bytes()))
        .with_context(|| format!("writing {}", index.display()))?;
    progress.finish_and_clear();

    if args.json {
        let steps: Vec<_> = steps
            .iter()
            .map(|s| serde_json::json!({"step": s.name, "seconds": s.seconds, "result": s.result}))
            .collect();
        return crate::output::print_json(&serde_json::json!({
            "scene": scene.source,
            "report": index,
            "pvs": pvs_path,
            "steps": steps,
            "equal_rays": equal_rays,
        }));
    }
    outln!("sightline demo on {}", scene.source);
    for s in &steps {
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
