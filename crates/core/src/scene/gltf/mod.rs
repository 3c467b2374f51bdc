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
//! - [`Object::name`] is the node path: the names of the node's ancestors from its scene root
//!   down to the node itself, joined with `/` (`Root/House/Door.001`); a node without a name
//!   (or with an empty one) is written `#<node index>` (`Root/#7`). Names are not escaped: a
//!   `/` inside a node name looks like a level of the path, and two sibling nodes with the
//!   same name have the same path, so `index` is the identity to rely on.
//! - [`Object::index`] is the node index (in the file's `nodes` array), [`Object::part`] the
//!   primitive index in the node's mesh (the primitive's own index, counting skipped ones).
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

use std::collections::HashMap;
use std::io::{self, Write};
use std::path::Path;
use std::rc::Rc;

use glam::{Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::{Mode, Semantic};

use super::builder::SceneBuilder;
use super::error::{LoadError, Location};
use super::limits::{check_geometry, show_bytes, RAISE};
use super::options::LoadOptions;
use super::types::{Object, Scene, UpAxis};

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

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
    check_index_widths(path, json)?;
    let root = gltf::json::Root::from_slice(json)
        .map_err(|e| json_error(path, gltf::Error::Deserialize(e)))?;
    check_position_indices(path, &root)?;
    let document = gltf::Document::from_json(root).map_err(|e| json_error(path, e))?;
    let buffers = load_buffers(path, &document, blob, options)?;
    build_scene(path, &document, &buffers, options)
}

/// gltf-json 1.4 reads every index as `value as u32`, so `"mesh": 4294967296` would silently
/// be mesh 0: every integer above `u32::MAX` is an error here, except in the size and count
/// members (`byteLength`, `byteOffset`, `byteStride`, `count`, read as 64-bit) and in
/// `extras` and `extensions` (application data that is not read). JSON that does not parse is
/// left to the `gltf` crate, whose error names the line.
fn check_index_widths(path: &Path, json: &[u8]) -> Result<(), LoadError> {
    /// The JSON path and value of the first integer too wide for an index.
    fn walk(value: &serde_json::Value, at: &mut String) -> Option<(String, u64)> {
        match value {
            serde_json::Value::Number(n) => n
                .as_u64()
                .filter(|&v| v > u64::from(u32::MAX))
                .map(|v| (at.clone(), v)),
            serde_json::Value::Array(items) => items.iter().enumerate().find_map(|(i, item)| {
                let len = at.len();
                at.push_str(&format!("[{i}]"));
                let found = walk(item, at);
                at.truncate(len);
                found
            }),
            serde_json::Value::Object(members) => members.iter().find_map(|(key, item)| {
                let skip = [
                    "extras",
                    "extensions",
                    "byteLength",
                    "byteOffset",
                    "byteStride",
                    "count",
                ];
                if skip.contains(&key.as_str()) {
                    return None;
                }
                let len = at.len();
                if !at.is_empty() {
                    at.push('.');
                }
                at.push_str(key);
                let found = walk(item, at);
                at.truncate(len);
                found
            }),
            _ => None,
        }
    }
    let Ok(value) = serde_json::from_slice::<serde_json::Value>(json) else {
        return Ok(());
    };
    match walk(&value, &mut String::new()) {
        Some((at, v)) => Err(LoadError::parse(
            path,
            Location::Element(at),
            format!("{v} is not a valid index (above 2^32 - 1)"),
        )),
        None => Ok(()),
    }
}

