//! Line plots as inline SVG (plotters' SVG backend writing into a string): PVS size against
//! rays per cell (convergence), per-frame culling numbers, and log-log error curves (GVS++
//! against RAND at equal budgets, `bench pvs --plot`).

use super::error::ReportError;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::prelude::*;

/// One line of a plot.
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points `(x, y)`, x increasing.
    pub points: Vec<(f64, f64)>,
}

/// Most lines drawn in one plot (more would be an unreadable tangle; the caller says so).
pub(crate) const MAX_LINES: usize = 48;

/// The colour of line `i` (plotters' 99-colour palette), for legends written outside a plot.
pub fn series_colour(i: usize) -> [u8; 3] {
    let c = Palette99::pick(i).to_rgba();
    [c.0, c.1, c.2]
}

/// A plot of `series` with axis descriptions, `width x height` pixels. With `legend`, a legend
/// is drawn in the lower right when there are at most 12 lines (callers plotting curves that
/// pass there write their own legend with [`series_colour`]).
pub fn line_plot(
    series: &[Series],
    x_desc: &str,
    y_desc: &str,
    (width, height): (u32, u32),
    legend: bool,
) -> Result<String, ReportError> {
    let series = &series[..series.len().min(MAX_LINES)];
    let xmax = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .filter(|x| x.is_finite())
        .fold(1.0, f64::max);
    let ymax = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .filter(|y| y.is_finite())
        .fold(1.0, f64::max);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
            root.fill(&WHITE)?;
            let mut chart = ChartBuilder::on(&root)
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(64)
                .build_cartesian_2d(0.0..xmax * 1.02, 0.0..ymax * 1.05)?;
            draw_series(
                &mut chart,
                series,
                (x_desc, y_desc),
                &|p| p.0.is_finite() && p.1.is_finite(),
                false,
                (legend && series.len() <= 12).then_some(SeriesLabelPosition::LowerRight),
            )?;
            root.present()?;
            Ok(())
        };
        draw().map_err(|e| ReportError::Plot(e.to_string()))?;
    }
    Ok(svg)
}

/// A percentile band (`low..high` shaded, `median` as a dark line) on the x values `xs`, with
/// further `lines` over it in the colours of [`series_colour`] and a legend; y from 0 to 1
/// (fractions), `width x height` pixels.
pub fn band_plot(
    xs: &[f64],
    (low, median, high): (&[f64], &[f64], &[f64]),
    lines: &[Series],
    (x_desc, y_desc): (&str, &str),
    (width, height): (u32, u32),
) -> Result<String, ReportError> {
    let xmax = xs
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .fold(1.0, f64::max);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
            root.fill(&WHITE)?;
            let mut chart = ChartBuilder::on(&root)
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(64)
                .build_cartesian_2d(0.0..xmax * 1.02, 0.0..1.05)?;
            let shade = RGBColor(110, 140, 200);
            let outline: Vec<(f64, f64)> = xs
                .iter()
                .copied()
                .zip(high.iter().copied())
                .chain(xs.iter().copied().zip(low.iter().copied()).rev())
                .collect();
            chart
                .draw_series(std::iter::once(Polygon::new(
                    outline,
                    shade.mix(0.35).filled(),
                )))?
                .label("10th-90th percentile of the cells")
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 16, y + 5)], shade.mix(0.35).filled())
                });
            let dark = RGBColor(20, 40, 90);
            let mid: Vec<(f64, f64)> = xs.iter().copied().zip(median.iter().copied()).collect();
            chart
                .draw_series(LineSeries::new(mid, dark.stroke_width(3)))?
                .label("median cell")
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 16, y)], dark.stroke_width(3))
                });
            draw_series(
                &mut chart,
                lines,
                (x_desc, y_desc),
                &|p| p.0.is_finite() && p.1.is_finite(),
                false,
                None,
            )?;
            // The legend always has the band and the median, lines or not.
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()?;
            root.present()?;
            Ok(())
        };
        draw().map_err(|e| ReportError::Plot(e.to_string()))?;
    }
    Ok(svg)
}

