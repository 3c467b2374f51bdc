//! `sightline report`: a self-contained HTML report of a `.pvs` file for its scene: summary,
//! per-cell PVS size and pixel error (the GVS++ paper's metric), the worst views with their
//! error pixels highlighted, convergence plots, GVS++ against RAND at equal small budgets and a
//! map of the cells coloured by PVS size.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use sightline_core::atomic_file::write_atomic;
use sightline_core::scene::LoadOptions;
use sightline_eval::EvalParams;

use crate::args::{parse_ray_budgets, BudgetList, LoadLimitArgs, SceneArgs};
use crate::commands::eval::{load_pvs_of, view_mode};
use crate::output::print_json;
use sightline_eval::report::budgets::{bake_budget_sets, ratio_text};
use sightline_eval::report::html::page;
use sightline_eval::report::{
    pvs_report, BudgetBakes, BudgetOptions, BudgetSummary, PvsReportOptions,
};

/// Arguments of `sightline report`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    /// Scene file or `procedural:NAME[?seed=S&size=N]` (the scene the .pvs was baked for).
    #[arg(value_name = "SCENE")]
    scene: String,
    /// The .pvs file.
    #[arg(value_name = "PVS")]
    pvs: PathBuf,
    /// Output directory; the report is DIR/index.html.
    #[arg(short, long, value_name = "DIR", default_value = "sightline-report")]
    output: PathBuf,
    /// Viewpoints per cell for the pixel error (randomly shifted Halton points in the cell).
    #[arg(long, value_name = "N", default_value_t = 16)]
    views: usize,
    /// Image size of the evaluation and of the worst views: square, one number (or NxN).
    #[arg(long, value_name = "PX", default_value = "256", value_parser = crate::args::parse_square_size)]
    size: u32,
    /// Views per viewpoint: `cube` (six faces) or `random` (one 90-degree view).
    #[arg(long, default_value = "cube", value_parser = ["cube", "random"])]
    view_mode: String,
    /// Worst views shown (one per cell, most erroneous pixels first).
    #[arg(long, value_name = "K", default_value_t = 6)]
    worst: usize,
    /// Rows of the cell table shown before its "show all" toggle: the worst cells (largest
    /// average error first); the others stay in the page, behind the toggle and the filter.
    #[arg(long, value_name = "N", default_value_t = 20)]
    cell_rows: usize,
    /// Seed of the viewpoint sequence.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Quake 3 maps: bezier patch tessellation (as when baking).
    #[arg(long, value_name = "N", default_value_t = LoadOptions::default().patch_subdivisions)]
    patch_subdivisions: u32,
    // How the scene is loaded (`--up-axis`, `--max-scene-bytes`, `--allow-outside-refs`), as
    // in every command that loads one.
    #[command(flatten)]
    limits: LoadLimitArgs,
    /// GVS++ against RAND at these ray budgets per cell (comma-separated, increasing), on
    /// `--budget-cells` of the file's cells, judged on the same views, with the time each bake
    /// took: the GVS++ paper's equal-time comparison, showing whether GVS++ beats random rays on
    /// this scene at small budgets. `none` leaves the section out.
    #[arg(long, value_name = "RAYS,..|none", default_value = "250000,1000000", value_parser = parse_ray_budgets)]
    budgets: BudgetList,
    /// Cells of the equal-budget comparison (spread evenly over the file's cells).
    #[arg(long, value_name = "N", default_value_t = 4)]
    budget_cells: usize,
    /// Print a JSON summary instead of text.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct CellSummary {
    cell: usize,
    pvs_size: usize,
    avg_error_pixels: f64,
    max_error_pixels: usize,
    avg_unconfirmed_pixels: f64,
    false_negatives: usize,
    /// Viewpoints not evaluated (Quake 3 cells: outside the cluster, or unreachable; other
    /// scenes: inside solid geometry).
    rejected_viewpoints: sightline_eval::report::evaluate::Rejected,
}

#[derive(Serialize)]
struct Summary {
    report: PathBuf,
    scene: String,
    cells: Vec<CellSummary>,
    /// GVS++ and RAND at each budget (absent with `--budgets none`).
    budgets: Option<BudgetSummary>,
}

impl Args {
    /// The scene to load, with its load options.
    fn scene_args(&self) -> SceneArgs {
        SceneArgs {
            scene: self.scene.clone(),
            patch_subdivisions: self.patch_subdivisions,
            limits: self.limits.clone(),
        }
    }
}

