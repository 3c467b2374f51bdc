//! The simulation loop of sightline-cull on a small Grid scene (few movers, 40 frames at
//! 160x90) with the GPU backend, under the bounds the software backend is tested with
//! (`crates/cull/tests/simulation.rs`):
//! - results used at once (`latency = 0`, stop and wait), every cell re-queried every frame:
//!   no pixel pops, no object goes missing, no frame draws more than the frustum baseline;
//! - the thesis' one-frame latency: a missing object comes back within the invisible duration
//!   plus the latency.
//! - per-object box queries inside drawn cells (results read next frame, like the cells'):
//!   fewer objects drawn than with cell queries alone, within the same popping bounds.

use sightline_cull::scenes::the_grid;
use sightline_cull::{simulate, SimConfig, SoftwareBackend};

use super::gpu;
use sightline_test_support::simulation::small_grid_config;

#[test]
fn immediate_results_never_pop_on_the_gpu() {
    let scene = the_grid(5, 3);
    let cfg = small_grid_config(0);
    let mut backend = gpu();
    let report = simulate(&scene, &mut backend, &cfg).unwrap();
    eprintln!("gpu, latency 0: {}", report.summary());
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
fn one_frame_latency_within_the_software_bounds() {
    let scene = the_grid(5, 3);
    // Cell queries only on both sides (object queries are tested below).
    let cfg = SimConfig {
        object_queries: false,
        ..small_grid_config(1)
    };
    let mut backend = gpu();
    let report = simulate(&scene, &mut backend, &cfg).unwrap();
    let mut sw = SoftwareBackend::new(cfg.width, cfg.height);
    // Like with like: the software backend can also test single objects at once
    // (`test_now`), which hardware queries cannot; compare the cell-query method alone.
    let sw_cfg = sightline_cull::SimConfig {
        object_tests: false,
        ..cfg
    };

    let sw_report = simulate(&scene, &mut sw, &sw_cfg).unwrap();
    eprintln!("gpu, latency 1: {}", report.summary());
    eprintln!("sw,  latency 1: {}", sw_report.summary());
    let bound = (cfg.scheduler.invisible_duration + 1) as usize;
    assert!(report.max_streak() <= bound, "{}", report.summary());
    assert!(sw_report.max_streak() <= bound, "{}", sw_report.summary());
    assert!(report.measured().iter().all(|f| f.drawn <= f.frustum));
    // Same objects move the same way: the GPU culls at least as well as the software buffer
    // on average, within a tenth (it is exact where the software buffer widens boxes).
    let drawn = |r: &sightline_cull::SimReport| r.mean(|f| f.drawn as f64);
    assert!(
        drawn(&report) <= drawn(&sw_report) * 1.1 + 1.0,
        "gpu {} sw {}",
        report.summary(),
        sw_report.summary()
    );
}

#[test]
fn object_queries_draw_fewer_objects_within_the_bounds() {
    let scene = the_grid(5, 3);
    let with = small_grid_config(1);
    let without = SimConfig {
        object_queries: false,
        ..with
    };
    let r_with = simulate(&scene, &mut gpu(), &with).unwrap();
    let r_without = simulate(&scene, &mut gpu(), &without).unwrap();
    eprintln!("gpu, object queries:  {}", r_with.summary());
    eprintln!("gpu, cell queries only: {}", r_without.summary());
    let drawn = |r: &sightline_cull::SimReport| r.mean(|f| f64::from(f.drawn));
    assert!(
        drawn(&r_with) < drawn(&r_without) * 0.8,
        "with {} without {}",
        r_with.summary(),
        r_without.summary()
    );
    assert!(r_with.frames.iter().any(|f| f.object_queries > 0));
    let bound = (with.scheduler.invisible_duration + 1) as usize;
    let popping = r_with.mean(|f| f64::from(f.popping_pixels)) / f64::from(r_with.pixels);
    assert!(r_with.max_streak() <= bound, "{}", r_with.summary());
    assert!(popping < 0.001, "{}", r_with.summary());
    assert!(r_with.measured().iter().all(|f| f.drawn <= f.frustum));
}
