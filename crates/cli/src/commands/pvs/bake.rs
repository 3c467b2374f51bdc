//! `sightline pvs bake` and `pvs merge`: the bake of the cells `cells.rs` collects (per cell or
//! with shared rays, on the CPU or the GPU caster), incremental rebakes, shard merging.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{bail, Context, Result};
use glam::Vec3;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use serde::Serialize;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_point::rv::{bake_sampler_for_cells, ConservativeSampler, CONSERVATIVE};
use sightline_region::bake::BakeSetup;
use sightline_region::bound::BoundTotals;
use sightline_region::cell_sources::{write_cells_file, Q3Cells, Q3OriginsSummary, Q3_ORIGINS_KEY};
use sightline_region::checkpoint::{checkpoint_path, fingerprint, BakeProgress, ResumableBake};
use sightline_region::methods::MethodParams;
use sightline_region::occupancy::{plain_cells_key, BakeOccupancy, OccupancySummary};
use sightline_region::pvs_file::EncodedPvsFile;
use sightline_region::rebake::{
    plan_incremental_bake, IncrementalBake, IncrementalBakeError, OldBake,
};
use sightline_region::shards::{merge, Shard};
use sightline_region::RasterSampler;
use sightline_region::{Budget, PvsFile, Sampler, ViewCell};

use crate::args::{thread_count, SceneArgs};
use crate::commands::bench::Device;
use crate::output::{print_json, refuse_overwriting_inputs};
use crate::output_lock::OutputLock;

use super::args::{BakeArgs, MergeArgs};
use super::bound::{bound_line, bound_sampler, bound_with_progress};
use super::cells::collect_cells;
use super::gpu::gpu_caster;

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
    /// Methods with a termination rule (GVS, GVS++): cells the budget stopped before the rule
    /// held (`converged: false` in their statistics). `None` for RAND and RASTER.
    unconverged_cells: Option<usize>,
    /// Mesh cells: how many of the baked cells reach into closed geometry (their origins there
    /// were skipped) and which lie wholly inside it (no origins: an empty set). `None` for
    /// Quake 3 cells and with --origins-anywhere.
    solid: Option<OccupancySummary>,
    /// With --bound: the conservative bounds' method, time, mean bound size over mean set
    /// size, and cells whose set the conservative method did not contain (as the file's
    /// `metadata.bound`).
    bound: Option<BoundTotals>,
}

/// Of cells' `converged` flags (`None` where a cell has none): how many are `false`, `None`
/// when no cell has a flag.
fn count_unconverged(flags: impl IntoIterator<Item = Option<bool>>) -> Option<usize> {
    flags.into_iter().flatten().fold(None, |n, converged| {
        Some(n.unwrap_or(0) + usize::from(!converged))
    })
}

/// Warns on stderr when cells stopped on the budget before converging.
fn warn_unconverged(summary: &BakeSummary) {
    if let Some(n @ 1..) = summary.unconverged_cells {
        eprintln!(
            "warning: {n} of {} cells stopped on the budget before {}'s termination rule held \
             (not converged: their PVS may miss triangles; `converged: false` in the file's cell \
             statistics). Raise --rays / --time, or bake without a budget to run each cell to \
             convergence.",
            summary.cells, summary.method
        );
    }
}

/// Says on stderr how many mesh cells reach into closed geometry, and warns about cells that lie
/// wholly inside it (their sets are empty).
fn warn_solid_cells(summary: &BakeSummary) {
    let Some(s) = &summary.solid else { return };
    if s.partly_closed > 0 {
        eprintln!(
            "{} of {} cells reach into closed geometry: their origins there were skipped \
             (--origins-anywhere keeps them)",
            s.partly_closed, s.tested
        );
    }
    if !s.all_closed.is_empty() {
        let shown: Vec<String> = s
            .all_closed
            .iter()
            .take(10)
            .map(|i| i.to_string())
            .collect();
        let more = if s.all_closed.len() > 10 { ", ..." } else { "" };
        eprintln!(
            "warning: {} cells lie wholly inside closed geometry and got no ray origins (empty \
             sets): cells {}{more}. Move them into free space, or, if the mesh is open or wound \
             inward (which the solid test takes for closed), bake with --origins-anywhere.",
            s.all_closed.len(),
            shown.join(", ")
        );
    }
}

