//! Planning an incremental rebake against an old bake: the checks that the old file may serve
//! as the source of unchanged cells, then the plan of [`crate::incremental`] and the cells it
//! keeps. What `pvs bake --since OLD.pvs --old-scene OLD` runs, without any argument parsing,
//! so every front end (CLI, Python) refuses the same files with the same messages.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use sightline_core::trace::Bvh;
use sightline_core::Scene;

use crate::bake::BakedCell;
use crate::checkpoint::fingerprint_differences_in;
use crate::incremental;
use crate::pvs_file::{PvsError, PvsFile};

/// The fingerprint keys an incremental rebake must share with the old bake: everything but
/// the scene (`scene_hash`, `triangles`), which the edit changes by definition.
pub const SHARED_FINGERPRINT_KEYS: [&str; 7] = [
    "method",
    "parameters",
    "seed",
    "budget",
    "cell_count",
    "cells_hash",
    "extra",
];

/// Rays per cell and added box of the probe (rule (c) of [`crate::incremental`]) unless the
/// caller says otherwise: the default of `pvs bake --probe-rays` and of Python's `bake`.
pub const DEFAULT_PROBE_RAYS: usize = 16384;

/// The old bake an incremental rebake starts from.
#[derive(Clone, Copy)]
pub struct OldBake<'a> {
    /// Where `file` was read from (named in errors).
    pub path: &'a Path,
    /// The old `.pvs` file, complete (not a shard).
    pub file: &'a PvsFile,
    /// The scene `file` was baked for (before the edit).
    pub scene: &'a Scene,
}

/// Why an old bake cannot serve an incremental rebake.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IncrementalBakeError {
    /// The old file indexes another scene than the old one given.
    #[error("{path} and the old scene")]
    OldSceneMismatch {
        /// The old file.
        path: PathBuf,
        /// The mismatch ([`PvsError::SceneMismatch`]).
        source: PvsError,
    },
    /// The old file records no fingerprint, so nothing says how it was baked.
    #[error("{0} has no bake fingerprint (baked by an older sightline); rebake it fully")]
    NoFingerprint(PathBuf),
    /// The old file is one shard of a bake.
    #[error("{0} holds only some cells (a shard); merge the shards first")]
    Shard(PathBuf),
    /// The old file was baked with other cells, method, parameters, seed or budget.
    #[error(
        "{path} was baked differently (it differs in: {differences}); --since needs the same \
         cells, method, parameters, seed and budget (with --grid, pass the same --bounds: the \
         default is the scene bounds, which an edit can change)"
    )]
    DifferentBake {
        /// The old file.
        path: PathBuf,
        /// The differing fingerprint keys with both values.
        differences: String,
    },
    /// The old file holds another number of cells than the new bake.
    #[error("{path} has {old} cells, this bake {new}")]
    CellCount {
        /// The old file.
        path: PathBuf,
        /// Cells in the old file.
        old: usize,
        /// Cells of the new bake.
        new: usize,
    },
}

/// A planned incremental rebake: the cells that need no rebake, and what the planner found.
#[derive(Clone, Debug)]
pub struct IncrementalBake {
    /// The old file's cells whose sets the edit cannot change, remapped to the new scene's
    /// triangle ids, by cell index ([`incremental::RebakePlan::kept_cells`]).
    pub kept: BTreeMap<usize, BakedCell>,
    /// [`Scene::geometry_hash`] of the old scene (part of a checkpoint's run key).
    pub old_scene_hash: u64,
    /// Old triangles without a match in the new scene.
    pub removed: usize,
    /// New triangles without a match in the old scene.
    pub added: usize,
    /// Boxes the added triangles are grouped into.
    pub boxes: usize,
}

impl IncrementalBake {
    /// The `incremental` entry of the rebaked file's metadata: the old file (`since`: its
    /// path, `null` when it has none) and scene as the caller named them, the triangles
    /// removed and added, the boxes they form, and how many of the file's cells were kept and
    /// rebaked.
    pub fn metadata(
        &self,
        since: Option<&Path>,
        old_scene: &str,
        kept_cells: usize,
        rebaked_cells: usize,
    ) -> serde_json::Value {
        serde_json::json!({
            "since": since.map(|p| p.display().to_string()),
            "old_scene": old_scene,
            "removed_triangles": self.removed,
            "added_triangles": self.added,
            "added_boxes": self.boxes,
            "kept_cells": kept_cells,
            "rebaked_cells": rebaked_cells,
        })
    }
}

