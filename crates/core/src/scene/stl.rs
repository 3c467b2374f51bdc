//! STL (stereolithography) reader, ASCII and binary.
//!
//! Follows the 3D Systems "StereoLithography Interface Specification" (1989, section 6.5):
//! binary = 80-byte header, `u32` triangle count `n`, then `n` records of 50 bytes (normal,
//! three vertices as little-endian `f32` xyz, `u16` attribute); ASCII = `solid NAME`,
//! `facet normal ...`, `outer loop`, three `vertex x y z`, `endloop`, `endfacet`, `endsolid`.
//!
//! Binary or ASCII: many binary exporters start the 80-byte header with `solid`, so the word
//! alone decides nothing. A file is binary when its size is exactly `84 + 50 n` for the count
//! `n` it declares, or when it does not start with `solid`. Anything else is parsed as ASCII,
//! and read as binary after all when that fails and its `n` records fit in the file (a binary
//! file with a `solid` header and a few bytes of padding).
//!
//! Counts: a binary file shorter than its `n` records is an error; so is one with room for
//! more records than `n` (50 or more bytes after them: the count and the data disagree, and
//! either could be the truth); fewer than 50 extra bytes (padding) are a load warning. An ASCII
//! file without facets is an error (it is empty or not STL); one whose last `solid` has no
//! `endsolid` loads with a warning (it may be cut short).
//!
//! Vertices are not welded: each triangle gets its own 3 vertices (STL has no shared vertices
//! and welding would cost a hash map for no gain in visibility). One object per ASCII `solid`
//! block (named after it, or `solid`); a binary file is one object named after the file stem.
//! Facet normals are ignored; triangle ids follow file order.

use std::path::Path;

use glam::Vec3;

use super::builder::SceneBuilder;
use super::error::{LoadError, Location};
use super::limits::check_geometry;
use super::options::LoadOptions;
use super::text;
use super::types::Scene;

/// Binary record size: normal, three corners (12 bytes each), `u16` attribute.
const RECORD: u64 = 50;

/// Loads an STL file (ASCII or binary) from its (decompressed) bytes with the default
/// [`LoadOptions`]; `path` is for error messages.
pub fn load(path: &Path, bytes: &[u8]) -> Result<Scene, LoadError> {
    load_with(path, bytes, &LoadOptions::default())
}

/// [`load`] with the limits of `options`.
pub fn load_with(path: &Path, bytes: &[u8], options: &LoadOptions) -> Result<Scene, LoadError> {
    let declared = bytes
        .get(80..84)
        .map(|b| u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])));
    let len = bytes.len() as u64;
    let exact_binary = declared.is_some_and(|n| 84 + RECORD * n == len);
    let looks_ascii = bytes.trim_ascii_start().starts_with(b"solid");
    if exact_binary || !looks_ascii {
        return load_binary(path, bytes, declared, options);
    }
    match load_ascii(path, bytes) {
        Ok(scene) => Ok(scene),
        // A `solid` header on binary data that is not exactly `84 + 50 n` bytes long: when
        // its records fit, the binary reading (and its error) is the one that counts.
        Err(ascii) => match declared {
            Some(n) if n > 0 && 84 + RECORD * n <= len => {
                load_binary(path, bytes, declared, options)
            }
            _ => Err(ascii),
        },
    }
}

fn load_binary(
    path: &Path,
    bytes: &[u8],
    declared: Option<u64>,
    options: &LoadOptions,
) -> Result<Scene, LoadError> {
    let Some(n) = declared else {
        return Err(LoadError::parse(
            path,
            Location::Byte(bytes.len() as u64),
            format!(
                "not an STL file: {} bytes is too short for a binary header (84 bytes) and it \
                 does not start with 'solid'",
                bytes.len()
            ),
        ));
    };
    let needed = 84 + RECORD * n;
    let len = bytes.len() as u64;
    if needed > len {
        return Err(LoadError::parse(
            path,
            Location::Byte(80),
            format!(
                "binary STL declares {n} triangles ({needed} bytes) but the file has {len} bytes"
            ),
        ));
    }
    let extra = len - needed;
    if extra >= RECORD {
        return Err(LoadError::parse(
            path,
            Location::Byte(80),
            format!(
                "binary STL declares {n} triangles ({needed} bytes) but the file has {len} \
                 bytes, room for {} records: the triangle count and the data disagree",
                n + extra / RECORD
            ),
        ));
    }
    check_geometry(path, Location::Byte(80), 3 * n, n, options)?;
    let stem = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = stem
        .split('.')
        .next()
        .filter(|s| !s.is_empty())
        .unwrap_or("stl");
    let mut builder = SceneBuilder::new(path.display().to_string());
    builder.reserve(3 * n as usize, n as usize);
    builder.begin_object(stem);
    let f = |b: &[u8], o: usize| f32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
    for record in bytes[84..needed as usize].chunks_exact(50) {
        let base = builder.vertex_count();
        for corner in 0..3 {
            // Skip the 12-byte normal; each corner is 12 bytes.
            let o = 12 + 12 * corner;
            builder.add_vertex(Vec3::new(f(record, o), f(record, o + 4), f(record, o + 8)));
        }
        builder.add_triangle([base, base + 1, base + 2]);
    }
    if n == 0 {
        builder.warn("the binary STL header declares 0 triangles");
    }
    if extra > 0 {
        builder.warn(format!(
            "{extra} bytes after the {n} triangle records (padding?) are ignored"
        ));
    }
    Ok(builder.finish())
}

