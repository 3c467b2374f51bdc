//! Incremental scene construction shared by every loader and generator.

use glam::Vec3;

use super::types::{Object, Scene, UpAxis};

/// Where a generator puts its geometry: a [`SceneBuilder`], or a consumer that hands the
/// triangles on without keeping the scene (e.g. a streaming visibility pass). Vertex indices
/// are the sink's own: a sink may forget vertices between objects as long as
/// [`TriangleSink::vertex_count`] and [`TriangleSink::add_vertex`] agree with the indices
/// [`TriangleSink::add_triangle`] then receives.
pub trait TriangleSink {
    /// Sets the scene's up axis (sinks that do not care ignore it).
    fn set_up(&mut self, _up: UpAxis) {}

    /// Starts a new object; following triangles belong to it. The name is formatted lazily so
    /// sinks that drop names do not pay for them.
    fn begin_object(&mut self, name: std::fmt::Arguments<'_>);

    /// Starts a new object with the numeric identity of [`Object::index`] and
    /// [`Object::part`] (loaders of formats that have one). The default forwards to
    /// [`TriangleSink::begin_object`], for sinks that drop identities.
    fn begin_object_with(
        &mut self,
        name: std::fmt::Arguments<'_>,
        _index: Option<u32>,
        _part: Option<u32>,
    ) {
        self.begin_object(name);
    }

    /// The index the next vertex will get.
    fn vertex_count(&self) -> u32;

    /// Adds a vertex and returns its index.
    fn add_vertex(&mut self, p: Vec3) -> u32;

    /// Adds a triangle by vertex indices; its id is the number of triangles added before it.
    fn add_triangle(&mut self, t: [u32; 3]);
}

/// A sink that only counts what a generator emits: to size something, or to pass over part of
/// a generated stream without keeping it (the generator's state still advances).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CountingSink {
    /// Objects begun.
    pub objects: usize,
    /// Vertices added.
    pub vertices: u32,
    /// Triangles added.
    pub triangles: usize,
}

impl TriangleSink for CountingSink {
    fn begin_object(&mut self, _name: std::fmt::Arguments<'_>) {
        self.objects += 1;
    }

    fn vertex_count(&self) -> u32 {
        self.vertices
    }

    fn add_vertex(&mut self, _p: Vec3) -> u32 {
        self.vertices += 1;
        self.vertices - 1
    }

    fn add_triangle(&mut self, _t: [u32; 3]) {
        self.triangles += 1;
    }
}

impl TriangleSink for SceneBuilder {
    fn set_up(&mut self, up: UpAxis) {
        SceneBuilder::set_up(self, up);
    }

    fn begin_object(&mut self, name: std::fmt::Arguments<'_>) {
        SceneBuilder::begin_object(self, name.to_string());
    }

    fn begin_object_with(
        &mut self,
        name: std::fmt::Arguments<'_>,
        index: Option<u32>,
        part: Option<u32>,
    ) {
        SceneBuilder::push_object(
            self,
            Object {
                name: name.to_string(),
                index,
                part,
            },
        );
    }

    fn vertex_count(&self) -> u32 {
        SceneBuilder::vertex_count(self)
    }

    fn add_vertex(&mut self, p: Vec3) -> u32 {
        SceneBuilder::add_vertex(self, p)
    }

    fn add_triangle(&mut self, t: [u32; 3]) {
        SceneBuilder::add_triangle(self, t);
    }
}

/// Builds a [`Scene`] object by object. Triangles get ids in the order they are added.
#[derive(Debug)]
pub struct SceneBuilder {
    scene: Scene,
    current_object: Option<u32>,
}

impl SceneBuilder {
    /// An empty builder; `source` names the file or spec for reports.
    pub fn new(source: impl Into<String>) -> Self {
        Self {
            scene: Scene {
                source: source.into(),
                ..Scene::default()
            },
            current_object: None,
        }
    }

    /// Sets the scene's up axis.
    pub fn set_up(&mut self, up: UpAxis) {
        self.scene.up = up;
    }

    /// Reserves room for more vertices and triangles.
    pub fn reserve(&mut self, vertices: usize, triangles: usize) {
        self.scene.positions.reserve(vertices);
        self.scene.triangles.reserve(triangles);
        self.scene.object_of_triangle.reserve(triangles);
    }

