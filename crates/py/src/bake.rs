//! Baking PVSs from Python: one cell, a batch of cells with their global indices (what a
//! distributed worker runs), or a whole list into a `.pvs` in memory.
//!
//! Every cell's seed is `cell_seed(seed, global_index)`, the rule of
//! `sightline_region::bake::bake` and so of `sightline pvs bake`: a cell's set does not depend
//! on which batch or machine bakes it.

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::Vec3;
use numpy::PyArray1;
use pyo3::prelude::*;
use sightline_core::trace::RayCaster;
use sightline_core::TriangleSet;
use sightline_region::bake::{cell_stats, BakeSetup};
use sightline_region::bound::add_bounds;
use sightline_region::checkpoint::{fingerprint, BakeProgress, ResumableBake};
use sightline_region::occupancy::{BakeOccupancy, CellOccupancy};

use sightline_region::rebake::{
    plan_incremental_bake, IncrementalBakeError, OldBake, DEFAULT_PROBE_RAYS,
};
use sightline_region::{Budget, CellContext, PvsFile, Sampler, ViewCell};

use crate::cells::PyViewCell;
use crate::convert::{ids_array, value_error};
use crate::device::BakeCaster;
use crate::method::MethodArg;
use crate::pvs::PyPvs;
use crate::run::{progress_callback, run_interruptible, Control, Stopped};
use crate::scene::{PyScene, SceneData};

/// The budget from `rays` / `time_ms`; both absent lets the method stop by its own rule.
fn budget(rays: Option<u64>, time_ms: Option<u64>) -> PyResult<Budget> {
    if rays == Some(0) || time_ms == Some(0) {
        return Err(value_error("rays and time_ms must be positive"));
    }
    Ok(Budget {
        max_rays: rays,
        max_time: time_ms.map(Duration::from_millis),
    })
}

/// The thread count to bake with: `None` (all cores) stays `None`; a count far above the
/// machine's cores is capped by the rule of the CLI's `--threads`
/// (`sightline_core::threads::capped_threads`), with a `RuntimeWarning` saying so.
pub(crate) fn thread_count(py: Python<'_>, threads: Option<usize>) -> PyResult<Option<usize>> {
    let Some(requested) = threads else {
        return Ok(None);
    };
    if requested == 0 {
        return Err(value_error("threads must be >= 1 (or None for all cores)"));
    }
    let (n, warning) = sightline_core::threads::capped_threads(requested);
    if let Some(w) = warning {
        let category = py.get_type::<pyo3::exceptions::PyRuntimeWarning>();
        py.import("warnings")?
            .call_method1("warn", (format!("threads: {w}"), category, 2))?;
    }
    Ok(Some(n))
}

/// Runs `work` on a pool of `threads` threads (all cores when `None`; counts already checked
/// by [`thread_count`]).
fn with_threads<T: Send>(
    threads: Option<usize>,
    work: impl FnOnce() -> T + Send,
) -> Result<T, String> {
    match threads {
        None => Ok(work()),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| format!("cannot start {n} threads: {e}"))?;
            Ok(pool.install(work))
        }
    }
}

/// Bakes `cells` (with global indices `indices`) one after the other, as the bake driver does:
/// each cell's set and its statistics (those of `metadata.cells` in a `.pvs`). Stops between
/// cells when `control` asks.
fn bake_batch(
    data: &SceneData,
    cells: &[ViewCell],
    indices: &[usize],
    sampler: &dyn Sampler,
    budget: &Budget,
    seed: u64,
    control: &Control,
) -> Result<Vec<(TriangleSet, serde_json::Value)>, Stopped> {
    let bvh = data.bvh();
    let mut out = Vec::with_capacity(cells.len());
    for (cell, &index) in cells.iter().zip(indices) {
        if control.stopped() {
            return Err(Stopped);
        }
        // The CLI's free-space test for plain (non-Quake-3) cells: their open voxels.
        let grid = CellOccupancy::of(&data.scene, bvh, cell);
        let inside = |p: Vec3| grid.allows(p);
        let ctx = CellContext {
            scene: &data.scene,
            caster: bvh,
            cell,
            seed: sightline_region::bake::cell_seed(seed, index),
            free_space: Some(&inside),
        };
        let result = sampler.sample(&ctx, budget, &|p| control.batch(index, p.rays));
        control.cell_done(index, result.rays);
        let stats = cell_stats(&result);
        out.push((result.visible, stats));
    }
    Ok(out)
}

