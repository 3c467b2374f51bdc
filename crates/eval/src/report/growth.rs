//! How the cells of a many-cell bake converged, as one distribution instead of hundreds of
//! lines: each cell's PVS size after each batch of rays, as a fraction of its final size,
//! resampled on a common ray axis, and the 10th, 50th and 90th percentile over the cells at
//! every point ([`growth_band`]). The report draws the band with the median and the worst
//! cells as labelled lines (`plot::band_plot`).
//!
//! A cell's curve holds its last value after its last batch (the cell had finished), and is 0
//! before its first. The fraction of the final size is what tells convergence apart from PVS
//! size: a cell that found 99 % of its set in the first tenth of its rays has converged, however
//! large the set.

/// The percentile band of the cells' growth curves on a common ray axis.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Band {
    /// Rays, increasing, from 0 to the largest ray count of any cell.
    pub rays: Vec<f64>,
    /// 10th percentile, median and 90th percentile of the fraction of the final PVS found.
    pub low: Vec<f64>,
    pub median: Vec<f64>,
    pub high: Vec<f64>,
}

/// A cell's `(rays, PVS size)` curve as `(rays, fraction of the final size)`, with the origin
/// first; `None` for an empty curve or an empty final set.
pub(crate) fn growth_fraction(curve: &[(u64, u64)]) -> Option<Vec<(f64, f64)>> {
    let &(_, last) = curve.last()?;
    if last == 0 {
        return None;
    }
    Some(
        std::iter::once((0.0, 0.0))
            .chain(
                curve
                    .iter()
                    .map(|&(r, p)| (r as f64, p as f64 / last as f64)),
            )
            .collect(),
    )
}

/// The value of a step curve (points increasing in x) at `x`: its last point at or before `x`.
fn value_at(curve: &[(f64, f64)], x: f64) -> f64 {
    let i = curve.partition_point(|p| p.0 <= x);
    if i == 0 {
        0.0
    } else {
        curve[i - 1].1
    }
}

/// The `q` quantile (0 to 1) of sorted values, interpolated linearly between ranks.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let at = q * (sorted.len() - 1) as f64;
    let (i, t) = (at.floor() as usize, at.fract());
    match sorted.get(i + 1) {
        Some(&next) => sorted[i] + t * (next - sorted[i]),
        None => sorted[i],
    }
}

/// The band of the growth curves (as [`growth_fraction`] gives them) at `points` rays evenly
/// spaced from 0 to the longest curve's end; `None` without curves or with fewer than 2 points.
pub(crate) fn growth_band(curves: &[Vec<(f64, f64)>], points: usize) -> Option<Band> {
    let end = curves
        .iter()
        .filter_map(|c| c.last().map(|p| p.0))
        .fold(0.0, f64::max);
    if curves.is_empty() || points < 2 || end <= 0.0 {
        return None;
    }
    let mut band = Band {
        rays: Vec::with_capacity(points),
        low: Vec::with_capacity(points),
        median: Vec::with_capacity(points),
        high: Vec::with_capacity(points),
    };
    let mut values = Vec::with_capacity(curves.len());
    for k in 0..points {
        let x = end * k as f64 / (points - 1) as f64;
        values.clear();
        values.extend(curves.iter().map(|c| value_at(c, x)));
        values.sort_by(f64::total_cmp);
        band.rays.push(x);
        band.low.push(quantile(&values, 0.1));
        band.median.push(quantile(&values, 0.5));
        band.high.push(quantile(&values, 0.9));
    }
    Some(band)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fractions_are_of_the_final_size_and_start_at_the_origin() {
        let f = growth_fraction(&[(100, 5), (200, 8), (300, 10)]).unwrap();
        assert_eq!(
            f,
            vec![(0.0, 0.0), (100.0, 0.5), (200.0, 0.8), (300.0, 1.0)]
        );
        assert_eq!(growth_fraction(&[]), None);
        assert_eq!(growth_fraction(&[(100, 0)]), None);
    }

    #[test]
    fn step_curves_hold_their_last_value() {
        let c = [(0.0, 0.0), (100.0, 0.5), (300.0, 1.0)];
        assert_eq!(value_at(&c, 50.0), 0.0);
        assert_eq!(value_at(&c, 100.0), 0.5);
        assert_eq!(value_at(&c, 299.0), 0.5);
        assert_eq!(value_at(&c, 1e9), 1.0);
    }

    #[test]
    fn quantiles_interpolate_between_ranks() {
        let v = [0.0, 1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile(&v, 0.5), 2.0);
        assert_eq!(quantile(&v, 0.1), 0.4);
        assert_eq!(quantile(&v, 1.0), 4.0);
        assert_eq!(quantile(&[7.0], 0.9), 7.0);
    }

    #[test]
    fn band_spans_the_cells_at_every_ray_count() {
        // Ten cells reaching their final size after 100, 200, ..., 1000 rays (half of it
        // half-way there).
        let curves: Vec<Vec<(f64, f64)>> = (1..=10)
            .map(|k| {
                let end = 100.0 * k as f64;
                vec![(0.0, 0.0), (end / 2.0, 0.5), (end, 1.0)]
            })
            .collect();
        let band = growth_band(&curves, 11).unwrap();
        assert_eq!(band.rays.len(), 11);
        assert_eq!((band.rays[0], band.rays[10]), (0.0, 1000.0));
        for k in 0..11 {
            assert!(band.low[k] <= band.median[k] && band.median[k] <= band.high[k]);
        }
        // At 500 rays: cells 1-5 are done (1.0), cells 6-10 half-way (0.5).
        assert_eq!(band.median[5], 0.75);
        assert_eq!((band.low[5], band.high[5]), (0.5, 1.0));
        // At the end every cell is done.
        assert_eq!((band.low[10], band.high[10]), (1.0, 1.0));
        assert!(growth_band(&[], 10).is_none());
        assert!(growth_band(&curves, 1).is_none());
    }
}
