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
//! - Objects: see "Objects" below. No material is ever read: `mtllib` is ignored, and so are
//!   `vt`, `vn`, `l`, `p`, `s` and unknown statements.
//! - Line continuation with `\` is not supported (no shipped file uses it).
//! - Lines end at `\n`, `\r\n` or a lone `\r`. A `v` line has exactly 3, 4 (`x y z w`) or 6
//!   (`x y z r g b`, the common vertex-colour extension) numbers: anything else is an error,
//!   as extra words usually mean lines that were not split (a file whose line ends were
//!   lost would otherwise load as its first vertex).
//! - A file without faces loads empty with a load warning. The scene memory
//!   grows with the file and is checked against [`LoadOptions::max_scene_bytes`] as it grows.
//!
//! Errors name the file and the 1-based line.
//!
//! # Objects
//! - Faces after an `o` or `g` line belong to the object of that name (the rest of the line,
//!   trimmed; `unnamed` when empty; `g a b` is the one name `a b`). A name that comes back
//!   later in the file continues the same object, as the OBJ specification's groups are named
//!   sets of faces, so every `o`/`g` name is one object, in order of its first face, and
//!   `usemtl` inside an `o`/`g` does not split it.
//! - Faces before any `o`/`g` line: a new object starts at the first face after each `usemtl`
//!   line, named after the material (files without `o`/`g` such as fzk_haus would otherwise be
//!   one object), or `default` before any `usemtl`. These names may repeat (fzk_haus has 177
//!   such objects and 11 material names); an engine that imported the file as one mesh treats
//!   them together.
//! - [`Object::index`] and [`Object::part`] are `None`, except in files written by [`write()`].
//!
//! [`write()`] precedes each `o` line with a comment `# sightline-object K [index I] [part P]`
//! (K = the object's id, I and P its `index` and `part` when set). When the `o`/`g` line that
//! starts a face run directly follows such a comment (other lines may come between, but no
//! other `o`/`g`), the run joins object K instead of the object of its name: all runs with the
//! same K are one object, named after the `o` line of its first run, with I and P. Objects with
//! a tag are numbered in ascending K, the others after them. So `convert` to `.obj` keeps the
//! objects as loaded, with two limits: names lose line breaks (written as spaces) and leading
//! or trailing whitespace, and an empty name comes back `unnamed`. Tools that drop comments
//! leave a file whose repeated `o` names join as above.

use std::collections::HashMap;
use std::io::{self, Write};
use std::path::Path;

use glam::Vec3;

use super::builder::SceneBuilder;
use super::error::{LoadError, Location};
use super::limits::{show_bytes, RAISE};
use super::options::LoadOptions;
use super::text;
use super::types::{Object, Scene};

/// Loads an OBJ file from its (decompressed) bytes with the default [`LoadOptions`]; `path` is
/// for error messages.
///
/// A file without faces gives an empty scene, not an error. See the module documentation for
/// how faces and groups become triangles and objects.
pub fn load(path: &Path, bytes: &[u8]) -> Result<Scene, LoadError> {
    load_with(path, bytes, &LoadOptions::default())
}

/// [`load`] with the limits of `options`.
pub fn load_with(path: &Path, bytes: &[u8], options: &LoadOptions) -> Result<Scene, LoadError> {
    let mut reader = Reader::new(path, bytes.len());
    for (line_index, raw_line) in text::lines(bytes).enumerate() {
        let line_no = line_index + 1;
        reader
            .line(raw_line)
            .map_err(|message| LoadError::parse(path, Location::Line(line_no), message))?;
        reader.check_limit(path, line_no, options)?;
    }
    Ok(reader.finish())
}

/// One pass over an OBJ file: the scene so far, and what decides which object the next face
/// joins (module docs, "Objects").
struct Reader {
    builder: SceneBuilder,
    /// The name of the last `o`/`g` line, if any.
    group: Option<String>,
    /// The material of the last `usemtl` line, if any.
    material: Option<String>,
    /// The `# sightline-object` tag of the last `o`/`g` line, if it had one.
    tag: Option<Tag>,
    /// The last tag comment read, waiting for its `o`/`g` line.
    pending: Option<Tag>,
    /// Whether the next face starts (or resumes) an object.
    new_object: bool,
    /// Object id of each `o`/`g` name and of each tag number seen so far.
    by_name: HashMap<String, u32>,
    by_tag: HashMap<u32, u32>,
    /// The corners of the face being read (a buffer reused across faces).
    corners: Vec<u32>,
}

