//! The AVX2 and AVX-512 kernels of the masked occlusion buffer: triangles in batches of 8, one
//! per lane, through the view transform, culling and clipping choice, projection and setup
//! ([`transform_batch`], [`setup8`]); then each triangle drawn a block of 4x2 tiles at a time
//! by `blocks.rs` ([`raster_blocks`], AVX2) or two block rows at a time by `pairs.rs`
//! (AVX-512).
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! section 4 (the AVX2 form: triangle setup in SIMD lanes; the per-triangle part is in
//! `blocks.rs`).
//!
//! Bit-exactness: every value is the one the tile-at-a-time kernels (`per_tile.rs`) compute,
//! with the same `f32` operations in the same order, so the buffers are identical bit for bit
//! (checked by the tests).

use std::arch::x86_64::*;

use glam::Vec3;

use super::project::Projector;
use super::raster_kernel::RasterKernel;
use super::tiles::Tiles;

mod blocks;
mod pairs;
mod setup;

use blocks::{raster_blocks, BlockGrid};
use setup::{setup8, Screen8, Setup8};

/// The AVX2 block kernel.
pub(super) struct Avx2;

impl RasterKernel for Avx2 {
    unsafe fn render(tiles: &mut Tiles, triangles: &[Vec3], proj: &Projector) {
        // SAFETY: the CPU supports AVX2 (this function's contract).
        unsafe { render_batches::<false>(tiles, triangles, proj) }
    }
}

/// The AVX-512 kernel: the AVX2 kernel's batches and setup, each triangle then drawn two block
/// rows at a time in 512-bit registers (`pairs.rs`).
pub(super) struct Avx512;

impl RasterKernel for Avx512 {
    unsafe fn render(tiles: &mut Tiles, triangles: &[Vec3], proj: &Projector) {
        // SAFETY: the CPU supports AVX-512 F, BW, DQ and VL, and so AVX2 (this function's
        // contract).
        unsafe { render_batches::<true>(tiles, triangles, proj) }
    }
}

/// View-space corners of up to 8 triangles, `x[corner][lane]`, for those that need clipping.
#[derive(Default)]
struct View8 {
    x: [[f32; 8]; 3],
    y: [[f32; 8]; 3],
    z: [[f32; 8]; 3],
}

impl View8 {
    /// The view-space corners of lane `l`.
    fn triangle(&self, l: usize) -> [Vec3; 3] {
        [0, 1, 2].map(|j| Vec3::new(self.x[j][l], self.y[j][l], self.z[j][l]))
    }
}

/// The rasterizer: triangles in batches of 8, one per lane, through [`transform_batch`] and
/// [`setup8`]; the pieces of the batch's clipped triangles through [`ClippedFans`] (set up 8
/// at a time too); then the batch's triangles are drawn in their order, a clipped one as its
/// pieces. Same arithmetic and order as the per-triangle path.
///
/// No prefetch of the blocks a batch will draw: measured side by side (`raster_probe`), the
/// hints cost 7-14 % at 1920x1080, where the buffer (780 KB) stays in the L2 cache, and
/// gained nothing at 3840x2160 but on 10-pixel triangles with the AVX2 kernel (4 %).
///
/// With `WIDE`, triangles are drawn by the AVX-512 step ([`pairs::raster_pairs`]).
///
/// # Safety
/// The CPU must support AVX2, and with `WIDE` AVX-512 F, BW, DQ and VL.
#[target_feature(enable = "avx2")]
unsafe fn render_batches<const WIDE: bool>(
    tiles: &mut Tiles,
    triangles: &[Vec3],
    proj: &Projector,
) {
    let grid = BlockGrid::new(tiles);
    let camera = Camera8::new(proj);
    let mut setup = Setup8::default();
    let mut s = Screen8::default();
    let mut views = View8::default();
    let mut fans = ClippedFans::default();
    for batch in triangles.chunks(24) {
        let n = batch.len() / 3;
        if n == 0 {
            break;
        }
        let (skip, fast) = transform_batch(&camera, batch, &mut s, &mut views);
        let draw = setup8(&s, tiles.width, tiles.height, &mut setup) & fast;
        let clipped = !(fast | skip) & ((1 << n) - 1);
        if clipped != 0 {
            fans.set_up(clipped, &views, proj, tiles.width, tiles.height);
        }
        for l in 0..n {
            let bit = 1 << l;
            if draw & bit != 0 {
                // SAFETY: with `WIDE` the CPU supports AVX-512 (this function's contract).
                unsafe { draw_one::<WIDE>(tiles, &grid, &setup, l) };
            } else if clipped & bit != 0 {
                for (piece, lane) in fans.pieces_of(l) {
                    // SAFETY: as above.
                    unsafe { draw_one::<WIDE>(tiles, &grid, piece, lane) };
                }
            }
        }
    }
}

/// Draws lane `l` of a set-up batch, with the AVX-512 step when `WIDE`.
///
/// # Safety
/// The CPU must support AVX2, and with `WIDE` AVX-512 F, BW, DQ and VL.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn draw_one<const WIDE: bool>(
    tiles: &mut Tiles,
    grid: &BlockGrid,
    setup: &Setup8,
    l: usize,
) {
    if WIDE {
        // SAFETY: with `WIDE` the CPU supports AVX-512 (this function's contract).
        unsafe { pairs::raster_pairs(&mut tiles.blocks, grid, setup, l) };
    } else {
        raster_blocks(&mut tiles.blocks, grid, setup, l);
    }
}

