//! The simulation loop: a camera path through a scene with moving objects, culled per frame by
//! the grid traversal, the query scheduler and an occlusion backend, and measured against the
//! exact image: objects drawn, queries, cells, culling time and popping.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, sections 4.3.2-4.3.5 (the per-frame loop) and 5.3 (metrics; the thesis judged
//! popping by eye, here it is counted). Beyond the thesis, where the backend answers object
//! tests at once (the software buffer): objects of drawn cells are tested front to back by
//! box, then triangles, tested objects get a larger pre-pass cap, and the drawn objects are
//! retested against the frame's occluders in reverse order (see [`SimConfig`]). Where it cannot
//! (hardware queries), objects of drawn cells get box queries of their own, read a frame later
//! like the cells' ([`SimConfig::object_queries`]).
//!
//! # Popping, precisely
//! The ground truth is the reference rasterizer's image of all objects. The image of the drawn
//! objects only differs from it exactly at the pixels whose ground-truth triangle belongs to a
//! culled object (a triangle nearest among all triangles is nearest among any subset holding
//! it, with the same tie rule), so those pixels are counted without rendering the second
//! image. An object is *missing* in a frame when it has a pixel in the ground truth and was
//! not drawn; a missing streak is the number of consecutive frames it stays missing.

use std::time::Instant;

use sightline_core::raster::{Frame, Rasterizer};
use sightline_core::{Camera, Hit};

use crate::backend::OcclusionBackend;
use crate::diagnose::Objects;
use crate::grid::{GridError, GridShape};
use crate::scenes::CullScene;
use crate::sim_method::MethodState;
use crate::sim_types::{FrameStats, Method, SimConfig, SimReport};
use crate::sim_world::{MovingObjects, World};
use crate::traversal::Traversal;

/// Runs the simulation of `scene` along its camera path with `backend`: the grid method only.
pub fn simulate(
    scene: &CullScene,
    backend: &mut dyn OcclusionBackend,
    config: &SimConfig,
) -> Result<SimReport, GridError> {
    let mut reports = simulate_methods(scene, backend, config, &[Method::Grid])?;
    Ok(reports.pop().unwrap_or_default())
}

/// Runs the simulation of `scene` along its camera path once, culling every frame with each
/// of `methods` (in that order; `backend` serves the grid and stop-and-wait methods, the
/// two-phase method has its own software buffer) and measuring each against the same ground
/// truth. Returns one report per method.
pub fn simulate_methods(
    scene: &CullScene,
    backend: &mut dyn OcclusionBackend,
    config: &SimConfig,
    methods: &[Method],
) -> Result<Vec<SimReport>, GridError> {
    let camera = |f: u32| {
        let t = f as f32 / config.fps;
        scene
            .path
            .camera(t, config.width, config.height, config.fov_y_deg)
    };
    simulate_methods_with_cameras(scene, &camera, backend, config, methods)
}

/// As [`simulate_methods`], with the camera of frame `f` given by `camera(f)` instead of the
/// scene's path (frames without a camera are skipped). The camera's image size should be the
/// configured one.
pub fn simulate_methods_with_cameras(
    scene: &CullScene,
    camera_of: &dyn Fn(u32) -> Option<Camera>,
    backend: &mut dyn OcclusionBackend,
    config: &SimConfig,
    methods: &[Method],
) -> Result<Vec<SimReport>, GridError> {
    let views: Vec<(Method, usize)> = methods.iter().map(|&m| (m, 0)).collect();
    simulate_views(scene, &[camera_of], backend, config, &views)
}

/// Several viewports (split screen, a shadow view, ...) culling one moving scene through one
/// shared uniform grid, each with its own query scheduler, traversal and popping measurement
/// (the thesis, section 4.4): viewport `v` sees the camera `cameras[v](frame)`. Every viewport
/// runs the grid method; the backend is used by one viewport after the other within a frame
/// (so it must answer a viewport's queries before the next one begins, as the software backend
/// does). Frames where a viewport has no camera are skipped for all. One report per viewport.
pub fn simulate_viewports(
    scene: &CullScene,
    cameras: &[&dyn Fn(u32) -> Option<Camera>],
    backend: &mut dyn OcclusionBackend,
    config: &SimConfig,
) -> Result<Vec<SimReport>, GridError> {
    let views: Vec<(Method, usize)> = (0..cameras.len()).map(|v| (Method::Grid, v)).collect();
    simulate_views(scene, cameras, backend, config, &views)
}