impl Reader {
    /// A reader for a file of `len` bytes at `path` (named in the scene).
    fn new(path: &Path, len: usize) -> Self {
        let mut builder = SceneBuilder::new(path.display().to_string());
        // About 30 bytes per `v` or `f` line in typical files; a hint, never a limit.
        builder.reserve(len / 64, len / 64);
        Reader {
            builder,
            group: None,
            material: None,
            tag: None,
            pending: None,
            new_object: true,
            by_name: HashMap::new(),
            by_tag: HashMap::new(),
            corners: Vec::with_capacity(8),
        }
    }

    /// Reads one line (without its line end). The error is the message; the caller names the
    /// line.
    fn line(&mut self, raw_line: &[u8]) -> Result<(), String> {
        let line = String::from_utf8_lossy(raw_line);
        let line = line.trim();
        let (keyword, rest) = match line.split_once(|c: char| c.is_ascii_whitespace()) {
            Some((k, r)) => (k, r.trim()),
            None => (line, ""),
        };
        match keyword {
            "v" => self.vertex(rest)?,
            "f" => self.face(rest)?,
            "o" | "g" => {
                self.group = Some(if rest.is_empty() {
                    "unnamed".to_string()
                } else {
                    rest.to_string()
                });
                self.tag = self.pending.take();
                self.new_object = true;
            }
            "usemtl" => {
                self.material = Some(rest.to_string());
                // Inside an `o`/`g` the material does not change the object.
                self.new_object |= self.group.is_none();
            }
            "#" => {
                if let Some((TAG, words)) = rest.split_once(|c: char| c.is_ascii_whitespace()) {
                    self.pending = Tag::parse(words);
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// A `v` line (`rest` follows the keyword): 3 coordinates, then nothing, a `w` or an
    /// `r g b` colour, which are checked and not kept.
    fn vertex(&mut self, rest: &str) -> Result<(), String> {
        let mut words = rest.split_ascii_whitespace();
        let mut xyz = [0.0f32; 3];
        for (axis, value) in xyz.iter_mut().enumerate() {
            let word = words
                .next()
                .ok_or_else(|| format!("vertex needs 3 coordinates, found {axis}"))?;
            *value = word
                .parse()
                .map_err(|_| format!("vertex coordinate '{word}' is not a number"))?;
        }
        // A 4th value (w) or vertex colours (r g b) may follow; neither changes the
        // position for polygonal geometry, so they are checked and not kept.
        let mut extra = 0usize;
        for word in words {
            word.parse::<f32>()
                .map_err(|_| format!("vertex value '{word}' is not a number"))?;
            extra += 1;
        }
        if !matches!(extra, 0 | 1 | 3) {
            return Err(format!(
                "vertex has {} values, expected 3 (x y z), 4 (x y z w) or 6 \
                 (x y z r g b): are line ends missing?",
                3 + extra
            ));
        }
        self.builder.add_vertex(Vec3::from_array(xyz));
        Ok(())
    }

    /// An `f` line (`rest` follows the keyword): its corners resolved, its object started if
    /// it is the first face since the object changed, and its fan of triangles added.
    fn face(&mut self, rest: &str) -> Result<(), String> {
        let count = self.builder.vertex_count();
        self.corners.clear();
        for word in rest.split_ascii_whitespace() {
            self.corners.push(resolve_index(word, count)?);
        }
        let corners = &self.corners;
        if corners.len() < 3 {
            return Err(format!(
                "face needs at least 3 vertices, found {}",
                corners.len()
            ));
        }
        if self.new_object {
            self.start_object();
            self.new_object = false;
        }
        let corners = &self.corners;
        for k in 1..corners.len() - 1 {
            self.builder
                .add_triangle([corners[0], corners[k], corners[k + 1]]);
        }
        Ok(())
    }

    /// Makes the object of the next faces current: the object of the tag of the last
    /// `o`/`g` line, else of its name, else a new object named after the material.
    fn start_object(&mut self) {
        match (&self.tag, &self.group) {
            (Some(t), _) => match self.by_tag.get(&t.object) {
                Some(&id) => self.builder.resume_object(id),
                None => {
                    let id = self.builder.push_object(Object {
                        name: self.group.clone().unwrap_or_else(|| "unnamed".into()),
                        index: t.index,
                        part: t.part,
                    });
                    self.by_tag.insert(t.object, id);
                }
            },
            (None, Some(name)) => match self.by_name.get(name) {
                Some(&id) => self.builder.resume_object(id),
                None => {
                    let id = self.builder.begin_object(name.clone());
                    self.by_name.insert(name.clone(), id);
                }
            },
            (None, None) => {
                self.builder
                    .begin_object(self.material.as_deref().unwrap_or("default"));
            }
        }
    }

    /// The scene memory so far must stay within [`LoadOptions::max_scene_bytes`]; checked
    /// after every line, so the error names the line where it grew past.
    fn check_limit(
        &self,
        path: &Path,
        line_no: usize,
        options: &LoadOptions,
    ) -> Result<(), LoadError> {
        if self.builder.geometry_bytes() > options.max_scene_bytes {
            return Err(LoadError::limit(
                path,
                Location::Line(line_no),
                format!(
                    "{} vertices and {} triangles so far, above the limit of {}; {RAISE}",
                    self.builder.vertex_count(),
                    self.builder.triangle_count(),
                    show_bytes(options.max_scene_bytes)
                ),
            ));
        }
        Ok(())
    }

    /// The scene: a warning when it has no triangles, and objects with a tag numbered by
    /// their tag.
    fn finish(mut self) -> Scene {
        let builder = &mut self.builder;
        if builder.triangle_count() == 0 {
            let n = builder.vertex_count();
            builder.warn(format!("{n} vertices and no 'f' lines: no triangles"));
        }
        if !self.by_tag.is_empty() {
            // Tagged objects take their tag order (the ids they had when written), the others
            // follow in file order.
            let mut keys = vec![(1u8, u32::MAX); builder.objects().len()];
            for (&object, &id) in &self.by_tag {
                keys[id as usize] = (0, object);
            }
            builder.sort_objects_by_key(&keys);
        }
        self.builder.finish()
    }
}

/// The comment word that [`write()`] puts before each `o` line.
const TAG: &str = "sightline-object";

/// A `# sightline-object K [index I] [part P]` comment (see the module docs, "Objects").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Tag {
    object: u32,
    index: Option<u32>,
    part: Option<u32>,
}

impl Tag {
    /// Parses the words after `sightline-object`; `None` (an ordinary comment) unless they
    /// have the documented shape.
    fn parse(words: &str) -> Option<Self> {
        let mut words = words.split_ascii_whitespace();
        let mut tag = Tag {
            object: words.next()?.parse().ok()?,
            index: None,
            part: None,
        };
        while let Some(key) = words.next() {
            let value = Some(words.next()?.parse().ok()?);
            match key {
                "index" => tag.index = value,
                "part" => tag.part = value,
                _ => return None,
            }
        }
        Some(tag)
    }
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
/// 1-based `f` lines, with a `# sightline-object K [index I] [part P]` comment and an
/// `o NAME` line each time the object changes from one triangle to the next (so objects whose
/// triangles are not contiguous get several `o` lines, and loading the output gives the same
/// triangle ids; the comments give back the same objects, see the module docs, "Objects").
/// Coordinates are written in Rust's shortest form that reads back to the same `f32`.
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
            let (name, index, part) = scene
                .objects
                .get(object as usize)
                .map_or(("default", None, None), |o| {
                    (o.name.as_str(), o.index, o.part)
                });
            write!(w, "# {TAG} {object}")?;
            if let Some(i) = index {
                write!(w, " index {i}")?;
            }
            if let Some(p) = part {
                write!(w, " part {p}")?;
            }
            // Names with line breaks would end the statement early.
            writeln!(w, "\no {}", name.replace(['\n', '\r'], " "))?;
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
    fn groups_join_by_name_and_materials_split_outside_groups() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n\
                    usemtl glass\nf 1 2 3\nusemtl wood\nf 1 2 3\nusemtl glass\nf 1 2 3\n\
                    g door\nusemtl wood\nf 1 2 3\nusemtl metal\nf 1 2 3\n\
                    o window\nf 1 2 3\no door\nf 1 2 3\n";
        let s = load_str(text).unwrap();
        let names: Vec<_> = s.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["glass", "wood", "glass", "door", "window"]);
        assert_eq!(s.object_of_triangle, vec![0, 1, 2, 3, 3, 4, 3]);
        assert!(s
            .objects
            .iter()
            .all(|o| o.index.is_none() && o.part.is_none()));
    }

    #[test]
    fn tags_join_runs_and_restore_ids() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n\
                    # sightline-object 1 index 4 part 2\no b\nf 1 2 3\n\
                    # sightline-object 0\no a\nf 1 2 3\n\
                    # sightline-object 1 index 4 part 2\no b\nf 1 2 3\n\
                    # sightline-object x\no a\nf 1 2 3\n";
        let s = load_str(text).unwrap();
        let ids: Vec<_> = s
            .objects
            .iter()
            .map(|o| (o.name.as_str(), o.index, o.part))
            .collect();
        // A malformed tag is an ordinary comment: the last run is the untagged object `a`.
        assert_eq!(
            ids,
            [
                ("a", None, None),
                ("b", Some(4), Some(2)),
                ("a", None, None)
            ]
        );
        assert_eq!(s.object_of_triangle, vec![1, 0, 1, 2]);
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
    fn cr_only_line_ends_split_lines() {
        let s = load_str(&quad_file().replace('\n', "\r")).unwrap();
        assert_eq!(s.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn vertex_colours_and_w_are_accepted() {
        let text = "v 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv 0 1 0\nf 1 2 3\n";
        assert_eq!(load_str(text).unwrap().positions[1], Vec3::X);
    }

    #[test]
    fn extra_vertex_values_name_line() {
        for line in ["v 0 0 0 1 2", "v 0 0 0 1 2 3 4", "v 0 0 0 v 1 0 0"] {
            let text = format!("v 1 1 1\n{line}\n");
            let e = load_str(&text).unwrap_err();
            assert!(e.to_string().contains("line 2"), "{line}: {e}");
        }
    }

    #[test]
    fn growth_above_the_limit_is_error() {
        let options = LoadOptions {
            max_scene_bytes: 100,
            ..LoadOptions::default()
        };
        let text = "v 0 0 0\n".repeat(20);
        let e = load_with(Path::new("big.obj"), text.as_bytes(), &options).unwrap_err();
        assert!(
            matches!(
                e,
                LoadError::Limit {
                    location: Location::Line(9),
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn vertices_without_faces_warn() {
        let s = load_str("v 1 2 3\n").unwrap();
        assert!(
            s.load_warnings[0].contains("no 'f' lines"),
            "{:?}",
            s.load_warnings
        );
    }

    #[test]
    fn write_then_load_keeps_ids_and_objects() {
        let mut b = SceneBuilder::new("x");
        let a = b.begin_object("a");
        for i in 0..4 {
            b.add_vertex(Vec3::new(i as f32 * 0.1, 1.0 / 3.0, -2.5e-7));
        }
        b.add_triangle([0, 1, 2]);
        // A second object with the same name, told apart by its tag (and index/part).
        b.push_object(Object {
            name: "a".into(),
            index: Some(3),
            part: Some(1),
        });
        b.add_triangle([1, 2, 3]);
        let mut scene = b.finish();
        // Make the first object non-contiguous: 0, 1, 0.
        scene.triangles.push([0, 2, 3]);
        scene.object_of_triangle.push(a);

        let mut out = Vec::new();
        write(&scene, &mut out).unwrap();
        let back = load(Path::new("back.obj"), &out).unwrap();
        assert_eq!(back.triangle_count(), 3);
        assert_eq!(back.objects, scene.objects);
        assert_eq!(back.object_of_triangle, scene.object_of_triangle);
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
