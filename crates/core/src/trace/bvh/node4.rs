//! The 4-wide layout of [`super::Bvh`]: four child boxes tested at once with SSE on x86_64
//! (part of its baseline, so no runtime detection), the reference slab test lane by lane
//! elsewhere. Used where the CPU lacks AVX2 (`node8.rs`).
//!
//! Based on: Wald, Benthin, Boulos. Getting rid of packets: efficient SIMD single-ray traversal
//! using multi-branching BVHs. IRT 2008 (the 4-wide tree and its SSE box test).
//!
//! # Layout
//! A node is 128 bytes on two cache lines: the four child boxes as six rows of four lanes
//! (min x, y, z, max x, y, z), then per child its node index or first packet, and its packet
//! count (0 for an inner child).

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    _mm_cmple_ps, _mm_loadu_ps, _mm_max_ps, _mm_min_ps, _mm_movemask_ps, _mm_mul_ps, _mm_set1_ps,
    _mm_sub_ps,
};

use crate::geometry::{Hit, Ray};

use super::build::Node;
use super::node::{Entry, Tree, WideNode};
use super::slab::{empty_boxes, lane_box, set_lane, BoxRay, Boxes};
use super::traverse::{self, stack_size, ROBUST_FAR};

/// A 4-wide node (see the module documentation). Unused slots have [`empty_boxes`]'
/// never-entered boxes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct Node4 {
    bounds: Boxes<4>,
    child: [u32; 4],
    count: [u32; 4],
}

/// A child of a [`Node4`] on the traversal stack: its node index or first packet, and its
/// packet count (0 for an inner child).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Child4 {
    child: u32,
    count: u32,
}

impl WideNode for Node4 {
    const WIDTH: usize = 4;
    const EMPTY: Node4 = Node4 {
        bounds: empty_boxes(),
        child: [0; 4],
        count: [0; 4],
    };
    type Child = Child4;
    type Dists = [f32; 4];
    type Stack = [Entry<Child4>; stack_size(4)];

    fn supported() -> bool {
        true
    }

    fn new_stack() -> Self::Stack {
        [Entry::default(); stack_size(4)]
    }

    fn set_box(&mut self, lane: usize, n: &Node) {
        set_lane(&mut self.bounds, lane, n.min, n.max);
    }

    fn child_box(&self, lane: usize) -> ([f32; 3], [f32; 3]) {
        lane_box(&self.bounds, lane)
    }

    fn set_leaf(&mut self, lane: usize, first: u32, packets: u32) {
        debug_assert!(packets > 0);
        self.child[lane] = first;
        self.count[lane] = packets;
    }

    fn set_inner(&mut self, lane: usize, index: usize) {
        self.child[lane] = index as u32;
    }

    #[inline(always)]
    fn child(&self, lane: usize) -> Child4 {
        Child4 {
            child: self.child[lane],
            count: self.count[lane],
        }
    }

    #[inline(always)]
    fn decode(child: Child4) -> (usize, usize) {
        (child.child as usize, child.count as usize)
    }

    #[inline(always)]
    unsafe fn enter(&self, ray: &BoxRay, t_far: f32, far_slack: f32) -> ([f32; 4], u32) {
        #[cfg(target_arch = "x86_64")]
        {
            enter_sse(ray, &self.bounds, t_far, far_slack)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            ray.enter_scalar(&self.bounds, t_far, far_slack)
        }
    }

    #[inline(always)]
    unsafe fn enter_finite(&self, ray: &BoxRay, t_far: f32) -> ([f32; 4], u32) {
        // SSE2 has no 32-bit integer max and min (SSE4.1 does), so the NaN-aware test serves.
        // SAFETY: as `enter`, which the caller's guarantee covers.
        unsafe { self.enter(ray, t_far, ROBUST_FAR) }
    }

    unsafe fn cast(
        tree: Tree<'_, Self>,
        rays: &[Ray],
        hits: &mut [Hit],
        stack: &mut <Self as WideNode>::Stack,
    ) {
        // SAFETY: `enter` needs nothing beyond the baseline (`supported` is always true).
        unsafe { traverse::cast(tree, rays, hits, stack) }
    }

    unsafe fn occluded(
        tree: Tree<'_, Self>,
        rays: &[Ray],
        out: &mut [bool],
        stack: &mut <Self as WideNode>::Stack,
    ) {
        // SAFETY: as in `cast`.
        unsafe { traverse::occluded(tree, rays, out, stack) }
    }
}

/// `BoxRay::enter_scalar` on four boxes with SSE.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn enter_sse(r: &BoxRay, boxes: &Boxes<4>, t_far: f32, far_slack: f32) -> ([f32; 4], u32) {
    // SAFETY: SSE is part of the x86_64 baseline, so these intrinsics are available on
    // every x86_64 CPU; the loads read one row of `boxes` each (`BoxRay::row_ptrs`).
    unsafe {
        let mut t0 = _mm_set1_ps(r.t_min);
        let mut t1 = _mm_set1_ps(t_far);
        let slack = _mm_set1_ps(far_slack);
        for a in 0..3 {
            let origin = _mm_set1_ps(r.origin[a]);
            let inv = _mm_set1_ps(r.inv[a]);
            let (near, far) = r.row_ptrs(boxes, a);
            let (near, far) = (_mm_loadu_ps(near), _mm_loadu_ps(far));
            let tn = _mm_mul_ps(_mm_sub_ps(near, origin), inv);
            let tf = _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(far, origin), inv), slack);
            // Operand order matters: the second operand is kept when the first is NaN.
            t0 = _mm_max_ps(tn, t0);
            t1 = _mm_min_ps(tf, t1);
        }
        let mask = _mm_movemask_ps(_mm_cmple_ps(t0, t1)) as u32;
        (bytemuck::cast(t0), mask)
    }
}

#[cfg(test)]
mod tests {
    use super::super::slab::kernel_tests;
    use super::*;

    /// The layout's box test, as the traversal calls it.
    fn enter(r: &BoxRay, boxes: &Boxes<4>, t_far: f32, far_slack: f32) -> ([f32; 4], u32) {
        let node = Node4 {
            bounds: *boxes,
            ..Node4::EMPTY
        };
        // SAFETY: `Node4::supported` is always true.
        unsafe { node.enter(r, t_far, far_slack) }
    }

    #[test]
    fn hits_box_ahead_only() {
        kernel_tests::hits_box_ahead_only(enter);
    }

    #[test]
    fn empty_boxes_are_never_entered() {
        kernel_tests::empty_boxes_are_never_entered(enter);
    }

    #[test]
    fn simd_equals_scalar_on_random_boxes() {
        // Every fifth node leaves lane 3 an empty slot.
        kernel_tests::equals_scalar_on_random_boxes(enter, |i| if i % 5 == 0 { 3 } else { 4 });
    }

    #[test]
    fn finite_test_is_the_nan_aware_test() {
        kernel_tests::finite_cases::<4>(|i, r, boxes, t_far| {
            let node = Node4 {
                bounds: *boxes,
                ..Node4::EMPTY
            };
            // SAFETY: the 4-wide test needs nothing beyond the x86-64 baseline.
            let finite = unsafe { node.enter_finite(r, t_far) };
            assert_eq!(finite, enter(r, boxes, t_far, ROBUST_FAR), "case {i}");
        });
    }
}
