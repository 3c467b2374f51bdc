//! CPU time of the calling thread, for benchmarks on shared machines: other tenants steal
//! wall time, not the thread's own CPU time, so A/B comparisons alternate and compare this.

/// CPU time consumed by the calling thread so far, in nanoseconds
/// (`clock_gettime(CLOCK_THREAD_CPUTIME_ID)`).
///
/// Panics when the clock is unavailable (it exists on every Linux this project runs on).
pub fn thread_cpu_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `clock_gettime` writes one `timespec` through a valid pointer.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

#[cfg(test)]
mod tests {
    #[test]
    fn advances_with_work() {
        let start = super::thread_cpu_ns();
        let mut x = 0u64;
        while super::thread_cpu_ns() - start < 1_000_000 {
            x = x.wrapping_add(std::hint::black_box(1));
        }
        assert!(x > 0);
    }
}
