//! sightline-core: the scene model, scene loaders and generators, validation, ray casting and
//! the reference software rasterizer that every visibility algorithm of sightline stands on.
//!
//! Triangle ids are the indices into [`Scene::triangles`]; every visible set in sightline is a
//! [`TriangleSet`] over those ids. See [`scene`] for how each loader orders its triangles.
#![deny(missing_docs)]

pub mod atomic_file;
pub mod atomic_set;
pub mod camera;
pub mod camera_path;
pub mod cpu_time;
pub mod geometry;
pub mod near_plane;
pub mod prefetch;
pub mod random;
pub mod raster;
pub mod sampling;
pub mod scene;
pub mod threads;
pub mod trace;
pub mod validate;

pub use camera::Camera;
pub use geometry::{Aabb, Hit, Ray};
pub use near_plane::{default_near, NearPlaneRule};
pub use scene::{LoadError, Object, Scene, UpAxis};

/// A set of triangle ids (bit `i` set = triangle `i` is in the set).
pub type TriangleSet = fixedbitset::FixedBitSet;
