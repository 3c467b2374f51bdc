//! The free space of a view cell in a mesh scene: a voxel grid over the cell whose voxels lie
//! entirely inside closed geometry are closed to ray origins.
//!
//! Ours (issue 18), not from the papers: GVS, GVS++ and RAND draw ray origins anywhere on or in
//! their cell, which in a game level or a city model often reaches into walls, floors and the
//! sealed insides of buildings. Rays from there see the back of the geometry around them and
//! add triangles that no camera can see (the PVS grows, never shrinks: the error it causes is
//! culling too little). Quake 3 maps answer "is this point in free space" from their BSP
//! (`cell_sources::q3_cells`); meshes have no BSP, so a point is solid when most axis rays from it
//! hit the back of a triangle ([`inside_solid`], the same test `eval` uses for viewpoints).
//!
//! Testing every origin would cost six rays per ray; instead each cell is divided into
//! [`RESOLUTION`]³ voxels once, and a voxel is closed only when its centre and its eight
//! corners are all solid. Erring towards open keeps origins near walls, where players stand, and
//! closes the inside of thick walls and sealed rooms: a voxel is at worst half open and its
//! origins then include some from inside the wall (as before), never fewer free origins than a
//! player could use, except where a whole voxel's nine test points are solid but a thin free gap
//! runs between them (narrower than a voxel, well below head height for room-sized cells).
//! Cost: ((R+1)³ + R³) × 6 rays per cell (7,446 at R = 8), and R³ bits.

use std::sync::OnceLock;

use fixedbitset::FixedBitSet;
use glam::Vec3;
use rayon::prelude::*;
use sightline_core::trace::RayCaster;
use sightline_core::Scene;

use crate::cell_sources::inside_solid;
use crate::viewcell::ViewCell;

/// Voxels per cell axis (a flat cell has one voxel across its flat axis).
pub const RESOLUTION: u32 = 8;

/// Which parts of one view cell are open to ray origins.
#[derive(Clone, Debug)]
pub struct CellOccupancy {
    center: Vec3,
    axes: [Vec3; 3],
    half_extents: Vec3,
    /// Voxels per axis.
    dims: [u32; 3],
    /// Closed voxels, x fastest.
    closed: FixedBitSet,
    /// No voxel is closed: every origin is allowed without a look-up (most cells; the test
    /// runs for every ray origin, a sixth of a bake's time when it looked each one up).
    all_open: bool,
}

impl CellOccupancy {
    /// Tests `cell`'s voxels against `scene` (`caster` built over it).
    pub fn of(scene: &Scene, caster: &dyn RayCaster, cell: &ViewCell) -> Self {
        let h = cell.half_extents;
        let dims: [u32; 3] = std::array::from_fn(|i| if h[i] > 0.0 { RESOLUTION } else { 1 });
        // Solidity at the (d+1)³ voxel corners and the d³ centres, in the unit cube's
        // coordinates.
        let corner_dims = dims.map(|d| d + 1);
        let corner_at = |i: u32, d: u32| if d == 1 { 0.5 } else { i as f32 / d as f32 };
        let corner_count = (corner_dims[0] * corner_dims[1] * corner_dims[2]) as usize;
        let corner_solid: Vec<bool> = (0..corner_count)
            .into_par_iter()
            .map(|k| {
                let [x, y, z] = unflatten(k, corner_dims);
                let s = [
                    corner_at(x, dims[0]),
                    corner_at(y, dims[1]),
                    corner_at(z, dims[2]),
                ];
                inside_solid(scene, caster, cell.interior_point(s))
            })
            .collect();
        let voxel_count = (dims[0] * dims[1] * dims[2]) as usize;
        let closed_flags: Vec<bool> = (0..voxel_count)
            .into_par_iter()
            .map(|k| {
                let [x, y, z] = unflatten(k, dims);
                let corners_solid = (0..8u32).all(|c| {
                    let at = [x + (c & 1), y + ((c >> 1) & 1), z + ((c >> 2) & 1)];
                    corner_solid[flatten(at, corner_dims)]
                });
                corners_solid && {
                    let centre = [x, y, z].map(|i| i as f32 + 0.5);
                    let s = std::array::from_fn(|i| centre[i] / dims[i] as f32);
                    inside_solid(scene, caster, cell.interior_point(s))
                }
            })
            .collect();
        let mut closed = FixedBitSet::with_capacity(voxel_count);
        for (k, &c) in closed_flags.iter().enumerate() {
            closed.set(k, c);
        }
        Self {
            center: cell.center,
            axes: cell.axes,
            half_extents: h,
            dims,
            all_open: closed.is_clear(),
            closed,
        }
    }

