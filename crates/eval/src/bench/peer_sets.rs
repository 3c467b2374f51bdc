//! The exchange files of `sightline bench peers`: the occluder sets, scenes and ray sets we
//! hand to the peer harnesses (Intel's Masked Occlusion Culling, tinybvh; `bench/peers/*.cpp`),
//! and what they hand back (hit records, a per-pixel depth buffer), so that every side works on
//! exactly the same input, read from one file.
//!
//! # Format (version 1)
//! Little-endian throughout. Every file starts with a 16-byte header:
//! - `magic`: the 8 bytes `SLPEERS\0`;
//! - `version`: u32, 1;
//! - `kind`: u32, one of [`Kind`] (1 occluders, 2 mesh, 3 rays, 4 hits, 5 depth).
//!
//! Then, by kind (`f32x3` is three f32, x y z):
//! - **occluders**: the camera — `eye` f32x3, `forward` f32x3 (unit), `up` f32x3 (unit,
//!   orthogonal to forward; `right = forward × up`), vertical field of view in degrees f32,
//!   width u32, height u32, near plane f32 — then the triangle count u32 and the triangles,
//!   three world-space corners (f32x3) each. Screen mapping: `sightline_core::camera`'s.
//! - **mesh**: vertex count u32, triangle count u32, the vertices (f32x3), the triangles (three
//!   u32 vertex indices each).
//! - **rays**: ray count u32, then per ray `origin` f32x3, `dir` f32x3 (not necessarily unit;
//!   distances are in units of `dir`), `t_min` f32, `t_max` f32 (may be +inf).
//! - **hits**: hit count u32, then per hit the triangle u32 (`u32::MAX` for a miss) and `t` f32
//!   (in units of the ray's `dir`; +inf for a miss).
//! - **depth**: width u32, height u32, then `width * height` f32 row by row from the top row:
//!   the occluder's `1 / view depth` at the pixel, 0 where nothing was drawn.
//!
//! The file must end right after its payload. Readers check every count against the bytes
//! that are there before allocating, so a corrupt or hostile file gives an error, never a
//! panic or a huge allocation.

use std::io::Write;
use std::path::Path;

use glam::Vec3;
use sightline_core::camera::CameraError;
use sightline_core::{Camera, Hit, Ray};

/// The first 8 bytes of every file.
pub const MAGIC: [u8; 8] = *b"SLPEERS\0";
/// The format version this code reads and writes.
pub const VERSION: u32 = 1;
/// The largest file a reader accepts (4 GiB).
pub const MAX_FILE_BYTES: u64 = 4 << 30;

/// What a file holds (the header's `kind`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Occluder triangles and a camera.
    Occluders = 1,
    /// An indexed triangle mesh.
    Mesh = 2,
    /// Rays.
    Rays = 3,
    /// Closest hits, one per ray.
    Hits = 4,
    /// A per-pixel depth buffer.
    Depth = 5,
}

/// Why an exchange file could not be read or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PeerSetError {
    /// Reading or writing failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        source: std::io::Error,
    },
    /// The file does not start with [`MAGIC`].
    #[error("not a sightline peer-bench file (bad magic)")]
    BadMagic,
    /// A version this code does not read.
    #[error("peer-bench file version {0}, expected {VERSION}")]
    Version(u32),
    /// The file holds another kind of data.
    #[error("peer-bench file of kind {found}, expected {expected:?}")]
    Kind {
        /// What the caller asked for.
        expected: Kind,
        /// The header's kind.
        found: u32,
    },
    /// The file ends before its payload does.
    #[error("truncated peer-bench file: {what} needs {need} bytes, {have} left")]
    Truncated {
        /// The field or array.
        what: &'static str,
        /// Bytes it needs.
        need: u64,
        /// Bytes left in the file.
        have: u64,
    },
    /// Bytes after the payload.
    #[error("{0} unexpected bytes after the peer-bench payload")]
    Trailing(usize),
    /// A file larger than [`MAX_FILE_BYTES`] or a count that does not fit a u32.
    #[error("{what}: {count} is too large")]
    TooLarge {
        /// What is counted.
        what: &'static str,
        /// The count or size.
        count: u64,
    },
    /// A triangle of a mesh names a vertex that is not there.
    #[error("mesh triangle {triangle} names vertex {index} of {vertices}")]
    BadIndex {
        /// The triangle.
        triangle: usize,
        /// The index.
        index: u32,
        /// Vertices in the mesh.
        vertices: usize,
    },
    /// The stored camera is not valid.
    #[error("stored camera: {0}")]
    Camera(#[from] CameraError),
}