pub(crate) fn run(args: Args) -> Result<()> {
    if args.views == 0 || args.size == 0 || args.size > 4096 {
        bail!("--views must be >= 1 and --size in 1..=4096");
    }
    crate::output::refuse_overwriting_inputs(
        &[&args.output, &args.output.join("index.html")],
        &[std::path::Path::new(&args.scene), &args.pvs],
    )?;
    let scene = args.scene_args().load()?;
    let file = load_pvs_of(&scene, &args.pvs)?;
    let options = PvsReportOptions {
        params: EvalParams {
            viewpoints: args.views,
            resolution: args.size,
            views: view_mode(&args.view_mode),
            seed: args.seed,
        },
        worst_views: args.worst,
        cell_rows: args.cell_rows,
    };
    let budget_options = (!args.budgets.0.is_empty()).then(|| BudgetOptions {
        budgets: args.budgets.0.clone(),
        cells: args.budget_cells,
        seed: args.seed,
    });
    if let Some(o) = &budget_options {
        o.validate()?;
    }
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("creating {}", args.output.display()))?;
    let budget_bakes = budget_options
        .map(|o| bake_comparison(&scene, &file, &o))
        .transpose()?;
    let bar = ProgressBar::new(file.cells.len() as u64).with_style(
        ProgressStyle::with_template("cell {pos}/{len} {bar:30} {msg} [{elapsed_precise} < {eta}]")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let label = args.pvs.display().to_string();
    let report = pvs_report(
        &scene,
        &file,
        &label,
        &options,
        &[],
        budget_bakes.as_ref(),
        &|cell, done, total| {
            bar.set_position(cell as u64);
            bar.set_message(format!("view {done}/{total}"));
        },
    )?;
    bar.finish_and_clear();
    let html = page(
        "sightline PVS report",
        &format!(
            "{} view cells of {} ({} triangles), from {}.",
            file.cells.len(),
            scene.source,
            scene.triangle_count(),
            label
        ),
        &report.sections,
    );
    let index = args.output.join("index.html");
    write_atomic(&index, |w| std::io::Write::write_all(w, html.as_bytes()))
        .with_context(|| format!("writing {}", index.display()))?;
    let cells: Vec<CellSummary> = report
        .outcomes
        .iter()
        .enumerate()
        .map(|(i, o)| CellSummary {
            cell: i,
            pvs_size: o.eval.pvs_size,
            avg_error_pixels: o.eval.avg_error_pixels,
            max_error_pixels: o.eval.max_error_pixels,
            avg_unconfirmed_pixels: o.eval.avg_unconfirmed_pixels,
            false_negatives: o.eval.false_negatives,
            rejected_viewpoints: o.rejected,
        })
        .collect();
    if args.json {
        return print_json(&Summary {
            report: index,
            scene: scene.source.clone(),
            cells,
            budgets: report.budgets,
        });
    }
    let k = cells.len().max(1) as f64;
    outln!(
        "{} cells: mean PVS {:.0} triangles, {:.3} erroneous pixels per {}² view (max {}); \
         report: {}",
        cells.len(),
        cells.iter().map(|c| c.pvs_size as f64).sum::<f64>() / k,
        cells.iter().map(|c| c.avg_error_pixels).sum::<f64>() / k,
        args.size,
        cells.iter().map(|c| c.max_error_pixels).max().unwrap_or(0),
        index.display()
    );
    print_rejected(&cells)?;
    if let Some(b) = &report.budgets {
        let ratios: Vec<String> = b
            .ratios()
            .iter()
            .map(|(rays, r)| format!("{rays} rays {}", ratio_text(*r)))
            .collect();
        outln!(
            "GVS++ against RAND on {} cells (RAND's error / GVS++'s): {}",
            b.cells.len(),
            ratios.join(", ")
        );
    }
    Ok(())
}

/// Bakes the equal-budget comparison's sets, with a progress bar.
fn bake_comparison(
    scene: &sightline_core::Scene,
    file: &sightline_region::PvsFile,
    options: &BudgetOptions,
) -> Result<BudgetBakes> {
    let bar = ProgressBar::new(0).with_style(
        ProgressStyle::with_template("equal-budget bakes {pos}/{len} {bar:30} [{elapsed_precise}]")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let bakes = bake_budget_sets(scene, file, options, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    Ok(bakes)
}

/// Prints how many viewpoints the evaluation left out, by reason (none: nothing).
fn print_rejected(cells: &[CellSummary]) -> Result<()> {
    let rejected: sightline_eval::report::evaluate::Rejected =
        cells.iter().map(|c| c.rejected_viewpoints).sum();
    let (unreachable, solid) = (rejected.unreachable, rejected.inside_solid);
    if unreachable > 0 {
        outln!("{unreachable} viewpoints were unreachable from the map's spawn points and not evaluated");
    }
    if solid > 0 {
        outln!(
            "{solid} viewpoints lay inside solid geometry (most rays from them hit back faces) \
             and were not evaluated"
        );
    }
    Ok(())
}
