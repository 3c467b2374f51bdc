//! Splitting a bake into shards and merging the shard files back into one `.pvs`.
//!
//! Shard `i` of `n` holds the cells whose global index `g` has `g % n == i` (interleaved, so
//! every shard gets a similar mix of cheap and expensive cells). A shard file records
//! `shard: {index, count}`, `total_cells`, `cell_indices` (the global index of each of its
//! cells) and the bake's `fingerprint`; the merge checks them all and writes the cells in
//! global order, so merging all shards gives the same cells and sets as the unsharded bake.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::json;

use crate::bound::{BoundSummary, CellBound};
use crate::checkpoint::fingerprint_differences;
use crate::pvs_file::{EncodedPvsFile, EncodedSet};
use crate::viewcell::ViewCell;

/// A shard `index / count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// Which shard, `0..count`.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// Parses `I/N` (`0 <= I < N`).
    pub fn parse(s: &str) -> Result<Self, ShardParseError> {
        let bad = || ShardParseError {
            spec: s.to_string(),
        };
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Self { index, count })
    }

    /// The global indices of this shard's cells among `total` cells.
    pub fn indices(&self, total: usize) -> Vec<usize> {
        (self.index..total).step_by(self.count).collect()
    }
}

/// A shard spec that is not `I/N` with `0 <= I < N`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("shard '{spec}': expected I/N with 0 <= I < N, e.g. 0/4")]
pub struct ShardParseError {
    /// The spec as given.
    pub spec: String,
}

/// Why shard files could not be merged.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MergeError {
    /// Nothing to merge.
    #[error("no files to merge")]
    Empty,
    /// Some files hold conservative bounds and some do not.
    #[error(
        "some of these .pvs files hold conservative bounds (baked with --bound) and some do \
         not: bake them alike, or add the bounds after joining them with `pvs bound`"
    )]
    BoundsMixed,
    /// Two files index different scenes.
    #[error("{a} and {b} were baked for different scenes (hash {ha:016x} vs {hb:016x})")]
    DifferentScenes {
        /// First file.
        a: PathBuf,
        /// Second file.
        b: PathBuf,
        /// Scene hash of `a`.
        ha: u64,
        /// Scene hash of `b`.
        hb: u64,
    },
    /// A file has no fingerprint (not written by a sharded or resumable bake).
    #[error(
        "{0} has no bake fingerprint in its metadata (bake it with this version of sightline)"
    )]
    NoFingerprint(PathBuf),
    /// Two files come from different bakes.
    #[error("{a} and {b} come from different bakes (they differ in: {differences})")]
    DifferentBakes {
        /// First file.
        a: PathBuf,
        /// Second file.
        b: PathBuf,
        /// The differing fingerprint keys.
        differences: String,
    },
    /// A file's cell indices are missing or inconsistent.
    #[error("{path}: {what}")]
    BadIndices {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// Two files hold the same cell.
    #[error("{a} and {b} overlap: both hold cell {cell}")]
    Overlap {
        /// First file.
        a: PathBuf,
        /// Second file.
        b: PathBuf,
        /// The cell's global index.
        cell: usize,
    },
    /// Some cells are in no file.
    #[error(
        "{missing} of {total} cells are in none of the files (first missing: {first}); \
         merge the other shards too, or pass --allow-partial"
    )]
    Missing {
        /// How many are missing.
        missing: usize,
        /// Cells of the whole bake.
        total: usize,
        /// The first missing global index.
        first: usize,
    },
}

