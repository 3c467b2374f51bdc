//! Which triangles of a scene form closed solids: triangles welded by bit-identical corner
//! positions, joined across edges that exactly two of them share in opposite directions, and
//! kept as a solid only when every edge of the group is such an edge, or all the edges that
//! only one triangle has lie in one axis plane with the whole group on one side of it (a
//! building without a floor standing on the ground: the plane closes it for every viewpoint
//! on the group's side).
//!
//! Why exact positions: a solid is only trusted where its surface is provably closed, and
//! positions that merely come near each other leave cracks a ray can pass (a group with a
//! T-junction or a near miss is open here, and left alone).

use glam::{DVec3, Vec3};
use sightline_core::Scene;

use super::embedded;

/// The plane that closes a solid whose open edges all lie in it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Cap {
    /// Axis the plane is perpendicular to (0, 1 or 2).
    pub axis: usize,
    /// The plane's coordinate along it.
    pub at: f64,
    /// +1 when the solid lies at or above `at`, -1 when at or below.
    pub side: f64,
}

/// A group of triangles that may form a closed solid (before the check that it does not cut
/// itself, `embedded.rs`).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Candidate {
    /// Its triangles' ids.
    pub triangles: Vec<u32>,
    /// The plane closing it, if it is open.
    pub cap: Option<Cap>,
    /// +1 when the triangles' winding faces out of the solid (positive volume), -1 when in.
    pub orientation: f64,
    /// Its bounding box.
    pub min: DVec3,
    /// Its bounding box.
    pub max: DVec3,
    /// Its volume over its surface area (half the thickness of a slab).
    pub thickness: f64,
}

/// One directed use of an edge: the edge's welded corner ids (smaller first), the triangle,
/// and whether the triangle runs the edge from smaller to larger.
#[derive(Clone, Copy)]
struct EdgeUse {
    key: u64,
    triangle: u32,
    forward: bool,
}

