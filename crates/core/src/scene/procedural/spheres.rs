//! `spheres`: random UV spheres ("planets", after the PLANETS scene of Auzinger et al. 2013)
//! in a 100³ volume, one object each.

use glam::Vec3;

use crate::random::SplitMix64;
use crate::scene::builder::SceneBuilder;

const EXTENT: f32 = 100.0;
/// Latitude bands and longitude segments per sphere: 2*24*(12-1) = 528 triangles.
const STACKS: u32 = 12;
const SLICES: u32 = 24;
const TRIANGLES_PER_SPHERE: usize = (2 * SLICES * (STACKS - 1)) as usize;

pub(super) fn generate(b: &mut SceneBuilder, seed: u64, size: usize) {
    let count = (size / TRIANGLES_PER_SPHERE).max(1);
    let mut rng = SplitMix64::new(seed);
    let radius_scale = EXTENT * (0.05 / count as f32).cbrt();
    // Spheres never overlap (the meshes are inscribed in their spheres, so they never
    // intersect): the exact analytic method assumes non-intersecting triangles, and PLANETS is
    // a scene of separate bodies. Rejection sampling over a hash grid of cells one maximal
    // diameter wide, so only neighbouring cells need checking.
    let cell = 2.0 * radius_scale;
    let mut grid: std::collections::HashMap<[i32; 3], Vec<(Vec3, f32)>> = Default::default();
    let key = |p: Vec3| (p / cell).floor().as_ivec3().to_array();
    for i in 0..count {
        let mut radius = radius_scale * rng.range_f32(0.4, 1.0);
        let center = loop {
            let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * EXTENT;
            let k = key(c);
            let mut free = true;
            'search: for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let n = [k[0] + dx, k[1] + dy, k[2] + dz];
                        for &(q, r) in grid.get(&n).map(Vec::as_slice).unwrap_or(&[]) {
                            if q.distance(c) <= r + radius {
                                free = false;
                                break 'search;
                            }
                        }
                    }
                }
            }
            if free {
                break c;
            }
            // Crowded: try again a little smaller (the loop ends: radius shrinks to nothing).
            radius *= 0.98;
        };
        grid.entry(key(center)).or_default().push((center, radius));
        b.begin_object(format!("sphere{i}"));
        add_uv_sphere(b, center, radius);
    }
}

/// A UV sphere with poles on ±Z, outward-facing triangles; poles are single vertices so no
/// degenerate triangles appear.
fn add_uv_sphere(b: &mut SceneBuilder, center: Vec3, radius: f32) {
    let north = b.add_vertex(center + Vec3::Z * radius);
    let ring0 = b.vertex_count();
    for stack in 1..STACKS {
        let theta = std::f32::consts::PI * stack as f32 / STACKS as f32;
        for slice in 0..SLICES {
            let phi = std::f32::consts::TAU * slice as f32 / SLICES as f32;
            let dir = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            b.add_vertex(center + dir * radius);
        }
    }
    let south = b.add_vertex(center - Vec3::Z * radius);
    let at = |stack: u32, slice: u32| ring0 + (stack - 1) * SLICES + slice % SLICES;
    for s in 0..SLICES {
        b.add_triangle([north, at(1, s), at(1, s + 1)]);
    }
    for stack in 1..STACKS - 1 {
        for s in 0..SLICES {
            let (a, c) = (at(stack, s), at(stack, s + 1));
            let (d, e) = (at(stack + 1, s), at(stack + 1, s + 1));
            b.add_triangle([a, d, e]);
            b.add_triangle([a, e, c]);
        }
    }
    for s in 0..SLICES {
        b.add_triangle([south, at(STACKS - 1, s + 1), at(STACKS - 1, s)]);
    }
}
