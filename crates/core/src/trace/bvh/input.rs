//! What the BVH is built over: which of the scene's triangles the leaf test can ever hit,
//! their corners and their boxes. Shared by [`super::Bvh`] (`mod.rs`) and [`super::FlatBvh`]
//! (`flatten.rs`), so that both build the same tree from the same boxes.

use glam::Vec3;
use rayon::prelude::*;

use crate::geometry::Aabb;
use crate::scene::Scene;

/// True when the triangle can ever be hit: finite corners and a non-zero cross product.
fn usable(corners: [Vec3; 3]) -> bool {
    let [a, b, c] = corners;
    a.is_finite() && b.is_finite() && c.is_finite() && (b - a).cross(c - a) != Vec3::ZERO
}

/// The corners of triangle `t` of `scene` when the leaf test can ever hit it (indices in
/// range, finite corners, non-zero area), else `None`: the triangles the BVH leaves out, and
/// those every other caster (Embree, the GPU's ray queries) must leave out too to give the
/// same hits.
pub fn hittable_corners(scene: &Scene, t: &[u32; 3]) -> Option<[Vec3; 3]> {
    corners(scene, t).filter(|&c| usable(c))
}

/// The corners of triangle `t` of `scene`; `None` when an index is out of range.
pub(super) fn corners(scene: &Scene, t: &[u32; 3]) -> Option<[Vec3; 3]> {
    let p = |i: u32| scene.positions.get(i as usize).copied();
    Some([p(t[0])?, p(t[1])?, p(t[2])?])
}

/// The box of every triangle of `scene` by id, [`Aabb::EMPTY`] for those the leaf test can never
/// hit (an index out of range, a non-finite corner, zero area): the build leaves them out.
pub(super) fn triangle_boxes(scene: &Scene) -> Vec<Aabb> {
    scene
        .triangles
        .par_iter()
        .map(|t| hittable_corners(scene, t).map_or(Aabb::EMPTY, Aabb::from_points))
        .collect()
}
