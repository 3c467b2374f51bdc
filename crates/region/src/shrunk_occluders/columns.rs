//! The union of a scene's closed solids as intervals along the up axis over a grid of square
//! columns: for each column, the heights at which the whole column (its square times the
//! interval) lies inside some solid. Where two solids touch (terraced houses), a column
//! across their shared wall is inside the union even though it is inside neither: the union,
//! not each solid, is what a viewpoint cannot see through.
//!
//! Per column: every piece of a solid's triangle inside the column's prism forbids its
//! height range (the union's surface may pass there); each gap between forbidden ranges
//! meets no triangle, so it lies wholly inside or wholly outside the union, and the winding
//! numbers of the solids at one point of it say which. Rounding doubt (a winding ray grazing
//! an edge) counts as outside.

use glam::DVec3;
use rayon::prelude::*;
use sightline_core::Scene;

use super::polygon::clip_by;
use crate::closed_solids::cell::winding_number;
use crate::closed_solids::ClosedSolids;

/// An interval of heights `lo..hi` inside the union over a whole column; `open` where it
/// rests on a solid's open bottom (no face below it: a segment from below may enter there).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Span {
    pub lo: f64,
    pub hi: f64,
    pub open: bool,
}

/// The union as column spans (see the module documentation).
#[derive(Clone, Debug)]
pub(super) struct Columns {
    /// The up axis and the two across it.
    pub up: usize,
    pub across: [usize; 2],
    /// The grid's corner (along `across`), column size and column counts.
    pub origin: [f64; 2],
    pub size: f64,
    pub dims: [usize; 2],
    /// Per column (index `i + j * dims[0]`), its range of `spans`.
    pub offsets: Vec<u32>,
    pub spans: Vec<Span>,
}

/// A triangle of a solid, as the columns use it.
struct SolidTriangle {
    corners: [DVec3; 3],
    solid: u32,
}

impl Columns {
    /// The union of `solids` of `scene` over columns of `size`, or `None` when the grid would
    /// have more than `max_columns` columns. Solids open anywhere but at their bottom (along
    /// the scene's up axis) are left out.
    pub fn new(
        scene: &Scene,
        solids: &ClosedSolids,
        size: f64,
        max_columns: usize,
    ) -> Option<Self> {
        let up = scene.up.index();
        let mut triangles = Vec::new();
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for s in 0..solids.solid_count() {
            let solid = solids.solid(s);
            if solid
                .open_at
                .is_some_and(|(axis, _, side)| axis != up || side < 0.0)
            {
                continue;
            }
            for &t in solid.triangles {
                let corners = scene.triangle(t).map(|p| p.as_dvec3());
                for c in corners {
                    lo = lo.min(c);
                    hi = hi.max(c);
                }
                triangles.push(SolidTriangle {
                    corners,
                    solid: s as u32,
                });
            }
        }
        if triangles.is_empty() || !size.is_finite() || size <= 0.0 {
            return None;
        }
        let mut columns = Self::grid(up, lo, hi, size, max_columns)?;
        let dims = columns.dims;
        // Triangles by the rows they reach.
        let mut by_row: Vec<Vec<u32>> = vec![Vec::new(); dims[1]];
        for (k, t) in triangles.iter().enumerate() {
            let (r0, r1) = columns.range_of(&t.corners, 1);
            for row in &mut by_row[r0..=r1] {
                row.push(k as u32);
            }
        }
        let rows: Vec<Vec<Vec<Span>>> = by_row
            .par_iter()
            .enumerate()
            .map(|(j, row)| columns.row(j, row, &triangles, solids))
            .collect();
        columns.fill(rows);
        Some(columns)
    }

    /// Takes the spans of every column, row by row (as [`Columns::grid`] orders them).
    pub(super) fn fill(&mut self, rows: Vec<Vec<Vec<Span>>>) {
        self.offsets.push(0);
        for row_spans in rows {
            for spans in row_spans {
                self.spans.extend(spans);
                self.offsets.push(self.spans.len() as u32);
            }
        }
    }

