//! Screen-space binning: every projected polygon is listed in the square bins its bounding box
//! overlaps, so each bin can run the whole visibility pipeline on its own, in parallel with the
//! others.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 4.3 (bins, a sort of the triangle-bin pairs, and quantized bounding boxes for
//! AREOVERLAPPING).
//!
//! Polygons are not clipped to the bins (that would round the cut points and open cracks of a
//! grid unit between neighbours). Instead each bin processes the parts of the edges inside its
//! rectangle (`clip_edge`), and the bin's border is processed as four extra edges so the visible
//! regions of a bin are closed polygons inside the bin (see `boundary.rs`). Bin borders are
//! whole pixels, hence grid lines.

use rayon::prelude::*;

use super::predicates::Pt;
use super::project::{ScreenPoly, GRID};

/// A projected polygon in the shared polygon storage.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BinPoly {
    /// Triangle id.
    pub(crate) id: u32,
    /// First vertex in [`Polys::verts`].
    pub(crate) start: u32,
    /// Number of vertices.
    pub(crate) len: u32,
    /// `1/z` plane over screen pixels (see `project.rs`).
    pub(crate) plane: [f64; 3],
    /// Bounding box `[min_x, min_y, max_x, max_y]` in grid units (the quantized box of the
    /// paper's AREOVERLAPPING test).
    pub(crate) bbox: [i64; 4],
    /// Smallest and largest `1/z` over the polygon (at its vertices, `1/z` being affine).
    pub(crate) inv_z_range: [f64; 2],
    /// Relative uncertainty of its `1/z` from the f32 input (see `project.rs`).
    pub(crate) noise: f64,
}

/// All projected polygons, in triangle id order.
#[derive(Clone, Debug, Default)]
pub(crate) struct Polys {
    /// Polygons.
    pub(crate) polys: Vec<BinPoly>,
    /// Vertex storage.
    pub(crate) verts: Vec<Pt>,
}

impl Polys {
    /// Stores the projected polygons.
    pub(crate) fn new(input: Vec<ScreenPoly>) -> Self {
        let mut out = Self::default();
        for p in input {
            let mut range = [f64::INFINITY, f64::NEG_INFINITY];
            for v in &p.verts {
                let (x, y) = (v[0] as f64 / GRID, v[1] as f64 / GRID);
                let inv = p.plane[0] * x + p.plane[1] * y + p.plane[2];
                range = [range[0].min(inv), range[1].max(inv)];
            }
            out.polys.push(BinPoly {
                id: p.id,
                start: out.verts.len() as u32,
                len: p.verts.len() as u32,
                plane: p.plane,
                bbox: bbox(&p.verts),
                inv_z_range: range,
                noise: p.noise,
            });
            out.verts.extend_from_slice(&p.verts);
        }
        out
    }

    /// The vertices of polygon `k`.
    pub(crate) fn verts_of(&self, k: u32) -> &[Pt] {
        let p = &self.polys[k as usize];
        &self.verts[p.start as usize..(p.start + p.len) as usize]
    }
}

/// One bin: its rectangle and the polygons overlapping it.
#[derive(Clone, Debug, Default)]
pub(crate) struct Bin {
    /// Bin column.
    pub(crate) x: u32,
    /// Bin row.
    pub(crate) y: u32,
    /// `[x0, y0, x1, y1]` in grid units.
    pub(crate) rect: [i64; 4],
    /// Indices into [`Polys::polys`], increasing (so triangle ids increase too).
    pub(crate) members: Vec<u32>,
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

/// The parameter range `[t0, t1]` of the edge `a → a + d` inside the closed rectangle (Liang–
/// Barsky), or `None` when that part has no length. An edge lying on the rectangle's border
/// belongs to the bin only when its left side (its polygon's interior) points into the bin, so
/// the two bins sharing that border do not both report it.
pub(crate) fn clip_edge(a: Pt, d: Pt, rect: [i64; 4]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for axis in 0..2 {
        let (lo, hi) = (rect[axis], rect[axis + 2]);
        if d[axis] == 0 {
            if a[axis] < lo || a[axis] > hi {
                return None;
            }
            // On the border line: the left normal (-d.y, d.x) must point inside.
            let inward = if axis == 0 { -d[1] } else { d[0] };
            if (a[axis] == lo && inward < 0) || (a[axis] == hi && inward > 0) {
                return None;
            }
            continue;
        }
        let (s, e) = (
            (lo - a[axis]) as f64 / d[axis] as f64,
            (hi - a[axis]) as f64 / d[axis] as f64,
        );
        let (s, e) = if s < e { (s, e) } else { (e, s) };
        t0 = t0.max(s);
        t1 = t1.min(e);
    }
    (t0 < t1).then_some((t0, t1))
}

/// Lists every polygon in the bins its bounding box overlaps (with positive area), grouped by
/// bin (row-major). Only bins with at least one polygon are returned.
pub(crate) fn bin_polygons(polys: &Polys, grid: BinGrid) -> Vec<Bin> {
    let step = i64::from(grid.size) * GRID as i64;
    let cols = i64::from(grid.cols);
    let rows = i64::from(grid.rows);
    // (bin index, polygon index) pairs, then one sort groups them (the paper's radix sort).
    let mut pairs: Vec<(u32, u32)> = polys
        .polys
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, p)| {
            let b = p.bbox;
            // Bins whose open interior meets the box: a box ending on a border stays out.
            let bx0 = (b[0] / step).clamp(0, cols - 1);
            let bx1 = ((b[2] - 1).div_euclid(step)).clamp(bx0, cols - 1);
            let by0 = (b[1] / step).clamp(0, rows - 1);
            let by1 = ((b[3] - 1).div_euclid(step)).clamp(by0, rows - 1);
            (by0..=by1)
                .flat_map(move |by| (bx0..=bx1).map(move |bx| ((by * cols + bx) as u32, k as u32)))
        })
        .collect();
    pairs.par_sort_unstable();
    let mut bins: Vec<Bin> = Vec::new();
    for (index, k) in pairs {
        let (x, y) = (index % grid.cols, index / grid.cols);
        if bins.last().is_none_or(|b| b.x != x || b.y != y) {
            let (x0, y0) = (i64::from(x) * step, i64::from(y) * step);
            bins.push(Bin {
                x,
                y,
                rect: [x0, y0, x0 + step, y0 + step],
                members: Vec::new(),
            });
        }
        if let Some(bin) = bins.last_mut() {
            bin.members.push(k);
        }
    }
    bins
}

