//! The one traversal of [`super::Bvh`], for every node layout ([`WideNode`]): one ray at a
//! time with a stack, nearer children first, closest-hit and any-hit. Each layout compiles it
//! with the CPU features its box test needs (`node8.rs` wraps it in AVX2 functions), so the
//! loop is monomorphised per layout and the box test is inlined into it.
//!
//! Based on: Wald, Benthin, Boulos. Getting rid of packets: efficient SIMD single-ray traversal
//! using multi-branching BVHs. IRT 2008 (one ray, all children's boxes at once, near to far).
//! Based on: Fuetterling, Lojewski, Pfreundt, Ebert. Efficient Ray Tracing Kernels for Modern
//! CPU Architectures. JCGT 4(5), 2015 (the same loop over 8-wide nodes; insertion-sorting the
//! entered children on the stack).
//! Based on: Ize. Robust BVH ray traversal. JCGT 2(2), 2013 (the `1 + 2 gamma(3)` slab slack).
//! Embree's `bvh_traverser1.h` and `node_intersector1.h` (read, not copied) for the integer
//! `max`/`min` of the slab bounds (`slab.rs`, rays with a finite inverse direction) and the
//! sorting network over three or four entered children.
//!
//! # Exactness
//! Box tests are only ever made more conservative (Ize's slack on the far distance, a relative
//! slack on the culling distance) so that a box whose triangle the leaf test would accept is
//! never culled by rounding; leaves use the watertight test four triangles at a time
//! (`tri4.rs`) and ties in `t` go to the lower triangle id, as in brute force.

use crate::geometry::{Hit, Ray};
use crate::trace::tri4::{intersect4, Tri4};
use crate::trace::triangle::ShearedRay;

use super::build::MAX_SAH_DEPTH;
use super::node::{Entry, Tree, WideNode};
use super::slab::{gamma, BoxRay};

/// Ize 2013: scaling far slab distances by this makes the box test conservative.
pub(super) const ROBUST_FAR: f32 = 1.0 + 2.0 * gamma(3.0);
/// Relative slack on the distances a box is culled against. The leaf test's `t` is a convex
/// combination of the corners' distances along the ray and carries a few ulps of rounding, so
/// it may sit a few ulps outside the box's slab interval; a tie at equal `t` with a lower id
/// must still be found. Larger than strictly needed, at no measurable cost.
pub(super) const CULL_SLACK: f32 = 16.0 * gamma(3.0);

/// Traversal stack size for nodes of `width` children: the binary tree has at most
/// `MAX_SAH_DEPTH` levels plus a median-split tail over at most 2^32 triangles; each wide level
/// spans at least one of them and pushes at most `width - 1` nodes (`width`, briefly, while
/// sorting).
pub(super) const fn stack_size(width: usize) -> usize {
    (width - 1) * (MAX_SAH_DEPTH as usize + 32) + 1
}

/// `t` moved up by the culling slack (infinity stays infinity).
pub(super) fn slack_up(t: f32) -> f32 {
    t + t.abs() * CULL_SLACK
}

/// Closest hits of `rays`, with `stack` as the traversal stack for them all: the caller
/// (`Bvh`'s tasks) keeps one for each run of tasks a thread takes on, where a fresh 4 KB stack
/// per call was zeroed for every 64 rays.
///
/// # Safety
/// The CPU must have what [`WideNode::supported`] checks for `N`.
#[inline(always)]
pub(super) unsafe fn cast<N: WideNode>(
    tree: Tree<'_, N>,
    rays: &[Ray],
    hits: &mut [Hit],
    stack: &mut N::Stack,
) {
    let stack = stack.as_mut();
    for (r, h) in rays.iter().zip(hits) {
        // SAFETY: the caller guarantees the CPU features.
        *h = unsafe { closest(tree, r, stack) };
    }
}

/// Any-hit tests of `rays`, with `stack` as [`cast`]'s.
///
/// # Safety
/// The CPU must have what [`WideNode::supported`] checks for `N`.
#[inline(always)]
pub(super) unsafe fn occluded<N: WideNode>(
    tree: Tree<'_, N>,
    rays: &[Ray],
    out: &mut [bool],
    stack: &mut N::Stack,
) {
    let stack = stack.as_mut();
    for (r, o) in rays.iter().zip(out) {
        // SAFETY: the caller guarantees the CPU features.
        *o = unsafe { any_hit(tree, r, stack) };
    }
}

/// What [`traverse`] does at a leaf: a trait with `#[inline(always)]` methods rather than a
/// closure, so that the leaf test is inlined into the loop in every layout's build (a closure
/// does not take on the AVX2 features of `node8.rs`'s wrappers, and was left out of line).
trait Leaf {
    /// Tests the leaf's packets with the ray prepared for them; returns the new culling
    /// distance, or `None` to stop at once.
    fn test(&mut self, sheared: &ShearedRay, packets: &[Tri4]) -> Option<f32>;
}

/// The closest-hit leaf test: keeps the best hit so far.
struct Closest {
    best: Hit,
    /// The culling distance while nothing is hit: `t_max` moved up by the slack.
    t_max: f32,
}

