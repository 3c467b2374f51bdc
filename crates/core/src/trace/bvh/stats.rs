//! Where a [`super::Bvh`]'s time goes, as counts rather than seconds: the SAH cost of its wide
//! tree and, per ray, the nodes whose boxes are tested, the leaves entered and the packets and
//! triangles tested. Counts do not depend on the machine's load, so build and traversal
//! changes can be compared on a shared machine where timings are noisy; the `bvh_probe`
//! example prints them. A separate, scalar copy of the traversal (same near-to-far order,
//! same culling), so that the hot loop in `traverse.rs` carries no counters.
//!
//! Based on: MacDonald, Booth. Heuristics for ray tracing using space subdivision. The Visual
//! Computer 6(3), 1990 (the surface area heuristic, here evaluated on the finished tree).
//! Based on: Aila, Karras, Laine. On quality metrics of bounding volume hierarchies. HPG 2013
//! (SAH cost alone predicts traversal cost imperfectly, hence the measured counts beside it).

use serde::Serialize;

use crate::geometry::{Aabb, Hit, Ray};
use crate::trace::tri4::intersect4;
use crate::trace::triangle::ShearedRay;

use super::node::{Entry, WideNode};
use super::slab::BoxRay;
use super::traverse::{slack_up, CULL_SLACK, ROBUST_FAR};
use super::{Bvh, Nodes};

/// Per-ray averages of one ray set, and the tree's shape.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct TraversalStats {
    /// Rays counted.
    pub rays: usize,
    /// Wide nodes whose child boxes were tested, per ray.
    pub nodes: f64,
    /// Leaves entered, per ray.
    pub leaves: f64,
    /// Four-triangle packets tested, per ray.
    pub packets: f64,
    /// Fraction of rays that hit something.
    pub hit_rate: f64,
}

/// The tree's shape and SAH cost (node and packet visits expected of a ray through the root's
/// box, by the ratio of surface areas).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct TreeStats {
    /// Wide nodes.
    pub nodes: usize,
    /// Leaves (runs of packets).
    pub leaves: usize,
    /// Packets.
    pub packets: usize,
    /// Triangles held (a triangle referenced by several leaves counts once per leaf).
    pub references: usize,
    /// Expected wide nodes visited per ray (SAH, relative to the root's box).
    pub sah_nodes: f64,
    /// Expected packets tested per ray (SAH).
    pub sah_packets: f64,
    /// Heap bytes per triangle of the scene held.
    pub bytes_per_triangle: f64,
}

impl Bvh {
    /// The counts of [`TraversalStats`] for `rays` (closest hit), one thread; the hits equal
    /// [`crate::trace::RayCaster::cast`]'s. A diagnostic: slower than `cast`.
    #[doc(hidden)]
    pub fn traversal_stats(&self, rays: &[Ray]) -> TraversalStats {
        let mut s = Counts::default();
        for ray in rays {
            let hit = match &self.nodes {
                Nodes::Four(n) => count_ray(n, &self.packets, ray, &mut s),
                Nodes::Eight(n) => count_ray(n, &self.packets, ray, &mut s),
            };
            s.hits += usize::from(hit.is_hit());
        }
        let per = |x: usize| x as f64 / rays.len().max(1) as f64;
        TraversalStats {
            rays: rays.len(),
            nodes: per(s.nodes),
            leaves: per(s.leaves),
            packets: per(s.packets),
            hit_rate: per(s.hits),
        }
    }

    /// The tree's [`TreeStats`].
    #[doc(hidden)]
    pub fn tree_stats(&self) -> TreeStats {
        let mut t = TreeStats::default();
        match &self.nodes {
            Nodes::Four(n) => tree_walk(n, &self.packets, &mut t),
            Nodes::Eight(n) => tree_walk(n, &self.packets, &mut t),
        }
        t.bytes_per_triangle = self.memory_bytes() as f64 / self.triangle_count.max(1) as f64;
        t
    }
}

#[derive(Default)]
struct Counts {
    nodes: usize,
    leaves: usize,
    packets: usize,
    hits: usize,
}

