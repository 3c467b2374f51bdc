//! Conservative depth pre-culling: removes polygons that are provably hidden everywhere before
//! the exact pipeline runs, so its per-edge work (quadratic in the polygons per bin) only sees
//! polygons that can be visible. The result is unchanged: a polygon hidden at every point by
//! more than the pipeline's depth tolerance contributes no visible piece, and removing it does
//! not uncover anything (whatever it hides is hidden by what hides it).
//!
//! Based on: the suggestion of depth pre-culling, made exact for sub-pixel geometry.
//! The paper (Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013)
//! processes every projected triangle; this step is ours.
//!
//! # Why a plain depth buffer is not enough, and what is used instead
//! A rasterized depth buffer knows the nearest surface at pixel *centres* only; a triangle
//! smaller than a pixel can be visible between them. A pixel may only serve as an occluder when
//! the nearest surface is bounded over the *whole* pixel square. We get that bound from
//! **patches**: polygons joined along edges that two polygons share in opposite directions (all
//! polygons are counter-clockwise, so such twins lie on opposite sides of the edge and the union
//! of the patch covers both sides). The boundary of a patch's union lies on its unmatched edges
//! (silhouette folds, mesh borders, T-junctions, the image border). So a pixel square that
//! touches the patch and no unmatched edge of it lies inside the union, and over that square the
//! nearest surface is at least as near (larger `1/z`) as the smallest `1/z` of the patch's
//! polygons touching the square. The largest such bound over all patches is the pixel's
//! occlusion bound; a polygon whose largest `1/z` over every pixel it touches is below the bound
//! (by more than the pipeline's tie tolerance) is hidden.
//!
//! Every pixel test is on the snapped grid coordinates the pipeline uses, with margins in the
//! conservative direction: polygons "touch" pixels within 1 grid unit, unmatched edges mark
//! pixels within 4 grid units (more than the touch margin, so a pixel touched only through the
//! margin is always marked when it is outside the union).
//!
//! The "pixels" are the cells of a [`Raster`]: the image's pixels, or, when the whole scene
//! covers only a few pixels (a tiny image, a far camera), power-of-two fractions of a pixel
//! over it, so that pre-culling still works there.
//!
//! Memory: 8 bytes per cell (the bound), 16 bytes per cell of each band in flight (patch
//! bound, two stamps), 48 bytes per polygon edge and 16 per
//! vertex for the matching; at most the image's pixels or about 2^20 cells.

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::intersect::DEPTH_TOL;
use super::predicates::Pt;
use super::project::{ScreenPoly, GRID, MAX_CLIPPED};

/// Grid units by which a polygon's pixel footprint is grown.
const TOUCH_MARGIN: f64 = 1.0;
/// Grid units by which an unmatched edge's pixel footprint is grown (must exceed
/// [`TOUCH_MARGIN`]).
const CONTOUR_MARGIN: f64 = 4.0;
/// Relative margin on depth comparisons, far above the pipeline's [`DEPTH_TOL`] so that a
/// culled polygon is never a tie for the pipeline.
const DEPTH_MARGIN: f64 = 1000.0 * DEPTH_TOL;

/// Cells per raster of a sub-pixel [`Raster`] (about the pixels of a 1024² image).
const MAX_CELLS: u64 = 1 << 20;
/// Finest sub-pixel cells: `2^-MAX_SPLIT` px (256 grid units, far above the margins).
const MAX_SPLIT: u32 = 12;

/// The square cells the occlusion bounds are kept on: `cols × rows` cells of `cell` grid units
/// from `origin` (grid units). Normally the image's pixels; when the polygons' box spans at
/// most a quarter of [`MAX_CELLS`] pixels (a tiny image, a far camera, a field of view near
/// 180°: a whole scene in a few pixels, where no pixel lies inside one patch alone), the finest
/// power-of-two fractions of a pixel over that box that stay within about [`MAX_CELLS`] cells.
/// Nothing in the argument needs cells to be pixels: every test is on grid coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Raster {
    origin: [f64; 2],
    cell: f64,
    cols: u32,
    rows: u32,
}

