//! Merging neighbouring view cells whose PVSs are nearly the same: fewer cells, so less memory
//! and fewer cell switches at run time, at a stated cost in PVS size. Not from one of the
//! papers; a greedy agglomeration in the spirit of view-cell merging in PVS pipelines (e.g.
//! Unreal's precomputed visibility, which bakes per cell and then shares identical sets).
//!
//! Why it is safe: the PVS of the union of two regions is exactly the union of their PVSs (a
//! point of the union lies in one of the two and sees what that cell's PVS lists), so a merged
//! cell is as correct as its parts were; it only makes players in it load a larger set. Two
//! cells merge only when their union is exactly a box (axis-aligned boxes sharing a whole
//! face), so the merged cell covers no space that neither covered.
//!
//! The rule: repeatedly merge the adjacent pair with the highest Jaccard similarity of their
//! sets, `|A ∩ B| / |A ∪ B|`, while it is at least `min_similarity`; pairs whose union would
//! grow the larger set by more than `max_growth` are never merged.

use sightline_core::TriangleSet;

use crate::pvs_file::{CellPvs, PvsFile};
use crate::viewcell::ViewCell;

/// How far merging may go.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MergeOptions {
    /// The least Jaccard similarity of two sets that may merge (0 to 1; 1 merges only equal
    /// sets).
    pub min_similarity: f64,
    /// The most a merged set may exceed the larger of its two parts, as a fraction (0.1: 10 %).
    pub max_growth: f64,
}

/// What merging did.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MergeReport {
    /// Cells in the file given.
    pub cells_before: usize,
    /// Cells after merging.
    pub cells_after: usize,
    /// Mean PVS size (triangles) per cell before merging.
    pub mean_pvs_before: f64,
    /// Mean PVS size (triangles) per cell after merging.
    pub mean_pvs_after: f64,
    /// Cells that are not axis-aligned boxes, left as they are.
    pub not_axis_aligned: usize,
}

/// Why merging refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MergeError {
    /// The similarity threshold is not in 0..=1.
    #[error("--min-similarity {0} is outside 0..=1")]
    Similarity(f64),
    /// The growth limit is negative or not finite.
    #[error("--max-growth {0} must be a finite fraction of at least 0")]
    Growth(f64),
}

/// Relative tolerance of "the same plane" between box faces (cells from one grid share their
/// planes up to the rounding of `min + i * step`).
const PLANE_TOLERANCE: f32 = 1e-5;

/// An axis-aligned cell's `(min, max)`, or `None` for an oriented one.
fn aligned_box(c: &ViewCell) -> Option<([f32; 3], [f32; 3])> {
    let identity = [glam::Vec3::X, glam::Vec3::Y, glam::Vec3::Z];
    let aligned = c
        .axes
        .iter()
        .zip(identity)
        .all(|(a, e)| (*a - e).abs().max_element() <= 1e-6);
    aligned.then(|| {
        (
            (c.center - c.half_extents).to_array(),
            (c.center + c.half_extents).to_array(),
        )
    })
}

/// `a` and `b` are equal up to the plane tolerance, relative to `scale`.
fn same(a: f32, b: f32, scale: f32) -> bool {
    (a - b).abs() <= PLANE_TOLERANCE * scale.max(1.0)
}

/// The box of the union of two axis-aligned boxes when that union is exactly a box (they
/// share a whole face), else `None`.
fn union_box(a: ([f32; 3], [f32; 3]), b: ([f32; 3], [f32; 3])) -> Option<([f32; 3], [f32; 3])> {
    let scale = a.1.iter().chain(&b.1).fold(0.0f32, |m, v| m.max(v.abs()));
    for k in 0..3 {
        let touching = same(a.1[k], b.0[k], scale) || same(b.1[k], a.0[k], scale);
        let others_equal = (0..3)
            .filter(|&j| j != k)
            .all(|j| same(a.0[j], b.0[j], scale) && same(a.1[j], b.1[j], scale));
        if touching && others_equal {
            let lo = [0, 1, 2].map(|j| a.0[j].min(b.0[j]));
            let hi = [0, 1, 2].map(|j| a.1[j].max(b.1[j]));
            return Some((lo, hi));
        }
    }
    None
}

