//! References for the exact analytic visibility, shared by its integration tests: the reference
//! rasterizer at 16×16 supersampling, and an independent brute force (an exact trapezoidal
//! arrangement of every projected triangle and every projected intersection segment, nearest
//! triangle per cell) for scenes below a few hundred triangles.
#![allow(dead_code, clippy::unwrap_used)]

use glam::{DVec2, DVec3, Vec3};
use sightline_core::raster::render;
use sightline_core::{Camera, Scene};
use sightline_point::analytic::{integrate, visible_fragments, AnalyticOptions, Filter};

pub fn scaled(c: &Camera, k: u32) -> Camera {
    Camera::looking(
        c.eye,
        c.forward,
        c.up,
        c.fov_y_deg,
        c.width * k,
        c.height * k,
        c.near,
    )
    .unwrap()
}

/// A per-triangle value in [0.2, 1] (hashed), so that a wrong triangle changes the pixel.
pub fn value(id: u32) -> f32 {
    let h = id
        .wrapping_mul(0x9E37_79B9)
        .rotate_left(13)
        .wrapping_mul(0x85EB_CA6B);
    0.2 + 0.8 * (h >> 8) as f32 / (1u32 << 24) as f32
}

pub const SS: u32 = 16;

/// Supersampled reference: the big image's pixel (X, Y) samples the small image's screen point
/// ((X + 0.5) / 16, (Y + 0.5) / 16) exactly (the two cameras differ only in size, and the
/// screen mapping scales by exactly 16), i.e. a stratified 16×16 grid per small pixel.
pub fn supersampled(scene: &Scene, cam: &Camera) -> (Vec<f32>, Vec<u32>) {
    let big = render(scene, &scaled(cam, SS));
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut img = vec![0.0f32; w * h];
    for (k, &id) in big.ids.iter().enumerate() {
        if (id as usize) < scene.triangles.len() {
            let (x, y) = (k % (w * SS as usize), k / (w * SS as usize));
            img[(y / SS as usize) * w + x / SS as usize] += value(id) / (SS * SS) as f32;
        }
    }
    (img, big.ids)
}

/// The rasterizer snaps to 1/256 of a (big) pixel, so it may attribute a sample within
/// 1/512 px per coordinate of a triangle's projected edge to that triangle (see
/// `sightline_core::raster`, "Agreement with ray casting"). Such samples are excused when checking
/// the visible set; `EDGE_EPS` is five times that distance, as in the rasterizer's own tests.
pub const EDGE_EPS: f64 = 0.01;

/// Distance (big pixels) from `p` to the boundary of the projected triangle `t`.
pub fn boundary_distance(t: &BruteTri, p: DVec2) -> f64 {
    let n = t.poly.len();
    (0..n)
        .map(|i| {
            let (a, b) = (t.poly[i], t.poly[(i + 1) % n]);
            let s = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
            (a + (b - a) * s - p).length()
        })
        .fold(f64::MAX, f64::min)
}

/// Checks the raster/analytic agreement and returns (max, mean) per-pixel error. Every triangle
/// the supersampled rasterizer shows must be in the exact set, except for samples within
/// `EDGE_EPS` of the triangle's projected boundary (snapping); at most 1 in 10^4 samples may be
/// excused.
pub fn check_against_raster(scene: &Scene, cam: &Camera) -> (f32, f32) {
    check_against_raster_with(scene, cam, &AnalyticOptions::default())
}

