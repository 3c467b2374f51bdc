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

use glam::Vec3;
use serde::Serialize;
use sightline_core::raster::{Frame, Rasterizer};
use sightline_core::{Aabb, Camera, Hit, Scene};

use crate::backend::OcclusionBackend;
use crate::diagnose::{Diagnosis, ExtraCauses, Objects};
use crate::front_to_back::sort_front_to_back;
use crate::grid::{Grid, GridError, GridShape};
use crate::hzb::Hzb;
use crate::masked_occlusion::OcclusionBuffer;
use crate::scenes::CullScene;
use crate::scheduler::{Scheduler, SchedulerConfig};
use crate::traversal::Traversal;

/// Settings of a simulation run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SimConfig {
    /// Frames to simulate.
    pub frames: u32,
    /// Frames per second of the simulated clock.
    pub fps: f32,
    /// Image (and occlusion buffer) width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Vertical field of view in degrees.
    pub fov_y_deg: f32,
    /// Far distance of the traversal.
    pub far: f32,
    /// Frames between issuing a query and using its result: 1 as with hardware queries (the
    /// thesis), 0 for a software backend that answers at once.
    pub latency: u32,
    /// The scheduler's numbers.
    pub scheduler: SchedulerConfig,
    /// Render the ground truth and count popping (costly); off measures culling only.
    pub measure_popping: bool,
    /// Grid method: query the union of a cell's object boxes clipped to the cell instead of
    /// the whole cell box (a cell whose objects are hidden is then found hidden even when the
    /// empty rest of the cell would show).
    pub tight_query_boxes: bool,
    /// Grid method: test each object of a drawn cell against the depth drawn so far in this
    /// frame when the backend answers at once (the software backend), and skip hidden ones.
    pub object_tests: bool,
    /// Grid method: where an object's box passes that test, test its triangles too
    /// ([`OcclusionBackend::test_object_now`]; the box of a box-shaped object still projects
    /// to a larger rectangle, at its nearest corner's depth).
    pub triangle_tests: bool,
    /// Grid method: the depth pre-pass cap for a sometimes-class object whose test was
    /// answered at once and passed (the larger of this and the scheduler's cap). The
    /// thesis' cap of 75 objects saves GPU pre-pass time; in a software buffer an object
    /// found visible costs about what its test did, and on The Grid the 75 are spent on
    /// walls in frames that see several rooms. Tuned: The Grid needs 120 (more changes
    /// nothing there), the Graveyard draws 1 % fewer objects with 300 at 60 % more pre-pass.
    pub tested_prepass_cap: usize,
    /// Grid method: test a drawn cell's objects front to back (by the nearest point of their
    /// boxes), so that an object's occluders in the same cell are drawn before its test.
    pub sort_cell_objects: bool,
    /// Grid method with `object_tests`: after the traversal, render the frame's pre-pass
    /// occluders once more in reverse order ([`OcclusionBackend::begin_retest`]), test the
    /// drawn objects against them ([`OcclusionBackend::retest_now`], where the backend
    /// answers at once) and drop the hidden ones; they stay in the depth as the real
    /// occluders they are.
    pub retest: bool,
    /// Grid method with `object_tests`, for objects whose test the backend cannot answer at
    /// once (hardware queries, [`OcclusionBackend::test_object_now`] returns `None`): the
    /// hardware-query analogue of the test. Such an object of a drawn cell is skipped when
    /// its own box query, issued in the last `invisible_duration` frames (the scheduler's)
    /// over a box that lay inside the view and still holds the object, said hidden; otherwise
    /// it is drawn (no answer yet, a visible one, or a stale one: new objects, cells just
    /// drawn, objects that moved out of their query box). Every skipped object is queried
    /// again, and a drawn one whenever it has no visible answer younger than
    /// `object_visible_duration` frames; answers are read a frame later, like the cells'.
    /// Query boxes are grown by the object's last step (twice ahead, once around) and by two
    /// of the camera's last steps, so that next frame's object and eye are still covered.
    /// Object queries count in the scheduler's query cap after the cells'. With `latency = 0`
    /// each object's answer is waited for instead and used at once. Backends that answer at
    /// once never see these queries.
    pub object_queries: bool,
    /// Frames a visible result of an object query lasts before the drawn object is queried
    /// again (so objects that become hidden are found).
    pub object_visible_duration: u64,
    /// Grid and stop-and-wait methods: attribute every drawn object that is not exactly
    /// visible to a cause ([`FrameStats::extra`]); needs `measure_popping`, costs a few
    /// occluder renders per frame outside the timed culling.
    pub diagnose: bool,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            frames: 300,
            fps: 30.0,
            width: 640,
            height: 360,
            fov_y_deg: 60.0,
            far: 1000.0,
            latency: 1,
            scheduler: SchedulerConfig::default(),
            measure_popping: true,
            tight_query_boxes: true,
            object_tests: true,
            triangle_tests: true,
            tested_prepass_cap: 150,
            sort_cell_objects: true,
            retest: true,
            object_queries: true,
            object_visible_duration: 8,
            diagnose: false,
        }
    }
}