/// Jaccard similarity of two sets (1 for two empty sets) and the size of their union.
fn similarity(a: &TriangleSet, b: &TriangleSet) -> (f64, usize) {
    let both = a.intersection(b).count();
    let either = a.union(b).count();
    if either == 0 {
        (1.0, 0)
    } else {
        (both as f64 / either as f64, either)
    }
}

/// A cell being merged: its box (`None`: oriented, never merged), its set, and the original
/// cells it stands for.
struct Group {
    aabb: Option<([f32; 3], [f32; 3])>,
    cell: ViewCell,
    visible: TriangleSet,
    /// The union of the members' conservative bounds (the union of supersets is one).
    bound: Option<TriangleSet>,
    members: Vec<usize>,
}

/// The best adjacent pair to merge under `options`: `(i, j)` with `i < j`.
fn best_pair(groups: &[Group], options: &MergeOptions) -> Option<(usize, usize)> {
    let mut best: Option<(f64, usize, usize)> = None;
    for i in 0..groups.len() {
        let Some(a) = groups[i].aabb else { continue };
        for j in i + 1..groups.len() {
            let Some(b) = groups[j].aabb else { continue };
            if union_box(a, b).is_none() {
                continue;
            }
            let (s, union) = similarity(&groups[i].visible, &groups[j].visible);
            let larger = groups[i]
                .visible
                .count_ones(..)
                .max(groups[j].visible.count_ones(..));
            let grows = union as f64 > (1.0 + options.max_growth) * larger as f64;
            if s >= options.min_similarity && !grows && best.is_none_or(|(bs, _, _)| s > bs) {
                best = Some((s, i, j));
            }
        }
    }
    best.map(|(_, i, j)| (i, j))
}

/// `file` with neighbouring cells of similar PVS merged (see the module documentation). The
/// merged file lists, per cell, `metadata.cells[i].merged_from` (the original cell indices),
/// with `rays` and `seconds` summed and `converged` true only when every part converged; the
/// parts' convergence curves are dropped (they do not add up).
pub fn merge_similar_cells(
    file: &PvsFile,
    options: &MergeOptions,
) -> Result<(PvsFile, MergeReport), MergeError> {
    if !(0.0..=1.0).contains(&options.min_similarity) {
        return Err(MergeError::Similarity(options.min_similarity));
    }
    if !(options.max_growth >= 0.0 && options.max_growth.is_finite()) {
        return Err(MergeError::Growth(options.max_growth));
    }
    let mut groups: Vec<Group> = file
        .cells
        .iter()
        .enumerate()
        .map(|(i, c)| Group {
            aabb: aligned_box(&c.cell),
            cell: c.cell,
            visible: c.visible.clone(),
            bound: c.bound.clone(),
            members: vec![i],
        })
        .collect();
    let not_axis_aligned = groups.iter().filter(|g| g.aabb.is_none()).count();
    while let Some((i, j)) = best_pair(&groups, options) {
        let b = groups.swap_remove(j);
        let a = &mut groups[i];
        let (lo, hi) =
            union_box(a.aabb.expect("aligned"), b.aabb.expect("aligned")).expect("adjacent");
        a.aabb = Some((lo, hi));
        a.cell = ViewCell::aabb(lo.into(), hi.into()).expect("the union of two valid boxes");
        a.visible.union_with(&b.visible);
        if let (Some(bound), Some(other)) = (&mut a.bound, &b.bound) {
            bound.union_with(other);
        }
        a.members.extend(b.members);
    }
    // The original order of the first member of each group.
    for g in &mut groups {
        g.members.sort_unstable();
    }
    groups.sort_by_key(|g| g.members[0]);
    let mean = |sizes: &mut dyn Iterator<Item = usize>, n: usize| {
        sizes.sum::<usize>() as f64 / n.max(1) as f64
    };
    let report = MergeReport {
        cells_before: file.cells.len(),
        cells_after: groups.len(),
        mean_pvs_before: mean(
            &mut file.cells.iter().map(|c| c.visible.count_ones(..)),
            file.cells.len(),
        ),
        mean_pvs_after: mean(
            &mut groups.iter().map(|g| g.visible.count_ones(..)),
            groups.len(),
        ),
        not_axis_aligned,
    };
    let mut merged = PvsFile {
        scene_hash: file.scene_hash,
        triangle_count: file.triangle_count,
        objects: file.objects.clone(),
        metadata: merged_metadata(&file.metadata, &groups, options),
        cells: Vec::with_capacity(groups.len()),
    };
    for g in groups {
        merged.cells.push(CellPvs {
            cell: g.cell,
            visible: g.visible,
            bound: g.bound,
        });
    }
    Ok((merged, report))
}

