//! `sightline eval`: the pixel error of a .pvs file, as the GVS++ paper measures it.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use image::RgbImage;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use sightline_core::raster::render;
use sightline_core::Hit;
use sightline_eval::{evaluate_cell_in, CellEvaluation, EvalParams, ViewMode, WorstView};
use sightline_region::{CellPvs, PvsFile};

use crate::args::SceneArgs;
use crate::output::{print_json, save_png};
use sightline_eval::report::evaluate::{Rejected, Viewpoints};
use sightline_eval::report::shading::id_colour;
use sightline_region::cell_sources::Q3Origins;
use sightline_region::reachable::ReachParams;

/// Arguments of `sightline eval`.
#[derive(clap::Args, Debug)]
pub(crate) struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// The .pvs file to evaluate (it must have been made for SCENE).
    #[arg(value_name = "PVS")]
    pvs_file: Option<PathBuf>,
    /// The .pvs file: the spelling before the commands shared one convention (hidden).
    #[arg(
        long = "pvs",
        value_name = "PVS",
        hide = true,
        conflicts_with = "pvs_file"
    )]
    pvs_flag: Option<PathBuf>,
    /// Viewpoints per cell (randomly shifted Halton points inside the cell) [default: 2000].
    /// (`--views cube|random`, the old spelling of --view-mode, is still understood.)
    #[arg(long, value_name = "N", value_parser = parse_views)]
    views: Option<ViewsArg>,
    /// The old spelling of --views N (hidden).
    #[arg(long, value_name = "N", hide = true)]
    viewpoints: Option<usize>,
    /// Image size of the evaluation: square, one number (or NxN).
    #[arg(long, value_name = "PX", alias = "resolution", default_value = "1000",
        value_parser = crate::args::parse_square_size)]
    size: u32,
    /// Views per viewpoint: `cube` (six faces, no direction unchecked) or `random` (one
    /// 90-degree view in a random direction, closer to the paper) [default: cube].
    #[arg(long, value_name = "MODE", value_parser = ["cube", "random"])]
    view_mode: Option<String>,
    /// Only these cells (comma-separated indices).
    #[arg(long, value_delimiter = ',')]
    cells: Vec<usize>,
    /// Write each cell's worst view with the error pixels highlighted in red to DIR.
    #[arg(long, value_name = "DIR")]
    images: Option<PathBuf>,
    /// Seed of the viewpoint sequence.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Quake 3 cells: take viewpoints only in the space reachable from the spawn points
    /// (lattice step UNITS, default 16), whatever rule the bake used. Viewpoints of a bake of
    /// --q3-leaves or --q3-clusters are where it took its ray origins by default; this judges
    /// an --include-unreachable bake from the viewpoints of a default one.
    #[arg(long, value_name = "UNITS", num_args = 0..=1, default_missing_value = "16")]
    reachable_viewpoints: Option<f32>,
    /// Which side of a two-sided file (`pvs bake --bound`) to evaluate: `set`, the sampled
    /// set, or `bound`, the conservative bound (its false negatives must be 0; its "extra"
    /// triangles measure how loose it is).
    #[arg(long, value_name = "SIDE", value_parser = ["set", "bound"], default_value = "set")]
    side: String,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

/// `--views`: a viewpoint count, as in every command; or, as `eval` spelled it before, the
/// view mode (`cube` or `random`).
#[derive(Clone, Debug)]
enum ViewsArg {
    Count(usize),
    Mode(String),
}

fn parse_views(s: &str) -> Result<ViewsArg, String> {
    match s {
        "cube" | "random" => Ok(ViewsArg::Mode(s.to_string())),
        _ => s.parse().map(ViewsArg::Count).map_err(|_| {
            format!("'{s}' is not a viewpoint count (the view mode is --view-mode cube|random)")
        }),
    }
}

impl Args {
    /// The .pvs file, from the positional argument or the old `--pvs`.
    fn pvs(&self) -> Result<&std::path::Path> {
        match (&self.pvs_file, &self.pvs_flag) {
            (Some(p), _) | (None, Some(p)) => Ok(p),
            (None, None) => bail!("no .pvs file to evaluate: sightline eval SCENE PVS"),
        }
    }

    /// Viewpoints per cell and the view mode, from `--views`, `--view-mode` and the old
    /// `--viewpoints` and `--views cube|random`; the same thing given twice is an error.
    fn views(&self) -> Result<(usize, String)> {
        let (count, mode) = match &self.views {
            Some(ViewsArg::Count(n)) => (Some(*n), None),
            Some(ViewsArg::Mode(m)) => (None, Some(m.clone())),
            None => (None, None),
        };
        let count = match (count, self.viewpoints) {
            (Some(_), Some(_)) => bail!("--views N and --viewpoints N say the same: give one"),
            (a, b) => a.or(b).unwrap_or(2000),
        };
        let mode = match (mode, &self.view_mode) {
            (Some(_), Some(_)) => {
                bail!("--views cube|random and --view-mode say the same: give --view-mode")
            }
            (a, b) => a.or(b.clone()).unwrap_or_else(|| "cube".to_string()),
        };
        Ok((count, mode))
    }
}