    /// True when `p` (on or in the cell) may serve as a ray origin: its voxel is open. Points
    /// outside the cell count as in the nearest voxel.
    pub fn allows(&self, p: Vec3) -> bool {
        if self.all_open {
            return true;
        }
        let d = p - self.center;
        let at: [u32; 3] = std::array::from_fn(|i| {
            let n = self.dims[i];
            if n == 1 {
                return 0;
            }
            let s = (d.dot(self.axes[i]) / self.half_extents[i] + 1.0) * 0.5;
            // The voxel's index: the floor of `s * n`, which for what is left after `max(0)`
            // is the truncation `as` does (NaN goes to 0 either way); no call to `floorf`.
            ((s * n as f32).max(0.0) as u32).min(n - 1)
        });
        !self.closed.contains(flatten(at, self.dims))
    }

    /// Closed voxels over all voxels (0: the whole cell is open, 1: none of it is).
    pub fn closed_fraction(&self) -> f64 {
        self.closed.count_ones(..) as f64 / self.closed.len().max(1) as f64
    }

    /// True when every voxel is closed: the cell lies inside solid geometry.
    pub fn is_all_closed(&self) -> bool {
        self.closed.count_ones(..) == self.closed.len()
    }
}

/// The occupancy grids of a bake's cells, each tested on first use (so a shard or an
/// incremental rebake tests only the cells it samples).
pub struct BakeOccupancy<'a> {
    scene: &'a Scene,
    caster: &'a dyn RayCaster,
    cells: &'a [ViewCell],
    grids: Vec<OnceLock<CellOccupancy>>,
}

/// How much of a bake's tested cells lies inside closed geometry.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct OccupancySummary {
    /// Cells whose grid was tested.
    pub tested: usize,
    /// Cells with some closed voxels (their origins there were skipped).
    pub partly_closed: usize,
    /// Indices of the cells whose voxels are all closed: no origin at all, an empty PVS.
    pub all_closed: Vec<usize>,
}

impl<'a> BakeOccupancy<'a> {
    /// Grids for `cells` of `scene` (`caster` built over it), none tested yet.
    pub fn new(scene: &'a Scene, caster: &'a dyn RayCaster, cells: &'a [ViewCell]) -> Self {
        Self {
            scene,
            caster,
            cells,
            grids: cells.iter().map(|_| OnceLock::new()).collect(),
        }
    }

    /// True when `p` may serve as a ray origin of cell `cell` ([`CellOccupancy::allows`]).
    ///
    /// The first call for a cell tests its voxels, in parallel, under the cell's `OnceLock`.
    /// Make that first call outside any parallel work that also asks about the cell (the bake
    /// drivers do, with `bake::touch_free_space`): a thread waiting for the test's parallel
    /// work may run such a task, which then waits on the lock the thread holds.
    pub fn allows(&self, cell: usize, p: Vec3) -> bool {
        self.grids[cell]
            .get_or_init(|| CellOccupancy::of(self.scene, self.caster, &self.cells[cell]))
            .allows(p)
    }

    /// The tested cells' counts.
    pub fn summary(&self) -> OccupancySummary {
        let mut s = OccupancySummary::default();
        for (i, grid) in self.grids.iter().enumerate() {
            let Some(grid) = grid.get() else { continue };
            s.tested += 1;
            if grid.is_all_closed() {
                s.all_closed.push(i);
            } else if grid.closed_fraction() > 0.0 {
                s.partly_closed += 1;
            }
        }
        s
    }
}

/// The fingerprint's part about plain (not Quake 3) cells, which the CLI's and the Python
/// bindings' bakes share: `{"clusters": null}`, with `"origins": "open voxels"` when origins
/// keep to the cells' open voxels (so a checkpoint or an incremental rebake never mixes sets
/// sampled under the two rules).
pub fn plain_cells_key(open_voxels: bool) -> serde_json::Value {
    if open_voxels {
        serde_json::json!({ "clusters": null, "origins": "open voxels" })
    } else {
        serde_json::json!({ "clusters": null })
    }
}

fn flatten(at: [u32; 3], dims: [u32; 3]) -> usize {
    (at[0] + dims[0] * (at[1] + dims[1] * at[2])) as usize
}