/// What one frame did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FrameStats {
    /// Objects drawn (in colour).
    pub drawn: u32,
    /// Objects with at least one pixel in the ground truth (0 when not measured).
    pub exact_visible: u32,
    /// Objects in cells inside the frustum (the frustum-culling baseline).
    pub frustum: u32,
    /// Queries issued (cell and object queries for the grid method, object tests for the
    /// baselines).
    pub queries: u32,
    /// Grid method: of `queries`, the object queries ([`SimConfig::object_queries`]).
    pub object_queries: u32,
    /// Grid method: objects of drawn cells tested at once against the frame's depth.
    pub object_tests: u32,
    /// Grid method: drawn objects dropped by the retest after the traversal.
    pub retest_culled: u32,
    /// Non-empty cells traversed.
    pub cells: u32,
    /// Objects rendered into the depth pre-pass.
    pub prepass: u32,
    /// Wall-clock milliseconds of culling (traversal, scheduling, occluders, queries).
    pub cull_ms: f64,
    /// Pixels wrong because a visible object was culled.
    pub popping_pixels: u32,
    /// Visible objects not drawn.
    pub missing: u32,
    /// Drawn objects that are not exactly visible, by cause (with [`SimConfig::diagnose`]).
    pub extra: ExtraCauses,
}

/// The whole run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SimReport {
    /// The culling method measured.
    pub method: Method,
    /// Per-frame numbers.
    pub frames: Vec<FrameStats>,
    /// `streaks[k]`: number of missing streaks that lasted `k` frames (index 0 unused).
    pub streaks: Vec<u32>,
    /// Pixels per frame.
    pub pixels: u32,
    /// Objects in the scene.
    pub objects: u32,
    /// Leading frames left out of the means: the first `latency` frames have no query results
    /// yet and draw nothing (every cell starts invisible, as in the thesis).
    pub warmup: u32,
}

impl SimReport {
    /// Mean of a per-frame quantity.
    pub fn mean(&self, f: impl Fn(&FrameStats) -> f64) -> f64 {
        let frames = self.measured();
        if frames.is_empty() {
            return 0.0;
        }
        frames.iter().map(f).sum::<f64>() / frames.len() as f64
    }

    /// The frames after the warm-up.
    pub fn measured(&self) -> &[FrameStats] {
        &self.frames[(self.warmup as usize).min(self.frames.len())..]
    }

    /// Longest missing streak in frames (0 when nothing ever went missing).
    pub fn max_streak(&self) -> usize {
        self.streaks.iter().rposition(|&n| n > 0).unwrap_or(0)
    }

    /// Mean per frame of each cause of drawn objects that are not exactly visible (zero
    /// without [`SimConfig::diagnose`]), in cascade order.
    pub fn extra_means(&self) -> Vec<(&'static str, f64)> {
        let names = ExtraCauses::default().named();
        (0..names.len())
            .map(|k| (names[k].0, self.mean(|f| f64::from(f.extra.named()[k].1))))
            .collect()
    }

