//! OBJ loader (being written).

use std::path::Path;

use super::{LoadError, Scene};

/// Loads a OBJ file from its (decompressed) bytes; `path` is for error messages.
pub fn load(path: &Path, _bytes: &[u8]) -> Result<Scene, LoadError> {
    Err(LoadError::Invalid {
        path: path.to_path_buf(),
        message: "OBJ loader not yet written".into(),
    })
}
