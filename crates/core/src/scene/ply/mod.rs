//! PLY (Stanford polygon file format) reader and writer.
//!
//! Follows Greg Turk's "The PLY Polygon File Format" (1994) as read by the common tools
//! (rply, Meshlab, Blender): a text header of `element NAME COUNT` blocks with `property TYPE
//! NAME` or `property list COUNT_TYPE ITEM_TYPE NAME` lines, then the data in `ascii`,
//! `binary_little_endian` or `binary_big_endian` encoding. Type names are the 1994 ones
//! (`char uchar short ushort int uint float double`) and their sized aliases (`int8` ...
//! `float64`).
//!
//! What the loader takes:
//! - `vertex` element: the `x`, `y`, `z` properties (any scalar type, converted to `f32`);
//!   other properties, in any order, are skipped.
//! - `face` element: the `vertex_indices` (or `vertex_index`) list, any count and index types.
//!   A polygon `a b c d ...` becomes the fan `(a b c) (a c d) ...`; faces with fewer than 3
//!   indices give no triangle and are counted in a load warning. Triangle ids follow face
//!   order.
//! - Any other element (edges, materials, ...) is skipped, lists included. Elements may come in
//!   any order; face indices are checked against the header's vertex count, so a face that
//!   names a vertex that does not exist is an error naming the face, wherever it sits.
//! - The whole file is one object named after the file stem.
//! - Counts are checked against the data: two elements of the same name are an error; each
//!   ASCII item is one line with exactly the values its properties declare (a misaligned file,
//!   `element vertex 10` with data for 8, is an error, not garbage geometry), and lines after
//!   the last item are an error; binary counts must fit in the bytes left (checked before any
//!   allocation), and bytes after the last item are a load warning. The geometry the header
//!   declares is checked against [`LoadOptions::max_scene_bytes`] before it is read.
//!
//! Binary data is read straight from the byte slice with no per-byte dispatch: vertices with
//! only scalar properties are read at a fixed stride, and the `list uchar int|uint` face
//! layout (what every shipped PLY and our writer use) has its own loop. Errors name the byte
//! offset (binary) or line (ascii) and the element.
//!
//! # Files
//! This file is the module's face: the docs, [`load`], [`load_with`] and [`write()`]. The
//! rooms: `header.rs` parses the header, `ascii.rs` and `binary.rs` read the data of each
//! encoding into the `Mesh` of `mesh.rs`, which triangulates the faces.

mod ascii;
mod binary;
mod header;
mod mesh;

use std::io::{self, Write};
use std::path::Path;

use super::builder::SceneBuilder;
use super::error::{LoadError, Location};
use super::limits::check_geometry;
use super::options::LoadOptions;
use super::types::Scene;
use ascii::read_ascii;
use binary::read_binary;
use header::{face_list, parse_header, Encoding};
use mesh::Mesh;

/// Loads a PLY file from its (decompressed) bytes with the default [`LoadOptions`]; `path` is
/// for error messages.
///
/// The result has one object named after the file stem. See the module documentation for
/// which elements and properties are read.
pub fn load(path: &Path, bytes: &[u8]) -> Result<Scene, LoadError> {
    load_with(path, bytes, &LoadOptions::default())
}

