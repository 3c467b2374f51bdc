//! Scenes, cells and parameters the ray-sharing tests share.

use glam::Vec3;
use sightline_core::scene::{self, LoadOptions, SceneBuilder};
use sightline_core::Scene;

use super::types::ShareParams;
use crate::gvspp::GvsPlusPlusParams;
use crate::viewcell::ViewCell;

/// `f` run on a pool of `threads` threads (results must not depend on the count).
pub(super) fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(f)
}

/// A small procedural city.
pub(super) fn small_city() -> Scene {
    scene::open("procedural:city?seed=3&size=3000", &LoadOptions::default()).unwrap()
}

/// An n x n layer of cells over the city, from the ground to 12 m.
pub(super) fn city_cells(scene: &Scene, n: u32) -> Vec<ViewCell> {
    let b = scene.bounds();
    ViewCell::grid(
        Vec3::new(b.min.x, b.min.y, 0.5),
        Vec3::new(b.max.x, b.max.y, 12.0),
        [n, n, 1],
    )
    .unwrap()
}

/// GVS++ parameters for quick bakes.
pub(super) fn small_params() -> ShareParams {
    ShareParams {
        gvspp: GvsPlusPlusParams {
            n_rand: 20_000,
            n_rs_edge: 4,
            n_rs_area: 8,
            // These fixtures test the paper's rounds (`bake/by_yield.rs` tests the schedule by
            // yield, the default).
            fixed_rounds: true,
            ..GvsPlusPlusParams::default()
        },
        ..ShareParams::default()
    }
}

/// An enclosure (a big box seen from inside) with a small blocker between two cells A and
/// B, and a small marker box beyond B.
pub(super) fn two_cell_scene() -> (Scene, [ViewCell; 2]) {
    let mut b = SceneBuilder::new("two cells");
    b.begin_object("enclosure");
    b.add_box(Vec3::splat(-10.0), Vec3::splat(10.0));
    b.begin_object("blocker");
    b.add_box(Vec3::splat(-0.3), Vec3::splat(0.3));
    b.begin_object("marker");
    b.add_box(Vec3::new(7.5, -0.5, -0.5), Vec3::new(8.5, 0.5, 0.5));
    let a = ViewCell::aabb(Vec3::new(-6.0, -1.0, -1.0), Vec3::new(-4.0, 1.0, 1.0)).unwrap();
    let bb = ViewCell::aabb(Vec3::new(4.0, -1.0, -1.0), Vec3::new(6.0, 1.0, 1.0)).unwrap();
    (b.finish(), [a, bb])
}

/// The triangles of `objects` whose plane is `x = x`.
pub(super) fn face(scene: &Scene, objects: std::ops::Range<usize>, x: f32) -> Vec<usize> {
    objects
        .filter(|&t| {
            scene
                .triangle(t as u32)
                .iter()
                .all(|p| (p.x - x).abs() < 1e-6)
        })
        .collect()
}
