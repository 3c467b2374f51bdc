//! A depth cube around one viewpoint: per pixel of six 90-degree faces, the depth (along the
//! face's axis) at which the ray through the pixel's centre enters the nearest occluder box,
//! and the test whether a triangle lies behind those depths over every pixel it may cover.
//!
//! Only pixel centres are rendered, so a ray through another point of a pixel may pass beside
//! the box its centre hits; at depth `z` it is at most `z * sqrt(2) / resolution` from the
//! centre ray (half a pixel in both directions on a face spanning -1..1). `mod.rs` grows the
//! required shrink by that much up to the farthest depth rendered, which makes the test
//! conservative (Wonka, Wimmer, Schmalstieg 2000, section 4: the shrink absorbs both the
//! viewpoint's freedom and the sampling).

use glam::DVec3;

use super::polygon::clip_by;
use crate::closed_solids::cell::may_meet_box;

/// A box as the cube renders it: it blocks segments between points above `cap` (along the
/// up axis given to [`CubeDepth::hides`]); `-inf` for every segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct DepthBox {
    pub min: DVec3,
    pub max: DVec3,
    pub cap: f64,
    /// Entries deeper than this are not written (the box's shrink does not cover the pixels'
    /// reach there).
    pub max_depth: f64,
    /// Whether the box's top and bottom along the up axis (given to [`CubeDepth::render`])
    /// still move in by the pixels' reach, per pixel at the depth the ray leaves the box
    /// (its sides have that reach in their shrink already, up to `max_depth`).
    pub reach_ends: [bool; 2],
}

/// Boxes to render, in groups of nearby boxes with the box around each group: a group that
/// projects onto no tile still to draw is skipped without projecting its boxes.
pub(super) struct BoxGroups {
    boxes: Vec<DepthBox>,
    groups: Vec<BoxGroup>,
}

struct BoxGroup {
    min: DVec3,
    max: DVec3,
    max_depth: f64,
    range: std::ops::Range<usize>,
}

/// Boxes a group holds at most.
const GROUP: usize = 64;

impl BoxGroups {
    /// `boxes` in groups of those whose centres share a cube of side `size`, at most
    /// [`GROUP`] a group; groups and the boxes in each nearest `centre` first (the near boxes
    /// drawn first let the pixels' depths skip the far ones).
    pub fn new(mut boxes: Vec<DepthBox>, centre: DVec3, size: f64) -> Self {
        let cube_of = |b: &DepthBox| {
            let mid = (b.min + b.max) * 0.5 / size;
            [
                mid.x.floor() as i64,
                mid.y.floor() as i64,
                mid.z.floor() as i64,
            ]
        };
        // Each box's cube and distance found once, not once per comparison.
        let mut keyed: Vec<([i64; 3], f64, DepthBox)> = boxes
            .drain(..)
            .map(|b| (cube_of(&b), distance(centre, &b), b))
            .collect();
        keyed.sort_by(|p, q| p.0.cmp(&q.0).then(p.1.total_cmp(&q.1)));
        let keys: Vec<[i64; 3]> = keyed.iter().map(|k| k.0).collect();
        boxes.extend(keyed.into_iter().map(|k| k.2));
        let mut groups = Vec::new();
        let mut start = 0;
        while start < boxes.len() {
            let key = keys[start];
            let mut end = start + 1;
            while end < boxes.len() && end - start < GROUP && keys[end] == key {
                end += 1;
            }
            let members = &boxes[start..end];
            groups.push(BoxGroup {
                min: members.iter().fold(DVec3::INFINITY, |m, b| m.min(b.min)),
                max: members
                    .iter()
                    .fold(DVec3::NEG_INFINITY, |m, b| m.max(b.max)),
                max_depth: members.iter().fold(0.0, |m: f64, b| m.max(b.max_depth)),
                range: start..end,
            });
            start = end;
        }
        groups.sort_by(|p, q| {
            let d = |g: &BoxGroup| {
                (g.min - centre)
                    .max(centre - g.max)
                    .max(DVec3::ZERO)
                    .length()
            };
            d(p).total_cmp(&d(q))
        });
        Self { boxes, groups }
    }

    /// How many boxes there are.
    pub fn len(&self) -> usize {
        self.boxes.len()
    }
}

