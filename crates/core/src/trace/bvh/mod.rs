//! Our default ray caster: a binned-SAH bounding volume hierarchy over the scene's triangles,
//! built in parallel as a binary tree, collapsed into an 8-wide tree whose eight child boxes
//! are tested at once with AVX2 (`bvh/bvh8.rs`) when the CPU has it, else into a 4-wide tree
//! tested with SSE, and traversed with a stack, nearer children first.
//!
//! Based on: Wald. On fast construction of SAH-based bounding volume hierarchies. 2007
//! (binned SAH build, 16 bins, bins keep bounds and centroid bounds so children need no extra pass).
//! Based on: Wald, Benthin, Boulos. Getting rid of packets: efficient SIMD single-ray traversal
//! using multi-branching BVHs. IRT 2008 (the 4-wide tree, collapsed from the binary one).
//! Based on: Ernst, Greiner. Multi bounding volume hierarchies. IRT 2008.
//! Based on: Fuetterling, Lojewski, Pfreundt, Ebert. Efficient Ray Tracing Kernels for Modern
//! CPU Architectures. JCGT 4(5), 2015 (the 8-wide tree).
//! Based on: Ize. Robust BVH ray traversal. JCGT 2(2), 2013 (the `1 + 2 gamma(3)` slab slack).
//! Based on: Woop, Benthin, Wald. Watertight ray/triangle intersection. JCGT 2(1), 2013
//! (the leaf test, [`super::triangle::intersect`]).
//!
//! # Layout
//! 4-wide nodes are 128 bytes on two cache lines: the four child boxes as six rows of four
//! lanes (min x, y, z, max x, y, z), then per child its node index or first packet, and its
//! packet count (0 for an inner child). 8-wide nodes are 224 bytes: eight lanes per row, and
//! index and packet count packed into one `u32` per child (`bvh/bvh8.rs`). Triangles are copied in leaf order, four to a 160-byte packet
//! (`Tri4`: corners as rows of four lanes, and the scene ids), so a leaf is one
//! contiguous run of packets tested four triangles at a time, and the scene is not touched
//! while tracing.
//!
//! # Memory
//! Per triangle that is kept (degenerate ones are dropped), with 8-wide nodes: about 48 bytes
//! of packets (3.4 triangles per packet) plus 13 to 17 bytes of nodes, so 61 bytes per
//! triangle on the 1M-triangle procedural city and 64 to 66 on munich, czest3ctf and the
//! Stanford bunny ([`Bvh::memory_bytes`]; 4-wide nodes took about 60 on the city). The build peaks at about 170 bytes
//! per triangle (24-byte boxes, 4-byte ids, and an uncompacted binary node array of 64 bytes
//! per triangle), i.e. about 1.7 GB for 10M triangles.
//!
//! # Exactness
//! Leaves use the same watertight test as [`super::BruteForce`] (four lanes at a time with the
//! same bits, see `tri4.rs`) and ties in `t` go to the lower triangle id, so hits equal brute
//! force bit for bit. Box tests are only ever made more
//! conservative (Ize's slack on the far distance, a relative slack on the culling distance) so
//! that a box whose triangle the leaf test would accept is never culled by rounding.

mod build;
mod bvh8;
#[cfg(test)]
mod tests;

use glam::Vec3;
use rayon::prelude::*;

use crate::geometry::{Aabb, Hit, Ray};
use crate::scene::Scene;

use super::box4::{BoxRay, Boxes4, EMPTY_BOXES};
use super::tri4::{intersect4, Tri4};
use super::triangle::ShearedRay;
use super::RayCaster;
use build::{BinaryTree, Node, NodePair, MAX_LEAF, MAX_SAH_DEPTH};
use bvh8::{collapse8, Node8};

/// Traversal stack size: the binary tree has at most `MAX_SAH_DEPTH` levels plus a
/// median-split tail over at most 2^32 triangles; each 4-wide level spans at least one of them
/// and pushes at most three nodes (four, briefly, while sorting).
const STACK_SIZE: usize = 3 * (MAX_SAH_DEPTH as usize + 32) + 1;
/// Rays per `rayon` task in [`Bvh::cast`].
const RAYS_PER_TASK: usize = 64;

/// `gamma(n) = n eps / (1 - n eps)` of Pharr et al. with `eps = 2^-24`.
const fn gamma(n: f32) -> f32 {
    let eps = f32::EPSILON * 0.5;
    n * eps / (1.0 - n * eps)
}
/// Ize 2013: scaling far slab distances by this makes the box test conservative.
const ROBUST_FAR: f32 = 1.0 + 2.0 * gamma(3.0);
/// Relative slack on the distances a box is culled against. The leaf test's `t` is a convex
/// combination of the corners' distances along the ray and carries a few ulps of rounding, so
/// it may sit a few ulps outside the box's slab interval; a tie at equal `t` with a lower id
/// must still be found. Larger than strictly needed, at no measurable cost.
const CULL_SLACK: f32 = 16.0 * gamma(3.0);

