//! Small geometric value types shared by every part of sightline: boxes, rays, hits.

use glam::Vec3;

/// An axis-aligned bounding box. The empty box has `min = +inf`, `max = -inf`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box: growing it by a point gives that point's box.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    /// The box with the given corners.
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// The eight corners; corner `i` takes `max` on x where bit 1 of `i` is set, on y for bit
    /// 2, on z for bit 4.
    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|i| {
            let pick = |bit: usize, lo: f32, hi: f32| if i & bit != 0 { hi } else { lo };
            Vec3::new(
                pick(1, self.min.x, self.max.x),
                pick(2, self.min.y, self.max.y),
                pick(4, self.min.z, self.max.z),
            )
        })
    }

    /// The smallest box holding all `points` (empty for no points).
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        let mut b = Self::EMPTY;
        for p in points {
            b.grow(p);
        }
        b
    }

    /// Grows the box to hold `p`.
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Grows the box to hold `other`.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// True when the box holds no point.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// `max - min` (zero for the empty box).
    pub fn extent(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }

    /// The centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Length of the diagonal (zero for the empty box).
    pub fn diagonal(&self) -> f32 {
        self.extent().length()
    }

    /// Surface area (zero for the empty box), the cost measure of the SAH.
    pub fn surface_area(&self) -> f32 {
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// True when `p` lies inside or on the box.
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
}

/// A ray `origin + t * dir` for `t` in `[t_min, t_max]`. `dir` need not be normalised; `t` is
/// measured in units of `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point.
    pub origin: Vec3,
    /// Direction (not necessarily unit length).
    pub dir: Vec3,
    /// Smallest accepted hit distance.
    pub t_min: f32,
    /// Largest accepted hit distance.
    pub t_max: f32,
}

impl Ray {
    /// A ray from `origin` along `dir` over `[0, inf)`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    /// The same ray restricted to `[t_min, t_max]`.
    pub fn with_range(self, t_min: f32, t_max: f32) -> Self {
        Self {
            t_min,
            t_max,
            ..self
        }
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// The closest hit of a ray: triangle id and distance, or a miss.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Triangle id, [`Hit::NONE`] for a miss.
    pub triangle: u32,
    /// Ray parameter of the hit (`f32::INFINITY` for a miss).
    pub t: f32,
}

impl Default for Hit {
    fn default() -> Self {
        Self::MISS
    }
}

impl Hit {
    /// The triangle id that marks a miss.
    pub const NONE: u32 = u32::MAX;
    /// A miss.
    pub const MISS: Hit = Hit {
        triangle: Self::NONE,
        t: f32::INFINITY,
    };

    /// The hit triangle, `None` for a miss.
    pub fn triangle(&self) -> Option<u32> {
        (self.triangle != Self::NONE).then_some(self.triangle)
    }

    /// True when the ray hit something.
    pub fn is_hit(&self) -> bool {
        self.triangle != Self::NONE
    }
}

/// Twice the area of triangle `(a, b, c)`.
pub fn triangle_double_area(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    (b - a).cross(c - a).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_box_grows_to_point() {
        let mut b = Aabb::EMPTY;
        assert!(b.is_empty());
        b.grow(Vec3::new(1.0, 2.0, 3.0));
        assert!(!b.is_empty());
        assert_eq!(b.min, b.max);
        assert_eq!(b.surface_area(), 0.0);
    }

    #[test]
    fn empty_box_has_zero_extent() {
        assert_eq!(Aabb::EMPTY.extent(), Vec3::ZERO);
        assert_eq!(Aabb::from_points([]).diagonal(), 0.0);
    }

    #[test]
    fn unit_box_surface_area_is_six() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(b.surface_area(), 6.0);
        assert!(b.contains(Vec3::splat(0.5)));
        assert!(!b.contains(Vec3::splat(1.5)));
    }

    #[test]
    fn miss_has_no_triangle() {
        assert_eq!(Hit::MISS.triangle(), None);
        assert_eq!(
            Hit {
                triangle: 3,
                t: 1.0
            }
            .triangle(),
            Some(3)
        );
    }
}
