//! What a shared bake takes and gives: its parameters, its progress reports and its result.

use serde::Serialize;
use serde_json::json;
use sightline_core::Scene;

use crate::gvspp::GvsPlusPlusParams;
use crate::pvs_file::{CellPvs, PvsFile};
use crate::sampler::{Budget, CellResult};
use crate::viewcell::ViewCell;

/// Parameters of a shared bake.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShareParams {
    /// The per-cell GVS++ parameters (`n_rand` is the random rays per cell and round, with
    /// `fixed_rounds`; otherwise cells are scheduled by yield).
    pub gvspp: GvsPlusPlusParams,
    /// Also cast every random ray backward from its origin, doubling the free segment it yields
    /// for two casts (the backward cast is counted in the rays). Guided rays (ABS, RS) are cast
    /// forward only: their backward half would be an untargeted ray at the price of a targeted
    /// one.
    pub backward: bool,
    /// Triangles a cell receives from other cells' rays enter its exploration queue (ABS and RS
    /// around them, from the crossing point); when false they only enter its PVS, and the cell
    /// explores exactly the triangles its own rays hit, as an independent GVS++ bake would.
    pub explore_shared: bool,
}

impl Default for ShareParams {
    fn default() -> Self {
        Self {
            gvspp: GvsPlusPlusParams::default(),
            backward: true,
            explore_shared: false,
        }
    }
}

/// Running totals of a shared bake, reported after every batch.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SharedProgress {
    /// Round (random phase + exploration) in progress, from 0; by yield, the step (one batch
    /// per cell).
    pub round: usize,
    /// Rays cast so far by all cells.
    pub rays: u64,
    /// Seconds so far.
    pub seconds: f64,
    /// Cells still random sampling.
    pub sampling_cells: usize,
    /// Sum of the PVS sizes of all cells.
    pub total_pvs: usize,
}

/// What a shared bake found.
#[derive(Clone, Debug, PartialEq)]
pub struct SharedBake {
    /// One result per cell, in cell order. `rays` are the rays the cell cast itself; `seconds`
    /// is the bake's wall-clock time divided by the number of cells (cells are baked together);
    /// `found_by` has "random", "abs", "rs" (the cell's own rays) and "shared" (other cells').
    pub cells: Vec<CellResult>,
    /// Rays cast by all cells (forward and backward).
    pub total_rays: u64,
    /// Wall-clock seconds of the whole bake.
    pub seconds: f64,
    /// Triangles a cell received from another cell's ray.
    pub shared_insertions: u64,
}

impl SharedBake {
    /// The `.pvs` file of this bake of `cells` (the same cells, in the same order) in `scene`,
    /// with `extra_metadata` merged into the metadata.
    pub fn to_pvs_file(
        &self,
        scene: &Scene,
        cells: &[ViewCell],
        params: &ShareParams,
        budget: &Budget,
        seed: u64,
        extra_metadata: serde_json::Value,
    ) -> PvsFile {
        let mut file = PvsFile::for_scene(scene, serde_json::Value::Null);
        file.cells = cells
            .iter()
            .zip(&self.cells)
            .map(|(cell, r)| CellPvs::new(*cell, r.visible.clone()))
            .collect();
        let stats: Vec<serde_json::Value> = self
            .cells
            .iter()
            .map(|r| {
                json!({
                    "rays": r.rays,
                    "pvs_size": r.visible.count_ones(..),
                    "found_by": r.found_by.iter().map(|(k, v)| json!([k, v])).collect::<Vec<_>>(),
                    "converged": r.converged,
                })
            })
            .collect();
        let mut metadata = json!({
            "tool": format!("sightline {}", env!("CARGO_PKG_VERSION")),
            "scene": scene.source,
            "method": "gvs++ shared",
            "share_params": params,
            "seed": seed,
            "budget": budget,
            "total_rays": self.total_rays,
            "seconds": self.seconds,
            "shared_insertions": self.shared_insertions,
            "cells": stats,
        });
        if let (Some(m), serde_json::Value::Object(extra)) =
            (metadata.as_object_mut(), extra_metadata)
        {
            m.extend(extra);
        }
        file.metadata = metadata;
        file
    }
}