/// The distance from `eye` to box `b`.
fn distance(eye: DVec3, b: &DepthBox) -> f64 {
    (b.min - eye).max(eye - b.max).max(DVec3::ZERO).length()
}

/// What drawing the boxes of one cube reuses: the slabs per column and row of pixels.
struct Scratch {
    columns: Vec<Option<(f64, f64)>>,
    rows: Vec<Option<(f64, f64)>>,
    up: usize,
    near: f64,
    reach_per_depth: f64,
}

/// Per triangle in doubt, the rows of pixels it may cover from one eye: found once per sample
/// for both marking the tiles to draw and testing the triangle against what was drawn.
#[derive(Default)]
pub(super) struct Footprints {
    /// Face, row, first and last pixel, and the triangle's nearest depth on that face.
    rows: Vec<(usize, usize, usize, usize, f64)>,
    /// Per triangle, the end of its rows.
    ends: Vec<usize>,
    /// Per triangle, whether it comes within `near` of the eye (seen anyway).
    near: Vec<bool>,
}

/// Slack in face coordinates for the pixels a triangle covers (rounding of the projection).
const ROUNDING: f64 = 1e-9;

/// Pixels along a tile's side (the coarse level that skips hidden boxes and pixels).
const TILE: usize = 16;

/// The depth cube (see the module documentation).
pub(super) struct CubeDepth {
    resolution: usize,
    tiles: usize,
    /// Per face, per pixel (row after row), the depth; `INFINITY` where no box was hit.
    depth: Vec<f32>,
    /// Per pixel, the cap of the box its depth comes from (`erosion::OccluderBox::cap`):
    /// that box only stands for the union above it.
    cap: Vec<f32>,
    /// Per face, per tile, the largest depth of its pixels.
    tile_max: Vec<f32>,
}

/// Face `f`'s axis (0-2), its sign and the two axes across it.
fn face_axes(f: usize) -> (usize, f64, usize, usize) {
    let a = f / 2;
    let sign = if f.is_multiple_of(2) { 1.0 } else { -1.0 };
    (a, sign, (a + 1) % 3, (a + 2) % 3)
}

impl CubeDepth {
    /// An empty cube of `resolution` pixels a face side (a multiple of the tile size).
    pub fn new(resolution: usize) -> Self {
        let resolution = resolution.div_ceil(TILE).max(1) * TILE;
        let tiles = resolution / TILE;
        Self {
            resolution,
            tiles,
            depth: vec![f32::INFINITY; 6 * resolution * resolution],
            cap: vec![f32::NEG_INFINITY; 6 * resolution * resolution],
            tile_max: vec![f32::INFINITY; 6 * tiles * tiles],
        }
    }

    /// Renders `boxes` (nearest first renders fastest) as seen from `eye`, from depth `near`
    /// up to each box's `max_depth` (nearer and farther entries are not written: less
    /// occlusion), in the tiles `needed` marks (per face, per tile; all when `None`). Along
    /// axis `up` the boxes' marked ends move in by the pixels' reach at the depth where the
    /// pixel's centre ray leaves the box (`DepthBox::reach_ends`): a shrink that grows with
    /// depth, so near roofs are lowered by centimetres, not by the far boxes' metres.
    pub fn render(
        &mut self,
        eye: DVec3,
        boxes: &BoxGroups,
        up: usize,
        near: f64,
        needed: Option<&[bool]>,
    ) {
        self.depth.fill(f32::INFINITY);
        self.cap.fill(f32::NEG_INFINITY);
        self.tile_max.fill(f32::INFINITY);
        let mut scratch = Scratch {
            columns: Vec::with_capacity(self.resolution),
            rows: Vec::with_capacity(self.resolution),
            up,
            near,
            // A pixel's rays lie within this many depths of its centre ray (half a pixel
            // both ways across the face), with a margin for rounding.
            reach_per_depth: std::f64::consts::SQRT_2 / self.resolution as f64 * (1.0 + 1e-6),
        };
        for f in 0..6 {
            let (a, sign, b, c) = face_axes(f);
            for group in &boxes.groups {
                // A group whose box reaches no tile to draw, or only tiles already nearer
                // than it, is skipped whole.
                let (lo, hi) = (group.min - eye, group.max - eye);
                let (z_lo, z_hi) = if sign > 0.0 {
                    (lo[a], hi[a])
                } else {
                    (-hi[a], -lo[a])
                };
                if z_hi <= near || z_lo > group.max_depth {
                    continue;
                }
                let z_lo = z_lo.max(near);
                let Some((x0, x1, y0, y1)) =
                    self.pixel_range(z_lo, z_hi, [lo[b], hi[b]], [lo[c], hi[c]])
                else {
                    continue;
                };
                let n = self.tiles;
                let open = (y0 / TILE..=y1 / TILE).any(|ty| {
                    (x0 / TILE..=x1 / TILE).any(|tx| {
                        let tile = f * n * n + ty * n + tx;
                        needed.is_none_or(|m| m[tile]) && self.tile_max[tile] >= z_lo as f32
                    })
                });
                if open {
                    for bx in &boxes.boxes[group.range.clone()] {
                        self.draw(f, bx, eye, needed, &mut scratch);
                    }
                }
            }
        }
    }

