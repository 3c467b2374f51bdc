//! The settings and results of a culling simulation run: [`SimConfig`], the per-frame
//! [`FrameStats`], the per-method [`SimReport`] and the [`Method`]s compared (Seletsky 2013,
//! section 5.3, the metrics; popping counted here, see `simulate.rs`). A leaf: the loop and
//! the per-method state take these types from here.

use serde::Serialize;

use crate::diagnose::ExtraCauses;
use crate::scheduler::SchedulerConfig;

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
    /// ([`crate::OcclusionBackend::test_object_now`]; the box of a box-shaped object still projects
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
    /// occluders once more in reverse order ([`OcclusionBackend::begin_retest`](crate::OcclusionBackend::begin_retest)), test the
    /// drawn objects against them ([`crate::OcclusionBackend::retest_now`], where the backend
    /// answers at once) and drop the hidden ones; they stay in the depth as the real
    /// occluders they are.
    pub retest: bool,
    /// Grid method with `object_tests`, for objects whose test the backend cannot answer at
    /// once (hardware queries, [`crate::OcclusionBackend::test_object_now`] returns `None`): the
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
    /// the box, then the triangles ([`OcclusionBackend::test_object_now`](crate::OcclusionBackend::test_object_now)); box queries
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
