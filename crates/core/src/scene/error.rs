//! Errors of scene loading, each naming the file and, where known, the place in it.

use std::fmt;
use std::path::PathBuf;

/// A place in an input file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    /// 1-based line of a text file.
    Line(usize),
    /// Byte offset from the start of a (decompressed) binary file.
    Byte(u64),
    /// An element of a structured file, e.g. "mesh 3, primitive 0" or "lump 13 (surfaces), record 12".
    Element(String),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(n) => write!(f, "line {n}"),
            Location::Byte(n) => write!(f, "byte offset {n}"),
            Location::Element(s) => f.write_str(s),
        }
    }
}

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LoadError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file's content is malformed.
    #[error("{path}: {location}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// Where in the file.
        location: Location,
        /// What is wrong.
        message: String,
    },
    /// The file's content is malformed somewhere we cannot pin down (e.g. inside a library).
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Loading would go past a limit of [`super::LoadOptions`] (memory, or a reference outside
    /// the scene's folder); the message names the option that raises it.
    #[error("{path}: {location}: {message}")]
    Limit {
        /// The file.
        path: PathBuf,
        /// Where in the file the count or reference that exceeds the limit is.
        location: Location,
        /// What exceeds which limit, and how to raise it.
        message: String,
    },
    /// The file extension names no format we read.
    #[error("{path}: unknown scene format (expected .obj, .ply, .gltf, .glb, .stl, .bsp, optionally .gz)")]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// A `procedural:` spec is malformed.
    #[error("scene spec '{spec}': {error}")]
    Spec {
        /// The spec as given.
        spec: String,
        /// What is wrong.
        #[source]
        error: super::procedural::params::SpecError,
    },
}

impl LoadError {
    /// A parse error at `location` in `path`.
    pub fn parse(path: impl Into<PathBuf>, location: Location, message: impl Into<String>) -> Self {
        LoadError::Parse {
            path: path.into(),
            location,
            message: message.into(),
        }
    }

    /// A [`LoadError::Limit`] at `location` in `path`.
    pub fn limit(path: impl Into<PathBuf>, location: Location, message: impl Into<String>) -> Self {
        LoadError::Limit {
            path: path.into(),
            location,
            message: message.into(),
        }
    }
}