/// Occluder triangles (three corners each) seen from a camera.
#[derive(Clone, Debug, PartialEq)]
pub struct OccluderSet {
    /// The camera.
    pub camera: Camera,
    /// World-space corners, three per triangle.
    pub triangles: Vec<Vec3>,
}

/// An indexed triangle mesh.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MeshSet {
    /// Vertices.
    pub vertices: Vec<Vec3>,
    /// Triangles, three vertex indices each.
    pub triangles: Vec<[u32; 3]>,
}

/// A per-pixel depth buffer (`1 / view depth`, 0 where empty), rows from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` values.
    pub inv_depth: Vec<f32>,
}

/// Writes occluders.
pub fn write_occluders(path: &Path, set: &OccluderSet) -> Result<(), PeerSetError> {
    let mut w = Writer::new(Kind::Occluders);
    let c = &set.camera;
    w.vec3(c.eye);
    w.vec3(c.forward);
    w.vec3(c.up);
    w.f32(c.fov_y_deg);
    w.u32(c.width);
    w.u32(c.height);
    w.f32(c.near);
    w.count("triangles", set.triangles.len() / 3)?;
    for p in &set.triangles[..set.triangles.len() / 3 * 3] {
        w.vec3(*p);
    }
    w.finish(path)
}

/// Reads occluders (the camera rebuilt by [`Camera::looking`]).
pub fn read_occluders(path: &Path) -> Result<OccluderSet, PeerSetError> {
    let bytes = read_file(path)?;
    let mut r = Reader::open(&bytes, Kind::Occluders)?;
    let (eye, forward, up) = (r.vec3("camera")?, r.vec3("camera")?, r.vec3("camera")?);
    let fov = r.f32("camera")?;
    let (width, height) = (r.u32("camera")?, r.u32("camera")?);
    let near = r.f32("camera")?;
    let camera = Camera::looking(eye, forward, up, fov, width, height, near)?;
    let n = r.u32("triangle count")? as usize;
    r.need("triangles", n as u64 * 36)?;
    let triangles = (0..3 * n)
        .map(|_| r.vec3("triangles"))
        .collect::<Result<_, _>>()?;
    r.end()?;
    Ok(OccluderSet { camera, triangles })
}

/// Writes a mesh.
pub fn write_mesh(path: &Path, mesh: &MeshSet) -> Result<(), PeerSetError> {
    let mut w = Writer::new(Kind::Mesh);
    w.count("vertices", mesh.vertices.len())?;
    w.count("triangles", mesh.triangles.len())?;
    for &v in &mesh.vertices {
        w.vec3(v);
    }
    for t in &mesh.triangles {
        t.iter().for_each(|&i| w.u32(i));
    }
    w.finish(path)
}

/// Reads a mesh; every index must name a vertex.
pub fn read_mesh(path: &Path) -> Result<MeshSet, PeerSetError> {
    let bytes = read_file(path)?;
    let mut r = Reader::open(&bytes, Kind::Mesh)?;
    let nv = r.u32("vertex count")? as usize;
    let nt = r.u32("triangle count")? as usize;
    r.need("vertices and triangles", nv as u64 * 12 + nt as u64 * 12)?;
    let vertices: Vec<Vec3> = (0..nv)
        .map(|_| r.vec3("vertices"))
        .collect::<Result<_, _>>()?;
    let mut triangles = Vec::with_capacity(nt);
    for t in 0..nt {
        let tri = [
            r.u32("triangles")?,
            r.u32("triangles")?,
            r.u32("triangles")?,
        ];
        if let Some(&index) = tri.iter().find(|&&i| i as usize >= nv) {
            return Err(PeerSetError::BadIndex {
                triangle: t,
                index,
                vertices: nv,
            });
        }
        triangles.push(tri);
    }
    r.end()?;
    Ok(MeshSet {
        vertices,
        triangles,
    })
}

