//! Occluder fusion from a view region: the triangles that several occluders hide together from
//! every point of the cell, found by drawing *shrunk* occluders into conservative depth maps
//! at points of the cell. The single-occluder umbrae of `from_region.rs` run first; this pass
//! only looks at what they left visible.
//!
//! Based on: Wonka, Wimmer, Schmalstieg. Visibility Preprocessing with Occluder Fusion for
//! Urban Walkthroughs. Eurographics Rendering Workshop 2000 (occluder shrinking: point
//! visibility with occluders shrunk by ε is conservative for every viewpoint within ε, and
//! point visibility fuses occluders for free). Their bound is for 2.5D urban scenes; the
//! per-edge bound below is ours, for planar occluders in 3D. The cell is split adaptively
//! (a box is only split while some triangle is neither proven hidden from it nor found
//! visible), in the spirit of their sampling of the cell.
//!
//! # Why it is conservative
//! Let `p` be a point, `q` any point with `|q - p| <= ε`, `O` a convex planar occluder whose
//! plane is at distance `h > ε` from `p` (so `p` and `q` are strictly on the same side), and
//! `x` a point whose segment from `p` crosses the plane at `o = p + t0 (x - p)`, `0 < t0 < 1`.
//! The point `o' = q + t0 (x - q)` of the segment from `q` is `o + (1 - t0)(q - p)`, within
//! `ε` of `o` and within `ε` of the plane; that segment crosses the plane at
//! `o'' = o' - (n · (o' - o)) / (n · u) u`, `u` its direction. For an edge of `O` with inward
//! in-plane normal `m`, the displacement `o'' - o` moves across the edge by at most
//! `ε (1 + |m · u| / |n · u|)`, and with `|x - p| >= |o - p|` that ratio is at most
//! `(|m · (o - p)| + ε) / (h - ε)` (it falls as `x` moves away). So if `o` is at least
//! `δ_m(o) = ε (1 + (|m · (o - p)| + ε) / (h - ε))` inside every edge of `O`, then `o''` is
//! inside `O` and `x` is hidden from `q` too. `δ_m(o)` depends on `o` only through
//! `|m · (o - p)|`, so "at least `δ_m(o)` inside edge `m`" is two half-planes (one per sign),
//! and the shrunk occluder is convex. It shrinks little across edges seen head-on and much
//! across edges that rays from `p` graze (the far end of a long wall along a street: there
//! `|m · (o - p)|` is large beside `h`), as it must.
//!
//! A triangle every point of which is hidden from `p` by the occluders shrunk that way (each
//! point by any occluder: that is the fusion) is hidden from every point within `ε` of `p`.
//! The depth map (`cube_depth.rs`) proves "every point hidden from `p`" conservatively. A box
//! of the cell lies in the ball of its largest centre-to-corner distance around its centre; a
//! triangle proven hidden from every box of a subdivision of the cell is hidden from the whole
//! cell.
//!
//! # Cost
//! A box's map is drawn only in the tiles its triangles still under test may reach (nothing
//! else is read). Above the last level the box's size, not the pixel, decides what can be
//! proven, so those maps are coarse; at the last level what is left is retested on a map
//! [`LEAF_REFINE`] times finer, where a pixel is what separates a triangle from a silhouette
//! (munich: 6 levels at 128 px then 512 px keep 29 triangles more than 512 px throughout, of
//! 99,826, in 60 % of the time; docs/BENCHMARKS.md, "Occluder fusion").
//!
//! Memory: the candidates' corners (72 bytes each), a visible flag per candidate, one cube
//! depth map per box under way (`6 * resolution^2 * 4` bytes, `LEAF_REFINE^2` times that at
//! the last level; one per worker thread), one shrunk occluder at a time.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::DVec3;

use super::cube_depth::{clip, CubeDepth};

/// How much finer the last level's second map is.
const LEAF_REFINE: usize = 4;
/// Relative slack added to the shrinking distances (rounding of the bounds).
const SHRINK_SLACK: f64 = 1e-9;

/// Options of the fusion pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct FusionOptions {
    /// Levels of halving of the cell (the smallest boxes are `2^-splits` of its volume).
    pub splits: u32,
    /// Pixels per side of each cube face.
    pub resolution: usize,
}

/// A convex planar occluder ready to shrink.
#[derive(Clone, Debug)]
pub(crate) struct FusionOccluder {
    corners: Vec<DVec3>,
    normal: DVec3,
    offset: f64,
    /// Per edge: the inward in-plane unit normal `m` and `c` (inside: `m · y >= c`).
    edges: Vec<(DVec3, f64)>,
}

