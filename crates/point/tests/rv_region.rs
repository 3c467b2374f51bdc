//! Conservative from-region visibility (`rv::conservative_from_region`): on the city, the
//! rooms and a Quake 3 map, for random view cells in free space, every triangle that a ray from
//! a random point of the cell hits is in the set (the ground truth the method must never miss),
//! and the set contains GVS++'s aggressive PVS of the same cell. Prints both sizes.
#![allow(clippy::unwrap_used)]

use sightline_core::scene::{open, LoadOptions};
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::{Hit, Scene};
use sightline_point::rv::{conservative_from_region, RegionOptions, SceneSource};
use sightline_region::cell_sources::random_free_cells;
use sightline_region::{Budget, CellContext, GvsPlusPlus, GvsPlusPlusParams, Sampler};

/// The triangles first hit by random rays from random points of the cell.
fn sampled_hits(bvh: &Bvh, cell: &sightline_region::ViewCell, rays: usize, seed: u64) -> Vec<u32> {
    let batch = cell.random_rays(rays, seed);
    let mut hits = vec![Hit::default(); batch.len()];
    bvh.cast(&batch, &mut hits);
    hits.iter()
        .filter(|h| h.triangle != Hit::NONE)
        .map(|h| h.triangle)
        .collect()
}

/// Checks `cells` random free cells of `scene`; returns the triangles fusion hid in all.
fn check(name: &str, scene: &Scene, cells: usize, half: f32) -> u64 {
    let bvh = Bvh::build(scene);
    let cells = random_free_cells(scene, &bvh, cells, half, 7);
    assert!(!cells.is_empty(), "{name}: no free cells");
    let gvspp = GvsPlusPlus {
        params: GvsPlusPlusParams {
            n_rand: 20_000,
            ..GvsPlusPlusParams::default()
        },
    };
    let mut fused_hidden = 0;
    for (k, cell) in cells.iter().enumerate() {
        let ctx = CellContext {
            scene,
            caster: &bvh,
            cell,
            seed: 3,
            free_space: None,
        };
        let aggressive = gvspp.sample(&ctx, &Budget::rays(400_000), &|_| {});
        let seen = sampled_hits(&bvh, cell, 50_000, k as u64);
        let mut single = None;
        // Single occluders, then with occluder fusion (a few levels, to keep the test short).
        for fusion_splits in [0, 6] {
            let options = RegionOptions {
                fusion_splits,
                fusion_resolution: 128,
                ..RegionOptions::default()
            };
            let r =
                conservative_from_region(&mut SceneSource::new(scene), &cell.corners(), &options)
                    .unwrap();
            for &t in &seen {
                assert!(
                    r.visible.contains(t as usize),
                    "{name} cell {k}, fusion splits {fusion_splits}: triangle {t} is seen from inside the cell but not in the set"
                );
            }
            let missing: Vec<usize> = aggressive.visible.difference(&r.visible).collect();
            assert!(
                missing.is_empty(),
                "{name} cell {k}, fusion splits {fusion_splits}: GVS++ found {} triangles outside the conservative set, e.g. {:?}",
                missing.len(),
                &missing[..missing.len().min(5)]
            );
            println!(
                "from-region {name} cell {k}, fusion splits {fusion_splits}: {} triangles, GVS++ {}, conservative {} ({:.1}x), {} occluders, {} hidden only by fusion",
                scene.triangle_count(),
                aggressive.visible.count_ones(..),
                r.visible.count_ones(..),
                r.visible.count_ones(..) as f64 / aggressive.visible.count_ones(..).max(1) as f64,
                r.stats.occluders,
                r.stats.fused_hidden,
            );
            match &single {
                None => {
                    assert_eq!(r.stats.fused_hidden, 0);
                    single = Some(r.visible);
                }
                Some(single) => {
                    // Fusion only removes triangles, exactly those it counts.
                    assert!(r.visible.is_subset(single));
                    assert_eq!(
                        single.count_ones(..) - r.visible.count_ones(..),
                        r.stats.fused_hidden as usize
                    );
                    fused_hidden += r.stats.fused_hidden;
                }
            }
        }
    }
    fused_hidden
}

#[test]
fn city_cells_are_conservative_and_contain_gvspp() {
    let scene = open("procedural:city?seed=2&size=20000", &LoadOptions::default()).unwrap();
    // Streets lined by separate buildings: fusion finds what no single facade hides.
    assert!(check("city", &scene, 3, 2.0) > 0);
}

#[test]
fn rooms_cells_are_conservative_and_contain_gvspp() {
    let scene = open("procedural:rooms?seed=2&size=4000", &LoadOptions::default()).unwrap();
    check("rooms", &scene, 3, 0.3);
}

#[test]
fn quake3_cells_are_conservative_and_contain_gvspp() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/q3dm6ish.bsp");
    let scene = open(path, &LoadOptions::default()).unwrap();
    check("q3dm6ish", &scene, 3, 8.0);
}

/// The bake's conservative sampler leaves out the back faces of closed solids the cell is
/// outside of: on munich (buildings standing on the ground without floors, many of them
/// sharing a wall's footing with a neighbour) it takes a good share off RV's set, and no ray
/// from inside the cell first hits a triangle it left out.
#[test]
fn back_faces_of_a_citys_buildings_leave_the_bound_and_are_never_seen() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes/city/munich.ply.gz"
    );
    let scene = open(path, &LoadOptions::default()).unwrap();
    let bvh = Bvh::build(&scene);
    // Two of the street cells of docs/BENCHMARKS.md ("Back faces of closed solids"): one at
    // street level, one on a roof.
    let cells = [
        "box:-805.58368,-688.60065,1.2,-785.58368,-668.60065,1.8",
        "box:-525.58368,-268.60065,18.483257,-505.58368,-248.60065,19.083271",
    ];
    for (k, spec) in cells.iter().enumerate() {
        let cell = sightline_region::ViewCell::parse(spec).unwrap();
        let ctx = CellContext {
            scene: &scene,
            caster: &bvh,
            cell: &cell,
            seed: 1,
            free_space: None,
        };
        let sample = |back_faces_of_solids| {
            let sampler = sightline_point::rv::ConservativeSampler {
                back_faces_of_solids,
                ..Default::default()
            };
            sampler.sample(&ctx, &Budget::default(), &|_| {}).visible
        };
        let (with, without) = (sample(true), sample(false));
        assert!(with.is_subset(&without));
        let (n_with, n_without) = (with.count_ones(..), without.count_ones(..));
        println!("munich cell {k}: {n_without} -> {n_with} triangles with the back-face rule");
        assert!(n_with * 100 < n_without * 85, "{n_with} of {n_without}");
        for t in sampled_hits(&bvh, &cell, 100_000, k as u64) {
            assert!(
                with.contains(t as usize),
                "munich cell {k}: triangle {t} is seen from inside the cell but was left out"
            );
        }
    }
}
