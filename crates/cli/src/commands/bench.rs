//! `sightline bench`: whole-algorithm throughput, measured side by side in one run so that
//! ratios stay meaningful on shared, noisy machines. Prints a Markdown table (or JSON) ready for
//! `docs/BENCHMARKS.md`. The measuring is `sightline_eval::bench`'s; this file parses the
//! options, loads the scenes, builds the ray casters (the GPU one behind the `gpu` feature) and
//! prints the rows.

use anyhow::Result;
use clap::Subcommand;
use indicatif::ProgressBar;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::Scene;
use sightline_eval::bench::{self as eval_bench, Progress, TraceBackend};

use crate::args::{parse_ms_budgets, parse_ray_budgets, BudgetList};
use crate::output::print_json;

mod peers;
mod plot;
mod scenes;
mod tables;

use scenes::{load, overview_camera};

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
    /// rays and at equal time, GVS and RASTER at equal rays; pixel error on shared views. With
    /// `--device gpu`, every GVS++ row again with the GPU ray caster (same cells and seeds).
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
    /// Peers side by side, one thread each: our occlusion buffer against Intel's Masked
    /// Occlusion Culling (AVX2 and AVX-512) on random and real occluder sets, our BVH against
    /// tinybvh (and Embree with `--features embree`) on `bench trace`'s rays, build time
    /// included. The peers run as harnesses (`bench/peers/`) that `scripts/peer-bench` builds
    /// from their own checkouts.
    Peers(peers::PeersArgs),
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
    /// The grid of cells: `N` (N x N over the scene's ground plane, one cell high) or
    /// `NX,NY,NZ` as in `pvs bake --grid`, with 1 along the scene's up axis (the cells form one
    /// layer, --layer). At most 1024 per axis.
    #[arg(long, value_name = "N|NX,NY,NZ", default_value = "16")]
    grid: String,
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
    /// GVS++ random rays per round of the independent bakes (with --fixed-rounds).
    #[arg(long, default_value_t = 50_000)]
    n_rand: u64,
    /// Random rays per cell and round of the shared bakes (default: half of --n-rand, as
    /// each is also cast backward; with --fixed-rounds).
    #[arg(long)]
    share_n_rand: Option<u64>,
    /// Both bakes in the paper's rounds (as before the eighteenth session); by default both
    /// schedule each cell's rays by yield.
    #[arg(long)]
    fixed_rounds: bool,
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
    #[arg(
        long = "views",
        alias = "viewpoints",
        value_name = "N",
        default_value_t = 16
    )]
    viewpoints: usize,
    /// Evaluation image size (square: one number, or NxN).
    #[arg(long = "size", alias = "resolution", value_name = "PX", default_value = "256",
        value_parser = crate::args::parse_square_size)]
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
    #[arg(
        long = "views",
        alias = "viewpoints",
        value_name = "N",
        default_value_t = 50
    )]
    viewpoints: usize,
    /// Evaluation image size (square: one number, or NxN).
    #[arg(long = "size", alias = "resolution", value_name = "PX", default_value = "512",
        value_parser = crate::args::parse_square_size)]
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
    /// `gpu` repeats every GVS++ row with the GPU ray caster ("GVS++ GPU": the same cells,
    /// seeds and budgets; its time per cell and rays/s beside the CPU's, and the cells whose
    /// set differs from the CPU bake's, 0 expected except at time budgets).
    #[arg(long, value_enum, default_value_t = Device::Cpu)]
    device: Device,
    /// With `--device gpu`: which GPU caster (see `pvs bake --gpu-caster`). With ray queries
    /// the sets may differ from the CPU bake's where rays decide at ties.
    #[arg(long, value_enum, default_value_t = GpuCasterChoice::Auto)]
    gpu_caster: GpuCasterChoice,
    /// Small time budgets (milliseconds, comma-separated) at which GVS++ and RAND are also
    /// compared at equal time, the paper's equal-time comparison (issue 24: GVS++ must start
    /// exploring before such a budget is spent). `none`: no equal-time rows.
    #[arg(
        long,
        value_name = "MS,..|none",
        default_value = "250,1000",
        value_parser = parse_ms_budgets
    )]
    time_budgets: BudgetList,
    /// Small ray budgets (comma-separated) at which GVS++ and RAND are also compared at equal
    /// rays: the equal-time comparison without the machine's load in it (both cast rays at the
    /// same rate, about 5 M rays per second on two cores, so 1 M rays is about 250 ms there).
    /// Empty (the default): none.
    #[arg(long, value_name = "RAYS,..", default_value = "none", value_parser = parse_ray_budgets)]
    ray_budgets: BudgetList,
    /// Only the equal-time rows of `--time-budgets` (GVS++ and RAND at each budget): skips the
    /// converged GVS++ bake and the baselines at its ray count, which take minutes per cell on
    /// large scenes.
    #[arg(long)]
    equal_time_only: bool,
    /// Also run GVS++ with the paper's discontinuities (searched at the border polygon's 9
    /// vertices only, not at every border sample) to convergence, as one more row: what our
    /// search of every border sample brings, on the same cells and views. Not with
    /// --equal-time-only.
    #[arg(long, conflicts_with = "equal_time_only")]
    paper_discontinuities: bool,
    /// Write plots per scene as SVG files into DIR: the convergence curves (average error
    /// against rays for every method, on the scene's first cell; not with --equal-time-only)
    /// and, with small budgets, GVS++ and RAND's error against seconds at those budgets
    /// (`budgets_<scene>.svg`).
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
    /// `gpu` adds the GPU ray casters (wgpu compute shaders, and hardware ray queries where the
    /// adapter has them; on the adapter `sightline-gpu` picks, `SIGHTLINE_GPU_ADAPTER` chooses)
    /// beside the CPU casters, on the same rays.
    #[arg(long, value_enum, default_value_t = Device::Cpu)]
    device: Device,
    /// Children per node of the GPU caster's BVH (2, 4 or 8), to compare layouts (default:
    /// the GPU caster's own, 4).
    #[arg(long, value_name = "N")]
    gpu_width: Option<usize>,
    /// With `--device gpu`: which GPU casters to measure. `auto` (the default) measures the
    /// compute caster and, where the adapter has ray queries, the ray-query caster too.
    #[arg(long, value_enum, default_value_t = GpuCasterChoice::Auto)]
    gpu_caster: GpuCasterChoice,
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

