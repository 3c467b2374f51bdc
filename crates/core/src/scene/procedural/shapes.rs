//! The pieces several generators build from (`city.rs`, `rooms.rs`): a box standing on the
//! floor and a quad.

use glam::Vec3;

use crate::scene::builder::{add_box_faces, TriangleSink};

/// Adds an axis-aligned box with Z up but without its bottom (-Z) face: buildings and walls
/// stand on a floor, and a bottom face coplanar with the floor would only make depth ties.
pub(super) fn add_box_on_floor<S: TriangleSink + ?Sized>(b: &mut S, min: Vec3, max: Vec3) {
    add_box_faces(b, min, max, false);
}

/// Adds a quad `a b c d` (counter-clockwise seen from the side it faces) as two triangles.
pub(super) fn add_quad<S: TriangleSink + ?Sized>(b: &mut S, a: Vec3, bb: Vec3, c: Vec3, d: Vec3) {
    let i = [
        b.add_vertex(a),
        b.add_vertex(bb),
        b.add_vertex(c),
        b.add_vertex(d),
    ];
    b.add_triangle([i[0], i[1], i[2]]);
    b.add_triangle([i[0], i[2], i[3]]);
}
