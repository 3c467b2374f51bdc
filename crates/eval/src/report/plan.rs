//! The scene seen from above, shared by the map and its footprint: the projection onto the
//! ground plane along the scene's up axis ([`Plan`]) and the ground rectangle's pixel frame
//! ([`MapFrame`]).

use glam::Vec3;
use sightline_core::scene::UpAxis;
use sightline_core::Scene;
use sightline_region::ViewCell;

/// The projection onto the ground plane: `(right, forward)` coordinates seen from above with
/// right to the right and forward up the page, and the height along the scene's up axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    right: Vec3,
    forward: Vec3,
    up: Vec3,
}

impl Plan {
    /// Seen from above along `up`: Z-up scenes show (x, y); Y-up scenes show (x, -z) (looking
    /// down -Y with +X to the right, -Z points up the page); X-up scenes show (y, z).
    pub fn new(up: UpAxis) -> Self {
        match up {
            UpAxis::X => Self {
                right: Vec3::Y,
                forward: Vec3::Z,
                up: Vec3::X,
            },
            UpAxis::Z => Self {
                right: Vec3::X,
                forward: Vec3::Y,
                up: Vec3::Z,
            },
            UpAxis::Y => Self {
                right: Vec3::X,
                forward: Vec3::NEG_Z,
                up: Vec3::Y,
            },
        }
    }

    /// Ground-plane coordinates of `p`.
    pub fn project(&self, p: Vec3) -> [f64; 2] {
        [p.dot(self.right) as f64, p.dot(self.forward) as f64]
    }

    /// Height of `p`.
    pub fn height(&self, p: Vec3) -> f64 {
        p.dot(self.up) as f64
    }

    /// The unit axes `[right, forward, up]`: right and up the page, and up out of it.
    pub fn axes(&self) -> [Vec3; 3] {
        [self.right, self.forward, self.up]
    }
}

/// Ground-plane rectangle `[min, max]` mapped onto a `width x height` pixel image with `margin`
/// pixels around it, uniformly scaled (north up: larger forward is higher on the page).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct MapFrame {
    /// Lower-left ground corner.
    pub min: [f64; 2],
    /// Pixels per ground unit.
    pub scale: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Pixels left free on each side.
    pub margin: f64,
}

impl MapFrame {
    /// The frame of `[min, max]` fitting in `max_width x max_height` pixels (the longer side
    /// fills it; the other is shrunk to keep the aspect ratio). A zero-size rectangle is grown
    /// to one unit.
    pub(crate) fn new(
        min: [f64; 2],
        max: [f64; 2],
        max_width: u32,
        max_height: u32,
        margin: f64,
    ) -> Self {
        let ext = [(max[0] - min[0]).max(1e-9), (max[1] - min[1]).max(1e-9)];
        let (ext, min) = if ext[0] <= 1e-9 && ext[1] <= 1e-9 {
            ([1.0, 1.0], [min[0] - 0.5, min[1] - 0.5])
        } else {
            (ext, min)
        };
        let avail = [
            (max_width as f64 - 2.0 * margin).max(1.0),
            (max_height as f64 - 2.0 * margin).max(1.0),
        ];
        let scale = (avail[0] / ext[0]).min(avail[1] / ext[1]);
        Self {
            min,
            scale,
            width: ((ext[0] * scale + 2.0 * margin).round() as u32).clamp(1, max_width.max(1)),
            height: ((ext[1] * scale + 2.0 * margin).round() as u32).clamp(1, max_height.max(1)),
            margin,
        }
    }

    /// The frame around `scene` and `cells` from above, 4 % larger on each side.
    pub(crate) fn around(
        scene: &Scene,
        cells: &[ViewCell],
        plan: &Plan,
        max_width: u32,
        max_height: u32,
    ) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let b = scene.bounds();
        let scene_corners = (0..8).map(|k| {
            Vec3::new(
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            )
        });
        let points = scene_corners.chain(cells.iter().flat_map(|c| c.corners()));
        for p in points.filter(|p| p.is_finite()) {
            let q = plan.project(p);
            for k in 0..2 {
                lo[k] = lo[k].min(q[k]);
                hi[k] = hi[k].max(q[k]);
            }
        }
        if lo[0] > hi[0] {
            (lo, hi) = ([0.0; 2], [1.0; 2]);
        }
        let pad = 0.04 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
        Self::new(
            [lo[0] - pad, lo[1] - pad],
            [hi[0] + pad, hi[1] + pad],
            max_width,
            max_height,
            0.0,
        )
    }

    /// Pixel position of ground point `q` (y grows downwards).
    pub(crate) fn pixel_of(&self, q: [f64; 2]) -> (f64, f64) {
        let x = self.margin + (q[0] - self.min[0]) * self.scale;
        let y = self.height as f64 - self.margin - (q[1] - self.min[1]) * self.scale;
        (x, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_maps_corners_to_image_corners() {
        let f = MapFrame::new([10.0, 20.0], [30.0, 30.0], 400, 400, 5.0);
        assert_eq!((f.width, f.height), (400, 205));
        assert_eq!(f.scale, 19.5);
        assert_eq!(f.pixel_of([10.0, 20.0]), (5.0, 200.0));
        assert_eq!(f.pixel_of([30.0, 30.0]), (395.0, 5.0));
    }

    #[test]
    fn frame_of_a_point_is_not_degenerate() {
        let f = MapFrame::new([1.0, 1.0], [1.0, 1.0], 100, 100, 0.0);
        assert!(f.scale.is_finite() && f.scale > 0.0);
        let (x, y) = f.pixel_of([1.0, 1.0]);
        assert!((0.0..=100.0).contains(&x) && (0.0..=100.0).contains(&y));
    }

    #[test]
    fn frame_around_contains_scene_and_cells() {
        let mut b = sightline_core::scene::SceneBuilder::new("box");
        b.add_box(Vec3::new(0.0, 0.0, 0.0), Vec3::new(10.0, 5.0, 2.0));
        let mut scene = b.finish();
        scene.up = UpAxis::Z;
        let cell = ViewCell::aabb(Vec3::new(12.0, -3.0, 0.0), Vec3::new(14.0, -1.0, 1.0)).unwrap();
        let plan = Plan::new(UpAxis::Z);
        let f = MapFrame::around(&scene, &[cell], &plan, 500, 500);
        for p in [
            Vec3::ZERO,
            Vec3::new(10.0, 5.0, 0.0),
            Vec3::new(14.0, -3.0, 0.0),
        ] {
            let (x, y) = f.pixel_of(plan.project(p));
            assert!(x > 0.0 && x < f.width as f64, "{p}: x {x}");
            assert!(y > 0.0 && y < f.height as f64, "{p}: y {y}");
        }
    }

    #[test]
    fn y_up_plan_puts_minus_z_up_the_page() {
        let plan = Plan::new(UpAxis::Y);
        assert_eq!(plan.project(Vec3::new(1.0, 7.0, -2.0)), [1.0, 2.0]);
        assert_eq!(plan.height(Vec3::new(1.0, 7.0, -2.0)), 7.0);
    }
}