/// The simulation core: one state per `(method, viewport)` in `views`, all over one world.
fn simulate_views(
    scene: &CullScene,
    cameras: &[&dyn Fn(u32) -> Option<Camera>],
    backend: &mut dyn OcclusionBackend,
    config: &SimConfig,
    views: &[(Method, usize)],
) -> Result<Vec<SimReport>, GridError> {
    let mut sim = Simulation::new(scene, config, views)?;
    for f in 0..config.frames {
        let t = f as f32 / config.fps;
        let Some(frame_cameras) = cameras
            .iter()
            .map(|c| c(f))
            .collect::<Option<Vec<Camera>>>()
        else {
            continue;
        };
        sim.moving.advance(&mut sim.world, t)?;
        let mut frame_stats = sim.cull_views(&frame_cameras, backend);
        if config.measure_popping {
            sim.score_views(&frame_cameras, &mut frame_stats, f);
        }
        for (st, stats) in sim.states.iter_mut().zip(frame_stats) {
            st.report.frames.push(stats);
        }
    }
    Ok(sim.into_reports())
}

/// The state of [`simulate_views`] across frames: the world and its moving objects, one
/// method state per view, and the buffers every frame reuses (the frustum baseline's
/// traversal, the ground truth's image and visible objects).
struct Simulation<'a> {
    config: &'a SimConfig,
    /// `(method, viewport)` of every state.
    views: &'a [(Method, usize)],
    world: World<'a>,
    moving: MovingObjects,
    /// One per view.
    states: Vec<MethodState>,
    /// The frustum baseline's cells, objects and traversal.
    frustum_cells: Vec<u32>,
    frustum_objs: Vec<u32>,
    frustum_traversal: Traversal,
    /// The ground truth's image.
    frame_img: Frame,
    /// Per object: whether it shows in the ground truth.
    visible: Vec<bool>,
}

impl<'a> Simulation<'a> {
    /// The world of `scene` at time 0 and a fresh state for every view.
    fn new(
        scene: &'a CullScene,
        config: &'a SimConfig,
        views: &'a [(Method, usize)],
    ) -> Result<Self, GridError> {
        let n_obj = scene.scene.objects.len();
        let shape = GridShape::with_cell_size(&scene.bounds, scene.cell_size)?;
        let (moving, world) = MovingObjects::start(scene, shape)?;
        let states = views
            .iter()
            .map(|&(method, _)| MethodState::new(method, shape, n_obj, config))
            .collect();
        Ok(Simulation {
            config,
            views,
            world,
            moving,
            states,
            frustum_cells: Vec::new(),
            frustum_objs: Vec::new(),
            frustum_traversal: Traversal::new(),
            frame_img: Frame::new(config.width, config.height),
            visible: vec![false; n_obj],
        })
    }

    /// Culls the frame with every view's method (timed) and counts its frustum baseline:
    /// one [`FrameStats`] per view, scored later.
    fn cull_views(
        &mut self,
        frame_cameras: &[Camera],
        backend: &mut dyn OcclusionBackend,
    ) -> Vec<FrameStats> {
        let config = self.config;
        let mut frame_stats = Vec::with_capacity(self.states.len());
        for (st, &(_, view)) in self.states.iter_mut().zip(self.views) {
            let camera = &frame_cameras[view];
            self.frustum_cells.clear();
            self.frustum_traversal.visit(
                &self.world.shape,
                camera,
                config.far,
                &mut self.frustum_cells,
            );
            self.frustum_objs.clear();
            self.world
                .frustum_objects(&self.frustum_cells, &mut self.frustum_objs);
            st.drawn.clear();
            st.prepassed.clear();
            let mut stats = FrameStats::default();
            let start = Instant::now();
            st.cull(&mut self.world, camera, backend, config, &mut stats);
            stats.cull_ms = start.elapsed().as_secs_f64() * 1e3;
            stats.drawn = st.drawn.len() as u32;
            stats.frustum = self.frustum_objs.len() as u32;
            frame_stats.push(stats);
        }
        frame_stats
    }