/// A bounding volume hierarchy over a scene's triangles: the default [`RayCaster`].
///
/// Owns a copy of the triangles it needs, so it does not borrow the scene.
///
/// ```
/// use glam::Vec3;
/// use sightline_core::scene::SceneBuilder;
/// use sightline_core::trace::{Bvh, RayCaster};
/// use sightline_core::Ray;
///
/// let mut b = SceneBuilder::new("one box");
/// b.add_box(Vec3::splat(1.0), Vec3::splat(2.0));
/// let bvh = Bvh::build(&b.finish());
/// let hit = bvh.cast_one(&Ray::new(Vec3::new(0.0, 1.5, 1.5), Vec3::X));
/// assert_eq!(hit.t, 1.0);
/// ```
#[derive(Debug)]
pub struct Bvh {
    /// 4-wide nodes, the root first (empty when `triangles` is, or when `nodes8` is used).
    nodes: Vec<Node4>,
    /// 8-wide nodes, the root first: used instead of `nodes` when the CPU has AVX2, and only
    /// then non-empty.
    nodes8: Vec<Node8>,
    /// Triangles in leaf order, four to a packet; a leaf is a run of packets.
    packets: Vec<Tri4>,
    /// Triangles held (the packets' lanes less the padding).
    triangle_count: usize,
}

/// A 4-wide node: its children's boxes side by side (one SIMD lane per child) and, per child,
/// either (inner, `count == 0`) its node index or (leaf) its first triangle and triangle count.
/// Unused slots have [`EMPTY_BOXES`]' never-entered boxes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node4 {
    bounds: Boxes4,
    child: [u32; 4],
    count: [u32; 4],
}

impl Node4 {
    const EMPTY: Node4 = Node4 {
        bounds: EMPTY_BOXES,
        child: [0; 4],
        count: [0; 4],
    };

    fn set_box(&mut self, lane: usize, n: &Node) {
        for a in 0..3 {
            self.bounds[a][lane] = n.min[a];
            self.bounds[a + 3][lane] = n.max[a];
        }
    }
}

fn node_area(n: &Node) -> f32 {
    Aabb::new(Vec3::from_array(n.min), Vec3::from_array(n.max)).surface_area()
}

/// Collapses the binary tree under `root` into 4-wide nodes, depth first (a subtree's nodes are
/// close together); the root is node 0. Each 4-wide node takes the binary node's two children
/// and keeps opening the child with the largest surface area (the likeliest to be entered)
/// until it has four (Wald et al. 2008).
///
/// `pack(first, count)` turns a binary leaf (a range of triangles in leaf order) into packets
/// and returns the first packet's index and the packet count, which the 4-wide node stores.
fn collapse(
    root: &Node,
    sparse: &[NodePair],
    pack: &mut impl FnMut(u32, u32) -> (u32, u32),
) -> Vec<Node4> {
    let mut nodes = Vec::with_capacity(sparse.len() / 2 + 1);
    if root.is_leaf() {
        let mut n = Node4::EMPTY;
        n.set_box(0, root);
        (n.child[0], n.count[0]) = pack(root.first, root.count);
        nodes.push(n);
    } else {
        collapse_inner(root, sparse, pack, &mut nodes);
    }
    nodes
}

/// The up to `W` nodes that replace binary node `inner` in a `W`-wide node: its two children,
/// then the inner child with the largest surface area (the likeliest to be entered) opened
/// again and again until there are `W` or only leaves (Wald et al. 2008). Returns them and
/// their number.
fn open_children<const W: usize>(inner: &Node, sparse: &[NodePair]) -> ([Node; W], usize) {
    let mut kids = [Node::default(); W];
    kids[..2].copy_from_slice(&sparse[inner.first as usize].0);
    let mut len = 2;
    while len < W {
        let widest = (0..len)
            .filter(|&i| !kids[i].is_leaf())
            .max_by(|&i, &j| node_area(&kids[i]).total_cmp(&node_area(&kids[j])));
        let Some(w) = widest else { break };
        let [l, r] = sparse[kids[w].first as usize].0;
        kids[w] = l;
        kids[len] = r;
        len += 1;
    }
    (kids, len)
}

fn collapse_inner(
    inner: &Node,
    sparse: &[NodePair],
    pack: &mut impl FnMut(u32, u32) -> (u32, u32),
    out: &mut Vec<Node4>,
) -> u32 {
    let index = out.len();
    out.push(Node4::EMPTY);
    let (kids, len) = open_children::<4>(inner, sparse);
    let mut node = Node4::EMPTY;
    for (lane, kid) in kids[..len].iter().enumerate() {
        node.set_box(lane, kid);
        if kid.is_leaf() {
            (node.child[lane], node.count[lane]) = pack(kid.first, kid.count);
        } else {
            node.child[lane] = collapse_inner(kid, sparse, pack, out);
        }
    }
    out[index] = node;
    index as u32
}

