//! Integration tests of the mesh loaders and writers (OBJ, PLY, STL, glTF):
//! - `shared_*`: every shared scene of `../shared/scenes` loads with the triangle count and
//!   bounding box of its `SOURCES.md` (override the folder with `SIGHTLINE_SHARED_SCENES`);
//! - `empty_*`: empty input per format, through `scene::open`;
//! - `round_trip_*`: writers then loaders keep triangle corners (and object names) in id order;
//! - `fuzz_*`: seeded mutations of small valid files never panic a loader, and no loaded scene
//!   has an out-of-range index;
//! - `header_fuzz_*`: every header count set to 0, 1, huge, `u32::MAX`, negative...,
//!   keywords swapped, cuts at every header line: each case loads with the triangles its
//!   header declares (or a load warning saying why not) or fails naming the file.

// Tests may unwrap (STYLE: no unwrap on input data in library code); helpers here are not
// `#[test]` functions, so clippy's `allow-unwrap-in-tests` does not cover them.
#![allow(clippy::unwrap_used)]

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use glam::Vec3;
use sightline_core::scene::{self, open, LoadError, LoadOptions, Scene, SceneBuilder};

// ---------------------------------------------------------------------------------------------
// Shared scenes

fn shared_scenes() -> PathBuf {
    match std::env::var_os("SIGHTLINE_SHARED_SCENES") {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes"),
    }
}

fn open_shared(relative: &str) -> Scene {
    let path = shared_scenes().join(relative);
    assert!(
        path.exists(),
        "{} is missing (set SIGHTLINE_SHARED_SCENES to the shared scenes folder)",
        path.display()
    );
    open(&path.to_string_lossy(), &LoadOptions::default()).unwrap()
}

/// Checks `value` against a bounding-box figure of SOURCES.md, printed with 3 to 4
/// significant digits: the relative tolerance is half a unit in the 3rd digit, and figures
/// near zero (like -0.003149 on a 10-unit model) get an absolute slack of 1e-4 of the extent.
fn assert_close(value: f32, expected: f32, extent: f32, what: &str) {
    let tolerance = (5e-3 * expected.abs()).max(1e-4 * extent);
    assert!(
        (value - expected).abs() <= tolerance,
        "{what}: {value} is not {expected} to 3 significant digits"
    );
}

fn check_shared(relative: &str, triangles: usize, min: [f32; 3], max: [f32; 3]) -> Scene {
    let s = open_shared(relative);
    assert_eq!(s.triangle_count(), triangles, "{relative}: triangle count");
    assert_eq!(s.object_of_triangle.len(), triangles);
    assert!(s
        .triangles
        .iter()
        .flatten()
        .all(|&i| (i as usize) < s.positions.len()));
    let b = s.bounds();
    let extent = (Vec3::from(max) - Vec3::from(min)).max_element();
    for axis in 0..3 {
        assert_close(
            b.min[axis],
            min[axis],
            extent,
            &format!("{relative} min[{axis}]"),
        );
        assert_close(
            b.max[axis],
            max[axis],
            extent,
            &format!("{relative} max[{axis}]"),
        );
    }
    s
}

#[test]
fn shared_bunny_obj() {
    let s = check_shared(
        "models/bunny.obj",
        3674,
        [-4.958, -0.003149, -3.73],
        [4.949, 9.655, 3.811],
    );
    assert_eq!(s.positions.len(), 1839);
    assert_eq!(s.objects.len(), 1);
}

#[test]
fn shared_stanford_bunny_obj_gz() {
    check_shared(
        "models/stanford_bunny.obj.gz",
        69451,
        [-0.09469, 0.03299, -0.06187],
        [0.06101, 0.1873, 0.0588],
    );
}

#[test]
fn shared_teapot_obj() {
    check_shared(
        "models/teapot.obj",
        992,
        [-16.07, -7.875, -10.0],
        [16.07, 7.875, 10.0],
    );
}

#[test]
fn shared_dragon_ply_gz() {
    let s = check_shared(
        "models/dragon_res3.ply.gz",
        47794,
        [-0.1077, 0.05277, -0.05005],
        [0.09598, 0.1966, 0.04083],
    );
    assert_eq!(s.positions.len(), 22998);
    assert_eq!(s.objects[0].name, "dragon_res3");
}

#[test]
fn shared_munich_ply_gz() {
    check_shared(
        "city/munich.ply.gz",
        38936,
        [-805.58, -688.60, 0.0],
        [669.88, 517.04, 98.57],
    );
}

#[test]
fn shared_etoile_ply_gz() {
    check_shared(
        "city/etoile.ply.gz",
        13098,
        [-426.83, -338.06, 0.0],
        [426.83, 338.06, 50.0],
    );
}

#[test]
fn shared_fzk_haus_obj_gz_objects_from_usemtl() {
    let s = check_shared(
        "buildings/fzk_haus.obj.gz",
        35906,
        [-3.0, -1.0, -13.0],
        [15.0, 6.318, 3.0],
    );
    // One object per `usemtl` run that has faces (the file has 177 `usemtl` lines and no
    // `o`/`g`), named after the material.
    assert_eq!(s.objects.len(), 177);
    let by_object = s.triangles_by_object();
    let glass: usize = s
        .objects
        .iter()
        .zip(&by_object)
        .filter(|(o, _)| o.name == "Glas")
        .map(|(_, t)| t.len())
        .sum();
    assert_eq!(
        glass, 820,
        "SOURCES.md: 820 triangles in `usemtl Glas` groups"
    );
}

