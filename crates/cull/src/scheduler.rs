//! Occlusion-query scheduling per grid cell: which traversed cells get a query this frame, which
//! are drawn, and which of the drawn objects go to the depth pre-pass.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, sections 4.3.2 (results used a frame later, per-cell 64-bit state, the
//! always/sometimes/never depth pre-pass classes with a cap on "sometimes"), 4.3.4 (a per-frame
//! query cap; visible results last ~30 frames, invisible ones 1-2), 4.3.5 (durations grow with
//! the number of consecutive frames that hit the cap, plus a random jitter against starvation;
//! visible cells are re-queried even over the cap, so they never blink).
//!
//! # Timing, pinned
//! A result of a query issued in frame `q` with duration `d` is valid for frames `q .. q + d`:
//! the cell is queried again in frame `q + d` (when the cap allows). With `invisible_duration
//! = 1` an invisible cell is queried every frame. A cell is drawn while its last result says
//! visible (an expired visible result still draws until a newer result says otherwise, as in
//! the thesis' pseudocode, where the visible bit makes the stored value compare as valid).
//! Durations: `d = duration + growth * overflowed + jitter`, `jitter` uniform in
//! `0..=jitter_per_overflow * overflowed`, where `overflowed` counts the consecutive frames
//! (up to the one the result is recorded in) that hit the query cap.

use serde::Serialize;
use sightline_core::random::SplitMix64;

/// Whether an object is rendered in the depth pre-pass when its cell is drawn (section 4.3.2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum DepthClass {
    /// Walls, floors, terrain: what keeps the world watertight.
    #[default]
    Always,
    /// Large detail objects (crates, columns, vehicles): while the frame's pre-pass budget lasts.
    Sometimes,
    /// Small detail objects: never worth their cost as occluders.
    Never,
}

/// The numbers of the scheduler; defaults are the thesis' recommended ones.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SchedulerConfig {
    /// At most this many queries per frame, except re-queries of visible cells (3000-4000 in the
    /// thesis' conclusions).
    pub query_cap: usize,
    /// Frames a visible result lasts (about 30).
    pub visible_duration: u64,
    /// Extra frames of a visible result per consecutive frame over the cap.
    pub visible_growth: u64,
    /// Frames an invisible result lasts (1-2, so hidden cells reappear quickly).
    pub invisible_duration: u64,
    /// Extra frames of an invisible result per consecutive frame over the cap (below
    /// `visible_growth`, to keep popping low).
    pub invisible_growth: u64,
    /// The random extension is uniform in `0..=jitter_per_overflow * overflowed` frames.
    pub jitter_per_overflow: u64,
    /// Depth pre-pass budget per frame: a `Sometimes` object is rendered only while fewer
    /// objects than this have entered the pre-pass (75 in Space Marine, quoted by the thesis).
    pub depth_prepass_cap: usize,
    /// Seed of the jitter.
    pub seed: u64,
}

impl Default for SchedulerConfig {
    fn default() -> Self {
        Self {
            query_cap: 4000,
            visible_duration: 30,
            visible_growth: 8,
            invisible_duration: 1,
            invisible_growth: 1,
            jitter_per_overflow: 2,
            depth_prepass_cap: 75,
            seed: 0x5e1e_75c4,
        }
    }
}

/// Bit 63 of a cell's state: the last result said visible; bits 0..63: first frame the result
/// is no longer valid (the thesis' Figure 4.21 layout).
const VISIBLE_BIT: u64 = 1 << 63;
const FRAME_MASK: u64 = VISIBLE_BIT - 1;

/// Per-viewport query state of every grid cell. Several viewports sharing one grid each own a
/// scheduler (section 4.4).
#[derive(Clone, Debug)]
pub struct Scheduler {
    config: SchedulerConfig,
    state: Vec<u64>,
    frame: u64,
    overflowed: u64,
    overflow_recorded: bool,
    queries: usize,
    prepass: usize,
    rng: SplitMix64,
}