/// A JSON value as Python objects (through `json.loads`, as `Pvs.metadata` does).
fn to_python<'py>(py: Python<'py>, value: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(value_error)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// The seed `sightline pvs bake --seed SEED` gives the cell at `index`: `seed` is the
/// bake's seed, `index` the cell's position in the whole bake.
#[pyfunction]
pub(crate) fn cell_seed(seed: u64, index: usize) -> u64 {
    sightline_region::bake::cell_seed(seed, index)
}

/// Bakes one cell: the ids of its potentially visible triangles (uint32, increasing). `cell`:
/// the `ViewCell`.
/// `index` is the cell's position in the whole bake (it picks the cell's seed). `threads` and
/// `progress` as for `bake`.
///
/// `scene`: the `Scene`; `method`: a `Method` or a method's name (default `"gvs++"`); `rays`:
/// the ray budget per cell (`None`: no budget, GVS++ and GVS run until their termination rule
/// holds); `time_ms`: a time budget per cell in milliseconds (`None`: none); `seed`: the bake's
/// seed (each cell's own derives from it and the cell's index: `cell_seed`).
#[pyfunction]
#[pyo3(signature = (scene, cell, method = MethodArg::Name("gvs++".into()), rays = None,
    seed = 1, index = 0, time_ms = None, threads = None, progress = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn bake_cell<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    cell: PyViewCell,
    method: MethodArg<'py>,
    rays: Option<u64>,
    seed: u64,
    index: usize,
    time_ms: Option<u64>,
    threads: Option<usize>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<u32>>> {
    let threads = thread_count(py, threads)?;
    let mut sets = bake_batch_py(
        py,
        scene,
        vec![cell],
        method,
        rays,
        seed,
        Some(vec![index]),
        time_ms,
        threads,
        progress,
    )?;
    let (set, _) = sets
        .pop()
        .ok_or_else(|| value_error("internal: no result for the cell"))?;
    Ok(ids_array(py, &set))
}

/// `bound_solid_fusion`: a radius, or `"auto"` / `"off"`.
#[derive(FromPyObject)]
pub(crate) enum SolidFusionArg {
    /// A radius in scene units.
    Radius(f64),
    /// `"auto"` or `"off"`.
    Name(String),
}

impl SolidFusionArg {
    /// The sampler's setting, as `--bound-solid-fusion` reads it.
    fn resolve(self) -> PyResult<Option<sightline_point::rv::SolidFusion>> {
        use sightline_point::rv::SolidFusion;
        match self {
            Self::Radius(r) if r.is_finite() && r > 0.0 => {
                Ok(Some(SolidFusion { radius: Some(r) }))
            }
            Self::Name(n) if n == "auto" => Ok(Some(SolidFusion { radius: None })),
            Self::Name(n) if n == "off" => Ok(None),
            Self::Radius(r) => Err(value_error(format!(
                "bound_solid_fusion must be a positive radius, \"auto\" or \"off\" (got {r})"
            ))),
            Self::Name(n) => Err(value_error(format!(
                "bound_solid_fusion must be a positive radius, \"auto\" or \"off\" (got {n:?})"
            ))),
        }
    }
}

