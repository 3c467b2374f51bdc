//! Polygon clipping for the rasterizer: the near plane in view space and a 2D guard band in
//! screen space.
//!
//! Based on: Sutherland, Hodgman. Reentrant Polygon Clipping. CACM 17(1), 1974.
//!
//! Both clips run in f64. An edge crossing a plane is always cut by interpolating *from its
//! inside end-point towards its outside end-point*, whatever the direction the polygon walks the
//! edge in, so two triangles sharing an edge get bit-identical cut points and stay watertight.
//! The cut coordinate is set exactly to the plane (`z = near`, `x = ±GUARD_BAND`, ...).

use glam::{DVec2, DVec3};

/// Half-size of the guard band in pixels: after projection, polygons are clipped to
/// `[-GUARD_BAND, GUARD_BAND]²`. Screens are at most 16384 = 2^14 pixels wide, so the band's
/// edges are always far outside the image and never decide a pixel; its only purpose is to bound
/// the fixed-point coordinates (2^20 px · 2^8 sub-pixels = 2^28, so edge functions stay below
/// 2^60 in i64, see `setup.rs`).
pub(crate) const GUARD_BAND: f64 = (1u64 << 20) as f64;

/// Up to 9 vertices: a triangle gains at most one vertex per clipping plane (1 near + 4 guard).
pub(crate) const MAX_POLY: usize = 9;

/// A small fixed-capacity convex polygon.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Poly<T: Copy + Default> {
    pub(crate) verts: [T; MAX_POLY],
    pub(crate) len: usize,
}

impl<T: Copy + Default> Poly<T> {
    pub(crate) fn new() -> Self {
        Self {
            verts: [T::default(); MAX_POLY],
            len: 0,
        }
    }

    pub(crate) fn from_slice(v: &[T]) -> Self {
        let mut p = Self::new();
        for &x in v {
            p.push(x);
        }
        p
    }

    pub(crate) fn push(&mut self, v: T) {
        debug_assert!(self.len < MAX_POLY, "clipped polygon overflow");
        if self.len < MAX_POLY {
            self.verts[self.len] = v;
            self.len += 1;
        }
    }

    pub(crate) fn as_slice(&self) -> &[T] {
        &self.verts[..self.len]
    }
}

/// One Sutherland–Hodgman pass: keeps the part of `poly` where `inside` holds; `cut(i, o)`
/// returns the crossing point of the edge from inside point `i` to outside point `o`.
fn clip_pass<T: Copy + Default>(
    poly: &Poly<T>,
    inside: impl Fn(T) -> bool,
    cut: impl Fn(T, T) -> T,
) -> Poly<T> {
    let mut out = Poly::new();
    let n = poly.len;
    for k in 0..n {
        let cur = poly.verts[k];
        let next = poly.verts[(k + 1) % n];
        let (ci, ni) = (inside(cur), inside(next));
        if ci {
            out.push(cur);
        }
        if ci != ni {
            out.push(if ci { cut(cur, next) } else { cut(next, cur) });
        }
    }
    out
}

/// Clips a view-space triangle to the half-space `z >= near`. Returns 0 vertices (the triangle is
/// entirely behind the near plane), 3 or 4.
pub(crate) fn clip_near(tri: [DVec3; 3], near: f64) -> Poly<DVec3> {
    let poly = Poly::from_slice(&tri);
    let out = clip_pass(
        &poly,
        |v| v.z >= near,
        |i, o| {
            let t = (near - i.z) / (o.z - i.z);
            DVec3::new(i.x + t * (o.x - i.x), i.y + t * (o.y - i.y), near)
        },
    );
    if out.len < 3 {
        Poly::new()
    } else {
        out
    }
}

/// Clips a screen-space convex polygon to the guard band `[-GUARD_BAND, GUARD_BAND]²`.
pub(crate) fn clip_guard_band(poly: &Poly<DVec2>) -> Poly<DVec2> {
    let g = GUARD_BAND;
    let lerp_x = |bound: f64| {
        move |i: DVec2, o: DVec2| {
            let t = (bound - i.x) / (o.x - i.x);
            DVec2::new(bound, i.y + t * (o.y - i.y))
        }
    };
    let lerp_y = |bound: f64| {
        move |i: DVec2, o: DVec2| {
            let t = (bound - i.y) / (o.y - i.y);
            DVec2::new(i.x + t * (o.x - i.x), bound)
        }
    };
    let p = clip_pass(poly, |v| v.x >= -g, lerp_x(-g));
    let p = clip_pass(&p, |v| v.x <= g, lerp_x(g));
    let p = clip_pass(&p, |v| v.y >= -g, lerp_y(-g));
    let p = clip_pass(&p, |v| v.y <= g, lerp_y(g));
    if p.len < 3 {
        Poly::new()
    } else {
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_clip_keeps_triangle_in_front() {
        let t = [
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, 2.0),
        ];
        let p = clip_near(t, 0.5);
        assert_eq!(p.as_slice(), &t);
    }

    #[test]
    fn near_clip_drops_triangle_behind() {
        let t = [
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, -1.0),
            DVec3::new(0.0, 1.0, 0.1),
        ];
        assert_eq!(clip_near(t, 0.5).len, 0);
    }

    #[test]
    fn near_clip_one_vertex_behind_gives_quad() {
        let t = [
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
        ];
        let p = clip_near(t, 0.5);
        assert_eq!(p.len, 4);
        assert!(p.as_slice().iter().all(|v| v.z >= 0.5));
    }

    #[test]
    fn near_clip_cut_is_direction_independent() {
        let a = DVec3::new(0.3, -0.7, -1.3);
        let b = DVec3::new(1.1, 0.9, 2.7);
        let c = DVec3::new(-0.4, 0.2, 3.0);
        let p1 = clip_near([a, b, c], 0.1);
        let p2 = clip_near([b, a, c], 0.1);
        let cut = |p: &Poly<DVec3>| {
            p.as_slice()
                .iter()
                .copied()
                .find(|v| v.z == 0.1 && v.x > 0.0)
        };
        assert!(cut(&p1).is_some());
        assert_eq!(cut(&p1), cut(&p2));
    }

    #[test]
    fn guard_band_clips_huge_triangle() {
        let p = Poly::from_slice(&[
            DVec2::new(-1e12, -1e12),
            DVec2::new(1e12, -1e12),
            DVec2::new(0.0, 1e12),
        ]);
        let c = clip_guard_band(&p);
        assert!(c.len >= 3);
        assert!(c
            .as_slice()
            .iter()
            .all(|v| v.x.abs() <= GUARD_BAND && v.y.abs() <= GUARD_BAND));
    }

    #[test]
    fn guard_band_keeps_small_triangle() {
        let t = [
            DVec2::new(1.0, 1.0),
            DVec2::new(5.0, 1.0),
            DVec2::new(1.0, 5.0),
        ];
        assert_eq!(clip_guard_band(&Poly::from_slice(&t)).as_slice(), &t);
    }
}
