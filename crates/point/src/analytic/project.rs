//! Projection and frustum clipping: world → view space (f64) → clip against the near plane and
//! the four side planes of the view frustum → project with exactly the mapping of
//! [`sightline_core::camera`] → snap to the analytic grid of [`GRID`] units per pixel.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 3 (the input is the projected scene triangles) and section 4.3 (setup).
//!
//! Clipping happens in view space, before the division by depth, so a triangle that crosses the
//! near plane never produces huge screen coordinates. A crossing edge is always cut by
//! interpolating from its inside end towards its outside end (as `raster/clip.rs` does), so two
//! triangles sharing an edge get bit-identical cut points and stay watertight.

use glam::{DVec2, DVec3};
use sightline_core::camera::ScreenMapping;
use sightline_core::{Camera, Scene};

use super::predicates::Pt;

/// Grid units per pixel: screen positions are snapped to `1 / GRID` px (2^-20 px, about 1e-6
/// px). Images are at most 16384 = 2^14 px wide, so grid coordinates stay below 2^34 (exact in
/// `f64`) and every cross product of grid differences is below 2^71: exact in `i128`, and in
/// `f64` whenever the float filter of `predicates.rs` accepts it.
pub(crate) const GRID: f64 = 1_048_576.0;

/// Grid units within which an edge of a polygon counts as collinear with the edge being
/// intersected. Snapping moves every vertex by up to half a grid unit per coordinate, so two
/// edges on one 3D line (the vertical corner of two walls of different heights, a T-junction)
/// end up a grid unit or so apart at a tiny angle. Taken as crossing, such an edge would make
/// the other polygon cover both sides over a sliver 1e-6 px wide, and the depth slopes at the
/// two edges would each hide the other: both polygons' boundaries would vanish there.
pub(crate) const NEAR_COLLINEAR_GRID: f64 = 2.0;

/// Most vertices of a frustum-clipped triangle: 3 plus one per clipping plane (near + 4 sides).
pub(crate) const MAX_CLIPPED: usize = 8;

/// A projected, clipped and snapped triangle: a convex polygon on the grid with positive area
/// (counter-clockwise in the `cross(b - a, c - a) > 0` sense of screen space, y down), and the
/// plane of its triangle as `1/z = plane[0] * sx + plane[1] * sy + plane[2]` over screen
/// pixels (larger `1/z` is nearer).
#[derive(Clone, Debug)]
pub(crate) struct ScreenPoly {
    /// Triangle id.
    pub(crate) id: u32,
    /// Vertices in grid units, no two consecutive equal.
    pub(crate) verts: Vec<Pt>,
    /// `1/z` plane over screen pixels.
    pub(crate) plane: [f64; 3],
    /// Relative uncertainty of the polygon's `1/z` from its f32 input: [`F32_NOISE`] times its
    /// largest world coordinate over its smallest view depth. Two polygons
    /// whose depths differ by less are coincident as far as the input can tell.
    pub(crate) noise: f64,
    /// Grid units within which another polygon's edge counts as collinear with one of this
    /// polygon's edges: the snapping (see [`NEAR_COLLINEAR_GRID`]), or one ulp of the
    /// largest coordinate seen at the smallest depth when that is more. Two f32 copies of one
    /// 3D corner (one ulp apart) are one line as far as the input can tell.
    pub(crate) collinear_grid: f64,
}

/// Rounding of an f32 coordinate, relative to its magnitude (two ulps: the vertex was
/// rounded once when stored, and once more by whatever produced it).
pub(crate) const F32_NOISE: f64 = 1.0 / (1u64 << 22) as f64;

/// The camera mapping of `camera.rs` in f64: `sightline_core::camera::ScreenMapping`, the one
/// the rasterizer uses, plus this algorithm's clipping helpers.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Projection(ScreenMapping);

impl std::ops::Deref for Projection {
    type Target = ScreenMapping;

    fn deref(&self) -> &ScreenMapping {
        &self.0
    }
}

