//! Wavefront OBJ reader and writer (geometry only: `v`, `f`, `o`, `g`, `usemtl`).
//!
//! Follows the geometry part of the Wavefront "Object Files (.obj)" specification (Appendix B1
//! of the Advanced Visualizer manual): 1-based vertex indices, negative indices relative to the
//! last vertex read so far, face corners written `v`, `v/vt`, `v//vn` or `v/vt/vn`.
//!
//! # Why a hand-written parser and not `tobj`
//! `tobj` was the first choice, but three of its behaviours contradict what sightline needs:
//! its errors carry no line number (`FaceParseError` for a whole file); it only starts a new
//! model on `usemtl` when the material was found in an `.mtl` file, and the shipped scenes
//! have no `.mtl` files, so `buildings/fzk_haus.obj.gz` (177 `usemtl` runs, no `o`/`g`) would
//! load as a single object; and it re-indexes vertices per model through a hash map, which
//! costs time we do not need. The subset of OBJ that carries triangle geometry is small, so
//! this module parses it directly in one pass over the bytes.
//!
//! # What the loader produces
//! - Positions: every `v` line, in file order (indices in the scene are the OBJ indices minus
//!   one). Vertices are shared by all objects; unreferenced vertices are kept.
//! - Triangles: `f` lines in file order; a polygon `f a b c d ...` becomes the fan
//!   `(a b c) (a c d) ...`, so triangle ids follow the face order of the file. A face with
//!   fewer than 3 corners is an error.
//! - Objects: a new object starts at the first face after an `o`, `g` or `usemtl` line. It is
//!   named after the last `o`/`g` name, or after the material when the file has no `o`/`g`
//!   (as fzk_haus), or `default`. No material is ever read: `mtllib` is ignored, and so are
//!   `vt`, `vn`, `l`, `p`, `s` and unknown statements.
//! - Line continuation with `\` is not supported (no shipped file uses it).
//!
//! Errors name the file and the 1-based line.

use std::io::{self, Write};
use std::path::Path;

use glam::Vec3;

use super::{LoadError, Location, Scene, SceneBuilder};

/// Loads an OBJ file from its (decompressed) bytes; `path` is for error messages.
///
/// A file without faces gives an empty scene, not an error. See the module documentation for
/// how faces and groups become triangles and objects.
pub fn load(path: &Path, bytes: &[u8]) -> Result<Scene, LoadError> {
    let mut builder = SceneBuilder::new(path.display().to_string());
    // About 30 bytes per `v` or `f` line in typical files; a hint, never a limit.
    builder.reserve(bytes.len() / 64, bytes.len() / 64);

    let mut group: Option<String> = None;
    let mut material: Option<String> = None;
    let mut new_object = true;
    let mut corners: Vec<u32> = Vec::with_capacity(8);

    for (line_index, raw_line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line_no = line_index + 1;
        let err = |message: String| LoadError::parse(path, Location::Line(line_no), message);
        let line = String::from_utf8_lossy(raw_line);
        let line = line.trim();
        let (keyword, rest) = match line.split_once(|c: char| c.is_ascii_whitespace()) {
            Some((k, r)) => (k, r.trim()),
            None => (line, ""),
        };
        match keyword {
            "v" => {
                let mut words = rest.split_ascii_whitespace();
                let mut xyz = [0.0f32; 3];
                for (axis, value) in xyz.iter_mut().enumerate() {
                    let word = words
                        .next()
                        .ok_or_else(|| err(format!("vertex needs 3 coordinates, found {axis}")))?;
                    *value = word
                        .parse()
                        .map_err(|_| err(format!("vertex coordinate '{word}' is not a number")))?;
                }
                // A 4th value (w) or vertex colours may follow; neither changes the position
                // for polygonal geometry, so they are ignored.
                builder.add_vertex(Vec3::from_array(xyz));
            }
            "f" => {
                let count = builder.vertex_count();
                corners.clear();
                for word in rest.split_ascii_whitespace() {
                    corners.push(resolve_index(word, count).map_err(&err)?);
                }
                if corners.len() < 3 {
                    return Err(err(format!(
                        "face needs at least 3 vertices, found {}",
                        corners.len()
                    )));
                }
                if new_object {
                    let name = group
                        .as_deref()
                        .or(material.as_deref())
                        .unwrap_or("default");
                    builder.begin_object(name);
                    new_object = false;
                }
                for k in 1..corners.len() - 1 {
                    builder.add_triangle([corners[0], corners[k], corners[k + 1]]);
                }
            }
            "o" | "g" => {
                group = Some(if rest.is_empty() {
                    "unnamed".to_string()
                } else {
                    rest.to_string()
                });
                new_object = true;
            }
            "usemtl" => {
                material = Some(rest.to_string());
                new_object = true;
            }
            _ => {}
        }
    }
    Ok(builder.finish())
}

