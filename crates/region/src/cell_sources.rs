//! Where view cells come from: a JSON or TOML file, a regular grid (optionally only cells not
//! inside solid geometry), or a Quake 3 map's BSP leaves.

use std::path::Path;

use glam::Vec3;
use serde::Deserialize;
use sightline_core::scene::q3::BspData;
use sightline_core::trace::RayCaster;
use sightline_core::{Ray, Scene};

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
    bsp.leaves
        .iter()
        .filter(|l| l.cluster >= 0)
        .filter(|l| clusters.is_none_or(|c| c.contains(&(l.cluster as u32))))
        .filter_map(|l| {
            let b = l.bounds();
            let margin = Vec3::splat(Q3_LEAF_MARGIN).min(b.extent() * 0.25);
            let cell = ViewCell::aabb(b.min + margin, b.max - margin).ok()?;
            Some((l.cluster as u32, cell))
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
