//! The scene model: triangles over shared positions, grouped into objects, and the loaders and
//! generators that build it.
//!
//! # Triangle ids
//! A triangle's id is its index in [`Scene::triangles`]. Every loader emits triangles in the
//! order they appear in the file (per-format details in each loader module), and every generator
//! emits them in a fixed order derived only from its parameters and seed, so ids are the same on
//! every run and platform: a `.pvs` file made today indexes the same triangles tomorrow.
//! Degenerate triangles are kept so that ids stay stable; algorithms never report them visible.
//!
//! # Memory
//! 12 bytes per position, 12 bytes per triangle (indices) and 4 bytes per triangle (object id):
//! about 22 bytes per triangle for a closed mesh (half as many vertices as triangles) and 24 for
//! unwelded boxes (8 vertices per 12 triangles).

mod builder;
mod error;
pub mod gltf;
mod limits;
pub mod obj;
pub mod ply;
pub mod procedural;
pub mod q3;
mod spec;
pub mod stl;
mod text;

use glam::Vec3;
use serde::Serialize;

use crate::geometry::Aabb;

pub use builder::{CountingSink, SceneBuilder, TriangleSink};
pub use error::{LoadError, Location};
pub use spec::{load_file, open, LoadOptions, SceneSpec};

/// Which world axis points up (used for default camera `up` vectors and top-down views).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum UpAxis {
    /// +Y is up (OBJ, glTF, PLY scans by convention).
    #[default]
    Y,
    /// +Z is up (Quake 3 maps, the city scenes, our procedural scenes).
    Z,
}

impl UpAxis {
    /// The up direction as a unit vector.
    pub fn vector(self) -> Vec3 {
        match self {
            UpAxis::Y => Vec3::Y,
            UpAxis::Z => Vec3::Z,
        }
    }
}

/// A named group of triangles: what run-time culling moves, draws and tests, and what an engine
/// maps to one of its mesh instances. `docs/objects.md` tables, per format, how the loaders
/// set these fields, so an engine can find its own mesh from them.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Object {
    /// Name from the file or generator: glTF node path (`Root/House/Door.001`), OBJ `o`/`g`
    /// name (or material), Quake 3 `model0/cluster{c}/{shader}` (world) or `model{m}/{shader}`,
    /// PLY/STL file stem or STL `solid` name.
    pub name: String,
    /// First numeric identity: glTF = node index, Quake 3 = model number (0 = world); `None`
    /// for other formats and for generators.
    pub index: Option<u32>,
    /// Second numeric identity: glTF = primitive index within the node's mesh, Quake 3 =
    /// shader index (lump 1); `None` for other formats and for generators.
    pub part: Option<u32>,
}

impl Object {
    /// An object with only a name (`index` and `part` are `None`).
    pub fn named(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            index: None,
            part: None,
        }
    }
}

/// A triangle scene. See the module documentation for the id and memory rules.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Triangles as indices into `positions`; the index of a triangle is its id.
    pub triangles: Vec<[u32; 3]>,
    /// For each triangle, the index of its object in `objects`.
    pub object_of_triangle: Vec<u32>,
    /// The objects.
    pub objects: Vec<Object>,
    /// Which axis points up.
    pub up: UpAxis,
    /// Where the scene came from (path or procedural spec), for reports.
    pub source: String,
    /// Quake 3 map data (clusters, leaves, the compiled PVS) when loaded from a `.bsp`.
    pub bsp: Option<Box<q3::BspData>>,
    /// What the loader found questionable but loaded anyway, one sentence each (e.g. PLY faces
    /// with fewer than 3 indices, glTF primitives of points or lines, bytes after the last
    /// STL record): the file loaded, but maybe not as its author meant. Empty for generators.
    /// The CLI prints them on stderr.
    pub load_warnings: Vec<String>,
}

impl Scene {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// True when the scene has no triangles.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The three corners of triangle `id`.
    ///
    /// Panics when `id` or the triangle's indices are out of range; a scene that passed
    /// [`crate::validate::validate`] never has such indices.
    pub fn triangle(&self, id: u32) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[id as usize];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// The bounding box of all vertices that triangles reference.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for t in &self.triangles {
            for &i in t {
                if let Some(p) = self.positions.get(i as usize) {
                    b.grow(*p);
                }
            }
        }
        b
    }

    /// Approximate heap bytes held by the geometry (positions, indices, object ids).
    pub fn geometry_bytes(&self) -> usize {
        self.positions.capacity() * 12
            + self.triangles.capacity() * 12
            + self.object_of_triangle.capacity() * 4
    }

    /// A 64-bit hash of the triangle geometry (positions of every triangle's corners, in id
    /// order). Two scenes with the same hash index the same triangles; `.pvs` files store it.
    pub fn geometry_hash(&self) -> u64 {
        // FNV-1a over the corner bit patterns: stable across platforms and runs.
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |x: u32| {
            for byte in x.to_le_bytes() {
                h ^= u64::from(byte);
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        eat(self.triangles.len() as u32);
        for t in &self.triangles {
            for &i in t {
                match self.positions.get(i as usize) {
                    Some(p) => {
                        eat(p.x.to_bits());
                        eat(p.y.to_bits());
                        eat(p.z.to_bits());
                    }
                    None => eat(u32::MAX),
                }
            }
        }
        h
    }

    /// Triangle ids of each object, in id order.
    pub fn triangles_by_object(&self) -> Vec<Vec<u32>> {
        let mut out = vec![Vec::new(); self.objects.len()];
        for (t, &o) in self.object_of_triangle.iter().enumerate() {
            if let Some(list) = out.get_mut(o as usize) {
                list.push(t as u32);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_triangle() -> Scene {
        let mut b = SceneBuilder::new("test");
        b.begin_object("tri");
        let a = b.add_vertex(Vec3::ZERO);
        let c = b.add_vertex(Vec3::X);
        let d = b.add_vertex(Vec3::Y);
        b.add_triangle([a, c, d]);
        b.finish()
    }

    #[test]
    fn empty_scene_has_empty_bounds() {
        let s = Scene::default();
        assert!(s.is_empty());
        assert!(s.bounds().is_empty());
        assert!(s.triangles_by_object().is_empty());
    }

    #[test]
    fn hash_changes_with_geometry() {
        let a = one_triangle();
        let mut b = one_triangle();
        assert_eq!(a.geometry_hash(), b.geometry_hash());
        b.positions[1].x = 2.0;
        assert_ne!(a.geometry_hash(), b.geometry_hash());
    }

    #[test]
    fn triangle_corners_come_back() {
        let s = one_triangle();
        assert_eq!(s.triangle(0), [Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(s.triangles_by_object(), vec![vec![0]]);
    }
}