impl FusionOccluder {
    /// The occluder of convex planar polygon `poly`, or `None` if it is degenerate.
    pub(crate) fn new(poly: &[DVec3]) -> Option<Self> {
        let centroid = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
        let mut normal = DVec3::ZERO;
        for i in 0..poly.len() {
            normal += (poly[i] - centroid).cross(poly[(i + 1) % poly.len()] - centroid);
        }
        let normal = normal.try_normalize()?;
        let mut edges = Vec::with_capacity(poly.len());
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let mut m = normal.cross(b - a).try_normalize()?;
            if m.dot(centroid - a) < 0.0 {
                m = -m;
            }
            edges.push((m, m.dot(a)));
        }
        Some(Self {
            corners: poly.to_vec(),
            normal,
            offset: normal.dot(centroid),
            edges,
        })
    }

    /// This occluder shrunk for the ball of radius `eps` around `p` (see the module
    /// documentation) into `out`; empty when its plane comes within `eps` of `p` or nothing
    /// is left.
    fn shrunk_for(&self, p: DVec3, eps: f64, out: &mut Vec<DVec3>, scratch: &mut Vec<DVec3>) {
        out.clear();
        let h = (self.normal.dot(p) - self.offset).abs();
        // (NaN distances leave nothing too.)
        if h.is_nan() || h <= eps * (1.0 + 1e-6) {
            return;
        }
        // Inside edge (m, c) by ε (1 + (|m · (o - p)| + ε) / (h - ε)): with k = ε / (h - ε),
        // (1 - k) m · o >= c + ε (1 + k) - k m · p  and  (1 + k) m · o >= c + ε (1 + k) + k m · p,
        // one per sign of m · (o - p). Both are half-planes, so the shrunk occluder is convex.
        let k = eps / (h - eps);
        let grow = 1.0 + SHRINK_SLACK;
        out.extend_from_slice(&self.corners);
        for &(m, c) in &self.edges {
            let mp = m.dot(p);
            let base = c + eps * (1.0 + k) * grow;
            for (scale, rhs) in [(1.0 - k, base - k * mp), (1.0 + k, base + k * mp)] {
                clip(out, |y| scale * m.dot(y) - rhs, scratch);
                std::mem::swap(out, scratch);
                if out.len() < 3 {
                    out.clear();
                    return;
                }
            }
        }
    }
}

/// The view cell as a parallelepiped `origin + s a + t b + u c`, `(s, t, u)` in the unit cube.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellShape {
    origin: DVec3,
    axes: [DVec3; 3],
}

impl CellShape {
    /// The parallelepiped of eight corners in `ViewCell::corners` order (bit 0, 1, 2 of the
    /// index along the first, second, third axis); any other corner list is bounded by its
    /// axis-aligned box (a larger region: still conservative).
    pub(crate) fn of(corners: &[DVec3]) -> Self {
        if corners.len() == 8 {
            let origin = corners[0];
            let axes = [
                corners[1] - origin,
                corners[2] - origin,
                corners[4] - origin,
            ];
            let scale = axes.iter().map(|a| a.length()).fold(0.0, f64::max);
            let exact = (0..8).all(|k| {
                let expect = origin
                    + axes[0] * f64::from(k & 1)
                    + axes[1] * f64::from((k >> 1) & 1)
                    + axes[2] * f64::from((k >> 2) & 1);
                (corners[k as usize] - expect).length() <= 1e-9 * scale.max(1e-30)
            });
            if exact {
                return Self { origin, axes };
            }
        }
        let lo = corners.iter().copied().fold(DVec3::INFINITY, DVec3::min);
        let hi = corners
            .iter()
            .copied()
            .fold(DVec3::NEG_INFINITY, DVec3::max);
        let d = hi - lo;
        Self {
            origin: lo,
            axes: [DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z],
        }
    }

    fn point(&self, s: DVec3) -> DVec3 {
        self.origin + self.axes[0] * s.x + self.axes[1] * s.y + self.axes[2] * s.z
    }

    /// The centre of parametric box `[lo, hi]` and the largest distance from it to a corner.
    fn ball(&self, lo: DVec3, hi: DVec3) -> (DVec3, f64) {
        let centre = self.point((lo + hi) * 0.5);
        let radius = (0..8)
            .map(|k| {
                let s = DVec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                );
                (self.point(s) - centre).length()
            })
            .fold(0.0f64, f64::max);
        (centre, radius)
    }
}

/// What the fusion pass found.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct FusionResult {
    /// Per candidate: hidden from the whole cell.
    pub hidden: Vec<bool>,
    /// Boxes of the cell a depth map was drawn for.
    pub boxes: u64,
}