/// Which GPU ray caster (`--gpu-caster`, with `--device gpu`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum GpuCasterChoice {
    /// Hardware ray queries where the adapter has them (Vulkan `VK_KHR_ray_query`), else the
    /// compute shader.
    #[default]
    Auto,
    /// The compute-shader caster: hits bit-identical to the CPU caster's on adapters with
    /// `SHADER_F64`, so a bake's sets equal a CPU bake's.
    Compute,
    /// Hardware ray queries (an error on an adapter without them): the driver's triangle
    /// test, hits equal to the CPU's except at ties and edges within rounding.
    RayQuery,
}

#[cfg(feature = "gpu")]
impl GpuCasterChoice {
    /// The library's name for the choice.
    pub(crate) fn kind(self) -> sightline_gpu::GpuCasterKind {
        match self {
            Self::Auto => sightline_gpu::GpuCasterKind::Auto,
            Self::Compute => sightline_gpu::GpuCasterKind::Compute,
            Self::RayQuery => sightline_gpu::GpuCasterKind::RayQuery,
        }
    }
}

impl Device {
    /// Refuses `--device gpu` in a build without the GPU parts (cargo feature `gpu`).
    pub(crate) fn check_built(self) -> Result<()> {
        match self {
            Device::Cpu => Ok(()),
            Device::Gpu => crate::features::require_gpu("--device gpu"),
        }
    }
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
        What::Peers(a) => peers::run(a),
    }
}