    /// A one-paragraph summary.
    pub fn summary(&self) -> String {
        let pop = self.mean(|f| f.popping_pixels as f64) / self.pixels.max(1) as f64 * 100.0;
        let max_pop = self
            .measured()
            .iter()
            .map(|f| f.popping_pixels)
            .max()
            .unwrap_or(0) as f64
            / self.pixels.max(1) as f64
            * 100.0;
        let max_ms = self
            .measured()
            .iter()
            .map(|f| f.cull_ms)
            .fold(0.0, f64::max);
        format!(
            "{}: frames {} objects {} | drawn {:.0} exact-visible {:.0} frustum {:.0} | queries {:.0} \
             cells {:.0} prepass {:.0} | cull {:.2} ms (max {:.2}) | popping {:.4} % (max {:.3} %), \
             missing {:.2} objects/frame, longest streak {} frames, streaks {:?}",
            self.method.name(),
            self.measured().len(),
            self.objects,
            self.mean(|f| f.drawn as f64),
            self.mean(|f| f.exact_visible as f64),
            self.mean(|f| f.frustum as f64),
            self.mean(|f| f.queries as f64),
            self.mean(|f| f.cells as f64),
            self.mean(|f| f.prepass as f64),
            self.mean(|f| f.cull_ms),
            max_ms,
            pop,
            max_pop,
            self.mean(|f| f.missing as f64),
            self.max_streak(),
            &self.streaks[1.min(self.streaks.len())..],
        )
    }
}

/// A culling method measured by the simulation, all over the same frames and ground truth.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
pub enum Method {
    /// The thesis' method: grid traversal in occlusion order, per-cell queries read with the
    /// configured latency, scheduler and depth pre-pass.
    #[default]
    Grid,
    /// Frustum culling only: every object of a cell touched by the frustum.
    Frustum,
    /// Stop-and-wait: every object in the frustum, front to back, queried against the current
    /// frame's depth, waiting for each answer; visible objects are drawn into the depth.
    StopAndWait,
    /// Two-phase hierarchical Z: draw last frame's visible objects, build a depth pyramid,
    /// test every object in the frustum, draw the newly visible.
    TwoPhaseHzb,
    /// Stop-and-wait with the grid method's object test where the backend answers at once:
    /// the box, then the triangles ([`OcclusionBackend::test_object_now`]); box queries
    /// otherwise.
    StopAndWaitTriangles,
}

impl Method {
    /// Every method, the grid first.
    pub const ALL: [Method; 5] = [
        Method::Grid,
        Method::Frustum,
        Method::StopAndWait,
        Method::TwoPhaseHzb,
        Method::StopAndWaitTriangles,
    ];

    /// A short name for reports and command lines.
    pub fn name(self) -> &'static str {
        match self {
            Method::Grid => "grid",
            Method::Frustum => "frustum",
            Method::StopAndWait => "stop-and-wait",
            Method::TwoPhaseHzb => "two-phase-hzb",
            Method::StopAndWaitTriangles => "stop-and-wait-triangles",
        }
    }
}

/// Runs the simulation of `scene` along its camera path with `backend`: the grid method only.
pub fn simulate(
    scene: &CullScene,
    backend: &mut dyn OcclusionBackend,
    config: &SimConfig,
) -> Result<SimReport, GridError> {
    let mut reports = simulate_methods(scene, backend, config, &[Method::Grid])?;
    Ok(reports.pop().unwrap_or_default())
}

/// The world shared by the methods in one frame: objects in the grid, their current boxes
/// and triangle corners.
struct World<'a> {
    scene: &'a CullScene,
    shape: GridShape,
    grid: Grid,
    boxes: Vec<Aabb>,
    /// Corners of every object's triangles at the current positions, object after object.
    corners: Vec<Vec3>,
    /// Per object, its range in `corners`.
    ranges: Vec<(usize, usize)>,
}

impl World<'_> {
    fn corners_of(&self, o: u32) -> &[Vec3] {
        let (a, b) = self.ranges[o as usize];
        &self.corners[a..b]
    }

    /// The objects of the frustum's cells in traversal order (each once) into `out`, and the
    /// number of non-empty cells.
    fn frustum_objects(&mut self, cells: &[u32], out: &mut Vec<u32>) -> u32 {
        self.grid.begin_pass();
        let mut nonempty = 0;
        for &cell in cells {
            if !self.grid.objects_in(cell).is_empty() {
                nonempty += 1;
                self.grid.collect(cell, out);
            }
        }
        nonempty
    }

    /// The box a cell's query tests: the union of its objects' boxes clipped to the cell
    /// (objects clamped into a border cell from outside keep their own box), or the cell's
    /// box when `tight` is off. Any visible point of an object listed in the cell lies in it.
    fn query_box(&self, cell: u32, tight: bool) -> Aabb {
        let bounds = self.shape.cell_bounds(cell);
        if !tight {
            return bounds;
        }
        let mut q = Aabb::EMPTY;
        for &o in self.grid.objects_in(cell) {
            let b = self.boxes[o as usize];
            let clipped = Aabb::new(b.min.max(bounds.min), b.max.min(bounds.max));
            q = q.union(if clipped.is_empty() { &b } else { &clipped });
        }
        if q.is_empty() {
            bounds
        } else {
            q
        }
    }
}

