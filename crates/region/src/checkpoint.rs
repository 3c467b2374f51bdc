//! Resumable bakes of many cells: the bake fingerprint, the checkpoint file beside the output,
//! and the driver that resumes from it and writes the final `.pvs` atomically.
//!
//! The checkpoint is itself a `.pvs` file (`OUTPUT.checkpoint`) holding the finished cells, with
//! metadata `{"checkpoint": 1, "key": .., "cell_indices": [..], "cells": [stats..]}`; it is
//! rewritten atomically (temp + rename) after finished cells, at most every
//! [`ResumableBake::checkpoint_interval`] and at the end, so a killed bake loses at most that
//! much work and never leaves a half-written file. A checkpoint whose key (the fingerprint of
//! everything that determines the result, plus which cells this run produces) differs from the
//! current bake's is refused rather than mixed in.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use serde_json::json;
use sightline_core::Scene;

use crate::bake::{bake_cells, bake_metadata, BakeSetup, BakedCell};
use crate::pvs_file::{save_encoded, CellPvs, EncodedPvsFile, ObjectTable, PvsError, PvsFile};
use crate::sampler::{Budget, CellResult, ConvergencePoint};
use crate::viewcell::ViewCell;

/// Why a resumable bake failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BakeError {
    /// Reading or writing the checkpoint or output failed.
    #[error(transparent)]
    Pvs(#[from] PvsError),
    /// The checkpoint was written by a different bake.
    #[error(
        "{path} is the checkpoint of a different bake (it differs in: {differences}); \
         rerun with --restart to discard it, or choose another output"
    )]
    CheckpointMismatch {
        /// The checkpoint file.
        path: PathBuf,
        /// The differing fingerprint keys.
        differences: String,
    },
    /// The checkpoint file exists but cannot be read (truncated, damaged, not a .pvs).
    #[error(
        "the checkpoint {path} cannot be read ({source}); rerun with --restart to discard it \
         and bake from the start"
    )]
    CorruptCheckpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// What the reader found.
        source: PvsError,
    },
    /// The checkpoint is not one (e.g. a user's file at that path).
    #[error(
        "{path} is not a bake checkpoint: {what}; rerun with --restart to discard it, or \
         choose another output"
    )]
    NotACheckpoint {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

/// 64-bit FNV-1a, for fingerprints (stable across platforms and runs).
pub(crate) fn fnv(bytes: impl IntoIterator<Item = u8>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Hash of a cell list (the bit patterns of every cell's centre, axes and half extents).
pub fn cells_hash(cells: &[ViewCell]) -> u64 {
    fnv(cells.iter().flat_map(|c| {
        [c.center, c.axes[0], c.axes[1], c.axes[2], c.half_extents]
            .into_iter()
            .flat_map(|v| v.to_array())
            .flat_map(|f| f.to_bits().to_le_bytes())
    }))
}

/// The fingerprint of a bake: everything that determines its result. Two bakes with equal
/// fingerprints give identical sets for every cell (for a ray budget; a time budget is recorded
/// but its results vary). `extra` holds anything else the caller's cells depend on (e.g. the
/// Quake 3 cluster of each cell). Stored as `metadata.fingerprint` in every file of a bake.
pub fn fingerprint(
    setup: &BakeSetup<'_>,
    parameters: &str,
    extra: serde_json::Value,
) -> serde_json::Value {
    fingerprint_of(
        setup.scene,
        setup.cells,
        setup.sampler.name(),
        parameters,
        setup.seed,
        &setup.budget,
        extra,
    )
}

/// [`fingerprint`] from its parts, for drivers that bake elsewhere and have no ray caster
/// (the Ray driver of the Python bindings): the same value for the same bake.
pub fn fingerprint_of(
    scene: &Scene,
    cells: &[ViewCell],
    method: &str,
    parameters: &str,
    seed: u64,
    budget: &Budget,
    extra: serde_json::Value,
) -> serde_json::Value {
    json!({
        "scene_hash": format!("{:016x}", scene.geometry_hash()),
        "triangles": scene.triangle_count(),
        "method": method,
        "parameters": parameters,
        "seed": seed,
        "budget": budget,
        "cell_count": cells.len(),
        "cells_hash": format!("{:016x}", cells_hash(cells)),
        "extra": extra,
    })
}

/// The key a checkpoint must carry to be resumed (`metadata.key`): the bake's `fingerprint`,
/// a hash of the global `indices` of the cells the run produces, and `run_key` (see
/// [`ResumableBake::run_key`]).
pub fn checkpoint_key(
    fingerprint: &serde_json::Value,
    indices: &[usize],
    run_key: &serde_json::Value,
) -> serde_json::Value {
    json!({
        "fingerprint": fingerprint,
        "indices_hash": format!("{:016x}", fnv(indices.iter().flat_map(|i| (*i as u64).to_le_bytes()))),
        "run": run_key,
    })
}

/// The top-level keys in which two fingerprints differ, comma-separated.
pub fn fingerprint_differences(a: &serde_json::Value, b: &serde_json::Value) -> String {
    let mut keys: Vec<&str> = [a, b]
        .into_iter()
        .filter_map(serde_json::Value::as_object)
        .flat_map(|m| m.keys().map(String::as_str))
        .collect();
    keys.sort_unstable();
    keys.dedup();
    let d = fingerprint_differences_in(a, b, &keys);
    if d.is_empty() && a != b {
        return "(whole fingerprint)".into();
    }
    d
}

/// [`fingerprint_differences`] over `keys` only, in that order: for fingerprints that differ
/// elsewhere by design (an incremental rebake's scene). Each entry is `key A vs B`.
pub fn fingerprint_differences_in(
    a: &serde_json::Value,
    b: &serde_json::Value,
    keys: &[&str],
) -> String {
    let show = |v: Option<&serde_json::Value>| {
        v.map_or("(none)".to_string(), |v| {
            let s = v.to_string();
            // By characters: a byte index could fall inside a multi-byte one (a scene name or
            // parameter in any script) and panic.
            match s.char_indices().nth(40) {
                Some((end, _)) => format!("{}..", &s[..end]),
                None => s,
            }
        })
    };
    // `Value::get` is `None` for a value that is not an object (a damaged fingerprint).
    let d: Vec<String> = keys
        .iter()
        .filter(|k| a.get(**k) != b.get(**k))
        .map(|k| format!("{k} {} vs {}", show(a.get(*k)), show(b.get(*k))))
        .collect();
    d.join(", ")
}

/// The checkpoint file of output `output`: `output` with `.checkpoint` appended.
pub fn checkpoint_path(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".checkpoint");
    PathBuf::from(s)
}

/// A bake of some cells of a cell list that resumes from and keeps a checkpoint.
pub struct ResumableBake<'a> {
    /// What is baked.
    pub setup: BakeSetup<'a>,
    /// Global indices of the cells this run's file holds (all cells, or a shard), ascending.
    pub indices: Vec<usize>,
    /// Cells known without baking (an incremental rebake's unchanged cells).
    pub kept: BTreeMap<usize, BakedCell>,
    /// The bake's fingerprint ([`fingerprint`]).
    pub fingerprint: serde_json::Value,
    /// Anything else the checkpoint must match (shard, incremental source), beside the
    /// fingerprint and `indices`.
    pub run_key: serde_json::Value,
    /// The checkpoint file; `None`: none is read or written.
    pub checkpoint: Option<PathBuf>,
    /// Discard an existing checkpoint instead of resuming from it.
    pub restart: bool,
    /// Least time between checkpoint writes (the first finished cell and the end are always
    /// written).
    pub checkpoint_interval: Duration,
    /// Stop starting new cells after this many (simulates an interrupted bake).
    pub max_new_cells: Option<usize>,
}

/// The outcome of [`ResumableBake::run`].
pub struct BakeProgress {
    /// Finished cells by global index (those of `indices` that are done).
    pub done: BTreeMap<usize, BakedCell>,
    /// Cells loaded from the checkpoint.
    pub resumed: usize,
    /// Cells baked by this run.
    pub baked: usize,
    /// True when every cell of `indices` is done.
    pub complete: bool,
    /// Seconds this run took.
    pub seconds: f64,
}

impl BakeProgress {
    /// Bytes the finished cells take in memory ([`BakedCell::memory_bytes`]).
    pub fn memory_bytes(&self) -> usize {
        self.done.values().map(BakedCell::memory_bytes).sum()
    }

    /// Bytes of the finished cells' encoded sets alone.
    pub fn set_bytes(&self) -> usize {
        self.done.values().map(|c| c.set.payload_bytes()).sum()
    }
}

impl<'a> ResumableBake<'a> {
    /// A bake of every cell of `setup` in memory: nothing kept, no checkpoint, no limit (set
    /// the other fields with struct update syntax for shards, resumes and rebakes).
    pub fn new(setup: BakeSetup<'a>, fingerprint: serde_json::Value) -> Self {
        Self {
            indices: (0..setup.cells.len()).collect(),
            setup,
            kept: BTreeMap::new(),
            fingerprint,
            run_key: serde_json::Value::Null,
            checkpoint: None,
            restart: false,
            checkpoint_interval: Duration::ZERO,
            max_new_cells: None,
        }
    }
}

impl ResumableBake<'_> {
    fn key(&self) -> serde_json::Value {
        checkpoint_key(&self.fingerprint, &self.indices, &self.run_key)
    }

    /// Loads the checkpoint's finished cells (none when there is no checkpoint).
    fn load_checkpoint(&self) -> Result<BTreeMap<usize, BakedCell>, BakeError> {
        let mut out = BTreeMap::new();
        let Some(path) = &self.checkpoint else {
            return Ok(out);
        };
        if self.restart || !path.exists() {
            return Ok(out);
        }
        let not = |what: &str| BakeError::NotACheckpoint {
            path: path.clone(),
            what: what.into(),
        };
        let file = EncodedPvsFile::load(path).map_err(|source| BakeError::CorruptCheckpoint {
            path: path.clone(),
            source,
        })?;
        if file.metadata["checkpoint"] != 1 {
            return Err(not("no checkpoint marker in its metadata"));
        }
        let key = self.key();
        if file.metadata["key"] != key {
            let mut differences =
                fingerprint_differences(&file.metadata["key"]["fingerprint"], &key["fingerprint"]);
            if differences.is_empty() {
                differences = "the cells this run bakes (--shard or --since)".into();
            }
            return Err(BakeError::CheckpointMismatch {
                path: path.clone(),
                differences,
            });
        }
        let indices = file.metadata["cell_indices"]
            .as_array()
            .ok_or_else(|| not("no cell_indices"))?;
        let stats = file.metadata["cells"]
            .as_array()
            .ok_or_else(|| not("no cell statistics"))?;
        if indices.len() != file.cells.len() || stats.len() != file.cells.len() {
            return Err(not("cell_indices or cells do not match its cells"));
        }
        if file.scene_hash != self.setup.scene.geometry_hash()
            || file.triangle_count as usize != self.setup.scene.triangle_count()
        {
            return Err(not("it indexes another scene"));
        }
        for ((i, s), (cell, set)) in indices.iter().zip(stats).zip(file.cells) {
            let index = i
                .as_u64()
                .map(|i| i as usize)
                .filter(|i| self.setup.cells.get(*i) == Some(&cell))
                .ok_or_else(|| not("a cell index does not name its cell"))?;
            out.insert(index, BakedCell::new(index, set, s));
        }
        Ok(out)
    }

    fn save_checkpoint(&self, done: &BTreeMap<usize, BakedCell>) -> Result<(), BakeError> {
        let Some(path) = &self.checkpoint else {
            return Ok(());
        };
        let metadata = json!({
            "checkpoint": 1,
            "key": self.key(),
            "cell_indices": done.keys().collect::<Vec<_>>(),
            "cells": done.values().map(BakedCell::stats).collect::<Vec<_>>(),
        });
        // Checkpoints are version 1: their object sets would be derived again at every save.
        save_encoded(
            path,
            self.setup.scene.geometry_hash(),
            self.setup.scene.triangle_count() as u32,
            None,
            &metadata,
            done.values().map(|c| (&self.setup.cells[c.index], &c.set)),
        )?;
        Ok(())
    }

    /// Resumes from the checkpoint (if any), bakes the missing cells of `indices` in parallel
    /// and keeps the checkpoint up to date. `on_cell(index, result)` is called after each
    /// cell baked by this run.
    pub fn run(
        &self,
        on_progress: &(dyn Fn(usize, &ConvergencePoint) + Sync),
        on_cell: &mut (dyn FnMut(usize, &CellResult) + Send),
    ) -> Result<BakeProgress, BakeError> {
        self.run_with(&mut |_| {}, on_progress, on_cell)
    }

    /// [`ResumableBake::run`], telling `on_start` how many of the cells are already done
    /// (resumed or kept) before baking the others, e.g. to start a progress bar there.
    pub fn run_with(
        &self,
        on_start: &mut dyn FnMut(usize),
        on_progress: &(dyn Fn(usize, &ConvergencePoint) + Sync),
        on_cell: &mut (dyn FnMut(usize, &CellResult) + Send),
    ) -> Result<BakeProgress, BakeError> {
        let start = Instant::now();
        let mut done = self.load_checkpoint()?;
        done.retain(|i, _| self.indices.binary_search(i).is_ok());
        let resumed = done.len();
        for (i, c) in &self.kept {
            done.entry(*i).or_insert_with(|| c.clone());
        }
        let todo: Vec<usize> = self
            .indices
            .iter()
            .copied()
            .filter(|i| !done.contains_key(i))
            .collect();
        on_start(self.indices.len() - todo.len());
        let mut last_write: Option<Instant> = None;
        let mut baked = 0usize;
        bake_cells(
            &self.setup,
            &todo,
            self.max_new_cells,
            on_progress,
            &mut |cell, result| {
                on_cell(cell.index, result);
                done.insert(cell.index, cell);
                baked += 1;
                if last_write.is_none_or(|t| t.elapsed() >= self.checkpoint_interval) {
                    self.save_checkpoint(&done)?;
                    last_write = Some(Instant::now());
                }
                Ok::<(), BakeError>(())
            },
        )?;
        let complete = self.indices.iter().all(|i| done.contains_key(i));
        // A complete bake goes straight to the output (see `write_output`); an incomplete one
        // leaves everything it finished in the checkpoint.
        if !complete && baked > 0 {
            self.save_checkpoint(&done)?;
        }
        Ok(BakeProgress {
            done,
            resumed,
            baked,
            complete,
            seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// The finished cells of `indices`, in order.
    fn output_cells<'p>(&self, progress: &'p BakeProgress) -> Vec<&'p BakedCell> {
        self.indices
            .iter()
            .filter_map(|i| progress.done.get(i))
            .collect()
    }

    /// The metadata of the output holding `cells` (see [`ResumableBake::write_output`]).
    fn output_metadata(
        &self,
        cells: &[&BakedCell],
        progress: &BakeProgress,
        extra: serde_json::Value,
    ) -> serde_json::Value {
        let total_rays = cells.iter().map(|c| c.rays).sum();
        let seconds: f64 = cells.iter().map(|c| c.seconds).sum();
        let mut extra_all = json!({
            "fingerprint": self.fingerprint,
            "total_cells": self.setup.cells.len(),
            "cell_seconds": seconds,
        });
        if cells.len() != self.setup.cells.len() {
            extra_all["cell_indices"] = json!(cells.iter().map(|c| c.index).collect::<Vec<_>>());
        }
        if let (Some(m), serde_json::Value::Object(e)) = (extra_all.as_object_mut(), extra) {
            m.extend(e);
        }
        bake_metadata(
            self.setup.scene,
            self.setup.sampler.name(),
            self.setup.seed,
            &self.setup.budget,
            total_rays,
            progress.seconds,
            cells.iter().map(|c| c.stats()).collect(),
            extra_all,
        )
    }

    /// The finished bake as a file in memory: the cells, sets and metadata
    /// [`ResumableBake::write_output`] writes (for front ends that return the file rather than
    /// write it, e.g. the Python bindings).
    pub fn to_pvs_file(
        &self,
        progress: &BakeProgress,
        extra: serde_json::Value,
    ) -> Result<PvsFile, BakeError> {
        let cells = self.output_cells(progress);
        let n = self.setup.scene.triangle_count();
        let mut file = PvsFile::for_scene(
            self.setup.scene,
            self.output_metadata(&cells, progress, extra),
        );
        for c in &cells {
            file.cells.push(CellPvs::new(
                self.setup.cells[c.index],
                c.set.decode(n).map_err(PvsError::from)?,
            ));
        }
        Ok(file)
    }

    /// Writes the finished bake to `output` atomically, then removes the checkpoint. The
    /// file holds the cells of `indices` in order; `extra` is merged into its metadata, beside
    /// `fingerprint` and, for a partial cell list (a shard), `cell_indices` and `total_cells`.
    pub fn write_output(
        &self,
        output: &Path,
        progress: &BakeProgress,
        extra: serde_json::Value,
    ) -> Result<(), BakeError> {
        let cells = self.output_cells(progress);
        let metadata = self.output_metadata(&cells, progress, extra);
        save_encoded(
            output,
            self.setup.scene.geometry_hash(),
            self.setup.scene.triangle_count() as u32,
            Some(&ObjectTable::from_scene(self.setup.scene)),
            &metadata,
            cells.iter().map(|c| (&self.setup.cells[c.index], &c.set)),
        )?;
        self.remove_checkpoint();
        Ok(())
    }

    /// Writes `file`, the finished bake as [`ResumableBake::to_pvs_file`] gave it and a front
    /// end completed (e.g. with conservative bounds), to `output` atomically, then removes the
    /// checkpoint.
    pub fn write_file(&self, output: &Path, file: &PvsFile) -> Result<(), BakeError> {
        file.save(output)?;
        self.remove_checkpoint();
        Ok(())
    }

    fn remove_checkpoint(&self) {
        if let Some(p) = &self.checkpoint {
            // The output is complete; a leftover checkpoint would only be refused or resumed
            // into the same result, so failing to delete it is not an error.
            let _ = std::fs::remove_file(p);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_name_the_keys() {
        let a = json!({"seed": 1, "method": "gvs++", "x": 2});
        let b = json!({"seed": 2, "method": "gvs++"});
        let d = fingerprint_differences(&a, &b);
        assert!(d.contains("seed 1 vs 2"), "{d}");
        assert!(d.contains("x 2 vs (none)"), "{d}");
        assert!(!d.contains("method"), "{d}");
    }

    #[test]
    fn differences_cut_long_values_between_characters() {
        // 39 ASCII bytes, then 'é' (2 bytes) across byte 40: a byte slice there panics.
        let long = format!("{}é{}", "a".repeat(38), "ü".repeat(30));
        let d = fingerprint_differences(&json!({ "scene": long }), &json!({ "scene": "b" }));
        assert!(d.starts_with("scene \""), "{d}");
        assert!(d.contains("..") && d.contains("vs \"b\""), "{d}");
    }

    #[test]
    fn differences_in_some_keys_ignore_the_others_and_keep_their_order() {
        let a = json!({"seed": 1, "scene_hash": "a", "method": "rand"});
        let b = json!({"seed": 2, "scene_hash": "b", "method": "gvs"});
        let d = fingerprint_differences_in(&a, &b, &["seed", "method", "budget"]);
        assert_eq!(d, r#"seed 1 vs 2, method "rand" vs "gvs""#);
        assert_eq!(fingerprint_differences_in(&a, &a, &["seed"]), "");
    }

    #[test]
    fn checkpoint_sits_beside_the_output() {
        assert_eq!(
            checkpoint_path(Path::new("a/b.pvs")),
            PathBuf::from("a/b.pvs.checkpoint")
        );
    }
}
