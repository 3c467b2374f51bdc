//! End-to-end tests of `sightline pvs` and `sightline eval`.

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

mod common;

use common::{assert_fails_with, sightline, stderr};
use std::path::{Path, PathBuf};

const SCENE: &str = "procedural:rooms?seed=2&size=2000";

/// `pvs bake SCENE` of the two test cells with `extra` arguments (output and budget).
fn bake_two_cells(dir: &Path, extra: &[&str]) -> std::process::Output {
    let cells = [
        "pvs",
        "bake",
        SCENE,
        "--cell",
        "box:2,2,1,4,4,2",
        "--cell",
        "box:8,2,1,10,4,2",
    ];
    sightline(&[&cells[..], extra].concat(), dir)
}

fn baked(dir: &Path) -> PathBuf {
    let o = bake_two_cells(dir, &["--n-rand", "20000", "-o", "a.pvs", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["cells"], 2);
    assert!(v["mean_pvs_size"].as_f64().unwrap() > 10.0);
    // No budget: each cell ran until GVS++'s termination rule held.
    assert_eq!(v["unconverged_cells"], 0);
    assert!(!stderr(&o).contains("not converged"), "{}", stderr(&o));
    dir.join("a.pvs")
}

/// The cells' triangle lists of a .pvs file, as `pvs show --json` prints them.
fn cell_triangles(dir: &Path, file: &str) -> Vec<serde_json::Value> {
    let o = sightline(&["pvs", "show", file, "--json"], dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let cells = v["cells"].as_array().unwrap();
    cells.iter().map(|c| c["triangles"].clone()).collect()
}

#[test]
fn gpu_bake_equals_cpu_bake() {
    // GVS++ under a ray budget goes through random, border and reverse sampling; the compute
    // caster's hits are bit-identical to the CPU's (lavapipe has SHADER_F64), so every
    // decision and the sets are the same: with the cells' rounds batched together (the
    // default, --gpu-cells 16) and with each cell's rounds alone (--gpu-cells 1).
    let dir = tempfile::tempdir().unwrap();
    let runs: [(&str, &[&str]); 3] = [
        ("cpu", &["--device", "cpu"]),
        ("gpu", &["--device", "gpu", "--gpu-caster", "compute"]),
        (
            "gpu1",
            &[
                "--device",
                "gpu",
                "--gpu-caster",
                "compute",
                "--gpu-cells",
                "1",
            ],
        ),
    ];
    for (name, device) in runs {
        let out = format!("{name}.pvs");
        let budget = ["--rays", "60000", "--seed", "5", "-o", &out];
        let o = bake_two_cells(dir.path(), &[&budget[..], device].concat());
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        if name == "gpu" {
            assert!(stderr(&o).contains(" batches ("), "{}", stderr(&o));
            assert!(stderr(&o).contains("compute caster on"), "{}", stderr(&o));
        }
    }
    let cpu = cell_triangles(dir.path(), "cpu.pvs");
    assert_eq!(cpu.len(), 2);
    assert!(cpu.iter().all(|t| t.as_array().unwrap().len() > 10));
    assert_eq!(cell_triangles(dir.path(), "gpu.pvs"), cpu);
    assert_eq!(cell_triangles(dir.path(), "gpu1.pvs"), cpu);
}

#[test]
fn ray_query_bake_is_the_cpu_bake_up_to_ties() {
    // The default GPU caster on an adapter with ray queries (CI's lavapipe, Mesa 25) is the
    // hardware ray-query caster: the driver's triangle test, whose hits equal the CPU's except
    // where a ray passes within rounding of an edge or two hits tie, and a budgeted bake's
    // later choices follow such a hit. So the sets may differ from the CPU bake's, but far
    // less than the same bake with another seed differs from it.
    let dir = tempfile::tempdir().unwrap();
    let runs: [(&str, &[&str]); 4] = [
        ("cpu", &["--device", "cpu", "--seed", "5"]),
        ("reseeded", &["--device", "cpu", "--seed", "6"]),
        ("auto", &["--device", "gpu", "--seed", "5"]),
        (
            "rq",
            &[
                "--device",
                "gpu",
                "--gpu-caster",
                "ray-query",
                "--seed",
                "5",
            ],
        ),
    ];
    for (name, device) in runs {
        let out = format!("{name}.pvs");
        let budget = ["--rays", "60000", "-o", &out];
        let o = bake_two_cells(dir.path(), &[&budget[..], device].concat());
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        if name == "auto" || name == "rq" {
            assert!(stderr(&o).contains("ray-query caster on"), "{}", stderr(&o));
        }
    }
    let ids = |name: &str| -> Vec<std::collections::BTreeSet<u64>> {
        let cells = cell_triangles(dir.path(), name);
        let set = |t: &serde_json::Value| {
            let t = t.as_array().unwrap().iter();
            t.map(|v| v.as_u64().unwrap()).collect()
        };
        cells.iter().map(set).collect()
    };
    let cpu = ids("cpu.pvs");
    assert!(cpu.iter().all(|t| t.len() > 10));
    let differ = |other: &[std::collections::BTreeSet<u64>]| -> usize {
        assert_eq!(other.len(), cpu.len());
        let pairs = other.iter().zip(&cpu);
        pairs.map(|(a, b)| a.symmetric_difference(b).count()).sum()
    };
    let reseeded = differ(&ids("reseeded.pvs"));
    assert!(reseeded > 10, "{reseeded}");
    for name in ["auto.pvs", "rq.pvs"] {
        let rq = differ(&ids(name));
        assert!(
            rq * 4 <= reseeded,
            "{name}: {rq} differ, {reseeded} with another seed"
        );
    }
}

#[test]
fn gpu_bake_refuses_shared_rays() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(
        &[
            "pvs",
            "bake",
            SCENE,
            "--grid",
            "2,1,1",
            "--share-rays",
            "--device",
            "gpu",
            "-o",
            "x.pvs",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "--share-rays");
    assert!(!dir.path().join("x.pvs").exists());
}

#[test]
fn bake_show_diff_eval_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    baked(dir.path());
    let o = sightline(&["pvs", "show", "a.pvs", "--json"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let cells = v["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 2);
    assert_eq!(
        cells[0]["pvs_size"].as_u64().unwrap() as usize,
        cells[0]["triangles"].as_array().unwrap().len()
    );
    assert_eq!(v["metadata"]["method"], "gvs++");
    for cell in v["metadata"]["cells"].as_array().unwrap() {
        assert_eq!(cell["converged"], true, "{cell}");
    }

    let o = sightline(&["pvs", "diff", "a.pvs", "a.pvs", "--json"], dir.path());
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(rows
        .as_array()
        .unwrap()
        .iter()
        .all(|r| r["jaccard"] == 1.0 && r["only_in_a"] == 0));

    let o = sightline(
        &[
            "eval",
            SCENE,
            "--pvs",
            "a.pvs",
            "--viewpoints",
            "4",
            "--resolution",
            "64",
            "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for r in rows.as_array().unwrap() {
        assert_eq!(r["images"], 24);
        assert!(r["ground_truth_size"].as_u64().unwrap() > 0);
        assert!(r["avg_error_pixels"].as_f64().unwrap() < 64.0 * 64.0 * 0.01);
    }
}

#[test]
fn a_bake_stopped_by_its_budget_says_its_cells_did_not_converge() {
    let dir = tempfile::tempdir().unwrap();
    let o = bake_two_cells(dir.path(), &["--rays", "20000", "-o", "b.pvs", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["unconverged_cells"], 2);
    let err = stderr(&o);
    assert!(
        err.contains("warning: 2 of 2 cells stopped on the budget") && err.contains("--rays"),
        "{err}"
    );
    let o = sightline(&["pvs", "show", "b.pvs", "--json"], dir.path());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for cell in v["metadata"]["cells"].as_array().unwrap() {
        assert_eq!(cell["converged"], false, "{cell}");
    }
    // RAND has no termination rule: no flag, no warning.
    let o = bake_two_cells(
        dir.path(),
        &[
            "--method", "rand", "--rays", "20000", "-o", "c.pvs", "--json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["unconverged_cells"].is_null(), "{v}");
    assert!(!stderr(&o).contains("not converged"));
}

#[test]
fn same_seed_gives_identical_file_contents() {
    let dir = tempfile::tempdir().unwrap();
    baked(dir.path());
    std::fs::rename(dir.path().join("a.pvs"), dir.path().join("first.pvs")).unwrap();
    baked(dir.path());
    let o = sightline(&["pvs", "diff", "first.pvs", "a.pvs", "--json"], dir.path());
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(rows.as_array().unwrap().iter().all(|r| r["jaccard"] == 1.0));
}

#[test]
fn pvs_for_another_scene_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    baked(dir.path());
    let o = sightline(
        &[
            "eval",
            "procedural:rooms?seed=3&size=2000",
            "--pvs",
            "a.pvs",
            "--viewpoints",
            "1",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "another scene");
}

#[test]
fn truncated_and_garbage_files_are_clean_errors() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(baked(dir.path())).unwrap();
    std::fs::write(dir.path().join("t.pvs"), &bytes[..bytes.len() / 2]).unwrap();
    assert_fails_with(
        &sightline(&["pvs", "show", "t.pvs"], dir.path()),
        "truncated",
    );
    std::fs::write(dir.path().join("g.pvs"), b"hello world").unwrap();
    assert_fails_with(
        &sightline(&["pvs", "show", "g.pvs"], dir.path()),
        "not a .pvs file",
    );
    let mut flipped = bytes.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 1;
    std::fs::write(dir.path().join("f.pvs"), &flipped).unwrap();
    assert_fails_with(
        &sightline(&["pvs", "show", "f.pvs"], dir.path()),
        "checksum",
    );
}

#[test]
fn bad_bake_arguments_are_clean_errors_and_keep_old_output() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("keep.pvs"), b"old").unwrap();
    let cases: [(&[&str], &str); 5] = [
        (
            &["pvs", "bake", SCENE, "-o", "keep.pvs"],
            "exactly one cell source",
        ),
        (
            &["pvs", "bake", SCENE, "--grid", "2,0,1", "-o", "keep.pvs"],
            "whole numbers",
        ),
        (
            &[
                "pvs",
                "bake",
                SCENE,
                "--cell",
                "box:1,1,1,0,0,0",
                "-o",
                "keep.pvs",
            ],
            "min must be <= max",
        ),
        (
            &["pvs", "bake", SCENE, "--q3-leaves", "-o", "keep.pvs"],
            "Quake 3 map",
        ),
        (
            &[
                "pvs",
                "bake",
                SCENE,
                "--cell",
                "point:1,1,1,1",
                "--delta-abs=-1",
                "-o",
                "keep.pvs",
            ],
            "delta_abs",
        ),
    ];
    for (args, needle) in cases {
        assert_fails_with(&sightline(args, dir.path()), needle);
        assert_eq!(std::fs::read(dir.path().join("keep.pvs")).unwrap(), b"old");
    }
}

#[test]
fn q3_leaf_bake_stays_inside_q3map2_pvs() {
    let dir = tempfile::tempdir().unwrap();
    let map = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/q3dm6ish.bsp");
    let o = sightline(
        &[
            "pvs",
            "bake",
            map,
            "--q3-leaves",
            "--clusters",
            "0,1,2,3,4,5",
            "--n-rand",
            "100000",
            "-o",
            "q.pvs",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = sightline(
        &[
            "pvs",
            "compare-q3",
            map,
            "q.pvs",
            "--json",
            "--viewpoints",
            "2",
            "--resolution",
            "64",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 6);
    let ours: u64 = rows.iter().map(|r| r["ours"].as_u64().unwrap()).sum();
    let outside: u64 = rows
        .iter()
        .map(|r| r["ours_not_q3map2"].as_u64().unwrap())
        .sum();
    println!("{outside} of {ours} (cluster, triangle) pairs outside q3map2's PVS");
    // q3map2's PVS is conservative (up to its epsilons), so almost nothing we see may lie
    // outside it; a handful of grazing pairs are tolerated.
    assert!(ours > 1000 && outside * 200 <= ours, "{outside} of {ours}");
    // Both PVSs are judged from inside each cluster: q3map2's conservative one must be
    // (nearly) free of error, ours small.
    for r in rows {
        assert!(r["q3map2_avg_error_pixels"].as_f64().unwrap() < 1.0, "{r}");
        assert!(r["ours_avg_error_pixels"].as_f64().unwrap() < 5.0, "{r}");
    }
}

#[test]
fn share_rays_bake_writes_a_file_and_rejects_other_methods() {
    let dir = tempfile::tempdir().unwrap();
    let args = |method: &'static str| -> Vec<&'static str> {
        vec![
            "pvs",
            "bake",
            SCENE,
            "--grid",
            "2,2,1",
            "--bounds=0,0,1,12,12,2",
            "--n-rand",
            "5000",
            "--rays",
            "30000",
            "--method",
            method,
            "--share-rays",
            "-o",
            "s.pvs",
            "--json",
        ]
    };
    let o = sightline(&args("gvs++"), dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    // Shared bakes are scheduled by yield: no rounds, no warning about them.
    assert!(!stderr(&o).contains("paper's rounds"), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["cells"], 4);
    assert!(v["mean_pvs_size"].as_f64().unwrap() > 10.0);
    let o = sightline(&["pvs", "show", "s.pvs", "--json"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["metadata"]["method"], "gvs++ shared");
    assert_eq!(v["cells"].as_array().unwrap().len(), 4);
    // With --fixed-rounds, a budget below one round is spent on random rays first: the user
    // is told.
    let mut short = args("gvs++");
    short[7] = "50000";
    short[14] = "short.pvs";
    short.push("--fixed-rounds");
    let o = sightline(&short, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o)
            .contains("warning: --fixed-rounds runs GVS++ in the paper's rounds of --n-rand 50000"),
        "{}",
        stderr(&o)
    );
    let before = std::fs::read(dir.path().join("s.pvs")).unwrap();
    assert_fails_with(&sightline(&args("rand"), dir.path()), "gvs++ only");
    assert_eq!(std::fs::read(dir.path().join("s.pvs")).unwrap(), before);
}

/// Issue 15's path: a level exported as glTF, baked, and the file's object table and
/// per-cell object sets as an engine will read them.
#[test]
fn gltf_level_bake_has_objects_and_object_sets() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["convert", SCENE, "-o", "level.glb"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = sightline(&["info", "level.glb", "--json"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let o = sightline(
        &[
            "pvs",
            "bake",
            "level.glb",
            "--grid",
            "2,2,1",
            "--method",
            "rand",
            "--rays",
            "20000",
            "-o",
            "level.pvs",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = sightline(&["pvs", "show", "level.pvs", "--json"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["version"], 2);
    let objects = v["objects"].as_array().unwrap();
    let total: u64 = objects
        .iter()
        .map(|o| o["triangles"].as_u64().unwrap())
        .sum();
    assert_eq!(total, v["triangle_count"].as_u64().unwrap());
    let object_count = info["objects"]
        .as_u64()
        .or_else(|| info["objects"].as_array().map(|a| a.len() as u64))
        .unwrap();
    assert_eq!(objects.len() as u64, object_count);
    // The objects are the loaded scene's, in its order (`convert` keeps the generator's names
    // and its empty index/part, docs/objects.md).
    for (o, i) in objects.iter().zip(info["objects"].as_array().unwrap()) {
        assert_eq!(o["name"], i["name"]);
        assert_eq!(o["triangles"], i["triangles"]);
    }
    for cell in v["cells"].as_array().unwrap() {
        let ids = cell["objects"].as_array().unwrap();
        assert!(ids
            .iter()
            .all(|i| i.as_u64().unwrap() < objects.len() as u64));
        assert_eq!(ids.is_empty(), cell["pvs_size"] == 0);
        assert!(ids.len() <= cell["pvs_size"].as_u64().unwrap() as usize);
    }
    let o = sightline(&["pvs", "show", "level.pvs", "--objects"], dir.path());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("version    2"), "{text}");
    assert!(
        text.contains(objects[0]["name"].as_str().unwrap()),
        "{text}"
    );
    let o = sightline(
        &["pvs", "diff", "level.pvs", "level.pvs", "--json"],
        dir.path(),
    );
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(rows
        .as_array()
        .unwrap()
        .iter()
        .all(|r| r["objects_only_in_a"] == 0 && r["objects_a"] == r["objects_b"]));
}

#[test]
fn q3_leaf_bake_leaves_out_unreachable_leaves_and_records_them() {
    let dir = tempfile::tempdir().unwrap();
    let map = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/q3dm6ish.bsp");
    let bake = |extra: &[&str], out: &str| {
        let mut args = vec![
            "pvs",
            "bake",
            map,
            "--q3-leaves",
            "--method",
            "rand",
            "--rays",
            "500",
            "-o",
            out,
            "--json",
        ];
        args.extend(extra);
        let o = sightline(&args, dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (v, stderr(&o))
    };
    let (v, err) = bake(&[], "r.pvs");
    let r = &v["reachable"];
    let (leaves, unreachable) = (
        r["leaves"].as_u64().unwrap(),
        r["unreachable_leaves"].as_u64().unwrap(),
    );
    // q3dm6ish has 247 leaves with a cluster, a few of them sealed off from its 11 spawns.
    assert_eq!(leaves, 247, "{r}");
    assert!((1..20).contains(&unreachable), "{r}");
    assert_eq!(v["cells"].as_u64().unwrap(), leaves - unreachable);
    assert_eq!(r["dropped_cells"].as_u64().unwrap(), unreachable);
    assert!(
        err.contains(&format!(
            "q3dm6ish: {unreachable} of 247 leaves ({} clusters) are unreachable from 11 spawn points",
            r["unreachable_clusters"]
        )) && err.contains("--include-unreachable"),
        "{err}"
    );
    // The file records the counts and the rule, and the rule is part of the fingerprint.
    let o = sightline(&["pvs", "show", "r.pvs", "--json"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let shown: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let m = &shown["metadata"];
    assert_eq!(
        m["reachable"]["unreachable_leaves"],
        r["unreachable_leaves"]
    );
    assert_eq!(m["reachable"]["step"], 16.0);
    assert_eq!(m["fingerprint"]["extra"]["origins"]["origins"], "reachable");
    assert_eq!(m["fingerprint"]["extra"]["origins"]["step"], 16.0);
    assert_eq!(
        m["clusters"].as_array().unwrap().len() as u64,
        leaves - unreachable
    );

    // The old rule keeps every leaf.
    let (all, _) = bake(&["--include-unreachable"], "a.pvs");
    assert_eq!(all["cells"].as_u64().unwrap(), leaves);
    assert_eq!(all["reachable"]["origins"], "cluster");
    assert!(all["reachable"]["unreachable_leaves"].is_null());

    // Another step is another bake: its checkpoint fingerprint differs.
    let (coarse, _) = bake(&["--reach-step", "32"], "c.pvs");
    assert_eq!(coarse["reachable"]["step"], 32.0);

    // Viewpoints of a reachable bake are where its origins were: evaluating a cell counts the
    // viewpoints it rejected.
    let o = sightline(
        &[
            "eval",
            map,
            "--pvs",
            "r.pvs",
            "--cells",
            "0",
            "--viewpoints",
            "8",
            "--resolution",
            "16",
            "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rejected = &rows[0]["rejected_viewpoints"];
    let judged = rows[0]["images"].as_u64().unwrap() / 6;
    let skipped =
        rejected["outside_cluster"].as_u64().unwrap() + rejected["unreachable"].as_u64().unwrap();
    assert_eq!(judged + skipped, 8, "{}", rows[0]);

    // Bad steps are clean errors naming the option.
    for bad in ["0", "-4", "NaN", "0.01"] {
        let o = sightline(
            &[
                "pvs",
                "bake",
                map,
                "--q3-leaves",
                "--reach-step",
                bad,
                "-o",
                "x.pvs",
            ],
            dir.path(),
        );
        assert_fails_with(&o, "--reach-step");
    }
    let o = sightline(
        &[
            "pvs",
            "bake",
            SCENE,
            "--cell",
            "box:2,2,1,4,4,2",
            "--include-unreachable",
            "-o",
            "x.pvs",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "--q3-leaves and --q3-clusters only");
}

#[test]
fn raster_bake_below_one_cube_map_says_what_it_renders() {
    // RASTER spends its budget a cube map at a time: --rays below one (6 x 16² = 1536 pixels)
    // still renders one per cell, and the bake says so instead of silently casting more.
    let dir = tempfile::tempdir().unwrap();
    let run = |rays: &str| {
        sightline(
            &[
                "pvs",
                "bake",
                "procedural:boxes?size=200",
                "--grid",
                "1,1,1",
                "--method",
                "raster",
                "--raster-resolution",
                "16",
                "--rays",
                rays,
                "--json",
                "-o",
                "r.pvs",
                "--restart",
            ],
            dir.path(),
        )
    };
    let o = run("1000");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("less than one RASTER cube map (6 x 16² = 1536"),
        "{}",
        stderr(&o)
    );
    let o = run("3072");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("cube map"), "{}", stderr(&o));
}

#[test]
fn walkable_cells_sit_at_eye_height_and_round_trip_through_a_cells_file() {
    let dir = tempfile::tempdir().unwrap();
    let bake = |extra: &[&str]| {
        let args = [&["pvs", "bake", SCENE, "--rays", "2000"][..], extra].concat();
        sightline(&args, dir.path())
    };
    let o = bake(&[
        "--walkable",
        "4",
        "--write-cells",
        "cells.json",
        "-o",
        "w.pvs",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let placed: usize = err
        .split("placed ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{err}"));
    // The rooms stand on a floor at z = 0, with furniture: every cell spans 1.2..1.8 m above
    // a floor no higher than 1.2 m.
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("cells.json")).unwrap()).unwrap();
    let cells = doc["cells"].as_array().unwrap();
    assert!(
        placed > 10 && cells.len() == placed,
        "{placed} {}",
        cells.len()
    );
    for c in cells {
        let z = c["center"][2].as_f64().unwrap();
        let h = c["half_extents"][2].as_f64().unwrap();
        assert!((1.45..=3.0).contains(&z) && h >= 0.299, "{c}");
    }
    // Edited or not, the file bakes the same cells.
    let o = bake(&["--cells", "cells.json", "-o", "again.pvs"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for file in ["w.pvs", "again.pvs"] {
        let o = sightline(&["pvs", "show", file, "--json"], dir.path());
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["cells"].as_array().unwrap().len(), placed, "{file}");
    }
    // Bad sizes are named.
    let o = bake(&["--walkable", "0", "-o", "bad.pvs"]);
    assert_fails_with(&o, "cell size 0");
}

/// `pvs merge-cells`: with no similarity asked, the whole 4x2 grid becomes one cell whose set is
/// the union of all (the PVS of the joined region); with equal sets asked, nothing merges; the
/// input is never overwritten and bad thresholds are refused.
#[test]
fn merge_cells_joins_neighbours_into_their_union() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "procedural:city?size=1500";
    let o = sightline(
        &[
            "pvs",
            "bake",
            scene,
            "--grid",
            "4,2,1",
            "--bounds=-100,-100,1,100,100,3",
            "--rays",
            "5000",
            "-o",
            "a.pvs",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let show = |file: &str| {
        let o = sightline(&["pvs", "show", file, "--json"], dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let before = show("a.pvs");
    let merge = |args: &[&str]| {
        let mut all = vec!["pvs", "merge-cells", "a.pvs", "--json"];
        all.extend_from_slice(args);
        let o = sightline(&all, dir.path());
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()
    };
    let all = merge(&[
        "-o",
        "one.pvs",
        "--min-similarity",
        "0",
        "--max-growth",
        "1000",
    ]);
    assert_eq!(
        (all["cells_before"].as_u64(), all["cells_after"].as_u64()),
        (Some(8), Some(1))
    );
    let one = show("one.pvs");
    let cells = one["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 1);
    let mut union: Vec<u64> = before["cells"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|c| {
            c["triangles"]
                .as_array()
                .unwrap()
                .iter()
                .map(|t| t.as_u64().unwrap())
        })
        .collect();
    union.sort_unstable();
    union.dedup();
    let merged: Vec<u64> = cells[0]["triangles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_u64().unwrap())
        .collect();
    assert_eq!(merged, union);
    let from = &one["metadata"]["cells"][0]["merged_from"];
    assert_eq!(from.as_array().unwrap().len(), 8, "{from}");
    let none = merge(&[
        "-o",
        "same.pvs",
        "--min-similarity",
        "1",
        "--max-growth",
        "0",
    ]);
    assert_eq!(
        none["cells_after"],
        before["cells"].as_array().unwrap().len()
    );
    assert_fails_with(
        &sightline(&["pvs", "merge-cells", "a.pvs", "-o", "a.pvs"], dir.path()),
        "refusing to overwrite an input",
    );
    assert_fails_with(
        &sightline(
            &[
                "pvs",
                "merge-cells",
                "a.pvs",
                "-o",
                "b.pvs",
                "--min-similarity",
                "1.5",
            ],
            dir.path(),
        ),
        "outside 0..=1",
    );
}

/// An OBJ of a closed block (outward normals) filling x in [0.5, 10], and a wall at x = -20
/// facing it, for the free-space tests of mesh cells.
fn block_scene(dir: &Path) -> &'static str {
    let mut obj = String::new();
    for i in 0..8 {
        let x = if i & 1 != 0 { 10.0 } else { 0.5 };
        let y = if i & 2 != 0 { 50.0 } else { -50.0 };
        let z = if i & 4 != 0 { 50.0 } else { -50.0 };
        obj.push_str(&format!("v {x} {y} {z}\n"));
    }
    for [a, b, c, d] in [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ] {
        obj.push_str(&format!("f {} {} {}\n", a + 1, b + 1, c + 1));
        obj.push_str(&format!("f {} {} {}\n", a + 1, c + 1, d + 1));
    }
    obj.push_str("v -20 -30 -30\nv -20 30 -30\nv -20 0 30\nf 9 10 11\n");
    std::fs::write(dir.join("block.obj"), obj).unwrap();
    "block.obj"
}

#[test]
fn mesh_cells_take_no_origins_inside_closed_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let scene = block_scene(dir.path());
    // Cell 0 reaches from free space into the block; cell 1 lies wholly inside it.
    let bake = |extra: &[&str]| {
        let args = [
            &[
                "pvs",
                "bake",
                scene,
                "--cell",
                "box:-4,-1,-1,4,1,1",
                "--cell",
                "box:2,-1,-1,8,1,1",
                "--rays",
                "20000",
                "--json",
            ][..],
            extra,
        ]
        .concat();
        sightline(&args, dir.path())
    };
    let o = bake(&["-o", "open.pvs"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["solid"]["tested"], 2, "{v}");
    assert_eq!(v["solid"]["partly_closed"], 1, "{v}");
    assert_eq!(v["solid"]["all_closed"], serde_json::json!([1]), "{v}");
    let err = stderr(&o);
    assert!(
        err.contains("1 of 2 cells reach into closed geometry"),
        "{err}"
    );
    assert!(
        err.contains("wholly inside closed geometry") && err.contains("cells 1"),
        "{err}"
    );
    let sets = cell_triangles(dir.path(), "open.pvs");
    // Cell 0 sees the wall (triangle 12) and the block's face towards it; cell 1 nothing.
    assert!(
        sets[0].as_array().unwrap().contains(&serde_json::json!(12)),
        "{sets:?}"
    );
    assert_eq!(sets[1].as_array().unwrap().len(), 0, "{sets:?}");

    // --origins-anywhere: the old rule, no test; origins inside the block see its inside.
    let o = bake(&["-o", "anywhere.pvs", "--origins-anywhere"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["solid"].is_null(), "{v}");
    assert!(!stderr(&o).contains("closed geometry"), "{}", stderr(&o));
    let sets = cell_triangles(dir.path(), "anywhere.pvs");
    assert!(!sets[1].as_array().unwrap().is_empty(), "{sets:?}");
}

#[test]
fn conservative_bake_contains_the_sampled_set_and_misses_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let o = bake_two_cells(dir.path(), &["--rays", "200000", "-o", "g.pvs"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = bake_two_cells(
        dir.path(),
        &[
            "--method",
            "conservative",
            "--rays",
            "5",
            "-o",
            "c.pvs",
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--rays and --time are ignored"),
        "{}",
        stderr(&o)
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        (v["method"].as_str(), v["total_rays"].as_u64()),
        (Some("conservative"), Some(0))
    );
    let sampled = cell_triangles(dir.path(), "g.pvs");
    let bound = cell_triangles(dir.path(), "c.pvs");
    for (g, c) in sampled.iter().zip(&bound) {
        let (g, c) = (g.as_array().unwrap(), c.as_array().unwrap());
        assert!(
            g.iter().all(|t| c.contains(t)),
            "a sampled triangle is outside the bound"
        );
        assert!(
            c.len() > g.len() && !g.is_empty(),
            "{} {}",
            g.len(),
            c.len()
        );
    }
    // Dense views from inside the cells see nothing outside the conservative sets.
    let o = sightline(
        &[
            "eval", SCENE, "c.pvs", "--views", "6", "--size", "96", "--json",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for r in rows.as_array().unwrap() {
        assert!(r["ground_truth_size"].as_u64().unwrap() > 0, "{r}");
        assert_eq!(r["false_negatives"], 0, "{r}");
        assert_eq!(r["avg_error_pixels"].as_f64(), Some(0.0), "{r}");
    }
    // It casts no rays, so the GPU does not apply.
    let o = bake_two_cells(
        dir.path(),
        &["--method", "conservative", "--device", "gpu", "-o", "d.pvs"],
    );
    assert_fails_with(&o, "casts no rays");
}

#[test]
fn two_sided_bake_stores_both_sides_and_its_bound_misses_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let budget = ["--rays", "200000"];
    let o = bake_two_cells(
        dir.path(),
        &[&budget[..], &["--bound", "-o", "b.pvs", "--json"]].concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["bound"]["method"], "conservative", "{v}");
    assert_eq!(v["bound"]["cells_not_contained"], 0, "{v}");
    assert!(v["bound"]["mean_ratio"].as_f64().unwrap() > 1.0, "{v}");
    // `pvs show` gives each cell's set and the gap: disjoint, and together the bound.
    let o = sightline(&["pvs", "show", "b.pvs", "--json"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let shown: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for c in shown["cells"].as_array().unwrap() {
        let (set, gap) = (
            c["triangles"].as_array().unwrap(),
            c["gap"].as_array().unwrap(),
        );
        assert!(!set.is_empty() && !gap.is_empty(), "{c}");
        assert!(gap.iter().all(|t| !set.contains(t)));
        assert_eq!(
            c["bound_size"].as_u64().unwrap() as usize,
            set.len() + gap.len()
        );
    }
    let o = sightline(&["pvs", "show", "b.pvs"], dir.path());
    assert!(String::from_utf8_lossy(&o.stdout).contains("gap"));
    // `pvs bound` on the same bake without --bound adds the same bounds.
    let o = bake_two_cells(dir.path(), &[&budget[..], &["-o", "plain.pvs"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = sightline(
        &["pvs", "bound", SCENE, "plain.pvs", "-o", "later.pvs"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = sightline(&["pvs", "show", "later.pvs", "--json"], dir.path());
    let later: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for (a, b) in shown["cells"]
        .as_array()
        .unwrap()
        .iter()
        .zip(later["cells"].as_array().unwrap())
    {
        assert_eq!(a["gap"], b["gap"]);
    }
    // With occluder fusion the bound is inside the bound without (fusion only removes).
    let fused_bound = |levels: &str, out: &str| {
        let args = [
            "pvs",
            "bound",
            SCENE,
            "plain.pvs",
            "--bound-fusion-splits",
            levels,
            "-o",
            out,
        ];
        sightline(&args, dir.path())
    };
    let o = fused_bound("3", "fused.pvs");
    assert!(o.status.success(), "{}", stderr(&o));
    let o = sightline(&["pvs", "show", "fused.pvs", "--json"], dir.path());
    let fused: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for (a, b) in fused["cells"]
        .as_array()
        .unwrap()
        .iter()
        .zip(later["cells"].as_array().unwrap())
    {
        let (a, b) = (a["gap"].as_array().unwrap(), b["gap"].as_array().unwrap());
        assert!(a.iter().all(|t| b.contains(t)), "{a:?} {b:?}");
    }
    assert_fails_with(
        &fused_bound("21", "never.pvs"),
        "--bound-fusion-splits must be 0 to 12 (got 21)",
    );
    // Dense views from inside the cells see nothing outside the bounds.
    let eval = |file: &str, side: &str| {
        let args = [
            "eval", SCENE, file, "--views", "6", "--size", "96", "--side", side, "--json",
        ];
        sightline(&args, dir.path())
    };
    for file in ["b.pvs", "fused.pvs"] {
        let o = eval(file, "bound");
        assert!(o.status.success(), "{}", stderr(&o));
        let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        for r in rows.as_array().unwrap() {
            assert!(r["ground_truth_size"].as_u64().unwrap() > 0, "{file}: {r}");
            assert_eq!(r["false_negatives"], 0, "{file}: {r}");
        }
    }
    assert_fails_with(&eval("plain.pvs", "bound"), "holds no conservative bounds");
    // Two-sided shards join into the same file as the whole bake; mixed ones are refused.
    for (shard, file) in [("0/2", "s0.pvs"), ("1/2", "s1.pvs")] {
        let args = [&budget[..], &["--bound", "--shard", shard, "-o", file]].concat();
        let o = bake_two_cells(dir.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = sightline(
        &["pvs", "merge", "s0.pvs", "s1.pvs", "-o", "m.pvs"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = sightline(&["pvs", "show", "m.pvs", "--json"], dir.path());
    let merged: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let cells = |v: &serde_json::Value| v["cells"].as_array().unwrap().clone();
    for (a, b) in cells(&shown).iter().zip(&cells(&merged)) {
        assert_eq!((&a["triangles"], &a["gap"]), (&b["triangles"], &b["gap"]));
    }
    assert_eq!(
        merged["metadata"]["bound"]["mean_ratio"],
        shown["metadata"]["bound"]["mean_ratio"]
    );
    let args = [&budget[..], &["--shard", "1/2", "-o", "one-sided.pvs"]].concat();
    assert!(bake_two_cells(dir.path(), &args).status.success());
    let o = sightline(
        &["pvs", "merge", "s0.pvs", "one-sided.pvs", "-o", "x.pvs"],
        dir.path(),
    );
    assert_fails_with(&o, "some of these .pvs files hold conservative bounds");
    // What does not combine says so.
    let o = bake_two_cells(
        dir.path(),
        &["--method", "conservative", "--bound", "-o", "x.pvs"],
    );
    assert_fails_with(&o, "already is the bound");
    let o = sightline(&["pvs", "bound", SCENE, "b.pvs", "-o", "b.pvs"], dir.path());
    assert_fails_with(&o, "refusing to overwrite an input");
}

#[test]
fn quake_cluster_bounds_go_through_the_portals_and_grid_bounds_do_not() {
    // Cluster cells keep their origins in the map's empty leaves, so their bounds are cut by
    // the map's portals: about 1.4-1.6x these two clusters' sets, where RV's umbrae alone
    // keep 5x. Grid boxes reach into solid space and the void, from where rays see through
    // brushes, so their bounds are RV's alone; the sets stay inside both.
    let dir = tempfile::tempdir().unwrap();
    let map = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/q3dm6ish.bsp");
    let bake = |cells: &[&str], out: &str| {
        let base = [
            "pvs", "bake", map, "--rays", "1000000", "--bound", "-o", out,
        ];
        let o = sightline(&[&base[..], cells].concat(), dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        let o = sightline(&["pvs", "show", out, "--json"], dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["metadata"]["bound"].clone()
    };
    let clusters = bake(&["--q3-clusters", "--clusters", "5,20"], "c.pvs");
    let ratio = clusters["mean_ratio"].as_f64().unwrap();
    assert!(ratio < 2.0, "{clusters}");
    let grid = bake(&["--grid", "2,2,1"], "g.pvs");
    assert_eq!(grid["cells_not_contained"], 0, "{grid}");
    // `pvs bound` on the cluster file finds its cells' clusters in the metadata.
    let o = sightline(
        &["pvs", "bound", map, "c.pvs", "-o", "c2.pvs", "--json"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["mean_ratio"], clusters["mean_ratio"], "{v}");
    // --bound-no-portals: RV's umbrae alone, which keep most of the map from these cells.
    let args = ["pvs", "bound", map, "c.pvs", "-o", "c3.pvs", "--json"];
    let o = sightline(&[&args[..], &["--bound-no-portals"]].concat(), dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["mean_ratio"].as_f64().unwrap() > 2.0 * ratio, "{v}");
}

#[test]
fn solid_fusion_takes_a_street_bound_down_and_misses_nothing() {
    // A street cell of the procedural city, whose houses are closed solids open at the
    // ground: the union of the houses, shrunk by 3 m, hides what whole blocks hide together.
    const CITY: &str = "procedural:city?size=5000";
    let dir = tempfile::tempdir().unwrap();
    let bake = [
        "pvs",
        "bake",
        CITY,
        "--cell",
        "box:-10,-10,1,10,10,2",
        "--rays",
        "100000",
        "-o",
        "p.pvs",
    ];
    assert!(sightline(&bake, dir.path()).status.success());
    let bound = |extra: &[&str], out: &str| {
        let args = [&["pvs", "bound", CITY, "p.pvs", "-o", out][..], extra].concat();
        sightline(&args, dir.path())
    };
    let gap_of = |file: &str| {
        let o = sightline(&["pvs", "show", file, "--json"], dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["cells"][0]["gap"].as_array().unwrap().clone()
    };
    let o = bound(&[], "plain.pvs");
    assert!(o.status.success(), "{}", stderr(&o));
    let o = bound(&["--bound-solid-fusion", "3"], "fused.pvs");
    assert!(o.status.success(), "{}", stderr(&o));
    let (plain, fused) = (gap_of("plain.pvs"), gap_of("fused.pvs"));
    assert!(fused.iter().all(|t| plain.contains(t)));
    assert!(
        fused.len() * 10 < plain.len() * 9,
        "fusion removed only {} of {}",
        plain.len() - fused.len(),
        plain.len()
    );
    // Views from inside the cell see nothing outside the fused bound.
    let args = [
        "eval",
        CITY,
        "fused.pvs",
        "--views",
        "40",
        "--size",
        "96",
        "--side",
        "bound",
        "--json",
    ];
    let o = sightline(&args, dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(rows[0]["ground_truth_size"].as_u64().unwrap() > 0, "{rows}");
    assert_eq!(rows[0]["false_negatives"], 0, "{rows}");
    // Values that make no sense say so.
    let o = bound(&["--bound-solid-fusion=-2"], "x.pvs");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("expected a positive radius, auto or off (got -2)"));
    assert_fails_with(
        &bound(
            &["--bound-solid-fusion", "auto", "--bound-no-solids"],
            "x.pvs",
        ),
        "--bound-solid-fusion needs the closed solids",
    );
}
