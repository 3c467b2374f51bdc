//! Automatic `SightlineObject`s from glTF node paths, on a hand-built hierarchy shaped exactly
//! like what Bevy's glTF loader (bevy_gltf 0.19.1) spawns — see `src/matching.rs` for the
//! loader lines it mirrors: level entity > scene root `Scene0` > node entities named after
//! their nodes (`GltfNode{i}` when unnamed) > one child per primitive with `Mesh3d` (label
//! `Mesh{m}/Primitive{p}`) named `{mesh}.{material}`. `tests/gltf.rs` (feature `gltf`) runs
//! the real loader.

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

mod common;

use bevy::asset::LoadState;
use bevy::prelude::*;
use bevy_sightline::{
    AutoMatched, PvsAsset, SightlineCamera, SightlineLevel, SightlineObject, SightlineStats,
    SightlineUnmatched,
};
use common::*;
use glam::Vec3 as V;
use sightline_core::scene::SceneBuilder;
use sightline_core::Object;
use sightline_runtime::Pvs;

/// Objects as sightline's glTF loader names them, each a small box at x = 3k, with one cell
/// around each box.
const OBJECTS: &[(&str, Option<u32>, Option<u32>)] = &[
    ("Root/House/Door.001", Some(2), Some(0)), // 0
    ("Root/House/Door.001", Some(2), Some(2)), // 1: same node, third primitive
    ("Root/#3", Some(3), Some(0)),             // 2: unnamed node 3
    ("Root/Twin", Some(4), Some(0)),           // 3: two sibling nodes share a name ...
    ("Root/Twin", Some(5), Some(0)),           // 4: ... so neither can be told apart
    ("Props/Lamp", None, None),                // 5: no part (another format, or by hand)
    ("Root/House", Some(1), Some(0)),          // 6
];

fn fixture(dir: &std::path::Path) {
    let mut b = SceneBuilder::new("named");
    for (k, &(name, index, part)) in OBJECTS.iter().enumerate() {
        b.push_object(Object {
            name: name.to_owned(),
            index,
            part,
        });
        let p = V::new(3.0 * k as f32, 0.0, 0.0);
        b.add_box(p, p + V::ONE);
    }
    let scene = b.finish();
    let cells: Vec<_> = (0..OBJECTS.len())
        .map(|k| {
            let p = V::new(3.0 * k as f32 - 1.0, -1.0, -1.0);
            sightline_region::ViewCell::aabb(p, p + V::new(0.5, 3.0, 3.0)).unwrap()
        })
        .collect();
    bake(&scene, &cells).save(&dir.join("named.pvs")).unwrap();
}

struct Level {
    door_p0: Entity,
    door_p1: Entity,
    door_p2: Entity,
    unnamed: Entity,
    twins: [Entity; 2],
    lamp: Entity,
    house: Entity,
    by_hand: Entity,
    nameless_parent: Entity,
}

/// Spawns the hierarchy bevy_gltf would spawn for a file with these nodes:
/// `Root` > `House` (mesh 2) > `Door.001` (mesh 1: primitives 0, 1, 2), `Root` > node 3
/// (unnamed, mesh 0), `Root` > `Twin` x 2 (mesh 3), and a second root node `Props` > `Lamp`.
fn spawn_level(app: &mut App, level: Entity) -> Level {
    let server = app.world().resource::<AssetServer>().clone();
    let mesh = |m: u32, p: u32| Mesh3d(server.load(format!("level.glb#Mesh{m}/Primitive{p}")));
    let world = app.world_mut();
    let node = |world: &mut World, parent: Entity, name: &str| {
        world
            .spawn((
                Name::new(name.to_owned()),
                Transform::default(),
                Visibility::default(),
                ChildOf(parent),
            ))
            .id()
    };
    let primitive = |world: &mut World, parent: Entity, mesh: Mesh3d, name: &str| {
        world
            .spawn((mesh, Name::new(name.to_owned()), ChildOf(parent)))
            .id()
    };
    let scene_root = node(world, level, "Scene0");
    let root = node(world, scene_root, "Root");
    let house = node(world, root, "House");
    let house_mesh = primitive(world, house, mesh(2, 0), "Mesh");
    let door = node(world, house, "Door.001");
    let door_p0 = primitive(world, door, mesh(1, 0), "door mesh.Wood");
    let door_p1 = primitive(world, door, mesh(1, 1), "door mesh.Glass");
    let door_p2 = primitive(world, door, mesh(1, 2), "door mesh.Metal");
    let n3 = node(world, root, "GltfNode3");
    let unnamed = primitive(world, n3, mesh(0, 0), "Mesh");
    let t1 = node(world, root, "Twin");
    let t2 = node(world, root, "Twin");
    let twins = [
        primitive(world, t1, mesh(3, 0), "Mesh"),
        primitive(world, t2, mesh(3, 0), "Mesh"),
    ];
    let props = node(world, scene_root, "Props");
    let lamp_node = node(world, props, "Lamp");
    let lamp = primitive(world, lamp_node, mesh(4, 0), "Lamp");
    // Set by hand: kept as it is.
    let by_hand = world
        .spawn((mesh(5, 0), SightlineObject(0), ChildOf(lamp_node)))
        .id();
    // A parent without a Name: the path is unknown.
    let anonymous = world.spawn(ChildOf(props)).id();
    let nameless_parent = primitive(world, anonymous, mesh(6, 0), "Mesh");
    Level {
        door_p0,
        door_p1,
        door_p2,
        unnamed,
        twins,
        lamp,
        house: house_mesh,
        by_hand,
        nameless_parent,
    }
}

