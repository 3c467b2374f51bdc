//! glTF 2.0 reader (`.gltf` and `.glb`) and GLB writer.
//!
//! Follows the Khronos glTF 2.0 specification (sections 3.5 scenes and nodes, 3.6 buffers and
//! accessors, 3.7 meshes, 4.4 GLB file format). The JSON is parsed and validated by the `gltf`
//! crate (`json::Root::from_slice` + `Document::from_json`, which is what `Gltf::from_slice`
//! does, split so that one reference its validator trusts can be checked first; see
//! `check_position_indices`); everything that touches binary data is done here with checked
//! arithmetic, so a malformed accessor or index is a [`LoadError`] naming the mesh and
//! primitive, never a panic:
//!
//! - GLB container: header and chunks are read here (errors name the byte offset), then the
//!   JSON chunk goes to the `gltf` crate.
//! - Buffers: the GLB `BIN` chunk, `data:...;base64,` URIs, or files relative to the directory
//!   of the `.gltf` file (URIs are taken as plain relative paths: no percent-decoding). Only
//!   buffers that a triangle primitive's `POSITION` or `indices` accessor uses are read, so
//!   images and animation data never are; each is cut to its `byteLength` (views must fit in
//!   that, not in whatever the file holds), and the sum of their `byteLength`s must fit in
//!   [`LoadOptions::max_scene_bytes`]. External files are read only up to `byteLength` bytes
//!   (a shorter file is an error), only when they are regular files (a FIFO or `/dev/zero` is
//!   an error, never read: checked before opening, and the open does not block), and only
//!   when their canonical path lies in the `.gltf` file's folder or below it, unless
//!   [`LoadOptions::allow_outside_refs`] is set; URIs with a scheme (`http:`, `file:`) are
//!   refused.
//! - Scene walk: the default scene, else scene 0, else every root node (a node that is no
//!   node's child), depth-first in node order. World transforms compose each node's matrix or
//!   TRS with its parents' (`world_from_node = world_from_parent * parent_from_node`). A node
//!   reached twice (the node graph must be a forest) is an error, so cycles cannot recurse.
//!   Rotation quaternions further than 1e-5 from unit length (in squared length) are
//!   normalised, as a scaled quaternion would scale the mesh by its squared length; unit ones
//!   are used as written, so the geometry of valid files stays bit for bit the same. A zero
//!   or non-finite rotation, translation, scale or matrix is an error naming the node.
//! - Each primitive of each node's mesh is appended with its positions transformed to world
//!   space (instanced meshes are duplicated, each with its node's transform); see "Objects".
//! - Primitives: `Triangles`, `TriangleStrip` (alternate winding kept) and `TriangleFan`;
//!   `Points` and `Lines*` are skipped without error. Non-indexed primitives use sequential
//!   indices. Positions must be `VEC3` `FLOAT`; indices `SCALAR` `UNSIGNED_BYTE/SHORT/INT`.
//!   Sparse accessors and accessors without a buffer view are rejected (an error, not silently
//!   wrong geometry). Primitives skipped for their mode or for having no positions are
//!   counted in a load warning, and so is a scene without triangles. The geometry is checked
//!   against [`LoadOptions::max_scene_bytes`] before each primitive is read (instancing a
//!   mesh in many nodes multiplies it).
//!
//! Triangle ids follow walk order, then primitive order, then index order.
//!
//! # Objects
//! One object per (node, primitive) pair that has triangle-mode primitives with positions, in
//! walk order, then primitive order (so object ids grow with triangle ids):
//! - [`Object::name`](super::Object::name) is the node path: the names of the node's
//!   ancestors from its scene root down to the node itself, joined with `/`
//!   (`Root/House/Door.001`); a node without a name (or with an empty one) is written
//!   `#<node index>` (`Root/#7`). Names are not escaped: a `/` inside a node name looks like a
//!   level of the path, and two sibling nodes with the same name have the same path, so
//!   `index` is the identity to rely on.
//! - [`Object::index`](super::Object::index) is the node index (in the file's `nodes` array),
//!   [`Object::part`](super::Object::part) the primitive index in the node's mesh (the
//!   primitive's own index, counting skipped ones).
//!   A mesh with several primitives gives several objects with the same name.
//!
//! Files written by [`write_glb`] carry each object in node `extras`:
//! `"extras": {"sightline": {"object": k, "name": "...", "index": i, "part": p}}` (`index`
//! and `part` may be `null`). Every primitive of a node with such a tag joins object `k`
//! (several nodes may share a `k`: the writer emits one node per run of consecutive
//! triangles), named `name` (the node path when absent) with the tag's `index` and `part`,
//! not the node's; tagged objects are numbered in ascending `k` order, untagged ones after
//! them in walk order. A node whose `extras.sightline` does not have this shape is loaded as
//! an ordinary node.
//!
//! # Files
//! This file is the module's face: the docs and the entry points. The rooms:
//! - `glb.rs`: the GLB container, split when reading and assembled when writing;
//! - `json.rs`: the JSON document, parsed and validated, with the checks gltf-json misses;
//! - `buffers.rs`: the bytes of the buffers geometry needs;
//! - `primitive.rs`: one primitive's positions, indices and triangles;
//! - `build.rs`: the scene walk, node transforms and objects;
//! - `extras.rs`: the `extras.sightline` tags that the writer writes and the walk reads;
//! - `write.rs`: [`write_glb`].

