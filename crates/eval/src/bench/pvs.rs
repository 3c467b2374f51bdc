//! PVS quality, the GVS++ paper's table 1: on random view cells in free space, GVS++ run to
//! convergence against RAND at equal rays and at equal time, and GVS and RASTER at equal
//! rays; optionally GVS++ against RAND at small fixed time and ray budgets (the equal-time
//! comparison of issue 24). Every set of a cell is judged by pixel error on the same views.
//!
//! Method: all methods of a cell sample the same cell with the same seed, and their sets are
//! evaluated together on one set of viewpoints (outside solid geometry), so the rows differ
//! only by method and budget. Means are over cells. Equal-rays rows are the comparison without
//! the machine's load in it; equal-time rows measure what a user waiting that long gets.
//!
//! With a second ray caster ([`bench_pvs_scene_on`], the GPU caster of `bench pvs --device
//! gpu`), every GVS++ row is repeated with that caster: the same cells, seeds and budgets, so
//! the time per cell compares the casters and `differing_cells` counts the cells whose set is
//! not the first caster's (0 expected where the casters' hits are equal and the budget is in
//! rays; a time budget casts as many rays as the caster manages, so there it is stated).

use std::time::Duration;

use serde::Serialize;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::{Scene, TriangleSet};
use sightline_region::cell_sources::{inside_solid, random_free_cells};
use sightline_region::{
    Budget, CellContext, CellResult, ConvergencePoint, Gvs, GvsParams, GvsPlusPlus,
    GvsPlusPlusParams, RandomSampler, RasterSampler, Sampler, ViewCell,
};

use super::common::{report, BenchError, OnProgress, Progress};
use super::convergence::{convergence_curves, Convergence};
use crate::pixel_error::{evaluate_cell_in, CellEvaluation, EvalParams};

/// The longest time budget, 1 hour in milliseconds.
const MAX_TIME_BUDGET_MS: u64 = 3_600_000;
/// The largest ray budget.
const MAX_RAY_BUDGET: u64 = 100_000_000_000;

/// The rows of the full comparison, per cell: (method, budget).
const FULL_ROWS: [(&str, &str); 5] = [
    ("GVS++", "converged"),
    ("RAND", "equal rays"),
    ("RAND", "equal time"),
    ("GVS", "equal rays"),
    ("RASTER", "equal rays"),
];

/// What `bench pvs` measures, per scene.
#[derive(Clone, Debug)]
pub struct PvsBenchOptions {
    /// View cells per scene (random cubes in free space).
    pub cells: usize,
    /// Half size of the cells as a fraction of the scene diagonal.
    pub cell_size: f32,
    /// Evaluation viewpoints per cell (six cube faces each).
    pub viewpoints: usize,
    /// Evaluation resolution.
    pub resolution: u32,
    /// GVS++/GVS random rays per round.
    pub n_rand: u64,
    /// Seed.
    pub seed: u64,
    /// Time budgets (ms) at which GVS++ and RAND are also compared.
    pub time_budgets_ms: Vec<u64>,
    /// Ray budgets at which GVS++ and RAND are also compared.
    pub ray_budgets: Vec<u64>,
    /// Only the rows of the small budgets: no converged GVS++ bake and no baselines.
    pub equal_time_only: bool,
    /// Also compute the convergence curves of every method on the scene's first cell.
    pub convergence: bool,
    /// Also run GVS++ with the paper's discontinuities (border vertices only) to convergence,
    /// as the row [`PAPER_GVSPP`] after the full rows (not with `equal_time_only`): what
    /// searching every border sample brings, on the same cells and views.
    pub paper_discontinuities: bool,
}

/// The method name of the row of [`PvsBenchOptions::paper_discontinuities`].
pub const PAPER_GVSPP: &str = "GVS++ (paper's discontinuities)";

impl PvsBenchOptions {
    /// Checks the budgets: time budgets within 1 ms..=1 h, ray budgets within 1..=10^11.
    pub fn validate(&self) -> Result<(), BenchError> {
        if let Some(&ms) =
            (self.time_budgets_ms.iter()).find(|&&ms| ms == 0 || ms > MAX_TIME_BUDGET_MS)
        {
            return Err(BenchError::TimeBudget(ms));
        }
        if let Some(&rays) = (self.ray_budgets.iter()).find(|&&r| r == 0 || r > MAX_RAY_BUDGET) {
            return Err(BenchError::RayBudget(rays));
        }
        Ok(())
    }

