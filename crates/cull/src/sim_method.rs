//! One culling method's state across the frames of a simulation, and its per-frame culling:
//! the grid method (traversal, query scheduler, object queries read a frame later; Seletsky
//! 2013, sections 4.3.2-4.3.5) and the baselines (frustum, stop-and-wait, two-phase HZB).

use glam::Vec3;
use sightline_core::{Aabb, Camera};

use crate::backend::OcclusionBackend;
use crate::diagnose::Diagnosis;
use crate::front_to_back::sort_front_to_back;
use crate::grid::GridShape;
use crate::hzb::Hzb;
use crate::masked_occlusion::OcclusionBuffer;
use crate::scheduler::Scheduler;
use crate::sim_types::{FrameStats, Method, SimConfig, SimReport};
use crate::sim_world::World;
use crate::traversal::Traversal;

/// Per-method state kept across frames.
pub(crate) struct MethodState {
    pub(crate) method: Method,
    pub(crate) scheduler: Scheduler,
    pub(crate) traversal: Traversal,
    pub(crate) cells: Vec<u32>,
    pub(crate) collected: Vec<u32>,
    pub(crate) pending: Vec<(u32, bool)>,
    pub(crate) drawn: Vec<u32>,
    /// Objects rendered as occluders this frame, in order (for the retest and the diagnosis).
    pub(crate) prepassed: Vec<u32>,
    /// Corners of the retest's occluders.
    pub(crate) retest_corners: Vec<Vec3>,
    pub(crate) drawn_flag: Vec<bool>,
    pub(crate) streak: Vec<u32>,
    /// Two-phase: objects found visible last frame.
    pub(crate) last_visible: Vec<u32>,
    /// Two-phase: its own software depth buffer and pyramid.
    pub(crate) buffer: OcclusionBuffer,
    pub(crate) hzb: Hzb,
    /// With [`SimConfig::diagnose`], for the methods it applies to.
    pub(crate) diagnosis: Option<Diagnosis>,
    /// Grid method, per object: its object queries ([`SimConfig::object_queries`]).
    pub(crate) objects: ObjectQueries,
    pub(crate) report: SimReport,
}

impl MethodState {
    /// The state of `method` before the first frame: empty queues and sets, a report with
    /// the run's sizes, object queries only where the tag bit leaves room for the indices.
    pub(crate) fn new(method: Method, shape: GridShape, n_obj: usize, config: &SimConfig) -> Self {
        MethodState {
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
        }
    }
}

/// The tag bit of object queries in the grid method; cell queries are tagged by cell index.
pub(crate) const OBJECT_TAG: u32 = 1 << 31;

/// Object query boxes grow by this many of the camera's last steps on every side.
pub(crate) const OBJECT_QUERY_EYE_STEPS: f32 = 2.0;

/// Per-object state of the grid method's object queries: the last answered query of every
/// object and the box it asked about.
#[derive(Default)]
pub(crate) struct ObjectQueries {
    /// Frame the last answered query was issued in (0: never), with bit 63 when it said
    /// visible.
    pub(crate) result: Vec<u64>,
    /// Box of the object's last query.
    pub(crate) queried: Vec<Aabb>,
    /// Box of the object when last queried, for the motion of the next query's box.
    pub(crate) seen: Vec<Aabb>,
    /// Frame of `seen` (0: never).
    pub(crate) seen_at: Vec<u64>,
    /// Whether the last query box lay inside the view: a hidden answer for a box partly
    /// outside may only say that it was off screen, which turning the camera undoes.
    pub(crate) in_view: Vec<bool>,
    /// The eye of the last frame, and how far it moved into this one.
    pub(crate) eye: Option<Vec3>,
    pub(crate) eye_step: f32,
}

impl ObjectQueries {
    const VISIBLE: u64 = 1 << 63;

