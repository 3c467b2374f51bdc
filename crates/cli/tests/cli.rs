//! End-to-end tests of the `sightline` binary: exit codes, error messages that name the problem,
//! outputs that are written (and never half-written).

mod common;

use common::{assert_fails_with, sightline, stderr};

#[test]
fn info_json_reports_counts_of_default_scene() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["info", "--json"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let triangles = v["validation"]["triangles"].as_u64().unwrap();
    assert!(triangles > 10_000, "default city has {triangles} triangles");
    assert_eq!(v["errors"].as_array().unwrap().len(), 0);
    assert_eq!(v["source"], "procedural:city?seed=1&size=20000");
}

#[test]
fn missing_file_is_clean_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["info", "no-such-scene.obj"], dir.path());
    assert_fails_with(&o, "no-such-scene.obj");
}

#[test]
fn unknown_generator_is_clean_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["info", "procedural:village"], dir.path());
    assert_fails_with(&o, "unknown generator 'village'");
}

#[test]
fn nan_eye_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["render", "--eye", "nan,0,0", "-o", "x.png"], dir.path());
    assert_eq!(o.status.code(), Some(2), "clap usage error: {}", stderr(&o));
    assert!(stderr(&o).contains("not finite"));
    assert!(!dir.path().join("x.png").exists());
}

#[test]
fn eye_equal_to_look_is_clean_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["render", "--eye", "1,2,3", "--look", "1,2,3"], dir.path());
    assert_fails_with(&o, "coincide");
}

#[test]
fn render_writes_png_of_requested_size() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &[
            "render",
            "procedural:boxes?size=2000",
            "--size",
            "64x48",
            "-o",
            "out.png",
            "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(dir.path().join("out.png")).unwrap();
    assert_eq!((img.width(), img.height()), (64, 48));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["visible_triangles"].as_u64().unwrap() > 0);
}

#[test]
fn failed_render_keeps_existing_output() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("keep.png"), b"precious").unwrap();
    // An output directory that does not exist: the write fails after rendering.
    let o = sightline(
        &["render", "--size", "8x8", "-o", "missing/keep.png"],
        dir.path(),
    );
    assert_fails_with(&o, "missing/keep.png");
    assert_eq!(
        std::fs::read(dir.path().join("keep.png")).unwrap(),
        b"precious"
    );
}

#[test]
fn empty_scene_file_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("empty.obj"), "# nothing here\n").unwrap();
    let o = sightline(&["render", "empty.obj"], dir.path());
    assert_fails_with(&o, "no triangles");
}

