//! `sightline pvs`: bake, show, diff and compare potentially visible sets.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{bail, Context, Result};
use glam::Vec3;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use serde::Serialize;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_region::bake::BakeSetup;
use sightline_region::cell_sources::{
    inside_solid, q3_cells, read_cells_file, Q3CellKind, Q3Cells, Q3Origins, Q3_ORIGINS_KEY,
};
use sightline_region::checkpoint::{checkpoint_path, fingerprint, ResumableBake};
use sightline_region::methods::{sampler, MethodOverrides, MethodParams, METHODS};
use sightline_region::pvs_file::EncodedPvsFile;
use sightline_region::reachable::{ReachParams, DEFAULT_STEP};
use sightline_region::rebake::{
    plan_incremental_bake, IncrementalBake, IncrementalBakeError, OldBake,
};
use sightline_region::shards::{merge, Shard};
use sightline_region::RasterSampler;
use sightline_region::{Budget, PvsFile, ViewCell};

use super::bench::Device;
use crate::args::{thread_count, SceneArgs};
use crate::errors::ExitStatus;
use crate::output::{print_json, refuse_overwriting_inputs};
use crate::output_lock::OutputLock;

/// Arguments of `sightline pvs`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(clap::Subcommand, Debug)]
enum What {
    /// Compute the PVS of view cells and write a .pvs file.
    Bake(Box<BakeArgs>),
    /// Print a .pvs file's header, metadata, object count and per-cell triangle and object set
    /// sizes (--objects: the object table).
    Show(ShowArgs),
    /// Join the shard files of a bake (`pvs bake --shard I/N`) into one .pvs, cells in order.
    Merge(MergeArgs),
    /// Compare two .pvs files of the same scene cell by cell. Exit status as `diff`: 0 when
    /// every cell's set is equal, 1 when some differ (with a summary line: cells differing,
    /// triangles only in the second file = added, only in the first = removed), 2 on errors.
    Diff(DiffArgs),
    /// Compare a PVS baked on a Quake 3 map's leaves (--q3-leaves) with the map's own compiled
    /// cluster PVS, cluster by cluster.
    CompareQ3(CompareQ3Args),
}

/// Where the view cells come from (exactly one source).
#[derive(clap::Args, Debug)]
pub(crate) struct CellArgs {
    /// JSON or TOML file with `cells`: `{"min": [..], "max": [..]}` or
    /// `{"center", "axes", "half_extents"}` entries.
    #[arg(long, value_name = "FILE")]
    cells: Option<PathBuf>,
    /// A cell on the command line: `box:MINX,MINY,MINZ,MAXX,MAXY,MAXZ` or `point:X,Y,Z,R`
    /// (repeatable).
    #[arg(long, value_name = "SPEC", allow_hyphen_values = true)]
    cell: Vec<String>,
    /// A regular grid of NX,NY,NZ cells over --bounds (default: the scene bounds); at most
    /// 2^20 cells in all (every cell's set stays in memory until the file is written).
    #[arg(long, value_name = "NX,NY,NZ")]
    grid: Option<String>,
    /// Region of --grid: MINX,MINY,MINZ,MAXX,MAXY,MAXZ.
    #[arg(
        long,
        value_name = "MINX,MINY,MINZ,MAXX,MAXY,MAXZ",
        allow_hyphen_values = true
    )]
    bounds: Option<String>,
    /// With --grid: drop cells whose centre is inside solid geometry.
    #[arg(long)]
    skip_solid: bool,
    /// Quake 3 maps: one cell per BSP leaf box (cells of a cluster together form it). Ray
    /// origins stay inside the leaf's cluster and in the space reachable from the map's spawn
    /// points; leaves without reachable space are not baked (see --include-unreachable).
    #[arg(long)]
    q3_leaves: bool,
    /// Quake 3 maps: one cell per cluster (the bounding box of its leaves; ray origins stay
    /// inside the cluster and in reachable space, as for --q3-leaves).
    #[arg(long)]
    q3_clusters: bool,
    /// With --q3-leaves or --q3-clusters: only these clusters (comma-separated).
    #[arg(long, value_name = "C1,C2,..", value_delimiter = ',')]
    clusters: Vec<u32>,
    /// With --q3-leaves or --q3-clusters: bake every cell, with origins anywhere in the cell's
    /// cluster (the rule before reachable space: also inside detail brushes, behind patches and
    /// in sealed voids, where no player can be).
    #[arg(long)]
    include_unreachable: bool,
    /// With --q3-leaves or --q3-clusters: lattice step, in map units, of the reachable space
    /// (the free space flood-filled from the spawn points; a player box is 32 x 32 x 56).
    /// Smaller finds narrower passages and costs 8x the memory and time per halving; the
    /// lattice is capped at 2^28 points.
    #[arg(long, value_name = "UNITS", default_value_t = DEFAULT_STEP, allow_hyphen_values = true)]
    reach_step: f32,
}

