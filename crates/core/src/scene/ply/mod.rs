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

use std::io::{self, Write};
use std::path::Path;

use glam::Vec3;

use super::builder::SceneBuilder;
use super::error::{LoadError, Location};
use super::limits::check_geometry;
use super::options::LoadOptions;
use super::types::Scene;

/// A scalar type of the PLY header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Reads one value at the start of `b` (which holds at least `self.size()` bytes).
    #[inline]
    fn read(self, b: &[u8], big: bool) -> f64 {
        macro_rules! get {
            ($t:ty, $n:expr) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(&b[..$n]);
                if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            }};
        }
        match self {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(get!(i16, 2)),
            Scalar::U16 => f64::from(get!(u16, 2)),
            Scalar::I32 => f64::from(get!(i32, 4)),
            Scalar::U32 => f64::from(get!(u32, 4)),
            Scalar::F32 => f64::from(get!(f32, 4)),
            Scalar::F64 => get!(f64, 8),
        }
    }
}

/// A property of an element: a scalar or a list.
#[derive(Clone, Debug)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<Property>,
}

impl Element {
    /// Bytes per item when every property is a scalar.
    fn fixed_stride(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => Some(s.size()),
                Kind::List { .. } => None,
            })
            .sum()
    }

    fn find(&self, names: &[&str]) -> Option<usize> {
        self.properties
            .iter()
            .position(|p| names.contains(&p.name.as_str()))
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Ascii,
    BinaryLittle,
    BinaryBig,
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Byte offset of the first data byte.
    data_start: usize,
    /// Number of header lines (ascii data starts at line `lines + 1`).
    lines: usize,
}

/// What the data pass collects.
struct Mesh {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// Faces with fewer than 3 indices (no triangle), and the first of them.
    short_faces: u64,
    first_short_face: u64,
    /// Load warnings.
    warnings: Vec<String>,
}

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
    let mut mesh = Mesh {
        positions: Vec::new(),
        triangles: Vec::new(),
        short_faces: 0,
        first_short_face: 0,
        warnings: Vec::new(),
    };
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

fn parse_header(path: &Path, bytes: &[u8]) -> Result<Header, LoadError> {
    let line_err = |line: usize, message: String| {
        LoadError::parse(path, Location::Line(line), format!("header: {message}"))
    };
    if !bytes.starts_with(b"ply") {
        return Err(LoadError::parse(
            path,
            Location::Byte(0),
            "not a PLY file (does not start with 'ply')",
        ));
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut pos = 0usize;
    let mut line_no = 0usize;
    loop {
        line_no += 1;
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(line_err(line_no, "no 'end_header' line".into()));
        };
        let raw = &bytes[pos..pos + len];
        pos += len + 1;
        let text = String::from_utf8_lossy(raw);
        let mut words = text.split_ascii_whitespace();
        match words.next() {
            Some("ply") | Some("comment") | Some("obj_info") | None => {}
            Some("format") => {
                encoding = Some(match words.next() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::BinaryLittle,
                    Some("binary_big_endian") => Encoding::BinaryBig,
                    other => {
                        return Err(line_err(
                            line_no,
                            format!("unknown format {:?}", other.unwrap_or("")),
                        ))
                    }
                });
            }
            Some("element") => {
                let (Some(name), Some(count)) = (words.next(), words.next()) else {
                    return Err(line_err(line_no, "element needs a name and a count".into()));
                };
                let count = count
                    .parse::<u64>()
                    .map_err(|_| line_err(line_no, format!("bad element count '{count}'")))?;
                if elements.iter().any(|e| e.name == name) {
                    return Err(line_err(
                        line_no,
                        format!("a second 'element {name}' (each element is declared once)"),
                    ));
                }
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            Some("property") => {
                let Some(element) = elements.last_mut() else {
                    return Err(line_err(line_no, "property before any element".into()));
                };
                let ty = words.next().unwrap_or("");
                let scalar = |name: Option<&str>| {
                    let name = name.unwrap_or("");
                    Scalar::parse(name)
                        .ok_or_else(|| line_err(line_no, format!("unknown type '{name}'")))
                };
                let kind = if ty == "list" {
                    let count = scalar(words.next())?;
                    let item = scalar(words.next())?;
                    if !count.is_integer() {
                        return Err(line_err(
                            line_no,
                            "list count type must be an integer".into(),
                        ));
                    }
                    Kind::List { count, item }
                } else {
                    Kind::Scalar(scalar(Some(ty))?)
                };
                let Some(name) = words.next() else {
                    return Err(line_err(line_no, "property without a name".into()));
                };
                element.properties.push(Property {
                    name: name.to_string(),
                    kind,
                });
            }
            Some("end_header") => break,
            Some(other) => {
                return Err(line_err(
                    line_no,
                    format!("unknown header keyword '{other}'"),
                ))
            }
        }
    }
    let encoding = encoding.ok_or_else(|| line_err(line_no, "no 'format' line".into()))?;
    for e in &elements {
        if e.name == "vertex" {
            for axis in ["x", "y", "z"] {
                match e.find(&[axis]).map(|i| &e.properties[i].kind) {
                    Some(Kind::Scalar(_)) => {}
                    _ => {
                        return Err(LoadError::parse(
                            path,
                            Location::Element("element vertex".into()),
                            format!("no scalar property '{axis}'"),
                        ))
                    }
                }
            }
        }
    }
    Ok(Header {
        encoding,
        elements,
        data_start: pos,
        lines: line_no,
    })
}

