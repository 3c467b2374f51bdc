//! The pixel error of a PVS, as Koch & Wimmer 2021 measure it (section 6, after Nirenstein &
//! Blake 2004): render the scene from many viewpoints in the view cell; a pixel is erroneous
//! when rendering only the PVS would show a different triangle there than rendering everything.
//!
//! Only the full scene is rendered: if the triangle that wins a pixel in the full scene is in
//! the PVS, it also wins among the PVS's triangles (it is in front of all of them, and the
//! rasterizer's tie rule is a total order), so that pixel is right; if it is not in the PVS, the
//! PVS render shows something else or nothing, so the pixel is wrong. Hence error pixels =
//! covered pixels whose triangle is missing from the PVS — exact, at half the rendering cost,
//! and several PVSs (methods) are judged on the same reference views.
//!
//! Snapping: the rasterizer snaps vertices to 1/256 pixel, so a triangle edge passing within
//! 1/512 px of a row or column of pixel centres can make a triangle "cover" a whole line of
//! centres it does not really cover (or miss one it does) — with axis-aligned walls and
//! axis-aligned cube-map views this happens in some views of every city. Each erroneous pixel
//! is therefore confirmed by casting the exact ray through its centre: if the ray hits the same
//! triangle, it is an error (`avg_error_pixels`, regions, false negatives); if not, it is a
//! snapping artefact of the reference, counted apart (`avg_unconfirmed_pixels`) so the paper's
//! raw metric can still be read off as the sum.
//!
//! Viewpoints: randomly shifted Halton points inside the cell (the paper: 2000 viewpoints,
//! 1000² pixels). Views per viewpoint: the six faces of a cube map (default: no direction is
//! left unchecked), or one view in a random direction with a 90-degree field of view (closer to
//! the paper).

use glam::Vec3;
use serde::Serialize;
use sightline_core::raster::{Frame, Rasterizer};
use sightline_core::sampling::ShiftedHalton;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::{Camera, Hit, Ray, Scene, TriangleSet};
use sightline_region::ViewCell;

use crate::error_regions::connected_regions;

/// Which views are rendered from each viewpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ViewMode {
    /// The six faces of a cube map.
    CubeFaces,
    /// One 90-degree view in a random direction.
    Random,
}

/// Evaluation settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct EvalParams {
    /// Viewpoints in the cell (paper: 2000).
    pub viewpoints: usize,
    /// Image width and height (paper: 1000).
    pub resolution: u32,
    /// Views per viewpoint.
    pub views: ViewMode,
    /// Seed of the Halton shift.
    pub seed: u64,
}

impl Default for EvalParams {
    fn default() -> Self {
        Self {
            viewpoints: 2000,
            resolution: 1000,
            views: ViewMode::CubeFaces,
            seed: 1,
        }
    }
}

/// The worst view of an evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct WorstView {
    /// Eye position.
    pub eye: [f32; 3],
    /// View direction.
    pub forward: [f32; 3],
    /// Up vector.
    pub up: [f32; 3],
    /// Erroneous pixels in it.
    pub error_pixels: usize,
}

impl WorstView {
    /// The camera of this view at `resolution` (square, 90 degrees). The evaluation's views
    /// have the near plane [`ViewCell::default_near`] of their cell.
    pub fn camera(&self, resolution: u32, near: f32) -> Option<Camera> {
        Camera::looking(
            Vec3::from(self.eye),
            Vec3::from(self.forward),
            Vec3::from(self.up),
            90.0,
            resolution,
            resolution,
            near,
        )
        .ok()
    }
}

/// The error measures of one PVS for one cell.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CellEvaluation {
    /// Images rendered.
    pub images: usize,
    /// Image width = height.
    pub resolution: u32,
    /// Average erroneous pixels per image (confirmed by ray casting, see the module docs).
    pub avg_error_pixels: f64,
    /// Average pixels per image that the rasterizer alone calls erroneous (snapping artefacts).
    pub avg_unconfirmed_pixels: f64,
    /// Maximum erroneous pixels in one image.
    pub max_error_pixels: usize,
    /// Average number of 4-connected error regions per image.
    pub avg_error_regions: f64,
    /// Largest 4-connected error region (pixels).
    pub max_error_region_size: usize,
    /// PVS size.
    pub pvs_size: usize,
    /// Triangles seen in at least one reference view (at a pixel centre that ray casting
    /// confirms).
    pub ground_truth_size: usize,
    /// Seen triangles missing from the PVS.
    pub false_negatives: usize,
    /// PVS triangles not seen in any reference view (the PVS may still be right about them:
    /// they may be visible from places or at resolutions the views miss).
    pub false_positives: usize,
    /// The view with the most erroneous pixels (none when every view is right).
    pub worst_view: Option<WorstView>,
}