// ---------------------------------------------------------------------------------------------
// Empty input through `open`

fn open_bytes(name: &str, bytes: &[u8]) -> Result<Scene, LoadError> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    open(&path.to_string_lossy(), &LoadOptions::default())
}

#[test]
fn empty_obj_is_empty_scene() {
    assert!(open_bytes("empty.obj", b"").unwrap().is_empty());
}

#[test]
fn empty_ply_is_error_with_location() {
    let e = open_bytes("empty.ply", b"").unwrap_err();
    assert!(matches!(e, LoadError::Parse { .. }), "{e}");
}

#[test]
fn empty_stl_is_error_with_location() {
    let e = open_bytes("empty.stl", b"").unwrap_err();
    assert!(matches!(e, LoadError::Parse { .. }), "{e}");
}

#[test]
fn empty_glb_is_error_with_location() {
    let e = open_bytes("empty.glb", b"").unwrap_err();
    assert!(matches!(e, LoadError::Parse { .. }), "{e}");
}

#[test]
fn garbage_ply_stl_glb_are_errors_with_location() {
    let garbage: Vec<u8> = (0..300u32).map(|i| (i * 7919 % 251) as u8).collect();
    for name in ["g.ply", "g.stl", "g.glb"] {
        let e = open_bytes(name, &garbage).unwrap_err();
        assert!(matches!(e, LoadError::Parse { .. }), "{name}: {e}");
    }
}

// ---------------------------------------------------------------------------------------------
// Round trips

fn assert_same_corners(a: &Scene, b: &Scene, with_objects: bool) {
    assert_eq!(a.triangle_count(), b.triangle_count());
    for id in 0..a.triangle_count() as u32 {
        assert_eq!(a.triangle(id), b.triangle(id), "triangle {id}");
        if with_objects {
            let name = |s: &Scene| {
                s.objects[s.object_of_triangle[id as usize] as usize]
                    .name
                    .clone()
            };
            assert_eq!(name(a), name(b), "object of triangle {id}");
        }
    }
}

/// fzk_haus has 177 objects whose materials repeat, a good test for object runs.
fn fzk_haus() -> Scene {
    open_shared("buildings/fzk_haus.obj.gz")
}

#[test]
fn round_trip_obj_fzk_haus() {
    let s = fzk_haus();
    let mut out = Vec::new();
    scene::obj::write(&s, &mut out).unwrap();
    let back = scene::obj::load(Path::new("back.obj"), &out).unwrap();
    assert_same_corners(&s, &back, true);
    // 177 objects with 11 names: the writer's tags keep them apart.
    assert_eq!(back.objects, s.objects);
    assert_eq!(back.object_of_triangle, s.object_of_triangle);
}

#[test]
fn round_trip_ply_fzk_haus() {
    let s = fzk_haus();
    let mut out = Vec::new();
    scene::ply::write(&s, &mut out).unwrap();
    let back = scene::ply::load(Path::new("back.ply"), &out).unwrap();
    assert_same_corners(&s, &back, false);
}

#[test]
fn round_trip_glb_fzk_haus() {
    let s = fzk_haus();
    let mut out = Vec::new();
    scene::gltf::write_glb(&s, &mut out).unwrap();
    let back = scene::gltf::load(Path::new("back.glb"), &out).unwrap();
    assert_same_corners(&s, &back, true);
    assert_eq!(back.objects, s.objects);
    assert_eq!(back.object_of_triangle, s.object_of_triangle);
    // The gltf crate itself (with its own buffer import) reads our file.
    let (doc, buffers, _) = gltf::import_slice(&out).unwrap();
    assert_eq!(doc.meshes().len(), s.objects.len());
    assert_eq!(buffers.len(), 1);
}

// ---------------------------------------------------------------------------------------------
// Fuzzing

/// Mutations per fixture; `SIGHTLINE_FUZZ_ITERATIONS` overrides it for longer local runs.
const ITERATIONS: usize = 5000;

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

/// Replacement texts for numbers in text formats.
const NUMBER_TEXTS: &[&str] = &[
    "99999999999999999999",
    "-1",
    "-2147483649",
    "4294967295",
    "4294967296",
    "NaN",
    "inf",
    "-inf",
    "1e39",
    "0",
    "3",
    "255",
    "-0",
    "0.5",
];

/// Replacement words for 4-byte fields of binary formats.
const NUMBER_WORDS: &[u32] = &[
    0,
    1,
    3,
    255,
    0xFFFF_FFFF,
    0x7FFF_FFFF,
    0x8000_0000,
    0x7FC0_0000, // NaN
    0x7F80_0000, // +inf
    0x7149_F2CA, // 1e30
];

