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
    /// Ray casting: our BVH (and Embree, when built with `--features embree`, and the GPU
    /// caster with `--device gpu`), coherent camera rays and incoherent random rays, million
    /// rays per second.
    Trace(TraceArgs),
    /// Reference rasterizer: frame time and triangles per second at a given resolution.
    Raster(RasterArgs),
    /// From-region PVS: the GVS++ paper's table 1 — GVS++ (converged) against RAND at equal
    /// rays and at equal time, GVS and RASTER at equal rays; pixel error on shared views.
    Pvs(PvsArgs),
    /// Ray sharing between view cells: a grid of cells baked independently with GVS++ and
    /// with shared rays at several budgets; pixel error on a fixed subset of cells and the
    /// speed-up at equal error.
    Share(ShareArgs),
    /// RV streaming throughput: a procedural city generated block by block (never held in
    /// memory) streamed through RV from a street-level and an aerial view, with the re-test
    /// pass (the default) and as the thesis' single pass, alternated round by round; million
    /// triangles per second, set sizes, peak memory.
    Rv(RvArgs),
}

/// Arguments of `sightline bench rv`.
#[derive(clap::Args, Debug)]
struct RvArgs {
    /// Triangles of the streamed city (about; `procedural:city?size=N`).
    #[arg(long, default_value_t = 10_000_000)]
    triangles: usize,
    /// Visibility workers, and as many geometry threads (default: all cores; at most 4 per
    /// core, more are capped with a warning).
    #[arg(long)]
    threads: Option<usize>,
    /// Image size (square).
    #[arg(long, default_value_t = 1024)]
    size: u32,
    /// Rounds; every configuration runs once per round (the median is reported).
    #[arg(long, default_value_t = 5)]
    rounds: usize,
    /// Memory budget, e.g. 256MiB.
    #[arg(long, default_value = "256MiB", value_parser = super::visible::parse_bytes)]
    memory: usize,
    /// Print JSON instead of a Markdown table.
    #[arg(long)]
    json: bool,
}

/// Arguments of `sightline bench share`.
#[derive(clap::Args, Debug)]
struct ShareArgs {
    /// Scene.
    #[arg(value_name = "SCENE", default_value = "procedural:city")]
    scene: String,
    /// Cells per side of the grid over the scene's ground plane.
    #[arg(long, default_value_t = 16)]
    grid: u32,
    /// Bottom and top of the cell layer above the scene's lowest point along its up axis, in
    /// scene units.
    #[arg(long, value_name = "BOTTOM,TOP", default_value = "0.5,10")]
    layer: String,
    /// Per-cell ray budgets of the independent GVS++ bakes.
    #[arg(long, value_delimiter = ',', default_value = "100000,400000,1600000")]
    budgets: Vec<u64>,
    /// Per-cell ray budgets of the shared bakes (rays each cell casts itself, backward casts
    /// included).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "50000,100000,200000,400000,800000"
    )]
    share_budgets: Vec<u64>,
    /// GVS++ random rays per round of the independent bakes.
    #[arg(long, default_value_t = 50_000)]
    n_rand: u64,
    /// Random rays per cell and round of the shared bakes (default: half of --n-rand, as
    /// each is also cast backward).
    #[arg(long)]
    share_n_rand: Option<u64>,
    /// Shared bakes: cast rays forward only.
    #[arg(long)]
    no_backward: bool,
    /// Shared bakes: triangles received from other cells' rays are explored too (ABS and RS
    /// from the crossing point), not only entered into the PVS.
    #[arg(long)]
    explore_shared: bool,
    /// Cells evaluated (a fixed random subset of the grid).
    #[arg(long, default_value_t = 16)]
    eval_cells: usize,
    /// Evaluation viewpoints per cell (in free space, six cube faces each).
    #[arg(long, default_value_t = 16)]
    viewpoints: usize,
    /// Evaluation resolution.
    #[arg(long, default_value_t = 256)]
    resolution: u32,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Both bakes only use ray origins (and shared crossing points) outside solid geometry, as
    /// the evaluation's viewpoints are (6 rays per test, not counted; slow). By default
    /// origins may lie anywhere in the cells, as in `pvs bake --grid`.
    #[arg(long)]
    free_space: bool,
    /// Print JSON instead of Markdown.
    #[arg(long)]
    json: bool,
}

/// A comma-separated list of budgets, or `none`.
#[derive(Clone, Debug, Default)]
struct BudgetList(Vec<u64>);

fn parse_budget_list(s: &str) -> Result<BudgetList, String> {
    if s.trim() == "none" || s.trim().is_empty() {
        return Ok(BudgetList::default());
    }
    s.split(',')
        .map(|v| {
            v.trim()
                .parse::<u64>()
                .map_err(|_| format!("'{v}' is not a whole number (or give 'none')"))
        })
        .collect::<Result<_, _>>()
        .map(BudgetList)
}

