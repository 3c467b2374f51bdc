//! Low-discrepancy sampling: randomly shifted Halton sequences.
//!
//! Based on: Halton. On the efficiency of certain quasi-random sequences of points in evaluating
//! multi-dimensional integrals. 1960; randomisation by a Cranley-Patterson rotation (a random
//! shift modulo 1 per dimension) as in Bhat. Simulation estimation of mixed discrete choice
//! models using randomized and scrambled Halton sequences. 2003 — the sampling the GVS++ paper
//! uses for ray origins, directions and evaluation viewpoints.

use crate::random::SplitMix64;

/// The first primes, the bases of the Halton dimensions.
pub const PRIMES: [u32; 16] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53];

/// The radical inverse of `index` in `base`: the `index`-th point of the 1D Halton (van der
/// Corput) sequence, in `[0, 1)`.
pub fn radical_inverse(mut index: u64, base: u32) -> f64 {
    let b = u64::from(base);
    let inv = 1.0 / base as f64;
    let mut factor = inv;
    let mut result = 0.0;
    while index > 0 {
        result += (index % b) as f64 * factor;
        index /= b;
        factor *= inv;
    }
    result
}

/// A `D`-dimensional Halton sequence (bases = the first `D` primes) with a random shift per
/// dimension drawn from a seed. Point `i` is deterministic given the seed.
#[derive(Clone, Debug)]
pub struct ShiftedHalton<const D: usize> {
    shift: [f64; D],
}

impl<const D: usize> ShiftedHalton<D> {
    /// A sequence shifted by random offsets drawn from `seed`.
    pub fn new(seed: u64) -> Self {
        assert!(
            D <= PRIMES.len(),
            "at most {} Halton dimensions",
            PRIMES.len()
        );
        let mut rng = SplitMix64::new(seed ^ 0x4861_6c74_6f6e);
        Self {
            shift: std::array::from_fn(|_| (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64),
        }
    }

    /// Point `index` of the sequence, each coordinate in `[0, 1)`. Index 0 is skipped internally
    /// (it is the origin in every base), so `point(0)` is the unshifted sequence's point 1.
    pub fn point(&self, index: u64) -> [f32; D] {
        std::array::from_fn(|d| {
            let x = radical_inverse(index + 1, PRIMES[d]) + self.shift[d];
            let x = (x - x.floor()) as f32;
            // Rounding to f32 can give exactly 1.0; keep the half-open interval.
            if x >= 1.0 {
                1.0 - f32::EPSILON / 2.0
            } else {
                x
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn van_der_corput_base_two() {
        let v: Vec<f64> = (1..=4).map(|i| radical_inverse(i, 2)).collect();
        assert_eq!(v, vec![0.5, 0.25, 0.75, 0.125]);
    }

    #[test]
    fn radical_inverse_of_zero_is_zero() {
        assert_eq!(radical_inverse(0, 3), 0.0);
    }

    #[test]
    fn shifted_points_stay_in_unit_cube_and_are_deterministic() {
        let a = ShiftedHalton::<4>::new(5);
        let b = ShiftedHalton::<4>::new(5);
        for i in 0..1000 {
            let p = a.point(i);
            assert_eq!(p, b.point(i));
            assert!(p.iter().all(|x| (0.0..1.0).contains(x)));
        }
    }

    #[test]
    fn halton_is_evenly_spread() {
        // Low discrepancy: every one of 16 bins of [0,1) gets 256 points out of 4096 within
        // a small tolerance (a random sequence would deviate by ~16).
        let h = ShiftedHalton::<2>::new(1);
        let mut bins = [0u32; 16];
        for i in 0..4096 {
            bins[(h.point(i)[1] * 16.0) as usize] += 1;
        }
        assert!(bins.iter().all(|&c| (250..=262).contains(&c)), "{bins:?}");
    }
}