/// Turns one face corner (`v`, `v/vt`, `v//vn`, `v/vt/vn`) into a 0-based position index,
/// given `count` vertices read so far.
fn resolve_index(word: &str, count: u32) -> Result<u32, String> {
    let v = word.split('/').next().unwrap_or(word);
    let index: i64 = v
        .parse()
        .map_err(|_| format!("face corner '{word}' is not a vertex index"))?;
    let resolved = match index {
        0 => {
            return Err(format!(
                "face corner '{word}': index 0 is invalid (OBJ is 1-based)"
            ))
        }
        i if i > 0 => i - 1,
        i => i64::from(count) + i,
    };
    if resolved < 0 || resolved >= i64::from(count) {
        return Err(format!(
            "face corner '{word}' refers to a vertex that does not exist ({count} vertices so far)"
        ));
    }
    Ok(resolved as u32)
}

/// Writes `scene` as OBJ: all positions as `v` lines, then the triangles in id order as
/// 1-based `f` lines, with an `o NAME` line each time the object changes from one triangle to
/// the next (so objects whose triangles are not contiguous get several `o` lines, and loading
/// the output gives the same triangle ids). Coordinates are written in Rust's shortest form
/// that reads back to the same `f32`.
pub fn write(scene: &Scene, w: &mut impl Write) -> io::Result<()> {
    let mut w = io::BufWriter::new(w);
    writeln!(w, "# written by sightline")?;
    for p in &scene.positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    let mut current: Option<u32> = None;
    for (id, t) in scene.triangles.iter().enumerate() {
        let object = scene.object_of_triangle.get(id).copied().unwrap_or(0);
        if current != Some(object) {
            let name = scene
                .objects
                .get(object as usize)
                .map_or("default", |o| o.name.as_str());
            // Names with line breaks would end the statement early.
            writeln!(w, "o {}", name.replace(['\n', '\r'], " "))?;
            current = Some(object);
        }
        writeln!(
            w,
            "f {} {} {}",
            u64::from(t[0]) + 1,
            u64::from(t[1]) + 1,
            u64::from(t[2]) + 1
        )?;
    }
    w.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load_str(text: &str) -> Result<Scene, LoadError> {
        load(Path::new("test.obj"), text.as_bytes())
    }

    fn quad_file() -> &'static str {
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
    }

    #[test]
    fn empty_input_gives_empty_scene() {
        let s = load_str("").unwrap();
        assert!(s.is_empty() && s.objects.is_empty());
    }

    #[test]
    fn vertices_without_faces_give_empty_scene() {
        let s = load_str("# nothing\nv 1 2 3\n").unwrap();
        assert!(s.is_empty());
    }

    #[test]
    fn quad_is_fan_triangulated() {
        let s = load_str(quad_file()).unwrap();
        assert_eq!(s.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(s.objects.len(), 1);
        assert_eq!(s.objects[0].name, "default");
    }

    #[test]
    fn negative_and_slash_indices_resolve() {
        let s = load_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3/1/1 -2//2 3/3\n").unwrap();
        assert_eq!(s.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn groups_and_materials_start_objects() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n\
                    usemtl glass\nf 1 2 3\n\
                    g door\nusemtl wood\nf 1 2 3\nusemtl metal\nf 1 2 3\n\
                    o door\nf 1 2 3\n";
        let s = load_str(text).unwrap();
        let names: Vec<_> = s.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["glass", "door", "door", "door"]);
        assert_eq!(s.object_of_triangle, vec![0, 1, 2, 3]);
    }

    #[test]
    fn out_of_range_index_names_line() {
        let e = load_str("v 0 0 0\nv 1 0 0\n\nf 1 2 3\n").unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("test.obj") && msg.contains("line 4"), "{msg}");
    }

    #[test]
    fn zero_index_is_error() {
        let e = load_str("v 0 0 0\nf 0 1 1\n").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
    }

    #[test]
    fn bad_coordinate_names_line() {
        let e = load_str("v 0 0 zero\n").unwrap_err();
        assert!(e.to_string().contains("line 1"), "{e}");
    }

    #[test]
    fn two_corner_face_is_error() {
        let e = load_str("v 0 0 0\nv 1 0 0\nf 1 2\n").unwrap_err();
        assert!(e.to_string().contains("line 3"), "{e}");
    }

    #[test]
    fn crlf_and_missing_mtllib_are_fine() {
        let text = "mtllib missing.mtl\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n";
        assert_eq!(load_str(text).unwrap().triangle_count(), 1);
    }

    #[test]
    fn write_then_load_keeps_ids_and_objects() {
        let mut b = SceneBuilder::new("x");
        let a = b.begin_object("a");
        for i in 0..4 {
            b.add_vertex(Vec3::new(i as f32 * 0.1, 1.0 / 3.0, -2.5e-7));
        }
        b.add_triangle([0, 1, 2]);
        b.begin_object("b");
        b.add_triangle([1, 2, 3]);
        let mut scene = b.finish();
        // Make object "a" non-contiguous: a, b, a.
        scene.triangles.push([0, 2, 3]);
        scene.object_of_triangle.push(a);

        let mut out = Vec::new();
        write(&scene, &mut out).unwrap();
        let back = load(Path::new("back.obj"), &out).unwrap();
        assert_eq!(back.triangle_count(), 3);
        for id in 0..3 {
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
    fn write_empty_scene_loads_empty() {
        let mut out = Vec::new();
        write(&Scene::default(), &mut out).unwrap();
        assert!(load(Path::new("e.obj"), &out).unwrap().is_empty());
    }
}