impl Projection {
    /// The mapping of `camera`.
    pub(crate) fn new(camera: &Camera) -> Self {
        Self(ScreenMapping::new(camera))
    }

    /// The five clip planes as signed distances (inside is `>= 0`): near, left, right, top,
    /// bottom. The side planes `|x| <= z tan_x` map exactly to `0 <= sx <= width`.
    fn plane_value(&self, k: usize, v: DVec3) -> f64 {
        match k {
            0 => v.z - self.near,
            1 => v.z * self.tan_half_x + v.x,
            2 => v.z * self.tan_half_x - v.x,
            3 => v.z * self.tan_half_y + v.y,
            _ => v.z * self.tan_half_y - v.y,
        }
    }

    /// Clips a view-space triangle to the frustum (Sutherland–Hodgman, one pass per plane).
    /// Returns fewer than 3 vertices when nothing is left.
    pub(crate) fn clip(&self, tri: [DVec3; 3]) -> Vec<DVec3> {
        let mut poly: Vec<DVec3> = tri.to_vec();
        let mut next = Vec::with_capacity(MAX_CLIPPED);
        for k in 0..5 {
            next.clear();
            let n = poly.len();
            for i in 0..n {
                let cur = poly[i];
                let nxt = poly[(i + 1) % n];
                let (fc, fn_) = (self.plane_value(k, cur), self.plane_value(k, nxt));
                let (ci, ni) = (fc >= 0.0, fn_ >= 0.0);
                if ci {
                    next.push(cur);
                }
                if ci != ni {
                    // Always from the inside point towards the outside point (watertightness).
                    let (i_pt, o_pt, fi, fo) = if ci {
                        (cur, nxt, fc, fn_)
                    } else {
                        (nxt, cur, fn_, fc)
                    };
                    let t = fi / (fi - fo);
                    let mut p = i_pt + (o_pt - i_pt) * t;
                    if k == 0 {
                        p.z = self.near;
                    }
                    next.push(p);
                }
            }
            std::mem::swap(&mut poly, &mut next);
            if poly.len() < 3 {
                poly.clear();
                return poly;
            }
        }
        poly
    }

    /// Snaps a screen position (pixels) to the grid, clamped to the image (the side planes put
    /// clipped points on the image border up to rounding).
    pub(crate) fn snap(&self, s: DVec2) -> Pt {
        let x = s.x.clamp(0.0, self.width) * GRID;
        let y = s.y.clamp(0.0, self.height) * GRID;
        [x.round() as i64, y.round() as i64]
    }
}

/// What became of one scene triangle in projection.
#[derive(Clone, Debug)]
pub(crate) enum Projected {
    /// In the frustum with positive snapped area.
    Poly(ScreenPoly),
    /// Out of the frustum, edge-on, or smaller than the grid: covers no area of the image.
    Empty,
    /// Out-of-range indices or non-finite corners: skipped with a warning.
    Invalid,
}

