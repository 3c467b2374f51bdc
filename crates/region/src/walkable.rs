//! View cells where players walk: boxes at eye height over the walkable surfaces of a mesh
//! level (`pvs bake --walkable SIZE`), so that a level without a BSP gets cells where a camera
//! can be instead of a grid through walls and sealed space.
//!
//! A column of `size x size` is probed with a few vertical rays (3 x 3 points): each ray is
//! cast down from above the scene and recast from below every surface it hits, so that every
//! storey is found. A hit is a floor when its triangle faces up (within `max_slope_deg` of the
//! up axis) and nothing lies above it closer than `head_room`. Floors of a column whose
//! heights lie within `head_room` of each other are one floor (stairs, ramps, uneven ground);
//! a floor needs room for a player's footprint (four more rays `footprint` away, left, right,
//! ahead and behind, find the same surface height within a step), so the top of a thin wall is
//! none. Each floor gets a cell spanning the column and the eye heights `eye_low..eye_high`
//! above its lowest and highest probe. Unreal's precomputed visibility places its cells over surfaces in
//! the same spirit (cells only above walkable geometry, at player height).
//!
//! Ours, not from the four papers. Memory: the cells (one per floor of each column); work: at
//! most 9 x (storeys + 1) + 9 x storeys rays per column.

use glam::Vec3;
use sightline_core::geometry::{Hit, Ray};
use sightline_core::trace::RayCaster;
use sightline_core::Scene;

use crate::viewcell::{ViewCell, ViewCellError};

/// How walkable cells are placed. Lengths in scene units (metres for most levels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WalkableParams {
    /// Edge of a cell across the floor.
    pub size: f32,
    /// Eye heights above the floor that a cell spans: `(low, high)`.
    pub eye: (f32, f32),
    /// Free height a floor needs above it (and the height difference within which probes of a
    /// column are one floor).
    pub head_room: f32,
    /// Steepest walkable surface, in degrees from horizontal.
    pub max_slope_deg: f32,
    /// A player's radius: a floor must extend this far around a probe.
    pub footprint: f32,
}

impl Default for WalkableParams {
    /// 4 m cells at 1.2-1.8 m eye height, 2 m head room, slopes up to 45 degrees, a 0.3 m
    /// footprint.
    fn default() -> Self {
        Self {
            size: 4.0,
            eye: (1.2, 1.8),
            head_room: 2.0,
            max_slope_deg: 45.0,
            footprint: 0.3,
        }
    }
}

/// Why no walkable cells could be placed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WalkableError {
    /// A parameter is not a positive finite number, or the eye heights are out of order.
    #[error("walkable cells: {0}")]
    BadParams(String),
    /// The grid of columns over the scene would be too large.
    #[error(
        "walkable cells: {columns} columns of {size} over the scene is more than {max}; give a \
         larger cell size"
    )]
    TooManyColumns {
        /// Columns the grid would have.
        columns: u64,
        /// The cell size asked for.
        size: f32,
        /// The limit.
        max: u64,
    },
    /// A cell could not be built.
    #[error(transparent)]
    Cell(#[from] ViewCellError),
}

/// At most this many columns (each costs some tens of rays).
pub const MAX_COLUMNS: u64 = 1 << 22;

/// Probe points per column, per side.
const PROBES: usize = 3;

/// Cells over the walkable surfaces of `scene` (see the module documentation), in column order
/// (along the first horizontal axis, then the second, then up).
pub fn walkable_cells(
    scene: &Scene,
    caster: &dyn RayCaster,
    p: &WalkableParams,
) -> Result<Vec<ViewCell>, WalkableError> {
    check(p)?;
    let up_index = scene.up.index();
    let up = scene.up.vector();
    let (a, b) = ((up_index + 1) % 3, (up_index + 2) % 3);
    let bounds = scene.bounds();
    if scene.triangle_count() == 0 || !bounds.min.is_finite() || !bounds.max.is_finite() {
        return Ok(Vec::new());
    }
    let extent = bounds.extent();
    let columns = [a, b].map(|axis| ((extent[axis] / p.size).ceil() as u64).max(1));
    let total = columns[0].saturating_mul(columns[1]);
    if total > MAX_COLUMNS {
        return Err(WalkableError::TooManyColumns {
            columns: total,
            size: p.size,
            max: MAX_COLUMNS,
        });
    }
    let min_up = p.max_slope_deg.to_radians().cos();
    let top = bounds.max[up_index] + 1.0;
    let mut cells = Vec::new();
    for i in 0..columns[0] {
        for j in 0..columns[1] {
            let mut corner = bounds.min;
            corner[a] += i as f32 * p.size;
            corner[b] += j as f32 * p.size;
            let column = Column {
                corner,
                a,
                b,
                up_index,
                up,
                top,
            };
            let floors = column.floors(scene, caster, p, min_up);
            for (low, high, _) in merge_floors(floors, p.head_room) {
                let mut min = corner;
                let mut max = corner;
                max[a] += p.size;
                max[b] += p.size;
                min[up_index] = low + p.eye.0;
                max[up_index] = high + p.eye.1;
                cells.push(ViewCell::aabb(min, max)?);
            }
        }
    }
    Ok(cells)
}