/// The global index of each cell of `file` (all cells in order for an unsharded file).
fn cell_indices(path: &Path, file: &EncodedPvsFile) -> Result<(Vec<usize>, usize), MergeError> {
    let bad = |what: &str| MergeError::BadIndices {
        path: path.to_path_buf(),
        what: what.into(),
    };
    let total = file.metadata["total_cells"]
        .as_u64()
        .map(|t| t as usize)
        .ok_or_else(|| bad("no total_cells in its metadata"))?;
    let indices: Vec<usize> = match file.metadata.get("cell_indices") {
        None => (0..file.cells.len()).collect(),
        Some(v) => v
            .as_array()
            .ok_or_else(|| bad("cell_indices is not a list"))?
            .iter()
            .map(|i| i.as_u64().map(|i| i as usize))
            .collect::<Option<_>>()
            .ok_or_else(|| bad("cell_indices holds a non-number"))?,
    };
    if indices.len() != file.cells.len() {
        return Err(bad("cell_indices does not list one index per cell"));
    }
    if indices.iter().any(|&i| i >= total) || !indices.windows(2).all(|w| w[0] < w[1]) {
        return Err(bad("cell_indices is not ascending within total_cells"));
    }
    Ok((indices, total))
}

/// Merges shard files (path and contents) into one file with the cells in global order.
/// Refuses different scenes or bakes, overlapping shards and, unless `allow_partial`, missing
/// cells (a partial merge records `cell_indices`).
pub fn merge(
    files: &[(PathBuf, EncodedPvsFile)],
    allow_partial: bool,
) -> Result<EncodedPvsFile, MergeError> {
    let (first_path, first) = files.first().ok_or(MergeError::Empty)?;
    let fp = first
        .metadata
        .get("fingerprint")
        .ok_or_else(|| MergeError::NoFingerprint(first_path.clone()))?;
    let mut gathered = Gathered::default();
    for (k, file) in files.iter().enumerate() {
        check_same_bake(&files[0], fp, file)?;
        gathered.add(files, k)?;
    }
    let total = gathered.total.unwrap_or(0);
    gathered.check_complete(total, allow_partial)?;
    let two_sided = !first.bound_extras.is_empty();
    if files
        .iter()
        .any(|(_, f)| f.bound_extras.is_empty() == two_sided)
    {
        return Err(MergeError::BoundsMixed);
    }
    let metadata = merged_metadata(files, &gathered, total)?;
    Ok(EncodedPvsFile {
        scene_hash: first.scene_hash,
        triangle_count: first.triangle_count,
        objects: first.objects.clone(),
        metadata,
        cells: gathered.cells.values().map(|c| c.cell.clone()).collect(),
        bound_extras: (gathered.cells.values())
            .filter_map(|c| c.bound_extra.cloned())
            .collect(),
    })
}

/// Checks that `file` comes from the same scene (hash, triangle count and object table) and
/// the same bake (fingerprint, `fp` being the first file's) as `first`: only such files can
/// be merged into one.
fn check_same_bake(
    (first_path, first): &(PathBuf, EncodedPvsFile),
    fp: &serde_json::Value,
    (path, file): &(PathBuf, EncodedPvsFile),
) -> Result<(), MergeError> {
    if file.scene_hash != first.scene_hash || file.triangle_count != first.triangle_count {
        return Err(MergeError::DifferentScenes {
            a: first_path.clone(),
            b: path.clone(),
            ha: first.scene_hash,
            hb: file.scene_hash,
        });
    }
    if file.objects != first.objects {
        return Err(MergeError::BadIndices {
            path: path.clone(),
            what: format!(
                "its object table differs from {}'s (a version-1 file, or another scene's objects)",
                first_path.display()
            ),
        });
    }
    let f = file
        .metadata
        .get("fingerprint")
        .ok_or_else(|| MergeError::NoFingerprint(path.clone()))?;
    if f != fp {
        return Err(MergeError::DifferentBakes {
            a: first_path.clone(),
            b: path.clone(),
            differences: fingerprint_differences(fp, f),
        });
    }
    Ok(())
}

/// One cell of the merge: the file it comes from (its position in the list), the cell with
/// its set, and its entry in that file's `cells` metadata.
struct MergedCell<'a> {
    file: usize,
    cell: &'a (ViewCell, EncodedSet),
    /// The triangles its bound adds, in a two-sided file.
    bound_extra: Option<&'a EncodedSet>,
    meta: &'a serde_json::Value,
}

