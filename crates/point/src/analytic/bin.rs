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
    /// Collinearity tolerance of its edges, grid units (see `project.rs`).
    pub(crate) collinear_grid: f64,
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
                collinear_grid: p.collinear_grid,
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

/// Finest level of [`BinIndex`]: at most `2^MAX_LEVEL` cells per side.
const MAX_LEVEL: u32 = 10;
/// Members per cell of the finest level that [`BinIndex`] aims at.
const MEMBERS_PER_CELL: usize = 2;
/// Up to this many members a bin is indexed by [`SPARSE_CELLS`]² cells over the whole bin, each
/// member listed in every cell its box meets (cheapest for the bins of ordinary images).
const SPARSE_MEMBERS: usize = 256;
/// Cells per side of a sparse bin's index.
const SPARSE_CELLS: i64 = 4;

/// One level of [`BinIndex`]: `side × side` square cells of `cell` grid units, listing (as
/// compressed rows) the members whose boxes fit this level.
#[derive(Debug, Default)]
struct Level {
    side: i64,
    cell: i64,
    /// `offsets[c]..offsets[c + 1]` is the slice of `entries` of cell `c` (row-major).
    offsets: Vec<u32>,
    /// Member positions (in `Bin::members`), per cell.
    entries: Vec<u32>,
    /// Every member of this level, for queries that cover more cells than it has members.
    members: Vec<u32>,
}

/// A grid over the polygons of one bin, so that an edge is tested only against the polygons
/// near it (a finer AREOVERLAPPING).
///
/// Up to [`SPARSE_MEMBERS`] members: [`SPARSE_CELLS`]² cells over the bin, every member listed
/// in each cell its box meets. Denser bins (a tiny image, a far camera or a field of view near
/// 180° put a whole scene into one bin, even into a fraction of one pixel) get a multi-level
/// grid over the part of the bin the members' boxes occupy, whose finest level has about one
/// cell per [`MEMBERS_PER_CELL`] members, so the work per query follows the local density
/// instead of the bin's member count: each member is listed at the finest level whose cells are
/// at least as large as its box (at most 2 × 2 cells there), and a query visits, per level, the
/// cells its box meets, or that level's member list when that is shorter.
#[derive(Debug, Default)]
pub(crate) struct BinIndex {
    levels: Vec<Level>,
    /// Per member: its bounding box (for the list scans).
    boxes: Vec<[i64; 4]>,
    /// Per member: the last query that returned it.
    stamp: Vec<u32>,
    query: u32,
    origin: [i64; 2],
}

