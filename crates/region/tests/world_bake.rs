//! Baking many cells: parallel cells independent of thread count, resuming an interrupted bake
//! from its checkpoint, shards and their merge, and incremental rebakes after a scene edit.

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

use std::collections::BTreeMap;
use std::path::Path;

use glam::Vec3;
use sightline_core::scene::{self, LoadOptions, SceneBuilder};
use sightline_core::trace::Bvh;
use sightline_core::{Scene, UpAxis};
use sightline_region::bake::{BakeSetup, BakedCell};
use sightline_region::checkpoint::{checkpoint_path, fingerprint, BakeError, ResumableBake};
use sightline_region::incremental;
use sightline_region::pvs_file::EncodedPvsFile;
use sightline_region::shards::{merge, MergeError, Shard};
use sightline_region::{Budget, GvsPlusPlus, GvsPlusPlusParams, PvsFile, RandomSampler, ViewCell};

fn city() -> Scene {
    scene::open("procedural:city?seed=3&size=3000", &LoadOptions::default()).unwrap()
}

/// Eight street-level cells along the city's central north-south street (x -12..0).
fn street_cells() -> Vec<ViewCell> {
    ViewCell::grid(
        Vec3::new(-10.0, -176.0, 1.0),
        Vec3::new(-2.0, 176.0, 3.0),
        [1, 8, 1],
    )
    .unwrap()
}

/// A bake of `cells` on `scene` with RAND and a ray budget; `f` gets the job.
fn with_job<R>(
    scene: &Scene,
    cells: &[ViewCell],
    seed: u64,
    rays: u64,
    f: impl FnOnce(ResumableBake<'_>) -> R,
) -> R {
    let bvh = Bvh::build(scene);
    let setup = BakeSetup {
        scene,
        caster: &bvh,
        cells,
        sampler: &RandomSampler,
        free_space: &|_, _| true,
        budget: Budget::rays(rays),
        seed,
    };
    let fp = fingerprint(&setup, "rand", serde_json::Value::Null);
    f(ResumableBake::new(setup, fp))
}

/// Bakes completely and writes `out`.
fn bake_to(job: &ResumableBake<'_>, out: &Path) -> PvsFile {
    let p = job.run(&|_, _| {}, &mut |_, _| {}).unwrap();
    assert!(p.complete);
    job.write_output(out, &p, serde_json::Value::Null).unwrap();
    PvsFile::load(out).unwrap()
}

fn sets(f: &PvsFile) -> Vec<Vec<usize>> {
    f.cells.iter().map(|c| c.visible.ones().collect()).collect()
}

#[test]
fn cells_in_parallel_do_not_depend_on_thread_count() {
    let scene = city();
    let cells = street_cells();
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for threads in [1, 4] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let out = dir.path().join(format!("t{threads}.pvs"));
        files.push(pool.install(|| with_job(&scene, &cells, 5, 30_000, |job| bake_to(&job, &out))));
    }
    assert_eq!(files[0].cells, files[1].cells);
    assert!(files[0].cells.iter().all(|c| c.visible.count_ones(..) > 0));
    // Cells come back in cell order with their convergence curves.
    for (i, c) in files[0].cells.iter().enumerate() {
        assert_eq!(c.cell, cells[i]);
        let curve = files[0].metadata["cells"][i]["convergence"]
            .as_array()
            .unwrap();
        assert!(!curve.is_empty() && curve.len() <= 64);
        assert_eq!(
            curve.last().unwrap()[1].as_u64().unwrap() as usize,
            c.visible.count_ones(..)
        );
    }
}

#[test]
fn an_interrupted_bake_resumes_to_the_uninterrupted_result() {
    let scene = city();
    let cells = street_cells();
    let dir = tempfile::tempdir().unwrap();
    let full = with_job(&scene, &cells, 8, 30_000, |job| {
        bake_to(&job, &dir.path().join("full.pvs"))
    });
    let out = dir.path().join("out.pvs");
    std::fs::write(&out, b"an older output that must survive").unwrap();
    let ckpt = checkpoint_path(&out);
    // Stop after 3 cells, as if killed.
    let first = with_job(&scene, &cells, 8, 30_000, |mut job| {
        job.checkpoint = Some(ckpt.clone());
        job.max_new_cells = Some(3);
        job.run(&|_, _| {}, &mut |_, _| {}).unwrap()
    });
    assert!(!first.complete);
    assert_eq!(first.baked, 3);
    assert_eq!(
        std::fs::read(&out).unwrap(),
        b"an older output that must survive"
    );
    let saved = PvsFile::load(&ckpt).unwrap();
    assert_eq!(saved.cells.len(), 3);
    // Resume: the 3 finished cells are loaded, only the other 5 are baked.
    let mut baked_now = Vec::new();
    let resumed = with_job(&scene, &cells, 8, 30_000, |mut job| {
        job.checkpoint = Some(ckpt.clone());
        let p = job.run(&|_, _| {}, &mut |i, _| baked_now.push(i)).unwrap();
        job.write_output(&out, &p, serde_json::Value::Null).unwrap();
        p
    });
    assert_eq!((resumed.resumed, resumed.baked), (3, 5));
    assert!(first.done.keys().all(|i| !baked_now.contains(i)));
    assert!(
        !ckpt.exists(),
        "the checkpoint is removed after the output is written"
    );
    let result = PvsFile::load(&out).unwrap();
    assert_eq!(result.cells, full.cells);
    // Memory: every finished set is stored encoded, never larger than its bitset.
    let n = scene.triangle_count();
    assert!(resumed
        .done
        .values()
        .all(|c| c.set.payload_bytes() <= n.div_ceil(8)));
}

