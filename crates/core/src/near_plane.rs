//! The default near-plane distance: one rule for every command, the Python API and the
//! samplers that render from many eyes, and a check of how much of a view a near plane hides.
//!
//! # The rule
//! `near = clamp(d / 100, floor, cap)`, where
//! - `d` is the distance from the eye (or from the box holding every eye of a path or a view
//!   cell) to the nearest triangle. A point's view depth never exceeds its distance from the
//!   eye, so a near plane below `d` clips no geometry at all; the factor 1/100 leaves room for
//!   a camera that moves closer than where the near plane was chosen (the viewer's fly camera
//!   keeps its starting near plane).
//! - `cap` is 1e-4 of the scene's bounding-box diagonal, the default before issue 16: a camera
//!   away from the geometry keeps the near plane it always had, so ordinary views render as
//!   before.
//! - `floor` is 1e-4 of the median longest edge of the scene's triangles: when the eye touches
//!   a surface (`d` = 0) the near plane is still a small, positive length set by the scene's
//!   typical triangles rather than by its largest one.
//!
//! The diagonal alone is not enough: one huge triangle (a 2,000 km ground under a 2-unit box)
//! makes 1e-4 of the diagonal (283 units) larger than the distance to everything in view, and
//! the near plane then clipped every triangle: every method returned an empty set.

use std::sync::OnceLock;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::camera::Camera;
use crate::geometry::Aabb;
use crate::scene::Scene;

/// The near plane is this fraction of the distance from the eye to the nearest triangle.
pub const DISTANCE_FRACTION: f64 = 1e-2;
/// The near plane is at most this fraction of the scene's bounding-box diagonal.
pub const DIAGONAL_FRACTION: f32 = 1e-4;
/// The near plane is at least this fraction of the median longest edge of the triangles.
pub const TRIANGLE_FRACTION: f32 = 1e-4;

/// Triangles per parallel task of the scans below (a task keeps its own running minimum, so
/// most triangles are rejected by a box test against it).
const CHUNK: usize = 4096;

/// The default near plane of one scene (see the module documentation for the rule). Each
/// query scans the triangles; the floor (the median edge, one more scan) is found on the first
/// query that needs it, as a camera away from the geometry only needs the cap.
#[derive(Clone, Debug)]
pub struct NearPlaneRule<'a> {
    scene: &'a Scene,
    floor: OnceLock<f32>,
    cap: f32,
}

impl<'a> NearPlaneRule<'a> {
    /// The rule for `scene`.
    pub fn new(scene: &'a Scene) -> Self {
        // The same guard as the old default: a zero-size scene still gets a positive plane.
        let cap = scene.bounds().diagonal().max(1e-6) * DIAGONAL_FRACTION;
        Self {
            scene,
            floor: OnceLock::new(),
            cap,
        }
    }

    /// The smallest near plane the rule gives (eye on a surface).
    pub fn floor(&self) -> f32 {
        *self
            .floor
            .get_or_init(|| match median_longest_edge(self.scene) {
                // Positive, and never above the cap (no edge is longer than the diagonal, but
                // rounding could make it so).
                Some(edge) => (edge * TRIANGLE_FRACTION)
                    .max(f32::MIN_POSITIVE)
                    .min(self.cap),
                // No triangle with a length: nothing can be clipped, any plane will do.
                None => self.cap,
            })
    }

    /// The largest near plane the rule gives (eye far from the geometry).
    pub fn cap(&self) -> f32 {
        self.cap
    }

    /// The near plane for a camera at `eye`.
    pub fn at(&self, eye: Vec3) -> f32 {
        self.for_distance(nearest_distance(self.scene, eye))
    }

    /// One near plane for cameras at all of `eyes` (a camera path): the smallest of theirs.
    /// The cap when `eyes` is empty.
    pub fn along(&self, eyes: &[Vec3]) -> f32 {
        eyes.iter().map(|&e| self.at(e)).fold(self.cap, f32::min)
    }

    /// One near plane for cameras anywhere in `region` (a view cell's bounds), from a lower
    /// bound of the distance between `region` and the triangles (their bounding boxes).
    pub fn within(&self, region: &Aabb) -> f32 {
        self.for_distance(region_distance(self.scene, region))
    }

    /// The rule's plane for nearest geometry at distance `d` (infinite or NaN: the cap).
    pub fn for_distance(&self, d: f64) -> f32 {
        if !d.is_finite() {
            return self.cap;
        }
        let near = (d * DISTANCE_FRACTION) as f32;
        if near >= self.cap {
            self.cap
        } else {
            near.max(self.floor())
        }
    }
}