/// Index of the face element's vertex list property, if this is a face element with one.
fn face_list(e: &Element) -> Option<usize> {
    if e.name != "face" {
        return None;
    }
    e.find(&["vertex_indices", "vertex_index"])
        .filter(|&i| matches!(e.properties[i].kind, Kind::List { .. }))
}

/// Appends the fan triangulation of `face` (index `face_index` in the face element) after
/// checking every index against `vertex_count`; a face of fewer than 3 indices is counted in
/// `mesh.short_faces`.
#[inline]
fn add_face(
    face: &[i64],
    face_index: u64,
    vertex_count: u32,
    mesh: &mut Mesh,
) -> Result<(), String> {
    for &i in face {
        if i < 0 || i >= i64::from(vertex_count) {
            return Err(format!(
                "face {face_index}: vertex index {i} out of range ({vertex_count} vertices)"
            ));
        }
    }
    if face.len() < 3 {
        if mesh.short_faces == 0 {
            mesh.first_short_face = face_index;
        }
        mesh.short_faces += 1;
    }
    for k in 1..face.len().saturating_sub(1) {
        mesh.triangles
            .push([face[0] as u32, face[k] as u32, face[k + 1] as u32]);
    }
    Ok(())
}

/// Converts a list item read as `f64` to an index; fractional or huge values become -1 so
/// that the range check rejects them.
#[inline]
fn as_index(v: f64) -> i64 {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        v as i64
    } else {
        -1
    }
}

