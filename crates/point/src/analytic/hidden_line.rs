//! Hidden-line elimination (the paper's Algorithm 2, HIDDENLINEELIMINATION): sort the
//! intersections along the edge, drop the occluded types, and find the visible parts of the edge
//! with an inclusive prefix scan over `±1` values.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 3.2 (Algorithm 2) and section 4.2 (sorting intersections along each edge).
//!
//! The scan value of a position on the edge is `init - (#anti-occluders active) + (#occluders
//! active)`; a position is reported where it is `<= -1`. For hidden-line elimination the only
//! anti-occluder is the edge itself (`self`, the paper's `V(n) = -V(n)` for self points), so the
//! edge is reported where no occluder covers it.

use super::intersect::{Overlap, Side};

/// One intersection point along an edge: parameter `t` and its scan value `v` (`+1` opens an
/// occlusion or closes an anti-occlusion, `-1` the reverse).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Event {
    /// Parameter along the edge.
    pub(crate) t: f64,
    /// `+1` or `-1`.
    pub(crate) v: i32,
}

/// Sorts `events` along the edge, runs the inclusive scan starting at `init`, and appends the
/// parameter intervals where the scan is `<= -1` to `out` (zero-length ones are dropped).
/// At equal `t`, `+1` values come first, so touching occluders leave no zero-length gap.
pub(crate) fn scan_report(events: &mut [Event], init: i32, out: &mut Vec<(f64, f64)>) {
    events.sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(b.v.cmp(&a.v)));
    let mut s = init;
    let mut open: Option<f64> = None;
    for e in events.iter() {
        s += e.v;
        match (s <= -1, open) {
            (true, None) => open = Some(e.t),
            (false, Some(start)) => {
                if e.t > start {
                    out.push((start, e.t));
                }
                open = None;
            }
            _ => {}
        }
    }
}

/// The visible parameter intervals of the part `[t0, t1]` of an edge (the part inside the bin),
/// given its overlaps: the parts covered by no occluding polygon. `events` is scratch space.
pub(crate) fn visible_intervals(
    overlaps: &[Overlap],
    (t0, t1): (f64, f64),
    events: &mut Vec<Event>,
    out: &mut Vec<(f64, f64)>,
) {
    out.clear();
    events.clear();
    // The edge itself ("self" points), with the sign flipped as in the paper.
    events.push(Event { t: t0, v: -1 });
    events.push(Event { t: t1, v: 1 });
    for o in overlaps {
        // Lines 4-9: only occluding intersections stay.
        if o.occluding && o.side != Side::Right {
            events.push(Event { t: o.lo, v: 1 });
            events.push(Event { t: o.hi, v: -1 });
        }
    }
    scan_report(events, 0, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn occluder(lo: f64, hi: f64) -> Overlap {
        Overlap {
            poly: 1,
            lo,
            hi,
            side: Side::Both,
            occluding: true,
        }
    }

    #[test]
    fn no_overlaps_leaves_edge_visible() {
        let mut out = Vec::new();
        visible_intervals(&[], (0.0, 1.0), &mut Vec::new(), &mut out);
        assert_eq!(out, vec![(0.0, 1.0)]);
    }

    #[test]
    fn occluders_cut_the_edge() {
        let mut out = Vec::new();
        let o = [occluder(0.2, 0.4), occluder(0.3, 0.5), occluder(0.8, 1.0)];
        visible_intervals(&o, (0.0, 1.0), &mut Vec::new(), &mut out);
        assert_eq!(out, vec![(0.0, 0.2), (0.5, 0.8)]);
    }

    #[test]
    fn touching_occluders_leave_no_gap() {
        let mut out = Vec::new();
        let o = [occluder(0.0, 0.5), occluder(0.5, 1.0)];
        visible_intervals(&o, (0.0, 1.0), &mut Vec::new(), &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn occluded_polygons_do_not_cut() {
        let mut out = Vec::new();
        let mut o = occluder(0.2, 0.4);
        o.occluding = false;
        visible_intervals(&[o], (0.0, 1.0), &mut Vec::new(), &mut out);
        assert_eq!(out, vec![(0.0, 1.0)]);
    }
}

#[cfg(test)]
mod range_tests {
    use super::*;

    #[test]
    fn only_the_part_in_the_bin_is_reported() {
        let mut out = Vec::new();
        visible_intervals(&[], (0.25, 0.5), &mut Vec::new(), &mut out);
        assert_eq!(out, vec![(0.25, 0.5)]);
    }
}