pub(super) fn run_bake(args: BakeArgs) -> Result<()> {
    if args.threads.is_none() {
        return bake_command(&args);
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(thread_count(args.threads)?)
        .build()
        .context("starting the worker threads")?
        .install(|| bake_command(&args))
}

/// `pvs bake`: resolves the cells, checks the arguments, then bakes them all at once with
/// shared rays or cell by cell ([`bake_cells`]: resumable, sharded, incremental), writing the
/// file atomically and printing the summary.
fn bake_command(args: &BakeArgs) -> Result<()> {
    args.device.check_built()?;
    let _lock = lock_output(args)?;
    let scene = args.scene.load()?;
    let bvh = Bvh::build(&scene);
    let (cells, q3) = collect_cells(&args.cells, &scene, &bvh)?;
    if cells.is_empty() {
        bail!("no view cells to bake (all filtered out?)");
    }
    if let Some(path) = &args.cells.write_cells {
        write_cells_file(path, &cells)?;
        eprintln!(
            "wrote {} cells to {} (edit it and bake with --cells {})",
            cells.len(),
            path.display(),
            path.display()
        );
    }
    let record = CellRecord::of(q3.as_ref(), !args.cells.origins_anywhere);
    let params = args.method_overrides.params();
    if args.method == CONSERVATIVE {
        if args.device == Device::Gpu {
            bail!("--method conservative casts no rays: --device gpu does not apply");
        }
        if args.rays.is_some() || args.time.is_some() {
            eprintln!(
                "warning: --method conservative casts no rays and has no budget: --rays and \
                 --time are ignored"
            );
        }
    }
    let sampler = bake_sampler_for_cells(&args.method, &params, q3.is_some())?;
    let (shard, budget) = check_bake_args(args, &params)?;
    let bound = args
        .bound
        .then(|| bound_sampler(args.bound_options, q3.is_some()))
        .transpose()?;
    if bound.is_some() && args.method == CONSERVATIVE {
        bail!("--bound adds the conservative set to a sampled one: --method conservative already is the bound");
    }
    // Quake 3 leaf boxes are bounding boxes of convex leaves and reach into solid space: only
    // points whose BSP cluster is the leaf's own serve as origins, and by default only those a
    // player can reach. Mesh cells skip their voxels inside closed geometry.
    let occupancy = (q3.is_none() && !args.cells.origins_anywhere)
        .then(|| BakeOccupancy::new(&scene, &bvh, &cells));
    let free_space = |cell: usize, p: Vec3| match (&q3, &occupancy) {
        (Some(q), _) => q.rule.allows(cell, p),
        (None, Some(grids)) => grids.allows(cell, p),
        (None, None) => true,
    };
    let inputs = BakeInputs {
        scene: &scene,
        bvh: &bvh,
        cells: &cells,
        params: &params,
        budget,
        free_space: &free_space,
        occupancy: occupancy.as_ref(),
        record: &record,
        bound: bound.as_ref(),
    };
    if args.share_rays {
        // All cells are baked together, so the per-cell machinery (shards, checkpoints,
        // incremental rebakes) does not apply.
        if args.shard.is_some() || args.since.is_some() || args.restart {
            bail!("--share-rays bakes all cells at once: it cannot be combined with --shard, --since or --restart");
        }
        if args.device == Device::Gpu {
            bail!("--share-rays casts on the CPU only (--device gpu is not supported with it yet)");
        }
        return bake_with_shared_rays(args, &inputs);
    }
    bake_cells(args, &inputs, sampler.as_ref(), shard)
}

/// Refuses an output (or its checkpoint) that would overwrite an input, then takes the
/// output's lock (held while the returned guard lives), so that two bakes never write one
/// file.
fn lock_output(args: &BakeArgs) -> Result<OutputLock> {
    // The --since file may be the output: it is read whole before the output is replaced,
    // so an in-place incremental rebake is safe.
    let mut inputs = vec![Path::new(&args.scene.scene)];
    inputs.extend(args.cells.cells.as_deref());
    inputs.extend(args.old_scene.as_deref().map(Path::new));
    let checkpoint = checkpoint_path(&args.output);
    refuse_overwriting_inputs(&[&args.output, &checkpoint], &inputs)?;
    OutputLock::acquire(&args.output)
}

/// Checks the budget and checkpoint arguments (warning when a RASTER budget is below one cube
/// map) and parses `--shard`: the shard, and the budget per cell.
fn check_bake_args(args: &BakeArgs, params: &MethodParams) -> Result<(Option<Shard>, Budget)> {
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
    Ok((shard, budget))
}

/// What the bake's cells depend on beyond their boxes, for its fingerprint and its file: the
/// cluster of each Quake 3 cell and the origin rule (the reachable space's parameters, and
/// what choosing the origins found). Plain cells have neither.
struct CellRecord {
    /// The cluster of each cell (Quake 3 cells).
    clusters: Option<Vec<u32>>,
    /// The fingerprint's part about the cells.
    key: serde_json::Value,
    /// What choosing the origins found (Quake 3 cells).
    origins: Option<Q3OriginsSummary>,
}

impl CellRecord {
    /// The record of the cells `collect_cells` found (`q3` for Quake 3 leaves and clusters;
    /// `open_voxels`: mesh cells' origins only in their open voxels).
    fn of(q3: Option<&Q3Cells<'_>>, open_voxels: bool) -> Self {
        let clusters = q3.map(|q| q.rule.clusters.clone());
        // Plain cells' key is the one the Python bindings' fingerprint uses for them.
        let key = match q3 {
            None => plain_cells_key(open_voxels),
            Some(q) => serde_json::json!({
                "clusters": clusters,
                "origins": q.origins().fingerprint(),
            }),
        };
        CellRecord {
            clusters,
            key,
            origins: q3.map(|q| q.summary.clone()),
        }
    }

    /// The file's extra metadata that both bakes write: the method's `parameters`, the
    /// clusters and the origin rule's summary.
    fn extra(&self, parameters: String) -> serde_json::Value {
        let mut extra = serde_json::json!({
            "parameters": parameters,
            "clusters": self.clusters,
        });
        if let Some(r) = &self.origins {
            extra[Q3_ORIGINS_KEY] = serde_json::json!(r);
        }
        extra
    }
}

/// What both kinds of bake work on: the scene and its BVH, the cells, the method's
/// parameters, the budget per cell, where ray origins may be, and the cells' record.
struct BakeInputs<'a> {
    scene: &'a sightline_core::Scene,
    bvh: &'a Bvh,
    cells: &'a [ViewCell],
    params: &'a MethodParams,
    budget: Budget,
    free_space: &'a (dyn Fn(usize, Vec3) -> bool + Sync),
    /// Mesh cells' free space (`None` for Quake 3 cells and with --origins-anywhere).
    occupancy: Option<&'a BakeOccupancy<'a>>,
    record: &'a CellRecord,
    /// With --bound: the sampler of the conservative bounds added after sampling.
    bound: Option<&'a ConservativeSampler>,
}

