//! A uniform grid of dynamic objects: each object is listed in every cell its bounding box
//! overlaps; objects are inserted, moved and removed every frame without rebuilding anything,
//! and a pass counter hands out an object that spans several cells only once per pass.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, sections 2.5 and 4.1 (objects binned by their axis-aligned box), 4.2.3 (the
//! 64-bit query counter against duplicates).

use glam::Vec3;
use sightline_core::Aabb;

/// Why a grid or an object's box was rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum GridError {
    /// The grid bounds are empty or not finite.
    #[error("grid bounds are empty or not finite")]
    BadBounds,
    /// A dimension is zero or the cell count exceeds `u32`.
    #[error("grid dimensions {0:?} are zero or too large")]
    BadDims([u32; 3]),
    /// An object's box is empty or not finite.
    #[error("object {0} has an empty or non-finite box")]
    BadBox(u32),
}

/// The geometry of a grid: where it is, how it is divided. Cells are indexed
/// `x + dims.x * (y + dims.y * z)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridShape {
    /// Minimum corner of cell `(0, 0, 0)`.
    pub origin: Vec3,
    /// Size of one cell along each axis (all positive).
    pub cell_size: Vec3,
    /// Number of cells along each axis (all positive).
    pub dims: [u32; 3],
}

impl GridShape {
    /// A shape dividing `bounds` into `dims` cells.
    pub fn new(bounds: &Aabb, dims: [u32; 3]) -> Result<Self, GridError> {
        if bounds.is_empty() || !bounds.min.is_finite() || !bounds.max.is_finite() {
            return Err(GridError::BadBounds);
        }
        let count = dims.iter().try_fold(1u32, |acc, &d| acc.checked_mul(d));
        if dims.contains(&0) || count.is_none() {
            return Err(GridError::BadDims(dims));
        }
        let size = bounds.extent() / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
        if !size.cmpgt(Vec3::ZERO).all() {
            return Err(GridError::BadBounds);
        }
        Ok(Self {
            origin: bounds.min,
            cell_size: size,
            dims,
        })
    }

    /// A shape covering `bounds` with cells of about `cell_size` (rounded so they fit exactly).
    pub fn with_cell_size(bounds: &Aabb, cell_size: Vec3) -> Result<Self, GridError> {
        if !(cell_size.min_element() > 0.0 && cell_size.is_finite()) {
            return Err(GridError::BadBounds);
        }
        let n = (bounds.extent() / cell_size).round().max(Vec3::ONE);
        if !n.is_finite() || n.max_element() > 65_536.0 {
            return Err(GridError::BadBounds);
        }
        Self::new(bounds, [n.x as u32, n.y as u32, n.z as u32])
    }

    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// The index of cell `c` (coordinates must be inside the grid).
    pub fn index(&self, c: [u32; 3]) -> u32 {
        debug_assert!(c[0] < self.dims[0] && c[1] < self.dims[1] && c[2] < self.dims[2]);
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    /// The coordinates of cell `index`.
    pub fn coords(&self, index: u32) -> [u32; 3] {
        let x = index % self.dims[0];
        let yz = index / self.dims[0];
        [x, yz % self.dims[1], yz / self.dims[1]]
    }

    /// The (unclamped, possibly outside the grid) cell coordinates of a point.
    pub fn cell_of(&self, p: Vec3) -> [i32; 3] {
        let t = ((p - self.origin) / self.cell_size).floor();
        [t.x as i32, t.y as i32, t.z as i32]
    }

    /// The world box of cell `index`.
    pub fn cell_bounds(&self, index: u32) -> Aabb {
        let [x, y, z] = self.coords(index);
        let min = self.origin + self.cell_size * Vec3::new(x as f32, y as f32, z as f32);
        Aabb::new(min, min + self.cell_size)
    }

    /// The world box of the whole grid.
    pub fn bounds(&self) -> Aabb {
        let n = Vec3::new(
            self.dims[0] as f32,
            self.dims[1] as f32,
            self.dims[2] as f32,
        );
        Aabb::new(self.origin, self.origin + self.cell_size * n)
    }

    /// The inclusive range of cells a box overlaps, clamped to the grid (objects outside the
    /// grid are kept in its border cells, so they are never lost).
    fn range(&self, aabb: &Aabb) -> ([u32; 3], [u32; 3]) {
        let lo = self.cell_of(aabb.min);
        let hi = self.cell_of(aabb.max);
        let clamp = |v: i32, k: usize| v.clamp(0, self.dims[k] as i32 - 1) as u32;
        (
            [clamp(lo[0], 0), clamp(lo[1], 1), clamp(lo[2], 2)],
            [clamp(hi[0], 0), clamp(hi[1], 1), clamp(hi[2], 2)],
        )
    }
}

#[derive(Clone, Debug)]
struct Slot {
    aabb: Aabb,
    lo: [u32; 3],
    hi: [u32; 3],
    present: bool,
}

/// A uniform grid of objects identified by `u32` ids (typically scene object indices).
#[derive(Clone, Debug)]
pub struct Grid {
    shape: GridShape,
    cells: Vec<Vec<u32>>,
    slots: Vec<Slot>,
    /// Per object, the pass in which it was last handed out (Seletsky's query counter).
    marks: Vec<u64>,
    pass: u64,
    len: usize,
}

impl Grid {
    /// An empty grid of the given shape.
    pub fn new(shape: GridShape) -> Self {
        Self {
            shape,
            cells: vec![Vec::new(); shape.cell_count()],
            slots: Vec::new(),
            marks: Vec::new(),
            pass: 0,
            len: 0,
        }
    }

