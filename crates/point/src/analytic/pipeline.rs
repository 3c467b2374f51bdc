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
use super::hidden_line::Event;
use super::intersect::{self, Counters, Edge, Overlap, Pass};
use super::predicates::Pt;
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
    if let [k] = bin.members[..] {
        return lone_polygon(polys, bin, k);
    }
    let mut work = BinWork::new(polys, bin);
    for &k in &bin.members {
        let verts = polys.verts_of(k);
        let n = verts.len();
        for j in 0..n {
            work.polygon_edge(k, verts[j], verts[(j + 1) % n]);
        }
    }
    work.bin_border();
    work.intersecting_pairs();
    work.into_output()
}

/// The output of a bin with one member: a lone polygon is entirely visible in its bin, so its
/// piece is the polygon clipped to the bin (none when the clip is degenerate). Skips the whole
/// edge pipeline, which would find nothing to hide.
fn lone_polygon(polys: &Polys, bin: &Bin, k: u32) -> BinOutput {
    let mut out = BinOutput::default();
    let g = project::GRID;
    let rect_px = bin.rect.map(|v| v as f64 / g);
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
    out
}

/// The state of one bin while its edges are processed: the bin's output so far, the boundary
/// segments of its visible regions, and work buffers. The buffers are allocated once per bin
/// and reused by every edge (this is the hot loop of the exact method), so the steps below
/// borrow them instead of allocating their own.
struct BinWork<'a> {
    /// The projected polygons.
    polys: &'a Polys,
    /// The bin being processed.
    bin: &'a Bin,
    /// Spatial index of the bin's members (candidate polygons for an edge).
    index: bin::BinIndex,
    /// Counters and pieces of the bin.
    out: BinOutput,
    /// Boundary segments of the visible regions, by polygon (hidden lines, completion, border
    /// and crossing segments).
    segments: Vec<Segment>,
    /// Candidate polygons of the current edge.
    candidates: Vec<u32>,
    /// Overlaps of the current edge with its candidates.
    overlaps: Vec<Overlap>,
    /// Scan events (scratch of the hidden-line and completion scans).
    events: Vec<Event>,
    /// Visible parameter intervals of the current edge.
    visible: Vec<(f64, f64)>,
    /// Reported intervals (scratch of boundary completion).
    intervals: Vec<(f64, f64)>,
    /// Pairs of polygons found to intersect, for [`BinWork::intersecting_pairs`].
    crossings: Vec<(u32, u32)>,
}

impl<'a> BinWork<'a> {
    /// Empty buffers and the index of `bin`'s members.
    fn new(polys: &'a Polys, bin: &'a Bin) -> Self {
        BinWork {
            polys,
            bin,
            index: bin::BinIndex::new(polys, bin),
            out: BinOutput::default(),
            segments: Vec::new(),
            candidates: Vec::new(),
            overlaps: Vec::new(),
            events: Vec::new(),
            visible: Vec::new(),
            intervals: Vec::new(),
            crossings: Vec::new(),
        }
    }

    /// Steps 3–5 for the edge `a → b` of member `k`: its visible parts inside the bin
    /// (hidden-line elimination), then the boundary completion along them. Degenerate edges and
    /// edges outside the bin add nothing.
    #[inline]
    fn polygon_edge(&mut self, k: u32, a: Pt, b: Pt) {
        let d = predicates::sub(b, a);
        if d == [0, 0] {
            return;
        }
        let r = self.bin.rect;
        let Some(range) = bin::clip_edge(a, d, r) else {
            return;
        };
        let e = Edge { owner: k, a, d };
        self.index.query(self.bin, e.bbox(), &mut self.candidates);
        if !self.hidden_lines(&e, range) {
            return;
        }
        // An edge on the bin's border has the outside of the bin on its right: nothing to
        // complete there.
        let on_border = (d[0] == 0 && (a[0] == r[0] || a[0] == r[2]))
            || (d[1] == 0 && (a[1] == r[1] || a[1] == r[3]));
        if on_border {
            return;
        }
        self.complete_boundary(&e);
    }