    /// The small budgets at which GVS++ and RAND are compared side by side, with their labels
    /// in the rows ("250 ms", "1000000 rays"): time budgets first.
    pub fn small_budgets(&self) -> Vec<(String, Budget)> {
        (self.time_budgets_ms.iter())
            .map(|&ms| {
                let budget = Budget {
                    max_rays: None,
                    max_time: Some(Duration::from_millis(ms)),
                };
                (format!("{ms} ms"), budget)
            })
            .chain(
                (self.ray_budgets.iter()).map(|&rays| (format!("{rays} rays"), Budget::rays(rays))),
            )
            .collect()
    }

    fn eval_params(&self) -> EvalParams {
        EvalParams {
            viewpoints: self.viewpoints,
            resolution: self.resolution,
            ..EvalParams::default()
        }
    }
}

/// One method at one budget on one scene, means over its cells.
#[derive(Serialize, Default, Clone, Debug)]
pub struct PvsRow {
    /// The scene's name.
    pub scene: String,
    /// "GVS++", "RAND", "GVS" or "RASTER".
    pub method: String,
    /// "converged", "equal rays", "equal time", or a small budget's label.
    pub budget: String,
    /// Cells averaged.
    pub cells: usize,
    /// Mean rays per cell.
    pub mean_rays: f64,
    /// Mean seconds per cell.
    pub mean_seconds: f64,
    /// Mean erroneous pixels per view.
    pub avg_error_pixels: f64,
    /// Mean pixels only the snapping tolerance confirmed, per view.
    pub avg_unconfirmed_pixels: f64,
    /// Most erroneous pixels in one view.
    pub max_error_pixels: usize,
    /// Mean error regions per view.
    pub avg_error_regions: f64,
    /// Largest error region, pixels.
    pub max_error_region_size: usize,
    /// Mean PVS size, percent of the scene's triangles.
    pub pvs_percent: f64,
    /// False negatives, summed over cells.
    pub false_negatives: usize,
    /// Rows of the second caster only: cells whose set differs from the first caster's
    /// GVS++ set at the same budget.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub differing_cells: Option<usize>,
    /// Each cell's mean erroneous pixels per view, in cell order (the JSON's per-cell view:
    /// whether a method wins on every cell, not only on the mean).
    pub cell_error_pixels: Vec<f64>,
}

/// A second ray caster whose GVS++ rows [`bench_pvs_scene_on`] adds beside the CPU's.
#[derive(Clone, Copy)]
pub struct SecondCaster<'a> {
    /// What its rows' method is called ("GVS++ GPU").
    pub method: &'a str,
    /// The caster, over the same scene.
    pub caster: &'a dyn RayCaster,
}

/// The result of one scene.
#[derive(Clone, Debug, Default)]
pub struct PvsSceneReport {
    /// One row per method and budget (empty when the scene had no free space for cells).
    pub rows: Vec<PvsRow>,
    /// The convergence curves, when asked for.
    pub convergence: Option<Convergence>,
}

/// The samplers of the benchmark, with its parameters.
struct Methods {
    gvspp: GvsPlusPlus,
    gvs: Gvs,
    raster: RasterSampler,
    /// GVS++ with the paper's discontinuities, when its row is asked for.
    gvspp_paper: Option<GvsPlusPlus>,
}

impl Methods {
    fn new(n_rand: u64, paper_discontinuities: bool) -> Self {
        let gvspp = GvsPlusPlus {
            params: GvsPlusPlusParams {
                n_rand,
                ..GvsPlusPlusParams::default()
            },
        };
        let gvspp_paper = paper_discontinuities.then(|| GvsPlusPlus {
            params: GvsPlusPlusParams {
                edge_discontinuities: false,
                ..gvspp.params.clone()
            },
        });
        Self {
            gvspp,
            gvspp_paper,
            gvs: Gvs {
                params: GvsParams {
                    n_rand,
                    ..GvsParams::default()
                },
            },
            raster: RasterSampler::default(),
        }
    }

    /// Whether the row of [`PAPER_GVSPP`] is among the full rows.
    fn paper_row(&self, equal_time_only: bool) -> bool {
        self.gvspp_paper.is_some() && !equal_time_only
    }