/// The default near plane of a camera at `eye` in `scene` ([`NearPlaneRule::at`]).
pub fn default_near(scene: &Scene, eye: Vec3) -> f32 {
    NearPlaneRule::new(scene).at(eye)
}

/// The corners of triangle `t`, `None` when an index is out of range or a corner not finite
/// (such triangles are never drawn, so they must not decide the near plane).
fn corners(scene: &Scene, t: &[u32; 3]) -> Option<[Vec3; 3]> {
    let p = |i: u32| {
        scene
            .positions
            .get(i as usize)
            .copied()
            .filter(|v| v.is_finite())
    };
    Some([p(t[0])?, p(t[1])?, p(t[2])?])
}

/// The median over the triangles of their longest edge, leaving out zero-length ones.
fn median_longest_edge(scene: &Scene) -> Option<f32> {
    let mut edges: Vec<f32> = scene
        .triangles
        .par_iter()
        .filter_map(|t| {
            let [a, b, c] = corners(scene, t)?;
            let e = a.distance(b).max(b.distance(c)).max(c.distance(a));
            (e > 0.0 && e.is_finite()).then_some(e)
        })
        .collect();
    if edges.is_empty() {
        return None;
    }
    let mid = edges.len() / 2;
    Some(*edges.select_nth_unstable_by(mid, f32::total_cmp).1)
}

/// Squared distance between two boxes (0 when they overlap), in f64.
fn box_distance_squared(a_min: DVec3, a_max: DVec3, b_min: DVec3, b_max: DVec3) -> f64 {
    let gap = (a_min - b_max).max(b_min - a_max).max(DVec3::ZERO);
    gap.length_squared()
}

/// The Euclidean distance from `eye` to the nearest triangle of `scene` (infinite when it has
/// none, or `eye` is not finite).
pub fn nearest_distance(scene: &Scene, eye: Vec3) -> f64 {
    if !eye.is_finite() {
        return f64::INFINITY;
    }
    let p = eye.as_dvec3();
    let best = scene
        .triangles
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut best = f64::INFINITY;
            for t in chunk {
                let Some([a, b, c]) = corners(scene, t) else {
                    continue;
                };
                let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
                // The triangle's box bounds its distance from below: skip the exact test when
                // even the box is farther than the nearest triangle so far.
                if box_distance_squared(p, p, a.min(b).min(c), a.max(b).max(c)) >= best {
                    continue;
                }
                best = best.min(closest_point_on_triangle(p, a, b, c).distance_squared(p));
            }
            best
        })
        .reduce(|| f64::INFINITY, f64::min);
    best.sqrt()
}

/// A lower bound of the distance from `region` to the nearest triangle: the distance to the
/// nearest triangle's bounding box (infinite when there is none).
fn region_distance(scene: &Scene, region: &Aabb) -> f64 {
    if region.is_empty() || !(region.min.is_finite() && region.max.is_finite()) {
        return f64::INFINITY;
    }
    let (lo, hi) = (region.min.as_dvec3(), region.max.as_dvec3());
    scene
        .triangles
        .par_iter()
        .filter_map(|t| {
            let [a, b, c] = corners(scene, t)?;
            let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
            Some(box_distance_squared(
                lo,
                hi,
                a.min(b).min(c),
                a.max(b).max(c),
            ))
        })
        .reduce(|| f64::INFINITY, f64::min)
        .sqrt()
}

/// The closest point to `p` on segment `a b`.
fn closest_point_on_segment(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 == 0.0 {
        return a;
    }
    a + ab * ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
}

/// The closest point to `p` on triangle `a b c`.
///
/// Based on: Ericson. Real-Time Collision Detection, 2005, section 5.1.5 (Voronoi regions of
/// the corners and edges, else the projection onto the plane).
fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    let q = a + ab * (vb / denom) + ac * (vc / denom);
    if q.is_finite() {
        q
    } else {
        // A degenerate (collinear) triangle reaches the interior case with a zero
        // denominator: its closest point is on one of its edges.
        [
            closest_point_on_segment(p, a, b),
            closest_point_on_segment(p, b, c),
            closest_point_on_segment(p, c, a),
        ]
        .into_iter()
        .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
        .unwrap_or(a)
    }
}

/// How much of a camera's view its near plane hides.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NearClipping {
    /// Triangles with a part inside the camera's view frustum (its four side planes; no near
    /// or far plane), whether occluded or not.
    pub in_frustum: usize,
    /// Of those, the triangles whose whole part inside the frustum is nearer than the near
    /// plane: no method can report them visible from this camera.
    pub hidden: usize,
}

