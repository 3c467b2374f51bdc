//! The per-bin pipeline: for every edge inside the bin, edge intersections, hidden-line
//! elimination and boundary completion; then the bin's border; then the visible polygons.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! sections 3.1, 3.2 and 4.2 (per-edge processing, with the bins of section 4.3 as the unit of
//! parallel work).

use glam::DVec2;

use super::bin::{self, Bin, Polys};
use super::boundary::{self, Segment};
use super::crossing::{self, CrossingScratch};
use super::intersect::{self, Counters, Edge, Pass};
use super::types::VisiblePolygon;
use super::{hidden_line, polygon, predicates, project};

/// What one bin produces.
#[derive(Default)]
pub(crate) struct BinOutput {
    /// Visible convex pieces, by triangle id.
    pub(crate) pieces: Vec<VisiblePolygon>,
    /// Counters of the bin.
    pub(crate) counters: Counters,
    /// Visible edge segments (hidden-line output).
    pub(crate) visible_segments: u64,
    /// Boundary-completion segments.
    pub(crate) completion_segments: u64,
    /// Intersecting pairs whose intersection segment bounds regions in the bin.
    pub(crate) crossing_pairs: u64,
    /// Pairs whose order flips in the bin but whose segment could not be built (the flip is
    /// on an edge only within rounding): resolved by the order at each part, as before.
    pub(crate) unresolved_pairs: u64,
}

/// Runs steps 3–6 of the pipeline on one bin.
pub(crate) fn process_bin(polys: &Polys, bin: &Bin) -> BinOutput {
    let mut out = BinOutput::default();
    let g = project::GRID;
    let rect_px = bin.rect.map(|v| v as f64 / g);
    if let [k] = bin.members[..] {
        // A lone polygon is entirely visible in its bin.
        let points: Vec<DVec2> = polys
            .verts_of(k)
            .iter()
            .map(|v| DVec2::new(v[0] as f64, v[1] as f64) / g)
            .collect();
        let points = polygon::clip_to_rect(&points, rect_px);
        if points.len() >= 3 && polygon::area(&points) > 0.0 {
            out.pieces.push(VisiblePolygon {
                triangle: polys.polys[k as usize].id,
                points,
            });
        }
        return out;
    }
    let mut segments: Vec<Segment> = Vec::new();
    let (mut overlaps, mut events, mut visible, mut intervals, mut crossings) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut index = bin::BinIndex::new(polys, bin);
    let mut candidates = Vec::new();
    let r = bin.rect;
    for &k in &bin.members {
        let verts = polys.verts_of(k);
        let n = verts.len();
        for j in 0..n {
            let (a, b) = (verts[j], verts[(j + 1) % n]);
            let d = predicates::sub(b, a);
            if d == [0, 0] {
                continue;
            }
            let Some(range) = bin::clip_edge(a, d, r) else {
                continue;
            };
            let e = Edge { owner: k, a, d };
            index.query(bin, e.bbox(), &mut candidates);
            // Hidden lines need only the polygons that may be in front; the ones behind are
            // needed for boundary completion, and only where the edge is visible.
            overlaps.clear();
            intersect::edge_intersections(
                polys,
                &candidates,
                &e,
                Pass::MaybeInFront,
                &mut out.counters,
                &mut overlaps,
                &mut crossings,
            );
            hidden_line::visible_intervals(&overlaps, range, &mut events, &mut visible);
            if visible.is_empty() {
                continue;
            }
            for &(s, t) in &visible {
                segments.push((k, e.at_px(s), e.at_px(t)));
            }
            out.visible_segments += visible.len() as u64;
            // An edge on the bin's border has the outside of the bin on its right: nothing to
            // complete there.
            let on_border = (d[0] == 0 && (a[0] == r[0] || a[0] == r[2]))
                || (d[1] == 0 && (a[1] == r[1] || a[1] == r[3]));
            if on_border {
                continue;
            }
            intersect::edge_intersections(
                polys,
                &candidates,
                &e,
                Pass::Behind,
                &mut out.counters,
                &mut overlaps,
                &mut crossings,
            );
            let before = segments.len();
            let mut scratch = boundary::Scratch {
                counters: &mut out.counters,
                events: &mut events,
                intervals: &mut intervals,
                crossings: &mut crossings,
            };
            boundary::complete(polys, &e, &overlaps, &visible, &mut scratch, &mut segments);
            out.completion_segments += (segments.len() - before) as u64;
        }
    }
    // The bin's border, counter-clockwise in the y-down sense (the bin on the left).
    let corners = [[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]]];
    for j in 0..4 {
        let (a, b) = (corners[j], corners[(j + 1) % 4]);
        let e = Edge {
            owner: intersect::NO_OWNER,
            a,
            d: predicates::sub(b, a),
        };
        index.query(bin, e.bbox(), &mut candidates);
        overlaps.clear();
        intersect::edge_intersections(
            polys,
            &candidates,
            &e,
            Pass::All,
            &mut out.counters,
            &mut overlaps,
            &mut crossings,
        );
        let mut scratch = boundary::Scratch {
            counters: &mut out.counters,
            events: &mut events,
            intervals: &mut intervals,
            crossings: &mut crossings,
        };
        boundary::border(polys, &e, &overlaps, &mut scratch, &mut segments);
    }
    // Intersecting pairs: their projected intersection segments are edges of both.
    for pair in crossings.iter_mut() {
        *pair = (pair.0.min(pair.1), pair.0.max(pair.1));
    }
    crossings.sort_unstable();
    crossings.dedup();
    let mut crossing_scratch = CrossingScratch::default();
    for &pair in &crossings {
        let built = crossing::bound_regions(
            polys,
            bin,
            rect_px,
            &mut index,
            pair,
            &mut out.counters,
            &mut crossing_scratch,
            &mut segments,
        );
        if built {
            out.crossing_pairs += 1;
        } else {
            out.unresolved_pairs += 1;
        }
    }
    segments.sort_by_key(|s| s.0);
    let mut pieces = Vec::new();
    for group in segments.chunk_by(|a, b| a.0 == b.0) {
        pieces.clear();
        polygon::pieces(group, &mut pieces);
        let id = polys.polys[group[0].0 as usize].id;
        out.pieces
            .extend(pieces.drain(..).map(|points| VisiblePolygon {
                triangle: id,
                points,
            }));
    }
    out
}
