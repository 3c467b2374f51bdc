//! Boundary completion (the paper's Algorithm 3, BOUNDARYCOMPLETION): for every polygon `o` that
//! an edge `e` of `T` occludes, the parts of `e` where `o` is the polygon seen right behind the
//! visible parts of `e`. There `e` is also a boundary of `o`'s visible region, with `o` on its
//! right side, so it is reported for `o` in the reverse direction.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 3.2 (Algorithm 3 and its INIT procedure, ISINFRONT).
//!
//! As in the paper the scan starts at 1; `o`'s own overlap (`n_start`, `n_end`) and the visible
//! parts of `e` (from hidden-line elimination) are anti-occlusions (`-1` at their start), and
//! every polygon covering the right side of `e` in front of `o` (the pairwise ISINFRONT test) is
//! an occlusion. Only polygons that `e` crosses (covering both sides) are completed: a polygon
//! that ends on `e`'s line gets that boundary from its own edge. Polygons in front of `T` that
//! cover both sides are skipped as occluders of `o`: `e` is not visible there anyway.

use super::bin::Polys;
use super::hidden_line::{scan_report, Event};
use super::intersect::{depth_of, depth_order, Counters, Edge, Overlap, Side};

/// A boundary segment of a visible region: polygon index in [`Polys`] and its end points
/// (pixels), oriented with the region on the left.
pub(crate) type Segment = (u32, glam::DVec2, glam::DVec2);

/// Scratch space and outputs shared by the completion steps of one bin.
pub(crate) struct Scratch<'a> {
    /// Counters of the bin.
    pub(crate) counters: &'a mut Counters,
    /// Scan events.
    pub(crate) events: &'a mut Vec<Event>,
    /// Reported intervals.
    pub(crate) intervals: &'a mut Vec<(f64, f64)>,
    /// Pairs of polygons found to intersect (their order flips along an edge).
    pub(crate) crossings: &'a mut Vec<(u32, u32)>,
}

/// Pushes the occlusion events of polygon `x` over `[lo, hi]` of `e` where it is in front of
/// `o` (both covering the side given by `normal`); where their order flips, only the part with
/// `x` in front occludes, and the pair is recorded as intersecting.
#[allow(clippy::too_many_arguments)]
fn occlude_where_in_front(
    polys: &Polys,
    e: &Edge,
    (lo, hi): (f64, f64),
    normal: glam::DVec2,
    x: u32,
    o: u32,
    scratch: &mut Scratch<'_>,
) {
    let order = depth_order(e, lo, hi, normal, depth_of(polys, x), depth_of(polys, o));
    if order.crosses() {
        scratch.counters.intersecting += 1;
        scratch.crossings.push((x, o));
    }
    for (s, t, front) in order.parts(lo, hi) {
        if front {
            scratch.events.push(Event { t: s, v: 1 });
            scratch.events.push(Event { t, v: -1 });
        }
    }
}

/// Reports the completion segments of edge `e` (whose visible intervals are `visible`).
pub(crate) fn complete(
    polys: &Polys,
    e: &Edge,
    overlaps: &[Overlap],
    visible: &[(f64, f64)],
    scratch: &mut Scratch<'_>,
    out: &mut Vec<Segment>,
) {
    if visible.is_empty() {
        return;
    }
    let right = -e.left_normal();
    for o in overlaps {
        if o.side != Side::Both || o.occluding {
            continue;
        }
        // Does o's overlap meet a visible part of e at all?
        if !visible.iter().any(|&(s, t)| s < o.hi && t > o.lo) {
            continue;
        }
        scratch.events.clear();
        scratch.events.push(Event { t: o.lo, v: -1 });
        scratch.events.push(Event { t: o.hi, v: 1 });
        for &(s, t) in visible {
            scratch.events.push(Event { t: s, v: -1 });
            scratch.events.push(Event { t, v: 1 });
        }
        for x in overlaps {
            if x.poly == o.poly
                || x.side == Side::Left
                || (x.side == Side::Both && x.occluding)
                || x.hi <= o.lo
                || x.lo >= o.hi
            {
                continue;
            }
            let part = (x.lo.max(o.lo), x.hi.min(o.hi));
            occlude_where_in_front(polys, e, part, right, x.poly, o.poly, scratch);
        }
        scratch.intervals.clear();
        scan_report(scratch.events, 1, scratch.intervals);
        for &(s, t) in scratch.intervals.iter() {
            out.push((o.poly, e.at_px(t), e.at_px(s)));
        }
    }
}

/// The bin's border as four extra edges, counter-clockwise (the bin on their left): for every
/// polygon that crosses a border edge, the parts where it is the nearest polygon just inside
/// the bin. These segments close the visible regions of the bin. (A polygon with an edge on the
/// border gets that boundary from its own edge.) The scan starts at 0: there is no owner whose
/// visibility gates the report.
pub(crate) fn border(
    polys: &Polys,
    e: &Edge,
    overlaps: &[Overlap],
    scratch: &mut Scratch<'_>,
    out: &mut Vec<Segment>,
) {
    let left = e.left_normal();
    for o in overlaps {
        if o.side != Side::Both {
            continue;
        }
        scratch.events.clear();
        scratch.events.push(Event { t: o.lo, v: -1 });
        scratch.events.push(Event { t: o.hi, v: 1 });
        for x in overlaps {
            if x.poly == o.poly || x.side == Side::Right || x.hi <= o.lo || x.lo >= o.hi {
                continue;
            }
            let part = (x.lo.max(o.lo), x.hi.min(o.hi));
            occlude_where_in_front(polys, e, part, left, x.poly, o.poly, scratch);
        }
        scratch.intervals.clear();
        scan_report(scratch.events, 0, scratch.intervals);
        for &(s, t) in scratch.intervals.iter() {
            out.push((o.poly, e.at_px(s), e.at_px(t)));
        }
    }
}
