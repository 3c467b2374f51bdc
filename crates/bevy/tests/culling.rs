//! The culling, headless (no GPU, no window): a corridor of rooms is baked in-process, a
//! camera flies through its cells, and every frame exactly the entities whose objects are in
//! the current cell's set (computed independently with `sightline_runtime`) are visible.

// Test helpers panic on broken fixtures; that is the failure report we want.
#![allow(clippy::unwrap_used)]

mod common;

use bevy::asset::LoadState;
use bevy::prelude::*;
use bevy_sightline::{PvsAsset, SightlineCamera, SightlineCulled, SightlineObject, SightlineStats};
use common::*;
use sightline_runtime::Pvs;

/// An entity tied to `object`, with its own visibility `own`.
struct Tied {
    entity: Entity,
    object: u32,
    own: Visibility,
}

fn spawn_tied(app: &mut App, object: u32, own: Visibility) -> Tied {
    let entity = app
        .world_mut()
        .spawn((SightlineObject(object), own, Transform::default()))
        .id();
    Tied {
        entity,
        object,
        own,
    }
}

fn move_to(app: &mut App, camera: Entity, p: Vec3) {
    *app.world_mut().get_mut::<Transform>(camera).unwrap() = Transform::from_translation(p);
}

fn visibility(app: &App, e: Entity) -> Visibility {
    *app.world().get::<Visibility>(e).unwrap()
}

/// Whether the plugin must hide the entity with the cameras' union `visible` (`None`: draw
/// all), and the visibility it must have then.
fn expected(t: &Tied, visible: Option<&[bool]>) -> (bool, Visibility) {
    match visible {
        Some(v) if (t.object as usize) < v.len() && !v[t.object as usize] => {
            (true, Visibility::Hidden)
        }
        _ => (false, t.own),
    }
}

fn union(pvs: &Pvs, cells: &[Option<u32>]) -> Option<Vec<bool>> {
    let mut v = vec![false; pvs.object_count() as usize];
    for cell in cells {
        for o in pvs.visible_objects((*cell)?).unwrap() {
            v[o as usize] = true;
        }
    }
    Some(v)
}

fn check_frame(app: &App, tied: &[Tied], visible: Option<&[bool]>, what: &str) {
    let mut drawn = 0;
    for t in tied {
        let (culled, want) = expected(t, visible);
        let got = visibility(app, t.entity);
        assert_eq!(got, want, "{what}: object {} (own {:?})", t.object, t.own);
        let state = app.world().get::<SightlineCulled>(t.entity).unwrap();
        assert_eq!(state.hidden, culled, "{what}: object {}", t.object);
        drawn += u32::from(!culled);
    }
    let stats = app.world().resource::<SightlineStats>();
    assert_eq!(stats.total as usize, tied.len(), "{what}");
    assert_eq!(stats.drawn, drawn, "{what}");
    assert_eq!(stats.draw_all, visible.is_none(), "{what}");
}

