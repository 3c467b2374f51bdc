//! The simulation loop on a small Grid scene (few movers, 40 frames at 160x90).
//! - With results used at once (`latency = 0`), every cell re-queried every frame and no cap,
//!   culling is conservative frame by frame: no pixel pops, no object goes missing.
//! - With the thesis' one-frame latency, a missing object comes back within the configured
//!   invisible duration plus the latency (no starvation under the default cap).
//! - Every frame draws at most the frustum baseline's objects.
//! - The baselines (frustum, stop-and-wait, two-phase HZB) run over the same frames and ground
//!   truth and never pop: they cull against the current frame only.
//! - The grid method's per-object refinements draw fewer objects than box tests alone, within
//!   the same bounds; the diagnosis of drawn objects that are not visible adds up.
//! - With a backend that answers only through `take_results` (as hardware queries do), the
//!   grid method's object queries draw fewer objects than cell queries alone, within the same
//!   popping bounds, and leave the software backend's runs unchanged.

use glam::Vec3;
use sightline_core::{Aabb, Camera};
use sightline_cull::scenes::the_grid;
use sightline_cull::{
    simulate, simulate_methods, simulate_methods_with_cameras, simulate_viewports, Method,
    OcclusionBackend, SimConfig, SimReport, SoftwareBackend,
};
use sightline_test_support::simulation::small_grid_config;

#[test]
fn immediate_results_never_pop() {
    let scene = the_grid(5, 3);
    let cfg = small_grid_config(0);
    let mut backend = SoftwareBackend::new(cfg.width, cfg.height);
    let report = simulate(&scene, &mut backend, &cfg).unwrap();
    assert_eq!(report.frames.len(), 40);
    for (i, f) in report.frames.iter().enumerate() {
        assert_eq!(f.popping_pixels, 0, "frame {i}: {f:?}");
        assert!(
            f.drawn <= f.frustum && f.exact_visible <= f.drawn,
            "frame {i}: {f:?}"
        );
    }
    assert_eq!(report.max_streak(), 0);
}

#[test]
fn one_frame_latency_objects_return_quickly() {
    let scene = the_grid(5, 3);
    let cfg = small_grid_config(1);
    let mut backend = SoftwareBackend::new(cfg.width, cfg.height);
    let report = simulate(&scene, &mut backend, &cfg).unwrap();
    let bound = (cfg.scheduler.invisible_duration + 1) as usize;
    assert!(report.max_streak() <= bound, "{}", report.summary());
    assert!(report.measured().iter().all(|f| f.drawn <= f.frustum));
}

#[test]
fn baselines_run_in_the_same_frames_and_never_pop() {
    let scene = the_grid(5, 3);
    let cfg = small_grid_config(1);
    let mut backend = SoftwareBackend::new(cfg.width, cfg.height);
    let reports = simulate_methods(&scene, &mut backend, &cfg, &Method::ALL).unwrap();
    let methods: Vec<Method> = reports.iter().map(|r| r.method).collect();
    assert_eq!(methods, Method::ALL.to_vec());
    let frustum = &reports[1];
    for r in &reports[1..] {
        // Frustum, stop-and-wait and two-phase HZB only cull against this frame's depth.
        assert_eq!(r.frames.len(), 40);
        assert_eq!(r.max_streak(), 0, "{}", r.summary());
        for (i, (f, g)) in r.frames.iter().zip(&frustum.frames).enumerate() {
            assert_eq!(f.popping_pixels, 0, "{} frame {i}: {f:?}", r.method.name());
            assert!(f.exact_visible <= f.drawn && f.drawn <= g.drawn, "{f:?}");
            // The same ground truth for every method.
            assert_eq!(f.exact_visible, g.exact_visible);
        }
    }
    // Occlusion culling culls: stop-and-wait draws fewer objects than the frustum.
    let (sw, fr) = (
        reports[2].mean(|f| f.drawn as f64),
        frustum.mean(|f| f.drawn as f64),
    );
    assert!(sw < 0.5 * fr, "stop-and-wait {sw} frustum {fr}");
}

