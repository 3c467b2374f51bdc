//! The tree of [`super::Bvh`] as plain arrays, for traversal engines outside this crate (the
//! GPU ray caster of `sightline-gpu`): the same binned-SAH binary tree (`build.rs`), without
//! spatial splits (each triangle in one leaf; splits on the GPU are not measured yet), collapsed
//! to nodes of a width the caller picks by the same rule as the CPU's wide nodes
//! (`collapse.rs`: open the inner child of largest surface area until the node is full), with
//! leaves as runs of triangle ids instead of SIMD packets.
//!
//! Based on: Wald. On fast construction of SAH-based bounding volume hierarchies. 2007.
//! Based on: Wald, Benthin, Boulos. Getting rid of packets: efficient SIMD single-ray traversal
//! using multi-branching BVHs. IRT 2008 (collapsing the binary tree, largest surface area first).

use crate::scene::Scene;

use super::build::{self, Node, NodePair, MAX_LEAF};
use super::collapse::{open_children, MAX_WIDTH};
use super::input::triangle_boxes;

/// What a child slot of a [`FlatBvh`] node holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlatLink {
    /// An unused slot (nodes have fewer children than the width where the tree runs out).
    Empty,
    /// The inner node at this index ([`FlatBvh::node`]).
    Inner(u32),
    /// A leaf: `count` (1 to [`FlatBvh::MAX_LEAF`]) triangles from position `first` of
    /// [`FlatBvh::triangles`] on.
    Leaf {
        /// First position in [`FlatBvh::triangles`].
        first: u32,
        /// Number of triangles.
        count: u32,
    },
}

/// A child slot of a [`FlatBvh`] node: the child's box and what it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlatChild {
    /// Box minimum (meaningless for [`FlatLink::Empty`]).
    pub min: [f32; 3],
    /// Box maximum (meaningless for [`FlatLink::Empty`]).
    pub max: [f32; 3],
    /// The child.
    pub link: FlatLink,
}

impl FlatChild {
    const EMPTY: FlatChild = FlatChild {
        min: [0.0; 3],
        max: [0.0; 3],
        link: FlatLink::Empty,
    };
}

/// The BVH's tree collapsed to nodes of `width` children, as plain arrays.
///
/// ```
/// use glam::Vec3;
/// use sightline_core::scene::SceneBuilder;
/// use sightline_core::trace::bvh::{FlatBvh, FlatLink};
///
/// let mut b = SceneBuilder::new("one box");
/// b.add_box(Vec3::splat(1.0), Vec3::splat(2.0));
/// let flat = FlatBvh::build(&b.finish(), 4);
/// assert_eq!(flat.triangles().len(), 12);
/// assert!(flat.node(0).iter().any(|c| c.link != FlatLink::Empty));
/// ```
#[derive(Clone, Debug)]
pub struct FlatBvh {
    width: usize,
    /// Node `i` is `children[i * width..(i + 1) * width]`; the root is node 0.
    children: Vec<FlatChild>,
    /// Triangle ids in leaf order.
    triangles: Vec<u32>,
}

impl FlatBvh {
    /// Most triangles in one leaf.
    pub const MAX_LEAF: usize = MAX_LEAF;
    /// Widest node [`FlatBvh::build`] makes.
    pub const MAX_WIDTH: usize = MAX_WIDTH;

    /// Builds the tree of [`super::Bvh::build`] for `scene` and collapses it to nodes of `width`
    /// children. Triangles the leaf test can never hit (degenerate, non-finite, an index out of
    /// range) are left out; a scene without others has no nodes. A root that is a leaf gets a
    /// node of its own.
    ///
    /// # Panics
    /// If `width` is not in `2..=`[`FlatBvh::MAX_WIDTH`] (a constant of the caller's layout).
    pub fn build(scene: &Scene, width: usize) -> Self {
        assert!(
            (2..=MAX_WIDTH).contains(&width),
            "node width {width} is not in 2..={MAX_WIDTH}"
        );
        let Some(tree) = build::binary_tree(&triangle_boxes(scene), None) else {
            return Self {
                width,
                children: Vec::new(),
                triangles: Vec::new(),
            };
        };
        let mut children = Vec::with_capacity((tree.pairs.len() / (width / 2).max(1) + 1) * width);
        if tree.root.is_leaf() {
            children.resize(width, FlatChild::EMPTY);
            children[0] = leaf(&tree.root);
        } else {
            flatten_inner(&tree.root, &tree.pairs, width, &mut children);
        }
        children.shrink_to_fit();
        Self {
            width,
            children,
            triangles: tree.ids,
        }
    }