#[test]
fn a_camera_flying_through_the_corridor_sees_exactly_its_cells_objects() {
    let dir = tempfile::tempdir().unwrap();
    let scene = bake_corridor(dir.path(), "corridor.pvs");
    // The independent answer: the runtime reader on the same file.
    let pvs = Pvs::open(dir.path().join("corridor.pvs")).unwrap();
    let n = pvs.object_count();
    assert_eq!(pvs.version(), 2);
    assert_eq!(n as usize, scene.objects.len());
    let sets: Vec<Vec<u32>> = (0..pvs.cell_count())
        .map(|c| pvs.visible_objects(c).unwrap())
        .collect();
    // The fixture is worth testing with: every cell sees some but not all objects, the sets
    // differ, and the first room does not see the last room's crate.
    assert!(
        sets.iter().all(|s| !s.is_empty() && s.len() < n as usize),
        "{sets:?}"
    );
    assert!(sets.windows(2).all(|w| w[0] != w[1]), "{sets:?}");
    let last_crate = scene
        .objects
        .iter()
        .position(|o| o.name == format!("Level/Room{}/Crate", ROOMS - 1))
        .unwrap() as u32;
    assert!(!sets[0].contains(&last_crate));

    let mut app = app(dir.path());
    let handle: Handle<PvsAsset> = app.world().resource::<AssetServer>().load("corridor.pvs");
    let mut tied: Vec<Tied> = (0..n)
        .map(|o| spawn_tied(&mut app, o, Visibility::Inherited))
        .collect();
    // Entities with their own visibility keep it whenever they are not culled; an id past
    // the file's objects is never culled.
    tied.push(spawn_tied(&mut app, last_crate, Visibility::Visible));
    tied.push(spawn_tied(&mut app, last_crate, Visibility::Hidden));
    tied.push(spawn_tied(&mut app, n + 7, Visibility::Inherited));
    // Entities without SightlineObject are never touched.
    let bystander = app.world_mut().spawn(Visibility::Hidden).id();
    let camera = app
        .world_mut()
        .spawn((
            Camera3d::default(),
            SightlineCamera::new(handle.clone()),
            Transform::from_xyz(-5.0, 1.7, 5.0),
        ))
        .id();
    let state = wait_for(&mut app, &handle);
    assert!(matches!(state, LoadState::Loaded), "{state:?}");

    let frames = 600;
    let mut frames_in_cell = vec![0; pvs.cell_count() as usize];
    let mut frames_outside = 0;
    let mut flips = 0;
    let mut last = Vec::new();
    for frame in 0..frames {
        // Along the corridor and past both ends, weaving in z, and every fourth stretch of
        // 30 frames above the cells (y 3.2: outside every cell, inside the room).
        let t = frame as f32 / (frames - 1) as f32;
        let x = -5.0 + 60.0 * t;
        let y = if (frame / 30) % 4 == 3 { 3.2 } else { 1.7 };
        let z = 5.0 + 3.5 * (t * 37.0).sin();
        let p = Vec3::new(x, y, z);
        move_to(&mut app, camera, p);
        app.update();

        let cell = pvs.cell_at(p.to_array());
        match cell {
            Some(c) => frames_in_cell[c as usize] += 1,
            None => frames_outside += 1,
        }
        let visible = union(&pvs, &[cell]);
        check_frame(
            &app,
            &tied,
            visible.as_deref(),
            &format!("frame {frame} at {p} (cell {cell:?})"),
        );
        assert_eq!(visibility(&app, bystander), Visibility::Hidden);
        let stats = app.world().resource::<SightlineStats>();
        assert_eq!(stats.cameras, vec![(camera, cell)]);
        assert_eq!(stats.object_count, n);
        let now: Vec<Visibility> = tied.iter().map(|t| visibility(&app, t.entity)).collect();
        flips += usize::from(!last.is_empty() && now != last);
        last = now;
    }
    assert!(
        frames_in_cell.iter().all(|&f| f >= 20),
        "the path crosses every cell: {frames_in_cell:?}"
    );
    assert!(frames_outside >= 100, "{frames_outside}");
    assert!(flips >= 10, "the visible set changed only {flips} times");
}

/// Two cameras: their cells' sets are united; one outside every cell draws everything;
/// inactive and disabled cameras and no camera at all follow the documented policy.
#[test]
fn several_cameras_unite_their_sets() {
    let dir = tempfile::tempdir().unwrap();
    bake_corridor(dir.path(), "corridor.pvs");
    let pvs = Pvs::open(dir.path().join("corridor.pvs")).unwrap();
    let mut app = app(dir.path());
    let handle: Handle<PvsAsset> = app.world().resource::<AssetServer>().load("corridor.pvs");
    let tied: Vec<Tied> = (0..pvs.object_count())
        .map(|o| spawn_tied(&mut app, o, Visibility::Inherited))
        .collect();
    let room = |i: usize| Vec3::new(i as f32 * ROOM + 5.0, 1.7, 5.0);
    let a = app
        .world_mut()
        .spawn((
            Camera3d::default(),
            SightlineCamera::new(handle.clone()),
            Transform::from_translation(room(0)),
        ))
        .id();
    let b = app
        .world_mut()
        .spawn((
            Camera3d::default(),
            SightlineCamera::new(handle.clone()),
            Transform::from_translation(room(4)),
        ))
        .id();
    let state = wait_for(&mut app, &handle);
    assert!(matches!(state, LoadState::Loaded), "{state:?}");
    let (c0, c4) = (
        pvs.cell_at(room(0).to_array()),
        pvs.cell_at(room(4).to_array()),
    );
    assert_eq!((c0, c4), (Some(0), Some(4)));

    app.update();
    let both = union(&pvs, &[c0, c4]).unwrap();
    assert!(both.iter().filter(|&&v| v).count() > pvs.visible_objects(0).unwrap().len());
    check_frame(&app, &tied, Some(&both), "a in room 0, b in room 4");

    move_to(&mut app, b, Vec3::new(25.0, 3.5, 5.0)); // above the cells
    app.update();
    check_frame(&app, &tied, None, "b outside every cell");

    move_to(&mut app, b, room(4));
    app.world_mut().get_mut::<Camera>(b).unwrap().is_active = false;
    app.update();
    check_frame(&app, &tied, union(&pvs, &[c0]).as_deref(), "b inactive");

    app.world_mut().get_mut::<Camera>(b).unwrap().is_active = true;
    app.world_mut()
        .get_mut::<SightlineCamera>(a)
        .unwrap()
        .enabled = false;
    app.update();
    check_frame(&app, &tied, union(&pvs, &[c4]).as_deref(), "a disabled");

    // A camera without a Camera component (a tool, a headless probe) takes part too.
    app.world_mut().entity_mut(b).remove::<SightlineCamera>();
    let probe = app
        .world_mut()
        .spawn((
            SightlineCamera::new(handle.clone()),
            Transform::from_translation(room(2)),
        ))
        .id();
    app.update();
    check_frame(
        &app,
        &tied,
        union(&pvs, &[Some(2)]).as_deref(),
        "probe in room 2",
    );

    app.world_mut().despawn(probe);
    app.update();
    check_frame(&app, &tied, None, "no camera takes part");
    assert!(app.world().resource::<SightlineStats>().cameras.is_empty());
}

