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

#[cfg(test)]
use glam::Vec3;
use glam::Vec3A;

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
    /// Per axis, where in the rows of [`Boxes`] (`lanes` floats each, flattened) the near
    /// plane's row starts (the max when the direction is negative), and the far plane's: a
    /// row index times `lanes`. Offsets rather than indices, because the SIMD kernels add
    /// them to a node's address as they are (an index cost a shift per row, six per node).
    pub(super) near: [usize; 3],
    pub(super) far: [usize; 3],
    /// The width of the [`Boxes`] the offsets are for.
    lanes: usize,
    pub(super) t_min: f32,
    /// `inv` scaled by [`FINITE_FAR`], for the far planes of [`BoxRay::enter_finite_scalar`].
    pub(super) inv_far: [f32; 3],
    /// True when `inv` is finite on every axis and `t_min` is not negative (nor `-0.0`):
    /// then no slab distance is NaN and the cheaper [`BoxRay::enter_finite_scalar`] applies.
    pub(super) finite: bool,
}

/// `gamma(n) = n eps / (1 - n eps)` of Pharr et al. with `eps = 2^-24`: the relative error
/// bound of `n` rounded operations.
pub(super) const fn gamma(n: f32) -> f32 {
    let eps = f32::EPSILON * 0.5;
    n * eps / (1.0 - n * eps)
}

/// The factor folded into the inverse direction of the far planes in the finite slab test.
/// The near distance `(near - o) * inv` carries three roundings (the subtraction, `1 / d`,
/// the product), so it may come out up to `(1 + eps)^3` above the true one; the far distance
/// `(far - o) * (inv * FINITE_FAR)` carries four (the extra one is the scaling), so it may
/// come out down to `FINITE_FAR (1 - eps)^4` times the true one. `FINITE_FAR >= (1 + eps)^3 /
/// (1 - eps)^4`, about `1 + 7 eps`, keeps every box whose true interval is not empty entered
/// (Ize 2013's argument, with the slack on the inverse rather than on each distance);
/// `1 + 2 gamma(6)`, about `1 + 12 eps`, also keeps it above Ize's `1 + 2 gamma(3)` on each
/// product, so the finite test enters every box the NaN-aware test enters.
pub(super) const FINITE_FAR: f32 = 1.0 + 2.0 * gamma(6.0);

impl BoxRay {
    /// `None` when the ray can never hit anything (non-finite or zero direction or origin,
    /// empty or NaN range), matching what the leaf test would say. `t_min` is the lower bound
    /// boxes are clipped to (the caller loosens it by its culling slack); `lanes` is the width
    /// of the [`Boxes`] it will be tested against.
    #[inline(always)]
    pub(super) fn new(ray: &Ray, t_min: f32, lanes: usize) -> Option<Self> {
        // In SIMD lanes with `&` rather than `&&`: a scalar check per coordinate took about
        // 35 instructions a ray, a tenth of a missed ray's whole cost.
        let (origin, dir) = (Vec3A::from(ray.origin), Vec3A::from(ray.dir));
        let usable = (origin.is_finite_mask() & dir.is_finite_mask()).all()
            & dir.cmpne(Vec3A::ZERO).any()
            & (ray.t_min <= ray.t_max);
        if !usable {
            return None;
        }
        // A zero component gives an infinite inverse whose sign follows the zero's sign; the
        // slab test handles the resulting infinities and NaNs. `Vec3A`: one SIMD division for
        // the three lanes (a `Vec3` divides as two and one).
        let inv = Vec3A::ONE / dir;
        let negative = [0, 1, 2].map(|a| ray.dir[a].is_sign_negative());
        Some(Self {
            origin: ray.origin.to_array(),
            inv: inv.to_array(),
            near: [0, 1, 2].map(|a| if negative[a] { a + 3 } else { a } * lanes),
            far: [0, 1, 2].map(|a| if negative[a] { a } else { a + 3 } * lanes),
            lanes,
            t_min,
            inv_far: (inv * FINITE_FAR).to_array(),
            finite: inv.is_finite() && t_min.is_sign_positive(),
        })
    }