/// The cells of the files merged so far, by global index (so in global order), with the
/// per-cell lists beside `cells` (Quake 3 leaf bakes' `clusters`) and the bake's cell count.
#[derive(Default)]
struct Gathered<'a> {
    cells: BTreeMap<usize, MergedCell<'a>>,
    clusters: BTreeMap<usize, &'a serde_json::Value>,
    /// `total_cells` of the files (all must agree); `None` before the first.
    total: Option<usize>,
}

impl<'a> Gathered<'a> {
    /// Adds the cells of `files[k]` by their global indices, refusing a different
    /// `total_cells` and a cell that an earlier file holds.
    fn add(&mut self, files: &'a [(PathBuf, EncodedPvsFile)], k: usize) -> Result<(), MergeError> {
        let (path, file) = &files[k];
        let (indices, t) = cell_indices(path, file)?;
        if *self.total.get_or_insert(t) != t {
            return Err(MergeError::BadIndices {
                path: path.clone(),
                what: format!("total_cells {t} differs from {}", self.total.unwrap_or(0)),
            });
        }
        for (j, (&g, cell)) in indices.iter().zip(&file.cells).enumerate() {
            if let Some(other) = self.cells.get(&g) {
                return Err(MergeError::Overlap {
                    a: files[other.file].0.clone(),
                    b: path.clone(),
                    cell: g,
                });
            }
            let meta = &file.metadata["cells"][j];
            self.cells.insert(
                g,
                MergedCell {
                    file: k,
                    cell,
                    bound_extra: file.bound_extras.get(j),
                    meta,
                },
            );
            if let Some(c) = file.metadata["clusters"].as_array().and_then(|c| c.get(j)) {
                self.clusters.insert(g, c);
            }
        }
        Ok(())
    }

    /// Refuses a merge that misses some of the `total` cells, unless `allow_partial`.
    fn check_complete(&self, total: usize, allow_partial: bool) -> Result<(), MergeError> {
        if self.cells.len() != total && !allow_partial {
            let first_missing = (0..total)
                .find(|i| !self.cells.contains_key(i))
                .unwrap_or(0);
            return Err(MergeError::Missing {
                missing: total - self.cells.len(),
                total,
                first: first_missing,
            });
        }
        Ok(())
    }
}