/// The plugin composes with visibility written by others and gives it back.
#[test]
fn user_visibility_is_kept_and_restored() {
    let dir = tempfile::tempdir().unwrap();
    let scene = bake_corridor(dir.path(), "corridor.pvs");
    let pvs = Pvs::open(dir.path().join("corridor.pvs")).unwrap();
    let far = scene
        .objects
        .iter()
        .position(|o| o.name == "Level/Room4/Crate")
        .unwrap() as u32;
    let near = scene
        .objects
        .iter()
        .position(|o| o.name == "Level/Room0/Crate")
        .unwrap() as u32;
    assert!(!pvs.visible_objects(0).unwrap().contains(&far));
    assert!(pvs.visible_objects(4).unwrap().contains(&far));

    let mut app = app(dir.path());
    let handle: Handle<PvsAsset> = app.world().resource::<AssetServer>().load("corridor.pvs");
    let e = app
        .world_mut()
        .spawn((SightlineObject(far), Visibility::Inherited))
        .id();
    let f = app
        .world_mut()
        .spawn((SightlineObject(far), Visibility::Visible))
        .id();
    let camera = app
        .world_mut()
        .spawn((
            SightlineCamera::new(handle.clone()),
            Transform::from_xyz(5.0, 1.7, 5.0),
        ))
        .id();
    let state = wait_for(&mut app, &handle);
    assert!(matches!(state, LoadState::Loaded), "{state:?}");
    app.update();
    assert_eq!(visibility(&app, e), Visibility::Hidden);
    assert_eq!(visibility(&app, f), Visibility::Hidden);

    // Someone shows a culled entity: it stays culled, and that value is what comes back.
    *app.world_mut().get_mut::<Visibility>(e).unwrap() = Visibility::Visible;
    app.update();
    assert_eq!(visibility(&app, e), Visibility::Hidden);
    assert_eq!(
        app.world().get::<SightlineCulled>(e).unwrap().saved,
        Visibility::Visible
    );
    move_to(&mut app, camera, Vec3::new(45.0, 1.7, 5.0));
    app.update();
    assert_eq!(visibility(&app, e), Visibility::Visible);
    assert_eq!(visibility(&app, f), Visibility::Visible);

    // Someone hides a drawn entity: the plugin leaves it hidden when it is in view.
    *app.world_mut().get_mut::<Visibility>(e).unwrap() = Visibility::Hidden;
    move_to(&mut app, camera, Vec3::new(5.0, 1.7, 5.0));
    app.update();
    move_to(&mut app, camera, Vec3::new(45.0, 1.7, 5.0));
    app.update();
    assert_eq!(visibility(&app, e), Visibility::Hidden);

    // Losing SightlineObject while culled gives the visibility back.
    move_to(&mut app, camera, Vec3::new(5.0, 1.7, 5.0));
    app.update();
    assert_eq!(visibility(&app, f), Visibility::Hidden);
    app.world_mut().entity_mut(f).remove::<SightlineObject>();
    app.update();
    assert_eq!(visibility(&app, f), Visibility::Visible);

    // Changing the object re-evaluates at once, even when no camera moved.
    app.world_mut().entity_mut(f).insert(SightlineObject(far));
    app.update();
    assert_eq!(visibility(&app, f), Visibility::Hidden);
    app.world_mut().get_mut::<SightlineObject>(f).unwrap().0 = near;
    app.update();
    assert_eq!(visibility(&app, f), Visibility::Visible);
    let stats = app.world().resource::<SightlineStats>();
    assert_eq!((stats.drawn, stats.total), (1, 2));
}

