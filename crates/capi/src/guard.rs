//! What every exported function runs inside: panics caught, failures turned into a status and
//! the thread's last-error message, and the per-thread decoding buffer.

use std::any::Any;
use std::cell::RefCell;
use std::ffi::{c_char, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

use crate::status::SlStatus;

thread_local! {
    /// The message of the last failing call on this thread.
    static LAST_ERROR: RefCell<Option<CString>> = const { RefCell::new(None) };
    /// Decoding buffer of the visible-set functions, kept between calls.
    static SCRATCH: RefCell<Vec<u32>> = const { RefCell::new(Vec::new()) };
}

/// Why a call failed.
pub(crate) struct Failure {
    pub status: SlStatus,
    pub message: String,
}

impl Failure {
    /// A required pointer argument was null.
    pub fn null(argument: &str) -> Self {
        fail(SlStatus::NullArgument, format!("{argument} is NULL"))
    }
}

/// A failure with `status` and `message`.
pub(crate) fn fail(status: SlStatus, message: impl Into<String>) -> Failure {
    Failure {
        status,
        message: message.into(),
    }
}

impl From<sightline_runtime::Error> for Failure {
    fn from(e: sightline_runtime::Error) -> Self {
        use sightline_runtime::Error as E;
        let status = match &e {
            E::NoSuchCell { .. } | E::NoSuchObject { .. } => SlStatus::OutOfRange,
            E::NoObjects(_) => SlStatus::NoObjects,
            E::NoBound => SlStatus::NoBound,
            E::BadMagic | E::UnsupportedVersion(_) | E::Truncated { .. } | E::Corrupt { .. } => {
                SlStatus::Corrupt
            }
            _ => SlStatus::Failed,
        };
        fail(status, e.to_string())
    }
}

fn set_last_error(message: String) {
    // A message cannot hold NUL bytes as a C string: they are written as `\0`.
    let message = CString::new(message.replace('\0', "\\0")).unwrap_or_default();
    // Fails only while the thread is being torn down; then there is no one to tell.
    let _ = LAST_ERROR.try_with(|e| *e.borrow_mut() = Some(message));
}

/// `sl_last_error`'s answer.
pub(crate) fn last_error() -> *const c_char {
    catch_unwind(|| {
        LAST_ERROR
            .try_with(|e| e.borrow().as_ref().map(|m| m.as_ptr()))
            .ok()
            .flatten()
    })
    .ok()
    .flatten()
    .unwrap_or(c"".as_ptr())
}

fn panic_message(payload: &(dyn Any + Send)) -> String {
    let what = payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("(no message)");
    format!("internal error (a bug in sightline, please report it): panic: {what}")
}

/// Runs `f`, catching panics; a failure or panic is recorded as this thread's last error,
/// prefixed with `function`, and yields `fallback`.
pub(crate) fn guard_value<T>(
    function: &str,
    fallback: T,
    f: impl FnOnce() -> Result<T, Failure>,
) -> T {
    guard(function, |_| fallback, f)
}

/// [`guard_value`] for functions that return a status: a failure returns its own.
pub(crate) fn guard_status(
    function: &str,
    f: impl FnOnce() -> Result<SlStatus, Failure>,
) -> SlStatus {
    guard(function, |status| status, f)
}

fn guard<T>(
    function: &str,
    on_failure: impl FnOnce(SlStatus) -> T,
    f: impl FnOnce() -> Result<T, Failure>,
) -> T {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(value)) => value,
        Ok(Err(failure)) => {
            set_last_error(format!("{function}: {}", failure.message));
            on_failure(failure.status)
        }
        Err(payload) => {
            set_last_error(format!("{function}: {}", panic_message(&*payload)));
            // Dropping the payload runs foreign code of its own: that must not unwind either.
            let _ = catch_unwind(AssertUnwindSafe(move || drop(payload)));
            on_failure(SlStatus::Internal)
        }
    }
}

/// Runs `f` with this thread's decoding buffer (a fresh one if it is in use or gone).
pub(crate) fn with_scratch<T>(f: impl FnOnce(&mut Vec<u32>) -> T) -> T {
    let mut f = Some(f);
    let kept = SCRATCH.try_with(|s| {
        let Ok(mut s) = s.try_borrow_mut() else {
            return None;
        };
        f.take().map(|f| f(&mut s))
    });
    match (kept, f) {
        (Ok(Some(value)), _) => value,
        (_, Some(f)) => f(&mut Vec::new()),
        // `f` ran and returned: `kept` holds its value.
        (_, None) => unreachable!("with_scratch: the closure ran without a result"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::CStr;

    fn last() -> String {
        // SAFETY: last_error always returns a valid NUL-terminated string.
        unsafe { CStr::from_ptr(last_error()) }
            .to_string_lossy()
            .into_owned()
    }

    #[test]
    fn a_panic_becomes_an_internal_error_with_its_message() {
        let status = guard_status("sl_test", || panic!("boom {}", 42));
        assert_eq!(status, SlStatus::Internal);
        let message = last();
        assert!(message.starts_with("sl_test: internal error"), "{message}");
        assert!(message.ends_with("panic: boom 42"), "{message}");
        assert_eq!(guard_value("sl_test", 7u32, || panic!("static str")), 7);
        assert!(last().ends_with("panic: static str"));
    }

    #[test]
    fn success_keeps_the_last_error_and_nul_bytes_are_escaped() {
        assert_eq!(
            guard_status("sl_test", || Err(fail(SlStatus::Failed, "a\0b"))),
            SlStatus::Failed
        );
        assert_eq!(last(), "sl_test: a\\0b");
        assert_eq!(guard_status("sl_test", || Ok(SlStatus::Ok)), SlStatus::Ok);
        assert_eq!(last(), "sl_test: a\\0b");
    }

    #[test]
    fn scratch_is_reused_and_nested_use_gets_a_fresh_buffer() {
        with_scratch(|s| {
            s.clear();
            s.extend([1, 2, 3]);
            with_scratch(|inner| assert!(inner.is_empty()));
        });
        with_scratch(|s| assert_eq!(s, &[1, 2, 3]));
    }
}
