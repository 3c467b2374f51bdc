//! What a wide node layout of [`super::Bvh`] provides, so that one collapse (`collapse.rs`) and
//! one traversal (`traverse.rs`) serve every width. A new layout (another width, compressed
//! boxes, another SIMD kernel) is one new file implementing [`WideNode`], plus its variant in
//! `Nodes` and its pick in `Width` (`mod.rs`). The two types the trait's methods name live here
//! too, beside it: the traversal stack's [`Entry`] and the [`Tree`] a traversal reads.
//!
//! Based on: Embree's `kernels/bvh` (one BVH-N traverser templated on the node width N).

use crate::geometry::{Hit, Ray};
use crate::trace::tri4::Tri4;

use super::build::Node;
use super::slab::BoxRay;

/// A node of up to [`WideNode::WIDTH`] children: their boxes side by side (one SIMD lane per
/// child) and, per child, either an inner node's index or a leaf's run of packets.
pub(super) trait WideNode: Copy + Sized {
    /// Children per node: a power of two (lane indices are masked with `WIDTH - 1`), at most
    /// [`super::collapse::MAX_WIDTH`].
    const WIDTH: usize;
    /// A node without children: every box is never entered, so unused slots need no count.
    const EMPTY: Self;
    /// What the traversal stack keeps of a child (the default is the root, node 0).
    type Child: Copy + Default;
    /// The entry distances of the `WIDTH` children, as [`WideNode::enter`] returns them.
    type Dists: Copy + std::ops::Index<usize, Output = f32>;
    /// The traversal stack: [`super::traverse::stack_size`]`(WIDTH)` entries.
    type Stack: AsMut<[Entry<Self::Child>]>;

    /// True when this CPU can run [`WideNode::enter`] (and so [`WideNode::cast`] and
    /// [`WideNode::occluded`]).
    fn supported() -> bool;

    /// A fresh traversal stack.
    fn new_stack() -> Self::Stack;

    /// Sets the box of child `lane` to binary node `n`'s box.
    fn set_box(&mut self, lane: usize, n: &Node);

    /// The `(min, max)` corners of child `lane`'s box (min above max for an unused slot).
    fn child_box(&self, lane: usize) -> ([f32; 3], [f32; 3]);

    /// Makes child `lane` a leaf of `packets` packets from `first` on (`packets` > 0).
    fn set_leaf(&mut self, lane: usize, first: u32, packets: u32);

    /// Makes child `lane` the inner node at `index`.
    fn set_inner(&mut self, lane: usize, index: usize);

    /// Child `lane` (`lane < WIDTH`) as the stack keeps it.
    fn child(&self, lane: usize) -> Self::Child;

    /// `(index, packets)` of a child: an inner node's index and 0, or a leaf's first packet and
    /// its packet count.
    fn decode(child: Self::Child) -> (usize, usize);

    /// [`WideNode::decode`] for the traversal: `(offset, packets)` with the child's byte
    /// offset in the node array (an inner node) or the packet array (a leaf). A layout whose
    /// slots hold offsets finds it with a mask, where an index costs a multiplication on the
    /// chain from one node to the next.
    #[inline(always)]
    fn locate(child: Self::Child) -> (usize, usize) {
        let (index, packets) = Self::decode(child);
        (index * record_bytes::<Self>(packets), packets)
    }

    /// Per lane, the entry distance into the child's box clipped to `[ray.t_min, t_far]`
    /// (far distances scaled by `far_slack`), and a bit mask of the lanes whose box the ray
    /// enters (bit `i` for lane `i`): exactly `BoxRay::enter_scalar`'s bits.
    ///
    /// # Safety
    /// The CPU must have what [`WideNode::supported`] checks.
    unsafe fn enter(&self, ray: &BoxRay, t_far: f32, far_slack: f32) -> (Self::Dists, u32);

    /// [`WideNode::enter`] with the traversal's far slack for a ray whose [`BoxRay::finite`]
    /// holds: the same entry distances, and a mask of at least the lanes `enter` gives. A
    /// layout with a cheaper kernel for such rays gives `BoxRay::enter_finite_scalar`'s bits;
    /// one without calls `enter`.
    ///
    /// # Safety
    /// As [`WideNode::enter`]; `ray.finite` holds.
    unsafe fn enter_finite(&self, ray: &BoxRay, t_far: f32) -> (Self::Dists, u32);

    /// Closest hits of `rays` by [`super::traverse::cast`], compiled with the CPU features
    /// [`WideNode::enter`] needs, with `stack` as the traversal stack.
    ///
    /// # Safety
    /// As [`WideNode::enter`].
    unsafe fn cast(tree: Tree<'_, Self>, rays: &[Ray], hits: &mut [Hit], stack: &mut Self::Stack);

    /// Any-hit tests of `rays` by [`super::traverse::occluded`], compiled as
    /// [`WideNode::cast`].
    ///
    /// # Safety
    /// As [`WideNode::enter`].
    unsafe fn occluded(
        tree: Tree<'_, Self>,
        rays: &[Ray],
        out: &mut [bool],
        stack: &mut Self::Stack,
    );
}

/// A node on the traversal stack: what the parent node says of the child, and its entry
/// distance.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Entry<C> {
    pub(super) child: C,
    pub(super) t: f32,
}

