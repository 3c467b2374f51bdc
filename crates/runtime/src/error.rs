//! The one error type of the runtime: every way a `.pvs` can fail to open or answer.

use std::path::PathBuf;

/// Why a `.pvs` file could not be opened, or a query could not be answered.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is larger than the reader accepts.
    #[error("{path}: {bytes} bytes is more than the {limit}-byte limit for a .pvs file")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size.
        bytes: u64,
        /// The limit in force.
        limit: u64,
    },
    /// The first eight bytes are not the `.pvs` magic.
    #[error("not a .pvs file (bad magic bytes)")]
    BadMagic,
    /// The version is not one this build reads.
    #[error("unsupported .pvs version {0} (this build reads versions 1 and 2)")]
    UnsupportedVersion(u32),
    /// The file ends early.
    #[error("truncated at byte {offset}: expected {what}")]
    Truncated {
        /// Where the data ran out.
        offset: usize,
        /// What was being read.
        what: String,
    },
    /// A checksum or value does not match.
    #[error("corrupt at byte {offset}: {what}")]
    Corrupt {
        /// Where.
        offset: usize,
        /// What is wrong.
        what: String,
    },
    /// A version-1 file was asked for objects (it has triangle sets only).
    #[error(
        "this .pvs file has no object table (version {0}); bake it again to get per-object sets"
    )]
    NoObjects(u32),
    /// The file holds no conservative bounds (bake with `--bound` to get them).
    #[error(
        "this .pvs file holds no conservative bounds; bake it with `pvs bake --bound` (or add \
         them with `pvs bound`) to get the per-cell superset"
    )]
    NoBound,
    /// A cell index past the file's cells.
    #[error("cell {cell} does not exist (the file has {count} cells)")]
    NoSuchCell {
        /// The index asked for.
        cell: u32,
        /// The number of cells.
        count: u32,
    },
    /// An object index past the file's objects.
    #[error("object {object} does not exist (the file has {count} objects)")]
    NoSuchObject {
        /// The index asked for.
        object: u32,
        /// The number of objects.
        count: u32,
    },
}

impl Error {
    pub(crate) fn corrupt(offset: usize, what: impl Into<String>) -> Self {
        Error::Corrupt {
            offset,
            what: what.into(),
        }
    }
}
