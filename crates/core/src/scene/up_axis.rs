//! The up axis of a mesh file that does not state one (OBJ, PLY, STL).
//!
//! The rule, chosen to be simple enough to predict: a scene whose bounding box is **flat** —
//! one axis' extent below [`FLAT_RATIO`] (a quarter) of both other extents — is up along that
//! axis: city blocks, terrains and levels laid out in a plane are wide and low whatever their
//! file's convention (the shared city meshes are 50-100 m high and 700-1500 m wide, Z-up). Any
//! other scene keeps the convention of OBJ and PLY scans, Y up: a scanned model or a building
//! is about as tall as it is wide, and its extents say nothing reliable (the Stanford dragon's
//! smallest extent is its depth, Z, at 0.63 of its height). A wrong guess is easy to see (the
//! report's map from above becomes a side view) and `--up-axis` (`LoadOptions::up_axis`)
//! overrides it; the loader says in a load warning when the guess differs from Y.

use super::types::{Scene, UpAxis};

/// An axis is "flat" when its extent is below this fraction of both other extents.
pub const FLAT_RATIO: f32 = 0.25;

/// The inferred up axis and why.
#[derive(Clone, Debug, PartialEq)]
pub struct UpInference {
    /// The axis.
    pub axis: UpAxis,
    /// The reason, for messages: the extents that decided it, or the convention.
    pub reason: String,
}

/// The up axis of `scene` by the module's rule, from the bounds of its finite vertices.
pub fn infer_up_axis(scene: &Scene) -> UpInference {
    let convention = |why: &str| UpInference {
        axis: UpAxis::Y,
        reason: format!("{why}; Y, the convention of OBJ and PLY"),
    };
    let bounds = scene.bounds();
    let extent = bounds.max - bounds.min;
    let e = extent.to_array();
    if !e.iter().all(|v| v.is_finite() && *v >= 0.0) || scene.triangles.is_empty() {
        return convention("no geometry to judge");
    }
    let flat = (0..3).find(|&i| {
        let others = [e[(i + 1) % 3], e[(i + 2) % 3]];
        others.iter().all(|&o| o > 0.0 && e[i] < FLAT_RATIO * o)
    });
    match flat.and_then(UpAxis::from_index) {
        Some(axis) => {
            let i = axis.index();
            UpInference {
                axis,
                reason: format!(
                    "the scene is flat along {}: extent {} against {} and {}",
                    axis.name().to_ascii_uppercase(),
                    e[i],
                    e[(i + 1) % 3],
                    e[(i + 2) % 3]
                ),
            }
        }
        None => convention("no axis is flat (below a quarter of the other extents)"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builder::SceneBuilder;
    use glam::Vec3;

    fn boxed(extent: Vec3) -> Scene {
        let mut b = SceneBuilder::new("box");
        b.add_box(Vec3::ZERO, extent);
        b.finish()
    }

    #[test]
    fn a_flat_scene_is_up_along_its_flat_axis() {
        // A city: 1,400 m by 1,200 m, 100 m high.
        let city = infer_up_axis(&boxed(Vec3::new(1400.0, 1200.0, 100.0)));
        assert_eq!(city.axis, UpAxis::Z, "{}", city.reason);
        assert!(city.reason.contains("flat along Z"), "{}", city.reason);
        // A Y-up terrain and an X-flat one.
        assert_eq!(
            infer_up_axis(&boxed(Vec3::new(500.0, 20.0, 400.0))).axis,
            UpAxis::Y
        );
        assert_eq!(
            infer_up_axis(&boxed(Vec3::new(20.0, 500.0, 400.0))).axis,
            UpAxis::X
        );
    }

    #[test]
    fn a_compact_scene_keeps_the_y_convention() {
        // The dragon's extents: its smallest (Z) is 0.63 of its height, not flat.
        let dragon = infer_up_axis(&boxed(Vec3::new(0.204, 0.144, 0.091)));
        assert_eq!(dragon.axis, UpAxis::Y, "{}", dragon.reason);
        // Just above the ratio on one side is not flat either.
        assert_eq!(
            infer_up_axis(&boxed(Vec3::new(100.0, 100.0, 26.0))).axis,
            UpAxis::Y
        );
        assert_eq!(
            infer_up_axis(&boxed(Vec3::new(100.0, 100.0, 24.0))).axis,
            UpAxis::Z
        );
    }

    #[test]
    fn degenerate_scenes_keep_the_convention() {
        assert_eq!(
            infer_up_axis(&SceneBuilder::new("empty").finish()).axis,
            UpAxis::Y
        );
        // A single flat quad has a zero extent: flat only against positive extents.
        let mut b = SceneBuilder::new("quad");
        let v = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)].map(|p| b.add_vertex(p));
        b.add_triangle(v);
        assert_eq!(infer_up_axis(&b.finish()).axis, UpAxis::Z);
        let mut b = SceneBuilder::new("line");
        let v = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0].map(|p| b.add_vertex(p));
        b.add_triangle(v);
        assert_eq!(infer_up_axis(&b.finish()).axis, UpAxis::Y);
    }
}
