//! Switches that only this crate's unit tests turn: they run a second path of the engine to
//! compare it with the first (the re-test pass without its shortcuts, bins without their
//! occluder index), or make a visibility worker panic.
//!
//! Outside `cfg(test)`, [`TestHooks`] is an empty struct whose methods return the production
//! choices as constants: no public signature names a switch, no option value is overloaded
//! as one, and the compiler removes the paths only tests take. A hook is a `cfg(test)` field
//! rather than a cargo feature because every test that turns one is a unit test of `rv`.

use super::occluder_index::INDEX_FROM;

/// Which alternative paths a run takes (see the module documentation).
#[derive(Clone, Copy, Debug)]
pub(crate) struct TestHooks {
    /// The re-test pass re-tests every triangle and intersects afterwards (the earlier
    /// behaviour), instead of skipping the triangles the first pass hid and those whose bins
    /// settled.
    #[cfg(test)]
    pub(crate) retest_all: bool,
    /// Bins index their occluders once they have this many of them, or never (`None`: linear
    /// scans).
    #[cfg(test)]
    pub(crate) index_from: Option<usize>,
    /// Every visibility worker panics on the first work item it takes.
    #[cfg(test)]
    pub(crate) panic_in_worker: bool,
}

impl TestHooks {
    /// The production choices.
    pub(crate) const NONE: Self = Self {
        #[cfg(test)]
        retest_all: false,
        #[cfg(test)]
        index_from: Some(INDEX_FROM),
        #[cfg(test)]
        panic_in_worker: false,
    };
}

#[cfg(test)]
impl TestHooks {
    pub(crate) fn retest_all(self) -> bool {
        self.retest_all
    }

    pub(crate) fn index_from(self) -> Option<usize> {
        self.index_from
    }

    pub(crate) fn worker_took_work(self) {
        assert!(!self.panic_in_worker, "injected worker panic");
    }
}

#[cfg(not(test))]
impl TestHooks {
    pub(crate) const fn retest_all(self) -> bool {
        false
    }

    pub(crate) const fn index_from(self) -> Option<usize> {
        Some(INDEX_FROM)
    }

    pub(crate) const fn worker_took_work(self) {}
}