/// The merged file's metadata: the first file's, without the shard's own keys, with the
/// totals summed over the files (rays, seconds), the cells' entries and clusters in global
/// order, the merged files' paths, and `cell_indices` when the merge is partial.
fn merged_metadata(
    files: &[(PathBuf, EncodedPvsFile)],
    gathered: &Gathered<'_>,
    total: usize,
) -> Result<serde_json::Value, MergeError> {
    let (first_path, first) = &files[0];
    let by_index = &gathered.cells;
    let mut metadata = first.metadata.clone();
    if let Some(m) = metadata.as_object_mut() {
        m.remove("shard");
        m.remove("cell_indices");
        let sum = |key: &str| -> serde_json::Value {
            let s: f64 = files
                .iter()
                .map(|(_, f)| f.metadata[key].as_f64().unwrap_or(0.0))
                .sum();
            json!(s)
        };
        m.insert(
            "total_rays".into(),
            json!(by_index
                .values()
                .map(|c| c.meta["rays"].as_u64().unwrap_or(0))
                .sum::<u64>()),
        );
        m.insert("seconds".into(), sum("seconds"));
        m.insert("cell_seconds".into(), sum("cell_seconds"));
        m.insert(
            "cells".into(),
            json!(by_index
                .values()
                .map(|c| c.meta.clone())
                .collect::<Vec<_>>()),
        );
        if m.contains_key("bound") {
            // Two-sided shards: the bounds' totals over every cell, from the cells' own
            // figures (`bound::add_bounds` writes them), as a whole bake's.
            let figure = |c: &MergedCell<'_>, key: &str| c.meta[key].as_u64().unwrap_or(0) as usize;
            let summary = BoundSummary {
                method: files[0].1.metadata["bound"]["method"]
                    .as_str()
                    .unwrap_or_default()
                    .to_string(),
                seconds: (files.iter())
                    .map(|(_, f)| f.metadata["bound"]["seconds"].as_f64().unwrap_or(0.0))
                    .sum(),
                cells: (by_index.values())
                    .map(|c| CellBound {
                        set_size: figure(c, "pvs_size"),
                        bound_size: figure(c, "bound_size"),
                        gap: figure(c, "gap"),
                        not_in_conservative: figure(c, "not_in_conservative"),
                    })
                    .collect(),
            };
            m.insert("bound".into(), json!(summary.totals()));
        }
        m.insert(
            "merged_from".into(),
            json!(files
                .iter()
                .map(|(p, _)| p.display().to_string())
                .collect::<Vec<_>>()),
        );
        if !m.get("clusters").is_none_or(serde_json::Value::is_null) {
            if gathered.clusters.len() != by_index.len() {
                return Err(MergeError::BadIndices {
                    path: first_path.clone(),
                    what: "some files have no cluster per cell".into(),
                });
            }
            m.insert(
                "clusters".into(),
                json!(gathered.clusters.values().collect::<Vec<_>>()),
            );
        }
        if by_index.len() != total {
            m.insert(
                "cell_indices".into(),
                json!(by_index.keys().collect::<Vec<_>>()),
            );
        }
    }
    Ok(metadata)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shard_file(indices: &[usize], clusters: &[u32]) -> EncodedPvsFile {
        use glam::Vec3;
        let cells = indices
            .iter()
            .map(|&i| {
                (
                    ViewCell::aabb(Vec3::splat(i as f32), Vec3::splat(i as f32 + 1.0)).unwrap(),
                    EncodedSet::encode(&fixedbitset::FixedBitSet::with_capacity(4), 4),
                )
            })
            .collect();
        EncodedPvsFile {
            scene_hash: 7,
            triangle_count: 4,
            objects: None,
            bound_extras: Vec::new(),
            metadata: json!({
                "fingerprint": {"seed": 1},
                "total_cells": 4,
                "cell_indices": indices,
                "clusters": clusters,
                "cells": indices.iter().map(|i| json!({"rays": i})).collect::<Vec<_>>(),
            }),
            cells,
        }
    }

    #[test]
    fn merge_puts_cells_and_their_clusters_in_global_order() {
        let files = [
            (PathBuf::from("b"), shard_file(&[1, 3], &[11, 13])),
            (PathBuf::from("a"), shard_file(&[0, 2], &[10, 12])),
        ];
        let m = merge(&files, false).unwrap();
        let firsts: Vec<f32> = m.cells.iter().map(|c| c.0.center.x).collect();
        assert_eq!(firsts, vec![0.5, 1.5, 2.5, 3.5]);
        assert_eq!(m.metadata["clusters"], json!([10, 11, 12, 13]));
        assert_eq!(m.metadata["total_rays"], 6);
        assert!(m.metadata.get("cell_indices").is_none());
        let partial = merge(&files[..1], true).unwrap();
        assert_eq!(partial.metadata["cell_indices"], json!([1, 3]));
        assert_eq!(partial.metadata["clusters"], json!([11, 13]));
    }

    #[test]
    fn shard_specs_parse_and_partition() {
        assert_eq!(Shard::parse("1/3").unwrap(), Shard { index: 1, count: 3 });
        for bad in ["3/3", "1", "a/2", "0/0", "-1/2"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        let mut all: Vec<usize> = (0..3)
            .flat_map(|i| Shard { index: i, count: 3 }.indices(10))
            .collect();
        all.sort_unstable();
        assert_eq!(all, (0..10).collect::<Vec<_>>());
        assert_eq!(Shard { index: 2, count: 3 }.indices(10), vec![2, 5, 8]);
    }
}