    /// The grid's geometry.
    pub fn shape(&self) -> &GridShape {
        &self.shape
    }

    /// Number of objects in the grid.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when no object is in the grid.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Inserts object `id` with box `aabb`, or moves it there when it is already present.
    pub fn insert(&mut self, id: u32, aabb: Aabb) -> Result<(), GridError> {
        if aabb.is_empty() || !aabb.min.is_finite() || !aabb.max.is_finite() {
            return Err(GridError::BadBox(id));
        }
        let i = id as usize;
        if i >= self.slots.len() {
            self.slots.resize(
                i + 1,
                Slot {
                    aabb: Aabb::EMPTY,
                    lo: [0; 3],
                    hi: [0; 3],
                    present: false,
                },
            );
            self.marks.resize(i + 1, 0);
        }
        let (lo, hi) = self.shape.range(&aabb);
        if self.slots[i].present {
            if self.slots[i].lo == lo && self.slots[i].hi == hi {
                // Same cells: a move inside them costs nothing.
                self.slots[i].aabb = aabb;
                return Ok(());
            }
            self.unlink(id);
        } else {
            self.len += 1;
        }
        self.slots[i] = Slot {
            aabb,
            lo,
            hi,
            present: true,
        };
        for_cells(&self.shape, lo, hi, |c| self.cells[c as usize].push(id));
        Ok(())
    }

    /// Removes object `id`; returns false when it was not in the grid.
    pub fn remove(&mut self, id: u32) -> bool {
        if !self.slots.get(id as usize).is_some_and(|s| s.present) {
            return false;
        }
        self.unlink(id);
        self.slots[id as usize].present = false;
        self.len -= 1;
        true
    }

    /// The box of object `id`, if present.
    pub fn object_box(&self, id: u32) -> Option<Aabb> {
        self.slots
            .get(id as usize)
            .filter(|s| s.present)
            .map(|s| s.aabb)
    }

    /// The objects listed in cell `index` (an object spanning several cells is in each).
    pub fn objects_in(&self, index: u32) -> &[u32] {
        self.cells.get(index as usize).map_or(&[], |c| c.as_slice())
    }

    /// Starts a new pass: every object can be collected once more.
    pub fn begin_pass(&mut self) {
        self.pass += 1;
    }

    /// Appends to `out` the objects of cell `index` not yet collected in this pass.
    pub fn collect(&mut self, index: u32, out: &mut Vec<u32>) {
        let Some(cell) = self.cells.get(index as usize) else {
            return;
        };
        for &id in cell {
            let mark = &mut self.marks[id as usize];
            if *mark < self.pass {
                *mark = self.pass;
                out.push(id);
            }
        }
    }

