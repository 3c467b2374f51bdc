//! The scene model's types: [`Scene`], its [`Object`]s and its [`UpAxis`]. Of `scene` it
//! imports only the Quake 3 map data a scene may hold (`q3/data.rs`), so the loaders, generators
//! and the builder take these types from here, never from the module's face (`mod.rs`), which
//! re-exports them and documents the id and memory rules.

use glam::Vec3;
use serde::Serialize;

use super::q3::data::BspData;
use crate::geometry::Aabb;

/// Which world axis points up (used for default camera `up` vectors and top-down views).
/// Formats that state it set it (glTF: Y, Quake 3: Z); for OBJ, PLY and STL, which do not,
/// the loader infers it (`up_axis.rs`) unless [`LoadOptions::up_axis`](super::LoadOptions)
/// says.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum UpAxis {
    /// +X is up (rare; only when a user says so).
    X,
    /// +Y is up (OBJ, glTF, PLY scans by convention).
    #[default]
    Y,
    /// +Z is up (Quake 3 maps, the city scenes, our procedural scenes, CAD and GIS exports).
    Z,
}

impl UpAxis {
    /// The up direction as a unit vector.
    pub fn vector(self) -> Vec3 {
        match self {
            UpAxis::X => Vec3::X,
            UpAxis::Y => Vec3::Y,
            UpAxis::Z => Vec3::Z,
        }
    }

    /// The axis' index: 0, 1 or 2.
    pub fn index(self) -> usize {
        match self {
            UpAxis::X => 0,
            UpAxis::Y => 1,
            UpAxis::Z => 2,
        }
    }

    /// The axis of index 0, 1 or 2.
    pub fn from_index(i: usize) -> Option<UpAxis> {
        [UpAxis::X, UpAxis::Y, UpAxis::Z].get(i).copied()
    }

    /// Its lower-case name: `x`, `y` or `z` (as `--up-axis` takes it).
    pub fn name(self) -> &'static str {
        ["x", "y", "z"][self.index()]
    }

    /// `x`, `y` or `z`, either case.
    pub fn parse(name: &str) -> Option<UpAxis> {
        match name {
            "x" | "X" => Some(UpAxis::X),
            "y" | "Y" => Some(UpAxis::Y),
            "z" | "Z" => Some(UpAxis::Z),
            _ => None,
        }
    }

    /// `p` in the Y-up frame of glTF: an exact rotation (a permutation with one sign change,
    /// no rounding) that takes this axis to +Y and keeps the frame right-handed. The sign
    /// change is `0.0 - v`, which makes a zero +0.0 (as `-v` would not): a loader's node
    /// transform turns -0.0 into +0.0 anyway, and the round trip through
    /// [`UpAxis::from_y_up`] then gives back every coordinate bit for bit except the sign of
    /// a -0.0.
    pub fn to_y_up(self, p: Vec3) -> Vec3 {
        match self {
            UpAxis::X => Vec3::new(0.0 - p.y, p.x, p.z),
            UpAxis::Y => p,
            UpAxis::Z => Vec3::new(p.x, p.z, 0.0 - p.y),
        }
    }

    /// The inverse of [`UpAxis::to_y_up`], also exact (zeros come out +0.0).
    pub fn from_y_up(self, p: Vec3) -> Vec3 {
        match self {
            UpAxis::X => Vec3::new(p.y, 0.0 - p.x, p.z),
            UpAxis::Y => p,
            UpAxis::Z => Vec3::new(p.x, 0.0 - p.z, p.y),
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
    pub bsp: Option<Box<BspData>>,
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