fn read_binary(
    path: &Path,
    bytes: &[u8],
    header: &Header,
    big: bool,
    vertex_count: u32,
    mesh: &mut Mesh,
) -> Result<(), LoadError> {
    let mut pos = header.data_start;
    let truncated = |pos: usize, e: &Element, item: u64| {
        LoadError::parse(
            path,
            Location::Byte(pos as u64),
            format!("element {} item {item}: file ends early", e.name),
        )
    };
    for e in &header.elements {
        let remaining = bytes.len() - pos;
        let stride = e.fixed_stride();
        // Reject counts the remaining bytes cannot hold before reserving memory for them.
        let min_item = stride.unwrap_or_else(|| {
            e.properties
                .iter()
                .map(|p| match p.kind {
                    Kind::Scalar(s) => s.size(),
                    Kind::List { count, .. } => count.size(),
                })
                .sum()
        });
        if (e.count as u128) * (min_item as u128) > remaining as u128 {
            return Err(LoadError::parse(
                path,
                Location::Byte(pos as u64),
                format!(
                    "element {}: {} items need at least {} bytes, {remaining} left",
                    e.name,
                    e.count,
                    (e.count as u128) * (min_item as u128)
                ),
            ));
        }
        let count = e.count as usize;
        if e.name == "vertex" {
            mesh.positions.reserve(count);
            let axes = [e.find(&["x"]), e.find(&["y"]), e.find(&["z"])];
            match stride {
                Some(stride) => {
                    // Offsets and types of x, y, z inside one fixed-size item.
                    let mut offsets = [(0usize, Scalar::F32); 3];
                    for (slot, axis) in offsets.iter_mut().zip(axes) {
                        let axis = axis.unwrap_or(0);
                        let offset: usize = e.properties[..axis]
                            .iter()
                            .map(|p| match p.kind {
                                Kind::Scalar(s) => s.size(),
                                Kind::List { .. } => 0,
                            })
                            .sum();
                        let ty = match e.properties[axis].kind {
                            Kind::Scalar(s) => s,
                            Kind::List { .. } => Scalar::F32,
                        };
                        *slot = (offset, ty);
                    }
                    let data = &bytes[pos..pos + count * stride];
                    let all_f32 = offsets.iter().all(|&(_, t)| t == Scalar::F32);
                    if all_f32 && !big {
                        let f = |item: &[u8], o: usize| {
                            f32::from_le_bytes([item[o], item[o + 1], item[o + 2], item[o + 3]])
                        };
                        let [(ox, _), (oy, _), (oz, _)] = offsets;
                        mesh.positions.extend(
                            data.chunks_exact(stride)
                                .map(|item| Vec3::new(f(item, ox), f(item, oy), f(item, oz))),
                        );
                    } else {
                        mesh.positions.extend(data.chunks_exact(stride).map(|item| {
                            let [x, y, z] = offsets.map(|(o, t)| t.read(&item[o..], big) as f32);
                            Vec3::new(x, y, z)
                        }));
                    }
                    pos += count * stride;
                }
                None => {
                    let mut values = vec![0.0f64; e.properties.len()];
                    for item in 0..e.count {
                        pos = read_item_binary(bytes, pos, e, big, &mut values, None)
                            .ok_or_else(|| truncated(pos, e, item))?;
                        let [x, y, z] = axes.map(|a| values[a.unwrap_or(0)] as f32);
                        mesh.positions.push(Vec3::new(x, y, z));
                    }
                }
            }
        } else if let Some(list) = face_list(e) {
            let fast = e.properties.len() == 1
                && matches!(
                    e.properties[0].kind,
                    Kind::List {
                        count: Scalar::U8,
                        item: Scalar::I32 | Scalar::U32
                    }
                );
            mesh.triangles.reserve(count);
            let face_err = |pos: usize, message: String| {
                LoadError::parse(
                    path,
                    Location::Byte(pos as u64),
                    format!("element face: {message}"),
                )
            };
            if fast {
                // `list uchar int`: one count byte, then 4-byte indices; triangles (count 3)
                // skip the general per-index conversion.
                let signed = matches!(
                    e.properties[0].kind,
                    Kind::List {
                        item: Scalar::I32,
                        ..
                    }
                );
                let mut face = [0i64; 255];
                for item in 0..e.count {
                    let start = pos;
                    let n = *bytes.get(pos).ok_or_else(|| truncated(pos, e, item))? as usize;
                    let end = pos + 1 + 4 * n;
                    let Some(data) = bytes.get(pos + 1..end) else {
                        return Err(truncated(pos, e, item));
                    };
                    if n == 3 {
                        let idx = |k: usize| {
                            let b = [
                                data[4 * k],
                                data[4 * k + 1],
                                data[4 * k + 2],
                                data[4 * k + 3],
                            ];
                            if big {
                                u32::from_be_bytes(b)
                            } else {
                                u32::from_le_bytes(b)
                            }
                        };
                        let t = [idx(0), idx(1), idx(2)];
                        if let Some(&bad) = t.iter().find(|&&i| i >= vertex_count) {
                            let shown = if signed {
                                i64::from(bad as i32)
                            } else {
                                i64::from(bad)
                            };
                            return Err(face_err(
                                start,
                                format!(
                                    "face {item}: vertex index {shown} out of range \
                                     ({vertex_count} vertices)"
                                ),
                            ));
                        }
                        mesh.triangles.push(t);
                    } else {
                        let ty = match e.properties[0].kind {
                            Kind::List { item, .. } => item,
                            Kind::Scalar(s) => s,
                        };
                        for (k, slot) in face[..n].iter_mut().enumerate() {
                            *slot = as_index(ty.read(&data[4 * k..], big));
                        }
                        add_face(&face[..n], item, vertex_count, mesh)
                            .map_err(|m| face_err(start, m))?;
                    }
                    pos = end;
                }
            } else {
                let mut values = vec![0.0f64; e.properties.len()];
                let mut face = Vec::new();
                for item in 0..e.count {
                    let start = pos;
                    face.clear();
                    pos =
                        read_item_binary(bytes, pos, e, big, &mut values, Some((list, &mut face)))
                            .ok_or_else(|| truncated(start, e, item))?;
                    add_face(&face, item, vertex_count, mesh).map_err(|m| face_err(start, m))?;
                }
            }
        } else if let Some(stride) = stride {
            pos += count * stride;
        } else {
            let mut values = vec![0.0f64; e.properties.len()];
            for item in 0..e.count {
                pos = read_item_binary(bytes, pos, e, big, &mut values, None)
                    .ok_or_else(|| truncated(pos, e, item))?;
            }
        }
    }
    if pos < bytes.len() {
        mesh.warnings.push(format!(
            "{} bytes after the last element (from byte offset {pos}) are ignored",
            bytes.len() - pos
        ));
    }
    Ok(())
}

