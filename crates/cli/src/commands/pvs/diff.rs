//! `sightline pvs diff`: the cells whose sets differ between two .pvs files (exit status as
//! `diff`).

use anyhow::{bail, Context, Result};
use serde::Serialize;
use sightline_region::PvsFile;

use crate::errors::ExitStatus;
use crate::output::print_json;

use super::args::DiffArgs;

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

pub(super) fn run_diff(args: DiffArgs) -> Result<()> {
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
