//! The solid space of a Quake 3 map as column spans: what occluder fusion shrinks on a map,
//! where the brushes' faces are no closed solids (the compiler removes the faces nobody can
//! see, so walls and floors are open shells) but the BSP tree says exactly which space is
//! solid: every point lies in one leaf, and a leaf without a cluster is solid (inside a
//! structural brush or outside the map).
//!
//! Per column (its square times the map's height range), the column's prism descends the tree;
//! each empty leaf it reaches forbids the height range of its piece of the prism, and the
//! heights no empty leaf's piece reaches are solid over the whole square. A piece's range is
//! found from its box, cut plane by plane with a margin, so it only grows: the solid spans
//! are conservative (never a point of empty space in them).
//!
//! Based on: Wonka, Wimmer, Schmalstieg. Visibility Preprocessing with Occluder Fusion for
//! Urban Walkthroughs. 2000 (the occluders to shrink: here the union of the map's solid
//! space); the Quake tools' BSP (empty and solid leaves).

use rayon::prelude::*;
use sightline_core::scene::q3::BspData;
use sightline_core::Scene;

use super::columns::{Columns, Span};
use crate::bsp_portals::{node_planes, Plane};

/// Map units by which every cut keeps more of an empty leaf's piece: the compiler's planes are
/// snapped, and rounding must never make empty space solid.
const CUT_MARGIN: f64 = 1.0 / 64.0;

impl Columns {
    /// The solid space of the map `bsp` (of `scene`) over columns of `size`, or `None` when the
    /// scene is empty or the grid would have more than `max_columns` columns.
    pub(super) fn from_bsp(
        scene: &Scene,
        bsp: &BspData,
        size: f64,
        max_columns: usize,
    ) -> Option<Self> {
        let bounds = scene.bounds();
        if bounds.is_empty() || !size.is_finite() || size <= 0.0 {
            return None;
        }
        let (lo, hi) = (bounds.min.as_dvec3(), bounds.max.as_dvec3());
        let up = scene.up.index();
        let mut columns = Self::grid(up, lo, hi, size, max_columns)?;
        let (across, dims) = (columns.across, columns.dims);
        let tree = Tree {
            bsp,
            planes: node_planes(bsp),
            up,
            across,
            heights: (lo[up] - size, hi[up] + size),
        };
        let rows: Vec<Vec<Vec<Span>>> = (0..dims[1])
            .into_par_iter()
            .map(|j| {
                let mut forbidden = Vec::new();
                (0..dims[0])
                    .map(|i| tree.solid_spans(columns.square(i, j), &mut forbidden))
                    .collect()
            })
            .collect();
        columns.fill(rows);
        Some(columns)
    }
}

/// The tree and the grid's axes, as the descent of a column reads them.
struct Tree<'a> {
    bsp: &'a BspData,
    planes: Vec<Option<Plane>>,
    up: usize,
    across: [usize; 2],
    /// The height range every column covers (the scene's, grown by a column).
    heights: (f64, f64),
}