/// [`check_against_raster`] with the given options.
pub fn check_against_raster_with(
    scene: &Scene,
    cam: &Camera,
    options: &AnalyticOptions,
) -> (f32, f32) {
    let r = visible_fragments(scene, cam, options).unwrap();
    let (reference, ids) = supersampled(scene, cam);
    let big = scaled(cam, SS);
    let projected = brute_project(scene, &big);
    let width = big.width as usize;
    let mut excused = 0usize;
    for (k, &id) in ids.iter().enumerate() {
        if (id as usize) < scene.triangles.len() && !r.visible.contains(id as usize) {
            let p = DVec2::new((k % width) as f64 + 0.5, (k / width) as f64 + 0.5);
            let near_edge = projected[id as usize]
                .as_ref()
                .is_some_and(|t| boundary_distance(t, p) < EDGE_EPS);
            assert!(near_edge, "sampled triangle {id} not in exact set");
            excused += 1;
        }
    }
    assert!(excused * 10_000 <= ids.len(), "{excused} excused samples");
    eprintln!("excused samples: {excused}");
    let exact = integrate(&r, Filter::Box, value);
    let mut max = 0.0f32;
    let mut sum = 0.0f32;
    for (a, b) in exact.iter().zip(&reference) {
        max = max.max((a - b).abs());
        sum += (a - b).abs();
    }
    (max, sum / exact.len() as f32)
}

/// Tolerance of the per-pixel comparison. A straight boundary crossing a pixel is missed by at
/// most one sample per sample column or row it crosses: 16 of 256 samples, 1/16 of the pixel.
/// With values in [0.2, 1] the error of one boundary is at most 0.8/16 = 0.05; pixels of these
/// scenes hold at most about three boundaries (a box corner on a background), hence 0.15.
/// The mean error must be far smaller (the sampling error of random boundaries averages out).
pub const PIXEL_TOL: f32 = 0.15;
pub const MEAN_TOL: f32 = 0.005;

/// Projected, near- and screen-clipped triangle of the brute force: polygon (pixels) and the
/// plane of its view-space points (normal, offset) to get depth along pixel rays.
pub struct BruteTri {
    /// Polygon (pixels).
    pub poly: Vec<DVec2>,
    /// View-space corners (before clipping).
    pub corners: [DVec3; 3],
    n: DVec3,
    d: f64,
}

pub fn clip_axis(poly: Vec<DVec2>, axis: usize, bound: f64, above: bool) -> Vec<DVec2> {
    let c = |p: DVec2| if axis == 0 { p.x } else { p.y };
    let inside = |p: DVec2| if above { c(p) >= bound } else { c(p) <= bound };
    let mut out = Vec::new();
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        if inside(a) {
            out.push(a);
        }
        if inside(a) != inside(b) {
            out.push(a + (b - a) * ((bound - c(a)) / (c(b) - c(a))));
        }
    }
    out
}

pub fn brute_project(scene: &Scene, cam: &Camera) -> Vec<Option<BruteTri>> {
    let (w, h) = (f64::from(cam.width), f64::from(cam.height));
    let (tx, ty) = (f64::from(cam.tan_half_x()), f64::from(cam.tan_half_y()));
    let near = f64::from(cam.near);
    let view = |p: Vec3| {
        let d = (p - cam.eye).as_dvec3();
        DVec3::new(
            d.dot(cam.right.as_dvec3()),
            d.dot(cam.up.as_dvec3()),
            d.dot(cam.forward.as_dvec3()),
        )
    };
    let screen = |v: DVec3| {
        DVec2::new(
            (v.x / (v.z * tx) + 1.0) * 0.5 * w,
            (1.0 - v.y / (v.z * ty)) * 0.5 * h,
        )
    };
    let clip_near = |poly: Vec<DVec3>| -> Vec<DVec3> {
        let mut out = Vec::new();
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            if a.z >= near {
                out.push(a);
            }
            if (a.z >= near) != (b.z >= near) {
                let t = (near - a.z) / (b.z - a.z);
                out.push(a + (b - a) * t);
            }
        }
        out
    };
    scene
        .triangles
        .iter()
        .map(|t| {
            let v = t.map(|i| view(scene.positions[i as usize]));
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            let d = n.dot(v[0]);
            if d == 0.0 {
                return None;
            }
            let p3 = clip_near(v.to_vec());
            if p3.len() < 3 {
                return None;
            }
            let mut p: Vec<DVec2> = p3.into_iter().map(screen).collect();
            p = clip_axis(p, 0, 0.0, true);
            p = clip_axis(p, 0, w, false);
            p = clip_axis(p, 1, 0.0, true);
            p = clip_axis(p, 1, h, false);
            (p.len() >= 3).then_some(BruteTri {
                poly: p,
                corners: v,
                n,
                d,
            })
        })
        .collect()
}

