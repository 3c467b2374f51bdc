//! Integration tests of the Quake 3 IBSP v46 loader on the six maps of `shared/scenes/q3/`:
//! counts against `shared/scenes/SOURCES.md`, the cluster PVS, spawn points, and malformed
//! input (hand-made corruptions and a seeded fuzz run) that must give errors, never panics.

use std::path::{Path, PathBuf};

use glam::Vec3;
use sightline_core::scene::q3::{self, SurfaceFlags, SurfaceKind};
use sightline_core::scene::LoadOptions;
use sightline_core::{Aabb, Scene};

/// The `shared/scenes` folder: `$SIGHTLINE_SHARED_SCENES`, else the first `shared/scenes`
/// found walking up from this crate (the repository normally sits beside `shared/`).
fn scenes_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("SIGHTLINE_SHARED_SCENES") {
        return PathBuf::from(dir);
    }
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .map(|a| a.join("shared").join("scenes"))
        .find(|d| d.join("q3").is_dir())
        .expect(
            "shared/scenes not found above CARGO_MANIFEST_DIR; set SIGHTLINE_SHARED_SCENES \
             to the scenes folder",
        )
}

fn map_path(name: &str) -> PathBuf {
    scenes_dir().join("q3").join(format!("{name}.bsp"))
}

