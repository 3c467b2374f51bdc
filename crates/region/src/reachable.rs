//! Reachable space of a Quake 3 map: the free space connected to the map's spawn points, as a
//! flood fill over a voxel lattice, with a point query and the BSP leaves it touches.
//!
//! This is not part of the GVS++ paper (Koch, Wimmer 2021), which samples ray origins in the
//! whole view cell. It is an engineering addition answering issue 24: Quake 3 leaf and cluster
//! cells also cover pockets no player can ever be in — the inside of detail brushes (they do
//! not split the BSP, so their inside lies in non-solid leaves), the space behind curved
//! patches, sealed voids — and origins there see what no player sees, which inflates the PVSs
//! and makes the comparison with q3map2's PVS mostly noise on maps with many patches.
//!
//! # The algorithm
//!
//! * **Lattice.** Points `origin + step * (i, j, k)` over the map's bounds (grown by a step).
//!   The default step, [`DEFAULT_STEP`] = 16 units, is half the width of a player's box
//!   (32 x 32 x 56), so every place a player fits holds lattice points, at least two across
//!   each way. The lattice is shifted off the integer grid by a fraction of a step
//!   ([`SHIFT_FRACTION`]) so that lattice points do not lie on the axis-aligned integer planes
//!   that nearly every brush face of a map lies on (a point on a face is on both sides of it).
//! * **Free points.** A lattice point is free when its BSP leaf has a cluster
//!   (`BspData::cluster_at`), i.e. it is not in structural solid. Evaluated lazily, when the
//!   fill reaches a neighbour: the descent is cheaper than storing a bit per point.
//! * **Fill.** A breadth-first fill from the spawn points (`BspData::spawn_points`; a spawn in
//!   solid is lifted by 9 units first, as the game does) through the 6 neighbours of each
//!   reached point, when the neighbour is free and the segment between the two hits no
//!   blocking triangle (the scene's own geometry: detail brushes and patches block, although
//!   they are not in the BSP's solid leaves). A spawn seeds the free corners of its lattice
//!   cell that it sees by a clear segment. The fill is level-synchronous: each level's edges
//!   are tested in parallel (rayon) against the reached set as it was when the level began,
//!   and each edge always from its lower lattice point, so the result (and the number of tests)
//!   does not depend on the thread count.
//! * **Point query** ([`ReachableSpace::is_reachable`]): `p` is reachable when it is in a
//!   cluster and some reached corner of its lattice cell has a clear segment to `p`.
//! * **Leaves** ([`ReachableSpace::leaf_reachable`]): a leaf is reachable when a reachable
//!   point lies in it: the leaf of every reached lattice point, and, for the leaves with none
//!   (small leaves hold no lattice point), the centre and 64 Halton points of the leaf's box
//!   that lie in the leaf, asked with the point query.
//!
//! **Segment tests without ray casts.** Every segment the algorithm tests lies in one closed
//! lattice cell (a fill edge, a spawn or query point and a corner of its cell), and only the
//! triangles touching that cell can meet it. So the blocking triangles of each cell are listed
//! once (a separating-axis triangle-box test, with a margin of a thousandth of a step), and a
//! segment is tested against its cell's few triangles (Möller-Trumbore). A cell with no
//! triangle is convex and empty: its segments are clear without a test, and that holds for
//! most fill edges and queries in open rooms. A first version cast each segment through the
//! scene's BVH. The origin rule runs for every candidate ray origin of a bake, and there one
//! BVH cast costs far more than the handful of triangle tests (measured in docs/BENCHMARKS.md).
//!
//! **Blocking triangles** are all triangles except those of brush models 1.. (doors, lifts,
//! platforms: the map holds them at one position, but they move) and liquid or fog surfaces
//! (players swim through water). Player-clip brushes are not drawn, so they are not in the
//! scene and do not block: the space is a slight over-estimate there.
//!
//! **No gravity.** The space is the free space connected to the spawns, not where a walking
//! player can stand: players jump, rocket-jump, are pushed by jump pads and fly as spectators,
//! and a PVS must hold for all of them.
//!
//! # Memory and time
//!
//! Kept for queries: two bits per lattice point (reached; cell touched by a triangle), half a
//! bit more for the touched cells' running count, 4 bytes per touched cell (its row) and per
//! (cell, triangle) pair, and a bit per leaf. While building, the (cell, triangle) pairs are
//! sorted at 8 bytes each, and the fill holds the current and next level as lists of 4-byte
//! indices (a shell of the fill, far smaller than the lattice). The lattice is capped at
//! [`MAX_VOXELS`] = 2^28 points. Measured on the shared maps (2 cores, release
//! build) in docs/BENCHMARKS.md, "Quake 3 cells: origins in reachable space": 0.08-0.82 s per map
//! at the default step, 0.6-5.1 MiB.

