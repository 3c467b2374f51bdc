//! Watertight ray/triangle intersection.
//!
//! Based on: Woop, Benthin, Wald. Watertight Ray/Triangle Intersection. JCGT 2(1), 2013.
//! The ray is sheared so that it points along +z; the edge functions of the triangle's
//! projection are then evaluated at the origin. Because every edge function is computed from
//! the same transformed vertices by the same formula, a ray through a shared edge or vertex
//! hits at least one of the triangles that share it (no cracks). When an edge function is
//! exactly zero in f32 it is recomputed in f64, as the paper recommends.
//!
//! `tri4.rs` evaluates this same test on four triangles at once with the same operations
//! in the same order; a change here must be made there too (its tests compare the two).

use glam::Vec3;

use crate::geometry::Ray;

/// A ray preprocessed for [`intersect`]: the permutation and shear of the paper.
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay {
    pub(super) origin: Vec3,
    /// `origin` permuted to `[origin[kx], origin[ky], origin[kz]]`, for the packet test
    /// (`tri4.rs`), which would otherwise permute it for every packet.
    pub(super) origin_k: [f32; 3],
    pub(super) kx: usize,
    pub(super) ky: usize,
    pub(super) kz: usize,
    pub(super) sx: f32,
    pub(super) sy: f32,
    pub(super) sz: f32,
    pub(super) t_min: f32,
    pub(super) t_max: f32,
}

impl ShearedRay {
    /// The permutation `[kx, ky, kz]`: `kz` the axis where the direction is largest, `kx`
    /// and `ky` the others, swapped when the direction points down `kz` (keeps the winding).
    /// Other engines that must reproduce this test bit for bit (the GPU caster) take it here.
    pub fn axes(&self) -> [usize; 3] {
        [self.kx, self.ky, self.kz]
    }

    /// The shear `[d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz]]` (`[0, 0, NaN]` for a zero
    /// direction).
    pub fn shear(&self) -> [f32; 3] {
        [self.sx, self.sy, self.sz]
    }

    /// Prepares `ray`. A ray with a zero direction never hits anything.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        // Indexing a plain array rather than `Vec3`: the kz of random directions is
        // unpredictable, and `Vec3`'s index compiles to a branch per access; an array is one
        // load.
        let d = ray.dir.to_array();
        let a = ray.dir.abs();
        // kz = dimension where the direction is largest.
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let (sx, sy, sz) = if d[kz] != 0.0 {
            (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz])
        } else {
            (0.0, 0.0, f32::NAN)
        };
        Self {
            origin: ray.origin,
            origin_k: {
                let o = ray.origin.to_array();
                [o[kx], o[ky], o[kz]]
            },
            kx,
            ky,
            kz,
            sx,
            sy,
            sz,
            t_min: ray.t_min,
            t_max: ray.t_max,
        }
    }
}

/// The ray parameter `t` where `ray` hits triangle `(a, b, c)` within `[t_min, t_max]`, if it
/// does. Both sides count; degenerate triangles are never hit.
#[inline]
pub fn intersect(ray: &ShearedRay, a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
    let (kx, ky, kz) = (ray.kx, ray.ky, ray.kz);
    let a = a - ray.origin;
    let b = b - ray.origin;
    let c = c - ray.origin;
    let ax = a[kx] - ray.sx * a[kz];
    let ay = a[ky] - ray.sy * a[kz];
    let bx = b[kx] - ray.sx * b[kz];
    let by = b[ky] - ray.sy * b[kz];
    let cx = c[kx] - ray.sx * c[kz];
    let cy = c[ky] - ray.sy * c[kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let (ax, ay, bx, by, cx, cy) = (
            ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
        );
        u = (cx * by - cy * bx) as f32;
        v = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let az = ray.sz * a[kz];
    let bz = ray.sz * b[kz];
    let cz = ray.sz * c[kz];
    let t_scaled = u * az + v * bz + w * cz;
    let t = t_scaled / det;
    (t >= ray.t_min && t <= ray.t_max && t.is_finite()).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(origin: Vec3, dir: Vec3, tri: [Vec3; 3]) -> Option<f32> {
        intersect(
            &ShearedRay::new(&Ray::new(origin, dir)),
            tri[0],
            tri[1],
            tri[2],
        )
    }

    const TRI: [Vec3; 3] = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];

    #[test]
    fn hits_inside_from_both_sides() {
        let t = hit(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, TRI).unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        assert!(hit(Vec3::new(0.2, 0.2, -2.0), Vec3::Z, TRI).is_some());
    }

    #[test]
    fn misses_outside() {
        assert!(hit(Vec3::new(0.8, 0.8, 1.0), Vec3::NEG_Z, TRI).is_none());
    }

    #[test]
    fn behind_origin_is_miss() {
        assert!(hit(Vec3::new(0.2, 0.2, 1.0), Vec3::Z, TRI).is_none());
    }

    #[test]
    fn degenerate_triangle_is_never_hit() {
        let flat = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert!(hit(Vec3::new(0.5, 0.0, 1.0), Vec3::NEG_Z, flat).is_none());
    }

    #[test]
    fn zero_direction_is_miss() {
        assert!(hit(Vec3::new(0.2, 0.2, 1.0), Vec3::ZERO, TRI).is_none());
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of the unit square; rays exactly on the diagonal
        // must hit at least one of them.
        let t1 = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)];
        let t2 = [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        for i in 1..100 {
            let s = i as f32 / 100.0;
            for d in [Vec3::NEG_Z, Vec3::new(0.013, -0.007, -1.0)] {
                // Aim at the diagonal point (s, s, 0) from 3 units away.
                let o = Vec3::new(s, s, 0.0) - d * 3.0;
                assert!(
                    hit(o, d, t1).is_some() || hit(o, d, t2).is_some(),
                    "crack at {s}"
                );
            }
        }
    }
}
