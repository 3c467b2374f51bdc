//! Which view cells does a line segment cross? A uniform grid of bins over the cells' bounding
//! boxes, walked with a 3D DDA along the segment; the cells listed in the visited bins are then
//! tested exactly with a slab test in each cell's own frame (cells may be oriented boxes or
//! rectangles, and may overlap).
//!
//! Based on: Amanatides, Woo. A Fast Voxel Traversal Algorithm for Ray Tracing. Eurographics
//! 1987 (the bin walk); Kay, Kajiya. Ray Tracing Complex Scenes. SIGGRAPH 1986 (the slab test).
//!
//! Used by ray sharing (`ray_sharing/`): a segment of free space found by one cell's ray is
//! handed to every cell it crosses. A regular grid of cells (the common case, e.g. `--grid
//! 16,16,1`) gets one bin per cell, so the walk visits about as many bins as the segment
//! crosses cells.

use glam::Vec3;
use sightline_core::Aabb;

use crate::viewcell::ViewCell;

/// One cell a segment crosses: the cell's index and the segment's parameter interval inside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// Index of the cell in the list the index was built from.
    pub cell: u32,
    /// Ray parameter where the segment enters the cell (clipped to the segment).
    pub t_enter: f32,
    /// Ray parameter where it leaves (clipped to the segment); `>= t_enter`.
    pub t_exit: f32,
}

