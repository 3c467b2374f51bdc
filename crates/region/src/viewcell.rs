//! View cells: the regions a PVS is computed for. A view cell is an oriented box, or a flat
//! rectangle (a box with zero thickness), given by its centre, an orthonormal frame and its
//! half extents along the frame's axes.
//!
//! Sampling maps points of the unit square/cube onto the cell: [`ViewCell::surface_point`] picks
//! a face with probability proportional to its area (the origin distribution of GVS++'s random
//! sampling, section 4.1 of Koch & Wimmer 2021, extended from one rectangle to a box's six);
//! [`ViewCell::interior_point`] fills the volume (evaluation viewpoints).

use glam::Vec3;
use serde::{Deserialize, Serialize};
use sightline_core::{Aabb, NearPlaneRule, Scene};
use sightline_runtime::format::{check_cell_geometry, CellGeometryError};

/// Why a view cell is not usable.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum ViewCellError {
    /// Non-finite coordinates, bad extents or axes: the check every reader of `.pvs` files
    /// runs too (`sightline_runtime::format::check_cell_geometry`).
    #[error(transparent)]
    Geometry(#[from] CellGeometryError),
    /// A `--cell` spec could not be parsed.
    #[error("view cell spec '{spec}': {message}")]
    Spec {
        /// The spec as given.
        spec: String,
        /// What is wrong.
        message: String,
    },
}

/// An oriented box or rectangle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewCell {
    /// Centre point.
    pub center: Vec3,
    /// Orthonormal frame: the box's local x, y, z axes in world space.
    pub axes: [Vec3; 3],
    /// Half extents along `axes` (one of them may be 0: a rectangle).
    pub half_extents: Vec3,
}

/// One rectangular face of a cell: `center ± u ± v` (u, v are half-edge vectors).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Centre.
    pub center: Vec3,
    /// Half-edge vector along the first side.
    pub u: Vec3,
    /// Half-edge vector along the second side.
    pub v: Vec3,
}

impl Rect {
    /// Area of the rectangle.
    pub fn area(&self) -> f32 {
        4.0 * self.u.cross(self.v).length()
    }

    /// The point at `(s, t)` in `[0,1]²`.
    pub fn point(&self, s: f32, t: f32) -> Vec3 {
        self.center + self.u * (2.0 * s - 1.0) + self.v * (2.0 * t - 1.0)
    }

    /// Unit normal `u × v` (zero for a degenerate rectangle).
    pub fn normal(&self) -> Vec3 {
        self.u.cross(self.v).normalize_or_zero()
    }
}

/// Precomputed faces and area weights of a cell, for drawing many surface samples without
/// allocating.
#[derive(Clone, Debug)]
pub struct CellSurface {
    faces: Vec<Rect>,
    cumulative_area: Vec<f32>,
}

impl CellSurface {
    /// The surface of `cell`.
    pub fn new(cell: &ViewCell) -> Self {
        let faces = cell.faces();
        let mut total = 0.0;
        let cumulative_area = faces
            .iter()
            .map(|f| {
                total += f.area();
                total
            })
            .collect();
        Self {
            faces,
            cumulative_area,
        }
    }

    /// The faces.
    pub fn faces(&self) -> &[Rect] {
        &self.faces
    }

    /// The point for sample `s` of the unit cube (`s[0]` picks the face by area, `s[1..]` the
    /// position on it) and the face it lies on.
    pub fn sample(&self, s: [f32; 3]) -> (Vec3, &Rect) {
        let total = self.cumulative_area.last().copied().unwrap_or(0.0);
        let pick = s[0] * total;
        let i = self
            .cumulative_area
            .partition_point(|&c| c <= pick)
            .min(self.faces.len() - 1);
        let face = &self.faces[i];
        (face.point(s[1], s[2]), face)
    }
}

impl ViewCell {
    /// An axis-aligned box from its corners (a flat one when two corners share a coordinate).
    pub fn aabb(min: Vec3, max: Vec3) -> Result<Self, ViewCellError> {
        Self::oriented(
            (min + max) * 0.5,
            [Vec3::X, Vec3::Y, Vec3::Z],
            (max - min) * 0.5,
        )
    }

