//! What each portal side might lead to: the leaves a portal sequence that starts through it
//! can enter at all, found by a flood through the portal graph that crosses only portals
//! with a point in front of the first portal's plane. The flow skips a portal when every leaf
//! it might lead to (and that the sequence so far might lead to) has all its triangles marked
//! already: walking it could mark nothing new, however many sequences it holds.
//!
//! Based on: the Quake tools' `vis` (its `BasePortalVis` flood of the portals each portal
//! "might see", intersected along the sequence in `PortalFlow` to prune it), here with
//! leaves and triangles instead of portals, as a pruning that never changes what the flow
//! marks.
//!
//! # Why skipping changes nothing that can be seen
//! A segment from the box that enters a leaf through a portal crosses the portal's plane
//! there, from the back of the plane (facing into the leaf) to its front, and a segment
//! crosses a plane once: every later portal it passes, it passes at a point in front of that
//! plane. So every leaf a sequence starting through the portal enters is reached by crossing
//! only portals with a point in front of it ([`might_see`] keeps [`SLACK`] more), and a
//! sequence through several portals only enters leaves every one of them might lead to. A
//! triangle the box sees is seen in a leaf the segment enters, and lies in that leaf's list
//! (`flow::leaf_triangles`). So a portal whose leaves' triangles are all marked can add
//! none.
//!
//! # Memory and time
//! One bit per (portal side, leaf): 2 x portals x leaves bits (czest3ctf: about 5 MB), made
//! once per map by one flood per side over the whole graph.

use fixedbitset::FixedBitSet;

use super::build::PortalGraph;

/// Map units behind a portal's plane within which a later portal still counts as in front:
/// more than the slivers the flow keeps at every cut (`build::GROW`) and the touch of a
/// triangle to a leaf (`build::TOUCH`), so that the flood errs on the large side.
const SLACK: f64 = 1.0;

/// Per portal side (`2p` enters portal `p`'s front leaf, `2p + 1` its back leaf), the leaves
/// of `leaves` a sequence starting through that side might enter (the one it enters first
/// included).
pub(crate) fn might_see(graph: &PortalGraph, leaves: usize) -> Vec<FixedBitSet> {
    let mut queue = Vec::new();
    (0..2 * graph.portals.len())
        .map(|side| {
            let portal = &graph.portals[side / 2];
            let (first, into) = if side % 2 == 0 {
                (portal.front, portal.plane)
            } else {
                (portal.back, portal.plane.flipped())
            };
            let mut seen = FixedBitSet::with_capacity(leaves);
            if first >= leaves {
                return seen;
            }
            seen.insert(first);
            queue.clear();
            queue.push(first);
            while let Some(leaf) = queue.pop() {
                for &q in &graph.of_leaf[leaf] {
                    let next = graph.portals[q].other(leaf);
                    if next >= leaves || seen.contains(next) {
                        continue;
                    }
                    let ahead = graph.portals[q]
                        .winding
                        .iter()
                        .any(|&v| into.distance(v) > -SLACK);
                    if ahead {
                        seen.insert(next);
                        queue.push(next);
                    }
                }
            }
            seen
        })
        .collect()
}

/// Whether every leaf in both `a` and `b` is in `complete` (false when the sets are not all
/// of one size, which a map's own sets always are).
pub(crate) fn all_complete(a: &FixedBitSet, b: &FixedBitSet, complete: &FixedBitSet) -> bool {
    let len = complete.len();
    if a.len() != len || b.len() != len {
        return false;
    }
    a.as_slice()
        .iter()
        .zip(b.as_slice())
        .zip(complete.as_slice())
        .all(|((&a, &b), &c)| a & b & !c == 0)
}