impl BinIndex {
    /// Indexes the members of `bin`.
    pub(crate) fn new(polys: &Polys, bin: &Bin) -> Self {
        let boxes: Vec<[i64; 4]> = bin
            .members
            .iter()
            .map(|&k| polys.polys[k as usize].bbox)
            .collect();
        let r = bin.rect;
        if boxes.len() <= SPARSE_MEMBERS {
            return Self::sparse(boxes, r);
        }
        // The occupied part of the bin: where the central 90% of the members' centres are
        // (members beyond it are listed in the border cells, which clamping keeps correct; a
        // few large polygons must not stretch the grid over an empty bin).
        let centre =
            |b: &[i64; 4], axis: usize| ((b[axis] + b[axis + 2]) / 2).clamp(r[axis], r[axis + 2]);
        let n = boxes.len();
        let (lo, hi) = (n / 20, n - 1 - n / 20);
        let mut region = [0i64; 4];
        for axis in 0..2 {
            let mut c: Vec<i64> = boxes.iter().map(|b| centre(b, axis)).collect();
            region[axis] = *c.select_nth_unstable(lo).1;
            region[axis + 2] = *c.select_nth_unstable(hi).1;
        }
        let origin = [region[0], region[1]];
        let extent = (region[2] - region[0]).max(region[3] - region[1]).max(1);
        let mut finest = 0;
        while finest < MAX_LEVEL
            && (1usize << (2 * finest)) * MEMBERS_PER_CELL < boxes.len()
            && extent >> finest > 1
        {
            finest += 1;
        }
        let mut levels: Vec<Level> = (0..=finest)
            .map(|l| Level {
                side: 1 << l,
                // Rounded up, so `side` cells cover the region.
                cell: ((extent + (1 << l) - 1) >> l).max(1),
                ..Level::default()
            })
            .collect();
        // The level of each member: the finest one whose cell is at least its size (clamped to
        // the region).
        let level_of: Vec<usize> = boxes
            .iter()
            .map(|b| {
                let w = b[2].min(region[2]) - b[0].max(region[0]);
                let h = b[3].min(region[3]) - b[1].max(region[1]);
                let size = w.max(h);
                levels.iter().rposition(|l| l.cell >= size).unwrap_or(0)
            })
            .collect();
        for (m, &l) in level_of.iter().enumerate() {
            levels[l].members.push(m as u32);
        }
        for level in &mut levels {
            let cells = (level.side * level.side) as usize;
            let mut counts = vec![0u32; cells + 1];
            let range =
                |level: &Level, b: &[i64; 4]| cell_range(origin, level.cell, level.side, *b);
            for &m in &level.members {
                let [x0, y0, x1, y1] = range(level, &boxes[m as usize]);
                for cy in y0..=y1 {
                    for cx in x0..=x1 {
                        counts[(cy * level.side + cx) as usize + 1] += 1;
                    }
                }
            }
            for c in 0..cells {
                counts[c + 1] += counts[c];
            }
            let mut fill = counts.clone();
            let mut entries = vec![0u32; counts[cells] as usize];
            for &m in &level.members {
                let [x0, y0, x1, y1] = range(level, &boxes[m as usize]);
                for cy in y0..=y1 {
                    for cx in x0..=x1 {
                        let c = (cy * level.side + cx) as usize;
                        entries[fill[c] as usize] = m;
                        fill[c] += 1;
                    }
                }
            }
            level.offsets = counts;
            level.entries = entries;
        }
        Self {
            levels,
            stamp: vec![0; boxes.len()],
            boxes,
            query: 0,
            origin,
        }
    }

    /// One level of [`SPARSE_CELLS`]² cells over the bin `rect`, listing every member in each
    /// cell its box meets.
    fn sparse(boxes: Vec<[i64; 4]>, rect: [i64; 4]) -> Self {
        let origin = [rect[0], rect[1]];
        let mut level = Level {
            side: SPARSE_CELLS,
            cell: ((rect[2] - rect[0]) / SPARSE_CELLS).max(1),
            ..Level::default()
        };
        let cells = (SPARSE_CELLS * SPARSE_CELLS) as usize;
        let mut lists: [Vec<u32>; (SPARSE_CELLS * SPARSE_CELLS) as usize] = Default::default();
        for (m, b) in boxes.iter().enumerate() {
            let [x0, y0, x1, y1] = cell_range(origin, level.cell, level.side, *b);
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    lists[(cy * SPARSE_CELLS + cx) as usize].push(m as u32);
                }
            }
        }
        level.offsets = Vec::with_capacity(cells + 1);
        level.offsets.push(0);
        for list in &lists {
            level.entries.extend_from_slice(list);
            level.offsets.push(level.entries.len() as u32);
        }
        Self {
            levels: vec![level],
            stamp: vec![0; boxes.len()],
            boxes,
            query: 0,
            origin,
        }
    }

    /// The members (as indices into [`Polys`]) whose boxes may meet the closed box `b`: every
    /// one that does, each once.
    #[inline]
    pub(crate) fn query(&mut self, bin: &Bin, b: [i64; 4], out: &mut Vec<u32>) {
        out.clear();
        if self.query == u32::MAX {
            self.stamp.fill(0);
            self.query = 0;
        }
        self.query += 1;
        for level in &self.levels {
            if level.entries.is_empty() {
                continue;
            }
            let [x0, y0, x1, y1] = cell_range(self.origin, level.cell, level.side, b);
            let cells = ((x1 - x0 + 1) * (y1 - y0 + 1)) as usize;
            // (A sparse index has no member list: its members may sit in several cells.)
            if !level.members.is_empty() && cells > level.members.len() {
                // Each member of a level is listed only here: no stamp needed.
                for &m in &level.members {
                    let p = &self.boxes[m as usize];
                    if p[0] <= b[2] && p[2] >= b[0] && p[1] <= b[3] && p[3] >= b[1] {
                        out.push(bin.members[m as usize]);
                    }
                }
                continue;
            }
            for cy in y0..=y1 {
                let row = (cy * level.side) as usize;
                let (lo, hi) = (
                    level.offsets[row + x0 as usize] as usize,
                    level.offsets[row + x1 as usize + 1] as usize,
                );
                for &m in &level.entries[lo..hi] {
                    if self.stamp[m as usize] != self.query {
                        self.stamp[m as usize] = self.query;
                        out.push(bin.members[m as usize]);
                    }
                }
            }
        }
    }
}

