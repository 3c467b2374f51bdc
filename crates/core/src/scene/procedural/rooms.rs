//! `rooms`: one storey of `R x R` rooms joined by doors, with furniture — an indoor scene with
//! strong occlusion between cells (the kind of scene portal-based PVS tools are made for).
//! Z up, metres.
//!
//! Every wall between two rooms has one door (a 1 m gap with a lintel above); outer walls are
//! closed. Walls are thin boxes, each wall segment one object; each room's floor, ceiling and
//! furniture boxes form one object. `R` and the furniture count per room are chosen so the
//! triangle count is close to `size`.

use glam::Vec3;

use super::shapes::{add_box_on_floor, add_quad};
use crate::random::SplitMix64;
use crate::scene::builder::SceneBuilder;
use crate::scene::types::UpAxis;

const ROOM: f32 = 6.0;
const WALL: f32 = 0.2;
const HEIGHT: f32 = 3.0;
const DOOR: f32 = 1.0;
const DOOR_HEIGHT: f32 = 2.2;
/// Triangles of a room without furniture: floor + ceiling (4) and two walls with a door
/// (2 side segments + lintel = 3 boxes of 10 triangles each).
const BASE_TRIANGLES_PER_ROOM: usize = 4 + 2 * 30;

pub(super) fn generate(b: &mut SceneBuilder, seed: u64, size: usize) {
    b.set_up(UpAxis::Z);
    // Aim for roughly 6 furniture boxes (60 triangles) per room.
    let rooms_per_side = ((size as f64 / (BASE_TRIANGLES_PER_ROOM + 60) as f64)
        .sqrt()
        .round() as usize)
        .max(2);
    let rooms = rooms_per_side * rooms_per_side;
    let furniture_budget = size.saturating_sub(rooms * BASE_TRIANGLES_PER_ROOM);
    let furniture_per_room = furniture_budget / (rooms * 10);
    let mut rng = SplitMix64::new(seed);
    let n = rooms_per_side;
    let span = n as f32 * ROOM;
    for ry in 0..n {
        for rx in 0..n {
            let (x0, y0) = (rx as f32 * ROOM, ry as f32 * ROOM);
            b.begin_object(format!("room{rx}_{ry}"));
            let lo = Vec3::new(x0, y0, 0.0);
            let hi = Vec3::new(x0 + ROOM, y0 + ROOM, 0.0);
            add_quad(
                b,
                lo,
                Vec3::new(hi.x, lo.y, 0.0),
                hi,
                Vec3::new(lo.x, hi.y, 0.0),
            );
            let c = HEIGHT;
            // Ceiling faces down (into the room).
            add_quad(
                b,
                Vec3::new(lo.x, lo.y, c),
                Vec3::new(lo.x, hi.y, c),
                Vec3::new(hi.x, hi.y, c),
                Vec3::new(hi.x, lo.y, c),
            );
            for _ in 0..furniture_per_room {
                let w = rng.range_f32(0.4, 1.5);
                let d = rng.range_f32(0.4, 1.5);
                let h = rng.range_f32(0.4, 2.0);
                let fx = x0 + WALL + rng.next_f32() * (ROOM - 2.0 * WALL - w);
                let fy = y0 + WALL + rng.next_f32() * (ROOM - 2.0 * WALL - d);
                add_box_on_floor(b, Vec3::new(fx, fy, 0.0), Vec3::new(fx + w, fy + d, h));
            }
            // Wall on this room's -x side (between rx-1 and rx) and -y side; outer walls closed.
            let door_x = rx > 0;
            let door_y = ry > 0;
            wall(
                b,
                &mut rng,
                format!("wall_x{rx}_{ry}"),
                Axis::X,
                x0,
                y0,
                ROOM,
                door_x,
            );
            wall(
                b,
                &mut rng,
                format!("wall_y{rx}_{ry}"),
                Axis::Y,
                y0,
                x0,
                ROOM,
                door_y,
            );
        }
    }
    // Closing walls on the +x and +y borders.
    for r in 0..n {
        let t = r as f32 * ROOM;
        wall(
            b,
            &mut rng,
            format!("wall_x{n}_{r}"),
            Axis::X,
            span,
            t,
            ROOM,
            false,
        );
        wall(
            b,
            &mut rng,
            format!("wall_y{r}_{n}"),
            Axis::Y,
            span,
            t,
            ROOM,
            false,
        );
    }
}

#[derive(Clone, Copy)]
enum Axis {
    /// A wall in the plane x = const, running along y.
    X,
    /// A wall in the plane y = const, running along x.
    Y,
}

/// A wall at `across` (plane coordinate) from `along` to `along + length`, with an optional
/// door at a random place, as boxes: one box without a door, else two side pieces and a lintel.
#[allow(clippy::too_many_arguments)]
fn wall(
    b: &mut SceneBuilder,
    rng: &mut SplitMix64,
    name: String,
    axis: Axis,
    across: f32,
    along: f32,
    length: f32,
    door: bool,
) {
    b.begin_object(name);
    let mut piece = |a0: f32, a1: f32, z0: f32, z1: f32| {
        let (min, max) = match axis {
            Axis::X => (
                Vec3::new(across - WALL * 0.5, a0, z0),
                Vec3::new(across + WALL * 0.5, a1, z1),
            ),
            Axis::Y => (
                Vec3::new(a0, across - WALL * 0.5, z0),
                Vec3::new(a1, across + WALL * 0.5, z1),
            ),
        };
        if z0 == 0.0 {
            add_box_on_floor(b, min, max);
        } else {
            // A lintel is seen from below, so it keeps its bottom face.
            b.add_box(min, max);
        }
    };
    if !door {
        piece(along, along + length, 0.0, HEIGHT);
        return;
    }
    let d0 = along + rng.range_f32(0.6, length - DOOR - 0.6);
    piece(along, d0, 0.0, HEIGHT);
    piece(d0 + DOOR, along + length, 0.0, HEIGHT);
    piece(d0, d0 + DOOR, DOOR_HEIGHT, HEIGHT);
}
