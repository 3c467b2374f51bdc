//! Depth pre-culling must not change the exact result: on real and procedural scenes, from
//! several viewpoints, the visible set and every triangle's visible area are the same with and
//! without it, and it does remove triangles (so the comparison is not vacuous). (Random
//! `boxes` are left out: they interpenetrate, which breaks the pipeline's own input assumption;
//! there pre-culling still removes only truly hidden triangles, but the pipeline without it is
//! the one that is wrong near intersection lines.)
#![allow(clippy::unwrap_used)]

use glam::Vec3;
use sightline_core::scene::{open, LoadOptions};
use sightline_core::{Camera, Scene};
use sightline_point::analytic::{visible_fragments, AnalyticOptions};

fn load(spec: &str) -> Scene {
    open(spec, &LoadOptions::default()).unwrap()
}

/// Cameras around the scene's centre at `distance` radii, at `angles` azimuths.
fn orbit(scene: &Scene, distance: f32, height: f32, angles: usize, size: u32) -> Vec<Camera> {
    let b = scene.bounds();
    let r = 0.5 * b.diagonal();
    let up = if b.extent().z < b.extent().y.min(b.extent().x) * 0.5 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    (0..angles)
        .map(|k| {
            let a = k as f32 * std::f32::consts::TAU / angles as f32 + 0.3;
            let (s, c) = a.sin_cos();
            let offset = if up == Vec3::Z {
                Vec3::new(c, s, height)
            } else {
                Vec3::new(c, height, s)
            };
            Camera::look_at(
                b.center() + offset * distance * r,
                b.center(),
                up,
                50.0,
                size,
                size,
                0.001 * r,
            )
            .unwrap()
        })
        .collect()
}

/// Compares the two runs; returns how many polygons pre-culling removed.
fn same_with_and_without(scene: &Scene, cam: &Camera) -> usize {
    let on = visible_fragments(scene, cam, &AnalyticOptions::default()).unwrap();
    let off = visible_fragments(
        scene,
        cam,
        &AnalyticOptions {
            depth_preculling: false,
            ..AnalyticOptions::default()
        },
    )
    .unwrap();
    assert_eq!(off.stats.preculled, 0);
    let n = scene.triangles.len();
    let (a_on, a_off) = (on.visible_area(n), off.visible_area(n));
    for id in 0..n {
        assert!(
            (a_on[id] - a_off[id]).abs() <= 1e-6 * (1.0 + a_off[id]),
            "{}: triangle {id} area {} with pre-culling, {} without",
            scene.source,
            a_on[id],
            a_off[id]
        );
    }
    assert_eq!(
        on.visible, off.visible,
        "{}: visible sets differ",
        scene.source
    );
    on.stats.preculled
}

#[test]
fn bunny_is_unchanged_by_preculling() {
    let scene = load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/bunny.obj"
    ));
    let mut culled = 0;
    for cam in orbit(&scene, 2.2, 0.3, 6, 384) {
        culled += same_with_and_without(&scene, &cam);
    }
    // Roughly half of a closed scan faces away and is hidden.
    assert!(culled > 6 * 500, "only {culled} polygons culled");
}

#[test]
fn city_is_unchanged_by_preculling() {
    let scene = load("procedural:city?seed=3&size=6000");
    let mut culled = 0;
    for cam in orbit(&scene, 0.9, 0.25, 4, 256) {
        culled += same_with_and_without(&scene, &cam);
    }
    assert!(culled > 0, "nothing culled");
}

#[test]
fn other_procedural_scenes_are_unchanged_by_preculling() {
    // (scene, whether something must be culled): the zone plates' rings are thinner than a
    // pixel with gaps between them, so no pixel is provably covered and nothing is culled.
    for (spec, must_cull) in [
        ("procedural:rooms?seed=2&size=3000", true),
        ("procedural:spheres?seed=5&size=4000", true),
        ("procedural:canyon?seed=4&size=3000", true),
        ("procedural:spikes?seed=6&size=2000", true),
        ("procedural:zoneplate?seed=1&size=3000", false),
    ] {
        let scene = load(spec);
        let mut culled = 0;
        for cam in orbit(&scene, 1.1, 0.4, 3, 256) {
            culled += same_with_and_without(&scene, &cam);
        }
        assert!(culled > 0 || !must_cull, "{spec}: nothing culled");
    }
}

#[test]
fn camera_inside_a_closed_box_keeps_the_walls_it_sees() {
    // From inside, every wall is seen from its back; nothing may be culled wrongly.
    let mut b = sightline_core::scene::SceneBuilder::new("box");
    b.add_box(Vec3::splat(-1.0), Vec3::splat(1.0));
    b.add_box(Vec3::new(-0.2, -0.2, -0.9), Vec3::new(0.2, 0.2, -0.5));
    let scene = b.finish();
    let cam = Camera::look_at(
        Vec3::new(0.1, 0.2, 0.6),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::Y,
        100.0,
        128,
        128,
        0.01,
    )
    .unwrap();
    same_with_and_without(&scene, &cam);
    let on = visible_fragments(&scene, &cam, &AnalyticOptions::default()).unwrap();
    // The far wall (z = -1) behind the small box is partly visible around it.
    assert!(on.visible.count_ones(..) >= 6);
}