fn mutate(rng: &mut Fuzz, original: &[u8]) -> Vec<u8> {
    let mut b = original.to_vec();
    for _ in 0..1 + rng.below(3) {
        if b.is_empty() {
            b.push(rng.next() as u8);
            continue;
        }
        let at = rng.below(b.len());
        match rng.below(7) {
            0 => b[at] ^= 1 << rng.below(8),
            1 => b.insert(at, rng.next() as u8),
            2 => {
                b.remove(at);
            }
            3 => b.truncate(at),
            4 => {
                // Replace the decimal number (if any) that starts at or after `at`.
                if let Some(start) = (at..b.len()).find(|&i| b[i].is_ascii_digit()) {
                    let end = (start..b.len())
                        .find(|&i| !(b[i].is_ascii_digit() || b[i] == b'.'))
                        .unwrap_or(b.len());
                    let text = NUMBER_TEXTS[rng.below(NUMBER_TEXTS.len())];
                    b.splice(start..end, text.bytes());
                }
            }
            5 => {
                let word = NUMBER_WORDS[rng.below(NUMBER_WORDS.len())].to_le_bytes();
                let at = at & !3;
                for (k, byte) in word.iter().enumerate() {
                    if let Some(slot) = b.get_mut(at + k) {
                        *slot = *byte;
                    }
                }
            }
            _ => {
                // Duplicate a chunk: repeated lines/records.
                let len = rng.below(16).min(b.len() - at);
                let chunk = b[at..at + len].to_vec();
                let to = rng.below(b.len());
                b.splice(to..to, chunk);
            }
        }
    }
    b
}

type Loader = fn(&Path, &[u8]) -> Result<Scene, LoadError>;

fn check_loaded(scene: &Scene, what: &str) {
    let n = scene.positions.len();
    for (id, t) in scene.triangles.iter().enumerate() {
        assert!(
            t.iter().all(|&i| (i as usize) < n),
            "{what}: triangle {id} {t:?} has an index out of range ({n} positions)"
        );
    }
    assert_eq!(
        scene.object_of_triangle.len(),
        scene.triangles.len(),
        "{what}"
    );
    assert!(
        scene
            .object_of_triangle
            .iter()
            .all(|&o| (o as usize) < scene.objects.len()),
        "{what}: bad object id"
    );
}

