//! The 8-wide layout of [`Bvh`]: the binary tree collapsed into nodes of eight children whose
//! boxes are tested at once with AVX2 (`box8.rs`), traversed with a stack, nearer children
//! first. Used instead of the 4-wide layout when the CPU has AVX2; leaves are the same
//! four-triangle packets.
//!
//! Based on: Fuetterling, Lojewski, Pfreundt, Ebert. Efficient Ray Tracing Kernels for Modern
//! CPU Architectures. JCGT 4(5), 2015 (BVH8 single-ray traversal with 8-wide box tests).
//! Based on: Wald, Benthin, Boulos. Getting rid of packets. IRT 2008 (collapsing the binary
//! tree, largest surface area first).
//!
//! # Layout
//! A node is 224 bytes: the eight child boxes as six rows of eight lanes (min x, y, z,
//! max x, y, z), then per child one `u32` slot, `index << 3 | packets`: an inner child
//! (`packets == 0`) by its node index, a leaf by its first packet and packet count (1 to 7;
//! leaves hold at most `MAX_LEAF` triangles, so at most 2 packets).

use crate::geometry::{Hit, Ray};

use super::super::box4::BoxRay;
#[cfg(target_arch = "x86_64")]
use super::super::box8::enter8_avx2;
use super::super::box8::{Boxes8, EMPTY_BOXES8};
#[cfg(target_arch = "x86_64")]
use super::super::tri4::intersect4;
#[cfg(target_arch = "x86_64")]
use super::super::triangle::ShearedRay;
use super::{
    open_children, slack_up, Bvh, Node, NodePair, Tri4, CULL_SLACK, MAX_LEAF, MAX_SAH_DEPTH,
    ROBUST_FAR,
};

/// Bits of a slot that hold a leaf's packet count.
const PACKET_BITS: u32 = 3;
/// Traversal stack size: as `bvh::STACK_SIZE`, with at most seven nodes pushed per level.
const STACK_SIZE8: usize = 7 * (MAX_SAH_DEPTH as usize + 32) + 1;

const _: () = assert!(MAX_LEAF.div_ceil(4) < 1 << PACKET_BITS);

/// An 8-wide node (see the module documentation). Unused slots have [`EMPTY_BOXES8`]'
/// never-entered boxes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(in super::super) struct Node8 {
    bounds: Boxes8,
    slot: [u32; 8],
}

impl Node8 {
    const EMPTY: Node8 = Node8 {
        bounds: EMPTY_BOXES8,
        slot: [0; 8],
    };

    fn set_box(&mut self, lane: usize, n: &Node) {
        for a in 0..3 {
            self.bounds[a][lane] = n.min[a];
            self.bounds[a + 3][lane] = n.max[a];
        }
    }
}

/// The slot of a leaf whose packets `pack` placed at `(first, count)`.
fn leaf_slot(first: u32, count: u32) -> u32 {
    assert!(
        first < 1 << (32 - PACKET_BITS),
        "at most 2^29 packets (about 1.8 billion triangles)"
    );
    debug_assert!(count > 0 && count < 1 << PACKET_BITS);
    first << PACKET_BITS | count
}

/// Collapses the binary tree under `root` into 8-wide nodes, depth first; the root is node 0
/// (a root leaf gets a node of its own). `pack` is as for `bvh::collapse`.
pub(super) fn collapse8(
    root: &Node,
    sparse: &[NodePair],
    pack: &mut impl FnMut(u32, u32) -> (u32, u32),
) -> Vec<Node8> {
    let mut nodes = Vec::with_capacity(sparse.len() / 4 + 1);
    if root.is_leaf() {
        let mut n = Node8::EMPTY;
        n.set_box(0, root);
        let (first, count) = pack(root.first, root.count);
        n.slot[0] = leaf_slot(first, count);
        nodes.push(n);
    } else {
        collapse8_inner(root, sparse, pack, &mut nodes);
    }
    nodes
}

fn collapse8_inner(
    inner: &Node,
    sparse: &[NodePair],
    pack: &mut impl FnMut(u32, u32) -> (u32, u32),
    out: &mut Vec<Node8>,
) -> u32 {
    let index = out.len();
    assert!(index < 1 << (32 - PACKET_BITS), "at most 2^29 nodes");
    out.push(Node8::EMPTY);
    let (kids, len) = open_children::<8>(inner, sparse);
    let mut node = Node8::EMPTY;
    for (lane, kid) in kids[..len].iter().enumerate() {
        node.set_box(lane, kid);
        node.slot[lane] = if kid.is_leaf() {
            let (first, count) = pack(kid.first, kid.count);
            leaf_slot(first, count)
        } else {
            collapse8_inner(kid, sparse, pack, out) << PACKET_BITS
        };
    }
    out[index] = node;
    index as u32
}