/// A bar over `len` `unit`s of a bench run on stderr (hidden when stderr is not a terminal).
fn bench_bar(len: usize, unit: &str) -> ProgressBar {
    crate::progress::bar(len as u64, &crate::progress::template(unit))
}

/// Prints a benchmark's progress line on stderr, above `bar` (alone where the bar is hidden,
/// so a log keeps every line); a round also moves the bar.
fn print_above(bar: &ProgressBar, p: &Progress<'_>) {
    bar.suspend(|| eprintln!("{p}"));
    if let Progress::Round { round, rounds } = *p {
        bar.set_length(rounds as u64);
        bar.set_position(round.saturating_sub(1) as u64);
    }
}

fn rv(args: RvArgs) -> Result<()> {
    anyhow::ensure!(args.rounds > 0, "--rounds must be at least 1");
    crate::limits::check_count(args.rounds as u64, crate::limits::MAX_FRAMES, "--rounds")?;
    anyhow::ensure!(args.triangles > 0, "--triangles must be at least 1");
    let threads = crate::args::thread_count(args.threads)?;
    crate::limits::check_pixels(args.size, args.size).map_err(anyhow::Error::msg)?;
    let options = eval_bench::RvBenchOptions {
        triangles: args.triangles,
        threads,
        size: args.size,
        rounds: args.rounds,
        memory_budget_bytes: args.memory,
    };
    let bar = bench_bar(args.rounds, "rounds");
    let rows = eval_bench::bench_rv(&options, Some(&|p| print_above(&bar, p)));
    bar.finish_and_clear();
    let rows = rows?;
    if args.json {
        return print_json(&rows);
    }
    tables::rv(&rows, &options)
}

/// The CPU ray casters `bench trace` measures: our BVH, and Embree when built with it.
fn cpu_backends(scene: &Scene) -> Result<Vec<TraceBackend>> {
    let named = |name: &str, c: Box<dyn RayCaster>| Ok::<_, anyhow::Error>((name.to_string(), c));
    Ok(vec![
        TraceBackend::timed(|| named("sightline BVH", Box::new(Bvh::build(scene))))?,
        #[cfg(feature = "embree")]
        TraceBackend::timed(|| {
            let embree = sightline_core::trace::embree::EmbreeCaster::build(scene)?;
            named("Embree 3", Box::new(embree))
        })?,
    ])
}