/// Writes rays.
pub fn write_rays(path: &Path, rays: &[Ray]) -> Result<(), PeerSetError> {
    let mut w = Writer::new(Kind::Rays);
    w.count("rays", rays.len())?;
    for r in rays {
        w.vec3(r.origin);
        w.vec3(r.dir);
        w.f32(r.t_min);
        w.f32(r.t_max);
    }
    w.finish(path)
}

/// Reads rays.
pub fn read_rays(path: &Path) -> Result<Vec<Ray>, PeerSetError> {
    let bytes = read_file(path)?;
    let mut r = Reader::open(&bytes, Kind::Rays)?;
    let n = r.u32("ray count")? as usize;
    r.need("rays", n as u64 * 32)?;
    let mut rays = Vec::with_capacity(n);
    for _ in 0..n {
        let (origin, dir) = (r.vec3("rays")?, r.vec3("rays")?);
        let (t_min, t_max) = (r.f32("rays")?, r.f32("rays")?);
        rays.push(Ray::new(origin, dir).with_range(t_min, t_max));
    }
    r.end()?;
    Ok(rays)
}

/// Writes hits.
pub fn write_hits(path: &Path, hits: &[Hit]) -> Result<(), PeerSetError> {
    let mut w = Writer::new(Kind::Hits);
    w.count("hits", hits.len())?;
    for h in hits {
        w.u32(h.triangle);
        w.f32(h.t);
    }
    w.finish(path)
}

/// Reads hits.
pub fn read_hits(path: &Path) -> Result<Vec<Hit>, PeerSetError> {
    let bytes = read_file(path)?;
    let mut r = Reader::open(&bytes, Kind::Hits)?;
    let n = r.u32("hit count")? as usize;
    r.need("hits", n as u64 * 8)?;
    let hits = (0..n)
        .map(|_| {
            Ok(Hit {
                triangle: r.u32("hits")?,
                t: r.f32("hits")?,
            })
        })
        .collect::<Result<_, PeerSetError>>()?;
    r.end()?;
    Ok(hits)
}

/// Writes a depth image.
pub fn write_depth(path: &Path, depth: &DepthImage) -> Result<(), PeerSetError> {
    let mut w = Writer::new(Kind::Depth);
    w.u32(depth.width);
    w.u32(depth.height);
    depth.inv_depth.iter().for_each(|&d| w.f32(d));
    w.finish(path)
}

/// Reads a depth image.
pub fn read_depth(path: &Path) -> Result<DepthImage, PeerSetError> {
    let bytes = read_file(path)?;
    let mut r = Reader::open(&bytes, Kind::Depth)?;
    let (width, height) = (r.u32("width")?, r.u32("height")?);
    let n = width as u64 * height as u64;
    r.need("depth values", n * 4)?;
    let inv_depth = (0..n).map(|_| r.f32("depth")).collect::<Result<_, _>>()?;
    r.end()?;
    Ok(DepthImage {
        width,
        height,
        inv_depth,
    })
}

/// The whole file, refusing one above [`MAX_FILE_BYTES`] before reading it.
fn read_file(path: &Path) -> Result<Vec<u8>, PeerSetError> {
    let io = |source| PeerSetError::Io {
        path: path.display().to_string(),
        source,
    };
    let len = std::fs::metadata(path).map_err(io)?.len();
    if len > MAX_FILE_BYTES {
        return Err(PeerSetError::TooLarge {
            what: "file size",
            count: len,
        });
    }
    std::fs::read(path).map_err(io)
}

/// Little-endian output into memory, written out at the end.
struct Writer {
    buf: Vec<u8>,
}

impl Writer {
    fn new(kind: Kind) -> Self {
        let mut w = Self { buf: Vec::new() };
        w.buf.extend_from_slice(&MAGIC);
        w.u32(VERSION);
        w.u32(kind as u32);
        w
    }