fn map_bytes(name: &str) -> Vec<u8> {
    let p = map_path(name);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn load_with(name: &str, n: u32) -> Scene {
    let p = map_path(name);
    q3::load(
        &p,
        &map_bytes(name),
        &LoadOptions {
            patch_subdivisions: n,
            ..LoadOptions::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// One row of the SOURCES.md table.
struct Facts {
    name: &'static str,
    all: usize,
    world: usize,
    polygon: usize,
    mesh: usize,
    clusters: u32,
    leafs: usize,
    density: f64,
    bbox: ([f32; 3], [f32; 3]),
    translucent_or_liquid: usize,
    sky: usize,
}

const MAPS: [Facts; 6] = [
    Facts {
        name: "fan",
        all: 1_082,
        world: 938,
        polygon: 634,
        mesh: 448,
        clusters: 108,
        leafs: 247,
        density: 0.912,
        bbox: ([-800.0, -800.0, -528.0], [800.0, 800.0, 1056.0]),
        translucent_or_liquid: 448,
        sky: 6,
    },
    Facts {
        name: "q3dm6ish",
        all: 2_621,
        world: 2_549,
        polygon: 2_621,
        mesh: 0,
        clusters: 247,
        leafs: 650,
        density: 0.370,
        bbox: ([-832.0, -768.0, -576.0], [768.4, 736.0, 608.0]),
        translucent_or_liquid: 0,
        sky: 0,
    },
    Facts {
        name: "dm4ish",
        all: 3_484,
        world: 3_484,
        polygon: 3_484,
        mesh: 0,
        clusters: 641,
        leafs: 1_427,
        density: 0.208,
        bbox: ([-864.0, -896.0, -416.0], [880.0, 896.0, 360.0]),
        translucent_or_liquid: 156,
        sky: 54,
    },
    Facts {
        name: "oa_dm1",
        all: 7_532,
        world: 7_460,
        polygon: 4_432,
        mesh: 3_100,
        clusters: 422,
        leafs: 1_123,
        density: 0.218,
        bbox: ([-704.0, 536.0, -232.0], [1152.0, 1672.0, 320.0]),
        translucent_or_liquid: 84,
        sky: 0,
    },
    Facts {
        name: "oa_dm2",
        all: 12_033,
        world: 11_485,
        polygon: 12_033,
        mesh: 0,
        clusters: 1_041,
        leafs: 2_560,
        density: 0.113,
        bbox: ([1152.0, -2592.0, -184.0], [3008.0, 352.0, 576.0]),
        translucent_or_liquid: 62,
        sky: 112,
    },
    Facts {
        name: "czest3ctf",
        all: 19_343,
        world: 19_283,
        polygon: 19_087,
        mesh: 256,
        clusters: 1_441,
        leafs: 4_457,
        density: 0.086,
        bbox: ([-3136.0, -1984.0, -192.0], [3136.0, 1984.0, 768.0]),
        translucent_or_liquid: 276,
        sky: 142,
    },
];

fn bsp(scene: &Scene) -> &q3::BspData {
    scene.bsp.as_deref().expect("a .bsp scene has BSP data")
}

/// Triangles of the given kinds in the given models.
fn triangles_of(bsp: &q3::BspData, models: std::ops::Range<usize>, kinds: &[SurfaceKind]) -> usize {
    bsp.models[models]
        .iter()
        .flat_map(|m| m.surfaces.clone())
        .map(|s| &bsp.surfaces[s as usize])
        .filter(|s| kinds.contains(&s.kind))
        .map(|s| s.triangles.len())
        .sum()
}

#[test]
fn q3_counts_match_sources_md_on_all_maps() {
    for f in &MAPS {
        let start = std::time::Instant::now();
        let scene = load_with(f.name, 0);
        eprintln!("{}: loaded in {:?}", f.name, start.elapsed());
        let b = bsp(&scene);
        let n = b.models.len();
        assert_eq!(scene.triangle_count(), f.all, "{} all models", f.name);
        let flat = [SurfaceKind::Polygon, SurfaceKind::Mesh];
        assert_eq!(triangles_of(b, 0..1, &flat), f.world, "{} world", f.name);
        assert_eq!(
            triangles_of(b, 0..n, &[SurfaceKind::Polygon]),
            f.polygon,
            "{}",
            f.name
        );
        assert_eq!(
            triangles_of(b, 0..n, &[SurfaceKind::Mesh]),
            f.mesh,
            "{}",
            f.name
        );
        assert_eq!(b.clusters, f.clusters, "{} clusters", f.name);
        assert_eq!(b.leaves.len(), f.leafs, "{} leafs", f.name);
        let density = (b.pvs_density() * 1000.0).round() / 1000.0;
        assert!(
            (density - f.density).abs() < 1e-9,
            "{} density {density}",
            f.name
        );
        assert_eq!(scene.up, sightline_core::UpAxis::Z);
        assert_eq!(b.surface_of_triangle.len(), scene.triangle_count());
        assert_eq!(scene.object_of_triangle.len(), scene.triangle_count());
    }
}

#[test]
fn q3_world_bbox_matches_sources_md() {
    for f in &MAPS {
        let scene = load_with(f.name, 4);
        let b = bsp(&scene);
        let mut bounds = Aabb::EMPTY;
        for s in b.models[0].surfaces.clone() {
            let s = &b.surfaces[s as usize];
            if matches!(s.kind, SurfaceKind::Polygon | SurfaceKind::Mesh) {
                for t in s.triangles.clone() {
                    for p in scene.triangle(t) {
                        bounds.grow(p);
                    }
                }
            }
        }
        let (lo, hi) = (Vec3::from_array(f.bbox.0), Vec3::from_array(f.bbox.1));
        assert!(
            (bounds.min - lo).abs().max_element() < 0.05
                && (bounds.max - hi).abs().max_element() < 0.05,
            "{}: {bounds:?}",
            f.name
        );
    }
}

#[test]
fn q3_flag_counts_match_sources_md() {
    for f in &MAPS {
        let scene = load_with(f.name, 0);
        let b = bsp(&scene);
        let count = |pred: &dyn Fn(SurfaceFlags) -> bool| {
            (0..scene.triangle_count() as u32)
                .filter(|&t| pred(b.triangle_flags(t)))
                .count()
        };
        let see_through = count(&|fl| {
            fl.contains(SurfaceFlags::TRANSLUCENT) || fl.contains(SurfaceFlags::LIQUID)
        });
        assert_eq!(
            see_through, f.translucent_or_liquid,
            "{} translucent",
            f.name
        );
        assert_eq!(
            count(&|fl| fl.contains(SurfaceFlags::SKY)),
            f.sky,
            "{} sky",
            f.name
        );
        assert_eq!(
            count(&|fl| fl.contains(SurfaceFlags::NODRAW)),
            0,
            "{} nodraw",
            f.name
        );
    }
}

#[test]
fn q3_czest3ctf_patches_tessellate_to_two_n_squared_per_sub_patch() {
    let flat = 19_343;
    for n in [4u32, 2, 0] {
        let scene = load_with("czest3ctf", n);
        let b = bsp(&scene);
        let patches: Vec<_> = b
            .surfaces
            .iter()
            .filter(|s| s.kind == SurfaceKind::Patch)
            .collect();
        assert_eq!(patches.len(), 424);
        let sub: u32 = patches
            .iter()
            .map(|s| (s.patch_size.0 - 1) / 2 * ((s.patch_size.1 - 1) / 2))
            .sum();
        assert_eq!(sub, 478);
        let expected = (478 * 2 * n * n) as usize;
        assert_eq!(scene.triangle_count(), flat + expected, "n = {n}");
        // Patch triangles come after every polygon/mesh triangle.
        let patch_tris: usize = patches.iter().map(|s| s.triangles.len()).sum();
        assert_eq!(patch_tris, expected);
        assert!(patches
            .iter()
            .all(|s| s.triangles.is_empty() || s.triangles.start >= flat as u32));
    }
}

#[test]
fn q3_flat_triangle_ids_do_not_depend_on_patch_level() {
    let coarse = load_with("czest3ctf", 1);
    let fine = load_with("czest3ctf", 4);
    for t in 0..19_343u32 {
        assert_eq!(coarse.triangle(t), fine.triangle(t));
    }
}

#[test]
fn q3_spawn_points_are_in_clusters_that_see_themselves() {
    for f in &MAPS {
        let scene = load_with(f.name, 0);
        let b = bsp(&scene);
        assert!(
            (6..=56).contains(&b.spawn_points.len()),
            "{}: {} spawn points",
            f.name,
            b.spawn_points.len()
        );
        for &p in &b.spawn_points {
            let c = b
                .cluster_at(p)
                .unwrap_or_else(|| panic!("{}: spawn {p} in no cluster", f.name));
            assert!(b.cluster_sees(c, c), "{}: cluster {c}", f.name);
            let visible = b.triangles_visible_from_cluster(c);
            assert!(!visible.is_empty(), "{}: spawn {p} sees nothing", f.name);
            assert!(visible.windows(2).all(|w| w[0] < w[1]));
            assert!(visible
                .iter()
                .all(|&t| (t as usize) < scene.triangle_count()));
        }
    }
    assert_eq!(bsp(&load_with("czest3ctf", 0)).spawn_points.len(), 56);
}

/// The lowest cluster of the leaves that list surface `s` (None: no leaf in a cluster does).
fn lowest_cluster(b: &q3::BspData, s: u32) -> Option<u32> {
    (0..b.leaves.len())
        .filter(|&l| b.surfaces_of_leaf(l).contains(&s))
        .filter_map(|l| u32::try_from(b.leaves[l].cluster).ok())
        .min()
}

#[test]
fn q3_objects_are_cluster_and_shader_in_the_world_model_and_shader_elsewhere() {
    let scene = load_with("q3dm6ish", 4);
    let b = bsp(&scene);
    assert_eq!(scene.object_of_triangle.len(), scene.triangle_count());
    let mut names = std::collections::HashMap::new();
    for (t, &s) in b.surface_of_triangle.iter().enumerate() {
        let surface = &b.surfaces[s as usize];
        let object = &scene.objects[scene.object_of_triangle[t] as usize];
        let model = surface.model.expect("emitted surfaces belong to a model");
        assert_eq!(object.index, Some(model), "triangle {t}");
        assert_eq!(object.part, Some(surface.shader), "triangle {t}");
        let shader = &b.shaders[surface.shader as usize].name;
        let expected = names.entry(s).or_insert_with(|| match model {
            0 => match lowest_cluster(b, s) {
                Some(c) => format!("model0/cluster{c}/{shader}"),
                None => format!("model0/nocluster/{shader}"),
            },
            m => format!("model{m}/{shader}"),
        });
        assert_eq!(object.name, *expected, "triangle {t}");
    }
    // One object per key with triangles (names and parts distinct), every one used.
    let mut keys: Vec<(&str, u32)> = scene
        .objects
        .iter()
        .map(|o| (o.name.as_str(), o.part.unwrap()))
        .collect();
    let count = keys.len();
    keys.sort_unstable();
    keys.dedup();
    assert_eq!(keys.len(), count, "no two objects share name and shader");
    assert!(scene.triangles_by_object().iter().all(|t| !t.is_empty()));
    // Ordered by model; the world has many rooms, brush models have objects of their own.
    let models: Vec<u32> = scene.objects.iter().map(|o| o.index.unwrap()).collect();
    assert!(models.windows(2).all(|w| w[0] <= w[1]));
    assert!(
        scene
            .objects
            .iter()
            .filter(|o| o.name.starts_with("model0/cluster"))
            .count()
            > 100
    );
    assert!(models.iter().any(|&m| m > 0));
}

/// Per-object culling with the map's own cluster PVS stays close to the triangle sets: the
/// share of triangles drawn when every object with a visible triangle is drawn, mean over
/// clusters, at most 1.15x the triangle PVS's (one object per world shader drew 2x).
#[test]
fn q3_objects_cull_close_to_the_triangle_sets() {
    for name in ["q3dm6ish", "oa_dm2"] {
        let scene = load_with(name, 4);
        let b = bsp(&scene);
        let by_object = scene.triangles_by_object();
        let (mut triangles, mut drawn) = (0usize, 0usize);
        for c in 0..b.clusters {
            let visible = b.triangles_visible_from_cluster(c);
            let mut objects: Vec<u32> = visible
                .iter()
                .map(|&t| scene.object_of_triangle[t as usize])
                .collect();
            objects.sort_unstable();
            objects.dedup();
            triangles += visible.len();
            drawn += objects
                .iter()
                .map(|&o| by_object[o as usize].len())
                .sum::<usize>();
        }
        let ratio = drawn as f64 / triangles as f64;
        assert!(
            triangles > 0 && ratio <= 1.15,
            "{name}: objects draw {ratio:.3}x the triangle PVS"
        );
    }
}

#[test]
fn q3_objects_survive_glb_and_obj_round_trips() {
    use sightline_core::scene::{gltf, obj};
    let scene = load_with("q3dm6ish", 4);
    assert!(scene.objects.len() > 10);
    // The writers emit one node / `o` line per run of consecutive triangles; there are many
    // more runs than objects, so joining them is what is tested.
    let runs = 1 + scene
        .object_of_triangle
        .windows(2)
        .filter(|w| w[0] != w[1])
        .count();
    assert!(runs > 2 * scene.objects.len(), "{runs} runs");
    for ext in ["glb", "obj"] {
        let mut out = Vec::new();
        let back = if ext == "glb" {
            gltf::write_glb(&scene, &mut out).unwrap();
            gltf::load(Path::new("back.glb"), &out).unwrap()
        } else {
            obj::write(&scene, &mut out).unwrap();
            obj::load(Path::new("back.obj"), &out).unwrap()
        };
        assert_eq!(back.objects, scene.objects, "{ext}: names, index, part");
        assert_eq!(
            back.object_of_triangle, scene.object_of_triangle,
            "{ext}: object of every triangle"
        );
        assert_eq!(back.geometry_hash(), scene.geometry_hash(), "{ext}: ids");
    }
}

#[test]
fn q3_object_counts_are_reported() {
    for f in &MAPS {
        let scene = load_with(f.name, LoadOptions::default().patch_subdivisions);
        let runs = 1 + scene
            .object_of_triangle
            .windows(2)
            .filter(|w| w[0] != w[1])
            .count();
        eprintln!("{}: {} objects {runs} runs", f.name, scene.objects.len());
        assert!(!scene.objects.is_empty());
    }
}

// ---------------------------------------------------------------------------------------------
// Malformed input

/// `(offset, length)` of lump `i` from the header.
fn lump(bytes: &[u8], i: usize) -> (usize, usize) {
    let at = |o: usize| i32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    (at(8 + 8 * i) as usize, at(12 + 8 * i) as usize)
}

fn put_i32(bytes: &mut [u8], at: usize, v: i32) {
    bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

fn load_err(bytes: &[u8]) -> String {
    match q3::load(Path::new("bad.bsp"), bytes, &LoadOptions::default()) {
        Ok(_) => panic!("malformed file loaded"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn q3_wrong_magic_and_version_are_errors() {
    let mut b = map_bytes("fan");
    b[0] = b'V';
    assert!(load_err(&b).contains("magic"), "{}", load_err(&b));
    let mut b = map_bytes("fan");
    put_i32(&mut b, 4, 47);
    let e = load_err(&b);
    assert!(
        e.contains("version 47") && e.contains("byte offset 4"),
        "{e}"
    );
}

#[test]
fn q3_truncated_files_are_errors() {
    let b = map_bytes("fan");
    let mut cuts: Vec<usize> = vec![0, 1, 4, 8, 143, 144, 145];
    for i in 0..17 {
        let (o, l) = lump(&b, i);
        cuts.extend([o, o + l / 2, (o + l).saturating_sub(1)]);
    }
    cuts.extend((0..b.len()).step_by(b.len() / 97));
    for cut in cuts.into_iter().filter(|&c| c < b.len()) {
        let e = load_err(&b[..cut]);
        assert!(
            e.contains("header") || e.contains("past the end"),
            "cut {cut}: {e}"
        );
    }
}

#[test]
fn q3_lump_outside_file_names_lump_and_offset() {
    let mut b = map_bytes("fan");
    let len = b.len() as i32;
    put_i32(&mut b, 8 + 8 * 13, len);
    let e = load_err(&b);
    assert!(
        e.contains("lump 13 (surfaces)") && e.contains(&format!("offset {len}")),
        "{e}"
    );
    let mut b = map_bytes("fan");
    put_i32(&mut b, 8 + 8 * 10 + 4, 45);
    let e = load_err(&b);
    assert!(
        e.contains("lump 10 (drawverts)") && e.contains("multiple"),
        "{e}"
    );
    let mut b = map_bytes("fan");
    put_i32(&mut b, 8 + 8 * 2, -16);
    assert!(load_err(&b).contains("lump 2 (planes)"));
}

/// Byte offset of field `field` of surface record `s`.
fn surface_field(b: &[u8], s: usize, field: usize) -> usize {
    lump(b, 13).0 + 104 * s + 4 * field
}

fn first_surface_of_type(b: &[u8], kind: i32) -> usize {
    let n = lump(b, 13).1 / 104;
    (0..n)
        .find(|&s| {
            let at = surface_field(b, s, 2);
            i32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]) == kind
        })
        .expect("surface of that type")
}

#[test]
fn q3_bad_index_names_surface() {
    let orig = map_bytes("fan");
    let s = first_surface_of_type(&orig, 1);
    let first_index = {
        let at = surface_field(&orig, s, 5);
        i32::from_le_bytes([orig[at], orig[at + 1], orig[at + 2], orig[at + 3]]) as usize
    };
    let want = format!("lump 13 (surfaces), record {s}");
    for bad in [-1, 1_000_000, i32::MIN, i32::MAX] {
        let mut b = orig.clone();
        put_i32(&mut b, lump(&orig, 11).0 + 4 * first_index, bad);
        let e = load_err(&b);
        assert!(e.contains(&want) && e.contains("index"), "{e}");
    }
    for (field, bad) in [
        (0, 99_999),
        (2, 7),
        (3, -5),
        (4, i32::MAX),
        (5, i32::MAX),
        (6, 4),
    ] {
        let mut b = orig.clone();
        put_i32(&mut b, surface_field(&orig, s, field), bad);
        let e = load_err(&b);
        assert!(e.contains(&want), "field {field} = {bad}: {e}");
    }
}

#[test]
fn q3_bad_tree_and_leaf_records_are_named() {
    let orig = map_bytes("fan");
    let cases = [
        // (lump, record, int field, bad value, expected place)
        (3, 0, 1, i32::MIN, "lump 3 (nodes), record 0"),
        (3, 0, 0, -1, "lump 3 (nodes), record 0"),
        (3, 0, 1, 0, "lump 3 (nodes), record 0"),
        (4, 1, 0, 5000, "lump 4 (leafs), record 1"),
        (4, 1, 9, 1 << 30, "lump 4 (leafs), record 1"),
        (5, 0, 0, -3, "lump 5 (leafsurfaces), record 0"),
        (7, 0, 7, 5000, "lump 7 (models), record 0"),
    ];
    for (l, record, field, bad, want) in cases {
        let mut b = orig.clone();
        let record_size = [0, 72, 16, 36, 48, 4, 4, 40][l];
        put_i32(
            &mut b,
            lump(&orig, l).0 + record_size * record + 4 * field,
            bad,
        );
        let r = q3::load(Path::new("bad.bsp"), &b, &LoadOptions::default());
        let e = r
            .err()
            .unwrap_or_else(|| panic!("{want} field {field} = {bad} loaded"));
        assert!(e.to_string().contains(want), "{want}: {e}");
    }
    let mut b = orig.clone();
    put_i32(&mut b, lump(&orig, 16).0 + 4, 1);
    assert!(load_err(&b).contains("lump 16 (visdata)"));
}

/// The fuzz tests' generator: the project's SplitMix64 (deterministic on every platform) with
/// `usize` bounds, 0 for an empty range.
struct Fuzz(sightline_core::random::SplitMix64);

impl Fuzz {
    fn new(seed: u64) -> Self {
        Self(sightline_core::random::SplitMix64::new(seed))
    }

    fn next(&mut self) -> u64 {
        self.0.next_u64()
    }

    fn below(&mut self, n: usize) -> usize {
        self.0.below(n.max(1) as u64) as usize
    }
}

#[test]
fn q3_fuzzed_fan_never_panics() {
    let orig = map_bytes("fan");
    let mut buf = orig.clone();
    let mut rng = Fuzz::new(0x5EED_F9A3);
    let hot: Vec<(usize, usize)> = [10, 11, 13, 3, 4, 5, 7, 16]
        .iter()
        .map(|&i| lump(&orig, i))
        .collect();
    let interesting = [
        0,
        1,
        -1,
        2,
        3,
        7,
        46,
        144,
        i32::MAX,
        i32::MIN,
        1 << 16,
        -(1 << 16),
    ];
    let (mut loaded, mut failed) = (0, 0);
    for round in 0..2000 {
        let mut touched = Vec::new();
        for _ in 0..1 + rng.below(3) {
            // Half the mutations hit the header, the rest the lumps (mostly 10, 11, 13).
            let at = if rng.below(2) == 0 {
                rng.below(144 - 3)
            } else {
                let (o, l) = hot[if rng.below(4) == 0 {
                    rng.below(hot.len())
                } else {
                    rng.below(3)
                }];
                if l < 4 {
                    continue;
                }
                o + rng.below(l - 3)
            };
            touched.push(at);
            match rng.below(3) {
                0 => buf[at] = rng.next() as u8,
                1 => put_i32(&mut buf, at & !3, interesting[rng.below(interesting.len())]),
                _ => put_i32(&mut buf, at & !3, rng.next() as i32 >> rng.below(31)),
            }
        }
        let len = if rng.below(8) == 0 {
            rng.below(buf.len())
        } else {
            buf.len()
        };
        let input = &buf[..len];
        let result = std::panic::catch_unwind(|| {
            q3::load(Path::new("fuzz.bsp"), input, &LoadOptions::default())
        });
        match result {
            Err(_) => panic!("round {round}: load panicked"),
            Ok(Err(_)) => failed += 1,
            Ok(Ok(scene)) => {
                loaded += 1;
                let n = scene.positions.len() as u32;
                assert!(
                    scene.triangles.iter().flatten().all(|&i| i < n),
                    "round {round}"
                );
                let b = bsp(&scene);
                for &p in b.spawn_points.iter().take(3) {
                    if let Some(c) = b.cluster_at(p) {
                        let _ = b.triangles_visible_from_cluster(c);
                    }
                }
            }
        }
        for at in touched {
            let at = at & !3;
            buf[at..at + 4].copy_from_slice(&orig[at..at + 4]);
        }
    }
    assert!(buf == orig, "mutations were not all undone");
    eprintln!("fuzz: {loaded} loaded, {failed} rejected");
    assert!(loaded > 0 && failed > 0);
}

#[test]
fn q3_fuzzed_czest3ctf_patches_never_panic() {
    // fan has no patches; here the mutations hit the patch fields (firstVert, numVerts,
    // patchWidth, patchHeight, type) of czest3ctf's patch surfaces.
    let orig = map_bytes("czest3ctf");
    let n = lump(&orig, 13).1 / 104;
    let read = |at: usize| i32::from_le_bytes([orig[at], orig[at + 1], orig[at + 2], orig[at + 3]]);
    let patches: Vec<usize> = (0..n)
        .filter(|&s| read(surface_field(&orig, s, 2)) == 2)
        .collect();
    assert_eq!(patches.len(), 424);
    let mut buf = orig.clone();
    let mut rng = Fuzz::new(0xC2E5_7C7F);
    let values = [0, 1, 2, 3, 4, 5, 9, -1, -3, 31, 1 << 15, i32::MAX, i32::MIN];
    let (mut loaded, mut failed) = (0, 0);
    for round in 0..300 {
        let s = patches[rng.below(patches.len())];
        let field = [2, 3, 4, 24, 25][rng.below(5)];
        let at = surface_field(&orig, s, field);
        put_i32(&mut buf, at, values[rng.below(values.len())]);
        let options = LoadOptions {
            patch_subdivisions: rng.below(4) as u32,
            ..LoadOptions::default()
        };
        let input = &buf[..];
        let result = std::panic::catch_unwind(|| q3::load(Path::new("fuzz.bsp"), input, &options));
        match result {
            Err(_) => panic!("round {round}: load panicked"),
            Ok(Err(_)) => failed += 1,
            Ok(Ok(scene)) => {
                loaded += 1;
                let n = scene.positions.len() as u32;
                assert!(
                    scene.triangles.iter().flatten().all(|&i| i < n),
                    "round {round}"
                );
            }
        }
        buf[at..at + 4].copy_from_slice(&orig[at..at + 4]);
    }
    eprintln!("patch fuzz: {loaded} loaded, {failed} rejected");
    assert!(loaded > 0 && failed > 0);
}

#[test]
fn q3_czest3ctf_load_time_is_reported() {
    // Timings are reported, never asserted (DESIGN.md).
    let bytes = map_bytes("czest3ctf");
    for n in [0, 4] {
        let options = LoadOptions {
            patch_subdivisions: n,
            ..LoadOptions::default()
        };
        let start = std::time::Instant::now();
        let scene = q3::load(&map_path("czest3ctf"), &bytes, &options).expect("loads");
        eprintln!(
            "czest3ctf, patch_subdivisions {n}: {} triangles, {} objects in {:?}",
            scene.triangle_count(),
            scene.objects.len(),
            start.elapsed()
        );
    }
}
