//! Traversal order: for random grids and cameras (eye inside and outside the grid, wide and
//! narrow fields of view), with `e` the eye's cell and the visit order `c_0, c_1, ..`:
//! - occlusion order: for every `i < j`, `c_j` does not lie strictly in front of `c_i`, i.e.
//!   `!(c_j != c_i && can_occlude(e, c_j, c_i))` (see `sightline_cull::can_occlude`: on each
//!   axis the occluder lies between the eye's cell and the occluded cell);
//! - no cell is visited twice;
//! - every cell containing a point of the frustum (random points, up to the far distance) is
//!   visited.

use glam::Vec3;
use sightline_core::random::SplitMix64;
use sightline_core::{Aabb, Camera};
use sightline_cull::{can_occlude, GridShape, Traversal};

fn random_case(rng: &mut SplitMix64) -> (GridShape, Camera, f32) {
    let dims = [
        3 + rng.below(14) as u32,
        3 + rng.below(14) as u32,
        1 + rng.below(8) as u32,
    ];
    let bounds = Aabb::new(
        Vec3::ZERO,
        Vec3::new(
            dims[0] as f32 * 2.0,
            dims[1] as f32 * 3.0,
            dims[2] as f32 * 1.5,
        ),
    );
    let shape = GridShape::new(&bounds, dims).unwrap();
    let ext = bounds.extent();
    // Mostly inside the grid, sometimes outside it.
    let eye = Vec3::new(
        rng.range_f32(-0.3, 1.3) * ext.x,
        rng.range_f32(-0.3, 1.3) * ext.y,
        rng.range_f32(-0.3, 1.3) * ext.z,
    );
    let dir = Vec3::new(
        rng.range_f32(-1.0, 1.0),
        rng.range_f32(-1.0, 1.0),
        rng.range_f32(-1.0, 1.0),
    );
    let up = if dir.normalize_or_zero().dot(Vec3::Z).abs() > 0.95 {
        Vec3::X
    } else {
        Vec3::Z
    };
    let fov = rng.range_f32(30.0, 120.0);
    let (w, h) = (160 + rng.below(160) as u32, 90 + rng.below(90) as u32);
    let cam = Camera::looking(eye, dir, up, fov, w, h, 0.05).unwrap();
    let far = rng.range_f32(5.0, 80.0);
    (shape, cam, far)
}

fn coords(shape: &GridShape, i: u32) -> [i32; 3] {
    let c = shape.coords(i);
    [c[0] as i32, c[1] as i32, c[2] as i32]
}

#[test]
fn visits_cells_in_occlusion_order_once_and_covers_the_frustum() {
    let mut rng = SplitMix64::new(3);
    let mut traversal = Traversal::new();
    let mut order = Vec::new();
    let mut total = 0usize;
    for case in 0..300 {
        let (shape, cam, far) = random_case(&mut rng);
        order.clear();
        traversal.visit(&shape, &cam, far, &mut order);
        total += order.len();
        let eye = shape.cell_of(cam.eye);
        let mut seen = vec![false; shape.cell_count()];
        for (i, &a) in order.iter().enumerate() {
            assert!(!seen[a as usize], "case {case}: cell {a} visited twice");
            seen[a as usize] = true;
            let ca = coords(&shape, a);
            for &b in &order[i + 1..] {
                let cb = coords(&shape, b);
                assert!(
                    !can_occlude(eye, cb, ca),
                    "case {case}: {cb:?} can occlude {ca:?} (eye cell {eye:?}) but comes later"
                );
            }
        }
        // Coverage: random points of the frustum inside the grid are in visited cells.
        let bounds = shape.bounds();
        for _ in 0..400 {
            let d = rng.range_f32(cam.near, far);
            let u = rng.range_f32(-1.0, 1.0) * cam.tan_half_x() * d;
            let v = rng.range_f32(-1.0, 1.0) * cam.tan_half_y() * d;
            let p = cam.eye + cam.forward * d + cam.right * u + cam.up * v;
            if !bounds.contains(p) {
                continue;
            }
            let c = shape.cell_of(p);
            let clamp = |k: usize| c[k].clamp(0, shape.dims[k] as i32 - 1) as u32;
            let idx = shape.index([clamp(0), clamp(1), clamp(2)]);
            assert!(
                seen[idx as usize],
                "case {case}: frustum point {p} in unvisited cell {c:?}"
            );
        }
    }
    assert!(
        total > 10_000,
        "the cases visit too few cells to mean much: {total}"
    );
}
