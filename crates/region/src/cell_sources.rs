//! Where view cells come from: a JSON or TOML file, a regular grid (optionally only cells not
//! inside solid geometry), or a Quake 3 map's BSP leaves or clusters, with the rule for their
//! ray origins (in the cell's cluster and, by default, in reachable space: [`q3_cells`]).

use std::path::Path;

use glam::Vec3;
use serde::{Deserialize, Serialize};
use sightline_core::scene::q3::BspData;
use sightline_core::trace::RayCaster;
use sightline_core::{Ray, Scene};

use crate::reachable::{self, ReachError, ReachParams, ReachStats, ReachableSpace};
use crate::viewcell::{ViewCell, ViewCellError};

/// Why cells could not be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CellsError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        source: std::io::Error,
    },
    /// The file is not valid JSON/TOML of the expected shape.
    #[error("{path}: {message}")]
    Syntax {
        /// The file.
        path: String,
        /// Parser message (with line/column where the parser gives one).
        message: String,
    },
    /// A cell in the file is not a usable cell.
    #[error("{path}: cell {index}: {source}")]
    BadCell {
        /// The file.
        path: String,
        /// 0-based index of the cell in the file.
        index: usize,
        /// What is wrong.
        source: ViewCellError,
    },
}

/// One cell in a cells file: either `min`/`max` corners, or `center`, `axes`, `half_extents`.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum CellEntry {
    Corners {
        min: [f32; 3],
        max: [f32; 3],
    },
    Oriented {
        center: [f32; 3],
        axes: [[f32; 3]; 3],
        half_extents: [f32; 3],
    },
}

#[derive(Debug, Deserialize)]
struct CellsDocument {
    cells: Vec<CellEntry>,
}

/// Reads cells from a `.json` or `.toml` file of the form
/// `{"cells": [{"min": [x,y,z], "max": [x,y,z]}, {"center": [..], "axes": [[..],[..],[..]],
/// "half_extents": [..]}]}` (TOML: `[[cells]]` tables with the same keys).
pub fn read_cells_file(path: &Path) -> Result<Vec<ViewCell>, CellsError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| CellsError::Io {
        path: name.clone(),
        source,
    })?;
    let is_toml = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    let doc: CellsDocument = if is_toml {
        toml::from_str(&text).map_err(|e| CellsError::Syntax {
            path: name.clone(),
            message: e.to_string(),
        })?
    } else {
        serde_json::from_str(&text).map_err(|e| CellsError::Syntax {
            path: name.clone(),
            message: e.to_string(),
        })?
    };
    doc.cells
        .into_iter()
        .enumerate()
        .map(|(index, entry)| {
            let cell = match entry {
                CellEntry::Corners { min, max } => {
                    let (min, max) = (Vec3::from(min), Vec3::from(max));
                    if min.cmpgt(max).any() {
                        Err(ViewCellError::Spec {
                            spec: format!("min {min} max {max}"),
                            message: "min must be <= max on every axis".into(),
                        })
                    } else {
                        ViewCell::aabb(min, max)
                    }
                }
                CellEntry::Oriented {
                    center,
                    axes,
                    half_extents,
                } => ViewCell::oriented(
                    Vec3::from(center),
                    axes.map(Vec3::from),
                    Vec3::from(half_extents),
                ),
            };
            cell.map_err(|source| CellsError::BadCell {
                path: name.clone(),
                index,
                source,
            })
        })
        .collect()
}

