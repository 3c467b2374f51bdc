//! The binary tree under [`super::Bvh`]: a binned-SAH build over the triangles' boxes, in
//! parallel (`rayon::join` per subtree, parallel binning of large nodes), with an object-median
//! fallback that bounds the depth. `collapse.rs` turns the result into wide nodes.
//!
//! Based on: Wald. On fast construction of SAH-based bounding volume hierarchies. 2007
//! (binned SAH build, 16 bins, bins keep bounds and centroid bounds so children need no extra pass).

use glam::Vec3A;
use rayon::prelude::*;

use crate::geometry::Aabb;

/// Number of SAH bins per axis (Wald 2007 finds 16 close to a full sweep in quality).
const BINS: usize = 16;
/// Largest leaf; bigger nodes are always split.
pub(super) const MAX_LEAF: usize = 8;
/// SAH cost of visiting an inner node (testing its two child boxes), relative to one triangle
/// test. Tuned on the 600k-triangle random-box bench scene: 1.0 gives 1-2 triangles per leaf
/// and 96 bytes per triangle; 2.0 gives 68 bytes per triangle and ~15% more incoherent
/// throughput at ~10% less coherent throughput (single thread, noisy shared machine).
const TRAVERSAL_COST: f32 = 3.0;
/// SAH cost of one watertight triangle test. Leaves and split sides are costed by the packet
/// lanes their triangles take ([`packet_lanes`]), not by their triangles: five triangles cost
/// two packets, as many as eight. Against counting triangles this took 57-61 bytes per
/// triangle instead of 61-68 on the shared scenes and 1.03 packets per incoherent ray instead
/// of 1.24 on the dragon, at the same speed within the noise (2026-12-05).
const INTERSECT_COST: f32 = 1.0;
/// Subtrees with at least this many triangles are built as a `rayon::join` task.
const PARALLEL_BUILD: usize = 4096;
/// Nodes with at least this many triangles bin them in parallel.
pub(super) const PARALLEL_BIN: usize = 1 << 16;
/// Below this depth splits follow the SAH; deeper nodes split at the object median, which
/// bounds the tree depth by `MAX_SAH_DEPTH + 32` and so the traversal stack.
pub(super) const MAX_SAH_DEPTH: u32 = 40;

/// A node: its box, and either (inner, `count == 0`) the index of its children's pair or
/// (leaf, `count > 0`) the first of its `count` triangles in leaf order.
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(32))]
pub(super) struct Node {
    pub(super) min: [f32; 3],
    pub(super) first: u32,
    pub(super) max: [f32; 3],
    pub(super) count: u32,
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

    pub(super) fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// The two children of one inner node, on one cache line.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub(super) struct NodePair(pub(super) [Node; 2]);

/// The binary tree over the usable triangles: its root, the pairs its inner nodes point to, and
/// the triangle ids in leaf order (a leaf's `first` indexes `ids`).
pub(super) struct BinaryTree {
    pub(super) root: Node,
    pub(super) pairs: Vec<NodePair>,
    pub(super) ids: Vec<u32>,
}

/// Builds the binary tree over the triangles whose box in `boxes` (indexed by triangle id) is
/// not empty; `None` when there are none.
pub(super) fn binary_tree(boxes: &[Aabb]) -> Option<BinaryTree> {
    let mut ids: Vec<u32> = (0..boxes.len() as u32)
        .filter(|&i| !boxes[i as usize].is_empty())
        .collect();
    if ids.is_empty() {
        return None;
    }
    let input = BuildInput::new(boxes);
    let content = summarize(&input, &ids);
    let mut pairs = vec![NodePair::default(); ids.len() - 1];
    let root = build_node(&input, &mut ids, 0, content, &mut pairs, 0, 0);
    Some(BinaryTree { root, pairs, ids })
}

/// Bounds, centroid bounds and count of a set of triangles: a node's content.
#[derive(Clone, Copy, Debug)]
struct Content {
    bounds: Aabb,
    centroids: Aabb,
    count: usize,
}

impl Content {
    const EMPTY: Content = Content {
        bounds: Aabb::EMPTY,
        centroids: Aabb::EMPTY,
        count: 0,
    };

    fn merge(&self, o: &Content) -> Content {
        Content {
            bounds: self.bounds.union(&o.bounds),
            centroids: self.centroids.union(&o.centroids),
            count: self.count + o.count,
        }
    }
}

/// Bounds and count of the triangles in one bin: what the SAH sweep needs. The children's
/// centroid bounds are gathered by the partition instead, once, rather than per axis here.
/// SIMD corners (`Vec3A`), so a union is two instructions.
#[derive(Clone, Copy, Debug)]
struct Bin {
    min: Vec3A,
    max: Vec3A,
    count: usize,
}

impl Bin {
    const EMPTY: Bin = Bin {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
        count: 0,
    };

    #[inline(always)]
    fn add(&mut self, b: &[Vec3A; 2]) {
        self.min = self.min.min(b[0]);
        self.max = self.max.max(b[1]);
        self.count += 1;
    }