    /// A grid of columns of `size` along the up axis `up` over `lo..hi` (a column to spare on
    /// each side), without spans yet; `None` when it would have more than `max_columns`.
    pub(super) fn grid(
        up: usize,
        lo: DVec3,
        hi: DVec3,
        size: f64,
        max_columns: usize,
    ) -> Option<Self> {
        let across = [(up + 1) % 3, (up + 2) % 3];
        let origin = [lo[across[0]] - size, lo[across[1]] - size];
        let dims = [0, 1].map(|k| ((hi[across[k]] - origin[k]) / size).ceil() as usize + 2);
        if dims[0].checked_mul(dims[1])? > max_columns {
            return None;
        }
        Some(Self {
            up,
            across,
            origin,
            size,
            dims,
            offsets: Vec::new(),
            spans: Vec::new(),
        })
    }

    /// The columns (first and last, inclusive) that `corners` reach along `across[k]`.
    fn range_of(&self, corners: &[DVec3; 3], k: usize) -> (usize, usize) {
        let axis = self.across[k];
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for c in corners {
            lo = lo.min(c[axis]);
            hi = hi.max(c[axis]);
        }
        let to_column = |x: f64| {
            (((x - self.origin[k]) / self.size).floor().max(0.0) as usize).min(self.dims[k] - 1)
        };
        // A triangle on a column border counts in both columns.
        (
            to_column(lo).saturating_sub(1),
            (to_column(hi) + 1).min(self.dims[k] - 1),
        )
    }

    /// The square of column `(i, j)` along `across`.
    pub(super) fn square(&self, i: usize, j: usize) -> [[f64; 2]; 2] {
        let x0 = self.origin[0] + i as f64 * self.size;
        let y0 = self.origin[1] + j as f64 * self.size;
        [[x0, x0 + self.size], [y0, y0 + self.size]]
    }

    /// The spans of row `j`.
    fn row(
        &self,
        j: usize,
        row: &[u32],
        triangles: &[SolidTriangle],
        solids: &ClosedSolids,
    ) -> Vec<Vec<Span>> {
        // Per column of the row: (triangle, lowest and highest height of its piece).
        let mut pieces: Vec<Vec<(u32, f64, f64)>> = vec![Vec::new(); self.dims[0]];
        for &k in row {
            let t = &triangles[k as usize];
            let (i0, i1) = self.range_of(&t.corners, 0);
            for (i, column) in pieces.iter_mut().enumerate().take(i1 + 1).skip(i0) {
                if let Some((lo, hi)) = self.piece_heights(&t.corners, self.square(i, j)) {
                    column.push((k, lo, hi));
                }
            }
        }
        pieces
            .iter()
            .enumerate()
            .map(|(i, column)| self.column_spans(i, j, column, triangles, solids))
            .collect()
    }

    /// The heights of the piece of triangle `t` inside the prism over `square` (lowest,
    /// highest), or `None` when it has none. Grown by a rounding margin.
    fn piece_heights(&self, t: &[DVec3; 3], square: [[f64; 2]; 2]) -> Option<(f64, f64)> {
        let polygon = self.piece(t, square);
        if polygon.is_empty() {
            return None;
        }
        let scale = t
            .iter()
            .map(|c| c.abs().max_element())
            .fold(self.size, f64::max);
        let margin = 1e-9 * scale;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in &polygon {
            lo = lo.min(p[self.up]);
            hi = hi.max(p[self.up]);
        }
        Some((lo - margin, hi + margin))
    }

    /// The spans of column `(i, j)` given its triangles' pieces.
    fn column_spans(
        &self,
        i: usize,
        j: usize,
        column: &[(u32, f64, f64)],
        triangles: &[SolidTriangle],
        solids: &ClosedSolids,
    ) -> Vec<Span> {
        if column.is_empty() {
            return Vec::new();
        }
        let square = self.square(i, j);
        let mut forbidden: Vec<(f64, f64)> = Vec::with_capacity(column.len());
        for &(k, lo, hi) in column {
            match self.uncovered(k, column, triangles, solids, square) {
                None => forbidden.push((lo, hi)),
                Some(rest) => forbidden.extend(rest),
            }
        }
        // An open bottom's plane bounds its solid's inside (the winding below it says
        // nothing).
        let mut caps: Vec<f64> = Vec::new();
        for &(k, _, _) in column {
            if let Some((_, at, _)) = solids.solid(triangles[k as usize].solid as usize).open_at {
                let margin = 1e-9 * at.abs().max(self.size);
                forbidden.push((at - margin, at + margin));
                caps.push(at);
            }
        }
        forbidden.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut merged: Vec<(f64, f64)> = Vec::new();
        for (lo, hi) in forbidden {
            match merged.last_mut() {
                Some(last) if lo <= last.1 => last.1 = last.1.max(hi),
                _ => merged.push((lo, hi)),
            }
        }
        // Solids with a piece here, and a point of the column off its centre lines (where
        // walls on the grid would make the winding ray graze them).
        let mut by_solid: Vec<u32> = column
            .iter()
            .map(|&(k, _, _)| triangles[k as usize].solid)
            .collect();
        by_solid.sort_unstable();
        by_solid.dedup();
        let mut point = DVec3::ZERO;
        point[self.across[0]] = square[0][0] + 0.5371 * self.size;
        point[self.across[1]] = square[1][0] + 0.4629 * self.size;
        let mut spans = Vec::new();
        for pair in merged.windows(2) {
            let (lo, hi) = (pair[0].1, pair[1].0);
            point[self.up] = 0.5 * (lo + hi);
            if self.inside_union(point, column, triangles, solids, &by_solid) {
                let open = caps.iter().any(|&at| pair[0].0 <= at && at <= pair[0].1);
                spans.push(Span { lo, hi, open });
            }
        }
        spans
    }