use std::time::Instant;

use fixedbitset::FixedBitSet;
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use sightline_core::sampling::ShiftedHalton;
use sightline_core::scene::q3::{BspData, SurfaceFlags};
use sightline_core::Scene;

/// Default lattice step in map units: half a player's width (a player box is 32 x 32 x 56).
pub const DEFAULT_STEP: f32 = 16.0;

/// The most lattice points a reachable space may have (2^28: 32 MiB per bit plane).
pub const MAX_VOXELS: u64 = 1 << 28;

/// Shift of the lattice off the integer grid, as a fraction of the step (0.37 units at the
/// default step): brush faces lie on integer planes, lattice points should not.
pub const SHIFT_FRACTION: f32 = 0.0231;

/// Version of the algorithm, recorded with the parameters: a change that can change the
/// answer must bump it, so that checkpoints of older bakes are not resumed.
pub const VERSION: u32 = 1;

/// How high a spawn point in solid is lifted (the game spawns players 9 units above the
/// spawn entity's origin).
const SPAWN_LIFT: f32 = 9.0;

/// Points of a leaf's box tried when no reached lattice point lies in the leaf.
const LEAF_SAMPLES: u64 = 64;

/// Parameters of a reachable space.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ReachParams {
    /// Lattice step in map units.
    pub step: f32,
}

impl Default for ReachParams {
    fn default() -> Self {
        Self { step: DEFAULT_STEP }
    }
}

/// Why a reachable space could not be built.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReachError {
    /// The step is not a positive finite number.
    #[error("reach step {step}: must be a positive, finite number of map units")]
    BadStep {
        /// The step given.
        step: f32,
    },
    /// The lattice would be too large.
    #[error(
        "reach step {step}: a lattice over the map would have {voxels} points, more than the \
         cap of {max} (2^28); use a larger step"
    )]
    TooManyVoxels {
        /// The step given.
        step: f32,
        /// Lattice points it would take.
        voxels: f64,
        /// The cap, [`MAX_VOXELS`].
        max: u64,
    },
    /// The scene has no BSP data.
    #[error("reachable space needs a Quake 3 map (.bsp): the scene has no BSP data")]
    NoBsp,
    /// The map has no spawn points to fill from.
    #[error("the map has no spawn points to find the reachable space from")]
    NoSpawnPoints,
}

/// What building a reachable space found and cost.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReachStats {
    /// Lattice step.
    pub step: f32,
    /// Lattice points per axis.
    pub lattice: [u32; 3],
    /// Lattice points in all.
    pub voxels: u64,
    /// Lattice points reached from the spawns.
    pub reached_voxels: u64,
    /// Spawn points of the map.
    pub spawn_points: usize,
    /// Spawn points that seeded the fill (the others are in solid or boxed in).
    pub seeded_spawn_points: usize,
    /// Leaves with a cluster.
    pub leaves: usize,
    /// Of those, the reachable ones.
    pub reachable_leaves: usize,
    /// Segments tested against the triangles of their lattice cell to build it (fill edges
    /// in touched cells, spawn seeds, leaf samples); edges in untouched cells need no test.
    pub segment_tests: u64,
    /// Bytes of the bit planes kept for queries.
    pub memory_bytes: u64,
    /// Wall-clock seconds to build it.
    pub seconds: f64,
}

/// The lattice: points `origin + step * (i, j, k)`, `i < n[0]` etc., x fastest.
#[derive(Clone, Copy, Debug)]
struct Lattice {
    origin: Vec3,
    step: f32,
    n: [u32; 3],
}

impl Lattice {
    fn len(&self) -> usize {
        self.n.iter().map(|&n| n as usize).product()
    }

    fn index(&self, c: [u32; 3]) -> u32 {
        c[0] + self.n[0] * (c[1] + self.n[1] * c[2])
    }

    fn coords(&self, i: u32) -> [u32; 3] {
        let (nx, ny) = (self.n[0], self.n[1]);
        [i % nx, (i / nx) % ny, i / (nx * ny)]
    }

