//! A cache prefetch hint for data a hot loop is about to read, for the algorithms whose inner
//! loops jump between scattered records (RV's per-bin triangle lists, the occlusion buffer's
//! tile blocks).

/// Asks the CPU to bring every cache line of `*value` into the cache. Only a hint: no effect on
/// results, and none off x86-64.
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        const LINE: usize = 64;
        let start = (value as *const T).cast::<i8>();
        let addr = start as usize;
        let size = std::mem::size_of::<T>().max(1);
        // One hint per cache line the value touches (2 for a 96-byte block, 2 or 3 for 128
        // bytes, depending on alignment).
        let lines = ((addr + size - 1) / LINE - addr / LINE) + 1;
        let first_line = start.wrapping_sub(addr % LINE);
        for k in 0..lines {
            // SAFETY: SSE is part of the x86-64 baseline, and a prefetch never faults nor
            // reads anything into the program, whatever the address.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(first_line.wrapping_add(k * LINE)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefetching_leaves_the_value_unchanged() {
        // A hint only: values of any size, including zero-sized ones, read back the same.
        let big = [7u8; 300];
        prefetch(&big);
        prefetch(&());
        assert!(big.iter().all(|&b| b == 7));
    }
}
