//! Random occluder scenes in a 100 m square (a ground, buildings, slanted walls), random
//! cameras over them and random boxes to test against them: the inputs of the conservative
//! occlusion tests of the software buffer (`sightline-cull`) and the GPU queries
//! (`sightline-gpu`), which compare against the reference rasterizer's exact depth test.

use glam::Vec3;
use sightline_core::random::SplitMix64;
use sightline_core::scene::SceneBuilder;
use sightline_core::{Aabb, Camera, Scene};

/// The ground under the occluders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ground {
    /// One quad at z = 0 (two triangles, no thickness).
    Quad,
    /// A box half a metre thick with its top at z = 0.
    Slab,
}

/// Adds a box whose six faces are each split into `k x k` quads: occluders of many small
/// triangles with shared edges, which exercises the merging of partial coverage within tiles,
/// and where a crack in a rasterizer's coverage would show a box behind.
pub fn add_tessellated_box(b: &mut SceneBuilder, min: Vec3, max: Vec3, k: u32) {
    let size = max - min;
    for axis in 0..3 {
        for side in [0.0f32, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |i: u32, j: u32| {
                let mut p = min;
                p[axis] += side * size[axis];
                p[u] += size[u] * i as f32 / k as f32;
                p[v] += size[v] * j as f32 / k as f32;
                p
            };
            for i in 0..k {
                for j in 0..k {
                    let q = [
                        b.add_vertex(corner(i, j)),
                        b.add_vertex(corner(i + 1, j)),
                        b.add_vertex(corner(i + 1, j + 1)),
                        b.add_vertex(corner(i, j + 1)),
                    ];
                    b.add_triangle([q[0], q[1], q[2]]);
                    b.add_triangle([q[0], q[2], q[3]]);
                }
            }
        }
    }
}

/// Random occluders in a 100 m square: the ground, 40 buildings (every third tessellated into
/// 1 to 6 quads per face edge) and 15 thin walls at random orientations (slanted quads).
pub fn occluder_scene(rng: &mut SplitMix64, ground: Ground) -> Scene {
    let mut b = SceneBuilder::new("occluders");
    match ground {
        Ground::Quad => {
            let g = [
                b.add_vertex(Vec3::new(-60.0, -60.0, 0.0)),
                b.add_vertex(Vec3::new(60.0, -60.0, 0.0)),
                b.add_vertex(Vec3::new(60.0, 60.0, 0.0)),
                b.add_vertex(Vec3::new(-60.0, 60.0, 0.0)),
            ];
            b.add_triangle([g[0], g[1], g[2]]);
            b.add_triangle([g[0], g[2], g[3]]);
        }
        Ground::Slab => b.add_box(Vec3::new(-60.0, -60.0, -0.5), Vec3::new(60.0, 60.0, 0.0)),
    }
    for i in 0..40 {
        let c = Vec3::new(rng.range_f32(-50.0, 50.0), rng.range_f32(-50.0, 50.0), 0.0);
        let h = Vec3::new(rng.range_f32(1.0, 8.0), rng.range_f32(1.0, 8.0), 0.0);
        let top = rng.range_f32(2.0, 25.0);
        let (min, max) = (c - h, c + h + Vec3::Z * top);
        if i % 3 == 0 {
            add_tessellated_box(&mut b, min, max, 1 + rng.below(6) as u32);
        } else {
            b.add_box(min, max);
        }
    }
    for _ in 0..15 {
        let c = Vec3::new(rng.range_f32(-50.0, 50.0), rng.range_f32(-50.0, 50.0), 0.0);
        let d = Vec3::new(rng.range_f32(-8.0, 8.0), rng.range_f32(-8.0, 8.0), 0.0);
        let lean = Vec3::new(rng.range_f32(-3.0, 3.0), rng.range_f32(-3.0, 3.0), 0.0);
        let top = Vec3::Z * rng.range_f32(2.0, 12.0);
        let q = [
            b.add_vertex(c - d),
            b.add_vertex(c + d),
            b.add_vertex(c + d + top + lean),
            b.add_vertex(c - d + top + lean),
        ];
        b.add_triangle([q[0], q[1], q[2]]);
        b.add_triangle([q[0], q[2], q[3]]);
    }
    b.finish()
}

/// A `w x h` camera at a random eye over the square (0.5 to 30 m up) looking at a random point
/// near the ground, field of view 40 to 100 degrees, Z up.
pub fn random_camera(rng: &mut SplitMix64, w: u32, h: u32) -> Camera {
    let eye = Vec3::new(
        rng.range_f32(-55.0, 55.0),
        rng.range_f32(-55.0, 55.0),
        rng.range_f32(0.5, 30.0),
    );
    let target = Vec3::new(
        rng.range_f32(-50.0, 50.0),
        rng.range_f32(-50.0, 50.0),
        rng.range_f32(0.0, 10.0),
    );
    let fov = rng.range_f32(40.0, 100.0);
    Camera::look_at(eye, target, Vec3::Z, fov, w, h, 0.1)
        .expect("a random eye never equals its target nor looks straight down the up axis")
}

/// A random box over the square, 0.1 to 6 m on each side.
pub fn random_box(rng: &mut SplitMix64) -> Aabb {
    let c = Vec3::new(
        rng.range_f32(-55.0, 55.0),
        rng.range_f32(-55.0, 55.0),
        rng.range_f32(0.0, 20.0),
    );
    let h = Vec3::new(
        rng.range_f32(0.05, 3.0),
        rng.range_f32(0.05, 3.0),
        rng.range_f32(0.05, 3.0),
    );
    Aabb::new(c - h, c + h)
}
