//! The viewer's state shared by the window and the headless driver: the scene, the optional
//! `.pvs`, the visibility method of each frame and the accumulated popping statistics.
//!
//! Methods (keys 1..4 in the window):
//! 1. `none`: every triangle is drawn.
//! 2. `pvs`: the set of the `.pvs` cell in use: the picked cell (keys `[` / `]`, `--cell`)
//!    from any viewpoint, else the cell containing the eye (the first one, in file order);
//!    outside every cell nothing is known and everything is drawn.
//! 3. `occlusion`: per-frame occlusion culling of scene chunks with the software occlusion
//!    buffer ([`OcclusionCuller`]).
//! 4. `exact`: the exact visible set of the frame (`sightline_point::analytic`, every triangle
//!    with a visible region however small), computed for a camera with the same frustum at a
//!    reduced resolution (1/[`ViewerOptions::exact_divisor`] of the image per axis) to save
//!    time: the analytic set does not depend on the resolution beyond its 2^-20-pixel
//!    snapping, so what popping remains is where the GPU's and the analytic method's edge
//!    and tie rules differ.
//!
//! **Frozen culling** (key F, `--freeze-at`): the visible set stays the one computed for the
//! camera at the moment of freezing (with whatever method is active; computed again only when
//! the method or the picked cell changes) while the camera flies on, so the set can be
//! inspected from outside; the frozen frustum is drawn. **Overview** (key O, `--overview`):
//! the frame is drawn from above by an orthographic camera ([`OrthoCamera`]), the set still
//! chosen from the eye (or the frozen camera).
//!
//! **Popping while frozen or in the overview**: the frame's `popping_pixels` is still measured,
//! but it is the number of pixels of the image *shown* (from the moving or overview camera)
//! that the set misses: how much of the scene lies outside the frozen set, not the method's
//! popping, which is only defined from the camera the set was chosen for. Those frames are
//! therefore not added to the popping statistics (the HUD's and `frames.json`'s max and mean),
//! and their records say `popping_counted: false`.

use std::time::Instant;

use glam::Vec3;
use serde::Serialize;
use sightline_core::{Camera, Scene, TriangleSet};
use sightline_point::analytic::{visible_fragments, AnalyticOptions};
use sightline_region::PvsFile;

use crate::cell_pick::{cell_in_use, step_cell, CellSource};
use crate::error::ViewError;
use crate::guides::{guides, GuideInput};
use crate::occlusion::OcclusionCuller;
use crate::overview::{OrthoCamera, ViewCamera};
use crate::renderer::{Renderer, Shading};

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
    /// Index of the `.pvs` cell in use: the picked cell, else the one containing the eye (of
    /// the frozen camera while frozen), if any.
    pub cell: Option<usize>,
    /// Whether `cell` was picked (`[`, `]`, `--cell`) rather than the eye's.
    pub cell_picked: bool,
    /// The frame at which culling was frozen, while frozen (the drawn set is that frame's).
    pub frozen_at: Option<u32>,
    /// Whether the frame was drawn from the top-down overview camera.
    pub overview: bool,
    /// Whether `popping_pixels` went into the popping statistics: not while frozen or in the
    /// overview, where it counts what the set misses as seen from elsewhere (see the module
    /// documentation).
    pub popping_counted: bool,
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

/// Culling frozen at a camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frozen {
    /// The camera the set is chosen for.
    pub camera: Camera,
    /// The frame number at which culling was frozen (the first frame drawn frozen).
    pub frame: u32,
}

