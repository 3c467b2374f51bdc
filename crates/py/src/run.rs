//! Long bakes that stay responsive: the work runs on its own thread without the GIL while the
//! calling thread polls Python for signals (Ctrl-C) and reports progress.
//!
//! Python runs signal handlers only on the main thread, and only when it executes Python code
//! or calls `PyErr_CheckSignals`; a bake that simply released the GIL for its whole length
//! would therefore ignore Ctrl-C until it finished. Here the caller's thread wakes every
//! [`POLL`], checks for signals and calls the progress callback (so the callback runs on the
//! caller's thread, with the GIL, like ordinary Python code). On a signal or an exception from
//! the callback it asks the work to stop ([`Control::stopped`], checked between cells), waits
//! for the cells under way and raises.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex, PoisonError};
use std::time::{Duration, Instant};

use pyo3::prelude::*;

use crate::convert::value_error;

/// How often the calling thread checks for signals: Ctrl-C is noticed within this time (the
/// cells under way then still finish).
const POLL: Duration = Duration::from_millis(50);
/// Least time between two progress calls (the last one, at the end, is always made).
const REPORT_EVERY: Duration = Duration::from_millis(200);

/// The work was asked to stop (a signal or a failing progress callback).
#[derive(Debug)]
pub(crate) struct Stopped;

/// Shared between the work and the calling thread: the stop request and the counters the
/// progress reports are made of.
#[derive(Default)]
pub(crate) struct Control {
    stop: AtomicBool,
    cells_done: AtomicUsize,
    /// Rays of the finished cells.
    rays_done: AtomicU64,
    /// Rays so far of the cells under way, by cell.
    rays_running: Mutex<BTreeMap<usize, u64>>,
    finished: Mutex<bool>,
    wake: Condvar,
}

impl Control {
    /// True once the work should stop: check it between cells.
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// `cell` has cast `rays` rays so far (its sampler's progress report).
    pub fn batch(&self, cell: usize, rays: u64) {
        self.rays_running
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .insert(cell, rays);
    }

    /// `cell` is finished after `rays` rays.
    pub fn cell_done(&self, cell: usize, rays: u64) {
        self.rays_running
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .remove(&cell);
        self.rays_done.fetch_add(rays, Ordering::Relaxed);
        self.cells_done.fetch_add(1, Ordering::Relaxed);
    }

    /// [`Control::cell_done`], then `Err(Stopped)` when a stop was requested: the bake
    /// drivers' per-cell callback. Checked as cells finish, so a stop request ends the bake
    /// there (the cells under way on other threads finish and are dropped).
    pub fn finish_cell(&self, cell: usize, rays: u64) -> Result<(), Stopped> {
        self.cell_done(cell, rays);
        if self.stopped() {
            Err(Stopped)
        } else {
            Ok(())
        }
    }

    /// Cells finished and rays cast so far (finished cells and those under way).
    fn snapshot(&self) -> (usize, u64) {
        let running: u64 = self
            .rays_running
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .values()
            .sum();
        (
            self.cells_done.load(Ordering::Relaxed),
            self.rays_done.load(Ordering::Relaxed) + running,
        )
    }

    fn set_finished(&self) {
        *self.finished.lock().unwrap_or_else(PoisonError::into_inner) = true;
        self.wake.notify_all();
    }

    /// Waits up to `timeout` for the work to finish; true when it has.
    fn wait_finished(&self, timeout: Duration) -> bool {
        let guard = self.finished.lock().unwrap_or_else(PoisonError::into_inner);
        let (guard, _) = self
            .wake
            .wait_timeout_while(guard, timeout, |finished| !*finished)
            .unwrap_or_else(PoisonError::into_inner);
        *guard
    }
}

/// Marks the work finished when dropped, so that a panicking worker also wakes the caller.
struct FinishOnDrop<'a>(&'a Control);

impl Drop for FinishOnDrop<'_> {
    fn drop(&mut self) {
        self.0.set_finished();
    }
}

/// The progress callback of a `progress` argument, by the rule of
/// `sightline._progress.resolve`: `None` shows a line on stderr when it is a terminal, `False`
/// nothing, `True` always that line, a callable is called as `progress(cells_done,
/// cells_total, rays)`.
pub(crate) fn progress_callback<'py>(
    py: Python<'py>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Option<Bound<'py, PyAny>>> {
    let resolved = py
        .import("sightline._progress")?
        .call_method1("resolve", (progress,))?;
    Ok((!resolved.is_none()).then_some(resolved))
}

/// Runs `work` on a new thread without the GIL, reporting `(cells done, total, rays)` to
/// `progress` and stopping it on a signal (the signal's exception, e.g. `KeyboardInterrupt`,
/// is raised) or when `progress` raises (that exception is raised). `work` must check
/// [`Control::stopped`] between cells and keep the counters up to date.
pub(crate) fn run_interruptible<T: Send>(
    py: Python<'_>,
    total: usize,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&Control) -> T + Send,
) -> PyResult<T> {
    let control = Control::default();
    std::thread::scope(|scope| {
        let worker = std::thread::Builder::new()
            .name("sightline-bake".into())
            .spawn_scoped(scope, || {
                let _finish = FinishOnDrop(&control);
                work(&control)
            })
            .map_err(|e| value_error(format!("cannot start the bake thread: {e}")))?;
        let mut failure: Option<PyErr> = None;
        let mut reported: Option<(usize, u64)> = None;
        let mut last_report: Option<Instant> = None;
        loop {
            let finished = py.detach(|| control.wait_finished(POLL));
            if failure.is_none() {
                if let Err(e) = py.check_signals() {
                    failure = Some(e);
                }
            }
            if let (None, Some(callback)) = (&failure, progress) {
                let now = control.snapshot();
                let due = last_report.is_none_or(|t| t.elapsed() >= REPORT_EVERY);
                // The final state is always reported (a bake that ends between two polls
                // still ends with `done == total`); intermediate ones at most every
                // REPORT_EVERY and only when something changed.
                if (finished && now.0 == total) || (due && reported != Some(now)) {
                    if let Err(e) = callback.call1((now.0, total, now.1)) {
                        failure = Some(e);
                    }
                    reported = Some(now);
                    last_report = Some(Instant::now());
                }
            }
            if failure.is_some() {
                control.stop.store(true, Ordering::Relaxed);
            }
            if finished {
                break;
            }
        }
        // The worker has finished (or is about to: `finished` is set by its drop guard).
        let value = py
            .detach(|| worker.join())
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        match failure {
            Some(e) => Err(e),
            None => Ok(value),
        }
    })
}
