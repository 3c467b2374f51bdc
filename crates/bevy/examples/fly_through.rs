//! Flies a camera through a glTF level with its baked `.pvs` culling the level's meshes, and
//! shows how many are drawn.
//!
//! ```sh
//! sightline pvs bake level.glb --grid 8,1,8 -o level.pvs
//! cargo run --release -p bevy_sightline --example fly_through --features viewer -- level.glb level.pvs
//! ```
//!
//! By default the camera flies from cell to cell in index order. Keys: Space switches to
//! manual flight (WASD, Q/E down/up, Shift faster, mouse look with the right button held) and
//! back; C turns the culling off and on.

use std::path::{Path, PathBuf};

use bevy::asset::UnapprovedPathMode;
use bevy::input::mouse::AccumulatedMouseMotion;
use bevy::prelude::*;
use bevy_sightline::{PvsAsset, SightlineCamera, SightlineLevel, SightlinePlugin, SightlineStats};

#[derive(Resource)]
struct Level {
    pvs: Handle<PvsAsset>,
}

#[derive(Component)]
struct Flyer {
    auto: bool,
    /// Position along the path of cell centres, in cells.
    along: f32,
    yaw: f32,
    pitch: f32,
}

#[derive(Component)]
struct Counts;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [gltf, pvs] = args.as_slice() else {
        eprintln!("usage: fly_through LEVEL.glb LEVEL.pvs");
        std::process::exit(2);
    };
    let absolute = |p: &str| -> PathBuf {
        std::fs::canonicalize(p).unwrap_or_else(|e| {
            eprintln!("fly_through: {p}: {e}");
            std::process::exit(1);
        })
    };
    let (gltf, pvs) = (absolute(gltf), absolute(pvs));
    // Assets are read from the glTF file's folder; the .pvs may lie anywhere.
    let folder = gltf.parent().unwrap_or(Path::new("/")).to_path_buf();
    App::new()
        .add_plugins((
            DefaultPlugins.set(AssetPlugin {
                file_path: folder.display().to_string(),
                unapproved_path_mode: UnapprovedPathMode::Allow,
                ..default()
            }),
            SightlinePlugin,
        ))
        .insert_resource(Paths { gltf, pvs })
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, fly, show_counts))
        .run();
}

#[derive(Resource)]
struct Paths {
    gltf: PathBuf,
    pvs: PathBuf,
}

fn setup(mut commands: Commands, assets: Res<AssetServer>, paths: Res<Paths>) {
    let pvs: Handle<PvsAsset> = assets.load(paths.pvs.clone());
    commands.spawn((
        WorldAssetRoot(assets.load(GltfAssetLabel::Scene(0).from_asset(paths.gltf.clone()))),
        SightlineLevel::gltf(pvs.clone()),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 8_000.0,
            shadow_maps_enabled: false,
            ..default()
        },
        Transform::from_xyz(1.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.insert_resource(GlobalAmbientLight {
        brightness: 400.0,
        ..default()
    });
    commands.spawn((
        Camera3d::default(),
        SightlineCamera::new(pvs.clone()),
        Transform::default(),
        Flyer {
            auto: true,
            along: 0.0,
            yaw: 0.0,
            pitch: 0.0,
        },
    ));
    commands.spawn((
        Text::new("loading"),
        Node {
            position_type: PositionType::Absolute,
            top: px(8),
            left: px(8),
            ..default()
        },
        Counts,
    ));
    commands.insert_resource(Level { pvs });
}

fn keys(input: Res<ButtonInput<KeyCode>>, mut cameras: Query<(&mut Flyer, &mut SightlineCamera)>) {
    for (mut flyer, mut camera) in &mut cameras {
        if input.just_pressed(KeyCode::Space) {
            flyer.auto = !flyer.auto;
        }
        if input.just_pressed(KeyCode::KeyC) {
            camera.enabled = !camera.enabled;
        }
    }
}

fn fly(
    time: Res<Time>,
    input: Res<ButtonInput<KeyCode>>,
    mouse: Res<ButtonInput<MouseButton>>,
    motion: Res<AccumulatedMouseMotion>,
    level: Res<Level>,
    files: Res<Assets<PvsAsset>>,
    mut cameras: Query<(&mut Flyer, &mut Transform)>,
) {
    let dt = time.delta_secs();
    for (mut flyer, mut transform) in &mut cameras {
        if flyer.auto {
            // Along the cell centres, 1.5 cells a second, looking at the next centre.
            let Some(pvs) = files.get(&level.pvs) else {
                continue;
            };
            let n = pvs.cell_count();
            if n == 0 {
                continue;
            }
            let centre = |i: u32| {
                pvs.cell(i % n)
                    .map(|c| Vec3::from_array(c.center))
                    .unwrap_or_default()
            };
            flyer.along = (flyer.along + 1.5 * dt) % n as f32;
            let i = flyer.along.floor() as u32;
            let here = centre(i).lerp(centre(i + 1), flyer.along.fract());
            let ahead = centre(i + 1).lerp(centre(i + 2), flyer.along.fract());
            transform.translation = here;
            if ahead.distance_squared(here) > 1e-6 {
                transform.look_at(ahead, Vec3::Y);
            }
            let (yaw, pitch, _) = transform.rotation.to_euler(EulerRot::YXZ);
            (flyer.yaw, flyer.pitch) = (yaw, pitch);
            continue;
        }
        if mouse.pressed(MouseButton::Right) {
            flyer.yaw -= motion.delta.x * 0.003;
            flyer.pitch = (flyer.pitch - motion.delta.y * 0.003).clamp(-1.5, 1.5);
        }
        transform.rotation = Quat::from_euler(EulerRot::YXZ, flyer.yaw, flyer.pitch, 0.0);
        let mut step = Vec3::ZERO;
        for (key, dir) in [
            (KeyCode::KeyW, transform.forward().as_vec3()),
            (KeyCode::KeyS, transform.back().as_vec3()),
            (KeyCode::KeyA, transform.left().as_vec3()),
            (KeyCode::KeyD, transform.right().as_vec3()),
            (KeyCode::KeyE, Vec3::Y),
            (KeyCode::KeyQ, Vec3::NEG_Y),
        ] {
            if input.pressed(key) {
                step += dir;
            }
        }
        let speed = if input.pressed(KeyCode::ShiftLeft) {
            20.0
        } else {
            5.0
        };
        transform.translation += step.normalize_or_zero() * speed * dt;
    }
}

fn show_counts(
    stats: Res<SightlineStats>,
    flyers: Query<(&Flyer, &SightlineCamera)>,
    mut text: Query<&mut Text, With<Counts>>,
) {
    let (mode, culling) = flyers.iter().next().map_or(("", true), |(f, c)| {
        (if f.auto { "auto" } else { "manual" }, c.enabled)
    });
    let cell = match stats.cameras.first() {
        Some((_, Some(c))) => format!("cell {c}"),
        Some((_, None)) => "outside every cell: drawing everything".to_owned(),
        None => "culling off".to_owned(),
    };
    let line = format!(
        "drawn {}/{} meshes, {}/{} objects visible, {} unmatched\n{cell}\n\
         flight: {mode} (Space)   culling: {} (C)",
        stats.drawn,
        stats.total,
        stats.visible_objects,
        stats.object_count,
        stats.unmatched,
        if culling { "on" } else { "off" },
    );
    for mut t in &mut text {
        if t.0 != line {
            t.0.clone_from(&line);
        }
    }
}