    /// Draws box `bx` on face `f` (see [`Self::render`]).
    fn draw(
        &mut self,
        f: usize,
        bx: &DepthBox,
        eye: DVec3,
        needed: Option<&[bool]>,
        scratch: &mut Scratch,
    ) {
        let (r, n) = (self.resolution, self.tiles);
        let (a, sign, b, c) = face_axes(f);
        let (up, near, reach_per_depth) = (scratch.up, scratch.near, scratch.reach_per_depth);
        let (columns, rows) = (&mut scratch.columns, &mut scratch.rows);
        let (lo, hi) = (bx.min - eye, bx.max - eye);
        let (z_lo, z_hi) = if sign > 0.0 {
            (lo[a], hi[a])
        } else {
            (-hi[a], -lo[a])
        };
        let max_depth = bx.max_depth;
        if z_hi <= near || z_lo > max_depth {
            return;
        }
        let z_lo = z_lo.max(near);
        let Some((x0, x1, y0, y1)) = self.pixel_range(z_lo, z_hi, [lo[b], hi[b]], [lo[c], hi[c]])
        else {
            return;
        };
        let cap = round_up(bx.cap);
        // Rounded down: a depth at or below it is nearer than any entry.
        let z_lo_f32 = round_down(z_lo);
        // The slabs of the box along the face's axis, and across it per column and
        // per row of pixels (a pixel's ray is in the box between the latest entry
        // and the earliest exit of its three slabs, as `entry` finds them).
        let Some(along) = slab(lo[a], hi[a], sign) else {
            return;
        };
        // Made when the first tile needs them (most boxes have none to draw).
        columns.clear();
        rows.clear();
        for ty in y0 / TILE..=y1 / TILE {
            for tx in x0 / TILE..=x1 / TILE {
                let tile = f * n * n + ty * n + tx;
                if needed.is_some_and(|m| !m[tile]) || self.tile_max[tile] < z_lo as f32 {
                    continue;
                }
                // Only a tile with a pixel written needs its largest depth found again.
                let mut wrote = false;
                if rows.is_empty() {
                    columns.extend((x0..=x1).map(|x| slab(lo[b], hi[b], self.centre(x))));
                    rows.extend((y0..=y1).map(|y| slab(lo[c], hi[c], self.centre(y))));
                }
                for y in (ty * TILE).max(y0)..=((ty + 1) * TILE - 1).min(y1) {
                    let Some(across_row) = rows[y - y0] else {
                        continue;
                    };
                    // The row's part of `through`: what varies along it is the column's slab.
                    let row_in = near.max(along.0).max(across_row.0);
                    let row_out = along.1.min(across_row.1);
                    for x in (tx * TILE).max(x0)..=((tx + 1) * TILE - 1).min(x1) {
                        // No entry comes nearer than the box's near side: a pixel
                        // already that near keeps its depth (most of them, nearest
                        // boxes first), without the slab test.
                        let at = f * r * r + y * r + x;
                        if self.depth[at] <= z_lo_f32 {
                            continue;
                        }
                        let Some(across_column) = columns[x - x0] else {
                            continue;
                        };
                        let (t, leaves) =
                            (row_in.max(across_column.0), row_out.min(across_column.1));
                        if t > leaves {
                            continue;
                        }
                        let t = if bx.reach_ends == [false, false] || t > max_depth {
                            t
                        } else {
                            let mut slabs = [along; 3];
                            slabs[b] = across_column;
                            slabs[c] = across_row;
                            let d = if up == a {
                                sign
                            } else {
                                self.centre(if up == b { x } else { y })
                            };
                            let reach = leaves.min(max_depth) * reach_per_depth;
                            match ends_moved_in(slabs, (lo, hi), bx.reach_ends, up, d, reach) {
                                Some(slabs) => match through(&slabs, near) {
                                    Some((t, _)) => t,
                                    None => continue,
                                },
                                None => continue,
                            }
                        };
                        if t <= max_depth {
                            // Round up: a depth never reads nearer than the box.
                            let stored = (t * (1.0 + 1e-6)) as f32;
                            if stored < self.depth[at] {
                                self.depth[at] = stored;
                                self.cap[at] = cap;
                                wrote = true;
                            }
                        }
                    }
                }
                if wrote {
                    self.update_tile(f, ty, tx);
                }
            }
        }
    }