/// Arguments of `sightline bench pvs`.
#[derive(clap::Args, Debug)]
struct PvsArgs {
    /// Scenes (default: the procedural city and rooms).
    #[arg(value_name = "SCENE")]
    scenes: Vec<String>,
    /// View cells per scene (random cubes in free space).
    #[arg(long, default_value_t = 10)]
    cells: usize,
    /// Half size of the cells as a fraction of the scene diagonal.
    #[arg(long, default_value_t = 0.004)]
    cell_size: f32,
    /// Evaluation viewpoints per cell (six cube faces each).
    #[arg(long, default_value_t = 50)]
    viewpoints: usize,
    /// Evaluation resolution.
    #[arg(long, default_value_t = 512)]
    resolution: u32,
    /// GVS++/GVS random rays per round (paper: 10,000,000).
    #[arg(long, default_value_t = 10_000_000)]
    n_rand: u64,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print JSON instead of Markdown.
    #[arg(long)]
    json: bool,
    /// Small time budgets (milliseconds, comma-separated) at which GVS++ and RAND are also
    /// compared at equal time, the paper's equal-time comparison (issue 24: GVS++ must start
    /// exploring before such a budget is spent). `none`: no equal-time rows.
    #[arg(
        long,
        value_name = "MS,..|none",
        default_value = "250,1000",
        value_parser = parse_budget_list
    )]
    time_budgets: BudgetList,
    /// Small ray budgets (comma-separated) at which GVS++ and RAND are also compared at equal
    /// rays: the equal-time comparison without the machine's load in it (both cast rays at the
    /// same rate, about 5 M rays per second on two cores, so 1 M rays is about 250 ms there).
    /// Empty (the default): none.
    #[arg(long, value_name = "RAYS,..", default_value = "none", value_parser = parse_budget_list)]
    ray_budgets: BudgetList,
    /// Only the equal-time rows of `--time-budgets` (GVS++ and RAND at each budget): skips the
    /// converged GVS++ bake and the baselines at its ray count, which take minutes per cell on
    /// large scenes.
    #[arg(long)]
    equal_time_only: bool,
    /// Write a convergence plot per scene (average error against rays for every method, on
    /// the scene's first cell) as SVG files into DIR.
    #[arg(long, value_name = "DIR")]
    plot: Option<std::path::PathBuf>,
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
    /// Seconds per backend and ray set, split into 5 alternating rounds (best round kept).
    #[arg(long, default_value_t = 2.0)]
    seconds: f64,
    /// `gpu` adds the GPU ray caster (wgpu compute shaders, on the adapter `sightline-gpu`
    /// picks; `SIGHTLINE_GPU_ADAPTER` chooses) beside the CPU casters, on the same rays.
    #[arg(long, value_enum, default_value_t = Device::Cpu)]
    device: Device,
    /// Children per node of the GPU caster's BVH (2, 4 or 8), to compare layouts (default:
    /// the GPU caster's own, 4).
    #[arg(long, value_name = "N")]
    gpu_width: Option<usize>,
    /// Print JSON instead of a Markdown table.
    #[arg(long)]
    json: bool,
}

/// Where rays are cast (`bench trace --device`, `pvs bake --device`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Device {
    /// The CPU casters only.
    Cpu,
    /// The CPU casters and the GPU caster.
    Gpu,
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
        What::Pvs(a) => pvs(a),
        What::Share(a) => share(a),
        What::Rv(a) => rv(a),
    }
}

/// One configuration of `bench rv`, over all rounds.
#[derive(Serialize, Debug)]
struct RvRow {
    view: &'static str,
    retest_pass: bool,
    triangles_streamed: u64,
    on_screen: u64,
    visible: usize,
    first_pass_visible: u64,
    /// Median, fastest and slowest wall-clock seconds over the rounds.
    median_seconds: f64,
    min_seconds: f64,
    max_seconds: f64,
    /// Triangles streamed per median second, in millions.
    mtriangles_per_second: f64,
    peak_memory_mib: f64,
}