    fn point(&self, c: [u32; 3]) -> Vec3 {
        self.origin + self.step * Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)
    }

    /// The lower corner of the lattice cell holding `p` (`None` outside the lattice).
    fn cell_of(&self, p: Vec3) -> Option<[u32; 3]> {
        let q = (p - self.origin) / self.step;
        let mut c = [0u32; 3];
        for k in 0..3 {
            let f = q[k].floor();
            if !(f >= 0.0 && f + 1.0 < self.n[k] as f32) {
                return None;
            }
            c[k] = f as u32;
        }
        Some(c)
    }

    /// Lower corners of the cells overlapping the box `[lo, hi]`, clamped to the lattice, as
    /// inclusive ranges per axis (`None` when it misses the lattice).
    fn cells_in(&self, lo: Vec3, hi: Vec3) -> Option<[(u32, u32); 3]> {
        let (a, b) = (
            (lo - self.origin) / self.step,
            (hi - self.origin) / self.step,
        );
        let mut r = [(0u32, 0u32); 3];
        for k in 0..3 {
            let last = self.n[k].saturating_sub(2) as f32;
            let (from, to) = (a[k].floor().max(0.0), b[k].floor().min(last));
            // NaN (a box at infinity) compares false and misses too.
            if from.partial_cmp(&to).is_none_or(|o| o.is_gt()) {
                return None;
            }
            r[k] = (from as u32, to as u32);
        }
        Some(r)
    }
}

/// The blocking triangles touching each lattice cell, in compressed rows: a bit per cell, a
/// running count per 64 cells to find a touched cell's row in O(1), and the rows' triangle ids.
struct CellTriangles {
    /// Bit `i` of word `i / 64`: a blocking triangle touches cell `i` (by its lower corner).
    words: Vec<u64>,
    /// Touched cells before word `w`.
    rank: Vec<u32>,
    /// Row starts into `triangles`, one per touched cell and one past the end.
    starts: Vec<u32>,
    /// Triangle ids, row by row.
    triangles: Vec<u32>,
}

impl CellTriangles {
    /// The triangles touching `cell`, or `None` when none does.
    fn of(&self, cell: u32) -> Option<&[u32]> {
        let (w, b) = (cell as usize / 64, cell % 64);
        let word = *self.words.get(w)?;
        if word & (1 << b) == 0 {
            return None;
        }
        let row = self.rank[w] as usize + (word & ((1u64 << b) - 1)).count_ones() as usize;
        let (from, to) = (self.starts[row] as usize, self.starts[row + 1] as usize);
        Some(&self.triangles[from..to])
    }

    fn memory_bytes(&self) -> usize {
        8 * self.words.len() + 4 * (self.rank.len() + self.starts.len() + self.triangles.len())
    }
}

/// The space reachable from a Quake 3 map's spawn points (see the module docs). Borrows the
/// map for the point queries.
pub struct ReachableSpace<'a> {
    scene: &'a Scene,
    bsp: &'a BspData,
    lattice: Lattice,
    /// Per lattice point: reached from a spawn.
    reached: FixedBitSet,
    /// Per lattice cell: the blocking triangles that touch it.
    cells: CellTriangles,
    /// Per BSP leaf: reachable.
    leaves: FixedBitSet,
    stats: ReachStats,
}

