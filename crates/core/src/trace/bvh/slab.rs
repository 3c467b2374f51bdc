//! The ray/box slab test of the wide nodes, any width: the ray prepared once ([`BoxRay`]), the
//! boxes of a node as rows of lanes ([`Boxes`]), and the reference test lane by lane
//! (`BoxRay::enter_scalar`). Each node layout's SIMD kernel (SSE in `node4.rs`, AVX2 in
//! `node8.rs`) computes exactly what the reference does, and is tested against it here.
//!
//! Based on: Williams, Barrus, Morley, Shirley. An efficient and robust ray-box intersection
//! algorithm. JGT 10(1), 2005 (near/far planes picked by the sign of the direction).
//! Based on: Ize. Robust BVH ray traversal. JCGT 2(2), 2013 (the `1 + 2 gamma(3)` slack on far
//! distances). Based on: Wald, Benthin, Boulos. Getting rid of packets. IRT 2008 (one ray
//! against the SIMD-wide boxes of a multi-branching BVH).
//!
//! # Exactness
//! Every kernel computes, per lane, exactly the same IEEE operations in the same order (no fused
//! multiply-add), and `max`/`min` keep the running bound when the new distance is NaN
//! (`_mm_max_ps(a, b)` returns `b` when unordered, like `if a > b { a } else { b }`), so the
//! SIMD and scalar paths give the same bits; `kernel_tests` checks it for each kernel.

use glam::Vec3;

use crate::geometry::Ray;

/// `N` boxes, lane `i` for child `i`: `[min x, min y, min z, max x, max y, max z]`.
pub(super) type Boxes<const N: usize> = [[f32; N]; 6];

/// `N` boxes that no ray ever enters: every near plane is `+inf` away along the ray and every
/// far plane `-inf`, so the entry distance is `+inf` and the exit `-inf` on every axis.
pub(super) const fn empty_boxes<const N: usize>() -> Boxes<N> {
    [
        [f32::INFINITY; N],
        [f32::INFINITY; N],
        [f32::INFINITY; N],
        [f32::NEG_INFINITY; N],
        [f32::NEG_INFINITY; N],
        [f32::NEG_INFINITY; N],
    ]
}

/// Sets lane `lane` of `boxes` to the box `[min, max]`.
pub(super) fn set_lane<const N: usize>(
    boxes: &mut Boxes<N>,
    lane: usize,
    min: [f32; 3],
    max: [f32; 3],
) {
    for a in 0..3 {
        boxes[a][lane] = min[a];
        boxes[a + 3][lane] = max[a];
    }
}

/// The `(min, max)` corners of lane `lane` of `boxes`.
pub(super) fn lane_box<const N: usize>(boxes: &Boxes<N>, lane: usize) -> ([f32; 3], [f32; 3]) {
    let row = |r: usize| boxes[r][lane];
    ([row(0), row(1), row(2)], [row(3), row(4), row(5)])
}

/// A ray prepared for slab tests against [`Boxes`] of any width.
#[derive(Clone, Copy, Debug)]
pub(super) struct BoxRay {
    pub(super) origin: [f32; 3],
    pub(super) inv: [f32; 3],
    /// Per axis, the row of [`Boxes`] holding the near plane (the max when the direction is
    /// negative) and the one holding the far plane.
    pub(super) near: [usize; 3],
    pub(super) far: [usize; 3],
    pub(super) t_min: f32,
}

impl BoxRay {
    /// `None` when the ray can never hit anything (non-finite or zero direction or origin,
    /// empty or NaN range), matching what the leaf test would say. `t_min` is the lower bound
    /// boxes are clipped to (the caller loosens it by its culling slack).
    pub(super) fn new(ray: &Ray, t_min: f32) -> Option<Self> {
        let usable = ray.origin.is_finite()
            && ray.dir.is_finite()
            && ray.dir != Vec3::ZERO
            && ray.t_min <= ray.t_max;
        if !usable {
            return None;
        }
        // A zero component gives an infinite inverse whose sign follows the zero's sign; the
        // slab test handles the resulting infinities and NaNs.
        let inv = Vec3::ONE / ray.dir;
        let negative = [0, 1, 2].map(|a| ray.dir[a].is_sign_negative());
        Some(Self {
            origin: ray.origin.to_array(),
            inv: inv.to_array(),
            near: [0, 1, 2].map(|a| if negative[a] { a + 3 } else { a }),
            far: [0, 1, 2].map(|a| if negative[a] { a } else { a + 3 }),
            t_min,
        })
    }

    /// Per lane, the entry distance into the box clipped to `[t_min, t_far]`, and a bit mask
    /// of the lanes whose box the ray enters in that range (bit `i` for lane `i`), one lane at
    /// a time: the reference every SIMD kernel equals, and the kernel where there is none.
    ///
    /// `(plane - origin) * inv` is NaN when the origin lies on a plane the ray is parallel
    /// to: such a slab does not constrain the interval (the box is closed). The entry of an
    /// entered box is always finite.
    #[cfg(any(test, not(target_arch = "x86_64")))]
    #[inline(always)]
    pub(super) fn enter_scalar<const N: usize>(
        &self,
        boxes: &Boxes<N>,
        t_far: f32,
        far_slack: f32,
    ) -> ([f32; N], u32) {
        let mut t0 = [self.t_min; N];
        let mut t1 = [t_far; N];
        for a in 0..3 {
            // `% 6` lets the compiler drop the bounds checks.
            let near = &boxes[self.near[a] % 6];
            let far = &boxes[self.far[a] % 6];
            for lane in 0..N {
                let tn = (near[lane] - self.origin[a]) * self.inv[a];
                let tf = (far[lane] - self.origin[a]) * self.inv[a] * far_slack;
                if tn > t0[lane] {
                    t0[lane] = tn;
                }
                if tf < t1[lane] {
                    t1[lane] = tf;
                }
            }
        }
        let mut mask = 0;
        for lane in 0..N {
            if t0[lane] <= t1[lane] {
                mask |= 1 << lane;
            }
        }
        (t0, mask)
    }
}