/// Writes `cells` as a cells file that [`read_cells_file`] reads back exactly (JSON, each cell
/// as `center`, `axes`, `half_extents`), atomically: for a user to edit (e.g. cells placed by
/// `walkable::walkable_cells`) and bake with `--cells`.
pub fn write_cells_file(path: &Path, cells: &[ViewCell]) -> Result<(), CellsError> {
    let entries: Vec<serde_json::Value> = cells
        .iter()
        .map(|c| {
            serde_json::json!({
                "center": c.center.to_array(),
                "axes": c.axes.map(|a| a.to_array()),
                "half_extents": c.half_extents.to_array(),
            })
        })
        .collect();
    let doc = serde_json::json!({ "cells": entries });
    sightline_core::atomic_file::write_atomic(path, |w| {
        serde_json::to_writer_pretty(&mut *w, &doc)?;
        std::io::Write::write_all(w, b"\n")
    })
    .map_err(|source| CellsError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// True when `point` is inside closed solid geometry: of six axis rays from it, at least four
/// first hit the back side of a triangle (its normal pointing away from the ray's origin).
/// Meshes are assumed to be consistently wound with outward normals (as generators and most
/// game maps are); for open or inconsistently wound meshes this is a heuristic.
/// Quake 3 maps answer from their BSP instead: a point is solid when its leaf has no cluster
/// (their polygons are wound clockwise, so the normal rule would be inverted there).
pub fn inside_solid(scene: &Scene, caster: &dyn RayCaster, point: Vec3) -> bool {
    if let Some(bsp) = scene.bsp.as_deref() {
        return bsp.cluster_at(point).is_none();
    }
    let dirs = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ];
    let rays = dirs.map(|d| Ray::new(point, d));
    let mut hits = [sightline_core::Hit::MISS; 6];
    caster.cast(&rays, &mut hits);
    let backs = hits
        .iter()
        .zip(&dirs)
        .filter(|(h, d)| {
            h.triangle().is_some_and(|t| {
                let [a, b, c] = scene.triangle(t);
                (b - a).cross(c - a).dot(**d) > 0.0
            })
        })
        .count();
    backs >= 4
}

/// `count` cubic cells of half size `half_extent` at random places in the scene's empty space:
/// centres drawn uniformly in the bounds (for Z-up scenes at 1 to 3 half sizes above the
/// lowest geometry below them, i.e. at eye height over the ground) and kept when neither the
/// centre nor any corner is inside solid geometry (and, for Quake 3 maps, lies in a cluster).
/// Deterministic for a seed; gives fewer cells when free space is hard to find.
pub fn random_free_cells(
    scene: &Scene,
    caster: &dyn RayCaster,
    count: usize,
    half_extent: f32,
    seed: u64,
) -> Vec<ViewCell> {
    let bounds = scene.bounds();
    let mut rng = sightline_core::random::SplitMix64::new(seed);
    let up = scene.up.vector();
    let mut cells = Vec::with_capacity(count);
    for _ in 0..count * 200 {
        if cells.len() == count {
            break;
        }
        let mut c = bounds.min
            + (bounds.max - bounds.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        if up == Vec3::Z {
            // Drop to the ground below and stand at eye height.
            let down = Ray::new(c, Vec3::NEG_Z);
            let hit = caster.cast_one(&down);
            if !hit.is_hit() {
                continue;
            }
            c = down.at(hit.t) + up * half_extent * rng.range_f32(1.2, 3.0);
        }
        let Ok(cell) = ViewCell::aabb(c - Vec3::splat(half_extent), c + Vec3::splat(half_extent))
        else {
            continue;
        };
        let free = std::iter::once(c)
            .chain(cell.corners())
            .all(|p| !inside_solid(scene, caster, p))
            && scene.bsp.as_ref().is_none_or(|b| b.cluster_at(c).is_some());
        // The cell must not intersect geometry either: a ray along each edge stays clear.
        let clear = free
            && cell.edges().iter().all(|(a, b)| {
                !caster
                    .cast_one(&Ray::new(*a, *b - *a).with_range(0.0, 1.0))
                    .is_hit()
            });
        if clear {
            cells.push(cell);
        }
    }
    cells
}

/// How far (in Quake units, about an inch each) leaf boxes are shrunk: leaf boxes share their
/// faces with the walls around them, and a ray starting exactly on a wall may round to the far
/// side of it and see what the wall hides.
pub const Q3_LEAF_MARGIN: f32 = 0.5;

/// A cell per BSP leaf that belongs to a cluster (solid leaves have cluster -1), with the
/// cluster of each: a cluster's PVS is the union of its leaves' PVSs. Leaf boxes are the BSP's
/// own integer bounds shrunk by [`Q3_LEAF_MARGIN`]; since they are bounding boxes of convex
/// leaves they can still reach into solid space, so bakes should only use origins whose
/// cluster is the leaf's (`BspData::cluster_at`). `clusters` restricts the result to the given
/// clusters.
pub fn q3_leaf_cells(bsp: &BspData, clusters: Option<&[u32]>) -> Vec<(u32, ViewCell)> {
    q3_leaf_cells_indexed(bsp, clusters)
        .into_iter()
        .map(|(_, c, cell)| (c, cell))
        .collect()
}

/// [`q3_leaf_cells`] with the index of each cell's leaf in `BspData::leaves`.
fn q3_leaf_cells_indexed(bsp: &BspData, clusters: Option<&[u32]>) -> Vec<(usize, u32, ViewCell)> {
    bsp.leaves
        .iter()
        .enumerate()
        .filter(|(_, l)| l.cluster >= 0)
        .filter(|(_, l)| clusters.is_none_or(|c| c.contains(&(l.cluster as u32))))
        .filter_map(|(i, l)| {
            let b = l.bounds();
            let margin = Vec3::splat(Q3_LEAF_MARGIN).min(b.extent() * 0.25);
            let cell = ViewCell::aabb(b.min + margin, b.max - margin).ok()?;
            Some((i, l.cluster as u32, cell))
        })
        .collect()
}

/// A cell per cluster: the bounding box of the cluster's [`q3_leaf_cells`], in cluster order.
/// The box reaches into other clusters and solid space, so bakes should only use origins whose
/// cluster is the cell's (`BspData::cluster_at`), as for leaves.
pub fn q3_cluster_cells(bsp: &BspData, clusters: Option<&[u32]>) -> Vec<(u32, ViewCell)> {
    let mut boxes: std::collections::BTreeMap<u32, (Vec3, Vec3)> = Default::default();
    for (c, cell) in q3_leaf_cells(bsp, clusters) {
        let (lo, hi) = (
            cell.center - cell.half_extents,
            cell.center + cell.half_extents,
        );
        let e = boxes.entry(c).or_insert((lo, hi));
        e.0 = e.0.min(lo);
        e.1 = e.1.max(hi);
    }
    boxes
        .into_iter()
        .filter_map(|(c, (lo, hi))| Some((c, ViewCell::aabb(lo, hi).ok()?)))
        .collect()
}

/// Quake 3 cells: one per BSP leaf or one per cluster.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Q3CellKind {
    /// [`q3_leaf_cells`].
    Leaves,
    /// [`q3_cluster_cells`].
    Clusters,
}

/// Where the ray origins (and evaluation viewpoints) of Quake 3 cells may be.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Q3Origins {
    /// In the cell's cluster and in the space reachable from the map's spawn points
    /// ([`crate::reachable`], issue 24); cells without reachable space are dropped. The
    /// default: a PVS is for where players can be.
    Reachable(ReachParams),
    /// Anywhere in the cell's cluster, every cell kept (the rule before issue 24).
    Cluster,
}

