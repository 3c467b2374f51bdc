//! Scene specs: a file path or `procedural:NAME?seed=S&size=N`, and the loader dispatch.

use std::path::{Path, PathBuf};

use super::error::{LoadError, Location};
use super::limits::read_capped;
use super::options::LoadOptions;
use super::procedural;
use super::types::Scene;
use super::up_axis::infer_up_axis;

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
                .map_err(|error| LoadError::Spec {
                    spec: spec.to_string(),
                    error,
                }),
            None => Ok(SceneSpec::File(PathBuf::from(spec))),
        }
    }
}

/// Loads or generates the scene named by `spec` (see [`SceneSpec::parse`]).
pub fn open(spec: &str, options: &LoadOptions) -> Result<Scene, LoadError> {
    match SceneSpec::parse(spec)? {
        SceneSpec::Procedural(params) => {
            let mut scene = procedural::generate(&params);
            if let Some(up) = options.up_axis {
                scene.up = up;
            }
            Ok(scene)
        }
        SceneSpec::File(path) => load_file(&path, options),
    }
}

/// Loads a scene file, choosing the format by extension; `.gz` files are inflated while they
/// are read (the compressed bytes are never held), both capped at
/// [`LoadOptions::max_scene_bytes`].
pub fn load_file(path: &Path, options: &LoadOptions) -> Result<Scene, LoadError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let (inner, gzipped) = match name.strip_suffix(".gz") {
        Some(inner) => (inner, true),
        None => (name.as_str(), false),
    };
    let ext = inner.rsplit('.').next().unwrap_or("");
    if !matches!(ext, "obj" | "ply" | "stl" | "gltf" | "glb" | "bsp") {
        return Err(LoadError::UnknownFormat {
            path: path.to_path_buf(),
        });
    }
    let io = |source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    // The size of a regular file sizes the buffer; devices and pipes report 0 and are read
    // through the same cap.
    let size = file
        .metadata()
        .ok()
        .filter(|m| m.is_file())
        .map(|m| m.len());
    let limit = options.max_scene_bytes;
    let bytes = match gzipped {
        true => {
            let inflate = flate2::read::MultiGzDecoder::new(std::io::BufReader::new(file));
            read_capped(path, inflate, limit, None, "the inflated gzip data")?
        }
        false => {
            if let Some(len) = size.filter(|&len| len > limit) {
                return Err(LoadError::limit(
                    path,
                    Location::Byte(limit),
                    format!(
                        "the file has {}, above the limit of {}; {}",
                        super::limits::show_bytes(len),
                        super::limits::show_bytes(limit),
                        super::limits::RAISE
                    ),
                ));
            }
            read_capped(path, file, limit, size, "the file")?
        }
    };
    let mut scene = match ext {
        "obj" => super::obj::load_with(path, &bytes, options)?,
        "ply" => super::ply::load_with(path, &bytes, options)?,
        "stl" => super::stl::load_with(path, &bytes, options)?,
        "gltf" | "glb" => super::gltf::load_with(path, &bytes, options)?,
        "bsp" => super::q3::load(path, &bytes, options)?,
        _ => {
            return Err(LoadError::UnknownFormat {
                path: path.to_path_buf(),
            })
        }
    };
    scene.source = path.display().to_string();
    match options.up_axis {
        Some(up) => scene.up = up,
        // These formats do not state an up axis (their loaders leave the default, Y).
        None if matches!(ext, "obj" | "ply" | "stl") => {
            let inferred = infer_up_axis(&scene);
            if inferred.axis != scene.up {
                scene.load_warnings.push(format!(
                    "up axis {} inferred: {} ({ext} files do not state their up axis; \
                     --up-axis chooses)",
                    inferred.axis.name().to_ascii_uppercase(),
                    inferred.reason
                ));
            }
            scene.up = inferred.axis;
        }
        None => {}
    }
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

    fn gzip(bytes: &[u8]) -> Vec<u8> {
        use std::io::Write;
        let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        z.write_all(bytes).unwrap();
        z.finish().unwrap()
    }

    #[test]
    fn gzip_bomb_stops_at_the_limit() {
        // 64 MiB of zeros inflate from about 64 KiB; a 1 MiB limit stops the inflation there.
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bomb.ply.gz");
        std::fs::write(&p, gzip(&vec![0u8; 64 << 20])).unwrap();
        let options = LoadOptions {
            max_scene_bytes: 1 << 20,
            ..LoadOptions::default()
        };
        let e = load_file(&p, &options).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, LoadError::Limit { .. }), "{msg}");
        assert!(
            msg.contains("bomb.ply.gz") && msg.contains("--max-scene-bytes"),
            "{msg}"
        );
    }

    #[test]
    fn gzip_under_the_limit_loads() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.obj.gz");
        std::fs::write(&p, gzip(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")).unwrap();
        assert_eq!(
            load_file(&p, &LoadOptions::default())
                .unwrap()
                .triangle_count(),
            1
        );
    }

    #[test]
    fn file_above_the_limit_is_not_read() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.obj");
        std::fs::write(&p, vec![b' '; 4096]).unwrap();
        let options = LoadOptions {
            max_scene_bytes: 1000,
            ..LoadOptions::default()
        };
        let e = load_file(&p, &options).unwrap_err();
        assert!(matches!(e, LoadError::Limit { .. }), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn endless_device_is_read_only_up_to_the_limit() {
        let options = LoadOptions {
            max_scene_bytes: 1 << 16,
            ..LoadOptions::default()
        };
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("zero.obj");
        std::os::unix::fs::symlink("/dev/zero", &p).unwrap();
        let e = load_file(&p, &options).unwrap_err();
        assert!(matches!(e, LoadError::Limit { .. }), "{e}");
    }

    #[test]
    fn spec_without_prefix_is_file() {
        assert_eq!(
            SceneSpec::parse("a/b.obj").unwrap(),
            SceneSpec::File("a/b.obj".into())
        );
    }
}
