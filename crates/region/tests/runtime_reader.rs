//! The run-time reader (`sightline-runtime`) on files written by this crate: every answer
//! agrees with the in-memory file, the cell-lookup policy holds against a brute-force scan,
//! and no damaged file makes it panic or answer out of range (truncations, every byte flip,
//! and seeded mutations whose checksums are repaired so they reach the inner checks).

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

use std::panic::{catch_unwind, AssertUnwindSafe};

use glam::Vec3;
use sightline_core::random::SplitMix64;
use sightline_core::scene::SceneBuilder;
use sightline_core::{Scene, TriangleSet};
use sightline_region::pvs_file::CellPvs;
use sightline_region::{PvsFile, ViewCell};
use sightline_runtime::Pvs;

/// Twelve boxes (one object each, the sixth split in two runs by the seventh) over a 4x3x1
/// grid of 2 m cells; every cell sees a seeded random part of the triangles.
fn fixture() -> (Scene, PvsFile) {
    let mut b = SceneBuilder::new("runtime fixture");
    for k in 0..12 {
        b.begin_object(format!("Root/box{k}"));
        let p = Vec3::new(k as f32 * 1.5, 0.5, 0.0);
        b.add_box(p, p + Vec3::ONE);
    }
    let mut scene = b.finish();
    // Object 5 takes two triangles of object 6's range: non-contiguous objects.
    scene.object_of_triangle[6 * 12 + 3] = 5;
    scene.object_of_triangle[6 * 12 + 4] = 5;
    let cells = ViewCell::grid(Vec3::ZERO, Vec3::new(8.0, 6.0, 2.0), [4, 3, 1]).unwrap();
    let mut file = PvsFile::for_scene(&scene, serde_json::json!({"method": "fixture"}));
    let n = scene.triangle_count();
    let mut rng = SplitMix64::new(7);
    for (i, cell) in cells.into_iter().enumerate() {
        let mut visible = TriangleSet::with_capacity(n);
        let density = (i % 4) as u64; // 0: empty, 3: dense (bitset encoding)
        for t in 0..n {
            if rng.next_u64() % 4 < density {
                visible.insert(t);
            }
        }
        file.cells.push(CellPvs::new(cell, visible));
    }
    (scene, file)
}

fn bytes_of(f: &PvsFile) -> Vec<u8> {
    let mut b = Vec::new();
    f.write(&mut b).unwrap();
    b
}

#[test]
fn answers_agree_with_the_file_in_memory() {
    let (scene, file) = fixture();
    let pvs = Pvs::from_bytes(bytes_of(&file)).unwrap();
    assert_eq!(pvs.version(), 2);
    assert_eq!(pvs.cell_count() as usize, file.cells.len());
    assert_eq!(pvs.object_count() as usize, scene.objects.len());
    assert_eq!(pvs.scene_hash(), scene.geometry_hash());
    pvs.verify_sets().unwrap();
    for (i, c) in file.cells.iter().enumerate() {
        let i = i as u32;
        let triangles: Vec<u32> = c.visible.ones().map(|t| t as u32).collect();
        assert_eq!(pvs.visible_triangles(i).unwrap(), triangles);
        let mut objects: Vec<u32> = triangles
            .iter()
            .map(|&t| scene.object_of_triangle[t as usize])
            .collect();
        objects.sort_unstable();
        objects.dedup();
        assert_eq!(pvs.visible_objects(i).unwrap(), objects, "cell {i}");
        assert_eq!(pvs.visible_object_count(i).unwrap() as usize, objects.len());
        let cell = pvs.cell(i).unwrap();
        assert_eq!(cell.center, c.cell.center.to_array());
    }
    for (o, object) in scene.objects.iter().enumerate() {
        let o = o as u32;
        assert_eq!(pvs.object(o).unwrap().name, object.name);
        let from_ranges: Vec<u32> = pvs.object_triangles(o).unwrap().flatten().collect();
        let expected: Vec<u32> = (0..scene.triangle_count() as u32)
            .filter(|&t| scene.object_of_triangle[t as usize] == o)
            .collect();
        assert_eq!(from_ranges, expected, "object {o}");
        for t in expected {
            assert_eq!(pvs.object_of_triangle(t), Some(o));
        }
    }
    assert_eq!(
        pvs.object_triangles(5).unwrap().count(),
        2,
        "object 5 has two runs"
    );
    assert_eq!(pvs.object_of_triangle(scene.triangle_count() as u32), None);
    assert!(pvs.object(99).is_err());
    assert!(pvs.visible_objects(99).is_err());
    let o = pvs.object(0).unwrap();
    assert_eq!(o.bounds_min, [0.0, 0.5, 0.0]);
    assert_eq!(o.bounds_max, [1.0, 1.5, 1.0]);
}

