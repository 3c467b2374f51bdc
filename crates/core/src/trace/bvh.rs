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

mod bvh8;

use glam::Vec3;
use rayon::prelude::*;

use crate::geometry::{Aabb, Hit, Ray};
use crate::scene::Scene;

use super::box4::{BoxRay, Boxes4, EMPTY_BOXES};
use super::tri4::{intersect4, Tri4};
use super::triangle::ShearedRay;
use super::RayCaster;
use bvh8::{collapse8, Node8};

/// Number of SAH bins per axis (Wald 2007 finds 16 close to a full sweep in quality).
const BINS: usize = 16;
/// Largest leaf; bigger nodes are always split.
const MAX_LEAF: usize = 8;
/// SAH cost of visiting an inner node (testing its two child boxes), relative to one triangle
/// test. Tuned on the 600k-triangle random-box bench scene: 1.0 gives 1-2 triangles per leaf
/// and 96 bytes per triangle; 2.0 gives 68 bytes per triangle and ~15% more incoherent
/// throughput at ~10% less coherent throughput (single thread, noisy shared machine).
const TRAVERSAL_COST: f32 = 3.0;
/// SAH cost of one watertight triangle test.
const INTERSECT_COST: f32 = 1.0;
/// Subtrees with at least this many triangles are built as a `rayon::join` task.
const PARALLEL_BUILD: usize = 4096;
/// Nodes with at least this many triangles bin them in parallel.
const PARALLEL_BIN: usize = 1 << 16;
/// Below this depth splits follow the SAH; deeper nodes split at the object median, which
/// bounds the tree depth by `MAX_SAH_DEPTH + 32` and so the traversal stack.
const MAX_SAH_DEPTH: u32 = 40;
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

/// A node: its box, and either (inner, `count == 0`) the index of its children's pair or
/// (leaf, `count > 0`) the first of its `count` triangles in leaf order.
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(32))]
struct Node {
    min: [f32; 3],
    first: u32,
    max: [f32; 3],
    count: u32,
}

impl Node {
    fn leaf(bounds: &Aabb, first: usize, count: usize) -> Self {
        debug_assert!(count > 0 && count <= MAX_LEAF);
        Self {
            min: bounds.min.to_array(),
            first: first as u32,
            max: bounds.max.to_array(),
            count: count as u32,
        }
    }

    fn inner(bounds: &Aabb, pair: usize) -> Self {
        Self {
            min: bounds.min.to_array(),
            first: pair as u32,
            max: bounds.max.to_array(),
            count: 0,
        }
    }

    fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// The two children of one inner node, on one cache line.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct NodePair([Node; 2]);

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

/// Bounds, centroid bounds and count of a set of triangles (a bin, or a node's content).
#[derive(Clone, Copy, Debug)]
struct Bin {
    bounds: Aabb,
    centroids: Aabb,
    count: usize,
}

impl Bin {
    const EMPTY: Bin = Bin {
        bounds: Aabb::EMPTY,
        centroids: Aabb::EMPTY,
        count: 0,
    };

    fn add(&mut self, b: &Aabb) {
        self.bounds = self.bounds.union(b);
        self.centroids.grow(b.center());
        self.count += 1;
    }

    fn merge(&self, o: &Bin) -> Bin {
        Bin {
            bounds: self.bounds.union(&o.bounds),
            centroids: self.centroids.union(&o.centroids),
            count: self.count + o.count,
        }
    }
}

/// What the build reads: each triangle's box, indexed by triangle id.
struct BuildInput<'a> {
    boxes: &'a [Aabb],
}

/// Maps a centroid to its bin along each axis (`None` for an axis of zero centroid extent).
struct Binner {
    min: Vec3,
    scale: [Option<f32>; 3],
}

impl Binner {
    fn new(centroids: &Aabb) -> Self {
        let e = centroids.extent();
        let scale = |x: f32| {
            let s = BINS as f32 / x;
            (x > 0.0 && s.is_finite()).then_some(s)
        };
        Self {
            min: centroids.min,
            scale: [scale(e.x), scale(e.y), scale(e.z)],
        }
    }