/// A log-log plot of `series` (each drawn as a line with a marker at every point, in the
/// colours of [`series_colour`], with a legend), `width x height` pixels. Points must be
/// positive; the axes span the points with some room.
pub fn log_log_plot(
    series: &[Series],
    x_desc: &str,
    y_desc: &str,
    (width, height): (u32, u32),
) -> Result<String, ReportError> {
    let series = &series[..series.len().min(MAX_LINES)];
    let points = || {
        series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|p| p.0.is_finite() && p.1.is_finite() && p.0 > 0.0 && p.1 > 0.0)
    };
    let (x0, x1) = points().fold((f64::MAX, f64::MIN_POSITIVE), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (y0, y1) = points().fold((f64::MAX, f64::MIN_POSITIVE), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    let (x0, y0) = (x0.min(x1), y0.min(y1));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
            root.fill(&WHITE)?;
            let mut chart = ChartBuilder::on(&root)
                .margin(10)
                .x_label_area_size(36)
                .y_label_area_size(64)
                .build_cartesian_2d(
                    (x0 * 0.8..x1 * 1.25).log_scale(),
                    (y0 * 0.5..y1 * 2.0).log_scale(),
                )?;
            draw_series(
                &mut chart,
                series,
                (x_desc, y_desc),
                &|p| p.0.is_finite() && p.1.is_finite() && p.0 > 0.0 && p.1 > 0.0,
                true,
                Some(SeriesLabelPosition::UpperRight),
            )?;
            root.present()?;
            Ok(())
        };
        draw().map_err(|e| ReportError::Plot(e.to_string()))?;
    }
    Ok(svg)
}

/// Draws the mesh with its axis descriptions, `series` as lines of points for which `keep`
/// holds (with a marker at each point when `markers`), and the legend at `legend` when there
/// is one and any series: what the linear and the log-log plot share.
fn draw_series<'a, 'b: 'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<X, Y>>,
    series: &[Series],
    (x_desc, y_desc): (&str, &str),
    keep: &dyn Fn(&(f64, f64)) -> bool,
    markers: bool,
    legend: Option<SeriesLabelPosition>,
) -> std::result::Result<(), Box<dyn std::error::Error>>
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&|v| short_number(*v))
        .y_label_formatter(&|v| short_number(*v))
        .draw()?;
    for (i, s) in series.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(|p| keep(p)).collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))?
            .label(s.label.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour.stroke_width(2)));
        if markers {
            chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, colour.filled())))?;
        }
    }
    if let (Some(position), false) = (legend, series.is_empty()) {
        chart
            .configure_series_labels()
            .position(position)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
    }
    Ok(())
}

/// `1234567` as `1.2M`, `25000` as `25k`, small numbers as they are.
pub(crate) fn short_number(v: f64) -> String {
    let a = v.abs();
    if a >= 1e9 {
        format!("{:.1}G", v / 1e9)
    } else if a >= 1e6 {
        format!("{:.1}M", v / 1e6)
    } else if a >= 1e4 {
        format!("{:.0}k", v / 1e3)
    } else if v.fract() == 0.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.2}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_numbers() {
        assert_eq!(short_number(0.0), "0");
        assert_eq!(short_number(950.0), "950");
        assert_eq!(short_number(25_000.0), "25k");
        assert_eq!(short_number(2_500_000.0), "2.5M");
        assert_eq!(short_number(0.25), "0.25");
    }

    #[test]
    fn plot_of_no_series_is_an_empty_chart() {
        let svg = line_plot(&[], "rays", "PVS", (300, 200), true).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    }

    #[test]
    fn plot_draws_one_polyline_per_series_with_legend() {
        let s = |label: &str, k: f64| Series {
            label: label.into(),
            points: (0..5).map(|i| (i as f64 * 100.0, k * i as f64)).collect(),
        };
        let series = [s("cell 0", 1.0), s("cell <1>", 2.0)];
        let svg = line_plot(&series, "rays", "PVS", (400, 300), true).unwrap();
        assert!(svg.matches("<polyline").count() >= 2, "{svg}");
        assert!(svg.contains("cell 0"));
        assert!(!svg.contains("cell <1>"), "legend text must be escaped");
        let bare = line_plot(&series, "rays", "PVS", (400, 300), false).unwrap();
        assert!(!bare.contains("cell 0"));
    }

    #[test]
    fn log_log_plot_draws_each_series_with_markers_and_skips_non_positive_points() {
        let series = [
            Series {
                label: "GVS++".into(),
                points: vec![(0.1, 5.0), (0.4, 0.01), (1.6, 0.0)],
            },
            Series {
                label: "RAND".into(),
                points: vec![(0.1, 50.0), (0.4, 12.0), (1.6, 3.0)],
            },
        ];
        let svg = log_log_plot(&series, "seconds", "error", (400, 300)).unwrap();
        assert!(svg.matches("<polyline").count() >= 2, "{svg}");
        assert!(svg.contains("GVS++") && svg.contains("RAND"));
        // Five positive points, a marker each (the zero error is left out).
        assert_eq!(svg.matches("<circle").count(), 5, "{svg}");
        let empty = log_log_plot(&[], "s", "e", (300, 200)).unwrap();
        assert!(empty.trim_end().ends_with("</svg>"));
    }

    #[test]
    fn series_colours_differ() {
        assert_ne!(series_colour(0), series_colour(1));
    }
}
