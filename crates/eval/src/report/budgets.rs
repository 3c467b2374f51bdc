//! The equal-budget comparison of a report: GVS++ against RAND at small ray budgets on a few of
//! the file's cells, judged on those cells' own views, with the time each bake took. It is the
//! GVS++ paper's equal-time comparison (Koch, Wimmer 2021, section 6 and table 1) at the budgets
//! where a CPU bake must already beat random sampling (issue 24), so that a report shows
//! whether GVS++ still earns its rays on the user's scene.
//!
//! Method: the cells are spread evenly over the file's cell list; each bakes with GVS++ and RAND
//! at every budget, from the same seed and, for Quake 3 cells, the same origin rule as the
//! bake; the sets join the cell's evaluation as extra sets, so they are judged on exactly the
//! views of the file's own PVS. Equal rays rather than equal time: both methods cast rays at
//! about the same rate, and ray counts do not depend on the machine's load; the time of every
//! bake is measured and shown beside its error.

use std::fmt::Write as _;

use serde::Serialize;
use sightline_core::trace::Bvh;
use sightline_core::{Scene, TriangleSet};
use sightline_region::bake::cell_seed;
use sightline_region::cell_sources::Q3OriginRule;
use sightline_region::{Budget, CellContext, GvsPlusPlus, PvsFile, RandomSampler, Sampler};

use super::error::ReportError;
use super::evaluate::CellOutcome;
use super::html::{Cell, Section, Table};
use super::plot::{log_log_plot, Series};

/// The most budgets one comparison takes.
pub const MAX_BUDGETS: usize = 8;
/// The largest budget, in rays (about four minutes on two cores per bake).
pub const MAX_BUDGET_RAYS: u64 = 1_000_000_000;
/// Errors below this are drawn at it on the log scale (a zero error has no logarithm).
pub const ERROR_FLOOR: f64 = 1e-3;

/// The two methods compared, in the order of each budget's sets.
pub const METHODS: [&str; 2] = ["GVS++", "RAND"];

/// What the comparison bakes.
#[derive(Clone, Debug, PartialEq)]
pub struct BudgetOptions {
    /// Ray budgets per cell, increasing.
    pub budgets: Vec<u64>,
    /// Cells compared (at most the file's).
    pub cells: usize,
    /// Seed of the bakes (cell `i` uses `cell_seed(seed, i)`, as a bake does).
    pub seed: u64,
}

impl BudgetOptions {
    /// Checks the options: 1 to [`MAX_BUDGETS`] budgets, each 1 to [`MAX_BUDGET_RAYS`] rays,
    /// increasing, and at least one cell.
    pub fn validate(&self) -> Result<(), ReportError> {
        if self.budgets.is_empty() || self.budgets.len() > MAX_BUDGETS {
            return Err(ReportError::BudgetCount {
                given: self.budgets.len(),
                max: MAX_BUDGETS,
            });
        }
        if let Some(&b) = self
            .budgets
            .iter()
            .find(|&&b| b == 0 || b > MAX_BUDGET_RAYS)
        {
            return Err(ReportError::BudgetOutOfRange {
                rays: b,
                max: MAX_BUDGET_RAYS,
            });
        }
        if self.budgets.windows(2).any(|w| w[0] >= w[1]) {
            return Err(ReportError::BudgetsNotIncreasing(self.budgets.clone()));
        }
        if self.cells == 0 {
            return Err(ReportError::NoBudgetCells);
        }
        Ok(())
    }
}

/// One bake of the comparison.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BudgetRun {
    /// Rays cast.
    pub rays: u64,
    /// Seconds it took.
    pub seconds: f64,
}

/// The comparison's bakes: for each compared cell, its index and, per budget, GVS++'s then
/// RAND's set.
pub struct BudgetBakes {
    /// The options baked with.
    pub options: BudgetOptions,
    /// (file cell index, runs and sets in [`BudgetBakes::set_order`]).
    pub cells: Vec<(usize, Vec<(BudgetRun, TriangleSet)>)>,
}

impl BudgetBakes {
    /// The (method, budget index) of the `k`-th set of a cell.
    pub fn set_order(&self, k: usize) -> (usize, usize) {
        (k % METHODS.len(), k / METHODS.len())
    }
}

/// Evenly spread indices of `count` of `total` cells (all when `count >= total`).
pub fn spread_cells(total: usize, count: usize) -> Vec<usize> {
    let n = count.min(total);
    (0..n).map(|i| i * total / n).collect()
}