struct Work<'a> {
    occluders: &'a [FusionOccluder],
    candidates: &'a [[DVec3; 3]],
    cell: CellShape,
    options: FusionOptions,
    visible: Vec<AtomicBool>,
    boxes: AtomicU64,
}

/// Which of `candidates` (triangles, in the same coordinates as the occluders and the cell)
/// `occluders` hide together from every point of the cell `cell`.
pub(crate) fn fused_hidden(
    occluders: &[FusionOccluder],
    candidates: &[[DVec3; 3]],
    cell: CellShape,
    options: FusionOptions,
) -> FusionResult {
    let work = Work {
        occluders,
        candidates,
        cell,
        options,
        visible: candidates.iter().map(|_| AtomicBool::new(false)).collect(),
        boxes: AtomicU64::new(0),
    };
    if !occluders.is_empty() && options.resolution > 0 {
        let all: Vec<u32> = (0..candidates.len() as u32).collect();
        refine(&work, DVec3::ZERO, DVec3::ONE, all, 0);
    } else {
        work.visible
            .iter()
            .for_each(|v| v.store(true, Ordering::Relaxed));
    }
    FusionResult {
        hidden: work
            .visible
            .iter()
            .map(|v| !v.load(Ordering::Relaxed))
            .collect(),
        boxes: work.boxes.load(Ordering::Relaxed),
    }
}

