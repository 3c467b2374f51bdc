//! glTF buffers (specification section 3.6.1): the bytes of the buffers that geometry needs,
//! fetched from the GLB `BIN` chunk, a base64 `data:` URI or a file next to the `.gltf` file
//! under the rules of the module docs (regular files inside the `.gltf` file's folder unless
//! [`LoadOptions::allow_outside_refs`], no URI schemes), each cut to its `byteLength`.

use std::borrow::Cow;
use std::path::Path;

use gltf::mesh::{Mode, Semantic};

use super::super::error::{LoadError, Location};
use super::super::limits::{show_bytes, RAISE};
use super::super::options::LoadOptions;

/// Whether primitives of this mode have triangles (the others are points and lines).
pub(super) fn is_triangle_mode(mode: Mode) -> bool {
    matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    )
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

/// Fetches the bytes of every buffer geometry needs (GLB blob, data URI or external file),
/// each cut to its `byteLength`; the others are left empty.
pub(super) fn load_buffers<'a>(
    path: &Path,
    doc: &gltf::Document,
    blob: Option<&'a [u8]>,
    options: &LoadOptions,
) -> Result<Vec<Cow<'a, [u8]>>, LoadError> {
    let needed = geometry_buffers(doc);
    check_declared_size(path, doc, &needed, options)?;
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        if !needed[buffer.index()] {
            out.push(Cow::Borrowed(&[][..]));
            continue;
        }
        out.push(buffer_bytes(path, &buffer, blob, options)?);
    }
    Ok(out)
}

/// Before anything is read: the `byteLength`s of the needed buffers must fit in
/// [`LoadOptions::max_scene_bytes`] together.
fn check_declared_size(
    path: &Path,
    doc: &gltf::Document,
    needed: &[bool],
    options: &LoadOptions,
) -> Result<(), LoadError> {
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
    Ok(())
}

/// The bytes of one buffer, from wherever its source says, cut to its `byteLength` (an error
/// when fewer bytes are available).
fn buffer_bytes<'a>(
    path: &Path,
    buffer: &gltf::Buffer,
    blob: Option<&'a [u8]>,
    options: &LoadOptions,
) -> Result<Cow<'a, [u8]>, LoadError> {
    let err = |message: String| {
        LoadError::parse(
            path,
            Location::Element(format!("buffer {}", buffer.index())),
            message,
        )
    };
    let data: Cow<'a, [u8]> = match buffer.source() {
        gltf::buffer::Source::Bin => blob
            .ok_or_else(|| err("refers to the GLB BIN chunk, which is missing".into()))?
            .into(),
        gltf::buffer::Source::Uri(uri) => {
            if let Some(rest) = uri.strip_prefix("data:") {
                decode_data_uri(rest).map_err(err)?.into()
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
    Ok(match data {
        Cow::Borrowed(b) => Cow::Borrowed(&b[..buffer.length()]),
        Cow::Owned(mut v) => {
            v.truncate(buffer.length());
            Cow::Owned(v)
        }
    })
}

/// The payload of a `data:` URI (`rest` is what follows `data:`); only base64 ones are read.
fn decode_data_uri(rest: &str) -> Result<Vec<u8>, String> {
    let (meta, payload) = rest
        .split_once(',')
        .ok_or_else(|| "data URI without ','".to_string())?;
    if !meta.ends_with(";base64") {
        return Err("data URI is not base64".into());
    }
    base64::decode(payload).map_err(|e| format!("bad base64 in data URI: {e}"))
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