impl Default for Q3Origins {
    fn default() -> Self {
        Self::Reachable(ReachParams::default())
    }
}

/// The key of `.pvs` metadata where a Quake 3 bake records its origin rule
/// ([`Q3OriginsSummary`]).
pub const Q3_ORIGINS_KEY: &str = "reachable";

impl Q3Origins {
    /// What of the rule decides the result, for a bake's fingerprint (the parameters and the
    /// algorithm version, not the time it took).
    pub fn fingerprint(&self) -> serde_json::Value {
        match self {
            Q3Origins::Reachable(p) => serde_json::json!({
                "origins": "reachable",
                "step": p.step,
                "version": reachable::VERSION,
            }),
            Q3Origins::Cluster => serde_json::json!({ "origins": "cluster" }),
        }
    }

    /// The rule a bake recorded in `metadata[Q3_ORIGINS_KEY]`; `Cluster` when there is no
    /// record (files from before issue 24 used that rule).
    pub fn from_metadata(metadata: &serde_json::Value) -> Self {
        let r = &metadata[Q3_ORIGINS_KEY];
        match (r["origins"].as_str(), r["step"].as_f64()) {
            (Some("reachable"), Some(step)) => {
                Q3Origins::Reachable(ReachParams { step: step as f32 })
            }
            _ => Q3Origins::Cluster,
        }
    }
}