    /// Whether `point` is inside some solid (winding number of its surface along the up axis
    /// above 0), counting only the column's triangles (the ray stays in the column). `false`
    /// when rounding leaves it open.
    fn inside_union(
        &self,
        point: DVec3,
        column: &[(u32, f64, f64)],
        triangles: &[SolidTriangle],
        solids: &ClosedSolids,
        by_solid: &[u32],
    ) -> bool {
        let mut inside = false;
        for &s in by_solid {
            let solid = solids.solid(s as usize);
            if solid.open_at.is_some_and(|(_, at, _)| point[self.up] < at) {
                continue; // below its open bottom: outside it
            }
            let orientation = solid.orientation;
            let corners = column
                .iter()
                .map(|&(k, _, _)| &triangles[k as usize])
                .filter(|t| t.solid == s)
                .map(|t| t.corners);
            match winding_number(corners, orientation, point, self.up, 1.0) {
                None => return false,
                Some(w) if w > 0 => inside = true,
                Some(_) => {}
            }
        }
        inside
    }

    /// The height ranges of the parts of triangle `k`'s piece in the prism over `square` that
    /// no face of another solid facing it covers, or `None` when no such face is there. A
    /// covered part is a wall two solids share (however each triangulates it): the union
    /// continues across it, so it bounds nothing. Faces count as facing it only when their
    /// corners lie on its plane to rounding.
    fn uncovered(
        &self,
        k: u32,
        column: &[(u32, f64, f64)],
        triangles: &[SolidTriangle],
        solids: &ClosedSolids,
        square: [[f64; 2]; 2],
    ) -> Option<Vec<(f64, f64)>> {
        let t = &triangles[k as usize];
        let orientation = solids.solid(t.solid as usize).orientation;
        let normal = (t.corners[1] - t.corners[0]).cross(t.corners[2] - t.corners[0]) * orientation;
        let length = normal.length();
        if length == 0.0 {
            return None;
        }
        let unit = normal / length;
        let scale = t
            .corners
            .iter()
            .map(|c| c.abs().max_element())
            .fold(self.size, f64::max);
        let on_plane = 1e-7 * scale;
        let rounding = 1e-9 * scale;
        let facing: Vec<&SolidTriangle> = column
            .iter()
            .map(|&(other, _, _)| &triangles[other as usize])
            .filter(|s| s.solid != t.solid)
            .filter(|s| {
                let o = solids.solid(s.solid as usize).orientation;
                let n = (s.corners[1] - s.corners[0]).cross(s.corners[2] - s.corners[0]) * o;
                n.dot(unit) < -(1.0 - 1e-9) * n.length()
                    && s.corners
                        .iter()
                        .all(|c| unit.dot(*c - t.corners[0]).abs() <= on_plane)
            })
            .collect();
        if facing.is_empty() {
            return None;
        }
        let mut rest = vec![self.piece(&t.corners, square)];
        for s in facing {
            rest = rest
                .into_iter()
                .flat_map(|polygon| outside_of(&polygon, &s.corners, unit, rounding))
                .collect();
            if rest.is_empty() {
                break;
            }
        }
        let margin = rounding + on_plane;
        Some(
            rest.iter()
                .map(|polygon| {
                    polygon
                        .iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                            (lo.min(p[self.up] - margin), hi.max(p[self.up] + margin))
                        })
                })
                .collect(),
        )
    }

    /// The piece of triangle `t` inside the prism over `square` (possibly empty).
    fn piece(&self, t: &[DVec3; 3], square: [[f64; 2]; 2]) -> Vec<DVec3> {
        let scale = t
            .iter()
            .map(|c| c.abs().max_element())
            .fold(self.size, f64::max);
        let margin = 1e-9 * scale;
        let mut polygon: Vec<DVec3> = t.to_vec();
        for (&axis, side) in self.across.iter().zip(square) {
            polygon = clip_by(&polygon, |p| p[axis] - (side[0] - margin));
            polygon = clip_by(&polygon, |p| (side[1] + margin) - p[axis]);
        }
        polygon
    }

    /// Column `(i, j)`'s spans.
    pub fn spans_of(&self, i: usize, j: usize) -> &[Span] {
        let c = i + j * self.dims[0];
        &self.spans[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }
}