impl Leaf for Closest {
    #[inline(always)]
    fn test(&mut self, sheared: &ShearedRay, packets: &[Tri4]) -> Option<f32> {
        for packet in packets {
            let (ts, mut mask) = intersect4(sheared, packet);
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize & 3;
                mask &= mask - 1;
                let (t, id) = (ts[lane], packet.ids[lane]);
                // The copies of this triangle that pad the packet hit at the same `t`: half
                // the hit lanes on the city models, a turn of this loop each.
                mask &= !packet.lanes_with_id(id);
                // Ties go to the lower id, as in brute force.
                let better = t < self.best.t || (t == self.best.t && id < self.best.triangle);
                self.best =
                    std::hint::select_unpredictable(better, Hit { triangle: id, t }, self.best);
            }
        }
        Some(if self.best.is_hit() {
            slack_up(self.best.t)
        } else {
            self.t_max
        })
    }
}

/// The any-hit leaf test: stops at the first hit.
struct AnyHit {
    /// As [`Closest::t_max`].
    t_max: f32,
}

impl Leaf for AnyHit {
    #[inline(always)]
    fn test(&mut self, sheared: &ShearedRay, packets: &[Tri4]) -> Option<f32> {
        let hit = packets.iter().any(|p| intersect4(sheared, p).1 != 0);
        (!hit).then_some(self.t_max)
    }
}

/// The closest hit of `ray`.
///
/// # Safety
/// As [`cast`].
#[inline(always)]
unsafe fn closest<N: WideNode>(tree: Tree<'_, N>, ray: &Ray, stack: &mut [Entry<N::Child>]) -> Hit {
    if tree.nodes.is_empty() {
        return Hit::MISS;
    }
    let t_max = slack_up(ray.t_max);
    let mut leaf = Closest {
        best: Hit::MISS,
        t_max,
    };
    // SAFETY: the caller guarantees the CPU features.
    unsafe { traverse(tree, ray, t_max, stack, &mut leaf) };
    leaf.best
}

/// Whether `ray` hits anything.
///
/// # Safety
/// As [`cast`].
#[inline(always)]
unsafe fn any_hit<N: WideNode>(
    tree: Tree<'_, N>,
    ray: &Ray,
    stack: &mut [Entry<N::Child>],
) -> bool {
    if tree.nodes.is_empty() {
        return false;
    }
    let t_max = slack_up(ray.t_max);
    let mut leaf = AnyHit { t_max };
    // SAFETY: the caller guarantees the CPU features.
    !unsafe { traverse(tree, ray, t_max, stack, &mut leaf) }
}

/// Walks the tree, children near to far, with `stack` (at least `N::new_stack`'s length) as the
/// traversal stack and `t_far` (the ray's `t_max` moved up by the slack, as `leaf` keeps it) as
/// the culling distance while nothing is hit. `leaf` tests each leaf reached. Returns false
/// when `leaf` stopped it.
///
/// # Safety
/// As [`cast`]; `tree.nodes` is not empty.
#[inline(always)]
unsafe fn traverse<N: WideNode>(
    tree: Tree<'_, N>,
    ray: &Ray,
    t_far: f32,
    stack: &mut [Entry<N::Child>],
    leaf: &mut impl Leaf,
) -> bool {
    let t_min = ray.t_min - ray.t_min.abs() * CULL_SLACK;
    let Some(r) = BoxRay::new(ray, t_min, N::WIDTH) else {
        return true;
    };
    let mut state = Walk {
        current: Entry::default(),
        top: 0,
        t_far,
    };
    // SAFETY: the caller guarantees the CPU features and a non-empty tree; `FINITE` only when
    // `r.finite` holds.
    unsafe {
        if r.finite {
            walk_in_phases::<N, true>(tree, ray, &r, &mut state, stack, leaf)
        } else {
            walk_in_phases::<N, false>(tree, ray, &r, &mut state, stack, leaf)
        }
    }
}

/// Where a walk stands: the node or leaf to visit next, the stack's height, the culling
/// distance.
#[derive(Clone, Copy)]
struct Walk<C> {
    current: Entry<C>,
    top: usize,
    t_far: f32,
}

/// [`walk`] in two phases: to the first leaf without the packet test's prepared ray
/// ([`ShearedRay`]), then on with it. A ray that reaches no leaf (a camera ray past the scene,
/// or one whose boxes all miss) never pays for the permutation and the divisions, about a
/// tenth of a coherent ray's instructions; and, unlike a check at every leaf for whether the
/// ray is prepared yet, the switch costs no branch of its own (cachegrind's branch simulation
/// mispredicted that check at about every other incoherent ray's first leaf).
///
/// # Safety
/// As [`walk`].
#[inline(always)]
unsafe fn walk_in_phases<N: WideNode, const FINITE: bool>(
    tree: Tree<'_, N>,
    ray: &Ray,
    r: &BoxRay,
    state: &mut Walk<N::Child>,
    stack: &mut [Entry<N::Child>],
    leaf: &mut impl Leaf,
) -> bool {
    // SAFETY: passed on from the caller.
    unsafe {
        match walk::<N, FINITE, true>(tree, r, state, stack, leaf, None) {
            Some(finished) => finished,
            None => {
                let sheared = ShearedRay::new(ray);
                // `state.current` is the leaf the first phase stopped at: the second phase
                // starts with it.
                walk::<N, FINITE, false>(tree, r, state, stack, leaf, Some(&sheared))
                    .unwrap_or(true)
            }
        }
    }
}