/// Bakes a batch of cells (`cells`: a list of `ViewCell`): one id array per cell. `indices` are the cells' global indices in
/// the whole bake (default `0..len(cells)`); they pick each cell's seed. With `stats=True`,
/// returns `(sets, stats)`: `stats` holds one dict per cell (`rays`, `seconds`, `pvs_size`,
/// `found_by`, `convergence`, as in a `.pvs` file's `metadata["cells"]`). `threads` and
/// `progress` as for `bake`.
///
/// `scene`: the `Scene`; `method`: a `Method` or a method's name (default `"gvs++"`); `rays`:
/// the ray budget per cell (`None`: no budget, GVS++ and GVS run until their termination rule
/// holds); `time_ms`: a time budget per cell in milliseconds (`None`: none); `seed`: the bake's
/// seed (each cell's own derives from it and the cell's index: `cell_seed`).
#[pyfunction]
#[pyo3(signature = (scene, cells, method = MethodArg::Name("gvs++".into()), rays = None,
    seed = 1, indices = None, time_ms = None, threads = None, progress = None, stats = false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn bake_cells<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    cells: Vec<PyViewCell>,
    method: MethodArg<'py>,
    rays: Option<u64>,
    seed: u64,
    indices: Option<Vec<usize>>,
    time_ms: Option<u64>,
    threads: Option<usize>,
    progress: Option<&Bound<'py, PyAny>>,
    stats: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let threads = thread_count(py, threads)?;
    let results = bake_batch_py(
        py, scene, cells, method, rays, seed, indices, time_ms, threads, progress,
    )?;
    let sets: Vec<_> = results.iter().map(|(s, _)| ids_array(py, s)).collect();
    if !stats {
        return sets.into_pyobject(py).map(Bound::into_any);
    }
    let stats = serde_json::Value::Array(results.into_iter().map(|(_, s)| s).collect());
    (sets, to_python(py, &stats)?)
        .into_pyobject(py)
        .map(Bound::into_any)
}

/// What `bake_cell` and `bake_cells` share: checks, then [`bake_batch`] off the GIL.
#[allow(clippy::too_many_arguments)]
fn bake_batch_py<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    cells: Vec<PyViewCell>,
    method: MethodArg<'py>,
    rays: Option<u64>,
    seed: u64,
    indices: Option<Vec<usize>>,
    time_ms: Option<u64>,
    threads: Option<usize>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Vec<(TriangleSet, serde_json::Value)>> {
    let method = method.resolve()?;
    let sampler = method.sampler()?;
    let budget = budget(rays, time_ms)?;
    let indices = indices.unwrap_or_else(|| (0..cells.len()).collect());
    if indices.len() != cells.len() {
        return Err(value_error(format!(
            "indices has {} entries for {} cells",
            indices.len(),
            cells.len()
        )));
    }
    let progress = progress_callback(py, progress)?;
    let cells: Vec<ViewCell> = cells.into_iter().map(|c| c.cell).collect();
    let data = scene.get().data.clone();
    let sampler = sampler.as_ref();
    let done = run_interruptible(py, cells.len(), progress.as_ref(), |control| {
        with_threads(threads, || {
            bake_batch(&data, &cells, &indices, sampler, &budget, seed, control)
        })
    })?;
    // `Stopped` only happens when run_interruptible raised already.
    done.map_err(value_error)?
        .map_err(|Stopped| value_error("internal: the bake stopped without a reason"))
}