#[derive(clap::Args, Debug)]
pub(crate) struct BakeArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    cells: CellArgs,
    /// Sampling method.
    #[arg(long, default_value = "gvs++", value_parser = clap::builder::PossibleValuesParser::new(METHODS))]
    method: String,
    /// Ray budget per cell (RASTER counts 6 R² per cube map). GVS++ keeps it to within one
    /// exploration step (about 340 rays at the defaults). Without --rays and --time, GVS++
    /// and GVS run until their own termination rule, RAND casts 10M rays, RASTER renders 64
    /// cube maps.
    #[arg(long)]
    rays: Option<u64>,
    /// Time budget per cell in milliseconds (wall clock: cells bake in parallel and share the
    /// cores; results under a time budget are not reproducible, use --rays for that).
    #[arg(long, value_name = "MS")]
    time: Option<u64>,
    /// Seed of every random choice (same seed, same result).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// `gpu` casts the bake's rays with the GPU ray caster (wgpu compute shaders; see
    /// `sightline bench trace --device gpu`). Hits are bit-identical to the CPU caster's on
    /// adapters with `SHADER_F64`, so the PVS is the same as a CPU bake's for the same seed and
    /// ray budget. Cells still run in parallel, each casting its own batches.
    #[arg(long, value_enum, default_value_t = Device::Cpu)]
    device: Device,
    // The methods' parameters (`--n-rand` to `--raster-resolution`): one list in the region
    // crate, which the Python `Method` takes as keywords too.
    #[command(flatten)]
    method_overrides: MethodOverrides,
    /// Output .pvs file (written atomically). While baking, finished cells are kept in
    /// OUTPUT.checkpoint; rerunning the same command resumes from it.
    #[arg(short, long)]
    output: PathBuf,
    /// Discard an existing checkpoint of OUTPUT instead of resuming from it.
    #[arg(long)]
    restart: bool,
    /// Least seconds between checkpoint writes (the first finished cell and the end are always
    /// written).
    #[arg(long, default_value_t = 2.0, value_name = "S")]
    checkpoint_every: f64,
    /// Bake only shard I of N: the cells whose index modulo N is I. Join the shard files with
    /// `sightline pvs merge`.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Incremental rebake: reuse the sets of this earlier .pvs (baked with the same cells,
    /// method, parameters, seed and budget on --old-scene) for every cell the scene edit cannot
    /// change, and rebake only the others.
    #[arg(long, value_name = "OLD.pvs", requires = "old_scene")]
    since: Option<PathBuf>,
    /// With --since: the scene the earlier .pvs was baked for (file or procedural spec).
    #[arg(long, value_name = "SCENE", requires = "since")]
    old_scene: Option<String>,
    /// With --since: rays per cell and added object cast in the old scene from the cell
    /// through the added geometry's box; one that gets there unblocked rebakes the cell
    /// (catches geometry seen only against the sky, with no old triangle behind it). 0 skips
    /// the probe.
    #[arg(long, default_value_t = 16384, value_name = "N")]
    probe_rays: usize,
    /// Worker threads (default: all cores; at most 4 per core, more are capped with a
    /// warning). Results do not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
    /// GVS++ only: bake all cells together, every ray also counting for every other cell it
    /// crosses (ray sharing); --rays and --time stay per cell.
    #[arg(long)]
    share_rays: bool,
}

#[derive(clap::Args, Debug)]
pub(crate) struct MergeArgs {
    /// The shard files (from `pvs bake --shard I/N` with otherwise identical arguments).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Output .pvs file (written atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Write the merge even when some cells are in none of the files (the result lists its
    /// cells' global indices in `cell_indices`).
    #[arg(long)]
    allow_partial: bool,
    /// Print a JSON summary.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args, Debug)]
pub(crate) struct ShowArgs {
    /// The .pvs file.
    file: PathBuf,
    /// Also list the object table (name, index, part, triangles, bounds) of a version-2 file.
    #[arg(long)]
    objects: bool,
    /// Print JSON (with the triangle and object ids of every cell, and the object table).
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args, Debug)]
pub(crate) struct DiffArgs {
    /// First .pvs file.
    a: PathBuf,
    /// Second .pvs file.
    b: PathBuf,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args, Debug)]
pub(crate) struct CompareQ3Args {
    /// The Quake 3 map (.bsp) the PVS was baked for.
    map: PathBuf,
    /// A .pvs baked with --q3-leaves on that map.
    pvs: PathBuf,
    /// Quake 3 maps: patch tessellation used for the bake.
    #[arg(long, default_value_t = 4)]
    patch_subdivisions: u32,
    /// Also measure the pixel error of both PVSs from this many viewpoints per leaf (inside
    /// the leaf's own cluster), six cube faces each; 0 skips it.
    #[arg(long, default_value_t = 0)]
    viewpoints: usize,
    /// Resolution of those views.
    #[arg(long, default_value_t = 256)]
    resolution: u32,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: Args) -> Result<()> {
    match args.what {
        What::Bake(a) => run_bake(*a),
        What::Show(a) => run_show(a),
        What::Merge(a) => run_merge(a),
        // As `diff`: 0 same sets, 1 different, 2 trouble (unreadable or unrelated files).
        What::Diff(a) => run_diff(a).map_err(|e| match e.downcast_ref::<ExitStatus>() {
            Some(_) => e,
            None => e.context(ExitStatus(2)),
        }),
        What::CompareQ3(a) => run_compare_q3(a),
    }
}

fn parse_numbers(s: &str, n: usize, what: &str) -> Result<Vec<f32>> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{what} '{s}': not a list of numbers"))?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        bail!("{what} '{s}': expected {n} finite numbers");
    }
    Ok(v)
}

