//! The viewer's state shared by the window and the headless driver: the scene, the optional
//! `.pvs`, the visibility method of each frame and the accumulated popping statistics.
//!
//! Methods (keys 1..4 in the window):
//! 1. `none`: every triangle is drawn.
//! 2. `pvs`: the set of the `.pvs` cell containing the eye (the first one, in file order);
//!    outside every cell nothing is known and everything is drawn.
//! 3. `occlusion`: per-frame occlusion culling of scene chunks with the software occlusion
//!    buffer ([`OcclusionCuller`]).
//! 4. `exact`: the exact visible set of the frame (`sightline_point::analytic`, every triangle
//!    with a visible region however small), computed for a camera with the same frustum at a
//!    reduced resolution (1/[`ViewerOptions::exact_divisor`] of the image per axis) to save
//!    time: the analytic set does not depend on the resolution beyond its 2^-20-pixel
//!    snapping, so what popping remains is where the GPU's and the analytic method's edge
//!    and tie rules differ.

use std::time::Instant;

use glam::Vec3;
use serde::Serialize;
use sightline_core::{Camera, Scene, TriangleSet};
use sightline_point::analytic::{visible_fragments, AnalyticOptions};
use sightline_region::PvsFile;

use crate::error::ViewError;
use crate::occlusion::OcclusionCuller;
use crate::renderer::{LineVertex, Renderer, Shading};

/// A visibility method of the viewer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Draw everything.
    #[default]
    None,
    /// The PVS of the current view cell.
    Pvs,
    /// Per-frame chunk occlusion culling with the software occlusion buffer.
    Occlusion,
    /// The exact visible set of the frame from the reference rasterizer at reduced resolution.
    Exact,
}

impl Method {
    /// Every method, in key order (key 1 is the first).
    pub const ALL: [Method; 4] = [Method::None, Method::Pvs, Method::Occlusion, Method::Exact];

    /// The name used on the command line, in titles and in `frames.json`.
    pub fn name(self) -> &'static str {
        match self {
            Method::None => "none",
            Method::Pvs => "pvs",
            Method::Occlusion => "occlusion",
            Method::Exact => "exact",
        }
    }

    /// The number key selecting it (1-based).
    pub fn key(self) -> u32 {
        Method::ALL.iter().position(|&m| m == self).unwrap_or(0) as u32 + 1
    }

    /// The method of number key `key` (1-based).
    pub fn from_key(key: u32) -> Option<Method> {
        Method::ALL.get((key as usize).checked_sub(1)?).copied()
    }

    /// Parses a method name (see [`Method::name`]).
    pub fn parse(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// Settings of a [`Viewer`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewerOptions {
    /// The exact method renders at 1/`exact_divisor` of the image size per axis (at least 1).
    pub exact_divisor: u32,
    /// The occlusion buffer has the image's size, scaled down to at most this width.
    pub occlusion_max_width: u32,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        Self {
            exact_divisor: 4,
            occlusion_max_width: 1024,
        }
    }
}

/// One rendered frame's numbers.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameRecord {
    /// Frame number (0-based).
    pub frame: u32,
    /// The method.
    pub method: Method,
    /// Eye position.
    pub eye: [f32; 3],
    /// View direction.
    pub forward: [f32; 3],
    /// Index of the `.pvs` cell containing the eye, if any.
    pub cell: Option<usize>,
    /// Triangles drawn by the method.
    pub triangles_drawn: usize,
    /// Triangles in the scene.
    pub triangles_total: usize,
    /// Objects with at least one triangle drawn.
    pub objects_drawn: usize,
    /// Objects in the scene.
    pub objects_total: usize,
    /// Pixels that differ between the culled and the full image (computed on the GPU).
    pub popping_pixels: u32,
    /// Pixels covered by the full image (counted by the compare pass, so 0 when the method
    /// drew everything and no comparison was made).
    pub covered_pixels: u32,
    /// Milliseconds the method spent choosing the drawn set (CPU).
    pub cull_ms: f64,
}

/// Popping accumulated over frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PoppingStats {
    /// Frames counted.
    pub frames: u32,
    /// Largest per-frame popping count.
    pub max: u32,
    /// Sum of the per-frame counts.
    pub total: u64,
}

impl PoppingStats {
    /// Adds one frame's count.
    pub fn add(&mut self, pixels: u32) {
        self.frames += 1;
        self.max = self.max.max(pixels);
        self.total += u64::from(pixels);
    }