    /// The rows of pixels each of `triangles` may cover from `eye`, into `out` (see
    /// [`Footprints`]).
    pub fn footprints<'a>(
        &self,
        eye: DVec3,
        triangles: impl Iterator<Item = &'a [DVec3; 3]>,
        near: f64,
        out: &mut Footprints,
    ) {
        out.rows.clear();
        out.ends.clear();
        out.near.clear();
        for t in triangles {
            let all = self.covered_rows(eye, t, near, |f, y, x0, x1, z_min| {
                out.rows.push((f, y, x0, x1, z_min));
                true
            });
            out.ends.push(out.rows.len());
            out.near.push(!all);
        }
    }

    /// Marks in `needed` (per face, per tile) the tiles the triangles of `footprints` may
    /// cover; all of them when one comes within `near` of the eye (it is seen anyway).
    pub fn mark(&self, footprints: &Footprints, needed: &mut [bool]) {
        if footprints.near.iter().any(|&near| near) {
            needed.fill(true);
            return;
        }
        let n = self.tiles;
        for &(f, y, x0, x1, _) in &footprints.rows {
            for tx in x0 / TILE..=x1 / TILE {
                needed[f * n * n + (y / TILE) * n + tx] = true;
            }
        }
    }

    /// An all-false tile mask for [`Self::mark`].
    pub fn no_tiles(&self) -> Vec<bool> {
        vec![false; 6 * self.tiles * self.tiles]
    }

    /// Whether triangle `k` of `footprints` lies behind the rendered depths over every pixel
    /// it may cover (on every face). A pixel's box must moreover stand for the union where
    /// the segments from the cell to the triangle pass it: its cap (`DepthBox::cap`) lies
    /// below the triangle's `lowest` point along the up axis, or below the lowest height a
    /// segment from a viewpoint at `cell_lowest` or above can have at the pixel's depth (a
    /// fraction `depth / nearest depth of the triangle` of the way). `false` when the
    /// triangle comes within `near` of the eye.
    pub fn hides(&self, footprints: &Footprints, k: usize, lowest: f64, cell_lowest: f64) -> bool {
        if footprints.near[k] {
            return false;
        }
        let start = if k == 0 { 0 } else { footprints.ends[k - 1] };
        let r = self.resolution;
        footprints.rows[start..footprints.ends[k]]
            .iter()
            .all(|&(f, y, x0, x1, z_min)| {
                let row = f * r * r + y * r + x0..=f * r * r + y * r + x1;
                let blocks = |d: f32, c: f32| {
                    let (d, c) = (f64::from(d), f64::from(c));
                    d < z_min
                        && (c <= lowest || d / z_min <= (cell_lowest - c) / (cell_lowest - lowest))
                };
                self.depth[row.clone()]
                    .iter()
                    .zip(&self.cap[row])
                    .all(|(&d, &c)| blocks(d, c))
            })
    }

    /// Calls `row(face, y, x0, x1, nearest depth)` for each row of pixels (`x0..=x1`) whose
    /// squares may meet triangle `t` seen from `eye`, until it returns `false`; returns
    /// `false` then, or when the triangle comes within `near` of the eye.
    fn covered_rows(
        &self,
        eye: DVec3,
        t: &[DVec3; 3],
        near: f64,
        mut row: impl FnMut(usize, usize, usize, usize, f64) -> bool,
    ) -> bool {
        if may_meet_box(t, eye - DVec3::splat(near), eye + DVec3::splat(near)) {
            return false;
        }
        let rel = t.map(|p| p - eye);
        for f in 0..6 {
            let (a, sign, b, c) = face_axes(f);
            // The part inside the face's frustum (slightly widened for rounding) and in front of
            // its near plane (what is nearer lies within `near` of the eye).
            let depth = |p: DVec3| p[a] * sign;
            let widen = 1.0 + 1e-9;
            let planes: [&dyn Fn(DVec3) -> f64; 5] = [
                &|p| depth(p) - near,
                &|p| depth(p) * widen - p[b],
                &|p| depth(p) * widen + p[b],
                &|p| depth(p) * widen - p[c],
                &|p| depth(p) * widen + p[c],
            ];
            let mut polygon = rel.to_vec();
            for plane in planes {
                polygon = clip_by(&polygon, plane);
                if polygon.is_empty() {
                    break;
                }
            }
            if polygon.is_empty() {
                continue;
            }
            let mut z_min = f64::INFINITY;
            let projected: Vec<(f64, f64)> = polygon
                .iter()
                .map(|p| {
                    let z = (p[a] * sign).max(near);
                    z_min = z_min.min(z);
                    (p[b] / z, p[c] / z)
                })
                .collect();
            let (v0, v1) = projected
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p.1), hi.max(p.1))
                });
            let Some((_, _, y0, y1)) = self.pixels_over(-1.0, 1.0, v0, v1) else {
                continue;
            };
            for y in y0..=y1 {
                // The pixels of this row whose square meets the triangle's projection.
                let band = (self.edge(y) - ROUNDING, self.edge(y + 1) + ROUNDING);
                let Some((u0, u1)) = span_in_band(&projected, band) else {
                    continue;
                };
                let Some((x0, x1, _, _)) =
                    self.pixels_over(u0 - ROUNDING, u1 + ROUNDING, band.0, band.1)
                else {
                    continue;
                };
                if !row(f, y, x0, x1, z_min) {
                    return false;
                }
            }
        }
        true
    }

    /// The lower edge of pixel `x` along a face's side, in -1..1.
    fn edge(&self, x: usize) -> f64 {
        x as f64 / self.resolution as f64 * 2.0 - 1.0
    }

    /// The centre of pixel `x` along a face's side, in -1..1.
    fn centre(&self, x: usize) -> f64 {
        (x as f64 + 0.5) / self.resolution as f64 * 2.0 - 1.0
    }

    /// The pixels whose area meets `u0..u1` x `v0..v1` (face coordinates), if any.
    fn pixels_over(
        &self,
        u0: f64,
        u1: f64,
        v0: f64,
        v1: f64,
    ) -> Option<(usize, usize, usize, usize)> {
        if !(u0 <= 1.0 && u1 >= -1.0 && v0 <= 1.0 && v1 >= -1.0) {
            return None; // also NaN
        }
        let r = self.resolution as f64;
        let to_pixel = |s: f64| (((s + 1.0) * 0.5 * r).floor().clamp(0.0, r - 1.0)) as usize;
        Some((to_pixel(u0), to_pixel(u1), to_pixel(v0), to_pixel(v1)))
    }

    /// The pixels a box spanning depths `z_lo..z_hi` (`z_lo` at least `near` > 0) and `bu`,
    /// `bv` across may cover.
    fn pixel_range(
        &self,
        z_lo: f64,
        z_hi: f64,
        bu: [f64; 2],
        bv: [f64; 2],
    ) -> Option<(usize, usize, usize, usize)> {
        let extent = |s: [f64; 2]| {
            let c = [s[0] / z_lo, s[0] / z_hi, s[1] / z_lo, s[1] / z_hi];
            (
                c.iter().copied().fold(f64::INFINITY, f64::min),
                c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        };
        let (u0, u1) = extent(bu);
        let (v0, v1) = extent(bv);
        self.pixels_over(u0, u1, v0, v1)
    }

    /// Recomputes a tile's largest depth after writing to it.
    fn update_tile(&mut self, f: usize, ty: usize, tx: usize) {
        let (n, r) = (self.tiles, self.resolution);
        let mut max = 0.0f32;
        for y in ty * TILE..(ty + 1) * TILE {
            let row = &self.depth[f * r * r + y * r + tx * TILE..][..TILE];
            max = row.iter().copied().fold(max, f32::max);
        }
        self.tile_max[f * n * n + ty * n + tx] = max;
    }
}

