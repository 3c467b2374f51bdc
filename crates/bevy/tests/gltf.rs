//! End to end through Bevy's glTF loader (feature `gltf`, headless): a level file is baked the
//! way `sightline pvs bake level.glb` bakes it (sightline's own glTF loader, then a bake), the
//! same file is spawned with `WorldAssetRoot`, and the plugin ties every mesh entity to its
//! object by itself and culls it.

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

mod common;

use std::path::Path;

use bevy::asset::LoadState;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::VisibilityClass;
use bevy::gltf::{
    GltfAssetLabel, GltfExtras, GltfMaterialExtras, GltfMaterialName, GltfMeshExtras, GltfMeshName,
    GltfPlugin, GltfSceneExtras,
};
use bevy::image::{CompressedImageFormatSupport, CompressedImageFormats, ImagePlugin};
use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use bevy::transform::components::TransformTreeChanged;
use bevy::world_serialization::{WorldAssetRoot, WorldSerializationPlugin};
use bevy_sightline::{
    primitive_index, AutoMatched, PvsAsset, SightlineCamera, SightlineLevel, SightlineObject,
    SightlineStats, SightlineUnmatched,
};
use common::*;
use sightline_core::scene::{self, LoadOptions};
use sightline_core::Scene;
use sightline_region::ViewCell;
use sightline_runtime::Pvs;

/// A headless app that loads glTF files from `dir`.
fn gltf_app(dir: &Path) -> App {
    let mut app = app(dir);
    app.insert_resource(CompressedImageFormatSupport(CompressedImageFormats::NONE))
        .add_plugins((
            ImagePlugin::default(),
            MeshPlugin,
            WorldSerializationPlugin,
            GltfPlugin::default(),
        ));
    // Spawning a loaded glTF world copies its components by reflection; an app with
    // `DefaultPlugins` registers them automatically (`reflect_auto_register`), this one by
    // hand: the components bevy_gltf puts on scene, node and primitive entities, and the
    // components they require.
    app.register_type::<Transform>()
        .register_type::<GlobalTransform>()
        .register_type::<TransformTreeChanged>()
        .register_type::<Visibility>()
        .register_type::<InheritedVisibility>()
        .register_type::<ViewVisibility>()
        .register_type::<VisibilityClass>()
        .register_type::<Name>()
        .register_type::<ChildOf>()
        .register_type::<Children>()
        .register_type::<Mesh3d>()
        .register_type::<Aabb>()
        .register_type::<GltfExtras>()
        .register_type::<GltfSceneExtras>()
        .register_type::<GltfMeshExtras>()
        .register_type::<GltfMeshName>()
        .register_type::<GltfMaterialExtras>()
        .register_type::<GltfMaterialName>();
    // `App::run` would do this; GltfPlugin registers its loader in `finish`.
    app.finish();
    app.cleanup();
    app
}

/// Bakes `dir/file` as the CLI does: sightline's glTF loader, then the bake, into `dir/pvs`.
fn bake_file(dir: &Path, file: &str, cells: &[ViewCell], pvs: &str) -> Scene {
    let scene = scene::open(dir.join(file).to_str().unwrap(), &LoadOptions::default()).unwrap();
    bake(&scene, cells).save(&dir.join(pvs)).unwrap();
    scene
}

/// Spawns `file` as a level culled by `pvs` and runs frames until its mesh entities are all
/// decided (matched or unmatched). Returns the pvs handle and the mesh entities.
fn spawn_level(
    app: &mut App,
    file: &str,
    pvs: &str,
    meshes: usize,
) -> (Handle<PvsAsset>, Vec<Entity>) {
    let server = app.world().resource::<AssetServer>().clone();
    let handle: Handle<PvsAsset> = server.load(pvs.to_owned());
    let world_asset = server.load(GltfAssetLabel::Scene(0).from_asset(file.to_owned()));
    app.world_mut().spawn((
        WorldAssetRoot(world_asset.clone()),
        SightlineLevel::gltf(handle.clone()),
    ));
    let state = wait_for(app, &world_asset);
    assert!(matches!(state, LoadState::Loaded), "{state:?}");
    let state = wait_for(app, &handle);
    assert!(matches!(state, LoadState::Loaded), "{state:?}");
    for _ in 0..100 {
        app.update();
        let world = app.world_mut();
        let mut q = world.query_filtered::<Entity, (
            With<Mesh3d>,
            Or<(With<SightlineObject>, With<SightlineUnmatched>)>,
        )>();
        let decided: Vec<Entity> = q.iter(world).collect();
        if decided.len() == meshes {
            return (handle, decided);
        }
    }
    panic!("the level's {meshes} mesh entities were not all matched or unmatched");
}

fn object_of(app: &App, e: Entity) -> Option<u32> {
    app.world().get::<SightlineObject>(e).map(|o| o.0)
}

fn parent_name(app: &App, e: Entity) -> String {
    let parent = app.world().get::<ChildOf>(e).unwrap().parent();
    app.world().get::<Name>(parent).unwrap().as_str().to_owned()
}