/// gltf-json 1.4 validation indexes `accessors[POSITION]` without a bounds check (a panic on
/// a bad index, found by our fuzz test), so that one reference is checked here first.
fn check_position_indices(path: &Path, root: &gltf::json::Root) -> Result<(), LoadError> {
    let position = gltf::json::validation::Checked::Valid(Semantic::Positions);
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(index) = primitive.attributes.get(&position) {
                if index.value() >= root.accessors.len() {
                    return Err(LoadError::parse(
                        path,
                        Location::Element(format!("mesh {m}, primitive {p}")),
                        format!(
                            "POSITION accessor {} does not exist ({} accessors)",
                            index.value(),
                            root.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

fn is_glb_name(path: &Path) -> bool {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    name.ends_with(".glb") || name.ends_with(".glb.gz")
}

fn json_error(path: &Path, e: gltf::Error) -> LoadError {
    match e {
        gltf::Error::Deserialize(e) => {
            LoadError::parse(path, Location::Line(e.line()), format!("glTF JSON: {e}"))
        }
        gltf::Error::Validation(list) => match list.first() {
            Some((where_, what)) => LoadError::parse(
                path,
                Location::Element(where_.to_string()),
                format!("invalid glTF: {what}"),
            ),
            None => LoadError::Invalid {
                path: path.to_path_buf(),
                message: "invalid glTF".into(),
            },
        },
        other => LoadError::Invalid {
            path: path.to_path_buf(),
            message: format!("glTF: {other}"),
        },
    }
}

fn read_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a GLB file into its JSON chunk and optional BIN chunk (GLB spec 4.4).
fn split_glb<'a>(path: &Path, bytes: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>), LoadError> {
    let err =
        |at: usize, message: String| LoadError::parse(path, Location::Byte(at as u64), message);
    let version = read_u32(bytes, 4).ok_or_else(|| err(4, "GLB header is cut short".into()))?;
    if version != 2 {
        return Err(err(
            4,
            format!("GLB version {version}, only 2 is supported"),
        ));
    }
    let total =
        read_u32(bytes, 8).ok_or_else(|| err(8, "GLB header is cut short".into()))? as usize;
    if total > bytes.len() {
        return Err(err(
            8,
            format!(
                "GLB header declares {total} bytes, the file has {}",
                bytes.len()
            ),
        ));
    }
    let bytes = &bytes[..total];
    let mut chunks = Vec::new();
    let mut at = 12usize;
    while at < bytes.len() {
        let (Some(len), Some(kind)) = (read_u32(bytes, at), read_u32(bytes, at + 4)) else {
            return Err(err(at, "chunk header is cut short".into()));
        };
        let start = at + 8;
        let Some(data) = start
            .checked_add(len as usize)
            .and_then(|end| bytes.get(start..end))
        else {
            return Err(err(
                at,
                format!("chunk of {len} bytes runs past the end of the file"),
            ));
        };
        chunks.push((at, kind, data));
        // Chunks are 4-byte aligned; tolerate a missing final pad.
        at = start + (len as usize).next_multiple_of(4);
    }
    let Some(&(_, CHUNK_JSON, json)) = chunks.first() else {
        return Err(err(12, "first chunk is not JSON".into()));
    };
    let blob = chunks
        .iter()
        .skip(1)
        .find(|c| c.1 == CHUNK_BIN)
        .map(|c| c.2);
    Ok((json, blob))
}

/// Indices of the buffers that the `POSITION` and `indices` accessors of triangle primitives
/// use: the only ones geometry needs.
fn geometry_buffers(doc: &gltf::Document) -> Vec<bool> {
    let mut needed = vec![false; doc.buffers().len()];
    for mesh in doc.meshes() {
        for primitive in mesh.primitives() {
            if !is_triangle_mode(primitive.mode()) {
                continue;
            }
            let accessors = primitive.get(&Semantic::Positions).into_iter();
            for accessor in accessors.chain(primitive.indices()) {
                if let Some(view) = accessor.view() {
                    if let Some(flag) = needed.get_mut(view.buffer().index()) {
                        *flag = true;
                    }
                }
            }
        }
    }
    needed
}

fn is_triangle_mode(mode: Mode) -> bool {
    matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    )
}

/// Fetches the bytes of every buffer geometry needs (GLB blob, data URI or external file),
/// each cut to its `byteLength`; the others are left empty.
fn load_buffers<'a>(
    path: &Path,
    doc: &gltf::Document,
    blob: Option<&'a [u8]>,
    options: &LoadOptions,
) -> Result<Vec<std::borrow::Cow<'a, [u8]>>, LoadError> {
    let needed = geometry_buffers(doc);
    let total: u64 = doc
        .buffers()
        .filter(|b| needed[b.index()])
        .map(|b| b.length() as u64)
        .sum();
    if total > options.max_scene_bytes {
        return Err(LoadError::limit(
            path,
            Location::Element("buffers".into()),
            format!(
                "the buffers geometry needs declare {} (byteLength), above the limit of {}; \
                 {RAISE}",
                show_bytes(total),
                show_bytes(options.max_scene_bytes)
            ),
        ));
    }
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        if !needed[buffer.index()] {
            out.push(std::borrow::Cow::Borrowed(&[][..]));
            continue;
        }
        let err = |message: String| {
            LoadError::parse(
                path,
                Location::Element(format!("buffer {}", buffer.index())),
                message,
            )
        };
        let data: std::borrow::Cow<'a, [u8]> = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .ok_or_else(|| err("refers to the GLB BIN chunk, which is missing".into()))?
                .into(),
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (meta, payload) = rest
                        .split_once(',')
                        .ok_or_else(|| err("data URI without ','".into()))?;
                    if !meta.ends_with(";base64") {
                        return Err(err("data URI is not base64".into()));
                    }
                    base64::decode(payload)
                        .map_err(|e| err(format!("bad base64 in data URI: {e}")))?
                        .into()
                } else {
                    read_external(path, buffer.index(), uri, buffer.length(), options)?.into()
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(err(format!(
                "byteLength is {} but only {} bytes are available",
                buffer.length(),
                data.len()
            )));
        }
        // Views must fit in the declared length, not in what the chunk or URI happens to hold.
        let data = match data {
            std::borrow::Cow::Borrowed(b) => std::borrow::Cow::Borrowed(&b[..buffer.length()]),
            std::borrow::Cow::Owned(mut v) => {
                v.truncate(buffer.length());
                std::borrow::Cow::Owned(v)
            }
        };
        out.push(data);
    }
    Ok(out)
}