fn fuzz(name: &str, original: &[u8], load: Loader, seed: u64) {
    let iterations = std::env::var("SIGHTLINE_FUZZ_ITERATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(ITERATIONS);
    let path = PathBuf::from(name);
    let (mut loaded, mut failed) = (0usize, 0usize);
    let mut run = |bytes: &[u8], what: &str| {
        let result = catch_unwind(AssertUnwindSafe(|| load(&path, bytes)));
        match result {
            Ok(Ok(scene)) => {
                check_loaded(&scene, what);
                loaded += 1;
            }
            Ok(Err(_)) => failed += 1,
            Err(_) => panic!("{name}: loader panicked on {what}: {bytes:?}"),
        }
    };
    // The original must load, else the fuzzing tests nothing.
    let scene = load(&path, original).unwrap();
    assert!(!scene.is_empty(), "{name}: fixture has no triangles");
    // Small files: every truncation.
    if original.len() <= 4096 {
        for len in 0..original.len() {
            run(&original[..len], &format!("truncation at {len}"));
        }
    }
    let mut rng = Fuzz::new(seed);
    for i in 0..iterations {
        let bytes = mutate(&mut rng, original);
        run(&bytes, &format!("mutation {i}"));
    }
    // Both outcomes must occur, else the mutations do not reach the loader's inner paths.
    assert!(
        loaded > 0 && failed > 0,
        "{name}: {loaded} loaded, {failed} failed"
    );
}

/// A small mesh with two objects, a shared edge and a non-contiguous object.
fn fixture_scene() -> Scene {
    let mut b = SceneBuilder::new("fixture");
    let a = b.begin_object("first");
    for i in 0..6 {
        b.add_vertex(Vec3::new(i as f32, (i * i) as f32 * 0.5, 1.0 - i as f32));
    }
    b.add_triangle([0, 1, 2]);
    b.add_triangle([2, 1, 3]);
    b.begin_object("second");
    b.add_triangle([3, 4, 5]);
    let mut s = b.finish();
    s.triangles.push([5, 0, 2]);
    s.object_of_triangle.push(a);
    s
}

#[test]
fn fuzz_obj() {
    let text = "# fixture\nmtllib none.mtl\no first\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                vt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1 4/1/1\ng second\nusemtl stone\n\
                v 2 2 2\nf -1 -2 -3\nf 5//1 1//1 2//1\n";
    fuzz("f.obj", text.as_bytes(), scene::obj::load, 1);
}

#[test]
fn fuzz_obj_written() {
    let mut out = Vec::new();
    scene::obj::write(&fixture_scene(), &mut out).unwrap();
    fuzz("w.obj", &out, scene::obj::load, 2);
}

#[test]
fn fuzz_ply_binary() {
    let mut out = Vec::new();
    scene::ply::write(&fixture_scene(), &mut out).unwrap();
    fuzz("f.ply", &out, scene::ply::load, 3);
}

#[test]
fn fuzz_ply_binary_general_layout() {
    // Big-endian, double coordinates, extra properties and an extra list element: the
    // general (non fast-path) binary reader.
    let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\n\
        property uchar q\nproperty double y\nproperty double z\nelement face 2\n\
        property list uint ushort vertex_indices\nproperty float w\nelement extra 1\n\
        property list uchar int stuff\nend_header\n"
        .to_vec();
    for v in 0..4u8 {
        for (k, c) in [f64::from(v), f64::from(v * v), -1.5]
            .into_iter()
            .enumerate()
        {
            b.extend_from_slice(&c.to_be_bytes());
            if k == 0 {
                b.push(v);
            }
        }
    }
    for face in [[0u16, 1, 2, 3].as_slice(), [3, 2, 1].as_slice()] {
        b.extend_from_slice(&(face.len() as u32).to_be_bytes());
        for i in face {
            b.extend_from_slice(&i.to_be_bytes());
        }
        b.extend_from_slice(&1.0f32.to_be_bytes());
    }
    b.extend_from_slice(&[2, 0, 0, 0, 1, 0, 0, 0, 2]);
    fuzz("g.ply", &b, scene::ply::load, 4);
}

#[test]
fn fuzz_ply_ascii() {
    let text = "ply\nformat ascii 1.0\ncomment fixture\nelement vertex 5\nproperty float x\n\
                property float y\nproperty float z\nproperty uchar red\nelement face 3\n\
                property list uchar int vertex_indices\nend_header\n\
                0 0 0 255\n1 0 0 0\n1 1 0 3\n0 1 0 9\n2 2 2 1\n4 0 1 2 3\n3 4 3 2\n3 0 4 1\n";
    fuzz("a.ply", text.as_bytes(), scene::ply::load, 5);
}

#[test]
fn fuzz_stl_ascii() {
    let text = "solid one\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
                vertex 0 1 0\nendloop\nendfacet\nendsolid one\nsolid two\n\
                facet normal 0 0 1\nouter loop\nvertex 0 0 1\nvertex 1 0 1\nvertex 0 1 1\n\
                endloop\nendfacet\nendsolid two\n";
    fuzz("a.stl", text.as_bytes(), scene::stl::load, 6);
}

#[test]
fn fuzz_stl_binary() {
    let mut b = b"solid but binary".to_vec();
    b.resize(80, 0);
    b.extend_from_slice(&3u32.to_le_bytes());
    for t in 0..3 {
        for c in 0..12 {
            b.extend_from_slice(&((t * 12 + c) as f32 * 0.25).to_le_bytes());
        }
        b.extend_from_slice(&[0, 0]);
    }
    fuzz("b.stl", &b, scene::stl::load, 7);
}

#[test]
fn fuzz_glb_written() {
    let mut out = Vec::new();
    scene::gltf::write_glb(&fixture_scene(), &mut out).unwrap();
    fuzz("f.glb", &out, scene::gltf::load, 8);
}

#[test]
fn fuzz_gltf_text() {
    // Positions (4 x VEC3 f32 = 48 bytes) then u16 indices of a strip and of a fan
    // (4 + 4 = 16 bytes), in a base64 data URI; two nodes in a hierarchy.
    let mut bin = Vec::new();
    for v in [
        0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0,
    ] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2, 3, 0, 1, 3, 2] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64_encode(&bin)
    );
    let text = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"name":"a","mesh":0,"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,5,6,7,1],"children":[1]}},
{{"mesh":1,"rotation":[0,0.7071068,0,0.7071068],"scale":[2,2,2]}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":5}}]}},
{{"name":"m","primitives":[{{"attributes":{{"POSITION":0}},"indices":2,"mode":6}},{{"attributes":{{"POSITION":0}},"mode":6}}]}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"byteOffset":0,"componentType":5123,"count":4,"type":"SCALAR"}},
{{"bufferView":1,"byteOffset":8,"componentType":5123,"count":4,"type":"SCALAR"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48,"byteStride":12}},{{"buffer":0,"byteOffset":48,"byteLength":16}}],
"buffers":[{{"byteLength":64,"uri":"{uri}"}}]}}"#
    );
    let s = scene::gltf::load(Path::new("t.gltf"), text.as_bytes()).unwrap();
    // 2 strip + 2 fan + 2 non-indexed fan.
    assert_eq!(s.triangle_count(), 6);
    assert_eq!(s.triangle(0)[1], Vec3::new(6.0, 6.0, 7.0));
    fuzz("t.gltf", text.as_bytes(), scene::gltf::load, 9);
}

/// Standard base64 with padding (enough for the fixture; avoids a dev-dependency).
fn base64_encode(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Header fuzzing: every count of a header set to 0, 1, huge, u32::MAX, past u32 and u64,
// negative or not an integer; pairs of header keywords swapped; the file cut at every line
// (and, in binary headers, every byte). Each case must load with the triangles its (mutated)
// header declares, or fail with an error naming the file; never panic.

/// What a header count is replaced with.
const COUNT_TEXTS: &[&str] = &[
    "0",
    "1",
    "2",
    "7",
    "65536",
    "99999999999",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "-1",
    "-4294967295",
    "3.5",
    "",
];

/// What a binary 4-byte count is replaced with.
const COUNT_WORDS: &[u32] = &[0, 1, 2, 4, 0xFFFF, 0x7FFF_FFFF, 0x8000_0000, 0xFFFF_FFFF];

/// Checks a scene that loaded from `bytes` against the counts `bytes` declare.
type Consistent = fn(&[u8], &Scene) -> Result<(), String>;

/// The header of a fixture to mutate: its bytes, where counts and keywords may be mutated
/// (`bytes[..header_len]`), its keywords, and the offsets of binary `u32` counts.
struct Header<'a> {
    name: &'a str,
    bytes: Vec<u8>,
    header_len: usize,
    keywords: &'a [&'a str],
    words: &'a [usize],
}

