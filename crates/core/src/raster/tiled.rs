//! The tiled, multi-threaded driver: vertex transform, clipping, triangle setup and binning in
//! parallel over chunks of triangle ids, then rasterization in parallel over screen tiles.
//!
//! Based on: the sort-middle binning of common tiled software rasterizers (e.g. Abrash,
//! Rasterization on Larrabee, 2009; Intel's Masked Software Occlusion Culling, 2016), without
//! their SIMD coverage masks.
//!
//! Tiles are full-width bands of [`BAND_ROWS`] rows: each band is one contiguous slice of the
//! frame, so bands render in parallel through `par_chunks_mut` with no `unsafe`, and a band of a
//! 1024-wide frame (32 Ki pixels, 256 KiB of ids + depth) stays in a core's L2 cache.
//! Triangles are set up in chunks of [`CHUNK`] consecutive ids; each chunk keeps one list per
//! band, in id order, and a band walks the chunks in order, so every band sees its triangles in
//! increasing id order (the depth tie rule makes the result order-independent anyway).

use fixedbitset::FixedBitSet;
use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::camera::{Camera, ScreenMapping as Projection};
use crate::scene::Scene;
use crate::TriangleSet;

use super::clip::{clip_guard_band, clip_near, Poly, GUARD_BAND};
use super::frame::Frame;
use super::setup::{count_coverage, rasterize, setup, snap, Band, RasterTri};

/// Rows per tile (band). 32 keeps 32+ bands in flight at 1024² for load balance.
pub const BAND_ROWS: u32 = 32;
/// Triangles per setup chunk (the unit of parallel setup and binning).
pub const CHUNK: usize = 8192;

/// A scene vertex in view space, with its snapped screen position when it can skip clipping.
#[derive(Clone, Copy, Debug, Default)]
struct ViewVertex {
    /// `(right, up, forward)` coordinates, f64.
    view: DVec3,
    /// Snapped screen position; valid only when `fast`.
    fixed: [i32; 2],
    /// In front of the near plane and projected inside the guard band.
    fast: bool,
}

/// Set-up triangles of one chunk of ids and their per-band lists.
#[derive(Debug, Default)]
struct Chunk {
    tris: Vec<RasterTri>,
    /// `bins[band]`: indices into `tris`, increasing.
    bins: Vec<Vec<u32>>,
}

/// A reusable rasterizer for one scene: holds the per-vertex transform buffer and the setup and
/// binning buffers, so rendering many views reallocates nothing once warm.
///
/// ```
/// use glam::Vec3;
/// use sightline_core::raster::{Frame, Rasterizer};
/// use sightline_core::scene::SceneBuilder;
/// use sightline_core::Camera;
///
/// let mut b = SceneBuilder::new("box");
/// b.add_box(Vec3::new(-1.0, -1.0, 4.0), Vec3::new(1.0, 1.0, 5.0));
/// let scene = b.finish();
/// let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, 64, 64, 0.1).expect("camera");
/// let mut raster = Rasterizer::new(&scene);
/// let mut frame = Frame::new(1, 1);
/// raster.render(&cam, None, &mut frame);
/// assert!(frame.ids[32 * 64 + 32] < 12);
/// assert!((frame.depth[32 * 64 + 32] - 4.0).abs() < 1e-5);
/// ```
#[derive(Debug)]
pub struct Rasterizer<'a> {
    scene: &'a Scene,
    /// Triangles that may be drawn: indices in range, finite corners, non-zero area in 3D.
    drawable: FixedBitSet,
    view: Vec<ViewVertex>,
    chunks: Vec<Chunk>,
}