fn trace(args: TraceArgs) -> Result<()> {
    // The incoherent rays are generated up front, 32 bytes each.
    crate::limits::check_count(args.rays as u64, crate::limits::MAX_BENCH_RAYS, "--rays")?;
    let specs = if args.scenes.is_empty() {
        vec!["procedural:city?size=1000000".to_string()]
    } else {
        args.scenes.clone()
    };
    args.device.check_built()?;
    // One device for every scene (acquiring one takes a while on lavapipe).
    #[cfg(feature = "gpu")]
    let mut gpu = None;
    let mut rows = Vec::new();
    let bar = bench_bar(specs.len(), "scenes");
    for spec in &specs {
        bar.set_message(format!("{spec}: loading, building the casters"));
        let scene = load(spec)?;
        let camera = overview_camera(&scene, args.size)?;
        let rays = eval_bench::TraceRays::new(&scene, &camera, args.rays);
        let backends = cpu_backends(&scene)?;
        #[cfg(feature = "gpu")]
        if args.device == Device::Gpu && gpu.is_none() {
            gpu = Some(sightline_gpu::vulkan_device()?);
        }
        #[cfg(feature = "gpu")]
        let mut backends = backends;
        #[cfg(feature = "gpu")]
        if let Some((device, queue, info)) = &gpu {
            use sightline_gpu::{AnyGpuCaster, GpuCasterKind, RayQueryCaster};
            let defaults = sightline_gpu::GpuRayCasterOptions::default();
            let width = args.gpu_width.unwrap_or(defaults.width);
            let options = sightline_gpu::GpuRayCasterOptions { width, ..defaults };
            let kinds = match args.gpu_caster {
                GpuCasterChoice::Auto if RayQueryCaster::supported(device) => {
                    vec![GpuCasterKind::Compute, GpuCasterKind::RayQuery]
                }
                GpuCasterChoice::Auto => vec![GpuCasterKind::Compute],
                choice => vec![choice.kind()],
            };
            for kind in kinds {
                backends.push(TraceBackend::timed(|| {
                    let caster = AnyGpuCaster::with_device(
                        device,
                        queue,
                        info.clone(),
                        &scene,
                        kind,
                        options,
                    )?;
                    let exact = if caster.exact() { "" } else { ", approximate" };
                    let (name, device_type) = (&info.name, info.device_type);
                    let name = match kind {
                        GpuCasterKind::RayQuery => {
                            format!("GPU ray queries ({name}, {device_type:?}{exact})")
                        }
                        _ => format!("GPU BVH{width} ({name}, {device_type:?}{exact})"),
                    };
                    Ok::<_, anyhow::Error>((name, Box::new(caster) as Box<dyn RayCaster>))
                })?);
            }
        }
        let n = scene.triangle_count();
        let seconds = args.seconds;
        // Each caster on the coherent and the incoherent rays.
        let expected = 2.0 * seconds * backends.len() as f64;
        bar.set_message(format!("{spec}: measuring, about {expected:.0} s"));
        rows.extend(eval_bench::bench_trace(spec, n, &backends, &rays, seconds));
        bar.inc(1);
    }
    bar.finish_and_clear();
    if args.json {
        return print_json(&rows);
    }
    tables::trace(&rows)
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
    let bar = bench_bar(specs.len(), "scenes");
    for spec in &specs {
        bar.set_message(format!("{spec}: loading"));
        let scene = load(spec)?;
        let camera = overview_camera(&scene, args.size)?;
        bar.set_message(format!("{spec}: {} frames", args.frames));
        rows.push(eval_bench::bench_raster(spec, &scene, &camera, args.frames));
        bar.inc(1);
    }
    bar.finish_and_clear();
    if args.json {
        return print_json(&rows);
    }
    tables::raster(&rows)
}

fn pvs(args: PvsArgs) -> Result<()> {
    args.device.check_built()?;
    let options = eval_bench::PvsBenchOptions {
        cells: args.cells,
        cell_size: args.cell_size,
        viewpoints: args.viewpoints,
        resolution: args.resolution,
        n_rand: args.n_rand,
        seed: args.seed,
        time_budgets_ms: args.time_budgets.0.clone(),
        ray_budgets: args.ray_budgets.0.clone(),
        equal_time_only: args.equal_time_only,
        // The curves start from a converged GVS++ bake, which --equal-time-only skips.
        convergence: args.plot.is_some() && !args.equal_time_only,
        paper_discontinuities: args.paper_discontinuities,
    };
    options.validate().map_err(|e| match e {
        eval_bench::BenchError::TimeBudget(_) => anyhow::anyhow!("--time-budgets: {e}"),
        eval_bench::BenchError::RayBudget(_) => anyhow::anyhow!("--ray-budgets: {e}"),
        e => e.into(),
    })?;
    let specs = if args.scenes.is_empty() {
        vec![
            "procedural:city".to_string(),
            "procedural:rooms".to_string(),
        ]
    } else {
        args.scenes.clone()
    };
    let mut all_rows = Vec::new();
    let bar = bench_bar(specs.len(), "scenes");
    // One device for every scene (acquiring one takes a while on lavapipe).
    #[cfg(feature = "gpu")]
    let gpu = match args.device {
        Device::Gpu => Some(sightline_gpu::vulkan_device()?),
        Device::Cpu => None,
    };
    for spec in &specs {
        bar.set_message(spec.clone());
        let scene = load(spec)?;
        #[cfg(feature = "gpu")]
        let caster = match &gpu {
            Some((device, queue, info)) => {
                let caster = sightline_gpu::AnyGpuCaster::with_device(
                    device,
                    queue,
                    info.clone(),
                    &scene,
                    args.gpu_caster.kind(),
                    Default::default(),
                )?;
                bar.suspend(|| eprintln!("GVS++ GPU rows: {}", caster.describe()));
                Some(caster)
            }
            None => None,
        };
        #[cfg(feature = "gpu")]
        let second = caster.as_ref().map(|c| eval_bench::SecondCaster {
            method: "GVS++ GPU",
            caster: c,
        });
        #[cfg(not(feature = "gpu"))]
        let second = None;
        let on_progress = |p: &Progress<'_>| print_above(&bar, p);
        let report =
            eval_bench::bench_pvs_scene_on(spec, &scene, &options, second, Some(&on_progress))?;
        bar.inc(1);
        if let (Some(dir), Some(convergence)) = (&args.plot, &report.convergence) {
            let path = plot::write_convergence_plot(dir, spec, convergence, args.resolution)?;
            bar.suspend(|| eprintln!("wrote {}", path.display()));
        }
        if let Some(dir) = &args.plot {
            if let Some(path) = plot::write_budget_plot(dir, spec, &report.rows, args.resolution)? {
                bar.suspend(|| eprintln!("wrote {}", path.display()));
            }
        }
        all_rows.extend(report.rows);
    }
    bar.finish_and_clear();
    if args.json {
        return print_json(&all_rows);
    }
    tables::pvs(&all_rows, &options)
}