/// The byte ranges of the decimal numbers in `text` (digits, optionally signed; `1e3` and
/// `0.5` count as one number each).
fn number_ranges(text: &[u8]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let starts = text[i].is_ascii_digit()
            && (i == 0 || !(text[i - 1].is_ascii_alphanumeric() || text[i - 1] == b'_'));
        if !starts {
            i += 1;
            continue;
        }
        let start = if i > 0 && text[i - 1] == b'-' {
            i - 1
        } else {
            i
        };
        let mut end = i;
        while end < text.len() && (text[end].is_ascii_digit() || b".eE".contains(&text[end])) {
            end += 1;
        }
        out.push(start..end);
        i = end;
    }
    out
}

/// The byte ranges of whole-word occurrences of `keywords` in `text`.
fn keyword_ranges(text: &[u8], keywords: &[&str]) -> Vec<std::ops::Range<usize>> {
    let word = |b: u8| b.is_ascii_alphanumeric() || b == b'_';
    let mut out = Vec::new();
    for k in keywords {
        let k = k.as_bytes();
        for at in 0..text.len().saturating_sub(k.len() - 1) {
            let before = at == 0 || !word(text[at - 1]);
            let after = text.get(at + k.len()).is_none_or(|&b| !word(b));
            if before && after && &text[at..at + k.len()] == k {
                out.push(at..at + k.len());
            }
        }
    }
    out.sort_by_key(|r| r.start);
    out
}

/// Every header mutation of `h` (see the section comment).
fn header_cases(h: &Header) -> Vec<(String, Vec<u8>)> {
    let (b, header) = (&h.bytes, &h.bytes[..h.header_len]);
    let mut cases = Vec::new();
    for r in number_ranges(header) {
        for text in COUNT_TEXTS {
            let mut m = b.clone();
            m.splice(r.clone(), text.bytes());
            cases.push((format!("number at {} = '{text}'", r.start), m));
        }
    }
    let keywords = keyword_ranges(header, h.keywords);
    for (i, x) in keywords.iter().enumerate() {
        for y in &keywords[i + 1..] {
            if b[x.clone()] == b[y.clone()] {
                continue;
            }
            let mut m = b[..x.start].to_vec();
            m.extend_from_slice(&b[y.clone()]);
            m.extend_from_slice(&b[x.end..y.start]);
            m.extend_from_slice(&b[x.clone()]);
            m.extend_from_slice(&b[y.end..]);
            cases.push((
                format!("keywords at {} and {} swapped", x.start, y.start),
                m,
            ));
        }
    }
    for &at in h.words {
        for w in COUNT_WORDS {
            let mut m = b.clone();
            if let Some(slot) = m.get_mut(at..at + 4) {
                slot.copy_from_slice(&w.to_le_bytes());
                cases.push((format!("u32 at {at} = {w}"), m));
            }
        }
    }
    // Every line end of the header, and every byte of a binary header.
    for cut in 0..=h.header_len.min(b.len()) {
        let at_line = cut > 0 && b[cut - 1] == b'\n';
        if at_line || !h.words.is_empty() || cut == h.header_len {
            cases.push((format!("cut at {cut}"), b[..cut].to_vec()));
        }
    }
    cases
}

/// Runs every header case of `h` through `load`: no panic, an `Ok` scene passes
/// [`check_loaded`] and `consistent`, an error names the file. Some cases must load and some
/// must fail, else the mutations miss the loader.
fn header_fuzz(h: &Header, load: Loader, consistent: Consistent) {
    let path = PathBuf::from(h.name);
    let original = load(&path, &h.bytes).unwrap();
    consistent(&h.bytes, &original).unwrap();
    let (mut loaded, mut failed) = (0usize, 0usize);
    for (what, bytes) in header_cases(h) {
        match catch_unwind(AssertUnwindSafe(|| load(&path, &bytes))) {
            Err(_) => panic!("{}: loader panicked on {what}", h.name),
            Ok(Ok(scene)) => {
                check_loaded(&scene, &what);
                if let Err(e) = consistent(&bytes, &scene) {
                    panic!(
                        "{}: {what} loaded inconsistently: {e}\n{}",
                        h.name,
                        String::from_utf8_lossy(&bytes)
                    );
                }
                loaded += 1;
            }
            Ok(Err(e)) => {
                assert!(e.to_string().contains(h.name), "{what}: {e}");
                failed += 1;
            }
        }
    }
    assert!(
        loaded > 0 && failed > 0,
        "{}: {loaded} loaded, {failed} failed",
        h.name
    );
}

/// An empty result must say why (item: no silently empty scene).
fn empty_is_explained(scene: &Scene) -> Result<(), String> {
    if scene.is_empty() && scene.load_warnings.is_empty() {
        return Err("no triangles and no load warning".into());
    }
    Ok(())
}

/// The count of `element NAME N` in a PLY header, if declared.
fn ply_count(bytes: &[u8], element: &str) -> Option<u64> {
    let text = String::from_utf8_lossy(bytes);
    let header = text.split("end_header").next()?;
    header.lines().find_map(|l| {
        let w: Vec<&str> = l.split_whitespace().collect();
        (w.len() >= 3 && w[0] == "element" && w[1] == element)
            .then(|| w[2].parse().ok())
            .flatten()
    })
}