/// The cell-by-cell bake: plans it ([`CellBake::prepare`]), runs it with progress bars,
/// writes the file atomically (the library's `write_output`) and prints the summary.
fn bake_cells(
    args: &BakeArgs,
    inputs: &BakeInputs<'_>,
    sampler: &dyn Sampler,
    shard: Option<Shard>,
) -> Result<()> {
    let gpu = match args.device {
        Device::Cpu => None,
        Device::Gpu => Some(gpu_caster(inputs.scene, args)?),
    };
    let caster: &dyn RayCaster = match &gpu {
        Some(g) => g.caster(),
        None => inputs.bvh,
    };
    let bake = CellBake::prepare(args, inputs, caster, sampler, shard)?;
    let n = inputs.scene.triangle_count().max(1) as f64;
    // On the GPU, `--gpu-cells` cells at once, whose rounds are cast together.
    let progress = match &gpu {
        Some(g) => g.install(|| bake.run_with_progress(n))?,
        None => bake.run_with_progress(n)?,
    };
    if let Some(g) = &gpu {
        g.report_batches();
    }
    let extra = bake.extra(inputs.record);
    let bound = match inputs.bound {
        // Two-sided: the sets decoded, bounded, then written (the checkpoint keeps the sampled
        // sets, so an interrupted bound step resumes with no ray cast again).
        Some(conservative) => {
            let mut file = bake.job.to_pvs_file(&progress, extra)?;
            let summary = bound_with_progress(inputs.scene, inputs.bvh, &mut file, conservative)?;
            bake.job.write_file(&args.output, &file)?;
            Some(summary.totals())
        }
        None => {
            bake.job.write_output(&args.output, &progress, extra)?;
            None
        }
    };
    let mut summary = bake.summary(args, inputs, &progress);
    summary.bound = bound;
    warn_unconverged(&summary);
    warn_solid_cells(&summary);
    if args.json {
        return print_json(&summary);
    }
    bake.print_summary(&summary, inputs.scene.triangle_count())
}

/// An incremental rebake (`--since OLD.pvs --old-scene OLD`): the old file and scene as the
/// user named them, and the library's plan.
struct Incremental<'a> {
    since: &'a Path,
    old_scene: &'a str,
    plan: IncrementalBake,
}