/// Per-method state kept across frames.
struct MethodState {
    method: Method,
    scheduler: Scheduler,
    traversal: Traversal,
    cells: Vec<u32>,
    collected: Vec<u32>,
    pending: Vec<(u32, bool)>,
    drawn: Vec<u32>,
    /// Objects rendered as occluders this frame, in order (for the retest and the diagnosis).
    prepassed: Vec<u32>,
    /// Corners of the retest's occluders.
    retest_corners: Vec<Vec3>,
    drawn_flag: Vec<bool>,
    streak: Vec<u32>,
    /// Two-phase: objects found visible last frame.
    last_visible: Vec<u32>,
    /// Two-phase: its own software depth buffer and pyramid.
    buffer: OcclusionBuffer,
    hzb: Hzb,
    /// With [`SimConfig::diagnose`], for the methods it applies to.
    diagnosis: Option<Diagnosis>,
    /// Grid method, per object: its object queries ([`SimConfig::object_queries`]).
    objects: ObjectQueries,
    report: SimReport,
}

/// The tag bit of object queries in the grid method; cell queries are tagged by cell index.
const OBJECT_TAG: u32 = 1 << 31;

/// Object query boxes grow by this many of the camera's last steps on every side.
const OBJECT_QUERY_EYE_STEPS: f32 = 2.0;

/// Per-object state of the grid method's object queries: the last answered query of every
/// object and the box it asked about.
#[derive(Default)]
struct ObjectQueries {
    /// Frame the last answered query was issued in (0: never), with bit 63 when it said
    /// visible.
    result: Vec<u64>,
    /// Box of the object's last query.
    queried: Vec<Aabb>,
    /// Box of the object when last queried, for the motion of the next query's box.
    seen: Vec<Aabb>,
    /// Frame of `seen` (0: never).
    seen_at: Vec<u64>,
    /// Whether the last query box lay inside the view: a hidden answer for a box partly
    /// outside may only say that it was off screen, which turning the camera undoes.
    in_view: Vec<bool>,
    /// The eye of the last frame, and how far it moved into this one.
    eye: Option<Vec3>,
    eye_step: f32,
}

impl ObjectQueries {
    const VISIBLE: u64 = 1 << 63;

    fn new(objects: usize) -> Self {
        Self {
            result: vec![0; objects],
            queried: vec![Aabb::EMPTY; objects],
            seen: vec![Aabb::EMPTY; objects],
            seen_at: vec![0; objects],
            in_view: vec![false; objects],
            eye: None,
            eye_step: 0.0,
        }
    }

    /// Records the answer of a query of `o` issued in frame `issued`.
    fn record(&mut self, o: u32, issued: u64, visible: bool) {
        if let Some(r) = self.result.get_mut(o as usize) {
            *r = issued | if visible { Self::VISIBLE } else { 0 };
        }
    }

    /// For an object of a drawn cell in frame `frame`, with box `aabb`: `(draw, query)`.
    /// Hidden only by a hidden answer at most `hidden_for` frames old over a box that still
    /// holds the object; queried when not drawn or without a visible answer younger than
    /// `visible_for` frames.
    fn decide(
        &self,
        o: u32,
        aabb: &Aabb,
        frame: u64,
        hidden_for: u64,
        visible_for: u64,
    ) -> (bool, bool) {
        let o = o as usize;
        let r = self.result[o];
        let issued = r & !Self::VISIBLE;
        if issued == 0 {
            return (true, true);
        }
        if r & Self::VISIBLE != 0 {
            return (true, issued + visible_for.max(1) <= frame);
        }
        let q = &self.queried[o];
        let holds = self.in_view[o] && q.min.cmple(aabb.min).all() && aabb.max.cmple(q.max).all();
        let hidden = holds && issued + hidden_for.max(1) >= frame;
        (!hidden, true)
    }