/// The origin rule of Quake 3 cells: `allows(cell, p)` when `p` is in the cell's cluster
/// and, with a reachable space, reachable.
pub struct Q3OriginRule<'a> {
    bsp: &'a BspData,
    /// The cluster of each cell.
    pub clusters: Vec<u32>,
    /// The reachable space, when origins must be reachable.
    pub reach: Option<ReachableSpace<'a>>,
}

impl<'a> Q3OriginRule<'a> {
    /// True when `p` may be a ray origin or viewpoint of cell `cell`.
    pub fn allows(&self, cell: usize, p: Vec3) -> bool {
        self.clusters
            .get(cell)
            .is_some_and(|&c| self.in_cluster(c, p))
            && self.reachable(p)
    }

    /// True when `p` is in cluster `cluster`.
    pub fn in_cluster(&self, cluster: u32, p: Vec3) -> bool {
        self.bsp.cluster_at(p) == Some(cluster)
    }

    /// True when `p`, a point of some cluster ([`Q3OriginRule::in_cluster`] held), is
    /// reachable (always, without a reachable space).
    pub fn reachable(&self, p: Vec3) -> bool {
        self.reach
            .as_ref()
            .is_none_or(|r| r.is_reachable_in_cluster(p))
    }

    /// The rule a `.pvs` file of a Quake 3 bake was baked with, from its metadata
    /// (`clusters`, and [`Q3_ORIGINS_KEY`] for the reachable space, rebuilt here with the
    /// recorded parameters), or the cells' clusters with the rule `origins` when given (to
    /// judge bakes of both rules from the same viewpoints): `None` when the file's cells are
    /// not Quake 3 cells (no cluster list) or the scene is not a map. A map without spawn
    /// points gets the cluster rule, as its bake did.
    pub fn from_metadata(
        scene: &'a Scene,
        metadata: &serde_json::Value,
        origins: Option<Q3Origins>,
    ) -> Result<Option<Self>, ReachError> {
        let (Some(bsp), Some(list)) = (scene.bsp.as_deref(), metadata["clusters"].as_array())
        else {
            return Ok(None);
        };
        let Some(clusters) = list
            .iter()
            .map(|c| c.as_u64().and_then(|c| u32::try_from(c).ok()))
            .collect::<Option<Vec<u32>>>()
        else {
            return Ok(None);
        };
        let reach = match origins.unwrap_or_else(|| Q3Origins::from_metadata(metadata)) {
            Q3Origins::Reachable(p) => match ReachableSpace::build(scene, &p) {
                Ok(r) => Some(r),
                Err(ReachError::NoSpawnPoints) => None,
                Err(e) => return Err(e),
            },
            Q3Origins::Cluster => None,
        };
        Ok(Some(Self {
            bsp,
            clusters,
            reach,
        }))
    }
}

/// What choosing the origins of Quake 3 cells found: recorded in the `.pvs` metadata under
/// [`Q3_ORIGINS_KEY`] and in the CLI's `--json` summary.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Q3OriginsSummary {
    /// `"reachable"` or `"cluster"`.
    pub origins: String,
    /// Why the cluster rule is used although reachable origins were asked for (a map without
    /// spawn points); `None` otherwise.
    pub fallback: Option<String>,
    /// Lattice step of the reachable space.
    pub step: Option<f32>,
    /// Version of the reachable-space algorithm ([`reachable::VERSION`]).
    pub version: Option<u32>,
    /// `"leaves"` or `"clusters"`.
    pub cell_kind: String,
    /// Spawn points of the map.
    pub spawn_points: usize,
    /// Leaves with a cluster among the selected clusters.
    pub leaves: usize,
    /// Of those, the leaves without reachable space (`None` under the cluster rule).
    pub unreachable_leaves: Option<usize>,
    /// Selected clusters.
    pub clusters: usize,
    /// Of those, the clusters none of whose leaves is reachable.
    pub unreachable_clusters: Option<usize>,
    /// Cells left out of the bake for having no reachable space.
    pub dropped_cells: usize,
    /// What building the reachable space found and cost.
    pub reach: Option<ReachStats>,
}