    /// Hidden-line elimination for edge `e` over its part `range` inside the bin: adds its
    /// visible parts as segments (leaving their intervals in `visible` and the edge's overlaps
    /// in `overlaps`, for the completion). Returns whether any part is visible.
    #[inline]
    fn hidden_lines(&mut self, e: &Edge, range: (f64, f64)) -> bool {
        // Hidden lines need only the polygons that may be in front; the ones behind are
        // needed for boundary completion, and only where the edge is visible.
        self.overlaps.clear();
        intersect::edge_intersections(
            self.polys,
            &self.candidates,
            e,
            Pass::MaybeInFront,
            &mut self.out.counters,
            &mut self.overlaps,
            &mut self.crossings,
        );
        hidden_line::visible_intervals(&self.overlaps, range, &mut self.events, &mut self.visible);
        if self.visible.is_empty() {
            return false;
        }
        for &(s, t) in &self.visible {
            self.segments.push((e.owner, e.at_px(s), e.at_px(t)));
        }
        self.out.visible_segments += self.visible.len() as u64;
        true
    }

    /// Boundary completion along the visible parts of edge `e` (after
    /// [`BinWork::hidden_lines`]): adds the polygons behind the edge to its overlaps and the
    /// segments where they become visible next to it.
    #[inline]
    fn complete_boundary(&mut self, e: &Edge) {
        intersect::edge_intersections(
            self.polys,
            &self.candidates,
            e,
            Pass::Behind,
            &mut self.out.counters,
            &mut self.overlaps,
            &mut self.crossings,
        );
        let before = self.segments.len();
        let mut scratch = boundary::Scratch {
            counters: &mut self.out.counters,
            events: &mut self.events,
            intervals: &mut self.intervals,
            crossings: &mut self.crossings,
        };
        boundary::complete(
            self.polys,
            e,
            &self.overlaps,
            &self.visible,
            &mut scratch,
            &mut self.segments,
        );
        self.out.completion_segments += (self.segments.len() - before) as u64;
    }

    /// The bin's border as four edges, counter-clockwise in the y-down sense (the bin on the
    /// left): the segments where polygons crossing the border are nearest just inside it.
    fn bin_border(&mut self) {
        let r = self.bin.rect;
        let corners = [[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]]];
        for j in 0..4 {
            let (a, b) = (corners[j], corners[(j + 1) % 4]);
            let e = Edge {
                owner: intersect::NO_OWNER,
                a,
                d: predicates::sub(b, a),
            };
            self.index.query(self.bin, e.bbox(), &mut self.candidates);
            self.overlaps.clear();
            intersect::edge_intersections(
                self.polys,
                &self.candidates,
                &e,
                Pass::All,
                &mut self.out.counters,
                &mut self.overlaps,
                &mut self.crossings,
            );
            let mut scratch = boundary::Scratch {
                counters: &mut self.out.counters,
                events: &mut self.events,
                intervals: &mut self.intervals,
                crossings: &mut self.crossings,
            };
            boundary::border(
                self.polys,
                &e,
                &self.overlaps,
                &mut scratch,
                &mut self.segments,
            );
        }
    }

    /// Intersecting pairs (each counted once, in sorted order): their projected intersection
    /// segments are edges of both polygons' visible regions. Pairs whose segment cannot be
    /// built are counted as unresolved.
    fn intersecting_pairs(&mut self) {
        for pair in self.crossings.iter_mut() {
            *pair = (pair.0.min(pair.1), pair.0.max(pair.1));
        }
        self.crossings.sort_unstable();
        self.crossings.dedup();
        let rect_px = self.bin.rect.map(|v| v as f64 / project::GRID);
        let mut crossing_scratch = CrossingScratch::default();
        for &pair in &self.crossings {
            let built = crossing::bound_regions(
                self.polys,
                self.bin,
                rect_px,
                &mut self.index,
                pair,
                &mut self.out.counters,
                &mut crossing_scratch,
                &mut self.segments,
            );
            if built {
                self.out.crossing_pairs += 1;
            } else {
                self.out.unresolved_pairs += 1;
            }
        }
    }

    /// Step 6: the visible polygons, assembled per polygon from its boundary segments.
    fn into_output(mut self) -> BinOutput {
        self.segments.sort_by_key(|s| s.0);
        let mut pieces = Vec::new();
        for group in self.segments.chunk_by(|a, b| a.0 == b.0) {
            pieces.clear();
            polygon::pieces(group, &mut pieces);
            let id = self.polys.polys[group[0].0 as usize].id;
            self.out
                .pieces
                .extend(pieces.drain(..).map(|points| VisiblePolygon {
                    triangle: id,
                    points,
                }));
        }
        self.out
    }
}
