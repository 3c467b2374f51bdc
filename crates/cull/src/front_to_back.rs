//! The front-to-back order of objects by their boxes: the order the stop-and-wait baselines
//! (and, with `sort_cell_objects`, the grid method within a cell) test objects in, and the order
//! the diagnosis renders its ideal occluders in. A file of its own so both take it from here.

use glam::Vec3;
use sightline_core::Aabb;

/// Sorts object ids by the distance from `eye` to the nearest point of their boxes (ties by
/// id, so the order never depends on the input's).
pub(crate) fn sort_front_to_back(ids: &mut [u32], boxes: &[Aabb], eye: Vec3) {
    let dist = |o: &u32| {
        let b = &boxes[*o as usize];
        (eye.clamp(b.min, b.max) - eye).length_squared()
    };
    ids.sort_by(|a, b| dist(a).total_cmp(&dist(b)).then(a.cmp(b)));
}