fn rv(args: RvArgs) -> Result<()> {
    use sightline_point::rv::{conservative_visible, RvOptions, StreamingCity};
    anyhow::ensure!(args.rounds > 0, "--rounds must be at least 1");
    crate::limits::check_count(args.rounds as u64, crate::limits::MAX_FRAMES, "--rounds")?;
    anyhow::ensure!(args.triangles > 0, "--triangles must be at least 1");
    let threads = crate::args::thread_count(args.threads)?;
    crate::limits::check_pixels(args.size, args.size).map_err(anyhow::Error::msg)?;

    let views = [
        ("street", StreamingCity::street_camera(args.size)?),
        ("aerial", StreamingCity::aerial_camera(args.size)?),
    ];
    let configs: Vec<(usize, bool)> = (0..views.len())
        .flat_map(|v| [(v, true), (v, false)])
        .collect();
    let mut times = vec![Vec::with_capacity(args.rounds); configs.len()];
    let mut rows: Vec<Option<RvRow>> = (0..configs.len()).map(|_| None).collect();
    for round in 0..args.rounds {
        eprintln!("round {}/{}", round + 1, args.rounds);
        for (k, &(v, retest_pass)) in configs.iter().enumerate() {
            let (view, camera) = &views[v];
            let options = RvOptions {
                memory_budget_bytes: args.memory,
                threads,
                geometry_threads: threads,
                retest_pass,
                ..RvOptions::default()
            };
            let mut city = StreamingCity::new(1, args.triangles);
            let r = conservative_visible(&mut city, camera, &options)?;
            times[k].push(r.stats.seconds);
            rows[k].get_or_insert(RvRow {
                view,
                retest_pass,
                triangles_streamed: r.stats.triangles_streamed,
                on_screen: r.stats.triangles_on_screen,
                visible: r.visible.count_ones(..),
                first_pass_visible: r.stats.first_pass_visible,
                median_seconds: 0.0,
                min_seconds: 0.0,
                max_seconds: 0.0,
                mtriangles_per_second: 0.0,
                peak_memory_mib: r.peak_memory_bytes as f64 / f64::from(1 << 20),
            });
        }
    }
    let rows: Vec<RvRow> = rows
        .into_iter()
        .zip(times)
        .filter_map(|(row, mut t)| {
            let mut row = row?;
            t.sort_by(f64::total_cmp);
            row.median_seconds = t[t.len() / 2];
            row.min_seconds = t[0];
            row.max_seconds = t[t.len() - 1];
            row.mtriangles_per_second = row.triangles_streamed as f64 / row.median_seconds / 1e6;
            Some(row)
        })
        .collect();
    if args.json {
        return print_json(&rows);
    }
    outln!(
        "RV streaming a procedural city of {} triangles, {}² px, {threads} workers + {threads} \
         geometry threads, {} rounds (median; fastest-slowest)\n",
        args.triangles,
        args.size,
        args.rounds
    );
    outln!("| view | passes | streamed | on screen | visible (first pass) | seconds (fastest-slowest) | M triangles/s | peak MiB |");
    outln!("|---|---|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        outln!(
            "| {} | {} | {} | {} | {} ({}) | {:.3} ({:.3}-{:.3}) | {:.1} | {:.1} |",
            r.view,
            if r.retest_pass {
                "two (re-test)"
            } else {
                "one (thesis)"
            },
            r.triangles_streamed,
            r.on_screen,
            r.visible,
            r.first_pass_visible,
            r.median_seconds,
            r.min_seconds,
            r.max_seconds,
            r.mtriangles_per_second,
            r.peak_memory_mib
        );
    }
    Ok(())
}

fn load(spec: &str) -> Result<Scene> {
    let scene = scene::open(spec, &LoadOptions::default())?;
    sightline_core::validate::validate(&scene).check()?;
    Ok(scene)
}

