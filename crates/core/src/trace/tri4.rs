//! The watertight ray/triangle test of [`super::triangle::intersect`] on four triangles at
//! once: SSE on x86_64 (part of its baseline, so no runtime detection), the reference test lane
//! by lane elsewhere.
//!
//! Based on: Woop, Benthin, Wald. Watertight Ray/Triangle Intersection. JCGT 2(1), 2013.
//! Based on: Wald, Benthin, Boulos. Getting rid of packets. IRT 2008 (one ray against several
//! primitives in SIMD lanes, as Embree's `Triangle4`).
//!
//! # Exactness
//! Every lane performs the reference's f32 operations in the same order (Rust never fuses a
//! multiply and an add, and SSE division is correctly rounded), so `t` has the same bits. The
//! rare lane where an edge function is exactly zero, which the reference recomputes in f64, is
//! handed to the reference itself. A test compares both on random triangles.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m128, _mm_add_ps, _mm_and_ps, _mm_andnot_ps, _mm_cmpeq_ps, _mm_cmpge_ps, _mm_cmpgt_ps,
    _mm_cmple_ps, _mm_cmplt_ps, _mm_cmpneq_ps, _mm_div_ps, _mm_max_ps, _mm_min_ps, _mm_movemask_ps,
    _mm_mul_ps, _mm_or_ps, _mm_set1_ps, _mm_setzero_ps, _mm_sub_ps,
};

use glam::Vec3;

use super::triangle::{intersect, ShearedRay};

/// Up to four triangles side by side: `corners[vertex][axis][lane]`, and their scene ids.
/// Unused lanes repeat the last triangle (same corners, same id), which changes no result: a
/// repeated hit ties with itself.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Tri4 {
    corners: [[[f32; 4]; 3]; 3],
    pub(super) ids: [u32; 4],
}

impl Tri4 {
    /// Packs 1 to 4 triangles given as `(corners, id)`.
    pub(super) fn new(tris: &[([Vec3; 3], u32)]) -> Self {
        debug_assert!(!tris.is_empty() && tris.len() <= 4);
        let mut out = Tri4 {
            corners: [[[0.0; 4]; 3]; 3],
            ids: [0; 4],
        };
        for lane in 0..4 {
            let (corners, id) = tris[lane.min(tris.len() - 1)];
            for (v, corner) in corners.iter().enumerate() {
                for axis in 0..3 {
                    out.corners[v][axis][lane] = corner[axis];
                }
            }
            out.ids[lane] = id;
        }
        out
    }

    /// A bit per lane (bit `i` for lane `i`) whose triangle is `id`: the lane itself and the
    /// copies that pad a packet of fewer than four. Lanes with the same id hold the same
    /// corners, so the packet test gives them the same result.
    #[inline(always)]
    pub(super) fn lanes_with_id(&self, id: u32) -> u32 {
        (0..4).fold(0, |m, lane| m | u32::from(self.ids[lane] == id) << lane)
    }

    /// The corners of lane `lane`.
    pub(super) fn triangle(&self, lane: usize) -> [Vec3; 3] {
        let c = &self.corners;
        [0, 1, 2].map(|v| Vec3::new(c[v][0][lane], c[v][1][lane], c[v][2][lane]))
    }
}

/// Per lane, `t` where `ray` hits the lane's triangle, and a mask of the lanes that are hit
/// (bit `i` for lane `i`): exactly what [`intersect`] says of each.
#[inline(always)]
pub(super) fn intersect4(ray: &ShearedRay, tris: &Tri4) -> ([f32; 4], u32) {
    #[cfg(target_arch = "x86_64")]
    {
        intersect4_sse(ray, tris)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        intersect4_scalar(ray, tris)
    }
}

/// [`intersect4`] by the reference test, lane by lane.
#[cfg(any(test, not(target_arch = "x86_64")))]
pub(super) fn intersect4_scalar(ray: &ShearedRay, tris: &Tri4) -> ([f32; 4], u32) {
    let mut t = [0.0; 4];
    let mut mask = 0;
    for (lane, t) in t.iter_mut().enumerate() {
        let [a, b, c] = tris.triangle(lane);
        if let Some(hit) = intersect(ray, a, b, c) {
            *t = hit;
            mask |= 1 << lane;
        }
    }
    (t, mask)
}

