//! Per-frame occlusion culling of a static scene in chunks with the software occlusion buffer:
//! triangles are grouped into chunks by a uniform grid over their centroids; every frame the
//! chunks are visited front to back (by the distance from the eye to their box), each chunk's
//! box is tested against the occluders rendered so far, and a chunk that may be visible is
//! drawn and its triangles rendered as occluders. This is the "stop-and-wait" loop of the
//! thesis with a software buffer that answers at once, so it has no frame of latency.
//!
//! Based on: Seletsky. Real Time Visibility Culling With Hardware Occlusion Queries and Uniform
//! Grids. 2013, section 4.3 (front-to-back traversal, queries against the depth drawn so far);
//! Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016 (the buffer,
//! `sightline_cull::OcclusionBuffer`).
//!
//! The buffer's box test is conservative for the buffer's own pixel grid; drawn at another
//! resolution than the image, an occluder may cover a buffer pixel centre but not every image
//! pixel centre in it, so popping is possible and is what the viewer measures.

use glam::Vec3;
use sightline_core::{Aabb, Camera, Scene, TriangleSet};
use sightline_cull::OcclusionBuffer;

/// Triangles per chunk the grid aims at: large enough that a chunk's occluders amortise its
/// box test, small enough that the boxes are tight.
pub const TRIANGLES_PER_CHUNK: usize = 256;

/// The scene cut into chunks.
#[derive(Clone, Debug, Default)]
struct Chunks {
    boxes: Vec<Aabb>,
    triangles: Vec<Vec<u32>>,
    /// The triangles' corners, three per triangle, per chunk.
    corners: Vec<Vec<Vec3>>,
}

impl Chunks {
    fn new(scene: &Scene, per_chunk: usize) -> Self {
        let n = scene.triangle_count();
        let bounds = scene.bounds();
        if n == 0 || bounds.is_empty() {
            return Self::default();
        }
        let dims = grid_dims(bounds.extent(), n.div_ceil(per_chunk.max(1)));
        let cell_count = dims.iter().product::<u32>() as usize;
        let mut triangles: Vec<Vec<u32>> = vec![Vec::new(); cell_count];
        let extent = bounds.extent().max(Vec3::splat(1e-30));
        for t in 0..n as u32 {
            let [a, b, c] = scene.triangle(t);
            let centroid = (a + b + c) / 3.0;
            let rel = (centroid - bounds.min) / extent;
            let cell = |k: usize| {
                let v = (rel[k] * dims[k] as f32).floor();
                // Non-finite or outside (rounding): clamp into the grid.
                if v.is_finite() {
                    (v.max(0.0) as u32).min(dims[k] - 1)
                } else {
                    0
                }
            };
            let i = cell(0) + dims[0] * (cell(1) + dims[1] * cell(2));
            triangles[i as usize].push(t);
        }
        triangles.retain(|ts| !ts.is_empty());
        Self::from_lists(scene, triangles)
    }

    /// Chunks of the given triangle lists (each non-empty).
    fn from_lists(scene: &Scene, triangles: Vec<Vec<u32>>) -> Self {
        let mut chunks = Self::default();
        for ts in triangles {
            let mut aabb = Aabb::EMPTY;
            let mut corners = Vec::with_capacity(ts.len() * 3);
            for &t in &ts {
                for p in scene.triangle(t) {
                    aabb.grow(p);
                    corners.push(p);
                }
            }
            chunks.boxes.push(aabb);
            chunks.triangles.push(ts);
            chunks.corners.push(corners);
        }
        chunks
    }
}

/// Grid dimensions over a box of `extent` with about `cells` cells of equal size: the cell
/// side is searched so that the product of `max(1, ceil(extent / side))` reaches `cells`, so a
/// flat scene gets a flat grid.
fn grid_dims(extent: Vec3, cells: usize) -> [u32; 3] {
    let cells = cells.clamp(1, 1 << 16) as f64;
    let dims_for = |side: f64| -> [u32; 3] {
        std::array::from_fn(|k| ((f64::from(extent[k]) / side).ceil().max(1.0) as u32).min(1024))
    };
    let count = |d: [u32; 3]| d.iter().map(|&v| f64::from(v)).product::<f64>();
    let (mut lo, mut hi) = (1e-12f64, f64::from(extent.max_element()).max(1e-12));
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        if count(dims_for(mid)) > cells {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    dims_for(hi)
}

/// What one frame of occlusion culling did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OcclusionStats {
    /// Chunks whose box was tested.
    pub chunks_tested: u32,
    /// Chunks drawn.
    pub chunks_drawn: u32,
}

/// The chunked occlusion culler. See the module documentation.
#[derive(Clone, Debug)]
pub struct OcclusionCuller {
    chunks: Chunks,
    buffer: OcclusionBuffer,
    order: Vec<(f32, u32)>,
}

impl OcclusionCuller {
    /// Chunks `scene` (about [`TRIANGLES_PER_CHUNK`] triangles each) and allocates a
    /// `width x height` occlusion buffer.
    pub fn new(scene: &Scene, width: u32, height: u32) -> Self {
        Self {
            chunks: Chunks::new(scene, TRIANGLES_PER_CHUNK),
            buffer: OcclusionBuffer::new(width, height),
            order: Vec::new(),
        }
    }