fn load_ascii(path: &Path, bytes: &[u8]) -> Result<Scene, LoadError> {
    let mut builder = SceneBuilder::new(path.display().to_string());
    // A facet takes about 250 bytes of text.
    builder.reserve(bytes.len() / 80, bytes.len() / 250);
    let mut in_solid = false;
    // Corners of the current `outer loop`, or None outside a loop.
    let mut corners: Option<Vec<u32>> = None;
    let mut last_line = 0;
    let mut facets = 0usize;
    for (index, raw) in text::lines(bytes).enumerate() {
        let line_no = index + 1;
        last_line = line_no;
        let err = |message: String| LoadError::parse(path, Location::Line(line_no), message);
        let line = String::from_utf8_lossy(raw);
        let line = line.trim();
        let (keyword, rest) = match line.split_once(|c: char| c.is_ascii_whitespace()) {
            Some((k, r)) => (k, r.trim()),
            None => (line, ""),
        };
        match keyword {
            "" => {}
            "solid" => {
                if in_solid {
                    return Err(err("'solid' inside a solid (missing 'endsolid')".into()));
                }
                builder.begin_object(if rest.is_empty() { "solid" } else { rest });
                in_solid = true;
            }
            "endsolid" => {
                if corners.is_some() {
                    return Err(err("'endsolid' inside a facet loop".into()));
                }
                in_solid = false;
            }
            "facet" | "endfacet" if in_solid => {}
            "outer" if in_solid => {
                if corners.is_some() {
                    return Err(err("'outer loop' inside a loop".into()));
                }
                corners = Some(Vec::with_capacity(3));
            }
            "vertex" => {
                let Some(list) = corners.as_mut() else {
                    return Err(err("'vertex' outside an 'outer loop'".into()));
                };
                let mut xyz = [0.0f32; 3];
                let mut words = rest.split_ascii_whitespace();
                for (axis, value) in xyz.iter_mut().enumerate() {
                    let word = words
                        .next()
                        .ok_or_else(|| err(format!("vertex needs 3 coordinates, found {axis}")))?;
                    *value = word
                        .parse()
                        .map_err(|_| err(format!("vertex coordinate '{word}' is not a number")))?;
                }
                if let Some(extra) = words.next() {
                    return Err(err(format!(
                        "vertex has more than 3 coordinates ('{extra}')"
                    )));
                }
                list.push(builder.add_vertex(Vec3::from_array(xyz)));
            }
            "endloop" => {
                let Some(list) = corners.take() else {
                    return Err(err("'endloop' without 'outer loop'".into()));
                };
                if list.len() != 3 {
                    return Err(err(format!(
                        "facet has {} vertices, STL facets have 3",
                        list.len()
                    )));
                }
                builder.add_triangle([list[0], list[1], list[2]]);
                facets += 1;
            }
            other => {
                return Err(err(format!(
                    "unexpected '{other}'{}",
                    if in_solid { "" } else { " outside a solid" }
                )))
            }
        }
    }
    if corners.is_some() {
        return Err(LoadError::parse(
            path,
            Location::Line(last_line),
            "file ends inside a facet",
        ));
    }
    if facets == 0 {
        return Err(LoadError::parse(
            path,
            Location::Line(last_line),
            "ASCII STL without facets (no 'outer loop' ... 'endloop'): empty or not STL",
        ));
    }
    if in_solid {
        builder.warn(format!(
            "the file ends inside a solid (no 'endsolid' after line {last_line}): it may be \
             cut short"
        ));
    }
    Ok(builder.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load_bytes(bytes: &[u8]) -> Result<Scene, LoadError> {
        load(Path::new("part.stl"), bytes)
    }

    fn ascii_two_solids() -> &'static str {
        "solid first\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n\
         \x20  vertex 0 1 0\n  endloop\n endfacet\nendsolid first\n\
         solid\nfacet normal 0 0 1\nouter loop\nvertex 0 0 1\nvertex 1 0 1\nvertex 0 1 1\n\
         endloop\nendfacet\nendsolid\n"
    }

    /// A binary STL whose header starts with "solid", as many exporters write.
    fn binary_with_solid_header(triangles: u32) -> Vec<u8> {
        let mut b = b"solid exported by some CAD tool".to_vec();
        b.resize(80, b' ');
        b.extend_from_slice(&triangles.to_le_bytes());
        for t in 0..triangles {
            b.extend_from_slice(&[0; 12]);
            for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, t as f32]] {
                for c in v {
                    b.extend_from_slice(&c.to_le_bytes());
                }
            }
            b.extend_from_slice(&[0; 2]);
        }
        b
    }

    #[test]
    fn ascii_solids_become_objects() {
        let s = load_bytes(ascii_two_solids().as_bytes()).unwrap();
        assert_eq!(s.triangle_count(), 2);
        assert_eq!(s.positions.len(), 6);
        let names: Vec<_> = s.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["first", "solid"]);
        assert_eq!(s.triangle(1)[2], Vec3::new(0.0, 1.0, 1.0));
    }

    #[test]
    fn binary_with_solid_header_is_binary() {
        let s = load_bytes(&binary_with_solid_header(2)).unwrap();
        assert_eq!(s.triangle_count(), 2);
        assert_eq!(
            s.triangle(1),
            [Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 1.0)]
        );
        assert_eq!(s.objects[0].name, "part");
    }

    #[test]
    fn binary_with_no_triangles_is_empty() {
        assert!(load_bytes(&binary_with_solid_header(0)).unwrap().is_empty());
    }

    #[test]
    fn empty_input_is_error() {
        let e = load_bytes(b"").unwrap_err();
        assert!(e.to_string().contains("part.stl: byte offset 0"), "{e}");
    }

    #[test]
    fn garbage_is_error_naming_offset() {
        let e = load_bytes(&[0xAB; 200]).unwrap_err();
        assert!(e.to_string().contains("byte offset 80"), "{e}");
    }

    #[test]
    fn truncated_binary_is_error() {
        let mut b = binary_with_solid_header(3);
        b[0] = b'x';
        b.truncate(b.len() - 10);
        let e = load_bytes(&b).unwrap_err();
        assert!(e.to_string().contains("declares 3 triangles"), "{e}");
    }

    #[test]
    fn ascii_four_vertex_facet_names_line() {
        let text =
            ascii_two_solids().replace("   vertex 0 1 0\n", "   vertex 0 1 0\nvertex 1 1 0\n");
        let e = load_bytes(text.as_bytes()).unwrap_err();
        assert!(e.to_string().contains("line 8"), "{e}");
    }

    #[test]
    fn binary_with_solid_header_and_padding_is_binary() {
        let mut b = binary_with_solid_header(2);
        b.extend_from_slice(&[0; 7]);
        let s = load_bytes(&b).unwrap();
        assert_eq!(s.triangle_count(), 2);
        assert!(
            s.load_warnings[0].contains("7 bytes"),
            "{:?}",
            s.load_warnings
        );
    }

    #[test]
    fn solid_alone_is_error() {
        let e = load_bytes(b"solid").unwrap_err();
        assert!(e.to_string().contains("without facets"), "{e}");
        let e = load_bytes(b"solid x\nendsolid x\n").unwrap_err();
        assert!(e.to_string().contains("without facets"), "{e}");
    }

    #[test]
    fn count_below_the_records_is_error() {
        let mut b = binary_with_solid_header(3);
        b[80..84].copy_from_slice(&1u32.to_le_bytes());
        let e = load_bytes(&b).unwrap_err();
        assert!(e.to_string().contains("room for 3 records"), "{e}");
        b[0] = b'x';
        let e = load_bytes(&b).unwrap_err();
        assert!(e.to_string().contains("room for 3 records"), "{e}");
    }

    #[test]
    fn declared_count_above_the_limit_is_error() {
        let b = binary_with_solid_header(100);
        let options = LoadOptions {
            max_scene_bytes: 1000,
            ..LoadOptions::default()
        };
        let e = load_with(Path::new("part.stl"), &b, &options).unwrap_err();
        assert!(matches!(e, LoadError::Limit { .. }), "{e}");
    }

    #[test]
    fn missing_endsolid_is_a_warning() {
        let text = ascii_two_solids().replace("endsolid\n", "");
        let s = load_bytes(text.as_bytes()).unwrap();
        assert_eq!(s.triangle_count(), 2);
        assert!(
            s.load_warnings[0].contains("endsolid"),
            "{:?}",
            s.load_warnings
        );
    }

    #[test]
    fn cr_only_ascii_loads() {
        let text = ascii_two_solids().replace('\n', "\r");
        assert_eq!(load_bytes(text.as_bytes()).unwrap().triangle_count(), 2);
    }

    #[test]
    fn ascii_unterminated_loop_is_error() {
        let e = load_bytes(b"solid a\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\n").unwrap_err();
        assert!(e.to_string().contains("ends inside a facet"), "{e}");
    }
}
