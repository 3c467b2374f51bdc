//! The 8-wide layout of [`super::Bvh`]: eight child boxes tested at once with AVX2, used instead of
//! the 4-wide layout (`node4.rs`) when the CPU has AVX2 and FMA (every AVX2 CPU of Intel and AMD
//! has both; checked at run time with `is_x86_feature_detected!`); the reference slab test lane by
//! lane off x86_64. Leaves are the same four-triangle packets.
//!
//! Based on: Fuetterling, Lojewski, Pfreundt, Ebert. Efficient Ray Tracing Kernels for Modern
//! CPU Architectures. JCGT 4(5), 2015 (BVH8 single-ray traversal with 8-wide box tests).
//!
//! # Layout
//! A node is 224 bytes: the eight child boxes as six rows of eight lanes (min x, y, z,
//! max x, y, z), then per child one `u32` slot, `(offset / 32) << 3 | packets`: an inner
//! child (`packets == 0`) by its node's byte offset in the node array, a leaf by its first
//! packet's byte offset in the packet array and its packet count (1 to 7; leaves hold at most
//! `MAX_LEAF` triangles, so at most 2 packets). Offsets rather than indices: the traversal
//! finds the next node with a mask and the load's address arithmetic, where an index cost a
//! multiplication (3 cycles) on the chain from node to node. Nodes (224 bytes) and packets
//! (160) are multiples of 32 bytes, so 29 bits address 2^29 / 7 nodes and 2^29 / 5 packets
//! (about 430 million triangles).

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256, _mm256_castps_si256, _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_fmadd_ps,
    _mm256_loadu_ps, _mm256_max_epi32, _mm256_max_ps, _mm256_min_epi32, _mm256_min_ps,
    _mm256_movemask_ps, _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps, _mm256_storeu_ps,
    _mm256_sub_ps, _CMP_LE_OQ,
};

use crate::geometry::{Hit, Ray};
use crate::trace::tri4::Tri4;

use super::build::{Node, MAX_LEAF};
use super::node::{record_bytes, Entry, Tree, WideNode};
use super::slab::{empty_boxes, lane_box, set_lane, BoxRay, Boxes};
use super::traverse::{self, stack_size};

/// Bits of a slot that hold a leaf's packet count.
const PACKET_BITS: u32 = 3;

const _: () = assert!(MAX_LEAF.div_ceil(4) < 1 << PACKET_BITS);

/// Slots hold byte offsets in units of this many bytes (nodes and packets are multiples of it).
const UNIT: usize = 32;
/// A node's and a packet's size in [`UNIT`]s.
const NODE_UNITS: usize = std::mem::size_of::<Node8>() / UNIT;
const PACKET_UNITS: usize = std::mem::size_of::<Tri4>() / UNIT;

const _: () = assert!(
    std::mem::size_of::<Node8>().is_multiple_of(UNIT)
        && std::mem::size_of::<Tri4>().is_multiple_of(UNIT)
        && UNIT.is_power_of_two()
        && UNIT.trailing_zeros() >= PACKET_BITS
);

/// An 8-wide node (see the module documentation). Unused slots have [`empty_boxes`]'
/// never-entered boxes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Node8 {
    bounds: Boxes<8>,
    slot: [u32; 8],
}

impl WideNode for Node8 {
    const WIDTH: usize = 8;
    const EMPTY: Node8 = Node8 {
        bounds: empty_boxes(),
        slot: [0; 8],
    };
    /// The child's slot.
    type Child = u32;
    type Dists = [f32; 8];
    type Stack = [Entry<u32>; stack_size(8)];

