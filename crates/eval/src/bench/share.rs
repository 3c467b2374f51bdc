//! Ray sharing between view cells: a grid of cells over the scene's ground baked once
//! independently with GVS++ and once with shared rays (a ray cast for one cell also serves the
//! cells it crosses), each at several per-cell budgets; pixel error on a fixed subset of cells
//! and the speed-up of sharing at equal error.
//!
//! Method: the speed-up compares costs at equal error, not errors at equal cost, because that
//! is what a user budgets for. Each independent bake's error is looked up on the shared bakes'
//! error curve (made monotone: the best error reached with at most each budget, as one noisy
//! run must not make the curve go back) and the shared cost interpolated there in log space;
//! outside the curve only a bound is given.

use serde::Serialize;
use sightline_core::trace::Bvh;
use sightline_core::{Scene, TriangleSet};
use sightline_region::bake::bake;
use sightline_region::cell_sources::inside_solid;
use sightline_region::ray_sharing::{bake_shared, ShareParams};
use sightline_region::{Budget, GvsPlusPlus, GvsPlusPlusParams, ViewCell};

use super::common::{report, BenchError, OnProgress, Progress};
use crate::pixel_error::{evaluate_cell_in, EvalParams};

/// The method of the independent bakes' rows.
pub const INDEPENDENT: &str = "GVS++ independent";
/// The method of the shared bakes' rows.
pub const SHARED: &str = "GVS++ shared";

/// What `bench share` measures.
#[derive(Clone, Debug)]
pub struct ShareBenchOptions {
    /// Cells along x, y and z (1..=1024 each), as `pvs bake --grid NX,NY,NZ`; the count along
    /// the scene's up axis must be 1 (the cells form one layer, `layer`).
    pub grid: [u32; 3],
    /// Bottom and top of the cell layer above the scene's lowest point along its up axis.
    pub layer: (f32, f32),
    /// Per-cell ray budgets of the independent GVS++ bakes.
    pub budgets: Vec<u64>,
    /// Per-cell ray budgets of the shared bakes (backward casts included).
    pub share_budgets: Vec<u64>,
    /// GVS++ random rays per round of the independent bakes (with `fixed_rounds`).
    pub n_rand: u64,
    /// Random rays per cell and round of the shared bakes (`None`: half of `n_rand`; with
    /// `fixed_rounds`).
    pub share_n_rand: Option<u64>,
    /// Both bakes in the paper's rounds; otherwise both are scheduled by yield.
    pub fixed_rounds: bool,
    /// Shared bakes also cast their random rays backward.
    pub backward: bool,
    /// Shared bakes explore triangles received from other cells' rays too.
    pub explore_shared: bool,
    /// Cells evaluated (a fixed random subset of the grid).
    pub eval_cells: usize,
    /// Evaluation viewpoints per cell.
    pub viewpoints: usize,
    /// Evaluation resolution.
    pub resolution: u32,
    /// Seed.
    pub seed: u64,
    /// Both bakes only use ray origins outside solid geometry.
    pub free_space: bool,
}

impl ShareBenchOptions {
    /// Checks the layer, the grid and that every budget and `n_rand` is positive.
    pub fn validate(&self) -> Result<(), BenchError> {
        let (bottom, top) = self.layer;
        if !(bottom.is_finite() && top.is_finite() && bottom < top) {
            return Err(BenchError::Layer(bottom, top));
        }
        if let Some(&n) = self.grid.iter().find(|&&n| n == 0 || n > 1024) {
            return Err(BenchError::Grid(n));
        }
        if self.budgets.contains(&0) || self.share_budgets.contains(&0) || self.n_rand == 0 {
            return Err(BenchError::Zero {
                what: "every budget and n_rand",
            });
        }
        Ok(())
    }
}

/// One bake of `bench share`.
#[derive(Serialize, Clone, Debug)]
pub struct ShareRow {
    /// [`INDEPENDENT`] or [`SHARED`].
    pub method: String,
    /// Per-cell ray budget.
    pub budget_per_cell: u64,
    /// Rays cast by all cells.
    pub total_rays: u64,
    /// Wall-clock seconds of the bake.
    pub seconds: f64,
    /// Mean erroneous pixels per view over the evaluated cells.
    pub avg_error_pixels: f64,
    /// Most erroneous pixels in one view.
    pub max_error_pixels: usize,
    /// False negatives, summed over the evaluated cells.
    pub false_negatives: usize,
    /// Mean PVS size of the evaluated cells, percent of the scene's triangles.
    pub pvs_percent: f64,
    /// Triangles first found through another cell's ray, percent of all found.
    pub shared_percent: f64,
}

