//! The binary tree under [`super::Bvh`]: a binned-SAH build over the triangles' boxes, in
//! parallel (`rayon::join` per subtree, parallel binning of large nodes), with an object-median
//! fallback that bounds the depth, and where asked spatial splits (`spatial.rs`): a node may
//! split its triangles' references by a plane rather than sort them to one side, within a
//! budget of extra references that each node shares out to its children as spare room at the
//! end of its run. `collapse.rs` turns the result into wide nodes.
//!
//! Based on: Wald. On fast construction of SAH-based bounding volume hierarchies. 2007
//! (binned SAH build, 16 bins (8 for nodes of up to 64 references), bins keep bounds and
//! centroid bounds so children need no extra pass).
//! Based on: Stich, Friedrich, Dietrich. Spatial splits in bounding volume hierarchies. HPG 2009
//! (the choice between an object and a spatial split per node, tried only where the object
//! split's children overlap).

use crate::geometry::Aabb;

use super::refs::{
    best_split, bin_in_parallel, longest_axis, packet_lanes, share_room, summarize, Bin, Content,
    Corners, Division, Grid, Merge, PrimRef, BINS, INTERSECT_COST,
};
use super::spatial;

/// Largest leaf; bigger nodes are always split.
pub(super) const MAX_LEAF: usize = 8;
/// Subtrees with at least this many triangles are built as a `rayon::join` task.
const PARALLEL_BUILD: usize = 4096;
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
#[derive(Clone, Copy, Debug, Default, bytemuck::Zeroable)]
#[repr(C, align(64))]
pub(super) struct NodePair(pub(super) [Node; 2]);

/// The binary tree over the usable triangles: its root, the pairs its inner nodes point to, and
/// the triangle ids in leaf order (a leaf's `first` indexes `ids`). With spatial splits a
/// triangle may sit in several leaves, and `ids` has unused slots (`refs::UNUSED`) that no leaf
/// covers.
pub(super) struct BinaryTree {
    pub(super) root: Node,
    pub(super) pairs: Vec<NodePair>,
    pub(super) ids: Vec<u32>,
    /// Distinct triangles in the tree.
    pub(super) triangles: usize,
}

/// Builds the binary tree over the triangles whose box in `boxes` (indexed by triangle id) is
/// not empty; `None` when there are none. With `splits`, nodes may split references by
/// planes through the triangles' corners (`spatial.rs`), up to [`SPLIT_BUDGET`] more
/// references than triangles.
pub(super) fn binary_tree(boxes: &[Aabb], splits: Option<Corners>) -> Option<BinaryTree> {
    let mut refs: Vec<PrimRef> = (0..boxes.len() as u32)
        .filter(|&i| !boxes[i as usize].is_empty())
        .map(|i| PrimRef::new(&boxes[i as usize], i))
        .collect();
    let triangles = refs.len();
    if triangles == 0 {
        return None;
    }
    let content = summarize(&refs);
    let capacity = match splits {
        Some(_) => triangles + (triangles as f64 * SPLIT_BUDGET) as usize,
        None => triangles,
    };
    refs.resize(capacity, PrimRef::UNUSED);
    let input = BuildInput {
        splits,
        root_area: content.bounds.surface_area(),
    };
    // Zeroed pages from the allocator: subtrees below `PARALLEL_BUILD` write their pairs
    // contiguously from the start of their room (`build_compact`), about a fifth of it.
    let mut pairs: Vec<NodePair> = bytemuck::zeroed_vec(capacity - 1);
    let root = build_node(
        &input,
        Subtree {
            refs: &mut refs,
            first: 0,
            content,
            depth: 0,
        },
        &mut pairs,
        0,
    );
    let ids = refs.iter().map(|r| r.id).collect();
    Some(BinaryTree {
        root,
        pairs,
        ids,
        triangles,
    })
}

/// Extra references spatial splits may add, as a share of the triangles (Stich et al. let the
/// tree grow unbounded; a budget bounds memory as Embree's `max_spatial_split_replications`).
pub(super) const SPLIT_BUDGET: f64 = 0.2;

/// What every node of the build reads besides its references.
pub(super) struct BuildInput<'a> {
    /// The triangles' corners where spatial splits are allowed.
    pub(super) splits: Option<Corners<'a>>,
    /// The root's surface area: the scale of the overlap worth a spatial split.
    pub(super) root_area: f32,
}