/// Bakes `cells` on this machine with the bake driver of `sightline pvs bake`: a `Pvs` whose
/// cells and sets equal the CLI's for the same scene, cells, method, budget and seed, with the
/// same per-cell statistics in its metadata (ray origins skip the cells' voxels inside closed
/// geometry, the CLI's default). `threads`: bake threads (default all cores; far
/// more than the cores are capped, with a warning). `progress`: see `sightline._progress`
/// (default: a line on stderr when it is a terminal). Ctrl-C stops the bake (cells under way
/// finish first) and raises `KeyboardInterrupt`. `device`: `"cpu"` (the default) or `"gpu"`,
/// as `pvs bake --device`, with the GPU caster `gpu_caster` (`"auto"`, `"compute"` or
/// `"ray-query"`, as `--gpu-caster`; the same sets as the CPU's for the same seed and rays
/// where the caster is exact; `crate::device`).
///
/// Incremental rebake (`pvs bake --since OLD.pvs --old-scene OLD --probe-rays N`): with
/// `since` (an earlier bake of the same cells, method, parameters, seed and budget, by the CLI,
/// the Ray driver or this function) and `old_scene` (the scene it was baked for), the cells the edit from
/// `old_scene` to `scene` cannot change keep their sets from `since` and only the others are
/// baked; `probe_rays` as `--probe-rays` (0 skips the probe). The result equals the CLI's and
/// its `metadata["incremental"]` counts the kept and rebaked cells.
///
/// Two-sided bake (`pvs bake --bound`): with `bound` true every cell also gets RV's
/// conservative from-region set joined with its sampled set (`Pvs.bound(i)`; the file's
/// `metadata["bound"]` and `metadata["cells"][i]["gap"]` say how far apart the sides are);
/// `bound_occluders` and `bound_fusion_splits` as `--bound-occluders` and
/// `--bound-fusion-splits` (more time for a tighter bound); `bound_solid_fusion` as
/// `--bound-solid-fusion` (`None` or `"off"`, `"auto"`, or a radius).
///
/// `scene`: the `Scene`; `method`: a `Method` or a method's name (default `"gvs++"`); `rays`:
/// the ray budget per cell (`None`: no budget, GVS++ and GVS run until their termination rule
/// holds); `time_ms`: a time budget per cell in milliseconds (`None`: none); `seed`: the bake's
/// seed (each cell's own derives from it and the cell's index: `cell_seed`).
#[pyfunction]
#[pyo3(signature = (scene, cells, method = MethodArg::Name("gvs++".into()), rays = None,
    seed = 1, time_ms = None, threads = None, progress = None, *, since = None,
    old_scene = None, probe_rays = DEFAULT_PROBE_RAYS, device = "cpu", gpu_caster = "auto",
    bound = false,
    bound_occluders = sightline_point::rv::DEFAULT_MAX_OCCLUDERS, bound_fusion_splits = 0,
    bound_solid_fusion = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn bake<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    cells: Vec<PyViewCell>,
    method: MethodArg<'py>,
    rays: Option<u64>,
    seed: u64,
    time_ms: Option<u64>,
    threads: Option<usize>,
    progress: Option<&Bound<'py, PyAny>>,
    since: Option<&Bound<'py, PyPvs>>,
    old_scene: Option<&Bound<'py, PyScene>>,
    probe_rays: usize,
    device: &str,
    gpu_caster: &str,
    bound: bool,
    bound_occluders: usize,
    bound_fusion_splits: u32,
    bound_solid_fusion: Option<SolidFusionArg>,
) -> PyResult<PyPvs> {
    let since = match (since, old_scene) {
        (Some(pvs), Some(old)) => Some(Since {
            pvs: pvs.get(),
            scene: old.get().data.clone(),
            probe_rays,
        }),
        (None, None) => None,
        _ => {
            return Err(value_error(
                "since and old_scene go together: pass both (the earlier Pvs and the scene \
                 it was baked for) or neither",
            ))
        }
    };
    let threads = thread_count(py, threads)?;
    let method = method.resolve()?;
    if bound && method.name == sightline_point::rv::CONSERVATIVE {
        return Err(value_error(
            "bound=True adds the conservative set to a sampled one: the conservative method \
             already is the bound",
        ));
    }
    // As `pvs bake --bound-occluders N --bound-fusion-splits S --bound-solid-fusion R`.
    let conservative = sightline_point::rv::ConservativeSampler {
        options: sightline_point::rv::RegionOptions {
            max_occluders: bound_occluders,
            fusion_splits: bound_fusion_splits,
            ..Default::default()
        },
        solid_fusion: bound_solid_fusion.map_or(Ok(None), SolidFusionArg::resolve)?,
        ..Default::default()
    };
    conservative.options.validate().map_err(value_error)?;
    let sampler = method.sampler()?;
    let data = scene.get().data.clone();
    let device = BakeCaster::new(py, device, gpu_caster, &data.scene)?;
    let caster = device.caster(data.bvh());
    let cells: Vec<ViewCell> = cells.into_iter().map(|c| c.cell).collect();
    // The CLI's free-space test for plain cells: their open voxels, each cell's tested when
    // it is baked (a rebake tests only the cells it does not keep).
    let grids = BakeOccupancy::new(&data.scene, caster, &cells);
    let free_space = |cell: usize, p: Vec3| grids.allows(cell, p);
    let job = BakeJob {
        caster,
        data: data.clone(),
        cells: &cells,
        free_space: &free_space,
        parameters: format!("{:?}", method.params),
        sampler: sampler.as_ref(),
        budget: budget(rays, time_ms)?,
        seed,
    };
    let progress = progress_callback(py, progress)?;
    let file = run_interruptible(py, job.cells.len(), progress.as_ref(), |control| {
        with_threads(threads, || {
            device.install(|| match &since {
                None => job.bake_all(control).map(Ok),
                Some(since) => job.rebake(since, control),
            })
        })
    })?;
    let mut file = file
        .map_err(value_error)?
        .map_err(|Stopped| value_error("internal: the bake stopped without a reason"))?
        .map_err(value_error)?;
    if bound {
        // As `pvs bake --bound`: RV's from-region set beside each sampled one.
        py.detach(|| {
            with_threads(threads, || {
                add_bounds(&data.scene, data.bvh(), &mut file, &conservative, &|_| {})
            })
        })
        .map_err(value_error)?
        .map_err(value_error)?;
    }
    Ok(PyPvs { file, path: None })
}