impl Tree<'_> {
    /// The solid spans of the column over `square` (`forbidden`: scratch space).
    fn solid_spans(&self, square: [[f64; 2]; 2], forbidden: &mut Vec<(f64, f64)>) -> Vec<Span> {
        forbidden.clear();
        let (bottom, top) = self.heights;
        if !self.empty_pieces(square, forbidden) {
            // A malformed tree: nothing counts as solid.
            return Vec::new();
        }
        forbidden.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut spans = Vec::new();
        let mut solid_from = bottom;
        for &(lo, hi) in forbidden.iter() {
            if lo > solid_from {
                spans.push(Span {
                    lo: solid_from,
                    hi: lo,
                    open: false,
                });
            }
            solid_from = solid_from.max(hi);
        }
        if top > solid_from {
            spans.push(Span {
                lo: solid_from,
                hi: top,
                open: false,
            });
        }
        spans
    }

    /// Pushes to `forbidden` the height range of every empty leaf's piece of the column over
    /// `square`; false when the descent took more steps than a tree has nodes and leaves.
    fn empty_pieces(&self, square: [[f64; 2]; 2], forbidden: &mut Vec<(f64, f64)>) -> bool {
        let bsp = self.bsp;
        if bsp.nodes.is_empty() {
            if bsp.leaves.first().is_some_and(|l| l.cluster >= 0) {
                forbidden.push(self.heights);
            }
            return true;
        }
        let corners = [
            [square[0][0], square[1][0]],
            [square[0][1], square[1][0]],
            [square[0][0], square[1][1]],
            [square[0][1], square[1][1]],
        ];
        let mut budget = 2 * (bsp.nodes.len() + bsp.leaves.len()) + 1;
        let mut stack = vec![(0i32, self.heights.0, self.heights.1)];
        while let Some((node, lo, hi)) = stack.pop() {
            budget = budget.saturating_sub(1);
            if budget == 0 {
                return false;
            }
            if node < 0 {
                let leaf = bsp.leaves.get((-(node + 1)) as usize);
                // An unknown leaf counts as empty (the safe side).
                if leaf.is_none_or(|l| l.cluster >= 0) {
                    forbidden.push((lo, hi));
                }
                continue;
            }
            let Some(n) = bsp.nodes.get(node as usize) else {
                return false;
            };
            let Some(plane) = self.planes.get(node as usize).copied().flatten() else {
                // No usable plane: the piece goes down both sides whole.
                stack.push((n.children[0], lo, hi));
                stack.push((n.children[1], lo, hi));
                continue;
            };
            let [front, back] = self.split(&plane, &corners, lo, hi);
            if let Some((a, b)) = front {
                stack.push((n.children[0], a, b));
            }
            if let Some((a, b)) = back {
                stack.push((n.children[1], a, b));
            }
        }
        true
    }

    /// The height ranges of the prism over the square with `corners` between `lo` and `hi` in
    /// front of `plane` (`normal · p >= dist`) and behind it, each grown by [`CUT_MARGIN`]
    /// along the plane's normal; `None` for a side the prism does not reach.
    fn split(
        &self,
        plane: &Plane,
        corners: &[[f64; 2]; 4],
        lo: f64,
        hi: f64,
    ) -> [Option<(f64, f64)>; 2] {
        let n = plane.normal;
        let (nu, na, nb) = (n[self.up], n[self.across[0]], n[self.across[1]]);
        // The plane's distance at a corner's foot, without the up part.
        let (mut dmin, mut dmax) = (f64::INFINITY, f64::NEG_INFINITY);
        for c in corners {
            let d = na * c[0] + nb * c[1] - plane.dist;
            dmin = dmin.min(d);
            dmax = dmax.max(d);
        }
        let nonempty = |a: f64, b: f64| (a <= b).then_some((a, b));
        if !(dmin.is_finite() && dmax.is_finite() && nu.is_finite()) {
            return [Some((lo, hi)), Some((lo, hi))];
        }
        if nu == 0.0 {
            let front = (dmax >= -CUT_MARGIN).then_some((lo, hi));
            let back = (dmin <= CUT_MARGIN).then_some((lo, hi));
            return [front, back];
        }
        // Distance at height z is `d + nu * z`. Front: some corner with `d + nu z >= -margin`,
        // so z on the plane's up side of `front_at`; back: some corner with
        // `d + nu z <= margin`, so z on its down side of `back_at` ("up" being the side the
        // normal points to along the up axis).
        let front_at = (-CUT_MARGIN - dmax) / nu;
        let back_at = (CUT_MARGIN - dmin) / nu;
        if nu > 0.0 {
            [
                nonempty(lo.max(front_at), hi),
                nonempty(lo, hi.min(back_at)),
            ]
        } else {
            [
                nonempty(lo, hi.min(front_at)),
                nonempty(lo.max(back_at), hi),
            ]
        }
    }
}