impl<'a> Rasterizer<'a> {
    /// Prepares `scene`. Triangles with out-of-range indices, non-finite corners or zero area
    /// (exactly collinear corners, tested in f64) are never drawn.
    pub fn new(scene: &'a Scene) -> Self {
        let n = scene.triangles.len();
        let mut drawable = FixedBitSet::with_capacity(n);
        for (id, t) in scene.triangles.iter().enumerate() {
            let corner = |i: u32| scene.positions.get(i as usize).copied();
            let (Some(a), Some(b), Some(c)) = (corner(t[0]), corner(t[1]), corner(t[2])) else {
                continue;
            };
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                continue;
            }
            let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
            if (b - a).cross(c - a) != DVec3::ZERO {
                drawable.insert(id);
            }
        }
        let chunks = (0..n.div_ceil(CHUNK)).map(|_| Chunk::default()).collect();
        Self {
            scene,
            drawable,
            view: vec![ViewVertex::default(); scene.positions.len()],
            chunks,
        }
    }

    /// Renders the scene (only the triangles in `filter`, when given) from `camera` into
    /// `frame`, which is resized to the camera's image and cleared first.
    pub fn render(&mut self, camera: &Camera, filter: Option<&TriangleSet>, frame: &mut Frame) {
        frame.reset(camera.width, camera.height);
        let proj = self.prepare(camera, filter);
        let width = camera.width;
        let band_len = (width * BAND_ROWS) as usize;
        let near = proj.near as f32;
        let chunks = &self.chunks;
        frame
            .ids
            .par_chunks_mut(band_len)
            .zip(frame.depth.par_chunks_mut(band_len))
            .enumerate()
            .for_each(|(b, (ids, depth))| {
                let mut band = Band {
                    width,
                    y_start: b as u32 * BAND_ROWS,
                    ids,
                    depth,
                };
                for chunk in chunks {
                    let Some(list) = chunk.bins.get(b) else {
                        continue;
                    };
                    for &k in list {
                        rasterize(&chunk.tris[k as usize], &mut band, near);
                    }
                }
            });
    }

    /// Debug coverage-count mode: for every pixel, how many triangles (in `filter`, when given)
    /// cover its centre, without any depth test. A single-layer mesh must give exactly 1 on every
    /// pixel it covers (no cracks, no double hits). `counts` is resized to the image.
    pub fn coverage_counts(
        &mut self,
        camera: &Camera,
        filter: Option<&TriangleSet>,
        counts: &mut Vec<u32>,
    ) {
        counts.clear();
        counts.resize((camera.width * camera.height) as usize, 0);
        self.prepare(camera, filter);
        for chunk in &self.chunks {
            for t in &chunk.tris {
                count_coverage(t, camera.width, counts);
            }
        }
    }

    /// Transforms the vertices, then clips, sets up and bins every drawable triangle.
    fn prepare(&mut self, camera: &Camera, filter: Option<&TriangleSet>) -> Projection {
        let proj = Projection::new(camera);
        let scene = self.scene;
        self.view
            .par_iter_mut()
            .zip(scene.positions.par_iter())
            .for_each(|(out, p)| {
                let view = proj.view_of(p.as_dvec3());
                let s = proj.screen_of(view);
                let fast = view.z >= proj.near
                    && s.is_finite()
                    && s.x.abs() <= GUARD_BAND
                    && s.y.abs() <= GUARD_BAND;
                *out = ViewVertex {
                    view,
                    fixed: if fast { [snap(s.x), snap(s.y)] } else { [0; 2] },
                    fast,
                };
            });
        let n_bands = camera.height.div_ceil(BAND_ROWS) as usize;
        let view = &self.view;
        let drawable = &self.drawable;
        self.chunks
            .par_iter_mut()
            .enumerate()
            .for_each(|(c, chunk)| {
                chunk.tris.clear();
                chunk.bins.resize_with(n_bands, Vec::new);
                for list in &mut chunk.bins {
                    list.clear();
                }
                let first = c * CHUNK;
                let last = (first + CHUNK).min(scene.triangles.len());
                for id in first..last {
                    if !drawable.contains(id) || filter.is_some_and(|f| !f.contains(id)) {
                        continue;
                    }
                    let [i0, i1, i2] = scene.triangles[id];
                    let corners = [view[i0 as usize], view[i1 as usize], view[i2 as usize]];
                    setup_triangle(&proj, id as u32, corners, camera, chunk);
                }
            });
        proj
    }
}

/// Clips (when needed), snaps, sets up and bins one triangle.
fn setup_triangle(
    proj: &Projection,
    id: u32,
    [a, b, c]: [ViewVertex; 3],
    camera: &Camera,
    chunk: &mut Chunk,
) {
    let Some(inv_z) = proj.inv_z_plane(a.view, b.view, c.view) else {
        return;
    };
    let mut emit = |v: [[i32; 2]; 3]| {
        if let Some(t) = setup(v, id, inv_z, camera.width, camera.height) {
            let k = chunk.tris.len() as u32;
            for band in u32::from(t.y0) / BAND_ROWS..=u32::from(t.y1) / BAND_ROWS {
                chunk.bins[band as usize].push(k);
            }
            chunk.tris.push(t);
        }
    };
    if a.fast && b.fast && c.fast {
        emit([a.fixed, b.fixed, c.fixed]);
        return;
    }
    let near = clip_near([a.view, b.view, c.view], proj.near);
    if near.len == 0 {
        return;
    }
    let mut screen = Poly::<DVec2>::new();
    for &v in near.as_slice() {
        let s = proj.screen_of(v);
        if !s.is_finite() {
            return;
        }
        screen.push(s);
    }
    let band = clip_guard_band(&screen);
    let n = band.len;
    if n < 3 {
        return;
    }
    let mut fixed = [[0i32; 2]; super::clip::MAX_POLY];
    for (f, s) in fixed.iter_mut().zip(band.as_slice()) {
        *f = [snap(s.x), snap(s.y)];
    }
    // The clipped polygon is convex: fan from its first vertex. Each piece carries the plane of
    // the whole triangle, so pieces of one triangle agree on depth along their shared diagonals.
    for k in 1..n - 1 {
        emit([fixed[0], fixed[k], fixed[k + 1]]);
    }
}