/// The cells `[x0, y0, x1, y1]` of a `side × side` grid of `cell`-unit cells at `origin` that
/// the closed box `b` touches, clamped to the grid (a box beyond the grid touches its border
/// cells, so clamping keeps every overlap).
#[inline]
fn cell_range(origin: [i64; 2], cell: i64, side: i64, b: [i64; 4]) -> [i64; 4] {
    let c = |v: i64, o: i64| (v - o).div_euclid(cell).clamp(0, side - 1);
    [
        c(b[0], origin[0]),
        c(b[1], origin[1]),
        c(b[2], origin[0]),
        c(b[3], origin[1]),
    ]
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
            collinear_grid: crate::analytic::project::NEAR_COLLINEAR_GRID,
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

    /// A bin over `[0, 16 px)²` holding boxes as polygons (index queries only see boxes).
    fn bin_of(boxes: &[[i64; 4]]) -> (Polys, Bin) {
        let polys = Polys::new(
            boxes
                .iter()
                .map(|b| square(b[0], b[1], b[2], b[3]))
                .collect(),
        );
        let bin = Bin {
            x: 0,
            y: 0,
            rect: [0, 0, 16 * G, 16 * G],
            members: (0..boxes.len() as u32).collect(),
        };
        (polys, bin)
    }

    /// Deterministic boxes: `n` of them, `size` grid units or less, inside `[0, extent)²`,
    /// and a few spanning the whole bin.
    fn random_boxes(n: usize, extent: i64, size: i64, seed: u64) -> Vec<[i64; 4]> {
        let mut state = seed;
        let mut next = |m: i64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % m as u64) as i64
        };
        (0..n)
            .map(|k| {
                if k % 997 == 0 {
                    return [0, 0, 16 * G, 16 * G];
                }
                let (x, y) = (next(extent), next(extent));
                [x, y, x + 1 + next(size), y + 1 + next(size)]
            })
            .collect()
    }

    #[test]
    fn index_queries_return_every_overlapping_member_once() {
        for (n, extent, size) in [(100, 16 * G, 4 * G), (3000, G, G / 50), (3000, 16 * G, G)] {
            let boxes = random_boxes(n, extent, size, 7 + n as u64);
            let (polys, bin) = bin_of(&boxes);
            let mut index = BinIndex::new(&polys, &bin);
            let mut out = Vec::new();
            for q in random_boxes(300, extent, size, 99) {
                index.query(&bin, q, &mut out);
                let mut sorted = out.clone();
                sorted.sort_unstable();
                sorted.dedup();
                assert_eq!(sorted.len(), out.len(), "duplicates");
                for (k, b) in boxes.iter().enumerate() {
                    let meets = b[0] <= q[2] && b[2] >= q[0] && b[1] <= q[3] && b[3] >= q[1];
                    assert!(
                        !meets || sorted.binary_search(&(k as u32)).is_ok(),
                        "missed {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn dense_bin_queries_see_only_nearby_members() {
        // A whole scene inside one pixel of one bin (a 1x1 image): 20,000 boxes of up to 1/200
        // px. Each query of a member's own box must see a handful of members, not the bin.
        let boxes = random_boxes(20_000, G, G / 200, 3);
        let (polys, bin) = bin_of(&boxes);
        let mut index = BinIndex::new(&polys, &bin);
        let (mut out, mut total) = (Vec::new(), 0usize);
        for b in &boxes {
            index.query(&bin, *b, &mut out);
            total += out.len();
        }
        // The boxes spanning the bin (1 in 997) are candidates of every query: 21 each.
        let average = total / boxes.len();
        assert!(average < 64, "{average} candidates per query");
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
