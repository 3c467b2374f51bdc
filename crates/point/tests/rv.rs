//! RV conservativeness: on procedural and real scenes, from several camera angles, every
//! triangle the reference rasterizer shows at 8x supersampling must be in the RV set computed
//! with [`Guarantee::AnySample`], and every triangle of the exact analytic set in the set
//! computed with the default [`Guarantee::PositiveArea`]. Prints the overestimation
//! |RV| / |reference| - 1 per scene (run with `--nocapture`).
#![allow(clippy::unwrap_used)]

use std::path::Path;

use glam::Vec3;
use sightline_core::raster::render;
use sightline_core::scene::{open, LoadOptions};
use sightline_core::{Camera, Scene};
use sightline_point::analytic::{visible_fragments, AnalyticOptions, MIN_VISIBLE_AREA_PX2};
use sightline_point::rv::{
    conservative_visible, Guarantee, HiddenOccluders, RvOptions, RvResult, SceneSource,
};

/// Base image size; the reference renders at 8x this.
const SIZE: u32 = 128;
/// Camera angles per scene (the thesis' 3-degree orbit, reduced: 8 angles 45 degrees apart).
const ANGLES: usize = 8;

fn options() -> RvOptions {
    RvOptions {
        bins: (16, 16),
        threads: 2,
        ..RvOptions::default()
    }
}

/// Where cameras go: orbiting outside the model, or looking around from inside the scene.
enum Placement {
    Orbit,
    Inside { height: f32 },
}

fn cameras(scene: &Scene, placement: &Placement) -> Vec<Camera> {
    let b = scene.bounds();
    let (c, diag) = (b.center(), b.diagonal());
    let up = scene.up.vector();
    // Two horizontal axes orthogonal to up.
    let (e1, e2) = if up == Vec3::Z {
        (Vec3::X, Vec3::Y)
    } else {
        (Vec3::Z, Vec3::X)
    };
    (0..ANGLES)
        .map(|k| {
            let a = (k as f32) * std::f32::consts::TAU / ANGLES as f32 + 0.05;
            let dir = e1 * a.cos() + e2 * a.sin();
            let (eye, target) = match placement {
                Placement::Orbit => {
                    let eye = c + dir * diag * 0.9 + up * diag * 0.25;
                    (eye, c)
                }
                Placement::Inside { height } => {
                    let eye = c + up * (*height - up.dot(c - b.min));
                    (eye, eye + dir * 10.0 - up * 1.5)
                }
            };
            Camera::look_at(eye, target, up, 60.0, SIZE, SIZE, diag * 1e-4).unwrap()
        })
        .collect()
}

/// Runs RV under both guarantees from every camera: with [`Guarantee::AnySample`] no triangle
/// the 8x reference rasterizer shows may be missing; with [`Guarantee::PositiveArea`] (the
/// default) no triangle of the exact analytic set with a visible area of at least 1e-6 px²
/// (smaller pieces are the exact method's own rounding on shared edges), or where the exact
/// method reports interpenetrating triangles, no triangle of the 8x reference with that exact
/// area. Returns the mean
/// overestimation of the two against their references.
fn check_scene(name: &str, scene: &Scene, placement: Placement) -> (f64, f64) {
    let n = scene.triangle_count();
    let (mut over_samples, mut over_area) = (Vec::new(), Vec::new());
    let mut peak = 0;
    let mut area_checked = 0;
    for (k, cam) in cameras(scene, &placement).iter().enumerate() {
        let big = Camera::looking(
            cam.eye,
            cam.forward,
            cam.up,
            cam.fov_y_deg,
            cam.width * 8,
            cam.height * 8,
            cam.near,
        )
        .unwrap();
        let reference = render(scene, &big).visible_set(n);
        let samples = RvOptions {
            guarantee: Guarantee::AnySample,
            ..options()
        };
        let rv = conservative_visible(&mut SceneSource::new(scene), cam, &samples).unwrap();
        let missing: Vec<usize> = reference.difference(&rv.visible).collect();
        assert!(
            missing.is_empty(),
            "{name} angle {k}: {} visible triangles missing from RV, e.g. {:?}",
            missing.len(),
            &missing[..missing.len().min(10)]
        );
        let (r, v) = (reference.count_ones(..), rv.visible.count_ones(..));
        if r > 0 {
            over_samples.push(v as f64 / r as f64 - 1.0);
        }
        peak = peak.max(rv.peak_memory_bytes);

        let exact = visible_fragments(scene, cam, &AnalyticOptions::default()).unwrap();
        let rv = conservative_visible(&mut SceneSource::new(scene), cam, &options()).unwrap();
        let area = exact.visible_area(n);
        // Interpenetrating triangles break the exact method's precondition (it says so): its
        // set is then no reference, and the 8x samples are, with a sample RV dropped allowed
        // only on a triangle whose exact visible area is zero (a silhouette contact).
        let judged = if exact.stats.warnings.unresolved_crossings > 0 {
            &reference
        } else {
            area_checked += 1;
            &exact.visible
        };
        let missing: Vec<(usize, f64)> = judged
            .difference(&rv.visible)
            .map(|t| (t, area[t]))
            .filter(|&(_, a)| a >= MIN_VISIBLE_AREA_PX2)
            .collect();
        assert!(
            missing.is_empty(),
            "{name} angle {k}: {} triangles with positive visible area missing from RV, e.g. \
             {:?}",
            missing.len(),
            &missing[..missing.len().min(10)]
        );
        let (e, v) = (exact.visible.count_ones(..), rv.visible.count_ones(..));
        if e > 0 {
            over_area.push(v as f64 / e as f64 - 1.0);
        }
    }
    let mean = |o: &[f64]| o.iter().sum::<f64>() / o.len().max(1) as f64;
    println!(
        "rv {name}: {n} triangles, overestimation against the 8x reference (any sample) {:.1}%, \
         against the exact set (positive area; exact method precondition-clean on {area_checked} views) {:.1}%, peak {:.1} MiB",
        100.0 * mean(&over_samples),
        100.0 * mean(&over_area),
        peak as f64 / (1 << 20) as f64
    );
    (mean(&over_samples), mean(&over_area))
}