/// Bakes the comparison's sets for `file`'s cells (made for `scene`). `progress(done, total)`
/// counts bakes.
pub fn bake_budget_sets(
    scene: &Scene,
    file: &PvsFile,
    options: &BudgetOptions,
    progress: &dyn Fn(usize, usize),
) -> Result<BudgetBakes, ReportError> {
    options.validate()?;
    let bvh = Bvh::build(scene);
    let rule = Q3OriginRule::from_metadata(scene, &file.metadata, None)?;
    let picked = spread_cells(file.cells.len(), options.cells);
    let total = picked.len() * options.budgets.len() * METHODS.len();
    let gvspp = GvsPlusPlus::default();
    let samplers: [&dyn Sampler; 2] = [&gvspp, &RandomSampler];
    let mut cells = Vec::with_capacity(picked.len());
    for (done_cells, &i) in picked.iter().enumerate() {
        let allows = |p| rule.as_ref().is_none_or(|r| r.allows(i, p));
        let ctx = CellContext {
            scene,
            caster: &bvh,
            cell: &file.cells[i].cell,
            seed: cell_seed(options.seed, i),
            free_space: rule
                .as_ref()
                .map(|_| &allows as &(dyn Fn(glam::Vec3) -> bool + Sync)),
        };
        let mut runs = Vec::with_capacity(options.budgets.len() * METHODS.len());
        for &b in &options.budgets {
            for s in samplers {
                let r = s.sample(&ctx, &Budget::rays(b), &|_| {});
                runs.push((
                    BudgetRun {
                        rays: r.rays,
                        seconds: r.seconds,
                    },
                    r.visible,
                ));
                progress(
                    done_cells * options.budgets.len() * METHODS.len() + runs.len(),
                    total,
                );
            }
        }
        cells.push((i, runs));
    }
    Ok(BudgetBakes {
        options: options.clone(),
        cells,
    })
}

/// One method at one budget, means over the compared cells.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BudgetPoint {
    /// "GVS++" or "RAND".
    pub method: &'static str,
    /// The budget, in rays.
    pub budget: u64,
    /// Mean rays cast.
    pub rays: f64,
    /// Mean seconds per bake.
    pub seconds: f64,
    /// Mean average erroneous pixels per view.
    pub avg_error_pixels: f64,
}

/// The comparison's means, GVS++ and RAND at each budget (in that order).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BudgetSummary {
    /// Cells compared (file indices).
    pub cells: Vec<usize>,
    /// Two points per budget: GVS++, RAND.
    pub points: Vec<BudgetPoint>,
}

impl BudgetSummary {
    /// Means over the compared cells of `bakes`, whose sets are
    /// `outcomes[cell].extra[offset(cell)..]` (after the extra sets the caller had for it).
    pub fn new(
        bakes: &BudgetBakes,
        outcomes: &[CellOutcome],
        offset: &dyn Fn(usize) -> usize,
    ) -> Self {
        let k = bakes.cells.len().max(1) as f64;
        let mut points: Vec<BudgetPoint> = bakes
            .options
            .budgets
            .iter()
            .flat_map(|&budget| {
                METHODS.map(|method| BudgetPoint {
                    method,
                    budget,
                    rays: 0.0,
                    seconds: 0.0,
                    avg_error_pixels: 0.0,
                })
            })
            .collect();
        for (cell, runs) in &bakes.cells {
            for (k_set, (run, _)) in runs.iter().enumerate() {
                let p = &mut points[k_set];
                p.rays += run.rays as f64;
                p.seconds += run.seconds;
                p.avg_error_pixels += outcomes
                    .get(*cell)
                    .and_then(|o| o.extra.get(offset(*cell) + k_set))
                    .map_or(0.0, |e| e.avg_error_pixels);
            }
        }
        for p in &mut points {
            p.rays /= k;
            p.seconds /= k;
            p.avg_error_pixels /= k;
        }
        Self {
            cells: bakes.cells.iter().map(|(i, _)| *i).collect(),
            points,
        }
    }

    /// (budget, GVS++'s point, RAND's point) for each budget.
    pub fn pairs(&self) -> impl Iterator<Item = (u64, &BudgetPoint, &BudgetPoint)> {
        self.points.chunks(2).map(|p| (p[0].budget, &p[0], &p[1]))
    }

    /// RAND's error over GVS++'s at each budget (infinite when GVS++'s is 0 and RAND's is not;
    /// 1 when both are 0).
    pub fn ratios(&self) -> Vec<(u64, f64)> {
        self.pairs()
            .map(|(b, g, r)| (b, error_ratio(r.avg_error_pixels, g.avg_error_pixels)))
            .collect()
    }
}

/// `rand / gvspp`, with 0 / 0 = 1 and x / 0 = infinity.
pub fn error_ratio(rand: f64, gvspp: f64) -> f64 {
    match (rand > 0.0, gvspp > 0.0) {
        (_, true) => rand / gvspp,
        (true, false) => f64::INFINITY,
        (false, false) => 1.0,
    }
}

