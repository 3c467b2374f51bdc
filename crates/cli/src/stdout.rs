//! Writing results to stdout without panicking.
//!
//! `println!` panics when stdout cannot be written (exit 101 and a backtrace hint): Rust ignores
//! SIGPIPE, so `sightline ... | head` gets EPIPE, and `> /dev/full` gets ENOSPC. The CLI's
//! output goes through `outln!` instead, which returns a [`StdoutError`] that `main` turns
//! into the exit status: a closed pipe ends the command quietly with status 0 (as ripgrep
//! does: the reader chose to stop, which is no failure of ours, and it keeps `set -o pipefail`
//! scripts with `| head` working), any other write error is reported on stderr with status 1.
//!
//! Output printed elsewhere with `println!` (library code, commands owned elsewhere) is caught
//! by [`catch_print_panics`], which turns those panics into the same errors.

use std::any::Any;
use std::fmt;
use std::io::{self, Write};
use std::panic;

/// Stdout could not be written.
#[derive(Debug)]
pub(crate) struct StdoutError(pub io::Error);

impl fmt::Display for StdoutError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "writing to stdout: {}", self.0)
    }
}

impl std::error::Error for StdoutError {}

impl StdoutError {
    /// True when the reader of a pipe has gone (the quiet, successful end).
    pub fn is_broken_pipe(&self) -> bool {
        self.0.kind() == io::ErrorKind::BrokenPipe
    }
}

/// Writes formatted text to stdout (as `print!`), returning `Err(StdoutError)`.
pub(crate) fn write_stdout(args: fmt::Arguments<'_>) -> Result<(), StdoutError> {
    io::stdout().lock().write_fmt(args).map_err(StdoutError)
}

/// Flushes stdout (its line buffer may hold a last line without a newline).
pub(crate) fn flush_stdout() -> Result<(), StdoutError> {
    io::stdout().lock().flush().map_err(StdoutError)
}

/// `println!` that returns from the enclosing function with a [`StdoutError`] (converted by
/// `?`, e.g. into `anyhow::Error`) instead of panicking.
macro_rules! outln {
    () => {
        $crate::stdout::write_stdout(format_args!("\n"))?
    };
    ($($arg:tt)*) => {
        $crate::stdout::write_stdout(format_args!("{}\n", format_args!($($arg)*)))?
    };
}

/// Which stream a `print!`-family panic message is about.
const PRINT_PANIC: [&str; 2] = ["failed printing to stdout: ", "failed printing to stderr: "];

/// The stream (0 stdout, 1 stderr) and OS error of a `println!`/`eprintln!` panic payload.
fn print_panic(message: &str) -> Option<(usize, io::Error)> {
    let (stream, rest) = PRINT_PANIC
        .iter()
        .enumerate()
        .find_map(|(i, p)| message.strip_prefix(p).map(|r| (i, r)))?;
    // "Broken pipe (os error 32)": the raw code gives the error kind on every platform.
    let code = rest
        .rsplit_once("(os error ")
        .and_then(|(_, c)| c.strip_suffix(')'))
        .and_then(|c| c.parse().ok());
    let error = match code {
        Some(c) => io::Error::from_raw_os_error(c),
        None => io::Error::other(rest.to_string()),
    };
    Some((stream, error))
}

fn payload_text(payload: &(dyn Any + Send)) -> Option<&str> {
    payload
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| payload.downcast_ref::<&str>().copied())
}

/// What a caught print panic means for the exit.
pub(crate) enum PrintFailure {
    /// Stdout failed: report it like any [`StdoutError`].
    Stdout(StdoutError),
    /// Stderr failed: nothing can be reported; exit quietly (0 for a closed pipe, else 1).
    Stderr(io::Error),
}

/// Runs `f`, turning the panics of `println!`/`eprintln!` on an unwritable stream into
/// [`PrintFailure`]s (their panic message is not printed); other panics go on as panics.
pub(crate) fn catch_print_panics<T>(f: impl FnOnce() -> T) -> Result<T, PrintFailure> {
    let default_hook = panic::take_hook();
    panic::set_hook(Box::new(move |info| {
        if info
            .payload_as_str()
            .is_none_or(|m| print_panic(m).is_none())
        {
            default_hook(info);
        }
    }));
    match panic::catch_unwind(panic::AssertUnwindSafe(f)) {
        Ok(v) => Ok(v),
        Err(payload) => match payload_text(payload.as_ref()).and_then(print_panic) {
            Some((0, e)) => Err(PrintFailure::Stdout(StdoutError(e))),
            Some((_, e)) => Err(PrintFailure::Stderr(e)),
            None => panic::resume_unwind(payload),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn print_panics_give_the_os_error() {
        let (stream, e) = print_panic("failed printing to stdout: Broken pipe (os error 32)")
            .expect("a print panic");
        assert_eq!(stream, 0);
        assert_eq!(e.raw_os_error(), Some(32));
        let (stream, _) =
            print_panic("failed printing to stderr: No space left on device (os error 28)")
                .expect("a print panic");
        assert_eq!(stream, 1);
        assert!(print_panic("index out of bounds").is_none());
    }
}
