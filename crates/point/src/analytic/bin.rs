//! Screen-space binning: every projected polygon is clipped to the square bins it overlaps, so
//! each bin can run the whole visibility pipeline on its own, in parallel with the others.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 4.3 (bins and quantized bounding boxes for AREOVERLAPPING).
//!
//! Unlike the paper, which assigns whole triangles to bins, we *clip* them to the bins: then the
//! visible regions of a bin are closed polygons inside the bin, the edges on the bin border are
//! ordinary edges (nothing in the bin lies on their outer side, so boundary completion never
//! reports anything there), and the integration of a bin only touches the bin's pixels.
//! Bin borders are whole pixels, hence grid lines. A cut point of an edge with a bin border is
//! the exact intersection rounded to the grid, computed in `i128` from the edge's end points
//! only, so both triangles that share the edge get the same cut point (watertight).

use rayon::prelude::*;

use super::predicates::{twice_area, Pt};
use super::project::{ScreenPoly, GRID};

/// A triangle's piece in one bin.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BinPoly {
    /// Triangle id.
    pub(crate) id: u32,
    /// First vertex in [`Bin::verts`].
    pub(crate) start: u32,
    /// Number of vertices.
    pub(crate) len: u32,
    /// `1/z` plane over screen pixels (see `project.rs`).
    pub(crate) plane: [f64; 3],
    /// Bounding box `[min_x, min_y, max_x, max_y]` in grid units (the quantized box of the
    /// paper's AREOVERLAPPING test).
    pub(crate) bbox: [i64; 4],
}

/// The pieces of one bin, ordered by triangle id.
#[derive(Clone, Debug, Default)]
pub(crate) struct Bin {
    /// Bin column and row.
    pub(crate) x: u32,
    /// Bin row.
    pub(crate) y: u32,
    /// Pieces.
    pub(crate) polys: Vec<BinPoly>,
    /// Vertex storage of all pieces.
    pub(crate) verts: Vec<Pt>,
}

impl Bin {
    /// The vertices of piece `k`.
    pub(crate) fn poly_verts(&self, k: usize) -> &[Pt] {
        let p = &self.polys[k];
        &self.verts[p.start as usize..(p.start + p.len) as usize]
    }
}

/// The layout of the bins over a `width × height` image.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BinGrid {
    /// Bin edge length in pixels.
    pub(crate) size: u32,
    /// Bins per row.
    pub(crate) cols: u32,
    /// Bin rows.
    pub(crate) rows: u32,
}

impl BinGrid {
    /// Bins of `size` pixels covering a `width × height` image.
    pub(crate) fn new(width: u32, height: u32, size: u32) -> Self {
        Self {
            size,
            cols: width.div_ceil(size),
            rows: height.div_ceil(size),
        }
    }
}

/// `round(num / den)` (half away from zero) for `den != 0`.
fn div_round(num: i128, den: i128) -> i128 {
    let (num, den) = if den < 0 { (-num, -den) } else { (num, den) };
    if num >= 0 {
        (2 * num + den) / (2 * den)
    } else {
        -((-2 * num + den) / (2 * den))
    }
}

