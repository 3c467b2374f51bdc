//! Two-sided bakes: every cell of a baked file gets a conservative bound beside its sampled set
//! (`pvs bake --bound`, `pvs bound`), so a file carries "surely visible ⊆ set ⊆ bound" and the
//! gap, bound minus set, says per cell how many triangles the sampled set might be missing.
//!
//! The bound comes from any sampler whose sets contain every triangle visible from the cell
//! (the front ends pass RV's from-region method, `sightline_point::rv::ConservativeSampler`;
//! this crate cannot name it). The file's set is always kept inside the bound: the bound stored
//! is the union of the two, and a set triangle the conservative method left out is counted
//! (`not_in_conservative`, 0 unless the conservative method is wrong or the two disagree on a
//! triangle at the edge of floating-point precision), never dropped.
//!
//! Memory: one decoded bound per cell of the file (`n/8` bytes per cell at most), plus what
//! the conservative sampler needs per cell under way (one per worker thread).

use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;
use serde_json::json;
use sightline_core::trace::RayCaster;
use sightline_core::{Scene, TriangleSet};

use crate::pvs_file::{PvsError, PvsFile};
use crate::sampler::{Budget, CellContext, Sampler};

/// What adding bounds found, per cell and in total.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct BoundSummary {
    /// The sampler that gave the bounds.
    pub method: String,
    /// Seconds spent.
    pub seconds: f64,
    /// Per cell, in file order.
    pub cells: Vec<CellBound>,
}

/// One cell's two sides.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct CellBound {
    /// Triangles in the cell's (sampled) set.
    pub set_size: usize,
    /// Triangles in its bound.
    pub bound_size: usize,
    /// Triangles in the bound and not in the set: those the set might be missing.
    pub gap: usize,
    /// Triangles of the set the conservative method left out (kept in the bound all the
    /// same). Anything but 0 means the conservative method missed a visible triangle.
    pub not_in_conservative: usize,
}

/// A two-sided file's bounds in total: the file's `metadata.bound`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct BoundTotals {
    /// The sampler that gave the bounds.
    pub method: String,
    /// Seconds spent.
    pub seconds: f64,
    /// Bound triangles over set triangles, summed over the cells.
    pub mean_ratio: f64,
    /// Cells whose set the conservative method did not contain.
    pub cells_not_contained: usize,
}

impl BoundSummary {
    /// The totals the file's metadata keeps.
    pub fn totals(&self) -> BoundTotals {
        BoundTotals {
            method: self.method.clone(),
            seconds: self.seconds,
            mean_ratio: self.mean_ratio(),
            cells_not_contained: self.cells_not_contained(),
        }
    }

    /// Mean bound size over mean set size (1 when the sets are empty).
    pub fn mean_ratio(&self) -> f64 {
        let set: usize = self.cells.iter().map(|c| c.set_size).sum();
        let bound: usize = self.cells.iter().map(|c| c.bound_size).sum();
        if set == 0 {
            1.0
        } else {
            bound as f64 / set as f64
        }
    }

    /// Cells whose set the conservative method did not contain.
    pub fn cells_not_contained(&self) -> usize {
        self.cells
            .iter()
            .filter(|c| c.not_in_conservative > 0)
            .count()
    }
}

/// Gives every cell of `file` (made for `scene`) its conservative bound from
/// `conservative`, cells in parallel; `on_cell(done)` is called after each. The file's
/// metadata gets `bound` (the method and its time) and each `cells[i]` its [`CellBound`]
/// (`bound_size`, `gap`, `not_in_conservative`). An existing bound is replaced.
///
/// # Errors
/// [`PvsError::SceneMismatch`] when the file was made for another scene.
pub fn add_bounds(
    scene: &Scene,
    caster: &dyn RayCaster,
    file: &mut PvsFile,
    conservative: &dyn Sampler,
    on_cell: &(dyn Fn(usize) + Sync),
) -> Result<BoundSummary, PvsError> {
    file.check_scene(scene)?;
    let start = Instant::now();
    let done = Mutex::new(0usize);
    let bounds: Vec<(TriangleSet, CellBound)> = file
        .cells
        .par_iter()
        .with_max_len(1)
        .map(|c| {
            let ctx = CellContext {
                scene,
                caster,
                cell: &c.cell,
                seed: 0,
                free_space: None,
            };
            let superset = conservative
                .sample(&ctx, &Budget::default(), &|_| {})
                .visible;
            let cell = two_sides(&c.visible, superset);
            let mut d = done.lock().unwrap_or_else(|e| e.into_inner());
            *d += 1;
            on_cell(*d);
            cell
        })
        .collect();
    let mut summary = BoundSummary {
        method: conservative.name().to_string(),
        seconds: 0.0,
        cells: Vec::with_capacity(bounds.len()),
    };
    let stats = file
        .metadata
        .get_mut("cells")
        .and_then(|c| c.as_array_mut());
    let mut stats = stats.map(|s| s.iter_mut()).into_iter().flatten();
    for (c, (bound, counts)) in file.cells.iter_mut().zip(bounds) {
        c.bound = Some(bound);
        if let Some(s) = stats.next().and_then(|s| s.as_object_mut()) {
            s.insert("bound_size".into(), json!(counts.bound_size));
            s.insert("gap".into(), json!(counts.gap));
            s.insert(
                "not_in_conservative".into(),
                json!(counts.not_in_conservative),
            );
        }
        summary.cells.push(counts);
    }
    summary.seconds = start.elapsed().as_secs_f64();
    if let Some(m) = file.metadata.as_object_mut() {
        m.insert("bound".into(), json!(summary.totals()));
    }
    Ok(summary)
}

/// The stored bound (the conservative set with the sampled set added) and the counts.
fn two_sides(set: &TriangleSet, mut superset: TriangleSet) -> (TriangleSet, CellBound) {
    superset.grow(set.len());
    let not_in_conservative = set.difference(&superset).count();
    superset.union_with(set);
    let bound_size = superset.count_ones(..);
    let set_size = set.count_ones(..);
    let counts = CellBound {
        set_size,
        bound_size,
        gap: bound_size - set_size,
        not_in_conservative,
    };
    (superset, counts)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(ids: &[usize]) -> TriangleSet {
        let mut s = TriangleSet::with_capacity(10);
        ids.iter().for_each(|&i| s.insert(i));
        s
    }

    #[test]
    fn the_bound_holds_the_set_and_counts_what_the_superset_missed() {
        let (bound, c) = two_sides(&set(&[1, 2]), set(&[2, 3, 4]));
        assert_eq!(bound, set(&[1, 2, 3, 4]));
        assert_eq!(
            c,
            CellBound {
                set_size: 2,
                bound_size: 4,
                gap: 2,
                not_in_conservative: 1
            }
        );
        let (_, c) = two_sides(&set(&[]), set(&[]));
        assert_eq!((c.gap, c.not_in_conservative), (0, 0));
    }
}
