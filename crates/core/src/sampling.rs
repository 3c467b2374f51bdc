//! Low-discrepancy sampling: randomly shifted Halton sequences.
//!
//! Based on: Halton. On the efficiency of certain quasi-random sequences of points in evaluating
//! multi-dimensional integrals. 1960; randomisation by a Cranley-Patterson rotation (a random
//! shift modulo 1 per dimension) as in Bhat. Simulation estimation of mixed discrete choice
//! models using randomized and scrambled Halton sequences. 2003 — the sampling the GVS++ paper
//! uses for ray origins, directions and evaluation viewpoints.

use std::sync::OnceLock;

use crate::random::SplitMix64;

/// The first primes, the bases of the Halton dimensions.
pub const PRIMES: [u32; 16] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53];

/// The radical inverse of `index` in `base`: the `index`-th point of the 1D Halton (van der
/// Corput) sequence, in `[0, 1)`.
///
/// Exact, then rounded once: the digits reversed as an integer `r` over `base^n` (both exact in
/// `f64` below 2^53), one division. Base 2 is the index's bits reversed; the bases of
/// [`PRIMES`] reverse several digits per step through a table (at most 4,096 entries), so the
/// chain of dependent operations is a few steps long. A bake draws a Halton point for every
/// random ray: the digit-by-digit sum (one `f64` multiply-add and one integer division per
/// digit, still [`radical_inverse_by_digits`]) took 43 ns per 5-dimensional point, about a
/// seventh of a GVS++ bake's time. Indices beyond the exact range take the digit-by-digit sum.
pub fn radical_inverse(index: u64, base: u32) -> f64 {
    // Each base of `PRIMES` but 2 with its chunk as a constant, so that the divisions by the
    // chunk are multiplications.
    macro_rules! by_chunks {
        ($($base:literal)*) => {
            match base {
                $($base => by_chunks::<{ chunk_of($base) as u64 }>(index, digit_table($base)),)*
                _ => exact_by_digits(index, base),
            }
        };
    }
    if base == 2 && index < EXACT {
        // The bits reversed are the digits reversed; scaling by 2^-64 is exact.
        return index.reverse_bits() as f64 * (1.0 / 18_446_744_073_709_551_616.0);
    }
    by_chunks!(3 5 7 11 13 17 19 23 29 31 37 41 43 47 53)
}

/// Numerators and denominators below this are exact in `f64`.
const EXACT: u64 = 1 << 53;

/// How many numbers a digit table of `base` holds: its largest power up to 4,096.
const fn chunk_of(base: u32) -> u32 {
    let mut chunk = base;
    while chunk * base <= 4096 {
        chunk *= base;
    }
    chunk
}

/// [`radical_inverse`] `CHUNK`'s digits at a time through `table` (its base's).
#[inline]
fn by_chunks<const CHUNK: u64>(index: u64, table: &DigitTable) -> f64 {
    let (mut rest, mut reversed, mut denominator) = (index, 0u64, 1u64);
    while rest > 0 {
        if denominator > EXACT / CHUNK {
            // The last chunk's padding would leave the exact range: digit by digit.
            return exact_by_digits(index, table.base);
        }
        reversed = reversed * CHUNK + u64::from(table.reversed[(rest % CHUNK) as usize]);
        rest /= CHUNK;
        denominator *= CHUNK;
    }
    reversed as f64 / denominator as f64
}

/// [`radical_inverse`] one digit at a time: exact (as an integer over `base^n`, rounded once)
/// while `base^n` stays below 2^53, else [`radical_inverse_by_digits`].
fn exact_by_digits(index: u64, base: u32) -> f64 {
    let b = u64::from(base);
    let (mut rest, mut reversed, mut denominator) = (index, 0u64, 1u64);
    while rest > 0 {
        if denominator > EXACT / b {
            return radical_inverse_by_digits(index, base);
        }
        reversed = reversed * b + rest % b;
        rest /= b;
        denominator *= b;
    }
    reversed as f64 / denominator as f64
}

/// [`radical_inverse`] summed digit by digit in `f64` (rounded at every step: within a few
/// ulps of the exact value).
pub fn radical_inverse_by_digits(mut index: u64, base: u32) -> f64 {
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

/// For one base: every number of as many digits as [`chunk_of`] the base allows, with its
/// digits reversed.
struct DigitTable {
    base: u32,
    reversed: Vec<u32>,
}

/// The table of `base`, one of [`PRIMES`] (built on first use; [`radical_inverse`] asks only
/// for those).
fn digit_table(base: u32) -> &'static DigitTable {
    static TABLES: [OnceLock<DigitTable>; PRIMES.len()] = [const { OnceLock::new() }; PRIMES.len()];
    debug_assert!(PRIMES.contains(&base), "no digit table for base {base}");
    let slot = PRIMES.iter().position(|&p| p == base).unwrap_or(0);
    TABLES[slot].get_or_init(|| {
        let chunk = chunk_of(base);
        let digits = chunk.ilog(base);
        let reversed = (0..chunk)
            .map(|mut c| {
                let mut r = 0;
                for _ in 0..digits {
                    r = r * base + c % base;
                    c /= base;
                }
                r
            })
            .collect();
        DigitTable { base, reversed }
    })
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

    /// The exact value of the digits reversed rounded once: the digits in `u128` and a
    /// division in `f64` of the numerator and denominator, where both are exact (`base^n` up
    /// to 2^53); `None` beyond.
    fn exact(mut index: u64, base: u32) -> Option<f64> {
        let b = u128::from(base);
        let (mut r, mut d) = (0u128, 1u128);
        while index > 0 {
            r = r * b + u128::from(index) % b;
            index /= base as u64;
            d *= b;
        }
        (d <= 1 << 53).then(|| r as f64 / d as f64)
    }

    #[test]
    fn radical_inverse_is_the_exact_value_rounded_once() {
        let mut rng = SplitMix64::new(3);
        for &base in &PRIMES {
            // Small indices, every chunk boundary's neighbourhood, and large random ones.
            let indices = (0..5000u64)
                .chain((1..12).flat_map(|k| {
                    let p = u64::from(base).pow(k);
                    [p - 1, p, p + 1]
                }))
                .chain((0..2000).map(|_| rng.next_u64() >> 24));
            for i in indices {
                let fast = radical_inverse(i, base);
                let slow = radical_inverse_by_digits(i, base);
                // Exact where it can be; beyond, the digit-by-digit sum.
                assert_eq!(
                    fast,
                    exact(i, base).unwrap_or(slow),
                    "index {i} base {base}"
                );
                // In [0, 1) where exact (the digit-by-digit sum may round up to 1).
                assert!(exact(i, base).is_none() || (0.0..1.0).contains(&fast));
                // The digit-by-digit sum agrees to within a few ulps.
                assert!(
                    (fast - slow).abs() <= 8.0 * f64::EPSILON * fast.max(1e-300),
                    "{i} {base}: {fast} {slow}"
                );
            }
        }
        // A base without a table is exact too; beyond the exact range, the digit-by-digit sum.
        assert_eq!(Some(radical_inverse(12345, 59)), exact(12345, 59));
        assert_eq!(
            radical_inverse(u64::MAX, 3),
            radical_inverse_by_digits(u64::MAX, 3)
        );
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
