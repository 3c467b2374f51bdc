//! The GLB container of glTF 2.0 (specification section 4.4): a 12-byte header, then a JSON
//! chunk and an optional BIN chunk. Split here when reading (errors name the byte offset) and
//! assembled here when writing; what the chunks hold is the business of the other files.

use std::io::{self, Write};
use std::path::Path;

use super::super::error::{LoadError, Location};

/// The first four bytes of every GLB file.
pub(super) const GLB_MAGIC: &[u8; 4] = b"glTF";
/// Chunk type of the JSON chunk (`JSON` in ASCII, little-endian).
const CHUNK_JSON: u32 = 0x4E4F_534A;
/// Chunk type of the binary buffer chunk (`BIN\0`).
const CHUNK_BIN: u32 = 0x004E_4942;

/// Whether the file name says GLB (`.glb`, `.glb.gz`): such a file must start with the magic,
/// where a `.gltf` file is JSON.
pub(super) fn is_glb_name(path: &Path) -> bool {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    name.ends_with(".glb") || name.ends_with(".glb.gz")
}

/// The little-endian `u32` at byte `at`, or `None` past the end.
fn read_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a GLB file into its JSON chunk and optional BIN chunk (GLB spec 4.4).
pub(super) fn split_glb<'a>(
    path: &Path,
    bytes: &'a [u8],
) -> Result<(&'a [u8], Option<&'a [u8]>), LoadError> {
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

/// Writes the GLB header, the JSON chunk and (when not empty) the BIN chunk, each padded to
/// 4 bytes as the specification requires. An error when the whole is 4 GiB or more (the
/// header's length is a `u32`).
pub(super) fn write_chunks(
    mut json: Vec<u8>,
    mut bin: Vec<u8>,
    w: &mut impl Write,
) -> io::Result<()> {
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
