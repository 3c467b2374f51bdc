//! The top-down map of the view cells: the scene's footprint (see `footprint.rs`) under the
//! cells, each drawn as the outline of its box seen from above (projected as `plan.rs` says)
//! and filled by its PVS size on the colour scale, with a legend. Cells stacked on the up axis
//! overlap; the upper ones are drawn last.

use std::fmt::Write as _;

use sightline_core::Scene;
use sightline_region::ViewCell;

use super::colour::{hex, ColourScale};
use super::error::ReportError;
use super::footprint::footprint_image;
use super::html::{escape, png_data_uri};
use super::plan::{MapFrame, Plan};

/// Convex hull of 2D points (Andrew's monotone chain), counter-clockwise, without repeats.
pub(crate) fn convex_hull(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|q| q.0.is_finite() && q.1.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &(f64, f64)>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

/// Half size in pixels under which a cell is drawn as a marker of this half size.
const MIN_HALF_PX: f64 = 8.0;

/// One cell on the map.
pub(crate) struct MapCell {
    /// The cell.
    pub cell: ViewCell,
    /// The value it is coloured by (PVS size).
    pub value: f64,
    /// Hover text.
    pub title: String,
}

/// The map as an inline `<svg>` at most `max_width` pixels wide; `value_label` names the
/// coloured quantity in the legend.
pub(crate) fn map_svg(
    scene: &Scene,
    cells: &[MapCell],
    max_width: u32,
    value_label: &str,
) -> Result<String, ReportError> {
    let plan = Plan::new(scene.up);
    let boxes: Vec<ViewCell> = cells.iter().map(|c| c.cell).collect();
    let frame = MapFrame::around(scene, &boxes, &plan, max_width, max_width);
    let ground = footprint_image(scene, &plan, &frame);
    let scale = ColourScale::spanning(cells.iter().map(|c| c.value));
    let legend_h = 44.0;
    let (w, h) = (frame.width as f64, frame.height as f64);
    let mut svg = format!(
        "<svg id=\"cell-map\" xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{:.0}\" \
         viewBox=\"0 0 {w:.0} {:.0}\" font-family=\"sans-serif\">\n\
         <image x=\"0\" y=\"0\" width=\"{w:.0}\" height=\"{h:.0}\" href=\"{}\"/>\n",
        h + legend_h,
        h + legend_h,
        png_data_uri(&ground)?
    );
    let mut order: Vec<usize> = (0..cells.len()).collect();
    order.sort_by(|&a, &b| {
        plan.height(cells[a].cell.center)
            .total_cmp(&plan.height(cells[b].cell.center))
    });
    let label = cells.len() <= 64;
    for i in order {
        let c = &cells[i];
        let corners: Vec<(f64, f64)> = c
            .cell
            .corners()
            .iter()
            .map(|&p| frame.pixel_of(plan.project(p)))
            .collect();
        let mut hull = convex_hull(&corners);
        // Cells a few pixels across would vanish: draw them as a small square marker.
        let (cx, cy) = frame.pixel_of(plan.project(c.cell.center));
        let span = hull
            .iter()
            .map(|&(x, y)| (x - cx).abs().max((y - cy).abs()))
            .fold(0.0, f64::max);
        let marker = span < MIN_HALF_PX;
        if marker {
            hull = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .map(|(dx, dy)| (cx + dx * MIN_HALF_PX, cy + dy * MIN_HALF_PX))
                .to_vec();
        }
        let points: String = hull
            .iter()
            .map(|(x, y)| format!("{x:.1},{y:.1} "))
            .collect();
        let _ = writeln!(
            svg,
            "<polygon class=\"cell\" data-cell=\"{i}\" data-value=\"{}\" points=\"{}\" fill=\"{}\" \
             fill-opacity=\"0.7\" stroke=\"#222\" stroke-width=\"0.8\"><title>{}</title></polygon>",
            c.value,
            points.trim_end(),
            hex(scale.colour(c.value)),
            escape(&c.title)
        );
        if label {
            // A marker's number goes beside it, a cell's in its middle.
            let (tx, anchor) = if marker {
                (cx + MIN_HALF_PX + 2.0, "start")
            } else {
                (cx, "middle")
            };
            let _ = writeln!(
                svg,
                "<text x=\"{tx:.1}\" y=\"{:.1}\" font-size=\"11\" text-anchor=\"{anchor}\" \
                 fill=\"#000\" stroke=\"#fff\" stroke-width=\"2.5\" paint-order=\"stroke\">{i}</text>",
                cy + 4.0
            );
        }
    }
    svg.push_str(&scale.legend_svg(
        "map-scale",
        10.0,
        h + 6.0,
        (w - 20.0).clamp(40.0, 320.0),
        value_label,
    ));
    svg.push_str("\n</svg>\n");
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use sightline_core::scene::UpAxis;

    #[test]
    fn hull_of_nothing_is_empty() {
        assert!(convex_hull(&[]).is_empty());
    }

    #[test]
    fn hull_of_box_corners_is_its_rectangle() {
        let pts = [
            (0.0, 0.0),
            (2.0, 0.0),
            (2.0, 1.0),
            (0.0, 1.0),
            (0.0, 0.0),
            (2.0, 1.0),
            (1.0, 0.5),
        ];
        let h = convex_hull(&pts);
        assert_eq!(h.len(), 4);
        for p in [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (0.0, 1.0)] {
            assert!(h.contains(&p));
        }
    }

    #[test]
    fn map_colours_cells_by_value_and_escapes_titles() {
        let mut b = sightline_core::scene::SceneBuilder::new("box");
        b.add_box(Vec3::ZERO, Vec3::new(10.0, 10.0, 1.0));
        let mut scene = b.finish();
        scene.up = UpAxis::Z;
        let cell =
            |x: f32| ViewCell::aabb(Vec3::new(x, 1.0, 0.0), Vec3::new(x + 1.0, 2.0, 1.0)).unwrap();
        let cells = [
            MapCell {
                cell: cell(1.0),
                value: 10.0,
                title: "a <b>".into(),
            },
            MapCell {
                cell: cell(5.0),
                value: 30.0,
                title: "c".into(),
            },
        ];
        let svg = map_svg(&scene, &cells, 300, "PVS").unwrap();
        assert_eq!(svg.matches("<polygon").count(), 2);
        assert!(svg.contains(&hex(super::super::colour::ramp(0.0))));
        assert!(svg.contains(&hex(super::super::colour::ramp(1.0))));
        assert!(svg.contains("a &lt;b&gt;"));
        assert!(svg.contains("data:image/png;base64,"));
    }
}