/// What `bake` bakes: the scene, its plain cells, the method and its budget and seed.
struct BakeJob<'a> {
    data: Arc<SceneData>,
    /// The scene's BVH, or the GPU caster (`device`).
    caster: &'a dyn RayCaster,
    cells: &'a [ViewCell],
    /// Where each cell's ray origins may be (its open voxels).
    free_space: &'a (dyn Fn(usize, Vec3) -> bool + Sync),
    /// The method's parameters, as the file records them.
    parameters: String,
    sampler: &'a dyn Sampler,
    budget: Budget,
    seed: u64,
}

/// An incremental rebake's old bake (`since`, `old_scene`, `probe_rays` of `bake`).
struct Since<'a> {
    pvs: &'a PyPvs,
    scene: Arc<SceneData>,
    probe_rays: usize,
}

/// The fingerprint's part about plain cells (not Quake 3 leaves): the CLI's for them, whose
/// origins keep to their open voxels by default.
fn plain_cells_key() -> serde_json::Value {
    sightline_region::occupancy::plain_cells_key(true)
}

impl BakeJob<'_> {
    /// The bake driver's view of this job (plain cells: origins in their open voxels).
    fn setup(&self) -> BakeSetup<'_> {
        BakeSetup {
            scene: &self.data.scene,
            caster: self.caster,
            cells: self.cells,
            sampler: self.sampler,
            free_space: self.free_space,
            budget: self.budget,
            seed: self.seed,
        }
    }

    /// The CLI's fingerprint of this bake (what an incremental rebake compares).
    fn fingerprint(&self) -> serde_json::Value {
        fingerprint(&self.setup(), &self.parameters, plain_cells_key())
    }

    /// Every cell, with `sightline_region::bake::try_bake`; the file records the CLI's
    /// fingerprint of the bake, so it can be the `since` of a later incremental rebake.
    fn bake_all(&self, control: &Control) -> Result<PvsFile, Stopped> {
        let extra = serde_json::json!({ "parameters": self.parameters, "via": "python" });
        let mut file = self.try_bake_all(extra, control)?;
        if let Some(m) = file.metadata.as_object_mut() {
            m.insert("fingerprint".into(), self.fingerprint());
        }
        Ok(file)
    }

    fn try_bake_all(
        &self,
        extra: serde_json::Value,
        control: &Control,
    ) -> Result<PvsFile, Stopped> {
        sightline_region::bake::try_bake(
            &self.data.scene,
            self.caster,
            self.cells,
            self.sampler,
            self.free_space,
            &self.budget,
            self.seed,
            extra,
            &|cell, p| control.batch(cell, p.rays),
            &mut |cell, result| control.finish_cell(cell, result.rays),
        )
    }

    /// The incremental rebake of `pvs bake --since`: plans it with the CLI's fingerprint for
    /// this bake (`sightline_region::rebake`, whose refusals are the `Err` text), bakes the
    /// cells it does not keep and assembles the file as the CLI writes it.
    fn rebake(
        &self,
        since: &Since<'_>,
        control: &Control,
    ) -> Result<Result<PvsFile, String>, Stopped> {
        let setup = self.setup();
        let fp = self.fingerprint();
        let path = since.pvs.path.as_deref();
        let old = OldBake {
            path: path.unwrap_or(Path::new("since")),
            file: &since.pvs.file,
            scene: &since.scene.scene,
        };
        let planned =
            plan_incremental_bake(&old, setup.scene, &fp, self.cells.len(), since.probe_rays);
        let mut plan = match planned {
            Ok(plan) => plan,
            Err(IncrementalBakeError::OldSceneMismatch { path, source }) => {
                return Ok(Err(format!("{} and old_scene: {source}", path.display())))
            }
            Err(e) => return Ok(Err(e.to_string())),
        };
        let start = Instant::now();
        let kept = plan.kept.len();
        let mut done = std::mem::take(&mut plan.kept);
        for i in done.keys() {
            control.cell_done(*i, 0);
        }
        let todo: Vec<usize> = (0..self.cells.len())
            .filter(|i| !done.contains_key(i))
            .collect();
        sightline_region::bake::bake_cells::<Stopped>(
            &setup,
            &todo,
            None,
            &|cell, p| control.batch(cell, p.rays),
            &mut |cell, result| {
                let index = cell.index;
                done.insert(index, cell);
                control.finish_cell(index, result.rays)
            },
        )?;
        let extra = serde_json::json!({
            "parameters": self.parameters,
            "via": "python",
            "incremental": plan.metadata(path, &since.scene.scene.source, kept, todo.len()),
        });
        let progress = BakeProgress {
            done,
            resumed: 0,
            baked: todo.len(),
            complete: true,
            seconds: start.elapsed().as_secs_f64(),
        };
        let file = ResumableBake::new(setup, fp).to_pvs_file(&progress, extra);
        Ok(file.map_err(|e| e.to_string()))
    }
}