/// One Sutherland–Hodgman pass against the axis-aligned line `coord[axis] = bound`, keeping the
/// side `coord >= bound` (`keep_above`) or `coord <= bound`.
fn clip_axis(poly: &[Pt], out: &mut Vec<Pt>, axis: usize, bound: i64, keep_above: bool) {
    out.clear();
    let n = poly.len();
    let inside = |p: Pt| {
        if keep_above {
            p[axis] >= bound
        } else {
            p[axis] <= bound
        }
    };
    let other = 1 - axis;
    for i in 0..n {
        let (cur, nxt) = (poly[i], poly[(i + 1) % n]);
        let (ci, ni) = (inside(cur), inside(nxt));
        if ci && out.last() != Some(&cur) {
            out.push(cur);
        }
        if ci != ni {
            // Exact rational intersection, rounded: symmetric in the two end points.
            let num = i128::from(bound - cur[axis]) * i128::from(nxt[other] - cur[other]);
            let den = i128::from(nxt[axis] - cur[axis]);
            let mut p = [0; 2];
            p[axis] = bound;
            p[other] = cur[other] + div_round(num, den) as i64;
            if out.last() != Some(&p) {
                out.push(p);
            }
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
}

/// Clips `poly` to the rectangle `[x0, x1] × [y0, y1]` (grid units) into `out`.
fn clip_rect(poly: &[Pt], rect: [i64; 4], out: &mut Vec<Pt>, tmp: &mut Vec<Pt>) {
    clip_axis(poly, tmp, 0, rect[0], true);
    clip_axis(tmp, out, 0, rect[2], false);
    clip_axis(out, tmp, 1, rect[1], true);
    clip_axis(tmp, out, 1, rect[3], false);
}

/// Bounding box of a vertex list.
pub(crate) fn bbox(verts: &[Pt]) -> [i64; 4] {
    let mut b = [i64::MAX, i64::MAX, i64::MIN, i64::MIN];
    for v in verts {
        b[0] = b[0].min(v[0]);
        b[1] = b[1].min(v[1]);
        b[2] = b[2].max(v[0]);
        b[3] = b[3].max(v[1]);
    }
    b
}

/// Clips every polygon to the bins it overlaps and groups the pieces by bin (row-major). Only
/// bins with at least one piece are returned.
pub(crate) fn bin_polygons(polys: &[ScreenPoly], grid: BinGrid) -> Vec<Bin> {
    let step = i64::from(grid.size) * GRID as i64;
    // Per polygon: (bin index, piece) pairs; then a stable sort groups them by bin while
    // keeping triangle ids increasing inside each bin (the paper's radix sort).
    let mut pieces: Vec<(u32, u32, [f64; 3], Vec<Pt>)> = polys
        .par_iter()
        .flat_map_iter(|p| {
            let b = bbox(&p.verts);
            let bx0 = (b[0] / step).clamp(0, i64::from(grid.cols) - 1);
            let bx1 = (b[2] / step).clamp(0, i64::from(grid.cols) - 1);
            let by0 = (b[1] / step).clamp(0, i64::from(grid.rows) - 1);
            let by1 = (b[3] / step).clamp(0, i64::from(grid.rows) - 1);
            let mut found = Vec::new();
            let (mut out, mut tmp) = (Vec::new(), Vec::new());
            for by in by0..=by1 {
                for bx in bx0..=bx1 {
                    let rect = [bx * step, by * step, (bx + 1) * step, (by + 1) * step];
                    let piece: Vec<Pt> =
                        if b[0] >= rect[0] && b[1] >= rect[1] && b[2] <= rect[2] && b[3] <= rect[3]
                        {
                            p.verts.clone()
                        } else {
                            clip_rect(&p.verts, rect, &mut out, &mut tmp);
                            if twice_area(&out) <= 0 {
                                continue;
                            }
                            out.clone()
                        };
                    let index = (by * i64::from(grid.cols) + bx) as u32;
                    found.push((index, p.id, p.plane, piece));
                }
            }
            found
        })
        .collect();
    pieces.par_sort_by_key(|(bin, id, _, _)| (*bin, *id));
    let mut bins: Vec<Bin> = Vec::new();
    for (index, id, plane, verts) in pieces {
        let (x, y) = (index % grid.cols, index / grid.cols);
        if bins.last().is_none_or(|b| b.x != x || b.y != y) {
            bins.push(Bin {
                x,
                y,
                ..Bin::default()
            });
        }
        if let Some(bin) = bins.last_mut() {
            bin.polys.push(BinPoly {
                id,
                start: bin.verts.len() as u32,
                len: verts.len() as u32,
                plane,
                bbox: bbox(&verts),
            });
            bin.verts.extend_from_slice(&verts);
        }
    }
    bins
}

#[cfg(test)]
mod tests {
    use super::*;

    const G: i64 = GRID as i64;

    fn square(x0: i64, y0: i64, x1: i64, y1: i64) -> ScreenPoly {
        ScreenPoly {
            id: 0,
            verts: vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]],
            plane: [0.0, 0.0, 1.0],
        }
    }

    #[test]
    fn no_polygons_gives_no_bins() {
        assert!(bin_polygons(&[], BinGrid::new(64, 64, 8)).is_empty());
    }

    #[test]
    fn square_over_four_bins_is_split_in_four() {
        let bins = bin_polygons(
            &[square(4 * G, 4 * G, 12 * G, 12 * G)],
            BinGrid::new(64, 64, 8),
        );
        assert_eq!(bins.len(), 4);
        let area: i128 = bins.iter().map(|b| twice_area(b.poly_verts(0))).sum();
        assert_eq!(area, 2 * 64 * i128::from(G * G));
    }

    #[test]
    fn shared_edge_gets_identical_cut_points() {
        // Two triangles sharing the diagonal (1,1)-(15,6), cut by the bin border x = 8.
        let a = ScreenPoly {
            id: 0,
            verts: vec![[G, G], [15 * G, 6 * G], [G, 7 * G]],
            plane: [0.0, 0.0, 1.0],
        };
        let b = ScreenPoly {
            id: 1,
            verts: vec![[G, G], [15 * G, G], [15 * G, 6 * G]],
            plane: [0.0, 0.0, 1.0],
        };
        let bins = bin_polygons(&[a, b], BinGrid::new(16, 16, 8));
        let on_border = |bin: &Bin, k: usize| -> Vec<Pt> {
            bin.poly_verts(k)
                .iter()
                .copied()
                .filter(|v| v[0] == 8 * G && v[1] > G)
                .collect()
        };
        let left = &bins[0];
        assert_eq!(left.polys.len(), 2);
        let cut_a = on_border(left, 0);
        let cut_b = on_border(left, 1);
        assert!(cut_a.iter().any(|p| cut_b.contains(p)));
    }

    #[test]
    fn rounding_is_half_away_from_zero() {
        assert_eq!(div_round(5, 2), 3);
        assert_eq!(div_round(-5, 2), -3);
        assert_eq!(div_round(4, -3), -1);
    }
}
