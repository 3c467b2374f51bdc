//! Occlusion-order traversal of the grid cells inside a view frustum: slices perpendicular to
//! the dominant axis of the view direction, each slice's footprint of the frustum rasterized
//! row by row as a convex polygon, and the frustum split at the eye's cell so that no cell is
//! visited after a cell that can occlude it.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, sections 4.2.1 (axis-aligned slices along the largest view component), 4.2.2
//! (splitting the frustum at the eye's cell into 8 pieces, traversed fanning out), 4.2.4 (the
//! convex polygon slice and row rasterizer).
//!
//! # The order, precisely
//! Let `e` be the eye's cell (its coordinates may lie outside the grid). Along a view ray the
//! cell coordinate on each axis changes monotonically away from `e`, so a cell `a` can occlude
//! a cell `b` only if, on every axis `k`, `a_k` lies in the closed interval between `e_k` and
//! `b_k` ([`can_occlude`]). Per axis we visit coordinates in the order `e, e+1, e+2, ..` then
//! `e-1, e-2, ..` (the side the view looks to first), which is a linear extension of that
//! interval order on each axis; visiting slices, then rows, then cells lexicographically in
//! those per-axis orders is therefore a linear extension of [`can_occlude`]: the thesis'
//! split into 8 pieces traversed fanning out from the eye's cell, written as one loop.

use glam::{Vec2, Vec3};
use sightline_core::Camera;

use crate::grid::GridShape;

/// True when cell `a` can lie in front of cell `b` on a view ray from a point in cell `eye`:
/// on every axis, `a`'s coordinate is between `eye`'s and `b`'s (inclusive). A cell can
/// occlude itself by this definition.
pub fn can_occlude(eye: [i32; 3], a: [i32; 3], b: [i32; 3]) -> bool {
    (0..3).all(|k| {
        let (lo, hi) = (eye[k].min(b[k]), eye[k].max(b[k]));
        lo <= a[k] && a[k] <= hi
    })
}

/// Reusable buffers of the traversal (so a frame allocates nothing once warmed up).
#[derive(Clone, Debug, Default)]
pub struct Traversal {
    points: Vec<Vec2>,
    hull: Vec<Vec2>,
    slices: Vec<i32>,
    rows: Vec<i32>,
    cols: Vec<i32>,
}

