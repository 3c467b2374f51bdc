//! STL loader (being written).

use std::path::Path;

use super::{LoadError, Scene};

/// Loads a STL file from its (decompressed) bytes; `path` is for error messages.
pub fn load(path: &Path, _bytes: &[u8]) -> Result<Scene, LoadError> {
    Err(LoadError::Invalid {
        path: path.to_path_buf(),
        message: "STL loader not yet written".into(),
    })
}