    /// The near and far plane rows of axis `a` in `boxes`.
    #[cfg(any(test, not(target_arch = "x86_64")))]
    #[inline(always)]
    fn rows<'b, const N: usize>(
        &self,
        boxes: &'b Boxes<N>,
        a: usize,
    ) -> (&'b [f32; N], &'b [f32; N]) {
        debug_assert_eq!(self.lanes, N);
        // `% 6` lets the compiler drop the bounds checks.
        (&boxes[self.near[a] / N % 6], &boxes[self.far[a] / N % 6])
    }

    /// Pointers to the near and far plane rows of axis `a` in `boxes`, for the SIMD kernels'
    /// loads: the offsets added to the first row's address, with no index arithmetic.
    ///
    /// # Panics
    /// When the ray was prepared for another width than `N` (then the offsets could point
    /// past `boxes`).
    #[inline(always)]
    pub(super) fn row_ptrs<const N: usize>(
        &self,
        boxes: &Boxes<N>,
        a: usize,
    ) -> (*const f32, *const f32) {
        assert_eq!(self.lanes, N, "a ray prepared for {} lanes", self.lanes);
        let first = boxes.as_flattened().as_ptr();
        // `near` and `far` are a row index below 6 times `lanes` (`new`), and `lanes == N`,
        // so each pointer starts a row of `boxes`; `wrapping_add` keeps this safe code.
        (
            first.wrapping_add(self.near[a]),
            first.wrapping_add(self.far[a]),
        )
    }

    /// [`BoxRay::enter_scalar`] for a ray whose [`BoxRay::finite`] holds, with the far slack
    /// folded into [`BoxRay::inv_far`]: the reference of the SIMD kernels' finite tests.
    ///
    /// With a finite inverse no distance is NaN (a plane at infinity of an empty slot gives an
    /// infinity), so the running bounds may be kept as the integers of the floats' bits, whose
    /// `max` and `min` take one cycle in SIMD where the float ones take four (Embree's
    /// `maxi`/`mini`). The order of the bits is that of the floats for non-negative floats,
    /// and every negative float (`-0.0` included) sorts below them. `t_min` is not negative,
    /// so the near bound is exactly the float maximum. Each far distance has `0.0` added in the
    /// multiply's one rounding (a fused multiply-add, as the SIMD kernel computes it), which
    /// turns `-0.0` (an origin on a far plane: `+0.0` times a negative inverse) into `+0.0` and
    /// changes nothing else; then the far bound is the float minimum when that is not
    /// negative, and otherwise some negative float, and the box is left out as by the float
    /// test. Without the addition a `-0.0` exit sorts below every other negative one as an
    /// integer, so a ray leaving a box's face from its origin entered the box at distance 0
    /// whatever its other slabs said; rays that start on planes shared by many boxes (a bake's
    /// rays start on a cell's faces, and spatial splits cut along such planes) then visited
    /// ten times the leaves.
    #[cfg(any(test, not(target_arch = "x86_64")))]
    #[inline(always)]
    pub(super) fn enter_finite_scalar<const N: usize>(
        &self,
        boxes: &Boxes<N>,
        t_far: f32,
    ) -> ([f32; N], u32) {
        debug_assert!(self.finite);
        let bits = |t: f32| t.to_bits() as i32;
        let mut t0 = [bits(self.t_min); N];
        let mut t1 = [bits(t_far); N];
        for a in 0..3 {
            let (near, far) = self.rows(boxes, a);
            for lane in 0..N {
                let tn = (near[lane] - self.origin[a]) * self.inv[a];
                let tf = (far[lane] - self.origin[a]).mul_add(self.inv_far[a], 0.0);
                t0[lane] = t0[lane].max(bits(tn));
                t1[lane] = t1[lane].min(bits(tf));
            }
        }
        let float = |b: i32| f32::from_bits(b as u32);
        let mut mask = 0;
        for lane in 0..N {
            if float(t0[lane]) <= float(t1[lane]) {
                mask |= 1 << lane;
            }
        }
        (t0.map(float), mask)
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
            let (near, far) = self.rows(boxes, a);
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
        let r = BoxRay::new(&Ray::new(Vec3::ZERO, Vec3::X), 0.0, N).expect("usable ray");
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
            let r = BoxRay::new(&Ray::new(Vec3::splat(0.5), dir), 0.0, N).expect("usable ray");
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
            let Some(r) = BoxRay::new(&Ray::new(origin, dir), 0.0, N) else {
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

    /// Random boxes (node `i` leaves its last `i % N` slots empty) and rays with no zero
    /// direction component, so [`BoxRay::finite`]: on a coarse lattice for even `i` (origins
    /// on planes, zero and `-0.0` distances) and continuous for odd `i` (rounding). Calls
    /// `check(i, ray, boxes, t_far)`.
    pub(crate) fn finite_cases<const N: usize>(
        mut check: impl FnMut(usize, &BoxRay, &Boxes<N>, f32),
    ) {
        // The project's generator, fixed seed.
        let mut rng = crate::random::SplitMix64::new(0x5eed_0f1a_17e5_0001);
        for i in 0..20_000 {
            let lattice = i % 2 == 0;
            let mut coord = || {
                if lattice {
                    rng.below(9) as f32 - 4.0
                } else {
                    rng.range_f32(-4.0, 4.0)
                }
            };
            let mut boxes = empty_boxes::<N>();
            for a in 0..3 {
                let (mins, maxs) = boxes.split_at_mut(3);
                for (min, max) in mins[a].iter_mut().zip(&mut maxs[a]).take(N - i % N) {
                    let (p, q) = (coord(), coord());
                    *min = p.min(q);
                    *max = p.max(q);
                }
            }
            let origin = Vec3::new(coord(), coord(), coord()) * 0.5;
            let nonzero = |c: f32| if c == 0.0 { 1.0 } else { c };
            let dir = Vec3::new(nonzero(coord()), -nonzero(coord()), nonzero(coord())) * 0.25;
            let t_far = if i % 3 == 0 {
                f32::INFINITY
            } else {
                coord().abs()
            };
            let r = BoxRay::new(&Ray::new(origin, dir), 0.0, N).expect("usable ray");
            assert!(r.finite, "case {i}");
            check(i, &r, &boxes, t_far);
        }
    }

    /// `enter_finite` gives `BoxRay::enter_finite_scalar`'s mask and, for entered lanes, its
    /// bits, on [`finite_cases`].
    pub(crate) fn finite_equals_scalar_on_random_boxes<const N: usize>(
        enter_finite: impl Fn(&BoxRay, &Boxes<N>, f32) -> ([f32; N], u32),
    ) {
        finite_cases::<N>(|i, r, boxes, t_far| {
            let (ts, ms) = r.enter_finite_scalar(boxes, t_far);
            let (tv, mv) = enter_finite(r, boxes, t_far);
            assert_eq!(ms, mv, "case {i}");
            for lane in (0..N).filter(|l| ms & (1 << l) != 0) {
                assert_eq!(
                    ts[lane].to_bits(),
                    tv[lane].to_bits(),
                    "case {i} lane {lane}"
                );
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finite_test_enters_every_box_the_nan_aware_test_enters() {
        // The traversal's far slack for the NaN-aware test (`traverse::ROBUST_FAR`).
        let robust_far = 1.0 + 2.0 * gamma(3.0);
        // Lanes entered by the finite test alone, on the lattice and off it.
        let mut extra = [0; 2];
        kernel_tests::finite_cases::<8>(|i, r, boxes, t_far| {
            let (tr, mr) = r.enter_scalar(boxes, t_far, robust_far);
            let (tf, mf) = r.enter_finite_scalar(boxes, t_far);
            assert_eq!(
                mr & !mf,
                0,
                "case {i}: a box the NaN-aware test enters is left out"
            );
            for lane in (0..8).filter(|l| mr & (1 << l) != 0) {
                assert_eq!(
                    tr[lane].to_bits(),
                    tf[lane].to_bits(),
                    "case {i} lane {lane}"
                );
            }
            extra[i % 2] += (mf & !mr).count_ones();
        });
        // The extra boxes are those at the rounding edge: few, on the lattice (where origins
        // lie on far planes: 1,000-2,000 lanes there before `-0.0` exits were made `+0.0`)
        // and off it, so the traversal does no extra work.
        assert!(
            extra[0] < 20 && extra[1] < 20,
            "{extra:?} of 80,000 lanes each"
        );
    }

    #[test]
    fn finite_far_covers_seven_roundings() {
        let eps = f64::from(f32::EPSILON) / 2.0;
        assert!(f64::from(FINITE_FAR) >= (1.0 + eps).powi(3) / (1.0 - eps).powi(4));
    }

    #[test]
    fn finite_needs_finite_inverse_and_non_negative_t_min() {
        let ray = |dir| Ray::new(Vec3::ZERO, dir);
        let finite = |dir, t_min| BoxRay::new(&ray(dir), t_min, 8).expect("usable").finite;
        assert!(finite(Vec3::ONE, 0.0));
        assert!(!finite(Vec3::new(1.0, 0.0, 1.0), 0.0));
        assert!(!finite(Vec3::new(1.0, -0.0, 1.0), 0.0));
        // 1 / 1e-40 overflows to infinity.
        assert!(!finite(Vec3::new(1.0, 1e-40, 1.0), 0.0));
        assert!(!finite(Vec3::ONE, -0.0));
        assert!(!finite(Vec3::ONE, -1.0));
    }

    #[test]
    fn zero_direction_is_unusable() {
        assert!(BoxRay::new(&Ray::new(Vec3::ZERO, Vec3::ZERO), 0.0, 8).is_none());
    }

    #[test]
    fn scalar_hits_box_ahead_only() {
        kernel_tests::hits_box_ahead_only::<4>(|r, b, t, s| r.enter_scalar(b, t, s));
        kernel_tests::hits_box_ahead_only::<8>(|r, b, t, s| r.enter_scalar(b, t, s));
    }
}
