//! The world of one simulated frame, shared by every method: the objects in the uniform grid
//! at their current positions, their boxes and triangle corners, and the box a cell's query
//! tests (Seletsky 2013, section 4.3.2).

use glam::Vec3;
use sightline_core::{Aabb, Scene};

use crate::grid::{Grid, GridError, GridShape};
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

/// What moving the objects needs across frames: each object's triangles and box at time 0,
/// the object of every vertex, each object's current offset, and the scene with the objects
/// at their current positions (which the ground truth renders). Kept apart from [`World`] so
/// that the methods see only the current frame.
pub(crate) struct MovingObjects {
    /// Per object: its triangles.
    tris_of: Vec<Vec<u32>>,
    /// Per object: its box at time 0 (empty for an object without triangles).
    base_box: Vec<Aabb>,
    /// Per vertex: its object (`u32::MAX` for a vertex of no triangle).
    object_of_vertex: Vec<u32>,
    /// Per object: its offset at the current time.
    offsets: Vec<Vec3>,
    /// The scene with every object at its current position.
    pub(crate) moved: Scene,
}

impl MovingObjects {
    /// The objects of `scene` at time 0, and the world holding them in a grid of `shape`
    /// (no corners yet: [`MovingObjects::advance`] gathers them each frame).
    pub(crate) fn start(
        scene: &CullScene,
        shape: GridShape,
    ) -> Result<(Self, World<'_>), GridError> {
        let base = &scene.scene;
        let n_obj = base.objects.len();
        // Per object: its triangles and its box at time 0.
        let tris_of = base.triangles_by_object();
        let base_box: Vec<Aabb> = tris_of
            .iter()
            .map(|ts| Aabb::from_points(ts.iter().flat_map(|&t| base.triangle(t))))
            .collect();
        let mut object_of_vertex = vec![u32::MAX; base.positions.len()];
        for (t, tri) in base.triangles.iter().enumerate() {
            for &v in tri {
                if let Some(o) = object_of_vertex.get_mut(v as usize) {
                    *o = base.object_of_triangle[t];
                }
            }
        }
        let moving = MovingObjects {
            tris_of,
            object_of_vertex,
            offsets: vec![Vec3::ZERO; n_obj],
            moved: base.clone(),
            base_box,
        };
        let mut world = World {
            scene,
            shape,
            grid: Grid::new(shape),
            boxes: moving.base_box.clone(),
            corners: Vec::new(),
            ranges: vec![(0, 0); n_obj],
        };
        for (o, b) in moving.base_box.iter().enumerate() {
            if !b.is_empty() {
                world.grid.insert(o as u32, *b)?;
            }
        }
        Ok((moving, world))
    }

    /// Moves the objects to time `t` (vertices, boxes and grid entries), then gathers their
    /// corners into `world`: the application's data, outside the timed culling.
    pub(crate) fn advance(&mut self, world: &mut World<'_>, t: f32) -> Result<(), GridError> {
        let scene = world.scene;
        for (o, m) in scene.motion.iter().enumerate() {
            if let Some(m) = m {
                self.offsets[o] = m.offset(t);
                let base_box = self.base_box[o];
                if !base_box.is_empty() {
                    let b = Aabb::new(
                        base_box.min + self.offsets[o],
                        base_box.max + self.offsets[o],
                    );
                    world.boxes[o] = b;
                    world.grid.insert(o as u32, b)?;
                }
            }
        }
        for (v, p) in self.moved.positions.iter_mut().enumerate() {
            let o = self.object_of_vertex[v];
            if let Some(off) = self.offsets.get(o as usize) {
                *p = scene.scene.positions[v] + *off;
            }
        }
        world.corners.clear();
        for (o, tris) in self.tris_of.iter().enumerate() {
            let a = world.corners.len();
            for &tri in tris {
                world.corners.extend_from_slice(&self.moved.triangle(tri));
            }
            world.ranges[o] = (a, world.corners.len());
        }
        Ok(())
    }
}
