//! A corridor of rooms baked in-process, and helpers to run a headless app until assets load.

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used, dead_code)]

use std::path::Path;
use std::time::{Duration, Instant};

use bevy::asset::{AssetServer, LoadState, UntypedAssetId};
use bevy::prelude::*;
use glam::Vec3 as V;
use sightline_core::scene::SceneBuilder;
use sightline_core::trace::Bvh;
use sightline_core::{Scene, UpAxis};
use sightline_region::{Budget, PvsFile, RandomSampler, ViewCell};

/// Rooms along +x, each `ROOM` m long (x), `WIDTH` wide (z), `HEIGHT` high (y, up).
pub const ROOMS: usize = 5;
pub const ROOM: f32 = 10.0;
pub const WIDTH: f32 = 10.0;
pub const HEIGHT: f32 = 4.0;

/// Five rooms in a row (y up). Every room has its floor, ceiling, two side walls and a crate
/// as separate objects (`Level/Room{i}/...`); between rooms stand walls with one door each,
/// alternately near z = 0 and z = WIDTH, so a room sees its neighbours only in part and the
/// far rooms not at all.
pub fn corridor() -> Scene {
    let mut b = SceneBuilder::new("corridor");
    b.set_up(UpAxis::Y);
    for i in 0..ROOMS {
        let x0 = i as f32 * ROOM;
        let x1 = x0 + ROOM;
        b.begin_object(format!("Level/Room{i}/Floor"));
        b.add_box(V::new(x0, -0.2, 0.0), V::new(x1, 0.0, WIDTH));
        b.begin_object(format!("Level/Room{i}/Ceiling"));
        b.add_box(V::new(x0, HEIGHT, 0.0), V::new(x1, HEIGHT + 0.2, WIDTH));
        b.begin_object(format!("Level/Room{i}/SideWalls"));
        b.add_box(V::new(x0, 0.0, -0.2), V::new(x1, HEIGHT, 0.0));
        b.add_box(V::new(x0, 0.0, WIDTH), V::new(x1, HEIGHT, WIDTH + 0.2));
        b.begin_object(format!("Level/Room{i}/Crate"));
        let c = V::new(x0 + 5.0, 0.0, 3.0 + (i % 2) as f32 * 4.0);
        b.add_box(c - V::new(0.5, 0.0, 0.5), c + V::new(0.5, 1.0, 0.5));
    }
    // End walls close the corridor; walls between rooms have a 2 m wide, 3 m high door.
    b.begin_object("Level/EndWalls");
    b.add_box(V::new(-0.2, 0.0, 0.0), V::new(0.0, HEIGHT, WIDTH));
    let end = ROOMS as f32 * ROOM;
    b.add_box(V::new(end, 0.0, 0.0), V::new(end + 0.2, HEIGHT, WIDTH));
    for i in 1..ROOMS {
        let x = i as f32 * ROOM;
        let door = if i % 2 == 1 { 0.5 } else { WIDTH - 2.5 };
        b.begin_object(format!("Level/Wall{i}"));
        b.add_box(V::new(x - 0.1, 0.0, 0.0), V::new(x + 0.1, HEIGHT, door));
        b.add_box(
            V::new(x - 0.1, 0.0, door + 2.0),
            V::new(x + 0.1, HEIGHT, WIDTH),
        );
        b.add_box(
            V::new(x - 0.1, 3.0, door),
            V::new(x + 0.1, HEIGHT, door + 2.0),
        );
    }
    b.finish()
}

/// One cell per room, inside it, at eye height: x in [10i + 1, 10i + 9], y in [1, 2.5],
/// z in [1, 9].
pub fn cells() -> Vec<ViewCell> {
    (0..ROOMS)
        .map(|i| {
            let x0 = i as f32 * ROOM;
            ViewCell::aabb(V::new(x0 + 1.0, 1.0, 1.0), V::new(x0 + 9.0, 2.5, 9.0)).unwrap()
        })
        .collect()
}

/// Bakes `scene` over `cells` with RAND (deterministic for its seed and ray budget).
pub fn bake(scene: &Scene, cells: &[ViewCell]) -> PvsFile {
    let bvh = Bvh::build(scene);
    sightline_region::bake::bake_plain(scene, &bvh, cells, &RandomSampler, &Budget::rays(20_000), 1)
}

/// Bakes the corridor into `dir/name` and returns the scene.
pub fn bake_corridor(dir: &Path, name: &str) -> Scene {
    let scene = corridor();
    bake(&scene, &cells()).save(&dir.join(name)).unwrap();
    scene
}

/// A headless app reading assets from `dir`: MinimalPlugins, assets, transforms and the
/// plugin (no renderer, no window).
pub fn app(dir: &Path) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin {
            file_path: dir.to_str().unwrap().to_owned(),
            ..default()
        },
        TransformPlugin,
        bevy_sightline::SightlinePlugin,
    ));
    app
}

/// Runs frames until `id` is loaded (with its dependencies) or failed; returns its state.
pub fn wait_for(app: &mut App, id: impl Into<UntypedAssetId>) -> LoadState {
    let id = id.into();
    let start = Instant::now();
    loop {
        app.update();
        let server = app.world().resource::<AssetServer>();
        let state = server.load_state(id);
        let done = match &state {
            LoadState::Loaded => server.is_loaded_with_dependencies(id),
            LoadState::Failed(_) => true,
            _ => false,
        };
        if done {
            return state;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "asset still {state:?} after 60 s"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
}
