//! The scene the C API tests bake: two sides of a wall, a few named boxes on each, four view
//! cells (two sharing a face, one rotated), baked in-process to a temporary `.pvs`.

// Fixture helpers panic on a broken fixture: that is the failure report we want.
#![allow(clippy::unwrap_used, dead_code)]

use std::path::PathBuf;

use glam::Vec3;
use sightline_core::scene::SceneBuilder;
use sightline_core::trace::Bvh;
use sightline_core::Scene;
use sightline_region::{Budget, PvsFile, RandomSampler, ViewCell};

/// Object names, in id order: non-ASCII UTF-8, a NUL byte, spaces and a quote included, to
/// check that names reach C unchanged.
pub const NAMES: [&str; 7] = [
    "Root/Wall",
    "Root/Left/Crate.001",
    "Root/Left/Tür mit \"Glas\"",
    "Root/Left/nul\0name",
    "Root/Right/Röhre",
    "Root/Right/Shell",
    "Root/Right/Shell/Hidden",
];

/// Id of the box closed inside `Root/Right/Shell`: visible from no cell.
pub const HIDDEN: u32 = 6;
/// Ids of the objects left of the wall (x < 0): never visible from the cells right of it.
pub const LEFT: [u32; 3] = [1, 2, 3];
/// Ids of the objects right of the wall.
pub const RIGHT: [u32; 3] = [4, 5, 6];

pub fn scene() -> Scene {
    let boxes: [(Vec3, Vec3); 7] = [
        // A thick wall at x = 0 splits the world: nothing on one side sees the other.
        (Vec3::new(-0.5, -60.0, -60.0), Vec3::new(0.5, 60.0, 60.0)),
        (Vec3::new(-8.0, -20.0, 0.0), Vec3::new(-5.0, -17.0, 3.0)),
        (Vec3::new(-20.0, -2.0, 0.0), Vec3::new(-17.0, 2.0, 4.0)),
        (Vec3::new(-8.0, 17.0, 0.0), Vec3::new(-5.0, 20.0, 3.0)),
        (Vec3::new(15.0, -2.0, 0.0), Vec3::new(18.0, 2.0, 4.0)),
        (Vec3::new(20.0, 10.0, 0.0), Vec3::new(26.0, 16.0, 6.0)),
        (Vec3::new(22.0, 12.0, 2.0), Vec3::new(24.0, 14.0, 4.0)),
    ];
    let mut b = SceneBuilder::new("capi-test");
    for (name, (lo, hi)) in NAMES.iter().zip(boxes) {
        b.begin_object(*name);
        b.add_box(lo, hi);
    }
    b.finish()
}

/// Cells 0 and 1 left of the wall, sharing the face y = 0; cell 2 right of it; cell 3 right
/// of it too, turned 45 degrees about z.
pub fn cells() -> Vec<ViewCell> {
    let mut cells = ViewCell::grid(
        Vec3::new(-10.0, -8.0, 0.5),
        Vec3::new(-2.0, 8.0, 2.5),
        [1, 2, 1],
    )
    .unwrap();
    cells.push(ViewCell::aabb(Vec3::new(2.0, -4.0, 0.5), Vec3::new(10.0, 4.0, 2.5)).unwrap());
    let (s, c) = std::f32::consts::FRAC_PI_4.sin_cos();
    cells.push(
        ViewCell::oriented(
            Vec3::new(6.0, 12.0, 1.5),
            [Vec3::new(c, s, 0.0), Vec3::new(-s, c, 0.0), Vec3::Z],
            Vec3::new(2.0, 1.0, 1.0),
        )
        .unwrap(),
    );
    cells
}

/// Positions to look up, as text (what the C program gets): inside each cell, on the shared
/// face, on a cell's outer face, inside the rotated cell's bounding box but outside the cell,
/// outside everything, NaN and infinity.
pub const POSITIONS: [[&str; 3]; 11] = [
    ["-6", "-4", "1.5"],
    ["-6", "4", "1.5"],
    ["-6", "0", "1.5"],
    ["6", "0", "1.5"],
    ["2", "0", "1.5"],
    ["6", "12", "1.5"],
    ["7", "12.9", "2"],
    ["7.5", "13.5", "1.5"],
    ["0", "0", "100"],
    ["nan", "0", "1"],
    ["inf", "0", "0"],
];

pub fn position(text: &[&str; 3]) -> [f32; 3] {
    text.map(|t| t.parse::<f32>().unwrap())
}

/// The baked file, in a temporary directory that lives as long as this value.
pub struct Baked {
    pub dir: tempfile::TempDir,
    pub path: PathBuf,
    pub bytes: Vec<u8>,
    pub file: PvsFile,
}

/// Bakes [`scene`] from [`cells`] with RAND (fixed seed and ray budget) and saves it; written
/// as version 2 (with objects) by a writer that has them, else as version 1.
pub fn bake() -> Baked {
    let scene = scene();
    let cells = cells();
    let bvh = Bvh::build(&scene);
    let file = sightline_region::bake::bake_plain(
        &scene,
        &bvh,
        &cells,
        &RandomSampler,
        &Budget::rays(20_000),
        1,
    );
    save(file, "scene.pvs")
}

/// Writes `file` to a fresh temporary directory.
pub fn save(file: PvsFile, name: &str) -> Baked {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    file.save(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    Baked {
        dir,
        path,
        bytes,
        file,
    }
}

/// The same bake written as version 1 (no object table).
pub fn bake_v1() -> Baked {
    let mut file = bake().file;
    file.objects = None;
    save(file, "scene-v1.pvs")
}