/// Bakes a Quake 3 map's leaf (`cells` = `"leaves"`, the CLI's `--q3-leaves`) or cluster
/// cells (`cells="clusters"`, `--q3-clusters`) on this machine: the `Pvs` of `sightline pvs bake`
/// with the same options (`clusters`: `--clusters`; `include_unreachable`:
/// `--include-unreachable`; `reach_step`: `--reach-step`). Ray origins are in the cell's
/// cluster and, unless `include_unreachable`, in the space reachable from the map's spawn
/// points; cells without reachable space are left out. `metadata["clusters"]` holds each
/// cell's cluster and `metadata["reachable"]` the rule and the unreachable counts. A map
/// without spawn points falls back to the cluster rule with a `RuntimeWarning`.
///
/// `scene`: the `Scene`; `method`: a `Method` or a method's name (default `"gvs++"`); `rays`:
/// the ray budget per cell (`None`: no budget, GVS++ and GVS run until their termination rule
/// holds); `time_ms`: a time budget per cell in milliseconds (`None`: none); `seed`: the bake's
/// seed (each cell's own derives from it and the cell's index: `cell_seed`); `threads` and
/// `progress` as for `bake`.
#[pyfunction]
#[pyo3(signature = (scene, cells = "leaves", method = MethodArg::Name("gvs++".into()),
    rays = None, seed = 1, time_ms = None, threads = None, progress = None, *, clusters = None,
    include_unreachable = false, reach_step = sightline_region::reachable::DEFAULT_STEP))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn bake_q3<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    cells: &str,
    method: MethodArg<'py>,
    rays: Option<u64>,
    seed: u64,
    time_ms: Option<u64>,
    threads: Option<usize>,
    progress: Option<&Bound<'py, PyAny>>,
    clusters: Option<Vec<u32>>,
    include_unreachable: bool,
    reach_step: f32,
) -> PyResult<PyPvs> {
    use sightline_region::cell_sources::{q3_cells, Q3CellKind, Q3Origins, Q3_ORIGINS_KEY};
    let threads = thread_count(py, threads)?;
    let method = method.resolve()?;
    // Its cells keep their origins in the map's empty leaves: the portals apply.
    let sampler = method.sampler_for_q3_cells()?;
    let budget = budget(rays, time_ms)?;
    let kind = match cells {
        "leaves" => Q3CellKind::Leaves,
        "clusters" => Q3CellKind::Clusters,
        other => {
            return Err(value_error(format!(
                "cells must be 'leaves' or 'clusters', not '{other}'"
            )))
        }
    };
    let data = scene.get().data.clone();
    if data.scene.bsp.is_none() {
        return Err(value_error(
            "bake_q3 needs a Quake 3 map (.bsp) as the scene",
        ));
    }
    let origins = if include_unreachable {
        Q3Origins::Cluster
    } else {
        Q3Origins::Reachable(sightline_region::reachable::ReachParams { step: reach_step })
    };
    // The reachable space (about a second on a large map) is built off the GIL, on the bake's
    // threads.
    let q3 = py
        .detach(|| {
            with_threads(threads, || {
                q3_cells(&data.scene, kind, clusters.as_deref(), origins)
            })
        })
        .map_err(value_error)?
        .map_err(|e| value_error(format!("reach_step: {e}")))?;
    if let Some(why) = &q3.summary.fallback {
        let category = py.get_type::<pyo3::exceptions::PyRuntimeWarning>();
        py.import("warnings")?.call_method1(
            "warn",
            (
                format!("bake_q3: {why}: ray origins are not restricted to reachable space"),
                category,
                2,
            ),
        )?;
    }
    if q3.cells.is_empty() {
        return Err(value_error(
            "no cells to bake (every selected cell is unreachable?)",
        ));
    }
    let mut extra = serde_json::json!({
        "parameters": format!("{:?}", method.params),
        "clusters": q3.rule.clusters,
        "via": "python",
    });
    extra[Q3_ORIGINS_KEY] = serde_json::json!(q3.summary);
    let progress = progress_callback(py, progress)?;
    let sampler = sampler.as_ref();
    let (cells, rule) = (&q3.cells, &q3.rule);
    let file = run_interruptible(py, cells.len(), progress.as_ref(), |control| {
        with_threads(threads, || {
            sightline_region::bake::try_bake(
                &data.scene,
                data.bvh(),
                cells,
                sampler,
                &|cell, p| rule.allows(cell, p),
                &budget,
                seed,
                extra,
                &|cell, p| control.batch(cell, p.rays),
                &mut |cell, result| control.finish_cell(cell, result.rays),
            )
        })
    })?;
    let file = file.map_err(value_error)?;
    let file =
        file.map_err(|Stopped| value_error("internal: the bake stopped without a reason"))?;
    Ok(PyPvs { file, path: None })
}