#[test]
fn a_glb_level_is_matched_and_culled_with_no_code() {
    let dir = tempfile::tempdir().unwrap();
    // The corridor as a level file, as `sightline convert -o level.glb` writes it.
    let mut glb = Vec::new();
    sightline_core::scene::gltf::write_glb(&corridor(), &mut glb).unwrap();
    std::fs::write(dir.path().join("level.glb"), glb).unwrap();
    let scene = bake_file(dir.path(), "level.glb", &cells(), "level.pvs");
    let pvs = Pvs::open(dir.path().join("level.pvs")).unwrap();
    assert_eq!(pvs.object_count() as usize, scene.objects.len());

    let mut app = gltf_app(dir.path());
    // One node with one primitive per object (the corridor's objects are contiguous).
    let (handle, meshes) = spawn_level(&mut app, "level.glb", "level.pvs", scene.objects.len());
    let mut seen = vec![false; scene.objects.len()];
    for &e in &meshes {
        let o = object_of(&app, e).unwrap_or_else(|| panic!("{} unmatched", parent_name(&app, e)));
        assert!(app.world().get::<AutoMatched>(e).is_some());
        assert_eq!(pvs.object(o).unwrap().name, parent_name(&app, e));
        assert!(!seen[o as usize], "object {o} twice");
        seen[o as usize] = true;
    }
    assert_eq!(app.world().resource::<SightlineStats>().unmatched, 0);

    // Fly through: frame by frame exactly the meshes of the cell's objects are visible.
    let camera = app
        .world_mut()
        .spawn((
            Camera3d::default(),
            SightlineCamera::new(handle),
            Transform::from_xyz(-5.0, 1.7, 5.0),
        ))
        .id();
    let mut inside = 0;
    for frame in 0..240 {
        let t = frame as f32 / 239.0;
        let p = Vec3::new(
            -5.0 + 60.0 * t,
            if frame % 60 < 45 { 1.7 } else { 3.3 },
            5.0 + 3.0 * (t * 23.0).sin(),
        );
        app.world_mut()
            .get_mut::<Transform>(camera)
            .unwrap()
            .translation = p;
        app.update();
        let cell = pvs.cell_at(p.to_array());
        let set = cell.map(|c| pvs.visible_objects(c).unwrap());
        inside += usize::from(cell.is_some());
        let mut drawn = 0;
        for &e in &meshes {
            let o = object_of(&app, e).unwrap();
            let hidden = set.as_ref().is_some_and(|s| !s.contains(&o));
            let vis = *app.world().get::<Visibility>(e).unwrap();
            assert_eq!(
                vis == Visibility::Hidden,
                hidden,
                "frame {frame} at {p}, cell {cell:?}, object {o}"
            );
            drawn += u32::from(!hidden);
        }
        let stats = app.world().resource::<SightlineStats>();
        assert_eq!((stats.drawn, stats.total), (drawn, meshes.len() as u32));
    }
    assert!(inside > 100, "{inside}");
}

/// A box as 8 positions and 36 indices.
fn box_mesh(min: [f32; 3], max: [f32; 3]) -> (Vec<[f32; 3]>, Vec<u16>) {
    let p = (0..8)
        .map(|i| {
            [
                if i & 1 == 0 { min[0] } else { max[0] },
                if i & 2 == 0 { min[1] } else { max[1] },
                if i & 4 == 0 { min[2] } else { max[2] },
            ]
        })
        .collect();
    let faces = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let idx = faces
        .iter()
        .flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]])
        .collect();
    (p, idx)
}

/// Writes `dir/hierarchy.gltf` (+ `.bin`): `Root` > `House` (mesh 2) > `Door.001` (mesh 1,
/// three primitives); `Root` > unnamed node 3 (mesh 0); `Root` > `Props` > `Lamp` (mesh 3,
/// two primitives). Every primitive is a 1 m box, side by side along x.
fn write_hierarchy(dir: &Path) {
    let prims_per_mesh = [1usize, 3, 1, 2];
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut meshes = Vec::new();
    let mut k = 0;
    for &n in &prims_per_mesh {
        let mut prims = Vec::new();
        for _ in 0..n {
            let x = 2.0 * k as f32;
            let (p, idx) = box_mesh([x, 0.0, 0.0], [x + 1.0, 1.0, 1.0]);
            let off = bin.len();
            for v in &p {
                for c in v {
                    bin.extend_from_slice(&c.to_le_bytes());
                }
            }
            let ioff = bin.len();
            for i in &idx {
                bin.extend_from_slice(&i.to_le_bytes());
            }
            bin.resize(bin.len().next_multiple_of(4), 0);
            let a = accessors.len();
            views.push(serde_json::json!({"buffer": 0, "byteOffset": off, "byteLength": 96}));
            views.push(serde_json::json!({"buffer": 0, "byteOffset": ioff, "byteLength": 72}));
            accessors.push(
                serde_json::json!({"bufferView": a, "componentType": 5126, "count": 8,
                "type": "VEC3", "min": [x, 0.0, 0.0], "max": [x + 1.0, 1.0, 1.0]}),
            );
            accessors.push(
                serde_json::json!({"bufferView": a + 1, "componentType": 5123,
                "count": 36, "type": "SCALAR"}),
            );
            prims.push(
                serde_json::json!({"attributes": {"POSITION": a}, "indices": a + 1, "mode": 4}),
            );
            k += 1;
        }
        meshes.push(serde_json::json!({"primitives": prims}));
    }
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"name": "Root", "children": [1, 3, 4]},
            {"name": "House", "children": [2], "mesh": 2},
            {"name": "Door.001", "mesh": 1},
            {"mesh": 0},
            {"name": "Props", "children": [5]},
            {"name": "Lamp", "mesh": 3},
        ],
        "meshes": meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len(), "uri": "hierarchy.bin"}],
    });
    std::fs::write(
        dir.join("hierarchy.gltf"),
        serde_json::to_vec(&gltf).unwrap(),
    )
    .unwrap();
    std::fs::write(dir.join("hierarchy.bin"), bin).unwrap();
}

