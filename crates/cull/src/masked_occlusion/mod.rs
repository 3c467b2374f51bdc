//! A software occlusion buffer: occluder triangles are rasterized into tiles of 8x4 pixels, each
//! holding a 32-bit coverage mask and two depth layers; boxes are tested against it
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
//! in SIMD). The scalar and SSE2 kernels, and the previous AVX2 kernel (`Kernel::Avx2PerTile`),
//! set up one triangle and draw one tile at a time. All use the same `f32` operations, so the
//! buffers they produce are identical bit for bit (checked by the tests).
//!
//! # Why it is conservative
//! - A tile's reference layer `z0` is a lower bound on `r` for every pixel of the tile, the
//!   working layer `z1` a lower bound for the pixels of `mask`. Both only ever come from the
//!   farthest value of an occluder over the pixels it covers (the plane's minimum over the tile,
//!   but never below the triangle's farthest vertex), so they never claim an occluder nearer
//!   than it is.
//! - Coverage is the pixel-centre rule evaluated in `f32`: it agrees with the exact rule except
//!   for pixel centres within about 1/100 of a pixel of an edge. The box test widens a box's
//!   screen rectangle by one pixel on each side, so a box peeking out next to a silhouette is
//!   tested against the uncovered pixels beyond it.
//! - A box's depth is its nearest corner (the minimum view depth over a box is at a corner), and
//!   the comparison keeps a relative slack of [`DEPTH_SLACK`] for the rounding of `f32`.

use glam::Vec3;
use sightline_core::{Aabb, Camera};

mod kernels;
pub(crate) mod project;
pub use kernels::Kernel;
use kernels::{BlockGrid, ColClamp, Edges, Screen8, Setup8, TileRowSpans, SCALAR};
#[cfg(target_arch = "x86_64")]
use kernels::{AVX2, AVX2_PER_TILE, SSE2, SSE2_PER_TILE};
#[cfg(target_arch = "x86_64")]
use project::GUARD;
use project::{ceil_i, floor_i, screen_bounds, BoxView, Projector, ViewTriangle};

/// Tile width in pixels (a row of a tile is one byte of the mask).
pub const TILE_W: u32 = 8;
/// Tile height in pixels.
pub const TILE_H: u32 = 4;
/// Relative slack on `1/z` when comparing a box with the buffer: the box is treated as this
/// much nearer than it is, which absorbs the `f32` rounding of both sides (about 1e-6
/// relative inside the guard band) with a wide margin.
pub const DEPTH_SLACK: f32 = 2e-5;
/// Margin in pixels of [`OcclusionBuffer::covers_pixel_centre`]: far above the `f32` error of
/// screen positions inside the guard band (about 1/100 px) and the reference rasterizer's
/// snapping of vertices to 1/256 px.
pub const COVER_MARGIN: f32 = 1.0 / 16.0;
const FULL: u32 = u32::MAX;

/// Pixel centres under a widened screen triangle's bounding box.
enum CentreRange {
    /// A corner is not finite: the caller must stay conservative.
    NotFinite,
    /// No pixel centre of the image.
    Empty,
    /// Inclusive `(col0, col1, row0, row1)`.
    Pixels((i32, i32, i32, i32)),
}

/// One 8x4 tile: reference layer, working layer and the working layer's coverage.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Tile {
    /// Every pixel of the tile has `1/z >= z0` (0 = nothing drawn, infinitely far).
    z0: f32,
    /// Every pixel in `mask` has `1/z >= z1`; `z1 > z0` whenever `mask != 0`.
    z1: f32,
    /// Pixels of the working layer, bit `8 * row + column`.
    mask: u32,
}

#[cfg(test)]
const CLEAR_TILE: Tile = Tile {
    z0: 0.0,
    z1: 0.0,
    mask: 0,
};

/// Tiles per block, across and down.
const BLOCK_TX: u32 = 4;
const BLOCK_TY: u32 = 2;

/// The storage of 4x2 tiles (32x8 pixels), one array per field with tile `4 * row + column`
/// in element `i`: the AVX2 kernel loads, merges and stores the 8 tiles of a block as three
/// 8-lane registers (the layout of Hasselgren et al. 2016, section 4).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, PartialEq)]
struct Block {
    z0: [f32; 8],
    z1: [f32; 8],
    mask: [u32; 8],
}

const CLEAR_BLOCK: Block = Block {
    z0: [0.0; 8],
    z1: [0.0; 8],
    mask: [0; 8],
};

/// A conservative masked software depth buffer. See the module documentation.
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
    width: u32,
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    /// Blocks across (`tiles_x / 4` rounded up); tiles beyond the image in the last block
    /// column / row are never drawn.
    blocks_x: u32,
    /// Mask bits of the last tile column / row that lie outside the image: they count as
    /// covered by every occluder, so that edge tiles can become full.
    outside_x: u32,
    outside_y: u32,
    blocks: Vec<Block>,
    kernel: Kernel,
}