/// [`load`] with the limits of `options`.
pub fn load_with(path: &Path, bytes: &[u8], options: &LoadOptions) -> Result<Scene, LoadError> {
    let header = parse_header(path, bytes)?;
    let vertex_count = header
        .elements
        .iter()
        .find(|e| e.name == "vertex")
        .map_or(0, |e| e.count);
    // Indices are u32; more vertices than that cannot be addressed.
    if vertex_count > u64::from(u32::MAX) {
        return Err(LoadError::parse(
            path,
            Location::Element("element vertex".into()),
            format!("{vertex_count} vertices is more than 2^32 - 1"),
        ));
    }
    // Each face gives at least one triangle unless it is short; polygons give more, but
    // their bytes bound those (and the whole input is capped by the same limit).
    let face_count = header
        .elements
        .iter()
        .find(|e| face_list(e).is_some())
        .map_or(0, |e| e.count);
    check_geometry(
        path,
        Location::Element("header".into()),
        vertex_count,
        face_count,
        options,
    )?;
    let mut mesh = Mesh::default();
    match header.elements.iter().find(|e| face_list(e).is_some()) {
        None => mesh
            .warnings
            .push("no 'face' element with a 'vertex_indices' list: no triangles".into()),
        Some(e) if e.count == 0 => mesh.warnings.push("'element face 0': no triangles".into()),
        Some(_) => {}
    }
    match header.encoding {
        Encoding::Ascii => read_ascii(path, bytes, &header, vertex_count as u32, &mut mesh)?,
        Encoding::BinaryLittle | Encoding::BinaryBig => {
            let big = header.encoding == Encoding::BinaryBig;
            read_binary(path, bytes, &header, big, vertex_count as u32, &mut mesh)?;
        }
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // The stem of `city.ply.gz` is `city`, not `city.ply`.
    let stem = name
        .split('.')
        .next()
        .filter(|s| !s.is_empty())
        .unwrap_or("ply")
        .to_string();
    let mut builder = SceneBuilder::new(path.display().to_string());
    if mesh.short_faces > 0 {
        builder.warn(format!(
            "{} face(s) with fewer than 3 vertex indices give no triangle (first: face {})",
            mesh.short_faces, mesh.first_short_face
        ));
    }
    for w in mesh.warnings.drain(..) {
        builder.warn(w);
    }
    builder.reserve(mesh.positions.len(), mesh.triangles.len());
    for p in mesh.positions {
        builder.add_vertex(p);
    }
    builder.begin_object(stem);
    for t in mesh.triangles {
        builder.add_triangle(t);
    }
    Ok(builder.finish())
}

/// Writes `scene` as binary little-endian PLY: `element vertex` with `float x, y, z` and
/// `element face` with `list uchar int vertex_indices`, triangles in id order.
///
/// Objects are lost: PLY has no standard way to group faces.
pub fn write(scene: &Scene, w: &mut impl Write) -> io::Result<()> {
    let mut w = io::BufWriter::new(w);
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment written by sightline\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        scene.positions.len(),
        scene.triangles.len()
    )?;
    let mut buf = Vec::with_capacity(64 * 1024);
    for p in &scene.positions {
        for c in [p.x, p.y, p.z] {
            buf.extend_from_slice(&c.to_le_bytes());
        }
        if buf.len() >= 60 * 1024 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    for t in &scene.triangles {
        buf.push(3);
        for i in t {
            buf.extend_from_slice(&i.to_le_bytes());
        }
        if buf.len() >= 60 * 1024 {
            w.write_all(&buf)?;
            buf.clear();
        }
    }
    w.write_all(&buf)?;
    w.flush()
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn load_bytes(bytes: &[u8]) -> Result<Scene, LoadError> {
        load(Path::new("dir/model.ply.gz"), bytes)
    }

    fn ascii_square() -> &'static str {
        "ply\nformat ascii 1.0\ncomment square\n\
         element vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"
    }

    fn two_triangles() -> Scene {
        let mut b = SceneBuilder::new("t");
        for p in [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.5, -2.0, 1e-3)] {
            b.add_vertex(p);
        }
        b.add_triangle([0, 1, 2]);
        b.add_triangle([1, 3, 2]);
        b.finish()
    }

    #[test]
    fn ascii_quad_is_fan_triangulated() {
        let s = load_bytes(ascii_square().as_bytes()).unwrap();
        assert_eq!(s.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(s.objects.len(), 1);
        assert_eq!(s.objects[0].name, "model");
    }

    #[test]
    fn empty_input_is_error_at_offset_zero() {
        let e = load_bytes(b"").unwrap_err();
        assert!(e.to_string().contains("byte offset 0"), "{e}");
    }

    #[test]
    fn garbage_is_error() {
        let e = load_bytes(b"\x00\x01garbage").unwrap_err();
        assert!(e.to_string().contains("model.ply.gz: byte offset 0"), "{e}");
    }

    #[test]
    fn header_only_gives_empty_scene() {
        let text = "ply\nformat binary_little_endian 1.0\nend_header\n";
        assert!(load_bytes(text.as_bytes()).unwrap().is_empty());
    }

    #[test]
    fn write_then_load_round_trips() {
        let scene = two_triangles();
        let mut out = Vec::new();
        write(&scene, &mut out).unwrap();
        let back = load_bytes(&out).unwrap();
        assert_eq!(back.triangles, scene.triangles);
        assert_eq!(back.positions, scene.positions);
    }

    #[test]
    fn big_endian_doubles_and_extra_properties() {
        let mut bytes = b"ply\nformat binary_big_endian 1.0\n\
            element face 1\nproperty uchar flags\nproperty list ushort uint vertex_index\nproperty float q\n\
            element vertex 3\nproperty double z\nproperty uchar red\nproperty list uchar float uv\nproperty double x\nproperty short y\n\
            element edge 1\nproperty list int int stuff\n\
            end_header\n"
            .to_vec();
        bytes.push(7);
        bytes.extend_from_slice(&3u16.to_be_bytes());
        for i in [2u32, 1, 0] {
            bytes.extend_from_slice(&i.to_be_bytes());
        }
        bytes.extend_from_slice(&1.0f32.to_be_bytes());
        for v in 0..3 {
            bytes.extend_from_slice(&(f64::from(v) + 0.5).to_be_bytes());
            bytes.push(255);
            bytes.push(2);
            bytes.extend_from_slice(&[0; 8]);
            bytes.extend_from_slice(&(-f64::from(v)).to_be_bytes());
            bytes.extend_from_slice(&(10i16 * v as i16).to_be_bytes());
        }
        bytes.extend_from_slice(&2i32.to_be_bytes());
        bytes.extend_from_slice(&[0; 8]);
        let s = load_bytes(&bytes).unwrap();
        assert_eq!(s.triangles, vec![[2, 1, 0]]);
        assert_eq!(s.positions[2], Vec3::new(-2.0, 20.0, 2.5));
    }

    #[test]
    fn out_of_range_index_names_face() {
        let text = ascii_square().replace("4 0 1 2 3", "3 0 1 9");
        let e = load_bytes(text.as_bytes()).unwrap_err();
        assert!(
            e.to_string().contains("face 0") && e.to_string().contains("line 15"),
            "{e}"
        );
    }

    #[test]
    fn binary_out_of_range_index_names_face_and_offset() {
        let mut out = Vec::new();
        write(&two_triangles(), &mut out).unwrap();
        let n = out.len();
        out[n - 4..].copy_from_slice(&99i32.to_le_bytes());
        let e = load_bytes(&out).unwrap_err();
        assert!(e.to_string().contains("face 1"), "{e}");
        assert!(
            e.to_string().contains(&format!("byte offset {}", n - 13)),
            "{e}"
        );
    }

    #[test]
    fn truncated_binary_names_offset() {
        let mut out = Vec::new();
        write(&two_triangles(), &mut out).unwrap();
        out.truncate(out.len() - 1);
        let e = load_bytes(&out).unwrap_err();
        assert!(e.to_string().contains("byte offset"), "{e}");
    }

    #[test]
    fn ascii_bad_number_names_line() {
        let text = ascii_square().replace("1 1 0", "1 x 0");
        let e = load_bytes(text.as_bytes()).unwrap_err();
        assert!(e.to_string().contains("line 13"), "{e}");
    }

    #[test]
    fn short_faces_are_counted_in_a_warning() {
        let text = ascii_square()
            .replace("element face 1", "element face 3")
            .replace("4 0 1 2 3\n", "2 0 1\n4 0 1 2 3\n0\n");
        let s = load_bytes(text.as_bytes()).unwrap();
        assert_eq!(s.triangle_count(), 2);
        assert_eq!(s.load_warnings.len(), 1, "{:?}", s.load_warnings);
        assert!(
            s.load_warnings[0].contains("2 face(s)"),
            "{:?}",
            s.load_warnings
        );
        assert!(
            s.load_warnings[0].contains("first: face 0"),
            "{:?}",
            s.load_warnings
        );
    }

    #[test]
    fn ascii_extra_value_is_error() {
        let text = ascii_square().replace("1 1 0\n", "1 1 0 7\n");
        let e = load_bytes(text.as_bytes()).unwrap_err();
        assert!(e.to_string().contains("line 13"), "{e}");
    }

    #[test]
    fn ascii_count_above_the_data_is_error() {
        // 5 vertices declared, 4 given: the face line would be read as a vertex.
        let text = ascii_square().replace("element vertex 4", "element vertex 5");
        assert!(load_bytes(text.as_bytes()).is_err());
    }

    #[test]
    fn ascii_count_below_the_data_is_error() {
        let text = ascii_square()
            .replace("element vertex 4", "element vertex 3")
            .replace("4 0 1 2 3", "3 0 1 2");
        let e = load_bytes(text.as_bytes()).unwrap_err();
        assert!(e.to_string().contains("line 14"), "{e}");
    }

    #[test]
    fn trailing_ascii_line_is_error() {
        let text = format!("{}3 0 1 2\n", ascii_square());
        let e = load_bytes(text.as_bytes()).unwrap_err();
        assert!(e.to_string().contains("after the last item"), "{e}");
    }

    #[test]
    fn second_element_of_a_name_is_error() {
        let text = ascii_square().replace(
            "element face 1",
            "element vertex 1\nproperty float x\nelement face 1",
        );
        let e = load_bytes(text.as_bytes()).unwrap_err();
        assert!(e.to_string().contains("second 'element vertex'"), "{e}");
    }

    #[test]
    fn declared_counts_above_the_limit_are_error() {
        let text = "ply\nformat binary_little_endian 1.0\nelement vertex 4294967295\n\
                    property float x\nproperty float y\nproperty float z\nend_header\n";
        let options = LoadOptions {
            max_scene_bytes: 1 << 30,
            ..LoadOptions::default()
        };
        let e = load_with(Path::new("big.ply"), text.as_bytes(), &options).unwrap_err();
        assert!(matches!(e, LoadError::Limit { .. }), "{e}");
    }

    #[test]
    fn binary_trailing_bytes_are_a_warning() {
        let mut out = Vec::new();
        write(&two_triangles(), &mut out).unwrap();
        out.extend_from_slice(b"junk");
        let s = load_bytes(&out).unwrap();
        assert_eq!(s.triangle_count(), 2);
        assert!(
            s.load_warnings[0].contains("4 bytes"),
            "{:?}",
            s.load_warnings
        );
    }

    #[test]
    fn missing_coordinate_is_error() {
        let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n";
        assert!(load_bytes(text.as_bytes()).is_err());
    }
}