fn bin_triangles(refs: &[PrimRef], grid: &Grid) -> [[Bin; BINS]; 3] {
    bin_in_parallel(refs, |chunk| {
        let mut bins = [[Bin::EMPTY; BINS]; 3];
        for r in chunk {
            let at = grid.bins(r.centroid());
            for (axis, axis_bins) in bins.iter_mut().enumerate() {
                if grid.splits(axis) {
                    axis_bins[at[axis] as usize].add(r.min, r.max);
                }
            }
        }
        bins
    })
}

impl Merge for [[Bin; BINS]; 3] {
    fn merge(&self, other: &Self) -> Self {
        std::array::from_fn(|a| std::array::from_fn(|i| self[a][i].merge(&other[a][i])))
    }
}

/// In-place partition: references whose centroid falls in a bin below `bin` on `axis` come
/// first. Returns their number and the centroid bounds of both sides (the children's binners
/// need them; gathering them here is one pass instead of one per axis in the binning).
fn partition(refs: &mut [PrimRef], grid: &Grid, axis: usize, bin: usize) -> (usize, Aabb, Aabb) {
    let (mut left, mut right) = (Bin::EMPTY, Bin::EMPTY);
    let mut n = 0;
    for j in 0..refs.len() {
        let c = refs[j].centroid();
        if grid.bin(c[axis], axis) < bin {
            left.add(c, c);
            refs.swap(n, j);
            n += 1;
        } else {
            right.add(c, c);
        }
    }
    (n, left.bounds(), right.bounds())
}

/// A subtree to build: its room (its `content.count` references first; the rest is room for
/// the references spatial splits add), where its references start in leaf order, what they
/// hold, and its depth.
struct Subtree<'r> {
    refs: &'r mut [PrimRef],
    first: usize,
    content: Content,
    depth: u32,
}

impl<'r> Subtree<'r> {
    /// The two children, the left one's room first ([`divide`]), or the leaf this subtree
    /// becomes (always for a single reference).
    fn split(self, input: &BuildInput) -> Result<[Subtree<'r>; 2], Node> {
        let Subtree {
            refs,
            first,
            content,
            depth,
        } = self;
        let m = content.count;
        if m == 1 {
            return Err(Node::leaf(&content.bounds, first, 1));
        }
        let Some(Division {
            left_room,
            left,
            right,
        }) = divide(input, refs, &content, depth)
        else {
            return Err(Node::leaf(&content.bounds, first, m));
        };
        debug_assert!(left.count <= left_room);
        let (left_refs, right_refs) = refs.split_at_mut(left_room);
        let child = |refs, first, content| Subtree {
            refs,
            first,
            content,
            depth: depth + 1,
        };
        Ok([
            child(left_refs, first, left),
            child(right_refs, first + left_room, right),
        ])
    }
}

/// Builds `sub` and returns its root. Its descendants are written into `pairs`, which has
/// room for `sub.refs.len() - 1` pairs and starts at pair index `pair_base`: a binary tree
/// over `m` leaves-with-at-least-one-reference has at most `m - 1` inner nodes, each owning
/// one pair, and a subtree never holds more references than its room. Each child gets the
/// pairs of its room, and the two are built as a `rayon::join` task.
fn build_node(input: &BuildInput, sub: Subtree, pairs: &mut [NodePair], pair_base: usize) -> Node {
    debug_assert!(sub.content.count <= sub.refs.len() && pairs.len() + 1 >= sub.refs.len());
    if sub.content.count < PARALLEL_BUILD {
        return build_compact(input, sub, pairs, pair_base, &mut 0);
    }
    let bounds = sub.content.bounds;
    let [left, right] = match sub.split(input) {
        Ok(children) => children,
        Err(leaf) => return leaf,
    };
    let left_room = left.refs.len();
    let (own, rest) = pairs.split_at_mut(1);
    let (left_pairs, right_pairs) = rest.split_at_mut(left_room - 1);
    let (l, r) = rayon::join(
        move || build_node(input, left, left_pairs, pair_base + 1),
        move || build_node(input, right, right_pairs, pair_base + left_room),
    );
    own[0] = NodePair([l, r]);
    Node::inner(&bounds, pair_base)
}

/// [`build_node`] for a subtree of fewer than [`PARALLEL_BUILD`] references, on this thread:
/// its inner nodes take their pairs in depth-first order from `pairs[*next..]` (pair index
/// `pair_base + *next` on), rather than each from the start of its children's rooms. A
/// subtree over `m` references has at most `m - 1` inner nodes, so `pairs` (room for
/// `refs.len() - 1`) suffices, and the pairs written are contiguous: about a fifth of the
/// room (leaves hold about 4.6 references on the 1M city), where the rooms' starts spread
/// the writes over every page of it.
fn build_compact(
    input: &BuildInput,
    sub: Subtree,
    pairs: &mut [NodePair],
    pair_base: usize,
    next: &mut usize,
) -> Node {
    let bounds = sub.content.bounds;
    let [left, right] = match sub.split(input) {
        Ok(children) => children,
        Err(leaf) => return leaf,
    };
    let own = *next;
    *next += 1;
    let l = build_compact(input, left, pairs, pair_base, next);
    let r = build_compact(input, right, pairs, pair_base, next);
    pairs[own] = NodePair([l, r]);
    Node::inner(&bounds, pair_base + own)
}