/// Checks that `old` may seed a bake of `new` with fingerprint `fingerprint` and `cell_count`
/// cells, and plans it: rules (a) and (b) of [`crate::incremental`], plus the probe (c) with
/// `probe_rays` rays per cell and added box when `probe_rays > 0`.
pub fn plan_incremental_bake(
    old: &OldBake<'_>,
    new: &Scene,
    fingerprint: &serde_json::Value,
    cell_count: usize,
    probe_rays: usize,
) -> Result<IncrementalBake, IncrementalBakeError> {
    check_old_bake(old, fingerprint, cell_count)?;
    let plan = if probe_rays > 0 {
        let old_bvh = Bvh::build(old.scene);
        incremental::plan_with_probe(old.scene, new, old.file, &old_bvh, probe_rays)
    } else {
        incremental::plan(old.scene, new, old.file)
    };
    Ok(IncrementalBake {
        kept: plan.kept_cells(old.file, new.triangle_count()),
        old_scene_hash: old.scene.geometry_hash(),
        removed: plan.matching.removed.len(),
        added: plan.matching.added.len(),
        boxes: plan.boxes.len(),
    })
}

/// The refusals of [`plan_incremental_bake`], cheapest first, before any planning work.
fn check_old_bake(
    old: &OldBake<'_>,
    fingerprint: &serde_json::Value,
    cell_count: usize,
) -> Result<(), IncrementalBakeError> {
    let path = || old.path.to_path_buf();
    old.file
        .check_scene(old.scene)
        .map_err(|source| IncrementalBakeError::OldSceneMismatch {
            path: path(),
            source,
        })?;
    let Some(old_fp) = old.file.metadata.get("fingerprint") else {
        return Err(IncrementalBakeError::NoFingerprint(path()));
    };
    // A shard's kept cells would leave the others unbaked, and its indices are not the bake's.
    if old.file.metadata.get("cell_indices").is_some() {
        return Err(IncrementalBakeError::Shard(path()));
    }
    let differences = fingerprint_differences_in(old_fp, fingerprint, &SHARED_FINGERPRINT_KEYS);
    if !differences.is_empty() {
        return Err(IncrementalBakeError::DifferentBake {
            path: path(),
            differences,
        });
    }
    if old.file.cells.len() != cell_count {
        return Err(IncrementalBakeError::CellCount {
            path: path(),
            old: old.file.cells.len(),
            new: cell_count,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use serde_json::json;
    use sightline_core::scene::SceneBuilder;
    use sightline_core::TriangleSet;

    use super::*;
    use crate::checkpoint::fingerprint_of;
    use crate::pvs_file::CellPvs;
    use crate::sampler::Budget;
    use crate::viewcell::ViewCell;

    fn boxes(n: usize) -> Scene {
        let mut b = SceneBuilder::new("boxes");
        for i in 0..n {
            let x = 3.0 * i as f32;
            b.add_box(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 1.0, 1.0));
        }
        b.finish()
    }

    fn cells(n: u32) -> Vec<ViewCell> {
        ViewCell::grid(
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(8.0, 4.0, 1.0),
            [n, 1, 1],
        )
        .unwrap()
    }

    fn fp(scene: &Scene, cells: &[ViewCell], seed: u64) -> serde_json::Value {
        let budget = Budget::rays(1000);
        fingerprint_of(scene, cells, "rand", "p", seed, &budget, json!(null))
    }

    /// An old bake of `scene` in which every cell sees every triangle.
    fn old_file(scene: &Scene, cells: &[ViewCell], metadata: serde_json::Value) -> PvsFile {
        let mut all = TriangleSet::with_capacity(scene.triangle_count());
        all.insert_range(..);
        let mut f = PvsFile::for_scene(scene, metadata);
        f.cells = cells
            .iter()
            .map(|&cell| CellPvs::new(cell, all.clone()))
            .collect();
        f
    }

    fn plan(
        file: &PvsFile,
        old: &Scene,
        new: &Scene,
        fingerprint: &serde_json::Value,
        cell_count: usize,
    ) -> Result<IncrementalBake, IncrementalBakeError> {
        let old = OldBake {
            path: Path::new("old.pvs"),
            file,
            scene: old,
        };
        plan_incremental_bake(&old, new, fingerprint, cell_count, 0)
    }

    #[test]
    fn a_matching_old_bake_is_planned() {
        let (old, new, cells) = (boxes(2), boxes(2), cells(2));
        let file = old_file(&old, &cells, json!({"fingerprint": fp(&old, &cells, 1)}));
        // Scene hash and triangle count differ by design; they are not compared.
        let p = plan(&file, &old, &new, &fp(&boxes(3), &cells, 1), 2).unwrap();
        assert_eq!((p.removed, p.added, p.boxes), (0, 0, 0));
        assert_eq!(p.kept.len(), 2);
        assert_eq!(p.old_scene_hash, old.geometry_hash());
    }

    #[test]
    fn the_metadata_names_the_old_bake_and_the_counts() {
        let (old, cells) = (boxes(2), cells(2));
        let file = old_file(&old, &cells, json!({"fingerprint": fp(&old, &cells, 1)}));
        let p = plan(&file, &old, &old, &fp(&old, &cells, 1), 2).unwrap();
        let m = p.metadata(Some(Path::new("old.pvs")), "old.obj", 2, 0);
        assert_eq!(m["since"], "old.pvs");
        assert_eq!(m["old_scene"], "old.obj");
        assert_eq!(
            (m["kept_cells"].as_u64(), m["rebaked_cells"].as_u64()),
            (Some(2), Some(0))
        );
        assert_eq!(m["added_boxes"], 0);
        assert!(p.metadata(None, "x", 0, 2)["since"].is_null());
    }

    #[test]
    fn another_bake_is_refused_naming_the_keys() {
        let (old, cells) = (boxes(2), cells(2));
        let file = old_file(&old, &cells, json!({"fingerprint": fp(&old, &cells, 1)}));
        let mut other = fp(&old, &cells, 9);
        other["parameters"] = json!("q");
        let e = plan(&file, &old, &old, &other, 2).unwrap_err();
        assert!(
            matches!(e, IncrementalBakeError::DifferentBake { .. }),
            "{e}"
        );
        let text = e.to_string();
        assert!(
            text.contains(r#"differs in: parameters "p" vs "q", seed 1 vs 9)"#),
            "{text}"
        );
        assert!(
            text.starts_with("old.pvs ") && text.contains("--bounds"),
            "{text}"
        );
    }

    #[test]
    fn shards_wrong_scenes_unfingerprinted_files_and_other_cell_counts_are_refused() {
        let (old, cells) = (boxes(2), cells(2));
        let fingerprint = fp(&old, &cells, 1);
        let shard = old_file(
            &old,
            &cells,
            json!({"fingerprint": fingerprint, "cell_indices": [0, 1]}),
        );
        let e = plan(&shard, &old, &old, &fingerprint, 2).unwrap_err();
        assert!(matches!(e, IncrementalBakeError::Shard(_)), "{e}");
        assert!(e.to_string().contains("merge the shards first"), "{e}");

        let bare = old_file(&old, &cells, json!({}));
        let e = plan(&bare, &old, &old, &fingerprint, 2).unwrap_err();
        assert!(matches!(e, IncrementalBakeError::NoFingerprint(_)), "{e}");

        let file = old_file(&old, &cells, json!({"fingerprint": fingerprint}));
        let e = plan(&file, &boxes(3), &old, &fingerprint, 2).unwrap_err();
        assert!(
            matches!(e, IncrementalBakeError::OldSceneMismatch { .. }),
            "{e}"
        );

        // The fingerprint agrees (cell_count included), yet the file holds fewer cells.
        let mut short = file.clone();
        short.cells.pop();
        let e = plan(&short, &old, &old, &fingerprint, 2).unwrap_err();
        assert!(
            matches!(e, IncrementalBakeError::CellCount { old: 1, new: 2, .. }),
            "{e}"
        );
        assert_eq!(e.to_string(), "old.pvs has 1 cells, this bake 2");
    }
}
