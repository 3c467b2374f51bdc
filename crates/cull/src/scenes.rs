//! Procedural scenes recreating the thesis' test scenes, with per-object motion, depth pre-pass
//! classes and a default camera path. Z up, metres.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, section 5.2: The Grid (an indoor maze of rooms and corridors repeated in a grid
//! pattern, about 130 x 12 x 210 m, two floors) and Teapot Graveyard (a large outdoor area of
//! terrain pieces, buildings and many teapots); section 4.3.2 for the classes (walls and
//! terrain always, teapots and vehicles sometimes, lamps never).

use std::f32::consts::TAU;

use glam::Vec3;
use sightline_core::random::SplitMix64;
use sightline_core::scene::SceneBuilder;
use sightline_core::{Aabb, Camera, Scene, UpAxis};

use crate::scheduler::DepthClass;

/// An object's motion: its vertices are offset by `amplitude * sin(TAU * t / period + phase)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Direction and size of the swing.
    pub amplitude: Vec3,
    /// Seconds per swing.
    pub period: f32,
    /// Phase in radians.
    pub phase: f32,
}

impl Motion {
    /// The offset at time `t` seconds.
    pub fn offset(&self, t: f32) -> Vec3 {
        self.amplitude * (TAU * t / self.period + self.phase).sin()
    }
}

/// A camera path: key points walked at constant speed, with a sideways look sway.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    /// Eye positions visited in order.
    pub keys: Vec<Vec3>,
    /// Walking speed in metres per second.
    pub speed: f32,
    /// Amplitude of the yaw sway in degrees (looking around while walking).
    pub sway_deg: f32,
    /// Seconds per sway.
    pub sway_period: f32,
}

impl CameraPath {
    /// Eye and view direction at time `t` (the path stops at its last key).
    pub fn pose(&self, t: f32) -> (Vec3, Vec3) {
        let mut left = t * self.speed;
        for w in self.keys.windows(2) {
            let seg = w[1] - w[0];
            let len = seg.length();
            if left <= len || len == 0.0 {
                let dir = seg.normalize_or(Vec3::X);
                let eye = w[0] + dir * left.min(len);
                return (eye, self.sway(dir, t));
            }
            left -= len;
        }
        let n = self.keys.len();
        let eye = self.keys.last().copied().unwrap_or(Vec3::ZERO);
        let dir = if n >= 2 {
            (self.keys[n - 1] - self.keys[n - 2]).normalize_or(Vec3::X)
        } else {
            Vec3::X
        };
        (eye, self.sway(dir, t))
    }

    fn sway(&self, dir: Vec3, t: f32) -> Vec3 {
        let yaw = self.sway_deg.to_radians() * (TAU * t / self.sway_period).sin();
        let (s, c) = yaw.sin_cos();
        Vec3::new(dir.x * c - dir.y * s, dir.x * s + dir.y * c, dir.z)
    }

    /// The camera at time `t`.
    pub fn camera(&self, t: f32, width: u32, height: u32, fov_y_deg: f32) -> Option<Camera> {
        let (eye, dir) = self.pose(t);
        Camera::looking(eye, dir, Vec3::Z, fov_y_deg, width, height, 0.1).ok()
    }
}

/// A scene for run-time culling: geometry, per-object motion and class, a grid cell size and
/// a default camera path.
#[derive(Clone, Debug)]
pub struct CullScene {
    /// The geometry at time 0.
    pub scene: Scene,
    /// Per object: its motion, `None` for static objects.
    pub motion: Vec<Option<Motion>>,
    /// Per object: its depth pre-pass class.
    pub class: Vec<DepthClass>,
    /// Bounds every object stays inside while moving (the grid's bounds).
    pub bounds: Aabb,
    /// Suggested grid cell size.
    pub cell_size: Vec3,
    /// The default camera path.
    pub path: CameraPath,
}

struct Build {
    b: SceneBuilder,
    motion: Vec<Option<Motion>>,
    class: Vec<DepthClass>,
}

impl Build {
    fn new(name: &str) -> Self {
        let mut b = SceneBuilder::new(format!("procedural:{name}"));
        b.set_up(UpAxis::Z);
        Self {
            b,
            motion: Vec::new(),
            class: Vec::new(),
        }
    }

    fn add_box(&mut self, name: &str, min: Vec3, max: Vec3, class: DepthClass, m: Option<Motion>) {
        self.b.begin_object(name);
        self.b.add_box(min, max);
        self.motion.push(m);
        self.class.push(class);
    }
}