fn check(p: &WalkableParams) -> Result<(), WalkableError> {
    let positive = |v: f32| v.is_finite() && v > 0.0;
    let footprint_ok = p.footprint >= 0.0 && p.footprint.is_finite();
    if !(positive(p.size) && positive(p.head_room) && footprint_ok) {
        return Err(WalkableError::BadParams(format!(
            "cell size {} and head room {} must be positive numbers, footprint {} not negative",
            p.size, p.head_room, p.footprint
        )));
    }
    if !(p.eye.0.is_finite() && p.eye.1.is_finite() && 0.0 <= p.eye.0 && p.eye.0 < p.eye.1) {
        return Err(WalkableError::BadParams(format!(
            "eye heights {}..{} must be finite with 0 <= low < high",
            p.eye.0, p.eye.1
        )));
    }
    if !(p.max_slope_deg.is_finite() && (0.0..90.0).contains(&p.max_slope_deg)) {
        return Err(WalkableError::BadParams(format!(
            "the steepest walkable slope {} must be in 0..90 degrees",
            p.max_slope_deg
        )));
    }
    Ok(())
}

/// One column of the grid: its corner (at the scene's lowest height), its horizontal axes and
/// the up axis.
struct Column {
    corner: Vec3,
    a: usize,
    b: usize,
    up_index: usize,
    up: Vec3,
    /// Height above the scene, where the probes start.
    top: f32,
}

impl Column {
    /// The floor heights the probes found, unsorted.
    fn floors(
        &self,
        scene: &Scene,
        caster: &dyn RayCaster,
        p: &WalkableParams,
        min_up: f32,
    ) -> Vec<f32> {
        let mut floors = Vec::new();
        for pi in 0..PROBES {
            for pj in 0..PROBES {
                let mut origin = self.corner;
                origin[self.a] += (pi as f32 + 0.5) / PROBES as f32 * p.size;
                origin[self.b] += (pj as f32 + 0.5) / PROBES as f32 * p.size;
                origin[self.up_index] = self.top;
                self.probe(scene, caster, origin, p, min_up, &mut floors);
            }
        }
        floors
    }

    /// Follows one vertical line down through every surface, recording the floors.
    fn probe(
        &self,
        scene: &Scene,
        caster: &dyn RayCaster,
        mut origin: Vec3,
        p: &WalkableParams,
        min_up: f32,
        floors: &mut Vec<f32>,
    ) {
        // Each step passes one surface; a bound keeps degenerate stacks from looping.
        for _ in 0..256 {
            let Some((t, triangle)) = cast_one(caster, Ray::new(origin, -self.up)) else {
                return;
            };
            let hit = origin - self.up * t;
            let [v0, v1, v2] = scene.triangle(triangle);
            let normal = (v1 - v0).cross(v2 - v0).normalize_or_zero();
            if normal.dot(self.up) >= min_up && self.standable(caster, hit, p) {
                floors.push(hit[self.up_index]);
            }
            // Continue just below this surface.
            let step = 1e-4 * (1.0 + hit[self.up_index].abs());
            origin = hit - self.up * step;
        }
    }

    /// Whether a player can stand at `hit` (on an upward-facing surface): `head_room` free
    /// above it, and the surface found again `footprint` away in the four horizontal
    /// directions, within a step's height (a quarter of the head room).
    fn standable(&self, caster: &dyn RayCaster, hit: Vec3, p: &WalkableParams) -> bool {
        let above = Ray::new(hit + self.up * 1e-3, self.up);
        if cast_one(caster, above).is_some_and(|(d, _)| d < p.head_room) {
            return false;
        }
        let step = 0.25 * p.head_room;
        [(self.a, 1.0), (self.a, -1.0), (self.b, 1.0), (self.b, -1.0)]
            .iter()
            .all(|&(axis, sign)| {
                let mut origin = hit + self.up * step;
                origin[axis] += sign * p.footprint;
                cast_one(caster, Ray::new(origin, -self.up))
                    .is_some_and(|(d, _)| (d - step).abs() <= step)
            })
    }
}