/// The checks every slab kernel passes: the node layouts' tests call them with their kernel.
#[cfg(test)]
pub(super) mod kernel_tests {
    use super::*;

    /// Boxes with every relation to a ray along +x from the origin: hit (lane 0), behind
    /// (lane 1), touching and degenerate (flat, lane 2), and empty slots.
    fn mixed_boxes<const N: usize>() -> Boxes<N> {
        let mut b = empty_boxes::<N>();
        set_lane(&mut b, 0, [1.0, -1.0, -1.0], [2.0, 1.0, 1.0]);
        set_lane(&mut b, 1, [-3.0, -1.0, -1.0], [-2.0, 1.0, 1.0]);
        set_lane(&mut b, 2, [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
        b
    }

    /// The box ahead and the flat box touching the ray are entered at 1, nothing else.
    pub(crate) fn hits_box_ahead_only<const N: usize>(
        enter: impl Fn(&BoxRay, &Boxes<N>, f32, f32) -> ([f32; N], u32),
    ) {
        let r = BoxRay::new(&Ray::new(Vec3::ZERO, Vec3::X), 0.0).expect("usable ray");
        let (t, mask) = enter(&r, &mixed_boxes(), f32::INFINITY, 1.0);
        assert_eq!(mask, 0b101);
        assert_eq!(t[0], 1.0);
        assert_eq!(t[2], 1.0);
    }

    /// [`empty_boxes`] are never entered, whatever the signs of the direction.
    pub(crate) fn empty_boxes_are_never_entered<const N: usize>(
        enter: impl Fn(&BoxRay, &Boxes<N>, f32, f32) -> ([f32; N], u32),
    ) {
        for dir in [Vec3::X, Vec3::NEG_Y, Vec3::new(0.0, -0.0, 1.0), Vec3::ONE] {
            let r = BoxRay::new(&Ray::new(Vec3::splat(0.5), dir), 0.0).expect("usable ray");
            let empty = empty_boxes::<N>();
            assert_eq!(enter(&r, &empty, f32::INFINITY, 1.0).1, 0, "{dir:?}");
            assert_eq!(r.enter_scalar(&empty, f32::INFINITY, 1.0).1, 0);
        }
    }

    /// `enter` gives the reference's mask and, for entered lanes, its bits, on random boxes;
    /// node `i` uses the first `used(i)` lanes and leaves the rest empty slots.
    pub(crate) fn equals_scalar_on_random_boxes<const N: usize>(
        enter: impl Fn(&BoxRay, &Boxes<N>, f32, f32) -> ([f32; N], u32),
        used: impl Fn(usize) -> usize,
    ) {
        // The project's generator, fixed seed; coordinates on a coarse lattice so that origins
        // often lie on planes (NaN distances) and directions often have (signed) zero
        // components.
        let mut rng = crate::random::SplitMix64::new(0x9e37_79b9_7f4a_7c15);
        let mut coord = || rng.below(9) as f32 - 4.0;
        for i in 0..20_000 {
            let mut boxes = empty_boxes::<N>();
            for a in 0..3 {
                let (mins, maxs) = boxes.split_at_mut(3);
                for (min, max) in mins[a].iter_mut().zip(&mut maxs[a]).take(used(i)) {
                    let (p, q) = (coord(), coord());
                    *min = p.min(q);
                    *max = p.max(q);
                }
            }
            let origin = Vec3::new(coord(), coord(), coord()) * 0.5;
            let dir = Vec3::new(coord(), -coord(), coord()) * 0.25;
            let t_far = if i % 3 == 0 {
                f32::INFINITY
            } else {
                coord().abs()
            };
            let Some(r) = BoxRay::new(&Ray::new(origin, dir), 0.0) else {
                continue;
            };
            let (ts, ms) = r.enter_scalar(&boxes, t_far, 1.0 + 1e-6);
            let (tv, mv) = enter(&r, &boxes, t_far, 1.0 + 1e-6);
            assert_eq!(ms, mv, "ray {i}");
            for lane in 0..N {
                if ms & (1 << lane) != 0 {
                    assert_eq!(
                        ts[lane].to_bits(),
                        tv[lane].to_bits(),
                        "ray {i} lane {lane}"
                    );
                }
            }
        }
    }

    #[test]
    fn zero_direction_is_unusable() {
        assert!(BoxRay::new(&Ray::new(Vec3::ZERO, Vec3::ZERO), 0.0).is_none());
    }

    #[test]
    fn scalar_hits_box_ahead_only() {
        hits_box_ahead_only::<4>(|r, b, t, s| r.enter_scalar(b, t, s));
        hits_box_ahead_only::<8>(|r, b, t, s| r.enter_scalar(b, t, s));
    }
}