impl Q3OriginsSummary {
    /// A line for the user: how many leaves and clusters are unreachable, or why origins are
    /// not restricted. `map` names the map (e.g. its file stem).
    pub fn describe(&self, map: &str) -> String {
        let n = thousands;
        if let Some(why) = &self.fallback {
            return format!(
                "{map}: {why}: ray origins are not restricted to reachable space (every cell is \
                 baked, origins anywhere in the cell's cluster)"
            );
        }
        let (Some(ul), Some(uc)) = (self.unreachable_leaves, self.unreachable_clusters) else {
            return format!(
                "{map}: every cell is baked, origins anywhere in the cell's cluster (reachable \
                 space not computed)"
            );
        };
        let from = format!(
            "from {} spawn point{}",
            n(self.spawn_points),
            if self.spawn_points == 1 { "" } else { "s" }
        );
        let counts = if self.cell_kind == "clusters" {
            format!(
                "{} of {} clusters ({} of {} leaves) are unreachable {from}",
                n(uc),
                n(self.clusters),
                n(ul),
                n(self.leaves)
            )
        } else {
            format!(
                "{} of {} leaves ({} clusters) are unreachable {from}",
                n(ul),
                n(self.leaves),
                n(uc)
            )
        };
        if self.dropped_cells == 0 {
            format!("{map}: {counts}")
        } else {
            format!("{map}: {counts}; their cells are not baked")
        }
    }
}

/// `1234567` as `1,234,567`.
fn thousands(v: usize) -> String {
    let digits = v.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, ch) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

/// The cells of a Quake 3 bake with their clusters and origin rule.
pub struct Q3Cells<'a> {
    /// The cells, in leaf or cluster order.
    pub cells: Vec<ViewCell>,
    /// Where their origins may be; `rule.clusters[i]` is the cluster of `cells[i]`.
    pub rule: Q3OriginRule<'a>,
    /// What was found (and dropped).
    pub summary: Q3OriginsSummary,
}

impl Q3Cells<'_> {
    /// The rule in force: [`Q3Origins::Reachable`] with the space's parameters when a
    /// reachable space was built, else [`Q3Origins::Cluster`] (asked for, or the fallback of a
    /// map without spawn points).
    pub fn origins(&self) -> Q3Origins {
        match &self.rule.reach {
            Some(r) => Q3Origins::Reachable(ReachParams {
                step: r.stats().step,
            }),
            None => Q3Origins::Cluster,
        }
    }
}

