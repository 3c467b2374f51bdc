//! The entry points of the analytic visibility: [`visible_fragments`] runs the pipeline's steps
//! (projection, pre-culling, binning, then the bins in parallel) and gathers their output;
//! [`integrate`] and [`antialiased_image`] make the images of its result. See the module
//! documentation (`mod.rs`) for the steps and the guarantees.

use std::time::Instant;

use rayon::prelude::*;
use sightline_core::{Camera, Scene, TriangleSet};

use super::bin::{bin_polygons, BinGrid, Polys};
use super::gauss::gauss_image;
use super::integrate::box_image;
use super::pipeline::{process_bin, BinOutput};
use super::project::{project_triangle, Projected, Projection};
use super::types::{
    AnalyticError, AnalyticOptions, AnalyticResult, AnalyticStats, BinRange, Filter,
};
use super::{domain, polygon, precull};

fn check_camera(c: &Camera) -> Result<(), AnalyticError> {
    if !(c.eye.is_finite() && c.forward.is_finite() && c.up.is_finite() && c.right.is_finite()) {
        return Err(AnalyticError::BadCamera("non-finite position or basis"));
    }
    if c.width == 0 || c.height == 0 || c.width > 16384 || c.height > 16384 {
        return Err(AnalyticError::BadCamera("image size outside 1..=16384"));
    }
    if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
        return Err(AnalyticError::BadCamera("field of view outside (0, 180)"));
    }
    if !(c.near > 0.0 && c.near.is_finite()) {
        return Err(AnalyticError::BadCamera(
            "near plane not positive and finite",
        ));
    }
    if c.forward.length_squared() < 0.5 || c.right.length_squared() < 0.5 {
        return Err(AnalyticError::BadCamera(
            "basis vectors are not unit length",
        ));
    }
    domain::check(c)
}

/// The exact visible fragments of `scene` seen from `camera`: for every triangle, convex
/// polygons covering exactly its visible region inside the image (however small), and the set
/// of triangles with a visible region of positive area. See the module docs for the assumptions.
pub fn visible_fragments(
    scene: &Scene,
    camera: &Camera,
    options: &AnalyticOptions,
) -> Result<AnalyticResult, AnalyticError> {
    let start = Instant::now();
    check_camera(camera)?;
    if options.bin_size == 0 || options.bin_size > 4096 {
        return Err(AnalyticError::BadBinSize(options.bin_size));
    }
    let proj = Projection::new(camera);
    let n = scene.triangles.len();
    let projected: Vec<Projected> = (0..n as u32)
        .into_par_iter()
        .map(|id| project_triangle(scene, &proj, id))
        .collect();
    let mut stats = AnalyticStats::default();
    let mut polys = Vec::new();
    for p in projected {
        match p {
            Projected::Poly(p) => polys.push(p),
            Projected::Empty => {}
            Projected::Invalid => stats.warnings.invalid_triangles += 1,
        }
    }
    stats.triangles_in_frustum = polys.len();
    stats.projection_time = start.elapsed();
    if options.depth_preculling {
        let (kept, culled) = precull::cull_hidden(polys, camera.width, camera.height);
        polys = kept;
        stats.preculled = culled;
    }
    stats.precull_time = start.elapsed() - stats.projection_time;
    let grid = BinGrid::new(camera.width, camera.height, options.bin_size);
    let polys = Polys::new(polys);
    let bins = bin_polygons(&polys, grid);
    stats.binning_time = start.elapsed() - stats.projection_time - stats.precull_time;
    stats.bins_filled = bins.len();
    stats.bin_assignments = bins.iter().map(|b| b.members.len()).sum();
    stats.max_pieces_per_bin = bins.iter().map(|b| b.members.len()).max().unwrap_or(0);
    let outputs: Vec<BinOutput> = bins.par_iter().map(|b| process_bin(&polys, b)).collect();
    let mut area = vec![0.0f64; n];
    let mut polygons = Vec::new();
    let mut ranges = Vec::with_capacity(bins.len());
    for (bin, o) in bins.iter().zip(outputs) {
        stats.intersections += o.counters.intersections;
        stats.exact_fallbacks += o.counters.exact_fallbacks;
        stats.flipped_overlaps += o.counters.intersecting;
        stats.crossing_pairs += o.crossing_pairs;
        stats.warnings.unresolved_crossings += o.unresolved_pairs;
        stats.visible_segments += o.visible_segments;
        stats.completion_segments += o.completion_segments;
        let first = polygons.len();
        for p in o.pieces {
            if let Some(a) = area.get_mut(p.triangle as usize) {
                *a += polygon::area(&p.points);
            }
            polygons.push(p);
        }
        ranges.push(BinRange {
            x: bin.x * options.bin_size,
            y: bin.y * options.bin_size,
            polys: first..polygons.len(),
        });
    }
    let mut visible = TriangleSet::with_capacity(n);
    visible.extend((0..n).filter(|&t| area[t] > 0.0));
    stats.visibility_time = start.elapsed();
    Ok(AnalyticResult {
        visible,
        polygons,
        stats,
        area,
        width: camera.width,
        height: camera.height,
        bin_size: options.bin_size,
        bins: ranges,
    })
}