impl Raster {
    /// The raster for `polys` on a `width × height` image.
    fn new(polys: &[ScreenPoly], width: u32, height: u32) -> Self {
        let pixels = Self {
            origin: [0.0, 0.0],
            cell: GRID,
            cols: width,
            rows: height,
        };
        let mut b = [i64::MAX, i64::MAX, i64::MIN, i64::MIN];
        for p in polys {
            for v in &p.verts {
                b = [
                    b[0].min(v[0]),
                    b[1].min(v[1]),
                    b[2].max(v[0]),
                    b[3].max(v[1]),
                ];
            }
        }
        if b[0] > b[2] {
            return pixels;
        }
        // Cells of 2^-k px aligned to multiples of their size, covering the box.
        let layout = |k: u32| {
            let cell = (GRID as i64) >> k;
            let (x0, y0) = (b[0].div_euclid(cell), b[1].div_euclid(cell));
            let (cols, rows) = (
                b[2].div_euclid(cell) - x0 + 1,
                b[3].div_euclid(cell) - y0 + 1,
            );
            (cell, x0 * cell, y0 * cell, cols as u64, rows as u64)
        };
        let (_, _, _, cols, rows) = layout(0);
        if cols * rows * 4 > MAX_CELLS {
            return pixels;
        }
        let mut k = 1;
        while k < MAX_SPLIT {
            let (_, _, _, cols, rows) = layout(k + 1);
            if cols * rows > MAX_CELLS {
                break;
            }
            k += 1;
        }
        let (cell, x0, y0, cols, rows) = layout(k);
        Self {
            origin: [x0 as f64, y0 as f64],
            cell: cell as f64,
            cols: cols as u32,
            rows: rows as u32,
        }
    }

    /// Number of cells.
    fn len(&self) -> usize {
        self.cols as usize * self.rows as usize
    }
}

/// Calls `f(x, y)` for every cell of `raster` whose closed square is within `margin` grid units
/// of the convex polygon (or segment) `verts`, clamped to the raster and to the cell rows
/// `rows`; stops early (and returns false) when `f` returns false.
fn for_each_touched_pixel(
    verts: &[Pt],
    margin: f64,
    raster: &Raster,
    rows: std::ops::Range<u32>,
    mut f: impl FnMut(u32, u32) -> bool,
) -> bool {
    let (mut y_min, mut y_max) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in verts {
        y_min = y_min.min(v[1] as f64);
        y_max = y_max.max(v[1] as f64);
    }
    let [ox, oy] = raster.origin;
    let cell = raster.cell;
    // Clamping before the cast makes the truncating cast a floor (and avoids a libm call).
    let row_of = |y: f64| (((y - oy) / cell).max(0.0) as i64).min(raster.rows as i64 - 1);
    let row_lo = row_of(y_min - margin).max(rows.start as i64);
    let row_hi = row_of(y_max + margin).min(rows.end as i64 - 1);
    let n = verts.len();
    for row in row_lo..=row_hi {
        // The polygon's x extent inside the strip of this row (grown by the margin): a convex
        // polygon's extent in a strip is reached on its boundary.
        let strip_lo = oy + row as f64 * cell - margin;
        let strip_hi = oy + (row + 1) as f64 * cell + margin;
        let (mut x_lo, mut x_hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..n {
            let (a, b) = (verts[i], verts[(i + 1) % n]);
            let (ax, ay, bx, by) = (a[0] as f64, a[1] as f64, b[0] as f64, b[1] as f64);
            let (lo, hi) = (ay.min(by), ay.max(by));
            if hi < strip_lo || lo > strip_hi {
                continue;
            }
            if ay == by {
                x_lo = x_lo.min(ax.min(bx));
                x_hi = x_hi.max(ax.max(bx));
                continue;
            }
            // The edge's part inside the strip, at its two clipped ends.
            for y in [lo.max(strip_lo), hi.min(strip_hi)] {
                let x = ax + (bx - ax) * ((y - ay) / (by - ay));
                x_lo = x_lo.min(x);
                x_hi = x_hi.max(x);
            }
        }
        if x_lo > x_hi {
            continue;
        }
        let col_of = |x: f64| (((x - ox) / cell).max(0.0) as i64).min(raster.cols as i64 - 1);
        for col in col_of(x_lo - margin - 1.0)..=col_of(x_hi + margin + 1.0) {
            if !f(col as u32, row as u32) {
                return false;
            }
        }
    }
    true
}

/// The cell rows of `raster` a polygon (or segment) grown by `margin` can touch.
fn row_span(verts: &[Pt], margin: f64, raster: &Raster) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in verts {
        lo = lo.min(v[1] as f64);
        hi = hi.max(v[1] as f64);
    }
    let oy = raster.origin[1];
    (
        ((lo - margin - oy) / raster.cell).floor(),
        ((hi + margin - oy) / raster.cell).floor(),
    )
}

