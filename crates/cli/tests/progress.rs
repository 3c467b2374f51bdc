//! Progress bars of the long commands (`cull`, `render --cube`, `bench`): drawn on stderr when
//! it is a terminal (here a pseudo-terminal from util-linux's `script`, in Debian's essential
//! `bsdutils`), with stdout redirected to a file that stays clean JSON; absent from stderr when
//! it is not a terminal.

#![cfg(unix)]
// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

#[allow(dead_code)] // `assert_fails_with`: every run here succeeds.
mod common;

use std::path::Path;
use std::process::Command;

use common::{sightline, stderr};

/// Small runs of the commands with progress bars, each with `--json`, and the unit its bar
/// counts.
const RUNS: &[(&[&str], &str)] = &[
    (
        &[
            "cull",
            "procedural:grid?seed=2&size=2",
            "--frames",
            "20",
            "--size",
            "64x36",
            "--json",
        ],
        "frames",
    ),
    (
        &[
            "render",
            "procedural:boxes?size=200",
            "--cube",
            "--size",
            "32x32",
            "-o",
            "cube.png",
            "--json",
        ],
        "faces",
    ),
    (
        &[
            "bench",
            "raster",
            "procedural:boxes?size=200",
            "--size",
            "32",
            "--frames",
            "2",
            "--json",
        ],
        "scenes",
    ),
];

/// Runs `sightline ARGS > out.json` in `dir` under a pseudo-terminal: returns what the
/// terminal showed (stderr) and the JSON written to stdout.
fn on_a_terminal(args: &[&str], dir: &Path) -> (String, serde_json::Value) {
    let quoted: Vec<String> = args.iter().map(|a| format!("'{a}'")).collect();
    let line = format!(
        "'{}' {} > out.json",
        env!("CARGO_BIN_EXE_sightline"),
        quoted.join(" ")
    );
    let o = Command::new("script")
        .args(["-q", "-e", "-c", &line, "/dev/null"])
        .current_dir(dir)
        .output()
        .expect("util-linux `script` runs (Debian: bsdutils)");
    let terminal = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{args:?}: {terminal}");
    let json = std::fs::read(dir.join("out.json")).unwrap();
    let json = serde_json::from_slice(&json)
        .unwrap_or_else(|e| panic!("{args:?}: stdout is not JSON ({e}): {terminal}"));
    (terminal, json)
}

#[test]
fn bars_show_on_a_terminal_and_stdout_stays_json() {
    for (args, unit) in RUNS {
        let dir = tempfile::tempdir().unwrap();
        let (terminal, json) = on_a_terminal(args, dir.path());
        assert!(
            terminal.contains(&format!("{unit} ")) && terminal.contains('/'),
            "{args:?}: no {unit} bar on the terminal: {terminal:?}"
        );
        assert!(!json.is_null(), "{args:?}");
    }
}

#[test]
fn no_bar_when_stderr_is_not_a_terminal() {
    for (args, unit) in RUNS {
        let dir = tempfile::tempdir().unwrap();
        let o = sightline(args, dir.path());
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        let err = stderr(&o);
        assert!(!err.contains(unit), "{args:?}: progress on a pipe: {err:?}");
        let _: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    }
}