    fn merge(&self, o: &Bin) -> Bin {
        Bin {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
            count: self.count + o.count,
        }
    }

    fn bounds(&self) -> Aabb {
        if self.count == 0 {
            Aabb::EMPTY
        } else {
            Aabb::new(self.min.into(), self.max.into())
        }
    }
}

/// What the build reads, by triangle id: each triangle's box and its centre, in SIMD form.
struct BuildInput {
    boxes: Vec<[Vec3A; 2]>,
    centroids: Vec<Vec3A>,
}

impl BuildInput {
    fn new(boxes: &[Aabb]) -> Self {
        let simd: Vec<[Vec3A; 2]> = boxes
            .par_iter()
            .map(|b| [b.min.into(), b.max.into()])
            .collect();
        // The same `(min + max) * 0.5` as `Aabb::center`, lane by lane.
        let centroids = simd.par_iter().map(|b| (b[0] + b[1]) * 0.5).collect();
        Self {
            boxes: simd,
            centroids,
        }
    }
}

/// Maps a centroid to its bin along each axis (`None` for an axis of zero centroid extent).
struct Binner {
    min: Vec3A,
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
            min: centroids.min.into(),
            scale: [scale(e.x), scale(e.y), scale(e.z)],
        }
    }

    #[inline(always)]
    fn bin(&self, c: Vec3A, axis: usize, scale: f32) -> usize {
        // `as usize` saturates (NaN gives 0), so this is always in range.
        (((c[axis] - self.min[axis]) * scale) as usize).min(BINS - 1)
    }

    #[inline(always)]
    fn bin_into(&self, bins: &mut [[Bin; BINS]; 3], b: &[Vec3A; 2], c: Vec3A) {
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
            let i = id as usize;
            binner.bin_into(&mut bins, &input.boxes[i], input.centroids[i]);
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
            let weighted = left.bounds().surface_area() * packet_lanes(left.count)
                + right.bounds().surface_area() * packet_lanes(right.count);
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

/// The lanes `count` triangles take in four-wide packets: what testing them costs, since a
/// packet is tested whole (Embree's `sahBlockSize` of 4).
fn packet_lanes(count: usize) -> f32 {
    (count.div_ceil(4) * 4) as f32
}

/// Bounds, centroid bounds and count of `ids` (parallel for big sets).
fn summarize(input: &BuildInput, ids: &[u32]) -> Content {
    let one = |chunk: &[u32]| {
        let (mut b, mut c) = (Bin::EMPTY, Bin::EMPTY);
        for &id in chunk {
            let i = id as usize;
            b.add(&input.boxes[i]);
            let centre = input.centroids[i];
            c.add(&[centre, centre]);
        }
        Content {
            bounds: b.bounds(),
            centroids: c.bounds(),
            count: b.count,
        }
    };
    if ids.len() < PARALLEL_BIN {
        one(ids)
    } else {
        ids.par_chunks(PARALLEL_BIN / 4)
            .map(one)
            .reduce(|| Content::EMPTY, |a, b| a.merge(&b))
    }
}

/// In-place partition: ids whose centroid falls in a bin below `bin` on `axis` come first.
/// Returns their number and the centroid bounds of both sides (the children's binners need
/// them; gathering them here is one pass instead of one per axis in the binning).
fn partition(
    input: &BuildInput,
    ids: &mut [u32],
    binner: &Binner,
    axis: usize,
    bin: usize,
) -> (usize, Aabb, Aabb) {
    let scale = binner.scale[axis].unwrap_or(0.0);
    let (mut left, mut right) = (Bin::EMPTY, Bin::EMPTY);
    let mut n = 0;
    for j in 0..ids.len() {
        let c = input.centroids[ids[j] as usize];
        if binner.bin(c, axis, scale) < bin {
            left.add(&[c, c]);
            ids.swap(n, j);
            n += 1;
        } else {
            right.add(&[c, c]);
        }
    }
    (n, left.bounds(), right.bounds())
}

/// Builds the subtree over `ids` (which start at `first` in leaf order) and returns its root.
/// Its descendants are written into `pairs`, which has room for `ids.len() - 1` pairs and
/// starts at pair index `pair_base`: a binary tree over `m` leaves-with-at-least-one-triangle
/// has at most `m - 1` inner nodes, each owning one pair.
fn build_node(
    input: &BuildInput,
    ids: &mut [u32],
    first: usize,
    content: Content,
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
    let leaf_cost = INTERSECT_COST * packet_lanes(m);
    let (n_left, left, right) = match split {
        Some(s) if m > MAX_LEAF || s.cost < leaf_cost => {
            let (n, lc, rc) = partition(input, ids, &binner, s.axis, s.bin);
            debug_assert_eq!(n, s.left.count);
            let side = |b: &Bin, centroids| Content {
                bounds: b.bounds(),
                centroids,
                count: b.count,
            };
            (n, side(&s.left, lc), side(&s.right, rc))
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
                let cp = input.centroids[p as usize][axis];
                let cq = input.centroids[q as usize][axis];
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
