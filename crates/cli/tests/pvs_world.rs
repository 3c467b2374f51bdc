//! End-to-end tests of baking many cells: a killed bake resumes from its checkpoint, shards
//! merge into the unsharded bake, incremental rebakes with --since.

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

mod common;

use common::{assert_fails_with, sightline, stderr};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const CITY: &str = "procedural:city?seed=3&size=3000";

/// `pvs bake` of a 4x4 street-level grid of the small city with RAND, plus `extra`.
fn bake_args<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec![
        "pvs",
        "bake",
        CITY,
        "--grid",
        "4,4,1",
        "--bounds=-184,-184,1,184,184,3",
        "--method",
        "rand",
        "--rays",
        "60000",
        "--seed",
        "4",
        "-o",
        out,
        "--json",
    ];
    a.extend_from_slice(extra);
    a
}

fn run_ok(args: &[&str], dir: &Path) -> serde_json::Value {
    let o = sightline(args, dir);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// The triangle ids of every cell of a .pvs file.
fn cell_sets(file: &str, dir: &Path) -> Vec<serde_json::Value> {
    let v = run_ok(&["pvs", "show", file, "--json"], dir);
    v["cells"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["triangles"].clone())
        .collect()
}

#[test]
fn a_killed_bake_resumes_from_its_checkpoint_to_the_same_file() {
    let dir = tempfile::tempdir().unwrap();
    // Cells heavy enough (400k rays each) that the 15 after the first take far longer than
    // the poll below needs to see the checkpoint and kill, even on a loaded machine.
    let args = |out: &'static str, extra: &[&'static str]| {
        let mut a = bake_args(out, extra);
        let k = a.iter().position(|a| *a == "--rays").unwrap();
        a[k + 1] = "400000";
        a
    };
    run_ok(&args("full.pvs", &[]), dir.path());
    // One thread, so cells finish one by one; kill as soon as the first checkpoint appears.
    let mut child = Command::new(env!("CARGO_BIN_EXE_sightline"))
        .args(args("out.pvs", &["--threads", "1"]))
        .current_dir(dir.path())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let checkpoint = dir.path().join("out.pvs.checkpoint");
    let start = Instant::now();
    while !checkpoint.exists() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "bake ended before a checkpoint"
        );
        assert!(start.elapsed() < Duration::from_secs(120), "no checkpoint");
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!dir.path().join("out.pvs").exists());
    let partial = cell_sets("out.pvs.checkpoint", dir.path()).len();
    assert!(
        (1..16).contains(&partial),
        "{partial} cells in the checkpoint"
    );

    let v = run_ok(&args("out.pvs", &[]), dir.path());
    assert_eq!(v["resumed_cells"].as_u64().unwrap() as usize, partial);
    assert_eq!(v["baked_cells"].as_u64().unwrap() as usize, 16 - partial);
    assert!(!checkpoint.exists());
    assert_eq!(
        cell_sets("out.pvs", dir.path()),
        cell_sets("full.pvs", dir.path())
    );
}