    /// An oriented box (validated).
    pub fn oriented(
        center: Vec3,
        axes: [Vec3; 3],
        half_extents: Vec3,
    ) -> Result<Self, ViewCellError> {
        check_cell_geometry(
            center.to_array(),
            axes.map(|a| a.to_array()),
            half_extents.to_array(),
        )?;
        Ok(Self {
            center,
            axes,
            half_extents,
        })
    }

    /// Parses a command-line cell: `box:MINX,MINY,MINZ,MAXX,MAXY,MAXZ` (axis-aligned; equal
    /// min and max on one axis gives a rectangle) or `point:X,Y,Z,R` (a cube of half size R).
    pub fn parse(spec: &str) -> Result<Self, ViewCellError> {
        let err = |message: &str| ViewCellError::Spec {
            spec: spec.into(),
            message: message.into(),
        };
        let (kind, numbers) = spec
            .split_once(':')
            .ok_or_else(|| err("expected KIND:NUMBERS"))?;
        let values: Vec<f32> = numbers
            .split(',')
            .map(|s| s.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| err("not a comma-separated list of numbers"))?;
        match (kind, values.as_slice()) {
            ("box", &[a, b, c, d, e, f]) => {
                let (min, max) = (Vec3::new(a, b, c), Vec3::new(d, e, f));
                if min.cmpgt(max).any() {
                    return Err(err("min must be <= max on every axis"));
                }
                Self::aabb(min, max)
            }
            ("point", &[x, y, z, r]) => Self::aabb(
                Vec3::new(x, y, z) - Vec3::splat(r),
                Vec3::new(x, y, z) + Vec3::splat(r),
            ),
            ("box", _) => Err(err("box needs 6 numbers: minx,miny,minz,maxx,maxy,maxz")),
            ("point", _) => Err(err("point needs 4 numbers: x,y,z,half_size")),
            _ => Err(err("unknown kind (use box: or point:)")),
        }
    }