fn random_motion(rng: &mut SplitMix64, reach: f32) -> Motion {
    let axis = if rng.below(2) == 0 { Vec3::X } else { Vec3::Y };
    Motion {
        amplitude: axis * rng.range_f32(0.5, reach),
        period: rng.range_f32(2.0, 6.0),
        phase: rng.range_f32(0.0, TAU),
    }
}

/// The Grid: `8 x 12` rooms of 15 m on two floors of 6 m (120 x 180 x 12 m), walls with a
/// doorway in the middle of every inner wall, and `per_room` moving boxes (0.3-1.2 m) in each
/// room. The camera walks along the ground floor through the doorways, looking around.
pub fn the_grid(seed: u64, per_room: usize) -> CullScene {
    const ROOM: f32 = 15.0;
    const FLOOR_H: f32 = 6.0;
    const T: f32 = 0.25;
    const DOOR: f32 = 1.6;
    const DOOR_H: f32 = 3.0;
    let (nx, ny, nf) = (8usize, 12usize, 2usize);
    let mut s = Build::new("grid");
    let mut rng = SplitMix64::new(seed);
    let always = DepthClass::Always;
    for f in 0..nf {
        let z0 = f as f32 * FLOOR_H;
        let z1 = z0 + FLOOR_H;
        // Floor slab per room.
        for i in 0..nx {
            for j in 0..ny {
                let (x, y) = (i as f32 * ROOM, j as f32 * ROOM);
                s.add_box(
                    "floor",
                    Vec3::new(x, y, z0 - T),
                    Vec3::new(x + ROOM, y + ROOM, z0),
                    always,
                    None,
                );
            }
        }
        // Walls: along x at y = j * ROOM and along y at x = i * ROOM, one piece per room side.
        for horizontal in [true, false] {
            let (lines, segs) = if horizontal {
                (ny + 1, nx)
            } else {
                (nx + 1, ny)
            };
            for l in 0..lines {
                for g in 0..segs {
                    let outer = l == 0 || l == lines - 1;
                    let c = l as f32 * ROOM;
                    let a = g as f32 * ROOM;
                    let mid = a + ROOM * 0.5;
                    let mut pieces = Vec::new();
                    if outer {
                        pieces.push((a, a + ROOM, z0, z1));
                    } else {
                        pieces.push((a, mid - DOOR, z0, z1));
                        pieces.push((mid + DOOR, a + ROOM, z0, z1));
                        pieces.push((mid - DOOR, mid + DOOR, z0 + DOOR_H, z1));
                    }
                    for (u0, u1, w0, w1) in pieces {
                        let (min, max) = if horizontal {
                            (Vec3::new(u0, c - T, w0), Vec3::new(u1, c + T, w1))
                        } else {
                            (Vec3::new(c - T, u0, w0), Vec3::new(c + T, u1, w1))
                        };
                        s.add_box("wall", min, max, always, None);
                    }
                }
            }
        }
        // Moving boxes in every room, clear of the walls by their swing.
        for i in 0..nx {
            for j in 0..ny {
                for _ in 0..per_room {
                    let h = Vec3::new(
                        rng.range_f32(0.15, 0.6),
                        rng.range_f32(0.15, 0.6),
                        rng.range_f32(0.15, 0.6),
                    );
                    let m = random_motion(&mut rng, 2.5);
                    let margin = 1.0 + h.max_element() + m.amplitude.length();
                    let c = Vec3::new(
                        i as f32 * ROOM + rng.range_f32(margin, ROOM - margin),
                        j as f32 * ROOM + rng.range_f32(margin, ROOM - margin),
                        z0 + h.z + rng.range_f32(0.0, 2.5),
                    );
                    s.add_box("mover", c - h, c + h, DepthClass::Sometimes, Some(m));
                }
            }
        }
    }
    let at = |i: usize, j: usize| Vec3::new((i as f32 + 0.5) * ROOM, (j as f32 + 0.5) * ROOM, 1.7);
    let path = CameraPath {
        keys: vec![at(0, 0), at(0, 11), at(7, 11), at(7, 0), at(3, 0), at(3, 6)],
        speed: 5.0,
        sway_deg: 70.0,
        sway_period: 6.0,
    };
    let bounds = Aabb::new(
        Vec3::new(-1.0, -1.0, -1.0),
        Vec3::new(
            nx as f32 * ROOM + 1.0,
            ny as f32 * ROOM + 1.0,
            nf as f32 * FLOOR_H + 1.0,
        ),
    );
    CullScene {
        scene: s.b.finish(),
        motion: s.motion,
        class: s.class,
        bounds,
        // Seletsky 2013, section 5.4.1: The Grid ran with 3 m cells across (finer cells for
        // tight indoor scenes, section 4.3.4); vertically one cell per 6 m floor (the bounds
        // -1..13 split at z = 6, where the upper floor starts).
        cell_size: Vec3::new(3.0, 3.0, 7.0),
        path,
    }
}

