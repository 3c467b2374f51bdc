//! The masked occlusion buffer (masked software occlusion culling): a software occlusion
//! buffer in which occluder triangles are rasterized into tiles of 8x4 pixels, each holding a
//! 32-bit coverage mask and two depth layers; boxes and triangles are tested against it
//! conservatively (a box may be reported visible when it is hidden, never the reverse).
//!
//! Based on: Andersson, Hasselgren, Akenine-Möller. Masked Depth Culling for Graphics Hardware.
//! 2015, section 3 (the two-layer tile: a reference layer valid for every pixel of the tile, a
//! working layer valid for the pixels of a coverage mask, merged with a depth-distance
//! discard heuristic); Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion
//! Culling. 2016 (its software form: per-scanline edge spans turned into masks by shifts,
//! depth as `1/z` so that it is affine in screen space, triangles clipped to a guard band).
//!
//! # Conventions
//! The camera conventions of [`sightline_core::camera`]: pixel `(x, y)` is sampled at its centre,
//! depth is the view depth `z` (distance along `forward`). Inside the buffer depth is stored as
//! `r = 1/z` (larger is nearer), because `1/z` of a planar triangle is an affine function of
//! the screen position, so the farthest point of a triangle over a tile is at a tile corner.
//! The buffer covers the camera's field of view with its own pixel grid (`width x height`).
//!
//! # Layout and kernels
//! Tiles are stored in blocks of 4x2 tiles (32x8 pixels), one array per field, as in the
//! paper's AVX2 form. The AVX2 kernel sets up 8 triangles at once (one per SIMD lane) and then
//! draws each triangle a block at a time (8 tiles per step: masks, depths and the tile merge
//! in SIMD). The scalar and SSE2 kernels, and the previous AVX2 kernel (kept as a baseline
//! for the bench, `BaselineKernel::Avx2PerTile`), set up one triangle and draw one tile at a
//! time. All use the same `f32` operations, so the buffers they produce are identical bit for
//! bit (checked by the tests).
//!
//! # Why it is conservative
//! - A tile's reference layer `z0` is a lower bound on `r` for every pixel of the tile, the
//!   working layer `z1` a lower bound for the pixels of `mask`. Both only ever come from the
//!   farthest value of an occluder over the pixels it covers (the plane's minimum over the tile,
//!   but never below the triangle's farthest vertex nor above its nearest), so they never
//!   claim an occluder nearer than it is.
//! - Coverage is the pixel-centre rule evaluated in `f32`: it agrees with the exact rule except
//!   for pixel centres within about 1/100 of a pixel of an edge. The box test widens a box's
//!   screen rectangle by one pixel on each side, so a box peeking out next to a silhouette is
//!   tested against the uncovered pixels beyond it.
//! - A box's depth is its nearest corner (the minimum view depth over a box is at a corner), and
//!   the comparison keeps a relative slack of [`DEPTH_SLACK`] for the rounding of `f32`.
//!
//! # Files, one job each
//! - `mod.rs`: this face: [`OcclusionBuffer`] and its documented methods, and the re-exports;
//!   none of the files below imports from it (the tests of `query.rs` aside).
//! - `constants.rs`: the tile size and the tests' tolerances ([`DEPTH_SLACK`], [`COVER_MARGIN`]).
//! - `project.rs`: view transform, projection, clipping to the near plane and the guard band,
//!   a box against the near plane (shared with [`Hzb`](crate::Hzb)).
//! - `tiles.rs`: the tile storage in 4x2-tile blocks and the two-layer tile merge;
//!   `block_storage.rs`: the blocks' memory, on huge pages for buffers of 512 KiB and more.
//! - `raster_kernel.rs`: the kernel trait, which every kernel implements.
//! - `kernel.rs`: [`Kernel`], the baseline kernels, CPU detection and dispatch (a new kernel is
//!   a new file plus its arms there).
//! - `per_tile.rs`: the tile-at-a-time rasterizer of the scalar, SSE2 and per-tile AVX2 kernels;
//!   `scalar.rs`, `sse2.rs`, `baseline.rs` (per-tile AVX2): their span and mask steps.
//! - `avx2/`: the batched AVX2 block kernel: `mod.rs` (batches, view transform, clipping
//!   choice), `setup.rs` (8 triangles set up at once), `blocks.rs` (a triangle drawn a block of
//!   4x2 tiles at a time, with the coarse depth cull of blocks and rows); and the AVX-512
//!   kernel, which shares the batches and the setup: `pairs.rs` (a triangle drawn two block
//!   rows at a time in 512-bit registers).
//! - `query.rs`: the box, rectangle and triangle tests and the per-pixel depth.