    /// A regular `nx x ny x nz` grid of axis-aligned cells filling `[min, max]`, in x-fastest
    /// order.
    pub fn grid(min: Vec3, max: Vec3, n: [u32; 3]) -> Result<Vec<Self>, ViewCellError> {
        if n.contains(&0) {
            return Err(ViewCellError::Spec {
                spec: format!("{n:?}"),
                message: "grid counts must be >= 1".into(),
            });
        }
        let step = (max - min) / Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32);
        // Checked and fallible: a u32 product wraps (4096³ does), and an impossible
        // allocation must be an error, not an abort.
        let too_many = || ViewCellError::Spec {
            spec: format!("{n:?}"),
            message: "too many grid cells to hold in memory".into(),
        };
        let total = n
            .iter()
            .try_fold(1usize, |acc, &k| acc.checked_mul(k as usize))
            .ok_or_else(too_many)?;
        let mut cells = Vec::new();
        cells.try_reserve_exact(total).map_err(|_| too_many())?;
        for z in 0..n[2] {
            for y in 0..n[1] {
                for x in 0..n[0] {
                    let lo = min + step * Vec3::new(x as f32, y as f32, z as f32);
                    cells.push(Self::aabb(lo, lo + step)?);
                }
            }
        }
        Ok(cells)
    }

    /// True when the cell is a flat rectangle.
    pub fn is_flat(&self) -> bool {
        self.half_extents.min_element() == 0.0
    }

    /// The cell's faces: one rectangle when flat, else six (outward normals).
    pub fn faces(&self) -> Vec<Rect> {
        let [ax, ay, az] = self.axes;
        let h = self.half_extents;
        let (x, y, z) = (ax * h.x, ay * h.y, az * h.z);
        if self.is_flat() {
            let flat = h.to_array().iter().position(|&e| e == 0.0).unwrap_or(2);
            let (u, v) = match flat {
                0 => (y, z),
                1 => (z, x),
                _ => (x, y),
            };
            return vec![Rect {
                center: self.center,
                u,
                v,
            }];
        }
        let c = self.center;
        vec![
            Rect {
                center: c + x,
                u: y,
                v: z,
            },
            Rect {
                center: c - x,
                u: z,
                v: y,
            },
            Rect {
                center: c + y,
                u: z,
                v: x,
            },
            Rect {
                center: c - y,
                u: x,
                v: z,
            },
            Rect {
                center: c + z,
                u: x,
                v: y,
            },
            Rect {
                center: c - z,
                u: y,
                v: x,
            },
        ]
    }

    /// Total surface area (one side for a rectangle).
    pub fn area(&self) -> f32 {
        self.faces().iter().map(Rect::area).sum()
    }

    /// The point on the cell's surface for a sample `s` of the unit cube: `s[0]` picks a face
    /// (area-weighted), `s[1], s[2]` the position on it.
    pub fn surface_point(&self, s: [f32; 3]) -> Vec3 {
        CellSurface::new(self).sample(s).0
    }

    /// The cell's edges as point pairs (4 for a rectangle, 12 for a box).
    pub fn edges(&self) -> Vec<(Vec3, Vec3)> {
        let c = self.corners();
        if self.is_flat() {
            // The four distinct corners of the flat cell, in order around it.
            let flat = self
                .half_extents
                .to_array()
                .iter()
                .position(|&e| e == 0.0)
                .unwrap_or(2);
            let (a, b) = match flat {
                0 => (2, 4),
                1 => (1, 4),
                _ => (1, 2),
            };
            let quad = [c[0], c[a], c[a | b], c[b]];
            return (0..4).map(|i| (quad[i], quad[(i + 1) % 4])).collect();
        }
        let mut edges = Vec::with_capacity(12);
        for i in 0..8usize {
            for bit in [1usize, 2, 4] {
                if i & bit == 0 {
                    edges.push((c[i], c[i | bit]));
                }
            }
        }
        edges
    }

    /// The distinct corners: 4 for a rectangle, 8 for a box.
    pub fn distinct_corners(&self) -> Vec<Vec3> {
        let mut out: Vec<Vec3> = Vec::with_capacity(8);
        for p in self.corners() {
            if !out.contains(&p) {
                out.push(p);
            }
        }
        out
    }

    /// The point inside the cell for a sample `s` of the unit cube.
    pub fn interior_point(&self, s: [f32; 3]) -> Vec3 {
        let [ax, ay, az] = self.axes;
        let h = self.half_extents;
        self.center
            + ax * h.x * (2.0 * s[0] - 1.0)
            + ay * h.y * (2.0 * s[1] - 1.0)
            + az * h.z * (2.0 * s[2] - 1.0)
    }

    /// `count` rays from uniformly random points of the cell in uniformly random directions,
    /// the same for the same `seed`: the dense sampling that conservative sets are checked
    /// against (no triangle a ray from inside the cell hits first may be missing).
    pub fn random_rays(&self, count: usize, seed: u64) -> Vec<sightline_core::Ray> {
        let mut rng = sightline_core::random::SplitMix64::new(seed);
        (0..count)
            .map(|_| {
                let o = self.interior_point([rng.next_f32(), rng.next_f32(), rng.next_f32()]);
                let z = rng.range_f32(-1.0, 1.0);
                let a = rng.range_f32(0.0, std::f32::consts::TAU);
                let r = (1.0 - z * z).max(0.0).sqrt();
                sightline_core::Ray::new(o, Vec3::new(r * a.cos(), r * a.sin(), z))
            })
            .collect()
    }

    /// True when `p` is inside or on the cell (with a relative tolerance for flat cells).
    pub fn contains(&self, p: Vec3) -> bool {
        let d = p - self.center;
        let eps = 1e-5 * self.half_extents.max_element().max(1e-6);
        (0..3).all(|i| d.dot(self.axes[i]).abs() <= self.half_extents[i] + eps)
    }

    /// The eight corners (four distinct ones for a rectangle, repeated).
    pub fn corners(&self) -> [Vec3; 8] {
        let [ax, ay, az] = self.axes;
        let h = self.half_extents;
        std::array::from_fn(|i| {
            let sign = |bit: usize| if i & bit != 0 { 1.0 } else { -1.0 };
            self.center + ax * h.x * sign(1) + ay * h.y * sign(2) + az * h.z * sign(4)
        })
    }

    /// The near plane of cameras anywhere in the cell: the default rule of
    /// [`sightline_core::near_plane`] for the cell's bounding box, so a cell away from the
    /// geometry clips none of it from any of its points.
    pub fn default_near(&self, scene: &Scene) -> f32 {
        NearPlaneRule::new(scene).within(&Aabb::from_points(self.corners()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> ViewCell {
        ViewCell::aabb(Vec3::ZERO, Vec3::ONE).unwrap()
    }

    #[test]
    fn box_area_is_six() {
        assert!((unit_box().area() - 6.0).abs() < 1e-5);
    }

    #[test]
    fn flat_cell_has_one_face() {
        let r = ViewCell::aabb(Vec3::ZERO, Vec3::new(2.0, 0.0, 3.0)).unwrap();
        assert!(r.is_flat());
        assert_eq!(r.faces().len(), 1);
        assert!((r.area() - 6.0).abs() < 1e-5);
    }

    #[test]
    fn box_faces_point_outwards() {
        let b = unit_box();
        for f in b.faces() {
            assert!(f.normal().dot(f.center - b.center) > 0.0);
        }
    }

    #[test]
    fn surface_points_lie_on_surface() {
        let b = ViewCell::aabb(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)).unwrap();
        let h = sightline_core::sampling::ShiftedHalton::<3>::new(1);
        for i in 0..500 {
            let p = b.surface_point(h.point(i));
            assert!(b.contains(p));
            let on_face = [p.x, p.y, p.z]
                .iter()
                .zip([1.0, 2.0, 3.0])
                .any(|(&c, m)| c.abs() < 1e-5 || (c - m).abs() < 1e-5);
            assert!(on_face, "{p} not on the surface");
        }
    }

    #[test]
    fn edges_and_corners_of_box_and_rect() {
        assert_eq!(unit_box().edges().len(), 12);
        assert_eq!(unit_box().distinct_corners().len(), 8);
        let r = ViewCell::aabb(Vec3::ZERO, Vec3::new(2.0, 0.0, 3.0)).unwrap();
        assert_eq!(r.distinct_corners().len(), 4);
        let edges = r.edges();
        assert_eq!(edges.len(), 4);
        let perimeter: f32 = edges.iter().map(|(a, b)| a.distance(*b)).sum();
        assert!((perimeter - 10.0).abs() < 1e-5);
    }

    #[test]
    fn line_and_nan_cells_are_rejected() {
        assert!(matches!(
            ViewCell::aabb(Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0)),
            Err(ViewCellError::Geometry(CellGeometryError::BadExtent(_)))
        ));
        assert_eq!(
            ViewCell::aabb(Vec3::NAN, Vec3::ONE),
            Err(ViewCellError::Geometry(CellGeometryError::NotFinite))
        );
    }

    #[test]
    fn parse_specs() {
        let c = ViewCell::parse("box:0,0,0,2,2,1").unwrap();
        assert_eq!(c.center, Vec3::new(1.0, 1.0, 0.5));
        let p = ViewCell::parse("point:1,2,3,0.5").unwrap();
        assert_eq!(p.half_extents, Vec3::splat(0.5));
        for bad in [
            "box:1,2",
            "cube:0,0,0,1,1,1",
            "box:0,0,0,a,1,1",
            "box:1,1,1,0,0,0",
            "nothing",
        ] {
            assert!(ViewCell::parse(bad).is_err(), "{bad} accepted");
        }
    }

    #[test]
    fn grid_tiles_region() {
        let cells = ViewCell::grid(Vec3::ZERO, Vec3::new(4.0, 2.0, 1.0), [4, 2, 1]).unwrap();
        assert_eq!(cells.len(), 8);
        assert_eq!(cells[5].center, Vec3::new(1.5, 1.5, 0.5));
        assert!(ViewCell::grid(Vec3::ZERO, Vec3::ONE, [0, 1, 1]).is_err());
        // The u32 product of these wraps around; the allocation would be 2^64 cells.
        assert!(ViewCell::grid(Vec3::ZERO, Vec3::ONE, [u32::MAX, u32::MAX, u32::MAX]).is_err());
    }
}