/// True when the triangle can ever be hit: finite corners and a non-zero cross product.
fn usable(corners: [Vec3; 3]) -> bool {
    let [a, b, c] = corners;
    a.is_finite() && b.is_finite() && c.is_finite() && (b - a).cross(c - a) != Vec3::ZERO
}

impl Bvh {
    /// Builds the BVH for `scene`. Triangles with an index out of range, a non-finite corner
    /// or zero area are left out: the leaf test would never hit them.
    pub fn build(scene: &Scene) -> Self {
        Self::build_with(scene, Width::widest())
    }

    /// [`Bvh::build`] with nodes of the given width.
    fn build_with(scene: &Scene, width: Width) -> Self {
        let corners = |t: &[u32; 3]| -> Option<[Vec3; 3]> {
            let p = |i: u32| scene.positions.get(i as usize).copied();
            Some([p(t[0])?, p(t[1])?, p(t[2])?])
        };
        let boxes: Vec<Aabb> = scene
            .triangles
            .par_iter()
            .map(|t| match corners(t) {
                Some(c) if usable(c) => Aabb::from_points(c),
                _ => Aabb::EMPTY,
            })
            .collect();
        let tree = build::binary_tree(&boxes);
        drop(boxes);
        let Some(BinaryTree {
            root,
            pairs: sparse,
            ids,
        }) = tree
        else {
            return Self {
                nodes: Vec::new(),
                nodes8: Vec::new(),
                packets: Vec::new(),
                triangle_count: 0,
            };
        };
        let mut packets = Vec::with_capacity(ids.len() / 2);
        let mut pack = |first: u32, count: u32| {
            let start = packets.len() as u32;
            let leaf = &ids[first as usize..(first + count) as usize];
            for chunk in leaf.chunks(4) {
                let mut tris = [([Vec3::ZERO; 3], 0); 4];
                for (slot, &id) in tris.iter_mut().zip(chunk) {
                    let c = corners(&scene.triangles[id as usize]).unwrap_or_default();
                    *slot = (c, id);
                }
                packets.push(Tri4::new(&tris[..chunk.len()]));
            }
            (start, packets.len() as u32 - start)
        };
        let (mut nodes, mut nodes8) = match width {
            Width::Four => (collapse(&root, &sparse, &mut pack), Vec::new()),
            Width::Eight => (Vec::new(), collapse8(&root, &sparse, &mut pack)),
        };
        drop(sparse);
        nodes.shrink_to_fit();
        nodes8.shrink_to_fit();
        packets.shrink_to_fit();
        Self {
            nodes,
            nodes8,
            packets,
            triangle_count: ids.len(),
        }
    }

