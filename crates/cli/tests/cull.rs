//! End-to-end tests of `sightline cull`: the default run prints a row per method, JSON and the
//! SVG plot are written, camera path files are used and bad ones are clean errors.

mod common;

use common::{assert_fails_with, sightline, stderr};

const SMALL: &[&str] = &["--frames", "12", "--size", "160x90"];

#[test]
fn default_scene_prints_a_row_per_method() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec!["cull", "procedural:grid?seed=2&size=2"];
    args.extend(SMALL);
    let o = sightline(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    for m in [
        "| grid |",
        "| frustum |",
        "| stop-and-wait |",
        "| two-phase-hzb |",
        "| stop-and-wait-triangles |",
    ] {
        assert!(out.contains(m), "{m} missing in:\n{out}");
    }
}

#[test]
fn json_and_plot_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec![
        "cull",
        "procedural:graveyard?seed=1&size=50",
        "--json",
        "--plot",
        "run.svg",
    ];
    args.extend(SMALL);
    let o = sightline(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let summaries = v["summaries"].as_array().unwrap();
    assert_eq!(summaries.len(), 5);
    assert_eq!(v["per_frame"][0]["frames"].as_array().unwrap().len(), 12);
    // The frustum baseline draws at least what any occlusion method draws.
    let drawn = |i: usize| summaries[i]["drawn_mean"].as_f64().unwrap();
    assert!(
        drawn(1) >= drawn(2) && drawn(1) >= drawn(3) && drawn(1) >= drawn(4),
        "{summaries:?}"
    );
    let svg = std::fs::read_to_string(dir.path().join("run.svg")).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.contains("polyline"),
        "{}",
        &svg[..200]
    );
}

#[test]
fn camera_path_file_is_used_and_interpolated() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("cam.json"),
        r#"{"frames": [{"eye": [7.5, 7.5, 1.7], "look": [7.5, 30, 1.7]},
                       {"eye": [7.5, 20, 1.7], "look": [7.5, 60, 1.7]}]}"#,
    )
    .unwrap();
    let mut args = vec![
        "cull",
        "procedural:grid?size=1",
        "--path",
        "cam.json",
        "--json",
    ];
    args.extend(SMALL);
    let o = sightline(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let frames = v["per_frame"][1]["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 12);
    assert!(frames.iter().all(|f| f["frustum"].as_u64().unwrap() > 0));
}

#[test]
fn other_scenes_are_animated() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec!["cull", "procedural:city?seed=1&size=300"];
    args.extend(SMALL);
    let o = sightline(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("| grid |"));
}

#[test]
fn bad_inputs_are_clean_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("bad.json"), "{\"frames\": [{\"eye\": [1, 2]}]}").unwrap();
    std::fs::write(d.join("empty.json"), "{\"frames\": []}").unwrap();
    std::fs::write(
        d.join("same.json"),
        "{\"frames\": [{\"eye\": [1, 1, 1], \"look\": [1, 1, 1]}]}",
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["cull", "procedural:grid?size=1"];
        args.extend(SMALL);
        args.extend(extra);
        sightline(&args, d)
    };
    assert_fails_with(&run(&["--path", "missing.json"]), "missing.json");
    assert_fails_with(&run(&["--path", "bad.json"]), "bad.json");
    assert_fails_with(&run(&["--path", "empty.json"]), "empty");
    assert_fails_with(&run(&["--path", "same.json"]), "frame 0");
    assert_fails_with(&run(&["--backend", "vulkan"]), "unknown backend");
    assert_fails_with(
        &sightline(&["cull", "procedural:grid?size=abc"], d),
        "bad size",
    );
    assert_fails_with(&sightline(&["cull", "nowhere.obj"], d), "nowhere.obj");
}

#[test]
fn gpu_backend_runs_on_vulkan_and_never_draws_more_than_frustum() {
    // CI installs mesa-vulkan-drivers (lavapipe); without a Vulkan driver this fails loudly.
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec![
        "cull",
        "procedural:graveyard?seed=1&size=50",
        "--backend",
        "gpu",
        "--json",
    ];
    args.extend(SMALL);
    let o = sightline(&args, dir.path());
    assert!(
        o.status.success(),
        "no Vulkan adapter? install mesa-vulkan-drivers: {}",
        stderr(&o)
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["backend"], "gpu");
    let summaries = v["summaries"].as_array().unwrap();
    assert_eq!(summaries.len(), 2, "grid and frustum on the GPU");
    let drawn = |i: usize| summaries[i]["drawn_mean"].as_f64().unwrap();
    assert!(drawn(0) <= drawn(1), "{summaries:?}");
    assert!(
        summaries[0]["queries_mean"].as_f64().unwrap() > 0.0,
        "{summaries:?}"
    );
}

/// `--eye` and `--look` (with `--fov`) hold the camera still, as in `render`: looking away from
/// the whole scene nothing is drawn, looking at it something is.
#[test]
fn a_still_camera_is_given_as_in_render() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["cull", "procedural:grid?seed=2&size=2", "--json"];
        args.extend(SMALL);
        args.extend(extra);
        sightline(&args, dir.path())
    };
    let frustum_drawn = |o: &std::process::Output| {
        assert!(o.status.success(), "{}", stderr(o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let s = v["summaries"].as_array().unwrap();
        let row = s.iter().find(|r| r["method"] == "frustum").unwrap();
        (
            row["drawn_mean"].as_f64().unwrap(),
            row["drawn_max"].as_u64().unwrap(),
        )
    };
    // The Grid spans 0..120 x 0..180 x 0..12: from high above one side, looking up and away,
    // the frustum holds nothing; looking down at its middle, something.
    let away = run(&["--eye", "-300,-300,600", "--look", "-600,-600,1200"]);
    assert_eq!(frustum_drawn(&away), (0.0, 0));
    let down = run(&["--eye", "-300,-300,600", "--look", "60,90,0", "--fov", "90"]);
    let (mean, max) = frustum_drawn(&down);
    assert!(mean > 0.0 && max > 0, "{mean} {max}");
    // A usage error (clap's exit status 2).
    let o = run(&["--eye", "0,0,1000"]);
    assert!(
        o.status.code() == Some(2) && stderr(&o).contains("--look"),
        "{}",
        stderr(&o)
    );
    assert_fails_with(
        &run(&["--eye", "0,0,1000", "--look", "0,0,0"]),
        "looking along the scene's up axis",
    );
    assert_fails_with(
        &run(&["--eye", "0,0,1", "--look", "1,0,1", "--fov", "0"]),
        "--fov",
    );
}