impl OcclusionBuffer {
    /// An empty (cleared) buffer of `width x height` pixels; sizes are clamped to at least 1.
    pub fn new(width: u32, height: u32) -> Self {
        let width = width.max(1);
        let height = height.max(1);
        let tiles_x = width.div_ceil(TILE_W);
        let tiles_y = height.div_ceil(TILE_H);
        let cols_in = width - (tiles_x - 1) * TILE_W;
        let rows_in = height - (tiles_y - 1) * TILE_H;
        let row_bits = ((1u32 << TILE_W) - 1) ^ ((1u32 << cols_in) - 1);
        let outside_x = row_bits.wrapping_mul(0x0101_0101);
        let outside_y = !(((1u64 << (TILE_W * rows_in)) - 1) as u32);
        Self {
            width,
            height,
            tiles_x,
            tiles_y,
            blocks_x: tiles_x.div_ceil(BLOCK_TX),
            outside_x,
            outside_y,
            blocks: vec![
                CLEAR_BLOCK;
                (tiles_x.div_ceil(BLOCK_TX) * tiles_y.div_ceil(BLOCK_TY)) as usize
            ],
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
        self.width == other.width && self.height == other.height && self.blocks == other.blocks
    }

    /// Block index and lane of tile `(tx, ty)`.
    #[inline(always)]
    fn slot(&self, tx: u32, ty: u32) -> (usize, usize) {
        let block = (ty / BLOCK_TY) * self.blocks_x + tx / BLOCK_TX;
        let lane = (ty % BLOCK_TY) * BLOCK_TX + tx % BLOCK_TX;
        (block as usize, lane as usize)
    }

    /// Tile `(tx, ty)` (inside the buffer).
    #[inline(always)]
    fn tile(&self, tx: u32, ty: u32) -> Tile {
        let (b, l) = self.slot(tx, ty);
        let b = &self.blocks[b];
        Tile {
            z0: b.z0[l],
            z1: b.z1[l],
            mask: b.mask[l],
        }
    }

    /// Merges coverage `cov` at `1/z` value `r` into tile `(tx, ty)` with [`update_tile`].
    #[inline(always)]
    fn update(&mut self, tx: u32, ty: u32, cov: u32, r: f32) {
        let (b, l) = self.slot(tx, ty);
        let b = &mut self.blocks[b];
        let mut t = Tile {
            z0: b.z0[l],
            z1: b.z1[l],
            mask: b.mask[l],
        };
        update_tile(&mut t, cov, r);
        (b.z0[l], b.z1[l], b.mask[l]) = (t.z0, t.z1, t.mask);
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Removes every occluder.
    pub fn clear(&mut self) {
        self.blocks.fill(CLEAR_BLOCK);
    }

    /// Rasterizes occluder triangles, given as a flat list of corners (three per triangle; a
    /// trailing incomplete triangle is ignored), seen from `camera`. Triangles are double-sided;
    /// non-finite and degenerate ones are skipped.
    pub fn render_occluders(&mut self, triangles: &[Vec3], camera: &Camera) {
        match self.kernel {
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2 => {
                // SAFETY: `self.kernel` is only ever `Avx2` after `Kernel::available` saw
                // `is_x86_feature_detected!("avx2")` (see `set_kernel` and `new`).
                unsafe { self.render_avx2(triangles, camera) }
            }
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2PerTile => {
                // SAFETY: as for `Avx2`, `available` checked AVX2 support.
                unsafe { self.render_avx2_per_tile(triangles, camera) }
            }
            #[cfg(target_arch = "x86_64")]
            Kernel::Sse2 => self.render_with::<SSE2>(triangles, camera),
            #[cfg(target_arch = "x86_64")]
            Kernel::Sse2PerTile => self.render_with::<SSE2_PER_TILE>(triangles, camera),
            _ => self.render_with::<SCALAR>(triangles, camera),
        }
    }

    /// The AVX2 entry point: the generic rasterizer compiled with AVX2 enabled, so that its
    /// `#[inline(always)]` body and the AVX2 mask kernel are inlined into one function.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn render_avx2(&mut self, triangles: &[Vec3], camera: &Camera) {
        self.render_with::<AVX2>(triangles, camera);
    }

    /// The previous AVX2 kernel, see [`Self::render_avx2`].
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn render_avx2_per_tile(&mut self, triangles: &[Vec3], camera: &Camera) {
        self.render_with::<AVX2_PER_TILE>(triangles, camera);
    }

    #[inline(always)]
    fn render_with<const K: u8>(&mut self, triangles: &[Vec3], camera: &Camera) {
        let proj = Projector::new(camera, self.width, self.height);
        #[cfg(target_arch = "x86_64")]
        if K == AVX2 {
            // SAFETY: `K == AVX2` only inside `render_avx2`, which the dispatcher calls only
            // after `is_x86_feature_detected!("avx2")`.
            unsafe { self.render_batches_avx2(triangles, &proj) };
            return;
        }
        // The SIMD kernels run one triangle behind the projection and prefetch the tiles of
        // the next triangle while rasterizing the current one: with scattered triangles the
        // tile loads miss the cache and dominate otherwise. The order of rasterization (which
        // the tile merge depends on) is unchanged.
        let mut queued: Option<[[f32; 3]; 3]> = None;
        for t in triangles.chunks_exact(3) {
            match proj.triangle(t) {
                ViewTriangle::NotFinite | ViewTriangle::Behind => {}
                ViewTriangle::Inside(s) => {
                    if K == SCALAR {
                        self.raster_triangle::<K>(s);
                        continue;
                    }
                    self.prefetch(&s);
                    if let Some(q) = queued.replace(s) {
                        self.raster_triangle::<K>(q);
                    }
                }
                ViewTriangle::Clip(v) => {
                    if let Some(q) = queued.take() {
                        self.raster_triangle::<K>(q);
                    }
                    self.raster_clipped::<K>(v, &proj);
                }
            }
        }
        if let Some(q) = queued {
            self.raster_triangle::<K>(q);
        }
    }

    /// The block grid for the AVX2 kernel.
    #[cfg(target_arch = "x86_64")]
    fn grid(&self) -> BlockGrid {
        BlockGrid {
            blocks_x: self.blocks_x,
            last_tx: self.tiles_x - 1,
            last_ty: self.tiles_y - 1,
            outside_x: self.outside_x,
            outside_y: self.outside_y,
        }
    }

    /// The AVX2 rasterizer: triangles in batches of 8, one per lane, through the view
    /// transform, the choice between culling, clipping and the fast path (every corner in
    /// front of the near plane and inside the guard band), projection and setup; then the
    /// batch's triangles are drawn in their order (clipped ones through [`Self::raster_clipped`])
    /// after prefetching their first blocks. Same arithmetic as the per-triangle path.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn render_batches_avx2(&mut self, triangles: &[Vec3], proj: &Projector) {
        use std::arch::x86_64::*;
        let grid = self.grid();
        let mut setup = Setup8::ZERO;
        let mut s = Screen8 {
            x: [[0.0; 8]; 3],
            y: [[0.0; 8]; 3],
            r: [[0.0; 8]; 3],
        };
        // View-space corners, `[corner][lane]`.
        let mut vx = [[0f32; 8]; 3];
        let mut vy = [[0f32; 8]; 3];
        let mut vz = [[0f32; 8]; 3];
        let set1 = _mm256_set1_ps;
        let (ex, ey, ez) = (set1(proj.eye.x), set1(proj.eye.y), set1(proj.eye.z));
        let axes = [proj.right, proj.up, proj.forward].map(|a| (set1(a.x), set1(a.y), set1(a.z)));
        let near = set1(proj.near);
        let (gx, gy) = (set1(GUARD * proj.tan_x), set1(GUARD * proj.tan_y));
        let (kx, nky, cx, cy) = (set1(proj.kx), set1(-proj.ky), set1(proj.cx), set1(proj.cy));
        let abs = |v: __m256| _mm256_andnot_ps(set1(-0.0), v);
        let inf = set1(f32::INFINITY);
        for batch in triangles.chunks(24) {
            let n = batch.len() / 3;
            if n == 0 {
                break;
            }
            // Lanes past the end repeat the last triangle; they are never drawn.
            let mut wx = [_mm256_setzero_ps(); 3];
            let mut wy = [_mm256_setzero_ps(); 3];
            let mut wz = [_mm256_setzero_ps(); 3];
            for j in 0..3 {
                let corner = |l: usize| batch[3 * l.min(n - 1) + j];
                let c: [Vec3; 8] = std::array::from_fn(corner);
                wx[j] = _mm256_setr_ps(
                    c[0].x, c[1].x, c[2].x, c[3].x, c[4].x, c[5].x, c[6].x, c[7].x,
                );
                wy[j] = _mm256_setr_ps(
                    c[0].y, c[1].y, c[2].y, c[3].y, c[4].y, c[5].y, c[6].y, c[7].y,
                );
                wz[j] = _mm256_setr_ps(
                    c[0].z, c[1].z, c[2].z, c[3].z, c[4].z, c[5].z, c[6].z, c[7].z,
                );
            }
            let mut behind = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
            let mut finite = behind;
            let mut guard = behind;
            for j in 0..3 {
                let (dx, dy, dz) = (
                    _mm256_sub_ps(wx[j], ex),
                    _mm256_sub_ps(wy[j], ey),
                    _mm256_sub_ps(wz[j], ez),
                );
                // `Vec3::dot`: (x * x') + (y * y') + (z * z').
                let [v_x, v_y, v_z] = axes.map(|(ax, ay, az)| {
                    _mm256_add_ps(
                        _mm256_add_ps(_mm256_mul_ps(dx, ax), _mm256_mul_ps(dy, ay)),
                        _mm256_mul_ps(dz, az),
                    )
                });
                behind = _mm256_and_ps(behind, _mm256_cmp_ps::<_CMP_LT_OQ>(v_z, near));
                for v in [v_x, v_y, v_z] {
                    finite = _mm256_and_ps(finite, _mm256_cmp_ps::<_CMP_LT_OQ>(abs(v), inf));
                }
                // `Projector::inside_guard`.
                let inside = _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(v_z, near),
                    _mm256_and_ps(
                        _mm256_cmp_ps::<_CMP_LE_OQ>(abs(v_x), _mm256_mul_ps(gx, v_z)),
                        _mm256_cmp_ps::<_CMP_LE_OQ>(abs(v_y), _mm256_mul_ps(gy, v_z)),
                    ),
                );
                guard = _mm256_and_ps(guard, inside);
                // `Projector::screen` (garbage in lanes that are not drawn this way).
                let r = _mm256_div_ps(set1(1.0), v_z);
                // SAFETY: stores of 8 lanes into `[f32; 8]` arrays (those of `s` aligned).
                unsafe {
                    _mm256_store_ps(
                        s.x[j].as_mut_ptr(),
                        _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(kx, v_x), r), cx),
                    );
                    _mm256_store_ps(
                        s.y[j].as_mut_ptr(),
                        _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(nky, v_y), r), cy),
                    );
                    _mm256_store_ps(s.r[j].as_mut_ptr(), r);
                    _mm256_storeu_ps(vx[j].as_mut_ptr(), v_x);
                    _mm256_storeu_ps(vy[j].as_mut_ptr(), v_y);
                    _mm256_storeu_ps(vz[j].as_mut_ptr(), v_z);
                }
            }
            let skip = _mm256_movemask_ps(_mm256_or_ps(
                behind,
                _mm256_xor_ps(finite, _mm256_castsi256_ps(_mm256_set1_epi32(-1))),
            )) as u32;
            let fast = _mm256_movemask_ps(guard) as u32 & !skip;
            let draw = kernels::setup8_avx2(&s, self.width, self.height, &mut setup) & fast;
            for l in 0..n {
                if draw & (1 << l) != 0 {
                    self.prefetch_blocks(&setup, l);
                }
            }
            for l in 0..n {
                let bit = 1 << l;
                if draw & bit != 0 {
                    // SAFETY: this function requires AVX2.
                    unsafe { kernels::raster_blocks_avx2(&mut self.blocks, &grid, &setup, l) };
                } else if (fast | skip) & bit == 0 {
                    let v = [0, 1, 2].map(|j| Vec3::new(vx[j][l], vy[j][l], vz[j][l]));
                    self.raster_clipped::<AVX2>(v, proj);
                }
            }
        }
    }

    /// Prefetches the blocks of the first block column of lane `l`'s bounding box (up to
    /// two block rows: 16 scanlines).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn prefetch_blocks(&self, setup: &Setup8, l: usize) {
        let (row0, row1, col0, _) = setup.bbox(l);
        let ty0 = row0 as u32 / TILE_H;
        self.prefetch_block_rows(col0 as u32 / TILE_W, ty0, row1 as u32 / TILE_H);
    }

    /// Prefetches the first tile of each tile row a triangle's bounding box touches.
    #[inline(always)]
    fn prefetch(&self, p: &[[f32; 3]; 3]) {
        let ymin = p[0][1].min(p[1][1]).min(p[2][1]);
        let ymax = p[0][1].max(p[1][1]).max(p[2][1]);
        let xmin = p[0][0].min(p[1][0]).min(p[2][0]);
        // Saturating float-to-int casts, clamped into the buffer: only valid tiles.
        let clamp_x = |v: f32| (v as i32).clamp(0, self.width as i32 - 1) as u32;
        let clamp_y = |v: f32| (v as i32).clamp(0, self.height as i32 - 1) as u32;
        let ty0 = clamp_y(ymin) / TILE_H;
        self.prefetch_block_rows(clamp_x(xmin) / TILE_W, ty0, clamp_y(ymax) / TILE_H);
    }

    /// Prefetches the blocks holding tile column `tx` of tile rows `ty0..=ty1`, at most the
    /// first four rows (two blocks).
    #[inline(always)]
    fn prefetch_block_rows(&self, tx: u32, ty0: u32, ty1: u32) {
        for by in ty0 / BLOCK_TY..=ty1.min(ty0 + 3) / BLOCK_TY {
            if let Some(block) = self.blocks.get(self.slot(tx, by * BLOCK_TY).0) {
                sightline_core::prefetch::prefetch(block);
            }
        }
    }

    /// Clips a view-space triangle to the near plane and the guard band, then fans it out.
    fn raster_clipped<const K: u8>(&mut self, v: [Vec3; 3], proj: &Projector) {
        proj.clipped_fan(v, |s| {
            self.raster_triangle::<K>(s);
            false
        });
    }

    /// Rasterizes one triangle given as `[sx, sy, 1/z]` per corner, all inside the guard band.
    #[inline(always)]
    fn raster_triangle<const K: u8>(&mut self, mut p: [[f32; 3]; 3]) {
        #[cfg(target_arch = "x86_64")]
        if K == AVX2 {
            // The batched setup with this triangle alone in lane 0 (a triangle of a clipped
            // polygon): the same results as the setup below.
            let mut s = Screen8 {
                x: [[0.0; 8]; 3],
                y: [[0.0; 8]; 3],
                r: [[0.0; 8]; 3],
            };
            for (j, c) in p.iter().enumerate() {
                (s.x[j][0], s.y[j][0], s.r[j][0]) = (c[0], c[1], c[2]);
            }
            let mut setup = Setup8::ZERO;
            // SAFETY: `K == AVX2` only inside `render_avx2`, which the dispatcher calls only
            // after `is_x86_feature_detected!("avx2")`.
            unsafe {
                if kernels::setup8_avx2(&s, self.width, self.height, &mut setup) & 1 != 0 {
                    let grid = self.grid();
                    kernels::raster_blocks_avx2(&mut self.blocks, &grid, &setup, 0);
                }
            }
            return;
        }
        let height = self.height;
        let area =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
        if area == 0.0 || area.is_nan() {
            return;
        }
        if area < 0.0 {
            p.swap(1, 2);
        }
        let area = area.abs();
        let ymin = p[0][1].min(p[1][1]).min(p[2][1]);
        let ymax = p[0][1].max(p[1][1]).max(p[2][1]);
        let xmin = p[0][0].min(p[1][0]).min(p[2][0]);
        let xmax = p[0][0].max(p[1][0]).max(p[2][0]);
        // Pixel centres inside [min, max]: first = ceil(min - 0.5), last = floor(max - 0.5).
        let row0 = ceil_i(ymin - 0.5).max(0);
        let row1 = floor_i(ymax - 0.5).min(height as i32 - 1);
        let col0 = ceil_i(xmin - 0.5).max(0);
        let col1 = floor_i(xmax - 0.5).min(self.width as i32 - 1);
        if row0 > row1 || col0 > col1 {
            return;
        }

        // 1/z over the screen: r = r0 + ra (x - x0) + rb (y - y0). For slivers (less than a
        // pixel of area) the gradient is ill-conditioned: use the farthest corner only.
        let r_far = p[0][2].min(p[1][2]).min(p[2][2]);
        let (ra, rb) = if area >= 1.0 {
            let (d1x, d1y, d1r) = (p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]);
            let (d2x, d2y, d2r) = (p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]);
            (
                (d1r * d2y - d2r * d1y) / area,
                (d2r * d1x - d1r * d2x) / area,
            )
        } else {
            (0.0, 0.0)
        };
        let plane_ok = area >= 1.0;

        // Edges a -> b with the interior on the left of (b - a) in y-down screen space: an edge
        // going up (dy < 0) bounds the span from the left, one going down from the right.
        let mut edge_x0 = [0.0f32; 3];
        let mut edge_y0 = [0.0f32; 3];
        let mut edge_slope = [0.0f32; 3];
        let mut edge_left = [false; 3];
        let mut edge_used = [false; 3];
        for i in 0..3 {
            let (a, b) = (p[i], p[(i + 1) % 3]);
            let dy = b[1] - a[1];
            if dy != 0.0 {
                edge_used[i] = true;
                edge_x0[i] = a[0];
                edge_y0[i] = a[1];
                edge_slope[i] = (b[0] - a[0]) / dy;
                edge_left[i] = dy < 0.0;
            }
        }

        let edges = Edges {
            x0: edge_x0,
            y0: edge_y0,
            slope: edge_slope,
            left: edge_left,
            used: edge_used,
        };
        let clamp = ColClamp {
            a_lo: col0 as f32,
            a_hi: (col1 + 1) as f32,
            b_lo: (col0 - 1) as f32,
            b_hi: col1 as f32,
            row0,
            row1,
        };
        let ty0 = row0 as u32 / TILE_H;
        let ty1 = row1 as u32 / TILE_H;
        for ty in ty0..=ty1 {
            // Spans of the up to four rows of this tile row, in pixels, inclusive; rows outside
            // the triangle hold an empty span.
            let spans = if K == SCALAR {
                TileRowSpans::scalar(&edges, &clamp, ty)
            } else {
                TileRowSpans::simd(&edges, &clamp, ty)
            };
            let (lo_all, hi_all) = spans.extent();
            if lo_all > hi_all {
                continue;
            }
            let ya = (ty * TILE_H) as f32 + 0.5;
            let yb = ya + (TILE_H - 1) as f32;
            let r_rows = p[0][2] + (rb * (ya - p[0][1])).min(rb * (yb - p[0][1]));
            let tx_first = lo_all as u32 / TILE_W;
            let tx_last = hi_all as u32 / TILE_W;
            for tx in tx_first..=tx_last {
                let base = (tx * TILE_W) as i32;
                let mut mask = match K {
                    SCALAR => spans.mask_scalar(base),
                    #[cfg(target_arch = "x86_64")]
                    AVX2 | AVX2_PER_TILE => {
                        // SAFETY: `K == AVX2` or `AVX2_PER_TILE` only inside `render_avx2` or
                        // `render_avx2_per_tile`, which the dispatcher calls only after
                        // `is_x86_feature_detected!("avx2")`.
                        unsafe { spans.mask_avx2(base) }
                    }
                    _ => spans.mask_sse2(base),
                };
                if mask == 0 {
                    continue;
                }
                // The farthest depth is over the covered columns only: the lowest and highest
                // set column of the tile (the same in every kernel, so they agree bit for bit).
                let cols = (mask | mask >> 8 | mask >> 16 | mask >> 24) & 0xFF;
                let cmin = cols.trailing_zeros() as i32;
                let cmax = 31 - cols.leading_zeros() as i32;
                if tx == self.tiles_x - 1 {
                    mask |= self.outside_x;
                }
                if ty == self.tiles_y - 1 {
                    mask |= self.outside_y;
                }
                let r = if plane_ok {
                    let xa = (base + cmin) as f32 + 0.5 - p[0][0];
                    let xb = (base + cmax) as f32 + 0.5 - p[0][0];
                    (r_rows + (ra * xa).min(ra * xb)).max(r_far)
                } else {
                    r_far
                };
                self.update(tx, ty, mask, r);
            }
        }
    }

    /// True when the box may be visible from `camera`: it crosses the near plane, or some pixel
    /// of its (widened) screen rectangle is not covered by a nearer occluder. A box entirely
    /// behind the near plane or outside the image is not visible.
    pub fn test_box(&self, aabb: &Aabb, camera: &Camera) -> bool {
        let proj = Projector::new(camera, self.width, self.height);
        let (corners, zmin) = match BoxView::new(aabb, proj.near, |c| proj.view(c)) {
            BoxView::NotFinite | BoxView::CrossesNear => return true,
            BoxView::Behind => return false,
            BoxView::InFront { corners, zmin } => (corners, zmin),
        };
        let (x0, y0, x1, y1) = screen_bounds(&corners, |v| {
            let [sx, sy, _] = proj.screen(v);
            (sx, sy)
        });
        // Pixel centres in [x0, x1] widened by one pixel on each side (see module docs).
        let px0 = (x0 - 0.5).ceil() - 1.0;
        let px1 = (x1 - 0.5).floor() + 2.0;
        let py0 = (y0 - 0.5).ceil() - 1.0;
        let py1 = (y1 - 0.5).floor() + 2.0;
        let clamp_x = |v: f32| v.clamp(0.0, self.width as f32) as u32;
        let clamp_y = |v: f32| v.clamp(0.0, self.height as f32) as u32;
        self.test_rect_depth(clamp_x(px0), clamp_y(py0), clamp_x(px1), clamp_y(py1), zmin)
    }

    /// True when some pixel of the rectangle `[x0, x1) x [y0, y1)` (clamped to the buffer) may
    /// show a surface at view depth `nearest_depth`, i.e. is not covered by an occluder nearer
    /// than that. An empty rectangle is not visible; a depth that is not positive is visible.
    pub fn test_rect_depth(&self, x0: u32, y0: u32, x1: u32, y1: u32, nearest_depth: f32) -> bool {
        let (x1, y1) = (x1.min(self.width), y1.min(self.height));
        if x0 >= x1 || y0 >= y1 {
            return false;
        }
        if nearest_depth.is_nan() || nearest_depth <= 0.0 {
            return true;
        }
        let r = (1.0 / nearest_depth) * (1.0 + DEPTH_SLACK);
        for ty in y0 / TILE_H..=(y1 - 1) / TILE_H {
            let rlo = y0.saturating_sub(ty * TILE_H).min(TILE_H);
            let rhi = (y1 - ty * TILE_H).min(TILE_H);
            let rows = ((1u64 << (TILE_W * rhi)) - (1u64 << (TILE_W * rlo))) as u32;
            for tx in x0 / TILE_W..=(x1 - 1) / TILE_W {
                let t = self.tile(tx, ty);
                if r < t.z0 {
                    continue;
                }
                let clo = x0.saturating_sub(tx * TILE_W).min(TILE_W);
                let chi = (x1 - tx * TILE_W).min(TILE_W);
                let cols = (1u32 << chi) - (1u32 << clo);
                let q = cols.wrapping_mul(0x0101_0101) & rows;
                if q & !t.mask != 0 || r >= t.z1 {
                    return true;
                }
            }
        }
        false
    }

    /// The conservative (farthest possible) occluder depth at pixel `(x, y)`:
    /// `f32::INFINITY` where nothing is known, `None` outside the buffer.
    pub fn depth_at(&self, x: u32, y: u32) -> Option<f32> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let t = self.tile(x / TILE_W, y / TILE_H);
        let bit = 1u32 << ((y % TILE_H) * TILE_W + x % TILE_W);
        let r = if t.mask & bit != 0 { t.z1 } else { t.z0 };
        Some(if r > 0.0 { 1.0 / r } else { f32::INFINITY })
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
        self.test_triangles_widened(triangles, camera, 1.0)
    }

    /// True when some of the triangles (as in [`OcclusionBuffer::test_triangles`]) covers a
    /// pixel centre of the buffer's image, within [`COVER_MARGIN`] pixels, whatever is in
    /// front: false means the triangles have no pixel at all.
    pub fn covers_pixel_centre(&self, triangles: &[Vec3], camera: &Camera) -> bool {
        let proj = Projector::new(camera, self.width, self.height);
        self.any_screen_triangle(triangles, &proj, |s| {
            self.screen_triangle_covers_centre(s, COVER_MARGIN)
        })
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
        let proj = Projector::new(camera, self.width, self.height);
        self.any_screen_triangle(triangles, &proj, |s| {
            self.screen_triangle_covers_centre(s, COVER_MARGIN)
        }) && self.any_screen_triangle(triangles, &proj, |s| self.test_screen_triangle(s, widen))
    }

    /// True when `f` holds for some screen triangle (`[sx, sy, 1/z]` per corner) of the
    /// triangles clipped to the near plane and the guard band, or some corner is not finite.
    fn any_screen_triangle(
        &self,
        triangles: &[Vec3],
        proj: &Projector,
        mut f: impl FnMut([[f32; 3]; 3]) -> bool,
    ) -> bool {
        for t in triangles.chunks_exact(3) {
            match proj.triangle(t) {
                ViewTriangle::NotFinite => return true,
                ViewTriangle::Behind => {}
                ViewTriangle::Inside(s) => {
                    if f(s) {
                        return true;
                    }
                }
                // Clipped to the near plane and the guard band, then fanned out (as the
                // occluder rasterizer does).
                ViewTriangle::Clip(v) => {
                    if proj.clipped_fan(v, &mut f) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// The pixel centres (inclusive columns and rows, clamped to the image) inside the
    /// bounding box of screen triangle `p` (`[sx, sy, 1/z]` per corner) grown by `margin`.
    fn widened_centres(&self, p: [[f32; 3]; 3], margin: f32) -> CentreRange {
        let xmin = p[0][0].min(p[1][0]).min(p[2][0]) - margin;
        let xmax = p[0][0].max(p[1][0]).max(p[2][0]) + margin;
        let ymin = p[0][1].min(p[1][1]).min(p[2][1]) - margin;
        let ymax = p[0][1].max(p[1][1]).max(p[2][1]) + margin;
        if !(xmin.is_finite() && xmax.is_finite() && ymin.is_finite() && ymax.is_finite()) {
            return CentreRange::NotFinite;
        }
        let col0 = ceil_i(xmin - 0.5).max(0);
        let col1 = floor_i(xmax - 0.5).min(self.width as i32 - 1);
        let row0 = ceil_i(ymin - 0.5).max(0);
        let row1 = floor_i(ymax - 0.5).min(self.height as i32 - 1);
        if col0 > col1 || row0 > row1 {
            CentreRange::Empty
        } else {
            CentreRange::Pixels((col0, col1, row0, row1))
        }
    }

    /// True when the screen triangle, widened by `margin` pixels, contains a pixel centre of
    /// the image. Row by row: each edge bounds the row's span from one side.
    fn screen_triangle_covers_centre(&self, p: [[f32; 3]; 3], margin: f32) -> bool {
        let (col0, col1, row0, row1) = match self.widened_centres(p, margin) {
            CentreRange::NotFinite => return true,
            CentreRange::Empty => return false,
            CentreRange::Pixels(r) => r,
        };
        let (d1x, d1y) = (p[1][0] - p[0][0], p[1][1] - p[0][1]);
        let (d2x, d2y) = (p[2][0] - p[0][0], p[2][1] - p[0][1]);
        let area = d1x * d2y - d1y * d2x;
        // Too thin to orient reliably in `f32`: its widened bounding box holds a centre.
        if area.is_nan() || area.abs() < 1e-2 {
            return true;
        }
        let q = if area > 0.0 { p } else { [p[0], p[2], p[1]] };
        for y in row0..=row1 {
            let fy = y as f32 + 0.5;
            let (mut lo, mut hi) = (col0 as f32 + 0.5, col1 as f32 + 0.5);
            for i in 0..3 {
                let (a, b) = (q[i], q[(i + 1) % 3]);
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                // E(x) = dx (y - ay) - dy (x - ax) + margin (|dx| + |dy|) >= 0.
                let c = dx * (fy - a[1]) + dy * a[0] + margin * (dx.abs() + dy.abs());
                if dy > 0.0 {
                    hi = hi.min(c / dy);
                } else if dy < 0.0 {
                    lo = lo.max(c / dy);
                } else if c < 0.0 {
                    hi = f32::NEG_INFINITY;
                }
            }
            if lo <= hi && ceil_i(lo - 0.5) <= floor_i(hi - 0.5) {
                return true;
            }
        }
        false
    }

    /// One screen triangle (`[sx, sy, 1/z]` per corner) against the buffer: true when some
    /// pixel of its coverage widened by `widen` pixels is not covered by a nearer occluder.
    fn test_screen_triangle(&self, p: [[f32; 3]; 3], widen: f32) -> bool {
        let (col0, col1, row0, row1) = match self.widened_centres(p, widen) {
            CentreRange::NotFinite => return true,
            CentreRange::Empty => return false,
            CentreRange::Pixels(r) => r,
        };
        let r_corner = p[0][2].max(p[1][2]).max(p[2][2]);
        let (d1x, d1y, d1r) = (p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]);
        let (d2x, d2y, d2r) = (p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]);
        let area = d1x * d2y - d1y * d2x;
        // Below a pixel of area the orientation and the depth gradient are unreliable in
        // `f32`: the widened bounding box at the nearest corner's depth stands for the sliver
        // (`test_rect_depth` adds the slack).
        if area.is_nan() || area.abs() < 1.0 {
            return self.test_rect_depth(
                col0 as u32,
                row0 as u32,
                col1 as u32 + 1,
                row1 as u32 + 1,
                1.0 / r_corner,
            );
        }
        let r_near = r_corner * (1.0 + DEPTH_SLACK);
        // Counter-clockwise in y-down screen space as `area > 0`: interior where every edge
        // function is >= 0. Widening moves each edge outward by `widen` pixels in both axes
        // (the Minkowski sum with a square, together with the widened bounding box).
        let q = if area > 0.0 { p } else { [p[0], p[2], p[1]] };
        let mut ex = [0.0f32; 3];
        let mut ey = [0.0f32; 3];
        let mut ec = [0.0f32; 3];
        for i in 0..3 {
            let (a, b) = (q[i], q[(i + 1) % 3]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            // E(x, y) = dx (y - ay) - dy (x - ax) + widen (|dx| + |dy|)
            ex[i] = -dy;
            ey[i] = dx;
            ec[i] = dy * a[0] - dx * a[1] + widen * (dx.abs() + dy.abs());
        }
        // 1/z over the screen: r = r0 + ra (x - x0) + rb (y - y0); a pixel stands for the
        // pixels within `widen` of it, so its depth is the plane's nearest over that square.
        let ra = (d1r * d2y - d2r * d1y) / area;
        let rb = (d2r * d1x - d1r * d2x) / area;
        let margin = widen * (ra.abs() + rb.abs());
        let plane = |x: f32, y: f32| p[0][2] + ra * (x - p[0][0]) + rb * (y - p[0][1]) + margin;
        let r_at = |x: f32, y: f32| (plane(x, y) * (1.0 + DEPTH_SLACK)).min(r_near);
        for ty in row0 as u32 / TILE_H..=row1 as u32 / TILE_H {
            let ya = (ty * TILE_H).max(row0 as u32);
            let yb = (ty * TILE_H + TILE_H - 1).min(row1 as u32);
            for tx in col0 as u32 / TILE_W..=col1 as u32 / TILE_W {
                let xa = (tx * TILE_W).max(col0 as u32);
                let xb = (tx * TILE_W + TILE_W - 1).min(col1 as u32);
                let t = self.tile(tx, ty);
                // The plane is affine: its nearest value over the tile's pixels is at a corner.
                let (fxa, fxb) = (xa as f32 + 0.5, xb as f32 + 0.5);
                let (fya, fyb) = (ya as f32 + 0.5, yb as f32 + 0.5);
                let r_tile = r_at(fxa, fya)
                    .max(r_at(fxb, fya))
                    .max(r_at(fxa, fyb))
                    .max(r_at(fxb, fyb));
                if r_tile < t.z0 {
                    continue;
                }
                for y in ya..=yb {
                    let fy = y as f32 + 0.5;
                    for x in xa..=xb {
                        let fx = x as f32 + 0.5;
                        let inside = (0..3).all(|i| ex[i] * fx + ey[i] * fy + ec[i] >= 0.0);
                        if !inside {
                            continue;
                        }
                        let bit = 1u32 << ((y % TILE_H) * TILE_W + x % TILE_W);
                        let stored = if t.mask & bit != 0 { t.z1 } else { t.z0 };
                        if r_at(fx, fy) >= stored {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }
}

/// Merges an occluder's coverage `cov` at conservative `1/z` value `r` into a tile.
///
/// Andersson et al. 2015, section 3: when the new triangle is much nearer than the working
/// layer (farther from it than the working layer is from the reference layer), the working
/// layer is dropped and restarted from the triangle, otherwise the triangle joins it at the
/// farther of the two depths. A full working mask becomes the new reference layer.
#[inline(always)]
fn update_tile(tile: &mut Tile, cov: u32, r: f32) {
    if r.is_nan() || r <= tile.z0 {
        // Nothing nearer than what every pixel already has.
        return;
    }
    if tile.mask == 0 || r - tile.z1 > tile.z1 - tile.z0 {
        tile.z1 = r;
        tile.mask = cov;
    } else {
        tile.z1 = tile.z1.min(r);
        tile.mask |= cov;
    }
    if tile.mask == FULL {
        tile.z0 = tile.z1;
        tile.z1 = 0.0;
        tile.mask = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(w: u32, h: u32) -> Camera {
        Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, w, h, 0.1).expect("camera")
    }

    fn wall(z: f32, half: f32) -> Vec<Vec3> {
        let a = Vec3::new(-half, -half, z);
        let b = Vec3::new(half, -half, z);
        let c = Vec3::new(half, half, z);
        let d = Vec3::new(-half, half, z);
        vec![a, b, c, a, c, d]
    }

    fn unit_box_at(z: f32) -> Aabb {
        Aabb::new(Vec3::new(-0.5, -0.5, z - 0.5), Vec3::new(0.5, 0.5, z + 0.5))
    }

    #[test]
    fn empty_buffer_sees_every_box_in_view() {
        let b = OcclusionBuffer::new(64, 48);
        assert!(b.test_box(&unit_box_at(-10.0), &camera(64, 48)));
        assert_eq!(b.depth_at(3, 3), Some(f32::INFINITY));
    }

    #[test]
    fn empty_occluder_list_changes_nothing() {
        let mut b = OcclusionBuffer::new(64, 48);
        b.render_occluders(&[], &camera(64, 48));
        assert!(b.blocks.iter().all(|t| *t == CLEAR_BLOCK));
    }

    #[test]
    fn full_screen_wall_hides_box_behind_and_not_in_front() {
        let cam = camera(61, 37);
        let mut b = OcclusionBuffer::new(61, 37);
        b.render_occluders(&wall(-5.0, 100.0), &cam);
        assert!(!b.test_box(&unit_box_at(-8.0), &cam));
        assert!(b.test_box(&unit_box_at(-3.0), &cam));
        // Straddling the wall: its near face is in front.
        assert!(b.test_box(&unit_box_at(-5.2), &cam));
        let d = b.depth_at(30, 18).expect("inside");
        assert!((d - 5.0).abs() < 1e-3, "{d}");
    }

    #[test]
    fn box_behind_camera_or_off_screen_is_not_visible() {
        let cam = camera(64, 64);
        let b = OcclusionBuffer::new(64, 64);
        assert!(!b.test_box(&unit_box_at(10.0), &cam));
        let side = Aabb::new(Vec3::new(100.0, 0.0, -2.0), Vec3::new(101.0, 1.0, -1.0));
        assert!(!b.test_box(&side, &cam));
    }

    #[test]
    fn box_crossing_near_plane_is_visible() {
        let cam = camera(64, 64);
        let mut b = OcclusionBuffer::new(64, 64);
        b.render_occluders(&wall(-1.0, 100.0), &cam);
        assert!(b.test_box(&unit_box_at(0.0), &cam));
    }

    #[test]
    fn wall_crossing_near_plane_is_clipped_and_still_occludes() {
        let cam = camera(64, 64);
        let mut b = OcclusionBuffer::new(64, 64);
        // A slanted wall z = -10 - 0.15 y: it fills the view and its lower corners lie
        // behind the camera.
        let (p, q, r, s) = (
            Vec3::new(-100.0, -100.0, 5.0),
            Vec3::new(100.0, -100.0, 5.0),
            Vec3::new(100.0, 100.0, -25.0),
            Vec3::new(-100.0, 100.0, -25.0),
        );
        b.render_occluders(&[p, q, r, p, r, s], &cam);
        assert!(!b.test_box(&unit_box_at(-30.0), &cam));
    }

    #[test]
    fn small_hole_keeps_box_visible() {
        let cam = camera(64, 64);
        let mut b = OcclusionBuffer::new(64, 64);
        // A wall with a 0.4-wide square hole in the middle (four quads around it).
        let z = -5.0;
        let quad = |x0: f32, y0: f32, x1: f32, y1: f32| {
            let (a, bb, c, d) = (
                Vec3::new(x0, y0, z),
                Vec3::new(x1, y0, z),
                Vec3::new(x1, y1, z),
                Vec3::new(x0, y1, z),
            );
            vec![a, bb, c, a, c, d]
        };
        let mut tris = quad(-50.0, -50.0, 50.0, -0.2);
        tris.extend(quad(-50.0, 0.2, 50.0, 50.0));
        tris.extend(quad(-50.0, -0.2, -0.2, 0.2));
        tris.extend(quad(0.2, -0.2, 50.0, 0.2));
        b.render_occluders(&tris, &cam);
        assert!(b.test_box(&unit_box_at(-10.0), &cam));
        let far_side = Aabb::new(Vec3::new(2.0, 2.0, -12.0), Vec3::new(3.0, 3.0, -10.0));
        assert!(!b.test_box(&far_side, &cam));
    }

    #[test]
    fn empty_rect_is_not_visible() {
        let b = OcclusionBuffer::new(16, 16);
        assert!(!b.test_rect_depth(5, 5, 5, 9, 1.0));
        assert!(b.test_rect_depth(0, 0, 16, 16, 1.0));
    }

    #[test]
    fn clear_forgets_occluders() {
        let cam = camera(32, 32);
        let mut b = OcclusionBuffer::new(32, 32);
        b.render_occluders(&wall(-5.0, 100.0), &cam);
        b.clear();
        assert!(b.test_box(&unit_box_at(-8.0), &cam));
    }

    #[test]
    fn tile_update_keeps_farther_depth_of_merged_layer() {
        let mut t = CLEAR_TILE;
        update_tile(&mut t, 0x0000_FFFF, 0.5);
        update_tile(&mut t, 0xFFFF_0000, 0.4);
        // Full: the reference layer is the farther of the two.
        assert_eq!(t.mask, 0);
        assert_eq!(t.z0, 0.4);
    }

    #[test]
    fn tile_update_discards_far_working_layer_for_near_triangle() {
        let mut t = CLEAR_TILE;
        update_tile(&mut t, 0x0000_00FF, 0.1);
        update_tile(&mut t, 0x0000_FF00, 0.9);
        assert_eq!((t.mask, t.z1), (0x0000_FF00, 0.9));
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn block_merge_equals_tile_update() {
        use std::arch::x86_64::*;
        if !Kernel::Avx2.available() {
            // The block merge can never run here; it must not be selectable either.
            eprintln!("no AVX2 on this CPU: checking that the block kernel cannot be selected");
            assert!(!OcclusionBuffer::new(8, 8).set_kernel(Kernel::Avx2));
            return;
        }
        let mut rng = sightline_core::random::SplitMix64::new(5);
        // Depths from a small set so that ties, equal layers and NaN all occur.
        let depths = [0.0, 0.1, 0.25, 0.5, 0.75, 1.0, f32::NAN];
        let masks = [0, 1, 0x0000_FFFF, 0xFFFF_0000, 0xF0F0_F0F0, FULL >> 1, FULL];
        let pick =
            |rng: &mut sightline_core::random::SplitMix64, n: usize| rng.below(n as u64) as usize;
        let mut changed = 0;
        for _ in 0..5_000 {
            let mut block = CLEAR_BLOCK;
            let mut want = CLEAR_BLOCK;
            let (mut cov, mut r) = ([0u32; 8], [0f32; 8]);
            for l in 0..8 {
                let mut tile = CLEAR_TILE;
                // A random history of merges gives reachable tile states.
                for _ in 0..pick(&mut rng, 4) {
                    let (m, z) = (masks[pick(&mut rng, 6) + 1], depths[pick(&mut rng, 6) + 1]);
                    update_tile(&mut tile, m, z);
                }
                (block.z0[l], block.z1[l], block.mask[l]) = (tile.z0, tile.z1, tile.mask);
                (cov[l], r[l]) = (masks[pick(&mut rng, 7)], depths[pick(&mut rng, 7)]);
                if cov[l] != 0 {
                    update_tile(&mut tile, cov[l], r[l]);
                }
                (want.z0[l], want.z1[l], want.mask[l]) = (tile.z0, tile.z1, tile.mask);
            }
            let before = block;
            // SAFETY: AVX2 support was checked above; unaligned loads of local arrays.
            unsafe {
                let c = _mm256_loadu_si256(cov.as_ptr().cast());
                let z = _mm256_loadu_ps(r.as_ptr());
                kernels::merge_block_avx2(&mut block, c, z, _mm256_set1_epi32(-1));
            }
            let bits = |b: &Block| (b.z0.map(f32::to_bits), b.z1.map(f32::to_bits), b.mask);
            assert_eq!(bits(&block), bits(&want), "{before:?} + {cov:x?}, {r:?}");
            changed += usize::from(want != before);
        }
        assert!(changed > 2_500, "{changed}");
    }
}
