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
    assert_fails_with(
        &bake(dir.path(), "z.pvs", &["--threads", "0"]),
        "at least 1",
    );
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

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = sightline(&["convert", "procedural:boxes?size=50", "-o", "t.obj"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    let original = std::fs::read(d.join("t.obj")).unwrap();
    std::fs::create_dir(d.join("sub")).unwrap();
    let cases: [&[&str]; 6] = [
        &["render", "t.obj", "-o", "t.obj"],
        // Another spelling of the same file.
        &["render", "t.obj", "-o", "sub/../t.obj"],
        &["visible", "t.obj", "-o", "./t.obj"],
        &["convert", "t.obj", "-o", "t.obj"],
        &[
            "pvs",
            "bake",
            "t.obj",
            "--cell",
            "point:0,0,0,1",
            "-o",
            "t.obj",
        ],
        &["render", "t.obj", "--cube", "-o", "t.png"],
    ];
    for args in &cases[..5] {
        assert_fails_with(&sightline(args, d), "is the input");
        assert_eq!(
            std::fs::read(d.join("t.obj")).unwrap(),
            original,
            "{args:?}"
        );
    }
    // A hard link is the same file under another name.
    std::fs::hard_link(d.join("t.obj"), d.join("link.obj")).unwrap();
    assert_fails_with(
        &sightline(&["convert", "t.obj", "-o", "link.obj"], d),
        "is the input",
    );
    // Writing elsewhere still works.
    let o = sightline(cases[5], d);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn render_refuses_image_names_it_would_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &["render", "procedural:boxes?size=50", "-o", "x.jpg"],
        dir.path(),
    );
    assert_fails_with(&o, "supported formats: png");
    assert!(!dir.path().join("x.jpg").exists());
}

#[test]
fn a_second_bake_of_the_same_output_is_refused_while_the_first_runs() {
    let dir = tempfile::tempdir().unwrap();
    // A bake that takes seconds: many random rays per round in one cell.
    let slow = Command::new(env!("CARGO_BIN_EXE_sightline"))
        .args([
            "pvs",
            "bake",
            SCENE,
            "--cell",
            "box:2,2,1,4,4,2",
            "--method",
            "rand",
            "--rays",
            "400000000",
            "-o",
            "same.pvs",
        ])
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut slow = scopeguard(slow);
    let lock = dir.path().join("same.pvs.lock");
    let start = std::time::Instant::now();
    while !lock.exists() && start.elapsed().as_secs() < 30 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let o = bake(dir.path(), "same.pvs", &[]);
    assert_fails_with(&o, "another bake");
    assert!(stderr(&o).contains("same.pvs.lock"), "{}", stderr(&o));
    slow.0.kill().unwrap();
    slow.0.wait().unwrap();
    // The lock died with its holder: the next bake runs.
    let o = bake(dir.path(), "same.pvs", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!lock.exists(), "the lock file is removed after a bake");
}

/// Kills the child when a test fails before it does.
struct Guard(std::process::Child);
fn scopeguard(c: std::process::Child) -> Guard {
    Guard(c)
}
impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn pvs_diff_exits_1_with_a_summary_when_sets_differ_and_2_on_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    baked(d, "a.pvs", &[]);
    baked(d, "b.pvs", &["--seed", "7"]);
    let o = sightline(&["pvs", "diff", "a.pvs", "a.pvs"], d);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 of 2 cells differ"));
    let o = sightline(&["pvs", "diff", "a.pvs", "b.pvs"], d);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(stderr(&o), "");
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    let last = out.lines().last().unwrap();
    assert!(
        last.contains("cells differ") && last.contains("added") && last.contains("removed"),
        "{out}"
    );
    let o = sightline(&["pvs", "diff", "a.pvs", "b.pvs", "--json"], d);
    assert_eq!(o.status.code(), Some(1));
    let _: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let o = sightline(&["pvs", "diff", "a.pvs", "missing.pvs"], d);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("missing.pvs"));
}

#[test]
fn an_os_error_is_printed_once() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["pvs", "show", "missing.pvs"], dir.path());
    assert_fails_with(&o, "missing.pvs");
    let text = std::io::Error::from_raw_os_error(2).to_string();
    assert_eq!(stderr(&o).matches(&text).count(), 1, "{}", stderr(&o));
}

#[test]
fn oversized_counts_are_refused_up_front_naming_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: [(&[&str], &str); 6] = [
        (
            &[
                "pvs",
                "bake",
                SCENE,
                "--grid",
                "1000,1000,1000",
                "--rays",
                "1000",
                "-o",
                "g.pvs",
            ],
            "limit of 1048576",
        ),
        (
            &["view", SCENE, "--frames", "100000000", "--out", "v"],
            "limit of 1000000 frames",
        ),
        (
            &["cull", "--frames", "4294967295"],
            "limit of 1000000 frames",
        ),
        (
            &["demo", "--frames", "4294967295", "-o", "r"],
            "limit of 1000000 frames",
        ),
        (
            &["bench", "trace", "--rays", "100000000000"],
            "limit of 33554432",
        ),
        (
            &["bench", "raster", "--frames", "100000000000"],
            "limit of 1000000 frames",
        ),
    ];
    for (args, needle) in cases {
        assert_fails_with(&sightline(args, d), needle);
    }
    // Each side within 1..=16384, but their product is the 3 GB image.
    let o = sightline(&["render", SCENE, "--size", "16384x16384"], d);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("above the limit of 67108864"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn file_content_quoted_in_an_error_is_escaped() {
    let dir = tempfile::tempdir().unwrap();
    // A binary file named .obj: the loader quotes the bad coordinate, terminal escapes and all.
    std::fs::write(
        dir.path().join("bin.obj"),
        b"v 1 2 \x1b[2J\x00\x07zz\nf 1 2 3\n",
    )
    .unwrap();
    let o = sightline(&["render", "bin.obj", "-o", "x.png"], dir.path());
    assert_fails_with(&o, "bin.obj");
    let err = stderr(&o);
    assert!(
        !err.chars().any(|c| c.is_control() && c != '\n'),
        "raw bytes in: {err:?}"
    );
    assert!(err.contains("\\u{1b}[2J"), "{err}");
}