/// The loop of [`traverse`] for the prepared ray `r`, from `state` on. `FINITE` picks the box
/// test: [`WideNode::enter_finite`] (only where `r.finite`), else [`WideNode::enter`]; almost
/// every ray takes the first (a zero direction component or a negative `t_min` takes the
/// second), each compiled as its own loop. With `TO_LEAF` (and `sheared` `None`) the walk
/// stops at the first leaf it reaches and returns `None`, leaving it in `state.current`;
/// otherwise (`sheared` given) `leaf` tests each leaf with `sheared`. Returns
/// `Some(false)` when `leaf` stopped the walk, `Some(true)` when the tree is done.
///
/// # Safety
/// As [`traverse`]; `r.finite` holds when `FINITE` is true; `sheared` is given unless
/// `TO_LEAF`.
#[inline(always)]
unsafe fn walk<N: WideNode, const FINITE: bool, const TO_LEAF: bool>(
    tree: Tree<'_, N>,
    r: &BoxRay,
    state: &mut Walk<N::Child>,
    stack: &mut [Entry<N::Child>],
    leaf: &mut impl Leaf,
    sheared: Option<&ShearedRay>,
) -> Option<bool> {
    let Walk {
        mut current,
        mut top,
        mut t_far,
    } = *state;
    loop {
        let (offset, packets) = N::locate(current.child);
        if packets > 0 {
            if TO_LEAF {
                *state = Walk {
                    current,
                    top,
                    t_far,
                };
                return None;
            }
            // SAFETY: given unless `TO_LEAF` (the caller's guarantee).
            let sheared = unsafe { sheared.unwrap_unchecked() };
            // SAFETY: a leaf child of this tree's nodes (the root is not one).
            match leaf.test(sheared, unsafe { tree.packets_at(offset, packets) }) {
                Some(t) => t_far = t,
                None => return Some(false),
            }
        } else {
            // SAFETY: the root (offset 0 of a non-empty array), or an inner child of this
            // tree's nodes.
            let node = unsafe { tree.node_at(offset) };
            // SAFETY: the caller guarantees the CPU features, and `r.finite` for `FINITE`.
            let (t, mut mask) = unsafe {
                if FINITE {
                    node.enter_finite(r, t_far)
                } else {
                    node.enter(r, t_far, ROBUST_FAR)
                }
            };
            if mask != 0 {
                let entry = |lane: u32| {
                    // The mask keeps the index in range without a bounds check.
                    let lane = lane as usize & (N::WIDTH - 1);
                    Entry {
                        child: node.child(lane),
                        t: t[lane],
                    }
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
                    debug_assert!(top < stack.len());
                    tree.prefetch(far.child);
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
                for e in &stack[pushed..top] {
                    tree.prefetch(e.child);
                }
                sort_far_to_near(&mut stack[pushed..top]);
                top -= 1;
                current = stack[top];
                continue;
            }
        }
        // Pop the next node that is not farther than the closest hit so far.
        loop {
            if top == 0 {
                return Some(true);
            }
            top -= 1;
            if stack[top].t <= t_far {
                current = stack[top];
                break;
            }
        }
    }
}

/// Sorts the entries of one node's entered children, farthest first. Three and four (most
/// nodes an incoherent ray enters more than two children of) go through a sorting network of
/// selects, as Embree's traverser does: an insertion sort's branches are mispredicted about
/// once per such node. Equal distances may come out in any order (the closest hit does not
/// depend on it).
#[inline(always)]
fn sort_far_to_near<C: Copy>(entries: &mut [Entry<C>]) {
    /// Puts the farther of entries `i` and `j` (`i < j`) at `i`.
    #[inline(always)]
    fn order<C: Copy>(e: &mut [Entry<C>], i: usize, j: usize) {
        let (a, b) = (e[i], e[j]);
        let swap = a.t < b.t;
        // A plain `if` compiled to a branch here.
        e[i] = std::hint::select_unpredictable(swap, b, a);
        e[j] = std::hint::select_unpredictable(swap, a, b);
    }
    match entries.len() {
        3 => {
            order(entries, 0, 1);
            order(entries, 1, 2);
            order(entries, 0, 1);
        }
        4 => {
            order(entries, 0, 1);
            order(entries, 2, 3);
            order(entries, 0, 2);
            order(entries, 1, 3);
            order(entries, 1, 2);
        }
        _ => {
            for i in 1..entries.len() {
                let e = entries[i];
                let mut j = i;
                while j > 0 && entries[j - 1].t < e.t {
                    entries[j] = entries[j - 1];
                    j -= 1;
                }
                entries[j] = e;
            }
        }
    }
}