/// View depth of `t` along the ray of screen point `s`.
pub fn brute_depth(t: &BruteTri, cam: &Camera, s: DVec2) -> f64 {
    let (tx, ty) = (f64::from(cam.tan_half_x()), f64::from(cam.tan_half_y()));
    let u = (2.0 * s.x / f64::from(cam.width) - 1.0) * tx;
    let v = (1.0 - 2.0 * s.y / f64::from(cam.height)) * ty;
    t.d / t.n.dot(DVec3::new(u, v, 1.0))
}

pub fn inside_convex(poly: &[DVec2], p: DVec2) -> bool {
    let n = poly.len();
    let (mut pos, mut neg) = (false, false);
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        let c = (b - a).perp_dot(p - a);
        pos |= c > 0.0;
        neg |= c < 0.0;
    }
    !(pos && neg)
}

/// The part of a view-space segment at depth `>= near`.
fn clip_to_near(a: DVec3, b: DVec3, near: f64) -> Option<(DVec3, DVec3)> {
    match (a.z >= near, b.z >= near) {
        (true, true) => Some((a, b)),
        (false, false) => None,
        (a_in, _) => {
            let p = a + (b - a) * ((near - a.z) / (b.z - a.z));
            Some(if a_in { (a, p) } else { (p, b) })
        }
    }
}

/// Screen position (pixels) of a view-space point in front of the eye.
fn screen_of(cam: &Camera, v: DVec3) -> DVec2 {
    let (tx, ty) = (f64::from(cam.tan_half_x()), f64::from(cam.tan_half_y()));
    let (w, h) = (f64::from(cam.width), f64::from(cam.height));
    DVec2::new(
        (v.x / (v.z * tx) + 1.0) * 0.5 * w,
        (1.0 - v.y / (v.z * ty)) * 0.5 * h,
    )
}

/// The segment where triangles `t` and `u` (f64 corners) cross, if they do: the part of
/// `t ∩ plane(u)` inside `u`. Touching (all corners of one on one side, or on the plane) is no
/// crossing. Written independently of the library (plain f64 geometry).
pub fn intersection_segment(t: &[DVec3; 3], u: &[DVec3; 3]) -> Option<(DVec3, DVec3)> {
    let side = |tri: &[DVec3; 3], p: DVec3| {
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        n.dot(p - tri[0])
    };
    let crosses = |a: &[DVec3; 3], b: &[DVec3; 3]| {
        let d = a.map(|p| side(b, p));
        d.iter().any(|&x| x > 0.0) && d.iter().any(|&x| x < 0.0)
    };
    if !crosses(t, u) || !crosses(u, t) {
        return None;
    }
    // t ∩ plane(u): the two points where t's edges change side.
    let d = t.map(|p| side(u, p));
    let mut pts = Vec::new();
    for i in 0..3 {
        let j = (i + 1) % 3;
        if d[i] == 0.0 {
            pts.push(t[i]);
        } else if (d[i] > 0.0) != (d[j] > 0.0) && d[j] != 0.0 {
            pts.push(t[i] + (t[j] - t[i]) * (d[i] / (d[i] - d[j])));
        }
    }
    let (mut a, mut b) = (*pts.first()?, *pts.last()?);
    // Clip a→b to u's three edges (inside: on the side of u's interior, in u's plane).
    let n = (u[1] - u[0]).cross(u[2] - u[0]);
    for i in 0..3 {
        let (p, q) = (u[i], u[(i + 1) % 3]);
        let inside = |x: DVec3| (q - p).cross(x - p).dot(n);
        let (fa, fb) = (inside(a), inside(b));
        if fa < 0.0 && fb < 0.0 {
            return None;
        }
        if fa < 0.0 {
            a = a + (b - a) * (fa / (fa - fb));
        } else if fb < 0.0 {
            b = a + (b - a) * (fa / (fa - fb));
        }
    }
    ((b - a).length() > 0.0).then_some((a, b))
}