    /// Starts a new object with only a name ([`Object::named`]); following triangles belong
    /// to it. Returns its index.
    pub fn begin_object(&mut self, name: impl Into<String>) -> u32 {
        self.push_object(Object::named(name))
    }

    /// Starts a new object with the given name and identity (loaders that have an
    /// [`Object::index`] / [`Object::part`]); following triangles belong to it. Returns its
    /// index.
    pub fn push_object(&mut self, object: Object) -> u32 {
        let id = self.scene.objects.len() as u32;
        self.scene.objects.push(object);
        self.current_object = Some(id);
        id
    }

    /// Makes the earlier object `id` (a value [`SceneBuilder::begin_object`] or
    /// [`SceneBuilder::push_object`] returned) current again: following triangles join it.
    /// Loaders use it when a file names the same object in several places (repeated OBJ
    /// groups, GLB nodes written by [`super::gltf::write_glb`]). Panics on an unknown id.
    pub fn resume_object(&mut self, id: u32) {
        assert!(
            (id as usize) < self.scene.objects.len(),
            "object {id} was never begun"
        );
        self.current_object = Some(id);
    }

    /// The objects begun so far, by id.
    pub fn objects(&self) -> &[Object] {
        &self.scene.objects
    }

    /// Renumbers the objects begun so far in ascending `key` order (`keys[id]` is object
    /// `id`'s key; ties keep their order) and updates every triangle's object. Loaders of
    /// files written by sightline use it to give objects back their original ids.
    pub(crate) fn sort_objects_by_key<K: Ord + Copy>(&mut self, keys: &[K]) {
        let n = self.scene.objects.len();
        assert_eq!(keys.len(), n, "one key per object");
        let mut numbered: Vec<(usize, Object)> = std::mem::take(&mut self.scene.objects)
            .into_iter()
            .enumerate()
            .collect();
        // Stable: ties keep their order.
        numbered.sort_by_key(|&(i, _)| keys[i]);
        let mut new_id = vec![0u32; n];
        for (k, (i, _)) in numbered.iter().enumerate() {
            new_id[*i] = k as u32;
        }
        self.scene.objects = numbered.into_iter().map(|(_, o)| o).collect();
        for o in &mut self.scene.object_of_triangle {
            *o = new_id[*o as usize];
        }
        self.current_object = self.current_object.map(|o| new_id[o as usize]);
    }

    /// Records a load warning ([`Scene::load_warnings`]).
    pub fn warn(&mut self, warning: impl Into<String>) {
        self.scene.load_warnings.push(warning.into());
    }

    /// Scene memory of the vertices and triangles so far, as [`super::limits`] counts it.
    pub(crate) fn geometry_bytes(&self) -> u64 {
        super::limits::geometry_bytes(
            self.scene.positions.len() as u64,
            self.scene.triangles.len() as u64,
        )
    }

    /// Number of vertices so far (the index the next vertex will get).
    pub fn vertex_count(&self) -> u32 {
        self.scene.positions.len() as u32
    }

    /// Number of triangles so far (the id the next triangle will get).
    pub fn triangle_count(&self) -> usize {
        self.scene.triangles.len()
    }

    /// Adds a vertex and returns its index.
    #[inline]
    pub fn add_vertex(&mut self, p: Vec3) -> u32 {
        self.scene.positions.push(p);
        self.scene.positions.len() as u32 - 1
    }

    /// Adds a triangle to the current object (an object named "default" is started if none
    /// is). Indices are not checked here; [`crate::validate::validate`] reports bad ones.
    #[inline]
    pub fn add_triangle(&mut self, t: [u32; 3]) {
        let object = match self.current_object {
            Some(o) => o,
            None => self.begin_default_object(),
        };
        self.scene.triangles.push(t);
        self.scene.object_of_triangle.push(object);
    }

    /// Starts the object "default" for a triangle added before any object. Cold and out of
    /// line: with it inlined, `add_triangle` grew too big to be inlined into the loaders'
    /// per-triangle loops, which cost about 10% of loading a large glTF mesh.
    #[cold]
    #[inline(never)]
    fn begin_default_object(&mut self) -> u32 {
        self.begin_object("default")
    }