/// A cell-by-cell bake, ready to run: the resumable job (this run's cells, those kept from
/// an earlier file, the checkpoint), with what its file and summary record about it.
struct CellBake<'a> {
    job: ResumableBake<'a>,
    /// The method's parameters, as the file records them.
    parameters: String,
    shard: Option<Shard>,
    incremental: Option<Incremental<'a>>,
    /// Cells of this run kept from the earlier file.
    kept_count: usize,
}

impl<'a> CellBake<'a> {
    /// The job: the bake's fingerprint, this run's cells (all, or the shard's: refused when
    /// it has none), the cells an incremental rebake keeps, the checkpoint next to the
    /// output.
    fn prepare(
        args: &'a BakeArgs,
        inputs: &BakeInputs<'a>,
        caster: &'a dyn RayCaster,
        sampler: &'a dyn Sampler,
        shard: Option<Shard>,
    ) -> Result<Self> {
        let setup = BakeSetup {
            scene: inputs.scene,
            caster,
            cells: inputs.cells,
            sampler,
            free_space: inputs.free_space,
            budget: inputs.budget,
            seed: args.seed,
        };
        let parameters = format!("{:?}", inputs.params);
        let fp = fingerprint(&setup, &parameters, inputs.record.key.clone());
        let cells = inputs.cells;
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
                let mut planned =
                    plan_incremental(args, old_pvs, old_scene, inputs.scene, cells, &fp)?;
                let key = serde_json::json!({
                    "since": old_pvs.display().to_string(),
                    "since_scene_hash": format!("{:016x}", planned.old_scene_hash),
                });
                let kept = std::mem::take(&mut planned.kept);
                let incremental = Incremental {
                    since: old_pvs,
                    old_scene,
                    plan: planned,
                };
                (kept, key, Some(incremental))
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
        Ok(CellBake {
            job,
            parameters,
            shard,
            incremental,
            kept_count,
        })
    }