fn ply_consistent(bytes: &[u8], scene: &Scene) -> Result<(), String> {
    empty_is_explained(scene)?;
    let vertices = ply_count(bytes, "vertex").unwrap_or(0);
    if scene.positions.len() as u64 != vertices {
        return Err(format!(
            "{} positions, {vertices} declared",
            scene.positions.len()
        ));
    }
    let faces = ply_count(bytes, "face").unwrap_or(0);
    // Short faces, or a face element without its index list, are warned about.
    let short = scene
        .load_warnings
        .iter()
        .any(|w| w.contains("fewer than 3") || w.contains("'vertex_indices' list"));
    if (scene.triangle_count() as u64) < faces && !short {
        return Err(format!(
            "{} triangles from {faces} faces, no warning",
            scene.triangle_count()
        ));
    }
    Ok(())
}

fn stl_consistent(bytes: &[u8], scene: &Scene) -> Result<(), String> {
    empty_is_explained(scene)?;
    let n = scene.triangle_count() as u64;
    let binary = bytes
        .get(80..84)
        .map(|b| u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])));
    let fits = binary.is_some_and(|d| d == n && 84 + 50 * d <= bytes.len() as u64);
    let ascii = keyword_ranges(bytes, &["endloop"]).len() as u64;
    if fits || ascii == n {
        return Ok(());
    }
    Err(format!(
        "{n} triangles: binary count {binary:?}, {ascii} ASCII loops"
    ))
}

/// Vertices and fan triangles of `v` and `f` lines, counted independently of the loader.
fn obj_counts(bytes: &[u8]) -> (usize, usize) {
    let text = String::from_utf8_lossy(bytes)
        .replace("\r\n", "\n")
        .replace('\r', "\n");
    let (mut v, mut t) = (0, 0);
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => v += 1,
            Some("f") => t += words.count().saturating_sub(2),
            _ => {}
        }
    }
    (v, t)
}

fn obj_consistent(bytes: &[u8], scene: &Scene) -> Result<(), String> {
    empty_is_explained(scene)?;
    let (v, t) = obj_counts(bytes);
    if (scene.positions.len(), scene.triangle_count()) != (v, t) {
        return Err(format!(
            "{} positions and {} triangles, the file has {v} and {t}",
            scene.positions.len(),
            scene.triangle_count()
        ));
    }
    Ok(())
}

/// Triangles the glTF JSON declares: over the nodes reachable from the scene (the default
/// one, else scene 0), each triangle-mode primitive of their meshes (indices count, else
/// POSITION count; `n / 3` for triangles, `n - 2` for strips and fans).
fn gltf_declared_triangles(json: &serde_json::Value) -> Option<u64> {
    let scene_index = json.get("scene").and_then(|s| s.as_u64()).unwrap_or(0) as usize;
    let roots = json["scenes"][scene_index]["nodes"].as_array()?;
    let mut stack: Vec<u64> = roots.iter().filter_map(|n| n.as_u64()).collect();
    let mut total = 0u64;
    while let Some(n) = stack.pop() {
        let node = &json["nodes"][n as usize];
        if let Some(children) = node["children"].as_array() {
            stack.extend(children.iter().filter_map(|c| c.as_u64()));
        }
        let Some(mesh) = node["mesh"].as_u64() else {
            continue;
        };
        for p in json["meshes"][mesh as usize]["primitives"].as_array()? {
            let mode = p.get("mode").map_or(Some(4), |m| m.as_u64())?;
            let accessor = p.get("indices").or(p["attributes"].get("POSITION"))?;
            let count = json["accessors"][accessor.as_u64()? as usize]["count"].as_u64()?;
            total += match mode {
                4 => count / 3,
                5 | 6 => count.saturating_sub(2),
                _ => 0,
            };
        }
    }
    Some(total)
}

fn gltf_json_consistent(json: &[u8], scene: &Scene) -> Result<(), String> {
    empty_is_explained(scene)?;
    let value: serde_json::Value = serde_json::from_slice(json).map_err(|e| e.to_string())?;
    let declared = gltf_declared_triangles(&value);
    if declared != Some(scene.triangle_count() as u64) {
        return Err(format!(
            "{} triangles, declared {declared:?}",
            scene.triangle_count()
        ));
    }
    Ok(())
}

fn gltf_consistent(bytes: &[u8], scene: &Scene) -> Result<(), String> {
    gltf_json_consistent(bytes, scene)
}

fn glb_consistent(bytes: &[u8], scene: &Scene) -> Result<(), String> {
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    gltf_json_consistent(&bytes[20..20 + len], scene)
}

/// A GLB file of `json` (padded with spaces) and `bin`, with consistent lengths.
fn glb_of(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let mut json = json.to_vec();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut out = b"glTF".to_vec();
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out
}

const PLY_KEYWORDS: &[&str] = &[
    "ply",
    "format",
    "ascii",
    "binary_little_endian",
    "binary_big_endian",
    "element",
    "vertex",
    "face",
    "property",
    "list",
    "float",
    "uchar",
    "int",
    "x",
    "y",
    "z",
    "vertex_indices",
    "end_header",
];

const PLY_ASCII: &str = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\n\
    property float y\nproperty float z\nelement face 3\nproperty list uchar int vertex_indices\n\
    end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 2\n4 0 1 2 3\n3 4 3 2\n3 0 4 1\n";