    /// Ground truth and popping, once per viewport for every method: renders each
    /// viewport's exact image and scores the views that see it.
    fn score_views(&mut self, frame_cameras: &[Camera], frame_stats: &mut [FrameStats], f: u32) {
        for (view, camera) in frame_cameras.iter().enumerate() {
            Rasterizer::new(&self.moving.moved).render(camera, None, &mut self.frame_img);
            self.visible.fill(false);
            let ids: Vec<usize> = self
                .frame_img
                .ids
                .iter()
                .filter(|&&id| id != Hit::NONE)
                .map(|&id| self.moving.moved.object_of_triangle[id as usize] as usize)
                .collect();
            for &o in &ids {
                self.visible[o] = true;
            }
            let exact = self.visible.iter().filter(|&&v| v).count() as u32;
            let of_view = self
                .states
                .iter_mut()
                .zip(frame_stats.iter_mut())
                .zip(self.views);
            for ((st, stats), _) in of_view.filter(|(_, &(_, v))| v == view) {
                let ground_truth = GroundTruth {
                    visible: &self.visible,
                    ids: &ids,
                    exact,
                };
                score_view(
                    st,
                    stats,
                    &ground_truth,
                    &self.world,
                    camera,
                    self.config,
                    f,
                );
            }
        }
    }

    /// One report per view, with the missing streaks still open at the end counted.
    fn into_reports(self) -> Vec<SimReport> {
        self.states
            .into_iter()
            .map(|mut st| {
                for &s in st.streak.iter().filter(|&&s| s > 0) {
                    bump(&mut st.report.streaks, s);
                }
                st.report
            })
            .collect()
    }
}

/// One viewport's ground truth in one frame: which objects show, the object of every covered
/// pixel, and how many objects show.
struct GroundTruth<'a> {
    visible: &'a [bool],
    ids: &'a [usize],
    exact: u32,
}

/// Scores one method's frame against the ground truth of its viewport: exactly visible
/// objects, the diagnosis of extra objects drawn, popping pixels, missing objects and their
/// streaks (after the method's warm-up frames).
fn score_view(
    st: &mut MethodState,
    stats: &mut FrameStats,
    truth: &GroundTruth,
    world: &World,
    camera: &Camera,
    config: &SimConfig,
    f: u32,
) {
    let (visible, ids, exact) = (truth.visible, truth.ids, truth.exact);
    for &o in &st.drawn {
        st.drawn_flag[o as usize] = true;
    }
    stats.exact_visible = exact;
    if let Some(diagnosis) = &mut st.diagnosis {
        let objects = Objects {
            boxes: &world.boxes,
            corners: &world.corners,
            ranges: &world.ranges,
        };
        let triangles = st.method == Method::StopAndWaitTriangles
            || (st.method == Method::Grid && config.object_tests && config.triangle_tests);
        stats.extra = diagnosis.classify(
            camera,
            &objects,
            &st.drawn,
            &st.prepassed,
            visible,
            triangles,
        );
    }
    stats.popping_pixels = ids.iter().filter(|&&o| !st.drawn_flag[o]).count() as u32;
    if f >= st.report.warmup {
        let per_object = visible.iter().zip(&st.drawn_flag).zip(&mut st.streak);
        for ((&vis, &drawn), streak) in per_object {
            if vis && !drawn {
                stats.missing += 1;
                *streak += 1;
            } else if *streak > 0 {
                bump(&mut st.report.streaks, *streak);
                *streak = 0;
            }
        }
    }
    for &o in &st.drawn {
        st.drawn_flag[o as usize] = false;
    }
}

fn bump(hist: &mut Vec<u32>, k: u32) {
    let k = k as usize;
    if hist.len() <= k {
        hist.resize(k + 1, 0);
    }
    hist[k] += 1;
}