/// One cell in front of the row of boxes.
fn front_cell() -> Vec<ViewCell> {
    vec![ViewCell::aabb(
        glam::Vec3::new(0.0, 0.0, 3.0),
        glam::Vec3::new(14.0, 1.0, 4.0),
    )
    .unwrap()]
}

/// A glTF file with a hierarchy, an unnamed node and multi-primitive meshes: every primitive
/// entity gets the object of its node path and primitive index.
#[test]
fn node_paths_and_primitives_match_through_the_gltf_loader() {
    let dir = tempfile::tempdir().unwrap();
    write_hierarchy(dir.path());
    let scene = bake_file(dir.path(), "hierarchy.gltf", &front_cell(), "hierarchy.pvs");
    let pvs = Pvs::open(dir.path().join("hierarchy.pvs")).unwrap();
    let identities: Vec<(&str, Option<u32>, Option<u32>)> =
        pvs.objects().map(|o| (o.name, o.index, o.part)).collect();
    assert_eq!(
        identities,
        [
            ("Root/House", Some(1), Some(0)),
            ("Root/House/Door.001", Some(2), Some(0)),
            ("Root/House/Door.001", Some(2), Some(1)),
            ("Root/House/Door.001", Some(2), Some(2)),
            ("Root/#3", Some(3), Some(0)),
            ("Root/Props/Lamp", Some(5), Some(0)),
            ("Root/Props/Lamp", Some(5), Some(1)),
        ],
        "sightline's glTF loader names objects by node path"
    );
    assert_eq!(scene.objects.len(), 7);

    let mut app = gltf_app(dir.path());
    let (_, meshes) = spawn_level(&mut app, "hierarchy.gltf", "hierarchy.pvs", 7);
    let mut seen = Vec::new();
    for &e in &meshes {
        let o = object_of(&app, e).unwrap_or_else(|| panic!("{} unmatched", parent_name(&app, e)));
        let object = pvs.object(o).unwrap();
        let node = parent_name(&app, e);
        let last = object.name.rsplit('/').next().unwrap();
        assert_eq!(last.replace("#3", "GltfNode3"), node, "object {o}");
        let primitive = primitive_index(app.world().get::<Mesh3d>(e).unwrap());
        assert_eq!(object.part, primitive, "object {o}");
        seen.push(o);
    }
    seen.sort_unstable();
    assert_eq!(seen, (0..7).collect::<Vec<u32>>());
}

/// The same file converted by sightline (`write_glb`: one node per object, each with one
/// primitive and an `extras.sightline` tag): the tags keep the three door primitives apart,
/// which node paths and primitive indices alone no longer can.
#[test]
fn converted_files_match_by_their_node_tags() {
    let dir = tempfile::tempdir().unwrap();
    write_hierarchy(dir.path());
    let original = scene::open(
        dir.path().join("hierarchy.gltf").to_str().unwrap(),
        &LoadOptions::default(),
    )
    .unwrap();
    let mut glb = Vec::new();
    sightline_core::scene::gltf::write_glb(&original, &mut glb).unwrap();
    std::fs::write(dir.path().join("converted.glb"), glb).unwrap();
    let scene = bake_file(dir.path(), "converted.glb", &front_cell(), "converted.pvs");
    assert_eq!(scene.objects, original.objects);
    let pvs = Pvs::open(dir.path().join("converted.pvs")).unwrap();

    let mut app = gltf_app(dir.path());
    let (_, meshes) = spawn_level(&mut app, "converted.glb", "converted.pvs", 7);
    let mut seen: Vec<u32> = meshes
        .iter()
        .map(|&e| {
            let o = object_of(&app, e).unwrap();
            assert_eq!(pvs.object(o).unwrap().name, parent_name(&app, e));
            o
        })
        .collect();
    seen.sort_unstable();
    assert_eq!(
        seen,
        (0..7).collect::<Vec<u32>>(),
        "every object exactly once"
    );
}