/// Splits the node's references between two children, the left ones first and the right ones
/// moved to the start of the right child's room; `None` when the node is better a leaf.
fn divide(
    input: &BuildInput,
    refs: &mut [PrimRef],
    content: &Content,
    depth: u32,
) -> Option<Division> {
    let m = content.count;
    let grid = Grid::with_bins(&content.centroids, object_bins(m));
    let object = if depth < MAX_SAH_DEPTH {
        let bins = bin_triangles(&refs[..m], &grid);
        best_split(&bins, &bins, &grid, content.bounds.surface_area())
    } else {
        None
    };
    let leaf_cost = INTERSECT_COST * packet_lanes(m);
    if let Some(splits) = input
        .splits
        .filter(|_| depth < MAX_SAH_DEPTH && refs.len() > m)
    {
        let overlap = object.as_ref().map_or(f32::INFINITY, |s| {
            overlap_area(&s.left.bounds(), &s.right.bounds())
        });
        // A spatial split must beat the object split, and the leaf where a leaf may be made.
        let mut beats = object.as_ref().map_or(f32::INFINITY, |s| s.cost);
        if m <= MAX_LEAF {
            beats = beats.min(leaf_cost);
        }
        if overlap > spatial::MIN_OVERLAP * input.root_area && m > spatial::MIN_REFERENCES {
            if let Some(d) = spatial::divide(
                refs,
                content,
                splits,
                beats,
                object.as_ref().map(|s| s.axis),
            ) {
                return Some(d);
            }
        }
    }
    let (left_count, left, right) = match object {
        Some(s) if m > MAX_LEAF || s.cost < leaf_cost => {
            let (n, lc, rc) = partition(&mut refs[..m], &grid, s.axis, s.bin);
            debug_assert_eq!(n, s.left.count);
            let side = |b: &Bin, centroids| Content {
                bounds: b.bounds(),
                centroids,
                count: b.count,
            };
            (n, side(&s.left, lc), side(&s.right, rc))
        }
        _ if m <= MAX_LEAF => return None,
        _ => {
            // No usable SAH split (identical centroids, or too deep): the object median along
            // the longest centroid axis. With identical centroids this is a split by index.
            let axis = longest_axis(content.centroids.extent());
            let half = m / 2;
            refs[..m].select_nth_unstable_by(half, |p, q| {
                let cp = p.centroid()[axis];
                let cq = q.centroid()[axis];
                cp.total_cmp(&cq).then(p.id.cmp(&q.id))
            });
            let (l, r) = refs[..m].split_at(half);
            (half, summarize(l), summarize(r))
        }
    };
    let left_room = share_room(refs.len(), left_count, m - left_count);
    refs.copy_within(left_count..m, left_room);
    Some(Division {
        left_room,
        left,
        right,
    })
}

/// Nodes with at most this many references sweep [`SMALL_NODE_BINS`] bins for their object
/// split, not [`BINS`]: most nodes are small, and there the sweep over 3 x 15 planes, not the
/// binning, is the cost (`best_split` was 21 % of the 1M city's build without splits).
const SMALL_NODE: usize = 64;
/// Bins per axis for nodes of up to [`SMALL_NODE`] references. Against 16 everywhere
/// (docs/BENCHMARKS.md, 2026-12-07): 16 % fewer instructions for the 1M city's build without
/// splits; nodes, leaves and packets per ray within 1 % on czest3ctf, munich and the bunny
/// (up to 256 references, munich's nodes per ray grew 1 %).
const SMALL_NODE_BINS: usize = 8;

/// Bins per axis for the object split of a node of `m` references.
fn object_bins(m: usize) -> usize {
    if m <= SMALL_NODE {
        SMALL_NODE_BINS
    } else {
        BINS
    }
}

/// Surface area of the intersection of two boxes (0 when they are disjoint).
fn overlap_area(a: &Aabb, b: &Aabb) -> f32 {
    let min = a.min.max(b.min);
    let max = a.max.min(b.max);
    if min.cmple(max).all() {
        Aabb::new(min, max).surface_area()
    } else {
        0.0
    }
}
