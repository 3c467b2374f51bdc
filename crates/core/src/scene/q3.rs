//! Quake 3 IBSP v46 loader (being written).

use std::path::Path;

use super::{LoadError, LoadOptions, Scene};

/// Quake 3 map data beyond triangles: clusters, leaves and the compiled PVS.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BspData {}

/// Loads a Quake 3 `.bsp` file from its bytes; `path` is for error messages.
pub fn load(path: &Path, _bytes: &[u8], _options: &LoadOptions) -> Result<Scene, LoadError> {
    Err(LoadError::Invalid {
        path: path.to_path_buf(),
        message: "BSP loader not yet written".into(),
    })
}