/// The speed-up of sharing at one independent bake's error.
#[derive(Serialize, Clone, Debug)]
pub struct ShareSpeedup {
    /// The independent bake's per-cell budget.
    pub budget_per_cell: u64,
    /// Its error.
    pub avg_error_pixels: f64,
    /// Shared rays needed for the same error (interpolated), `None` when no shared budget
    /// reached it; `bound` says whether the value is only a bound.
    pub shared_rays: Option<f64>,
    /// Shared seconds needed for the same error.
    pub shared_seconds: Option<f64>,
    /// Independent rays over shared rays.
    pub rays_speedup: Option<f64>,
    /// Independent seconds over shared seconds.
    pub time_speedup: Option<f64>,
    /// "" (interpolated), "at least", "not reached" or "no shared run".
    pub bound: &'static str,
}

/// The whole `bench share` result.
#[derive(Serialize, Clone, Debug)]
pub struct ShareReport {
    /// The scene's name.
    pub scene: String,
    /// Its triangles.
    pub triangles: usize,
    /// Cells of the grid.
    pub cells: usize,
    /// The grid indices of the evaluated cells, ascending.
    pub evaluated_cells: Vec<usize>,
    /// Independent bakes, then shared bakes, each by budget as given.
    pub rows: Vec<ShareRow>,
    /// One per independent bake.
    pub speedups: Vec<ShareSpeedup>,
}

/// The cost (rays, seconds) at which the shared curve reaches `error`, interpolating
/// log(cost) linearly in the error between the two shared runs around it; the bound kind when
/// `error` lies outside the shared curve.
pub fn cost_at_error(shared: &[ShareRow], error: f64) -> (Option<(f64, f64)>, &'static str) {
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

/// The grid of cells over the ground, one cell high, in the layer.
fn grid_cells(scene: &Scene, options: &ShareBenchOptions) -> Result<Vec<ViewCell>, BenchError> {
    let b = scene.bounds();
    let up_axis = scene.up.index();
    let (mut min, mut max) = (b.min, b.max);
    min[up_axis] = b.min[up_axis] + options.layer.0;
    max[up_axis] = b.min[up_axis] + options.layer.1;
    if options.grid[up_axis] != 1 {
        return Err(BenchError::GridHeight(options.grid[up_axis]));
    }
    Ok(ViewCell::grid(min, max, options.grid)?)
}

/// `count` of `0..cells`, a fixed random choice by `seed`, ascending.
fn evaluated_subset(cells: usize, count: usize, seed: u64) -> Vec<usize> {
    let mut rng = sightline_core::random::SplitMix64::new(seed ^ 0x5348_4152);
    let mut order: Vec<usize> = (0..cells).collect();
    for i in (1..order.len()).rev() {
        order.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
    }
    let mut evaluated: Vec<usize> = order.into_iter().take(count).collect();
    evaluated.sort_unstable();
    evaluated
}

/// A row before evaluation.
fn unevaluated(method: &str, budget: u64, total_rays: u64, seconds: f64) -> ShareRow {
    ShareRow {
        method: method.into(),
        budget_per_cell: budget,
        total_rays,
        seconds,
        pvs_percent: 0.0,
        avg_error_pixels: 0.0,
        max_error_pixels: 0,
        false_negatives: 0,
        shared_percent: 0.0,
    }
}

/// Per bake: its row and the sets of the evaluated cells.
type Run = (ShareRow, Vec<TriangleSet>);

/// The grid, its ray caster and what the bakes share.
struct Setup<'a> {
    scene: &'a Scene,
    bvh: Bvh,
    cells: Vec<ViewCell>,
    evaluated: Vec<usize>,
}