/// Two viewports (as in split screen) over one shared grid: each keeps its own scheduler and
/// traversal, so a viewport's culling is exactly what it would be alone (sharing the grid and
/// its per-pass draw marks must not leak between viewports), and each stays within the
/// latency bound on its own ground truth.
#[test]
fn two_viewports_share_one_grid_without_interfering() {
    let scene = the_grid(5, 3);
    let cfg = small_grid_config(1);
    let path_camera = |f: u32| {
        let t = f as f32 / cfg.fps;
        scene.path.camera(t, cfg.width, cfg.height, cfg.fov_y_deg)
    };
    // The second viewport looks back along the path from a little higher up.
    let back_camera = |f: u32| {
        let t = f as f32 / cfg.fps;
        let (eye, dir) = scene.path.pose(t);
        let eye = eye + glam::Vec3::new(0.0, 0.0, 1.5);
        sightline_core::Camera::look_at(
            eye,
            eye - dir,
            glam::Vec3::Z,
            cfg.fov_y_deg,
            cfg.width,
            cfg.height,
            0.05,
        )
        .ok()
    };
    let mut backend = SoftwareBackend::new(cfg.width, cfg.height);
    let both =
        simulate_viewports(&scene, &[&path_camera, &back_camera], &mut backend, &cfg).unwrap();
    assert_eq!(both.len(), 2);
    for (v, camera) in [&path_camera as &dyn Fn(u32) -> _, &back_camera]
        .iter()
        .enumerate()
    {
        let mut alone_backend = SoftwareBackend::new(cfg.width, cfg.height);
        let alone = simulate_methods_with_cameras(
            &scene,
            *camera,
            &mut alone_backend,
            &cfg,
            &[Method::Grid],
        )
        .unwrap();
        let drawn = |r: &sightline_cull::SimReport| -> Vec<u32> {
            r.frames.iter().map(|f| f.drawn).collect()
        };
        assert_eq!(drawn(&both[v]), drawn(&alone[0]), "viewport {v}");
        assert_eq!(both[v].frames.len(), 40);
        let bound = (cfg.scheduler.invisible_duration + 1) as usize;
        assert!(both[v].max_streak() <= bound, "{}", both[v].summary());
    }
    // The two viewports see different parts of the scene.
    let exact = |r: &sightline_cull::SimReport| -> Vec<u32> {
        r.frames.iter().map(|f| f.exact_visible).collect()
    };
    assert_ne!(exact(&both[0]), exact(&both[1]));
}

/// The grid method's per-object refinements (the triangle test where the box passes, a larger
/// pre-pass cap for tested objects, a cell's objects front to back, the reverse-order retest)
/// draw fewer objects than the box test alone over the same frames and ground truth, and keep
/// the latency bound; the triangle test alone draws no more than the box test either.
#[test]
fn object_refinements_draw_fewer_objects_within_the_bounds() {
    let scene = the_grid(5, 3);
    let refined = small_grid_config(1);
    let boxes = SimConfig {
        triangle_tests: false,
        tested_prepass_cap: 0,
        sort_cell_objects: false,
        retest: false,
        ..refined
    };
    let triangles_only = SimConfig {
        triangle_tests: true,
        ..boxes
    };
    let run = |cfg: &SimConfig| {
        let mut backend = SoftwareBackend::new(cfg.width, cfg.height);
        simulate(&scene, &mut backend, cfg).unwrap()
    };
    let (r_boxes, r_tri, r_refined) = (run(&boxes), run(&triangles_only), run(&refined));
    let drawn = |r: &sightline_cull::SimReport| r.mean(|f| f.drawn as f64);
    eprintln!(
        "drawn: boxes {:.2}, triangles {:.2}, refined {:.2}",
        drawn(&r_boxes),
        drawn(&r_tri),
        drawn(&r_refined)
    );
    assert!(drawn(&r_tri) <= drawn(&r_boxes), "{}", r_tri.summary());
    assert!(
        drawn(&r_refined) < drawn(&r_boxes),
        "{}",
        r_refined.summary()
    );
    let bound = (refined.scheduler.invisible_duration + 1) as usize;
    for r in [&r_boxes, &r_tri, &r_refined] {
        assert!(r.max_streak() <= bound, "{}", r.summary());
        for (f, g) in r.frames.iter().zip(&r_boxes.frames) {
            assert_eq!(f.exact_visible, g.exact_visible);
            assert!(f.drawn <= f.frustum, "{f:?}");
        }
    }
    let retested: u32 = r_refined.frames.iter().map(|f| f.retest_culled).sum();
    assert!(
        retested > 0,
        "the retest never culled: {}",
        r_refined.summary()
    );
}