/// The 12 edges of a frustum given as 4 near corners then 4 far corners (same order).
const EDGES: [(usize, usize); 12] = [
    (0, 1),
    (1, 2),
    (2, 3),
    (3, 0),
    (4, 5),
    (5, 6),
    (6, 7),
    (7, 4),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

/// Cells whose boundary is within this fraction of a cell of the frustum are included.
const SLACK: f32 = 1e-4;

impl Traversal {
    /// A traversal with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends to `out`, in occlusion order, the index of every cell of `shape` that the view
    /// frustum of `camera` (from its near plane to view depth `far`) touches. A `far` at or
    /// below the near plane, or not finite, visits nothing.
    pub fn visit(&mut self, shape: &GridShape, camera: &Camera, far: f32, out: &mut Vec<u32>) {
        if !(far > camera.near && far.is_finite()) {
            return;
        }
        let corners = frustum_corners(camera, far);
        let eye = shape.cell_of(camera.eye);
        let fwd = camera.forward;
        let dom = (0..3)
            .max_by(|&a, &b| fwd[a].abs().total_cmp(&fwd[b].abs()))
            .unwrap_or(0);
        let (a2, a3) = ((dom + 1) % 3, (dom + 2) % 3);
        let to_cell = |v: f32, k: usize| (v - shape.origin[k]) / shape.cell_size[k];
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for c in &corners {
            lo = lo.min(to_cell(c[dom], dom));
            hi = hi.max(to_cell(c[dom], dom));
        }
        let Some((s_lo, s_hi)) = clamp_range(lo, hi, shape.dims[dom]) else {
            return;
        };
        axis_order(eye[dom], s_lo, s_hi, fwd[dom] >= 0.0, &mut self.slices);
        for si in 0..self.slices.len() {
            let s = self.slices[si];
            let z0 = shape.origin[dom] + shape.cell_size[dom] * (s as f32 - SLACK);
            let z1 = shape.origin[dom] + shape.cell_size[dom] * (s as f32 + 1.0 + SLACK);
            // Vertices of frustum ∩ slab: corners inside it, edges crossing its two planes.
            self.points.clear();
            let flat = |p: Vec3| Vec2::new(p[a2], p[a3]);
            for c in &corners {
                if c[dom] >= z0 && c[dom] <= z1 {
                    self.points.push(flat(*c));
                }
            }
            for (i, j) in EDGES {
                let (p, q) = (corners[i], corners[j]);
                for z in [z0, z1] {
                    if (p[dom] - z) * (q[dom] - z) < 0.0 {
                        let t = (z - p[dom]) / (q[dom] - p[dom]);
                        self.points.push(flat(p + (q - p) * t));
                    }
                }
            }
            if self.points.is_empty() {
                continue;
            }
            convex_hull(&mut self.points, &mut self.hull);
            self.rasterize_slice(shape, [dom, a2, a3], s, eye, fwd, out);
        }
    }

    /// Rows of one slice: the range of the slice polygon within each row's strip.
    fn rasterize_slice(
        &mut self,
        shape: &GridShape,
        axes: [usize; 3],
        slice: i32,
        eye: [i32; 3],
        fwd: Vec3,
        out: &mut Vec<u32>,
    ) {
        let [dom, a2, a3] = axes;
        let to_cell = |v: f32, k: usize| (v - shape.origin[k]) / shape.cell_size[k];
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for p in &self.hull {
            lo = lo.min(to_cell(p.x, a2));
            hi = hi.max(to_cell(p.x, a2));
        }
        let Some((r_lo, r_hi)) = clamp_range(lo, hi, shape.dims[a2]) else {
            return;
        };
        axis_order(eye[a2], r_lo, r_hi, fwd[a2] >= 0.0, &mut self.rows);
        let n = self.hull.len();
        for &r in &self.rows {
            let y0 = shape.origin[a2] + shape.cell_size[a2] * (r as f32 - SLACK);
            let y1 = shape.origin[a2] + shape.cell_size[a2] * (r as f32 + 1.0 + SLACK);
            let (mut x_lo, mut x_hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for i in 0..n {
                let p = self.hull[i];
                if p.x >= y0 && p.x <= y1 {
                    x_lo = x_lo.min(p.y);
                    x_hi = x_hi.max(p.y);
                }
                let q = self.hull[(i + 1) % n];
                for y in [y0, y1] {
                    if (p.x - y) * (q.x - y) < 0.0 {
                        let x = p.y + (q.y - p.y) * ((y - p.x) / (q.x - p.x));
                        x_lo = x_lo.min(x);
                        x_hi = x_hi.max(x);
                    }
                }
            }
            let Some((c_lo, c_hi)) =
                clamp_range(to_cell(x_lo, a3), to_cell(x_hi, a3), shape.dims[a3])
            else {
                continue;
            };
            axis_order(eye[a3], c_lo, c_hi, fwd[a3] >= 0.0, &mut self.cols);
            for &c in &self.cols {
                let mut cell = [0u32; 3];
                cell[dom] = slice as u32;
                cell[a2] = r as u32;
                cell[a3] = c as u32;
                out.push(shape.index(cell));
            }
        }
    }
}

/// The near and far rectangles of the camera's frustum (far at view depth `far`).
pub fn frustum_corners(camera: &Camera, far: f32) -> [Vec3; 8] {
    let (tx, ty) = (camera.tan_half_x(), camera.tan_half_y());
    let mut out = [Vec3::ZERO; 8];
    for (k, d) in [camera.near, far].into_iter().enumerate() {
        for (i, (sx, sy)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .into_iter()
            .enumerate()
        {
            out[4 * k + i] = camera.eye
                + camera.forward * d
                + camera.right * (sx * tx * d)
                + camera.up * (sy * ty * d);
        }
    }
    out
}

/// Integer cell range `[floor(lo), floor(hi)]` (widened by [`SLACK`]) clamped to `0..n`.
fn clamp_range(lo: f32, hi: f32, n: u32) -> Option<(i32, i32)> {
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let a = (lo - SLACK).floor().max(0.0);
    let b = (hi + SLACK).floor().min(n as f32 - 1.0);
    (a <= b).then_some((a as i32, b as i32))
}

/// Coordinates `lo..=hi` ordered outward from `eye`: `eye` first, then the side the view
/// faces (`positive_first`), then the other side; an eye outside the range walks it from
/// the eye's end.
fn axis_order(eye: i32, lo: i32, hi: i32, positive_first: bool, out: &mut Vec<i32>) {
    out.clear();
    if eye < lo {
        out.extend(lo..=hi);
    } else if eye > hi {
        out.extend((lo..=hi).rev());
    } else if positive_first {
        out.extend(eye..=hi);
        out.extend((lo..eye).rev());
    } else {
        out.extend((lo..=eye).rev());
        out.extend(eye + 1..=hi);
    }
}

/// Andrew's monotone chain: the convex hull of `points` (which it sorts) into `hull`,
/// counter-clockwise; degenerate inputs give one or two points.
fn convex_hull(points: &mut [Vec2], hull: &mut Vec<Vec2>) {
    hull.clear();
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    for &p in points.iter() {
        while hull.len() >= 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    let lower = hull.len() + 1;
    for &p in points.iter().rev().skip(1) {
        while hull.len() >= lower && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    if hull.len() > 1 {
        hull.pop();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::Aabb;

    fn shape() -> GridShape {
        GridShape::new(
            &Aabb::new(Vec3::splat(-10.0), Vec3::splat(10.0)),
            [10, 10, 10],
        )
        .expect("shape")
    }

    #[test]
    fn far_at_near_plane_visits_nothing() {
        let cam = Camera::look_at(Vec3::ZERO, Vec3::X, Vec3::Z, 60.0, 64, 64, 0.1).expect("camera");
        let mut out = Vec::new();
        Traversal::new().visit(&shape(), &cam, 0.05, &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn eye_cell_comes_first() {
        let cam = Camera::look_at(
            Vec3::splat(0.5),
            Vec3::new(5.0, 1.0, 2.0),
            Vec3::Z,
            90.0,
            64,
            64,
            0.1,
        )
        .expect("camera");
        let mut out = Vec::new();
        Traversal::new().visit(&shape(), &cam, 100.0, &mut out);
        let s = shape();
        assert_eq!(out.first().copied(), Some(s.index([5, 5, 5])));
    }

    #[test]
    fn camera_looking_away_from_grid_visits_nothing() {
        let cam = Camera::look_at(
            Vec3::new(0.0, 0.0, 30.0),
            Vec3::new(0.0, 0.0, 40.0),
            Vec3::X,
            60.0,
            64,
            64,
            0.1,
        )
        .expect("camera");
        let mut out = Vec::new();
        Traversal::new().visit(&shape(), &cam, 1000.0, &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn hull_of_square_with_inner_point() {
        let mut pts = vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y, Vec2::splat(0.5)];
        let mut hull = Vec::new();
        convex_hull(&mut pts, &mut hull);
        assert_eq!(hull.len(), 4);
    }

    #[test]
    fn axis_order_fans_out_from_eye() {
        let mut v = Vec::new();
        axis_order(3, 0, 5, true, &mut v);
        assert_eq!(v, vec![3, 4, 5, 2, 1, 0]);
        axis_order(3, 0, 5, false, &mut v);
        assert_eq!(v, vec![3, 2, 1, 0, 4, 5]);
        axis_order(-2, 0, 2, false, &mut v);
        assert_eq!(v, vec![0, 1, 2]);
    }

    #[test]
    fn can_occlude_is_between_eye_and_target() {
        assert!(can_occlude([0, 0, 0], [1, 0, 0], [3, 2, 0]));
        assert!(!can_occlude([0, 0, 0], [4, 0, 0], [3, 2, 0]));
        assert!(!can_occlude([0, 0, 0], [-1, 0, 0], [3, 2, 0]));
    }
}