/// Reads the first `length` bytes of the external buffer file `uri` of buffer `index`, under
/// the rules of the module docs (regular files only, inside the `.gltf` file's folder unless
/// [`LoadOptions::allow_outside_refs`]).
fn read_external(
    path: &Path,
    index: usize,
    uri: &str,
    length: usize,
    options: &LoadOptions,
) -> Result<Vec<u8>, LoadError> {
    let location = || Location::Element(format!("buffer {index}"));
    let err = |message: String| LoadError::parse(path, location(), message);
    // `scheme:` before any `/` (http:, file:, ...): not a relative path.
    if let Some(colon) = uri.find(':') {
        if !uri[..colon].contains('/') {
            return Err(err(format!(
                "uri '{uri}' has a scheme; only data: URIs and relative file paths are read"
            )));
        }
    }
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let file = folder.join(uri);
    let io = |source| LoadError::Io {
        path: file.clone(),
        source,
    };
    // Before opening: a FIFO would block the open, a device would never end.
    let meta = std::fs::metadata(&file).map_err(io)?;
    if !meta.is_file() {
        return Err(err(format!(
            "uri '{uri}' ({}) is not a regular file",
            file.display()
        )));
    }
    if !options.allow_outside_refs {
        let base = folder.canonicalize().map_err(io)?;
        let real = file.canonicalize().map_err(io)?;
        if !real.starts_with(&base) {
            return Err(LoadError::limit(
                path,
                location(),
                format!(
                    "uri '{uri}' resolves to {}, outside the folder of the glTF file ({}); \
                     allow it with --allow-outside-refs (LoadOptions::allow_outside_refs)",
                    real.display(),
                    base.display()
                ),
            ));
        }
    }
    let mut open = std::fs::OpenOptions::new();
    open.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        // The file may have been swapped for a FIFO since the check: never block on it.
        open.custom_flags(libc::O_NONBLOCK);
    }
    let handle = open.open(&file).map_err(io)?;
    let meta = handle.metadata().map_err(io)?;
    if !meta.is_file() {
        return Err(err(format!(
            "uri '{uri}' ({}) is not a regular file",
            file.display()
        )));
    }
    if meta.len() < length as u64 {
        return Err(err(format!(
            "uri '{uri}' has {} bytes, byteLength is {length}",
            meta.len()
        )));
    }
    let mut data = Vec::with_capacity(length);
    std::io::Read::read_to_end(&mut std::io::Read::take(handle, length as u64), &mut data)
        .map_err(io)?;
    if data.len() < length {
        return Err(err(format!(
            "uri '{uri}' ended after {} bytes, byteLength is {length}",
            data.len()
        )));
    }
    Ok(data)
}

