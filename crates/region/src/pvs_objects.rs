//! The object table of a version-2 `.pvs` file (layout in `docs/pvs-format.md`): the scene's
//! objects (name, format-specific index and part, bounds) and which object every triangle
//! belongs to, from which the writer derives each cell's visible-object set: an object is
//! visible from a cell when any of its triangles is.

use glam::Vec3;
use sightline_core::{Scene, TriangleSet};

/// One object as an engine sees it (see `docs/objects.md` for each format's names).
#[derive(Clone, Debug, PartialEq)]
pub struct PvsObject {
    /// The object's name from the scene (glTF node path, OBJ group, ...).
    pub name: String,
    /// glTF node index, Quake 3 model number; `None` elsewhere.
    pub index: Option<u32>,
    /// glTF primitive index, Quake 3 shader index; `None` elsewhere.
    pub part: Option<u32>,
    /// Minimum corner of its triangles' bounds (`+inf` when it has none).
    pub bounds_min: Vec3,
    /// Maximum corner (`-inf` when it has none).
    pub bounds_max: Vec3,
}

/// The objects of the scene a file was baked for, and the object of every triangle.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectTable {
    /// The objects, in the scene's order.
    pub objects: Vec<PvsObject>,
    /// The object of each triangle, in id order.
    pub object_of_triangle: Vec<u32>,
}

/// Why an object table does not fit a scene.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ObjectTableError {
    /// The table maps another number of triangles than the scene has.
    #[error("the object table maps {mapped} triangles, the scene has {triangles}")]
    TriangleCount {
        /// Triangles the table maps.
        mapped: usize,
        /// Triangles of the scene.
        triangles: usize,
    },
    /// A triangle names an object past the table's objects.
    #[error("triangle {triangle} names an object >= the {objects} objects")]
    ObjectPastEnd {
        /// The triangle.
        triangle: usize,
        /// Objects in the table.
        objects: usize,
    },
    /// An object's index or part is `u32::MAX`, which the file format reserves for "none".
    #[error("object {object}: index or part {} is reserved", u32::MAX)]
    ReservedNumber {
        /// The object.
        object: usize,
    },
}

impl ObjectTable {
    /// The scene's objects with the bounds of their triangles.
    pub fn from_scene(scene: &Scene) -> Self {
        let mut objects: Vec<PvsObject> = scene
            .objects
            .iter()
            .map(|o| PvsObject {
                name: o.name.clone(),
                index: o.index,
                part: o.part,
                bounds_min: Vec3::INFINITY,
                bounds_max: Vec3::NEG_INFINITY,
            })
            .collect();
        for (t, &o) in scene.object_of_triangle.iter().enumerate() {
            let Some(object) = objects.get_mut(o as usize) else {
                continue;
            };
            for i in scene.triangles[t] {
                if let Some(&p) = scene.positions.get(i as usize) {
                    object.bounds_min = object.bounds_min.min(p);
                    object.bounds_max = object.bounds_max.max(p);
                }
            }
        }
        Self {
            objects,
            object_of_triangle: scene.object_of_triangle.clone(),
        }
    }

    /// Checks the table against a scene of `triangle_count` triangles; the error names the
    /// first problem.
    pub fn check(&self, triangle_count: usize) -> Result<(), ObjectTableError> {
        if self.object_of_triangle.len() != triangle_count {
            return Err(ObjectTableError::TriangleCount {
                mapped: self.object_of_triangle.len(),
                triangles: triangle_count,
            });
        }
        let k = self.objects.len();
        if let Some(t) = self
            .object_of_triangle
            .iter()
            .position(|&o| o as usize >= k)
        {
            return Err(ObjectTableError::ObjectPastEnd {
                triangle: t,
                objects: k,
            });
        }
        if let Some((i, _)) = self
            .objects
            .iter()
            .enumerate()
            .find(|(_, o)| o.index == Some(u32::MAX) || o.part == Some(u32::MAX))
        {
            return Err(ObjectTableError::ReservedNumber { object: i });
        }
        Ok(())
    }

    /// The objects visible from a cell whose visible triangles are `triangles`.
    pub fn visible_objects(&self, triangles: &TriangleSet) -> TriangleSet {
        let mut objects = TriangleSet::with_capacity(self.objects.len());
        for t in triangles.ones() {
            if let Some(&o) = self.object_of_triangle.get(t) {
                objects.insert(o as usize);
            }
        }
        objects
    }

    /// The objects that own a triangle of `bound` and are not in `objects` (a cell's visible
    /// objects): what a conservative bound adds to the cell's object set.
    pub fn objects_added(&self, objects: &TriangleSet, bound: &TriangleSet) -> TriangleSet {
        let mut added = self.visible_objects(bound);
        added.difference_with(objects);
        added
    }

    /// The triangle runs in id order, as (object, number of consecutive triangles).
    pub fn runs(&self) -> Vec<(u32, u32)> {
        let mut runs: Vec<(u32, u32)> = Vec::new();
        for &o in &self.object_of_triangle {
            match runs.last_mut() {
                Some((object, count)) if *object == o => *count += 1,
                _ => runs.push((o, 1)),
            }
        }
        runs
    }
}