/// A ratio as text: `12.3x`, or `GVS++ exact` when GVS++ made no error and RAND did.
pub fn ratio_text(ratio: f64) -> String {
    if ratio.is_finite() {
        format!("{ratio:.1}x")
    } else {
        "GVS++ exact".to_string()
    }
}

/// The report section: error against time, log-log, and the table behind it.
pub(crate) fn budget_section(
    summary: &BudgetSummary,
    resolution: u32,
) -> Result<Section, ReportError> {
    let series: Vec<Series> = METHODS
        .iter()
        .enumerate()
        .map(|(m, name)| Series {
            label: name.to_string(),
            points: summary
                .points
                .iter()
                .skip(m)
                .step_by(METHODS.len())
                .map(|p| (p.seconds.max(1e-6), p.avg_error_pixels.max(ERROR_FLOOR)))
                .collect(),
        })
        .collect();
    let mut table = Table::new(
        "budget-table",
        &[
            "rays per cell",
            "GVS++ error px",
            "RAND error px",
            "RAND / GVS++",
            "GVS++ s",
            "RAND s",
        ],
    );
    for (budget, g, r) in summary.pairs() {
        let ratio = error_ratio(r.avg_error_pixels, g.avg_error_pixels);
        table.row(
            vec![
                Cell::Num(budget.to_string()),
                Cell::Num(format!("{:.3}", g.avg_error_pixels)),
                Cell::Num(format!("{:.3}", r.avg_error_pixels)),
                Cell::Num(ratio_text(ratio)),
                Cell::Num(format!("{:.3}", g.seconds)),
                Cell::Num(format!("{:.3}", r.seconds)),
            ],
            &[
                ("budget", budget.to_string()),
                ("ratio", format!("{ratio}")),
            ],
        );
    }
    let mut body = String::new();
    let _ = writeln!(
        body,
        "<p>GVS++ against RAND at small ray budgets, on {} of the file's cells ({}), judged on \
         the same views as the file's PVS: average erroneous pixels per {resolution}² view \
         against the seconds a bake took (both log scales; a zero error is drawn at {ERROR_FLOOR}). \
         The GVS++ paper's equal-time comparison: below the RAND line, GVS++ earns its rays.</p>",
        summary.cells.len(),
        cell_list(&summary.cells),
    );
    body.push_str("<div id=\"budget-plot\">");
    body.push_str(&log_log_plot(
        &series,
        "seconds per cell",
        "avg error px",
        (900, 420),
    )?);
    body.push_str("</div>\n");
    body.push_str(&table.html());
    Ok(Section::new(
        "budgets",
        "GVS++ against RAND at equal budgets",
        body,
    ))
}

/// "0, 5, 10" (the first 12, then "…").
fn cell_list(cells: &[usize]) -> String {
    let mut s: Vec<String> = cells.iter().take(12).map(|c| format!("cell {c}")).collect();
    if cells.len() > 12 {
        s.push("…".into());
    }
    s.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_are_spread_over_the_list() {
        assert_eq!(spread_cells(10, 4), vec![0, 2, 5, 7]);
        assert_eq!(spread_cells(3, 8), vec![0, 1, 2]);
        assert!(spread_cells(0, 4).is_empty());
    }

    #[test]
    fn ratios_handle_zero_errors() {
        assert_eq!(error_ratio(10.0, 2.0), 5.0);
        assert_eq!(error_ratio(3.0, 0.0), f64::INFINITY);
        assert_eq!(error_ratio(0.0, 0.0), 1.0);
        assert_eq!(ratio_text(12.34), "12.3x");
        assert_eq!(ratio_text(f64::INFINITY), "GVS++ exact");
    }

    #[test]
    fn bad_options_are_errors_naming_the_problem() {
        let ok = BudgetOptions {
            budgets: vec![1000, 4000],
            cells: 2,
            seed: 1,
        };
        assert!(ok.validate().is_ok());
        let bad = |budgets: Vec<u64>, cells| {
            BudgetOptions {
                budgets,
                cells,
                seed: 1,
            }
            .validate()
        };
        assert!(bad(vec![], 1).unwrap_err().to_string().contains("budgets"));
        assert!(bad(vec![4000, 1000], 1)
            .unwrap_err()
            .to_string()
            .contains("increase"));
        assert!(bad(vec![0], 1).unwrap_err().to_string().contains("outside"));
        assert!(bad(vec![MAX_BUDGET_RAYS + 1], 1).is_err());
        assert!(bad(vec![1000], 0).unwrap_err().to_string().contains("cell"));
        assert!(matches!(
            bad(vec![4000, 1000], 1),
            Err(ReportError::BudgetsNotIncreasing(b)) if b == [4000, 1000]
        ));
        assert!(matches!(
            bad(vec![1; MAX_BUDGETS + 1], 1),
            Err(ReportError::BudgetCount { given, .. }) if given == MAX_BUDGETS + 1
        ));
    }
}