impl std::fmt::Debug for ReachableSpace<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReachableSpace")
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl<'a> ReachableSpace<'a> {
    /// Floods the free space of `scene`'s map from its spawn points. Errors: no BSP data, no
    /// spawn points, a bad step or a lattice over [`MAX_VOXELS`] points.
    pub fn build(scene: &'a Scene, params: &ReachParams) -> Result<Self, ReachError> {
        let start = Instant::now();
        let step = params.step;
        if !(step.is_finite() && step > 0.0) {
            return Err(ReachError::BadStep { step });
        }
        let bsp = scene.bsp.as_deref().ok_or(ReachError::NoBsp)?;
        if bsp.spawn_points.is_empty() {
            return Err(ReachError::NoSpawnPoints);
        }
        let mut bounds = scene.bounds();
        for &s in &bsp.spawn_points {
            bounds.grow(s);
        }
        // One step of margin all round, so that spawns and walls never sit on the last cell.
        let origin = bounds.min - Vec3::splat(step * (1.0 - SHIFT_FRACTION));
        let span = (bounds.max + Vec3::splat(step) - origin) / step;
        let counts = span.to_array().map(|s| f64::from(s.ceil()) + 1.0);
        let voxels = counts.iter().product::<f64>();
        // NaN (an unbounded map) is refused too.
        if voxels.is_nan() || voxels > MAX_VOXELS as f64 {
            return Err(ReachError::TooManyVoxels {
                step,
                voxels,
                max: MAX_VOXELS,
            });
        }
        let lattice = Lattice {
            origin,
            step,
            n: counts.map(|c| c.max(2.0) as u32),
        };
        let cells = cell_triangles(scene, &lattice, &blocking_triangles(scene, bsp));
        let mut space = Self {
            scene,
            bsp,
            lattice,
            reached: FixedBitSet::with_capacity(lattice.len()),
            cells,
            leaves: FixedBitSet::with_capacity(bsp.leaves.len()),
            stats: ReachStats {
                step,
                lattice: lattice.n,
                voxels: lattice.len() as u64,
                reached_voxels: 0,
                spawn_points: bsp.spawn_points.len(),
                seeded_spawn_points: 0,
                leaves: bsp.leaves.iter().filter(|l| l.cluster >= 0).count(),
                reachable_leaves: 0,
                segment_tests: 0,
                memory_bytes: 0,
                seconds: 0.0,
            },
        };
        let seed_tests = space.seed();
        let fill_tests = space.fill();
        let leaf_tests = space.find_leaves();
        let s = &mut space.stats;
        s.segment_tests = seed_tests + fill_tests + leaf_tests;
        s.reached_voxels = space.reached.count_ones(..) as u64;
        s.reachable_leaves = space.leaves.count_ones(..);
        s.memory_bytes = (space.lattice.len().div_ceil(8)
            + space.cells.memory_bytes()
            + space.leaves.len() / 8) as u64;
        s.seconds = start.elapsed().as_secs_f64();
        Ok(space)
    }

    /// What building it found and cost.
    pub fn stats(&self) -> &ReachStats {
        &self.stats
    }

    /// True when a player can be at `p`: it is in a cluster and some reached corner of its
    /// lattice cell sees it by a clear segment.
    pub fn is_reachable(&self, p: Vec3) -> bool {
        p.is_finite() && self.bsp.cluster_at(p).is_some() && self.reachable_free_point(p, &mut 0)
    }

    /// [`ReachableSpace::is_reachable`] for a point already known to be in a cluster (the
    /// origin rule of Quake 3 cells tests the cluster first): saves the second BSP descent.
    pub fn is_reachable_in_cluster(&self, p: Vec3) -> bool {
        p.is_finite() && self.reachable_free_point(p, &mut 0)
    }

    /// True when leaf `leaf` (an index of `BspData::leaves`) holds a reachable point.
    pub fn leaf_reachable(&self, leaf: usize) -> bool {
        self.leaves.contains(leaf)
    }

    /// True when some leaf of cluster `cluster` is reachable.
    pub fn cluster_reachable(&self, cluster: u32) -> bool {
        self.leaves.ones().any(|l| {
            self.bsp
                .leaves
                .get(l)
                .is_some_and(|l| l.cluster == cluster as i32)
        })
    }

    /// The point query for a point in a cluster, counting its segment tests into `tests`.
    fn reachable_free_point(&self, p: Vec3, tests: &mut u64) -> bool {
        let Some(c) = self.lattice.cell_of(p) else {
            return false;
        };
        // The reached corners (at most 8: kept on the stack, this runs for every ray origin).
        let mut corners = [(0.0f32, [0u32; 3]); 8];
        let mut k = 0;
        for bits in 0..8u32 {
            let q = [
                c[0] + (bits & 1),
                c[1] + ((bits >> 1) & 1),
                c[2] + (bits >> 2),
            ];
            if self.reached.contains(self.lattice.index(q) as usize) {
                corners[k] = (self.lattice.point(q).distance_squared(p), q);
                k += 1;
            }
        }
        if k == 0 {
            return false;
        }
        // An untouched cell is convex and holds no blocking triangle: every segment in it is
        // clear.
        let Some(triangles) = self.cells.of(self.lattice.index(c)) else {
            return true;
        };
        // Nearest first: the most likely to see p.
        let corners = &mut corners[..k];
        corners.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        corners.iter().any(|&(_, q)| {
            *tests += 1;
            self.segment_clear(triangles, self.lattice.point(q), p)
        })
    }

    /// True when the segment `a`-`b`, which lies in a lattice cell whose blocking triangles
    /// are `triangles`, hits none of them. A segment inside a closed cell can only meet the
    /// triangles that touch the cell, so this is exact without a ray cast through the scene.
    fn segment_clear(&self, triangles: &[u32], a: Vec3, b: Vec3) -> bool {
        triangles
            .iter()
            .all(|&t| !segment_hits_triangle(a, b, self.scene.triangle(t)))
    }

    fn free(&self, c: [u32; 3]) -> bool {
        self.bsp.cluster_at(self.lattice.point(c)).is_some()
    }

    /// Seeds the fill: for each spawn point (lifted out of solid if need be), the free corners
    /// of its lattice cell that it sees. Returns the segment tests made.
    fn seed(&mut self) -> u64 {
        let up = Vec3::Z;
        let mut tests = 0;
        let mut seeded = 0;
        let bsp = self.bsp;
        for &spawn in &bsp.spawn_points {
            let Some(p) = [spawn, spawn + up * SPAWN_LIFT]
                .into_iter()
                .find(|&p| self.bsp.cluster_at(p).is_some())
            else {
                continue;
            };
            let Some(c) = self.lattice.cell_of(p) else {
                continue;
            };
            let triangles = self.cells.of(self.lattice.index(c)).unwrap_or(&[]);
            let mut any = false;
            for k in 0..8u32 {
                let q = [c[0] + (k & 1), c[1] + ((k >> 1) & 1), c[2] + (k >> 2)];
                tests += 1;
                if self.free(q) && self.segment_clear(triangles, p, self.lattice.point(q)) {
                    self.reached.insert(self.lattice.index(q) as usize);
                    any = true;
                }
            }
            seeded += usize::from(any);
        }
        self.stats.seeded_spawn_points = seeded;
        tests
    }

    /// True when the lattice edge from `u` to `u + e_axis` is clear: some cell around it is
    /// untouched, or it hits none of the triangles of one of them (every triangle meeting the
    /// edge touches all the cells around it).
    fn edge_clear(&self, u: [u32; 3], axis: usize, tests: &mut u64) -> bool {
        let (j, k) = ((axis + 1) % 3, (axis + 2) % 3);
        let n = self.lattice.n;
        let mut fewest: Option<&[u32]> = None;
        for (dj, dk) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            if u[j] < dj || u[k] < dk {
                continue;
            }
            let mut c = u;
            c[j] -= dj;
            c[k] -= dk;
            if c[j] + 1 >= n[j] || c[k] + 1 >= n[k] {
                continue;
            }
            match self.cells.of(self.lattice.index(c)) {
                None => return true,
                Some(t) if fewest.is_none_or(|f| t.len() < f.len()) => fewest = Some(t),
                Some(_) => {}
            }
        }
        let mut v = u;
        v[axis] += 1;
        *tests += 1;
        self.segment_clear(
            fewest.unwrap_or(&[]),
            self.lattice.point(u),
            self.lattice.point(v),
        )
    }

    /// The breadth-first fill from the seeds. Returns the segment tests made.
    fn fill(&mut self) -> u64 {
        let mut frontier: Vec<u32> = self.reached.ones().map(|i| i as u32).collect();
        let mut tests = 0;
        while !frontier.is_empty() {
            let this = &*self;
            let (mut next, level_tests) = frontier
                .par_iter()
                .fold(
                    || (Vec::new(), 0u64),
                    |(mut found, mut tests), &i| {
                        let u = this.lattice.coords(i);
                        for axis in 0..3 {
                            for down in [false, true] {
                                let mut v = u;
                                if down {
                                    if v[axis] == 0 {
                                        continue;
                                    }
                                    v[axis] -= 1;
                                } else {
                                    if v[axis] + 1 >= this.lattice.n[axis] {
                                        continue;
                                    }
                                    v[axis] += 1;
                                }
                                let vi = this.lattice.index(v);
                                if this.reached.contains(vi as usize) || !this.free(v) {
                                    continue;
                                }
                                // Always from the lower end: one answer per edge.
                                let lower = if down { v } else { u };
                                if this.edge_clear(lower, axis, &mut tests) {
                                    found.push(vi);
                                }
                            }
                        }
                        (found, tests)
                    },
                )
                .reduce(
                    || (Vec::new(), 0),
                    |(mut a, ta), (b, tb)| {
                        a.extend(b);
                        (a, ta + tb)
                    },
                );
            tests += level_tests;
            next.sort_unstable();
            next.dedup();
            for &v in &next {
                self.reached.insert(v as usize);
            }
            frontier = next;
        }
        tests
    }

    /// Marks the reachable leaves (see the module docs). Returns the segment tests made.
    fn find_leaves(&mut self) -> u64 {
        let bsp = self.bsp;
        let mut leaves = FixedBitSet::with_capacity(bsp.leaves.len());
        let reached: Vec<u32> = self.reached.ones().map(|i| i as u32).collect();
        let hit: Vec<usize> = reached
            .par_chunks(4096)
            .flat_map_iter(|chunk| {
                chunk
                    .iter()
                    .map(|&i| bsp.leaf_at(self.lattice.point(self.lattice.coords(i))))
            })
            .collect();
        for l in hit {
            // `leaf_at` answers 0 for a map without nodes, even when it has no leaves.
            if l < leaves.len() {
                leaves.insert(l);
            }
        }
        let halton = ShiftedHalton::<3>::new(0x6c65_6166);
        let rest: Vec<usize> = (0..bsp.leaves.len())
            .filter(|&l| bsp.leaves[l].cluster >= 0 && !leaves.contains(l))
            .collect();
        let this = &*self;
        let found: Vec<(usize, u64)> = rest
            .par_iter()
            .map(|&l| {
                let b = bsp.leaves[l].bounds();
                let mut tests = 0;
                let reachable = (0..=LEAF_SAMPLES)
                    .map(|i| {
                        if i == 0 {
                            b.center()
                        } else {
                            b.min + b.extent() * Vec3::from(halton.point(i - 1))
                        }
                    })
                    // A point of the leaf is in its cluster (leaves of `rest` have one).
                    .any(|p| bsp.leaf_at(p) == l && this.reachable_free_point(p, &mut tests));
                (if reachable { l } else { usize::MAX }, tests)
            })
            .collect();
        let mut tests = 0;
        for (l, t) in found {
            tests += t;
            if l != usize::MAX {
                leaves.insert(l);
            }
        }
        self.leaves = leaves;
        tests
    }
}

