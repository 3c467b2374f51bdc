//! Eight ray/box slab tests at once, for the 8-wide nodes of [`super::Bvh`]: AVX2 on x86_64
//! CPUs that have it (the caller checks with `is_x86_feature_detected!`), and the same
//! arithmetic lane by lane for the tests.
//!
//! Based on: Fuetterling, Lojewski, Pfreundt, Ebert. Efficient Ray Tracing Kernels for Modern
//! CPU Architectures. JCGT 4(5), 2015 (one ray against the eight boxes of a BVH8 node).
//! Based on: Williams, Barrus, Morley, Shirley. An efficient and robust ray-box intersection
//! algorithm. JGT 10(1), 2005. Based on: Ize. Robust BVH ray traversal. JCGT 2(2), 2013.
//!
//! # Exactness
//! As in `box4.rs`: per lane the same IEEE operations in the same order as the scalar path
//! (no fused multiply-add), and `max`/`min` keep the running bound when the new distance is
//! NaN, so both give the same bits; a test checks it.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    _mm256_cmp_ps, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps,
    _mm256_mul_ps, _mm256_set1_ps, _mm256_storeu_ps, _mm256_sub_ps, _CMP_LE_OQ,
};

use super::box4::BoxRay;

/// Eight boxes, lane `i` for child `i`: `[min x, min y, min z, max x, max y, max z]`.
pub(super) type Boxes8 = [[f32; 8]; 6];

/// Eight boxes that no ray ever enters (see `box4::EMPTY_BOXES`).
pub(super) const EMPTY_BOXES8: Boxes8 = [
    [f32::INFINITY; 8],
    [f32::INFINITY; 8],
    [f32::INFINITY; 8],
    [f32::NEG_INFINITY; 8],
    [f32::NEG_INFINITY; 8],
    [f32::NEG_INFINITY; 8],
];

/// [`enter8_avx2`] one lane at a time.
#[cfg(test)]
pub(super) fn enter8_scalar(
    r: &BoxRay,
    boxes: &Boxes8,
    t_far: f32,
    far_slack: f32,
) -> ([f32; 8], u32) {
    let mut t0 = [r.t_min; 8];
    let mut t1 = [t_far; 8];
    for a in 0..3 {
        let near = &boxes[r.near[a] % 6];
        let far = &boxes[r.far[a] % 6];
        for lane in 0..8 {
            let tn = (near[lane] - r.origin[a]) * r.inv[a];
            let tf = (far[lane] - r.origin[a]) * r.inv[a] * far_slack;
            if tn > t0[lane] {
                t0[lane] = tn;
            }
            if tf < t1[lane] {
                t1[lane] = tf;
            }
        }
    }
    let mut mask = 0;
    for lane in 0..8 {
        if t0[lane] <= t1[lane] {
            mask |= 1 << lane;
        }
    }
    (t0, mask)
}

/// Per lane, the entry distance into the box clipped to `[r.t_min, t_far]`, and a bit mask of
/// the lanes whose box the ray enters in that range (bit `i` for lane `i`); as
/// `BoxRay::enter`, eight lanes wide.
///
/// # Safety
/// The CPU must support AVX2 (`is_x86_feature_detected!("avx2")`).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(super) unsafe fn enter8_avx2(
    r: &BoxRay,
    boxes: &Boxes8,
    t_far: f32,
    far_slack: f32,
) -> ([f32; 8], u32) {
    let mut out = [0.0f32; 8];
    // SAFETY: the caller guarantees AVX2 (which implies AVX); the loads read the eight floats
    // of one row of `boxes` and the store writes the eight of `out`, all in bounds.
    let mask = unsafe {
        let mut t0 = _mm256_set1_ps(r.t_min);
        let mut t1 = _mm256_set1_ps(t_far);
        let slack = _mm256_set1_ps(far_slack);
        for a in 0..3 {
            let origin = _mm256_set1_ps(r.origin[a]);
            let inv = _mm256_set1_ps(r.inv[a]);
            let near = _mm256_loadu_ps(boxes[r.near[a] % 6].as_ptr());
            let far = _mm256_loadu_ps(boxes[r.far[a] % 6].as_ptr());
            let tn = _mm256_mul_ps(_mm256_sub_ps(near, origin), inv);
            let tf = _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(far, origin), inv), slack);
            // Operand order matters: the second operand is kept when the first is NaN.
            t0 = _mm256_max_ps(tn, t0);
            t1 = _mm256_min_ps(tf, t1);
        }
        _mm256_storeu_ps(out.as_mut_ptr(), t0);
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32
    };
    (out, mask)
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use glam::Vec3;

    fn has_avx2() -> bool {
        is_x86_feature_detected!("avx2")
    }

    #[test]
    fn empty_boxes_are_never_entered() {
        for dir in [Vec3::X, Vec3::NEG_Y, Vec3::new(0.0, -0.0, 1.0), Vec3::ONE] {
            let r = BoxRay::new(&Ray::new(Vec3::splat(0.5), dir), 0.0).expect("usable ray");
            assert_eq!(enter8_scalar(&r, &EMPTY_BOXES8, f32::INFINITY, 1.0).1, 0);
            if has_avx2() {
                // SAFETY: AVX2 was detected just above.
                let (_, mask) = unsafe { enter8_avx2(&r, &EMPTY_BOXES8, f32::INFINITY, 1.0) };
                assert_eq!(mask, 0, "{dir:?}");
            }
        }
    }

    #[test]
    fn simd_equals_scalar_on_random_boxes() {
        if !has_avx2() {
            return;
        }
        // xorshift64*, fixed seed; coordinates on a coarse lattice so that origins often lie on
        // planes (NaN distances) and directions often have (signed) zero components.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as u32
        };
        let mut coord = || (next() % 9) as f32 - 4.0;
        for i in 0..20_000 {
            let mut boxes = EMPTY_BOXES8;
            // Some nodes leave empty slots at the end.
            let used = 8 - i % 7;
            for a in 0..3 {
                let (mins, maxs) = boxes.split_at_mut(3);
                for (min, max) in mins[a].iter_mut().zip(&mut maxs[a]).take(used) {
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
            let (ts, ms) = enter8_scalar(&r, &boxes, t_far, 1.0 + 1e-6);
            // SAFETY: AVX2 was detected at the start of the test.
            let (tv, mv) = unsafe { enter8_avx2(&r, &boxes, t_far, 1.0 + 1e-6) };
            assert_eq!(ms, mv, "ray {i}");
            for lane in 0..8 {
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
}