/// Welded corner ids: positions sorted by their bits, equal bits one id.
fn weld(scene: &Scene) -> Vec<u32> {
    let bits = |p: Vec3| (p.x.to_bits(), p.y.to_bits(), p.z.to_bits());
    let mut order: Vec<u32> = (0..scene.positions.len() as u32).collect();
    order.sort_unstable_by_key(|&i| bits(scene.positions[i as usize]));
    let mut id = vec![0u32; scene.positions.len()];
    let mut next = 0u32;
    for (k, &i) in order.iter().enumerate() {
        if k > 0
            && bits(scene.positions[order[k - 1] as usize]) != bits(scene.positions[i as usize])
        {
            next += 1;
        }
        id[i as usize] = next;
    }
    id
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

/// Twice the triangle's area vector in f64 (exact products of f32 inputs, one rounding).
pub(super) fn normal_of(t: &[DVec3; 3]) -> DVec3 {
    (t[1] - t[0]).cross(t[2] - t[0])
}

/// The triangle's corners in f64.
pub(super) fn corners_of(scene: &Scene, id: u32) -> [DVec3; 3] {
    scene.triangle(id).map(|p| p.as_dvec3())
}

/// The groups of `scene` that may be closed solids, in no particular order. Memory while it
/// runs: about 50 bytes per triangle (three edge uses of 16 bytes, the union-find).
pub(super) fn candidates(scene: &Scene) -> Vec<Candidate> {
    let n = scene.triangle_count();
    if n == 0 || scene.positions.len() > u32::MAX as usize {
        return Vec::new();
    }
    let welded = weld(scene);
    let corner_ids = |t: u32| scene.triangles[t as usize].map(|i| welded[i as usize]);
    let (internal, mut state) = internal_walls(n, &corner_ids);
    let mut uses = edge_uses(n, &internal, &corner_ids);
    uses.sort_unstable_by_key(|u| u.key);
    let (mut parent, open_edges) = join_across_edges(scene, &uses, &mut state);
    drop(uses);
    for t in 0..n as u32 {
        let c = scene.triangle(t);
        let area = normal_of(&c.map(|p| p.as_dvec3())).length_squared();
        if area.is_nan() || area <= 0.0 || c.iter().any(|p| !p.is_finite()) {
            state[t as usize] |= BROKEN;
        }
    }

    // Group the triangles by their root.
    let mut roots: Vec<(u32, u32)> = (0..n as u32)
        .filter(|&t| !internal[t as usize])
        .map(|t| (find(&mut parent, t), t))
        .collect();
    drop(parent);
    roots.sort_unstable();
    let mut open_by_triangle = open_edges;
    open_by_triangle.sort_unstable();
    let open_of = |t: u32| -> &[(u32, u64)] {
        let s = open_by_triangle.partition_point(|e| e.0 < t);
        let e = open_by_triangle.partition_point(|e| e.0 <= t);
        &open_by_triangle[s..e]
    };
    let position_of_welded: Vec<u32> = {
        let mut p = vec![0u32; welded.iter().map(|&w| w as usize + 1).max().unwrap_or(0)];
        for (i, &w) in welded.iter().enumerate() {
            p[w as usize] = i as u32;
        }
        p
    };
    let welded_position = |w: u32| scene.positions[position_of_welded[w as usize] as usize];

    let mut out = Vec::new();
    let mut s = 0;
    while s < roots.len() {
        let mut e = s + 1;
        while e < roots.len() && roots[e].0 == roots[s].0 {
            e += 1;
        }
        let triangles: Vec<u32> = roots[s..e].iter().map(|r| r.1).collect();
        s = e;
        if triangles.len() < 4 || triangles.iter().any(|&t| state[t as usize] & BROKEN != 0) {
            continue;
        }
        let open: Vec<u64> = triangles
            .iter()
            .filter(|&&t| state[t as usize] & OPEN != 0)
            .flat_map(|&t| open_of(t).iter().map(|e| e.1))
            .collect();
        let cap = if open.is_empty() {
            None
        } else {
            let corners: Vec<Vec3> = open
                .iter()
                .flat_map(|&key| [(key >> 32) as u32, key as u32])
                .map(welded_position)
                .collect();
            match cap_of(scene, &triangles, &corners, &open, &corner_ids) {
                Some(cap) => Some(cap),
                None => continue,
            }
        };
        if let Some(c) = candidate(scene, triangles, cap) {
            out.push(c);
        }
    }
    out
}

/// Every directed use of an edge by a triangle that is not an internal wall.
fn edge_uses(n: usize, internal: &[bool], corner_ids: &dyn Fn(u32) -> [u32; 3]) -> Vec<EdgeUse> {
    let mut uses: Vec<EdgeUse> = Vec::with_capacity(3 * n);
    for t in 0..n as u32 {
        if internal[t as usize] {
            continue;
        }
        let c = corner_ids(t);
        for e in 0..3 {
            let (a, b) = (c[e], c[(e + 1) % 3]);
            if a == b {
                continue; // a collapsed edge: the triangle is degenerate, rejected below
            }
            let (lo, hi) = (a.min(b), a.max(b));
            uses.push(EdgeUse {
                key: (u64::from(lo) << 32) | u64::from(hi),
                triangle: t,
                forward: a < b,
            });
        }
    }
    uses
}

/// Over edge uses sorted by key: joins (union-find parents) the two triangles of every edge
/// used twice in opposite directions, and marks the triangles of open edges [`OPEN`] (with the
/// edges, by triangle) and those of edges used otherwise [`BROKEN`].
fn join_across_edges(
    scene: &Scene,
    uses: &[EdgeUse],
    state: &mut [u8],
) -> (Vec<u32>, Vec<(u32, u64)>) {
    let mut parent: Vec<u32> = (0..state.len() as u32).collect();
    let mut open_edges: Vec<(u32, u64)> = Vec::new();
    let mut k = 0;
    while k < uses.len() {
        let mut end = k + 1;
        while end < uses.len() && uses[end].key == uses[k].key {
            end += 1;
        }
        let group = &uses[k..end];
        match group {
            [one] => {
                state[one.triangle as usize] |= OPEN;
                open_edges.push((one.triangle, one.key));
            }
            [a, b]
                if a.forward != b.forward
                    && a.triangle != b.triangle
                    && embedded::fold_onto_each_other(
                        &corners_of(scene, a.triangle),
                        &corners_of(scene, b.triangle),
                    ) =>
            {
                // Folded back onto each other (two buildings' walls on one footing): not a
                // surface going on, but where each of two surfaces ends.
                for u in group {
                    state[u.triangle as usize] |= OPEN;
                    open_edges.push((u.triangle, u.key));
                }
            }
            [a, b] if a.forward != b.forward && a.triangle != b.triangle => {
                let (ra, rb) = (find(&mut parent, a.triangle), find(&mut parent, b.triangle));
                if ra != rb {
                    parent[ra as usize] = rb;
                }
            }
            _ => {
                for u in group {
                    state[u.triangle as usize] |= BROKEN;
                }
            }
        }
        k = end;
    }
    (parent, open_edges)
}

/// Per triangle: a state of 0 = fine so far, [`OPEN`] = has an edge no other triangle has,
/// [`BROKEN`] = cannot be part of a solid (an edge shared by three or more, or twice in the
/// same direction; degenerate; the same corners as other triangles but not as a cancelling
/// pair).
const OPEN: u8 = 1;
const BROKEN: u8 = 2;

/// Pairs of triangles with the same three corners wound opposite ways: the wall two abutting
/// buildings share, drawn once for each. As parts of the surface they cancel (the union of
/// the two solids is bounded by the rest), so both are left out of every solid. Returns which
/// triangles are such walls, and the initial state of every triangle (other triangles with
/// repeated corners are broken).
fn internal_walls(n: usize, corner_ids: &dyn Fn(u32) -> [u32; 3]) -> (Vec<bool>, Vec<u8>) {
    // Corners rotated to start at the smallest id (the winding kept), and the winding's hand.
    let canonical = |t: u32| {
        let c = corner_ids(t);
        let k = (0..3).min_by_key(|&k| c[k]).unwrap_or(0);
        let (a, b, c) = (c[k], c[(k + 1) % 3], c[(k + 2) % 3]);
        if b < c {
            ([a, b, c], true)
        } else {
            ([a, c, b], false)
        }
    };
    let mut order: Vec<([u32; 3], bool, u32)> = (0..n as u32)
        .map(|t| {
            let (key, hand) = canonical(t);
            (key, hand, t)
        })
        .collect();
    order.sort_unstable();
    let mut internal = vec![false; n];
    let mut state = vec![0u8; n];
    let mut k = 0;
    while k < order.len() {
        let mut end = k + 1;
        while end < order.len() && order[end].0 == order[k].0 {
            end += 1;
        }
        match &order[k..end] {
            [_] => {}
            [a, b] if a.1 != b.1 => {
                internal[a.2 as usize] = true;
                internal[b.2 as usize] = true;
            }
            group => {
                for g in group {
                    state[g.2 as usize] |= BROKEN;
                }
            }
        }
        k = end;
    }
    (internal, state)
}

/// The axis plane holding every open edge of a group, with the group on one side of it and
/// touching it only along those edges; `None` when there is none.
fn cap_of(
    scene: &Scene,
    triangles: &[u32],
    open_corners: &[Vec3],
    open_edges: &[u64],
    corner_ids: &dyn Fn(u32) -> [u32; 3],
) -> Option<Cap> {
    let open_ids: std::collections::HashSet<u32> = open_edges
        .iter()
        .flat_map(|&k| [(k >> 32) as u32, k as u32])
        .collect();
    let open_keys: std::collections::HashSet<u64> = open_edges.iter().copied().collect();
    (0..3).find_map(|axis| {
        let at = open_corners[0][axis];
        if open_corners.iter().any(|p| p[axis] != at) {
            return None;
        }
        let mut side = 0.0f64;
        for &t in triangles {
            let c = scene.triangle(t);
            let ids = corner_ids(t);
            for (k, p) in c.iter().enumerate() {
                let d = p[axis] - at;
                if d == 0.0 {
                    // Only corners of the open edges may touch the plane ...
                    if !open_ids.contains(&ids[k]) {
                        return None;
                    }
                } else {
                    let s = d.signum() as f64;
                    if side == 0.0 {
                        side = s;
                    } else if side != s {
                        return None;
                    }
                }
            }
            // ... and of the group's edges only the open ones may lie in it.
            for e in 0..3 {
                let (a, b) = (ids[e], ids[(e + 1) % 3]);
                let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
                if c[e][axis] == at && c[(e + 1) % 3][axis] == at && !open_keys.contains(&key) {
                    return None;
                }
            }
        }
        (side != 0.0).then_some(Cap {
            axis,
            at: f64::from(at),
            side,
        })
    })
}

/// The group as a candidate solid: its orientation from its signed volume (taken from a
/// point of the cap plane, where the cap adds none), its bounds; `None` when the volume is
/// too small to tell the orientation.
fn candidate(scene: &Scene, triangles: Vec<u32>, cap: Option<Cap>) -> Option<Candidate> {
    let mut min = DVec3::splat(f64::INFINITY);
    let mut max = -min;
    for &t in &triangles {
        for p in corners_of(scene, t) {
            min = min.min(p);
            max = max.max(p);
        }
    }
    let mut origin = (min + max) * 0.5;
    if let Some(c) = cap {
        origin[c.axis] = c.at;
    }
    let volume: f64 = triangles
        .iter()
        .map(|&t| {
            let c = corners_of(scene, t).map(|p| p - origin);
            c[0].dot(c[1].cross(c[2]))
        })
        .sum();
    let extent = max - min;
    let scale = extent.x.max(extent.y).max(extent.z);
    // The volume's rounding is far below this; a flat group has none to speak of.
    if volume.is_nan() || volume.abs() <= 1e-9 * scale * scale * scale {
        return None;
    }
    let area: f64 = triangles
        .iter()
        .map(|&t| normal_of(&corners_of(scene, t)).length() * 0.5)
        .sum();
    Some(Candidate {
        thickness: volume.abs() / area,
        triangles,
        cap,
        orientation: volume.signum(),
        min,
        max,
    })
}