/// The arrays one traversal reads: the nodes (the root first) and the triangle packets in leaf
/// order.
///
/// Invariant, which the traversal's unchecked indexing relies on: every child slot of every
/// node indexes `nodes` (an inner child) or a run of `packets` (a leaf). `Bvh::build_with`
/// checks it with [`assert_children_in_range`] before the tree is ever traversed, and a `Tree`
/// is only made from a built `Bvh`'s arrays.
#[derive(Clone, Copy, Debug)]
pub(super) struct Tree<'a, N> {
    pub(super) nodes: &'a [N],
    pub(super) packets: &'a [Tri4],
}

impl<N: WideNode> Tree<'_, N> {
    /// Asks the CPU to start loading `child` (a node, or a leaf's first packet). A ray pushes
    /// the farther children it enters and pops most of them later, when a cache miss would
    /// stall the loop; on scenes larger than the caches a traversal is bound by such misses,
    /// and a hint costs a few instructions.
    ///
    /// The address is picked without a branch (node or packet is unpredictable for incoherent
    /// rays), and the same run of lines is fetched for both: the larger of a node and a
    /// packet (with 8-wide nodes, a packet and the start of the next one, a leaf's second
    /// packet when it has one).
    #[inline(always)]
    pub(super) fn prefetch(&self, child: N::Child) {
        let (offset, packets) = N::locate(child);
        let node = self.nodes.as_ptr().cast::<i8>().wrapping_add(offset);
        let packet = self.packets.as_ptr().cast::<i8>().wrapping_add(offset);
        let start = if packets > 0 { packet } else { node };
        let size = std::mem::size_of::<N>().max(std::mem::size_of::<Tri4>());
        prefetch_lines(start, size);
    }
}

impl<'a, N: WideNode> Tree<'a, N> {
    /// The inner node at byte `offset` of `nodes` ([`WideNode::locate`]).
    ///
    /// # Safety
    /// `offset` is an inner child's, located from a slot of this tree's nodes (then it is in
    /// range: `Tree`'s invariant).
    #[inline(always)]
    pub(super) unsafe fn node_at(&self, offset: usize) -> &'a N {
        debug_assert!(offset.is_multiple_of(std::mem::size_of::<N>()));
        debug_assert!(offset / std::mem::size_of::<N>() < self.nodes.len());
        // SAFETY: the caller's guarantee.
        unsafe { &*self.nodes.as_ptr().cast::<u8>().add(offset).cast::<N>() }
    }

    /// The `count` packets from byte `offset` of `packets` ([`WideNode::locate`]).
    ///
    /// # Safety
    /// As [`Tree::node_at`], for a leaf child.
    #[inline(always)]
    pub(super) unsafe fn packets_at(&self, offset: usize, count: usize) -> &'a [Tri4] {
        debug_assert!(offset.is_multiple_of(std::mem::size_of::<Tri4>()));
        debug_assert!(offset / std::mem::size_of::<Tri4>() + count <= self.packets.len());
        // SAFETY: the caller's guarantee.
        unsafe {
            let first = self
                .packets
                .as_ptr()
                .cast::<u8>()
                .add(offset)
                .cast::<Tri4>();
            std::slice::from_raw_parts(first, count)
        }
    }
}

/// One prefetch hint per 64 bytes of the `size` bytes from `start` and one for the last
/// byte, which covers every cache line they touch, unrolled for the fixed sizes of nodes (a
/// generic helper that counts the lines at run time looped for every pushed child). A
/// prefetch never faults, so `start` may point anywhere.
#[inline(always)]
fn prefetch_lines(start: *const i8, size: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let mut offset = 0;
        while offset < size {
            // SAFETY: SSE is part of the x86-64 baseline, and a prefetch never faults nor
            // reads anything into the program, whatever the address.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(offset)) };
            offset += 64;
        }
        // SAFETY: as above.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(size.max(1) - 1)) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (start, size);
}

/// The size of what a child with `packets` packets points at: a packet of a leaf's run, or an
/// inner node; the unit between a child's index and its byte offset ([`WideNode::locate`]).
#[inline(always)]
pub(super) const fn record_bytes<N: WideNode>(packets: usize) -> usize {
    if packets > 0 {
        std::mem::size_of::<Tri4>()
    } else {
        std::mem::size_of::<N>()
    }
}

/// Panics unless every child slot of `nodes` indexes `nodes` or a run of the `packets` packets:
/// [`Tree`]'s invariant, checked once per build (a pass over the nodes, a few milliseconds for
/// a million triangles) so that the traversal may index without bounds checks.
pub(super) fn assert_children_in_range<N: WideNode>(nodes: &[N], packets: usize) {
    for (i, node) in nodes.iter().enumerate() {
        for lane in 0..N::WIDTH {
            // As the traversal reads the slot.
            let (offset, count) = N::locate(node.child(lane));
            let size = record_bytes::<N>(count);
            let (index, aligned) = (offset / size, offset.is_multiple_of(size));
            let in_range = if count > 0 {
                index.checked_add(count).is_some_and(|end| end <= packets)
            } else {
                index < nodes.len()
            };
            assert!(
                aligned && in_range,
                "node {i} lane {lane}: child at byte {offset} ({count} packets) out of range"
            );
        }
    }
}