/// The cells and, for Quake 3 leaves and clusters, their clusters and origin rule.
fn collect_cells<'a>(
    args: &CellArgs,
    scene: &'a sightline_core::Scene,
    caster: &Bvh,
) -> Result<(Vec<ViewCell>, Option<Q3Cells<'a>>)> {
    let sources = usize::from(args.cells.is_some())
        + usize::from(!args.cell.is_empty())
        + usize::from(args.grid.is_some())
        + usize::from(args.q3_leaves)
        + usize::from(args.q3_clusters);
    if sources != 1 {
        bail!("give exactly one cell source: --cells FILE, --cell SPEC, --grid NX,NY,NZ, --q3-leaves or --q3-clusters");
    }
    let q3 = args.q3_leaves || args.q3_clusters;
    if !q3 && (args.include_unreachable || args.reach_step != DEFAULT_STEP) {
        bail!("--include-unreachable and --reach-step apply to --q3-leaves and --q3-clusters only");
    }
    if let Some(path) = &args.cells {
        return Ok((read_cells_file(path)?, None));
    }
    if !args.cell.is_empty() {
        let cells = args
            .cell
            .iter()
            .map(|s| ViewCell::parse(s))
            .collect::<Result<_, _>>()?;
        return Ok((cells, None));
    }
    if let Some(grid) = &args.grid {
        let n = parse_numbers(grid, 3, "--grid")?;
        if n.iter().any(|&x| x < 1.0 || x.fract() != 0.0 || x > 4096.0) {
            bail!("--grid '{grid}': counts must be whole numbers in 1..=4096");
        }
        let (min, max) = match &args.bounds {
            Some(b) => {
                let v = parse_numbers(b, 6, "--bounds")?;
                (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]))
            }
            None => {
                let b = scene.bounds();
                (b.min, b.max)
            }
        };
        crate::limits::check_cells(&[n[0] as u64, n[1] as u64, n[2] as u64], "--grid")?;
        let mut cells = ViewCell::grid(min, max, [n[0] as u32, n[1] as u32, n[2] as u32])?;
        if args.skip_solid {
            cells.retain(|c| !inside_solid(scene, caster, c.center));
        }
        return Ok((cells, None));
    }
    if scene.bsp.is_none() {
        bail!("--q3-leaves and --q3-clusters need a Quake 3 map (.bsp) as the scene");
    }
    let filter = (!args.clusters.is_empty()).then_some(args.clusters.as_slice());
    let kind = if args.q3_clusters {
        Q3CellKind::Clusters
    } else {
        Q3CellKind::Leaves
    };
    let origins = if args.include_unreachable {
        Q3Origins::Cluster
    } else {
        Q3Origins::Reachable(ReachParams {
            step: args.reach_step,
        })
    };
    let mut q3 = q3_cells(scene, kind, filter, origins).context("--reach-step")?;
    let map = Path::new(&scene.source).file_stem().map_or_else(
        || scene.source.clone(),
        |s| s.to_string_lossy().into_owned(),
    );
    let line = q3.summary.describe(&map);
    match (&q3.summary.fallback, q3.summary.dropped_cells) {
        (Some(_), _) => eprintln!("warning: {line}"),
        (None, 0) if q3.rule.reach.is_none() => {}
        (None, 0) => eprintln!("{line}"),
        (None, _) => eprintln!("{line} (--include-unreachable bakes them with the old rule)"),
    }
    let cells = std::mem::take(&mut q3.cells);
    Ok((cells, Some(q3)))
}

#[derive(Serialize)]
struct BakeSummary {
    output: PathBuf,
    method: String,
    cells: usize,
    /// Cells taken from the checkpoint of an interrupted run.
    resumed_cells: usize,
    /// Cells baked by this run.
    baked_cells: usize,
    /// With --since: cells whose sets were kept (remapped) from the earlier .pvs.
    kept_cells: usize,
    total_rays: u64,
    seconds: f64,
    mean_pvs_size: f64,
    mean_pvs_percent: f64,
    /// Bytes per finished cell kept in memory while baking (encoded set, statistics text,
    /// bookkeeping).
    memory_bytes_per_cell: f64,
    /// Bytes per cell of the encoded sets alone.
    set_bytes_per_cell: f64,
    /// Bytes per cell of the written file (including its metadata).
    file_bytes_per_cell: f64,
    /// Quake 3 cells: the origin rule and what it found (unreachable leaves and clusters,
    /// dropped cells, the reachable space's parameters and cost), as in the file's metadata.
    reachable: Option<serde_json::Value>,
}