#[derive(Serialize)]
struct Row {
    cell: usize,
    #[serde(flatten)]
    evaluation: CellEvaluation,
    pvs_percent: f64,
    seconds: f64,
    /// Viewpoints not evaluated (Quake 3 cells: outside the cell's cluster, or unreachable in
    /// a bake with reachable origins; other scenes: inside solid geometry).
    rejected_viewpoints: Rejected,
}

/// Reads the `.pvs` file at `path` and checks that it was baked for `scene`.
pub(crate) fn load_pvs_of(
    scene: &sightline_core::Scene,
    path: &std::path::Path,
) -> Result<PvsFile> {
    let file = PvsFile::load(path).with_context(|| format!("reading {}", path.display()))?;
    file.check_scene(scene)
        .with_context(|| format!("{}", path.display()))?;
    Ok(file)
}

/// The view mode named on the command line (`random`; anything else is the cube faces, which
/// clap's value list already restricts to `cube`).
pub(crate) fn view_mode(name: &str) -> ViewMode {
    if name == "random" {
        ViewMode::Random
    } else {
        ViewMode::CubeFaces
    }
}

/// Evaluates the `.pvs` file: validates the arguments, loads the scene and the file, checks
/// the cells asked for, evaluates each cell (with a progress bar), then prints the rows as
/// JSON or as a table with its mean.
pub(crate) fn run(args: Args) -> Result<()> {
    if let Some(dir) = &args.images {
        crate::output::refuse_overwriting_inputs(
            &[dir],
            &[std::path::Path::new(&args.scene.scene), args.pvs()?],
        )?;
    }
    let scene = args.scene.load()?;
    let mut file = load_pvs_of(&scene, args.pvs()?)?;
    if args.side == "bound" {
        if !file.has_bounds() {
            bail!(
                "{} holds no conservative bounds to evaluate (bake with --bound, or add them \
                 with `pvs bound`)",
                args.pvs()?.display()
            );
        }
        for c in &mut file.cells {
            c.visible = c.bound.take().unwrap_or_default();
        }
    }
    let plan = plan(&args, &file)?;
    let rows = evaluate_cells(&args, &scene, &file, &plan)?;
    if args.json {
        return print_json(&rows);
    }
    print_table(&rows)?;
    print_mean(&rows, args.size)
}

/// What to evaluate, from the checked arguments.
struct Plan {
    /// The evaluation's settings.
    params: EvalParams,
    /// The cells to evaluate (indices into the file), in order.
    indices: Vec<usize>,
}

