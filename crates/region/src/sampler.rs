//! The interface every from-region sampler implements (RAND, GVS, GVS++, RASTER), the budget
//! that stops it, and what it reports.

use std::time::{Duration, Instant};

use glam::Vec3;

use serde::Serialize;
use sightline_core::atomic_set::AtomicTriangleSet;
use sightline_core::trace::RayCaster;
use sightline_core::{Scene, TriangleSet};

use crate::viewcell::ViewCell;

/// Everything a sampler needs for one view cell.
pub struct CellContext<'a> {
    /// The scene (validated: indices in range, finite coordinates).
    pub scene: &'a Scene,
    /// Ray caster over `scene`.
    pub caster: &'a dyn RayCaster,
    /// The view cell.
    pub cell: &'a ViewCell,
    /// Seed of every random choice.
    pub seed: u64,
    /// The empty-space part of the cell, when the cell's box also covers solid space (e.g. a
    /// Quake 3 leaf's bounding box around a slanted leaf): ray origins and viewpoints for
    /// which it returns false are skipped. `None`: the whole cell.
    pub free_space: Option<&'a (dyn Fn(Vec3) -> bool + Sync)>,
}

impl CellContext<'_> {
    /// True when `p` may serve as a ray origin (see [`CellContext::free_space`]).
    pub fn origin_allowed(&self, p: Vec3) -> bool {
        self.free_space.is_none_or(|f| f(p))
    }
}

/// When a sampler stops. With neither limit set, samplers with their own termination rule
/// (GVS, GVS++) run until it holds; the others use their default ray count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Budget {
    /// Stop after about this many rays (a running batch completes).
    pub max_rays: Option<u64>,
    /// Stop after about this much time (a running batch completes).
    pub max_time: Option<Duration>,
}

impl Budget {
    /// A budget of `n` rays.
    pub fn rays(n: u64) -> Self {
        Self {
            max_rays: Some(n),
            max_time: None,
        }
    }

    /// True when no limit is set.
    pub fn is_unlimited(&self) -> bool {
        self.max_rays.is_none() && self.max_time.is_none()
    }
}

/// One point of a convergence curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ConvergencePoint {
    /// Rays cast so far.
    pub rays: u64,
    /// Seconds so far.
    pub seconds: f64,
    /// PVS size so far.
    pub pvs_size: usize,
}

/// What a sampler found for one cell.
#[derive(Clone, Debug, PartialEq)]
pub struct CellResult {
    /// The PVS.
    pub visible: TriangleSet,
    /// Rays cast.
    pub rays: u64,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// PVS size after each batch.
    pub convergence: Vec<ConvergencePoint>,
    /// Triangles first found by each strategy (e.g. "random", "abs", "rs").
    pub found_by: Vec<(&'static str, usize)>,
    /// For samplers with a termination rule (GVS, GVS++): whether the cell converged, i.e. the
    /// rule held (or the cell had nothing left to sample) before the budget ran out. `false`
    /// means the budget stopped it first, so its PVS may still miss triangles. `None` for
    /// samplers without such a rule (RAND, RASTER).
    pub converged: Option<bool>,
}

/// A from-region visibility sampler.
pub trait Sampler: Send + Sync {
    /// Short name (`rand`, `gvs`, `gvs++`, `raster`).
    fn name(&self) -> &'static str;

    /// Computes the PVS of `ctx.cell` within `budget`. `progress` is called after every batch
    /// with the running totals.
    fn sample(
        &self,
        ctx: &CellContext<'_>,
        budget: &Budget,
        progress: &(dyn Fn(&ConvergencePoint) + Sync),
    ) -> CellResult;
}

/// Bookkeeping shared by the samplers: the concurrent PVS, ray and time counters, the
/// convergence curve and the budget check.
pub(crate) struct Tally {
    pub pvs: AtomicTriangleSet,
    pub rays: u64,
    start: Instant,
    budget: Budget,
    pub convergence: Vec<ConvergencePoint>,
}

impl Tally {
    pub fn new(triangles: usize, budget: Budget) -> Self {
        Self {
            pvs: AtomicTriangleSet::new(triangles),
            rays: 0,
            start: Instant::now(),
            budget,
            convergence: Vec::new(),
        }
    }

    /// Records a finished batch of `rays` rays and reports progress.
    pub fn batch_done(&mut self, rays: usize, progress: &(dyn Fn(&ConvergencePoint) + Sync)) {
        self.rays += rays as u64;
        let point = ConvergencePoint {
            rays: self.rays,
            seconds: self.start.elapsed().as_secs_f64(),
            pvs_size: self.pvs.count(),
        };
        self.convergence.push(point);
        progress(&point);
    }

    /// Rays still allowed (`u64::MAX` without a ray limit).
    pub fn rays_left(&self) -> u64 {
        self.budget
            .max_rays
            .map_or(u64::MAX, |m| m.saturating_sub(self.rays))
    }

    /// True without a ray or time limit.
    pub fn budget_unlimited(&self) -> bool {
        self.budget.is_unlimited()
    }

    /// True when the budget is used up.
    pub fn exhausted(&self) -> bool {
        self.rays_left() == 0
            || self
                .budget
                .max_time
                .is_some_and(|t| self.start.elapsed() >= t)
    }

    /// The result of a sampler without a termination rule.
    pub fn finish(self, found_by: Vec<(&'static str, usize)>) -> CellResult {
        CellResult {
            visible: self.pvs.to_set(),
            rays: self.rays,
            seconds: self.start.elapsed().as_secs_f64(),
            convergence: self.convergence,
            found_by,
            converged: None,
        }
    }

    /// The result of a sampler with a termination rule that held at some point (`rule_held`):
    /// the cell converged when the rule held or when it stopped for another reason than the
    /// budget (no free space for origins).
    pub fn finish_guided(
        self,
        found_by: Vec<(&'static str, usize)>,
        rule_held: bool,
    ) -> CellResult {
        let converged = rule_held || !self.exhausted();
        CellResult {
            converged: Some(converged),
            ..self.finish(found_by)
        }
    }
}