fn run_bake(args: BakeArgs) -> Result<()> {
    if args.threads.is_none() {
        return bake_command(&args);
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(thread_count(args.threads)?)
        .build()
        .context("starting the worker threads")?
        .install(|| bake_command(&args))
}

/// The GPU ray caster for a bake, with a line on stderr naming the adapter.
#[cfg(feature = "gpu")]
fn gpu_caster(scene: &sightline_core::Scene) -> Result<Box<dyn RayCaster>> {
    let caster = sightline_gpu::GpuRayCaster::new(scene, Default::default())?;
    let info = caster.adapter_info();
    eprintln!("casting rays on {} ({:?})", info.name, info.device_type);
    if !caster.exact() {
        eprintln!(
            "warning: this adapter has no SHADER_F64: hit distances may differ from the CPU \
             caster's in the last bits, and the PVS slightly from a CPU bake's"
        );
    }
    Ok(Box::new(caster))
}

/// A headless build has no GPU caster (`bake_command` refuses `--device gpu` before loading).
#[cfg(not(feature = "gpu"))]
fn gpu_caster(_scene: &sightline_core::Scene) -> Result<Box<dyn RayCaster>> {
    Err(crate::features::not_built("gpu", "--device gpu"))
}

fn bake_command(args: &BakeArgs) -> Result<()> {
    if args.device == Device::Gpu && !cfg!(feature = "gpu") {
        return Err(crate::features::not_built("gpu", "--device gpu"));
    }
    // The --since file may be the output: it is read whole before the output is replaced,
    // so an in-place incremental rebake is safe.
    let mut inputs = vec![Path::new(&args.scene.scene)];
    inputs.extend(args.cells.cells.as_deref());
    inputs.extend(args.old_scene.as_deref().map(Path::new));
    let checkpoint = checkpoint_path(&args.output);
    refuse_overwriting_inputs(&[&args.output, &checkpoint], &inputs)?;
    let _lock = OutputLock::acquire(&args.output)?;
    let scene = args.scene.load()?;
    let bvh = Bvh::build(&scene);
    let (cells, q3) = collect_cells(&args.cells, &scene, &bvh)?;
    if cells.is_empty() {
        bail!("no view cells to bake (all filtered out?)");
    }
    let clusters = q3.as_ref().map(|q| q.rule.clusters.clone());
    // What the bake's cells depend on beyond their boxes: the cluster of each Quake 3 cell and
    // the origin rule (the reachable space's parameters). Plain cells keep `{"clusters": null}`,
    // the value the Python bindings' fingerprint uses for them.
    let cells_key = match &q3 {
        None => serde_json::json!({ "clusters": null }),
        Some(q) => serde_json::json!({
            "clusters": clusters,
            "origins": q.origins().fingerprint(),
        }),
    };
    let origins_record = q3.as_ref().map(|q| q.summary.clone());
    let params = args.method_overrides.params();
    let sampler = sampler(&args.method, &params)?;
    if args.rays == Some(0) || args.time == Some(0) {
        bail!("--rays and --time must be positive");
    }
    if args.method == "raster" {
        // RASTER spends its budget a cube map at a time (6 R² pixels, counted as rays): a
        // smaller budget still renders one per cell, which the user should hear about.
        let r = u64::from(
            params
                .raster_resolution
                .unwrap_or(RasterSampler::default().resolution),
        );
        let cube_map = 6 * r * r;
        if let Some(rays) = args.rays.filter(|&rays| rays < cube_map) {
            eprintln!(
                "warning: --rays {rays} is less than one RASTER cube map (6 x {r}² = {cube_map} \
                 pixels, counted as rays); every cell renders one, {cube_map} rays"
            );
        }
    }
    if !(args.checkpoint_every.is_finite() && args.checkpoint_every >= 0.0) {
        bail!("--checkpoint-every must be a non-negative number of seconds");
    }
    let shard = args
        .shard
        .as_deref()
        .map(Shard::parse)
        .transpose()
        .map_err(|e| anyhow::anyhow!("--shard: {e}"))?;
    let budget = Budget {
        max_rays: args.rays,
        max_time: args.time.map(Duration::from_millis),
    };
    // Quake 3 leaf boxes are bounding boxes of convex leaves and reach into solid space: only
    // points whose BSP cluster is the leaf's own serve as origins, and by default only those a
    // player can reach.
    let free_space = |cell: usize, p: Vec3| q3.as_ref().is_none_or(|q| q.rule.allows(cell, p));
    if args.share_rays {
        // All cells are baked together, so the per-cell machinery (shards, checkpoints,
        // incremental rebakes) does not apply.
        if args.shard.is_some() || args.since.is_some() || args.restart {
            bail!("--share-rays bakes all cells at once: it cannot be combined with --shard, --since or --restart");
        }
        if args.device == Device::Gpu {
            bail!("--share-rays casts on the CPU only (--device gpu is not supported with it yet)");
        }
        let mut extra = serde_json::json!({
            "parameters": format!("{params:?}"),
            "clusters": clusters,
        });
        if let Some(r) = &origins_record {
            extra[Q3_ORIGINS_KEY] = serde_json::json!(r);
        }
        return bake_with_shared_rays(
            args,
            &scene,
            &bvh,
            &cells,
            &params,
            &budget,
            &free_space,
            extra,
        );
    }
    let gpu = match args.device {
        Device::Cpu => None,
        Device::Gpu => Some(gpu_caster(&scene)?),
    };
    let caster: &dyn RayCaster = match &gpu {
        Some(g) => g.as_ref(),
        None => &bvh,
    };
    let setup = BakeSetup {
        scene: &scene,
        caster,
        cells: &cells,
        sampler: sampler.as_ref(),
        free_space: &free_space,
        budget,
        seed: args.seed,
    };
    let parameters = format!("{params:?}");
    let fp = fingerprint(&setup, &parameters, cells_key);
    let indices = match shard {
        Some(s) => s.indices(cells.len()),
        None => (0..cells.len()).collect(),
    };
    if indices.is_empty() {
        bail!(
            "shard {} has no cells (the bake has only {} cells)",
            args.shard.as_deref().unwrap_or(""),
            cells.len()
        );
    }
    let (kept, run_key, incremental) = match (&args.since, &args.old_scene) {
        (Some(old_pvs), Some(old_scene)) => {
            let mut planned = plan_incremental(args, old_pvs, old_scene, &scene, &cells, &fp)?;
            let key = serde_json::json!({
                "since": old_pvs.display().to_string(),
                "since_scene_hash": format!("{:016x}", planned.old_scene_hash),
            });
            let kept = std::mem::take(&mut planned.kept);
            (kept, key, Some((old_pvs, old_scene, planned)))
        }
        _ => (BTreeMap::new(), serde_json::Value::Null, None),
    };
    let kept_count = indices.iter().filter(|i| kept.contains_key(i)).count();
    let job = ResumableBake {
        setup,
        indices,
        kept,
        fingerprint: fp,
        run_key,
        checkpoint: Some(checkpoint_path(&args.output)),
        restart: args.restart,
        checkpoint_interval: Duration::from_secs_f64(args.checkpoint_every),
        max_new_cells: None,
    };

    let multi = MultiProgress::new();
    let cells_bar = multi.add(
        ProgressBar::new(job.indices.len() as u64).with_style(
            ProgressStyle::with_template("cells {bar:30} {pos}/{len} [{elapsed_precise} < {eta}]")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        ),
    );
    let cell_bar = multi.add(ProgressBar::new_spinner());
    let n = scene.triangle_count().max(1) as f64;
    let progress = job.run_with(
        &mut |done| cells_bar.set_position(done as u64),
        &|cell, p| {
            cell_bar.set_message(format!(
                "cell {cell}: {} rays, PVS {} ({:.2}%)",
                p.rays,
                p.pvs_size,
                100.0 * p.pvs_size as f64 / n
            ));
            cell_bar.tick();
        },
        &mut |_, _| cells_bar.inc(1),
    )?;
    cell_bar.finish_and_clear();
    cells_bar.finish_and_clear();
    let mut extra = serde_json::json!({
        "parameters": parameters,
        "clusters": clusters,
    });
    if let Some(r) = &origins_record {
        extra[Q3_ORIGINS_KEY] = serde_json::json!(r);
    }
    if let Some(s) = shard {
        extra["shard"] = serde_json::json!({"index": s.index, "count": s.count});
        // Each shard file carries only its cells' clusters.
        if let Some(c) = &clusters {
            extra["clusters"] =
                serde_json::json!(job.indices.iter().map(|&i| c[i]).collect::<Vec<_>>());
        }
    }
    if let Some((since, old_scene, r)) = &incremental {
        extra["incremental"] = serde_json::json!({
            "since": since.display().to_string(),
            "old_scene": old_scene,
            "removed_triangles": r.removed,
            "added_triangles": r.added,
            "added_boxes": r.boxes,
            "kept_cells": kept_count,
            "rebaked_cells": job.indices.len() - kept_count,
        });
    }
    job.write_output(&args.output, &progress, extra)?;
    let sizes: Vec<usize> = progress.done.values().map(|c| c.set.len()).collect();
    let mean = sizes.iter().sum::<usize>() as f64 / sizes.len().max(1) as f64;
    let summary = BakeSummary {
        output: args.output.clone(),
        method: sampler.name().to_string(),
        cells: job.indices.len(),
        resumed_cells: progress.resumed,
        baked_cells: progress.baked,
        kept_cells: kept_count,
        total_rays: progress.done.values().map(|c| c.rays).sum(),
        seconds: progress.seconds,
        mean_pvs_size: mean,
        mean_pvs_percent: 100.0 * mean / n,
        memory_bytes_per_cell: progress.memory_bytes() as f64 / sizes.len().max(1) as f64,
        set_bytes_per_cell: progress.set_bytes() as f64 / sizes.len().max(1) as f64,
        file_bytes_per_cell: std::fs::metadata(&args.output).map_or(0.0, |m| m.len() as f64)
            / sizes.len().max(1) as f64,
        reachable: origins_record.as_ref().map(|r| serde_json::json!(r)),
    };
    if args.json {
        return print_json(&summary);
    }
    if let Some((_, _, r)) = &incremental {
        outln!(
            "incremental: {} triangles removed, {} added in {} groups; rebaked {} of {} cells, kept {}",
            r.removed,
            r.added,
            r.boxes,
            job.indices.len() - kept_count,
            job.indices.len(),
            kept_count
        );
    }
    outln!(
        "baked {} cells with {} in {:.2} s ({} resumed from the checkpoint, {} rays): mean PVS {:.0} \
         triangles ({:.2}% of {}), {:.0} bytes per cell in memory, wrote {}",
        summary.cells,
        summary.method,
        summary.seconds,
        summary.resumed_cells,
        summary.total_rays,
        summary.mean_pvs_size,
        summary.mean_pvs_percent,
        scene.triangle_count(),
        summary.memory_bytes_per_cell,
        summary.output.display()
    );
    Ok(())
}

/// `--since OLD.pvs --old-scene OLD`: loads the old scene (with this bake's loading options)
/// and file, and plans the rebake in `sightline-region`, which checks that the file fits.
fn plan_incremental(
    args: &BakeArgs,
    old_pvs: &Path,
    old_scene: &str,
    scene: &sightline_core::Scene,
    cells: &[ViewCell],
    fp: &serde_json::Value,
) -> Result<IncrementalBake> {
    let old_scene_args = SceneArgs {
        scene: old_scene.to_string(),
        ..args.scene.clone()
    };
    let old = old_scene_args.load()?;
    let old_file =
        PvsFile::load(old_pvs).with_context(|| format!("reading {}", old_pvs.display()))?;
    let old_bake = OldBake {
        path: old_pvs,
        file: &old_file,
        scene: &old,
    };
    let planned = plan_incremental_bake(&old_bake, scene, fp, cells.len(), args.probe_rays)
        .map_err(|e| match e {
            // The library names no flag; the user's own words say which scene was meant.
            IncrementalBakeError::OldSceneMismatch { source, .. } => anyhow::Error::new(source)
                .context(format!("{} and --old-scene {old_scene}", old_pvs.display())),
            e => e.into(),
        })?;
    Ok(planned)
}

#[derive(Serialize)]
struct MergeSummary {
    output: PathBuf,
    files: usize,
    cells: usize,
    total_cells: u64,
}

fn run_merge(args: MergeArgs) -> Result<()> {
    let inputs: Vec<&Path> = args.files.iter().map(PathBuf::as_path).collect();
    refuse_overwriting_inputs(&[&args.output], &inputs)?;
    let mut files = Vec::with_capacity(args.files.len());
    for p in &args.files {
        let f = EncodedPvsFile::load(p).with_context(|| format!("reading {}", p.display()))?;
        files.push((p.clone(), f));
    }
    let merged = merge(&files, args.allow_partial)?;
    merged.save(&args.output)?;
    let summary = MergeSummary {
        output: args.output.clone(),
        files: files.len(),
        cells: merged.cells.len(),
        total_cells: merged.metadata["total_cells"].as_u64().unwrap_or(0),
    };
    if args.json {
        return print_json(&summary);
    }
    outln!(
        "merged {} files: {} of {} cells, wrote {}",
        summary.files,
        summary.cells,
        summary.total_cells,
        summary.output.display()
    );
    Ok(())
}

/// `pvs bake --share-rays`: all cells at once with ray sharing (GVS++ only); writes the file
/// and prints the summary like the independent bake.
#[allow(clippy::too_many_arguments)]
fn bake_with_shared_rays(
    args: &BakeArgs,
    scene: &sightline_core::Scene,
    bvh: &Bvh,
    cells: &[ViewCell],
    params: &MethodParams,
    budget: &Budget,
    free_space: &(dyn Fn(usize, Vec3) -> bool + Sync),
    extra: serde_json::Value,
) -> Result<()> {
    use sightline_region::ray_sharing::{bake_shared, ShareParams};
    let reachable = extra.get(Q3_ORIGINS_KEY).cloned();
    if !matches!(args.method.as_str(), "gvs++" | "gvspp") {
        bail!(
            "--share-rays works with --method gvs++ only (got '{}')",
            args.method
        );
    }
    // As measured by `bench share` (docs/BENCHMARKS.md): received triangles are explored too.
    let share = ShareParams {
        gvspp: params.gvspp.clone(),
        explore_shared: true,
        ..ShareParams::default()
    };
    let bar = ProgressBar::new_spinner();
    let result = bake_shared(
        scene,
        bvh,
        cells,
        &share,
        budget,
        args.seed,
        free_space,
        &|p| {
            bar.set_message(format!(
                "round {}: {} rays, {} cells sampling, mean PVS {:.0}",
                p.round,
                p.rays,
                p.sampling_cells,
                p.total_pvs as f64 / cells.len().max(1) as f64
            ));
            bar.tick();
        },
    );
    bar.finish_and_clear();
    let file = result.to_pvs_file(scene, cells, &share, budget, args.seed, extra);
    file.save(&args.output)?;
    let n = scene.triangle_count().max(1) as f64;
    let mean = file
        .cells
        .iter()
        .map(|c| c.visible.count_ones(..))
        .sum::<usize>() as f64
        / file.cells.len().max(1) as f64;
    // Sets are held decoded while the shared bake runs (all cells advance together).
    let set_bytes: usize = file
        .cells
        .iter()
        .map(|c| {
            sightline_region::EncodedSet::encode(&c.visible, scene.triangle_count()).payload_bytes()
        })
        .sum();
    let per_cell = |bytes: f64| bytes / file.cells.len().max(1) as f64;
    let file_bytes = std::fs::metadata(&args.output).map_or(0, |m| m.len());
    let summary = BakeSummary {
        output: args.output.clone(),
        method: "gvs++ shared".into(),
        cells: cells.len(),
        resumed_cells: 0,
        baked_cells: cells.len(),
        kept_cells: 0,
        total_rays: result.total_rays,
        seconds: result.seconds,
        mean_pvs_size: mean,
        mean_pvs_percent: 100.0 * mean / n,
        memory_bytes_per_cell: scene.triangle_count().div_ceil(8) as f64,
        set_bytes_per_cell: per_cell(set_bytes as f64),
        file_bytes_per_cell: per_cell(file_bytes as f64),
        reachable,
    };
    if args.json {
        return print_json(&summary);
    }
    outln!(
        "baked {} cells with GVS++ and ray sharing in {:.2} s ({} rays, {} triangles handed from cell to cell): mean PVS {:.0} triangles ({:.2}% of {}), wrote {}",
        summary.cells,
        summary.seconds,
        summary.total_rays,
        result.shared_insertions,
        summary.mean_pvs_size,
        summary.mean_pvs_percent,
        scene.triangle_count(),
        summary.output.display()
    );
    Ok(())
}

#[derive(Serialize)]
struct CellJson {
    center: [f32; 3],
    half_extents: [f32; 3],
    axes: [[f32; 3]; 3],
    pvs_size: usize,
    triangles: Vec<usize>,
    /// Visible objects (version 2 files).
    objects: Option<Vec<usize>>,
}

#[derive(Serialize)]
struct ObjectJson {
    name: String,
    index: Option<u32>,
    part: Option<u32>,
    triangles: usize,
    bounds_min: [f32; 3],
    bounds_max: [f32; 3],
}

fn object_rows(file: &PvsFile) -> Option<Vec<ObjectJson>> {
    let table = file.objects.as_ref()?;
    let mut triangles = vec![0usize; table.objects.len()];
    for &o in &table.object_of_triangle {
        triangles[o as usize] += 1;
    }
    Some(
        table
            .objects
            .iter()
            .zip(triangles)
            .map(|(o, triangles)| ObjectJson {
                name: o.name.clone(),
                index: o.index,
                part: o.part,
                triangles,
                bounds_min: o.bounds_min.to_array(),
                bounds_max: o.bounds_max.to_array(),
            })
            .collect(),
    )
}

fn run_show(args: ShowArgs) -> Result<()> {
    let file =
        PvsFile::load(&args.file).with_context(|| format!("reading {}", args.file.display()))?;
    let version = if file.objects.is_some() { 2 } else { 1 };
    if args.json {
        #[derive(Serialize)]
        struct Out {
            version: u32,
            scene_hash: String,
            triangle_count: u32,
            metadata: serde_json::Value,
            objects: Option<Vec<ObjectJson>>,
            cells: Vec<CellJson>,
        }
        let cells = file
            .cells
            .iter()
            .enumerate()
            .map(|(i, c)| CellJson {
                center: c.cell.center.to_array(),
                half_extents: c.cell.half_extents.to_array(),
                axes: c.cell.axes.map(|a| a.to_array()),
                pvs_size: c.visible.count_ones(..),
                triangles: c.visible.ones().collect(),
                objects: file.visible_objects(i).map(|o| o.ones().collect()),
            })
            .collect();
        return print_json(&Out {
            version,
            scene_hash: format!("{:016x}", file.scene_hash),
            triangle_count: file.triangle_count,
            objects: object_rows(&file),
            metadata: file.metadata,
            cells,
        });
    }
    let n = f64::from(file.triangle_count.max(1));
    outln!("file       {}", args.file.display());
    outln!(
        "scene      {} ({} triangles, hash {:016x})",
        file.metadata["scene"].as_str().unwrap_or("?"),
        file.triangle_count,
        file.scene_hash
    );
    outln!(
        "method     {}",
        file.metadata["method"].as_str().unwrap_or("?")
    );
    outln!("version    {version}");
    match &file.objects {
        Some(t) => outln!("objects    {}", t.objects.len()),
        None => outln!("objects    none (version 1: triangle sets only; bake again for objects)"),
    }
    if args.objects {
        for (i, o) in object_rows(&file).unwrap_or_default().iter().enumerate() {
            let number = |v: Option<u32>| v.map_or("-".to_string(), |v| v.to_string());
            outln!(
                "  object {i:>5}  {:<40}  index {:>5}  part {:>4}  {:>7} triangles  bounds {:.2?} .. {:.2?}",
                o.name,
                number(o.index),
                number(o.part),
                o.triangles,
                o.bounds_min,
                o.bounds_max
            );
        }
    }
    outln!("cells      {}", file.cells.len());
    let objects_total = file.objects.as_ref().map_or(0, |t| t.objects.len().max(1)) as f64;
    for (i, c) in file.cells.iter().enumerate() {
        let size = c.visible.count_ones(..);
        let objects = file.visible_objects(i).map_or(String::new(), |o| {
            let k = o.count_ones(..);
            format!(
                "  objects {k:>6} ({:.2}%)",
                100.0 * k as f64 / objects_total
            )
        });
        outln!(
            "  cell {i:>4}  centre {:>28}  half extents {:>24}  PVS {size:>8} ({:.2}%){objects}",
            format!("{:.2?}", c.cell.center.to_array()),
            format!("{:.2?}", c.cell.half_extents.to_array()),
            100.0 * size as f64 / n
        );
    }
    Ok(())
}

#[derive(Serialize)]
struct CellDiff {
    cell: usize,
    size_a: usize,
    size_b: usize,
    only_in_a: usize,
    only_in_b: usize,
    jaccard: f64,
    /// Objects (when both files have the same object table).
    objects_a: Option<usize>,
    objects_b: Option<usize>,
    objects_only_in_a: Option<usize>,
    objects_only_in_b: Option<usize>,
}

fn run_diff(args: DiffArgs) -> Result<()> {
    let a = PvsFile::load(&args.a).with_context(|| format!("reading {}", args.a.display()))?;
    let b = PvsFile::load(&args.b).with_context(|| format!("reading {}", args.b.display()))?;
    if a.scene_hash != b.scene_hash || a.triangle_count != b.triangle_count {
        bail!(
            "{} and {} were made for different scenes",
            args.a.display(),
            args.b.display()
        );
    }
    if a.cells.len() != b.cells.len() {
        bail!(
            "{} has {} cells, {} has {}",
            args.a.display(),
            a.cells.len(),
            args.b.display(),
            b.cells.len()
        );
    }
    // Objects are compared only under one object table: the same scene can be loaded with
    // another grouping (e.g. before and after a loader change), and ids would then differ.
    let same_objects = a.objects.is_some() && a.objects == b.objects;
    let mut rows = Vec::new();
    for (i, (ca, cb)) in a.cells.iter().zip(&b.cells).enumerate() {
        if ca.cell != cb.cell {
            bail!("cell {i} differs in geometry between the files");
        }
        let union = ca.visible.union(&cb.visible).count().max(1);
        let (oa, ob) = match (same_objects, a.visible_objects(i), b.visible_objects(i)) {
            (true, Some(oa), Some(ob)) => (Some(oa), Some(ob)),
            _ => (None, None),
        };
        let count = |s: &Option<fixedbitset::FixedBitSet>| s.as_ref().map(|s| s.count_ones(..));
        let only = |x: &Option<fixedbitset::FixedBitSet>, y: &Option<fixedbitset::FixedBitSet>| {
            x.as_ref()
                .zip(y.as_ref())
                .map(|(x, y)| x.difference(y).count())
        };
        rows.push(CellDiff {
            objects_a: count(&oa),
            objects_b: count(&ob),
            objects_only_in_a: only(&oa, &ob),
            objects_only_in_b: only(&ob, &oa),
            cell: i,
            size_a: ca.visible.count_ones(..),
            size_b: cb.visible.count_ones(..),
            only_in_a: ca.visible.difference(&cb.visible).count(),
            only_in_b: cb.visible.difference(&ca.visible).count(),
            jaccard: ca.visible.intersection(&cb.visible).count() as f64 / union as f64,
        });
    }
    let differing: Vec<&CellDiff> = rows
        .iter()
        .filter(|r| r.only_in_a + r.only_in_b > 0)
        .collect();
    let summary = format!(
        "{} of {} cells differ: {} triangles added (only in {}), {} removed (only in {}), \
         summed over cells",
        differing.len(),
        rows.len(),
        differing.iter().map(|r| r.only_in_b).sum::<usize>(),
        args.b.display(),
        differing.iter().map(|r| r.only_in_a).sum::<usize>(),
        args.a.display()
    );
    let status = if differing.is_empty() {
        Ok(())
    } else {
        Err(ExitStatus(1).into())
    };
    if args.json {
        print_json(&rows)?;
        return status;
    }
    if !same_objects {
        outln!(
            "(objects not compared: {})",
            if a.objects.is_none() || b.objects.is_none() {
                "a version-1 file has none"
            } else {
                "the files' object tables differ"
            }
        );
    }
    outln!("| cell | |A| | |B| | only in A | only in B | Jaccard | objects A | objects B | objects only in A | objects only in B |");
    outln!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let opt = |v: Option<usize>| v.map_or("-".to_string(), |v| v.to_string());
    for r in &rows {
        outln!(
            "| {} | {} | {} | {} | {} | {:.4} | {} | {} | {} | {} |",
            r.cell,
            r.size_a,
            r.size_b,
            r.only_in_a,
            r.only_in_b,
            r.jaccard,
            opt(r.objects_a),
            opt(r.objects_b),
            opt(r.objects_only_in_a),
            opt(r.objects_only_in_b)
        );
    }
    outln!("{summary}");
    status
}

#[derive(Serialize)]
struct ClusterComparison {
    cluster: u32,
    leaves: usize,
    ours: usize,
    q3map2: usize,
    ours_not_q3map2: usize,
    q3map2_not_ours: usize,
    /// Average erroneous pixels per view of our PVS and of q3map2's (with --viewpoints).
    ours_avg_error_pixels: Option<f64>,
    q3map2_avg_error_pixels: Option<f64>,
    /// Viewpoints not evaluated (outside the cluster, or unreachable in a bake with reachable
    /// origins), with --viewpoints.
    rejected_viewpoints: sightline_eval::report::evaluate::Rejected,
}

fn run_compare_q3(args: CompareQ3Args) -> Result<()> {
    let scene_args = SceneArgs::new(args.map.display().to_string(), args.patch_subdivisions);
    let scene = scene_args.load()?;
    let file =
        PvsFile::load(&args.pvs).with_context(|| format!("reading {}", args.pvs.display()))?;
    file.check_scene(&scene)?;
    let Some(bsp) = scene.bsp.as_deref() else {
        bail!("{} is not a Quake 3 map", args.map.display())
    };
    let Some(clusters) = file.metadata["clusters"].as_array() else {
        bail!(
            "{} was not baked with --q3-leaves (no cluster per cell)",
            args.pvs.display()
        );
    };
    if clusters.len() != file.cells.len() {
        bail!(
            "{}: cluster list does not match the cells",
            args.pvs.display()
        );
    }
    type ClusterCells = (Vec<ViewCell>, fixedbitset::FixedBitSet);
    let mut by_cluster: std::collections::BTreeMap<u32, ClusterCells> = Default::default();
    for (c, cell) in clusters.iter().zip(&file.cells) {
        let c = c.as_u64().context("cluster ids must be numbers")? as u32;
        let entry = by_cluster.entry(c).or_insert_with(|| {
            (
                Vec::new(),
                fixedbitset::FixedBitSet::with_capacity(scene.triangle_count()),
            )
        });
        entry.0.push(cell.cell);
        entry.1.union_with(&cell.visible);
    }
    let eval = sightline_eval::EvalParams {
        viewpoints: args.viewpoints,
        resolution: args.resolution.clamp(1, 8192),
        ..sightline_eval::EvalParams::default()
    };
    // Viewpoints where the bake took its origins: the cluster, and reachable space when the
    // bake recorded one.
    let viewpoints = sightline_eval::report::evaluate::Viewpoints::of(&scene, &file, None)?;
    let mut rows = Vec::new();
    for (cluster, (leaves, ours)) in by_cluster {
        let mut q3 = fixedbitset::FixedBitSet::with_capacity(scene.triangle_count());
        for t in bsp.triangles_visible_from_cluster(cluster) {
            q3.insert(t as usize);
        }
        let (mut ours_error, mut q3_error) = (None, None);
        let filter = viewpoints.cluster(cluster);
        if args.viewpoints > 0 {
            let (mut sum, mut images) = ([0.0f64; 2], 0usize);
            for leaf in &leaves {
                let e = sightline_eval::evaluate_cell_in(
                    &scene,
                    leaf,
                    &|p| filter.allows(p),
                    &[&ours, &q3],
                    &eval,
                    &|_, _| {},
                );
                for (k, ek) in e.iter().enumerate() {
                    sum[k] += ek.avg_error_pixels * ek.images as f64;
                }
                images += e[0].images;
            }
            if images > 0 {
                ours_error = Some(sum[0] / images as f64);
                q3_error = Some(sum[1] / images as f64);
            }
        }
        rows.push(ClusterComparison {
            rejected_viewpoints: filter.rejected(),
            cluster,
            ours_avg_error_pixels: ours_error,
            q3map2_avg_error_pixels: q3_error,
            leaves: leaves.len(),
            ours: ours.count_ones(..),
            q3map2: q3.count_ones(..),
            ours_not_q3map2: ours.difference(&q3).count(),
            q3map2_not_ours: q3.difference(&ours).count(),
        });
    }
    if args.json {
        return print_json(&rows);
    }
    outln!("| cluster | leaves | ours | q3map2 | ours, culled by q3map2 | q3map2, not ours | ours avg err px | q3map2 avg err px |");
    outln!("|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        let error = |e: Option<f64>| e.map_or("-".to_string(), |v| format!("{v:.3}"));
        outln!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            r.cluster,
            r.leaves,
            r.ours,
            r.q3map2,
            r.ours_not_q3map2,
            r.q3map2_not_ours,
            error(r.ours_avg_error_pixels),
            error(r.q3map2_avg_error_pixels)
        );
    }
    let suspicious: usize = rows.iter().map(|r| r.ours_not_q3map2).sum();
    outln!(
        "{} clusters; {suspicious} (cluster, triangle) pairs we see that q3map2's conservative PVS culls \
         (each is a bug in one of the two, or geometry q3map2 does not treat as occluding)",
        rows.len()
    );
    Ok(())
}