#[test]
fn shards_merge_into_the_unsharded_bake() {
    let dir = tempfile::tempdir().unwrap();
    run_ok(&bake_args("full.pvs", &[]), dir.path());
    for i in 0..3 {
        let out = format!("s{i}.pvs");
        let shard = format!("{i}/3");
        let v = run_ok(&bake_args(&out, &["--shard", &shard]), dir.path());
        assert_eq!(v["cells"], if i == 0 { 6 } else { 5 });
        let meta = run_ok(&["pvs", "show", &out, "--json"], dir.path())["metadata"].clone();
        assert_eq!(meta["shard"]["count"], 3);
        assert_eq!(meta["total_cells"], 16);
        assert_eq!(meta["cell_indices"][1], i + 3);
    }
    let v = run_ok(
        &[
            "pvs", "merge", "s2.pvs", "s0.pvs", "s1.pvs", "-o", "m.pvs", "--json",
        ],
        dir.path(),
    );
    assert_eq!(v["cells"], 16);
    assert_eq!(
        cell_sets("m.pvs", dir.path()),
        cell_sets("full.pvs", dir.path())
    );
    let o = sightline(
        &["pvs", "merge", "s0.pvs", "s1.pvs", "-o", "p.pvs"],
        dir.path(),
    );
    assert_fails_with(&o, "--allow-partial");
    assert!(!dir.path().join("p.pvs").exists());
    // Ray sharing is a way of baking, not of merging: merge refuses the flag (it used to
    // accept it and do nothing).
    let o = sightline(
        &[
            "pvs",
            "merge",
            "s0.pvs",
            "s1.pvs",
            "s2.pvs",
            "-o",
            "p.pvs",
            "--share-rays",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--share-rays"), "{}", stderr(&o));
    assert!(!dir.path().join("p.pvs").exists());
    let o = sightline(
        &[
            "pvs", "merge", "s0.pvs", "s0.pvs", "s1.pvs", "s2.pvs", "-o", "p.pvs",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "overlap");
    let mut other = bake_args("seed5.pvs", &["--shard", "1/3"]);
    let k = other.iter().position(|a| *a == "--seed").unwrap();
    other[k + 1] = "5";
    run_ok(&other, dir.path());
    let o = sightline(
        &[
            "pvs",
            "merge",
            "s0.pvs",
            "seed5.pvs",
            "s2.pvs",
            "-o",
            "p.pvs",
        ],
        dir.path(),
    );
    assert_fails_with(&o, "seed 4 vs 5");
    assert_fails_with(
        &sightline(&bake_args("x.pvs", &["--shard", "3/3"]), dir.path()),
        "0 <= I < N",
    );
}

#[test]
fn since_rebakes_only_cells_that_can_see_the_edit() {
    let dir = tempfile::tempdir().unwrap();
    let o = sightline(&["convert", CITY, "-o", "old.obj"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    // The new scene: the old one plus a box standing in a street near the north-east corner.
    let mut obj = std::fs::read_to_string(dir.path().join("old.obj")).unwrap();
    let vertices = obj.lines().filter(|l| l.starts_with("v ")).count();
    obj.push_str("o added\n");
    for (x, y, z) in [
        (120, 82, 0),
        (130, 82, 0),
        (130, 90, 0),
        (120, 90, 0),
        (120, 82, 6),
        (130, 82, 6),
        (130, 90, 6),
        (120, 90, 6),
    ] {
        obj.push_str(&format!("v {x} {y} {z}\n"));
    }
    for f in [
        [1, 2, 6],
        [1, 6, 5],
        [2, 3, 7],
        [2, 7, 6],
        [3, 4, 8],
        [3, 8, 7],
        [4, 1, 5],
        [4, 5, 8],
        [5, 6, 7],
        [5, 7, 8],
    ] {
        let f = f.map(|i| i + vertices);
        obj.push_str(&format!("f {} {} {}\n", f[0], f[1], f[2]));
    }
    std::fs::write(dir.path().join("new.obj"), obj).unwrap();
    let grid = ["--grid", "1,8,1", "--bounds=-10,-176,1,-2,176,3"];
    let bake = |scene: &'static str, out: &'static str, extra: &[&'static str]| {
        let mut a = vec!["pvs", "bake", scene];
        a.extend_from_slice(&grid);
        a.extend_from_slice(&["--method", "rand", "--rays", "40000", "-o", out]);
        a.extend_from_slice(extra);
        sightline(&a, dir.path())
    };
    let o = bake("old.obj", "old.pvs", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = bake(
        "new.obj",
        "new.pvs",
        &["--since", "old.pvs", "--old-scene", "old.obj"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(text.contains("10 added in 1 groups"), "{text}");
    let meta = run_ok(&["pvs", "show", "new.pvs", "--json"], dir.path())["metadata"].clone();
    let kept = meta["incremental"]["kept_cells"].as_u64().unwrap();
    let rebaked = meta["incremental"]["rebaked_cells"].as_u64().unwrap();
    assert!(kept >= 1 && rebaked >= 1 && kept + rebaked == 8, "{meta}");
    assert!(
        text.contains(&format!("rebaked {rebaked} of 8 cells")),
        "{text}"
    );
    // The result is a file for the new scene, and a different seed is refused.
    run_ok(
        &[
            "eval",
            "new.obj",
            "--pvs",
            "new.pvs",
            "--viewpoints",
            "1",
            "--resolution",
            "16",
            "--json",
        ],
        dir.path(),
    );
    let o = bake(
        "new.obj",
        "x.pvs",
        &[
            "--since",
            "old.pvs",
            "--old-scene",
            "old.obj",
            "--seed",
            "9",
        ],
    );
    assert_fails_with(&o, "seed");
}

#[test]
fn q3_cluster_cells_shard_and_merge_keep_their_clusters() {
    let dir = tempfile::tempdir().unwrap();
    let map = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/q3dm6ish.bsp");
    let bake = |out: &str, shard: &str| {
        run_ok(
            &[
                "pvs",
                "bake",
                map,
                "--q3-clusters",
                "--clusters",
                "0,1,2,3,4",
                "--method",
                "rand",
                "--rays",
                "30000",
                "--shard",
                shard,
                "-o",
                out,
                "--json",
            ],
            dir.path(),
        )
    };
    assert_eq!(bake("a.pvs", "0/2")["cells"], 3);
    assert_eq!(bake("b.pvs", "1/2")["cells"], 2);
    let meta = run_ok(&["pvs", "show", "b.pvs", "--json"], dir.path())["metadata"].clone();
    assert_eq!(meta["clusters"], serde_json::json!([1, 3]));
    run_ok(
        &["pvs", "merge", "b.pvs", "a.pvs", "-o", "m.pvs", "--json"],
        dir.path(),
    );
    let o = sightline(&["pvs", "compare-q3", map, "m.pvs", "--json"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 5);
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r["cluster"], k);
        assert_eq!(r["leaves"], 1, "one cell per cluster");
        assert!(r["ours"].as_u64().unwrap() > 0);
        // Origins stay inside the cluster, so what we see lies (almost) inside q3map2's
        // conservative cluster PVS.
        let (ours, outside) = (
            r["ours"].as_u64().unwrap(),
            r["ours_not_q3map2"].as_u64().unwrap(),
        );
        assert!(outside * 50 <= ours, "{r}");
    }
}
