//! End-to-end tests of running unattended (issue 17): unwritable stdout, oversized
//! parameters, outputs that are inputs, concurrent bakes, exit statuses and messages.

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

mod common;

use common::{assert_fails_with, sightline, stderr};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const SCENE: &str = "procedural:rooms?seed=2&size=2000";

/// The root of the workspace (where `scenes/` is).
fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn bake(dir: &Path, out: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "pvs",
        "bake",
        SCENE,
        "--cell",
        "box:2,2,1,4,4,2",
        "--cell",
        "box:8,2,1,10,4,2",
        "--n-rand",
        "20000",
        "-o",
        out,
    ];
    args.extend_from_slice(extra);
    sightline(&args, dir)
}

fn baked(dir: &Path, out: &str, extra: &[&str]) -> PathBuf {
    let o = bake(dir, out, extra);
    assert!(o.status.success(), "{}", stderr(&o));
    dir.join(out)
}

/// Runs `sightline args` in `dir` with stdout a pipe whose reading end is closed before the
/// command writes anything.
fn with_closed_stdout(args: &[&str], dir: &Path) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_sightline"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    child.wait_with_output().unwrap()
}

/// Runs `sightline args` in `dir` with stdout `/dev/full` (every write fails with ENOSPC).
fn with_full_stdout(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sightline"))
        .args(args)
        .current_dir(dir)
        .stdout(File::options().write(true).open("/dev/full").unwrap())
        .output()
        .unwrap()
}

#[test]
fn closed_stdout_pipe_ends_quietly_with_success() {
    let dir = tempfile::tempdir().unwrap();
    baked(dir.path(), "a.pvs", &[]);
    for args in [
        &["pvs", "show", "a.pvs", "--json"][..],
        &["pvs", "show", "a.pvs"],
        &["info", "procedural:boxes?size=50"],
    ] {
        let o = with_closed_stdout(args, dir.path());
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
        assert_eq!(stderr(&o), "", "{args:?}");
    }
}

#[test]
fn full_disk_on_stdout_is_a_clean_error() {
    let dir = tempfile::tempdir().unwrap();
    baked(dir.path(), "a.pvs", &[]);
    let teapot = workspace().join("scenes/teapot.obj");
    for args in [
        &["pvs", "show", "a.pvs", "--json"][..],
        &["info", teapot.to_str().unwrap()],
    ] {
        let o = with_full_stdout(args, dir.path());
        assert_fails_with(&o, "writing to stdout: No space left on device");
        assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));
    }
}

#[test]
fn thread_counts_far_above_the_cores_are_capped_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let o = bake(dir.path(), "t.pvs", &["--threads", "100000"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("warning: --threads: 100000 threads requested, using"),
        "{err}"
    );
    assert_fails_with(&bake(dir.path(), "z.pvs", &["--threads", "0"]), "at least 1");
}

#[test]
fn corrupt_checkpoint_is_named_with_the_restart_flag() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("c.pvs.checkpoint"), b"\x89garbage\x1b[2J").unwrap();
    let o = bake(dir.path(), "c.pvs", &[]);
    assert_fails_with(&o, "c.pvs.checkpoint");
    assert!(stderr(&o).contains("--restart"), "{}", stderr(&o));
    // The flag does what the message says.
    assert!(bake(dir.path(), "c.pvs", &["--restart"]).status.success());
}