/// [`intersect4`] with SSE.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn intersect4_sse(ray: &ShearedRay, tris: &Tri4) -> ([f32; 4], u32) {
    let lanes = |v: [f32; 4]| -> __m128 { bytemuck::cast(v) };
    let [kx, ky, kz] = ray.axes();
    debug_assert!(kx < 3 && ky < 3 && kz < 3);
    // One vertex's axis: `ShearedRay::new` makes each axis 0, 1 or 2, and only it sets
    // them, so no bounds check (`% 3` cost a multiplication per axis and ray).
    let c = |v: usize, axis: usize| -> __m128 {
        // SAFETY: `axis` is below 3 (above).
        lanes(unsafe { *tris.corners[v].get_unchecked(axis) })
    };
    // SAFETY: SSE is part of the x86_64 baseline, so these intrinsics are available on every
    // x86_64 CPU; they only operate on values (no memory access).
    let (t, mask, zero) = unsafe {
        let [ox, oy, oz] = ray.origin_k.map(|o| _mm_set1_ps(o));
        let sx = _mm_set1_ps(ray.sx);
        let sy = _mm_set1_ps(ray.sy);
        let sz = _mm_set1_ps(ray.sz);
        // Translated to the origin, then sheared: `p[kx] - sx * p[kz]`, as the reference.
        let vertex = |v: usize| {
            let x = _mm_sub_ps(c(v, kx), ox);
            let y = _mm_sub_ps(c(v, ky), oy);
            let z = _mm_sub_ps(c(v, kz), oz);
            (
                _mm_sub_ps(x, _mm_mul_ps(sx, z)),
                _mm_sub_ps(y, _mm_mul_ps(sy, z)),
                z,
            )
        };
        let (ax, ay, az) = vertex(0);
        let (bx, by, bz) = vertex(1);
        let (cx, cy, cz) = vertex(2);
        let u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
        let v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
        let w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
        let zero = _mm_setzero_ps();
        let any_zero = _mm_or_ps(
            _mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)),
            _mm_cmpeq_ps(w, zero),
        );
        // Signs mixed: some edge function below zero and some above, as the smallest and the
        // largest of the three say. On lanes without NaN that is the reference's test
        // exactly; a lane with a NaN may come out either way, and is never hit (its `det` is
        // NaN, so `det_ok` fails), as in the reference. Six instructions fewer than comparing
        // each function twice.
        let lowest = _mm_min_ps(_mm_min_ps(u, v), w);
        let highest = _mm_max_ps(_mm_max_ps(u, v), w);
        let mixed = _mm_and_ps(_mm_cmplt_ps(lowest, zero), _mm_cmpgt_ps(highest, zero));
        // Most packets an incoherent ray reaches are missed on the edge functions alone: stop
        // before the division, the test's longest latency, when no lane can still be hit.
        let open = _mm_movemask_ps(mixed) as u32 ^ 0b1111 | _mm_movemask_ps(any_zero) as u32;
        if open == 0 {
            return ([0.0; 4], 0);
        }
        let det = _mm_add_ps(_mm_add_ps(u, v), w);
        // `det - det` is 0 exactly when `det` is finite (NaN otherwise).
        let det_ok = _mm_and_ps(
            _mm_cmpneq_ps(det, zero),
            _mm_cmpeq_ps(_mm_sub_ps(det, det), zero),
        );
        let t_scaled = _mm_add_ps(
            _mm_add_ps(
                _mm_mul_ps(u, _mm_mul_ps(sz, az)),
                _mm_mul_ps(v, _mm_mul_ps(sz, bz)),
            ),
            _mm_mul_ps(w, _mm_mul_ps(sz, cz)),
        );
        let t = _mm_div_ps(t_scaled, det);
        let in_range = _mm_and_ps(
            _mm_and_ps(
                _mm_cmpge_ps(t, _mm_set1_ps(ray.t_min)),
                _mm_cmple_ps(t, _mm_set1_ps(ray.t_max)),
            ),
            _mm_cmpeq_ps(_mm_sub_ps(t, t), zero),
        );
        let hit = _mm_andnot_ps(mixed, _mm_and_ps(det_ok, in_range));
        (
            bytemuck::cast::<__m128, [f32; 4]>(t),
            _mm_movemask_ps(hit) as u32,
            _mm_movemask_ps(any_zero) as u32,
        )
    };
    if zero == 0 {
        return (t, mask);
    }
    // An edge function is exactly zero: the reference recomputes it in f64.
    let (mut t, mut mask) = (t, mask & !zero);
    let mut rest = zero;
    while rest != 0 {
        let lane = rest.trailing_zeros() as usize & 3;
        rest &= rest - 1;
        let [a, b, c] = tris.triangle(lane);
        if let Some(hit) = intersect(ray, a, b, c) {
            t[lane] = hit;
            mask |= 1 << lane;
        }
    }
    (t, mask)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use crate::random::SplitMix64;

    #[test]
    fn lanes_with_id_include_the_copies_that_pad_a_packet() {
        let corners = |x: f32| [Vec3::new(x, 0.0, 0.0), Vec3::Y, Vec3::Z];
        let packet = Tri4::new(&[(corners(1.0), 7), (corners(2.0), 9)]);
        assert_eq!(packet.lanes_with_id(7), 0b0001);
        assert_eq!(packet.lanes_with_id(9), 0b1110);
        assert_eq!(packet.lanes_with_id(8), 0);
        let full = Tri4::new(&[0, 1, 2, 3].map(|i| (corners(i as f32 + 1.0), i)));
        assert_eq!(full.lanes_with_id(3), 0b1000);
    }

    /// The project's generator, fixed seed; small integers make exact zeros (edges through
    /// the origin, flat triangles, zero direction components) common.
    struct Rng(SplitMix64);

    impl Rng {
        /// 24 random bits.
        fn next(&mut self) -> u32 {
            (self.0.next_u64() >> 40) as u32
        }

        fn coord(&mut self, lattice: bool) -> f32 {
            if lattice {
                (self.next() % 7) as f32 - 3.0
            } else {
                (self.next() as f32 / (1u32 << 24) as f32 - 0.5) * 6.0
            }
        }

        fn vec(&mut self, lattice: bool) -> Vec3 {
            Vec3::new(
                self.coord(lattice),
                self.coord(lattice),
                self.coord(lattice),
            )
        }
    }

    fn unit_triangle() -> [Vec3; 3] {
        [Vec3::ZERO, Vec3::X, Vec3::Y]
    }

    #[test]
    fn padding_repeats_last_triangle() {
        let t = Tri4::new(&[(unit_triangle(), 7)]);
        assert_eq!(t.ids, [7; 4]);
        assert_eq!(t.triangle(3), unit_triangle());
    }

    #[test]
    fn hits_unit_triangle_in_every_lane() {
        let t = Tri4::new(&[(unit_triangle(), 0)]);
        let ray = ShearedRay::new(&Ray::new(Vec3::new(0.25, 0.25, 2.0), Vec3::NEG_Z));
        assert_eq!(intersect4(&ray, &t), ([2.0; 4], 0b1111));
    }

    #[test]
    fn simd_equals_reference_on_random_triangles() {
        let mut rng = Rng(SplitMix64::new(0x1234_5678_9abc_def1));
        for i in 0..50_000 {
            let lattice = i % 2 == 0;
            let tris: Vec<([Vec3; 3], u32)> = (0..4)
                .map(|id| {
                    let p = [rng.vec(lattice), rng.vec(lattice), rng.vec(lattice)];
                    // Some flat and some repeated-corner triangles, some whose edge functions
                    // overflow to infinities (or to NaN, `inf - inf`), and some with a NaN
                    // corner (the builder leaves those out, but the kernels must still agree).
                    let p = match rng.next() % 16 {
                        0 => [p[0], p[0], p[1]],
                        1 => [p[0], p[1], p[0] * 2.0 - p[1]],
                        2 => p.map(|c| c * 1e19),
                        3 => [p[0], Vec3::new(f32::NAN, p[1].y, p[1].z), p[2]],
                        _ => p,
                    };
                    (p, id)
                })
                .collect();
            let packet = Tri4::new(&tris);
            let mut ray = Ray::new(rng.vec(lattice), rng.vec(i % 3 == 0));
            if i % 5 == 0 {
                ray = ray.with_range(rng.coord(false).abs(), 2.0 + rng.coord(false).abs());
            }
            let sheared = ShearedRay::new(&ray);
            let (want_t, want) = intersect4_scalar(&sheared, &packet);
            let (got_t, got) = intersect4(&sheared, &packet);
            assert_eq!(got, want, "case {i}");
            for lane in 0..4 {
                if want & (1 << lane) != 0 {
                    assert_eq!(got_t[lane].to_bits(), want_t[lane].to_bits(), "case {i}");
                }
            }
        }
    }
}