    /// Number of triangles the BVH holds (the scene's, less degenerate ones).
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// Heap bytes held by the BVH (nodes and leaf triangles).
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node4>()
            + self.nodes8.capacity() * std::mem::size_of::<Node8>()
            + self.packets.capacity() * std::mem::size_of::<Tri4>()
    }

    /// Walks the tree, children near to far. `leaf` tests one leaf and returns the new culling
    /// distance, or `None` to stop at once (any-hit). Returns false when stopped.
    #[inline(always)]
    fn traverse(&self, ray: &Ray, mut leaf: impl FnMut(&[Tri4]) -> Option<f32>) -> bool {
        let t_min = ray.t_min - ray.t_min.abs() * CULL_SLACK;
        let Some(r) = BoxRay::new(ray, t_min) else {
            return true;
        };
        let mut t_far = slack_up(ray.t_max);
        let mut stack = [Entry::default(); STACK_SIZE];
        let mut top = 0usize;
        // The root, an inner node.
        let mut current = Entry::default();
        loop {
            if current.count > 0 {
                let s = current.child as usize;
                let e = s + current.count as usize;
                match leaf(&self.packets[s..e]) {
                    Some(t) => t_far = t,
                    None => return false,
                }
            } else {
                let node = &self.nodes[current.child as usize];
                let (t, mut mask) = r.enter(&node.bounds, t_far, ROBUST_FAR);
                if mask != 0 {
                    let entry = |lane: u32| Entry {
                        child: node.child[lane as usize & 3],
                        count: node.count[lane as usize & 3],
                        t: t[lane as usize & 3],
                    };
                    let first = entry(mask.trailing_zeros());
                    mask &= mask - 1;
                    if mask == 0 {
                        current = first;
                        continue;
                    }
                    let second = entry(mask.trailing_zeros());
                    mask &= mask - 1;
                    if mask == 0 {
                        let (near, far) = if second.t < first.t {
                            (second, first)
                        } else {
                            (first, second)
                        };
                        debug_assert!(top < STACK_SIZE);
                        stack[top] = far;
                        top += 1;
                        current = near;
                        continue;
                    }
                    // Three or four children: push them all, sort the pushed ones far to near
                    // (insertion sort), and take the nearest back off.
                    let pushed = top;
                    stack[top] = first;
                    stack[top + 1] = second;
                    top += 2;
                    while mask != 0 {
                        stack[top] = entry(mask.trailing_zeros());
                        top += 1;
                        mask &= mask - 1;
                    }
                    for i in pushed + 1..top {
                        let e = stack[i];
                        let mut j = i;
                        while j > pushed && stack[j - 1].t < e.t {
                            stack[j] = stack[j - 1];
                            j -= 1;
                        }
                        stack[j] = e;
                    }
                    top -= 1;
                    current = stack[top];
                    continue;
                }
            }
            // Pop the next node that is not farther than the closest hit so far.
            loop {
                if top == 0 {
                    return true;
                }
                top -= 1;
                if stack[top].t <= t_far {
                    current = stack[top];
                    break;
                }
            }
        }
    }

    fn closest(&self, ray: &Ray) -> Hit {
        if self.nodes.is_empty() {
            return Hit::MISS;
        }
        let sheared = ShearedRay::new(ray);
        let mut best = Hit::MISS;
        let t_max = slack_up(ray.t_max);
        self.traverse(ray, |packets| {
            for packet in packets {
                let (ts, mut mask) = intersect4(&sheared, packet);
                while mask != 0 {
                    let lane = mask.trailing_zeros() as usize & 3;
                    mask &= mask - 1;
                    let (t, id) = (ts[lane], packet.ids[lane]);
                    // Ties go to the lower id, as in brute force.
                    if t < best.t || (t == best.t && id < best.triangle) {
                        best = Hit { triangle: id, t };
                    }
                }
            }
            Some(if best.is_hit() {
                slack_up(best.t)
            } else {
                t_max
            })
        });
        best
    }

    fn any_hit(&self, ray: &Ray) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let sheared = ShearedRay::new(ray);
        let t_max = slack_up(ray.t_max);
        !self.traverse(ray, |packets| {
            let hit = packets.iter().any(|p| intersect4(&sheared, p).1 != 0);
            (!hit).then_some(t_max)
        })
    }
}

/// `t` moved up by the culling slack (infinity stays infinity).
fn slack_up(t: f32) -> f32 {
    t + t.abs() * CULL_SLACK
}

/// A node on the traversal stack: what [`Node4`] says of the child, and its entry distance.
#[derive(Clone, Copy, Debug, Default)]
struct Entry {
    child: u32,
    count: u32,
    t: f32,
}

/// Node width: 8 (AVX2 box tests) where the CPU has AVX2, else 4 (SSE or scalar).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Width {
    Four,
    Eight,
}

impl Width {
    /// The widest width this CPU traverses with SIMD.
    fn widest() -> Self {
        #[cfg(target_arch = "x86_64")]
        if is_x86_feature_detected!("avx2") {
            return Width::Eight;
        }
        Width::Four
    }
}

impl Bvh {
    fn cast_chunk(&self, rays: &[Ray], hits: &mut [Hit]) {
        #[cfg(target_arch = "x86_64")]
        if !self.nodes8.is_empty() {
            // SAFETY: `nodes8` is only built when `Width::widest` detected AVX2.
            unsafe { self.cast8(rays, hits) };
            return;
        }
        for (r, h) in rays.iter().zip(hits) {
            *h = self.closest(r);
        }
    }

    fn occluded_chunk(&self, rays: &[Ray], out: &mut [bool]) {
        #[cfg(target_arch = "x86_64")]
        if !self.nodes8.is_empty() {
            // SAFETY: `nodes8` is only built when `Width::widest` detected AVX2.
            unsafe { self.occluded8(rays, out) };
            return;
        }
        for (r, o) in rays.iter().zip(out) {
            *o = self.any_hit(r);
        }
    }
}

impl RayCaster for Bvh {
    fn cast(&self, rays: &[Ray], hits: &mut [Hit]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        rays.par_chunks(RAYS_PER_TASK)
            .zip(hits.par_chunks_mut(RAYS_PER_TASK))
            .for_each(|(rs, hs)| self.cast_chunk(rs, hs));
    }

    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "one output slot per ray");
        rays.par_chunks(RAYS_PER_TASK)
            .zip(out.par_chunks_mut(RAYS_PER_TASK))
            .for_each(|(rs, os)| self.occluded_chunk(rs, os));
    }
}