/// For each lattice cell, the blocking triangles that touch it (closed cell boxes grown by a
/// thousandth of a step, so that a triangle on a cell face counts for both cells; a
/// separating-axis test per cell of the triangle's box).
fn cell_triangles(scene: &Scene, l: &Lattice, blocking: &FixedBitSet) -> CellTriangles {
    let margin = l.step * 1e-3;
    let half = Vec3::splat(0.5 * l.step + margin);
    let ids: Vec<u32> = blocking.ones().map(|t| t as u32).collect();
    // (cell, triangle) pairs, chunk by chunk in parallel; sorted, they are the rows.
    let mut pairs: Vec<(u32, u32)> = ids
        .par_chunks(1024)
        .flat_map_iter(|chunk| {
            let mut out = Vec::new();
            for &t in chunk {
                let tri = scene.triangle(t);
                if (tri[1] - tri[0]).cross(tri[2] - tri[0]) == Vec3::ZERO {
                    continue; // zero area: blocks nothing
                }
                let lo = tri[0].min(tri[1]).min(tri[2]) - Vec3::splat(margin);
                let hi = tri[0].max(tri[1]).max(tri[2]) + Vec3::splat(margin);
                let Some([(x0, x1), (y0, y1), (z0, z1)]) = l.cells_in(lo, hi) else {
                    continue;
                };
                for z in z0..=z1 {
                    for y in y0..=y1 {
                        for x in x0..=x1 {
                            let c = [x, y, z];
                            let centre = l.point(c) + Vec3::splat(0.5 * l.step);
                            if triangle_overlaps_box(tri, centre, half) {
                                out.push((l.index(c), t));
                            }
                        }
                    }
                }
            }
            out
        })
        .collect();
    pairs.par_sort_unstable();
    let mut words = vec![0u64; l.len().div_ceil(64)];
    let mut starts = Vec::new();
    let mut triangles = Vec::with_capacity(pairs.len());
    let mut last = u32::MAX;
    for &(cell, t) in &pairs {
        if cell != last {
            words[cell as usize / 64] |= 1 << (cell % 64);
            starts.push(triangles.len() as u32);
            last = cell;
        }
        triangles.push(t);
    }
    starts.push(triangles.len() as u32);
    let mut rank = Vec::with_capacity(words.len());
    let mut count = 0u32;
    for w in &words {
        rank.push(count);
        count += w.count_ones();
    }
    CellTriangles {
        words,
        rank,
        starts,
        triangles,
    }
}