/// Evaluates each of `pvs_sets` for `cell`, on the same reference views. `progress` is called
/// with (views done, views total).
pub fn evaluate_cell(
    scene: &Scene,
    cell: &ViewCell,
    pvs_sets: &[&TriangleSet],
    params: &EvalParams,
    progress: &dyn Fn(usize, usize),
) -> Vec<CellEvaluation> {
    evaluate_cell_in(scene, cell, &|_| true, pvs_sets, params, progress)
}

/// [`evaluate_cell`] with viewpoints restricted to the cell's free space: Halton points for
/// which `free_space` returns false are skipped (e.g. the solid part of a Quake 3 leaf box), so
/// fewer than `params.viewpoints` viewpoints may be used.
pub fn evaluate_cell_in(
    scene: &Scene,
    cell: &ViewCell,
    free_space: &dyn Fn(Vec3) -> bool,
    pvs_sets: &[&TriangleSet],
    params: &EvalParams,
    progress: &dyn Fn(usize, usize),
) -> Vec<CellEvaluation> {
    let n = scene.triangle_count();
    let near = cell.default_near(scene);
    let cameras: Vec<Camera> = view_cameras(scene, cell, params, near)
        .into_iter()
        .filter(|c| free_space(c.eye))
        .collect();
    let mut rasterizer = Rasterizer::new(scene);
    let bvh = Bvh::build(scene);
    let r = params.resolution.max(1);
    let mut frame = Frame::new(r, r);
    let mut ground_truth = TriangleSet::with_capacity(n);
    let mut acc: Vec<Accumulator> = pvs_sets.iter().map(|_| Accumulator::default()).collect();
    let mut mask = vec![false; (r * r) as usize];
    for (i, camera) in cameras.iter().enumerate() {
        rasterizer.render(camera, None, &mut frame);
        // Pixels whose triangle some PVS misses: confirm them with the exact pixel-centre ray.
        let confirmed = confirm_pixels(&bvh, camera, &frame, &|id| {
            pvs_sets.iter().any(|p| !p.contains(id as usize))
        });
        for (&id, &ok) in frame.ids.iter().zip(&confirmed) {
            if id != Hit::NONE && ok {
                ground_truth.insert(id as usize);
            }
        }
        for (a, pvs) in acc.iter_mut().zip(pvs_sets) {
            let mut errors = 0;
            for ((m, &id), &ok) in mask.iter_mut().zip(&frame.ids).zip(&confirmed) {
                let wrong = id != Hit::NONE && !pvs.contains(id as usize);
                *m = wrong && ok;
                errors += usize::from(*m);
                a.unconfirmed += usize::from(wrong && !ok);
            }
            let (regions, largest) = if errors > 0 {
                connected_regions(&mask, r as usize, r as usize)
            } else {
                (0, 0)
            };
            a.add(errors, regions, largest, camera);
        }
        progress(i + 1, cameras.len());
    }
    let seen = ground_truth.count_ones(..);
    acc.into_iter()
        .zip(pvs_sets)
        .map(|(a, pvs)| {
            let images = cameras.len().max(1) as f64;
            CellEvaluation {
                images: cameras.len(),
                resolution: r,
                avg_error_pixels: a.error_pixels as f64 / images,
                avg_unconfirmed_pixels: a.unconfirmed as f64 / images,
                max_error_pixels: a.max_error_pixels,
                avg_error_regions: a.regions as f64 / images,
                max_error_region_size: a.max_region,
                pvs_size: pvs.count_ones(..),
                ground_truth_size: seen,
                false_negatives: ground_truth.difference(pvs).count(),
                false_positives: pvs.difference(&ground_truth).count(),
                worst_view: a.worst,
            }
        })
        .collect()
}

/// Whether each pixel's triangle is confirmed by the exact ray through the pixel centre. Only
/// covered pixels whose triangle `suspect` returns true for are checked (one ray each); every
/// other pixel counts as confirmed.
fn confirm_pixels(
    caster: &dyn RayCaster,
    camera: &Camera,
    frame: &Frame,
    suspect: &dyn Fn(u32) -> bool,
) -> Vec<bool> {
    let w = frame.width.max(1);
    let candidates: Vec<usize> = frame
        .ids
        .iter()
        .enumerate()
        .filter(|(_, &id)| id != Hit::NONE && suspect(id))
        .map(|(i, _)| i)
        .collect();
    let rays: Vec<Ray> = candidates
        .iter()
        .map(|&i| camera.pixel_ray(i as u32 % w, i as u32 / w))
        .collect();
    let mut hits = vec![Hit::MISS; rays.len()];
    caster.cast(&rays, &mut hits);
    let mut confirmed = vec![true; frame.ids.len()];
    for (&i, h) in candidates.iter().zip(&hits) {
        confirmed[i] = h.triangle == frame.ids[i];
    }
    confirmed
}

