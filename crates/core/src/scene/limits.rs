//! Bounds on what loading reads and allocates, so that a hostile or broken file is an error
//! instead of an out-of-memory abort: the file itself (or its inflated gzip data) is read
//! through a cap, and every loader checks the counts a file declares against
//! [`LoadOptions::max_scene_bytes`] before it reserves memory for them.

use std::io::Read;
use std::path::Path;

use super::error::{LoadError, Location};
use super::options::LoadOptions;

/// Scene memory of one vertex (a `Vec3`), the figure of the [`super`] module docs ("Memory").
pub(crate) const VERTEX_BYTES: u64 = 12;
/// Scene memory of one triangle: three `u32` indices and its `u32` object id.
pub(crate) const TRIANGLE_BYTES: u64 = 16;

/// How every limit error says how to raise the limit.
pub(crate) const RAISE: &str = "raise it with --max-scene-bytes (LoadOptions::max_scene_bytes)";

/// `n` bytes for messages: `6442450944 bytes (6.0 GiB)`.
pub(crate) fn show_bytes(n: u64) -> String {
    format!("{n} bytes ({:.1} GiB)", n as f64 / (1u64 << 30) as f64)
}

/// Scene memory of `vertices` vertices and `triangles` triangles (saturating: a declared
/// count can be any `u64`).
pub(crate) fn geometry_bytes(vertices: u64, triangles: u64) -> u64 {
    vertices
        .saturating_mul(VERTEX_BYTES)
        .saturating_add(triangles.saturating_mul(TRIANGLE_BYTES))
}

/// Checks that a scene of `vertices` and `triangles` (as declared at `location`) fits in
/// [`LoadOptions::max_scene_bytes`]; loaders call it before reserving memory for them.
pub(crate) fn check_geometry(
    path: &Path,
    location: Location,
    vertices: u64,
    triangles: u64,
    options: &LoadOptions,
) -> Result<(), LoadError> {
    let bytes = geometry_bytes(vertices, triangles);
    if bytes <= options.max_scene_bytes {
        return Ok(());
    }
    Err(LoadError::limit(
        path,
        location,
        format!(
            "{vertices} vertices and {triangles} triangles need {} of scene memory, above the \
             limit of {}; {RAISE}",
            show_bytes(bytes),
            show_bytes(options.max_scene_bytes)
        ),
    ))
}

/// Reads all of `reader` but at most `limit` bytes: more is a [`LoadError::Limit`] saying
/// `what` (e.g. "the file", "the inflated gzip data") is too large. `size_hint` (the file
/// size, when known) only sizes the first allocation.
pub(crate) fn read_capped(
    path: &Path,
    reader: impl Read,
    limit: u64,
    size_hint: Option<u64>,
    what: &str,
) -> Result<Vec<u8>, LoadError> {
    let mut out = Vec::new();
    if let Some(hint) = size_hint {
        // Never more than the limit, whatever the metadata says.
        out.reserve(hint.min(limit) as usize);
    }
    reader
        .take(limit.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::InvalidData | std::io::ErrorKind::InvalidInput => {
                LoadError::Invalid {
                    path: path.to_path_buf(),
                    message: format!("{what}: {e}"),
                }
            }
            _ => LoadError::Io {
                path: path.to_path_buf(),
                source: e,
            },
        })?;
    if out.len() as u64 > limit {
        return Err(LoadError::limit(
            path,
            Location::Byte(limit),
            format!(
                "{what} is larger than the limit of {}; {RAISE}",
                show_bytes(limit)
            ),
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_bytes_saturate() {
        assert_eq!(geometry_bytes(1, 1), 28);
        assert_eq!(geometry_bytes(u64::MAX, 1), u64::MAX);
    }

    #[test]
    fn read_capped_rejects_more_than_the_limit() {
        let data = [7u8; 10];
        let p = Path::new("x.ply");
        assert_eq!(
            read_capped(p, &data[..], 10, None, "the file")
                .unwrap()
                .len(),
            10
        );
        let e = read_capped(p, &data[..], 9, Some(u64::MAX), "the file").unwrap_err();
        assert!(matches!(e, LoadError::Limit { .. }), "{e}");
        assert!(e.to_string().contains("--max-scene-bytes"), "{e}");
    }

    #[test]
    fn empty_reader_gives_empty_bytes() {
        let p = Path::new("x.ply");
        assert!(read_capped(p, std::io::empty(), 0, None, "the file")
            .unwrap()
            .is_empty());
    }
}