/// The diagnosis attributes every drawn object without a ground-truth pixel to exactly one
/// cause; methods that test triangles leave no sub-pixel object and nothing for the triangle
/// test to catch, while the box test leaves some.
#[test]
fn diagnosis_accounts_for_every_drawn_object_that_is_not_visible() {
    let scene = the_grid(5, 3);
    let cfg = SimConfig {
        diagnose: true,
        ..small_grid_config(1)
    };
    let mut backend = SoftwareBackend::new(cfg.width, cfg.height);
    let methods = [
        Method::Grid,
        Method::StopAndWait,
        Method::StopAndWaitTriangles,
    ];
    let reports = simulate_methods(&scene, &mut backend, &cfg, &methods).unwrap();
    for r in &reports {
        for (i, f) in r.measured().iter().enumerate() {
            let drawn_visible = f.exact_visible - f.missing;
            assert_eq!(
                f.extra.total(),
                f.drawn - drawn_visible,
                "{} frame {i}: {f:?}",
                r.method.name()
            );
        }
    }
    let sum = |r: &sightline_cull::SimReport, pick: fn(&sightline_cull::ExtraCauses) -> u32| {
        r.measured().iter().map(|f| pick(&f.extra)).sum::<u32>()
    };
    for r in [&reports[0], &reports[2]] {
        assert_eq!(sum(r, |e| e.sub_pixel), 0, "{}", r.method.name());
        assert_eq!(sum(r, |e| e.box_test), 0, "{}", r.method.name());
    }
    let by_box = sum(&reports[1], |e| e.box_test) + sum(&reports[1], |e| e.sub_pixel);
    assert!(by_box > 0, "{:?}", reports[1].extra_means());
    // Stop-and-wait with triangle tests draws no more than with boxes.
    let drawn = |r: &sightline_cull::SimReport| r.mean(|f| f.drawn as f64);
    assert!(drawn(&reports[2]) <= drawn(&reports[1]));
}

/// The software backend seen as hardware queries: no answer at once (`test_*_now` keep their
/// `None` defaults), box queries answered through `take_results` only.
struct Deferred(SoftwareBackend);

impl OcclusionBackend for Deferred {
    fn begin_frame(&mut self, camera: &Camera) {
        self.0.begin_frame(camera);
    }
    fn draw_depth(&mut self, triangles: &[Vec3]) {
        self.0.draw_depth(triangles);
    }
    fn query(&mut self, tag: u32, aabb: &Aabb) {
        self.0.query(tag, aabb);
    }
    fn take_results(&mut self, out: &mut Vec<(u32, bool)>) {
        self.0.take_results(out);
    }
}

fn popping_percent(r: &SimReport) -> f64 {
    r.mean(|f| f64::from(f.popping_pixels)) / f64::from(r.pixels) * 100.0
}

#[test]
fn object_queries_cull_inside_drawn_cells_when_answers_come_later() {
    let scene = the_grid(5, 3);
    let with = small_grid_config(1);
    let without = SimConfig {
        object_queries: false,
        ..with
    };
    let run = |cfg: &SimConfig| {
        let mut backend = Deferred(SoftwareBackend::new(cfg.width, cfg.height));
        simulate(&scene, &mut backend, cfg).unwrap()
    };
    let (r_with, r_without) = (run(&with), run(&without));
    let drawn = |r: &SimReport| r.mean(|f| f64::from(f.drawn));
    eprintln!("with object queries:    {}", r_with.summary());
    eprintln!("without object queries: {}", r_without.summary());
    assert!(
        drawn(&r_with) < drawn(&r_without) * 0.8,
        "with {} without {}",
        r_with.summary(),
        r_without.summary()
    );
    // Object queries are counted among the queries, and only where they were on.
    let object_queries: u32 = r_with.frames.iter().map(|f| f.object_queries).sum();
    assert!(object_queries > 0);
    assert!(r_with.frames.iter().all(|f| f.object_queries <= f.queries));
    assert!(r_without.frames.iter().all(|f| f.object_queries == 0));
    // An object hidden by last frame's answer and visible now is missed one frame, like a
    // cell: within the same streak bound, and the mean popping within the goal.
    let bound = (with.scheduler.invisible_duration + 1) as usize;
    for r in [&r_with, &r_without] {
        assert!(r.max_streak() <= bound, "{}", r.summary());
        assert!(popping_percent(r) < 0.1, "{}", r.summary());
        for (f, g) in r.frames.iter().zip(&r_without.frames) {
            assert_eq!(f.exact_visible, g.exact_visible);
            assert!(f.drawn <= f.frustum, "{f:?}");
        }
    }
    // A backend that answers at once never issues object queries: the same run either way.
    let sw = |cfg: &SimConfig| {
        let mut backend = SoftwareBackend::new(cfg.width, cfg.height);
        simulate(&scene, &mut backend, cfg).unwrap()
    };
    let (s_with, s_without) = (sw(&with), sw(&without));
    for (f, g) in s_with.frames.iter().zip(&s_without.frames) {
        let (f, g) = (
            sightline_cull::FrameStats { cull_ms: 0.0, ..*f },
            sightline_cull::FrameStats { cull_ms: 0.0, ..*g },
        );
        assert_eq!(f, g);
        assert_eq!(f.object_queries, 0);
    }
}