    fn unlink(&mut self, id: u32) {
        let s = &self.slots[id as usize];
        let (lo, hi) = (s.lo, s.hi);
        let cells = &mut self.cells;
        for_cells(&self.shape, lo, hi, |c| {
            let list = &mut cells[c as usize];
            if let Some(k) = list.iter().position(|&o| o == id) {
                list.swap_remove(k);
            }
        });
    }
}

fn for_cells(shape: &GridShape, lo: [u32; 3], hi: [u32; 3], mut f: impl FnMut(u32)) {
    for z in lo[2]..=hi[2] {
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                f(shape.index([x, y, z]));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> Grid {
        let b = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        Grid::new(GridShape::new(&b, [10, 10, 10]).expect("shape"))
    }

    fn cube(min: Vec3, size: f32) -> Aabb {
        Aabb::new(min, min + Vec3::splat(size))
    }

    #[test]
    fn empty_grid_has_no_objects() {
        let g = grid();
        assert!(g.is_empty());
        assert!(g.objects_in(0).is_empty());
        assert!(g.objects_in(10_000).is_empty());
    }

    #[test]
    fn object_spanning_cells_is_listed_in_each_and_collected_once() {
        let mut g = grid();
        g.insert(3, cube(Vec3::splat(1.5), 1.0)).expect("insert");
        let s = *g.shape();
        let cells = [[1, 1, 1], [2, 2, 2], [1, 2, 1]];
        for c in cells {
            assert_eq!(g.objects_in(s.index(c)), &[3]);
        }
        g.begin_pass();
        let mut out = Vec::new();
        for c in cells {
            g.collect(s.index(c), &mut out);
        }
        assert_eq!(out, vec![3]);
        g.begin_pass();
        g.collect(s.index([2, 2, 2]), &mut out);
        assert_eq!(out, vec![3, 3]);
    }

    #[test]
    fn move_and_remove_update_cells() {
        let mut g = grid();
        let s = *g.shape();
        g.insert(0, cube(Vec3::splat(0.2), 0.5)).expect("insert");
        g.insert(0, cube(Vec3::splat(5.2), 0.5)).expect("move");
        assert!(g.objects_in(s.index([0, 0, 0])).is_empty());
        assert_eq!(g.objects_in(s.index([5, 5, 5])), &[0]);
        assert_eq!(g.len(), 1);
        assert!(g.remove(0));
        assert!(!g.remove(0));
        assert!(g.objects_in(s.index([5, 5, 5])).is_empty());
        assert!(g.is_empty());
    }

    #[test]
    fn objects_outside_are_clamped_into_border_cells() {
        let mut g = grid();
        g.insert(1, cube(Vec3::new(-5.0, 4.2, 20.0), 0.5))
            .expect("insert");
        assert_eq!(g.objects_in(g.shape().index([0, 4, 9])), &[1]);
    }

    #[test]
    fn bad_boxes_and_shapes_are_errors() {
        let mut g = grid();
        let nan = Aabb::new(Vec3::NAN, Vec3::ONE);
        assert_eq!(g.insert(2, nan), Err(GridError::BadBox(2)));
        assert_eq!(g.insert(2, Aabb::EMPTY), Err(GridError::BadBox(2)));
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(
            GridShape::new(&b, [0, 1, 1]),
            Err(GridError::BadDims([0, 1, 1]))
        );
        assert_eq!(
            GridShape::new(&Aabb::EMPTY, [1, 1, 1]),
            Err(GridError::BadBounds)
        );
    }

    #[test]
    fn shape_index_and_coords_round_trip() {
        let b = Aabb::new(Vec3::ZERO, Vec3::new(4.0, 6.0, 2.0));
        let s = GridShape::with_cell_size(&b, Vec3::splat(2.0)).expect("shape");
        assert_eq!(s.dims, [2, 3, 1]);
        for i in 0..s.cell_count() as u32 {
            assert_eq!(s.index(s.coords(i)), i);
        }
        assert_eq!(
            s.cell_bounds(s.index([1, 2, 0])).min,
            Vec3::new(2.0, 4.0, 0.0)
        );
    }
}