/// `1/z` of `plane` at the vertices of `verts`: (smallest, largest).
fn inv_z_range(plane: &[f64; 3], verts: &[Pt]) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in verts {
        let z = plane[0] * (v[0] as f64 / GRID) + plane[1] * (v[1] as f64 / GRID) + plane[2];
        lo = lo.min(z);
        hi = hi.max(z);
    }
    (lo, hi)
}

/// The depth margin of a polygon: relative (far above the pipeline's tie tolerance, which
/// includes the polygon's input noise), plus what snapping (half a grid unit) can change.
fn depth_margin(plane: &[f64; 3], hi: f64, noise: f64) -> f64 {
    (DEPTH_MARGIN + 10.0 * noise) * (hi.abs() + plane[2].abs())
        + 4.0 * (plane[0].abs() + plane[1].abs()) / GRID
}

/// Smallest and largest `1/z` of `plane` over the square of cell `(x, y)` of `raster`.
#[inline]
fn pixel_range(plane: &[f64; 3], raster: &Raster, x: u32, y: u32) -> (f64, f64) {
    let (cx, cy) = (
        (raster.origin[0] + x as f64 * raster.cell) / GRID,
        (raster.origin[1] + y as f64 * raster.cell) / GRID,
    );
    let base = plane[0] * cx + plane[1] * cy + plane[2];
    let (dx, dy) = (plane[0] * raster.cell / GRID, plane[1] * raster.cell / GRID);
    (
        base + dx.min(0.0) + dy.min(0.0),
        base + dx.max(0.0) + dy.max(0.0),
    )
}

fn find(parent: &mut [u32], mut k: u32) -> u32 {
    while parent[k as usize] != k {
        let p = parent[k as usize];
        parent[k as usize] = parent[p as usize];
        k = p;
    }
    k
}

/// Polygon patches and their unmatched edges: `(patch of each polygon, unmatched edges as
/// (polygon, edge index))`.
fn patches(polys: &[ScreenPoly]) -> (Vec<u32>, Vec<(u32, u32)>) {
    // Snapped vertices get small ids (shared vertices snap identically), so an undirected edge
    // is one u64 key and matching is a sort of plain integers.
    let mut vertex_id: FxHashMap<Pt, u32> = FxHashMap::default();
    vertex_id.reserve(polys.len());
    // (key, polygon, edge index << 1 | forward)
    let mut keys: Vec<(u64, u32, u32)> = Vec::with_capacity(polys.len() * 3);
    for (k, p) in polys.iter().enumerate() {
        let n = p.verts.len();
        // A clipped polygon has at most MAX_CLIPPED vertices: no allocation per polygon.
        debug_assert!(n <= MAX_CLIPPED);
        let mut ids = [0u32; MAX_CLIPPED];
        for (id, v) in ids.iter_mut().zip(&p.verts) {
            let next = vertex_id.len() as u32;
            *id = *vertex_id.entry(*v).or_insert(next);
        }
        for i in 0..n {
            let (a, b) = (ids[i], ids[(i + 1) % n]);
            let forward = a < b;
            let (lo, hi) = if forward { (a, b) } else { (b, a) };
            keys.push((
                (lo as u64) << 32 | hi as u64,
                k as u32,
                (i as u32) << 1 | forward as u32,
            ));
        }
    }
    keys.par_sort_unstable_by_key(|e| e.0);
    let mut parent: Vec<u32> = (0..polys.len() as u32).collect();
    let mut unmatched = Vec::new();
    for group in keys.chunk_by(|a, b| a.0 == b.0) {
        // Twins: exactly two uses of the edge, in opposite directions. Anything else (a border,
        // a fold where both lie on one side, a non-manifold edge) bounds the patch.
        if group.len() == 2 && (group[0].2 & 1) != (group[1].2 & 1) {
            let (a, b) = (find(&mut parent, group[0].1), find(&mut parent, group[1].1));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        } else {
            unmatched.extend(group.iter().map(|e| (e.1, e.2 >> 1)));
        }
    }
    let patch = (0..polys.len() as u32)
        .map(|k| find(&mut parent, k))
        .collect();
    (patch, unmatched)
}