/// What the guides were last built for (they are rebuilt only when it changes).
#[derive(Clone, Copy, Debug, PartialEq)]
struct GuidesKey {
    cell: Option<(usize, CellSource)>,
    show_cells: bool,
    frozen: Option<u32>,
    /// The overview camera and the eye marker's pose, in the overview.
    overview: Option<(OrthoCamera, Vec3, Vec3)>,
}

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
    /// Whether frames are drawn from the top-down overview camera.
    pub overview: bool,
    occlusion: Option<OcclusionCuller>,
    drawn: TriangleSet,
    popping: PoppingStats,
    frames: u32,
    frozen: Option<Frozen>,
    picked: Option<usize>,
    /// The eye's cell in the last frame (where `[` / `]` start from).
    last_eye_cell: Option<usize>,
    /// While frozen: the method and cell the drawn set was chosen with, and its size.
    frozen_set: Option<(Method, Option<usize>, Option<usize>)>,
    /// What the guides given to the renderer show.
    guides_for: Option<GuidesKey>,
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
            overview: false,
            occlusion: None,
            drawn: TriangleSet::new(),
            popping: PoppingStats::default(),
            frames: 0,
            frozen: None,
            picked: None,
            last_eye_cell: None,
            frozen_set: None,
            guides_for: None,
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

    /// Freezes culling at `camera`: the next frames draw the set chosen for it, whatever the
    /// camera they are drawn from, until [`Viewer::unfreeze`]. Frame numbers count on; the
    /// next frame is the first frozen one.
    pub fn freeze(&mut self, camera: Camera) {
        self.frozen = Some(Frozen {
            camera,
            frame: self.frames,
        });
        self.frozen_set = None;
    }

    /// Unfreezes culling: each frame's set is chosen for its own camera again.
    pub fn unfreeze(&mut self) {
        self.frozen = None;
        self.frozen_set = None;
    }

    /// The frozen camera, while frozen.
    pub fn frozen(&self) -> Option<&Frozen> {
        self.frozen.as_ref()
    }

    /// Picks cell `cell` for the pvs method (from any viewpoint), or the eye's cell again
    /// with `None`. Fails when the `.pvs` has no such cell (or there is no `.pvs`).
    pub fn pick_cell(&mut self, cell: Option<usize>) -> Result<(), ViewError> {
        let cells = self.pvs.as_ref().map_or(0, |p| p.cells.len());
        if let Some(c) = cell.filter(|&c| c >= cells) {
            return Err(ViewError::NoSuchCell { cell: c, cells });
        }
        self.picked = cell;
        Ok(())
    }

    /// The picked cell, if any.
    pub fn picked_cell(&self) -> Option<usize> {
        self.picked
    }

    /// Picks the next cell (`next`) or the previous one, wrapping around; the first step
    /// starts from the eye's cell of the last frame. Nothing happens without cells.
    pub fn step_cell(&mut self, next: bool) {
        let cells = self.pvs.as_ref().map_or(0, |p| p.cells.len());
        self.picked = step_cell(self.picked, self.last_eye_cell, cells, next);
    }

    /// Culls with the current method, renders with `renderer` into `target` and records the
    /// frame's numbers. `camera` is the eye's; while frozen the set is chosen for the frozen
    /// camera instead, and in the overview the frame is drawn from above. Popping is added to
    /// [`Viewer::popping`] only when neither (see the module documentation).
    pub fn frame(
        &mut self,
        renderer: &mut Renderer,
        camera: &Camera,
        target: &wgpu::TextureView,
    ) -> Result<FrameRecord, ViewError> {
        let cull_camera = self.frozen.map_or(*camera, |f| f.camera);
        self.last_eye_cell = self.cell_at(cull_camera.eye);
        let cell = cell_in_use(self.picked, self.last_eye_cell);
        let view = if self.overview {
            let (up, bounds) = (self.scene.up, self.scene.bounds());
            ViewCamera::Orthographic(OrthoCamera::over(&bounds, up, camera.width, camera.height))
        } else {
            ViewCamera::Perspective(*camera)
        };
        self.update_guides(renderer, &view, camera, cell);
        let start = Instant::now();
        let drawn = self.cull_once(&cull_camera, cell.map(|c| c.0))?;
        let cull_ms = start.elapsed().as_secs_f64() * 1e3;
        let gpu = renderer.render_view(&view, drawn.map(|_| &self.drawn), self.shading, target)?;
        let popping_counted = self.frozen.is_none() && !self.overview;
        if popping_counted {
            self.popping.add(gpu.popping_pixels);
        }
        let objects_total = self.scene.objects.len();
        let objects_drawn = drawn.map_or(objects_total, |_| self.objects_drawn());
        let record = FrameRecord {
            frame: self.frames,
            method: self.method,
            eye: camera.eye.to_array(),
            forward: camera.forward.to_array(),
            cell: cell.map(|c| c.0),
            cell_picked: cell.is_some_and(|c| c.1 == CellSource::Picked),
            frozen_at: self.frozen.map(|f| f.frame),
            overview: self.overview,
            popping_counted,
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

    /// [`Viewer::cull`], except while frozen, where the set of the frozen camera is kept until
    /// the method or the cell changes (it would come out the same every frame).
    fn cull_once(
        &mut self,
        camera: &Camera,
        cell: Option<usize>,
    ) -> Result<Option<usize>, ViewError> {
        if self.frozen.is_none() {
            return self.cull(camera, cell);
        }
        match self.frozen_set {
            Some((method, c, drawn)) if method == self.method && c == cell => Ok(drawn),
            _ => {
                let drawn = self.cull(camera, cell)?;
                self.frozen_set = Some((self.method, cell, drawn));
                Ok(drawn)
            }
        }
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
            (true, Some(c)) => format!(" | {}", cell_label(c, r.cell_picked)),
            (true, None) => " | no cell".into(),
        };
        let modes = format!(
            "{}{}{}{}",
            if self.shading.xray { " x-ray" } else { "" },
            r.frozen_at
                .map_or(String::new(), |f| format!(" frozen at frame {f}")),
            if r.overview { " overview" } else { "" },
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

    /// Gives `renderer` the guides of this frame (see `guides.rs`) when they changed.
    fn update_guides(
        &mut self,
        renderer: &mut Renderer,
        view: &ViewCamera,
        eye: &Camera,
        cell: Option<(usize, CellSource)>,
    ) {
        let overview = match view {
            ViewCamera::Orthographic(o) => Some((*o, eye.eye, eye.forward)),
            ViewCamera::Perspective(_) => None,
        };
        let key = GuidesKey {
            cell,
            show_cells: self.show_cells,
            frozen: self.frozen.map(|f| f.frame),
            overview,
        };
        if self.guides_for == Some(key) {
            return;
        }
        self.guides_for = Some(key);
        let g = guides(&GuideInput {
            pvs: self.pvs.as_ref(),
            show_cells: self.show_cells,
            cell,
            frozen: self.frozen.as_ref().map(|f| &f.camera),
            bounds: self.scene.bounds(),
            overview: overview.as_ref().map(|o| &o.0),
            eye: (eye.eye, eye.forward),
        });
        renderer.set_guides(&g.lines, &g.fills);
    }
}

/// `cell 12 (picked)` or `cell 12 (eye)`: the cell in use and where it came from.
pub(crate) fn cell_label(cell: usize, picked: bool) -> String {
    let source = if picked {
        CellSource::Picked
    } else {
        CellSource::Eye
    };
    format!("cell {cell} ({})", source.name())
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
