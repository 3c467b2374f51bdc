//! The GLB writer: a scene as one mesh and one node per run of consecutive triangles of the
//! same object, tagged so that the loader gives back the same triangle ids, objects and up
//! axis (module docs, "Objects").

use std::io::{self, Write};
use std::ops::Range;

use glam::Vec3;

use super::super::types::{Scene, UpAxis};
use super::glb::write_chunks;

/// Writes `scene` as a binary glTF 2.0 file (GLB): one mesh and one root node per run of
/// consecutive triangles of the same object (both named after the object), each with its own
/// `f32` VEC3 positions (only the vertices the run uses) and `u32` indices, in triangle-id
/// order, so loading the result gives the same triangle ids. Each node's
/// `extras.sightline = {"object", "name", "index", "part"}` names the object it belongs to
/// (module docs, "Objects"), so loading the result with [`load`](super::load) also gives the
/// same objects: ids, names, `index` and `part`. Objects without triangles are not written.
///
/// glTF is Y-up: a scene with another up axis is written turned so that its up axis is +Y (an
/// exact rotation, [`UpAxis::to_y_up`]), so other tools show it upright, and the scene's
/// `extras.sightline.up` names the original axis, so [`load`](super::load) turns it back: the
/// same coordinates, geometry hash and up axis as before writing.
pub fn write_glb(scene: &Scene, w: &mut impl Write) -> io::Result<()> {
    let mut parts = Parts::default();
    let n = scene.triangles.len();
    let mut start = 0;
    let mut remap = vec![u32::MAX; scene.positions.len()];
    while start < n {
        let object = object_of(scene, start);
        let mut end = start + 1;
        while end < n && object_of(scene, end) == object {
            end += 1;
        }
        let run = compact_run(scene, start..end, &mut remap)?;
        parts.push_run(scene, object, &run);
        start = end;
    }
    let (root, bin) = parts.finish(scene.up);
    let json = serde_json::to_vec(&root).map_err(io::Error::other)?;
    write_chunks(json, bin, w)
}

/// The object of triangle `id` (object 0 when the scene does not say).
fn object_of(scene: &Scene, id: usize) -> u32 {
    scene.object_of_triangle.get(id).copied().unwrap_or(0)
}

/// One run of triangles with its vertices compacted: `used` are the scene vertices it uses, in
/// first-use order, and `indices` its corners as indices into `used`.
struct Run {
    used: Vec<u32>,
    indices: Vec<u32>,
}

/// Compacts the vertices of the triangles `ids`, in first-use order. `remap` (scene vertex to
/// run vertex, `u32::MAX` = not yet used) is all `u32::MAX` before and after.
fn compact_run(scene: &Scene, ids: Range<usize>, remap: &mut [u32]) -> io::Result<Run> {
    let mut used: Vec<u32> = Vec::new();
    let mut indices: Vec<u32> = Vec::with_capacity(3 * ids.len());
    for t in &scene.triangles[ids] {
        for &i in t {
            let slot = remap.get_mut(i as usize).ok_or_else(|| {
                io::Error::new(io::ErrorKind::InvalidInput, "triangle index out of range")
            })?;
            if *slot == u32::MAX {
                *slot = used.len() as u32;
                used.push(i);
            }
            indices.push(*slot);
        }
    }
    for &i in &used {
        remap[i as usize] = u32::MAX;
    }
    Ok(Run { used, indices })
}

/// The GLB being assembled: the BIN chunk and the JSON arrays that index into it.
#[derive(Default)]
struct Parts {
    bin: Vec<u8>,
    meshes: Vec<serde_json::Value>,
    nodes: Vec<serde_json::Value>,
    accessors: Vec<serde_json::Value>,
    views: Vec<serde_json::Value>,
}

impl Parts {
    /// Appends one run of triangles of `object`: its positions and indices to the BIN chunk,
    /// and a buffer view and accessor for each, a mesh and a tagged node to the JSON.
    fn push_run(&mut self, scene: &Scene, object: u32, run: &Run) {
        let position_offset = self.bin.len();
        let (min, max) = self.push_positions(scene, &run.used);
        let index_offset = self.bin.len();
        for i in &run.indices {
            self.bin.extend_from_slice(&i.to_le_bytes());
        }
        let run_index = self.meshes.len();
        self.views.push(serde_json::json!({
            "buffer": 0, "byteOffset": position_offset,
            "byteLength": index_offset - position_offset, "target": 34962
        }));
        self.views.push(serde_json::json!({
            "buffer": 0, "byteOffset": index_offset,
            "byteLength": self.bin.len() - index_offset, "target": 34963
        }));
        self.accessors.push(serde_json::json!({
            "bufferView": 2 * run_index, "componentType": 5126, "count": run.used.len(),
            "type": "VEC3", "min": min.to_array(), "max": max.to_array()
        }));
        self.accessors.push(serde_json::json!({
            "bufferView": 2 * run_index + 1, "componentType": 5125, "count": run.indices.len(),
            "type": "SCALAR"
        }));
        let (name, index, part) = scene
            .objects
            .get(object as usize)
            .map_or(("default", None, None), |o| {
                (o.name.as_str(), o.index, o.part)
            });
        self.meshes.push(serde_json::json!({
            "name": name,
            "primitives": [{
                "attributes": { "POSITION": 2 * run_index }, "indices": 2 * run_index + 1,
                "mode": 4
            }]
        }));
        self.nodes.push(serde_json::json!({
            "name": name, "mesh": run_index,
            "extras": { "sightline": {
                "object": object, "name": name, "index": index, "part": part
            } }
        }));
    }

    /// Appends the positions of the scene vertices `used`, turned Y-up, to the BIN chunk and
    /// returns their bounds (the accessor's `min` and `max`).
    fn push_positions(&mut self, scene: &Scene, used: &[u32]) -> (Vec3, Vec3) {
        let mut min = Vec3::splat(f32::MAX);
        let mut max = Vec3::splat(f32::MIN);
        for &i in used {
            // glTF is Y-up: other scenes are turned (exactly) and the scene's extras say from
            // which axis, so `load` turns them back.
            let p = scene.up.to_y_up(scene.positions[i as usize]);
            // min/max must be numbers in JSON; non-finite coordinates are left out of them.
            if p.is_finite() {
                min = min.min(p);
                max = max.max(p);
            }
            for c in p.to_array() {
                self.bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        if min.x > max.x {
            (min, max) = (Vec3::ZERO, Vec3::ZERO);
        }
        (min, max)
    }

    /// The JSON document (for a scene whose up axis is `up`) and the BIN chunk.
    fn finish(self, up: UpAxis) -> (serde_json::Value, Vec<u8>) {
        // glTF forbids other empty arrays, so an empty scene is `scenes[0]` with no nodes (the
        // `gltf` crate insists on the `nodes` key) and nothing else.
        let mut root = serde_json::json!({
            "asset": { "version": "2.0", "generator": "sightline" },
            "scene": 0,
            "scenes": [{ "nodes": [] }],
        });
        if up != UpAxis::Y {
            root["scenes"][0]["extras"] = serde_json::json!({ "sightline": { "up": up.name() } });
        }
        if !self.meshes.is_empty() {
            root["scenes"][0]["nodes"] = (0..self.meshes.len()).collect::<Vec<_>>().into();
            root["nodes"] = self.nodes.into();
            root["meshes"] = self.meshes.into();
            root["accessors"] = self.accessors.into();
            root["bufferViews"] = self.views.into();
            root["buffers"] = serde_json::json!([{ "byteLength": self.bin.len() }]);
        }
        (root, self.bin)
    }
}
