//! Camera paths: a JSON file of keyframes (the format of `sightline cull --path` and of the
//! viewer's headless mode: `{"frames": [{"eye": [x, y, z], "look": [x, y, z]}, ...]}`,
//! interpolated linearly when it has fewer keyframes than frames), or an automatic orbit.
//!
//! Here rather than in the viewer because the culling simulation replays the same paths, and a
//! headless build (no window, no GPU) must read them too.

use std::io::Read;
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use serde::Deserialize;

/// The largest camera path file read: 16 MiB is about 250,000 keyframes, far more than any
/// flight needs; a larger file is refused before it is parsed.
pub const MAX_CAMERA_PATH_BYTES: u64 = 16 << 20;

/// A camera path file that cannot be used; the message names what is wrong.
#[derive(Debug, thiserror::Error)]
#[error("camera path {}: {message}", path.display())]
pub struct CameraPathError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong with it.
    pub message: String,
}

/// One keyframe: eye and look-at point.
#[derive(Deserialize, Debug, Clone, Copy, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    /// Eye position.
    pub eye: [f32; 3],
    /// Look-at point.
    pub look: [f32; 3],
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct PathFile {
    frames: Vec<Keyframe>,
}

/// Reads a camera path file (at most [`MAX_CAMERA_PATH_BYTES`]); errors name the file and the
/// bad keyframe.
pub fn read_camera_path(path: &Path) -> Result<Vec<Keyframe>, CameraPathError> {
    let err = |message: String| CameraPathError {
        path: path.to_path_buf(),
        message,
    };
    let mut text = String::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_CAMERA_PATH_BYTES + 1).read_to_string(&mut text))
        .map_err(|e| err(e.to_string()))?;
    if text.len() as u64 > MAX_CAMERA_PATH_BYTES {
        return Err(err(format!(
            "larger than the limit of {} MiB for a camera path",
            MAX_CAMERA_PATH_BYTES >> 20
        )));
    }
    let file: PathFile = serde_json::from_str(&text).map_err(|e| {
        err(format!(
            "{e}; expected {{\"frames\": [{{\"eye\": [x, y, z], \"look\": [x, y, z]}}, ...]}}"
        ))
    })?;
    if file.frames.is_empty() {
        return Err(err("\"frames\" is empty".into()));
    }
    for (i, k) in file.frames.iter().enumerate() {
        if !k.eye.iter().chain(&k.look).all(|v| v.is_finite()) {
            return Err(err(format!("keyframe {i} has a non-finite coordinate")));
        }
        if k.eye == k.look {
            return Err(err(format!("keyframe {i} has its eye at its look point")));
        }
    }
    Ok(file.frames)
}

/// Eye and look of frame `f` of `n`: the keyframes spread evenly over the frames, linear in
/// between (frame `f` is keyframe `f` when there are at least as many keyframes as frames).
/// `keys` must not be empty.
pub fn interpolate(keys: &[Keyframe], f: usize, n: usize) -> (Vec3, Vec3) {
    debug_assert!(!keys.is_empty());
    let at = |i: usize| (Vec3::from(keys[i].eye), Vec3::from(keys[i].look));
    if keys.len() == 1 || n <= 1 {
        return at(0);
    }
    if keys.len() >= n {
        return at(f.min(keys.len() - 1));
    }
    let u = f as f32 / (n - 1) as f32 * (keys.len() - 1) as f32;
    let i = (u.floor() as usize).min(keys.len() - 2);
    let s = u - i as f32;
    let ((e0, l0), (e1, l1)) = (at(i), at(i + 1));
    (e0.lerp(e1, s), l0.lerp(l1, s))
}

/// `n` frames orbiting once around `look` about the `up` axis, starting at `eye` and always
/// looking at `look`.
pub fn orbit(eye: Vec3, look: Vec3, up: Vec3, n: usize) -> Vec<(Vec3, Vec3)> {
    let up = up.normalize_or(Vec3::Z);
    (0..n)
        .map(|f| {
            let angle = std::f32::consts::TAU * f as f32 / n.max(1) as f32;
            (look + Quat::from_axis_angle(up, angle) * (eye - look), look)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(x: f32) -> Keyframe {
        Keyframe {
            eye: [x, 0.0, 0.0],
            look: [x, 1.0, 0.0],
        }
    }

    #[test]
    fn interpolation_spreads_keyframes_over_frames() {
        let keys = [key(0.0), key(10.0)];
        assert_eq!(interpolate(&keys, 0, 3).0.x, 0.0);
        assert_eq!(interpolate(&keys, 1, 3).0.x, 5.0);
        assert_eq!(interpolate(&keys, 2, 3).0.x, 10.0);
    }

    #[test]
    fn orbit_keeps_distance_and_starts_at_eye() {
        let path = orbit(Vec3::new(10.0, 0.0, 5.0), Vec3::ZERO, Vec3::Z, 8);
        assert_eq!(path.len(), 8);
        assert!((path[0].0 - Vec3::new(10.0, 0.0, 5.0)).length() < 1e-5);
        for (eye, look) in &path {
            assert!((eye.length() - 125f32.sqrt()).abs() < 1e-3);
            assert!((eye.z - 5.0).abs() < 1e-4);
            assert_eq!(*look, Vec3::ZERO);
        }
        assert!(orbit(Vec3::X, Vec3::ZERO, Vec3::Z, 0).is_empty());
    }

    #[test]
    fn bad_path_files_are_rejected_with_the_file_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cam.json");
        std::fs::write(&p, r#"{"frames": []}"#).unwrap();
        let e = read_camera_path(&p).unwrap_err().to_string();
        assert!(e.contains("cam.json") && e.contains("empty"), "{e}");
        std::fs::write(&p, r#"{"frames": [{"eye": [0,0,0]}]}"#).unwrap();
        assert!(read_camera_path(&p).is_err());
        std::fs::write(&p, r#"{"frames": [{"eye": [0,0,0], "look": [1,0,0]}]}"#).unwrap();
        assert_eq!(read_camera_path(&p).unwrap().len(), 1);
    }

    #[test]
    fn oversized_path_files_are_refused_without_being_parsed() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("huge.json");
        let f = std::fs::File::create(&p).unwrap();
        // A sparse file: its size is past the limit without writing 16 MiB.
        f.set_len(MAX_CAMERA_PATH_BYTES + 10).unwrap();
        let e = read_camera_path(&p).unwrap_err().to_string();
        assert!(e.contains("huge.json") && e.contains("limit"), "{e}");
    }
}