    /// Adds an axis-aligned box as 8 vertices and 12 outward-facing triangles.
    pub fn add_box(&mut self, min: Vec3, max: Vec3) {
        add_box_faces(self, min, max, true);
    }

    /// Drops objects that received no triangle (renumbering the rest) and returns the scene.
    pub fn finish(mut self) -> Scene {
        let n = self.scene.objects.len();
        let mut used = vec![false; n];
        for &o in &self.scene.object_of_triangle {
            used[o as usize] = true;
        }
        if used.iter().all(|&u| u) {
            return self.scene;
        }
        let mut remap = vec![u32::MAX; n];
        let mut kept = Vec::new();
        for (i, obj) in std::mem::take(&mut self.scene.objects)
            .into_iter()
            .enumerate()
        {
            if used[i] {
                remap[i] = kept.len() as u32;
                kept.push(obj);
            }
        }
        for o in &mut self.scene.object_of_triangle {
            *o = remap[*o as usize];
        }
        self.scene.objects = kept;
        self.scene
    }
}

/// Adds an axis-aligned box to `sink` as 8 vertices and its faces as outward-facing triangle
/// pairs, in the order -x, +x, -y, +y, -z, +z; `with_bottom = false` leaves the -z face out
/// (boxes standing on a floor, Z up). The one place box topology is written down.
pub(crate) fn add_box_faces<S: TriangleSink + ?Sized>(
    sink: &mut S,
    min: Vec3,
    max: Vec3,
    with_bottom: bool,
) {
    let base = sink.vertex_count();
    for i in 0..8u32 {
        let pick = |bit: u32, lo: f32, hi: f32| if i & bit != 0 { hi } else { lo };
        sink.add_vertex(Vec3::new(
            pick(1, min.x, max.x),
            pick(2, min.y, max.y),
            pick(4, min.z, max.z),
        ));
    }
    // Corner index bits: x = 1, y = 2, z = 4. Counter-clockwise seen from outside.
    const FACES: [[u32; 4]; 6] = [
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
    ];
    for (k, [a, b, c, d]) in FACES.into_iter().enumerate() {
        if k == 4 && !with_bottom {
            continue;
        }
        sink.add_triangle([base + a, base + b, base + c]);
        sink.add_triangle([base + a, base + c, base + d]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_builder_gives_empty_scene() {
        let s = SceneBuilder::new("x").finish();
        assert!(s.is_empty() && s.objects.is_empty());
    }

    #[test]
    fn unused_objects_are_dropped() {
        let mut b = SceneBuilder::new("x");
        b.begin_object("empty");
        b.begin_object("full");
        let v = b.add_vertex(Vec3::ZERO);
        b.add_triangle([v, v, v]);
        let s = b.finish();
        assert_eq!(s.objects.len(), 1);
        assert_eq!(s.objects[0].name, "full");
        assert_eq!(s.object_of_triangle, vec![0]);
    }

    #[test]
    fn resumed_and_sorted_objects_keep_their_triangles() {
        let mut b = SceneBuilder::new("x");
        let v = b.add_vertex(Vec3::ZERO);
        let first = b.begin_object("first");
        b.add_triangle([v, v, v]);
        b.push_object(Object {
            name: "second".into(),
            index: Some(7),
            part: Some(1),
        });
        b.add_triangle([v, v, v]);
        b.resume_object(first);
        b.add_triangle([v, v, v]);
        b.sort_objects_by_key(&[2, 1]);
        // The current object follows the renumbering.
        b.add_triangle([v, v, v]);
        let s = b.finish();
        let names: Vec<_> = s.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["second", "first"]);
        assert_eq!((s.objects[0].index, s.objects[0].part), (Some(7), Some(1)));
        assert_eq!(s.objects[1], Object::named("first"));
        assert_eq!(s.object_of_triangle, vec![1, 0, 1, 1]);
    }

    #[test]
    fn box_faces_point_outwards() {
        let mut b = SceneBuilder::new("box");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        let s = b.finish();
        assert_eq!(s.triangle_count(), 12);
        for id in 0..12 {
            let [a, b, c] = s.triangle(id);
            let n = (b - a).cross(c - a);
            let centroid = (a + b + c) / 3.0;
            assert!(
                n.dot(centroid - Vec3::splat(0.5)) > 0.0,
                "triangle {id} faces inwards"
            );
        }
    }
}