/// The image of `result` filtered with `filter`: pixel `(x, y)` (row-major, top row first) is
/// the integral of `value(triangle)` over the visible polygons against the filter centred on the
/// pixel: for [`Filter::Box`] exactly the sum of value × area inside the pixel's square, for
/// [`Filter::Gauss`] to 3e-8 of value × the window's mass (see `gauss.rs`). A radius outside
/// 0.1..=16 is clamped, a non-finite one replaced by the paper's 2.3 px. The result is linear in
/// `value` (see [`Filter`]).
pub fn integrate(
    result: &AnalyticResult,
    filter: Filter,
    value: impl Fn(u32) -> f32 + Sync,
) -> Vec<f32> {
    match filter {
        Filter::Box => box_image(
            result.width,
            result.height,
            result.bin_size,
            &result.bins,
            &result.polygons,
            &value,
        ),
        Filter::Gauss { radius_px } => gauss_image(
            result.width,
            result.height,
            &result.bins,
            &result.polygons,
            if radius_px.is_finite() {
                radius_px.clamp(0.1, 16.0)
            } else {
                2.3
            },
            &value,
        ),
    }
}

/// A grey anti-aliased image of `result`: every triangle is shaded flat with a headlight,
/// `0.1 + 0.9 |cos θ|` (θ between its normal and the ray to its centroid), background 0; the
/// values are linear light (see [`Filter`]).
/// `scene` and `camera` must be the ones `result` was computed for.
pub fn antialiased_image(
    result: &AnalyticResult,
    scene: &Scene,
    camera: &Camera,
    filter: Filter,
) -> Vec<f32> {
    let shade: Vec<f32> = (0..scene.triangles.len())
        .map(|id| {
            let corners = scene.triangles[id].map(|i| scene.positions.get(i as usize).copied());
            let [Some(a), Some(b), Some(c)] = corners else {
                return 0.0;
            };
            let n = (b - a).cross(c - a).normalize_or_zero();
            let v = ((a + b + c) / 3.0 - camera.eye).normalize_or_zero();
            0.1 + 0.9 * n.dot(v).abs()
        })
        .collect();
    integrate(result, filter, |id| {
        shade.get(id as usize).copied().unwrap_or(0.0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn camera() -> Camera {
        Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 32, 32, 0.1).expect("camera")
    }

    #[test]
    fn empty_scene_sees_nothing() {
        let r = visible_fragments(&Scene::default(), &camera(), &AnalyticOptions::default())
            .expect("valid");
        assert_eq!(r.visible.count_ones(..), 0);
        assert!(r.polygons.is_empty());
        let img = integrate(&r, Filter::Box, |_| 1.0);
        assert!(img.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn empty_result_gives_black_images() {
        let scene = Scene::default();
        let r = visible_fragments(&scene, &camera(), &AnalyticOptions::default()).expect("valid");
        let img = antialiased_image(&r, &scene, &camera(), Filter::Box);
        assert!(img.len() == 32 * 32 && img.iter().all(|&v| v == 0.0));
        let img = integrate(
            &r,
            Filter::Gauss {
                radius_px: f64::NAN,
            },
            |_| 1.0,
        );
        assert!(img.len() == 32 * 32 && img.iter().all(|&v| v == 0.0));
        assert_eq!(r.visible_area(0), Vec::<f64>::new());
    }

    #[test]
    fn zero_bin_size_is_error() {
        let r = visible_fragments(
            &Scene::default(),
            &camera(),
            &AnalyticOptions {
                bin_size: 0,
                ..AnalyticOptions::default()
            },
        );
        assert_eq!(r.err(), Some(AnalyticError::BadBinSize(0)));
    }

    #[test]
    fn broken_camera_is_error() {
        let mut c = camera();
        c.width = 0;
        let r = visible_fragments(&Scene::default(), &c, &AnalyticOptions::default());
        assert!(matches!(r, Err(AnalyticError::BadCamera(_))));
        let mut c = camera();
        c.eye.x = f32::NAN;
        let r = visible_fragments(&Scene::default(), &c, &AnalyticOptions::default());
        assert!(matches!(r, Err(AnalyticError::BadCamera(_))));
    }
}