#[test]
fn header_fuzz_ply_ascii() {
    let bytes = PLY_ASCII.as_bytes().to_vec();
    let header_len = PLY_ASCII.find("end_header").unwrap() + 11;
    let h = Header {
        name: "h.ply",
        bytes,
        header_len,
        keywords: PLY_KEYWORDS,
        words: &[],
    };
    header_fuzz(&h, scene::ply::load, ply_consistent);
}

#[test]
fn header_fuzz_ply_binary() {
    let mut bytes = Vec::new();
    scene::ply::write(&fixture_scene(), &mut bytes).unwrap();
    let header_len = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let h = Header {
        name: "h.ply",
        bytes,
        header_len,
        keywords: PLY_KEYWORDS,
        words: &[],
    };
    header_fuzz(&h, scene::ply::load, ply_consistent);
}

const STL_ASCII: &str = "solid one\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n\
    vertex 0 1 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 1\n\
    vertex 1 0 1\nvertex 0 1 1\nendloop\nendfacet\nendsolid one\n";

const STL_KEYWORDS: &[&str] = &[
    "solid", "facet", "normal", "outer", "loop", "vertex", "endloop", "endfacet", "endsolid",
];

#[test]
fn header_fuzz_stl_ascii() {
    let h = Header {
        name: "h.stl",
        bytes: STL_ASCII.as_bytes().to_vec(),
        header_len: STL_ASCII.len(),
        keywords: STL_KEYWORDS,
        words: &[],
    };
    header_fuzz(&h, scene::stl::load, stl_consistent);
}

#[test]
fn header_fuzz_stl_binary() {
    let mut b = b"solid but binary 3 facets".to_vec();
    b.resize(80, b' ');
    b.extend_from_slice(&3u32.to_le_bytes());
    for t in 0..3 {
        for c in 0..12 {
            b.extend_from_slice(&((t * 12 + c) as f32 * 0.25).to_le_bytes());
        }
        b.extend_from_slice(&[0, 0]);
    }
    let h = Header {
        name: "h.stl",
        bytes: b,
        header_len: 84,
        keywords: STL_KEYWORDS,
        words: &[80],
    };
    header_fuzz(&h, scene::stl::load, stl_consistent);
}

#[test]
fn header_fuzz_obj() {
    let text = "# fixture\no first\nv 0 0 0\nv 1 0 0 1\nv 1 1 0 0.5 0.5 0.5\nv 0 1 0\n\
                vt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1 4/1/1\ng second\nusemtl stone\n\
                v 2 2 2\nf -1 -2 -3\nf 5//1 1//1 2//1\n";
    let h = Header {
        name: "h.obj",
        bytes: text.as_bytes().to_vec(),
        header_len: text.len(),
        keywords: &["v", "f", "o", "g", "usemtl", "vt", "vn"],
        words: &[],
    };
    header_fuzz(&h, scene::obj::load, obj_consistent);
}

const GLTF_KEYWORDS: &[&str] = &[
    "count",
    "byteLength",
    "byteOffset",
    "bufferView",
    "buffer",
    "POSITION",
    "indices",
    "mode",
    "nodes",
    "children",
    "mesh",
    "byteStride",
    "VEC3",
    "SCALAR",
    "componentType",
];

/// Positions (4 x VEC3 f32, 48 bytes) and u16 indices of a strip and a fan (16 bytes).
fn gltf_fixture_bin() -> Vec<u8> {
    let mut bin = Vec::new();
    for v in [
        0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0,
    ] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2, 3, 0, 1, 3, 2] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    bin
}

/// Two nodes in a hierarchy, a strip, a fan and a non-indexed fan, over buffer 0 = `buffer`.
fn gltf_fixture_json(buffer: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"name":"a","mesh":0,"children":[1]}},{{"mesh":1,"rotation":[0,0,10,0]}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":5}}]}},
{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":2,"mode":6}},{{"attributes":{{"POSITION":0}},"mode":6}}]}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"byteOffset":0,"componentType":5123,"count":4,"type":"SCALAR"}},
{{"bufferView":1,"byteOffset":8,"componentType":5123,"count":4,"type":"SCALAR"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48,"byteStride":12}},{{"buffer":0,"byteOffset":48,"byteLength":16}}],
"buffers":[{{"byteLength":64{buffer}}}]}}"#
    )
}

#[test]
fn header_fuzz_gltf() {
    let uri = format!(
        r#","uri":"data:application/octet-stream;base64,{}""#,
        base64_encode(&gltf_fixture_bin())
    );
    let text = gltf_fixture_json(&uri);
    // Mutate only the JSON before the data URI (its base64 has digits of its own).
    let header_len = text.find("data:").unwrap();
    let h = Header {
        name: "h.gltf",
        bytes: text.into_bytes(),
        header_len,
        keywords: GLTF_KEYWORDS,
        words: &[],
    };
    header_fuzz(&h, scene::gltf::load, gltf_consistent);
}