    fn supported() -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            true
        }
    }

    fn new_stack() -> Self::Stack {
        [Entry::default(); stack_size(8)]
    }

    fn set_box(&mut self, lane: usize, n: &Node) {
        set_lane(&mut self.bounds, lane, n.min, n.max);
    }

    fn child_box(&self, lane: usize) -> ([f32; 3], [f32; 3]) {
        lane_box(&self.bounds, lane)
    }

    fn set_leaf(&mut self, lane: usize, first: u32, packets: u32) {
        let units = first as usize * PACKET_UNITS;
        assert!(
            units < 1 << (32 - PACKET_BITS),
            "at most 2^29 / 5 packets (about 430 million triangles)"
        );
        debug_assert!(packets > 0 && packets < 1 << PACKET_BITS);
        self.slot[lane] = (units as u32) << PACKET_BITS | packets;
    }

    fn set_inner(&mut self, lane: usize, index: usize) {
        let units = index * NODE_UNITS;
        assert!(units < 1 << (32 - PACKET_BITS), "at most 2^29 / 7 nodes");
        self.slot[lane] = (units as u32) << PACKET_BITS;
    }

    #[inline(always)]
    fn child(&self, lane: usize) -> u32 {
        self.slot[lane]
    }

    fn decode(slot: u32) -> (usize, usize) {
        let (offset, packets) = Self::locate(slot);
        (offset / record_bytes::<Self>(packets), packets)
    }

    #[inline(always)]
    fn locate(slot: u32) -> (usize, usize) {
        let low = (1 << PACKET_BITS) - 1;
        // `(slot >> PACKET_BITS) * UNIT`, as a mask and a shift the load's address takes in.
        let offset = ((slot & !low) as usize) << (UNIT.trailing_zeros() - PACKET_BITS);
        (offset, (slot & low) as usize)
    }

    #[inline(always)]
    unsafe fn enter(&self, ray: &BoxRay, t_far: f32, far_slack: f32) -> ([f32; 8], u32) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: the caller guarantees AVX2 (`supported`).
            unsafe { enter_avx2(ray, &self.bounds, t_far, far_slack) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            ray.enter_scalar(&self.bounds, t_far, far_slack)
        }
    }

    #[inline(always)]
    unsafe fn enter_finite(&self, ray: &BoxRay, t_far: f32) -> ([f32; 8], u32) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: the caller guarantees AVX2 (`supported`) and `ray.finite`.
            unsafe { enter_finite_avx2(ray, &self.bounds, t_far) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            ray.enter_finite_scalar(&self.bounds, t_far)
        }
    }

    unsafe fn cast(
        tree: Tree<'_, Self>,
        rays: &[Ray],
        hits: &mut [Hit],
        stack: &mut <Node8 as WideNode>::Stack,
    ) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the caller guarantees AVX2.
        unsafe {
            cast_avx2(tree, rays, hits, stack)
        }
        #[cfg(not(target_arch = "x86_64"))]
        // SAFETY: off x86_64 `enter` is the scalar test, which needs nothing.
        unsafe {
            traverse::cast(tree, rays, hits, stack)
        }
    }

    unsafe fn occluded(
        tree: Tree<'_, Self>,
        rays: &[Ray],
        out: &mut [bool],
        stack: &mut <Node8 as WideNode>::Stack,
    ) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the caller guarantees AVX2.
        unsafe {
            occluded_avx2(tree, rays, out, stack)
        }
        #[cfg(not(target_arch = "x86_64"))]
        // SAFETY: as in `cast`.
        unsafe {
            traverse::occluded(tree, rays, out, stack)
        }
    }
}

/// [`traverse::cast`] compiled with AVX2, so that [`enter_avx2`] is inlined into the loop.
///
/// # Safety
/// The CPU must support AVX2 and FMA ([`Node8::supported`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn cast_avx2(
    tree: Tree<'_, Node8>,
    rays: &[Ray],
    hits: &mut [Hit],
    stack: &mut <Node8 as WideNode>::Stack,
) {
    // SAFETY: the caller guarantees AVX2, all that `Node8::enter` needs.
    unsafe { traverse::cast(tree, rays, hits, stack) }
}

/// [`traverse::occluded`] compiled with AVX2.
///
/// # Safety
/// The CPU must support AVX2 and FMA ([`Node8::supported`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn occluded_avx2(
    tree: Tree<'_, Node8>,
    rays: &[Ray],
    out: &mut [bool],
    stack: &mut <Node8 as WideNode>::Stack,
) {
    // SAFETY: the caller guarantees AVX2, all that `Node8::enter` needs.
    unsafe { traverse::occluded(tree, rays, out, stack) }
}

/// `BoxRay::enter_scalar` on eight boxes with AVX2.
///
/// # Safety
/// The CPU must support AVX2 and FMA ([`Node8::supported`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn enter_avx2(r: &BoxRay, boxes: &Boxes<8>, t_far: f32, far_slack: f32) -> ([f32; 8], u32) {
    let mut out = [0.0f32; 8];
    // SAFETY: the caller guarantees AVX2 (which implies AVX); the loads read the eight floats
    // of one row of `boxes` (`BoxRay::row_ptrs`) and the store writes the eight of `out`.
    let mask = unsafe {
        let mut t0 = _mm256_set1_ps(r.t_min);
        let mut t1 = _mm256_set1_ps(t_far);
        let slack = _mm256_set1_ps(far_slack);
        for a in 0..3 {
            let origin = _mm256_set1_ps(r.origin[a]);
            let inv = _mm256_set1_ps(r.inv[a]);
            let (near, far) = r.row_ptrs(boxes, a);
            let (near, far) = (_mm256_loadu_ps(near), _mm256_loadu_ps(far));
            let tn = _mm256_mul_ps(_mm256_sub_ps(near, origin), inv);
            let tf = _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(far, origin), inv), slack);
            // Operand order matters: the second operand is kept when the first is NaN.
            t0 = _mm256_max_ps(tn, t0);
            t1 = _mm256_min_ps(tf, t1);
        }
        _mm256_storeu_ps(out.as_mut_ptr(), t0);
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32
    };
    (out, mask)
}