#[test]
fn a_checkpoint_of_another_bake_is_refused() {
    let scene = city();
    let cells = street_cells();
    let dir = tempfile::tempdir().unwrap();
    let ckpt = checkpoint_path(&dir.path().join("out.pvs"));
    with_job(&scene, &cells, 8, 20_000, |mut job| {
        job.checkpoint = Some(ckpt.clone());
        job.max_new_cells = Some(1);
        job.run(&|_, _| {}, &mut |_, _| {}).unwrap();
    });
    let e = with_job(&scene, &cells, 9, 20_000, |mut job| {
        job.checkpoint = Some(ckpt.clone());
        job.run(&|_, _| {}, &mut |_, _| {}).err().unwrap()
    });
    assert!(matches!(e, BakeError::CheckpointMismatch { .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("seed 8 vs 9") && text.contains("--restart"),
        "{text}"
    );
    // Same bake, other cells (a shard): refused too.
    let e = with_job(&scene, &cells, 8, 20_000, |mut job| {
        job.checkpoint = Some(ckpt.clone());
        job.indices = vec![1, 3, 5];
        job.run(&|_, _| {}, &mut |_, _| {}).err().unwrap()
    });
    assert!(e.to_string().contains("--shard"), "{e}");
    // --restart discards it.
    let p = with_job(&scene, &cells, 9, 20_000, |mut job| {
        job.checkpoint = Some(ckpt.clone());
        job.restart = true;
        job.run(&|_, _| {}, &mut |_, _| {}).unwrap()
    });
    assert_eq!((p.resumed, p.baked), (0, cells.len()));
}

#[test]
fn shards_merge_into_the_unsharded_bake_and_bad_merges_are_refused() {
    let scene = city();
    let cells = street_cells();
    let dir = tempfile::tempdir().unwrap();
    let full = with_job(&scene, &cells, 2, 20_000, |job| {
        bake_to(&job, &dir.path().join("full.pvs"))
    });
    let mut shards = Vec::new();
    for i in 0..3 {
        let path = dir.path().join(format!("s{i}.pvs"));
        let f = with_job(&scene, &cells, 2, 20_000, |mut job| {
            job.indices = Shard { index: i, count: 3 }.indices(cells.len());
            bake_to(&job, &path)
        });
        assert_eq!(f.metadata["total_cells"], 8);
        shards.push((path.clone(), EncodedPvsFile::load(&path).unwrap()));
    }
    // Merge order does not matter.
    shards.reverse();
    let merged_path = dir.path().join("merged.pvs");
    merge(&shards, false).unwrap().save(&merged_path).unwrap();
    let merged = PvsFile::load(&merged_path).unwrap();
    assert_eq!(merged.cells, full.cells);
    assert_eq!(sets(&merged), sets(&full));
    assert!(merged.metadata.get("cell_indices").is_none());

    let e = merge(&shards[..2], false).unwrap_err();
    assert!(matches!(e, MergeError::Missing { missing: 3, .. }), "{e}");
    assert_eq!(merge(&shards[..2], true).unwrap().cells.len(), 5);
    let overlapping = [shards[0].clone(), shards[0].clone()];
    assert!(matches!(
        merge(&overlapping, false),
        Err(MergeError::Overlap { .. })
    ));
    let other = dir.path().join("other.pvs");
    with_job(&scene, &cells, 3, 20_000, |mut job| {
        job.indices = vec![0, 3, 6];
        bake_to(&job, &other)
    });
    let mixed = [
        shards[0].clone(),
        (other.clone(), EncodedPvsFile::load(&other).unwrap()),
    ];
    let e = merge(&mixed, true).unwrap_err();
    assert!(e.to_string().contains("seed"), "{e}");
    let mut other_scene = shards[1].clone();
    other_scene.1.scene_hash ^= 1;
    let e = merge(&[shards[0].clone(), other_scene], true).unwrap_err();
    assert!(matches!(e, MergeError::DifferentScenes { .. }), "{e}");
}

/// `scene` with the box `min..max` added after its triangles.
fn with_box(scene: &Scene, min: Vec3, max: Vec3) -> Scene {
    let mut b = SceneBuilder::new("edited");
    b.set_up(UpAxis::Z);
    for t in 0..scene.triangle_count() as u32 {
        let v = scene.triangle(t).map(|p| b.add_vertex(p));
        b.add_triangle(v);
    }
    b.add_box(min, max);
    b.finish()
}

#[test]
fn incremental_rebake_redoes_every_cell_that_can_see_the_edit_and_skips_others() {
    let old = city();
    let cells = street_cells();
    let dir = tempfile::tempdir().unwrap();
    // GVS++ with a high ray budget: a cell that can see the box finds it.
    let gvspp = GvsPlusPlus {
        params: GvsPlusPlusParams {
            n_rand: 50_000,
            ..GvsPlusPlusParams::default()
        },
    };
    let bake_file = |scene: &Scene, kept: BTreeMap<usize, BakedCell>, out: &str| {
        let bvh = Bvh::build(scene);
        let setup = BakeSetup {
            scene,
            caster: &bvh,
            cells: &cells,
            sampler: &gvspp,
            free_space: &|_, _| true,
            budget: Budget::rays(400_000),
            seed: 11,
        };
        let fp = fingerprint(&setup, "gvs++", serde_json::Value::Null);
        let job = ResumableBake {
            kept,
            ..ResumableBake::new(setup, fp)
        };
        let p = job.run(&|_, _| {}, &mut |_, _| {}).unwrap();
        (bake_to(&job, &dir.path().join(out)), p.baked)
    };
    let (old_file, _) = bake_file(&old, BTreeMap::new(), "old.pvs");
    // A 6 m box in the east-west street y 80..92, 120 m east of the central crossing: visible
    // from the cells near that crossing, hidden by blocks of buildings from the far ones. (The
    // ground is one quad per 92 m block, and a box standing on a quad is inside the hull of any
    // cell that sees part of that quad, so cells seeing its ground tile are rebaked too.) Then
    // a 300 m tower in the same place, which far cells see over the roofs against the sky
    // only (no old triangle behind it): the probe must catch those.
    for (height, some_skipped) in [(6.0, true), (300.0, false)] {
        let new = with_box(
            &old,
            Vec3::new(120.0, 82.0, 0.0),
            Vec3::new(130.0, 90.0, height),
        );
        check_incremental(&old, &new, &old_file, &bake_file, some_skipped);
    }
}

/// Bakes a scene with some cells already known, into a named file: the file and the number of
/// cells baked.
type BakeFile<'a> = dyn Fn(&Scene, BTreeMap<usize, BakedCell>, &str) -> (PvsFile, usize) + 'a;

/// Plans the rebake of `old_file` for `new`, bakes fresh and incrementally with `bake_file`,
/// and checks that no skipped cell sees the added geometry in the fresh bake.
fn check_incremental(
    old: &Scene,
    new: &Scene,
    old_file: &PvsFile,
    bake_file: &BakeFile<'_>,
    some_skipped: bool,
) {
    let cells = old_file.cells.len();
    let plan = incremental::plan_with_probe(old, new, old_file, &Bvh::build(old), 16384);
    assert_eq!(plan.matching.removed.len(), 0);
    assert_eq!(plan.matching.added.len(), 12);
    let (fresh, _) = bake_file(new, BTreeMap::new(), "fresh.pvs");
    let (updated, baked) = bake_file(
        new,
        plan.kept_cells(old_file, new.triangle_count()),
        "updated.pvs",
    );
    let rebaked: Vec<usize> = (0..cells).filter(|&i| plan.rebake[i]).collect();
    eprintln!("rebaked {rebaked:?}: {:?}", plan.reasons);
    assert_eq!(baked, rebaked.len());
    let added = |i: usize| {
        plan.matching
            .added
            .iter()
            .filter(|&&t| fresh.cells[i].visible.contains(t as usize))
            .count()
    };
    // The fresh bake sees the box from some cells (else the test shows nothing) ...
    assert!((0..cells).any(|i| added(i) > 0));
    for i in 0..cells {
        if plan.rebake[i] {
            // ... rebaked cells are exactly the fresh bake's (same seed and budget) ...
            assert_eq!(updated.cells[i], fresh.cells[i], "cell {i}");
        } else {
            // ... and no skipped cell sees any added triangle in the fresh bake.
            assert_eq!(added(i), 0, "cell {i} was skipped but sees the new box");
            let remapped = plan
                .matching
                .remap(&old_file.cells[i].visible, new.triangle_count());
            assert_eq!(updated.cells[i].visible, remapped);
            // The kept set is what a fresh bake finds, up to sampling noise (the same rays hit
            // the same triangles; only exact ties between triangles may resolve differently
            // in the new BVH).
            let fresh_set = &fresh.cells[i].visible;
            let differ = fresh_set.symmetric_difference(&remapped).count();
            assert!(
                differ <= 2.max(fresh_set.count_ones(..) / 100),
                "cell {i}: kept set differs from a fresh bake in {differ} triangles"
            );
        }
    }
    if some_skipped {
        assert!(
            rebaked.len() < cells,
            "some far cell is skipped: rebaked {rebaked:?}"
        );
    }
}