/// Damaged files fail to load (no panic); a version-1 file (no object sets) draws everything.
#[test]
fn bad_files_fail_to_load_and_version_1_draws_everything() {
    let dir = tempfile::tempdir().unwrap();
    let scene = corridor();
    let mut file = bake(&scene, &cells());
    file.save(&dir.path().join("good.pvs")).unwrap();
    let good = std::fs::read(dir.path().join("good.pvs")).unwrap();
    std::fs::write(dir.path().join("garbage.pvs"), b"not a pvs file at all").unwrap();
    std::fs::write(dir.path().join("truncated.pvs"), &good[..good.len() / 2]).unwrap();
    let mut flipped = good.clone();
    flipped[good.len() / 3] ^= 0x10;
    std::fs::write(dir.path().join("flipped.pvs"), &flipped).unwrap();
    file.objects = None;
    file.save(&dir.path().join("v1.pvs")).unwrap();

    let mut app = app(dir.path());
    for name in ["garbage.pvs", "truncated.pvs", "flipped.pvs", "missing.pvs"] {
        let h: Handle<PvsAsset> = app.world().resource::<AssetServer>().load(name);
        let state = wait_for(&mut app, &h);
        assert!(matches!(state, LoadState::Failed(_)), "{name}: {state:?}");
    }

    let h: Handle<PvsAsset> = app.world().resource::<AssetServer>().load("v1.pvs");
    let state = wait_for(&mut app, &h);
    assert!(matches!(state, LoadState::Loaded), "{state:?}");
    let v1 = app
        .world()
        .resource::<Assets<PvsAsset>>()
        .get(&h)
        .unwrap()
        .shared();
    assert_eq!((v1.version(), v1.object_count()), (1, 0));
    let tied: Vec<Tied> = (0..scene.objects.len() as u32)
        .map(|o| spawn_tied(&mut app, o, Visibility::Inherited))
        .collect();
    app.world_mut()
        .spawn((SightlineCamera::new(h), Transform::from_xyz(5.0, 1.7, 5.0)));
    app.update();
    check_frame(&app, &tied, None, "version-1 file");
    let stats = app.world().resource::<SightlineStats>();
    assert!(
        stats
            .last_error
            .as_deref()
            .is_some_and(|e| e.contains("no object table")),
        "{stats:?}"
    );
}

/// A camera with `with_bound` culls with the cells' conservative bounds; on a file without
/// bounds it draws everything and says why.
#[test]
fn a_camera_may_cull_with_the_conservative_bounds() {
    let dir = tempfile::tempdir().unwrap();
    let scene = corridor();
    let mut file = bake(&scene, &cells());
    file.save(&dir.path().join("plain.pvs")).unwrap();
    // Each cell's bound: its set and the last room's crate (in no set of the first room).
    let last_crate = scene
        .objects
        .iter()
        .position(|o| o.name == format!("Level/Room{}/Crate", ROOMS - 1))
        .unwrap();
    let table = file.objects.clone().unwrap();
    for c in &mut file.cells {
        let mut bound = c.visible.clone();
        for (t, &o) in table.object_of_triangle.iter().enumerate() {
            if o as usize == last_crate {
                bound.insert(t);
            }
        }
        c.bound = Some(bound);
    }
    file.save(&dir.path().join("bound.pvs")).unwrap();
    let pvs = Pvs::open(dir.path().join("bound.pvs")).unwrap();
    assert!(!pvs
        .visible_objects(0)
        .unwrap()
        .contains(&(last_crate as u32)));

    let mut app = app(dir.path());
    let tied: Vec<Tied> = (0..pvs.object_count())
        .map(|o| spawn_tied(&mut app, o, Visibility::Inherited))
        .collect();
    let room_0 = Transform::from_xyz(5.0, 1.7, 5.0);
    let bound: Handle<PvsAsset> = app.world().resource::<AssetServer>().load("bound.pvs");
    assert!(matches!(wait_for(&mut app, &bound), LoadState::Loaded));
    let camera = app
        .world_mut()
        .spawn((SightlineCamera::new(bound.clone()).with_bound(), room_0))
        .id();
    app.update();
    let mut want = vec![false; pvs.object_count() as usize];
    for o in pvs.bound_objects(0).unwrap() {
        want[o as usize] = true;
    }
    assert!(want[last_crate]);
    check_frame(&app, &tied, Some(&want), "bound of cell 0");
    // The same camera on its sampled set hides the crate again.
    app.world_mut()
        .get_mut::<SightlineCamera>(camera)
        .unwrap()
        .use_bound = false;
    app.update();
    let sampled = union(&pvs, &[Some(0)]).unwrap();
    assert!(!sampled[last_crate]);
    check_frame(&app, &tied, Some(&sampled), "set of cell 0");
    // A file without bounds draws everything.
    let plain: Handle<PvsAsset> = app.world().resource::<AssetServer>().load("plain.pvs");
    assert!(matches!(wait_for(&mut app, &plain), LoadState::Loaded));
    *app.world_mut().get_mut::<SightlineCamera>(camera).unwrap() =
        SightlineCamera::new(plain).with_bound();
    app.update();
    check_frame(&app, &tied, None, "bound asked of a file without");
    let stats = app.world().resource::<SightlineStats>();
    let error = stats.last_error.as_deref().unwrap_or("");
    assert!(error.contains("no conservative bounds"), "{stats:?}");
}
