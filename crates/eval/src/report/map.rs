//! The top-down map of the view cells: the scene's footprint (see `footprint.rs`) under the
//! cells, each drawn as the outline of its box seen from above (projected as `plan.rs` says)
//! and filled on a colour scale, with a legend, once per layer (PVS size, pixel error: the page
//! shows one at a time); cells whose PVS missed triangles are outlined in red, and each cell
//! links to its row of the cell table. Cells stacked on the up axis overlap; the upper ones
//! are drawn last.

use std::fmt::Write as _;

use sightline_core::Scene;
use sightline_region::ViewCell;

use super::colour::{hex, ColourScale};
use super::error::ReportError;
use super::footprint::footprint_image;
use super::html::{escape, png_data_uri};
use super::plan::{MapFrame, Plan};

/// Convex hull of 2D points (Andrew's monotone chain), counter-clockwise, without repeats.
pub fn convex_hull(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
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
    /// Hover text.
    pub title: String,
    /// Drawn with a red outline (cells whose PVS missed triangles seen from them).
    pub flagged: bool,
}

/// One colouring of the cells: `values[i]` for cell `i` on its own colour scale, drawn in a
/// group of class `class` with its legend.
pub(crate) struct MapLayer<'a> {
    /// The group's class (the page's controls show one layer at a time by class).
    pub class: &'a str,
    /// The coloured quantity, for the legend.
    pub label: &'a str,
    pub values: Vec<f64>,
}

/// Most floors the map offers (its radio buttons and the page's style rules go to 4).
pub(crate) const MAX_FLOORS: usize = 4;

/// The floor of every cell when cells are stacked (two cells overlapping from above, one
/// wholly above the other, as Quake 3 clusters of several storeys are), else `None`: the cells'
/// heights (of their centres) split at the largest gaps between them (of at least half the
/// median cell height) into at most [`MAX_FLOORS`] bands, numbered from 1, lowest first.
pub(crate) fn floors(cells: &[ViewCell], plan: &Plan) -> Option<Vec<usize>> {
    let extent = |c: &ViewCell| {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in c.corners() {
            let [x, y] = plan.project(p);
            let z = plan.height(p);
            for (k, v) in [x, y, z].into_iter().enumerate() {
                lo[k] = lo[k].min(v);
                hi[k] = hi[k].max(v);
            }
        }
        (lo, hi)
    };
    let boxes: Vec<_> = cells.iter().map(extent).collect();
    let stacked = (0..boxes.len()).any(|i| {
        (i + 1..boxes.len()).any(|j| {
            let ((a0, a1), (b0, b1)) = (boxes[i], boxes[j]);
            let overlap = |k: usize| a0[k] < b1[k] && b0[k] < a1[k];
            overlap(0) && overlap(1) && (a1[2] <= b0[2] || b1[2] <= a0[2])
        })
    });
    if !stacked {
        return None;
    }
    let heights: Vec<f64> = cells.iter().map(|c| plan.height(c.center)).collect();
    let mut sorted = heights.clone();
    sorted.sort_by(f64::total_cmp);
    // The largest gaps between consecutive heights are the splits between floors; a gap under
    // half a typical cell's height is cells of one floor at slightly different heights.
    let mut tall: Vec<f64> = boxes.iter().map(|(lo, hi)| hi[2] - lo[2]).collect();
    tall.sort_by(f64::total_cmp);
    let least_gap = 0.5 * tall[tall.len() / 2];
    let mut gaps: Vec<(f64, f64)> = sorted
        .windows(2)
        .filter(|w| w[1] - w[0] >= least_gap && w[1] > w[0])
        .map(|w| (w[1] - w[0], 0.5 * (w[0] + w[1])))
        .collect();
    gaps.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut splits: Vec<f64> = gaps.iter().take(MAX_FLOORS - 1).map(|g| g.1).collect();
    splits.sort_by(f64::total_cmp);
    Some(
        heights
            .iter()
            .map(|&h| 1 + splits.iter().filter(|&&s| h > s).count())
            .collect(),
    )
}

/// A cell's outline on the map in pixels: the convex hull of its box's corners seen from above,
/// or a small square marker for a cell a few pixels across (it would vanish), and its centre.
fn outline(c: &ViewCell, plan: &Plan, frame: &MapFrame) -> (Vec<(f64, f64)>, (f64, f64), bool) {
    let corners: Vec<(f64, f64)> = c
        .corners()
        .iter()
        .map(|&p| frame.pixel_of(plan.project(p)))
        .collect();
    let hull = convex_hull(&corners);
    let (cx, cy) = frame.pixel_of(plan.project(c.center));
    let span = hull
        .iter()
        .map(|&(x, y)| (x - cx).abs().max((y - cy).abs()))
        .fold(0.0, f64::max);
    if span < MIN_HALF_PX {
        let square = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(dx, dy)| (cx + dx * MIN_HALF_PX, cy + dy * MIN_HALF_PX))
            .to_vec();
        (square, (cx, cy), true)
    } else {
        (hull, (cx, cy), false)
    }
}