fn unflatten(k: usize, dims: [u32; 3]) -> [u32; 3] {
    let k = k as u32;
    [
        k % dims[0],
        (k / dims[0]) % dims[1],
        k / (dims[0] * dims[1]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;
    use sightline_core::trace::Bvh;

    fn scene_with_block() -> Scene {
        let mut b = SceneBuilder::new("block");
        // A solid block filling x in [0.5, 10] (and far beyond the cells in y and z), wound
        // with outward normals.
        b.add_box(Vec3::new(0.5, -50.0, -50.0), Vec3::new(10.0, 50.0, 50.0));
        b.finish()
    }

    #[test]
    fn outward_box_winding_makes_its_inside_solid() {
        let scene = scene_with_block();
        let bvh = Bvh::build(&scene);
        assert!(inside_solid(&scene, &bvh, Vec3::new(5.0, 0.0, 0.0)));
        assert!(!inside_solid(&scene, &bvh, Vec3::new(-5.0, 0.0, 0.0)));
    }

    #[test]
    fn voxels_inside_the_block_are_closed_and_the_rest_open() {
        let scene = scene_with_block();
        let bvh = Bvh::build(&scene);
        // The cell spans x in [-4, 4] in voxels 1 wide: those from x = 1 on lie in the block.
        let cell = ViewCell::aabb(Vec3::new(-4.0, -1.0, -1.0), Vec3::new(4.0, 1.0, 1.0)).unwrap();
        let occ = CellOccupancy::of(&scene, &bvh, &cell);
        assert!(occ.allows(Vec3::new(-3.0, 0.0, 0.0)));
        assert!(occ.allows(Vec3::new(-0.2, 0.3, -0.9)));
        assert!(!occ.allows(Vec3::new(3.0, 0.0, 0.0)));
        assert!(!occ.allows(Vec3::new(1.6, -0.9, 0.9)));
        // The voxel [0, 1) straddles the block's face at x = 0.5: half open, it stays open,
        // also at its points inside the block.
        assert!(occ.allows(Vec3::new(0.8, 0.0, 0.0)));
        // Surface points map to the voxels they bound.
        assert!(!occ.allows(Vec3::new(4.0, 1.0, 1.0)));
        assert!(occ.allows(Vec3::new(-4.0, -1.0, -1.0)));
        let f = occ.closed_fraction();
        assert_eq!(f, 3.0 / 8.0, "closed fraction");
        assert!(!occ.is_all_closed());
    }

    #[test]
    fn a_cell_inside_the_block_is_all_closed_and_a_free_one_all_open() {
        let scene = scene_with_block();
        let bvh = Bvh::build(&scene);
        let inside = ViewCell::aabb(Vec3::new(2.0, -1.0, -1.0), Vec3::new(8.0, 1.0, 1.0)).unwrap();
        assert!(CellOccupancy::of(&scene, &bvh, &inside).is_all_closed());
        let free = ViewCell::aabb(Vec3::new(-8.0, -1.0, -1.0), Vec3::new(-2.0, 1.0, 1.0)).unwrap();
        let occ = CellOccupancy::of(&scene, &bvh, &free);
        assert_eq!(occ.closed_fraction(), 0.0);
        // A bake's grids: tested on first use, summarised per cell.
        let half = ViewCell::aabb(Vec3::new(-4.0, -1.0, -1.0), Vec3::new(4.0, 1.0, 1.0)).unwrap();
        let cells = [inside, free, half];
        let bake = BakeOccupancy::new(&scene, &bvh, &cells);
        assert_eq!(bake.summary(), OccupancySummary::default());
        assert!(!bake.allows(0, Vec3::new(5.0, 0.0, 0.0)));
        assert!(bake.allows(1, Vec3::new(-5.0, 0.0, 0.0)));
        assert!(bake.allows(2, Vec3::new(-3.0, 0.0, 0.0)));
        let summary = bake.summary();
        assert_eq!(summary.tested, 3);
        assert_eq!(summary.partly_closed, 1);
        assert_eq!(summary.all_closed, vec![0]);
    }

    #[test]
    fn a_flat_cell_has_one_voxel_across_its_flat_axis() {
        let scene = scene_with_block();
        let bvh = Bvh::build(&scene);
        let flat = ViewCell::aabb(Vec3::new(-4.0, 0.0, -1.0), Vec3::new(4.0, 0.0, 1.0)).unwrap();
        let occ = CellOccupancy::of(&scene, &bvh, &flat);
        assert_eq!(occ.dims, [RESOLUTION, 1, RESOLUTION]);
        assert!(occ.allows(Vec3::new(-3.0, 0.0, 0.0)));
        assert!(!occ.allows(Vec3::new(3.0, 0.0, 0.0)));
    }
}