    /// The box to query for `o`, now at `aabb`: its box, stretched by the motion since its
    /// last query when that was in the previous frame (so that next frame's box is likely
    /// still inside and the answer applies).
    fn query_box(&mut self, o: u32, aabb: &Aabb, frame: u64, camera: &Camera) -> Aabb {
        let o = o as usize;
        // The camera's last step around the box: parallax lets the next eye see past an
        // occluder's edge about as far as the eye moves, so the answer holds for it.
        let margin = Vec3::splat(self.eye_step * OBJECT_QUERY_EYE_STEPS);
        let mut q = Aabb::new(aabb.min - margin, aabb.max + margin);
        if self.seen_at[o] + 1 == frame && !self.seen[o].is_empty() {
            // Two steps ahead and a step around: room for acceleration and turning back.
            let step = aabb.min - self.seen[o].min;
            let pad = step.abs();
            q = q.union(&Aabb::new(aabb.min + 2.0 * step, aabb.max + 2.0 * step));
            q = Aabb::new(q.min - pad, q.max + pad);
        }
        self.queried[o] = q;
        self.in_view[o] = inside_view(&q, camera);
        q
    }

    /// Notes the box of `o` in frame `frame` (every frame it is decided on).
    fn seen(&mut self, o: u32, aabb: &Aabb, frame: u64) {
        self.seen[o as usize] = *aabb;
        self.seen_at[o as usize] = frame;
    }
}

impl MethodState {
    fn cull(
        &mut self,
        w: &mut World,
        camera: &Camera,
        backend: &mut dyn OcclusionBackend,
        config: &SimConfig,
        stats: &mut FrameStats,
    ) {
        self.cells.clear();
        self.traversal
            .visit(&w.shape, camera, config.far, &mut self.cells);
        match self.method {
            Method::Grid => self.cull_grid(w, camera, backend, config, stats),
            Method::Frustum => {
                stats.cells = w.frustum_objects(&self.cells, &mut self.drawn);
            }
            Method::StopAndWait | Method::StopAndWaitTriangles => {
                let triangles = self.method == Method::StopAndWaitTriangles;
                self.collected.clear();
                stats.cells = w.frustum_objects(&self.cells, &mut self.collected);
                // Front to back by the distance from the eye to each box.
                sort_front_to_back(&mut self.collected, &w.boxes, camera.eye);
                backend.begin_frame(camera);
                for &o in &self.collected {
                    stats.queries += 1;
                    let aabb = &w.boxes[o as usize];
                    let answer = if triangles {
                        backend.test_object_now(aabb, w.corners_of(o))
                    } else {
                        None
                    };
                    let visible = answer.unwrap_or_else(|| {
                        backend.query(o, aabb);
                        // Wait for the answer; a backend that cannot answer now draws it.
                        self.pending.clear();
                        backend.take_results(&mut self.pending);
                        self.pending.iter().find(|r| r.0 == o).is_none_or(|r| r.1)
                    });
                    if visible {
                        self.drawn.push(o);
                        self.prepassed.push(o);
                        stats.prepass += 1;
                        backend.draw_depth(w.corners_of(o));
                    }
                }
                self.pending.clear();
            }
            Method::TwoPhaseHzb => {
                self.collected.clear();
                stats.cells = w.frustum_objects(&self.cells, &mut self.collected);
                self.buffer.clear();
                // Phase 1: last frame's visible objects (still in the frustum) into the depth.
                for &o in &self.last_visible {
                    self.drawn_flag[o as usize] = true;
                }
                for &o in &self.collected {
                    if self.drawn_flag[o as usize] {
                        self.drawn.push(o);
                        stats.prepass += 1;
                        self.buffer.render_occluders(w.corners_of(o), camera);
                    }
                }
                for &o in &self.last_visible {
                    self.drawn_flag[o as usize] = false;
                }
                for &o in &self.drawn {
                    self.drawn_flag[o as usize] = true;
                }
                self.hzb.build(&self.buffer);
                // Phase 2: every object in the frustum against the pyramid.
                self.last_visible.clear();
                for &o in &self.collected {
                    stats.queries += 1;
                    if self.hzb.test_box(&w.boxes[o as usize], camera) {
                        self.last_visible.push(o);
                        if !self.drawn_flag[o as usize] {
                            self.drawn.push(o);
                        }
                    }
                }
                for &o in &self.drawn {
                    self.drawn_flag[o as usize] = false;
                }
            }
        }
    }