#[test]
fn gltf_mesh_entities_get_the_objects_of_their_node_paths() {
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let pvs = Pvs::open(dir.path().join("named.pvs")).unwrap();
    assert_eq!(pvs.object(1).unwrap().part, Some(2));

    let mut app = app(dir.path());
    app.init_asset::<Mesh>();
    let handle: Handle<PvsAsset> = app.world().resource::<AssetServer>().load("named.pvs");
    let level_entity = app
        .world_mut()
        .spawn((
            SightlineLevel::gltf(handle.clone()),
            Transform::default(),
            Visibility::default(),
        ))
        .id();
    let level = spawn_level(&mut app, level_entity);
    // A mesh below no level: never matched, never culled.
    let stray_mesh = Mesh3d(
        app.world()
            .resource::<AssetServer>()
            .load("other.glb#Mesh0/Primitive0"),
    );
    let stray = app.world_mut().spawn(stray_mesh).id();
    let state = wait_for(&mut app, &handle);
    assert!(matches!(state, LoadState::Loaded), "{state:?}");
    app.update();

    let object = |app: &App, e: Entity| app.world().get::<SightlineObject>(e).map(|o| o.0);
    let auto = |app: &App, e: Entity| app.world().get::<AutoMatched>(e).is_some();
    let unmatched = |app: &App, e: Entity| app.world().get::<SightlineUnmatched>(e).is_some();
    assert_eq!(object(&app, level.door_p0), Some(0));
    assert_eq!(object(&app, level.door_p2), Some(1));
    assert_eq!(
        object(&app, level.unnamed),
        Some(2),
        "GltfNode3 is sightline's #3"
    );
    assert_eq!(
        object(&app, level.lamp),
        Some(5),
        "a single object without part"
    );
    assert_eq!(object(&app, level.house), Some(6));
    for e in [
        level.door_p0,
        level.door_p2,
        level.unnamed,
        level.lamp,
        level.house,
    ] {
        assert!(auto(&app, e) && !unmatched(&app, e));
    }
    // No object for primitive 1; twins are ambiguous; an unnamed ancestor hides the path.
    for e in [
        level.door_p1,
        level.twins[0],
        level.twins[1],
        level.nameless_parent,
        stray,
    ] {
        assert_eq!(object(&app, e), None);
        assert!(unmatched(&app, e));
    }
    assert_eq!(object(&app, level.by_hand), Some(0));
    assert!(!auto(&app, level.by_hand) && !unmatched(&app, level.by_hand));
    assert_eq!(app.world().resource::<SightlineStats>().unmatched, 5);

    // The matched entities are culled like hand-tied ones; unmatched ones stay drawn.
    let camera = app
        .world_mut()
        .spawn((
            SightlineCamera::new(handle.clone()),
            Transform::from_xyz(-0.75, 0.5, 0.5),
        ))
        .id();
    let all = [
        level.door_p0,
        level.door_p1,
        level.door_p2,
        level.unnamed,
        level.twins[0],
        level.twins[1],
        level.lamp,
        level.house,
        level.by_hand,
        level.nameless_parent,
        stray,
    ];
    for k in 0..OBJECTS.len() {
        let p = Vec3::new(3.0 * k as f32 - 0.75, 0.5, 0.5);
        app.world_mut()
            .get_mut::<Transform>(camera)
            .unwrap()
            .translation = p;
        app.update();
        let cell = pvs.cell_at(p.to_array()).unwrap();
        let set = pvs.visible_objects(cell).unwrap();
        let mut hidden = 0;
        for &e in &all {
            // (Unmatched meshes may have no Visibility at all: nothing added one.)
            let vis = app
                .world()
                .get::<Visibility>(e)
                .copied()
                .unwrap_or_default();
            let want_hidden = object(&app, e).is_some_and(|o| !set.contains(&o));
            hidden += usize::from(want_hidden);
            assert_eq!(vis == Visibility::Hidden, want_hidden, "cell {cell}, {e:?}");
        }
        let stats = app.world().resource::<SightlineStats>();
        assert_eq!(stats.total, 6);
        assert_eq!(stats.drawn as usize, 6 - hidden);
    }

    // Changing the level redoes the automatic assignments (here: skip one more level, so
    // node paths lose their first name and nothing matches any more).
    app.world_mut()
        .get_mut::<SightlineLevel>(level_entity)
        .unwrap()
        .skip = 2;
    app.update();
    app.update();
    assert_eq!(object(&app, level.door_p0), None);
    assert!(unmatched(&app, level.door_p0));
    assert_eq!(
        object(&app, level.by_hand),
        Some(0),
        "hand-set objects are kept"
    );
}
