#![allow(clippy::unwrap_used)]
//! End-to-end tests of `sightline view` in its headless mode (the window cannot run in CI):
//! frames and `frames.json` are written, a `.pvs` drives the `pvs` method, bad input is a
//! clean error. Needs a Vulkan adapter (lavapipe in CI) and fails without one.

mod common;

use common::{assert_fails_with, sightline, stderr};

const CITY: &str = "procedural:city?size=2000";

#[test]
fn headless_orbit_writes_frames_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &[
            "view", CITY, "--frames", "2", "--out", "out", "--size", "64x48", "--method", "exact",
            "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["frame_0000.png", "frame_0001.png"] {
        let img = image::open(dir.path().join("out").join(f)).unwrap();
        assert_eq!((img.width(), img.height()), (64, 48));
    }
    assert!(!dir.path().join("out/frame_0002.png").exists());
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("out/frames.json")).unwrap())
            .unwrap();
    let frames = json["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 2);
    assert!(frames.iter().all(|f| f["method"] == "exact"));
    // The printed summary is the same report.
    let printed: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(printed["popping"], json["popping"]);
}

#[test]
fn pvs_file_drives_the_pvs_method_along_a_path() {
    let dir = tempfile::tempdir().unwrap();
    bake_city_and_path(dir.path());
    let o = sightline(
        &[
            "view",
            CITY,
            "--pvs",
            "city.pvs",
            "--path",
            "path.json",
            "--frames",
            "3",
            "--out",
            "out",
            "--size",
            "80x60",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("out/frames.json")).unwrap())
            .unwrap();
    let frames = json["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    // First and last frame are in opposite cells of the 2x2 grid; the PVS culls.
    assert_eq!(frames[0]["method"], "pvs");
    assert!(frames[0]["cell"].is_u64() && frames[2]["cell"].is_u64());
    assert_ne!(frames[0]["cell"], frames[2]["cell"]);
    for f in frames {
        assert!(f["triangles_drawn"].as_u64() < f["triangles_total"].as_u64());
    }
}

#[test]
fn bad_arguments_are_clean_errors() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &[
            "view", CITY, "--method", "pvs", "--frames", "1", "--out", "o",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "--method pvs needs --pvs");
    let o = sightline(
        &[
            "view", CITY, "--method", "magic", "--frames", "1", "--out", "o",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "unknown method \"magic\"");
    std::fs::write(dir.path().join("bad.json"), "{\"frames\": []}").unwrap();
    let o = sightline(
        &[
            "view", CITY, "--path", "bad.json", "--frames", "1", "--out", "o",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "bad.json");
    std::fs::write(dir.path().join("x.pvs"), b"not a pvs").unwrap();
    let o = sightline(
        &[
            "view", CITY, "--pvs", "x.pvs", "--frames", "1", "--out", "o",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "x.pvs");
    // --frames without --out is refused by the argument parser.
    let o = sightline(&["view", CITY, "--frames", "1"], dir.path());
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--out"), "{}", stderr(&o));
}

#[test]
fn window_without_a_display_is_a_clean_error_pointing_to_headless_mode() {
    let dir = tempfile::tempdir().unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_sightline"))
        .args(["view", CITY])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_fails_with(&o, "--frames N --out DIR");
    assert!(stderr(&o).contains("DISPLAY"), "{}", stderr(&o));
}

#[test]
fn headless_run_without_a_session_prints_no_display_errors() {
    let dir = tempfile::tempdir().unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_sightline"))
        .args([
            "view", CITY, "--frames", "1", "--out", "out", "--size", "32x32",
        ])
        .current_dir(dir.path())
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("DISPLAY")
        .env_remove("NODEVICE_SELECT")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("XDG_RUNTIME_DIR"), "{}", stderr(&o));
}

#[cfg(feature = "viewer")]
#[test]
fn hud_flag_draws_text_in_the_top_left_band_only() {
    use sightline_view::{hud_height, HUD_TEXT};
    let dir = tempfile::tempdir().unwrap();
    let frame = |out: &str, hud: bool| {
        let mut args = vec![
            "view", CITY, "--frames", "1", "--out", out, "--size", "160x120",
        ];
        if hud {
            args.push("--hud");
        }
        let o = sightline(&args, dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        image::open(dir.path().join(out).join("frame_0000.png"))
            .unwrap()
            .to_rgba8()
    };
    let plain = frame("plain", false);
    let hud = frame("hud", true);
    // Headless HUD: five lines (method, triangles, objects, popping, frame) at scale 1.
    let band = hud_height(5, 1);
    let mut text = 0;
    for (x, y, p) in hud.enumerate_pixels() {
        if p != plain.get_pixel(x, y) {
            assert!(
                y < band,
                "pixel ({x}, {y}) changed below the HUD's {band} rows"
            );
        }
        text += usize::from(p.0 == HUD_TEXT);
    }
    assert!(text > 400, "only {text} pixels of the HUD's text colour");
    assert!(plain.pixels().filter(|p| p.0 == HUD_TEXT).count() < 10);
}

#[cfg(feature = "viewer")]
#[test]
fn help_lists_every_control_of_the_window() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["view", "--help"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let help = String::from_utf8(o.stdout).unwrap();
    // The window's key handler reads the same table (sightline_view::action_of).
    for control in sightline_view::CONTROLS {
        let line = help
            .lines()
            .find(|l| l.trim_start().starts_with(control.input) && l.ends_with(control.does));
        assert!(
            line.is_some(),
            "{} ({}) not in:\n{help}",
            control.input,
            control.does
        );
    }
    for key in ["W", "1", "4", "X", "P", "C", "H, F1", "Esc"] {
        assert!(
            sightline_view::CONTROLS.iter().any(|c| c.input == key),
            "{key} missing from the table"
        );
    }
    assert!(help.contains("--hud"), "{help}");
    // The short help points to the long one.
    let o = sightline(&["view", "-h"], dir.path());
    assert!(String::from_utf8(o.stdout).unwrap().contains("see --help"));
}

/// Bakes a 2x2 grid of street-level cells over [`CITY`] into `dir/city.pvs` (small budget) and
/// writes `dir/path.json`, a flight from one corner cell to the opposite one.
fn bake_city_and_path(dir: &std::path::Path) {
    let bake = sightline(
        &[
            "pvs",
            "bake",
            CITY,
            "--grid",
            "2,2,1",
            "--bounds=-150,-150,1,140,140,4",
            "--method",
            "rand",
            "--rays",
            "20000",
            "-o",
            "city.pvs",
        ],
        dir,
    );
    assert!(bake.status.success(), "{}", stderr(&bake));
    std::fs::write(
        dir.join("path.json"),
        r#"{"frames": [{"eye": [-100, -100, 2], "look": [100, -100, 10]},
                       {"eye": [100, 100, 2], "look": [200, 100, 10]}]}"#,
    )
    .unwrap();
}

/// Runs `sightline view` with `args` (after the scene; 96x64 pixels unless they give a
/// `--size`) into `dir/out`, returns its frames.json.
fn view_frames(dir: &std::path::Path, out: &str, args: &[&str]) -> serde_json::Value {
    let mut all = vec!["view", CITY, "--out", out];
    if !args.contains(&"--size") {
        all.extend(["--size", "96x64"]);
    }
    all.extend_from_slice(args);
    let o = sightline(&all, dir);
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_slice(&std::fs::read(dir.join(out).join("frames.json")).unwrap()).unwrap()
}

/// `triangles_drawn` of every frame.
fn drawn(json: &serde_json::Value) -> Vec<u64> {
    json["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["triangles_drawn"].as_u64().unwrap())
        .collect()
}

#[test]
fn freeze_at_keeps_the_frozen_frames_set_while_the_camera_moves() {
    let dir = tempfile::tempdir().unwrap();
    bake_city_and_path(dir.path());
    let common = [
        "--path",
        "path.json",
        "--frames",
        "5",
        "--method",
        "occlusion",
    ];
    let live = view_frames(dir.path(), "live", &common);
    let live_drawn = drawn(&live);
    // Without freezing, occlusion culling's set changes along the flight.
    assert!(
        live_drawn[1..].windows(2).any(|w| w[0] != w[1]),
        "{live_drawn:?}"
    );
    let mut args = common.to_vec();
    args.extend(["--freeze-at", "1"]);
    let frozen = view_frames(dir.path(), "frozen", &args);
    let frozen_drawn = drawn(&frozen);
    // Frame 0 is live; from frame 1 on, frame 1's set (the same camera as the live run's).
    assert_eq!(frozen_drawn[0], live_drawn[0]);
    assert!(
        frozen_drawn[1..].iter().all(|&d| d == live_drawn[1]),
        "{frozen_drawn:?} vs {live_drawn:?}"
    );
    let frames = frozen["frames"].as_array().unwrap();
    assert!(frames[0]["frozen_at"].is_null());
    assert_eq!(frames[0]["popping_counted"], true);
    for f in &frames[1..] {
        assert_eq!(f["frozen_at"], 1);
        assert_eq!(f["popping_counted"], false);
    }
    // Only the live frame's popping is in the summary.
    assert_eq!(frozen["popping"]["frames"], 1);
    let o = sightline(
        &[
            "view",
            CITY,
            "--frames",
            "2",
            "--out",
            "o",
            "--freeze-at",
            "2",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "--freeze-at 2 is past the last frame");
}

#[test]
fn picked_cell_drives_the_pvs_method_from_anywhere() {
    let dir = tempfile::tempdir().unwrap();
    bake_city_and_path(dir.path());
    let pvs = sightline_region::PvsFile::load(&dir.path().join("city.pvs")).unwrap();
    assert_eq!(pvs.cells.len(), 4);
    let eye = view_frames(
        dir.path(),
        "eye",
        &["--pvs", "city.pvs", "--path", "path.json", "--frames", "3"],
    );
    for cell in [0usize, 3] {
        let size = pvs.cells[cell].visible.count_ones(..) as u64;
        let out = format!("cell{cell}");
        let json = view_frames(
            dir.path(),
            &out,
            &[
                "--pvs",
                "city.pvs",
                "--path",
                "path.json",
                "--frames",
                "3",
                "--cell",
                &cell.to_string(),
            ],
        );
        assert_eq!(drawn(&json), vec![size; 3], "cell {cell}");
        for f in json["frames"].as_array().unwrap() {
            assert_eq!(f["cell"], cell);
            assert_eq!(f["cell_picked"], true);
        }
    }
    // Without a pick, the flight passes through cells of different sets.
    let eye_frames = eye["frames"].as_array().unwrap();
    assert_eq!(eye_frames[0]["cell_picked"], false);
    assert_ne!(eye_frames[0]["cell"], eye_frames[2]["cell"]);
    let o = sightline(
        &[
            "view", CITY, "--pvs", "city.pvs", "--cell", "4", "--frames", "1", "--out", "o",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "the .pvs has 4 cells (0 to 3)");
    let o = sightline(
        &["view", CITY, "--cell", "0", "--frames", "1", "--out", "o"],
        dir.path(),
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--pvs"), "{}", stderr(&o));
}

#[cfg(feature = "viewer")]
#[test]
fn overview_shows_the_cells_in_the_report_maps_colours() {
    use sightline_eval::report::colour::ColourScale;
    let dir = tempfile::tempdir().unwrap();
    bake_city_and_path(dir.path());
    let pvs = sightline_region::PvsFile::load(&dir.path().join("city.pvs")).unwrap();
    let sizes: Vec<f64> = pvs
        .cells
        .iter()
        .map(|c| c.visible.count_ones(..) as f64)
        .collect();
    let scale = ColourScale::spanning(sizes.iter().copied());
    let ramp: Vec<[u8; 3]> = sizes.iter().map(|&s| scale.colour(s)).collect();
    let image = |out: &str, args: &[&str]| {
        let mut all = vec!["--frames", "1", "--overview", "--size", "160x120"];
        all.extend_from_slice(args);
        let json = view_frames(dir.path(), out, &all);
        assert_eq!(json["frames"][0]["overview"], true);
        image::open(dir.path().join(out).join("frame_0000.png"))
            .unwrap()
            .to_rgba8()
    };
    let count = |img: &image::RgbaImage, colours: &[[u8; 3]]| {
        img.pixels()
            .filter(|p| colours.iter().any(|c| p.0[..3] == c[..]))
            .count()
    };
    let with_cells = image("cells", &["--pvs", "city.pvs"]);
    let without = image("plain", &[]);
    // Not blank: the scene's shaded faces from above.
    let mut colours: Vec<[u8; 4]> = without.pixels().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 20, "only {} colours", colours.len());
    // The cells' outlines are in their ramp colours; without a .pvs there are none.
    let (n_cells, n_plain) = (count(&with_cells, &ramp), count(&without, &ramp));
    assert!(
        n_cells >= 40 && n_plain * 10 < n_cells,
        "{n_cells} pixels of the cells' colours with cells, {n_plain} without"
    );
    // Frozen: the frozen camera's frustum and marker in orange (guides.rs's FRUSTUM), which no
    // shaded face reaches (their red stays below 0.9).
    let orange = |img: &image::RgbaImage| {
        img.pixels()
            .filter(|p| {
                let [r, g, b, _] = p.0;
                r == 255 && g.abs_diff(140) <= 1 && b.abs_diff(26) <= 1
            })
            .count()
    };
    let frozen = image("frozen", &["--path", "path.json", "--freeze-at", "0"]);
    assert!(
        orange(&frozen) >= 10 && orange(&without) == 0,
        "{} orange pixels frozen, {} live",
        orange(&frozen),
        orange(&without)
    );
}