    fn cull_grid(
        &mut self,
        w: &mut World,
        camera: &Camera,
        backend: &mut dyn OcclusionBackend,
        config: &SimConfig,
        stats: &mut FrameStats,
    ) {
        let scheduler = &mut self.scheduler;
        scheduler.begin_frame();
        let frame_no = scheduler.frame();
        // Object queries have their state only where they are on (see `simulate_views`).
        let object_queries = config.object_tests && !self.objects.result.is_empty();
        let objects = &mut self.objects;
        objects.eye_step = objects.eye.map_or(0.0, |e| e.distance(camera.eye));
        objects.eye = Some(camera.eye);
        record_results(&mut self.pending, scheduler, objects, frame_no - 1);
        backend.begin_frame(camera);
        w.grid.begin_pass();
        for &cell in &self.cells {
            if w.grid.objects_in(cell).is_empty() {
                continue;
            }
            stats.cells += 1;
            if scheduler.should_query(cell) {
                backend.query(cell, &w.query_box(cell, config.tight_query_boxes));
                stats.queries += 1;
                if config.latency == 0 {
                    backend.take_results(&mut self.pending);
                    record_results(&mut self.pending, scheduler, objects, frame_no);
                }
            }
            if !scheduler.is_drawn(cell) {
                continue;
            }
            self.collected.clear();
            w.grid.collect(cell, &mut self.collected);
            if config.sort_cell_objects {
                sort_front_to_back(&mut self.collected, &w.boxes, camera.eye);
            }
            for &o in &self.collected {
                // Objects of a drawn cell against the depth drawn so far this frame (exact
                // for this frame, so it never adds popping), where the backend answers now.
                let mut tested = false;
                if config.object_tests {
                    let aabb = &w.boxes[o as usize];
                    let answer = if config.triangle_tests {
                        backend.test_object_now(aabb, w.corners_of(o))
                    } else {
                        backend.test_now(aabb)
                    };
                    if let Some(vis) = answer {
                        tested = true;
                        stats.object_tests += 1;
                        if !vis {
                            continue;
                        }
                    } else if object_queries && config.latency == 0 {
                        // Results used at once: wait for the object's answer (stop and wait),
                        // exact for this frame like the software test.
                        let tag = OBJECT_TAG | o;
                        backend.query(tag, aabb);
                        stats.object_queries += 1;
                        stats.queries += 1;
                        backend.take_results(&mut self.pending);
                        let vis = self.pending.iter().rev().find(|r| r.0 == tag);
                        let vis = vis.is_none_or(|r| r.1);
                        record_results(&mut self.pending, scheduler, objects, frame_no);
                        if !vis {
                            continue;
                        }
                    } else if object_queries {
                        let (draw, query) = objects.decide(
                            o,
                            aabb,
                            frame_no,
                            scheduler.config().invisible_duration,
                            config.object_visible_duration,
                        );
                        // Within the frame's query cap (cells' queries first); an object
                        // left unqueried has no fresh answer next frame and is drawn then.
                        let room = scheduler.queries_this_frame() + (stats.object_queries as usize)
                            < scheduler.config().query_cap;
                        if query && room {
                            let q = objects.query_box(o, aabb, frame_no, camera);
                            // Before the object's own depth, which would hide its box's back.
                            backend.query(OBJECT_TAG | o, &q);
                            stats.object_queries += 1;
                            stats.queries += 1;
                        }
                        objects.seen(o, aabb, frame_no);
                        if !draw {
                            continue;
                        }
                    }
                }
                self.drawn.push(o);
                let class = w.scene.class[o as usize];
                let cap = scheduler.config().depth_prepass_cap;
                let cap = if tested {
                    cap.max(config.tested_prepass_cap)
                } else {
                    cap
                };
                if scheduler.enters_prepass_capped(class, cap) {
                    self.prepassed.push(o);
                    stats.prepass += 1;
                    backend.draw_depth(w.corners_of(o));
                }
            }
        }
        // Only when the backend answered object tests this frame (it can retest then).
        if config.object_tests && config.retest && stats.object_tests > 0 {
            // The frame's occluders in reverse order into the backend's second buffer.
            self.retest_corners.clear();
            for &o in self.prepassed.iter().rev() {
                self.retest_corners.extend_from_slice(w.corners_of(o));
            }
            backend.begin_retest(&self.retest_corners);
            let mut kept = 0;
            for i in 0..self.drawn.len() {
                let o = self.drawn[i];
                let aabb = &w.boxes[o as usize];
                if backend.retest_now(aabb, w.corners_of(o)) == Some(false) {
                    stats.retest_culled += 1;
                } else {
                    self.drawn[kept] = o;
                    kept += 1;
                }
            }
            self.drawn.truncate(kept);
        }
        backend.take_results(&mut self.pending);
        scheduler.end_frame();
    }
}

