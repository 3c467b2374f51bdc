//! The guides drawn over the scene, as line and triangle vertices for the renderer: the view
//! cells' wireframe with the cell in use highlighted (yellow for the eye's cell, cyan for a
//! picked one), the frozen camera's frustum (orange) and, in the overview, the cells as quads
//! filled and outlined in the report map's colours for their PVS size, with the eye marked
//! (white; the frozen camera orange). Pure geometry: no GPU, so it is tested on its own.

use glam::Vec3;
use sightline_core::{Aabb, Camera};
use sightline_eval::report::colour::ColourScale;
use sightline_eval::report::convex_hull;
use sightline_region::PvsFile;

use crate::cell_pick::CellSource;
use crate::frustum::{clamped_far, frustum_corners, frustum_edges};
use crate::overview::OrthoCamera;
use crate::renderer::LineVertex;

/// The eye's cell.
const EYE_CELL: [f32; 4] = [1.0, 0.85, 0.1, 1.0];
/// A picked cell.
const PICKED_CELL: [f32; 4] = [0.1, 0.9, 1.0, 1.0];
/// The other cells of the wireframe: faint, so they do not hide the scene.
const OTHER_CELL: [f32; 4] = [0.7, 0.8, 1.0, 0.25];
/// The frozen camera's frustum and marker.
pub(crate) const FRUSTUM: [f32; 4] = [1.0, 0.55, 0.1, 1.0];
/// The eye's marker in the overview.
const EYE_MARKER: [f32; 4] = [1.0, 1.0, 1.0, 1.0];
/// Opacity of the overview's cell fills (outlines are opaque, in the same colour).
const FILL_ALPHA: f32 = 0.45;

/// What the guides show.
pub(crate) struct GuideInput<'a> {
    /// The cells, if a `.pvs` is loaded.
    pub pvs: Option<&'a PvsFile>,
    /// Whether cells are drawn (key C).
    pub show_cells: bool,
    /// The cell in use and where it came from.
    pub cell: Option<(usize, CellSource)>,
    /// The frozen camera, while frozen.
    pub frozen: Option<&'a Camera>,
    /// The scene's bounds (the frustum's far plane is clamped to them).
    pub bounds: Aabb,
    /// The overview's camera, in the overview.
    pub overview: Option<&'a OrthoCamera>,
    /// The moving eye and its view direction (marked in the overview).
    pub eye: (Vec3, Vec3),
}

/// Line vertices (in pairs) and triangle vertices (in triples).
#[derive(Default)]
pub(crate) struct Guides {
    pub lines: Vec<LineVertex>,
    pub fills: Vec<LineVertex>,
}

impl Guides {
    fn line(&mut self, a: Vec3, b: Vec3, colour: [f32; 4]) {
        for p in [a, b] {
            self.lines.push(LineVertex {
                position: p.to_array(),
                colour,
            });
        }
    }
}

/// The colour highlighting the cell in use from `source`.
fn highlight(source: CellSource) -> [f32; 4] {
    match source {
        CellSource::Picked => PICKED_CELL,
        CellSource::Eye => EYE_CELL,
    }
}

/// The guides of `input`: see the module documentation.
pub(crate) fn guides(input: &GuideInput) -> Guides {
    let mut g = Guides::default();
    match input.overview {
        None => {
            cell_wireframe(input, &mut g);
            if let Some(frozen) = input.frozen {
                let corners = frustum_corners(frozen, clamped_far(frozen, &input.bounds));
                for (a, b) in frustum_edges(&corners) {
                    g.line(a, b, FRUSTUM);
                }
            }
        }
        Some(o) => {
            cell_map(input, o, &mut g);
            overview_marks(input, o, &mut g);
        }
    }
    g
}

/// Every cell's edges, the one in use highlighted.
fn cell_wireframe(input: &GuideInput, g: &mut Guides) {
    let Some(pvs) = input.pvs.filter(|_| input.show_cells) else {
        return;
    };
    for (i, c) in pvs.cells.iter().enumerate() {
        let colour = match input.cell {
            Some((cell, source)) if cell == i => highlight(source),
            _ => OTHER_CELL,
        };
        for (a, b) in c.cell.edges() {
            g.line(a, b, colour);
        }
    }
}

/// The colour of every cell on the report map's scale of PVS sizes (triangles), as RGBA.
pub(crate) fn cell_colours(pvs: &PvsFile) -> Vec<[f32; 4]> {
    let sizes: Vec<f64> = pvs
        .cells
        .iter()
        .map(|c| c.visible.count_ones(..) as f64)
        .collect();
    let scale = ColourScale::spanning(sizes.iter().copied());
    sizes
        .iter()
        .map(|&s| {
            let [r, g, b] = scale.colour(s).map(|v| f32::from(v) / 255.0);
            [r, g, b, 1.0]
        })
        .collect()
}

