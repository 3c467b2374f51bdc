//! One rule for user-given thread counts, shared by the CLI and the bindings: a count far above
//! the machine's cores only adds memory and scheduling cost (each worker has its own stack and
//! scratch buffers), and a typo such as `--threads 100000` would start that many OS threads.

use std::num::NonZeroUsize;

/// Requested counts above this many times the available cores are capped.
pub const OVERSUBSCRIPTION: usize = 4;

/// The logical cores this process may use ([`std::thread::available_parallelism`]; 1 when it
/// cannot be determined).
pub fn available_cores() -> usize {
    std::thread::available_parallelism().map_or(1, NonZeroUsize::get)
}

/// The thread count to use for a requested one, and a warning to show when it was changed.
///
/// `0` means "all cores" ([`available_cores`]) and gives no warning. A request above
/// [`OVERSUBSCRIPTION`] × the available cores is capped to that, with a warning naming both
/// numbers; anything else is returned unchanged.
///
/// ```
/// use sightline_core::threads::{available_cores, capped_threads, OVERSUBSCRIPTION};
/// assert_eq!(capped_threads(0), (available_cores(), None));
/// assert_eq!(capped_threads(1), (1, None));
/// let (n, warning) = capped_threads(usize::MAX);
/// assert_eq!(n, OVERSUBSCRIPTION * available_cores());
/// assert!(warning.is_some());
/// ```
pub fn capped_threads(requested: usize) -> (usize, Option<String>) {
    capped_for(requested, available_cores())
}

fn capped_for(requested: usize, cores: usize) -> (usize, Option<String>) {
    let cap = cores.saturating_mul(OVERSUBSCRIPTION).max(1);
    match requested {
        0 => (cores.max(1), None),
        n if n > cap => (
            cap,
            Some(format!(
                "{n} threads requested, using {cap} ({OVERSUBSCRIPTION} per available core, \
                 {cores} cores): more only add memory and scheduling cost"
            )),
        ),
        n => (n, None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_means_all_cores() {
        assert_eq!(capped_for(0, 8), (8, None));
    }

    #[test]
    fn counts_up_to_the_cap_are_kept() {
        assert_eq!(capped_for(1, 8), (1, None));
        assert_eq!(capped_for(32, 8), (32, None));
    }

    #[test]
    fn counts_above_the_cap_are_capped_with_a_warning() {
        let (n, warning) = capped_for(100_000, 8);
        assert_eq!(n, 32);
        let warning = warning.expect("a warning");
        assert!(
            warning.contains("100000") && warning.contains("32"),
            "{warning}"
        );
    }
}
