//! Gaussian-filtered image: every pixel is the integral of the shaded visible polygons against a
//! Gaussian centred on the pixel centre, over a square window of half-width `radius`, normalised
//! by the window's mass.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 4.4 (Algorithm 4, radial filters of radius 2.3 px after Auzinger, Guthe, Jeschke.
//! Analytic Anti-Aliasing of Linear Functions on Polytopes. 2012).
//!
//! # The integral
//! The truncated Gaussian `w(x) w(y)` (`w(t) = g(t)` for `|t| ≤ radius`, else 0; `σ = radius /
//! 3`) is separable, so by Green's theorem its integral over a polygon is a sum over the edges of
//! `-∫ w(x - cx) W(y(x) - cy) dx`, with `W(t) = Φ(clamp(t, ±radius)) - Φ(-radius)` the integral
//! of `w` up to `t` (Φ the normal CDF). The zero of `w` outside the window clips in x and the
//! clamp clips in y, so the polygon is never clipped to a window; the offset `Φ(-radius)` makes
//! an edge add nothing to the windows below it, the window's 1D mass `M` times `∫ w dx` to those
//! wholly above it, and a smooth term only to the windows it crosses. Unlike the paper's
//! polynomial filters, the smooth term has no elementary closed form: it is a Gauss–Legendre sum.
//!
//! # Sharing the work between pixels
//! An edge is cut where it crosses any window border (`x = i + ½ ± radius` for the columns,
//! `y = m + ½ ± radius` for the rows) and into pieces at most σ long in x and in y. On each piece
//! the integrand is smooth for every pixel, so one set of nodes serves all of them: `w` at the
//! nodes once per column, `W` once per row, and each pixel's term is the dot product of the two.
//! The constant terms of the windows above a piece go into one entry per column that a sum from
//! the bottom row up spreads over all the rows above (over a closed polygon they cancel above
//! its top, so each bin sums only its own tile). `w` and `W` come from cubic Hermite tables
//! built from exact values and derivatives, so no transcendental function is evaluated per node.
//! Bins run in parallel, each into a tile of the pixels within `radius` of its pieces; the tiles
//! are added into the image in bin order, so the result does not depend on the thread count.
//!
//! # Accuracy
//! Against the per-window clipping with fine quadrature (the reference of the tests) the pixels
//! agree to 3e-8 of the window's mass (4-point Gauss–Legendre on pieces up to σ long; the tables
//! add 2e-10), below the f32 of the image; `erf` (for the tables only) is its Taylor series, to
//! about 1e-15 on the `|x| ≤ 3/√2` it is needed for. The window is a square, so the filter is radially
//! symmetric up to its truncation at `radius` (the Gaussian's mass outside is 0.5 %).

use glam::DVec2;
use rayon::prelude::*;

use super::types::{BinRange, VisiblePolygon};

/// Gauss–Legendre nodes and weights on [-1, 1], 4 points (2 pairs ± x).
const GL_X: [f64; 2] = [0.339_981_043_584_856_3, 0.861_136_311_594_052_6];
const GL_W: [f64; 2] = [0.652_145_154_862_546_1, 0.347_854_845_137_453_9];

/// Nodes per piece.
const NODES: usize = 2 * GL_X.len();

/// Table intervals per σ (rounded up to a whole number per pixel): the cubic Hermite error is
/// `h⁴/384 · max|f⁗|`, 2.4e-10 of `g(0)` for `h = σ/64` (measured), and the 6 × 64 intervals
/// of 32 bytes per table stay in the L1 cache.
const TABLE_PER_SIGMA: usize = 64;

/// `erf(x)` by its Taylor series; about 1e-15 absolute for `|x| ≤ 2.2` (the tables need
/// `|x| ≤ 3/√2`; beyond 3 the alternating terms lose too many digits).
fn erf(x: f64) -> f64 {
    debug_assert!(x.abs() <= 3.0, "erf series used outside its range: {x}");
    let x2 = x * x;
    // term = (-1)^n x^(2n+1) / n!, sum of term / (2n + 1).
    let (mut term, mut sum) = (x, x);
    for n in 1..100 {
        term *= -x2 / n as f64;
        let add = term / (2 * n + 1) as f64;
        sum += add;
        if add.abs() < 1e-17 {
            break;
        }
    }
    sum * std::f64::consts::FRAC_2_SQRT_PI
}