fn procedural(spec: &str) -> Scene {
    open(spec, &LoadOptions::default()).unwrap()
}

fn shared(path: &str) -> Option<Scene> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/scenes")
        .join(path);
    if !p.exists() {
        eprintln!("skipping {path}: not found");
        return None;
    }
    Some(open(p.to_str().unwrap(), &LoadOptions::default()).unwrap())
}

#[test]
fn rv_conservative_boxes() {
    check_scene(
        "boxes",
        &procedural("procedural:boxes?size=3000"),
        Placement::Orbit,
    );
}

#[test]
fn rv_conservative_city() {
    check_scene(
        "city",
        &procedural("procedural:city?size=8000"),
        Placement::Inside { height: 40.0 },
    );
}

#[test]
fn rv_conservative_rooms() {
    check_scene(
        "rooms",
        &procedural("procedural:rooms?size=4000"),
        Placement::Orbit,
    );
}

#[test]
fn rv_conservative_spheres() {
    check_scene(
        "spheres",
        &procedural("procedural:spheres?size=6000"),
        Placement::Orbit,
    );
}

#[test]
fn rv_conservative_bunny() {
    if let Some(s) = shared("models/bunny.obj") {
        check_scene("bunny", &s, Placement::Orbit);
    }
}

#[test]
fn rv_conservative_teapot() {
    if let Some(s) = shared("models/teapot.obj") {
        check_scene("teapot", &s, Placement::Orbit);
    }
}

#[test]
fn rv_conservative_q3dm6ish() {
    if let Some(s) = shared("q3/q3dm6ish.bsp") {
        check_scene("q3dm6ish", &s, Placement::Inside { height: 120.0 });
    }
}

/// A street-level view down a long street of a city streamed block by block (far blocks can
/// arrive before the near walls that hide them): still no false negative against the 8x
/// reference, and the set stays within a small multiple of it. Before occluder eviction and
/// the re-test pass, full bins near the vanishing point kept the far occluders that arrived
/// first and RV reported about 270 times the reference on this kind of view.
#[test]
fn rv_streamed_city_street_view_is_conservative_and_tight() {
    use sightline_point::rv::StreamingCity;
    let size = 150_000;
    let scene = procedural(&format!("procedural:city?seed=1&size={size}"));
    // The blocks per side are even here, so a street crossing sits at (-6, -6).
    let eye = Vec3::new(-6.0, -6.0, 2.0);
    let cam = Camera::look_at(eye, eye + Vec3::X, Vec3::Z, 60.0, 256, 256, 0.1).unwrap();
    let big = Camera::look_at(eye, eye + Vec3::X, Vec3::Z, 60.0, 2048, 2048, 0.1).unwrap();
    let reference = render(&scene, &big).visible_set(scene.triangle_count());
    let samples = RvOptions {
        guarantee: Guarantee::AnySample,
        ..options()
    };
    let rv = conservative_visible(&mut StreamingCity::new(1, size), &cam, &samples).unwrap();
    assert!(rv.stats.retested);
    let missing: Vec<usize> = reference.difference(&rv.visible).collect();
    assert!(
        missing.is_empty(),
        "{} visible triangles missing",
        missing.len()
    );
    let (r, v) = (reference.count_ones(..), rv.visible.count_ones(..));
    println!(
        "rv streamed street: {} triangles, reference {r}, RV {v} (first pass {})",
        scene.triangle_count(),
        rv.stats.first_pass_visible
    );
    assert!(r > 50, "the view sees too little to judge ({r})");
    assert!(v <= 8 * r, "RV {v} against reference {r}");
}

