//! Helpers shared by the end-to-end test binaries: run `sightline`, read its stderr, check a
//! clean failure.

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `sightline` binary with `args` in `dir`.
pub fn sightline(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sightline"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the sightline binary runs")
}

/// The run's stderr as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A clean failure: exit code 1 (not a panic's 101) and a message containing `needle`.
pub fn assert_fails_with(o: &Output, needle: &str) {
    assert_eq!(o.status.code(), Some(1), "stderr: {}", stderr(o));
    let err = stderr(o);
    assert!(err.contains(needle), "expected '{needle}' in: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
}