    /// Number of chunks.
    pub fn chunk_count(&self) -> usize {
        self.chunks.boxes.len()
    }

    /// The buffer's size.
    pub fn buffer_size(&self) -> (u32, u32) {
        (self.buffer.width(), self.buffer.height())
    }

    /// Resizes the occlusion buffer (a no-op at the same size).
    pub fn resize(&mut self, width: u32, height: u32) {
        if (width.max(1), height.max(1)) != self.buffer_size() {
            self.buffer = OcclusionBuffer::new(width, height);
        }
    }

    /// Culls for `camera`: sets in `drawn` (cleared first, grown to `triangle_count`) the
    /// triangles of every chunk that may be visible.
    pub fn cull(
        &mut self,
        camera: &Camera,
        triangle_count: usize,
        drawn: &mut TriangleSet,
    ) -> OcclusionStats {
        drawn.clear();
        drawn.grow(triangle_count);
        self.buffer.clear();
        let eye = camera.eye;
        self.order.clear();
        for (i, b) in self.chunks.boxes.iter().enumerate() {
            let d = (eye.clamp(b.min, b.max) - eye).length_squared();
            self.order.push((d, i as u32));
        }
        self.order
            .sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut stats = OcclusionStats::default();
        for &(_, i) in &self.order {
            let i = i as usize;
            stats.chunks_tested += 1;
            // `test_box` is also the frustum test: a box outside the image is not visible.
            if !self.buffer.test_box(&self.chunks.boxes[i], camera) {
                continue;
            }
            stats.chunks_drawn += 1;
            for &t in &self.chunks.triangles[i] {
                drawn.insert(t as usize);
            }
            self.buffer
                .render_occluders(&self.chunks.corners[i], camera);
        }
        stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;

    /// A big wall at x = 0 and a small box behind it at x = 10, seen from x = -10.
    fn wall_and_box() -> Scene {
        let mut b = SceneBuilder::new("wall");
        let q = |b: &mut SceneBuilder, x: f32, h: f32| {
            let p = [
                b.add_vertex(Vec3::new(x, -h, -h)),
                b.add_vertex(Vec3::new(x, h, -h)),
                b.add_vertex(Vec3::new(x, h, h)),
                b.add_vertex(Vec3::new(x, -h, h)),
            ];
            b.add_triangle([p[0], p[1], p[2]]);
            b.add_triangle([p[0], p[2], p[3]]);
        };
        q(&mut b, 0.0, 50.0);
        q(&mut b, 10.0, 1.0);
        b.finish()
    }

    fn camera() -> Camera {
        Camera::look_at(
            Vec3::new(-10.0, 0.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            60.0,
            64,
            64,
            0.01,
        )
        .unwrap()
    }

    #[test]
    fn grid_dims_reach_the_cell_count_and_stay_flat() {
        let d = grid_dims(Vec3::new(100.0, 100.0, 0.0), 16);
        assert_eq!(d[2], 1);
        assert!(d[0] * d[1] >= 16 && d[0] * d[1] <= 36, "{d:?}");
        assert_eq!(grid_dims(Vec3::ONE, 1), [1, 1, 1]);
    }

    #[test]
    fn empty_scene_has_no_chunks_and_draws_nothing() {
        let mut c = OcclusionCuller::new(&Scene::default(), 16, 16);
        assert_eq!(c.chunk_count(), 0);
        let mut set = TriangleSet::new();
        let stats = c.cull(&camera(), 0, &mut set);
        assert_eq!(set.count_ones(..), 0);
        assert_eq!(stats, OcclusionStats::default());
    }

    #[test]
    fn chunks_hold_every_triangle_once() {
        let scene = wall_and_box();
        let chunks = Chunks::new(&scene, 1);
        let mut all: Vec<u32> = chunks.triangles.concat();
        all.sort_unstable();
        assert_eq!(all, vec![0, 1, 2, 3]);
    }

    #[test]
    fn box_behind_the_wall_is_culled() {
        let scene = wall_and_box();
        let mut c = OcclusionCuller {
            chunks: Chunks::from_lists(&scene, vec![vec![0, 1], vec![2, 3]]),
            buffer: OcclusionBuffer::new(64, 64),
            order: Vec::new(),
        };
        assert_eq!(c.chunk_count(), 2);
        let mut set = TriangleSet::new();
        let stats = c.cull(&camera(), 4, &mut set);
        assert_eq!(set.ones().collect::<Vec<_>>(), vec![0, 1]);
        assert_eq!(stats.chunks_drawn, 1);
        // Seen from behind the small box, both are drawn.
        let back = Camera::look_at(
            Vec3::new(20.0, 0.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            60.0,
            64,
            64,
            0.01,
        )
        .unwrap();
        c.cull(&back, 4, &mut set);
        assert_eq!(set.count_ones(..), 4);
    }
}
