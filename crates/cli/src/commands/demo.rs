//! `sightline demo`: the main job on the embedded default scene, ending in
//! `sightline-report/index.html`. It grows as the algorithm parts land: today it generates and
//! validates the city, builds the ray-casting BVH, renders views with the reference rasterizer,
//! cross-checks them against ray casting, computes the sampled, exact and conservative
//! from-point sets, bakes a PVS for a few view cells with GVS++ and RAND
//! at equal rays, and measures both with the GVS++ paper's pixel error.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use sightline_core::atomic_file::write_atomic;
use sightline_core::raster;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::validate::validate;
use sightline_core::{Camera, Hit, Ray, TriangleSet};

use sightline_eval::{evaluate_cell, EvalParams};
use sightline_region::cell_sources::random_free_cells;
use sightline_region::{
    Budget, CellContext, GvsPlusPlus, GvsPlusPlusParams, RandomSampler, Sampler,
};

use crate::args::{default_eye, SceneArgs};
use crate::output::{id_image, save_png, shaded_image};

/// Arguments of `sightline demo`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Directory for the report.
    #[arg(short, long, default_value = "sightline-report")]
    output: PathBuf,
    /// Image size (square) of the rendered views.
    #[arg(long, default_value_t = 512)]
    size: u32,
    /// View cells baked.
    #[arg(long, default_value_t = 3)]
    cells: usize,
    /// GVS++ random rays per round (the paper uses 10M; the demo stays quick).
    #[arg(long, default_value_t = 500_000)]
    n_rand: u64,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

struct Step {
    name: String,
    seconds: f64,
    result: String,
}

pub(crate) fn run(args: Args) -> Result<()> {
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("creating {}", args.output.display()))?;
    let progress = ProgressBar::new(8).with_style(
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
    let near = bounds.diagonal().max(1e-6) * 1e-4;
    let overview = Camera::look_at(eye, center, up, 60.0, args.size, args.size, near)?;
    let frame = raster::render(&scene, &overview);
    save_png(
        &shaded_image(&frame, &scene, &overview),
        &args.output.join("overview.png"),
    )?;
    save_png(&id_image(&frame), &args.output.join("overview_ids.png"))?;
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
    for (i, face) in Camera::cube_faces(street_eye, args.size / 2, near)?
        .iter()
        .enumerate()
    {
        let f = raster::render(&scene, face);
        cube_visible.union_with(&visible_set(&f.ids, scene.triangle_count()));
        save_png(
            &shaded_image(&f, &scene, face),
            &args.output.join(format!("cube{i}.png")),
        )?;
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
    let exact = sightline_point::analytic::visible_fragments(
        &scene,
        &small,
        &sightline_point::analytic::AnalyticOptions::default(),
    )?;
    let rv = sightline_point::rv::conservative_visible(
        &mut sightline_point::rv::SceneSource::new(&scene),
        &small,
        &sightline_point::rv::RvOptions::default(),
    )?;
    let sampled = visible_set(&raster::render(&scene, &small).ids, scene.triangle_count());
    step(
        "from-point: sampled / exact / conservative",
        t,
        format!(
            "{} / {} / {} triangles at 256² (exact ⊆ conservative: {}; RV peak memory {:.1} MiB)",
            sampled.count_ones(..),
            exact.visible.count_ones(..),
            rv.visible.count_ones(..),
            exact.visible.is_subset(&rv.visible),
            rv.peak_memory_bytes as f64 / 1048576.0
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
    let mut pvs_rows = Vec::new();
    for (i, cell) in cells.iter().enumerate() {
        let ctx = CellContext {
            scene: &scene,
            caster: &bvh,
            cell,
            seed: i as u64,
            free_space: None,
        };
        let ours = gvspp.sample(&ctx, &Budget::default(), &|_| {});
        let rand = RandomSampler.sample(&ctx, &Budget::rays(ours.rays), &|_| {});
        pvs_rows.push((*cell, ours, rand));
    }
    let mean_pvs = pvs_rows
        .iter()
        .map(|r| r.1.visible.count_ones(..))
        .sum::<usize>() as f64
        / pvs_rows.len().max(1) as f64;
    step(
        "PVS bake (GVS++, RAND)",
        t,
        format!(
            "{} view cells, mean PVS {:.0} triangles ({:.2}%), {} rays per cell",
            pvs_rows.len(),
            mean_pvs,
            100.0 * mean_pvs / scene.triangle_count().max(1) as f64,
            pvs_rows.first().map_or(0, |r| r.1.rays)
        ),
    );

    progress.set_message("evaluating the PVS (pixel error)");
    let t = Instant::now();
    let eval_params = EvalParams {
        viewpoints: 8,
        resolution: 256,
        ..EvalParams::default()
    };
    let mut errors = (0.0, 0.0, 0usize, 0usize);
    for (cell, ours, rand) in &pvs_rows {
        let e = evaluate_cell(
            &scene,
            cell,
            &[&ours.visible, &rand.visible],
            &eval_params,
            &|_, _| {},
        );
        errors.0 += e[0].avg_error_pixels;
        errors.1 += e[1].avg_error_pixels;
        errors.2 += e[0].false_negatives;
        errors.3 += e[1].false_negatives;
    }
    let k = pvs_rows.len().max(1) as f64;
    step(
        "PVS pixel error (GVS++ vs RAND, equal rays)",
        t,
        format!(
            "avg erroneous pixels per 256² view: GVS++ {:.2}, RAND {:.2}; missed seen triangles {} vs {}",
            errors.0 / k,
            errors.1 / k,
            errors.2,
            errors.3
        ),
    );
    progress.finish_and_clear();

    let html = report_html(&scene.source, &steps);
    let index = args.output.join("index.html");
    write_atomic(&index, |w| std::io::Write::write_all(w, html.as_bytes()))
        .with_context(|| format!("writing {}", index.display()))?;
    if args.json {
        let steps: Vec<_> = steps
            .iter()
            .map(|s| serde_json::json!({"step": s.name, "seconds": s.seconds, "result": s.result}))
            .collect();
        return crate::output::print_json(&serde_json::json!({
            "scene": scene.source,
            "report": index,
            "steps": steps,
        }));
    }
    println!("sightline demo on {}", scene.source);
    for s in &steps {
        println!("  {:<44} {:>8.3} s  {}", s.name, s.seconds, s.result);
    }
    println!("report: {}", index.display());
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

fn report_html(source: &str, steps: &[Step]) -> String {
    let mut rows = String::new();
    for s in steps {
        let _ = writeln!(
            rows,
            "<tr><td>{}</td><td>{:.3}</td><td>{}</td></tr>",
            html_escape(&s.name),
            s.seconds,
            html_escape(&s.result)
        );
    }
    let cube: String = (0..6)
        .map(|i| format!("<img src=\"cube{i}.png\" width=\"160\">"))
        .collect();
    format!(
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>sightline demo</title>\n\
         <style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;background:#fafafa}}\
         table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:4px 8px}}</style>\
         </head><body>\n<h1>sightline demo</h1>\n<p>Scene: <code>{}</code></p>\n\
         <table><tr><th>step</th><th>seconds</th><th>result</th></tr>\n{rows}</table>\n\
         <h2>Overview (reference rasterizer)</h2>\n<img src=\"overview.png\" width=\"512\"> \
         <img src=\"overview_ids.png\" width=\"512\">\n<h2>Cube map at street level</h2>\n{cube}\n\
         </body></html>\n",
        html_escape(source)
    )
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