impl Scheduler {
    /// A scheduler for `cells` cells; every cell starts invisible and due for a query.
    pub fn new(cells: usize, config: SchedulerConfig) -> Self {
        Self {
            config,
            state: vec![0; cells],
            frame: 0,
            overflowed: 0,
            overflow_recorded: false,
            queries: 0,
            prepass: 0,
            rng: SplitMix64::new(config.seed),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SchedulerConfig {
        &self.config
    }

    /// The current frame number (0 before the first [`Scheduler::begin_frame`]).
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// Consecutive frames that hit the query cap so far.
    pub fn overflowed_frames(&self) -> u64 {
        self.overflowed
    }

    /// Queries issued in the current frame.
    pub fn queries_this_frame(&self) -> usize {
        self.queries
    }

    /// Starts the next frame. Results of the previous frame's queries should be recorded with
    /// [`Scheduler::record`] right after this (the thesis reads them before traversing).
    pub fn begin_frame(&mut self) {
        self.frame += 1;
        self.queries = 0;
        self.prepass = 0;
        self.overflow_recorded = false;
    }

    /// Ends the frame: a frame that stayed under the cap resets the overflow count.
    pub fn end_frame(&mut self) {
        if self.queries < self.config.query_cap {
            self.overflowed = 0;
        }
    }

    /// Called for each non-empty traversed cell in traversal order: true when the cell should
    /// be queried now. Cells out of range are never queried.
    pub fn should_query(&mut self, cell: u32) -> bool {
        let Some(&s) = self.state.get(cell as usize) else {
            return false;
        };
        if s & FRAME_MASK > self.frame {
            return false;
        }
        let visible = s & VISIBLE_BIT != 0;
        if self.queries >= self.config.query_cap {
            if !self.overflow_recorded {
                self.overflowed += 1;
                self.overflow_recorded = true;
            }
            if !visible {
                return false;
            }
        }
        self.queries += 1;
        true
    }

    /// Records the result of a query of `cell` issued in frame `issued`.
    pub fn record(&mut self, cell: u32, issued: u64, visible: bool) {
        let c = &self.config;
        let (base, growth) = if visible {
            (c.visible_duration, c.visible_growth)
        } else {
            (c.invisible_duration, c.invisible_growth)
        };
        let n = self.overflowed;
        let jitter = match c.jitter_per_overflow.saturating_mul(n) {
            0 => 0,
            span => self.rng.below(span + 1),
        };
        let until = issued
            .saturating_add(base.max(1))
            .saturating_add(growth.saturating_mul(n))
            .saturating_add(jitter)
            .min(FRAME_MASK);
        if let Some(s) = self.state.get_mut(cell as usize) {
            *s = until | if visible { VISIBLE_BIT } else { 0 };
        }
    }

    /// True when the cell's objects are drawn this frame (its last result said visible).
    pub fn is_drawn(&self, cell: u32) -> bool {
        self.state
            .get(cell as usize)
            .is_some_and(|s| s & VISIBLE_BIT != 0)
    }

    /// The first frame in which the cell is due for a new query.
    pub fn due_frame(&self, cell: u32) -> Option<u64> {
        self.state.get(cell as usize).map(|s| s & FRAME_MASK)
    }

    /// For an object of a drawn cell: true when it goes to the depth pre-pass.
    pub fn enters_prepass(&mut self, class: DepthClass) -> bool {
        self.enters_prepass_capped(class, self.config.depth_prepass_cap)
    }

    /// As [`Scheduler::enters_prepass`] with `cap` in place of the configured cap (for
    /// objects the caller found visible itself, whose rendering it judges cheaper).
    pub fn enters_prepass_capped(&mut self, class: DepthClass, cap: usize) -> bool {
        let take = match class {
            DepthClass::Always => true,
            DepthClass::Sometimes => self.prepass < cap,
            DepthClass::Never => false,
        };
        self.prepass += usize::from(take);
        take
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> SchedulerConfig {
        SchedulerConfig {
            query_cap: 3,
            visible_duration: 30,
            visible_growth: 8,
            invisible_duration: 2,
            invisible_growth: 1,
            jitter_per_overflow: 0,
            depth_prepass_cap: 2,
            seed: 1,
        }
    }

    #[test]
    fn empty_scheduler_queries_nothing() {
        let mut s = Scheduler::new(0, config());
        s.begin_frame();
        assert!(!s.should_query(0));
        assert!(!s.is_drawn(0));
        s.end_frame();
    }

    #[test]
    fn new_cells_are_queried_and_not_drawn() {
        let mut s = Scheduler::new(4, config());
        s.begin_frame();
        assert!(s.should_query(2));
        assert!(!s.is_drawn(2));
    }

    #[test]
    fn visible_result_lasts_its_duration() {
        let mut s = Scheduler::new(1, config());
        s.begin_frame();
        assert!(s.should_query(0));
        s.end_frame();
        s.begin_frame();
        s.record(0, 1, true);
        assert_eq!(s.due_frame(0), Some(31));
        for _ in 2..31 {
            assert!(!s.should_query(0));
            assert!(s.is_drawn(0));
            s.end_frame();
            s.begin_frame();
        }
        assert_eq!(s.frame(), 31);
        assert!(s.should_query(0));
    }

    #[test]
    fn prepass_classes() {
        let mut s = Scheduler::new(1, config());
        s.begin_frame();
        assert!(!s.enters_prepass(DepthClass::Never));
        assert!(s.enters_prepass(DepthClass::Sometimes));
        assert!(s.enters_prepass(DepthClass::Always));
        assert!(!s.enters_prepass(DepthClass::Sometimes));
        assert!(s.enters_prepass(DepthClass::Always));
        s.begin_frame();
        assert!(s.enters_prepass(DepthClass::Sometimes));
    }

    #[test]
    fn prepass_with_a_larger_cap_takes_more_sometimes_objects() {
        let mut s = Scheduler::new(1, config());
        s.begin_frame();
        assert!(s.enters_prepass(DepthClass::Sometimes));
        assert!(s.enters_prepass(DepthClass::Sometimes));
        assert!(!s.enters_prepass(DepthClass::Sometimes));
        assert!(s.enters_prepass_capped(DepthClass::Sometimes, 4));
        assert!(s.enters_prepass_capped(DepthClass::Sometimes, 4));
        assert!(!s.enters_prepass_capped(DepthClass::Sometimes, 4));
        assert!(!s.enters_prepass_capped(DepthClass::Never, 100));
    }
}