/// The pixels of one view that a PVS gets wrong, classified as [`evaluate_cell`] counts them.
#[derive(Clone, Debug)]
pub struct ViewErrors {
    /// The reference render of the full scene.
    pub frame: Frame,
    /// Erroneous pixels: the winning triangle is missing from the PVS and ray casting through
    /// the pixel centre confirms it is seen there (row-major, `frame.width` wide).
    pub error: Vec<bool>,
    /// Pixels the rasterizer alone calls erroneous (snapping artefacts of the reference).
    pub unconfirmed: Vec<bool>,
}

impl ViewErrors {
    /// Number of erroneous pixels.
    pub fn error_count(&self) -> usize {
        self.error.iter().filter(|&&e| e).count()
    }

    /// Number of unconfirmed pixels.
    pub fn unconfirmed_count(&self) -> usize {
        self.unconfirmed.iter().filter(|&&e| e).count()
    }
}

/// Renders `camera`'s view of `scene` and classifies every pixel for `pvs`, with the same
/// rules as [`evaluate_cell`]: e.g. to show a cell's [`WorstView`] with its error pixels.
/// `caster` must be built over `scene`.
pub fn view_errors(
    scene: &Scene,
    caster: &dyn RayCaster,
    camera: &Camera,
    pvs: &TriangleSet,
) -> ViewErrors {
    let frame = sightline_core::raster::render(scene, camera);
    let missing = |id: u32| !pvs.contains(id as usize);
    let confirmed = confirm_pixels(caster, camera, &frame, &missing);
    let wrong: Vec<bool> = frame
        .ids
        .iter()
        .map(|&id| id != Hit::NONE && missing(id))
        .collect();
    ViewErrors {
        error: wrong
            .iter()
            .zip(&confirmed)
            .map(|(&w, &c)| w && c)
            .collect(),
        unconfirmed: wrong
            .iter()
            .zip(&confirmed)
            .map(|(&w, &c)| w && !c)
            .collect(),
        frame,
    }
}

#[derive(Default)]
struct Accumulator {
    error_pixels: usize,
    unconfirmed: usize,
    max_error_pixels: usize,
    regions: usize,
    max_region: usize,
    worst: Option<WorstView>,
}

impl Accumulator {
    fn add(&mut self, errors: usize, regions: usize, largest: usize, camera: &Camera) {
        self.error_pixels += errors;
        self.regions += regions;
        self.max_region = self.max_region.max(largest);
        if errors > self.max_error_pixels {
            self.max_error_pixels = errors;
            self.worst = Some(WorstView {
                eye: camera.eye.to_array(),
                forward: camera.forward.to_array(),
                up: camera.up.to_array(),
                error_pixels: errors,
            });
        }
    }
}