/// The bytes of each element of `accessor`: `(data, first element offset, stride)`, with every
/// element checked to lie inside its buffer view and buffer.
fn accessor_bytes<'b>(
    accessor: &gltf::Accessor,
    buffers: &'b [std::borrow::Cow<'_, [u8]>],
) -> Result<(&'b [u8], usize, usize), String> {
    let what = || format!("accessor {}", accessor.index());
    if accessor.sparse().is_some() {
        return Err(format!("{}: sparse accessors are not supported", what()));
    }
    let view = accessor
        .view()
        .ok_or_else(|| format!("{}: no buffer view (not supported)", what()))?;
    let buffer = buffers
        .get(view.buffer().index())
        .ok_or_else(|| format!("{}: missing buffer", what()))?;
    let view_end = view
        .offset()
        .checked_add(view.length())
        .filter(|&end| end <= buffer.len())
        .ok_or_else(|| {
            format!(
                "{}: buffer view {} exceeds its buffer",
                what(),
                view.index()
            )
        })?;
    let data = &buffer[view.offset()..view_end];
    let element = accessor.size();
    let stride = view.stride().unwrap_or(element);
    if stride < element {
        return Err(format!(
            "{}: byteStride {stride} < element size {element}",
            what()
        ));
    }
    if accessor.count() > 0 {
        let end = (accessor.count() - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(accessor.offset()))
            .and_then(|x| x.checked_add(element));
        if !matches!(end, Some(end) if end <= data.len()) {
            return Err(format!(
                "{}: {} elements at offset {} do not fit in buffer view {} ({} bytes)",
                what(),
                accessor.count(),
                accessor.offset(),
                view.index(),
                data.len()
            ));
        }
    }
    Ok((data, accessor.offset(), stride))
}

fn read_positions(
    accessor: &gltf::Accessor,
    buffers: &[std::borrow::Cow<'_, [u8]>],
) -> Result<Vec<Vec3>, String> {
    if accessor.data_type() != DataType::F32 || accessor.dimensions() != Dimensions::Vec3 {
        return Err(format!(
            "accessor {}: POSITION must be VEC3 FLOAT",
            accessor.index()
        ));
    }
    let (data, offset, stride) = accessor_bytes(accessor, buffers)?;
    let f = |o: usize| f32::from_le_bytes([data[o], data[o + 1], data[o + 2], data[o + 3]]);
    Ok((0..accessor.count())
        .map(|i| {
            let o = offset + i * stride;
            Vec3::new(f(o), f(o + 4), f(o + 8))
        })
        .collect())
}

fn read_indices(
    accessor: &gltf::Accessor,
    buffers: &[std::borrow::Cow<'_, [u8]>],
) -> Result<Vec<u32>, String> {
    if accessor.dimensions() != Dimensions::Scalar {
        return Err(format!(
            "accessor {}: indices must be SCALAR",
            accessor.index()
        ));
    }
    let (data, offset, stride) = accessor_bytes(accessor, buffers)?;
    let at = |i: usize| offset + i * stride;
    let n = accessor.count();
    Ok(match accessor.data_type() {
        DataType::U8 => (0..n).map(|i| u32::from(data[at(i)])).collect(),
        DataType::U16 => (0..n)
            .map(|i| u32::from(u16::from_le_bytes([data[at(i)], data[at(i) + 1]])))
            .collect(),
        DataType::U32 => (0..n)
            .map(|i| {
                let o = at(i);
                u32::from_le_bytes([data[o], data[o + 1], data[o + 2], data[o + 3]])
            })
            .collect(),
        other => {
            return Err(format!(
                "accessor {}: index type {other:?} is not an unsigned integer",
                accessor.index()
            ))
        }
    })
}

/// Appends the triangles of one primitive, given its corner indices (relative to its own
/// positions, `vertex_count` of them) and mode. Returns false for modes without triangles.
fn triangulate(
    mode: Mode,
    indices: &[u32],
    vertex_count: usize,
    out: &mut Vec<[u32; 3]>,
) -> Result<(), String> {
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= vertex_count) {
        return Err(format!(
            "index {bad} out of range ({vertex_count} positions)"
        ));
    }
    match mode {
        Mode::Triangles => {
            if !indices.chunks_exact(3).remainder().is_empty() {
                return Err(format!("{} indices is not a multiple of 3", indices.len()));
            }
            out.extend(indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]));
        }
        Mode::TriangleStrip => {
            // Odd triangles swap their first two corners to keep a consistent winding
            // (glTF spec 3.7.2.1, same as OpenGL).
            for k in 0..indices.len().saturating_sub(2) {
                let (a, b, c) = (indices[k], indices[k + 1], indices[k + 2]);
                out.push(if k % 2 == 0 { [a, b, c] } else { [b, a, c] });
            }
        }
        Mode::TriangleFan => {
            for k in 1..indices.len().saturating_sub(1) {
                out.push([indices[0], indices[k], indices[k + 1]]);
            }
        }
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => {}
    }
    Ok(())
}