/// Counts the triangles in `camera`'s view frustum and those of them its near plane hides
/// entirely (see [`NearClipping`]). Tested in f64 in view space. Degenerate triangles and
/// those seen edge-on (their plane through the eye) are left out: they cover no area from this
/// eye whatever the near plane, so hiding them loses nothing.
pub fn near_clipping(scene: &Scene, camera: &Camera) -> NearClipping {
    let (eye, right, up, forward) = (
        camera.eye.as_dvec3(),
        camera.right.as_dvec3(),
        camera.up.as_dvec3(),
        camera.forward.as_dvec3(),
    );
    let (tx, ty) = (
        f64::from(camera.tan_half_x()),
        f64::from(camera.tan_half_y()),
    );
    let near = f64::from(camera.near);
    let view = |v: Vec3| {
        let d = v.as_dvec3() - eye;
        DVec3::new(d.dot(right), d.dot(up), d.dot(forward))
    };
    // The side planes as `n·v >= 0` in view space: |x| <= z tan_x, |y| <= z tan_y (they also
    // keep z >= 0).
    let planes = [
        DVec3::new(-1.0, 0.0, tx),
        DVec3::new(1.0, 0.0, tx),
        DVec3::new(0.0, -1.0, ty),
        DVec3::new(0.0, 1.0, ty),
    ];
    scene
        .triangles
        .par_iter()
        .filter_map(|t| corners(scene, t))
        .map(|[a, b, c]| {
            let tri = [view(a), view(b), view(c)];
            if edge_on(tri) {
                return NearClipping::default();
            }
            match farthest_depth_in_frustum(tri, &planes) {
                None => NearClipping::default(),
                Some(z_max) => NearClipping {
                    in_frustum: 1,
                    hidden: usize::from(z_max < near),
                },
            }
        })
        .reduce(NearClipping::default, |x, y| NearClipping {
            in_frustum: x.in_frustum + y.in_frustum,
            hidden: x.hidden + y.hidden,
        })
}

/// True when view-space triangle `tri` is degenerate or its plane passes through the eye (the
/// origin), to the rounding of f32 input: its distance from the eye's plane is at most 1e-7 of
/// its corners' distance from the eye.
fn edge_on([a, b, c]: [DVec3; 3]) -> bool {
    let n = (b - a).cross(c - a);
    let scale = a.length().max(b.length()).max(c.length());
    let len = n.length();
    len == 0.0 || n.dot(a).abs() <= 1e-7 * len * scale
}

