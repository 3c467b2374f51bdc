//! Two-sided files: `sightline pvs bound` and the last step of `pvs bake --bound` give every
//! cell a conservative bound (`sightline_region::bound` over RV's from-region method) and
//! report the gap between the two sides.

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use sightline_core::trace::Bvh;
use sightline_core::Scene;
use sightline_point::rv::{
    ConservativeSampler, RegionOptions, SolidFusion, MAX_FUSION_RESOLUTION, MAX_FUSION_SPLITS,
    MAX_OCCLUDERS,
};
use sightline_region::bound::{add_bounds, BoundSummary, BoundTotals, CellBound};
use sightline_region::PvsFile;

use super::args::{BoundArgs, BoundOptionArgs, SolidFusionArg};
use crate::args::thread_count;
use crate::output::{print_json, refuse_overwriting_inputs};

/// The conservative sampler of `--bound-occluders` and `--bound-fusion-*`.
/// The conservative sampler of `--bound` and `pvs bound` with `options`; `q3_cells`: the
/// cells are Quake 3 leaves or clusters, whose origins keep to the map's empty leaves, so the
/// bound goes through the map's portals (`ConservativeSampler::through_portals`, and the map's
/// solid space where their walk runs out) unless `--bound-no-portals`.
pub(super) fn bound_sampler(
    options: BoundOptionArgs,
    q3_cells: bool,
) -> Result<ConservativeSampler> {
    if !(1..=MAX_OCCLUDERS).contains(&options.bound_occluders) {
        bail!(
            "--bound-occluders must be 1 to {MAX_OCCLUDERS} (got {})",
            options.bound_occluders
        );
    }
    if options.bound_fusion_splits > MAX_FUSION_SPLITS {
        bail!(
            "--bound-fusion-splits must be 0 to {MAX_FUSION_SPLITS} (got {})",
            options.bound_fusion_splits
        );
    }
    if !(1..=MAX_FUSION_RESOLUTION).contains(&options.bound_fusion_resolution) {
        bail!(
            "--bound-fusion-resolution must be 1 to {MAX_FUSION_RESOLUTION} (got {})",
            options.bound_fusion_resolution
        );
    }
    let solid_fusion = match options.bound_solid_fusion {
        SolidFusionArg::Off => None,
        SolidFusionArg::Auto => Some(SolidFusion { radius: None }),
        SolidFusionArg::Radius(r) => Some(SolidFusion { radius: Some(r) }),
    };
    if solid_fusion.is_some() && options.bound_no_solids {
        bail!("--bound-solid-fusion needs the closed solids (drop --bound-no-solids)");
    }
    Ok(ConservativeSampler {
        options: RegionOptions {
            max_occluders: options.bound_occluders,
            fusion_splits: options.bound_fusion_splits,
            fusion_resolution: options.bound_fusion_resolution,
            ..RegionOptions::default()
        },
        through_portals: q3_cells && !options.bound_no_portals,
        back_faces_of_solids: !options.bound_no_solids,
        solid_fusion,
        ..Default::default()
    })
}

/// Adds the bounds to `file` with a progress bar, warns about cells whose sampled set the
/// conservative method did not contain, and returns the summary.
pub(super) fn bound_with_progress(
    scene: &Scene,
    bvh: &Bvh,
    file: &mut PvsFile,
    sampler: &ConservativeSampler,
) -> Result<BoundSummary> {
    let bar = ProgressBar::new(file.cells.len() as u64).with_style(
        ProgressStyle::with_template("bounds {bar:30} {pos}/{len} [{elapsed_precise} < {eta}]")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let summary = add_bounds(scene, bvh, file, sampler, &|done| {
        bar.set_position(done as u64)
    })?;
    bar.finish_and_clear();
    let not_contained = summary.cells_not_contained();
    if not_contained > 0 {
        eprintln!(
            "warning: in {not_contained} cells the conservative set lacks triangles the rays \
             found visible (kept in the bound; `metadata.cells[i].not_in_conservative` counts \
             them). The conservative set holds every triangle seen over some area; a ray that \
             meets a triangle only where another surface touches it (a T-junction, a wall \
             against a neighbour's, a tie in f32 depth) finds such ones too, a few per cell on \
             city scenes. Many more would be a bug: please report it with the scene"
        );
    }
    Ok(summary)
}

/// What `pvs bound --json` prints: the output, the file's `metadata.bound` totals and the
/// cells' sizes.
#[derive(Serialize)]
struct Report<'a> {
    output: &'a std::path::Path,
    #[serde(flatten)]
    totals: BoundTotals,
    cells: &'a [CellBound],
}

/// One line for the two sides of a bake (the file's `metadata.bound`).
pub(super) fn bound_line(totals: &BoundTotals) -> String {
    format!(
        "two-sided: {} bounds in {:.2} s, on average {:.2}x the sampled sets",
        totals.method, totals.seconds, totals.mean_ratio
    )
}

pub(super) fn run_bound(args: BoundArgs) -> Result<()> {
    let threads = thread_count(args.threads)?;
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("starting the worker threads")?
        .install(|| bound_command(&args))
}

fn bound_command(args: &BoundArgs) -> Result<()> {
    let Some(path) = &args.file else {
        bail!("no .pvs file to bound: sightline pvs bound SCENE PVS -o OUTPUT");
    };
    refuse_overwriting_inputs(&[&args.output], &[path])?;
    let scene = args.scene.load()?;
    let mut file = PvsFile::load(path).with_context(|| format!("reading {}", path.display()))?;
    // A Quake 3 bake records its cells' clusters (`pvs bake --q3-leaves | --q3-clusters`).
    let q3_cells = scene.bsp.is_some() && file.metadata["clusters"].is_array();
    let sampler = bound_sampler(args.options, q3_cells)?;
    file.check_scene(&scene)
        .with_context(|| format!("{} and {}", path.display(), args.scene.scene))?;
    let bvh = Bvh::build(&scene);
    let summary = bound_with_progress(&scene, &bvh, &mut file, &sampler)?;
    file.save(&args.output)?;
    if args.json {
        return print_json(&Report {
            output: &args.output,
            totals: summary.totals(),
            cells: &summary.cells,
        });
    }
    outln!("cell  set  bound  gap");
    for (i, c) in summary.cells.iter().enumerate() {
        outln!("{i} {} {} {}", c.set_size, c.bound_size, c.gap);
    }
    outln!(
        "{}, wrote {}",
        bound_line(&summary.totals()),
        args.output.display()
    );
    Ok(())
}