/// Checks the numeric arguments and the cells asked for against `file` (every cell when none
/// are), and creates the images' folder: the errors a user can fix, before any work.
fn plan(args: &Args, file: &PvsFile) -> Result<Plan> {
    let (viewpoints, mode) = args.views()?;
    if viewpoints == 0 || args.size > 8192 {
        bail!("--views must be >= 1 and --size in 1..=8192");
    }
    let params = EvalParams {
        viewpoints,
        resolution: args.size,
        views: view_mode(&mode),
        seed: args.seed,
    };
    let indices: Vec<usize> = if args.cells.is_empty() {
        (0..file.cells.len()).collect()
    } else {
        args.cells.clone()
    };
    if let Some(&bad) = indices.iter().find(|&&i| i >= file.cells.len()) {
        bail!(
            "cell {bad} does not exist ({} cells in {})",
            file.cells.len(),
            args.pvs()?.display()
        );
    }
    if let Some(dir) = &args.images {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    Ok(Plan { params, indices })
}

/// Evaluates the planned cells one after the other (the library's per-cell evaluation, from
/// the viewpoints the bake's cells allow), with a progress bar on stderr, saving each cell's
/// worst view with `--images`. One row per cell.
fn evaluate_cells(
    args: &Args,
    scene: &sightline_core::Scene,
    file: &PvsFile,
    plan: &Plan,
) -> Result<Vec<Row>> {
    let bar = ProgressBar::new(plan.indices.len() as u64).with_style(
        ProgressStyle::with_template("cell {pos}/{len} {bar:30} {msg} [{elapsed_precise} < {eta}]")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let n = scene.triangle_count().max(1) as f64;
    // Quake 3 cells are judged from where the bake took its ray origins.
    let origins = args
        .reachable_viewpoints
        .map(|step| Q3Origins::Reachable(ReachParams { step }));
    let viewpoints = Viewpoints::of(scene, file, origins).context("--reachable-viewpoints")?;
    let mut rows = Vec::new();
    for &i in &plan.indices {
        let start = Instant::now();
        let cell = &file.cells[i];
        let filter = viewpoints.cell(i);
        let e = evaluate_cell_in(
            scene,
            &cell.cell,
            &|p| filter.allows(p),
            &[&cell.visible],
            &plan.params,
            &|done, total| {
                bar.set_message(format!("view {done}/{total}"));
            },
        )
        .remove(0);
        if let (Some(dir), Some(worst)) = (&args.images, e.worst_view) {
            save_worst_view(
                scene,
                cell,
                &worst,
                args.size,
                &dir.join(format!("cell{i}_worst.png")),
            )?;
        }
        rows.push(Row {
            cell: i,
            pvs_percent: 100.0 * e.pvs_size as f64 / n,
            evaluation: e,
            seconds: start.elapsed().as_secs_f64(),
            rejected_viewpoints: filter.rejected(),
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(rows)
}

/// Saves the image of a cell's worst view to `path`: triangles of the cell's set in their id
/// colour (dimmed), triangles it misses in red (the error pixels), background black. Nothing
/// is written when the view gives no camera.
fn save_worst_view(
    scene: &sightline_core::Scene,
    cell: &CellPvs,
    worst: &WorstView,
    resolution: u32,
    path: &std::path::Path,
) -> Result<()> {
    // The near plane the evaluation rendered the view with.
    let near = cell.cell.default_near(scene);
    if let Some(camera) = worst.camera(resolution, near) {
        let frame = render(scene, &camera);
        let img = RgbImage::from_fn(frame.width, frame.height, |x, y| {
            let id = frame.ids[(y * frame.width + x) as usize];
            image::Rgb(if id == Hit::NONE {
                [0, 0, 0]
            } else if !cell.visible.contains(id as usize) {
                [255, 0, 0]
            } else {
                id_colour(id).map(|c| c / 2)
            })
        })
        .clone();
        save_png(&img, path)?;
    }
    Ok(())
}

/// Prints the rows as a Markdown table, one line per cell.
fn print_table(rows: &[Row]) -> Result<()> {
    outln!(
        "| cell | avg err px | max err px | avg err regions | max region px | avg snapping px | PVS | PVS % | seen | false neg | images | s |"
    );
    outln!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let e = &r.evaluation;
        outln!(
            "| {} | {:.2} | {} | {:.2} | {} | {:.2} | {} | {:.2} | {} | {} | {} | {:.1} |",
            r.cell,
            e.avg_error_pixels,
            e.max_error_pixels,
            e.avg_error_regions,
            e.max_error_region_size,
            e.avg_unconfirmed_pixels,
            e.pvs_size,
            r.pvs_percent,
            e.ground_truth_size,
            e.false_negatives,
            e.images,
            r.seconds
        );
    }
    Ok(())
}

/// Prints the mean over the cells that had viewpoints (images of `resolution`²), and how
/// many viewpoints were not evaluated.
fn print_mean(rows: &[Row], resolution: u32) -> Result<()> {
    // Cells without a viewpoint (a Quake 3 cell judged from reachable viewpoints only) have
    // no error to average.
    let rejected: Rejected = rows.iter().map(|r| r.rejected_viewpoints).sum();
    let (outside, unreachable, solid) = (
        rejected.outside_cluster,
        rejected.unreachable,
        rejected.inside_solid,
    );
    let judged: Vec<&Row> = rows.iter().filter(|r| r.evaluation.images > 0).collect();
    if judged.len() < rows.len() {
        outln!(
            "{} cells had no viewpoint and are left out of the mean",
            rows.len() - judged.len()
        );
    }
    let rows = judged;
    let k = rows.len().max(1) as f64;
    outln!(
        "mean over {} cells: {:.2} erroneous pixels per {}² image, max {}, {:.2} error regions, PVS {:.2}%",
        rows.len(),
        rows.iter().map(|r| r.evaluation.avg_error_pixels).sum::<f64>() / k,
        resolution,
        rows.iter().map(|r| r.evaluation.max_error_pixels).max().unwrap_or(0),
        rows.iter().map(|r| r.evaluation.avg_error_regions).sum::<f64>() / k,
        rows.iter().map(|r| r.pvs_percent).sum::<f64>() / k,
    );
    if outside + unreachable > 0 {
        outln!(
            "viewpoints not evaluated: {outside} outside their cell's cluster, {unreachable} \
             unreachable from the map's spawn points"
        );
    }
    if solid > 0 {
        outln!(
            "viewpoints not evaluated: {solid} inside solid geometry (most rays from them hit \
             back faces: a wall's volume or a sealed pocket, where no camera can be)"
        );
    }
    Ok(())
}