#[test]
fn header_fuzz_glb() {
    let bin = gltf_fixture_bin();
    let json = gltf_fixture_json("");
    // The container: lengths and chunk types of the GLB header and chunk headers.
    let glb = glb_of(json.as_bytes(), &bin);
    let bin_header = 20 + json.len().next_multiple_of(4);
    let h = Header {
        name: "h.glb",
        bytes: glb.clone(),
        header_len: bin_header + 8,
        keywords: &[],
        words: &[4, 8, 12, 16, bin_header, bin_header + 4],
    };
    header_fuzz(&h, scene::gltf::load, |bytes, scene| {
        let len = bytes
            .get(12..16)
            .map_or(0, |b| u32::from_le_bytes(b.try_into().unwrap()));
        match bytes.get(20..20 + len as usize) {
            Some(json) => gltf_json_consistent(json, scene),
            None => Err("loaded without a JSON chunk".into()),
        }
    });
    // The JSON inside, with the container rebuilt around each mutation.
    let cases = header_cases(&Header {
        name: "h.glb",
        bytes: json.clone().into_bytes(),
        header_len: json.len(),
        keywords: GLTF_KEYWORDS,
        words: &[],
    });
    let path = Path::new("h.glb");
    for (what, json) in cases {
        let bytes = glb_of(&json, &bin);
        match catch_unwind(AssertUnwindSafe(|| scene::gltf::load(path, &bytes))) {
            Err(_) => panic!("h.glb: loader panicked on JSON {what}"),
            Ok(Ok(scene)) => {
                check_loaded(&scene, &what);
                glb_consistent(&bytes, &scene).unwrap_or_else(|e| panic!("{what}: {e}"));
            }
            Ok(Err(e)) => assert!(e.to_string().contains("h.glb"), "{what}: {e}"),
        }
    }
}

/// A flat box (a city block: 400 x 300 m, 30 m high, Z up) as an OBJ file.
fn flat_block_obj(dir: &Path) -> PathBuf {
    let mut b = SceneBuilder::new("block");
    b.add_box(Vec3::ZERO, Vec3::new(400.0, 300.0, 30.0));
    let mut out = Vec::new();
    scene::obj::write(&b.finish(), &mut out).unwrap();
    let p = dir.join("block.obj");
    std::fs::write(&p, out).unwrap();
    p
}

/// OBJ, PLY and STL do not state an up axis: a flat scene is inferred up along its flat
/// axis (with a load warning saying so), a compact one keeps Y, and `up_axis` overrides both.
#[test]
fn mesh_files_get_an_inferred_up_axis_that_options_override() {
    let dir = tempfile::tempdir().unwrap();
    let block = flat_block_obj(dir.path());
    let s = scene::load_file(&block, &LoadOptions::default()).unwrap();
    assert_eq!(s.up, scene::UpAxis::Z);
    assert!(
        s.load_warnings
            .iter()
            .any(|w| w.contains("up axis Z inferred") && w.contains("--up-axis")),
        "{:?}",
        s.load_warnings
    );
    let forced = LoadOptions {
        up_axis: Some(scene::UpAxis::Y),
        ..LoadOptions::default()
    };
    let s = scene::load_file(&block, &forced).unwrap();
    assert_eq!(s.up, scene::UpAxis::Y);
    assert!(s.load_warnings.is_empty(), "{:?}", s.load_warnings);
    // The bunny is about as tall as it is wide: Y, the convention, and nothing to say.
    let bunny = open_shared("models/bunny.obj");
    assert_eq!(bunny.up, scene::UpAxis::Y);
    assert!(bunny.load_warnings.is_empty(), "{:?}", bunny.load_warnings);
    // The shared city meshes are Z-up PLY files: flat, so Z.
    assert_eq!(open_shared("city/etoile.ply.gz").up, scene::UpAxis::Z);
    // Procedural scenes keep their own axis unless overridden.
    assert_eq!(
        open("procedural:city?size=2000", &LoadOptions::default())
            .unwrap()
            .up,
        scene::UpAxis::Z
    );
    assert_eq!(
        open("procedural:city?size=2000", &forced).unwrap().up,
        scene::UpAxis::Y
    );
}

/// glTF is Y-up: a Z-up scene is written turned upright (its height along +Y, as other tools
/// expect) with its axis in the scene's extras, and loads back with the same coordinates,
/// ids and up axis.
#[test]
fn glb_of_a_z_up_scene_is_y_up_and_loads_back_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene::load_file(&flat_block_obj(dir.path()), &LoadOptions::default()).unwrap();
    assert_eq!(s.up, scene::UpAxis::Z);
    let mut glb = Vec::new();
    scene::gltf::write_glb(&s, &mut glb).unwrap();
    // The JSON chunk: length at byte 12, text from byte 20.
    let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&glb[20..20 + len]).unwrap();
    assert_eq!(json["scenes"][0]["extras"]["sightline"]["up"], "z");
    let max = &json["accessors"][0]["max"];
    assert_eq!(max[1].as_f64().unwrap(), 30.0, "height along +Y: {max}");
    let back = scene::gltf::load(Path::new("back.glb"), &glb).unwrap();
    assert_eq!(back.up, scene::UpAxis::Z);
    assert_eq!(back.geometry_hash(), s.geometry_hash());
    // A Y-up scene is written as it is, with no tag.
    let mut y_up = s.clone();
    y_up.up = scene::UpAxis::Y;
    let mut glb = Vec::new();
    scene::gltf::write_glb(&y_up, &mut glb).unwrap();
    let back = scene::gltf::load(Path::new("back.glb"), &glb).unwrap();
    assert_eq!(
        (back.up, back.geometry_hash()),
        (scene::UpAxis::Y, s.geometry_hash())
    );
}