/// The closest hit of `ray`, as `traverse.rs` finds it, counting what it visits.
fn count_ray<N: WideNode>(
    nodes: &[N],
    packets: &[crate::trace::tri4::Tri4],
    ray: &Ray,
    s: &mut Counts,
) -> Hit {
    let mut best = Hit::MISS;
    if nodes.is_empty() {
        return best;
    }
    let sheared = ShearedRay::new(ray);
    let t_min = ray.t_min - ray.t_min.abs() * CULL_SLACK;
    let Some(r) = BoxRay::new(ray, t_min, N::WIDTH) else {
        return best;
    };
    let mut t_far = slack_up(ray.t_max);
    let mut stack = vec![Entry::<N::Child>::default()];
    while let Some(e) = stack.pop() {
        if e.t > t_far {
            continue;
        }
        let (index, count) = N::decode(e.child);
        if count > 0 {
            s.leaves += 1;
            for p in &packets[index..index + count] {
                s.packets += 1;
                let (ts, mask) = intersect4(&sheared, p);
                for lane in (0..4).filter(|l| mask & (1 << l) != 0) {
                    let (t, id) = (ts[lane], p.ids[lane]);
                    if t < best.t || (t == best.t && id < best.triangle) {
                        best = Hit { triangle: id, t };
                    }
                }
            }
            if best.is_hit() {
                t_far = slack_up(best.t);
            }
            continue;
        }
        s.nodes += 1;
        // SAFETY: `Bvh::build_with` only builds a layout where the CPU runs its box test.
        // As `traverse::walk` picks it.
        let (t, mask) = unsafe {
            if r.finite {
                nodes[index].enter_finite(&r, t_far)
            } else {
                nodes[index].enter(&r, t_far, ROBUST_FAR)
            }
        };
        let mut kids: Vec<_> = (0..N::WIDTH)
            .filter(|&l| mask & (1 << l) != 0)
            .map(|l| Entry {
                child: nodes[index].child(l),
                t: t[l],
            })
            .collect();
        // Far to near, so the nearest is popped first.
        kids.sort_by(|a, b| b.t.total_cmp(&a.t));
        stack.extend(kids);
    }
    best
}

/// Counts nodes, leaves and packets, and sums the SAH weights (each child's box area over the
/// root's) of every node and packet.
fn tree_walk<N: WideNode>(nodes: &[N], packets: &[crate::trace::tri4::Tri4], t: &mut TreeStats) {
    let Some(root) = nodes.first() else {
        return;
    };
    let root_box = (0..N::WIDTH)
        .map(|l| lane_box(root.child_box(l)))
        .fold(Aabb::EMPTY, |a, b| a.union(&b));
    let root_area = f64::from(root_box.surface_area()).max(f64::MIN_POSITIVE);
    t.nodes = nodes.len();
    t.packets = packets.len();
    t.sah_nodes = 1.0;
    for n in nodes {
        for l in 0..N::WIDTH {
            let b = lane_box(n.child_box(l));
            if b.is_empty() {
                continue;
            }
            let w = f64::from(b.surface_area()) / root_area;
            let (first, count) = N::decode(n.child(l));
            if count == 0 {
                t.sah_nodes += w;
            } else {
                t.leaves += 1;
                t.sah_packets += w * count as f64;
                t.references += packets[first..first + count]
                    .iter()
                    .map(|p| {
                        let mut ids = p.ids;
                        ids.sort_unstable();
                        1 + ids.windows(2).filter(|w| w[0] != w[1]).count()
                    })
                    .sum::<usize>();
            }
        }
    }
}

fn lane_box((min, max): ([f32; 3], [f32; 3])) -> Aabb {
    let (min, max) = (glam::Vec3::from_array(min), glam::Vec3::from_array(max));
    if min.cmple(max).all() {
        Aabb::new(min, max)
    } else {
        Aabb::EMPTY
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::scene::SceneBuilder;
    use crate::trace::measure::incoherent_rays;
    use crate::trace::{Bvh, RayCaster};

    #[test]
    fn counts_agree_with_the_caster() {
        let mut b = SceneBuilder::new("boxes");
        for i in 0..300 {
            let p = Vec3::new((i % 17) as f32 * 3.0, (i % 5) as f32 * 2.0, (i / 17) as f32);
            b.add_box(p, p + Vec3::splat(0.8));
        }
        let scene = b.finish();
        let bvh = Bvh::build(&scene);
        let rays = incoherent_rays(scene.bounds(), 2000, 3);
        let mut hits = vec![crate::Hit::MISS; rays.len()];
        bvh.cast(&rays, &mut hits);
        let s = bvh.traversal_stats(&rays);
        let hit_rate = hits.iter().filter(|h| h.is_hit()).count() as f64 / rays.len() as f64;
        assert_eq!(s.hit_rate, hit_rate);
        assert!(s.nodes >= 1.0 && s.packets >= s.leaves && s.leaves > 0.0);
        let t = bvh.tree_stats();
        assert_eq!(t.references, scene.triangles.len());
        assert!(t.sah_nodes >= 1.0 && t.packets >= t.leaves);
    }
}