/// A smooth function of a pixel offset as cubic Hermite pieces through exact values and
/// derivatives, `per_px` intervals per pixel: an offset one pixel further is exactly `per_px`
/// intervals further at the same local coordinate, so a piece locates each node once for all of
/// its columns (or rows).
#[derive(Clone, Debug)]
struct HermiteTable {
    lo: f64,
    per_px: usize,
    /// Per interval, the cubic's coefficients in the local coordinate `u ∈ [0, 1]`.
    coef: Vec<[f64; 4]>,
}

/// A located offset: its interval and the powers `u, u², u³` of its local coordinate.
type Located = (usize, [f64; 3]);

impl HermiteTable {
    /// Tabulates `f`, which returns the value and the derivative, over `[-radius, radius]` and
    /// two intervals more on either side (for offsets that rounding puts just outside).
    fn new(radius: f64, per_px: usize, f: impl Fn(f64) -> (f64, f64)) -> Self {
        let step = 1.0 / per_px as f64;
        let lo = -radius - 2.0 * step;
        let intervals = ceil_i64(2.0 * radius * per_px as f64) as usize + 4;
        let coef = (0..intervals)
            .map(|j| {
                let (f0, d0) = f(lo + step * j as f64);
                let (f1, d1) = f(lo + step * (j + 1) as f64);
                let (d0, d1, df) = (d0 * step, d1 * step, f1 - f0);
                [f0, d0, 3.0 * df - 2.0 * d0 - d1, d0 + d1 - 2.0 * df]
            })
            .collect();
        Self { lo, per_px, coef }
    }

    /// Where offset `t` lies in the table (clamped to it).
    #[inline]
    fn locate(&self, t: f64) -> Located {
        let last = (self.coef.len() - 1) as f64;
        let z = ((t - self.lo) * self.per_px as f64).clamp(0.0, last);
        let j = z as usize;
        let u = z - j as f64;
        (j, [u, u * u, u * u * u])
    }

    /// The interpolant at the offset `shift` pixels smaller than the located one.
    #[inline]
    fn at(&self, (j, [u, u2, u3]): Located, shift: usize) -> f64 {
        let [c0, c1, c2, c3] = self.coef[j.saturating_sub(shift * self.per_px)];
        c0 + c1 * u + c2 * u2 + c3 * u3
    }
}

/// The filter: `σ = radius / 3`, its window, and the tables of `w` and `W` (module docs).
#[derive(Clone, Debug)]
pub(crate) struct Gauss {
    radius: f64,
    sigma: f64,
    /// Mass of the 1D Gaussian over `[-radius, radius]`.
    mass_1d: f64,
    /// `g(t)` on `[-radius, radius]`.
    density: HermiteTable,
    /// `Φ(t) - Φ(-radius)` on `[-radius, radius]`.
    cdf: HermiteTable,
}

impl Gauss {
    /// A Gaussian with `σ = radius / 3`, truncated to the square of half-width `radius`.
    pub(crate) fn new(radius: f64) -> Self {
        let sigma = radius / 3.0;
        let scale = 1.0 / (sigma * std::f64::consts::SQRT_2);
        let norm = 1.0 / (sigma * (2.0 * std::f64::consts::PI).sqrt());
        let g = move |t: f64| norm * (-0.5 * (t / sigma).powi(2)).exp();
        let phi_lo = 0.5 * erf(-radius * scale);
        let per_px = ceil_i64(TABLE_PER_SIGMA as f64 / sigma) as usize;
        Self {
            radius,
            sigma,
            mass_1d: erf(radius * scale),
            density: HermiteTable::new(radius, per_px, |t| (g(t), -t / (sigma * sigma) * g(t))),
            cdf: HermiteTable::new(radius, per_px, |t| (0.5 * erf(t * scale) - phi_lo, g(t))),
        }
    }
}

/// Bins filtered between two merges into the image: bounds the tiles alive at once (about 1 MB
/// for 16 px bins) so that their memory is reused instead of faulted in fresh for every bin
/// (collecting all tiles first spent 15 % of the time clearing new pages).
const BINS_PER_MERGE: usize = 256;

