//! The simulation loop: a camera path through a scene with moving objects, culled per frame by
//! the grid traversal, the query scheduler and an occlusion backend, and measured against the
//! exact image: objects drawn, queries, cells, culling time and popping.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, sections 4.3.2-4.3.5 (the per-frame loop) and 5.3 (metrics; the thesis judged
//! popping by eye, here it is counted).
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
use sightline_core::{Aabb, Hit, Scene};

use crate::backend::OcclusionBackend;
use crate::grid::{Grid, GridError, GridShape};
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
    /// Queries issued.
    pub queries: u32,
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
}

/// The whole run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SimReport {
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
            "frames {} objects {} | drawn {:.0} exact-visible {:.0} frustum {:.0} | queries {:.0} \
             cells {:.0} prepass {:.0} | cull {:.2} ms (max {:.2}) | popping {:.4} % (max {:.3} %), \
             missing {:.2} objects/frame, longest streak {} frames, streaks {:?}",
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

/// Runs the simulation of `scene` along its camera path with `backend`.
pub fn simulate(
    scene: &CullScene,
    backend: &mut dyn OcclusionBackend,
    config: &SimConfig,
) -> Result<SimReport, GridError> {
    let base = &scene.scene;
    let n_obj = base.objects.len();
    let shape = GridShape::with_cell_size(&scene.bounds, scene.cell_size)?;
    let mut grid = Grid::new(shape);
    let mut scheduler = Scheduler::new(shape.cell_count(), config.scheduler);
    let mut traversal = Traversal::new();

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
    for (o, b) in base_box.iter().enumerate() {
        if !b.is_empty() {
            grid.insert(o as u32, *b)?;
        }
    }

    let mut report = SimReport {
        pixels: config.width * config.height,
        objects: n_obj as u32,
        streaks: vec![0; 2],
        warmup: config.latency,
        ..SimReport::default()
    };
    let mut cells = Vec::new();
    let mut collected = Vec::new();
    let mut drawn_flag = vec![false; n_obj];
    let mut drawn_list = Vec::new();
    let mut corners = Vec::new();
    let mut pending: Vec<(u32, bool)> = Vec::new();
    let mut streak = vec![0u32; n_obj];
    let mut frame_img = Frame::new(config.width, config.height);

    for f in 0..config.frames {
        let t = f as f32 / config.fps;
        let Some(camera) = scene
            .path
            .camera(t, config.width, config.height, config.fov_y_deg)
        else {
            continue;
        };
        // Move objects (vertices and grid entries).
        for (o, m) in scene.motion.iter().enumerate() {
            if let Some(m) = m {
                offsets[o] = m.offset(t);
                if !base_box[o].is_empty() {
                    let b = Aabb::new(base_box[o].min + offsets[o], base_box[o].max + offsets[o]);
                    grid.insert(o as u32, b)?;
                }
            }
        }
        for (v, p) in moved.positions.iter_mut().enumerate() {
            let o = object_of_vertex[v];
            if let Some(off) = offsets.get(o as usize) {
                *p = base.positions[v] + *off;
            }
        }

        // --- Culling (timed) ---
        let start = Instant::now();
        let mut stats = FrameStats::default();
        scheduler.begin_frame();
        let frame_no = scheduler.frame();
        for &(cell, vis) in &pending {
            scheduler.record(cell, frame_no - 1, vis);
        }
        pending.clear();
        backend.begin_frame(&camera);
        cells.clear();
        traversal.visit(&shape, &camera, config.far, &mut cells);
        grid.begin_pass();
        for &o in &drawn_list {
            drawn_flag[o as usize] = false;
        }
        drawn_list.clear();
        for &cell in &cells {
            if grid.objects_in(cell).is_empty() {
                continue;
            }
            stats.cells += 1;
            if scheduler.should_query(cell) {
                backend.query(cell, &shape.cell_bounds(cell));
                stats.queries += 1;
                if config.latency == 0 {
                    backend.take_results(&mut pending);
                    for &(c, vis) in &pending {
                        scheduler.record(c, frame_no, vis);
                    }
                    pending.clear();
                }
            }
            if !scheduler.is_drawn(cell) {
                continue;
            }
            collected.clear();
            grid.collect(cell, &mut collected);
            corners.clear();
            for &o in &collected {
                drawn_flag[o as usize] = true;
                drawn_list.push(o);
                if scheduler.enters_prepass(scene.class[o as usize]) {
                    stats.prepass += 1;
                    for &tri in &tris_of[o as usize] {
                        corners.extend_from_slice(&moved.triangle(tri));
                    }
                }
            }
            if !corners.is_empty() {
                backend.draw_depth(&corners);
            }
        }
        backend.take_results(&mut pending);
        scheduler.end_frame();
        stats.cull_ms = start.elapsed().as_secs_f64() * 1e3;
        stats.drawn = drawn_list.len() as u32;

        // --- Baseline: frustum culling over the same cells ---
        grid.begin_pass();
        collected.clear();
        for &cell in &cells {
            grid.collect(cell, &mut collected);
        }
        stats.frustum = collected.len() as u32;

        // --- Ground truth and popping ---
        if config.measure_popping {
            Rasterizer::new(&moved).render(&camera, None, &mut frame_img);
            let mut visible = vec![false; n_obj];
            for &id in &frame_img.ids {
                if id == Hit::NONE {
                    continue;
                }
                let o = moved.object_of_triangle[id as usize] as usize;
                visible[o] = true;
                if !drawn_flag[o] {
                    stats.popping_pixels += 1;
                }
            }
            for o in 0..n_obj {
                stats.exact_visible += u32::from(visible[o]);
                if f < config.latency {
                    continue;
                }
                if visible[o] && !drawn_flag[o] {
                    stats.missing += 1;
                    streak[o] += 1;
                } else if streak[o] > 0 {
                    bump(&mut report.streaks, streak[o]);
                    streak[o] = 0;
                }
            }
        }
        report.frames.push(stats);
    }
    for s in streak.into_iter().filter(|&s| s > 0) {
        bump(&mut report.streaks, s);
    }
    Ok(report)
}

fn bump(hist: &mut Vec<u32>, k: u32) {
    let k = k as usize;
    if hist.len() <= k {
        hist.resize(k + 1, 0);
    }
    hist[k] += 1;
}