    fn bin(&self, c: Vec3, axis: usize, scale: f32) -> usize {
        // `as usize` saturates (NaN gives 0), so this is always in range.
        (((c[axis] - self.min[axis]) * scale) as usize).min(BINS - 1)
    }

    fn bin_into(&self, bins: &mut [[Bin; BINS]; 3], b: &Aabb) {
        let c = b.center();
        for (axis, axis_bins) in bins.iter_mut().enumerate() {
            if let Some(s) = self.scale[axis] {
                axis_bins[self.bin(c, axis, s)].add(b);
            }
        }
    }
}

/// The best SAH split of a node.
struct Split {
    axis: usize,
    /// Triangles in bins `< bin` go left.
    bin: usize,
    cost: f32,
    left: Bin,
    right: Bin,
}

fn bin_triangles(input: &BuildInput, ids: &[u32], binner: &Binner) -> [[Bin; BINS]; 3] {
    let bin_chunk = |chunk: &[u32]| {
        let mut bins = [[Bin::EMPTY; BINS]; 3];
        for &id in chunk {
            binner.bin_into(&mut bins, &input.boxes[id as usize]);
        }
        bins
    };
    if ids.len() < PARALLEL_BIN {
        return bin_chunk(ids);
    }
    // Box unions and counts are exact, so the parallel reduction is deterministic.
    ids.par_chunks(PARALLEL_BIN / 4).map(bin_chunk).reduce(
        || [[Bin::EMPTY; BINS]; 3],
        |mut a, b| {
            for (aa, ba) in a.iter_mut().zip(&b) {
                for (x, y) in aa.iter_mut().zip(ba) {
                    *x = x.merge(y);
                }
            }
            a
        },
    )
}

fn best_split(bins: &[[Bin; BINS]; 3], binner: &Binner, parent_area: f32) -> Option<Split> {
    let mut best: Option<Split> = None;
    for (axis, axis_bins) in bins.iter().enumerate() {
        if binner.scale[axis].is_none() {
            continue;
        }
        // Sweep from the right, keeping the accumulated right side for every plane.
        let mut right_acc = [Bin::EMPTY; BINS];
        let mut acc = Bin::EMPTY;
        for i in (1..BINS).rev() {
            acc = acc.merge(&axis_bins[i]);
            right_acc[i] = acc;
        }
        let mut left = Bin::EMPTY;
        for plane in 1..BINS {
            left = left.merge(&axis_bins[plane - 1]);
            let right = right_acc[plane];
            if left.count == 0 || right.count == 0 {
                continue;
            }
            let weighted = left.bounds.surface_area() * left.count as f32
                + right.bounds.surface_area() * right.count as f32;
            let cost = if parent_area > 0.0 {
                TRAVERSAL_COST + INTERSECT_COST * weighted / parent_area
            } else {
                TRAVERSAL_COST + INTERSECT_COST * (left.count.max(right.count)) as f32
            };
            if !cost.is_finite() {
                continue;
            }
            if best.as_ref().is_none_or(|b| cost < b.cost) {
                best = Some(Split {
                    axis,
                    bin: plane,
                    cost,
                    left,
                    right,
                });
            }
        }
    }
    best
}

/// Bounds and centroid bounds of `ids` (parallel for big sets).
fn summarize(input: &BuildInput, ids: &[u32]) -> Bin {
    let one = |chunk: &[u32]| {
        let mut b = Bin::EMPTY;
        for &id in chunk {
            b.add(&input.boxes[id as usize]);
        }
        b
    };
    if ids.len() < PARALLEL_BIN {
        one(ids)
    } else {
        ids.par_chunks(PARALLEL_BIN / 4)
            .map(one)
            .reduce(|| Bin::EMPTY, |a, b| a.merge(&b))
    }
}

/// In-place partition: ids for which `left` holds come first. Returns their number.
fn partition(ids: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut n = 0;
    for j in 0..ids.len() {
        if left(ids[j]) {
            ids.swap(n, j);
            n += 1;
        }
    }
    n
}