/// Rows per band of the parallel occlusion-bound pass.
const BAND_ROWS: u32 = 64;

/// For every cell of `raster`, a lower bound of the nearest surface's `1/z` over the whole cell
/// square (`-inf` where nothing is known). Horizontal bands of cells run in parallel; each walks
/// the patches in the same order and touches only its own rows.
fn occlusion_bounds(polys: &[ScreenPoly], raster: &Raster) -> Vec<f64> {
    let (patch, unmatched) = patches(polys);
    let (width, height) = (raster.cols, raster.rows);
    let mut bound = vec![f64::NEG_INFINITY; raster.len()];
    // Polygons and unmatched edges grouped by patch, with the rows they may touch.
    let mut members: Vec<u32> = (0..polys.len() as u32).collect();
    members.sort_unstable_by_key(|&k| patch[k as usize]);
    let member_rows: Vec<(f64, f64)> = members
        .iter()
        .map(|&k| row_span(&polys[k as usize].verts, TOUCH_MARGIN, raster))
        .collect();
    // Patch ids in member order, so the bands' walks read memory sequentially.
    let member_patch: Vec<u32> = members.iter().map(|&k| patch[k as usize]).collect();
    let mut contour: Vec<(u32, [Pt; 2])> = unmatched
        .iter()
        .map(|&(k, i)| {
            let v = &polys[k as usize].verts;
            (
                patch[k as usize],
                [v[i as usize], v[(i as usize + 1) % v.len()]],
            )
        })
        .collect();
    contour.sort_unstable_by_key(|c| c.0);
    let contour_rows: Vec<(f64, f64)> = contour
        .iter()
        .map(|c| row_span(&c.1, CONTOUR_MARGIN, raster))
        .collect();
    let band_len = (BAND_ROWS * width) as usize;
    bound
        .par_chunks_mut(band_len)
        .enumerate()
        .for_each(|(band, bound)| {
            let first = band as u32 * BAND_ROWS;
            let rows = first..(first + BAND_ROWS).min(height);
            let (lo_row, hi_row) = (rows.start as f64, (rows.end - 1) as f64);
            let local = |x: u32, y: u32| ((y - first) * width + x) as usize;
            let mut patch_bound = vec![0.0f64; bound.len()];
            let mut touched_by = vec![u32::MAX; bound.len()];
            let mut contour_of = vec![u32::MAX; bound.len()];
            let mut touched = Vec::new();
            let (mut m, mut c) = (0, 0);
            while m < members.len() {
                let id = member_patch[m];
                while c < contour.len() && contour[c].0 < id {
                    c += 1;
                }
                while c < contour.len() && contour[c].0 == id {
                    let (r0, r1) = contour_rows[c];
                    if r1 >= lo_row && r0 <= hi_row {
                        for_each_touched_pixel(
                            &contour[c].1,
                            CONTOUR_MARGIN,
                            raster,
                            rows.clone(),
                            |x, y| {
                                contour_of[local(x, y)] = id;
                                true
                            },
                        );
                    }
                    c += 1;
                }
                touched.clear();
                while m < members.len() && member_patch[m] == id {
                    let (r0, r1) = member_rows[m];
                    if r1 >= lo_row && r0 <= hi_row {
                        let p = &polys[members[m] as usize];
                        let (lo, hi) = inv_z_range(&p.plane, &p.verts);
                        let margin = depth_margin(&p.plane, hi, p.noise);
                        for_each_touched_pixel(
                            &p.verts,
                            TOUCH_MARGIN,
                            raster,
                            rows.clone(),
                            |x, y| {
                                let at = local(x, y);
                                let v = lo.max(pixel_range(&p.plane, raster, x, y).0) - margin;
                                if touched_by[at] != id {
                                    touched_by[at] = id;
                                    patch_bound[at] = v;
                                    touched.push(at);
                                } else {
                                    patch_bound[at] = patch_bound[at].min(v);
                                }
                                true
                            },
                        );
                    }
                    m += 1;
                }
                for &at in &touched {
                    if contour_of[at] != id {
                        bound[at] = bound[at].max(patch_bound[at]);
                    }
                }
            }
        });
    bound
}