/// Reads one binary item of `e` at `pos`: scalars go to `values`, the items of list property
/// `list.0` (if given) to `list.1`, other lists are skipped. Returns the position after the
/// item, or `None` when the data ends early.
fn read_item_binary(
    bytes: &[u8],
    mut pos: usize,
    e: &Element,
    big: bool,
    values: &mut [f64],
    mut list: Option<(usize, &mut Vec<i64>)>,
) -> Option<usize> {
    for (i, p) in e.properties.iter().enumerate() {
        match p.kind {
            Kind::Scalar(s) => {
                values[i] = s.read(bytes.get(pos..pos + s.size())?, big);
                pos += s.size();
            }
            Kind::List { count, item } => {
                let n = as_index(count.read(bytes.get(pos..pos + count.size())?, big));
                pos += count.size();
                let n = usize::try_from(n).ok()?;
                let len = n.checked_mul(item.size())?;
                let data = bytes.get(pos..pos.checked_add(len)?)?;
                if let Some((target, out)) = list.as_mut() {
                    if *target == i {
                        out.extend(
                            data.chunks_exact(item.size())
                                .map(|b| as_index(item.read(b, big))),
                        );
                    }
                }
                pos += len;
            }
        }
    }
    Some(pos)
}

fn read_ascii(
    path: &Path,
    bytes: &[u8],
    header: &Header,
    vertex_count: u32,
    mesh: &mut Mesh,
) -> Result<(), LoadError> {
    let text = &bytes[header.data_start..];
    let mut lines = text
        .split(|&b| b == b'\n')
        .enumerate()
        .map(|(i, l)| (header.lines + 1 + i, l));
    let end_line = header.lines + 1 + text.split(|&b| b == b'\n').count();
    let mut words: Vec<&str> = Vec::new();
    let mut face: Vec<i64> = Vec::new();
    for e in &header.elements {
        let is_vertex = e.name == "vertex";
        let list = face_list(e);
        if is_vertex {
            // At least 6 bytes ("0 0 0\n") per vertex line: bound the reservation by the input.
            mesh.positions
                .reserve((e.count as usize).min(text.len() / 6));
        } else if list.is_some() {
            mesh.triangles
                .reserve((e.count as usize).min(text.len() / 8));
        }
        let axes = [e.find(&["x"]), e.find(&["y"]), e.find(&["z"])];
        let mut values = vec![0.0f64; e.properties.len()];
        for item in 0..e.count {
            // Blank lines between items are tolerated.
            let (line_no, line) = loop {
                let Some((n, l)) = lines.next() else {
                    return Err(LoadError::parse(
                        path,
                        Location::Line(end_line),
                        format!("element {} item {item}: file ends early", e.name),
                    ));
                };
                let l = std::str::from_utf8(l)
                    .map_err(|_| LoadError::parse(path, Location::Line(n), "not UTF-8 text"))?;
                if !l.trim().is_empty() {
                    break (n, l);
                }
            };
            let err = |message: String| {
                LoadError::parse(
                    path,
                    Location::Line(line_no),
                    format!("element {} item {item}: {message}", e.name),
                )
            };
            words.clear();
            words.extend(line.split_ascii_whitespace());
            let mut w = words.iter();
            let mut next = |what: &str| -> Result<f64, LoadError> {
                let word = w.next().ok_or_else(|| err(format!("missing {what}")))?;
                word.parse::<f64>()
                    .map_err(|_| err(format!("{what} '{word}' is not a number")))
            };
            face.clear();
            for (i, p) in e.properties.iter().enumerate() {
                match p.kind {
                    Kind::Scalar(_) => values[i] = next(&p.name)?,
                    Kind::List { .. } => {
                        let n = usize::try_from(as_index(next("list count")?))
                            .map_err(|_| err(format!("bad count of list {}", p.name)))?;
                        for _ in 0..n {
                            let v = next(&p.name)?;
                            if list == Some(i) {
                                face.push(as_index(v));
                            }
                        }
                    }
                }
            }
            let extra = w.count();
            if extra > 0 {
                return Err(err(format!(
                    "{extra} value(s) more than the element's properties declare ({} on the \
                     line): the data does not match the header",
                    words.len()
                )));
            }
            if is_vertex {
                let [x, y, z] = axes.map(|a| values[a.unwrap_or(0)] as f32);
                mesh.positions.push(Vec3::new(x, y, z));
            } else if list.is_some() {
                add_face(&face, item, vertex_count, mesh).map_err(err)?;
            }
        }
    }
    for (n, l) in lines {
        if !l.trim_ascii().is_empty() {
            let last = header.elements.last().map_or("header", |e| e.name.as_str());
            return Err(LoadError::parse(
                path,
                Location::Line(n),
                format!(
                    "data after the last item of element {last}: the element counts of the \
                     header do not match the data"
                ),
            ));
        }
    }
    Ok(())
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