/// The convex pieces of planar `polygon` (on the plane with unit normal `unit`) outside
/// triangle `s` (on the same plane). Pieces reaching less than `rounding` past an edge of `s`
/// are dropped: slivers left where two faces of a wall meet.
fn outside_of(polygon: &[DVec3], s: &[DVec3; 3], unit: DVec3, rounding: f64) -> Vec<Vec<DVec3>> {
    let mut pieces = Vec::new();
    let mut rest = polygon.to_vec();
    // Edge normals in the plane, pointing out of `s` whichever way it winds.
    let centre = (s[0] + s[1] + s[2]) / 3.0;
    for e in 0..3 {
        let (a, b) = (s[e], s[(e + 1) % 3]);
        let mut out = (b - a).cross(unit);
        if out.dot(centre - a) > 0.0 {
            out = -out;
        }
        let length = out.length();
        if length == 0.0 {
            return vec![polygon.to_vec()];
        }
        let out = out / length;
        let beyond = clip_by(&rest, |p| out.dot(p - a));
        if beyond.iter().any(|v| out.dot(*v - a) > rounding) {
            pieces.push(beyond);
        }
        rest = clip_by(&rest, |p| -out.dot(p - a));
        if rest.len() < 3 {
            break;
        }
    }
    pieces
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;

    fn boxes(list: &[([f32; 3], [f32; 3])]) -> Scene {
        let mut b = SceneBuilder::new("boxes");
        b.set_up(sightline_core::scene::UpAxis::Z);
        for (min, max) in list {
            b.add_box(glam::Vec3::from(*min), glam::Vec3::from(*max));
        }
        b.finish()
    }

    #[test]
    fn two_touching_boxes_make_one_column_span_across_their_shared_wall() {
        // A 10 m cube and a lower, wider box sharing part of the wall x = 10 (so they are
        // two solids, their walls triangulated differently); columns of 0.7 m, the wall
        // inside a column.
        let scene = boxes(&[
            ([0.0, 0.0, 0.0], [10.0, 10.0, 10.0]),
            ([10.0, -2.0, 0.0], [20.0, 12.0, 8.0]),
        ]);
        let solids = ClosedSolids::new(&scene);
        assert_eq!(solids.solid_count(), 2);
        let columns = Columns::new(&scene, &solids, 0.7, 1 << 20).unwrap();
        let column_at = |x: f64, y: f64| {
            let i = ((x - columns.origin[0]) / columns.size) as usize;
            let j = ((y - columns.origin[1]) / columns.size) as usize;
            columns.spans_of(i, j).to_vec()
        };
        // Inside one box: one span from floor to roof (less the margins).
        let inner = column_at(5.0, 5.0);
        assert_eq!(inner.len(), 1);
        assert!(inner[0].lo < 1e-6 && inner[0].hi > 10.0 - 1e-6, "{inner:?}");
        // Across the shared wall: the two boxes' wall pieces cover each other up to the
        // lower roof, so the column is inside the union up to it (the cube's wall above it
        // bounds the union).
        let wall = column_at(10.0, 5.0);
        assert_eq!(wall.len(), 1, "{wall:?}");
        assert!(
            wall[0].lo < 1e-6 && (wall[0].hi - 8.0).abs() < 1e-4,
            "{wall:?}"
        );
        // Beside the cube, the wider box alone.
        let side = column_at(10.0, -1.0);
        assert!(side.is_empty(), "{side:?}"); // its wall at x = 10 is open there
                                              // Outside both: nothing.
        assert!(column_at(5.0, 11.0).is_empty());
        assert!(column_at(5.0, -0.5).is_empty());
    }
}
