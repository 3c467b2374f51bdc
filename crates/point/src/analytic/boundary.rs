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
use super::intersect::{in_front, Counters, Edge, Overlap, Side};

/// A boundary segment of a visible region: polygon index in [`Polys`] and its end points
/// (pixels), oriented with the region on the left.
pub(crate) type Segment = (u32, glam::DVec2, glam::DVec2);

/// Reports the completion segments of edge `e` (whose visible intervals are `visible`).
#[allow(clippy::too_many_arguments)]
pub(crate) fn complete(
    polys: &Polys,
    e: &Edge,
    overlaps: &[Overlap],
    visible: &[(f64, f64)],
    counters: &mut Counters,
    events: &mut Vec<Event>,
    scratch: &mut Vec<(f64, f64)>,
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
        let po = &polys.polys[o.poly as usize];
        events.clear();
        events.push(Event { t: o.lo, v: -1 });
        events.push(Event { t: o.hi, v: 1 });
        for &(s, t) in visible {
            events.push(Event { t: s, v: -1 });
            events.push(Event { t, v: 1 });
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
            let px = &polys.polys[x.poly as usize];
            let (lo, hi) = (x.lo.max(o.lo), x.hi.min(o.hi));
            let (front, crossing) =
                in_front(e, lo, hi, right, (&px.plane, px.id), (&po.plane, po.id));
            counters.intersecting += u64::from(crossing);
            if front {
                events.push(Event { t: x.lo, v: 1 });
                events.push(Event { t: x.hi, v: -1 });
            }
        }
        scratch.clear();
        scan_report(events, 1, scratch);
        for &(s, t) in scratch.iter() {
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
    counters: &mut Counters,
    events: &mut Vec<Event>,
    scratch: &mut Vec<(f64, f64)>,
    out: &mut Vec<Segment>,
) {
    let left = e.left_normal();
    for o in overlaps {
        if o.side != Side::Both {
            continue;
        }
        let po = &polys.polys[o.poly as usize];
        events.clear();
        events.push(Event { t: o.lo, v: -1 });
        events.push(Event { t: o.hi, v: 1 });
        for x in overlaps {
            if x.poly == o.poly || x.side == Side::Right || x.hi <= o.lo || x.lo >= o.hi {
                continue;
            }
            let px = &polys.polys[x.poly as usize];
            let (lo, hi) = (x.lo.max(o.lo), x.hi.min(o.hi));
            let (front, crossing) =
                in_front(e, lo, hi, left, (&px.plane, px.id), (&po.plane, po.id));
            counters.intersecting += u64::from(crossing);
            if front {
                events.push(Event { t: x.lo, v: 1 });
                events.push(Event { t: x.hi, v: -1 });
            }
        }
        scratch.clear();
        scan_report(events, 0, scratch);
        for &(s, t) in scratch.iter() {
            out.push((o.poly, e.at_px(s), e.at_px(t)));
        }
    }
}