    fn u32(&mut self, v: u32) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    fn f32(&mut self, v: f32) {
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    fn vec3(&mut self, v: Vec3) {
        v.to_array().iter().for_each(|&c| self.f32(c));
    }

    fn count(&mut self, what: &'static str, n: usize) -> Result<(), PeerSetError> {
        let n = u32::try_from(n).map_err(|_| PeerSetError::TooLarge {
            what,
            count: n as u64,
        })?;
        self.u32(n);
        Ok(())
    }

    fn finish(self, path: &Path) -> Result<(), PeerSetError> {
        let io = |source| PeerSetError::Io {
            path: path.display().to_string(),
            source,
        };
        let mut f = std::fs::File::create(path).map_err(io)?;
        f.write_all(&self.buf).map_err(io)
    }
}

/// Little-endian input from memory with the bounds checks of the format.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// Checks the header: magic, version and `kind`.
    fn open(bytes: &'a [u8], kind: Kind) -> Result<Self, PeerSetError> {
        if bytes.len() < 8 || bytes[..8] != MAGIC {
            return Err(PeerSetError::BadMagic);
        }
        let mut r = Self { bytes, at: 8 };
        let version = r.u32("header")?;
        if version != VERSION {
            return Err(PeerSetError::Version(version));
        }
        let found = r.u32("header")?;
        if found != kind as u32 {
            return Err(PeerSetError::Kind {
                expected: kind,
                found,
            });
        }
        Ok(r)
    }

    /// Fails unless `n` more bytes are there.
    fn need(&self, what: &'static str, n: u64) -> Result<(), PeerSetError> {
        let have = (self.bytes.len() - self.at) as u64;
        if n > have {
            return Err(PeerSetError::Truncated {
                what,
                need: n,
                have,
            });
        }
        Ok(())
    }

    fn take4(&mut self, what: &'static str) -> Result<[u8; 4], PeerSetError> {
        self.need(what, 4)?;
        let mut b = [0; 4];
        b.copy_from_slice(&self.bytes[self.at..self.at + 4]);
        self.at += 4;
        Ok(b)
    }

    fn u32(&mut self, what: &'static str) -> Result<u32, PeerSetError> {
        Ok(u32::from_le_bytes(self.take4(what)?))
    }

    fn f32(&mut self, what: &'static str) -> Result<f32, PeerSetError> {
        Ok(f32::from_le_bytes(self.take4(what)?))
    }

    fn vec3(&mut self, what: &'static str) -> Result<Vec3, PeerSetError> {
        Ok(Vec3::new(self.f32(what)?, self.f32(what)?, self.f32(what)?))
    }

    /// Fails when bytes are left.
    fn end(&self) -> Result<(), PeerSetError> {
        match self.bytes.len() - self.at {
            0 => Ok(()),
            n => Err(PeerSetError::Trailing(n)),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn camera() -> Camera {
        Camera::look_at(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::ZERO,
            Vec3::Y,
            60.0,
            64,
            48,
            0.1,
        )
        .unwrap()
    }

    fn rays() -> Vec<Ray> {
        vec![
            Ray::new(Vec3::new(0.0, 1.0, 2.0), Vec3::new(0.0, 0.0, -1.0)),
            Ray::new(Vec3::ONE, Vec3::new(1.0, 2.0, 3.0)).with_range(0.5, 7.0),
        ]
    }

    #[test]
    fn every_kind_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let p = |n: &str| dir.path().join(n);
        let occ = OccluderSet {
            camera: camera(),
            triangles: vec![
                Vec3::X,
                Vec3::Y,
                Vec3::Z,
                Vec3::ONE,
                Vec3::NEG_X,
                Vec3::NEG_Y,
            ],
        };
        write_occluders(&p("o"), &occ).unwrap();
        let back = read_occluders(&p("o")).unwrap();
        assert_eq!(back.triangles, occ.triangles);
        let (a, b) = (back.camera, occ.camera);
        assert_eq!(
            (a.eye, a.width, a.height, a.near, a.fov_y_deg),
            (b.eye, 64, 48, 0.1, 60.0)
        );
        assert!((a.right - b.right).length() < 1e-6 && (a.up - b.up).length() < 1e-6);
        let mesh = MeshSet {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            triangles: vec![[0, 1, 2], [2, 1, 0]],
        };
        write_mesh(&p("m"), &mesh).unwrap();
        assert_eq!(read_mesh(&p("m")).unwrap(), mesh);
        write_rays(&p("r"), &rays()).unwrap();
        assert_eq!(read_rays(&p("r")).unwrap(), rays());
        let hits = vec![
            Hit::MISS,
            Hit {
                triangle: 7,
                t: 2.5,
            },
        ];
        write_hits(&p("h"), &hits).unwrap();
        assert_eq!(read_hits(&p("h")).unwrap(), hits);
        let depth = DepthImage {
            width: 2,
            height: 3,
            inv_depth: vec![0.0, 0.5, 1.0, 0.25, 0.0, 2.0],
        };
        write_depth(&p("d"), &depth).unwrap();
        assert_eq!(read_depth(&p("d")).unwrap(), depth);
    }

    #[test]
    fn truncated_files_are_errors_at_every_length() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r");
        write_rays(&path, &rays()).unwrap();
        let full = std::fs::read(&path).unwrap();
        for len in 0..full.len() {
            std::fs::write(&path, &full[..len]).unwrap();
            match read_rays(&path) {
                Err(PeerSetError::BadMagic) => assert!(len < 8),
                Err(PeerSetError::Truncated { need, have, .. }) => assert!(need > have),
                other => panic!("length {len}: {other:?}"),
            }
        }
    }