/// Proves hidden from the parametric box `[lo, hi]` what its depth map can, and splits the
/// box for the rest (marking visible what is left at the last level).
fn refine(work: &Work<'_>, lo: DVec3, hi: DVec3, pending: Vec<u32>, level: u32) {
    let pending: Vec<u32> = pending
        .into_iter()
        .filter(|&i| !work.visible[i as usize].load(Ordering::Relaxed))
        .collect();
    if pending.is_empty() {
        return;
    }
    work.boxes.fetch_add(1, Ordering::Relaxed);
    let (p, eps) = work.cell.ball(lo, hi);
    let near = 1e-3 * eps.max(1e-9);
    // Once per box: the occluders shrunk for its ball and the triangles under test, both
    // relative to its centre (the last level draws them twice).
    let mut shrunk = Vec::new();
    let mut scratch = Vec::new();
    for o in work.occluders {
        let mut poly = Vec::new();
        o.shrunk_for(p, eps, &mut poly, &mut scratch);
        if !poly.is_empty() {
            poly.iter_mut().for_each(|v| *v -= p);
            shrunk.push((poly, o.normal, o.offset - o.normal.dot(p)));
        }
    }
    let mut tests: Vec<(u32, [DVec3; 3])> = pending
        .into_iter()
        .map(|i| (i, work.candidates[i as usize].map(|v| v - p)))
        .collect();
    let prove = |resolution: usize, tests: &mut Vec<(u32, [DVec3; 3])>| {
        let mut map = CubeDepth::new(resolution);
        // Only where the triangles under test may land is drawn.
        for (_, t) in tests.iter() {
            map.mark_interest(t);
        }
        for (poly, normal, offset) in &shrunk {
            map.draw(poly, *normal, *offset, near);
        }
        tests.retain(|(_, t)| !map.hides(t, near));
    };
    prove(work.options.resolution, &mut tests);
    if tests.is_empty() {
        return;
    }
    if level >= work.options.splits {
        // What is left may be hidden at a finer resolution: near a silhouette a pixel is too
        // coarse to prove it.
        prove(work.options.resolution * LEAF_REFINE, &mut tests);
        for (i, _) in tests {
            work.visible[i as usize].store(true, Ordering::Relaxed);
        }
        return;
    }
    let left: Vec<u32> = tests.into_iter().map(|(i, _)| i).collect();
    // Halve the box across its longest side.
    let size = hi - lo;
    let axis = (0..3)
        .max_by(|&a, &b| {
            (work.cell.axes[a].length() * size[a])
                .total_cmp(&(work.cell.axes[b].length() * size[b]))
        })
        .unwrap_or(0);
    let mut mid_hi = hi;
    mid_hi[axis] = lo[axis] + size[axis] * 0.5;
    let mut mid_lo = lo;
    mid_lo[axis] = mid_hi[axis];
    let again = left.clone();
    rayon::join(
        || refine(work, lo, mid_hi, left, level + 1),
        || refine(work, mid_lo, hi, again, level + 1),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wall(x: f64, y0: f64, y1: f64, half_height: f64) -> Vec<DVec3> {
        vec![
            DVec3::new(x, y0, -half_height),
            DVec3::new(x, y1, -half_height),
            DVec3::new(x, y1, half_height),
            DVec3::new(x, y0, half_height),
        ]
    }

    fn unit_cell() -> CellShape {
        let corners: Vec<DVec3> = (0..8)
            .map(|k| {
                DVec3::new(
                    f64::from(k & 1) - 0.5,
                    f64::from((k >> 1) & 1) - 0.5,
                    f64::from((k >> 2) & 1) - 0.5,
                )
            })
            .collect();
        CellShape::of(&corners)
    }

    #[test]
    fn the_cell_shape_keeps_a_box_and_bounds_other_corner_lists() {
        let c = unit_cell();
        assert_eq!(c.origin, DVec3::splat(-0.5));
        let (centre, r) = c.ball(DVec3::ZERO, DVec3::ONE);
        assert!(centre.length() < 1e-12);
        assert!((r - 0.75f64.sqrt()).abs() < 1e-12);
        // A triangle of corners: its bounding box.
        let c = CellShape::of(&[DVec3::ZERO, DVec3::X, DVec3::new(0.0, 2.0, 3.0)]);
        assert_eq!(c.point(DVec3::ONE), DVec3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn shrinking_keeps_far_facing_walls_and_drops_walls_too_near() {
        let o = FusionOccluder::new(&wall(10.0, -5.0, 5.0, 5.0)).unwrap();
        let (mut out, mut s) = (Vec::new(), Vec::new());
        o.shrunk_for(DVec3::ZERO, 0.5, &mut out, &mut s);
        // Inside the wall, at least eps (1 + eps / (h - eps)) inside each edge, and centred.
        let least = 0.5 * (1.0 + 0.5 / 9.5);
        assert_eq!(out.len(), 4);
        for v in &out {
            assert!((v.x - 10.0).abs() < 1e-12, "{v}");
            assert!(v.y.abs() <= 5.0 - least && v.z.abs() <= 5.0 - least, "{v}");
            assert!(v.y.abs() > 3.0 && v.z.abs() > 3.0, "{v}");
        }
        o.shrunk_for(DVec3::new(9.7, 0.0, 0.0), 0.5, &mut out, &mut s);
        assert!(out.is_empty(), "the plane is within eps");
    }

    #[test]
    fn two_walls_side_by_side_hide_what_neither_hides_alone() {
        // Two overlapping walls at x = 6, y in -6..1 and -1..6; a triangle behind at x = 9,
        // y in -3..3, that each wall alone lets the cell (the unit box at the origin) see past
        // its inner edge. Together they hide it.
        let left = FusionOccluder::new(&wall(6.0, -6.0, 1.0, 6.0)).unwrap();
        let right = FusionOccluder::new(&wall(6.0, -1.0, 6.0, 6.0)).unwrap();
        let behind = [
            DVec3::new(9.0, -3.0, -0.5),
            DVec3::new(9.0, 3.0, -0.5),
            DVec3::new(9.0, 0.0, 0.5),
        ];
        // Beside both walls, seen past their edge.
        let beside = [
            DVec3::new(9.0, 20.0, -0.5),
            DVec3::new(9.0, 21.0, -0.5),
            DVec3::new(9.0, 20.0, 0.5),
        ];
        let options = FusionOptions {
            splits: 6,
            resolution: 64,
        };
        let run = |occ: &[FusionOccluder]| {
            fused_hidden(occ, &[behind, beside], unit_cell(), options).hidden
        };
        assert_eq!(run(std::slice::from_ref(&left)), [false, false]);
        assert_eq!(run(std::slice::from_ref(&right)), [false, false]);
        assert_eq!(run(&[left, right]), [true, false]);
    }

    #[test]
    fn a_cell_reaching_past_a_gap_keeps_what_the_gap_shows() {
        // Two walls with a gap at y = -0.2..0.2 between them: from the cell, the triangle
        // behind the gap is visible through it.
        let left = FusionOccluder::new(&wall(6.0, -6.0, -0.2, 6.0)).unwrap();
        let right = FusionOccluder::new(&wall(6.0, 0.2, 6.0, 6.0)).unwrap();
        let behind = [
            DVec3::new(9.0, -0.5, -0.5),
            DVec3::new(9.0, 0.5, -0.5),
            DVec3::new(9.0, 0.0, 0.5),
        ];
        let r = fused_hidden(
            &[left, right],
            &[behind],
            unit_cell(),
            FusionOptions {
                splits: 8,
                resolution: 64,
            },
        );
        assert_eq!(r.hidden, [false]);
        assert!(r.boxes > 1);
    }
}