/// Builds the subtree over `ids` (which start at `first` in leaf order) and returns its root.
/// Its descendants are written into `pairs`, which has room for `ids.len() - 1` pairs and
/// starts at pair index `pair_base`: a binary tree over `m` leaves-with-at-least-one-triangle
/// has at most `m - 1` inner nodes, each owning one pair.
fn build_node(
    input: &BuildInput,
    ids: &mut [u32],
    first: usize,
    content: Bin,
    pairs: &mut [NodePair],
    pair_base: usize,
    depth: u32,
) -> Node {
    let m = ids.len();
    debug_assert_eq!(m, content.count);
    debug_assert!(pairs.len() + 1 >= m);
    if m == 1 {
        return Node::leaf(&content.bounds, first, 1);
    }
    let binner = Binner::new(&content.centroids);
    let split = if depth < MAX_SAH_DEPTH {
        let bins = bin_triangles(input, ids, &binner);
        best_split(&bins, &binner, content.bounds.surface_area())
    } else {
        None
    };
    let leaf_cost = INTERSECT_COST * m as f32;
    let (n_left, left, right) = match split {
        Some(s) if m > MAX_LEAF || s.cost < leaf_cost => {
            let scale = binner.scale[s.axis].unwrap_or(0.0);
            let n = partition(ids, |id| {
                binner.bin(input.boxes[id as usize].center(), s.axis, scale) < s.bin
            });
            debug_assert_eq!(n, s.left.count);
            (n, s.left, s.right)
        }
        _ if m <= MAX_LEAF => return Node::leaf(&content.bounds, first, m),
        _ => {
            // No usable SAH split (identical centroids, or too deep): the object median along
            // the longest centroid axis. With identical centroids this is a split by index.
            let e = content.centroids.extent();
            let axis = if e.x >= e.y && e.x >= e.z {
                0
            } else if e.y >= e.z {
                1
            } else {
                2
            };
            let half = m / 2;
            ids.select_nth_unstable_by(half, |&p, &q| {
                let cp = input.boxes[p as usize].center()[axis];
                let cq = input.boxes[q as usize].center()[axis];
                cp.total_cmp(&cq).then(p.cmp(&q))
            });
            let (l, r) = ids.split_at(half);
            (half, summarize(input, l), summarize(input, r))
        }
    };
    let (left_ids, right_ids) = ids.split_at_mut(n_left);
    let (own, rest) = pairs.split_at_mut(1);
    let (left_pairs, right_pairs) = rest.split_at_mut(n_left - 1);
    let left_base = pair_base + 1;
    let right_base = pair_base + n_left;
    let mut build_left = move || {
        build_node(
            input,
            left_ids,
            first,
            left,
            left_pairs,
            left_base,
            depth + 1,
        )
    };
    let mut build_right = move || {
        let first = first + n_left;
        build_node(
            input,
            right_ids,
            first,
            right,
            right_pairs,
            right_base,
            depth + 1,
        )
    };
    let (l, r) = if m >= PARALLEL_BUILD {
        rayon::join(build_left, build_right)
    } else {
        (build_left(), build_right())
    };
    own[0] = NodePair([l, r]);
    Node::inner(&content.bounds, pair_base)
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
        let n = scene.triangles.len();
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
        let mut ids: Vec<u32> = (0..n as u32)
            .filter(|&i| !boxes[i as usize].is_empty())
            .collect();
        let input = BuildInput { boxes: &boxes };
        if ids.is_empty() {
            return Self {
                nodes: Vec::new(),
                nodes8: Vec::new(),
                packets: Vec::new(),
                triangle_count: 0,
            };
        }
        let content = summarize(&input, &ids);
        let mut sparse = vec![NodePair::default(); ids.len() - 1];
        let root = build_node(&input, &mut ids, 0, content, &mut sparse, 0, 0);
        drop(boxes);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneBuilder;
    use crate::trace::BruteForce;

    /// xorshift64*: a tiny fixed-seed generator so the tests need no dependency.
    struct Rng(u64);

    impl Rng {
        fn next_u32(&mut self) -> u32 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 32) as u32
        }

        /// Uniform in `[0, 1)`.
        fn unit(&mut self) -> f32 {
            (self.next_u32() >> 8) as f32 / (1u32 << 24) as f32
        }

        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * self.unit()
        }

        fn point(&mut self, b: &Aabb) -> Vec3 {
            Vec3::new(
                self.range(b.min.x, b.max.x),
                self.range(b.min.y, b.max.y),
                self.range(b.min.z, b.max.z),
            )
        }

        fn direction(&mut self) -> Vec3 {
            loop {
                let d = Vec3::new(
                    self.range(-1.0, 1.0),
                    self.range(-1.0, 1.0),
                    self.range(-1.0, 1.0),
                );
                if d.length_squared() > 1e-4 && d.length_squared() <= 1.0 {
                    return d;
                }
            }
        }
    }

    fn one_triangle() -> Scene {
        let mut b = SceneBuilder::new("one triangle");
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y].map(|p| b.add_vertex(p));
        b.add_triangle(v);
        b.finish()
    }

    /// `n` small random triangles in a 10-unit cube, with a few degenerate ones mixed in.
    fn random_soup(n: usize, seed: u64) -> Scene {
        let mut rng = Rng(seed);
        let mut b = SceneBuilder::new("random soup");
        let cube = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        for i in 0..n {
            let c = rng.point(&cube);
            let size = rng.range(0.05, 1.5);
            let mut corner = || c + rng.direction() * size;
            let (p, q, r) = (corner(), corner(), corner());
            let tri = match i % 50 {
                0 => [p, p, q],             // repeated corner
                1 => [p, (p + q) * 0.5, q], // collinear
                2 => [p, q, Vec3::NAN],     // non-finite
                _ => [p, q, r],
            };
            let v = tri.map(|p| b.add_vertex(p));
            b.add_triangle(v);
        }
        b.finish()
    }

    /// A 6x6x3 grid of unit boxes that touch along faces and edges (many ties on shared
    /// edges and faces), plus random boxes.
    fn box_scene(seed: u64) -> Scene {
        let mut rng = Rng(seed);
        let mut b = SceneBuilder::new("boxes");
        for x in 0..6 {
            for y in 0..6 {
                for z in 0..3 {
                    if (x + y + z) % 3 != 0 {
                        let min = Vec3::new(x as f32, y as f32, z as f32 * 2.0);
                        b.add_box(min, min + Vec3::ONE);
                    }
                }
            }
        }
        let region = Aabb::new(Vec3::splat(-2.0), Vec3::splat(8.0));
        for _ in 0..200 {
            let min = rng.point(&region);
            let size = Vec3::new(rng.unit(), rng.unit(), rng.unit()) * 1.5 + 0.01;
            b.add_box(min, min + size);
        }
        b.finish()
    }

    /// Rays of every kind the casters must agree on: random origins inside and around the
    /// scene, random and axis-aligned directions (with zero and negative-zero components),
    /// lattice origins on box faces and edges, and limited `t` ranges.
    fn random_rays(bounds: Aabb, n: usize, seed: u64) -> Vec<Ray> {
        let mut rng = Rng(seed);
        let grown = Aabb::new(bounds.min - 2.0, bounds.max + 2.0);
        let axes = [
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(0.0, 1.0, 1.0),
            Vec3::new(-0.0, -0.0, 1.0),
            Vec3::new(-1.0, 0.0, -0.0),
        ];
        (0..n)
            .map(|i| {
                let mut origin = rng.point(&grown);
                let dir = match i % 4 {
                    0 | 1 => rng.direction(),
                    2 => axes[rng.next_u32() as usize % axes.len()],
                    _ => {
                        // A lattice origin (on box faces and edges of the grid scene) with an
                        // axis-aligned direction.
                        origin = origin.round();
                        axes[rng.next_u32() as usize % axes.len()] * 0.5
                    }
                };
                let ray = Ray::new(origin, dir);
                match i % 7 {
                    0 => ray.with_range(rng.range(0.0, 3.0), rng.range(3.0, 12.0)),
                    1 => ray.with_range(0.5, f32::INFINITY),
                    _ => ray,
                }
            })
            .collect()
    }

    fn assert_matches_brute_force(scene: &Scene, rays: &[Ray]) {
        let bvh = Bvh::build(scene);
        let brute = BruteForce::new(scene);
        let mut got = vec![Hit::MISS; rays.len()];
        let mut want = vec![Hit::MISS; rays.len()];
        bvh.cast(rays, &mut got);
        brute.cast(rays, &mut want);
        let mut hits = 0;
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(g, w, "ray {i}: {:?}", rays[i]);
            hits += usize::from(w.is_hit());
        }
        assert!(hits > rays.len() / 10, "too few hits ({hits}) to test much");
        let mut occluded = vec![false; rays.len()];
        bvh.occluded(rays, &mut occluded);
        for (i, (o, w)) in occluded.iter().zip(&want).enumerate() {
            assert_eq!(*o, w.is_hit(), "occluded, ray {i}: {:?}", rays[i]);
        }
    }

    #[test]
    fn empty_scene_misses() {
        let bvh = Bvh::build(&Scene::default());
        assert_eq!(bvh.triangle_count(), 0);
        assert_eq!(bvh.cast_one(&Ray::new(Vec3::ZERO, Vec3::X)), Hit::MISS);
        let mut out = [true];
        bvh.occluded(&[Ray::new(Vec3::ZERO, Vec3::X)], &mut out);
        assert!(!out[0]);
        bvh.cast(&[], &mut []);
    }

    #[test]
    fn single_triangle_is_hit() {
        let bvh = Bvh::build(&one_triangle());
        let h = bvh.cast_one(&Ray::new(Vec3::new(0.25, 0.25, 2.0), Vec3::NEG_Z));
        assert_eq!(
            h,
            Hit {
                triangle: 0,
                t: 2.0
            }
        );
        let miss = bvh.cast_one(&Ray::new(Vec3::new(0.75, 0.75, 2.0), Vec3::NEG_Z));
        assert!(!miss.is_hit());
        let short = Ray::new(Vec3::new(0.25, 0.25, 2.0), Vec3::NEG_Z).with_range(0.0, 1.5);
        assert!(!bvh.cast_one(&short).is_hit());
    }

    #[test]
    fn degenerate_triangles_are_skipped() {
        let mut b = SceneBuilder::new("degenerate");
        let v = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0].map(|p| b.add_vertex(p));
        b.add_triangle(v);
        b.add_triangle([v[0], v[0], v[1]]);
        b.add_triangle([0, 1, 99]); // index out of range
        let bvh = Bvh::build(&b.finish());
        assert_eq!(bvh.triangle_count(), 0);
        assert!(!bvh
            .cast_one(&Ray::new(Vec3::new(0.5, 0.0, 1.0), Vec3::NEG_Z))
            .is_hit());
    }

    #[test]
    fn non_finite_ray_misses() {
        let bvh = Bvh::build(&one_triangle());
        for r in [
            Ray::new(Vec3::new(0.25, 0.25, f32::NAN), Vec3::NEG_Z),
            Ray::new(
                Vec3::new(0.25, 0.25, 1.0),
                Vec3::new(0.0, 0.0, f32::NEG_INFINITY),
            ),
            Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::ZERO),
            Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z).with_range(f32::NAN, 2.0),
        ] {
            assert!(!bvh.cast_one(&r).is_hit(), "{r:?}");
        }
    }

    #[test]
    fn identical_centroids_match_brute_force() {
        // 100 copies of one triangle and 100 rotated ones around the same centroid: no SAH
        // split exists, the build falls back to splitting by index; ties go to the lowest id.
        let mut b = SceneBuilder::new("same centroid");
        for i in 0..200 {
            let angle = if i < 100 { 0.0 } else { i as f32 * 0.1 };
            let (s, c) = angle.sin_cos();
            let corners = [
                Vec3::new(c, s, 0.0),
                Vec3::new(-0.5 * c - 0.866 * s, -0.5 * s + 0.866 * c, 0.0),
                Vec3::new(-0.5 * c + 0.866 * s, -0.5 * s - 0.866 * c, 0.0),
            ];
            let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
            let v = corners.map(|p| b.add_vertex(p - centroid + Vec3::splat(5.0)));
            b.add_triangle(v);
        }
        let scene = b.finish();
        let h = Bvh::build(&scene).cast_one(&Ray::new(Vec3::new(5.0, 5.0, 9.0), Vec3::NEG_Z));
        assert_eq!(h.triangle, 0);
        // Rays aimed at the disc the triangles cover, plus the usual mix.
        let mut rng = Rng(7);
        let around = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        let mut rays = random_rays(scene.bounds(), 1000, 8);
        for _ in 0..1000 {
            let o = rng.point(&around);
            let target = Vec3::new(rng.range(4.5, 5.5), rng.range(4.5, 5.5), 5.0);
            rays.push(Ray::new(o, target - o));
        }
        assert_matches_brute_force(&scene, &rays);
    }

    #[test]
    fn random_soup_matches_brute_force() {
        let scene = random_soup(3000, 1);
        assert_matches_brute_force(&scene, &random_rays(scene.bounds(), 4000, 2));
    }

    #[test]
    fn large_random_soup_matches_brute_force() {
        // Above the parallel binning and parallel build thresholds.
        let scene = random_soup(PARALLEL_BIN + 5000, 3);
        assert_matches_brute_force(&scene, &random_rays(scene.bounds(), 1000, 4));
    }

    #[test]
    fn box_scene_matches_brute_force() {
        let scene = box_scene(5);
        assert_matches_brute_force(&scene, &random_rays(scene.bounds(), 8000, 6));
    }

    /// Both node widths against brute force, whatever the CPU picks for [`Bvh::build`].
    fn assert_both_widths_match_brute_force(scene: &Scene, rays: &[Ray]) {
        let brute = BruteForce::new(scene);
        let mut want = vec![Hit::MISS; rays.len()];
        brute.cast(rays, &mut want);
        for width in [Width::Four, Width::widest()] {
            let bvh = Bvh::build_with(scene, width);
            let mut got = vec![Hit::MISS; rays.len()];
            bvh.cast(rays, &mut got);
            let mut occluded = vec![false; rays.len()];
            bvh.occluded(rays, &mut occluded);
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert_eq!(g, w, "{width:?}, ray {i}: {:?}", rays[i]);
                assert_eq!(occluded[i], w.is_hit(), "{width:?}, occluded, ray {i}");
            }
        }
    }

    #[test]
    fn avx2_cpu_builds_eight_wide_nodes() {
        let bvh = Bvh::build(&box_scene(1));
        #[cfg(target_arch = "x86_64")]
        if is_x86_feature_detected!("avx2") {
            assert!(bvh.nodes.is_empty() && !bvh.nodes8.is_empty());
            return;
        }
        assert!(!bvh.nodes.is_empty() && bvh.nodes8.is_empty());
    }

    #[test]
    fn both_widths_match_brute_force_on_box_scene() {
        let scene = box_scene(11);
        assert_both_widths_match_brute_force(&scene, &random_rays(scene.bounds(), 4000, 12));
    }

    #[test]
    fn both_widths_match_brute_force_on_random_soup() {
        let scene = random_soup(5000, 13);
        assert_both_widths_match_brute_force(&scene, &random_rays(scene.bounds(), 4000, 14));
    }

    #[test]
    fn both_widths_match_brute_force_on_one_triangle() {
        // The root is a leaf: both layouts give it a node of its own.
        let scene = one_triangle();
        assert_both_widths_match_brute_force(&scene, &random_rays(scene.bounds(), 500, 15));
    }

    #[test]
    fn skewed_scene_stays_within_stack() {
        // Exponentially spaced triangles: a pure SAH build would peel one off per level.
        let mut b = SceneBuilder::new("skewed");
        for i in 0..300 {
            let x = 1.3f32.powi(i);
            let v = [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
                Vec3::new(x, 0.0, 1.0),
            ]
            .map(|p| b.add_vertex(p));
            b.add_triangle(v);
        }
        let scene = b.finish();
        let ray = Ray::new(Vec3::new(1e36, 0.2, 0.2), Vec3::NEG_X);
        let h = Bvh::build(&scene).cast_one(&ray);
        assert_eq!(h, BruteForce::new(&scene).cast_one(&ray));
        assert!(h.is_hit());
    }
}