/// Whether every corner of `aabb` lies inside the camera's view (beyond the near plane,
/// within the image's edges).
fn inside_view(aabb: &Aabb, camera: &Camera) -> bool {
    let (tx, ty) = (camera.tan_half_x(), camera.tan_half_y());
    (0..8).all(|i| {
        let c = Vec3::new(
            if i & 1 != 0 { aabb.max.x } else { aabb.min.x },
            if i & 2 != 0 { aabb.max.y } else { aabb.min.y },
            if i & 4 != 0 { aabb.max.z } else { aabb.min.z },
        );
        let v = camera.to_view(c);
        v.z >= camera.near && v.x.abs() <= v.z * tx && v.y.abs() <= v.z * ty
    })
}

/// Records query results of the grid method, `(tag, visible)` issued in frame `issued`, with
/// the scheduler (cells) or the object queries ([`OBJECT_TAG`]), and empties `pending`.
fn record_results(
    pending: &mut Vec<(u32, bool)>,
    scheduler: &mut Scheduler,
    objects: &mut ObjectQueries,
    issued: u64,
) {
    for &(tag, vis) in pending.iter() {
        if tag & OBJECT_TAG != 0 && !objects.result.is_empty() {
            objects.record(tag & !OBJECT_TAG, issued, vis);
        } else {
            scheduler.record(tag, issued, vis);
        }
    }
    pending.clear();
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
    let base = &scene.scene;
    let n_obj = base.objects.len();
    let shape = GridShape::with_cell_size(&scene.bounds, scene.cell_size)?;

    // Per object: its triangles and its box at time 0.
    let tris_of = base.triangles_by_object();
    let base_box: Vec<Aabb> = tris_of
        .iter()
        .map(|ts| Aabb::from_points(ts.iter().flat_map(|&t| base.triangle(t))))
        .collect();
    let mut object_of_vertex = vec![u32::MAX; base.positions.len()];
    for (t, tri) in base.triangles.iter().enumerate() {
        for &v in tri {
            if let Some(o) = object_of_vertex.get_mut(v as usize) {
                *o = base.object_of_triangle[t];
            }
        }
    }
    let mut moved: Scene = base.clone();
    let mut offsets = vec![Vec3::ZERO; n_obj];
    let mut world = World {
        scene,
        shape,
        grid: Grid::new(shape),
        boxes: base_box.clone(),
        corners: Vec::new(),
        ranges: vec![(0, 0); n_obj],
    };
    for (o, b) in base_box.iter().enumerate() {
        if !b.is_empty() {
            world.grid.insert(o as u32, *b)?;
        }
    }

    let mut states: Vec<MethodState> = views
        .iter()
        .map(|&(method, _)| MethodState {
            method,
            scheduler: Scheduler::new(shape.cell_count(), config.scheduler),
            traversal: Traversal::new(),
            cells: Vec::new(),
            collected: Vec::new(),
            pending: Vec::new(),
            drawn: Vec::new(),
            prepassed: Vec::new(),
            retest_corners: Vec::new(),
            diagnosis: (config.diagnose
                && config.measure_popping
                && matches!(
                    method,
                    Method::Grid | Method::StopAndWait | Method::StopAndWaitTriangles
                ))
            .then(|| Diagnosis::new(config.width, config.height)),
            // Object tags need cell and object indices below the tag bit.
            objects: if method == Method::Grid
                && config.object_queries
                && shape.cell_count() < OBJECT_TAG as usize
                && n_obj < OBJECT_TAG as usize
            {
                ObjectQueries::new(n_obj)
            } else {
                ObjectQueries::default()
            },
            drawn_flag: vec![false; n_obj],
            streak: vec![0; n_obj],
            last_visible: Vec::new(),
            buffer: OcclusionBuffer::new(config.width, config.height),
            hzb: Hzb::new(),
            report: SimReport {
                method,
                pixels: config.width * config.height,
                objects: n_obj as u32,
                streaks: vec![0; 2],
                // Methods that wait for no earlier frame have nothing to warm up.
                warmup: if method == Method::Grid {
                    config.latency
                } else {
                    0
                },
                ..SimReport::default()
            },
        })
        .collect();
    let mut frustum_cells = Vec::new();
    let mut frustum_objs = Vec::new();
    let mut frustum_traversal = Traversal::new();
    let mut frame_img = Frame::new(config.width, config.height);
    let mut visible = vec![false; n_obj];

    for f in 0..config.frames {
        let t = f as f32 / config.fps;
        let Some(frame_cameras) = cameras
            .iter()
            .map(|c| c(f))
            .collect::<Option<Vec<Camera>>>()
        else {
            continue;
        };
        // Move objects (vertices, boxes and grid entries), then gather their corners: the
        // application's data, outside the timed culling.
        for (o, m) in scene.motion.iter().enumerate() {
            if let Some(m) = m {
                offsets[o] = m.offset(t);
                if !base_box[o].is_empty() {
                    let b = Aabb::new(base_box[o].min + offsets[o], base_box[o].max + offsets[o]);
                    world.boxes[o] = b;
                    world.grid.insert(o as u32, b)?;
                }
            }
        }
        for (v, p) in moved.positions.iter_mut().enumerate() {
            let o = object_of_vertex[v];
            if let Some(off) = offsets.get(o as usize) {
                *p = base.positions[v] + *off;
            }
        }
        world.corners.clear();
        for (o, tris) in tris_of.iter().enumerate() {
            let a = world.corners.len();
            for &tri in tris {
                world.corners.extend_from_slice(&moved.triangle(tri));
            }
            world.ranges[o] = (a, world.corners.len());
        }
        let mut frame_stats = Vec::with_capacity(states.len());
        for (st, &(_, view)) in states.iter_mut().zip(views) {
            let camera = &frame_cameras[view];
            frustum_cells.clear();
            frustum_traversal.visit(&shape, camera, config.far, &mut frustum_cells);
            frustum_objs.clear();
            world.frustum_objects(&frustum_cells, &mut frustum_objs);
            st.drawn.clear();
            st.prepassed.clear();
            let mut stats = FrameStats::default();
            let start = Instant::now();
            st.cull(&mut world, camera, backend, config, &mut stats);
            stats.cull_ms = start.elapsed().as_secs_f64() * 1e3;
            stats.drawn = st.drawn.len() as u32;
            stats.frustum = frustum_objs.len() as u32;
            frame_stats.push(stats);
        }

        // --- Ground truth and popping, once per viewport for every method ---
        for (view, camera) in frame_cameras.iter().enumerate() {
            if !config.measure_popping {
                break;
            }
            Rasterizer::new(&moved).render(camera, None, &mut frame_img);
            visible.fill(false);
            let ids: Vec<usize> = frame_img
                .ids
                .iter()
                .filter(|&&id| id != Hit::NONE)
                .map(|&id| moved.object_of_triangle[id as usize] as usize)
                .collect();
            for &o in &ids {
                visible[o] = true;
            }
            let exact = visible.iter().filter(|&&v| v).count() as u32;
            let of_view = states.iter_mut().zip(&mut frame_stats).zip(views);
            for ((st, stats), _) in of_view.filter(|(_, &(_, v))| v == view) {
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
                        || (st.method == Method::Grid
                            && config.object_tests
                            && config.triangle_tests);
                    stats.extra = diagnosis.classify(
                        camera,
                        &objects,
                        &st.drawn,
                        &st.prepassed,
                        &visible,
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
        }
        for (st, stats) in states.iter_mut().zip(frame_stats) {
            st.report.frames.push(stats);
        }
    }
    Ok(states
        .into_iter()
        .map(|mut st| {
            for &s in st.streak.iter().filter(|&&s| s > 0) {
                bump(&mut st.report.streaks, s);
            }
            st.report
        })
        .collect())
}

fn bump(hist: &mut Vec<u32>, k: u32) {
    let k = k as usize;
    if hist.len() <= k {
        hist.resize(k + 1, 0);
    }
    hist[k] += 1;
}