/// The metadata of the merged file: the original's, with per-cell statistics combined and a
/// record of the merge.
fn merged_metadata(
    original: &serde_json::Value,
    groups: &[Group],
    options: &MergeOptions,
) -> serde_json::Value {
    let mut meta = original.clone();
    if !meta.is_object() {
        meta = serde_json::json!({});
    }
    let old_cells = original["cells"].as_array();
    let cells: Vec<serde_json::Value> = groups
        .iter()
        .map(|g| {
            let stats: Vec<&serde_json::Value> = g
                .members
                .iter()
                .filter_map(|&m| old_cells.and_then(|c| c.get(m)))
                .collect();
            let sum = |key: &str| {
                (stats.len() == g.members.len())
                    .then(|| stats.iter().map(|s| s[key].as_f64()).sum::<Option<f64>>())
                    .flatten()
            };
            let converged = (stats.len() == g.members.len())
                .then(|| {
                    stats
                        .iter()
                        .map(|s| s["converged"].as_bool())
                        .collect::<Option<Vec<_>>>()
                })
                .flatten()
                .map(|all| all.iter().all(|&c| c));
            serde_json::json!({
                "merged_from": g.members,
                "rays": sum("rays").map(|r| r as u64),
                "seconds": sum("seconds"),
                "converged": converged,
            })
        })
        .collect();
    meta["cells"] = serde_json::Value::Array(cells);
    meta["merged"] = serde_json::json!({
        "min_similarity": options.min_similarity,
        "max_growth": options.max_growth,
        "cells_before": groups.iter().map(|g| g.members.len()).sum::<usize>(),
    });
    meta
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn set(n: usize, ids: &[usize]) -> TriangleSet {
        let mut s = TriangleSet::with_capacity(n);
        for &i in ids {
            s.insert(i);
        }
        s
    }

    /// Four cells in a row along x (unit boxes), then one above the first.
    fn file(sets: [&[usize]; 5]) -> PvsFile {
        let boxes = [
            (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 1.0)),
            (Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 1.0, 1.0)),
            (Vec3::new(2.0, 0.0, 0.0), Vec3::new(3.0, 1.0, 1.0)),
            (Vec3::new(3.0, 0.0, 0.0), Vec3::new(4.0, 1.0, 1.0)),
            (Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 1.0, 2.0)),
        ];
        PvsFile {
            scene_hash: 7,
            triangle_count: 100,
            objects: None,
            metadata: serde_json::json!({
                "method": "gvs++",
                "cells": (0..5).map(|i| serde_json::json!(
                    {"rays": 10 * (i + 1), "seconds": 1.0, "converged": i != 1}
                )).collect::<Vec<_>>(),
            }),
            cells: boxes
                .iter()
                .zip(sets)
                .map(|(&(lo, hi), ids)| CellPvs {
                    cell: ViewCell::aabb(lo, hi).unwrap(),
                    visible: set(100, ids),
                    bound: None,
                })
                .collect(),
        }
    }

    #[test]
    fn similar_neighbours_merge_into_their_union_box_with_the_union_set() {
        let f = file([
            &[1, 2, 3, 4],
            &[1, 2, 3, 4, 5],
            &[50, 51],
            &[50, 51],
            &[1, 2, 3, 4, 90, 91, 92],
        ]);
        let options = MergeOptions {
            min_similarity: 0.75,
            max_growth: 0.5,
        };
        let (m, report) = merge_similar_cells(&f, &options).unwrap();
        // 2+3 (similarity 1.0), then 0+1 (0.8) merge; 4 above 0 is too different (4/7), and
        // once 0 and 1 merged their box no longer shares a whole face with it.
        assert_eq!((report.cells_before, report.cells_after), (5, 3));
        let members: Vec<Vec<u64>> = m.metadata["cells"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| {
                c["merged_from"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_u64().unwrap())
                    .collect()
            })
            .collect();
        assert_eq!(members, vec![vec![0, 1], vec![2, 3], vec![4]]);
        // The merged box is the union, the set the union of the sets.
        let c = &m.cells[0];
        assert_eq!(
            c.cell,
            ViewCell::aabb(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0)).unwrap()
        );
        assert_eq!(c.visible, set(100, &[1, 2, 3, 4, 5]));
        // Statistics: rays and seconds summed, converged only if every part did.
        let stats = &m.metadata["cells"][0];
        assert_eq!(stats["rays"], 30);
        assert_eq!(stats["seconds"], 2.0);
        assert_eq!(stats["converged"], false);
        assert_eq!(m.metadata["cells"][1]["converged"], true);
        assert_eq!(m.metadata["merged"]["cells_before"], 5);
        assert_eq!(m.metadata["method"], "gvs++");
        // Every point of the old cells lies in a new cell whose set holds the old cell's set.
        for (i, old) in f.cells.iter().enumerate() {
            let p = old.cell.center;
            let new = m.cells.iter().find(|c| c.cell.contains(p)).unwrap();
            assert!(old.visible.is_subset(&new.visible), "cell {i}");
        }
    }

    #[test]
    fn dissimilar_growing_or_non_adjacent_cells_stay() {
        let f = file([&[1, 2], &[3, 4], &[1, 2], &[5], &[9]]);
        let strict = MergeOptions {
            min_similarity: 0.9,
            max_growth: 1.0,
        };
        let (m, r) = merge_similar_cells(&f, &strict).unwrap();
        assert_eq!(r.cells_after, 5);
        assert_eq!(m.cells.len(), 5);
        // Equal sets two cells apart (0 and 2) do not merge across cell 1.
        let loose = MergeOptions {
            min_similarity: 0.0,
            max_growth: 0.0,
        };
        let (_, r) = merge_similar_cells(&f, &loose).unwrap();
        assert_eq!(r.cells_after, 5, "any merge here grows a set");
        let all = MergeOptions {
            min_similarity: 0.0,
            max_growth: 10.0,
        };
        let (m, r) = merge_similar_cells(&f, &all).unwrap();
        assert!(r.cells_after < 5 && r.mean_pvs_after >= r.mean_pvs_before);
        assert!(m.cells.iter().all(|c| c.visible.count_ones(..) > 0));
    }

    #[test]
    fn bad_options_are_errors() {
        let f = file([&[1], &[1], &[1], &[1], &[1]]);
        let bad = |s, g| {
            merge_similar_cells(
                &f,
                &MergeOptions {
                    min_similarity: s,
                    max_growth: g,
                },
            )
        };
        assert_eq!(bad(1.5, 0.1).unwrap_err(), MergeError::Similarity(1.5));
        assert_eq!(bad(0.5, -1.0).unwrap_err(), MergeError::Growth(-1.0));
        assert!(matches!(bad(f64::NAN, 0.1), Err(MergeError::Similarity(_))));
        assert!(matches!(
            bad(0.5, f64::INFINITY),
            Err(MergeError::Growth(_))
        ));
    }
}