/// The overview's cells seen from above: each cell's outline (the convex hull of its corners
/// on the map plane) filled translucent and outlined opaque in its colour; the cell in use
/// outlined in its highlight colour, last, so it stays on top.
fn cell_map(input: &GuideInput, o: &OrthoCamera, g: &mut Guides) {
    let Some(pvs) = input.pvs.filter(|_| input.show_cells) else {
        return;
    };
    let colours = cell_colours(pvs);
    // Map-plane points from (right, up) coordinates: the plane's depth is the same for all.
    let plane = o.flatten(o.eye).dot(o.forward);
    let lift = |(x, y): (f64, f64)| o.right * x as f32 + o.up * y as f32 + o.forward * plane;
    let outline = |i: usize| -> Vec<Vec3> {
        let corners: Vec<(f64, f64)> = pvs.cells[i]
            .cell
            .corners()
            .iter()
            .map(|&p| (f64::from(p.dot(o.right)), f64::from(p.dot(o.up))))
            .collect();
        convex_hull(&corners).into_iter().map(lift).collect()
    };
    for (i, &colour) in colours.iter().enumerate() {
        let hull = outline(i);
        let fill = [colour[0], colour[1], colour[2], FILL_ALPHA];
        for k in 1..hull.len().saturating_sub(1) {
            for p in [hull[0], hull[k], hull[k + 1]] {
                g.fills.push(LineVertex {
                    position: p.to_array(),
                    colour: fill,
                });
            }
        }
        polygon(g, &hull, colour);
    }
    if let Some((cell, source)) = input.cell.filter(|(c, _)| *c < pvs.cells.len()) {
        polygon(g, &outline(cell), highlight(source));
    }
}

/// The closed polygon through `points`.
fn polygon(g: &mut Guides, points: &[Vec3], colour: [f32; 4]) {
    for k in 0..points.len() {
        g.line(points[k], points[(k + 1) % points.len()], colour);
    }
}

/// The overview's marks on the map plane: the eye (a cross with a tick along its view
/// direction) and, while frozen, the frozen camera's frustum and its eye.
fn overview_marks(input: &GuideInput, o: &OrthoCamera, g: &mut Guides) {
    let size = 0.03 * o.half_width.max(o.half_height);
    let mut mark = |eye: Vec3, forward: Vec3, colour: [f32; 4]| {
        let c = o.flatten(eye);
        g.line(c - o.right * size, c + o.right * size, colour);
        g.line(c - o.up * size, c + o.up * size, colour);
        let ahead = forward - o.forward * forward.dot(o.forward);
        if let Some(dir) = ahead.try_normalize() {
            g.line(c, c + dir * size * 2.5, colour);
        }
    };
    mark(input.eye.0, input.eye.1, EYE_MARKER);
    if let Some(frozen) = input.frozen {
        mark(frozen.eye, frozen.forward, FRUSTUM);
        let corners = frustum_corners(frozen, clamped_far(frozen, &input.bounds));
        for (a, b) in frustum_edges(&corners) {
            g.line(o.flatten(a), o.flatten(b), FRUSTUM);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::{TriangleSet, UpAxis};
    use sightline_eval::report::colour::ramp;
    use sightline_region::{CellPvs, ViewCell};

    /// Two cells side by side, with 1 and 3 triangles visible.
    fn pvs() -> PvsFile {
        let cell = |x: f32, ids: &[usize]| {
            let mut visible = TriangleSet::with_capacity(4);
            ids.iter().for_each(|&t| visible.insert(t));
            CellPvs {
                cell: ViewCell::aabb(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 1.0, 1.0)).unwrap(),
                visible,
                bound: None,
            }
        };
        PvsFile {
            scene_hash: 0,
            triangle_count: 4,
            objects: None,
            metadata: serde_json::Value::Null,
            cells: vec![cell(0.0, &[0]), cell(1.0, &[0, 1, 2])],
        }
    }

    fn input<'a>(pvs: &'a PvsFile, o: Option<&'a OrthoCamera>) -> GuideInput<'a> {
        GuideInput {
            pvs: Some(pvs),
            show_cells: true,
            cell: Some((1, CellSource::Picked)),
            frozen: None,
            bounds: Aabb::new(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0)),
            overview: o,
            eye: (Vec3::new(0.5, 0.5, 0.5), Vec3::X),
        }
    }

    #[test]
    fn cells_are_coloured_by_pvs_size_on_the_report_ramp() {
        let colours = cell_colours(&pvs());
        let rgb = |c: [f32; 4]| [c[0], c[1], c[2]].map(|v| (v * 255.0).round() as u8);
        assert_eq!(rgb(colours[0]), ramp(0.0));
        assert_eq!(rgb(colours[1]), ramp(1.0));
    }

    #[test]
    fn wireframe_highlights_the_picked_cell() {
        let p = pvs();
        let g = guides(&input(&p, None));
        assert_eq!(g.lines.len(), 2 * 24);
        assert!(g.fills.is_empty());
        assert!(g.lines[24..].iter().all(|v| v.colour == PICKED_CELL));
        assert!(g.lines[..24].iter().all(|v| v.colour == OTHER_CELL));
    }

    #[test]
    fn overview_fills_each_cell_on_the_map_plane_and_marks_the_eye() {
        let p = pvs();
        let mut i = input(&p, None);
        let o = OrthoCamera::over(&i.bounds, UpAxis::Z, 64, 32);
        i.overview = Some(&o);
        let camera = Camera::look_at(Vec3::ZERO, Vec3::X, Vec3::Z, 60.0, 8, 8, 0.1).unwrap();
        i.frozen = Some(&camera);
        let g = guides(&i);
        // Two triangles a cell, all on the map plane above the scene.
        assert_eq!(g.fills.len(), 2 * 6);
        let depth = |v: &LineVertex| o.ndc(Vec3::from_array(v.position)).z;
        let plane = depth(&g.fills[0]);
        assert!(g
            .fills
            .iter()
            .chain(&g.lines)
            .all(|v| (depth(v) - plane).abs() < 1e-4));
        assert!(g.lines.iter().any(|v| v.colour == EYE_MARKER));
        // The frozen frustum's 12 edges and the frozen eye's marker (3 lines).
        let frozen = g.lines.iter().filter(|v| v.colour == FRUSTUM).count();
        assert_eq!(frozen, 2 * (12 + 3));
    }
}