/// The node's local transform (`parent_from_node`), with its rotation normalised (module docs).
fn node_matrix(node: &gltf::Node) -> Result<Mat4, String> {
    let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            if !matrix.iter().all(|c| finite(c)) {
                return Err("matrix has a NaN or infinite value".into());
            }
            Ok(Mat4::from_cols_array_2d(&matrix))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            if !(finite(&translation) && finite(&rotation) && finite(&scale)) {
                return Err("translation, rotation or scale has a NaN or infinite value".into());
            }
            let q = glam::Quat::from_array(rotation);
            let length_squared = q.length_squared();
            if length_squared == 0.0 || !length_squared.is_finite() {
                return Err(format!(
                    "rotation {rotation:?} is not a rotation (zero length)"
                ));
            }
            // Unit within exporters' rounding: as written, so valid files keep their bits.
            let rotation = if (length_squared - 1.0).abs() <= 1e-5 {
                rotation
            } else {
                q.normalize().to_array()
            };
            let transform = gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            };
            Ok(Mat4::from_cols_array_2d(&transform.matrix()))
        }
    }
}

fn build_scene(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[std::borrow::Cow<'_, [u8]>],
    options: &LoadOptions,
) -> Result<Scene, LoadError> {
    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            let mut is_child = vec![false; doc.nodes().len()];
            for node in doc.nodes() {
                for child in node.children() {
                    if let Some(flag) = is_child.get_mut(child.index()) {
                        *flag = true;
                    }
                }
            }
            doc.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    };
    let mut builder = SceneBuilder::new(path.display().to_string());
    let mut visited = vec![false; doc.nodes().len()];
    // Depth-first with an explicit stack (no recursion depth limit to hit); children are
    // pushed in reverse so they pop in node order. Each entry carries its parent's world
    // transform and node path.
    let mut stack: Vec<(gltf::Node, Mat4, Rc<str>)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, Mat4::IDENTITY, Rc::from("")))
        .collect();
    let mut triangles = Vec::new();
    // Objects written by `write_glb`: object id of each `sightline.object` number.
    let mut tagged: HashMap<u32, u32> = HashMap::new();
    // Primitives skipped: not triangles, or without positions.
    let (mut not_triangles, mut no_positions) = (0usize, 0usize);
    while let Some((node, world_from_parent, parent_path)) = stack.pop() {
        let seen = visited
            .get_mut(node.index())
            .ok_or_else(|| LoadError::Invalid {
                path: path.to_path_buf(),
                message: format!("node {} does not exist", node.index()),
            })?;
        if *seen {
            return Err(LoadError::parse(
                path,
                Location::Element(format!("node {}", node.index())),
                "node is reached twice: the node hierarchy is not a tree",
            ));
        }
        *seen = true;
        let parent_from_node = node_matrix(&node).map_err(|message| {
            LoadError::parse(
                path,
                Location::Element(format!("node {}", node.index())),
                message,
            )
        })?;
        let world_from_node = world_from_parent * parent_from_node;
        let node_path: Rc<str> = {
            let segment = match node.name() {
                Some(name) if !name.is_empty() => name.to_string(),
                _ => format!("#{}", node.index()),
            };
            if parent_path.is_empty() {
                segment.into()
            } else {
                format!("{parent_path}/{segment}").into()
            }
        };
        if let Some(mesh) = node.mesh() {
            let tag = SightlineTag::of(&node);
            for primitive in mesh.primitives() {
                let err = |message: String| {
                    LoadError::parse(
                        path,
                        Location::Element(format!(
                            "mesh {}, primitive {}",
                            mesh.index(),
                            primitive.index()
                        )),
                        message,
                    )
                };
                if !is_triangle_mode(primitive.mode()) {
                    not_triangles += 1;
                    continue;
                }
                // A primitive without positions has nothing to draw (spec 3.7.2.1).
                let Some(position_accessor) = primitive.get(&Semantic::Positions) else {
                    no_positions += 1;
                    continue;
                };
                // Before reading: the scene this primitive would make (the accessors' counts
                // are checked against their views when read).
                let vertices = position_accessor.count() as u64;
                let corners = primitive.indices().map_or(vertices, |a| a.count() as u64);
                let new_triangles = match primitive.mode() {
                    Mode::Triangles => corners / 3,
                    _ => corners.saturating_sub(2),
                };
                let total_vertices = u64::from(builder.vertex_count()) + vertices;
                check_geometry(
                    path,
                    Location::Element(format!(
                        "mesh {}, primitive {}",
                        mesh.index(),
                        primitive.index()
                    )),
                    total_vertices,
                    builder.triangle_count() as u64 + new_triangles,
                    options,
                )?;
                if total_vertices > u64::from(u32::MAX) {
                    return Err(err(format!(
                        "the scene would have {total_vertices} vertices, more than 2^32 - 1"
                    )));
                }
                let positions = read_positions(&position_accessor, buffers).map_err(&err)?;
                let indices = match primitive.indices() {
                    Some(a) => read_indices(&a, buffers).map_err(&err)?,
                    None => (0..positions.len() as u32).collect(),
                };
                triangles.clear();
                triangulate(primitive.mode(), &indices, positions.len(), &mut triangles)
                    .map_err(&err)?;
                // One object per (node, primitive); nodes tagged by `write_glb` join the
                // object of their tag instead (module docs, "Objects").
                match &tag {
                    Some(tag) => match tagged.get(&tag.object) {
                        Some(&id) => builder.resume_object(id),
                        None => {
                            let id = builder.push_object(Object {
                                name: tag.name.clone().unwrap_or_else(|| node_path.to_string()),
                                index: tag.index,
                                part: tag.part,
                            });
                            tagged.insert(tag.object, id);
                        }
                    },
                    None => {
                        builder.push_object(Object {
                            name: node_path.to_string(),
                            index: Some(node.index() as u32),
                            part: Some(primitive.index() as u32),
                        });
                    }
                }
                let base = builder.vertex_count();
                for p in positions {
                    builder.add_vertex(world_from_node.transform_point3(p));
                }
                for t in &triangles {
                    builder.add_triangle(t.map(|i| base + i));
                }
            }
        }
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, world_from_node, node_path.clone()));
        }
    }
    if not_triangles > 0 {
        builder.warn(format!(
            "{not_triangles} primitive(s) of points or lines skipped (no triangles)"
        ));
    }
    if no_positions > 0 {
        builder.warn(format!(
            "{no_positions} triangle primitive(s) without POSITION skipped"
        ));
    }
    if builder.triangle_count() == 0 {
        builder.warn("the scene's nodes have no triangle primitives");
    }
    if !tagged.is_empty() {
        // Tagged objects take their `sightline.object` order (the ids they had when
        // written), untagged ones follow in walk order.
        let mut keys = vec![(1u8, u32::MAX); builder.objects().len()];
        for (&object, &id) in &tagged {
            keys[id as usize] = (0, object);
        }
        builder.sort_objects_by_key(&keys);
    }
    let mut scene = builder.finish();
    // A file `write_glb` wrote from a scene that was not Y-up holds that scene turned Y-up
    // (as glTF requires) and names the original axis: turn it back, exactly, so the loaded
    // scene has the original coordinates and ids (and so the `.pvs` files baked from it).
    if let Some(up) = written_up_axis(doc) {
        for p in &mut scene.positions {
            *p = up.from_y_up(*p);
        }
        scene.up = up;
    }
    Ok(scene)
}