/// Teapot Graveyard: a 400 m square of 10 x 10 terrain tiles, 80 buildings, `teapots` objects
/// of about 1 m (a third of them moving) and as many small lamps (never in the pre-pass).
/// The camera walks across at eye height, looking around.
pub fn graveyard(seed: u64, teapots: usize) -> CullScene {
    const SIZE: f32 = 400.0;
    let mut s = Build::new("graveyard");
    let mut rng = SplitMix64::new(seed);
    let tile = SIZE / 10.0;
    for i in 0..10 {
        for j in 0..10 {
            let (x, y) = (i as f32 * tile, j as f32 * tile);
            s.add_box(
                "terrain",
                Vec3::new(x, y, -1.0),
                Vec3::new(x + tile, y + tile, rng.range_f32(-0.2, 0.0)),
                DepthClass::Always,
                None,
            );
        }
    }
    for _ in 0..80 {
        let c = Vec3::new(
            rng.range_f32(20.0, SIZE - 20.0),
            rng.range_f32(20.0, SIZE - 20.0),
            0.0,
        );
        // Keep the camera's corridor (y around 200) free.
        if (c.y - 200.0).abs() < 14.0 {
            continue;
        }
        let h = Vec3::new(rng.range_f32(4.0, 14.0), rng.range_f32(4.0, 14.0), 0.0);
        let top = rng.range_f32(6.0, 30.0);
        s.add_box(
            "building",
            c - h,
            c + h + Vec3::Z * top,
            DepthClass::Always,
            None,
        );
    }
    for k in 0..teapots {
        let c = Vec3::new(
            rng.range_f32(5.0, SIZE - 5.0),
            rng.range_f32(5.0, SIZE - 5.0),
            0.5,
        );
        let h = Vec3::splat(rng.range_f32(0.3, 0.8));
        let m = (k % 3 == 0).then(|| random_motion(&mut rng, 3.0));
        s.add_box("teapot", c - h, c + h, DepthClass::Sometimes, m);
        let l = Vec3::new(
            rng.range_f32(5.0, SIZE - 5.0),
            rng.range_f32(5.0, SIZE - 5.0),
            1.0,
        );
        s.add_box(
            "lamp",
            l - Vec3::new(0.1, 0.1, 1.0),
            l + Vec3::new(0.1, 0.1, 1.0),
            DepthClass::Never,
            None,
        );
    }
    let path = CameraPath {
        keys: vec![Vec3::new(10.0, 200.0, 1.7), Vec3::new(390.0, 200.0, 1.7)],
        speed: 6.0,
        sway_deg: 80.0,
        sway_period: 8.0,
    };
    CullScene {
        scene: s.b.finish(),
        motion: s.motion,
        class: s.class,
        bounds: Aabb::new(
            Vec3::new(-5.0, -5.0, -2.0),
            Vec3::new(SIZE + 5.0, SIZE + 5.0, 40.0),
        ),
        cell_size: Vec3::new(20.0, 20.0, 42.0),
        path,
    }
}