/// Cells per bin side of [`BinIndex`].
const CELLS: usize = 4;

/// A uniform grid of `CELLS × CELLS` cells over one bin, listing the bin's polygons per cell,
/// so that an edge is tested only against the polygons near it (a finer AREOVERLAPPING).
#[derive(Debug, Default)]
pub(crate) struct BinIndex {
    cells: Vec<Vec<u32>>,
    /// Per member (position in `Bin::members`): the last query that returned it.
    stamp: Vec<u32>,
    query: u32,
    origin: [i64; 2],
    cell: i64,
}

impl BinIndex {
    /// Indexes the members of `bin`.
    pub(crate) fn new(polys: &Polys, bin: &Bin) -> Self {
        let cell = ((bin.rect[2] - bin.rect[0]) / CELLS as i64).max(1);
        let mut index = Self {
            cells: vec![Vec::new(); CELLS * CELLS],
            stamp: vec![0; bin.members.len()],
            query: 0,
            origin: [bin.rect[0], bin.rect[1]],
            cell,
        };
        for (m, &k) in bin.members.iter().enumerate() {
            let [x0, y0, x1, y1] = index.cell_range(polys.polys[k as usize].bbox);
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    index.cells[cy * CELLS + cx].push(m as u32);
                }
            }
        }
        index
    }

    /// Cells touched by a closed box, clamped to the bin.
    fn cell_range(&self, b: [i64; 4]) -> [usize; 4] {
        let c =
            |v: i64, o: i64| ((v - o).div_euclid(self.cell)).clamp(0, CELLS as i64 - 1) as usize;
        [
            c(b[0], self.origin[0]),
            c(b[1], self.origin[1]),
            c(b[2], self.origin[0]),
            c(b[3], self.origin[1]),
        ]
    }

    /// The members (as indices into [`Polys`]) whose cells meet the closed box `b`, each once.
    pub(crate) fn query(&mut self, bin: &Bin, b: [i64; 4], out: &mut Vec<u32>) {
        out.clear();
        self.query += 1;
        let [x0, y0, x1, y1] = self.cell_range(b);
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                for &m in &self.cells[cy * CELLS + cx] {
                    if self.stamp[m as usize] != self.query {
                        self.stamp[m as usize] = self.query;
                        out.push(bin.members[m as usize]);
                    }
                }
            }
        }
    }
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
            noise: 0.0,
        }
    }

    #[test]
    fn no_polygons_gives_no_bins() {
        assert!(bin_polygons(&Polys::new(Vec::new()), BinGrid::new(64, 64, 8)).is_empty());
    }

    #[test]
    fn square_over_four_bins_is_in_four() {
        let polys = Polys::new(vec![square(4 * G, 4 * G, 12 * G, 12 * G)]);
        let bins = bin_polygons(&polys, BinGrid::new(64, 64, 8));
        assert_eq!(bins.len(), 4);
    }

    #[test]
    fn square_ending_on_border_stays_in_its_bin() {
        let polys = Polys::new(vec![square(G, G, 8 * G, 8 * G)]);
        let bins = bin_polygons(&polys, BinGrid::new(64, 64, 8));
        assert_eq!(bins.len(), 1);
    }

    #[test]
    fn edge_clip_cuts_at_border() {
        let r = clip_edge([0, 0], [20, 10], [5, 0, 10, 10]);
        assert_eq!(r, Some((0.25, 0.5)));
        assert_eq!(clip_edge([0, 0], [4, 0], [5, 0, 10, 10]), None);
    }

    #[test]
    fn edge_on_border_goes_to_its_interior_side() {
        // Upward edge (d = (0, -10)) on x = 10: its left normal (10, 0) points to +x.
        assert_eq!(clip_edge([10, 10], [0, -10], [0, 0, 10, 10]), None);
        assert_eq!(
            clip_edge([10, 10], [0, -10], [10, 0, 20, 10]),
            Some((0.0, 1.0))
        );
    }
}