/// True when the closed segment `a`-`b` meets the triangle (Möller-Trumbore, edges and ends
/// included; a segment in the triangle's plane does not meet it, as a ray along a surface
/// does not hit it).
fn segment_hits_triangle(a: Vec3, b: Vec3, [p0, p1, p2]: [Vec3; 3]) -> bool {
    let d = b - a;
    let (e1, e2) = (p1 - p0, p2 - p0);
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() <= f32::EPSILON * e1.length() * e2.length() * d.length() {
        return false;
    }
    let inv = 1.0 / det;
    let s = a - p0;
    let u = inv * s.dot(h);
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = inv * d.dot(q);
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let t = inv * e2.dot(q);
    (0.0..=1.0).contains(&t)
}

/// Per triangle: true unless it belongs to a brush model 1.. (movers) or a liquid or fog
/// surface. Triangles with no surface record block.
fn blocking_triangles(scene: &Scene, bsp: &BspData) -> FixedBitSet {
    let mut out = FixedBitSet::with_capacity(scene.triangle_count());
    out.insert_range(..);
    let passable = SurfaceFlags(SurfaceFlags::LIQUID.0 | SurfaceFlags::FOG.0);
    for s in &bsp.surfaces {
        let mover = s.model.is_some_and(|m| m > 0);
        if mover || s.flags.0 & passable.0 != 0 {
            for t in s.triangles.clone() {
                if (t as usize) < out.len() {
                    out.set(t as usize, false);
                }
            }
        }
    }
    out
}