/// Visible area per triangle by brute force: split the screen into vertical slabs at every
/// vertex, every crossing of two projected edges and every projected intersection segment of
/// two triangles; inside a slab no edges cross, so the cells
/// between consecutive edges are trapezoids covered by a fixed set of triangles; each cell's
/// area goes to the triangle nearest at the cell's centre (ties to the lower id).
pub fn brute_visible_area(scene: &Scene, cam: &Camera) -> Vec<f64> {
    let tris = brute_project(scene, cam);
    let mut segs: Vec<(DVec2, DVec2)> = Vec::new();
    for t in tris.iter().flatten() {
        for i in 0..t.poly.len() {
            let (a, b) = (t.poly[i], t.poly[(i + 1) % t.poly.len()]);
            if a.x != b.x {
                segs.push(if a.x < b.x { (a, b) } else { (b, a) });
            }
        }
    }
    // Intersecting triangles: their projected intersection segments are cell boundaries too,
    // so that inside every cell one triangle is nearest throughout.
    let projected: Vec<&BruteTri> = tris.iter().flatten().collect();
    for (i, t) in projected.iter().enumerate() {
        for u in &projected[i + 1..] {
            let Some((a, b)) = intersection_segment(&t.corners, &u.corners) else {
                continue;
            };
            let Some((a, b)) = clip_to_near(a, b, f64::from(cam.near)) else {
                continue;
            };
            let (a, b) = (screen_of(cam, a), screen_of(cam, b));
            if a.x != b.x {
                segs.push(if a.x < b.x { (a, b) } else { (b, a) });
            }
        }
    }
    let mut xs: Vec<f64> = segs.iter().flat_map(|s| [s.0.x, s.1.x]).collect();
    for i in 0..segs.len() {
        for j in i + 1..segs.len() {
            let ((a, b), (c, d)) = (segs[i], segs[j]);
            let den = (b - a).perp_dot(d - c);
            if den == 0.0 {
                continue;
            }
            let t = (c - a).perp_dot(d - c) / den;
            let u = (c - a).perp_dot(b - a) / den;
            if (0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&u) {
                xs.push(a.x + t * (b.x - a.x));
            }
        }
    }
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    let mut area = vec![0.0; scene.triangles.len()];
    let y_at = |s: &(DVec2, DVec2), x: f64| {
        let t = ((x - s.0.x) / (s.1.x - s.0.x)).clamp(0.0, 1.0);
        s.0.y + t * (s.1.y - s.0.y)
    };
    for w in xs.windows(2) {
        let (x0, x1) = (w[0], w[1]);
        if x1 - x0 < 1e-12 {
            continue;
        }
        let xm = 0.5 * (x0 + x1);
        let mut span: Vec<&(DVec2, DVec2)> =
            segs.iter().filter(|s| s.0.x <= x0 && s.1.x >= x1).collect();
        span.sort_by(|a, b| y_at(a, xm).total_cmp(&y_at(b, xm)));
        for pair in span.windows(2) {
            let (lo, hi) = (pair[0], pair[1]);
            let cell =
                0.5 * (x1 - x0) * ((y_at(hi, x0) - y_at(lo, x0)) + (y_at(hi, x1) - y_at(lo, x1)));
            if cell <= 0.0 {
                continue;
            }
            let p = DVec2::new(xm, 0.5 * (y_at(lo, xm) + y_at(hi, xm)));
            let mut best: Option<(f64, usize)> = None;
            for (id, t) in tris.iter().enumerate() {
                let Some(t) = t else { continue };
                if !inside_convex(&t.poly, p) {
                    continue;
                }
                let z = brute_depth(t, cam, p);
                if best.is_none_or(|(bz, _)| z < bz * (1.0 - 1e-9)) {
                    best = Some((z, id));
                }
            }
            if let Some((_, id)) = best {
                area[id] += cell;
            }
        }
    }
    area
}