use glam::Vec3;
use sightline_core::{Aabb, Camera};

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod baseline;
mod block_storage;
mod constants;
mod kernel;
mod per_tile;
pub(crate) mod project;
mod query;
mod raster_kernel;
mod scalar;
#[cfg(target_arch = "x86_64")]
mod sse2;
mod tiles;

pub use constants::{COVER_MARGIN, DEPTH_SLACK, TILE_H, TILE_W};
pub use kernel::{BaselineKernel, Kernel};
use project::Projector;
use tiles::Tiles;

/// A conservative masked software depth buffer (masked occlusion culling). See the module
/// documentation.
///
/// ```
/// use glam::Vec3;
/// use sightline_core::{Aabb, Camera};
/// use sightline_cull::OcclusionBuffer;
///
/// let cam = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 128, 128, 0.1).unwrap();
/// let mut buffer = OcclusionBuffer::new(128, 128);
/// // A large wall at z = -5 in front of the camera.
/// let (a, b, c, d) = (
///     Vec3::new(-50.0, -50.0, -5.0), Vec3::new(50.0, -50.0, -5.0),
///     Vec3::new(50.0, 50.0, -5.0), Vec3::new(-50.0, 50.0, -5.0),
/// );
/// buffer.render_occluders(&[a, b, c, a, c, d], &cam);
/// let behind = Aabb::new(Vec3::new(-1.0, -1.0, -12.0), Vec3::new(1.0, 1.0, -10.0));
/// let before = Aabb::new(Vec3::new(-1.0, -1.0, -4.0), Vec3::new(1.0, 1.0, -3.0));
/// assert!(!buffer.test_box(&behind, &cam));
/// assert!(buffer.test_box(&before, &cam));
/// ```
#[derive(Clone, Debug)]
pub struct OcclusionBuffer {
    tiles: Tiles,
    /// Always one that [`Kernel::available`] accepts (see [`OcclusionBuffer::set_kernel`]).
    kernel: Kernel,
}