/// The cells of `kind` of `scene`'s map (only `clusters` when given) with the origin rule
/// `origins`. Under [`Q3Origins::Reachable`] the reachable space is built over the whole map
/// and the cells without reachable space are dropped; a map without spawn points falls back
/// to the cluster rule (`summary.fallback` says so). Errors: the scene is not a map, or the
/// reachable space's parameters are bad ([`ReachError`]).
pub fn q3_cells<'a>(
    scene: &'a Scene,
    kind: Q3CellKind,
    clusters: Option<&[u32]>,
    origins: Q3Origins,
) -> Result<Q3Cells<'a>, ReachError> {
    let bsp = scene.bsp.as_deref().ok_or(ReachError::NoBsp)?;
    let leaves = q3_leaf_cells_indexed(bsp, clusters);
    let selected: std::collections::BTreeSet<u32> = leaves.iter().map(|l| l.1).collect();
    let mut summary = Q3OriginsSummary {
        origins: "cluster".into(),
        fallback: None,
        step: None,
        version: None,
        cell_kind: match kind {
            Q3CellKind::Leaves => "leaves",
            Q3CellKind::Clusters => "clusters",
        }
        .into(),
        spawn_points: bsp.spawn_points.len(),
        leaves: leaves.len(),
        unreachable_leaves: None,
        clusters: selected.len(),
        unreachable_clusters: None,
        dropped_cells: 0,
        reach: None,
    };
    let reach = match origins {
        Q3Origins::Cluster => None,
        Q3Origins::Reachable(params) => match ReachableSpace::build(scene, &params) {
            Ok(r) => Some(r),
            Err(ReachError::NoSpawnPoints) => {
                summary.fallback = Some("the map has no spawn points".into());
                None
            }
            Err(e) => return Err(e),
        },
    };
    let all = match kind {
        Q3CellKind::Leaves => leaves.iter().map(|(_, c, cell)| (*c, *cell)).collect(),
        Q3CellKind::Clusters => q3_cluster_cells(bsp, clusters),
    };
    let (cells, cell_clusters): (Vec<ViewCell>, Vec<u32>) = match &reach {
        None => all.into_iter().map(|(c, cell)| (cell, c)).unzip(),
        Some(r) => {
            let reachable_leaf: Vec<bool> = leaves.iter().map(|l| r.leaf_reachable(l.0)).collect();
            let reachable_clusters: std::collections::BTreeSet<u32> = leaves
                .iter()
                .zip(&reachable_leaf)
                .filter(|(_, &ok)| ok)
                .map(|(l, _)| l.1)
                .collect();
            summary.origins = "reachable".into();
            summary.step = Some(r.stats().step);
            summary.version = Some(reachable::VERSION);
            summary.unreachable_leaves = Some(reachable_leaf.iter().filter(|&&ok| !ok).count());
            summary.unreachable_clusters = Some(selected.len() - reachable_clusters.len());
            summary.reach = Some(r.stats().clone());
            let keep: Vec<bool> = match kind {
                Q3CellKind::Leaves => reachable_leaf,
                Q3CellKind::Clusters => all
                    .iter()
                    .map(|(c, _)| reachable_clusters.contains(c))
                    .collect(),
            };
            summary.dropped_cells = keep.iter().filter(|&&k| !k).count();
            all.into_iter()
                .zip(keep)
                .filter(|(_, k)| *k)
                .map(|((c, cell), _)| (cell, c))
                .unzip()
        }
    };
    Ok(Q3Cells {
        cells,
        rule: Q3OriginRule {
            bsp,
            clusters: cell_clusters,
            reach,
        },
        summary,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;
    use sightline_core::trace::Bvh;

    fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn json_and_toml_cells_read_alike() {
        let dir = tempfile::tempdir().unwrap();
        let j = write(
            &dir,
            "c.json",
            r#"{"cells": [{"min": [0,0,0], "max": [1,2,3]},
            {"center": [0,0,0], "axes": [[1,0,0],[0,1,0],[0,0,1]], "half_extents": [1,1,0]}]}"#,
        );
        let t = write(
            &dir,
            "c.toml",
            "[[cells]]\nmin = [0,0,0]\nmax = [1,2,3]\n[[cells]]\ncenter = [0,0,0]\n\
             axes = [[1,0,0],[0,1,0],[0,0,1]]\nhalf_extents = [1,1,0]\n",
        );
        let a = read_cells_file(&j).unwrap();
        assert_eq!(a, read_cells_file(&t).unwrap());
        assert_eq!(a.len(), 2);
        assert!(a[1].is_flat());
    }

    #[test]
    fn bad_cells_files_name_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_cells_file(&write(&dir, "a.json", "{\"cells\": [")).unwrap_err();
        assert!(
            e.to_string().contains("a.json") && e.to_string().contains("line"),
            "{e}"
        );
        let e = read_cells_file(&write(
            &dir,
            "b.json",
            r#"{"cells": [{"min": [0,0,0], "max": [1,1,1]}, {"min": [2,0,0], "max": [1,1,1]}]}"#,
        ))
        .unwrap_err();
        assert!(e.to_string().contains("cell 1"), "{e}");
        let e = read_cells_file(&dir.path().join("missing.json")).unwrap_err();
        assert!(e.to_string().contains("missing.json"));
    }

    #[test]
    fn random_cells_avoid_geometry() {
        let scene = sightline_core::scene::open(
            "procedural:city?size=5000",
            &sightline_core::scene::LoadOptions::default(),
        )
        .unwrap();
        let bvh = Bvh::build(&scene);
        let cells = random_free_cells(&scene, &bvh, 5, 2.0, 3);
        assert_eq!(cells.len(), 5);
        for c in &cells {
            assert!(!inside_solid(&scene, &bvh, c.center));
            // Standing at eye height over the ground or a roof below.
            let below = bvh.cast_one(&Ray::new(c.center, Vec3::NEG_Z));
            assert!(below.t > 2.0 && below.t < 6.1, "eye height: {}", below.t);
        }
        assert_eq!(cells, random_free_cells(&scene, &bvh, 5, 2.0, 3));
    }

    #[test]
    fn q3_cells_leave_out_unreachable_leaves_and_say_so() {
        let scene = sightline_core::scene::open(
            concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/q3dm6ish.bsp"),
            &sightline_core::scene::LoadOptions::default(),
        )
        .unwrap();
        let coarse = Q3Origins::Reachable(ReachParams { step: 32.0 });
        let q = q3_cells(&scene, Q3CellKind::Leaves, None, coarse).unwrap();
        let all = q3_cells(&scene, Q3CellKind::Leaves, None, Q3Origins::Cluster).unwrap();
        let s = &q.summary;
        let unreachable = s.unreachable_leaves.unwrap();
        assert_eq!(all.cells.len(), s.leaves);
        assert!(
            unreachable > 0 && q.cells.len() == s.leaves - unreachable,
            "{s:?}"
        );
        assert_eq!(s.dropped_cells, unreachable);
        assert_eq!(q.rule.clusters.len(), q.cells.len());
        assert_eq!(q.origins(), coarse);
        assert_eq!(all.origins(), Q3Origins::Cluster);
        assert!(all.summary.unreachable_leaves.is_none());
        // Every spawn point is an allowed origin of the cell of its leaf's cluster.
        let bsp = scene.bsp.as_deref().unwrap();
        for &p in &bsp.spawn_points {
            let c = bsp.cluster_at(p).unwrap();
            let cell = q.rule.clusters.iter().position(|&k| k == c).unwrap();
            assert!(q.rule.allows(cell, p), "{p}");
        }
        let line = s.describe("q3dm6ish");
        assert!(
            line.starts_with(&format!(
                "q3dm6ish: {unreachable} of 247 leaves ({} clusters) are unreachable from 11 \
                 spawn points; their cells are not baked",
                s.unreachable_clusters.unwrap()
            )),
            "{line}"
        );
        // The recorded rule comes back from the metadata.
        let m = serde_json::json!({ Q3_ORIGINS_KEY: s, "clusters": q.rule.clusters });
        assert_eq!(Q3Origins::from_metadata(&m), coarse);
        assert_eq!(
            Q3Origins::from_metadata(&serde_json::Value::Null),
            Q3Origins::Cluster
        );
        let rule = Q3OriginRule::from_metadata(&scene, &m, None)
            .unwrap()
            .unwrap();
        assert!(rule.reach.is_some() && rule.clusters == q.rule.clusters);
    }

    #[test]
    fn thousands_are_grouped() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1021), "1,021");
        assert_eq!(thousands(1234567), "1,234,567");
    }

    #[test]
    fn point_inside_box_is_solid_outside_is_not() {
        let mut b = SceneBuilder::new("box");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        let scene = b.finish();
        let bvh = Bvh::build(&scene);
        assert!(inside_solid(&scene, &bvh, Vec3::splat(0.5)));
        assert!(!inside_solid(&scene, &bvh, Vec3::splat(2.0)));
        assert!(!inside_solid(&scene, &bvh, Vec3::new(0.5, 0.5, 3.0)));
    }
}