/// The up axis `write_glb` recorded in the default scene's `extras.sightline.up`, if any.
fn written_up_axis(doc: &gltf::Document) -> Option<UpAxis> {
    #[derive(serde::Deserialize)]
    struct Extras {
        sightline: Tag,
    }
    #[derive(serde::Deserialize)]
    struct Tag {
        up: String,
    }
    let scene = doc.default_scene().or_else(|| doc.scenes().next())?;
    let raw = scene.extras().as_ref()?;
    let extras: Extras = serde_json::from_str(raw.get()).ok()?;
    UpAxis::parse(&extras.sightline.up)
}

/// The `extras.sightline` member of a node written by [`write_glb`]:
/// `{"object": k, "name": "...", "index": i, "part": p}`. `object` is required (a `u32`);
/// the rest are optional (`null` or missing = `None`; a missing name = the node path).
#[derive(Debug, serde::Deserialize)]
struct SightlineTag {
    object: u32,
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    index: Option<u32>,
    #[serde(default)]
    part: Option<u32>,
}

#[derive(serde::Deserialize)]
struct NodeExtras {
    sightline: SightlineTag,
}

impl SightlineTag {
    /// The node's tag; `None` when it has none or when its extras do not have the documented
    /// shape (such a node is then an ordinary node, not an error).
    fn of(node: &gltf::Node) -> Option<Self> {
        let raw = node.extras().as_ref()?;
        serde_json::from_str::<NodeExtras>(raw.get())
            .ok()
            .map(|e| e.sightline)
    }
}