#[test]
fn cell_lookup_follows_the_documented_policy() {
    let (_, file) = fixture();
    let pvs = Pvs::from_bytes(bytes_of(&file)).unwrap();
    // Brute force: the lowest-index cell whose box holds the point within 1e-5 of its size.
    let brute = |p: Vec3| {
        file.cells.iter().position(|c| {
            let d = p - c.cell.center;
            let t = 1e-5 * (c.cell.half_extents.max_element() + c.cell.center.abs().max_element());
            (0..3).all(|k| d.dot(c.cell.axes[k]).abs() <= c.cell.half_extents[k] + t)
        })
    };
    let mut rng = SplitMix64::new(11);
    let mut inside = 0;
    for _ in 0..20_000 {
        let u = |rng: &mut SplitMix64, lo: f32, hi: f32| {
            lo + (hi - lo) * (rng.next_u64() % 10_000) as f32 / 10_000.0
        };
        // Points on the grid's lines (shared faces) are a quarter of the draws.
        let snap = rng.next_u64().is_multiple_of(4);
        let mut p = Vec3::new(
            u(&mut rng, -1.0, 9.0),
            u(&mut rng, -1.0, 7.0),
            u(&mut rng, -1.0, 3.0),
        );
        if snap {
            p = (p / 2.0).round() * 2.0;
        }
        let got = pvs.cell_at(p.to_array());
        assert_eq!(got.map(|c| c as usize), brute(p), "at {p}");
        inside += usize::from(got.is_some());
    }
    assert!(inside > 5_000, "too few points inside cells: {inside}");
    // A face shared by cells 0 and 1 (x = 2) belongs to the lower index.
    assert_eq!(pvs.cell_at([2.0, 1.0, 1.0]), Some(0));
    assert_eq!(pvs.cell_at([2.0 + 1e-3, 1.0, 1.0]), Some(1));
    assert_eq!(pvs.cell_at([-0.5, 1.0, 1.0]), None);
    assert_eq!(pvs.cell_at([f32::NAN, 1.0, 1.0]), None);
    assert_eq!(pvs.cell_at([f32::INFINITY, 1.0, 1.0]), None);
}

#[test]
fn every_truncation_and_byte_flip_is_refused() {
    let (_, file) = fixture();
    let b = bytes_of(&file);
    for len in 0..b.len() {
        assert!(
            Pvs::from_bytes(b[..len].to_vec()).is_err(),
            "truncated to {len} accepted"
        );
    }
    for i in 0..b.len() {
        let mut c = b.clone();
        c[i] ^= 0x04;
        assert!(Pvs::from_bytes(c).is_err(), "flip at byte {i} accepted");
    }
}

/// A checksummed region: its bytes, where its CRC is stored, and the payload ranges it also
/// covers (a cell record's).
struct Region {
    start: usize,
    end: usize,
    crc_at: usize,
    payloads: Vec<(usize, usize)>,
}