/// Closed objects are where the guarantees differ: each back face meets the silhouette along
/// shared edges, where the rasterizer's tie rule can show it but its visible area is zero. With
/// positive-area semantics RV must find exactly the exact set of a lone box (every back face
/// lies inside the front faces' silhouette and behind them), from every angle, for boxes of
/// several proportions; with any-sample semantics it keeps back faces.
#[test]
fn rv_positive_area_drops_the_back_faces_of_closed_boxes() {
    use sightline_core::scene::SceneBuilder;
    let mut samples_extra = 0;
    for (min, max) in [
        (Vec3::splat(-1.0), Vec3::splat(1.0)),
        (Vec3::new(3.0, -0.5, -1.0), Vec3::new(4.0, 0.5, 0.5)),
        (Vec3::new(-4.0, 2.0, -1.0), Vec3::new(-2.5, 3.5, 9.0)),
    ] {
        let mut b = SceneBuilder::new("box");
        b.add_box(min, max);
        let scene = b.finish();
        for (k, cam) in cameras(&scene, &Placement::Orbit).iter().enumerate() {
            let exact = visible_fragments(&scene, cam, &AnalyticOptions::default()).unwrap();
            let area =
                conservative_visible(&mut SceneSource::new(&scene), cam, &options()).unwrap();
            assert_eq!(
                area.visible.ones().collect::<Vec<_>>(),
                exact.visible.ones().collect::<Vec<_>>(),
                "box {min}..{max} angle {k}: positive-area RV against the exact set"
            );
            let samples = RvOptions {
                guarantee: Guarantee::AnySample,
                ..options()
            };
            let rv = conservative_visible(&mut SceneSource::new(&scene), cam, &samples).unwrap();
            assert!(exact.visible.is_subset(&rv.visible), "angle {k}");
            samples_extra += rv.visible.count_ones(..) - exact.visible.count_ones(..);
        }
    }
    assert!(samples_extra > 0, "any-sample semantics kept no back face");
}

/// The thesis' initialization phase accepts each bin's first work item untested: still
/// conservative (against the exact set, with and without the re-test pass), and it does accept
/// triangles untested.
#[test]
fn rv_initialization_phase_stays_conservative() {
    let scene = procedural("procedural:city?size=8000");
    for retest_pass in [false, true] {
        let options = RvOptions {
            init_phase: true,
            retest_pass,
            ..options()
        };
        check_against_exact(&scene, &options, |rv| {
            assert!(rv.stats.init_accepted > 0, "nothing initialised")
        });
    }
}

/// Hidden triangles as occluder parts (only joining, or all): still conservative, and they do
/// build occluders (more triangle additions than visible triangles in the first pass).
#[test]
fn rv_hidden_occluders_stay_conservative() {
    let scene = procedural("procedural:city?size=8000");
    for hidden_occluders in [HiddenOccluders::Joining, HiddenOccluders::All] {
        let options = RvOptions {
            hidden_occluders,
            ..options()
        };
        check_against_exact(&scene, &options, |rv| {
            let s = &rv.stats;
            let added = s.occluders_created + s.occluders_grown + s.occluder_merges;
            assert!(
                added > s.first_pass_visible,
                "{hidden_occluders:?}: {added} occluder additions, {} visible",
                s.first_pass_visible
            );
        });
    }
}

/// Zero false negatives against the exact set from every other street-level angle, with
/// `check` run on each result.
fn check_against_exact(scene: &Scene, options: &RvOptions, check: impl Fn(&RvResult)) {
    for (k, cam) in cameras(scene, &Placement::Inside { height: 40.0 })
        .iter()
        .enumerate()
        .step_by(2)
    {
        let exact = visible_fragments(scene, cam, &AnalyticOptions::default()).unwrap();
        let rv = conservative_visible(&mut SceneSource::new(scene), cam, options).unwrap();
        check(&rv);
        let area = exact.visible_area(scene.triangle_count());
        let missing: Vec<usize> = exact
            .visible
            .difference(&rv.visible)
            .filter(|&t| area[t] >= MIN_VISIBLE_AREA_PX2)
            .collect();
        assert!(missing.is_empty(), "angle {k} ({options:?}): {missing:?}");
    }
}