/// The pieces of a batch's clipped triangles: each clipped to the near plane and the guard
/// band ([`Projector::clipped_fan`]), its fan's triangles set up 8 at a time, as the
/// unclipped ones are, instead of one at a time (in Quake 3 frames about a third of the
/// occluders cross the guard band or the near plane).
#[derive(Default)]
struct ClippedFans {
    /// Set-up pieces, 8 a batch; those of triangle `l` are `first[l]..first[l + 1]`, piece
    /// `i` in lane `i % 8` of `setups[i / 8]`, drawn where bit `i % 8` of `draw[i / 8]` is set.
    setups: Vec<Setup8>,
    draw: Vec<u32>,
    first: [usize; 9],
}

impl ClippedFans {
    /// Clips and sets up the triangles of `clipped` (a bit per lane of `views`).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn set_up(&mut self, clipped: u32, views: &View8, proj: &Projector, width: u32, height: u32) {
        let mut screens = Screen8::default();
        let mut count = 0;
        for l in 0..8 {
            self.first[l] = count;
            if clipped & (1 << l) == 0 {
                continue;
            }
            proj.clipped_fan(views.triangle(l), |p| {
                let lane = count % 8;
                for (j, c) in p.iter().enumerate() {
                    (screens.x[j][lane], screens.y[j][lane], screens.r[j][lane]) =
                        (c[0], c[1], c[2]);
                }
                count += 1;
                if lane == 7 {
                    self.flush(&screens, count, width, height);
                }
                false
            });
        }
        self.first[8] = count;
        if count % 8 != 0 {
            self.flush(&screens, count, width, height);
        }
    }

    /// Sets up the batch of pieces that ends with piece `count - 1`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn flush(&mut self, screens: &Screen8, count: usize, width: u32, height: u32) {
        let batch = (count - 1) / 8;
        if self.setups.len() <= batch {
            self.setups.resize_with(batch + 1, Setup8::default);
            self.draw.resize(batch + 1, 0);
        }
        let lanes = (1u32 << (count - 8 * batch)) - 1;
        self.draw[batch] = setup8(screens, width, height, &mut self.setups[batch]) & lanes;
    }

    /// The set-up pieces of triangle `l` that have something to draw, in fan order.
    fn pieces_of(&self, l: usize) -> impl Iterator<Item = (&Setup8, usize)> + '_ {
        (self.first[l]..self.first[l + 1])
            .filter(|&i| self.draw[i / 8] & (1 << (i % 8)) != 0)
            .map(|i| (&self.setups[i / 8], i % 8))
    }
}

/// A [`Projector`] broadcast to the 8 lanes.
struct Camera8 {
    eye: [__m256; 3],
    /// `right`, `up`, `forward`, each `(x, y, z)`.
    axes: [(__m256, __m256, __m256); 3],
    near: __m256,
    /// The guard band's half-widths per unit of depth.
    gx: __m256,
    gy: __m256,
    kx: __m256,
    /// `-ky`.
    nky: __m256,
    cx: __m256,
    cy: __m256,
    ky: __m256,
    beyond_x: __m256,
    beyond_y: __m256,
}

impl Camera8 {
    #[inline]
    #[target_feature(enable = "avx2")]
    fn new(proj: &Projector) -> Self {
        let set1 = _mm256_set1_ps;
        Camera8 {
            eye: [set1(proj.eye.x), set1(proj.eye.y), set1(proj.eye.z)],
            axes: [proj.right, proj.up, proj.forward].map(|a| (set1(a.x), set1(a.y), set1(a.z))),
            near: set1(proj.near),
            gx: set1(proj.guard_x),
            gy: set1(proj.guard_y),
            kx: set1(proj.kx),
            nky: set1(-proj.ky),
            cx: set1(proj.cx),
            cy: set1(proj.cy),
            ky: set1(proj.ky),
            beyond_x: set1(proj.beyond_x),
            beyond_y: set1(proj.beyond_y),
        }
    }
}

