//! The optional parts of the CLI (cargo features `gpu` and `viewer`). This test runs in both
//! builds: the default one (`cargo test --workspace`) and the headless one (`cargo test -p
//! sightline-cli --no-default-features --test features`, in the README's test command), and
//! checks each against what it was built with: `--version` names the features, and in a build
//! without them the commands and flags that need them still parse but end with exit status 2
//! and a message naming the feature, before any scene is loaded.

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

#[allow(dead_code)] // `assert_fails_with` expects exit status 1; these failures are 2.
mod common;

use common::{sightline, stderr};

const GPU: bool = cfg!(feature = "gpu");
const VIEWER: bool = cfg!(feature = "viewer");

#[test]
fn version_names_the_features_built_in() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["--version"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    let line = text
        .lines()
        .find(|l| l.starts_with("features: "))
        .unwrap_or_else(|| panic!("no features line in {text:?}"));
    assert_eq!(line.contains("gpu"), GPU, "{line}");
    assert_eq!(line.contains("viewer"), VIEWER, "{line}");
    assert_eq!(line.contains("headless"), !GPU && !VIEWER, "{line}");
}

/// Runs `args` on a scene file that does not exist: a build without the feature must refuse
/// the request before it reads the scene (so the error names the feature), a build with it
/// gets as far as loading the scene.
fn refused_without(feature: &str, built: bool, args: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(args, dir.path());
    let err = stderr(&o);
    assert!(!o.status.success(), "{args:?} succeeded: {err}");
    let names_feature = err.contains(&format!("cargo feature `{feature}`"));
    assert_eq!(names_feature, !built, "{args:?}: {err}");
    if built {
        assert!(err.contains("missing.obj"), "{args:?}: {err}");
    } else {
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(!err.contains("missing.obj"), "read the scene first: {err}");
    }
}

#[test]
fn gpu_ray_casting_needs_the_gpu_feature() {
    refused_without(
        "gpu",
        GPU,
        &[
            "pvs",
            "bake",
            "missing.obj",
            "--device",
            "gpu",
            "-o",
            "a.pvs",
        ],
    );
}

#[test]
fn gpu_occlusion_backend_needs_the_gpu_feature() {
    refused_without("gpu", GPU, &["cull", "missing.obj", "--backend", "gpu"]);
}

#[test]
fn gpu_trace_bench_needs_the_gpu_feature() {
    refused_without(
        "gpu",
        GPU,
        &["bench", "trace", "missing.obj", "--device", "gpu"],
    );
}

#[test]
fn gpu_pvs_bench_needs_the_gpu_feature() {
    refused_without(
        "gpu",
        GPU,
        &["bench", "pvs", "missing.obj", "--device", "gpu"],
    );
}

#[test]
fn the_viewer_needs_the_viewer_feature() {
    refused_without("viewer", VIEWER, &["view", "missing.obj"]);
}

/// Every build bakes on the CPU: the headless build is a whole tool, not a stub.
#[test]
fn every_build_bakes_on_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &[
            "pvs",
            "bake",
            "procedural:rooms?seed=2&size=2000",
            "--cell",
            "box:2,2,1,4,4,2",
            "--n-rand",
            "20000",
            "-o",
            "a.pvs",
            "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["cells"], 1);
    assert!(v["mean_pvs_size"].as_f64().unwrap() > 10.0);
}