/// `floor(x)` as an integer, without the libm call that `f64::floor` is on x86-64 without SSE4.1
/// (the pieces' loops call it several times per piece). `|x|` is far below 2^63 here.
#[inline]
fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t - i64::from((t as f64) > x)
}

/// `ceil(x)` as an integer, see [`floor_i64`].
#[inline]
fn ceil_i64(x: f64) -> i64 {
    let t = x as i64;
    t + i64::from((t as f64) < x)
}

/// A bin's share of the image: the pixels within `radius` of its pieces, clipped to the image.
struct Tile {
    /// First column and row (image pixels).
    x0: i64,
    y0: i64,
    w: usize,
    h: usize,
    /// The filtered values, row-major.
    sum: Vec<f64>,
}

/// Buffers reused across the pieces, edges and bins of one worker.
#[derive(Default)]
struct Scratch {
    cuts: Vec<f64>,
    /// Weight × `w(x_k - cx)` per column of the piece.
    wx: Vec<[f64; NODES]>,
    /// Per tile pixel, the constant that it and every row above it receive (module docs).
    above: Vec<f64>,
}

impl Gauss {
    /// The tile of one bin: `value × ∫∫ w w / M²` of its pieces for every pixel they reach.
    fn bin_tile(
        &self,
        polys: &[VisiblePolygon],
        value: &(dyn Fn(u32) -> f32 + Sync),
        (width, height): (i64, i64),
        s: &mut Scratch,
    ) -> Option<Tile> {
        let r = self.radius;
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for poly in polys.iter().filter(|p| value(p.triangle) != 0.0) {
            for p in &poly.points {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        if !(lo.x <= hi.x && lo.y <= hi.y) {
            return None;
        }
        // Pixels whose window can meet the pieces' box.
        let x0 = floor_i64(lo.x - r - 0.5).max(0);
        let x1 = ceil_i64(hi.x + r - 0.5).min(width - 1);
        let y0 = floor_i64(lo.y - r - 0.5).max(0);
        let y1 = ceil_i64(hi.y + r - 0.5).min(height - 1);
        if x0 > x1 || y0 > y1 {
            return None;
        }
        let (w, h) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
        let mut tile = Tile {
            x0,
            y0,
            w,
            h,
            sum: vec![0.0; w * h],
        };
        s.above.clear();
        s.above.resize(w * h, 0.0);
        let norm = 1.0 / (self.mass_1d * self.mass_1d);
        for poly in polys {
            let v = f64::from(value(poly.triangle));
            if v == 0.0 {
                continue;
            }
            let pts = &poly.points;
            for (i, &a) in pts.iter().enumerate() {
                let b = pts[(i + 1) % pts.len()];
                self.add_edge(a, b, v * norm, &mut tile, s);
            }
        }
        // Spread the constants over the rows above: a running sum from the bottom row up. The
        // rows above the tile would receive the full sum over closed polygons, which is zero.
        for y in (1..h).rev() {
            for x in 0..w {
                let a = s.above[y * w + x];
                tile.sum[y * w + x] += a;
                s.above[(y - 1) * w + x] += a;
            }
        }
        for (o, a) in tile.sum[..w].iter_mut().zip(&s.above) {
            *o += a;
        }
        Some(tile)
    }

    /// Adds `value × ∫∫ w w` of the polygon with edges `a → b` (see the module docs) into the
    /// tile, without the `1 / M²` normalisation.
    fn add_edge(&self, a: DVec2, b: DVec2, value: f64, tile: &mut Tile, s: &mut Scratch) {
        if a.x == b.x {
            return; // dx = 0 along the whole edge.
        }
        // Integrate over increasing x; Green's theorem for counter-clockwise polygons in the
        // y-down sense (clockwise in the usual y-up sense) reads ∫∫ w w dA = -∮ w W dx.
        let (p, q, value) = if a.x < b.x {
            (a, b, -value)
        } else {
            (b, a, value)
        };
        let r = self.radius;
        let cuts = &mut s.cuts;
        cuts.clear();
        cuts.extend([p.x, q.x]);
        let (ylo, yhi) = (p.y.min(q.y), p.y.max(q.y));
        for off in [0.5 - r, 0.5 + r] {
            // Column window borders k + off inside (p.x, q.x).
            for k in floor_i64(p.x - off) + 1..=ceil_i64(q.x - off) - 1 {
                cuts.push(k as f64 + off);
            }
            // Row window borders, where the edge's y crosses them.
            for k in floor_i64(ylo - off) + 1..=ceil_i64(yhi - off) - 1 {
                let x = p.x + (k as f64 + off - p.y) * (q.x - p.x) / (q.y - p.y);
                cuts.push(x.clamp(p.x, q.x));
            }
        }
        cuts.sort_unstable_by(f64::total_cmp);
        let dydx = (q.y - p.y) / (q.x - p.x);
        for i in 1..s.cuts.len() {
            let (xa, xb) = (s.cuts[i - 1], s.cuts[i]);
            if xb <= xa {
                continue;
            }
            // At most σ in x and in y: there the 4-point rule is within 3e-8 of the window's mass
            // (the tests; 8 points gave 1e-12 for 1.5x the time).
            let len = (xb - xa) * dydx.abs().max(1.0);
            let n = ceil_i64(len / self.sigma).max(1) as usize;
            let step = (xb - xa) / n as f64;
            for j in 0..n {
                let x0 = xa + step * j as f64;
                let x1 = if j + 1 == n { xb } else { x0 + step };
                self.add_piece(x0, x1, p, dydx, value, tile, s);
            }
        }
    }

    /// The piece `[xa, xb]` of the edge `y = p.y + dydx (x - p.x)`, inside or outside each
    /// window as a whole, into every pixel it affects.
    #[allow(clippy::too_many_arguments)]
    fn add_piece(
        &self,
        xa: f64,
        xb: f64,
        p: DVec2,
        dydx: f64,
        value: f64,
        tile: &mut Tile,
        s: &mut Scratch,
    ) {
        let r = self.radius;
        let (xm, half) = (0.5 * (xa + xb), 0.5 * (xb - xa));
        let ym = p.y + dydx * (xm - p.x);
        // Columns whose window holds the piece: |xm - (i + ½)| < r.
        let c0 = ceil_i64(xm - r - 0.5).max(tile.x0);
        let c1 = floor_i64(xm + r - 0.5).min(tile.x0 + tile.w as i64 - 1);
        if c0 > c1 {
            return;
        }
        // Rows whose window holds the piece, and the last row whose window is wholly above it.
        let first_row = ceil_i64(ym - r - 0.5);
        let r0 = first_row.max(tile.y0);
        let r1 = floor_i64(ym + r - 0.5).min(tile.y0 + tile.h as i64 - 1);
        let mut xs = [0.0; NODES];
        let mut ws = [0.0; NODES];
        for (k, (&x, &wt)) in GL_X.iter().zip(&GL_W).enumerate() {
            xs[2 * k] = xm - half * x;
            xs[2 * k + 1] = xm + half * x;
            ws[2 * k] = half * wt;
            ws[2 * k + 1] = half * wt;
        }
        let wx = &mut s.wx;
        wx.clear();
        let above_row = (first_row - 1).min(tile.y0 + tile.h as i64 - 1);
        // Nodes located once, at the first column and row; the others are whole pixels away.
        let cx0 = c0 as f64 + 0.5;
        let at_x: [Located; NODES] = std::array::from_fn(|k| self.density.locate(xs[k] - cx0));
        for (d, c) in (c0..=c1).enumerate() {
            let col: [f64; NODES] = std::array::from_fn(|k| ws[k] * self.density.at(at_x[k], d));
            if above_row >= tile.y0 {
                let i = (above_row - tile.y0) as usize * tile.w + (c - tile.x0) as usize;
                s.above[i] += value * self.mass_1d * col.iter().sum::<f64>();
            }
            wx.push(col);
        }
        let cy0 = r0 as f64 + 0.5;
        let at_y: [Located; NODES] =
            std::array::from_fn(|k| self.cdf.locate(p.y + dydx * (xs[k] - p.x) - cy0));
        for (d, m) in (r0..=r1).enumerate() {
            let row: [f64; NODES] = std::array::from_fn(|k| self.cdf.at(at_y[k], d));
            let base = (m - tile.y0) as usize * tile.w + (c0 - tile.x0) as usize;
            for (out, col) in tile.sum[base..].iter_mut().zip(&s.wx) {
                let dot: f64 = col.iter().zip(&row).map(|(a, b)| a * b).sum();
                *out += value * dot;
            }
        }
    }
}

/// Gaussian-filtered image (see the module docs); `value` per triangle.
pub(crate) fn gauss_image(
    width: u32,
    height: u32,
    bins: &[BinRange],
    polygons: &[VisiblePolygon],
    radius: f64,
    value: &(dyn Fn(u32) -> f32 + Sync),
) -> Vec<f32> {
    gauss_image_f64(width, height, bins, polygons, radius, value)
        .into_iter()
        .map(|v| v as f32)
        .collect()
}

/// [`gauss_image`] before rounding to f32 (the tests compare beyond f32 precision).
fn gauss_image_f64(
    width: u32,
    height: u32,
    bins: &[BinRange],
    polygons: &[VisiblePolygon],
    radius: f64,
    value: &(dyn Fn(u32) -> f32 + Sync),
) -> Vec<f64> {
    let filter = Gauss::new(radius);
    let size = (i64::from(width), i64::from(height));
    let mut image = vec![0.0f64; width as usize * height as usize];
    // Tiles overlap (by the window), so they are added one after another, in bin order.
    for chunk in bins.chunks(BINS_PER_MERGE) {
        let tiles: Vec<Option<Tile>> = chunk
            .par_iter()
            .map_init(Scratch::default, |s, bin| {
                filter.bin_tile(&polygons[bin.polys.clone()], value, size, s)
            })
            .collect();
        for tile in tiles.into_iter().flatten() {
            for (y, row) in tile.sum.chunks_exact(tile.w).enumerate() {
                let start = (tile.y0 as usize + y) * width as usize + tile.x0 as usize;
                for (o, v) in image[start..start + tile.w].iter_mut().zip(row) {
                    *o += v;
                }
            }
        }
    }
    image
}

#[cfg(test)]
mod tests {
    use super::super::polygon::clip_to_rect;
    use super::*;

    /// 8-point Gauss–Legendre rule of the reference (independent of the production rule).
    const REF_X: [f64; 4] = [
        0.183_434_642_495_649_8,
        0.525_532_409_916_329,
        0.796_666_477_413_626_7,
        0.960_289_856_497_536_3,
    ];
    const REF_W: [f64; 4] = [
        0.362_683_783_378_362,
        0.313_706_645_877_887_3,
        0.222_381_034_453_374_5,
        0.101_228_536_290_376_3,
    ];

    /// The previous method as an independent reference: clip every polygon to every pixel's
    /// window, then integrate `-∮ g(x) Φ(y) dx` with the 8-point rule on pieces σ/16 long in x
    /// and y, `exp` and the series `erf` directly (no tables, cuts, shared nodes, running sums or
    /// tiles). Its own error is below 1e-12 (it moved by less when the pieces were halved).
    fn reference_image(
        width: u32,
        height: u32,
        polygons: &[VisiblePolygon],
        radius: f64,
        value: impl Fn(u32) -> f64,
    ) -> Vec<f64> {
        let sigma = radius / 3.0;
        let scale = 1.0 / (sigma * std::f64::consts::SQRT_2);
        let g = |t: f64| {
            (-0.5 * (t / sigma).powi(2)).exp() / (sigma * (2.0 * std::f64::consts::PI).sqrt())
        };
        let cdf = |t: f64| 0.5 * (1.0 + erf(t * scale));
        let mass = erf(radius * scale);
        let mut image = vec![0.0; (width * height) as usize];
        for py in 0..height {
            for px in 0..width {
                let c = DVec2::new(f64::from(px) + 0.5, f64::from(py) + 0.5);
                let window = [c.x - radius, c.y - radius, c.x + radius, c.y + radius];
                for poly in polygons {
                    let clipped = clip_to_rect(&poly.points, window);
                    let mut sum = 0.0;
                    for i in 0..clipped.len() {
                        let (a, b) = (clipped[i] - c, clipped[(i + 1) % clipped.len()] - c);
                        let w = b.x - a.x;
                        if w == 0.0 {
                            continue;
                        }
                        let pieces = ((16.0 * w.abs().max((b.y - a.y).abs()) / sigma).ceil()
                            as usize)
                            .max(1);
                        let (h, slope) = (w / pieces as f64, (b.y - a.y) / w);
                        for k in 0..pieces {
                            let mid = a.x + h * (k as f64 + 0.5);
                            for (&x, &wt) in REF_X.iter().zip(&REF_W) {
                                for xx in [mid - 0.5 * h * x, mid + 0.5 * h * x] {
                                    let y = a.y + slope * (xx - a.x);
                                    sum += wt * 0.5 * h * g(xx) * cdf(y);
                                }
                            }
                        }
                    }
                    image[(py * width + px) as usize] -= value(poly.triangle) * sum / (mass * mass);
                }
            }
        }
        image
    }

    /// A generator of fixed-seed uniform numbers in [0, 1) (64-bit LCG, top bits).
    struct Lcg(u64);

    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Random triangles and convex quads (counter-clockwise in the y-down sense) over a
    /// `w × h` image, some reaching past its border, some thin, some sub-pixel.
    fn random_polygons(seed: u64, count: u32, w: f64, h: f64) -> Vec<VisiblePolygon> {
        let mut rng = Lcg(seed);
        (0..count)
            .map(|triangle| {
                let c = DVec2::new(rng.next() * w, rng.next() * h);
                let size = [0.3, 2.0, 6.0][triangle as usize % 3];
                let corners = 3 + triangle as usize % 2;
                let start = rng.next() * std::f64::consts::TAU;
                let points = (0..corners)
                    .map(|k| {
                        // Increasing angles in the y-down frame are counter-clockwise there.
                        let a = start
                            + std::f64::consts::TAU * (k as f64 + 0.8 * rng.next())
                                / corners as f64;
                        c + size * (0.3 + rng.next()) * DVec2::new(a.cos(), a.sin())
                    })
                    .collect();
                VisiblePolygon { triangle, points }
            })
            .collect()
    }

    fn one_bin(polygons: &[VisiblePolygon]) -> Vec<BinRange> {
        vec![BinRange {
            x: 0,
            y: 0,
            polys: 0..polygons.len(),
        }]
    }

    fn square(lo: f64, hi: f64) -> VisiblePolygon {
        VisiblePolygon {
            triangle: 0,
            points: vec![
                DVec2::new(lo, lo),
                DVec2::new(hi, lo),
                DVec2::new(hi, hi),
                DVec2::new(lo, hi),
            ],
        }
    }

    #[test]
    fn erf_matches_known_values() {
        let e = [erf(0.5), erf(-1.5), erf(0.0), erf(2.121_320_343_559_642_4)];
        assert!((e[0] - 0.520_499_877_813_046_5).abs() < 1e-15, "{e:?}");
        assert!((e[1] + 0.966_105_146_475_310_7).abs() < 1e-15, "{e:?}");
        assert_eq!(e[2], 0.0);
        // erf(3 / √2) = P(|Z| < 3).
        assert!((e[3] - 0.997_300_203_936_739_8).abs() < 1e-14, "{e:?}");
    }

    #[test]
    fn tables_match_the_gaussian() {
        // Offsets located once and read whole pixels further, as the pieces do.
        let g = Gauss::new(2.3);
        let sigma = 2.3 / 3.0;
        let scale = 1.0 / (sigma * std::f64::consts::SQRT_2);
        let density = |t: f64| {
            (-0.5 * (t / sigma).powi(2)).exp() / (sigma * (2.0 * std::f64::consts::PI).sqrt())
        };
        let cdf = |t: f64| 0.5 * (erf(t * scale) - erf(-2.3 * scale));
        let (mut worst_g, mut worst_cdf) = (0.0f64, 0.0f64);
        for k in 0..=1000 {
            let t = -2.3 + 4.6 * k as f64 / 1000.0;
            let (at_g, at_cdf) = (g.density.locate(t), g.cdf.locate(t));
            for shift in 0..=((t + 2.3).floor() as usize) {
                let u = t - shift as f64;
                worst_g = worst_g.max((g.density.at(at_g, shift) - density(u)).abs());
                worst_cdf = worst_cdf.max((g.cdf.at(at_cdf, shift) - cdf(u)).abs());
            }
        }
        // 2.4e-10 measured for g (h⁴/384 · max|g⁗| predicts 1.4e-10 · g(0)), less for Φ.
        assert!(worst_g < 1e-9 && worst_cdf < 1e-9, "{worst_g} {worst_cdf}");
    }

    #[test]
    fn whole_window_integrates_to_one() {
        // The centre pixel (4, 4) of a 9 × 9 image, its window wholly inside the square.
        let polys = [square(-10.0, 20.0)];
        let img = gauss_image_f64(9, 9, &one_bin(&polys), &polys, 2.3, &|_| 1.0);
        // 2.8e-10 measured: quadrature and tables along the square's far-away sides cancel.
        assert!((img[4 * 9 + 4] - 1.0).abs() < 1e-8, "{}", img[4 * 9 + 4]);
    }

    #[test]
    fn half_window_integrates_to_half() {
        // Pixel (4, 4) has its centre at x = 4.5, on the square's left side.
        let polys = [VisiblePolygon {
            triangle: 0,
            points: vec![
                DVec2::new(4.5, -10.0),
                DVec2::new(20.0, -10.0),
                DVec2::new(20.0, 20.0),
                DVec2::new(4.5, 20.0),
            ],
        }];
        let img = gauss_image_f64(9, 9, &one_bin(&polys), &polys, 2.3, &|_| 1.0);
        assert!((img[4 * 9 + 4] - 0.5).abs() < 1e-8, "{}", img[4 * 9 + 4]);
    }

    #[test]
    fn random_polygons_match_window_clipping_reference() {
        // 40 polygons on 14 × 11 pixels (values 0.2..1, up to ~5 layers deep), for radii from a
        // fraction of a pixel to more than the image. Tolerance 5e-8 of the window's mass: the
        // 4-point rule on pieces up to σ long measured 2.3e-8 at worst (radius 1, where pieces
        // are σ long), the tables 2e-10; a wrong window border, row, sign or table offset
        // fails by orders of magnitude more.
        let (w, h) = (14, 11);
        let polys = random_polygons(7, 40, f64::from(w), f64::from(h));
        let value = |id: u32| 0.2 + 0.1 * f64::from(id % 9);
        for radius in [0.1, 0.45, 1.0, 1.5, 2.3, 4.0, 16.0] {
            let fast = gauss_image_f64(w, h, &one_bin(&polys), &polys, radius, &|id| {
                value(id) as f32
            });
            let slow = reference_image(w, h, &polys, radius, |id| f64::from(value(id) as f32));
            let worst = max_difference(&fast, &slow);
            assert!(worst < 5e-8, "radius {radius}: worst pixel error {worst:e}");
        }
    }

    /// The largest per-pixel difference of two images.
    fn max_difference(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn pieces_split_over_bins_sum_as_one() {
        // The same polygons listed in two bins give the image of one bin listing them all.
        let polys = random_polygons(11, 12, 10.0, 10.0);
        let two = [
            BinRange {
                x: 0,
                y: 0,
                polys: 0..5,
            },
            BinRange {
                x: 8,
                y: 0,
                polys: 5..12,
            },
        ];
        let a = gauss_image_f64(10, 10, &two, &polys, 2.3, &|_| 1.0);
        let b = gauss_image_f64(10, 10, &one_bin(&polys), &polys, 2.3, &|_| 1.0);
        let worst = max_difference(&a, &b);
        assert!(worst < 1e-12, "{worst}");
    }

    #[test]
    fn no_bins_gives_black_image() {
        assert_eq!(gauss_image(3, 2, &[], &[], 2.3, &|_| 1.0), vec![0.0; 6]);
        let empty = [VisiblePolygon {
            triangle: 0,
            points: Vec::new(),
        }];
        assert_eq!(
            gauss_image(3, 2, &one_bin(&empty), &empty, 2.3, &|_| 1.0),
            vec![0.0; 6]
        );
    }
}