/// A node on the 8-wide traversal stack: its slot and entry distance.
#[derive(Clone, Copy, Debug, Default)]
struct Entry8 {
    slot: u32,
    t: f32,
}

#[cfg(target_arch = "x86_64")]
impl Bvh {
    /// Closest hits of `rays` through the 8-wide nodes.
    ///
    /// # Safety
    /// The CPU must support AVX2 (`is_x86_feature_detected!("avx2")`).
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn cast8(&self, rays: &[Ray], hits: &mut [Hit]) {
        // One stack for the whole chunk: clearing 4 KiB per ray costs about a tenth of a
        // coherent ray's time.
        let mut stack = [Entry8::default(); STACK_SIZE8];
        for (r, h) in rays.iter().zip(hits) {
            // SAFETY: the caller guarantees AVX2.
            *h = unsafe { self.closest8(r, &mut stack) };
        }
    }

    /// Any-hit tests of `rays` through the 8-wide nodes.
    ///
    /// # Safety
    /// The CPU must support AVX2 (`is_x86_feature_detected!("avx2")`).
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn occluded8(&self, rays: &[Ray], out: &mut [bool]) {
        let mut stack = [Entry8::default(); STACK_SIZE8];
        for (r, o) in rays.iter().zip(out) {
            // SAFETY: the caller guarantees AVX2.
            *o = unsafe { self.any_hit8(r, &mut stack) };
        }
    }

    /// As `Bvh::traverse`, over the 8-wide nodes, with `stack` as the traversal stack.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn traverse8(
        &self,
        ray: &Ray,
        stack: &mut [Entry8; STACK_SIZE8],
        mut leaf: impl FnMut(&[Tri4]) -> Option<f32>,
    ) -> bool {
        let t_min = ray.t_min - ray.t_min.abs() * CULL_SLACK;
        let Some(r) = BoxRay::new(ray, t_min) else {
            return true;
        };
        let mut t_far = slack_up(ray.t_max);
        let mut top = 0usize;
        // The root, an inner node.
        let mut current = Entry8::default();
        let low = (1 << PACKET_BITS) - 1;
        loop {
            let packets = current.slot & low;
            let index = (current.slot >> PACKET_BITS) as usize;
            if packets > 0 {
                match leaf(&self.packets[index..index + packets as usize]) {
                    Some(t) => t_far = t,
                    None => return false,
                }
            } else {
                let node = &self.nodes8[index];
                // SAFETY: the caller guarantees AVX2.
                let (t, mut mask) = unsafe { enter8_avx2(&r, &node.bounds, t_far, ROBUST_FAR) };
                if mask != 0 {
                    let entry = |lane: u32| Entry8 {
                        slot: node.slot[lane as usize & 7],
                        t: t[lane as usize & 7],
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
                        debug_assert!(top < STACK_SIZE8);
                        stack[top] = far;
                        top += 1;
                        current = near;
                        continue;
                    }
                    // Three or more children: push them all, sort the pushed ones far to near
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

    /// As `Bvh::closest`, over the 8-wide nodes.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn closest8(&self, ray: &Ray, stack: &mut [Entry8; STACK_SIZE8]) -> Hit {
        if self.nodes8.is_empty() {
            return Hit::MISS;
        }
        let sheared = ShearedRay::new(ray);
        let mut best = Hit::MISS;
        let t_max = slack_up(ray.t_max);
        let leaf = |packets: &[Tri4]| {
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
        };
        // SAFETY: the caller guarantees AVX2.
        unsafe { self.traverse8(ray, stack, leaf) };
        best
    }

    /// As `Bvh::any_hit`, over the 8-wide nodes.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn any_hit8(&self, ray: &Ray, stack: &mut [Entry8; STACK_SIZE8]) -> bool {
        if self.nodes8.is_empty() {
            return false;
        }
        let sheared = ShearedRay::new(ray);
        let t_max = slack_up(ray.t_max);
        let leaf = |packets: &[Tri4]| {
            let hit = packets.iter().any(|p| intersect4(&sheared, p).1 != 0);
            (!hit).then_some(t_max)
        };
        // SAFETY: the caller guarantees AVX2.
        !unsafe { self.traverse8(ray, stack, leaf) }
    }
}