mod buffers;
mod build;
mod extras;
mod glb;
mod json;
mod primitive;
mod write;

use std::path::Path;

use super::error::{LoadError, Location};
use super::options::LoadOptions;
use super::types::Scene;
use buffers::load_buffers;
use build::build_scene;
use glb::{is_glb_name, split_glb, GLB_MAGIC};
use json::parse_document;
pub use write::write_glb;

/// Loads a glTF 2.0 file (`.gltf` JSON or `.glb` binary) from its (decompressed) bytes with the
/// default [`LoadOptions`]. `path` is used for error messages and to find external buffer
/// files next to it.
pub fn load(path: &Path, bytes: &[u8]) -> Result<Scene, LoadError> {
    load_with(path, bytes, &LoadOptions::default())
}

/// [`load`] with the limits of `options` (memory, and which external files may be read).
pub fn load_with(path: &Path, bytes: &[u8], options: &LoadOptions) -> Result<Scene, LoadError> {
    let (json, blob) = if bytes.starts_with(GLB_MAGIC) {
        let (json, blob) = split_glb(path, bytes)?;
        (json, blob)
    } else if is_glb_name(path) {
        return Err(LoadError::parse(
            path,
            Location::Byte(0),
            "not a GLB file (does not start with 'glTF')",
        ));
    } else {
        (bytes, None)
    };
    let document = parse_document(path, json)?;
    let buffers = load_buffers(path, &document, blob, options)?;
    build_scene(path, &document, &buffers, options)
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::super::builder::SceneBuilder;
    use super::*;

    fn load_gltf(text: &str) -> Result<Scene, LoadError> {
        load(Path::new("dir/model.gltf"), text.as_bytes())
    }

    /// base64 of 3 f32 VEC3 positions (0,0,0) (1,0,0) (0,1,0) followed by u16 indices 0 1 2
    /// and 2 bytes of padding: 42 bytes.
    fn triangle_buffer_uri() -> String {
        let mut b = Vec::new();
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for i in [0u16, 1, 2] {
            b.extend_from_slice(&i.to_le_bytes());
        }
        b.extend_from_slice(&[0, 0]);
        format!("data:application/octet-stream;base64,{}", base64::encode(b))
    }

    /// A node hierarchy: parent translated by +10 x, child scaled by 2, both with the mesh.
    fn two_node_gltf(mode: u32, index_count: usize) -> String {
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"name":"parent","mesh":0,"translation":[10,0,0],"children":[1]}},
                     {{"mesh":0,"scale":[2,2,2]}}],
            "meshes":[{{"name":"tri","primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":{mode}}}]}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5123,"count":{index_count},"type":"SCALAR"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
            "buffers":[{{"byteLength":42,"uri":"{}"}}]}}"#,
            triangle_buffer_uri()
        )
    }

    fn two_objects() -> Scene {
        let mut b = SceneBuilder::new("x");
        let a = b.begin_object("a");
        for p in [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.25, -3.0, 7.5)] {
            b.add_vertex(p);
        }
        b.add_triangle([0, 1, 2]);
        b.begin_object("b");
        b.add_triangle([3, 2, 1]);
        let mut s = b.finish();
        s.triangles.push([0, 3, 1]);
        s.object_of_triangle.push(a);
        s
    }

    #[test]
    fn node_transforms_compose() {
        let s = load_gltf(&two_node_gltf(4, 3)).unwrap();
        assert_eq!(s.triangle_count(), 2);
        let names: Vec<_> = s.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["parent", "parent/#1"]);
        let ids: Vec<_> = s.objects.iter().map(|o| (o.index, o.part)).collect();
        assert_eq!(ids, [(Some(0), Some(0)), (Some(1), Some(0))]);
        assert_eq!(s.triangle(0)[1], Vec3::new(11.0, 0.0, 0.0));
        assert_eq!(s.triangle(1)[1], Vec3::new(12.0, 0.0, 0.0));
    }

    /// `Root` (no mesh) > `House` (no mesh) > `Door.001` (mesh 1: triangle, points, triangle)
    /// and `Root` > unnamed node 3 (mesh 0), with `extras` on node 2 (not a sightline tag).
    fn hierarchy_gltf(door_extras: &str) -> String {
        let tri = r#"{"attributes":{"POSITION":0},"indices":1,"mode":4}"#;
        let points = r#"{"attributes":{"POSITION":0},"mode":0}"#;
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"name":"Root","children":[1,3]}},
                     {{"name":"House","children":[2],"translation":[0,0,5]}},
                     {{"name":"Door.001","mesh":1,"extras":{door_extras}}},
                     {{"mesh":0,"translation":[1,0,0]}}],
            "meshes":[{{"primitives":[{tri}]}},
                      {{"name":"door mesh","primitives":[{tri},{points},{tri}]}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
            "buffers":[{{"byteLength":42,"uri":"{}"}}]}}"#,
            triangle_buffer_uri()
        )
    }

    fn identities(s: &Scene) -> Vec<(&str, Option<u32>, Option<u32>)> {
        s.objects
            .iter()
            .map(|o| (o.name.as_str(), o.index, o.part))
            .collect()
    }

    #[test]
    fn objects_are_node_paths_per_primitive() {
        let s = load_gltf(&hierarchy_gltf(r#"{"sightline":"not a tag"}"#)).unwrap();
        assert_eq!(
            identities(&s),
            [
                ("Root/House/Door.001", Some(2), Some(0)),
                ("Root/House/Door.001", Some(2), Some(2)),
                ("Root/#3", Some(3), Some(0)),
            ]
        );
        // Ids in walk order, then primitive order: the door's two triangles, then node 3's.
        assert_eq!(s.object_of_triangle, [0, 1, 2]);
        assert_eq!(s.triangle(1)[1], Vec3::new(1.0, 0.0, 5.0));
        assert_eq!(s.triangle(2)[1], Vec3::new(2.0, 0.0, 0.0));
    }

    #[test]
    fn sightline_tag_names_the_object() {
        let tag = r#"{"sightline":{"object":7,"name":"door","index":40,"part":null}}"#;
        let s = load_gltf(&hierarchy_gltf(tag)).unwrap();
        // Both door primitives join the tagged object, which comes first; node 3 after it.
        assert_eq!(
            identities(&s),
            [("door", Some(40), None), ("Root/#3", Some(3), Some(0))]
        );
        assert_eq!(s.object_of_triangle, [0, 0, 1]);
    }

    #[test]
    fn glb_round_trip_keeps_objects() {
        let mut scene = two_objects();
        scene.objects[0].index = Some(9);
        scene.objects[1].part = Some(0);
        // Object 1's triangle first, so tag order and walk order differ.
        scene.triangles.swap(0, 1);
        scene.object_of_triangle.swap(0, 1);
        let mut out = Vec::new();
        write_glb(&scene, &mut out).unwrap();
        let back = load(Path::new("back.glb"), &out).unwrap();
        assert_eq!(back.objects, scene.objects);
        assert_eq!(back.object_of_triangle, scene.object_of_triangle);
        assert_eq!(back.triangles.len(), 3);
        for id in 0..3u32 {
            assert_eq!(back.triangle(id), scene.triangle(id));
        }
    }

    #[test]
    fn points_are_skipped() {
        let s = load_gltf(&two_node_gltf(0, 3)).unwrap();
        assert!(s.is_empty());
    }

    #[test]
    fn accessor_past_view_names_mesh_and_primitive() {
        let e = load_gltf(&two_node_gltf(4, 4)).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("mesh 0, primitive 0"), "{msg}");
    }

    #[test]
    fn glb_round_trip_keeps_ids_and_names() {
        let scene = two_objects();
        let mut out = Vec::new();
        write_glb(&scene, &mut out).unwrap();
        assert_eq!(out.len() % 4, 0);
        let back = load(Path::new("back.glb"), &out).unwrap();
        assert_eq!(back.triangle_count(), 3);
        for id in 0..3u32 {
            assert_eq!(back.triangle(id), scene.triangle(id));
            let name = |s: &Scene| {
                s.objects[s.object_of_triangle[id as usize] as usize]
                    .name
                    .clone()
            };
            assert_eq!(name(&back), name(&scene));
        }
    }

    #[test]
    fn glb_of_empty_scene_loads_empty() {
        let mut out = Vec::new();
        write_glb(&Scene::default(), &mut out).unwrap();
        assert!(load(Path::new("e.glb"), &out).unwrap().is_empty());
    }

    #[test]
    fn empty_glb_is_error_at_offset_zero() {
        let e = load(Path::new("x.glb"), b"").unwrap_err();
        assert!(e.to_string().contains("byte offset 0"), "{e}");
    }

    #[test]
    fn truncated_glb_names_offset() {
        let mut out = Vec::new();
        write_glb(&two_objects(), &mut out).unwrap();
        out.truncate(out.len() - 8);
        let e = load(Path::new("x.glb"), &out).unwrap_err();
        assert!(e.to_string().contains("byte offset 8"), "{e}");
    }

    #[test]
    fn bad_json_names_line() {
        let e = load_gltf("{\n\"asset\": [\n").unwrap_err();
        assert!(e.to_string().contains("line"), "{e}");
    }

    /// The 42 bytes of [`triangle_buffer_uri`].
    fn triangle_buffer() -> Vec<u8> {
        let uri = triangle_buffer_uri();
        base64::decode(uri.split_once(',').unwrap().1).unwrap()
    }

    /// One node (with `node_extra` members) and one triangle whose buffer 0 has `uri` and
    /// `byte_length`; buffer 1 (`unused_uri`) is used by no accessor.
    fn one_triangle_gltf(
        node_extra: &str,
        uri: &str,
        byte_length: usize,
        unused_uri: &str,
    ) -> String {
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0{node_extra}}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                         {{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
            "buffers":[{{"byteLength":{byte_length},"uri":"{uri}"}},{{"byteLength":8,"uri":"{unused_uri}"}}]}}"#
        )
    }

    /// Writes `text` as `dir/model.gltf` and `triangle_buffer()` as `dir/tri.bin`, loads it.
    fn load_in_dir(dir: &Path, text: &str, options: &LoadOptions) -> Result<Scene, LoadError> {
        std::fs::write(dir.join("tri.bin"), triangle_buffer()).unwrap();
        let path = dir.join("model.gltf");
        std::fs::write(&path, text).unwrap();
        load_with(&path, text.as_bytes(), options)
    }

    #[test]
    fn scaled_rotation_is_normalised() {
        // [0, 0, 10, 0] is 180 degrees about z, scaled by 100 if used as is.
        let text = one_triangle_gltf(r#","rotation":[0,0,10,0]"#, &triangle_buffer_uri(), 42, "x");
        let s = load_gltf(&text).unwrap();
        let corner = s.triangle(0)[1];
        assert!((corner - Vec3::NEG_X).length() < 1e-6, "{corner}");
    }

    #[test]
    fn zero_rotation_is_error() {
        let text = one_triangle_gltf(r#","rotation":[0,0,0,0]"#, &triangle_buffer_uri(), 42, "x");
        let e = load_gltf(&text).unwrap_err();
        assert!(e.to_string().contains("node 0"), "{e}");
    }

    #[test]
    fn view_past_byte_length_is_error() {
        // The data URI holds 42 bytes, but the buffer declares 40: the index view ends at 42.
        let text = one_triangle_gltf("", &triangle_buffer_uri(), 40, "x");
        let e = load_gltf(&text).unwrap_err();
        assert!(e.to_string().contains("exceeds its buffer"), "{e}");
    }

    #[test]
    fn unused_buffer_is_never_read() {
        let dir = tempfile::tempdir().unwrap();
        let text = one_triangle_gltf("", "tri.bin", 42, "/nonexistent/image.bin");
        let s = load_in_dir(dir.path(), &text, &LoadOptions::default()).unwrap();
        assert_eq!(s.triangle_count(), 1);
    }

    #[test]
    fn external_buffer_reads_only_byte_length() {
        let dir = tempfile::tempdir().unwrap();
        let text = one_triangle_gltf("", "tri.bin", 42, "x");
        assert_eq!(
            load_in_dir(dir.path(), &text, &LoadOptions::default())
                .unwrap()
                .triangle_count(),
            1
        );
        let text = one_triangle_gltf("", "tri.bin", 50, "x");
        let e = load_in_dir(dir.path(), &text, &LoadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("byteLength is 50"), "{e}");
    }

    #[test]
    fn outside_refs_need_the_option() {
        let dir = tempfile::tempdir().unwrap();
        let inner = dir.path().join("inner");
        std::fs::create_dir(&inner).unwrap();
        std::fs::write(dir.path().join("up.bin"), triangle_buffer()).unwrap();
        let absolute = dir.path().join("up.bin").display().to_string();
        for uri in ["../up.bin", absolute.as_str()] {
            let text = one_triangle_gltf("", uri, 42, "x");
            let e = load_in_dir(&inner, &text, &LoadOptions::default()).unwrap_err();
            assert!(matches!(e, LoadError::Limit { .. }), "{uri}: {e}");
            assert!(e.to_string().contains("--allow-outside-refs"), "{e}");
            let allowed = LoadOptions {
                allow_outside_refs: true,
                ..LoadOptions::default()
            };
            let s = load_in_dir(&inner, &text, &allowed).unwrap();
            assert_eq!(s.triangle_count(), 1, "{uri}");
        }
    }

    #[test]
    fn uri_with_scheme_is_error() {
        let text = one_triangle_gltf("", "file:///etc/passwd", 42, "x");
        let e = load_gltf(&text).unwrap_err();
        assert!(e.to_string().contains("scheme"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn devices_and_fifos_are_not_read() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo.bin");
        let name = std::ffi::CString::new(fifo.display().to_string()).unwrap();
        // SAFETY: `name` is a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(name.as_ptr(), 0o600) }, 0);
        std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.bin")).unwrap();
        let allowed = LoadOptions {
            allow_outside_refs: true,
            ..LoadOptions::default()
        };
        for uri in ["fifo.bin", "zero.bin", "/dev/zero"] {
            let text = one_triangle_gltf("", uri, 42, "x");
            let e = load_in_dir(dir.path(), &text, &allowed).unwrap_err();
            assert!(e.to_string().contains("not a regular file"), "{uri}: {e}");
        }
    }

    #[test]
    fn buffers_above_the_limit_are_error() {
        let text = one_triangle_gltf("", &triangle_buffer_uri(), 42, "x");
        let options = LoadOptions {
            max_scene_bytes: 41,
            ..LoadOptions::default()
        };
        let e = load_with(Path::new("m.gltf"), text.as_bytes(), &options).unwrap_err();
        assert!(matches!(e, LoadError::Limit { .. }), "{e}");
    }

    #[test]
    fn points_only_scene_warns() {
        let s = load_gltf(&two_node_gltf(0, 3)).unwrap();
        assert!(
            s.load_warnings
                .iter()
                .any(|w| w.contains("points or lines")),
            "{:?}",
            s.load_warnings
        );
    }

    #[test]
    fn index_past_u32_is_error_not_index_0() {
        let text = one_triangle_gltf("", &triangle_buffer_uri(), 42, "x")
            .replace(r#""mesh":0"#, r#""mesh":4294967296"#);
        let e = load_gltf(&text).unwrap_err();
        assert!(e.to_string().contains("nodes[0].mesh"), "{e}");
    }

    #[test]
    fn node_cycle_is_error() {
        let text = r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],
            "nodes":[{"children":[1]},{"children":[0]}]}"#;
        assert!(load_gltf(text).is_err());
    }
}