    #[test]
    fn bad_headers_and_trailing_bytes_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h");
        write_hits(&path, &[Hit::MISS]).unwrap();
        let good = std::fs::read(&path).unwrap();
        let with = |f: &dyn Fn(&mut Vec<u8>)| {
            let mut b = good.clone();
            f(&mut b);
            std::fs::write(&path, &b).unwrap();
        };
        with(&|b| b[0] = b'X');
        assert!(matches!(read_hits(&path), Err(PeerSetError::BadMagic)));
        with(&|b| b[8] = 2);
        assert!(matches!(read_hits(&path), Err(PeerSetError::Version(2))));
        with(&|_| ());
        let e = read_rays(&path).unwrap_err();
        assert!(
            matches!(
                e,
                PeerSetError::Kind {
                    expected: Kind::Rays,
                    found: 4
                }
            ),
            "{e}"
        );
        with(&|b| b.push(0));
        assert!(matches!(read_hits(&path), Err(PeerSetError::Trailing(1))));
        assert!(read_hits(&dir.path().join("missing")).is_err());
    }

    #[test]
    fn huge_counts_fail_before_allocating() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x");
        // Headers that claim 2^32 - 1 items (or a 65535² depth image) with no payload.
        let header = |kind: Kind, words: &[u32]| {
            let mut b = MAGIC.to_vec();
            for w in [VERSION, kind as u32].iter().chain(words) {
                b.extend_from_slice(&w.to_le_bytes());
            }
            std::fs::write(&path, b).unwrap();
        };
        header(Kind::Rays, &[u32::MAX]);
        let e = read_rays(&path).unwrap_err();
        assert!(matches!(e, PeerSetError::Truncated { need, .. } if need == 32 * u32::MAX as u64));
        header(Kind::Mesh, &[u32::MAX, u32::MAX]);
        assert!(matches!(
            read_mesh(&path),
            Err(PeerSetError::Truncated { .. })
        ));
        header(Kind::Hits, &[u32::MAX]);
        assert!(matches!(
            read_hits(&path),
            Err(PeerSetError::Truncated { .. })
        ));
        header(Kind::Depth, &[65535, 65535]);
        assert!(matches!(
            read_depth(&path),
            Err(PeerSetError::Truncated { .. })
        ));
    }

    #[test]
    fn bad_indices_and_cameras_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m");
        let mesh = MeshSet {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            triangles: vec![[0, 1, 3]],
        };
        write_mesh(&path, &mesh).unwrap();
        let e = read_mesh(&path).unwrap_err();
        assert!(matches!(
            e,
            PeerSetError::BadIndex {
                triangle: 0,
                index: 3,
                vertices: 3
            }
        ));
        let mut camera = camera();
        camera.fov_y_deg = 0.0;
        let set = OccluderSet {
            camera,
            triangles: Vec::new(),
        };
        write_occluders(&path, &set).unwrap();
        let e = read_occluders(&path).unwrap_err();
        assert!(
            matches!(e, PeerSetError::Camera(CameraError::BadFov(_))),
            "{e}"
        );
    }
}