/// The fingerprint of a bake and the key its checkpoint carries, as JSON text
/// `{"fingerprint": .., "checkpoint_key": .., "parameters": ..}`: the values `sightline pvs
/// bake` computes for the same scene, cells (a `--grid` or cell file, not Quake 3 leaves),
/// method, ray budget and seed, so the Ray driver's checkpoints are the CLI's. For the Ray
/// driver (`sightline.ray`); not part of the public API.
#[pyfunction]
#[pyo3(name = "_bake_fingerprint", signature = (scene, cells, method, rays, seed))]
pub(crate) fn bake_fingerprint(
    scene: &Bound<'_, PyScene>,
    cells: Vec<PyViewCell>,
    method: MethodArg<'_>,
    rays: Option<u64>,
    seed: u64,
) -> PyResult<String> {
    let method = method.resolve()?;
    let budget = budget(rays, None)?;
    let cells: Vec<ViewCell> = cells.into_iter().map(|c| c.cell).collect();
    let parameters = format!("{:?}", method.params);
    // The CLI's extra part for cells that are not Quake 3 leaves, and its run key for a bake
    // of every cell (no shard, no incremental rebake).
    let fingerprint = sightline_region::checkpoint::fingerprint_of(
        &scene.get().data.scene,
        &cells,
        method.sampler()?.name(),
        &parameters,
        seed,
        &budget,
        plain_cells_key(),
    );
    let indices: Vec<usize> = (0..cells.len()).collect();
    let key = sightline_region::checkpoint::checkpoint_key(
        &fingerprint,
        &indices,
        &serde_json::Value::Null,
    );
    let out = serde_json::json!({
        "fingerprint": fingerprint,
        "checkpoint_key": key,
        "parameters": parameters,
    });
    serde_json::to_string(&out).map_err(value_error)
}
