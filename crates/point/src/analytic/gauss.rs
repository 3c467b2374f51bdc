//! Gaussian-filtered image: every pixel is the integral of the shaded visible polygons against a
//! Gaussian centred on the pixel centre, over a square window of half-width `radius`, normalised
//! by the window's mass.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 4.4 (Algorithm 4, radial filters of radius 2.3 px after Auzinger, Guthe, Jeschke.
//! Analytic Anti-Aliasing of Linear Functions on Polytopes. 2012).
//!
//! The Gaussian `g(x) g(y)` with `σ = radius / 3` is separable, so by Green's theorem its
//! integral over a convex polygon is a sum over the polygon's edges of
//! `∫ g(x - cx) Φ((y(x) - cy) / σ) dx` (Φ the normal CDF), a smooth one-dimensional integral.
//! Unlike the paper's polynomial filters, it has no elementary closed form; we evaluate it with
//! 8-point Gauss–Legendre rules on pieces at most σ wide (error far below f32 precision) and
//! `erf` to about 1e-7 (Abramowitz–Stegun 7.1.26). The window is a square, so the filter is
//! radially symmetric up to its truncation at `radius` (the Gaussian's mass outside is 0.5 %).

use glam::DVec2;
use rayon::prelude::*;

use super::integrate::BinRange;
use super::polygon::clip_to_rect;
use super::VisiblePolygon;

/// Gauss–Legendre nodes and weights on [-1, 1], 8 points.
const GL_X: [f64; 4] = [
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_3,
];
const GL_W: [f64; 4] = [
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_5,
    0.101_228_536_290_376_3,
];

/// `erf(x)`, absolute error below 1.5e-7 (Abramowitz–Stegun 7.1.26).
fn erf(x: f64) -> f64 {
    let s = x.signum();
    let x = x.abs();
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    s * (1.0 - poly * (-x * x).exp())
}

/// The filter: `σ` and the window half-width, in pixels.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Gauss {
    sigma: f64,
    /// Mass of the 1D Gaussian over `[-radius, radius]`.
    mass_1d: f64,
}

impl Gauss {
    /// A Gaussian with `σ = radius / 3`, truncated to the square of half-width `radius`.
    pub(crate) fn new(radius: f64) -> Self {
        let sigma = radius / 3.0;
        Self {
            sigma,
            mass_1d: erf(radius / (sigma * std::f64::consts::SQRT_2)),
        }
    }

    /// `Φ(t / σ)`, the normal CDF at `t` pixels.
    fn cdf(&self, t: f64) -> f64 {
        0.5 * (1.0 + erf(t / (self.sigma * std::f64::consts::SQRT_2)))
    }

    /// The 1D Gaussian density at `t` pixels.
    fn density(&self, t: f64) -> f64 {
        (-0.5 * (t / self.sigma).powi(2)).exp() / (self.sigma * (2.0 * std::f64::consts::PI).sqrt())
    }

    /// `∫ g(x) g(y) dA` over the convex polygon `poly` (coordinates relative to the pixel
    /// centre, counter-clockwise in the y-down sense), normalised by the window's mass.
    pub(crate) fn integral(&self, poly: &[DVec2]) -> f64 {
        let n = poly.len();
        let mut sum = 0.0;
        for i in 0..n {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            let w = b.x - a.x;
            if w == 0.0 {
                continue;
            }
            // Green's theorem: for a polygon counter-clockwise in the y-down sense (clockwise in
            // the usual y-up sense), ∫∫ g(x) g(y) dA = -∮ g(x) Φ(y) dx.
            let pieces = ((w.abs() / self.sigma).ceil() as usize).max(1);
            let h = w / pieces as f64;
            let slope = (b.y - a.y) / w;
            for k in 0..pieces {
                let mid = a.x + h * (k as f64 + 0.5);
                let half = 0.5 * h;
                for (&x, &wt) in GL_X.iter().zip(&GL_W) {
                    for xx in [mid - half * x, mid + half * x] {
                        let y = a.y + slope * (xx - a.x);
                        sum += wt * half * self.density(xx) * self.cdf(y);
                    }
                }
            }
        }
        -sum / (self.mass_1d * self.mass_1d)
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
    let filter = Gauss::new(radius);
    let (w, h) = (width as i64, height as i64);
    // Each bin adds into the pixels within `radius` of its pieces; bins are summed in order.
    let parts: Vec<Vec<(usize, f64)>> = bins
        .par_iter()
        .map(|bin| {
            let mut acc: Vec<(usize, f64)> = Vec::new();
            for poly in &polygons[bin.polys.clone()] {
                let v = f64::from(value(poly.triangle));
                if v == 0.0 {
                    continue;
                }
                let (mut lo, mut hi) =
                    (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
                for p in &poly.points {
                    lo = lo.min(*p);
                    hi = hi.max(*p);
                }
                // Pixel centres within `radius` of the box.
                let x0 = ((lo.x - radius - 0.5).ceil() as i64).max(0);
                let x1 = ((hi.x + radius - 0.5).floor() as i64).min(w - 1);
                let y0 = ((lo.y - radius - 0.5).ceil() as i64).max(0);
                let y1 = ((hi.y + radius - 0.5).floor() as i64).min(h - 1);
                for py in y0..=y1 {
                    for px in x0..=x1 {
                        let c = DVec2::new(px as f64 + 0.5, py as f64 + 0.5);
                        let window = [c.x - radius, c.y - radius, c.x + radius, c.y + radius];
                        let clipped = clip_to_rect(&poly.points, window);
                        if clipped.len() < 3 {
                            continue;
                        }
                        let local: Vec<DVec2> = clipped.iter().map(|p| *p - c).collect();
                        acc.push(((py * w + px) as usize, v * filter.integral(&local)));
                    }
                }
            }
            acc
        })
        .collect();
    let mut image = vec![0.0f64; (w * h) as usize];
    for part in parts {
        for (i, v) in part {
            image[i] += v;
        }
    }
    image.into_iter().map(|v| v as f32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(h: f64) -> Vec<DVec2> {
        vec![
            DVec2::new(-h, -h),
            DVec2::new(h, -h),
            DVec2::new(h, h),
            DVec2::new(-h, h),
        ]
    }

    #[test]
    fn erf_matches_known_values() {
        let e = [erf(0.5), erf(-1.5), erf(0.0)];
        assert!((e[0] - 0.520_499_877_813_046_5).abs() < 2e-7, "{e:?}");
        assert!((e[1] + 0.966_105_146_475_310_7).abs() < 2e-7, "{e:?}");
        assert!(e[2].abs() < 2e-7, "{e:?}");
    }

    #[test]
    fn whole_window_integrates_to_one() {
        let g = Gauss::new(2.3);
        let v = g.integral(&square(2.3));
        assert!((v - 1.0).abs() < 1e-6, "{v}");
    }

    #[test]
    fn half_window_integrates_to_half() {
        let g = Gauss::new(2.3);
        let half = [
            DVec2::new(0.0, -2.3),
            DVec2::new(2.3, -2.3),
            DVec2::new(2.3, 2.3),
            DVec2::new(0.0, 2.3),
        ];
        let v = g.integral(&half);
        assert!((v - 0.5).abs() < 1e-6, "{v}");
    }

    #[test]
    fn empty_polygon_integrates_to_zero() {
        assert_eq!(Gauss::new(2.3).integral(&[]), 0.0);
    }
}