/// The largest view depth of the part of view-space triangle `tri` inside all of `planes`
/// (`n·v >= 0`), `None` when no part is inside.
fn farthest_depth_in_frustum(tri: [DVec3; 3], planes: &[DVec3; 4]) -> Option<f64> {
    let inside_all = |v: &DVec3| planes.iter().all(|n| n.dot(*v) >= 0.0);
    if tri.iter().all(inside_all) {
        return Some(tri[0].z.max(tri[1].z).max(tri[2].z));
    }
    if planes.iter().any(|n| tri.iter().all(|v| n.dot(*v) < 0.0)) {
        return None;
    }
    // Sutherland-Hodgman against each plane: a triangle gains at most one vertex per plane.
    let mut poly: Vec<DVec3> = tri.to_vec();
    for n in planes {
        let mut next = Vec::with_capacity(poly.len() + 1);
        for (i, &p) in poly.iter().enumerate() {
            let q = poly[(i + 1) % poly.len()];
            let (dp, dq) = (n.dot(p), n.dot(q));
            if dp >= 0.0 {
                next.push(p);
            }
            if (dp >= 0.0) != (dq >= 0.0) {
                next.push(p + (q - p) * (dp / (dp - dq)));
            }
        }
        poly = next;
        if poly.is_empty() {
            return None;
        }
    }
    poly.iter().map(|v| v.z).reduce(f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneBuilder;

    /// A ground quad (two triangles, z = 0) reaching `half` from the origin each way, and a
    /// 2-unit box standing on it at the origin.
    fn ground_and_box(half: f32) -> Scene {
        let mut b = SceneBuilder::new("ground and box");
        b.set_up(crate::scene::UpAxis::Z);
        let v = [(-half, -half), (half, -half), (half, half), (-half, half)]
            .map(|(x, y)| b.add_vertex(Vec3::new(x, y, 0.0)));
        b.add_triangle([v[0], v[1], v[2]]);
        b.add_triangle([v[0], v[2], v[3]]);
        b.add_box(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 2.0));
        b.finish()
    }

    /// The scene of issue 16: a 2,000 km ground under the 2-unit box.
    fn huge_ground() -> Scene {
        ground_and_box(1.0e6)
    }

    /// The 2-unit box alone.
    fn box_only() -> Scene {
        let mut b = SceneBuilder::new("box");
        b.set_up(crate::scene::UpAxis::Z);
        b.add_box(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 2.0));
        b.finish()
    }

    /// The longest edge of the box's triangles: a face diagonal.
    const BOX_EDGE: f32 = 2.828_427;

    #[test]
    fn huge_ground_gives_a_near_plane_far_below_the_distance_to_the_box() {
        let scene = huge_ground();
        // 5 units from the box's nearest edge, 1.5 above the ground.
        let eye = Vec3::new(5.0, -4.0, 1.5);
        let old = scene.bounds().diagonal() * 1e-4;
        assert!(
            old > 50.0 * 5.0,
            "the old default ({old}) lies far behind the box"
        );
        assert!((nearest_distance(&scene, eye) - 1.5).abs() < 1e-9);
        let near = default_near(&scene, eye);
        assert!(
            (near - 0.015).abs() < 1e-6,
            "near {near}: 1/100 of the height"
        );
        let camera =
            Camera::look_at(eye, Vec3::new(0.0, 0.0, 1.0), Vec3::Z, 60.0, 64, 48, near).unwrap();
        let clip = near_clipping(&scene, &camera);
        // The whole box (12 triangles) and both ground triangles are in the frustum.
        assert_eq!(
            clip,
            NearClipping {
                in_frustum: 14,
                hidden: 0
            }
        );
        // The old near plane hides all of the box and the ground triangle under the eye (the
        // diagonal x = y cuts it off within 9 units in view); only the other ground triangle
        // reaches past it.
        let old_clip = near_clipping(
            &scene,
            &Camera {
                near: old,
                ..camera
            },
        );
        assert_eq!(
            old_clip,
            NearClipping {
                in_frustum: 14,
                hidden: 13
            }
        );
    }

    #[test]
    fn ordinary_scene_keeps_the_old_default_away_from_geometry() {
        // A 100-unit ground and the box: diagonal 141, old default 0.0141.
        let scene = ground_and_box(50.0);
        let rule = NearPlaneRule::new(&scene);
        let old = scene.bounds().diagonal() * 1e-4;
        assert_eq!(rule.cap(), old);
        // 20 units above the ground: 1/100 of that is above the cap, which is kept.
        assert_eq!(rule.at(Vec3::new(30.0, 0.0, 20.0)), old);
        // 0.5 from a face: 1/100 of the distance, below the cap.
        let close = rule.at(Vec3::new(1.5, 0.0, 1.0));
        assert!((close - 0.005).abs() < 1e-7, "{close}");
        // On a face: the floor, 1e-4 of the median longest edge (12 box triangles outvote the
        // 2 ground ones).
        let on = rule.at(Vec3::new(1.0, 0.0, 1.0));
        assert!((on - BOX_EDGE * 1e-4).abs() < 1e-8, "{on}");
        assert_eq!(on, rule.floor());
        // A path takes the smallest plane of its eyes.
        let path = rule.along(&[Vec3::new(30.0, 0.0, 20.0), Vec3::new(1.5, 0.0, 1.0)]);
        assert_eq!(path, close);
        assert_eq!(rule.along(&[]), old);
    }

    #[test]
    fn floor_follows_typical_triangles_not_the_largest() {
        let scene = huge_ground();
        let huge = NearPlaneRule::new(&scene);
        assert_eq!(huge.floor(), NearPlaneRule::new(&box_only()).floor());
        assert!(huge.cap() > 1e5 * huge.floor());
    }

    #[test]
    fn region_rule_stays_below_its_distance_to_the_geometry() {
        let scene = huge_ground();
        let rule = NearPlaneRule::new(&scene);
        // A cell 3 units from the box and 0.5 above the ground.
        let cell = Aabb::new(Vec3::new(4.0, -1.0, 0.5), Vec3::new(6.0, 1.0, 1.5));
        assert!((rule.within(&cell) - 0.005).abs() < 1e-7);
        // A cell on the ground: the floor.
        let low = Aabb::new(Vec3::new(4.0, -1.0, 0.0), Vec3::new(6.0, 1.0, 1.5));
        assert_eq!(rule.within(&low), rule.floor());
    }

    #[test]
    fn empty_scene_gets_a_positive_plane() {
        let scene = Scene::default();
        let near = default_near(&scene, Vec3::ZERO);
        assert!(near > 0.0 && near.is_finite(), "{near}");
    }

    #[test]
    fn closest_points_of_corner_edge_and_face_regions() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let q = |p: DVec3| closest_point_on_triangle(p, a, b, c);
        assert_eq!(q(DVec3::new(0.25, 0.5, 5.0)), DVec3::new(0.25, 0.5, 0.0));
        assert_eq!(q(DVec3::new(-1.0, -1.0, 1.0)), a);
        assert_eq!(q(DVec3::new(2.0, -0.5, 0.0)), b);
        assert_eq!(q(DVec3::new(0.5, -2.0, 0.0)), DVec3::new(0.5, 0.0, 0.0));
        assert_eq!(q(DVec3::new(1.0, 1.0, 0.0)), DVec3::new(0.5, 0.5, 0.0));
        // Collinear corners: the nearest point of the segment they span.
        let line = closest_point_on_triangle(DVec3::new(0.5, 1.0, 0.0), a, b, DVec3::X * 2.0);
        assert_eq!(line, DVec3::new(0.5, 0.0, 0.0));
    }

    #[test]
    fn closest_point_is_no_farther_than_any_sampled_point_of_the_triangle() {
        let mut rng = crate::random::SplitMix64::new(16);
        let mut coordinate = || f64::from(rng.range_f32(-2.0, 2.0));
        let mut r = || DVec3::new(coordinate(), coordinate(), coordinate());
        for _ in 0..200 {
            let (p, a, b, c) = (r(), r(), r(), r());
            let q = closest_point_on_triangle(p, a, b, c);
            let d = q.distance(p);
            // q lies on the triangle: inside its plane's barycentric range.
            let n = (b - a).cross(c - a);
            assert!(
                (q - a).dot(n).abs() <= 1e-9 * n.length() * 4.0,
                "off the plane"
            );
            let mut sampled = f64::INFINITY;
            for i in 0..=40 {
                for j in 0..=(40 - i) {
                    let (u, v) = (f64::from(i) / 40.0, f64::from(j) / 40.0);
                    let s = a + (b - a) * u + (c - a) * v;
                    sampled = sampled.min(s.distance(p));
                }
            }
            // No sample is nearer, and the nearest sample is within the grid's spacing.
            let spacing = (b - a).length().max((c - a).length()) / 40.0;
            assert!(d <= sampled + 1e-9, "{d} > sampled {sampled}");
            assert!(
                sampled - d <= 2.0 * spacing,
                "{d} far below sampled {sampled}"
            );
        }
    }

    #[test]
    fn only_triangles_in_the_frustum_count() {
        let scene = box_only();
        let eye = Vec3::new(5.0, 0.0, 1.0);
        let camera = |look: Vec3, near: f32| {
            Camera::look_at(eye, look, Vec3::Z, 60.0, 64, 48, near).unwrap()
        };
        // Looking away from the box.
        let away = camera(Vec3::new(10.0, 0.0, 1.0), 50.0);
        assert_eq!(near_clipping(&scene, &away), NearClipping::default());
        // Looking at it with the near plane past the box: every triangle in view is hidden.
        let past = near_clipping(&scene, &camera(Vec3::new(0.0, 0.0, 1.0), 50.0));
        assert_eq!(
            past,
            NearClipping {
                in_frustum: 12,
                hidden: 12
            }
        );
        // A near plane cutting through the box hides its near face (x = 1, 4 units away)
        // but not the far one.
        let cut = near_clipping(&scene, &camera(Vec3::new(0.0, 0.0, 1.0), 4.5));
        assert_eq!(cut.in_frustum, 12);
        assert_eq!(cut.hidden, 2, "{cut:?}");
        // In front of the box nothing is hidden.
        let fine = near_clipping(&scene, &camera(Vec3::new(0.0, 0.0, 1.0), 1.0));
        assert_eq!(fine.hidden, 0);
    }

    #[test]
    fn triangles_seen_edge_on_do_not_count() {
        let scene = box_only();
        // In the plane of the face x = 1, 2 units beside the box, looking along that plane at
        // it: all 12 triangles are in the frustum, but the face's 2 are seen edge-on and no
        // near plane hides anything of them.
        let eye = Vec3::new(1.0, 3.0, 1.0);
        let camera =
            |near: f32| Camera::look_at(eye, eye - Vec3::Y, Vec3::Z, 60.0, 64, 48, near).unwrap();
        let past = near_clipping(&scene, &camera(10.0));
        assert_eq!(
            past,
            NearClipping {
                in_frustum: 10,
                hidden: 10
            }
        );
        assert_eq!(near_clipping(&scene, &camera(1.0)).hidden, 0);
    }
}