fn overview_camera(scene: &Scene, size: u32) -> Result<Camera> {
    crate::limits::check_pixels(size, size).map_err(anyhow::Error::msg)?;
    let b = scene.bounds();
    let eye = default_eye(scene, b.center(), b.diagonal());
    Ok(Camera::look_at(
        eye,
        b.center(),
        scene.up.vector(),
        60.0,
        size,
        size,
        sightline_core::default_near(scene, eye),
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
    // The incoherent rays are generated up front, 32 bytes each.
    crate::limits::check_count(args.rays as u64, crate::limits::MAX_BENCH_RAYS, "--rays")?;
    let specs = if args.scenes.is_empty() {
        vec!["procedural:city?size=1000000".to_string()]
    } else {
        args.scenes.clone()
    };
    let mut rows = Vec::new();
    if args.device == Device::Gpu && !cfg!(feature = "gpu") {
        return Err(crate::features::not_built("gpu", "--device gpu"));
    }
    // One device for every scene (acquiring one takes a while on lavapipe).
    #[cfg(feature = "gpu")]
    let mut gpu = None;
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
        #[cfg(feature = "gpu")]
        if args.device == Device::Gpu && gpu.is_none() {
            gpu = Some(sightline_gpu::vulkan_device()?);
        }
        #[cfg(feature = "gpu")]
        if let Some((device, queue, info)) = &gpu {
            let t = Instant::now();
            let defaults = sightline_gpu::GpuRayCasterOptions::default();
            let width = args.gpu_width.unwrap_or(defaults.width);
            let options = sightline_gpu::GpuRayCasterOptions { width, ..defaults };
            let caster = sightline_gpu::GpuRayCaster::with_device(
                device,
                queue,
                info.clone(),
                &scene,
                options,
            )?;
            let exact = if caster.exact() { "" } else { ", approximate" };
            casters.push((
                format!(
                    "GPU BVH{width} ({}, {:?}{exact})",
                    info.name, info.device_type
                ),
                t.elapsed().as_secs_f64(),
                Box::new(caster),
            ));
        }
        // Alternate the backends in several short rounds and keep each one's best round, so
        // a burst of load on this shared machine hits both alike and is then discarded.
        const ROUNDS: usize = 5;
        let mut coherent_rates = vec![0.0f64; casters.len()];
        let mut incoherent_rates = vec![0.0f64; casters.len()];
        for _ in 0..ROUNDS {
            for (i, (_, _, c)) in casters.iter().enumerate() {
                let per_round = args.seconds / ROUNDS as f64;
                let coh = measure::rays_per_second(c.as_ref(), &coherent, per_round);
                let inc = measure::rays_per_second(c.as_ref(), &incoherent, per_round);
                coherent_rates[i] = coherent_rates[i].max(coh);
                incoherent_rates[i] = incoherent_rates[i].max(inc);
            }
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
    outln!(
        "| scene | triangles | backend | build s | coherent Mrays/s | incoherent Mrays/s | speed relative to the first backend (coherent / incoherent) |"
    );
    outln!("|---|---:|---|---:|---:|---:|---:|");
    let mut first: Option<(String, f64, f64)> = None;
    for r in &rows {
        if first.as_ref().is_none_or(|f| f.0 != r.scene) {
            first = Some((r.scene.clone(), r.coherent_mrays, r.incoherent_mrays));
        }
        let (_, fc, fi) = first.clone().unwrap_or_default();
        outln!(
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
    crate::limits::check_frames(args.frames as u64, "--frames")?;
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
    outln!("| scene | triangles | size | median ms/frame | Mtriangles/s | covered pixels |");
    outln!("|---|---:|---:|---:|---:|---:|");
    for r in &rows {
        outln!(
            "| `{}` | {} | {}² | {:.1} | {:.1} | {} |",
            r.scene,
            r.triangles,
            r.size,
            r.median_ms,
            r.mtriangles_per_second,
            r.visible_pixels
        );
    }
    Ok(())
}

#[derive(Serialize, Default, Clone)]
struct PvsRow {
    scene: String,
    method: String,
    budget: String,
    cells: usize,
    mean_rays: f64,
    mean_seconds: f64,
    avg_error_pixels: f64,
    avg_unconfirmed_pixels: f64,
    max_error_pixels: usize,
    avg_error_regions: f64,
    max_error_region_size: usize,
    pvs_percent: f64,
    false_negatives: usize,
}

fn pvs(args: PvsArgs) -> Result<()> {
    use sightline_region::cell_sources::{inside_solid, random_free_cells};
    use sightline_region::{
        Budget, CellContext, Gvs, GvsParams, GvsPlusPlus, GvsPlusPlusParams, RandomSampler,
        RasterSampler, Sampler,
    };
    if let Some(ms) = args
        .time_budgets
        .0
        .iter()
        .find(|&&ms| ms == 0 || ms > 3_600_000)
    {
        anyhow::bail!("--time-budgets: {ms} ms is not a budget between 1 ms and one hour");
    }
    if let Some(rays) = args
        .ray_budgets
        .0
        .iter()
        .find(|&&r| r == 0 || r > 100_000_000_000)
    {
        anyhow::bail!("--ray-budgets: {rays} is not a budget between 1 and 10^11 rays");
    }
    // The small budgets at which GVS++ and RAND are compared side by side: (label, budget).
    let small_budgets: Vec<(String, Budget)> = (args.time_budgets.0.iter())
        .map(|&ms| {
            let budget = Budget {
                max_rays: None,
                max_time: Some(std::time::Duration::from_millis(ms)),
            };
            (format!("{ms} ms"), budget)
        })
        .chain(
            (args.ray_budgets.0.iter()).map(|&rays| (format!("{rays} rays"), Budget::rays(rays))),
        )
        .collect();
    let specs = if args.scenes.is_empty() {
        vec![
            "procedural:city".to_string(),
            "procedural:rooms".to_string(),
        ]
    } else {
        args.scenes.clone()
    };
    let gvspp = GvsPlusPlus {
        params: GvsPlusPlusParams {
            n_rand: args.n_rand,
            ..GvsPlusPlusParams::default()
        },
    };
    let gvs = Gvs {
        params: GvsParams {
            n_rand: args.n_rand,
            ..GvsParams::default()
        },
    };
    let raster = RasterSampler::default();
    let eval = sightline_eval::EvalParams {
        viewpoints: args.viewpoints,
        resolution: args.resolution,
        ..sightline_eval::EvalParams::default()
    };
    let mut all_rows = Vec::new();
    for spec in &specs {
        let scene = load(spec)?;
        let bvh = Bvh::build(&scene);
        let half = scene.bounds().diagonal() * args.cell_size;
        let cells = random_free_cells(&scene, &bvh, args.cells, half, args.seed);
        if cells.is_empty() {
            eprintln!("{spec}: found no free space for view cells, skipped");
            continue;
        }
        const LABELS: [(&str, &str); 5] = [
            ("GVS++", "converged"),
            ("RAND", "equal rays"),
            ("RAND", "equal time"),
            ("GVS", "equal rays"),
            ("RASTER", "equal rays"),
        ];
        let mut labels: Vec<(String, String)> = if args.equal_time_only {
            Vec::new()
        } else {
            LABELS
                .iter()
                .map(|(m, b)| (m.to_string(), b.to_string()))
                .collect()
        };
        for (label, _) in &small_budgets {
            for m in ["GVS++", "RAND"] {
                labels.push((m.to_string(), label.clone()));
            }
        }
        let mut rows: Vec<PvsRow> = labels
            .into_iter()
            .map(|(method, budget)| PvsRow {
                scene: spec.clone(),
                method,
                budget,
                cells: cells.len(),
                ..PvsRow::default()
            })
            .collect();
        for (i, cell) in cells.iter().enumerate() {
            eprintln!("{spec}: cell {}/{}", i + 1, cells.len());
            let ctx = CellContext {
                scene: &scene,
                caster: &bvh,
                cell,
                seed: args.seed.wrapping_add(i as u64),
                free_space: None,
            };
            let none = &|_: &sightline_region::ConvergencePoint| {};
            let mut results = Vec::new();
            if !args.equal_time_only {
                let a = gvspp.sample(&ctx, &Budget::default(), none);
                let equal_rays = Budget::rays(a.rays);
                let equal_time = Budget {
                    max_rays: None,
                    max_time: Some(std::time::Duration::from_secs_f64(a.seconds)),
                };
                results = vec![
                    a,
                    RandomSampler.sample(&ctx, &equal_rays, none),
                    RandomSampler.sample(&ctx, &equal_time, none),
                    gvs.sample(&ctx, &equal_rays, none),
                    raster.sample(&ctx, &equal_rays, none),
                ];
            }
            for (_, budget) in &small_budgets {
                results.push(gvspp.sample(&ctx, budget, none));
                results.push(RandomSampler.sample(&ctx, budget, none));
            }
            let sets: Vec<&sightline_core::TriangleSet> =
                results.iter().map(|r| &r.visible).collect();
            // Viewpoints only outside solid geometry: a view from inside a wall sees what no
            // player can, and both methods fail it alike.
            let free = |p: glam::Vec3| !inside_solid(&scene, &bvh, p);
            let evaluations =
                sightline_eval::evaluate_cell_in(&scene, cell, &free, &sets, &eval, &|_, _| {});
            let n = scene.triangle_count().max(1) as f64;
            for ((row, r), e) in rows.iter_mut().zip(&results).zip(&evaluations) {
                row.mean_rays += r.rays as f64;
                row.mean_seconds += r.seconds;
                row.avg_error_pixels += e.avg_error_pixels;
                row.avg_unconfirmed_pixels += e.avg_unconfirmed_pixels;
                row.max_error_pixels = row.max_error_pixels.max(e.max_error_pixels);
                row.avg_error_regions += e.avg_error_regions;
                row.max_error_region_size = row.max_error_region_size.max(e.max_error_region_size);
                row.pvs_percent += 100.0 * e.pvs_size as f64 / n;
                row.false_negatives += e.false_negatives;
            }
        }
        if let Some(dir) = &args.plot {
            std::fs::create_dir_all(dir)?;
            let name: String = spec
                .rsplit('/')
                .next()
                .unwrap_or(spec)
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '.' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            let path = dir.join(format!("convergence_{name}.svg"));
            let ctx = CellContext {
                scene: &scene,
                caster: &bvh,
                cell: &cells[0],
                seed: args.seed,
                free_space: None,
            };
            let samplers: [&dyn Sampler; 4] = [&gvspp, &RandomSampler, &gvs, &raster];
            convergence_plot(&ctx, &samplers, &eval, spec, &path)?;
            eprintln!("wrote {}", path.display());
        }
        let k = cells.len() as f64;
        for row in &mut rows {
            row.mean_rays /= k;
            row.mean_seconds /= k;
            row.avg_error_pixels /= k;
            row.avg_unconfirmed_pixels /= k;
            row.avg_error_regions /= k;
            row.pvs_percent /= k;
        }
        all_rows.extend(rows);
    }
    if args.json {
        return print_json(&all_rows);
    }
    outln!(
        "| scene | method | budget | mean rays | mean s | avg err px | max err px | avg err regions | max region px | avg snapping px | PVS % | false neg (sum) |"
    );
    outln!("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &all_rows {
        outln!(
            "| `{}` | {} | {} | {:.3e} | {:.2} | {:.2} | {} | {:.2} | {} | {:.2} | {:.2} | {} |",
            r.scene,
            r.method,
            r.budget,
            r.mean_rays,
            r.mean_seconds,
            r.avg_error_pixels,
            r.max_error_pixels,
            r.avg_error_regions,
            r.max_error_region_size,
            r.avg_unconfirmed_pixels,
            r.pvs_percent,
            r.false_negatives
        );
    }
    // The equal-time comparison in one line per scene and budget: how many times fewer
    // erroneous pixels GVS++ leaves than RAND.
    for r in all_rows.iter().filter(|r| {
        r.method == "GVS++" && small_budgets.iter().any(|(label, _)| *label == r.budget)
    }) {
        let Some(rand) = all_rows
            .iter()
            .find(|x| x.scene == r.scene && x.method == "RAND" && x.budget == r.budget)
        else {
            continue;
        };
        let ratio = if r.avg_error_pixels > 0.0 {
            format!("{:.1}x", rand.avg_error_pixels / r.avg_error_pixels)
        } else if rand.avg_error_pixels > 0.0 {
            "GVS++ has no error".to_string()
        } else {
            "both have no error".to_string()
        };
        outln!(
            "`{}` at {}: RAND {:.2} avg err px, GVS++ {:.2}: {ratio}",
            r.scene,
            r.budget,
            rand.avg_error_pixels,
            r.avg_error_pixels
        );
    }
    outln!(
        "({} cells per scene, {} viewpoints x 6 cube faces at {}² each)",
        args.cells,
        args.viewpoints,
        args.resolution
    );
    Ok(())
}

/// Average erroneous pixels against rays for every sampler on one cell: each sampler runs at
/// 1/16, 1/8, 1/4, 1/2 and 1 times the rays GVS++ (the first sampler) needs to converge, and
/// all resulting sets are judged on the same views. Log-log; a zero error is drawn at 0.001.
fn convergence_plot(
    ctx: &sightline_region::CellContext<'_>,
    samplers: &[&dyn sightline_region::Sampler],
    eval: &sightline_eval::EvalParams,
    title: &str,
    path: &std::path::Path,
) -> Result<()> {
    use plotters::prelude::*;
    use sightline_region::Budget;
    let none = &|_: &sightline_region::ConvergencePoint| {};
    let converged = samplers[0].sample(ctx, &Budget::default(), none);
    let fractions = [1.0 / 16.0, 0.125, 0.25, 0.5, 1.0];
    let mut runs = Vec::new();
    for s in samplers {
        for f in fractions {
            let budget = Budget::rays(((converged.rays as f64 * f) as u64).max(1));
            runs.push((s.name(), s.sample(ctx, &budget, none)));
        }
    }
    let sets: Vec<&sightline_core::TriangleSet> = runs.iter().map(|(_, r)| &r.visible).collect();
    let evaluations = sightline_eval::evaluate_cell(ctx.scene, ctx.cell, &sets, eval, &|_, _| {});
    let floor = 1e-3;
    let points: Vec<(&str, f64, f64)> = runs
        .iter()
        .zip(&evaluations)
        .map(|((name, r), e)| (*name, r.rays.max(1) as f64, e.avg_error_pixels.max(floor)))
        .collect();
    let (x0, x1) = points
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let y1 = points.iter().fold(1.0f64, |a, p| a.max(p.2));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 600)).into_drawing_area();
        let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
            root.fill(&WHITE)?;
            let mut chart = ChartBuilder::on(&root)
                .caption(
                    format!(
                        "{title}: average erroneous pixels per {}² view",
                        eval.resolution
                    ),
                    ("sans-serif", 18),
                )
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(
                    (x0 * 0.8..x1 * 1.25).log_scale(),
                    (floor..y1 * 2.0).log_scale(),
                )?;
            chart
                .configure_mesh()
                .x_desc("rays (RASTER: pixels)")
                .y_desc("avg error px")
                .draw()?;
            const COLOURS: [RGBColor; 4] = [RED, BLUE, GREEN, MAGENTA];
            for (s, colour) in samplers.iter().zip(COLOURS.iter().cycle()) {
                let series: Vec<(f64, f64)> = points
                    .iter()
                    .filter(|p| p.0 == s.name())
                    .map(|p| (p.1, p.2))
                    .collect();
                chart
                    .draw_series(LineSeries::new(series.clone(), colour))?
                    .label(s.name())
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
                chart.draw_series(series.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()?;
            root.present()?;
            Ok(())
        };
        draw().map_err(|e| anyhow::anyhow!("drawing {}: {e}", path.display()))?;
    }
    sightline_core::atomic_file::write_atomic(path, |w| {
        std::io::Write::write_all(w, svg.as_bytes())
    })
    .map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))
}

#[derive(Serialize, Clone)]
struct ShareRow {
    method: String,
    budget_per_cell: u64,
    total_rays: u64,
    seconds: f64,
    avg_error_pixels: f64,
    max_error_pixels: usize,
    false_negatives: usize,
    pvs_percent: f64,
    shared_percent: f64,
}

#[derive(Serialize)]
struct ShareSpeedup {
    budget_per_cell: u64,
    avg_error_pixels: f64,
    /// Shared rays needed for the same error (interpolated), `None` when no shared budget
    /// reached it; `bound` says whether the value is only a bound.
    shared_rays: Option<f64>,
    shared_seconds: Option<f64>,
    rays_speedup: Option<f64>,
    time_speedup: Option<f64>,
    bound: &'static str,
}

#[derive(Serialize)]
struct ShareReport {
    scene: String,
    triangles: usize,
    cells: usize,
    evaluated_cells: Vec<usize>,
    rows: Vec<ShareRow>,
    speedups: Vec<ShareSpeedup>,
}

/// The cost (rays, seconds) at which the shared curve reaches `error`, interpolating
/// log(cost) linearly in the error between the two shared runs around it; the bound kind when
/// `error` lies outside the shared curve.
fn cost_at_error(shared: &[ShareRow], error: f64) -> (Option<(f64, f64)>, &'static str) {
    // The best error reached with at most each budget (the curve made monotone).
    let mut curve: Vec<(f64, f64, f64)> = Vec::new();
    for r in shared {
        let e = curve
            .last()
            .map_or(r.avg_error_pixels, |c| c.2.min(r.avg_error_pixels));
        curve.push((r.total_rays as f64, r.seconds, e));
    }
    let Some(first) = curve.first() else {
        return (None, "no shared run");
    };
    if error >= first.2 {
        return (Some((first.0, first.1)), "at least");
    }
    for w in curve.windows(2) {
        let (a, b) = (w[0], w[1]);
        if error >= b.2 && error < a.2 {
            let f = (a.2 - error) / (a.2 - b.2);
            let lerp = |x: f64, y: f64| (x.ln() + (y.ln() - x.ln()) * f).exp();
            return (Some((lerp(a.0, b.0), lerp(a.1, b.1))), "");
        }
    }
    (None, "not reached")
}

fn share(args: ShareArgs) -> Result<()> {
    use sightline_region::bake::bake;
    use sightline_region::cell_sources::inside_solid;
    use sightline_region::ray_sharing::{bake_shared, ShareParams};
    use sightline_region::{Budget, GvsPlusPlus, GvsPlusPlusParams, ViewCell};

    let layer: Vec<f32> = args
        .layer
        .split(',')
        .map(|v| v.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("--layer '{}': expected BOTTOM,TOP", args.layer))?;
    if layer.len() != 2 || layer[0] >= layer[1] || layer.iter().any(|v| !v.is_finite()) {
        anyhow::bail!(
            "--layer '{}': expected BOTTOM,TOP with BOTTOM < TOP",
            args.layer
        );
    }
    if args.grid == 0 || args.grid > 1024 {
        anyhow::bail!("--grid {} must be in 1..=1024", args.grid);
    }
    if args.budgets.contains(&0) || args.share_budgets.contains(&0) || args.n_rand == 0 {
        anyhow::bail!("budgets and --n-rand must be positive");
    }
    let scene = load(&args.scene)?;
    let bvh = Bvh::build(&scene);
    let b = scene.bounds();
    let up = scene.up.vector();
    let up_axis = if up == glam::Vec3::Z { 2 } else { 1 };
    let mut min = b.min;
    let mut max = b.max;
    min[up_axis] = b.min[up_axis] + layer[0];
    max[up_axis] = b.min[up_axis] + layer[1];
    let mut n = [args.grid; 3];
    n[up_axis] = 1;
    let cells = ViewCell::grid(min, max, n)?;
    let mut rng = sightline_core::random::SplitMix64::new(args.seed ^ 0x5348_4152);
    let mut order: Vec<usize> = (0..cells.len()).collect();
    for i in (1..order.len()).rev() {
        order.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
    }
    let mut evaluated: Vec<usize> = order.into_iter().take(args.eval_cells).collect();
    evaluated.sort_unstable();

    let independent = GvsPlusPlus {
        params: GvsPlusPlusParams {
            n_rand: args.n_rand,
            ..GvsPlusPlusParams::default()
        },
    };
    let share_params = ShareParams {
        gvspp: GvsPlusPlusParams {
            n_rand: args.share_n_rand.unwrap_or((args.n_rand / 2).max(1)),
            ..GvsPlusPlusParams::default()
        },
        backward: !args.no_backward,
        explore_shared: args.explore_shared,
    };
    let n_tri = scene.triangle_count().max(1) as f64;
    // Origins inside buildings see only the building's inside, which no evaluation viewpoint
    // does: with --free-space both bakes skip them.
    let use_free = args.free_space;
    let bake_free = |_: usize, p: glam::Vec3| !use_free || !inside_solid(&scene, &bvh, p);
    // Per run: its row and the sets of the evaluated cells.
    let mut runs: Vec<(ShareRow, Vec<sightline_core::TriangleSet>)> = Vec::new();
    for &budget in &args.budgets {
        eprintln!("independent GVS++, {budget} rays per cell ...");
        let t = Instant::now();
        let file = bake(
            &scene,
            &bvh,
            &cells,
            &independent,
            &bake_free,
            &Budget::rays(budget),
            args.seed,
            serde_json::Value::Null,
            &|_, _| {},
            &mut |_, _| {},
        );
        let seconds = t.elapsed().as_secs_f64();
        let total_rays = file.metadata["total_rays"].as_u64().unwrap_or(0);
        let sets = evaluated
            .iter()
            .map(|&i| file.cells[i].visible.clone())
            .collect();
        let row = ShareRow {
            method: "GVS++ independent".into(),
            budget_per_cell: budget,
            total_rays,
            seconds,
            pvs_percent: 0.0,
            avg_error_pixels: 0.0,
            max_error_pixels: 0,
            false_negatives: 0,
            shared_percent: 0.0,
        };
        runs.push((row, sets));
    }
    for &budget in &args.share_budgets {
        eprintln!("GVS++ with ray sharing, {budget} rays per cell ...");
        let r = bake_shared(
            &scene,
            &bvh,
            &cells,
            &share_params,
            &Budget::rays(budget),
            args.seed,
            &bake_free,
            &|_| {},
        );
        let found: usize = r.cells.iter().map(|c| c.visible.count_ones(..)).sum();
        let row = ShareRow {
            method: "GVS++ shared".into(),
            budget_per_cell: budget,
            total_rays: r.total_rays,
            seconds: r.seconds,
            pvs_percent: 0.0,
            avg_error_pixels: 0.0,
            max_error_pixels: 0,
            false_negatives: 0,
            shared_percent: 100.0 * r.shared_insertions as f64 / found.max(1) as f64,
        };
        let sets = evaluated
            .iter()
            .map(|&i| r.cells[i].visible.clone())
            .collect();
        runs.push((row, sets));
    }
    let eval = sightline_eval::EvalParams {
        viewpoints: args.viewpoints,
        resolution: args.resolution,
        seed: args.seed,
        ..sightline_eval::EvalParams::default()
    };
    let free = |p: glam::Vec3| !inside_solid(&scene, &bvh, p);
    for (k, &cell) in evaluated.iter().enumerate() {
        eprintln!("evaluating cell {cell} ({}/{})", k + 1, evaluated.len());
        let sets: Vec<&sightline_core::TriangleSet> = runs.iter().map(|(_, s)| &s[k]).collect();
        let evaluations =
            sightline_eval::evaluate_cell_in(&scene, &cells[cell], &free, &sets, &eval, &|_, _| {});
        for ((row, _), e) in runs.iter_mut().zip(&evaluations) {
            row.avg_error_pixels += e.avg_error_pixels / evaluated.len() as f64;
            row.max_error_pixels = row.max_error_pixels.max(e.max_error_pixels);
            row.false_negatives += e.false_negatives;
            row.pvs_percent += 100.0 * e.pvs_size as f64 / n_tri / evaluated.len() as f64;
        }
    }
    let rows: Vec<ShareRow> = runs.into_iter().map(|(r, _)| r).collect();
    let (indep, shared): (Vec<ShareRow>, Vec<ShareRow>) = rows
        .iter()
        .cloned()
        .partition(|r| r.method == "GVS++ independent");
    let speedups: Vec<ShareSpeedup> = indep
        .iter()
        .map(|r| {
            let (cost, bound) = cost_at_error(&shared, r.avg_error_pixels);
            ShareSpeedup {
                budget_per_cell: r.budget_per_cell,
                avg_error_pixels: r.avg_error_pixels,
                shared_rays: cost.map(|c| c.0),
                shared_seconds: cost.map(|c| c.1),
                rays_speedup: cost.map(|c| r.total_rays as f64 / c.0),
                time_speedup: cost.map(|c| r.seconds / c.1),
                bound,
            }
        })
        .collect();
    let report = ShareReport {
        scene: args.scene.clone(),
        triangles: scene.triangle_count(),
        cells: cells.len(),
        evaluated_cells: evaluated,
        rows,
        speedups,
    };
    if args.json {
        return print_json(&report);
    }
    outln!(
        "`{}` ({} triangles), {} cells ({}x{} over the ground, layer {}), pixel error on {} cells x {} viewpoints x 6 faces at {}²",
        report.scene,
        report.triangles,
        report.cells,
        args.grid,
        args.grid,
        args.layer,
        report.evaluated_cells.len(),
        args.viewpoints,
        args.resolution
    );
    outln!();
    outln!("| method | rays/cell budget | total rays | s | avg err px | max err px | false neg (sum) | PVS % | first found via another cell's ray % |");
    outln!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &report.rows {
        outln!(
            "| {} | {} | {:.3e} | {:.1} | {:.3} | {} | {} | {:.2} | {:.1} |",
            r.method,
            r.budget_per_cell,
            r.total_rays as f64,
            r.seconds,
            r.avg_error_pixels,
            r.max_error_pixels,
            r.false_negatives,
            r.pvs_percent,
            r.shared_percent
        );
    }
    outln!();
    outln!("| independent rays/cell | its avg err px | shared rays for that error | speed-up (rays) | speed-up (time) |");
    outln!("|---:|---:|---:|---:|---:|");
    for s in &report.speedups {
        let prefix = if s.bound == "at least" { ">= " } else { "" };
        let fmt =
            |v: Option<f64>| v.map_or_else(|| s.bound.to_string(), |v| format!("{prefix}{v:.1}x"));
        outln!(
            "| {} | {:.3} | {} | {} | {} |",
            s.budget_per_cell,
            s.avg_error_pixels,
            s.shared_rays
                .map_or_else(|| s.bound.to_string(), |v| format!("{v:.3e}")),
            fmt(s.rays_speedup),
            fmt(s.time_speedup)
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(rays: u64, seconds: f64, error: f64) -> ShareRow {
        ShareRow {
            method: "GVS++ shared".into(),
            budget_per_cell: rays,
            total_rays: rays,
            seconds,
            avg_error_pixels: error,
            max_error_pixels: 0,
            false_negatives: 0,
            pvs_percent: 0.0,
            shared_percent: 0.0,
        }
    }

    #[test]
    fn cost_at_error_interpolates_and_bounds() {
        assert_eq!(cost_at_error(&[], 1.0), (None, "no shared run"));
        // A noisy curve: the 400 run is worse than the 200 run; the envelope keeps 2.0.
        let curve = [
            row(100, 1.0, 8.0),
            row(200, 2.0, 2.0),
            row(400, 4.0, 3.0),
            row(800, 8.0, 0.5),
        ];
        assert_eq!(cost_at_error(&curve, 9.0), (Some((100.0, 1.0)), "at least"));
        let (cost, bound) = cost_at_error(&curve, 5.0);
        let (rays, seconds) = cost.unwrap();
        assert_eq!(bound, "");
        // Halfway in error between 8 and 2: halfway between 100 and 200 in log(rays).
        assert!((rays - 100.0 * 2f64.sqrt()).abs() < 1e-9 && (seconds - 2f64.sqrt()).abs() < 1e-12);
        // 1.0 lies between the envelope's 2.0 (at 400) and 0.5 (at 800).
        let (cost, _) = cost_at_error(&curve, 1.0);
        assert!(cost.unwrap().0 > 400.0 && cost.unwrap().0 < 800.0);
        assert_eq!(cost_at_error(&curve, 0.1), (None, "not reached"));
    }
}
