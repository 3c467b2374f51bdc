//! Scene specs: a file path or `procedural:NAME?seed=S&size=N`, and the loader dispatch.

use std::io::Read;
use std::path::{Path, PathBuf};

use super::{procedural, LoadError, Scene};

/// Options that change how files are turned into triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoadOptions {
    /// Quake 3 bezier patches: each 3x3 sub-patch is tessellated into an `n x n` grid of quads
    /// (`2 n²` triangles). 0 leaves patches out.
    pub patch_subdivisions: u32,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            patch_subdivisions: 4,
        }
    }
}

/// A parsed scene spec.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneSpec {
    /// A file on disk.
    File(PathBuf),
    /// A procedural generator with its parameters.
    Procedural(procedural::Params),
}

impl SceneSpec {
    /// Parses `procedural:NAME[?key=value&...]` or takes anything else as a path.
    pub fn parse(spec: &str) -> Result<Self, LoadError> {
        match spec.strip_prefix("procedural:") {
            Some(rest) => procedural::Params::parse(rest)
                .map(SceneSpec::Procedural)
                .map_err(|message| LoadError::Spec {
                    spec: spec.to_string(),
                    message,
                }),
            None => Ok(SceneSpec::File(PathBuf::from(spec))),
        }
    }
}

/// Loads or generates the scene named by `spec` (see [`SceneSpec::parse`]).
pub fn open(spec: &str, options: &LoadOptions) -> Result<Scene, LoadError> {
    match SceneSpec::parse(spec)? {
        SceneSpec::Procedural(params) => Ok(procedural::generate(&params)),
        SceneSpec::File(path) => load_file(&path, options),
    }
}

/// Loads a scene file, choosing the format by extension; `.gz` files are decompressed first.
pub fn load_file(path: &Path, options: &LoadOptions) -> Result<Scene, LoadError> {
    let io = |source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    };
    let raw = std::fs::read(path).map_err(io)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let (bytes, inner) = match name.strip_suffix(".gz") {
        Some(inner) => {
            let mut out = Vec::new();
            flate2::read::MultiGzDecoder::new(raw.as_slice())
                .read_to_end(&mut out)
                .map_err(|e| LoadError::Invalid {
                    path: path.to_path_buf(),
                    message: format!("gzip decompression failed: {e}"),
                })?;
            (out, inner.to_string())
        }
        None => (raw, name),
    };
    let ext = inner.rsplit('.').next().unwrap_or("");
    let mut scene = match ext {
        "obj" => super::obj::load(path, &bytes)?,
        "ply" => super::ply::load(path, &bytes)?,
        "stl" => super::stl::load(path, &bytes)?,
        "gltf" | "glb" => super::gltf::load(path, &bytes)?,
        "bsp" => super::q3::load(path, &bytes, options)?,
        _ => {
            return Err(LoadError::UnknownFormat {
                path: path.to_path_buf(),
            })
        }
    };
    scene.source = path.display().to_string();
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_extension_is_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("scene.xyz");
        std::fs::write(&p, b"hello").unwrap();
        let e = load_file(&p, &LoadOptions::default()).unwrap_err();
        assert!(matches!(e, LoadError::UnknownFormat { .. }), "{e}");
    }

    #[test]
    fn missing_file_names_path() {
        let e = open("/nonexistent/dir/scene.obj", &LoadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/dir/scene.obj"), "{e}");
    }

    #[test]
    fn bad_gzip_is_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("scene.obj.gz");
        std::fs::write(&p, b"not gzip at all").unwrap();
        let e = load_file(&p, &LoadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("gzip"), "{e}");
    }

    #[test]
    fn spec_without_prefix_is_file() {
        assert_eq!(
            SceneSpec::parse("a/b.obj").unwrap(),
            SceneSpec::File("a/b.obj".into())
        );
    }
}