/// Byte offsets of the checksummed regions of a valid version-2 file, to repair checksums
/// after a mutation: (region start, region end, CRC position) in file order.
fn checksum_regions(b: &[u8]) -> Vec<Region> {
    let u32_at = |at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap()) as usize;
    let cells = u32_at(28);
    let objects = u32_at(32);
    let metadata = u32_at(36);
    let header_end = 40 + metadata;
    let region = |start, end, payloads| Region {
        start,
        end,
        crc_at: end,
        payloads,
    };
    let mut regions = vec![region(0, header_end, vec![])];
    let section = header_end + 4;
    let names = u32_at(section);
    let runs = u32_at(section + 4);
    let section_end = section + 8 + objects * 40 + runs * 8 + names;
    regions.push(region(section, section_end, vec![]));
    let table = section_end + 4;
    let mut payload = table + cells * 84;
    for i in 0..cells {
        let r = table + i * 84;
        let len = u32_at(r + 68) + u32_at(r + 76);
        regions.push(region(r, r + 80, vec![(payload, payload + len)]));
        payload += len;
    }
    regions
}

fn repair_checksums(b: &mut [u8], regions: &[Region]) {
    for r in regions {
        let mut h = crc32fast::Hasher::new();
        h.update(&b[r.start..r.end]);
        for &(s, e) in &r.payloads {
            h.update(&b[s..e]);
        }
        let crc = h.finalize().to_le_bytes();
        b[r.crc_at..r.crc_at + 4].copy_from_slice(&crc);
    }
}

#[test]
fn mutated_files_with_repaired_checksums_never_panic_or_answer_out_of_range() {
    let (_, file) = fixture();
    let original = bytes_of(&file);
    let regions = checksum_regions(&original);
    let iterations: usize = std::env::var("SIGHTLINE_FUZZ_ITERATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3_000);
    let mut rng = SplitMix64::new(2026);
    let (mut opened, mut refused, mut query_errors) = (0, 0, 0);
    for i in 0..iterations {
        let mut b = original.clone();
        // 1-4 changes anywhere but the checksums: random bytes, or a u32 field set to an
        // edge value (0, 1, max, a large count).
        for _ in 0..1 + rng.next_u64() % 4 {
            let at = (rng.next_u64() as usize) % (b.len() - 4);
            match rng.next_u64() % 3 {
                0 => b[at] = rng.next_u64() as u8,
                1 => b[at] ^= 1 << (rng.next_u64() % 8),
                _ => {
                    let v: u32 = [0, 1, u32::MAX, 1 << 30, 7][(rng.next_u64() % 5) as usize];
                    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
                }
            }
        }
        repair_checksums(&mut b, &regions);
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            let Ok(pvs) = Pvs::from_bytes(b.clone()) else {
                return (false, 0);
            };
            let mut errors = 0;
            let mut ids = Vec::new();
            for c in 0..pvs.cell_count() + 1 {
                match pvs.visible_objects_into(c, &mut ids) {
                    Ok(()) => assert!(ids.iter().all(|&o| o < pvs.object_count())),
                    Err(_) => errors += 1,
                }
                match pvs.visible_triangles_into(c, &mut ids) {
                    Ok(()) => assert!(ids.iter().all(|&t| t < pvs.triangle_count())),
                    Err(_) => errors += 1,
                }
            }
            for o in 0..pvs.object_count() + 1 {
                if let Ok(runs) = pvs.object_triangles(o) {
                    assert!(runs.flatten().all(|t| t < pvs.triangle_count()));
                }
                let _ = pvs.object(o);
            }
            for _ in 0..20 {
                let p = [(i % 9) as f32, (i % 7) as f32, (i % 3) as f32];
                if let Some(c) = pvs.cell_at(p) {
                    assert!(c < pvs.cell_count());
                }
            }
            let _ = pvs.verify_sets();
            (true, errors)
        }));
        match outcome {
            Ok((true, errors)) => {
                opened += 1;
                query_errors += errors;
            }
            Ok((false, _)) => refused += 1,
            Err(_) => panic!("mutation {i} panicked the reader: {b:?}"),
        }
    }
    // Both outcomes must occur, or the mutations do not reach the inner checks.
    assert!(
        opened > 0 && refused > 0,
        "{opened} opened, {refused} refused"
    );
    assert!(
        query_errors > 0,
        "no mutation reached the set decoder's checks"
    );
}
