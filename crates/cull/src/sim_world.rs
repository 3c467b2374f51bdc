//! The world of one simulated frame, shared by every method: the objects in the uniform grid
//! at their current positions, their boxes and triangle corners, and the box a cell's query
//! tests (Seletsky 2013, section 4.3.2).

use glam::Vec3;
use sightline_core::Aabb;

use crate::grid::{Grid, GridShape};
use crate::scenes::CullScene;

/// The world shared by the methods in one frame: objects in the grid, their current boxes
/// and triangle corners.
pub(crate) struct World<'a> {
    pub(crate) scene: &'a CullScene,
    pub(crate) shape: GridShape,
    pub(crate) grid: Grid,
    pub(crate) boxes: Vec<Aabb>,
    /// Corners of every object's triangles at the current positions, object after object.
    pub(crate) corners: Vec<Vec3>,
    /// Per object, its range in `corners`.
    pub(crate) ranges: Vec<(usize, usize)>,
}

impl World<'_> {
    pub(crate) fn corners_of(&self, o: u32) -> &[Vec3] {
        let (a, b) = self.ranges[o as usize];
        &self.corners[a..b]
    }

    /// The objects of the frustum's cells in traversal order (each once) into `out`, and the
    /// number of non-empty cells.
    pub(crate) fn frustum_objects(&mut self, cells: &[u32], out: &mut Vec<u32>) -> u32 {
        self.grid.begin_pass();
        let mut nonempty = 0;
        for &cell in cells {
            if !self.grid.objects_in(cell).is_empty() {
                nonempty += 1;
                self.grid.collect(cell, out);
            }
        }
        nonempty
    }

    /// The box a cell's query tests: the union of its objects' boxes clipped to the cell
    /// (objects clamped into a border cell from outside keep their own box), or the cell's
    /// box when `tight` is off. Any visible point of an object listed in the cell lies in it.
    pub(crate) fn query_box(&self, cell: u32, tight: bool) -> Aabb {
        let bounds = self.shape.cell_bounds(cell);
        if !tight {
            return bounds;
        }
        let mut q = Aabb::EMPTY;
        for &o in self.grid.objects_in(cell) {
            let b = self.boxes[o as usize];
            let clipped = Aabb::new(b.min.max(bounds.min), b.max.min(bounds.max));
            q = q.union(if clipped.is_empty() { &b } else { &clipped });
        }
        if q.is_empty() {
            bounds
        } else {
            q
        }
    }
}