/// `bench share --grid`: `N` is N x N over the ground of `scene` (1 along its up axis);
/// `NX,NY,NZ` is taken as given (the library refuses more than 1 along the up axis).
fn share_grid(text: &str, scene: &sightline_core::Scene) -> Result<[u32; 3]> {
    let bad = || anyhow::anyhow!("--grid '{text}': expected N or NX,NY,NZ (whole numbers)");
    let counts: Vec<u32> = text
        .split(',')
        .map(|v| v.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad())?;
    match counts[..] {
        [n] => {
            let mut grid = [n; 3];
            grid[scene.up.index()] = 1;
            Ok(grid)
        }
        [x, y, z] => Ok([x, y, z]),
        _ => Err(bad()),
    }
}

fn share(args: ShareArgs) -> Result<()> {
    let bad_layer = || {
        let layer = &args.layer;
        anyhow::anyhow!("--layer '{layer}': expected BOTTOM,TOP with BOTTOM < TOP")
    };
    let layer: Vec<f32> = args
        .layer
        .split(',')
        .map(|v| v.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("--layer '{}': expected BOTTOM,TOP", args.layer))?;
    let [bottom, top] = layer[..] else {
        return Err(bad_layer());
    };
    let scene = load(&args.scene)?;
    let options = eval_bench::ShareBenchOptions {
        grid: share_grid(&args.grid, &scene)?,
        layer: (bottom, top),
        budgets: args.budgets.clone(),
        share_budgets: args.share_budgets.clone(),
        n_rand: args.n_rand,
        share_n_rand: args.share_n_rand,
        fixed_rounds: args.fixed_rounds,
        backward: !args.no_backward,
        explore_shared: args.explore_shared,
        eval_cells: args.eval_cells,
        viewpoints: args.viewpoints,
        resolution: args.resolution,
        seed: args.seed,
        free_space: args.free_space,
    };
    options.validate().map_err(|e| match e {
        eval_bench::BenchError::Layer(..) => bad_layer(),
        eval_bench::BenchError::Grid(n) => {
            anyhow::anyhow!("--grid {}: {n} cells is not in 1..=1024", args.grid)
        }
        eval_bench::BenchError::Zero { .. } => {
            anyhow::anyhow!("budgets and --n-rand must be positive")
        }
        e => e.into(),
    })?;
    let bar = crate::progress::bar(0, "{spinner} bench share [{elapsed_precise}]");
    let report = eval_bench::bench_share(
        &args.scene,
        &scene,
        &options,
        Some(&|p| print_above(&bar, p)),
    );
    bar.finish_and_clear();
    let report = report?;
    if args.json {
        return print_json(&report);
    }
    tables::share(&report, &options, &args.layer)
}