/// Whether polygon `p` is hidden at every point by more than the depth margin, given the
/// per-cell occlusion bounds.
fn is_hidden(p: &ScreenPoly, bound: &[f64], raster: &Raster) -> bool {
    let (_, hi) = inv_z_range(&p.plane, &p.verts);
    let margin = depth_margin(&p.plane, hi, p.noise);
    for_each_touched_pixel(&p.verts, TOUCH_MARGIN, raster, 0..raster.rows, |x, y| {
        let top = hi.min(pixel_range(&p.plane, raster, x, y).1) + margin;
        top < bound[(y * raster.cols + x) as usize]
    })
}

/// Splits `polys` into (possibly visible, provably hidden count): the polygons kept are in
/// their input order.
pub(crate) fn cull_hidden(
    polys: Vec<ScreenPoly>,
    width: u32,
    height: u32,
) -> (Vec<ScreenPoly>, usize) {
    if polys.len() < 2 || width == 0 || height == 0 {
        return (polys, 0);
    }
    let raster = Raster::new(&polys, width, height);
    let bound = occlusion_bounds(&polys, &raster);
    let hidden: Vec<bool> = polys
        .par_iter()
        .map(|p| is_hidden(p, &bound, &raster))
        .collect();
    let culled = hidden.iter().filter(|&&h| h).count();
    let kept = polys
        .into_iter()
        .zip(hidden)
        .filter_map(|(p, h)| (!h).then_some(p))
        .collect();
    (kept, culled)
}

#[cfg(test)]
mod tests {
    use super::*;

    const G: i64 = GRID as i64;

    fn pixels(cols: u32, rows: u32) -> Raster {
        Raster {
            origin: [0.0, 0.0],
            cell: GRID,
            cols,
            rows,
        }
    }

    fn square(x0: i64, y0: i64, x1: i64, y1: i64, inv_z: f64, id: u32) -> [ScreenPoly; 2] {
        // Two counter-clockwise triangles (y down: cross(b - a, c - a) > 0) sharing a diagonal
        // in opposite directions.
        let plane = [0.0, 0.0, inv_z];
        [
            ScreenPoly {
                id,
                verts: vec![[x0, y0], [x1, y1], [x0, y1]],
                plane,
                noise: 0.0,
                collinear_grid: crate::analytic::project::NEAR_COLLINEAR_GRID,
            },
            ScreenPoly {
                id: id + 1,
                verts: vec![[x0, y0], [x1, y0], [x1, y1]],
                plane,
                noise: 0.0,
                collinear_grid: crate::analytic::project::NEAR_COLLINEAR_GRID,
            },
        ]
    }

    fn tri(verts: [Pt; 3], inv_z: f64, id: u32) -> ScreenPoly {
        ScreenPoly {
            id,
            verts: verts.to_vec(),
            plane: [0.0, 0.0, inv_z],
            noise: 0.0,
            collinear_grid: crate::analytic::project::NEAR_COLLINEAR_GRID,
        }
    }

    #[test]
    fn empty_input_culls_nothing() {
        let (kept, culled) = cull_hidden(Vec::new(), 8, 8);
        assert!(kept.is_empty());
        assert_eq!(culled, 0);
    }

    #[test]
    fn touched_pixels_of_a_small_triangle_include_its_pixel_and_neighbours_on_borders() {
        let mut seen = Vec::new();
        // Inside pixel (2, 3), touching no border.
        let t = [
            [2 * G + 10, 3 * G + 10],
            [2 * G + 10, 3 * G + 20],
            [2 * G + 20, 3 * G + 20],
        ];
        for_each_touched_pixel(&t, TOUCH_MARGIN, &pixels(8, 8), 0..8, |x, y| {
            seen.push((x, y));
            true
        });
        assert!(seen.contains(&(2, 3)));
        assert!(seen.iter().all(|&(x, y)| (1..=3).contains(&x) && y == 3));
        // A segment along the pixel border x = 4 touches columns 3 and 4.
        seen.clear();
        let seg = [[4 * G, G / 2], [4 * G, G / 2 + 5]];
        for_each_touched_pixel(&seg, CONTOUR_MARGIN, &pixels(8, 8), 0..8, |x, y| {
            seen.push((x, y));
            true
        });
        assert!(seen.contains(&(3, 0)) && seen.contains(&(4, 0)));
    }