/// The parameter interval of the line `origin + t dir` inside `cell`, clipped to
/// `[t_min, t_max]`, or `None` when they do not meet. Boundary contact counts as crossing.
pub fn segment_in_cell(
    cell: &ViewCell,
    origin: Vec3,
    dir: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<(f32, f32)> {
    let d = origin - cell.center;
    let (mut lo, mut hi) = (t_min, t_max);
    for i in 0..3 {
        let axis = cell.axes[i];
        let o = d.dot(axis);
        let v = dir.dot(axis);
        let h = cell.half_extents[i];
        if v == 0.0 {
            if o.abs() > h {
                return None;
            }
            continue;
        }
        let (a, b) = ((-h - o) / v, (h - o) / v);
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        lo = lo.max(a);
        hi = hi.min(b);
        if lo > hi {
            return None;
        }
    }
    Some((lo, hi))
}

/// When `cells` are a regular grid of equal axis-aligned boxes: the grid's box, its counts and
/// the cell of every bin. Without padding, a segment lying exactly on a face two cells share is
/// handed to one of them only (sharing may skip a contribution, never invent one).
fn regular_layout(cells: &[ViewCell], boxes: &[Aabb]) -> Option<(Aabb, [usize; 3], Vec<u32>)> {
    let size = boxes.first()?.extent();
    if size.min_element() <= 0.0 || cells.iter().any(|c| c.axes != [Vec3::X, Vec3::Y, Vec3::Z]) {
        return None;
    }
    let tolerance = size.max_element() * 1e-4;
    if boxes
        .iter()
        .any(|b| (b.extent() - size).abs().max_element() > tolerance)
    {
        return None;
    }
    let union = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let dims: [usize; 3] = std::array::from_fn(|a| (union.extent()[a] / size[a]).round() as usize);
    if dims.iter().product::<usize>() != cells.len() {
        return None;
    }
    let mut cell_of_bin = vec![u32::MAX; cells.len()];
    for (id, b) in boxes.iter().enumerate() {
        let at = (b.min - union.min) / size;
        let index: [usize; 3] = std::array::from_fn(|a| at[a].round().max(0.0) as usize);
        if (0..3).any(|a| (at[a] - index[a] as f32).abs() > 1e-3 || index[a] >= dims[a]) {
            return None;
        }
        let bin = index[0] + dims[0] * (index[1] + dims[1] * index[2]);
        if cell_of_bin[bin] != u32::MAX {
            return None;
        }
        cell_of_bin[bin] = id as u32;
    }
    Some((union, dims, cell_of_bin))
}

/// The cells crossed by a segment, for many segments against a fixed list of cells.
#[derive(Clone, Debug)]
pub struct SegmentCells {
    cells: Vec<ViewCell>,
    bounds: Aabb,
    dims: [usize; 3],
    bin_size: Vec3,
    /// Bin `b` lists `ids[offsets[b]..offsets[b + 1]]`.
    offsets: Vec<u32>,
    ids: Vec<u32>,
    /// Built by `regular_layout`: one bin per cell.
    regular: bool,
}

/// The most bins per axis, and in all (a bound on memory for odd cell layouts).
const MAX_BINS_PER_AXIS: usize = 512;
const MAX_BINS: usize = 1 << 22;

impl SegmentCells {
    /// An index over `cells`. Bins are about the median cell size along each axis; a regular
    /// grid of axis-aligned boxes (as [`ViewCell::grid`] makes) gets exactly one bin per cell.
    pub fn new(cells: &[ViewCell]) -> Self {
        let boxes: Vec<Aabb> = cells
            .iter()
            .map(|c| Aabb::from_points(c.corners()))
            .collect();
        if let Some((bounds, dims, cell_of_bin)) = regular_layout(cells, &boxes) {
            let bin_size =
                bounds.extent() / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
            return Self {
                cells: cells.to_vec(),
                bounds,
                dims,
                bin_size,
                offsets: (0..=cell_of_bin.len() as u32).collect(),
                ids: cell_of_bin,
                regular: true,
            };
        }
        let mut bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        if cells.is_empty() {
            bounds = Aabb::new(Vec3::ZERO, Vec3::ZERO);
        }
        // Pad so that cells touching the bounds' faces lie strictly inside the bin range.
        let pad = (bounds.extent().max_element() * 1e-4).max(1e-6);
        bounds = Aabb::new(bounds.min - Vec3::splat(pad), bounds.max + Vec3::splat(pad));
        let extent = bounds.extent();
        let mut dims = [1usize; 3];
        for (axis, dim) in dims.iter_mut().enumerate() {
            let mut sizes: Vec<f32> = boxes.iter().map(|b| b.extent()[axis]).collect();
            sizes.sort_by(f32::total_cmp);
            let median = sizes.get(sizes.len() / 2).copied().unwrap_or(0.0);
            *dim = if median > 0.0 {
                ((extent[axis] / median).floor() as usize).clamp(1, MAX_BINS_PER_AXIS)
            } else {
                // Flat along this axis (e.g. a layer of rectangles): one bin.
                1
            };
        }
        while dims.iter().product::<usize>() > MAX_BINS {
            let largest = (0..3).max_by_key(|&i| dims[i]).unwrap_or(0);
            dims[largest] = dims[largest].div_ceil(2);
        }
        let bin_size = extent / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
        let mut index = Self {
            cells: cells.to_vec(),
            bounds,
            dims,
            bin_size,
            offsets: Vec::new(),
            ids: Vec::new(),
            regular: false,
        };
        // Each cell goes into every bin its (slightly grown) box overlaps, so rounding in the
        // walk never skips it.
        let ranges: Vec<[std::ops::RangeInclusive<usize>; 3]> = boxes
            .iter()
            .map(|b| {
                let lo = index.bin_of(b.min - Vec3::splat(pad));
                let hi = index.bin_of(b.max + Vec3::splat(pad));
                [lo[0]..=hi[0], lo[1]..=hi[1], lo[2]..=hi[2]]
            })
            .collect();
        let n_bins = dims.iter().product::<usize>();
        let mut counts = vec![0u32; n_bins + 1];
        let each = |f: &mut dyn FnMut(usize, u32)| {
            for (id, [rx, ry, rz]) in ranges.iter().enumerate() {
                for z in rz.clone() {
                    for y in ry.clone() {
                        for x in rx.clone() {
                            f(x + dims[0] * (y + dims[1] * z), id as u32);
                        }
                    }
                }
            }
        };
        each(&mut |bin, _| counts[bin + 1] += 1);
        for i in 0..n_bins {
            counts[i + 1] += counts[i];
        }
        let mut fill = counts.clone();
        let mut ids = vec![0u32; counts[n_bins] as usize];
        each(&mut |bin, id| {
            ids[fill[bin] as usize] = id;
            fill[bin] += 1;
        });
        index.offsets = counts;
        index.ids = ids;
        index
    }

    /// True when the cells form a regular grid of equal axis-aligned boxes (no two overlap).
    pub fn is_regular(&self) -> bool {
        self.regular
    }

    /// The cells of the index.
    pub fn cells(&self) -> &[ViewCell] {
        &self.cells
    }

    /// Bins per axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The bin holding `p`, clamped to the grid.
    fn bin_of(&self, p: Vec3) -> [usize; 3] {
        let f = (p - self.bounds.min) / self.bin_size;
        std::array::from_fn(|i| {
            let v = f[i];
            if v.is_nan() || v <= 0.0 {
                0
            } else {
                (v as usize).min(self.dims[i] - 1)
            }
        })
    }

    /// Appends to `out` every cell that the segment `origin + t dir`, `t` in `[t_min, t_max]`
    /// crosses (`t_max` may be infinite), with its interval, in ascending cell index. `scratch`
    /// is reused between calls to avoid allocating.
    pub fn crossings(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
        scratch: &mut Vec<u32>,
        out: &mut Vec<Crossing>,
    ) {
        if self.regular {
            // One cell per bin and no bin twice: the walk's own intervals are the crossings.
            let start = out.len();
            self.walk(origin, dir, t_min, t_max, &mut |bin, t_enter, t_exit| {
                out.push(Crossing {
                    cell: self.ids[bin],
                    t_enter,
                    t_exit,
                });
            });
            out[start..].sort_unstable_by_key(|c| c.cell);
            return;
        }
        scratch.clear();
        self.walk(origin, dir, t_min, t_max, &mut |bin, _, _| {
            scratch.extend_from_slice(
                &self.ids[self.offsets[bin] as usize..self.offsets[bin + 1] as usize],
            );
        });
        scratch.sort_unstable();
        scratch.dedup();
        for &id in scratch.iter() {
            if let Some((t_enter, t_exit)) =
                segment_in_cell(&self.cells[id as usize], origin, dir, t_min, t_max)
            {
                out.push(Crossing {
                    cell: id,
                    t_enter,
                    t_exit,
                });
            }
        }
    }

    /// Calls `visit(bin, t_enter, t_exit)` for every bin the segment passes, in order along it.
    fn walk(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
        visit: &mut dyn FnMut(usize, f32, f32),
    ) {
        // Clip to the grid's box.
        let (mut lo, mut hi) = (t_min, t_max);
        for i in 0..3 {
            let (o, v) = (origin[i], dir[i]);
            let (bmin, bmax) = (self.bounds.min[i], self.bounds.max[i]);
            if v == 0.0 {
                if o < bmin || o > bmax {
                    return;
                }
                continue;
            }
            let (a, b) = ((bmin - o) / v, (bmax - o) / v);
            let (a, b) = if a <= b { (a, b) } else { (b, a) };
            lo = lo.max(a);
            hi = hi.min(b);
        }
        if lo > hi || lo.is_nan() || hi.is_nan() {
            return;
        }
        // Amanatides & Woo: step from bin to bin, always across the nearest bin boundary.
        let start = origin + dir * lo;
        let mut bin = self.bin_of(start);
        let mut step = [0isize; 3];
        let mut t_next = [f32::INFINITY; 3];
        let mut t_delta = [f32::INFINITY; 3];
        for i in 0..3 {
            let v = dir[i];
            if v > 0.0 {
                step[i] = 1;
                let boundary = self.bounds.min[i] + (bin[i] + 1) as f32 * self.bin_size[i];
                t_next[i] = (boundary - origin[i]) / v;
                t_delta[i] = self.bin_size[i] / v;
            } else if v < 0.0 {
                step[i] = -1;
                let boundary = self.bounds.min[i] + bin[i] as f32 * self.bin_size[i];
                t_next[i] = (boundary - origin[i]) / v;
                t_delta[i] = -self.bin_size[i] / v;
            }
        }
        let mut t_enter = lo;
        loop {
            let b = bin[0] + self.dims[0] * (bin[1] + self.dims[1] * bin[2]);
            // The axis whose boundary comes first.
            let axis = if t_next[0] <= t_next[1] && t_next[0] <= t_next[2] {
                0
            } else if t_next[1] <= t_next[2] {
                1
            } else {
                2
            };
            let t_exit = t_next[axis].min(hi).max(t_enter);
            visit(b, t_enter, t_exit);
            if t_next[axis] > hi || step[axis] == 0 {
                break;
            }
            t_enter = t_exit;
            let next = bin[axis] as isize + step[axis];
            if next < 0 || next >= self.dims[axis] as isize {
                break;
            }
            bin[axis] = next as usize;
            t_next[axis] += t_delta[axis];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::random::SplitMix64;

    fn brute_force(cells: &[ViewCell], o: Vec3, d: Vec3, t0: f32, t1: f32) -> Vec<u32> {
        cells
            .iter()
            .enumerate()
            .filter(|(_, c)| segment_in_cell(c, o, d, t0, t1).is_some())
            .map(|(i, _)| i as u32)
            .collect()
    }

    fn random_vec(rng: &mut SplitMix64, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(
            rng.range_f32(lo, hi),
            rng.range_f32(lo, hi),
            rng.range_f32(lo, hi),
        )
    }

    fn check_against_brute_force(cells: &[ViewCell], seed: u64, segments: usize) -> usize {
        let index = SegmentCells::new(cells);
        let mut rng = SplitMix64::new(seed);
        let (mut scratch, mut out) = (Vec::new(), Vec::new());
        let mut total = 0;
        for k in 0..segments {
            let o = random_vec(&mut rng, -2.0, 18.0);
            let d = random_vec(&mut rng, -1.0, 1.0);
            // Some segments unbounded (a ray that hit nothing), some short.
            let (t0, t1) = match k % 3 {
                0 => (-rng.range_f32(0.0, 30.0), f32::INFINITY),
                1 => (-rng.range_f32(0.0, 2.0), rng.range_f32(0.0, 2.0)),
                _ => (rng.range_f32(-20.0, 0.0), rng.range_f32(0.0, 20.0)),
            };
            out.clear();
            index.crossings(o, d, t0, t1, &mut scratch, &mut out);
            let found: Vec<u32> = out.iter().map(|c| c.cell).collect();
            assert_eq!(
                found,
                brute_force(cells, o, d, t0, t1),
                "segment {k}: {o} + t {d}, t in [{t0}, {t1}]"
            );
            for c in &out {
                assert!(c.t_enter <= c.t_exit && c.t_enter >= t0 && c.t_exit <= t1);
                let mid = o + d * (0.5 * (c.t_enter + c.t_exit.min(1e6)));
                if c.t_exit.is_finite() {
                    assert!(cells[c.cell as usize].contains(mid));
                }
            }
            total += found.len();
        }
        total
    }

    #[test]
    fn grid_crossings_equal_brute_force() {
        let cells = ViewCell::grid(Vec3::ZERO, Vec3::new(16.0, 16.0, 4.0), [16, 16, 2]).unwrap();
        let index = SegmentCells::new(&cells);
        assert_eq!(index.dims(), [16, 16, 2]);
        let total = check_against_brute_force(&cells, 11, 3000);
        assert!(total > 3000, "random segments crossed only {total} cells");
    }

    #[test]
    fn scattered_oriented_and_flat_cells_equal_brute_force() {
        let mut rng = SplitMix64::new(5);
        let mut cells = Vec::new();
        for i in 0..60 {
            let c = random_vec(&mut rng, 0.0, 16.0);
            let a = random_vec(&mut rng, -1.0, 1.0).normalize_or(Vec3::X);
            let b = a.any_orthonormal_vector();
            let h = random_vec(&mut rng, 0.2, 3.0);
            // Every fifth cell is a rectangle.
            let h = if i % 5 == 0 {
                Vec3::new(h.x, h.y, 0.0)
            } else {
                h
            };
            cells.push(ViewCell::oriented(c, [a, b, a.cross(b)], h).unwrap());
        }
        let total = check_against_brute_force(&cells, 12, 3000);
        assert!(total > 1000, "random segments crossed only {total} cells");
    }

    #[test]
    fn empty_index_finds_nothing() {
        let index = SegmentCells::new(&[]);
        let (mut scratch, mut out) = (Vec::new(), Vec::new());
        index.crossings(Vec3::ZERO, Vec3::X, 0.0, 10.0, &mut scratch, &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn axis_parallel_segment_on_a_shared_face_finds_both_neighbours() {
        // Two cells of different sizes (not a regular grid): the binned path pads.
        let cells = [
            ViewCell::aabb(Vec3::ZERO, Vec3::ONE).unwrap(),
            ViewCell::aabb(Vec3::new(1.0, 0.0, 0.0), Vec3::new(3.0, 1.0, 1.0)).unwrap(),
        ];
        let index = SegmentCells::new(&cells);
        let (mut scratch, mut out) = (Vec::new(), Vec::new());
        // Along the face x = 1 that both cells share.
        index.crossings(
            Vec3::new(1.0, -1.0, 0.5),
            Vec3::Y,
            0.0,
            f32::INFINITY,
            &mut scratch,
            &mut out,
        );
        assert_eq!(out.iter().map(|c| c.cell).collect::<Vec<_>>(), vec![0, 1]);
        assert_eq!((out[0].t_enter, out[0].t_exit), (1.0, 2.0));
    }

    #[test]
    fn regular_grid_gets_one_bin_per_cell() {
        let cells = ViewCell::grid(Vec3::ZERO, Vec3::new(16.0, 16.0, 4.0), [16, 16, 2]).unwrap();
        let index = SegmentCells::new(&cells);
        assert_eq!(index.ids.len(), cells.len());
        // A grid with one cell left out is not regular: the padded bins are used.
        let partial = SegmentCells::new(&cells[1..]);
        assert!(partial.ids.len() > cells.len());
        check_against_brute_force(&cells[1..], 13, 1000);
    }
}
