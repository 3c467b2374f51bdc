//! `zoneplate`: two superposed zone plates — flat discs of concentric rings whose widths shrink
//! as 1/sqrt(ring), alternate rings solid — one slightly in front of and beside the other, so
//! their rings cross at every scale down to far below a pixel. A robustness test of exact
//! visibility and of anti-aliasing (after the ZONEPLATES scene of Auzinger, Wimmer, Jeschke,
//! Analytic Visibility on the GPU, 2013, figure 5), in the XY plane facing +Z, Z up.

use glam::Vec3;

use crate::scene::builder::SceneBuilder;

/// Rings per plate (half of them solid). Ring `k` spans radii `R sqrt(k / RINGS) ..
/// R sqrt((k + 1) / RINGS)`: equal areas, so outer rings are thin.
const RINGS: usize = 64;
/// Plate radius.
const RADIUS: f32 = 10.0;

pub(super) fn generate(b: &mut SceneBuilder, seed: u64, size: usize) {
    // The seed shifts the second plate, so seeds give different moiré patterns.
    let shift = 0.2 + (seed % 7) as f32 * 0.05;
    let per_plate = (size / 2).max(RINGS);
    let plates = [
        (Vec3::ZERO, "plate0"),
        (
            Vec3::new(shift * RADIUS, 0.1 * RADIUS, 0.05 * RADIUS),
            "plate1",
        ),
    ];
    for (centre, name) in plates {
        b.begin_object(name);
        add_plate(b, centre, per_plate);
    }
}

/// One plate of about `triangles` triangles: each solid ring gets segments in proportion to its
/// mean radius, two triangles per segment.
fn add_plate(b: &mut SceneBuilder, centre: Vec3, triangles: usize) {
    let radius_at = |k: usize| RADIUS * (k as f32 / RINGS as f32).sqrt();
    let solid: Vec<usize> = (0..RINGS).step_by(2).map(|k| k + 1).collect();
    let total_radius: f32 = solid.iter().map(|&k| radius_at(k) + radius_at(k + 1)).sum();
    for &k in &solid {
        let (r0, r1) = (radius_at(k), radius_at(k + 1));
        let share = (r0 + r1) / total_radius;
        let segments = ((share * triangles as f32 / 2.0) as usize).max(8);
        let ring = |r: f32, s: usize| {
            let a = std::f32::consts::TAU * s as f32 / segments as f32;
            centre + Vec3::new(r * a.cos(), r * a.sin(), 0.0)
        };
        let inner0 = b.vertex_count();
        for s in 0..segments {
            b.add_vertex(ring(r0, s));
        }
        let outer0 = b.vertex_count();
        for s in 0..segments {
            b.add_vertex(ring(r1, s));
        }
        for s in 0..segments {
            let t = (s + 1) % segments;
            let (i0, i1) = (inner0 + s as u32, inner0 + t as u32);
            let (o0, o1) = (outer0 + s as u32, outer0 + t as u32);
            // Counter-clockwise seen from +Z.
            b.add_triangle([i0, o0, o1]);
            b.add_triangle([i0, o1, i1]);
        }
    }
}