    /// Runs the job with two progress bars on stderr: cells done, and the current cell's rays
    /// and set size (`n` triangles in the scene, for its percentage).
    fn run_with_progress(&self, n: f64) -> Result<BakeProgress> {
        let multi = MultiProgress::new();
        let cells_bar = multi.add(
            ProgressBar::new(self.job.indices.len() as u64).with_style(
                ProgressStyle::with_template(
                    "cells {bar:30} {pos}/{len} [{elapsed_precise} < {eta}]",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            ),
        );
        let cell_bar = multi.add(ProgressBar::new_spinner());
        let progress = self.job.run_with(
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
        Ok(progress)
    }

    /// The file's extra metadata: the common part ([`CellRecord::extra`]), a shard's index
    /// and its own cells' clusters, and what an incremental rebake removed, added and kept.
    fn extra(&self, record: &CellRecord) -> serde_json::Value {
        let mut extra = record.extra(self.parameters.clone());
        if let Some(s) = self.shard {
            extra["shard"] = serde_json::json!({"index": s.index, "count": s.count});
            // Each shard file carries only its cells' clusters.
            if let Some(c) = &record.clusters {
                extra["clusters"] =
                    serde_json::json!(self.job.indices.iter().map(|&i| c[i]).collect::<Vec<_>>());
            }
        }
        if let Some(inc) = &self.incremental {
            extra["incremental"] = inc.plan.metadata(
                Some(inc.since),
                inc.old_scene,
                self.kept_count,
                self.job.indices.len() - self.kept_count,
            );
        }
        extra
    }

    /// The summary of the finished bake (after the file is written: it reports the file's
    /// size).
    fn summary(
        &self,
        args: &BakeArgs,
        inputs: &BakeInputs<'_>,
        progress: &BakeProgress,
    ) -> BakeSummary {
        let n = inputs.scene.triangle_count().max(1) as f64;
        let sizes: Vec<usize> = progress.done.values().map(|c| c.set.len()).collect();
        let mean = sizes.iter().sum::<usize>() as f64 / sizes.len().max(1) as f64;
        BakeSummary {
            output: args.output.clone(),
            method: self.job.setup.sampler.name().to_string(),
            cells: self.job.indices.len(),
            resumed_cells: progress.resumed,
            baked_cells: progress.baked,
            kept_cells: self.kept_count,
            total_rays: progress.done.values().map(|c| c.rays).sum(),
            seconds: progress.seconds,
            mean_pvs_size: mean,
            mean_pvs_percent: 100.0 * mean / n,
            memory_bytes_per_cell: progress.memory_bytes() as f64 / sizes.len().max(1) as f64,
            set_bytes_per_cell: progress.set_bytes() as f64 / sizes.len().max(1) as f64,
            file_bytes_per_cell: std::fs::metadata(&args.output).map_or(0.0, |m| m.len() as f64)
                / sizes.len().max(1) as f64,
            reachable: inputs.record.origins.as_ref().map(|r| serde_json::json!(r)),
            unconverged_cells: count_unconverged(progress.done.values().map(|c| c.converged)),
            solid: inputs.occupancy.map(BakeOccupancy::summary),
            bound: None,
        }
    }

    /// Prints the summary: the incremental rebake's line, then the bake's (`triangles` in
    /// the scene).
    fn print_summary(&self, summary: &BakeSummary, triangles: usize) -> Result<()> {
        let cells = self.job.indices.len();
        if let Some(inc) = &self.incremental {
            let r = &inc.plan;
            outln!(
                "incremental: {} triangles removed, {} added in {} groups; rebaked {} of {} cells, kept {}",
                r.removed,
                r.added,
                r.boxes,
                cells - self.kept_count,
                cells,
                self.kept_count
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
            triangles,
            summary.memory_bytes_per_cell,
            summary.output.display()
        );
        print_bound_line(summary)
    }
}

/// With --bound: how the two sides compare.
fn print_bound_line(summary: &BakeSummary) -> Result<()> {
    if let Some(totals) = &summary.bound {
        outln!(
            "{}; the gap (might be visible, not found) is per cell in `pvs show`",
            bound_line(totals)
        );
    }
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

pub(super) fn run_merge(args: MergeArgs) -> Result<()> {
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
/// The shared-ray bake runs GVS++ in the paper's rounds even under a budget (the per-cell
/// bake's schedule by yield is not shared yet): a ray budget below one round, or a time budget,
/// may go to random rays before border and reverse sampling run. The user should hear it.
fn warn_shared_rounds_under_budget(args: &BakeArgs, params: &sightline_region::GvsPlusPlusParams) {
    let n_rand = params.n_rand;
    let short = args.rays.is_some_and(|rays| rays < n_rand) || args.time.is_some();
    if params.fixed_rounds && short {
        eprintln!(
            "warning: --fixed-rounds runs GVS++ in the paper's rounds of --n-rand {n_rand} random \
             rays; under this budget a cell may spend it on random rays before border and reverse \
             sampling run (without --fixed-rounds, the bake schedules its rays by yield)"
        );
    }
}

fn bake_with_shared_rays(args: &BakeArgs, inputs: &BakeInputs<'_>) -> Result<()> {
    use sightline_region::ray_sharing::{bake_shared, ShareParams};
    let (scene, cells, budget) = (inputs.scene, inputs.cells, &inputs.budget);
    let extra = inputs.record.extra(format!("{:?}", inputs.params));
    let reachable = extra.get(Q3_ORIGINS_KEY).cloned();
    if !matches!(args.method.as_str(), "gvs++" | "gvspp") {
        bail!(
            "--share-rays works with --method gvs++ only (got '{}')",
            args.method
        );
    }
    warn_shared_rounds_under_budget(args, &inputs.params.gvspp);
    // As measured by `bench share` (docs/BENCHMARKS.md): received triangles are explored too.
    let share = ShareParams {
        gvspp: inputs.params.gvspp.clone(),
        explore_shared: true,
        ..ShareParams::default()
    };
    let bar = ProgressBar::new_spinner();
    let result = bake_shared(
        scene,
        inputs.bvh,
        cells,
        &share,
        budget,
        args.seed,
        inputs.free_space,
        &|p| {
            let step = if share.gvspp.fixed_rounds {
                "round"
            } else {
                "step"
            };
            bar.set_message(format!(
                "{step} {}: {} rays, {} cells sampling, mean PVS {:.0}",
                p.round,
                p.rays,
                p.sampling_cells,
                p.total_pvs as f64 / cells.len().max(1) as f64
            ));
            bar.tick();
        },
    );
    bar.finish_and_clear();
    let mut file = result.to_pvs_file(scene, cells, &share, budget, args.seed, extra);
    let bound = match inputs.bound {
        Some(conservative) => {
            Some(bound_with_progress(scene, inputs.bvh, &mut file, conservative)?.totals())
        }
        None => None,
    };
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
        unconverged_cells: count_unconverged(result.cells.iter().map(|c| c.converged)),
        solid: inputs.occupancy.map(BakeOccupancy::summary),
        bound,
    };
    warn_unconverged(&summary);
    warn_solid_cells(&summary);
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
    print_bound_line(&summary)
}