/// `BoxRay::enter_finite_scalar` on eight boxes with AVX2: the running bounds as integers
/// (one-cycle `max`/`min`), reduced as a tree (two steps deep rather than three), and no far
/// slack multiplication (it is in `inv_far`). Per node, the chain from the load of a box row
/// to the mask is half as long as [`enter_avx2`]'s, and an incoherent ray's traversal waits
/// on that chain at every node.
///
/// # Safety
/// The CPU must support AVX2 and FMA ([`Node8::supported`]); `r.finite` holds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn enter_finite_avx2(r: &BoxRay, boxes: &Boxes<8>, t_far: f32) -> ([f32; 8], u32) {
    let mut out = [0.0f32; 8];
    // SAFETY: the caller guarantees AVX2 (which implies AVX); the loads read the eight floats
    // of one row of `boxes` (`BoxRay::row_ptrs`) and the store writes the eight of `out`.
    let mask = unsafe {
        let slab = |a: usize| -> (__m256, __m256) {
            let origin = _mm256_set1_ps(r.origin[a]);
            let (near, far) = r.row_ptrs(boxes, a);
            let (near, far) = (_mm256_loadu_ps(near), _mm256_loadu_ps(far));
            let tn = _mm256_mul_ps(_mm256_sub_ps(near, origin), _mm256_set1_ps(r.inv[a]));
            // `* inv_far + 0.0` in one rounding: turns a `-0.0` exit into `+0.0`
            // (`BoxRay::enter_finite_scalar`) at no latency beyond the multiply's.
            let tf = _mm256_fmadd_ps(
                _mm256_sub_ps(far, origin),
                _mm256_set1_ps(r.inv_far[a]),
                _mm256_setzero_ps(),
            );
            (tn, tf)
        };
        let int = |v: __m256| _mm256_castps_si256(v);
        let ((nx, fx), (ny, fy), (nz, fz)) = (slab(0), slab(1), slab(2));
        let t0 = _mm256_max_epi32(
            _mm256_max_epi32(int(nx), int(ny)),
            _mm256_max_epi32(int(nz), int(_mm256_set1_ps(r.t_min))),
        );
        let t1 = _mm256_min_epi32(
            _mm256_min_epi32(int(fx), int(fy)),
            _mm256_min_epi32(int(fz), int(_mm256_set1_ps(t_far))),
        );
        let (t0, t1) = (_mm256_castsi256_ps(t0), _mm256_castsi256_ps(t1));
        _mm256_storeu_ps(out.as_mut_ptr(), t0);
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32
    };
    (out, mask)
}

#[cfg(test)]
mod tests {
    use super::super::slab::kernel_tests;
    use super::*;

    /// The layout's box test, as the traversal calls it. Only called where
    /// [`Node8::supported`].
    fn enter(r: &BoxRay, boxes: &Boxes<8>, t_far: f32, far_slack: f32) -> ([f32; 8], u32) {
        let node = Node8 {
            bounds: *boxes,
            ..Node8::EMPTY
        };
        assert!(Node8::supported());
        // SAFETY: `Node8::supported` was checked just above.
        unsafe { node.enter(r, t_far, far_slack) }
    }

    #[test]
    fn hits_box_ahead_only() {
        if Node8::supported() {
            kernel_tests::hits_box_ahead_only(enter);
        }
    }

    #[test]
    fn empty_boxes_are_never_entered() {
        if Node8::supported() {
            kernel_tests::empty_boxes_are_never_entered(enter);
        }
    }

    #[test]
    fn finite_simd_equals_scalar_on_random_boxes() {
        if Node8::supported() {
            kernel_tests::finite_equals_scalar_on_random_boxes(|r, boxes, t_far| {
                let node = Node8 {
                    bounds: *boxes,
                    ..Node8::EMPTY
                };
                // SAFETY: `Node8::supported` was checked above; `finite_cases` only makes
                // finite rays.
                unsafe { node.enter_finite(r, t_far) }
            });
        }
    }

    #[test]
    fn simd_equals_scalar_on_random_boxes() {
        if Node8::supported() {
            // Some nodes leave empty slots at the end.
            kernel_tests::equals_scalar_on_random_boxes(enter, |i| 8 - i % 7);
        }
    }
}