/// The closest hit of one ray: distance and triangle.
fn cast_one(caster: &dyn RayCaster, ray: Ray) -> Option<(f32, u32)> {
    let mut hit = [Hit::MISS];
    caster.cast(&[ray], &mut hit);
    hit[0].triangle().map(|t| (hit[0].t, t))
}

/// Floors within `gap` of the next one form one floor: `(lowest, highest, probe hits)`,
/// ascending.
fn merge_floors(mut heights: Vec<f32>, gap: f32) -> Vec<(f32, f32, usize)> {
    heights.sort_by(f32::total_cmp);
    let mut out: Vec<(f32, f32, usize)> = Vec::new();
    for h in heights {
        match out.last_mut() {
            Some(last) if h - last.1 < gap => {
                last.1 = h;
                last.2 += 1;
            }
            _ => out.push((h, h, 1)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;
    use sightline_core::trace::Bvh;

    #[test]
    fn floors_within_head_room_merge() {
        assert_eq!(
            merge_floors(vec![3.1, 0.0, 0.4, 3.0, 0.2], 2.0),
            vec![(0.0, 0.4, 3), (3.0, 3.1, 2)]
        );
        assert!(merge_floors(Vec::new(), 2.0).is_empty());
    }

    /// A 20 x 20 ground slab (top at z = 0) and an upper storey (top at z = 4) over x < 8.
    fn two_storeys() -> Scene {
        let mut b = SceneBuilder::new("two storeys");
        b.add_box(Vec3::new(0.0, 0.0, -0.2), Vec3::new(20.0, 20.0, 0.0));
        b.add_box(Vec3::new(0.0, 0.0, 3.8), Vec3::new(8.0, 20.0, 4.0));
        // A thin wall on the ground: its top is no floor (one probe at most lands on it).
        b.add_box(Vec3::new(13.9, 0.0, 0.0), Vec3::new(14.1, 20.0, 3.0));
        let mut scene = b.finish();
        scene.up = sightline_core::scene::UpAxis::Z;
        scene
    }

    #[test]
    fn cells_sit_at_eye_height_over_every_storey() {
        let scene = two_storeys();
        let bvh = Bvh::build(&scene);
        let cells = walkable_cells(&scene, &bvh, &WalkableParams::default()).unwrap();
        // 5 x 5 columns of 4 m over the ground, and the 2 x 5 under the upper storey twice.
        assert_eq!(cells.len(), 35);
        let (ground, upper): (Vec<&ViewCell>, Vec<&ViewCell>) =
            cells.iter().partition(|c| c.center.z < 3.0);
        assert_eq!((ground.len(), upper.len()), (25, 10));
        for c in &ground {
            assert!((c.center.z - 1.5).abs() < 1e-3 && (c.half_extents.z - 0.3).abs() < 1e-3);
            assert!((c.half_extents.x - 2.0).abs() < 1e-3, "{c:?}");
        }
        for c in &upper {
            assert!((c.center.z - 5.5).abs() < 1e-3 && c.center.x < 8.0, "{c:?}");
        }
        // With 5 m of head room the ground under the upper storey (3.8 m free) is no floor.
        let tall = WalkableParams {
            head_room: 5.0,
            ..Default::default()
        };
        assert_eq!(walkable_cells(&scene, &bvh, &tall).unwrap().len(), 25);
    }

    #[test]
    fn bad_parameters_are_named() {
        let scene = SceneBuilder::new("empty").finish();
        let bvh = Bvh::build(&scene);
        for p in [
            WalkableParams {
                size: 0.0,
                ..Default::default()
            },
            WalkableParams {
                size: f32::NAN,
                ..Default::default()
            },
            WalkableParams {
                eye: (1.8, 1.2),
                ..Default::default()
            },
            WalkableParams {
                max_slope_deg: 90.0,
                ..Default::default()
            },
        ] {
            let e = walkable_cells(&scene, &bvh, &p).unwrap_err();
            assert!(matches!(e, WalkableError::BadParams(_)), "{e}");
        }
        // An empty scene has no floor.
        let cells = walkable_cells(&scene, &bvh, &WalkableParams::default()).unwrap();
        assert!(cells.is_empty());
    }
}