/// The range of `u` over the part of convex polygon `points` (u, v) with `v` in `band`.
fn span_in_band(points: &[(f64, f64)], band: (f64, f64)) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut take = |u: f64| {
        lo = lo.min(u);
        hi = hi.max(u);
    };
    for (k, &(u, v)) in points.iter().enumerate() {
        if band.0 <= v && v <= band.1 {
            take(u);
        }
        // Where the edge to the next corner crosses either side of the band.
        let (u2, v2) = points[(k + 1) % points.len()];
        for side in [band.0, band.1] {
            if (v - side) * (v2 - side) < 0.0 {
                take(u + (u2 - u) * (side - v) / (v2 - v));
            }
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// `x` as the nearest f32 at or below it.
fn round_down(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) > x {
        y.next_down()
    } else {
        y
    }
}

/// `x` as the nearest f32 at or above it.
fn round_up(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) < x {
        y.next_up()
    } else {
        y
    }
}

/// The parameters at which the ray from the origin with direction component `d` along one
/// axis is between `lo` and `hi` on it (all of them when `d` is 0 and the origin is between),
/// or `None` when it never is.
fn slab(lo: f64, hi: f64, d: f64) -> Option<(f64, f64)> {
    if d == 0.0 {
        return (lo <= 0.0 && hi >= 0.0).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let (near, far) = (lo / d, hi / d);
    Some((near.min(far), near.max(far)))
}

/// `slabs` (of the box `lo..hi`, from [`slab`]) with the box's `ends` along axis `up` (top,
/// bottom) moved in by `reach`, for a ray whose direction component along `up` is `d`; `None`
/// when the box has no height left or the ray is never within it along `up`.
fn ends_moved_in(
    mut slabs: [(f64, f64); 3],
    (mut lo, mut hi): (DVec3, DVec3),
    ends: [bool; 2],
    up: usize,
    d: f64,
    reach: f64,
) -> Option<[(f64, f64); 3]> {
    if ends[0] {
        hi[up] -= reach;
    }
    if ends[1] {
        lo[up] += reach;
    }
    if lo[up] >= hi[up] {
        return None;
    }
    slabs[up] = slab(lo[up], hi[up], d)?;
    Some(slabs)
}

/// Where a ray within the three `slabs` (per axis, from [`slab`]) from parameter `near` on
/// enters their box (`near` when it is inside there) and where it leaves it, or `None` when
/// it misses it.
fn through(slabs: &[(f64, f64); 3], near: f64) -> Option<(f64, f64)> {
    let t0 = near.max(slabs[0].0).max(slabs[1].0).max(slabs[2].0);
    let t1 = slabs[0].1.min(slabs[1].1).min(slabs[2].1);
    (t0 <= t1).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `cube`, drawn from the origin, hides triangle `t` (up axis z, no cell below).
    fn hides(cube: &CubeDepth, t: &[DVec3; 3], near: f64) -> bool {
        let mut footprints = Footprints::default();
        cube.footprints(DVec3::ZERO, std::iter::once(t), near, &mut footprints);
        let lowest = t[0].z.min(t[1].z).min(t[2].z);
        cube.hides(&footprints, 0, lowest, f64::NEG_INFINITY)
    }

    fn group(b: DepthBox) -> BoxGroups {
        BoxGroups::new(vec![b], DVec3::ZERO, 16.0)
    }

    fn wall() -> DepthBox {
        // A wall 10 m ahead along +x, 20 m wide and high, 1 m thick.
        DepthBox {
            min: DVec3::new(10.0, -10.0, -10.0),
            max: DVec3::new(11.0, 10.0, 10.0),
            cap: f64::NEG_INFINITY,
            max_depth: 100.0,
            reach_ends: [false, false],
        }
    }

    #[test]
    fn a_triangle_behind_a_wall_is_hidden_and_one_beside_it_is_not() {
        let mut cube = CubeDepth::new(64);
        cube.render(DVec3::ZERO, &group(wall()), 2, 1e-3, None);
        let behind = [
            DVec3::new(20.0, -1.0, -1.0),
            DVec3::new(20.0, 1.0, -1.0),
            DVec3::new(20.0, 0.0, 1.0),
        ];
        assert!(hides(&cube, &behind, 1e-3));
        // In front of the wall.
        let front = behind.map(|p| p - DVec3::new(15.0, 0.0, 0.0));
        assert!(!hides(&cube, &front, 1e-3));
        // Behind, but reaching past the wall's edge (seen past it).
        let past = behind.map(|p| p + DVec3::new(0.0, 25.0, 0.0));
        assert!(!hides(&cube, &past, 1e-3));
        // Behind the eye (another face, nothing rendered there).
        let back = behind.map(|p| -p);
        assert!(!hides(&cube, &back, 1e-3));
        // Beyond the rendered depth, the wall is not there.
        let mut short = CubeDepth::new(64);
        let near_only = DepthBox {
            max_depth: 5.0,
            ..wall()
        };
        short.render(DVec3::ZERO, &group(near_only), 2, 1e-3, None);
        assert!(!hides(&short, &behind, 1e-3));
    }

    #[test]
    fn the_eye_inside_a_box_sees_nothing_beyond_it_past_the_near_depth() {
        let mut cube = CubeDepth::new(32);
        let room = DepthBox {
            min: DVec3::splat(-1.0),
            max: DVec3::splat(1.0),
            cap: f64::NEG_INFINITY,
            max_depth: 10.0,
            reach_ends: [false, false],
        };
        cube.render(DVec3::ZERO, &group(room), 2, 1e-3, None);
        let far = [
            DVec3::new(5.0, 0.0, 0.0),
            DVec3::new(0.0, 5.0, 0.0),
            DVec3::new(0.0, 0.0, 5.0),
        ];
        assert!(hides(&cube, &far, 1e-3));
        // A triangle nearer than the near depth is in front of everything rendered.
        let close = far.map(|p| p * 1e-4);
        assert!(!hides(&cube, &close, 1e-6));
    }

    #[test]
    fn groups_skip_only_boxes_that_would_draw_nothing() {
        // Random boxes around the eye, some with a cap, some with their ends moving in by
        // the pixels' reach; drawn in groups of neighbours and each alone, with and without a
        // mask of tiles to draw: the same depths and caps, pixel for pixel.
        let mut rng = sightline_core::random::SplitMix64::new(5);
        let mut boxes = Vec::new();
        for _ in 0..300 {
            let centre = DVec3::new(
                f64::from(rng.range_f32(-60.0, 60.0)),
                f64::from(rng.range_f32(-60.0, 60.0)),
                f64::from(rng.range_f32(-10.0, 10.0)),
            );
            let half = DVec3::new(
                f64::from(rng.range_f32(0.2, 6.0)),
                f64::from(rng.range_f32(0.2, 6.0)),
                f64::from(rng.range_f32(0.2, 6.0)),
            );
            boxes.push(DepthBox {
                min: centre - half,
                max: centre + half,
                cap: if rng.next_f32() < 0.5 {
                    f64::NEG_INFINITY
                } else {
                    centre.z
                },
                max_depth: f64::from(rng.range_f32(20.0, 80.0)),
                reach_ends: [rng.next_f32() < 0.5, rng.next_f32() < 0.5],
            });
        }
        let eye = DVec3::new(1.0, -2.0, 0.5);
        let mut mask = [false; 6 * 4 * 4];
        for (k, m) in mask.iter_mut().enumerate() {
            *m = k % 3 != 0;
        }
        for needed in [None, Some(&mask[..])] {
            let mut grouped = CubeDepth::new(64);
            grouped.render(
                eye,
                &BoxGroups::new(boxes.clone(), eye, 32.0),
                2,
                1e-3,
                needed,
            );
            let mut alone = CubeDepth::new(64);
            alone.render(
                eye,
                &BoxGroups::new(boxes.clone(), eye, 1e-3),
                2,
                1e-3,
                needed,
            );
            assert!(BoxGroups::new(boxes.clone(), eye, 32.0).groups.len() < 150);
            assert_eq!(BoxGroups::new(boxes.clone(), eye, 1e-3).groups.len(), 300);
            assert_eq!(grouped.depth, alone.depth);
            assert_eq!(grouped.cap, alone.cap);
            assert!(grouped.depth.iter().any(|d| d.is_finite()));
        }
    }
}