    /// Every method's set of one cell, in the order of the rows.
    fn sample(
        &self,
        ctx: &CellContext<'_>,
        small_budgets: &[(String, Budget)],
        equal_time_only: bool,
    ) -> Vec<CellResult> {
        let none = &|_: &ConvergencePoint| {};
        let mut results = Vec::new();
        if !equal_time_only {
            let a = self.gvspp.sample(ctx, &Budget::default(), none);
            let equal_rays = Budget::rays(a.rays);
            let equal_time = Budget {
                max_rays: None,
                max_time: Some(Duration::from_secs_f64(a.seconds)),
            };
            results = vec![
                a,
                RandomSampler.sample(ctx, &equal_rays, none),
                RandomSampler.sample(ctx, &equal_time, none),
                self.gvs.sample(ctx, &equal_rays, none),
                self.raster.sample(ctx, &equal_rays, none),
            ];
            if let Some(paper) = &self.gvspp_paper {
                results.push(paper.sample(ctx, &Budget::default(), none));
            }
        }
        for (_, budget) in small_budgets {
            results.push(self.gvspp.sample(ctx, budget, none));
            results.push(RandomSampler.sample(ctx, budget, none));
        }
        results
    }

    /// GVS++ with the second caster at the budgets of its rows (the order of
    /// [`second_rows`]): converged, then the small budgets.
    fn sample_second(
        &self,
        ctx: &CellContext<'_>,
        small_budgets: &[(String, Budget)],
        equal_time_only: bool,
    ) -> Vec<CellResult> {
        let none = &|_: &ConvergencePoint| {};
        let converged = (!equal_time_only).then(Budget::default);
        (converged.iter())
            .chain(small_budgets.iter().map(|(_, b)| b))
            .map(|budget| self.gvspp.sample(ctx, budget, none))
            .collect()
    }
}

/// The second caster's rows, in the order [`Methods::sample_second`] returns sets, each with
/// the index of the first caster's GVS++ row at the same budget among `rows`.
fn second_rows(rows: &[PvsRow], method: &str) -> Vec<(PvsRow, usize)> {
    (rows.iter().enumerate())
        .filter(|(_, r)| r.method == "GVS++")
        .map(|(i, r)| {
            let row = PvsRow {
                method: method.to_string(),
                differing_cells: Some(0),
                ..r.clone()
            };
            (row, i)
        })
        .collect()
}

/// The empty rows of a scene, in the order [`Methods::sample`] returns sets.
fn empty_rows(
    scene_name: &str,
    cells: usize,
    small_budgets: &[(String, Budget)],
    equal_time_only: bool,
    paper_row: bool,
) -> Vec<PvsRow> {
    let full = if equal_time_only {
        &[][..]
    } else {
        &FULL_ROWS[..]
    };
    let paper = paper_row.then_some((PAPER_GVSPP, "converged"));
    let full = (full.iter().copied().chain(paper)).map(|(m, b)| (m.to_string(), b.to_string()));
    let small = small_budgets
        .iter()
        .flat_map(|(label, _)| ["GVS++", "RAND"].map(|m| (m.to_string(), label.clone())));
    full.chain(small)
        .map(|(method, budget)| PvsRow {
            scene: scene_name.to_string(),
            method,
            budget,
            cells,
            ..PvsRow::default()
        })
        .collect()
}

/// Adds one cell's results and evaluations to the rows' sums.
fn accumulate(rows: &mut [PvsRow], results: &[CellResult], evaluations: &[CellEvaluation], n: f64) {
    for ((row, r), e) in rows.iter_mut().zip(results).zip(evaluations) {
        row.mean_rays += r.rays as f64;
        row.mean_seconds += r.seconds;
        row.avg_error_pixels += e.avg_error_pixels;
        row.cell_error_pixels.push(e.avg_error_pixels);
        row.avg_unconfirmed_pixels += e.avg_unconfirmed_pixels;
        row.max_error_pixels = row.max_error_pixels.max(e.max_error_pixels);
        row.avg_error_regions += e.avg_error_regions;
        row.max_error_region_size = row.max_error_region_size.max(e.max_error_region_size);
        row.pvs_percent += 100.0 * e.pvs_size as f64 / n;
        row.false_negatives += e.false_negatives;
    }
}

/// Turns the rows' sums over `cells` cells into means.
fn average(rows: &mut [PvsRow], cells: usize) {
    let k = cells as f64;
    for row in rows {
        row.mean_rays /= k;
        row.mean_seconds /= k;
        row.avg_error_pixels /= k;
        row.avg_unconfirmed_pixels /= k;
        row.avg_error_regions /= k;
        row.pvs_percent /= k;
    }
}