/// The map as an inline `<svg>` at most `max_width` pixels wide: the footprint, then one group
/// per layer (class `layer` and the layer's class: its cells filled on its scale, and its
/// legend), then the cell numbers. Each cell links to `#cell-row-{i}` (its row in the cell
/// table); flagged cells get a red outline in every layer.
pub(crate) fn map_svg(
    scene: &Scene,
    cells: &[MapCell],
    layers: &[MapLayer<'_>],
    max_width: u32,
) -> Result<String, ReportError> {
    let plan = Plan::new(scene.up);
    let boxes: Vec<ViewCell> = cells.iter().map(|c| c.cell).collect();
    let frame = MapFrame::around(scene, &boxes, &plan, max_width, max_width);
    let ground = footprint_image(scene, &plan, &frame);
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
    // Upper cells last, so they cover the ones below.
    let mut order: Vec<usize> = (0..cells.len()).collect();
    order.sort_by(|&a, &b| {
        plan.height(cells[a].cell.center)
            .total_cmp(&plan.height(cells[b].cell.center))
    });
    let outlines: Vec<_> = cells
        .iter()
        .map(|c| outline(&c.cell, &plan, &frame))
        .collect();
    // With stacked cells every drawn element says its floor, so the page can show one.
    let floor_of = floors(&boxes, &plan);
    let floor_class = |i: usize| match &floor_of {
        Some(f) => format!(r#" class="floor band-{}""#, f[i]),
        None => String::new(),
    };
    for layer in layers {
        let scale = ColourScale::spanning(layer.values.iter().copied());
        let _ = writeln!(svg, "<g class=\"layer {}\">", escape(layer.class));
        for &i in &order {
            let (c, value) = (&cells[i], layer.values[i]);
            let points: String = outlines[i]
                .0
                .iter()
                .map(|(x, y)| format!("{x:.1},{y:.1} "))
                .collect();
            let (class, stroke, stroke_w) = if c.flagged {
                ("cell flagged", "#d00", 2.5)
            } else {
                ("cell", "#222", 0.8)
            };
            let _ = writeln!(
                svg,
                "<a href=\"#cell-row-{i}\"{}><polygon class=\"{class}\" data-cell=\"{i}\" data-value=\"{value}\" \
                 points=\"{}\" fill=\"{}\" fill-opacity=\"0.7\" stroke=\"{stroke}\" \
                 stroke-width=\"{stroke_w}\"><title>{}</title></polygon></a>",
                floor_class(i),
                points.trim_end(),
                hex(scale.colour(value)),
                escape(&c.title)
            );
        }
        svg.push_str(&scale.legend_svg(
            &format!("map-scale-{}", layer.class),
            10.0,
            h + 6.0,
            (w - 20.0).clamp(40.0, 320.0),
            layer.label,
        ));
        svg.push_str("</g>\n");
    }
    if cells.len() <= 64 {
        for &i in &order {
            // A marker's number goes beside it, a cell's in its middle.
            let (_, (cx, cy), marker) = outlines[i];
            let (tx, anchor) = if marker {
                (cx + MIN_HALF_PX + 2.0, "start")
            } else {
                (cx, "middle")
            };
            let _ = writeln!(
                svg,
                "<text{} x=\"{tx:.1}\" y=\"{:.1}\" font-size=\"11\" text-anchor=\"{anchor}\" \
                 fill=\"#000\" stroke=\"#fff\" stroke-width=\"2.5\" paint-order=\"stroke\" \
                 pointer-events=\"none\">{i}</text>",
                floor_class(i),
                cy + 4.0
            );
        }
    }
    svg.push_str("</svg>\n");
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
                title: "a <b>".into(),
                flagged: false,
            },
            MapCell {
                cell: cell(5.0),
                title: "c".into(),
                flagged: true,
            },
        ];
        let layers = [
            MapLayer {
                class: "by-pvs",
                label: "PVS",
                values: vec![10.0, 30.0],
            },
            MapLayer {
                class: "by-error",
                label: "error",
                values: vec![0.0, 2.0],
            },
        ];
        let svg = map_svg(&scene, &cells, &layers, 300).unwrap();
        // Each layer draws every cell, linked to its table row; the flagged cell is outlined
        // in red in both.
        assert_eq!(svg.matches("<polygon").count(), 4);
        assert_eq!(svg.matches("<g class=\"layer by-error\">").count(), 1);
        assert_eq!(svg.matches("href=\"#cell-row-1\"").count(), 2);
        assert_eq!(
            svg.matches("class=\"cell flagged\" data-cell=\"1\"")
                .count(),
            2
        );
        assert!(!svg.contains("class=\"cell flagged\" data-cell=\"0\""));
        assert!(svg.contains("data-cell=\"1\" data-value=\"2\""));
        assert!(svg.contains(&hex(super::super::colour::ramp(0.0))));
        assert!(svg.contains(&hex(super::super::colour::ramp(1.0))));
        assert!(svg.contains("a &lt;b&gt;"));
        assert!(svg.contains("data:image/png;base64,"));
    }

    #[test]
    fn stacked_cells_get_floors_from_the_largest_height_gaps() {
        let plan = Plan::new(UpAxis::Z);
        let cell = |x: f32, z: f32| {
            ViewCell::aabb(Vec3::new(x, 0.0, z), Vec3::new(x + 1.0, 1.0, z + 1.0)).unwrap()
        };
        // Side by side: no floors.
        assert_eq!(floors(&[cell(0.0, 0.0), cell(2.0, 0.0)], &plan), None);
        // Two storeys (z 0 and 0.2 below, 5 above): the gap between them splits them.
        let two = [
            cell(0.0, 0.0),
            cell(2.0, 0.2),
            cell(0.0, 5.0),
            cell(2.0, 5.0),
        ];
        let f = floors(&two, &plan).unwrap();
        assert_eq!(f[0], f[1]);
        assert_eq!(f[2], f[3]);
        assert!(f[0] < f[2]);
        // Never more than MAX_FLOORS, numbered from 1.
        let tower: Vec<ViewCell> = (0..10).map(|k| cell(0.0, 3.0 * k as f32)).collect();
        let f = floors(&tower, &plan).unwrap();
        assert_eq!(*f.iter().min().unwrap(), 1);
        assert_eq!(*f.iter().max().unwrap(), MAX_FLOORS);
        assert!(f.windows(2).all(|w| w[0] <= w[1]), "lowest first: {f:?}");
    }
}