/// Projects triangle `id` of `scene`.
pub(crate) fn project_triangle(scene: &Scene, proj: &Projection, id: u32) -> Projected {
    let Some(tri) = scene.triangles.get(id as usize) else {
        return Projected::Invalid;
    };
    let mut corners = [DVec3::ZERO; 3];
    // The vertices' own rounding: the eye's is a common shift of every triangle, which
    // changes no depth order (the view transform itself is exact enough in f64).
    let mut magnitude = 0.0f64;
    for (c, &i) in corners.iter_mut().zip(tri) {
        match scene.positions.get(i as usize) {
            Some(p) if p.is_finite() => {
                *c = proj.view_of(p.as_dvec3());
                magnitude = magnitude.max(f64::from(p.abs().max_element()));
            }
            _ => return Projected::Invalid,
        }
    }
    let Some(plane) = proj.inv_z_plane(corners[0], corners[1], corners[2]) else {
        return Projected::Empty;
    };
    let clipped = proj.clip(corners);
    if clipped.len() < 3 {
        return Projected::Empty;
    }
    let nearest = clipped.iter().map(|v| v.z).fold(f64::INFINITY, f64::min);
    let noise = F32_NOISE * magnitude / nearest.max(proj.near);
    // F32_NOISE is two ulps of the magnitude; the projection scales angles by the focal length.
    let focal_px = proj.height / (2.0 * proj.tan_half_y);
    let ulp_grid = 0.5 * noise * focal_px * GRID;
    let collinear_grid = NEAR_COLLINEAR_GRID.max(ulp_grid);
    let mut verts: Vec<Pt> = Vec::with_capacity(clipped.len());
    for v in clipped {
        let s = proj.screen_of(v);
        if !s.is_finite() {
            return Projected::Empty;
        }
        let p = proj.snap(s);
        if verts.last() != Some(&p) {
            verts.push(p);
        }
    }
    while verts.len() > 1 && verts.first() == verts.last() {
        verts.pop();
    }
    let area = super::predicates::twice_area(&verts);
    if area == 0 {
        return Projected::Empty;
    }
    if area < 0 {
        // Double-sided triangles: every polygon is made counter-clockwise (interior on the left).
        verts.reverse();
    }
    Projected::Poly(ScreenPoly {
        id,
        verts,
        plane,
        noise,
        collinear_grid,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn camera() -> Camera {
        Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0, 100, 100, 0.1).expect("camera")
    }

    fn one_triangle(a: Vec3, b: Vec3, c: Vec3) -> Scene {
        let mut builder = sightline_core::scene::SceneBuilder::new("t");
        let i = [
            builder.add_vertex(a),
            builder.add_vertex(b),
            builder.add_vertex(c),
        ];
        builder.add_triangle(i);
        builder.finish()
    }

    #[test]
    fn triangle_in_view_projects_counter_clockwise() {
        let s = one_triangle(
            Vec3::new(-1.0, -1.0, -2.0),
            Vec3::new(1.0, -1.0, -2.0),
            Vec3::new(0.0, 1.0, -2.0),
        );
        let Projected::Poly(p) = project_triangle(&s, &Projection::new(&camera()), 0) else {
            panic!("expected a polygon");
        };
        assert_eq!(p.verts.len(), 3);
        assert!(super::super::predicates::twice_area(&p.verts) > 0);
        // Screen centre column 50 px, corner (-1,-1,-2) at x = 25 px.
        assert!(p.verts.contains(&[25 * GRID as i64, 75 * GRID as i64]));
    }

    #[test]
    fn triangle_behind_eye_is_empty() {
        let s = one_triangle(
            Vec3::new(-1.0, -1.0, 2.0),
            Vec3::new(1.0, -1.0, 2.0),
            Vec3::new(0.0, 1.0, 2.0),
        );
        let r = project_triangle(&s, &Projection::new(&camera()), 0);
        assert!(matches!(r, Projected::Empty));
    }

    #[test]
    fn triangle_crossing_near_plane_is_clipped_inside_image() {
        let s = one_triangle(
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, -3.0),
            Vec3::new(0.0, 1.0, -3.0),
        );
        let Projected::Poly(p) = project_triangle(&s, &Projection::new(&camera()), 0) else {
            panic!("expected a polygon");
        };
        let max = 100 * GRID as i64;
        assert!(p
            .verts
            .iter()
            .all(|v| (0..=max).contains(&v[0]) && (0..=max).contains(&v[1])));
    }

    #[test]
    fn edge_on_triangle_is_empty() {
        // The plane x = 0 passes through the eye.
        let s = one_triangle(
            Vec3::new(0.0, -1.0, -2.0),
            Vec3::new(0.0, 1.0, -2.0),
            Vec3::new(0.0, 0.0, -4.0),
        );
        let r = project_triangle(&s, &Projection::new(&camera()), 0);
        assert!(matches!(r, Projected::Empty));
    }

    #[test]
    fn invalid_index_is_invalid() {
        let mut s = Scene::default();
        s.triangles.push([0, 1, 2]);
        let r = project_triangle(&s, &Projection::new(&camera()), 0);
        assert!(matches!(r, Projected::Invalid));
    }
}