    pub(crate) fn new(objects: usize) -> Self {
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
    pub(crate) fn record(&mut self, o: u32, issued: u64, visible: bool) {
        if let Some(r) = self.result.get_mut(o as usize) {
            *r = issued | if visible { Self::VISIBLE } else { 0 };
        }
    }

    /// For an object of a drawn cell in frame `frame`, with box `aabb`: `(draw, query)`.
    /// Hidden only by a hidden answer at most `hidden_for` frames old over a box that still
    /// holds the object; queried when not drawn or without a visible answer younger than
    /// `visible_for` frames.
    pub(crate) fn decide(
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
    pub(crate) fn query_box(&mut self, o: u32, aabb: &Aabb, frame: u64, camera: &Camera) -> Aabb {
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
    pub(crate) fn seen(&mut self, o: u32, aabb: &Aabb, frame: u64) {
        self.seen[o as usize] = *aabb;
        self.seen_at[o as usize] = frame;
    }
}

impl MethodState {
    pub(crate) fn cull(
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

    /// One frame of the grid method: answers of earlier queries recorded, then every cell of
    /// the traversal in order ([`MethodState::grid_cell`]), then the retest of the drawn
    /// objects where the backend answered object tests, then the frame's last answers taken.
    pub(crate) fn cull_grid(
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
        let mut frame = GridFrame {
            w,
            camera,
            backend,
            config,
            stats,
            frame_no,
            object_queries,
        };
        for i in 0..self.cells.len() {
            self.grid_cell(&mut frame, self.cells[i]);
        }
        // Only when the backend answered object tests this frame (it can retest then).
        if config.object_tests && config.retest && frame.stats.object_tests > 0 {
            self.retest_drawn(&mut frame);
        }
        frame.backend.take_results(&mut self.pending);
        self.scheduler.end_frame();
    }

    /// The grid method on one traversed cell: skipped when empty; queried when the
    /// scheduler says so (its answer read at once without latency); when the scheduler draws
    /// it, its objects (front to back if configured) decided on and drawn.
    fn grid_cell(&mut self, fr: &mut GridFrame<'_, '_>, cell: u32) {
        if fr.w.grid.objects_in(cell).is_empty() {
            return;
        }
        fr.stats.cells += 1;
        if self.scheduler.should_query(cell) {
            fr.backend
                .query(cell, &fr.w.query_box(cell, fr.config.tight_query_boxes));
            fr.stats.queries += 1;
            if fr.config.latency == 0 {
                fr.backend.take_results(&mut self.pending);
                record_results(
                    &mut self.pending,
                    &mut self.scheduler,
                    &mut self.objects,
                    fr.frame_no,
                );
            }
        }
        if !self.scheduler.is_drawn(cell) {
            return;
        }
        self.collected.clear();
        fr.w.grid.collect(cell, &mut self.collected);
        if fr.config.sort_cell_objects {
            sort_front_to_back(&mut self.collected, &fr.w.boxes, fr.camera.eye);
        }
        for i in 0..self.collected.len() {
            let o = self.collected[i];
            if let Verdict::Draw { tested } = self.object_verdict(fr, o) {
                self.draw_object(fr, o, tested);
            }
        }
    }

    /// Whether object `o` of a drawn cell is drawn. Without object tests, always. Otherwise
    /// against the depth drawn so far this frame where the backend answers now (exact for
    /// this frame, so it never adds popping); else by an object query of its own, waited for
    /// without latency, or else read a frame later.
    fn object_verdict(&mut self, fr: &mut GridFrame<'_, '_>, o: u32) -> Verdict {
        if !fr.config.object_tests {
            return Verdict::Draw { tested: false };
        }
        let aabb = &fr.w.boxes[o as usize];
        let answer = if fr.config.triangle_tests {
            fr.backend.test_object_now(aabb, fr.w.corners_of(o))
        } else {
            fr.backend.test_now(aabb)
        };
        if let Some(vis) = answer {
            fr.stats.object_tests += 1;
            return if vis {
                Verdict::Draw { tested: true }
            } else {
                Verdict::Hidden
            };
        }
        let draw = if fr.object_queries && fr.config.latency == 0 {
            self.wait_for_object_query(fr, o)
        } else if fr.object_queries {
            self.defer_object_query(fr, o)
        } else {
            true
        };
        if draw {
            Verdict::Draw { tested: false }
        } else {
            Verdict::Hidden
        }
    }

    /// Results used at once: queries object `o` and waits for its answer (stop and wait),
    /// exact for this frame like the software test. Returns whether it is visible (a
    /// backend that gives no answer draws it).
    fn wait_for_object_query(&mut self, fr: &mut GridFrame<'_, '_>, o: u32) -> bool {
        let tag = OBJECT_TAG | o;
        fr.backend.query(tag, &fr.w.boxes[o as usize]);
        fr.stats.object_queries += 1;
        fr.stats.queries += 1;
        fr.backend.take_results(&mut self.pending);
        let vis = self.pending.iter().rev().find(|r| r.0 == tag);
        let vis = vis.is_none_or(|r| r.1);
        record_results(
            &mut self.pending,
            &mut self.scheduler,
            &mut self.objects,
            fr.frame_no,
        );
        vis
    }

    /// Results read a frame later: decides object `o` by its last answer and queries it
    /// again when due and within the frame's query cap. Returns whether it is drawn.
    fn defer_object_query(&mut self, fr: &mut GridFrame<'_, '_>, o: u32) -> bool {
        let aabb = &fr.w.boxes[o as usize];
        let (draw, query) = self.objects.decide(
            o,
            aabb,
            fr.frame_no,
            self.scheduler.config().invisible_duration,
            fr.config.object_visible_duration,
        );
        // Within the frame's query cap (cells' queries first); an object left unqueried has
        // no fresh answer next frame and is drawn then.
        let room = self.scheduler.queries_this_frame() + (fr.stats.object_queries as usize)
            < self.scheduler.config().query_cap;
        if query && room {
            let q = self.objects.query_box(o, aabb, fr.frame_no, fr.camera);
            // Before the object's own depth, which would hide its box's back.
            fr.backend.query(OBJECT_TAG | o, &q);
            fr.stats.object_queries += 1;
            fr.stats.queries += 1;
        }
        self.objects.seen(o, aabb, fr.frame_no);
        draw
    }

    /// Draws object `o`, and renders it as an occluder when its depth class is within the
    /// pre-pass cap (the larger cap for objects the backend tested this frame).
    fn draw_object(&mut self, fr: &mut GridFrame<'_, '_>, o: u32, tested: bool) {
        self.drawn.push(o);
        let class = fr.w.scene.class[o as usize];
        let cap = self.scheduler.config().depth_prepass_cap;
        let cap = if tested {
            cap.max(fr.config.tested_prepass_cap)
        } else {
            cap
        };
        if self.scheduler.enters_prepass_capped(class, cap) {
            self.prepassed.push(o);
            fr.stats.prepass += 1;
            fr.backend.draw_depth(fr.w.corners_of(o));
        }
    }

    /// Retests the drawn objects against the frame's occluders in reverse order (the
    /// backend's second buffer), dropping those it finds hidden.
    fn retest_drawn(&mut self, fr: &mut GridFrame<'_, '_>) {
        self.retest_corners.clear();
        for &o in self.prepassed.iter().rev() {
            self.retest_corners.extend_from_slice(fr.w.corners_of(o));
        }
        fr.backend.begin_retest(&self.retest_corners);
        let mut kept = 0;
        for i in 0..self.drawn.len() {
            let o = self.drawn[i];
            let aabb = &fr.w.boxes[o as usize];
            if fr.backend.retest_now(aabb, fr.w.corners_of(o)) == Some(false) {
                fr.stats.retest_culled += 1;
            } else {
                self.drawn[kept] = o;
                kept += 1;
            }
        }
        self.drawn.truncate(kept);
    }
}

/// One frame of the grid method: what its steps share, so that they take one argument.
struct GridFrame<'f, 'w> {
    w: &'f mut World<'w>,
    camera: &'f Camera,
    backend: &'f mut dyn OcclusionBackend,
    config: &'f SimConfig,
    stats: &'f mut FrameStats,
    /// The scheduler's number of this frame.
    frame_no: u64,
    /// Whether objects of drawn cells get queries of their own
    /// ([`SimConfig::object_queries`], with their state allocated).
    object_queries: bool,
}

/// The grid method's decision on an object of a drawn cell.
enum Verdict {
    /// Culled this frame.
    Hidden,
    /// Drawn; `tested` when the backend tested it against this frame's depth.
    Draw { tested: bool },
}

/// Whether every corner of `aabb` lies inside the camera's view (beyond the near plane,
/// within the image's edges).
pub(crate) fn inside_view(aabb: &Aabb, camera: &Camera) -> bool {
    let (tx, ty) = (camera.tan_half_x(), camera.tan_half_y());
    aabb.corners().into_iter().all(|c| {
        let v = camera.to_view(c);
        v.z >= camera.near && v.x.abs() <= v.z * tx && v.y.abs() <= v.z * ty
    })
}

/// Records query results of the grid method, `(tag, visible)` issued in frame `issued`, with
/// the scheduler (cells) or the object queries ([`OBJECT_TAG`]), and empties `pending`.
pub(crate) fn record_results(
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