    /// Children per node.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of nodes (0 for a scene without hittable triangles).
    pub fn node_count(&self) -> usize {
        self.children.len() / self.width
    }

    /// The `width` child slots of node `index` (`index < node_count()`).
    pub fn node(&self, index: usize) -> &[FlatChild] {
        &self.children[index * self.width..(index + 1) * self.width]
    }

    /// All nodes' child slots, node after node.
    pub fn children(&self) -> &[FlatChild] {
        &self.children
    }

    /// Triangle ids in leaf order (each hittable triangle once).
    pub fn triangles(&self) -> &[u32] {
        &self.triangles
    }
}

fn with_box(n: &Node, link: FlatLink) -> FlatChild {
    FlatChild {
        min: n.min,
        max: n.max,
        link,
    }
}

fn leaf(n: &Node) -> FlatChild {
    with_box(
        n,
        FlatLink::Leaf {
            first: n.first,
            count: n.count,
        },
    )
}

/// Appends the node that replaces binary node `inner`, then its inner children's subtrees
/// (depth first, as `collapse.rs`); returns its index.
fn flatten_inner(inner: &Node, pairs: &[NodePair], width: usize, out: &mut Vec<FlatChild>) -> u32 {
    let index = out.len() / width;
    out.resize(out.len() + width, FlatChild::EMPTY);
    let mut buffer = [Node::default(); MAX_WIDTH];
    let kids = &mut buffer[..width];
    let len = open_children(inner, pairs, kids);
    for (lane, kid) in kids[..len].iter().enumerate() {
        let child = if kid.is_leaf() {
            leaf(kid)
        } else {
            let at = flatten_inner(kid, pairs, width, out);
            with_box(kid, FlatLink::Inner(at))
        };
        out[index * width + lane] = child;
    }
    index as u32
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::scene::SceneBuilder;

    fn boxes(n: usize) -> Scene {
        let mut b = SceneBuilder::new("boxes");
        for i in 0..n {
            let p = Vec3::new(i as f32 * 3.0, (i % 7) as f32, (i % 3) as f32);
            b.add_box(p, p + Vec3::ONE);
        }
        b.finish()
    }

    #[test]
    fn empty_scene_has_no_nodes() {
        let flat = FlatBvh::build(&Scene::default(), 2);
        assert_eq!(flat.node_count(), 0);
        assert!(flat.triangles().is_empty());
    }

    #[test]
    fn single_leaf_root_gets_a_node() {
        let mut b = SceneBuilder::new("one triangle");
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y].map(|p| b.add_vertex(p));
        b.add_triangle(v);
        let flat = FlatBvh::build(&b.finish(), 4);
        assert_eq!(flat.node_count(), 1);
        assert_eq!(flat.node(0)[0].link, FlatLink::Leaf { first: 0, count: 1 });
        assert_eq!(flat.node(0)[1].link, FlatLink::Empty);
    }

    #[test]
    fn every_triangle_is_in_exactly_one_leaf_inside_its_boxes() {
        let scene = boxes(200);
        for width in [2, 4, 8] {
            let flat = FlatBvh::build(&scene, width);
            let mut seen = vec![0u32; scene.triangles.len()];
            let mut reached = vec![false; flat.node_count()];
            reached[0] = true;
            for (i, c) in flat.children().iter().enumerate() {
                assert!(reached[i / width], "node {} unreachable", i / width);
                match c.link {
                    FlatLink::Empty => {}
                    FlatLink::Inner(n) => {
                        assert!((n as usize) > i / width, "children come after parents");
                        reached[n as usize] = true;
                        for &cc in flat.node(n as usize) {
                            if cc.link != FlatLink::Empty {
                                for a in 0..3 {
                                    assert!(c.min[a] <= cc.min[a] && cc.max[a] <= c.max[a]);
                                }
                            }
                        }
                    }
                    FlatLink::Leaf { first, count } => {
                        assert!(count >= 1 && count as usize <= FlatBvh::MAX_LEAF);
                        for &id in &flat.triangles()[first as usize..(first + count) as usize] {
                            seen[id as usize] += 1;
                            for &v in &scene.triangles[id as usize] {
                                let p = scene.positions[v as usize];
                                for a in 0..3 {
                                    assert!(c.min[a] <= p[a] && p[a] <= c.max[a]);
                                }
                            }
                        }
                    }
                }
            }
            assert!(seen.iter().all(|&s| s == 1), "width {width}");
        }
    }

    #[test]
    #[should_panic(expected = "node width")]
    fn width_one_panics() {
        let _ = FlatBvh::build(&boxes(2), 1);
    }
}