    /// Mean popping pixels per frame (0 without frames).
    pub fn mean(&self) -> f64 {
        if self.frames == 0 {
            0.0
        } else {
            self.total as f64 / f64::from(self.frames)
        }
    }
}

/// Colours of the cell wireframe: the current cell, the others.
const CURRENT_CELL: [f32; 4] = [1.0, 0.85, 0.1, 1.0];
const OTHER_CELL: [f32; 4] = [0.7, 0.8, 1.0, 0.25];

/// The viewer's state. See the module documentation.
pub struct Viewer {
    scene: Scene,
    pvs: Option<PvsFile>,
    options: ViewerOptions,
    /// The method of the next frames.
    pub method: Method,
    /// Shading of the next frames.
    pub shading: Shading,
    /// Whether the cell wireframe is drawn.
    pub show_cells: bool,
    occlusion: Option<OcclusionCuller>,
    drawn: TriangleSet,
    popping: PoppingStats,
    frames: u32,
    /// The wireframe last given to the renderer: (current cell, shown).
    lines_for: Option<(Option<usize>, bool)>,
}

impl Viewer {
    /// A viewer of `scene`, with the PVS file `pvs` if given (checked to belong to the scene).
    pub fn new(
        scene: Scene,
        pvs: Option<PvsFile>,
        options: ViewerOptions,
    ) -> Result<Self, ViewError> {
        if let Some(p) = &pvs {
            p.check_scene(&scene)?;
        }
        Ok(Self {
            scene,
            pvs,
            options,
            method: Method::None,
            shading: Shading {
                xray: false,
                mark_popping: true,
            },
            show_cells: true,
            occlusion: None,
            drawn: TriangleSet::new(),
            popping: PoppingStats::default(),
            frames: 0,
            lines_for: None,
        })
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The PVS file, if any.
    pub fn pvs(&self) -> Option<&PvsFile> {
        self.pvs.as_ref()
    }

    /// The viewer's settings.
    pub fn options(&self) -> ViewerOptions {
        self.options
    }

    /// Popping accumulated since the last method change.
    pub fn popping(&self) -> PoppingStats {
        self.popping
    }

    /// Switches the method and restarts the popping statistics.
    pub fn set_method(&mut self, method: Method) {
        if method != self.method {
            self.method = method;
            self.popping = PoppingStats::default();
        }
    }

    /// The `.pvs` cell containing `eye` (the first in file order), if any.
    pub fn cell_at(&self, eye: Vec3) -> Option<usize> {
        self.pvs
            .as_ref()?
            .cells
            .iter()
            .position(|c| c.cell.contains(eye))
    }

    /// Chooses the triangles to draw for `camera` with the current method: `None` means all.
    fn cull(&mut self, camera: &Camera, cell: Option<usize>) -> Result<Option<usize>, ViewError> {
        let n = self.scene.triangle_count();
        match self.method {
            Method::None => Ok(None),
            Method::Pvs => {
                let Some(set) = cell.and_then(|c| self.pvs.as_ref().map(|p| &p.cells[c].visible))
                else {
                    return Ok(None);
                };
                self.drawn.clone_from(set);
                self.drawn.grow(n);
                Ok(Some(self.drawn.count_ones(..)))
            }
            Method::Occlusion => {
                let scale =
                    (self.options.occlusion_max_width as f32 / camera.width as f32).min(1.0);
                let w = ((camera.width as f32 * scale).round() as u32).max(1);
                let h = ((camera.height as f32 * scale).round() as u32).max(1);
                let culler = self
                    .occlusion
                    .get_or_insert_with(|| OcclusionCuller::new(&self.scene, w, h));
                culler.resize(w, h);
                culler.cull(camera, n, &mut self.drawn);
                Ok(Some(self.drawn.count_ones(..)))
            }
            Method::Exact => {
                let d = self.options.exact_divisor.max(1);
                let small = Camera::looking(
                    camera.eye,
                    camera.forward,
                    camera.up,
                    camera.fov_y_deg,
                    (camera.width / d).max(1),
                    (camera.height / d).max(1),
                    camera.near,
                )?;
                let exact = visible_fragments(&self.scene, &small, &AnalyticOptions::default())
                    .map_err(|e| ViewError::Exact(e.to_string()))?;
                self.drawn = exact.visible;
                self.drawn.grow(n);
                Ok(Some(self.drawn.count_ones(..)))
            }
        }
    }

    /// Culls with the current method, renders with `renderer` into `target` and records the
    /// frame's numbers (popping is added to [`Viewer::popping`]).
    pub fn frame(
        &mut self,
        renderer: &mut Renderer,
        camera: &Camera,
        target: &wgpu::TextureView,
    ) -> Result<FrameRecord, ViewError> {
        let cell = self.cell_at(camera.eye);
        self.update_lines(renderer, cell);
        let start = Instant::now();
        let drawn = self.cull(camera, cell)?;
        let cull_ms = start.elapsed().as_secs_f64() * 1e3;
        let gpu = renderer.render(camera, drawn.map(|_| &self.drawn), self.shading, target)?;
        self.popping.add(gpu.popping_pixels);
        let objects_total = self.scene.objects.len();
        let objects_drawn = drawn.map_or(objects_total, |_| self.objects_drawn());
        let record = FrameRecord {
            frame: self.frames,
            method: self.method,
            eye: camera.eye.to_array(),
            forward: camera.forward.to_array(),
            cell,
            triangles_drawn: drawn.unwrap_or(self.scene.triangle_count()),
            triangles_total: self.scene.triangle_count(),
            objects_drawn,
            objects_total,
            popping_pixels: gpu.popping_pixels,
            covered_pixels: gpu.covered_pixels,
            cull_ms,
        };
        self.frames += 1;
        Ok(record)
    }

    /// Objects with a triangle in the drawn set (one pass over the drawn triangles).
    fn objects_drawn(&self) -> usize {
        let mut seen = fixedbitset::FixedBitSet::with_capacity(self.scene.objects.len());
        for t in self.drawn.ones() {
            if let Some(&o) = self.scene.object_of_triangle.get(t) {
                seen.grow(o as usize + 1);
                seen.insert(o as usize);
            }
        }
        seen.count_ones(..)
    }

    /// The triangles drawn in the last frame of a culling method (empty before any).
    pub fn last_drawn(&self) -> &TriangleSet {
        &self.drawn
    }

    /// A one-line status: method, cell, triangles, popping (for the window title).
    pub fn status(&self, r: &FrameRecord) -> String {
        let cell = match (self.pvs.is_some(), r.cell) {
            (false, _) => String::new(),
            (true, Some(c)) => format!(" | cell {c}"),
            (true, None) => " | no cell".into(),
        };
        let modes = format!(
            "{}{}",
            if self.shading.xray { " x-ray" } else { "" },
            if self.method == Method::Pvs && r.cell.is_none() {
                " (outside cells: all drawn)"
            } else {
                ""
            }
        );
        format!(
            "[{}] {}{modes}{cell} | {}/{} tris | popping {} px (max {}, mean {:.1})",
            self.method.key(),
            self.method.name(),
            r.triangles_drawn,
            r.triangles_total,
            r.popping_pixels,
            self.popping.max,
            self.popping.mean(),
        )
    }

    fn update_lines(&mut self, renderer: &mut Renderer, cell: Option<usize>) {
        let key = (cell, self.show_cells);
        if self.lines_for == Some(key) {
            return;
        }
        self.lines_for = Some(key);
        let mut lines = Vec::new();
        if let (Some(pvs), true) = (&self.pvs, self.show_cells) {
            for (i, c) in pvs.cells.iter().enumerate() {
                let colour = if Some(i) == cell {
                    CURRENT_CELL
                } else {
                    OTHER_CELL
                };
                for (a, b) in c.cell.edges() {
                    lines.push(LineVertex {
                        position: a.to_array(),
                        colour,
                    });
                    lines.push(LineVertex {
                        position: b.to_array(),
                        colour,
                    });
                }
            }
        }
        renderer.set_lines(&lines);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn method_keys_and_names_round_trip() {
        for m in Method::ALL {
            assert_eq!(Method::from_key(m.key()), Some(m));
            assert_eq!(Method::parse(m.name()), Some(m));
        }
        assert_eq!(Method::from_key(0), None);
        assert_eq!(Method::from_key(5), None);
        assert_eq!(Method::parse("bogus"), None);
    }

    #[test]
    fn popping_stats_of_no_frames_are_zero() {
        let s = PoppingStats::default();
        assert_eq!(s.mean(), 0.0);
        let mut s = s;
        s.add(4);
        s.add(0);
        assert_eq!((s.max, s.mean()), (4, 2.0));
    }
}
