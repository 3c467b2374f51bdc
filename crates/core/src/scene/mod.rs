//! The scene model: triangles over shared positions, grouped into objects, and the loaders and
//! generators that build it.
//!
//! # Triangle ids
//! A triangle's id is its index in [`Scene::triangles`]. Every loader emits triangles in the
//! order they appear in the file (per-format details in each loader module), and every generator
//! emits them in a fixed order derived only from its parameters and seed, so ids are the same on
//! every run and platform: a `.pvs` file made today indexes the same triangles tomorrow.
//! Degenerate triangles are kept so that ids stay stable; algorithms never report them visible.
//!
//! # Memory
//! 12 bytes per position, 12 bytes per triangle (indices) and 4 bytes per triangle (object id):
//! about 22 bytes per triangle for a closed mesh (half as many vertices as triangles) and 24 for
//! unwelded boxes (8 vertices per 12 triangles).
//!
//! # Files
//! This file is the module's face: the loaders, generators and the builder take the model's
//! types from `types.rs`, the options from `options.rs` and the errors from `error.rs`, never
//! from here.

pub(crate) mod builder;
mod error;
pub mod gltf;
mod limits;
pub mod obj;
mod options;
pub mod ply;
pub mod procedural;
pub mod q3;
mod spec;
pub mod stl;
mod text;
pub(crate) mod types;
mod up_axis;

pub use builder::{CountingSink, SceneBuilder, TriangleSink};
pub use error::{LoadError, Location};
pub use options::LoadOptions;
pub use spec::{load_file, open, SceneSpec};
pub use types::{Object, Scene, UpAxis};
pub use up_axis::{infer_up_axis, UpInference, FLAT_RATIO};

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn one_triangle() -> Scene {
        let mut b = SceneBuilder::new("test");
        b.begin_object("tri");
        let a = b.add_vertex(Vec3::ZERO);
        let c = b.add_vertex(Vec3::X);
        let d = b.add_vertex(Vec3::Y);
        b.add_triangle([a, c, d]);
        b.finish()
    }

    #[test]
    fn empty_scene_has_empty_bounds() {
        let s = Scene::default();
        assert!(s.is_empty());
        assert!(s.bounds().is_empty());
        assert!(s.triangles_by_object().is_empty());
    }

    #[test]
    fn hash_changes_with_geometry() {
        let a = one_triangle();
        let mut b = one_triangle();
        assert_eq!(a.geometry_hash(), b.geometry_hash());
        b.positions[1].x = 2.0;
        assert_ne!(a.geometry_hash(), b.geometry_hash());
    }

    #[test]
    fn triangle_corners_come_back() {
        let s = one_triangle();
        assert_eq!(s.triangle(0), [Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(s.triangles_by_object(), vec![vec![0]]);
    }
}