/// The view transform, the choice between culling, clipping and the fast path (every corner
/// in front of the near plane and inside the guard band) and the projection of a batch of up
/// to 8 triangles (24 corners; lanes past the end repeat the last triangle and are never
/// drawn): the screen corners into `s`, the view corners into `views`; returns the lanes to
/// skip (behind the near plane, not finite, or needing clipping but beside the view) and the
/// lanes of the fast path, a bit each. The arithmetic of `Projector::view`, `inside_guard`,
/// `beside_view` and `screen`, lane by lane.
#[inline]
#[target_feature(enable = "avx2")]
fn transform_batch(c: &Camera8, batch: &[Vec3], s: &mut Screen8, views: &mut View8) -> (u32, u32) {
    let n = batch.len() / 3;
    let set1 = _mm256_set1_ps;
    let abs = |v: __m256| _mm256_andnot_ps(set1(-0.0), v);
    let inf = set1(f32::INFINITY);
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
    let [ex, ey, ez] = c.eye;
    for j in 0..3 {
        let (dx, dy, dz) = (
            _mm256_sub_ps(wx[j], ex),
            _mm256_sub_ps(wy[j], ey),
            _mm256_sub_ps(wz[j], ez),
        );
        // `Vec3::dot`: (x * x') + (y * y') + (z * z').
        let [v_x, v_y, v_z] = c.axes.map(|(ax, ay, az)| {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(dx, ax), _mm256_mul_ps(dy, ay)),
                _mm256_mul_ps(dz, az),
            )
        });
        behind = _mm256_and_ps(behind, _mm256_cmp_ps::<_CMP_LT_OQ>(v_z, c.near));
        for v in [v_x, v_y, v_z] {
            finite = _mm256_and_ps(finite, _mm256_cmp_ps::<_CMP_LT_OQ>(abs(v), inf));
        }
        // `Projector::inside_guard`.
        let inside = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GE_OQ>(v_z, c.near),
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_LE_OQ>(abs(v_x), _mm256_mul_ps(c.gx, v_z)),
                _mm256_cmp_ps::<_CMP_LE_OQ>(abs(v_y), _mm256_mul_ps(c.gy, v_z)),
            ),
        );
        guard = _mm256_and_ps(guard, inside);
        // `Projector::screen` (garbage in lanes that are not drawn this way).
        let r = _mm256_div_ps(set1(1.0), v_z);
        // SAFETY: stores of 8 lanes into `[f32; 8]` arrays (those of `s` aligned).
        unsafe {
            _mm256_store_ps(
                s.x[j].as_mut_ptr(),
                _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(c.kx, v_x), r), c.cx),
            );
            _mm256_store_ps(
                s.y[j].as_mut_ptr(),
                _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(c.nky, v_y), r), c.cy),
            );
            _mm256_store_ps(s.r[j].as_mut_ptr(), r);
            _mm256_storeu_ps(views.x[j].as_mut_ptr(), v_x);
            _mm256_storeu_ps(views.y[j].as_mut_ptr(), v_y);
            _mm256_storeu_ps(views.z[j].as_mut_ptr(), v_z);
        }
    }
    let skip = _mm256_movemask_ps(_mm256_or_ps(
        behind,
        _mm256_xor_ps(finite, _mm256_castsi256_ps(_mm256_set1_epi32(-1))),
    )) as u32;
    let fast = _mm256_movemask_ps(guard) as u32 & !skip;
    // A triangle that needs clipping but lies beside the view is dropped (`per_tile::render`
    // does the same). The test runs only for batches with lanes to clip (czest3ctf's frame:
    // 142 of 930 triangles; the city's frame and the random sets: none), since on every
    // batch it cost up to 4 % on 10-pixel triangles.
    let clip = !(skip | fast) & ((1 << n) - 1);
    let beside = if clip != 0 { beside8(c, views) } else { 0 };
    (skip | (beside & clip), fast)
}

/// The lanes of `views` whose three corners lie beyond the same screen edge, a pixel out:
/// `Projector::beside_view` lane by lane, with the same operations.
#[inline]
#[target_feature(enable = "avx2")]
fn beside8(c: &Camera8, views: &View8) -> u32 {
    // SAFETY: unaligned loads of `[f32; 8]` arrays.
    let ld = |a: &[f32; 8]| unsafe { _mm256_loadu_ps(a.as_ptr()) };
    let zero = _mm256_setzero_ps();
    // Left, right, top, bottom.
    let mut beyond = [_mm256_castsi256_ps(_mm256_set1_epi32(-1)); 4];
    for j in 0..3 {
        let (x, y) = (
            _mm256_mul_ps(c.kx, ld(&views.x[j])),
            _mm256_mul_ps(c.ky, ld(&views.y[j])),
        );
        let v_z = ld(&views.z[j]);
        let (zx, zy) = (
            _mm256_mul_ps(c.beyond_x, v_z),
            _mm256_mul_ps(c.beyond_y, v_z),
        );
        let sides = [
            _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_add_ps(x, zx), zero),
            _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_sub_ps(x, zx), zero),
            _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_sub_ps(y, zy), zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_add_ps(y, zy), zero),
        ];
        for (b, side) in beyond.iter_mut().zip(sides) {
            *b = _mm256_and_ps(*b, side);
        }
    }
    let [left, right, top, bottom] = beyond;
    _mm256_movemask_ps(_mm256_or_ps(
        _mm256_or_ps(left, right),
        _mm256_or_ps(top, bottom),
    )) as u32
}
