//! Collapsing the binary tree of `build.rs` into wide nodes of any layout ([`WideNode`]),
//! depth first (a subtree's nodes are close together); the root is node 0. Each wide node takes
//! the binary node's two children and keeps opening the child with the largest surface area
//! (the likeliest to be entered) until it has `WIDTH`.
//!
//! Based on: Wald, Benthin, Boulos. Getting rid of packets: efficient SIMD single-ray traversal
//! using multi-branching BVHs. IRT 2008 (collapsing the binary tree, largest surface area first).
//! Based on: Ernst, Greiner. Multi bounding volume hierarchies. IRT 2008.

use glam::Vec3;

use crate::geometry::Aabb;

use super::build::{Node, NodePair};
use super::node::WideNode;

/// The widest node [`collapse`] fills (the size of its buffer of opened children).
pub(super) const MAX_WIDTH: usize = 16;

fn node_area(n: &Node) -> f32 {
    Aabb::new(Vec3::from_array(n.min), Vec3::from_array(n.max)).surface_area()
}

/// Collapses the binary tree under `root` (whose inner nodes point into `sparse`) into nodes
/// of layout `N`; a root leaf gets a node of its own.
///
/// `pack(first, count)` turns a binary leaf (a range of triangles in leaf order) into packets
/// and returns the first packet's index and the packet count, which the wide node stores.
pub(super) fn collapse<N: WideNode>(
    root: &Node,
    sparse: &[NodePair],
    pack: &mut impl FnMut(u32, u32) -> (u32, u32),
) -> Vec<N> {
    const { assert!(N::WIDTH.is_power_of_two() && N::WIDTH >= 2 && N::WIDTH <= MAX_WIDTH) };
    // Each wide node replaces at least `WIDTH / 2` binary inner nodes, one per pair.
    let mut nodes = Vec::with_capacity(sparse.len() / (N::WIDTH / 2) + 1);
    if root.is_leaf() {
        let mut n = N::EMPTY;
        n.set_box(0, root);
        let (first, count) = pack(root.first, root.count);
        n.set_leaf(0, first, count);
        nodes.push(n);
    } else {
        collapse_inner(root, sparse, pack, &mut nodes);
    }
    nodes
}

/// Fills `kids` (`WIDTH` long) with the nodes that replace binary node `inner` in a wide node:
/// its two children, then the inner child with the largest surface area (the likeliest to be
/// entered) opened again and again until there are `WIDTH` or only leaves (Wald et al. 2008).
/// Returns their number.
pub(super) fn open_children(inner: &Node, sparse: &[NodePair], kids: &mut [Node]) -> usize {
    kids[..2].copy_from_slice(&sparse[inner.first as usize].0);
    let mut len = 2;
    while len < kids.len() {
        let widest = (0..len)
            .filter(|&i| !kids[i].is_leaf())
            .max_by(|&i, &j| node_area(&kids[i]).total_cmp(&node_area(&kids[j])));
        let Some(w) = widest else { break };
        let [l, r] = sparse[kids[w].first as usize].0;
        kids[w] = l;
        kids[len] = r;
        len += 1;
    }
    len
}

/// Appends the wide node that replaces binary node `inner`, then its inner children's
/// subtrees; returns its index.
fn collapse_inner<N: WideNode>(
    inner: &Node,
    sparse: &[NodePair],
    pack: &mut impl FnMut(u32, u32) -> (u32, u32),
    out: &mut Vec<N>,
) -> usize {
    let index = out.len();
    out.push(N::EMPTY);
    let mut buffer = [Node::default(); MAX_WIDTH];
    let kids = &mut buffer[..N::WIDTH];
    let len = open_children(inner, sparse, kids);
    let mut node = N::EMPTY;
    for (lane, kid) in kids[..len].iter().enumerate() {
        node.set_box(lane, kid);
        if kid.is_leaf() {
            let (first, count) = pack(kid.first, kid.count);
            node.set_leaf(lane, first, count);
        } else {
            let child = collapse_inner(kid, sparse, pack, out);
            node.set_inner(lane, child);
        }
    }
    out[index] = node;
    index
}