impl Setup<'_> {
    /// Whether a bake may use origin `p`: with `free_space`, only outside solid geometry
    /// (origins inside buildings see only the building's inside, which no evaluation
    /// viewpoint does).
    fn origin_ok(&self, free_space: bool, p: glam::Vec3) -> bool {
        !free_space || !inside_solid(self.scene, &self.bvh, p)
    }

    /// The evaluated cells' sets of a bake whose cell `i` has the set `visible(i)`.
    fn sets_of(&self, visible: impl Fn(usize) -> TriangleSet) -> Vec<TriangleSet> {
        self.evaluated.iter().map(|&i| visible(i)).collect()
    }

    /// The independent GVS++ bakes, one per budget.
    fn independent(&self, options: &ShareBenchOptions, progress: OnProgress<'_>) -> Vec<Run> {
        let sampler = GvsPlusPlus {
            params: GvsPlusPlusParams {
                n_rand: options.n_rand,
                fixed_rounds: options.fixed_rounds,
                ..GvsPlusPlusParams::default()
            },
        };
        let free = |_: usize, p: glam::Vec3| self.origin_ok(options.free_space, p);
        let mut runs = Vec::new();
        for &budget in &options.budgets {
            report(progress, Progress::IndependentBake { budget });
            let t = std::time::Instant::now();
            let file = bake(
                self.scene,
                &self.bvh,
                &self.cells,
                &sampler,
                &free,
                &Budget::rays(budget),
                options.seed,
                serde_json::Value::Null,
                &|_, _| {},
                &mut |_, _| {},
            );
            let seconds = t.elapsed().as_secs_f64();
            let total_rays = file.metadata["total_rays"].as_u64().unwrap_or(0);
            let row = unevaluated(INDEPENDENT, budget, total_rays, seconds);
            runs.push((row, self.sets_of(|i| file.cells[i].visible.clone())));
        }
        runs
    }

    /// The shared-ray bakes, one per budget.
    fn shared(&self, options: &ShareBenchOptions, progress: OnProgress<'_>) -> Vec<Run> {
        let params = ShareParams {
            gvspp: GvsPlusPlusParams {
                n_rand: options.share_n_rand.unwrap_or((options.n_rand / 2).max(1)),
                fixed_rounds: options.fixed_rounds,
                ..GvsPlusPlusParams::default()
            },
            backward: options.backward,
            explore_shared: options.explore_shared,
        };
        let free = |_: usize, p: glam::Vec3| self.origin_ok(options.free_space, p);
        let mut runs = Vec::new();
        for &budget in &options.share_budgets {
            report(progress, Progress::SharedBake { budget });
            let r = bake_shared(
                self.scene,
                &self.bvh,
                &self.cells,
                &params,
                &Budget::rays(budget),
                options.seed,
                &free,
                &|_| {},
            );
            let found: usize = r.cells.iter().map(|c| c.visible.count_ones(..)).sum();
            let mut row = unevaluated(SHARED, budget, r.total_rays, r.seconds);
            row.shared_percent = 100.0 * r.shared_insertions as f64 / found.max(1) as f64;
            runs.push((row, self.sets_of(|i| r.cells[i].visible.clone())));
        }
        runs
    }

    /// Judges every run's sets on the evaluated cells, filling in the rows' errors.
    fn evaluate(&self, runs: &mut [Run], options: &ShareBenchOptions, progress: OnProgress<'_>) {
        let eval = EvalParams {
            viewpoints: options.viewpoints,
            resolution: options.resolution,
            seed: options.seed,
            ..EvalParams::default()
        };
        let n_tri = self.scene.triangle_count().max(1) as f64;
        let count = self.evaluated.len();
        let free = |p: glam::Vec3| !inside_solid(self.scene, &self.bvh, p);
        for (k, &cell) in self.evaluated.iter().enumerate() {
            report(
                progress,
                Progress::Evaluating {
                    cell,
                    index: k + 1,
                    count,
                },
            );
            let sets: Vec<&TriangleSet> = runs.iter().map(|(_, s)| &s[k]).collect();
            let evaluations = evaluate_cell_in(
                self.scene,
                &self.cells[cell],
                &free,
                &sets,
                &eval,
                &|_, _| {},
            );
            for ((row, _), e) in runs.iter_mut().zip(&evaluations) {
                row.avg_error_pixels += e.avg_error_pixels / count as f64;
                row.max_error_pixels = row.max_error_pixels.max(e.max_error_pixels);
                row.false_negatives += e.false_negatives;
                row.pvs_percent += 100.0 * e.pvs_size as f64 / n_tri / count as f64;
            }
        }
    }
}

/// The speed-up of sharing at each independent row's error.
fn speedups(rows: &[ShareRow]) -> Vec<ShareSpeedup> {
    let (indep, shared): (Vec<ShareRow>, Vec<ShareRow>) =
        rows.iter().cloned().partition(|r| r.method == INDEPENDENT);
    indep
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
        .collect()
}

/// Runs the ray-sharing benchmark on `scene` (`scene_name` labels the report).
pub fn bench_share(
    scene_name: &str,
    scene: &Scene,
    options: &ShareBenchOptions,
    progress: OnProgress<'_>,
) -> Result<ShareReport, BenchError> {
    options.validate()?;
    let cells = grid_cells(scene, options)?;
    let setup = Setup {
        scene,
        bvh: Bvh::build(scene),
        evaluated: evaluated_subset(cells.len(), options.eval_cells, options.seed),
        cells,
    };
    let mut runs = setup.independent(options, progress);
    runs.extend(setup.shared(options, progress));
    setup.evaluate(&mut runs, options, progress);
    let rows: Vec<ShareRow> = runs.into_iter().map(|(r, _)| r).collect();
    Ok(ShareReport {
        scene: scene_name.to_string(),
        triangles: scene.triangle_count(),
        cells: setup.cells.len(),
        evaluated_cells: setup.evaluated,
        speedups: speedups(&rows),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(rays: u64, seconds: f64, error: f64) -> ShareRow {
        ShareRow {
            method: SHARED.into(),
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

    #[test]
    fn the_evaluated_subset_is_fixed_by_the_seed_and_ascending() {
        let a = evaluated_subset(256, 16, 1);
        assert_eq!(a, evaluated_subset(256, 16, 1));
        assert_eq!(a.len(), 16);
        assert!(a.windows(2).all(|w| w[0] < w[1]) && a[15] < 256);
        assert_ne!(a, evaluated_subset(256, 16, 2));
        assert_eq!(evaluated_subset(4, 16, 1), vec![0, 1, 2, 3]);
    }
}