/// Makes any scene a culling scene, so that loaded scenes (the city, Quake 3 maps, files) can
/// be simulated with moving objects. Deterministic rules, with `D` the scene's bounding-box
/// diagonal and `d` an object's:
/// - motion: objects with `d < D / 50` sway along a horizontal axis (alternating between the
///   two axes perpendicular to the scene's up axis by object index), amplitude `d / 2`, period
///   `2 + (index mod 5)` seconds, phase `index * 2.4` radians; larger objects stay put;
/// - depth pre-pass class: `d >= D / 10` always, `d >= D / 100` sometimes, smaller never;
/// - grid: the scene's bounds grown by the largest swing, cells of about `1/48` of the bounds'
///   longest side on each axis;
/// - camera path: a walk along the longer horizontal axis through the centre, from 10 % to
///   90 % of it, at 30 % of the height, 60 s long, looking around by up to 40 degrees (a Z-up
///   [`CameraPath`]; for Y-up scenes callers build their own cameras from
///   [`walk_keys`], see the CLI).
pub fn animate(scene: Scene) -> CullScene {
    let bounds = scene.bounds();
    let diag = bounds.diagonal().max(1e-6);
    let up = scene.up.vector();
    let (h1, h2) = match scene.up {
        UpAxis::X => (Vec3::Y, Vec3::Z),
        UpAxis::Z => (Vec3::X, Vec3::Y),
        UpAxis::Y => (Vec3::X, Vec3::Z),
    };
    let boxes: Vec<Aabb> = scene
        .triangles_by_object()
        .iter()
        .map(|ts| Aabb::from_points(ts.iter().flat_map(|&t| scene.triangle(t))))
        .collect();
    let mut motion = Vec::with_capacity(boxes.len());
    let mut class = Vec::with_capacity(boxes.len());
    let mut reach = 0.0f32;
    for (o, b) in boxes.iter().enumerate() {
        let d = if b.is_empty() { 0.0 } else { b.diagonal() };
        class.push(if d >= diag / 10.0 {
            DepthClass::Always
        } else if d >= diag / 100.0 {
            DepthClass::Sometimes
        } else {
            DepthClass::Never
        });
        let m = (d > 0.0 && d < diag / 50.0).then(|| Motion {
            amplitude: if o % 2 == 0 { h1 } else { h2 } * (0.5 * d),
            period: 2.0 + (o % 5) as f32,
            phase: (o as f32 * 2.4) % TAU,
        });
        if let Some(m) = &m {
            reach = reach.max(m.amplitude.length());
        }
        motion.push(m);
    }
    let grown = Aabb::new(
        bounds.min - Vec3::splat(reach + 1e-3 * diag),
        bounds.max + Vec3::splat(reach + 1e-3 * diag),
    );
    let cell = grown.extent().max_element() / 48.0;
    let (start, end) = walk_keys(&bounds, up);
    let path = CameraPath {
        keys: vec![start, end],
        speed: (end - start).length() / 60.0,
        sway_deg: 40.0,
        sway_period: 8.0,
    };
    CullScene {
        scene,
        motion,
        class,
        bounds: grown,
        cell_size: Vec3::splat(cell.max(1e-4)),
        path,
    }
}

/// Start and end of the default walk through `bounds` (see [`animate`]).
pub fn walk_keys(bounds: &Aabb, up: Vec3) -> (Vec3, Vec3) {
    let e = bounds.extent();
    let c = bounds.center();
    // The longer horizontal axis.
    let (a, b) = if up == Vec3::Z { (0, 1) } else { (0, 2) };
    let axis = if e[a] >= e[b] { a } else { b };
    let k = if up == Vec3::Z { 2 } else { 1 };
    let mut start = c;
    start[k] = bounds.min[k] + 0.3 * e[k];
    let mut end = start;
    start[axis] = bounds.min[axis] + 0.1 * e[axis];
    end[axis] = bounds.min[axis] + 0.9 * e[axis];
    (start, end)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_scene_has_one_motion_and_class_per_object() {
        let s = the_grid(1, 2);
        assert_eq!(s.motion.len(), s.scene.objects.len());
        assert_eq!(s.class.len(), s.scene.objects.len());
        assert!(s.motion.iter().any(Option::is_some));
        assert!(s.bounds.contains(s.scene.bounds().min));
    }

    #[test]
    fn animate_moves_small_objects_and_keeps_them_in_bounds() {
        let s = the_grid(3, 1);
        let n = s.scene.objects.len();
        let a = animate(s.scene);
        assert_eq!((a.motion.len(), a.class.len()), (n, n));
        // Movers (about 1 m) are small against the 217 m diagonal, walls are not all small.
        let moving = a.motion.iter().filter(|m| m.is_some()).count();
        assert!(moving > 0 && moving < n, "{moving} of {n}");
        for m in a.motion.iter().flatten() {
            assert!(a.bounds.contains(a.scene.bounds().min - m.amplitude.abs()));
        }
        let (p, q) = walk_keys(&a.scene.bounds(), Vec3::Z);
        assert!(a.scene.bounds().contains(p) && a.scene.bounds().contains(q) && p != q);
    }

    #[test]
    fn graveyard_with_no_teapots_has_terrain_and_buildings() {
        let s = graveyard(1, 0);
        assert!(s.scene.objects.len() >= 100);
        assert!(s.motion.iter().all(Option::is_none));
    }

    #[test]
    fn path_walks_at_its_speed_and_stops_at_the_end() {
        let p = CameraPath {
            keys: vec![Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)],
            speed: 2.0,
            sway_deg: 0.0,
            sway_period: 1.0,
        };
        assert!((p.pose(2.5).0.x - 5.0).abs() < 1e-5);
        assert_eq!(p.pose(100.0).0, Vec3::new(10.0, 0.0, 0.0));
        assert!(p.camera(1.0, 16, 16, 60.0).is_some());
    }
}