/// Absolute tolerance on visible areas (px²). The analytic pipeline snaps screen positions to
/// 2^-20 px: each vertex moves by at most 2^-21·√2 ≈ 6.7e-7 px, so a region of perimeter P
/// changes by at most about P · 6.7e-7 px²; perimeters in these small images stay below 200 px,
/// hence 1.5e-4. Everything else (f64 intersection points) is far below that.
pub const AREA_TOL: f64 = 1.5e-4;

/// What intersecting triangles add to [`AREA_TOL`] (px² per px² of image). Where two crossing
/// planes are nearly parallel their intersection line is ill-conditioned: the same point,
/// computed from the planes along two different edges, differs by up to about 1e-7 of the
/// overlap's length (f64 rounding over the depth tolerance of 1e-9), and the gap leaves a strip
/// of that width uncovered. Measured: 2.7e-4 px² in a 48×40 image.
pub const CROSSING_AREA_TOL_PER_PX2: f64 = 2e-7;

/// The area tolerance for `cam`'s image.
pub fn area_tolerance(cam: &Camera) -> f64 {
    AREA_TOL + CROSSING_AREA_TOL_PER_PX2 * f64::from(cam.width) * f64::from(cam.height)
}

/// Compares per-triangle visible areas; returns the largest absolute difference (px²).
pub fn check_against_brute(scene: &Scene, cam: &Camera) -> f64 {
    check_against_brute_with(scene, cam, &AnalyticOptions::default())
}

/// [`check_against_brute`] with the given options.
pub fn check_against_brute_with(scene: &Scene, cam: &Camera, options: &AnalyticOptions) -> f64 {
    let r = visible_fragments(scene, cam, options).unwrap();
    let exact = r.visible_area(scene.triangles.len());
    let brute = brute_visible_area(scene, cam);
    let mut max = 0.0f64;
    let tolerance = area_tolerance(cam);
    for (id, (a, b)) in exact.iter().zip(&brute).enumerate() {
        max = max.max((a - b).abs());
        assert!(
            (a - b).abs() <= tolerance,
            "triangle {id}: analytic {a} px², brute force {b} px²"
        );
        // A triangle with visible area is in the set, and only then.
        assert_eq!(
            r.visible.contains(id),
            *a > 0.0,
            "triangle {id} set/area mismatch"
        );
    }
    max
}

/// The triangle an f64 ray through screen point `s` of `cam` hits first (Möller–Trumbore over
/// every triangle, double-sided, beyond the near plane): `(id, ray parameter, smallest
/// barycentric)`; the last says how far inside the triangle the hit is (0 on an edge). An
/// independent judge of a pixel sample: written without the library's ray caster or
/// rasterizer.
pub fn ray_nearest(scene: &Scene, cam: &Camera, s: DVec2) -> Option<(usize, f64, f64)> {
    let (tx, ty) = (f64::from(cam.tan_half_x()), f64::from(cam.tan_half_y()));
    let u = (2.0 * s.x / f64::from(cam.width) - 1.0) * tx;
    let v = (1.0 - 2.0 * s.y / f64::from(cam.height)) * ty;
    let dir = cam.right.as_dvec3() * u + cam.up.as_dvec3() * v + cam.forward.as_dvec3();
    let o = cam.eye.as_dvec3();
    let mut best: Option<(usize, f64, f64)> = None;
    for (id, t) in scene.triangles.iter().enumerate() {
        let p = t.map(|i| scene.positions[i as usize].as_dvec3());
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let h = dir.cross(e2);
        let a = e1.dot(h);
        if a.abs() < 1e-300 {
            continue;
        }
        let f = 1.0 / a;
        let sv = o - p[0];
        let bu = f * sv.dot(h);
        let q = sv.cross(e1);
        let bv = f * dir.dot(q);
        let tt = f * e2.dot(q);
        if bu < 0.0 || bv < 0.0 || bu + bv > 1.0 || tt <= 0.0 {
            continue;
        }
        let margin = bu.min(bv).min(1.0 - bu - bv);
        let z = tt * dir.dot(cam.forward.as_dvec3());
        if z < f64::from(cam.near) {
            continue;
        }
        if best.is_none_or(|b| tt < b.1) {
            best = Some((id, tt, margin));
        }
    }
    best
}