/// Separating-axis test of a triangle against the box `centre ± half` (Akenine-Möller 2001):
/// the box axes, the triangle's normal and the nine edge-axis cross products.
fn triangle_overlaps_box(tri: [Vec3; 3], centre: Vec3, half: Vec3) -> bool {
    let v = tri.map(|p| p - centre);
    let separated = |axis: Vec3| {
        let p = v.map(|x| x.dot(axis));
        let r = half.dot(axis.abs());
        p[0].min(p[1]).min(p[2]) > r || p[0].max(p[1]).max(p[2]) < -r
    };
    if [Vec3::X, Vec3::Y, Vec3::Z].into_iter().any(separated) {
        return false;
    }
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    if separated(e[0].cross(e[1])) {
        return false;
    }
    for edge in e {
        for a in [Vec3::X, Vec3::Y, Vec3::Z] {
            let axis = a.cross(edge);
            // A zero axis (edge along a box axis) separates nothing and is covered above.
            if axis != Vec3::ZERO && separated(axis) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::q3::{Leaf, Node, Plane};
    use sightline_core::scene::SceneBuilder;

    /// A closed room [0, 512]^3 with a closed crate [200, 264]^3 in it and a spawn point in
    /// a corner; the BSP has one leaf of cluster 0 everywhere except a 0.5-unit slab
    /// `100 <= x < 100.5` (leaf 1, cluster 1), which holds no lattice point.
    fn room() -> Scene {
        let mut b = SceneBuilder::new("room");
        b.add_box(Vec3::ZERO, Vec3::splat(512.0));
        b.add_box(Vec3::splat(200.0), Vec3::splat(264.0));
        let mut scene = b.finish();
        let plane = |x: f32| Plane {
            normal: Vec3::X,
            dist: x,
        };
        scene.bsp = Some(Box::new(BspData {
            clusters: 2,
            planes: vec![plane(100.0), plane(100.5)],
            // Node 0: x >= 100 -> node 1, else leaf 0. Node 1: x >= 100.5 -> leaf 2, else leaf 1.
            nodes: vec![
                Node {
                    plane: 0,
                    children: [1, -1],
                    ..Node::default()
                },
                Node {
                    plane: 1,
                    children: [-3, -2],
                    ..Node::default()
                },
            ],
            leaves: vec![
                Leaf {
                    cluster: 0,
                    mins: [-16, -16, -16],
                    maxs: [100, 528, 528],
                    ..Leaf::default()
                },
                Leaf {
                    cluster: 1,
                    mins: [100, 0, 0],
                    maxs: [101, 512, 512],
                    ..Leaf::default()
                },
                Leaf {
                    cluster: 0,
                    mins: [101, -16, -16],
                    maxs: [528, 528, 528],
                    ..Leaf::default()
                },
            ],
            spawn_points: vec![Vec3::new(40.0, 40.0, 30.0)],
            ..BspData::default()
        }));
        scene
    }

    #[test]
    fn spawn_and_room_are_reachable_crate_and_outside_are_not() {
        let scene = room();
        let r = ReachableSpace::build(&scene, &ReachParams::default()).unwrap();
        let s = r.stats();
        assert_eq!(s.seeded_spawn_points, 1);
        assert!(r.is_reachable(Vec3::new(40.0, 40.0, 30.0)));
        assert!(r.is_reachable(Vec3::new(480.0, 300.0, 500.0)));
        // Right next to the walls and the crate, on the room side.
        assert!(r.is_reachable(Vec3::new(0.3, 256.0, 256.0)));
        assert!(r.is_reachable(Vec3::new(199.8, 230.0, 230.0)));
        // Inside the crate (free for the BSP, boxed in by triangles), and outside the room.
        assert!(!r.is_reachable(Vec3::splat(232.0)));
        assert!(!r.is_reachable(Vec3::new(200.2, 230.0, 230.0)));
        assert!(!r.is_reachable(Vec3::new(-5.0, 256.0, 256.0)));
        assert!(!r.is_reachable(Vec3::splat(f32::NAN)));
        // The room's inside holds 32 lattice points each way (0.37 .. 496.37); the crate's
        // 4 x 4 x 4 are not reached, nor any outside the walls.
        assert_eq!(s.reached_voxels, 32u64.pow(3) - 64, "{s:?}");
        // All three leaves hold room space; the thin slab only through its samples.
        assert!(r.leaf_reachable(0) && r.leaf_reachable(1) && r.leaf_reachable(2));
        assert_eq!(s.reachable_leaves, 3);
        assert!(r.cluster_reachable(1));
        // One bit per lattice point (reached), the touched cells' bits and rows (the walls
        // touch one layer of cells each, the crate a few), a bit per leaf.
        let touched = r.cells.starts.len() - 1;
        assert!(touched > 6 * 32 * 32 && touched < 7 * 35 * 35, "{touched}");
        assert!(s.memory_bytes < s.voxels / 4 + 64 * touched as u64, "{s:?}");
    }

    #[test]
    fn a_sealed_leaf_is_unreachable() {
        // The same room with the spawn inside the crate: only the crate's inside is reached.
        let mut scene = room();
        scene.bsp.as_mut().unwrap().spawn_points = vec![Vec3::splat(232.0)];
        let r = ReachableSpace::build(&scene, &ReachParams::default()).unwrap();
        assert!(r.is_reachable(Vec3::splat(232.0)));
        assert!(!r.is_reachable(Vec3::new(40.0, 40.0, 30.0)));
        assert!(!r.leaf_reachable(0) && !r.leaf_reachable(1) && r.leaf_reachable(2));
        assert!(!r.cluster_reachable(1));
        // The crate's inside holds 4 x 4 x 4 lattice points (at 208.37 .. 256.37 each way).
        assert_eq!(r.stats().reached_voxels, 64, "{:?}", r.stats());
    }

    #[test]
    fn result_does_not_depend_on_the_thread_count() {
        let scene = sightline_core::scene::open(
            concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/q3dm6ish.bsp"),
            &sightline_core::scene::LoadOptions::default(),
        )
        .unwrap();
        let build = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    let r = ReachableSpace::build(&scene, &ReachParams { step: 32.0 }).unwrap();
                    (r.reached.clone(), r.leaves.clone(), r.stats().clone())
                })
        };
        let (reached, leaves, stats) = build(1);
        let (reached3, leaves3, stats3) = build(3);
        assert_eq!(reached, reached3);
        assert_eq!(leaves, leaves3);
        assert_eq!(stats.segment_tests, stats3.segment_tests);
        // Every spawn point of the map is reachable, and so is its leaf.
        let bsp = scene.bsp.as_deref().unwrap();
        let r = ReachableSpace::build(&scene, &ReachParams { step: 32.0 }).unwrap();
        assert_eq!(stats.seeded_spawn_points, bsp.spawn_points.len());
        for &s in &bsp.spawn_points {
            assert!(r.is_reachable(s), "spawn {s}");
            assert!(r.leaf_reachable(bsp.leaf_at(s)), "spawn {s}");
        }
        // Some leaves are not reachable, most are.
        assert!(
            stats.reachable_leaves < stats.leaves && 2 * stats.reachable_leaves > stats.leaves,
            "{stats:?}"
        );
    }

    #[test]
    fn bad_parameters_are_errors() {
        let scene = room();
        for step in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let e = ReachableSpace::build(&scene, &ReachParams { step }).unwrap_err();
            assert!(matches!(e, ReachError::BadStep { .. }), "{e}");
        }
        let e = ReachableSpace::build(&scene, &ReachParams { step: 0.05 }).unwrap_err();
        assert!(e.to_string().contains("2^28"), "{e}");
        let mut none = room();
        none.bsp.as_mut().unwrap().spawn_points.clear();
        let e = ReachableSpace::build(&none, &ReachParams::default()).unwrap_err();
        assert!(matches!(e, ReachError::NoSpawnPoints), "{e}");
        let plain = SceneBuilder::new("x").finish();
        let e = ReachableSpace::build(&plain, &ReachParams::default()).unwrap_err();
        assert!(matches!(e, ReachError::NoBsp), "{e}");
    }

    #[test]
    fn segments_meet_triangles_on_edges_not_in_their_plane() {
        let tri = [
            Vec3::ZERO,
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
        ];
        let through = |x: f32, y: f32| {
            segment_hits_triangle(Vec3::new(x, y, -1.0), Vec3::new(x, y, 1.0), tri)
        };
        assert!(through(1.0, 1.0) && through(2.0, 2.0) && through(0.0, 0.0));
        assert!(!through(2.1, 2.1) && !through(-0.1, 1.0));
        // Ending short of the triangle, starting on it, and lying in its plane.
        let short = segment_hits_triangle(Vec3::new(1.0, 1.0, 2.0), Vec3::new(1.0, 1.0, 0.5), tri);
        let on = segment_hits_triangle(Vec3::new(1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 3.0), tri);
        let along = segment_hits_triangle(Vec3::new(-1.0, 1.0, 0.0), Vec3::new(5.0, 1.0, 0.0), tri);
        assert!(!short && on && !along);
    }

    #[test]
    fn triangle_box_overlap() {
        let tri = [
            Vec3::ZERO,
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
        ];
        assert!(triangle_overlaps_box(
            tri,
            Vec3::new(1.0, 1.0, 0.5),
            Vec3::ONE
        ));
        assert!(!triangle_overlaps_box(
            tri,
            Vec3::new(1.0, 1.0, 1.5),
            Vec3::splat(0.4)
        ));
        // Beyond the hypotenuse: only the edge-cross axes separate it.
        assert!(!triangle_overlaps_box(
            tri,
            Vec3::new(3.0, 3.0, 0.0),
            Vec3::splat(0.9)
        ));
        assert!(triangle_overlaps_box(
            tri,
            Vec3::new(2.5, 2.5, 0.0),
            Vec3::splat(0.9)
        ));
    }
}