    #[test]
    fn triangle_behind_a_two_triangle_square_is_culled_and_the_square_is_kept() {
        let mut polys = square(0, 0, 6 * G, 6 * G, 1.0, 0).to_vec();
        // Far behind (1/z smaller) and inside the square, away from its border.
        polys.push(tri(
            [[2 * G, 2 * G], [2 * G, 3 * G], [3 * G, 3 * G]],
            0.5,
            2,
        ));
        let (kept, culled) = cull_hidden(polys, 8, 8);
        assert_eq!(culled, 1);
        assert_eq!(kept.iter().map(|p| p.id).collect::<Vec<_>>(), vec![0, 1]);
    }

    #[test]
    fn a_scene_inside_one_pixel_is_culled_on_sub_pixel_cells() {
        // The first scene shrunk into the only pixel of a 1x1 image (u = 1/1024 px): a pixel
        // raster has one cell, touched by the square's border, and could cull nothing.
        let u = G / 1024;
        let mut polys = square(100 * u, 100 * u, 700 * u, 700 * u, 1.0, 0).to_vec();
        polys.push(tri(
            [[300 * u, 300 * u], [300 * u, 400 * u], [400 * u, 400 * u]],
            0.5,
            2,
        ));
        let raster = Raster::new(&polys, 1, 1);
        assert!(
            raster.cell < GRID && raster.len() <= MAX_CELLS as usize,
            "{raster:?}"
        );
        let (kept, culled) = cull_hidden(polys, 1, 1);
        assert_eq!(culled, 1);
        assert_eq!(kept.len(), 2);
        // A scene covering the image keeps the pixel raster.
        let polys = square(0, 0, 1024 * G, 1024 * G, 1.0, 0).to_vec();
        assert_eq!(Raster::new(&polys, 1024, 1024), pixels(1024, 1024));
    }

    #[test]
    fn triangle_in_front_or_reaching_past_the_border_is_kept() {
        let mut polys = square(0, 0, 6 * G, 6 * G, 1.0, 0).to_vec();
        // In front of the square.
        polys.push(tri(
            [[2 * G, 2 * G], [2 * G, 3 * G], [3 * G, 3 * G]],
            2.0,
            2,
        ));
        // Behind, but reaching a sub-pixel amount past the square's border, where it is seen.
        polys.push(tri(
            [[4 * G, 4 * G], [4 * G, 6 * G + 3], [5 * G, 6 * G + 3]],
            0.5,
            3,
        ));
        let (kept, culled) = cull_hidden(polys, 8, 8);
        assert_eq!(culled, 0);
        assert_eq!(kept.len(), 4);
    }

    #[test]
    fn a_gap_between_two_squares_is_not_an_occluder() {
        // Two squares with a sub-pixel gap between them (x in 3G .. 3G + 2): a triangle behind
        // the gap can be seen through it.
        let mut polys = square(0, 0, 3 * G, 6 * G, 1.0, 0).to_vec();
        polys.extend(square(3 * G + 2, 0, 6 * G, 6 * G, 1.0, 2));
        polys.push(tri(
            [[2 * G, 2 * G], [2 * G, 3 * G], [4 * G, 3 * G]],
            0.5,
            4,
        ));
        let (_, culled) = cull_hidden(polys, 8, 8);
        assert_eq!(culled, 0);
    }

    #[test]
    fn folded_edges_do_not_join_patches() {
        // Two triangles on the same side of a shared edge (a silhouette fold): the edge is used
        // twice in the same direction and bounds both, so the pixels along it are no occluder.
        let a = tri([[0, 0], [4 * G, 4 * G], [0, 4 * G]], 1.0, 0);
        let b = tri([[0, 0], [2 * G, 4 * G], [0, 4 * G]], 1.0, 1);
        let (patch, unmatched) = patches(&[a, b]);
        assert_ne!(patch[0], patch[1]);
        assert_eq!(unmatched.len(), 6);
    }
}