/// The reference cameras: Halton viewpoints inside the cell, each with six cube faces or one
/// random 90-degree view.
pub fn view_cameras(scene: &Scene, cell: &ViewCell, params: &EvalParams, near: f32) -> Vec<Camera> {
    let halton = ShiftedHalton::<5>::new(params.seed ^ 0x6576_616c);
    let r = params.resolution.max(1);
    let mut cameras = Vec::new();
    for i in 0..params.viewpoints as u64 {
        let h = halton.point(i);
        let eye = cell.interior_point([h[0], h[1], h[2]]);
        match params.views {
            ViewMode::CubeFaces => {
                if let Ok(faces) = Camera::cube_faces(eye, r, near) {
                    cameras.extend(faces);
                }
            }
            ViewMode::Random => {
                let phi = std::f32::consts::TAU * h[3];
                let z = 2.0 * h[4] - 1.0;
                let s = (1.0 - z * z).max(0.0).sqrt();
                let forward = Vec3::new(s * phi.cos(), s * phi.sin(), z);
                let up = if forward.cross(scene.up.vector()).length_squared() > 1e-6 {
                    scene.up.vector()
                } else {
                    Vec3::X
                };
                if let Ok(c) = Camera::looking(eye, forward, up, 90.0, r, r, near) {
                    cameras.push(c);
                }
            }
        }
    }
    cameras
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;

    /// A small box in front of a big wall, viewed from a cell on the other side.
    fn occluder_scene() -> Scene {
        let mut b = SceneBuilder::new("occluder");
        b.begin_object("wall");
        b.add_box(Vec3::new(-10.0, 10.0, -10.0), Vec3::new(10.0, 11.0, 10.0));
        b.begin_object("small");
        b.add_box(Vec3::new(-1.0, 4.0, -1.0), Vec3::new(1.0, 5.0, 1.0));
        b.finish()
    }

    fn cell() -> ViewCell {
        ViewCell::aabb(Vec3::splat(-0.5), Vec3::splat(0.5)).unwrap()
    }

    fn params() -> EvalParams {
        EvalParams {
            viewpoints: 4,
            resolution: 64,
            ..EvalParams::default()
        }
    }

    #[test]
    fn full_set_has_no_error() {
        let scene = occluder_scene();
        let mut all = TriangleSet::with_capacity(scene.triangle_count());
        all.insert_range(..);
        let e = &evaluate_cell(&scene, &cell(), &[&all], &params(), &|_, _| {})[0];
        assert_eq!(e.images, 24);
        assert_eq!(
            (e.max_error_pixels, e.false_negatives, e.avg_error_regions),
            (0, 0, 0.0)
        );
        assert!(e.ground_truth_size > 0);
        assert_eq!(
            e.false_positives,
            scene.triangle_count() - e.ground_truth_size
        );
        assert!(e.worst_view.is_none());
    }

    #[test]
    fn empty_set_misses_everything_seen() {
        let scene = occluder_scene();
        let none = TriangleSet::with_capacity(scene.triangle_count());
        let e = &evaluate_cell(&scene, &cell(), &[&none], &params(), &|_, _| {})[0];
        assert_eq!(e.false_negatives, e.ground_truth_size);
        assert!(e.max_error_pixels > 0 && e.worst_view.is_some());
        // Snapping artefacts are rare next to real errors on clean geometry.
        assert!(
            e.avg_unconfirmed_pixels * 100.0 <= e.avg_error_pixels,
            "{e:?}"
        );
        assert!(e.avg_error_regions >= 1.0 / 6.0);
    }

    #[test]
    fn error_pixels_equal_a_pvs_only_render() {
        // The shortcut (membership test) must agree with really rendering only the PVS.
        let scene = occluder_scene();
        let mut pvs = TriangleSet::with_capacity(scene.triangle_count());
        for id in (0..scene.triangle_count()).step_by(3) {
            pvs.insert(id);
        }
        let camera = Camera::look_at(
            Vec3::ZERO,
            Vec3::new(0.3, 10.0, 0.2),
            Vec3::Z,
            90.0,
            64,
            64,
            1e-3,
        )
        .unwrap();
        let full = sightline_core::raster::render(&scene, &camera);
        let only = sightline_core::raster::render_subset(&scene, &camera, &pvs);
        let by_render = full
            .ids
            .iter()
            .zip(&only.ids)
            .filter(|(a, b)| a != b)
            .count();
        let by_membership = full
            .ids
            .iter()
            .filter(|&&id| id != Hit::NONE && !pvs.contains(id as usize))
            .count();
        assert!(by_render > 0);
        assert_eq!(by_render, by_membership);
    }

    #[test]
    fn worst_view_errors_match_the_evaluation() {
        let scene = occluder_scene();
        let none = TriangleSet::with_capacity(scene.triangle_count());
        let e = &evaluate_cell(&scene, &cell(), &[&none], &params(), &|_, _| {})[0];
        let worst = e.worst_view.unwrap();
        let camera = worst.camera(params().resolution, cell().default_near(&scene));
        let bvh = Bvh::build(&scene);
        let v = view_errors(&scene, &bvh, &camera.unwrap(), &none);
        assert_eq!(v.error_count(), e.max_error_pixels);
        assert!(v.error.iter().zip(&v.unconfirmed).all(|(&a, &b)| !(a && b)));
        // With everything in the PVS nothing is wrong.
        let mut all = TriangleSet::with_capacity(scene.triangle_count());
        all.insert_range(..);
        let camera = worst.camera(params().resolution, cell().default_near(&scene));
        let v = view_errors(&scene, &bvh, &camera.unwrap(), &all);
        assert_eq!((v.error_count(), v.unconfirmed_count()), (0, 0));
    }

    #[test]
    fn random_views_give_one_camera_per_viewpoint() {
        let scene = occluder_scene();
        let p = EvalParams {
            views: ViewMode::Random,
            ..params()
        };
        let cams = view_cameras(&scene, &cell(), &p, 1e-3);
        assert_eq!(cams.len(), 4);
        assert!(cams.iter().all(|c| cell().contains(c.eye)));
    }
}