/// Runs the PVS benchmark on one scene (`scene_name` labels its rows and progress).
pub fn bench_pvs_scene(
    scene_name: &str,
    scene: &Scene,
    options: &PvsBenchOptions,
    progress: OnProgress<'_>,
) -> Result<PvsSceneReport, BenchError> {
    bench_pvs_scene_on(scene_name, scene, options, None, progress)
}

/// [`bench_pvs_scene`], with the GVS++ rows repeated on `second` (appended after the others).
pub fn bench_pvs_scene_on(
    scene_name: &str,
    scene: &Scene,
    options: &PvsBenchOptions,
    second: Option<SecondCaster<'_>>,
    progress: OnProgress<'_>,
) -> Result<PvsSceneReport, BenchError> {
    options.validate()?;
    let small_budgets = options.small_budgets();
    let methods = Methods::new(options.n_rand, options.paper_discontinuities);
    let eval = options.eval_params();
    let bvh = Bvh::build(scene);
    let half = scene.bounds().diagonal() * options.cell_size;
    let cells = random_free_cells(scene, &bvh, options.cells, half, options.seed);
    if cells.is_empty() {
        report(progress, Progress::NoFreeSpace { scene: scene_name });
        return Ok(PvsSceneReport::default());
    }
    let mut rows = empty_rows(
        scene_name,
        cells.len(),
        &small_budgets,
        options.equal_time_only,
        methods.paper_row(options.equal_time_only),
    );
    let mut extra = second.map_or_else(Vec::new, |s| second_rows(&rows, s.method));
    // Viewpoints only outside solid geometry: a view from inside a wall sees what no player
    // can, and both methods fail it alike.
    let free = |p: glam::Vec3| !inside_solid(scene, &bvh, p);
    let n = scene.triangle_count().max(1) as f64;
    for (i, cell) in cells.iter().enumerate() {
        report(
            progress,
            Progress::Cell {
                scene: scene_name,
                cell: i + 1,
                cells: cells.len(),
            },
        );
        let seed = options.seed.wrapping_add(i as u64);
        let ctx = context(scene, &bvh, cell, seed);
        let mut results = methods.sample(&ctx, &small_budgets, options.equal_time_only);
        let first = results.len();
        if let Some(s) = second {
            let ctx = CellContext {
                caster: s.caster,
                ..context(scene, &bvh, cell, seed)
            };
            results.extend(methods.sample_second(&ctx, &small_budgets, options.equal_time_only));
        }
        let sets: Vec<&TriangleSet> = results.iter().map(|r| &r.visible).collect();
        let evaluations = evaluate_cell_in(scene, cell, &free, &sets, &eval, &|_, _| {});
        accumulate(&mut rows, &results, &evaluations, n);
        for (k, (row, of)) in extra.iter_mut().enumerate() {
            let at = first + k;
            let (result, evaluation) = (&results[at..=at], &evaluations[at..=at]);
            accumulate(std::slice::from_mut(row), result, evaluation, n);
            if results[at].visible != results[*of].visible {
                *row.differing_cells.get_or_insert(0) += 1;
            }
        }
    }
    rows.extend(extra.into_iter().map(|(row, _)| row));
    let convergence = options.convergence.then(|| {
        let ctx = context(scene, &bvh, &cells[0], options.seed);
        let m = &methods;
        let samplers: [&dyn Sampler; 4] = [&m.gvspp, &RandomSampler, &m.gvs, &m.raster];
        convergence_curves(&ctx, &samplers, &eval)
    });
    average(&mut rows, cells.len());
    Ok(PvsSceneReport { rows, convergence })
}

fn context<'a>(scene: &'a Scene, bvh: &'a Bvh, cell: &'a ViewCell, seed: u64) -> CellContext<'a> {
    CellContext {
        scene,
        caster: bvh,
        cell,
        seed,
        free_space: None,
    }
}

/// The equal-budget comparisons in `rows`: for every GVS++ row at one of `options`' small
/// budgets, that row and the RAND row of the same scene and budget (GVS++ first).
pub fn equal_budget_pairs<'a>(
    rows: &'a [PvsRow],
    options: &PvsBenchOptions,
) -> Vec<(&'a PvsRow, &'a PvsRow)> {
    let labels: Vec<String> = options
        .small_budgets()
        .into_iter()
        .map(|(l, _)| l)
        .collect();
    rows.iter()
        .filter(|r| r.method == "GVS++" && labels.contains(&r.budget))
        .filter_map(|r| {
            let rand = rows
                .iter()
                .find(|x| x.scene == r.scene && x.method == "RAND" && x.budget == r.budget)?;
            Some((r, rand))
        })
        .collect()
}