#[test]
fn exact_png_is_srgb_encoded_and_tagged() {
    // The anti-aliased values are linear light (area averages); the file must hold their sRGB
    // codes and say so. Expected codes: the library's image through the sRGB formula, written
    // out here independently of the CLI's own.
    use glam::Vec3;
    use sightline_point::analytic::{
        antialiased_image, visible_fragments, AnalyticOptions, Filter,
    };
    let dir = tempfile::tempdir().unwrap();
    let bunny = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/bunny.obj");
    let scene = sightline_core::scene::open(bunny, &Default::default()).unwrap();
    let b = scene.bounds();
    let (look, near) = (b.center(), 1e-3 * b.diagonal());
    let eye = look + Vec3::new(0.0, 0.0, 1.2 * b.diagonal());
    let camera = sightline_core::Camera::look_at(eye, look, Vec3::Y, 45.0, 48, 32, near).unwrap();
    let result = visible_fragments(&scene, &camera, &AnalyticOptions::default()).unwrap();
    let srgb = |v: f32| {
        let v = f64::from(v).clamp(0.0, 1.0);
        let e = if v <= 0.003_130_8 {
            12.92 * v
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        };
        (e * 255.0).round() as u8
    };
    let vec3 = |v: Vec3| format!("{},{},{}", v.x, v.y, v.z);
    let (eye, look, near) = (vec3(eye), vec3(look), near.to_string());
    for (name, filter) in [
        ("box", Filter::Box),
        ("gauss", Filter::Gauss { radius_px: 2.3 }),
    ] {
        let file = format!("{name}.png");
        let args = [
            "visible", bunny, "--exact", "--size", "48x32", "--eye", &eye, "--look", &look, "--up",
            "0,1,0", "--fov", "45", "--near", &near, "--png", &file, "--filter", name,
        ];
        let o = sightline(&args, dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        let bytes = std::fs::read(dir.path().join(&file)).unwrap();
        let chunk = |tag: &[u8]| bytes.windows(4).position(|w| w == tag);
        let (tag, idat) = (chunk(b"sRGB"), chunk(b"IDAT"));
        assert!(
            tag.is_some() && tag < idat,
            "{name}: no sRGB chunk before the image data"
        );
        let codes = image::open(dir.path().join(&file)).unwrap().into_luma8();
        assert_eq!(codes.dimensions(), (48, 32));
        let linear = antialiased_image(&result, &scene, &camera, filter);
        let worst = codes
            .pixels()
            .zip(&linear)
            .map(|(c, &v)| c.0[0].abs_diff(srgb(v)))
            .max()
            .unwrap();
        assert_eq!(
            worst, 0,
            "{name}: a code differs from the sRGB encoding by {worst}"
        );
        // And the encoding is not the identity: mid-grey values gain 30-60 codes.
        assert!(linear
            .iter()
            .any(|&v| srgb(v) > (v * 255.0).round() as u8 + 30));
    }
}

#[test]
fn conservative_visible_set_misses_nothing_the_reference_sees() {
    let dir = tempfile::tempdir().unwrap();
    let bunny = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/bunny.obj");
    let o = sightline(
        &[
            "visible",
            bunny,
            "--conservative",
            "--size",
            "128x128",
            "--json",
            "-o",
            "ids.txt",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["missed"], 0);
    let visible = v["visible"].as_u64().unwrap();
    assert!(visible >= v["reference_visible"].as_u64().unwrap());
    let ids = std::fs::read_to_string(dir.path().join("ids.txt")).unwrap();
    assert_eq!(ids.lines().count() as u64, visible);
    // Without the cross-check: the same set, and no reference figures claimed.
    let args = [
        "visible",
        bunny,
        "--conservative",
        "--no-check",
        "--size",
        "128x128",
        "--json",
    ];
    let o = sightline(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let unchecked: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(unchecked["visible"].as_u64(), Some(visible));
    for key in ["reference", "reference_visible", "overestimation", "missed"] {
        assert!(unchecked[key].is_null(), "{key}: {}", unchecked[key]);
    }
}

#[test]
fn conservative_from_a_cell_keeps_every_sampled_hit() {
    let dir = tempfile::tempdir().unwrap();
    let from_cell = |extra: &[&str]| {
        let cell = [
            "visible",
            "procedural:city?size=6000",
            "--conservative",
            "--cell",
            "point:-6,-6,2,1",
        ];
        sightline(&[&cell[..], extra].concat(), dir.path())
    };
    let o = from_cell(&["--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["missed"], 0);
    let (visible, seen) = (
        v["visible"].as_u64().unwrap(),
        v["reference_visible"].as_u64().unwrap(),
    );
    assert!(seen > 0 && visible >= seen);
    // Conservative, but far from everything: most of the city is hidden from one street.
    assert!(visible < v["triangles"].as_u64().unwrap() / 2);

    // With occluder fusion: still every sampled hit, and never more than without.
    let o = from_cell(&["--fusion-splits", "4", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let fused: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(fused["missed"], 0);
    assert!(fused["visible"].as_u64().unwrap() <= visible);

    let o = from_cell(&["--fusion-splits", "99"]);
    assert_fails_with(&o, "fusion_splits 99 is more than 12");
}

#[test]
fn malformed_cell_is_clean_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &["visible", "--conservative", "--cell", "box:1,2,3"],
        dir.path(),
    );
    assert_fails_with(&o, "box needs 6 numbers");
}

#[test]
fn impossible_memory_budget_is_clean_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &["visible", "--conservative", "--memory", "1KiB"],
        dir.path(),
    );
    assert_fails_with(&o, "too small");
}

#[test]
fn convert_keeps_triangle_ids() {
    let dir = tempfile::tempdir().unwrap();
    let spec = "procedural:spheres?size=2000";
    let mut hashes = Vec::new();
    for out in ["s.ply", "s.obj", "s.glb"] {
        let o = sightline(&["convert", spec, "-o", out, "--json"], dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        let written: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let o = sightline(&["info", out, "--json"], dir.path());
        let read: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(
            written["geometry_hash"], read["geometry_hash"],
            "{out} changed the ids"
        );
        hashes.push(read["geometry_hash"].clone());
    }
    assert!(hashes.windows(2).all(|w| w[0] == w[1]));
}

#[test]
fn convert_keeps_objects_of_a_bsp() {
    // Objects are (model, shader) pairs whose triangles are not contiguous (198 runs for 19
    // objects), so the writers emit several nodes / `o` lines per object.
    let dir = tempfile::tempdir().unwrap();
    let map = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/q3dm6ish.bsp");
    let info = |scene: &str| {
        let o = sightline(&["info", scene, "--json"], dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let loaded = info(map);
    let objects = loaded["objects"].as_array().unwrap();
    assert!(objects.len() > 10, "{} objects", objects.len());
    assert!(objects[0]["name"].as_str().unwrap().starts_with("model0/"));
    assert_eq!(objects[0]["index"], 0);
    assert!(objects[0]["part"].is_u64());
    for out in ["q.obj", "q.glb"] {
        let o = sightline(&["convert", map, "-o", out, "--json"], dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        let written: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(written["objects"], objects.len());
        let back = info(out);
        assert_eq!(back["geometry_hash"], loaded["geometry_hash"], "{out}");
        // Names, index, part and triangle count of every object, in object order.
        assert_eq!(back["objects"], loaded["objects"], "{out}");
    }
}

#[test]
fn demo_writes_report_with_every_step() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &[
            "demo",
            "procedural:city?size=5000",
            "--size",
            "128",
            "--cells",
            "2",
            "--n-rand",
            "100000",
            "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["steps"].as_array().unwrap().len() >= 7);
    // RAND gets each cell's own GVS++ ray count (the bake reports cells in completion order;
    // the demo used to pair them by that order).
    let cells = v["equal_rays"].as_array().unwrap();
    assert_eq!(cells.len(), 2);
    for c in cells {
        assert!(c["gvspp_rays"].as_u64().unwrap() > 0, "{c}");
        assert_eq!(c["gvspp_rays"], c["rand_rays"], "{c}");
    }
    let pvs = dir.path().join("sightline-report/demo.pvs");
    let o = sightline(
        &["pvs", "show", pvs.to_str().unwrap(), "--json"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let shown: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let text = shown.to_string();
    for c in cells {
        let rays = c["gvspp_rays"].as_u64().unwrap().to_string();
        assert!(
            text.contains(&rays),
            "cell rays {rays} not in the file's metadata"
        );
    }
    let html = std::fs::read_to_string(dir.path().join("sightline-report/index.html")).unwrap();
    for id in [
        "steps-table",
        "cell-table",
        "from-point-table",
        "rand-table",
        "culling-table",
    ] {
        assert!(html.contains(&format!("<table id=\"{id}\"")), "no {id}");
    }
    // What the numbers mean for a player: the error on a 1080p frame, the method to ship.
    assert!(html.contains("<p id=\"error-for-a-player\">For a player: an average of "));
    assert!(html.contains("<p id=\"culling-advice\">"));
    assert!(html.contains("Which to ship: ") || html.contains("Every method culled"));
    // Self-contained: images are inline, the PNG files beside it are extras.
    assert!(html.contains("src=\"data:image/png;base64,"));
    assert!(!html.contains("src=\"overview.png"));
    assert!(dir.path().join("sightline-report/overview.png").exists());
    assert!(dir.path().join("sightline-report/demo.pvs").exists());
}

/// `bench pvs` at small ray budgets: one GVS++ and one RAND row per budget, each within its
/// budget, and `--plot` draws both methods' error against seconds.
#[test]
fn bench_pvs_compares_gvspp_and_rand_at_small_budgets_and_plots_them() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &[
            "bench",
            "pvs",
            "procedural:rooms?size=2000",
            "--cells",
            "1",
            "--viewpoints",
            "2",
            "--resolution",
            "64",
            "--equal-time-only",
            "--time-budgets",
            "none",
            "--ray-budgets",
            "5000,20000",
            "--plot",
            "plots",
            "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    let got: Vec<(&str, &str)> = rows
        .iter()
        .map(|r| (r["method"].as_str().unwrap(), r["budget"].as_str().unwrap()))
        .collect();
    assert_eq!(
        got,
        [
            ("GVS++", "5000 rays"),
            ("RAND", "5000 rays"),
            ("GVS++", "20000 rays"),
            ("RAND", "20000 rays")
        ]
    );
    for r in rows {
        let budget: f64 = r["budget"]
            .as_str()
            .unwrap()
            .split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        let rays = r["mean_rays"].as_f64().unwrap();
        assert!(rays > 0.0 && rays <= budget * 1.05, "{r}");
    }
    let svg = std::fs::read_to_string(
        dir.path()
            .join("plots/budgets_procedural_rooms_size_2000.svg"),
    )
    .unwrap();
    assert!(
        svg.matches("<polyline").count() >= 2 && svg.contains("RAND"),
        "{svg}"
    );
    // --equal-time-only skips the converged bake, and with it the convergence curves.
    assert!(!dir
        .path()
        .join("plots/convergence_procedural_rooms_size_2000.svg")
        .exists());
}

#[test]
fn bench_rv_reports_both_views_and_passes_consistently() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "bench",
        "rv",
        "--triangles",
        "30000",
        "--size",
        "128",
        "--rounds",
        "1",
        "--threads",
        "2",
        "--json",
    ];
    let o = sightline(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(
        rows.len(),
        4,
        "street and aerial, each with and without the re-test"
    );
    for view in ["street", "aerial"] {
        let of = |retest: bool| {
            rows.iter()
                .find(|r| r["view"] == view && r["retest_pass"] == retest)
                .unwrap_or_else(|| panic!("{view} retest={retest} missing"))
        };
        let (two, one) = (of(true), of(false));
        let n = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap();
        // The same stream and the same first pass in both configurations.
        assert_eq!(two["triangles_streamed"], one["triangles_streamed"]);
        assert_eq!(two["first_pass_visible"], one["first_pass_visible"]);
        assert!(n(two, "triangles_streamed") >= 24_000.0);
        assert!(n(two, "on_screen") <= n(two, "triangles_streamed"));
        // The re-test only removes triangles; the single pass reports its first pass.
        assert!(n(two, "visible") <= n(two, "first_pass_visible"));
        assert_eq!(n(one, "visible"), n(one, "first_pass_visible"));
        for r in [two, one] {
            assert!(n(r, "min_seconds") <= n(r, "median_seconds"));
            assert!(n(r, "median_seconds") <= n(r, "max_seconds"));
            assert!(n(r, "mtriangles_per_second") > 0.0);
            assert!(n(r, "peak_memory_mib") <= 256.0);
        }
    }
}

#[test]
fn bench_trace_gpu_measures_the_gpu_casters_beside_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "bench",
        "trace",
        "--device",
        "gpu",
        "--gpu-width",
        "8",
        "--rays",
        "2000",
        "--size",
        "32",
        "--seconds",
        "0.05",
        "--json",
        "procedural:city?size=2000",
    ];
    let o = sightline(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = v.as_array().unwrap();
    let backends: Vec<&str> = rows
        .iter()
        .map(|r| r["backend"].as_str().unwrap())
        .collect();
    assert_eq!(backends[0], "sightline BVH");
    // Two GPU rows on an adapter with ray queries (CI's lavapipe, Mesa 25): the compute
    // caster, named with its node width and the adapter, and the ray-query caster.
    let [compute, ray_query] = &rows[rows.len() - 2..] else {
        panic!("{backends:?}");
    };
    let name = compute["backend"].as_str().unwrap();
    assert!(name.starts_with("GPU BVH8 ("), "{name}");
    let name = ray_query["backend"].as_str().unwrap();
    assert!(name.starts_with("GPU ray queries ("), "{name}");
    for gpu in [compute, ray_query] {
        assert!(gpu["incoherent_mrays"].as_f64().unwrap() > 0.0);
        assert!(gpu["coherent_mrays"].as_f64().unwrap() > 0.0);
    }
    // `--gpu-caster compute` measures the compute caster alone.
    let compute_only = [&args[..4], &["--gpu-caster", "compute"], &args[4..]].concat();
    let o = sightline(&compute_only, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let names: Vec<&str> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["backend"].as_str().unwrap())
        .collect();
    assert!(
        names.iter().all(|n| !n.starts_with("GPU ray queries")),
        "{names:?}"
    );
    assert!(names.last().unwrap().starts_with("GPU BVH8 ("), "{names:?}");
}

#[test]
fn bench_pvs_gpu_repeats_gvspp_on_the_gpu_with_the_same_sets() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "bench",
        "pvs",
        "--device",
        "gpu",
        "--gpu-caster",
        "compute",
        "--cells",
        "2",
        "--viewpoints",
        "2",
        "--resolution",
        "32",
        "--n-rand",
        "2000",
        "--time-budgets",
        "none",
        "--ray-budgets",
        "6000",
        "--equal-time-only",
        "--json",
        "procedural:rooms?seed=2&size=2000",
    ];
    let o = sightline(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = v.as_array().unwrap();
    let methods: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    assert_eq!(methods, ["GVS++", "RAND", "GVS++ GPU"]);
    let (cpu, gpu) = (&rows[0], &rows[2]);
    // The compute caster's hits are bit-identical on lavapipe (SHADER_F64): the same rays,
    // the same sets.
    assert_eq!(gpu["differing_cells"], 0);
    assert!(cpu.get("differing_cells").is_none());
    assert_eq!(gpu["budget"], cpu["budget"]);
    assert_eq!(gpu["mean_rays"], cpu["mean_rays"]);
    assert_eq!(gpu["pvs_percent"], cpu["pvs_percent"]);
    assert!(gpu["mean_seconds"].as_f64().unwrap() > 0.0);
    assert!(
        stderr(&o).contains("GVS++ GPU rows: compute caster on"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bench_trace_rejects_an_unknown_device() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["bench", "trace", "--device", "tpu"], dir.path());
    assert_eq!(o.status.code(), Some(2), "clap usage error: {}", stderr(&o));
    assert!(stderr(&o).contains("tpu"));
}

#[test]
fn bench_rv_rejects_zero_rounds() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["bench", "rv", "--rounds", "0"], dir.path());
    assert_fails_with(&o, "--rounds");
}

/// `bench peers` without peer harnesses: ours alone on a random set and one simulated frame's
/// occluders, with a note that the MOC columns are missing; JSON has a row per set.
#[test]
fn bench_peers_without_harnesses_measures_ours_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &[
            "bench",
            "peers",
            "--no-rays",
            "--legs",
            "10",
            "--cull-scenes",
            "procedural:grid?seed=2&size=2",
            "--frames",
            "4",
            "--rounds",
            "1",
            "--reps",
            "1",
            "--json",
            "peers.json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("No MOC harness"), "{out}");
    assert!(
        out.contains("| random 10 px | 100000 | sightline "),
        "{out}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("peers.json")).unwrap()).unwrap();
    let rows = json["occluders"].as_array().unwrap();
    // A row per set and kernel of ours: the CPU's best, then AVX2 where the best is AVX-512.
    let sets: Vec<&str> = rows.iter().map(|r| r["set"].as_str().unwrap()).collect();
    let per_set = if rows[0]["side"] == "sightline avx512" {
        2
    } else {
        1
    };
    assert_eq!(rows.len(), 2 * per_set, "{rows:?}");
    assert!(sets[0].starts_with("random 10 px"), "{sets:?}");
    assert!(sets[rows.len() - 1].ends_with("frame 2"), "{sets:?}");
    for set in rows.chunks(per_set) {
        assert_eq!(set[0]["time_over_ours"], 1.0, "{set:?}");
        assert!(set[0]["triangles"].as_u64().unwrap() > 0);
        if per_set == 2 {
            assert_eq!(set[1]["side"], "sightline avx2", "{set:?}");
            assert_eq!(set[1]["set"], set[0]["set"]);
            assert!(set[1]["time_over_ours"].as_f64().unwrap() > 0.0);
        }
    }
    assert!(json["rays"].as_array().unwrap().is_empty());
}

#[test]
fn bench_peers_rejects_zero_rounds_and_a_missing_harness() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["bench", "peers", "--rounds", "0"], dir.path());
    assert_fails_with(&o, "rounds must be at least 1");
    let o = sightline(
        &[
            "bench",
            "peers",
            "--no-rays",
            "--legs",
            "10",
            "--cull-scenes",
            "",
            "--moc",
            "/nonexistent/moc",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "could not start /nonexistent/moc");
}

#[test]
fn exact_listing_keeps_triangles_above_the_stated_area() {
    // `visible --exact -o` lists the triangles with at least --min-area px² (1e-6 by default,
    // the conservative check's threshold), and says how many positive-area slivers it left out;
    // the listing is the library's set at that threshold.
    let dir = tempfile::tempdir().unwrap();
    let scene = "procedural:city?seed=3&size=400";
    let run = |min_area: &str, file: &str| {
        let o = sightline(
            &[
                "visible",
                scene,
                "--exact",
                "--size",
                "96x96",
                "--json",
                "--min-area",
                min_area,
                "-o",
                file,
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let ids: Vec<u32> = std::fs::read_to_string(dir.path().join(file))
            .unwrap()
            .lines()
            .map(|l| l.parse().unwrap())
            .collect();
        assert_eq!(v["visible"].as_u64().unwrap() as usize, ids.len());
        (ids, v["below_min_area"].as_u64().unwrap() as usize)
    };
    let (all, none_below) = run("0", "all.txt");
    assert_eq!(none_below, 0);
    let (default, below) = run("1e-6", "default.txt");
    assert_eq!(default.len() + below, all.len());
    assert!(default.iter().all(|id| all.contains(id)));
    // A threshold large enough to drop visible triangles drops them, and counts them.
    let (coarse, dropped) = run("50", "coarse.txt");
    assert!(
        dropped > 0 && coarse.len() + dropped == all.len(),
        "{dropped}"
    );
    let o = sightline(
        &[
            "visible",
            scene,
            "--exact",
            "--size",
            "32x32",
            "--min-area=-1",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--min-area"), "{}", stderr(&o));
}

/// A flat OBJ (a 400 x 300 x 30 m block, Z up) is inferred Z-up with a warning naming the
/// rule, `--up-axis` overrides it (and the warning goes), and bad axes are refused.
#[test]
fn up_axis_is_inferred_for_flat_meshes_and_overridable() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = String::new();
    for (x, y, z) in [
        (0, 0, 0),
        (400, 0, 0),
        (400, 300, 0),
        (0, 300, 0),
        (0, 0, 30),
        (400, 0, 30),
        (400, 300, 30),
        (0, 300, 30),
    ] {
        obj.push_str(&format!("v {x} {y} {z}\n"));
    }
    obj.push_str("f 1 2 3\nf 1 3 4\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n");
    std::fs::write(dir.path().join("block.obj"), obj).unwrap();
    let info = |extra: &[&str]| {
        let o = sightline(
            &[&["info", "block.obj", "--json"], extra].concat(),
            dir.path(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (v["up"].as_str().unwrap().to_string(), stderr(&o))
    };
    let (up, err) = info(&[]);
    assert_eq!(up, "Z");
    assert!(
        err.contains("up axis Z inferred") && err.contains("flat along Z"),
        "{err}"
    );
    let (up, err) = info(&["--up-axis", "y"]);
    assert_eq!(up, "Y");
    assert!(!err.contains("inferred"), "{err}");
    assert_eq!(info(&["--up-axis", "X"]).0, "X");
    let o = sightline(&["info", "block.obj", "--up-axis", "w"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("use x, y or z"), "{}", stderr(&o));
}

/// One vocabulary across commands (issue 18): viewpoints are `--views N`, square image sizes
/// `--size PX` (or `PXxPX`), other image sizes `--size WxH` or one number, the view mode
/// `--view-mode`, and `eval` takes the PVS as its second argument like `report`; the old
/// spellings (`--viewpoints`, `--resolution`, `eval --pvs F`, `eval --views cube|random`) still
/// work as hidden aliases and give the same results.
#[test]
fn commands_share_one_vocabulary_and_keep_the_old_spellings() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "procedural:city?size=1500";
    let o = sightline(
        &[
            "pvs",
            "bake",
            scene,
            "--grid",
            "2,1,1",
            "--bounds=-100,-100,1,100,100,3",
            "--rays",
            "5000",
            "-o",
            "a.pvs",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let eval = |args: &[&str]| {
        let mut all = vec!["eval", scene];
        all.extend_from_slice(args);
        all.push("--json");
        let o = sightline(&all, dir.path());
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        let mut v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        for row in v.as_array_mut().unwrap() {
            row.as_object_mut().unwrap().remove("seconds");
        }
        v
    };
    let new = eval(&[
        "a.pvs",
        "--views",
        "2",
        "--size",
        "48",
        "--view-mode",
        "random",
    ]);
    let old = eval(&[
        "--pvs",
        "a.pvs",
        "--viewpoints",
        "2",
        "--resolution",
        "48",
        "--views",
        "random",
    ]);
    assert_eq!(new, old);
    assert_eq!(new.as_array().unwrap().len(), 2);
    // The sizes agree too: `48x48` is `48`.
    assert_eq!(
        eval(&[
            "a.pvs",
            "--views",
            "2",
            "--size",
            "48x48",
            "--view-mode",
            "random"
        ]),
        new
    );
    // And the settings matter (the comparison above could not pass by ignoring them).
    assert_ne!(
        eval(&[
            "a.pvs",
            "--views",
            "3",
            "--size",
            "48",
            "--view-mode",
            "random"
        ]),
        new
    );
    let fails = |args: &[&str], message: &str| {
        let mut all = vec!["eval", scene];
        all.extend_from_slice(args);
        assert_fails_with(&sightline(&all, dir.path()), message);
    };
    fails(
        &["a.pvs", "--views", "2", "--viewpoints", "3"],
        "say the same",
    );
    fails(
        &["a.pvs", "--views", "cube", "--view-mode", "random"],
        "say the same",
    );
    // A bad value is a usage error (clap's exit code 2), naming the rule.
    let o = sightline(&["eval", scene, "a.pvs", "--size", "48x32"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("these images are square"),
        "{}",
        stderr(&o)
    );
    fails(&[], "no .pvs file to evaluate");
    // `render --size N` is an N x N image, as `--size NxN`.
    let o = sightline(
        &["render", scene, "--size", "40", "-o", "r.png"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(dir.path().join("r.png")).unwrap();
    assert_eq!((img.width(), img.height()), (40, 40));
    // `cull`'s procedural scenes are scene specs of every command (their geometry at time 0).
    for spec in ["procedural:grid?size=2", "procedural:graveyard?size=3"] {
        let o = sightline(&["info", spec, "--json"], dir.path());
        assert!(o.status.success(), "{spec}: {}", stderr(&o));
        let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let triangles = info["validation"]["triangles"].as_u64().unwrap();
        assert!(triangles > 100, "{spec}: {info}");
    }
    let o = sightline(&["info", "procedural:grid?size=5000"], dir.path());
    assert_fails_with(&o, "above the maximum of 1000");
}

/// `bench share --grid` takes `N` (N x N over the ground) or `pvs bake`'s `NX,NY,NZ`, which
/// must be one cell high along the scene's up axis.
#[test]
fn bench_share_takes_the_grid_as_pvs_bake_does() {
    let dir = tempfile::tempdir().unwrap();
    let share = |grid: &str| {
        sightline(
            &[
                "bench",
                "share",
                "procedural:city?size=1500",
                "--grid",
                grid,
                "--budgets",
                "2000",
                "--share-budgets",
                "2000",
                "--n-rand",
                "1000",
                "--eval-cells",
                "1",
                "--views",
                "1",
                "--size",
                "16",
                "--json",
            ],
            dir.path(),
        )
    };
    let cells = |o: &std::process::Output| {
        assert!(o.status.success(), "{}", stderr(o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["cells"].as_u64().unwrap()
    };
    // The procedural city is Z-up: "2" is 2 x 2 x 1, the same as "2,2,1".
    assert_eq!(cells(&share("2")), 4);
    assert_eq!(cells(&share("2,2,1")), 4);
    assert_eq!(cells(&share("3,2,1")), 6);
    assert_fails_with(&share("2,2,2"), "must be 1");
    assert_fails_with(&share("2,x"), "expected N or NX,NY,NZ");
    assert_fails_with(&share("2000"), "not in 1..=1024");
}
