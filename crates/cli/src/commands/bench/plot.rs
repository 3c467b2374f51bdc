//! The convergence plot of `sightline bench pvs --plot`: the curves
//! `sightline_eval::bench` computes, drawn log-log as an SVG file with plotters.

use anyhow::Result;
use sightline_eval::bench::{Convergence, ERROR_FLOOR};

/// Draws `convergence` (average error against rays, log-log) as `convergence_<scene>.svg` in
/// `dir`; returns the file's path.
pub(super) fn write_convergence_plot(
    dir: &std::path::Path,
    spec: &str,
    convergence: &Convergence,
    resolution: u32,
) -> Result<std::path::PathBuf> {
    use plotters::prelude::*;
    std::fs::create_dir_all(dir)?;
    let name: String = (spec.rsplit('/').next().unwrap_or(spec).chars())
        .map(|c| match c.is_ascii_alphanumeric() || c == '.' {
            true => c,
            false => '_',
        })
        .collect();
    let path = dir.join(format!("convergence_{name}.svg"));
    let (x0, x1) = convergence.ray_range();
    let y1 = convergence.max_error();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 600)).into_drawing_area();
        let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
            root.fill(&WHITE)?;
            let caption = format!("{spec}: average erroneous pixels per {resolution}² view");
            let mut chart = ChartBuilder::on(&root)
                .caption(caption, ("sans-serif", 18))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(
                    (x0 * 0.8..x1 * 1.25).log_scale(),
                    (ERROR_FLOOR..y1 * 2.0).log_scale(),
                )?;
            chart
                .configure_mesh()
                .x_desc("rays (RASTER: pixels)")
                .y_desc("avg error px")
                .draw()?;
            const COLOURS: [RGBColor; 4] = [RED, BLUE, GREEN, MAGENTA];
            for (s, colour) in convergence.series.iter().zip(COLOURS.iter().cycle()) {
                chart
                    .draw_series(LineSeries::new(s.points.clone(), colour))?
                    .label(s.method)
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
                chart.draw_series(s.points.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()?;
            root.present()?;
            Ok(())
        };
        draw().map_err(|e| anyhow::anyhow!("drawing {}: {e}", path.display()))?;
    }
    sightline_core::atomic_file::write_atomic(&path, |w| {
        std::io::Write::write_all(w, svg.as_bytes())
    })
    .map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))?;
    Ok(path)
}
