//! `sightline pvs merge-cells`: neighbouring view cells of nearly the same PVS merged into one
//! (`sightline_region::merge_similar`), for fewer cells at run time.

use anyhow::{Context, Result};
use serde::Serialize;
use sightline_region::merge_similar::{merge_similar_cells, MergeOptions, MergeReport};
use sightline_region::PvsFile;

use super::args::MergeCellsArgs;
use crate::output::{print_json, refuse_overwriting_inputs};

#[derive(Serialize)]
struct Summary {
    output: std::path::PathBuf,
    #[serde(flatten)]
    report: MergeReport,
}

pub(super) fn run_merge_cells(args: MergeCellsArgs) -> Result<()> {
    refuse_overwriting_inputs(&[&args.output], &[&args.file])?;
    let file =
        PvsFile::load(&args.file).with_context(|| format!("reading {}", args.file.display()))?;
    let options = MergeOptions {
        min_similarity: args.min_similarity,
        max_growth: args.max_growth,
    };
    let (merged, report) = merge_similar_cells(&file, &options)?;
    merged.save(&args.output)?;
    if report.not_axis_aligned > 0 {
        eprintln!(
            "warning: {} cells are not axis-aligned boxes; they were left as they are",
            report.not_axis_aligned
        );
    }
    let summary = Summary {
        output: args.output.clone(),
        report,
    };
    if args.json {
        return print_json(&summary);
    }
    let r = &summary.report;
    let growth = 100.0 * (r.mean_pvs_after / r.mean_pvs_before.max(1e-9) - 1.0);
    outln!(
        "merged {} cells into {}: mean PVS {:.1} -> {:.1} triangles ({growth:+.1} %), wrote {}",
        r.cells_before,
        r.cells_after,
        r.mean_pvs_before,
        r.mean_pvs_after,
        summary.output.display()
    );
    Ok(())
}