/// Writes `scene` as a binary glTF 2.0 file (GLB): one mesh and one root node per run of
/// consecutive triangles of the same object (both named after the object), each with its own
/// `f32` VEC3 positions (only the vertices the run uses) and `u32` indices, in triangle-id
/// order, so loading the result gives the same triangle ids. Each node's
/// `extras.sightline = {"object", "name", "index", "part"}` names the object it belongs to
/// (module docs, "Objects"), so loading the result with [`load`] also gives the same objects:
/// ids, names, `index` and `part`. Objects without triangles are not written.
///
/// glTF is Y-up: a scene with another up axis is written turned so that its up axis is +Y (an
/// exact rotation, [`UpAxis::to_y_up`]), so other tools show it upright, and the scene's
/// `extras.sightline.up` names the original axis, so [`load`] turns it back: the same
/// coordinates, geometry hash and up axis as before writing.
pub fn write_glb(scene: &Scene, w: &mut impl Write) -> io::Result<()> {
    let mut bin: Vec<u8> = Vec::new();
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    let mut accessors = Vec::new();
    let mut views = Vec::new();
    let n = scene.triangles.len();
    let mut start = 0;
    let mut remap = vec![u32::MAX; scene.positions.len()];
    while start < n {
        let object = scene.object_of_triangle.get(start).copied().unwrap_or(0);
        let mut end = start + 1;
        while end < n && scene.object_of_triangle.get(end).copied().unwrap_or(0) == object {
            end += 1;
        }
        // Compact the vertices of this run, in first-use order.
        let mut used: Vec<u32> = Vec::new();
        let mut indices: Vec<u32> = Vec::with_capacity(3 * (end - start));
        for t in &scene.triangles[start..end] {
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
        let mut min = Vec3::splat(f32::MAX);
        let mut max = Vec3::splat(f32::MIN);
        let position_offset = bin.len();
        for &i in &used {
            // glTF is Y-up: other scenes are turned (exactly) and the scene's extras say from
            // which axis, so `load` turns them back.
            let p = scene.up.to_y_up(scene.positions[i as usize]);
            // min/max must be numbers in JSON; non-finite coordinates are left out of them.
            if p.is_finite() {
                min = min.min(p);
                max = max.max(p);
            }
            for c in p.to_array() {
                bin.extend_from_slice(&c.to_le_bytes());
            }
            remap[i as usize] = u32::MAX;
        }
        if min.x > max.x {
            (min, max) = (Vec3::ZERO, Vec3::ZERO);
        }
        let index_offset = bin.len();
        for i in &indices {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        let run = meshes.len();
        views.push(serde_json::json!({
            "buffer": 0, "byteOffset": position_offset,
            "byteLength": index_offset - position_offset, "target": 34962
        }));
        views.push(serde_json::json!({
            "buffer": 0, "byteOffset": index_offset,
            "byteLength": bin.len() - index_offset, "target": 34963
        }));
        accessors.push(serde_json::json!({
            "bufferView": 2 * run, "componentType": 5126, "count": used.len(), "type": "VEC3",
            "min": min.to_array(), "max": max.to_array()
        }));
        accessors.push(serde_json::json!({
            "bufferView": 2 * run + 1, "componentType": 5125, "count": indices.len(),
            "type": "SCALAR"
        }));
        let (name, index, part) = scene
            .objects
            .get(object as usize)
            .map_or(("default", None, None), |o| {
                (o.name.as_str(), o.index, o.part)
            });
        meshes.push(serde_json::json!({
            "name": name,
            "primitives": [{ "attributes": { "POSITION": 2 * run }, "indices": 2 * run + 1, "mode": 4 }]
        }));
        nodes.push(serde_json::json!({
            "name": name, "mesh": run,
            "extras": { "sightline": {
                "object": object, "name": name, "index": index, "part": part
            } }
        }));
        start = end;
    }
    // glTF forbids other empty arrays, so an empty scene is `scenes[0]` with no nodes (the
    // `gltf` crate insists on the `nodes` key) and nothing else.
    let mut root = serde_json::json!({
        "asset": { "version": "2.0", "generator": "sightline" },
        "scene": 0,
        "scenes": [{ "nodes": [] }],
    });
    if scene.up != UpAxis::Y {
        root["scenes"][0]["extras"] = serde_json::json!({ "sightline": { "up": scene.up.name() } });
    }
    if !meshes.is_empty() {
        root["scenes"][0]["nodes"] = (0..meshes.len()).collect::<Vec<_>>().into();
        root["nodes"] = nodes.into();
        root["meshes"] = meshes.into();
        root["accessors"] = accessors.into();
        root["bufferViews"] = views.into();
        root["buffers"] = serde_json::json!([{ "byteLength": bin.len() }]);
    }
    let mut json = serde_json::to_vec(&root).map_err(io::Error::other)?;
    // Chunk data must be 4-byte aligned: JSON is padded with spaces, BIN with zeros.
    json.resize(json.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let mut total = 12 + 8 + json.len();
    if !bin.is_empty() {
        total += 8 + bin.len();
    }
    let total = u32::try_from(total)
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "GLB larger than 4 GiB"))?;
    let mut w = io::BufWriter::new(w);
    w.write_all(GLB_MAGIC)?;
    w.write_all(&2u32.to_le_bytes())?;
    w.write_all(&total.to_le_bytes())?;
    w.write_all(&(json.len() as u32).to_le_bytes())?;
    w.write_all(&CHUNK_JSON.to_le_bytes())?;
    w.write_all(&json)?;
    if !bin.is_empty() {
        w.write_all(&(bin.len() as u32).to_le_bytes())?;
        w.write_all(&CHUNK_BIN.to_le_bytes())?;
        w.write_all(&bin)?;
    }
    w.flush()
}

#[cfg(test)]
mod tests {
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