impl OcclusionBuffer {
    /// An empty (cleared) buffer of `width x height` pixels; sizes are clamped to at least 1.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            tiles: Tiles::new(width.max(1), height.max(1)),
            kernel: Kernel::detect(),
        }
    }

    /// The rasterization kernel in use (the best available one unless set).
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Selects a rasterization kernel; returns false (and keeps the current one) when the CPU
    /// does not support it. Every kernel produces the same buffer, bit for bit.
    pub fn set_kernel(&mut self, kernel: Kernel) -> bool {
        if kernel.available() {
            self.kernel = kernel;
        }
        self.kernel == kernel
    }

    /// True when both buffers have the same size and identical tiles (masks and depths).
    pub fn same_contents(&self, other: &Self) -> bool {
        self.tiles.same_contents(&other.tiles)
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.tiles.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.tiles.height
    }

    /// Removes every occluder.
    pub fn clear(&mut self) {
        self.tiles.clear();
    }

    /// Rasterizes occluder triangles, given as a flat list of corners (three per triangle; a
    /// trailing incomplete triangle is ignored), seen from `camera`. Triangles are double-sided;
    /// non-finite and degenerate ones are skipped.
    pub fn render_occluders(&mut self, triangles: &[Vec3], camera: &Camera) {
        let proj = Projector::new(camera, self.tiles.width, self.tiles.height);
        // SAFETY: `self.kernel` is only ever set after `Kernel::available` accepted it (see
        // `new` and `set_kernel`).
        unsafe { kernel::render(self.kernel, &mut self.tiles, triangles, &proj) };
    }

    /// [`OcclusionBuffer::render_occluders`] with a baseline kernel (for the bench and the
    /// kernel tests only): false, and nothing drawn, when the CPU does not support it.
    #[doc(hidden)]
    pub fn render_occluders_baseline(
        &mut self,
        kernel: BaselineKernel,
        triangles: &[Vec3],
        camera: &Camera,
    ) -> bool {
        let proj = Projector::new(camera, self.tiles.width, self.tiles.height);
        kernel::render_baseline(kernel, &mut self.tiles, triangles, &proj)
    }

    /// True when the box may be visible from `camera`: it crosses the near plane, or some pixel
    /// of its (widened) screen rectangle is not covered by a nearer occluder. A box entirely
    /// behind the near plane or outside the image is not visible.
    pub fn test_box(&self, aabb: &Aabb, camera: &Camera) -> bool {
        self.tiles.test_box(aabb, camera)
    }

    /// True when some pixel of the rectangle `[x0, x1) x [y0, y1)` (clamped to the buffer) may
    /// show a surface at view depth `nearest_depth`, i.e. is not covered by an occluder nearer
    /// than that. An empty rectangle is not visible; a depth that is not positive is visible.
    pub fn test_rect_depth(&self, x0: u32, y0: u32, x1: u32, y1: u32, nearest_depth: f32) -> bool {
        self.tiles.test_rect_depth(x0, y0, x1, y1, nearest_depth)
    }

    /// The conservative (farthest possible) occluder depth at pixel `(x, y)`:
    /// `f32::INFINITY` where nothing is known, `None` outside the buffer.
    pub fn depth_at(&self, x: u32, y: u32) -> Option<f32> {
        self.tiles.depth_at(x, y)
    }

    /// True when some of an object's triangles (three corners each, double-sided; a trailing
    /// incomplete triangle is ignored) may show at some pixel from `camera`: a tighter test
    /// than [`OcclusionBuffer::test_box`] for an object whose screen rectangle or nearest
    /// corner says little about where it really is. Conservative like the box test: each
    /// triangle is clipped to the near plane and the guard band, its coverage is widened by
    /// one pixel on each side (the box test's widening, for the same reason: occluder edges
    /// are rasterized in `f32`), and at each pixel its depth is the plane's nearest value over
    /// the pixels that pixel stands for, capped by the triangle's nearest corner, with
    /// [`DEPTH_SLACK`]. An object whose triangles cover no pixel centre (within
    /// [`COVER_MARGIN`] pixels) has no pixel in any image of this size and is not visible.
    /// Non-finite corners make the object visible.
    pub fn test_triangles(&self, triangles: &[Vec3], camera: &Camera) -> bool {
        self.tiles.test_triangles_widened(triangles, camera, 1.0)
    }

    /// True when some of the triangles (as in [`OcclusionBuffer::test_triangles`]) covers a
    /// pixel centre of the buffer's image, within [`COVER_MARGIN`] pixels, whatever is in
    /// front: false means the triangles have no pixel at all.
    pub fn covers_pixel_centre(&self, triangles: &[Vec3], camera: &Camera) -> bool {
        self.tiles.covers_pixel_centre(triangles, camera)
    }

    /// [`OcclusionBuffer::test_triangles`] with the coverage widened by `widen` pixels (0:
    /// plain pixel centres, which the diagnosis of the simulation uses to tell what the
    /// widening costs).
    pub(crate) fn test_triangles_widened(
        &self,
        triangles: &[Vec3],
        camera: &Camera,
        widen: f32,
    ) -> bool {
        self.tiles.test_triangles_widened(triangles, camera, widen)
    }
}
