//! Back faces of closed solids, from a whole view cell: a conservative rule beside occluders
//! and portals for the two-sided bake's bound.
//!
//! A viewpoint outside a closed solid sees only the faces of the solid that face it: a
//! segment from the viewpoint to a point just behind a face ends inside the solid, so it
//! crosses the solid's surface before it gets there. A face whose plane has the whole (convex)
//! cell strictly behind it, of a solid the cell lies wholly outside, is therefore hidden from
//! every point of the cell (its edges have no area: positive-area semantics, as the exact
//! method's). This is cell-wide back-face culling (Kumar, Manocha, Garrett, Lin. Hierarchical
//! back-face computation. Eurographics Rendering Workshop 1996) applied only where the
//! surface provably closes: in a city, about half the walls and roofs in a street cell's
//! umbra-only bound face away from the whole cell, and no single convex occluder hides them,
//! because they meet the silhouette of their own building along shared edges.
//!
//! # What counts as a closed solid
//! - `topology.rs`: triangles welded by bit-identical corners, joined across edges shared by
//!   exactly two of them in opposite directions; a group is kept when each of its edges is such
//!   an edge, or when every edge only one triangle has lies in one axis plane with the group on
//!   one side of it (a building without a floor on the ground: for a viewpoint on the group's
//!   side of the plane, no segment reaches the open bottom without crossing the plane).
//!   Orientation from the signed volume.
//! - `embedded.rs`: no two triangles of the group meet except at shared corners and edges
//!   (a self-crossing surface, such as a footprint drawn as a bow tie, encloses space twice or
//!   with the wrong hand, and "behind a face is inside" fails).
//! - `ties.rs`: a face another triangle lies on (two walls drawn in one plane) is never
//!   removed, nor a narrow face: a margin against f32 depth ties near edges.
//! - `cell.rs`, per cell: the cell's box lies on the group's side of its cap plane, meets no
//!   triangle of it, and its centre has winding number 0.
//!
//! Every test leans to "not a solid" / "not outside" under rounding doubt, so the rule only
//! removes triangles it has proved hidden.
//!
//! # Memory and time
//! Built once per scene: about 50 bytes per triangle while it is built (welding, edge uses),
//! 9 bytes per triangle kept (its solid, the solids' member lists, a tie flag) and 64 bytes per solid.
//! The self-crossing check tests the pairs of a group's triangles whose boxes overlap, at most
//! [`MAX_PAIR_TESTS_PER_TRIANGLE`] per triangle (a group needing more is left alone); the tie
//! check the pairs of the scene's triangles whose boxes overlap, one of them in a solid, with
//! the same allowance per triangle of the scene (a scene needing more gets no solids). Per
//! cell: one box test per solid, the precise tests for solids whose box meets the cell's, and
//! four plane tests per set triangle of a solid.

pub(crate) mod cell;
mod embedded;
mod span;
mod ties;
mod topology;

use std::ops::Range;

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use sightline_core::{Scene, TriangleSet};

use topology::{corners_of, normal_of, Cap};

/// Precise pair tests the self-crossing check may spend per triangle of a group (beyond a
/// fixed allowance for small groups); a group that needs more is not used.
pub const MAX_PAIR_TESTS_PER_TRIANGLE: usize = 256;

/// Pair tests every group may spend whatever its size.
const PAIR_TEST_ALLOWANCE: usize = 1 << 16;

/// Margins of the per-cell plane tests, relative to the distances involved.
const RELATIVE_MARGIN: f64 = 1e-7;

/// Another triangle within this distance of a face's plane (relative to the scene's
/// diagonal) and over it lies on the face (`ties.rs`): f32 depths along a ray at 500 m are
/// about 3e-5 m apart, so 1e-5 of a 1.5 km city (1.5 cm) leaves a wide margin.
const TIE_DISTANCE: f64 = 1e-5;

/// Solids thinner than this many tie distances (volume over surface, half a slab's
/// thickness), and faces narrower than it, are not used: where a solid is that thin, its
/// front and back lie so close that a ray caster's f32 depths tie over a share of a face
/// (fzk_haus's window muntins, under a millimetre across, showed their back faces to up to
/// 0.3 % of the rays aimed at them from a cell, etoile's 19 cm wall ends to 0.004 %).
const THIN_SOLID: f64 = 4.0;

const NO_SOLID: u32 = u32::MAX;

/// A closed solid as other rules read it (`ClosedSolids::solid`).
pub(crate) struct SolidView<'a> {
    /// Its triangles.
    pub triangles: &'a [u32],
    /// +1 when the triangles' winding faces out of the solid, -1 when it faces in.
    pub orientation: f64,
    /// The plane of its open bottom, where it has one: axis, coordinate and the side the
    /// solid lies on (+1 above).
    pub open_at: Option<(usize, f64, f64)>,
}

/// The closed solids of a scene (see the module documentation).
#[derive(Clone, Debug, Default)]
pub struct ClosedSolids {
    /// Per triangle, its solid or [`NO_SOLID`].
    solid_of: Vec<u32>,
    solids: Vec<Solid>,
    /// The solids' triangles, solid after solid.
    members: Vec<u32>,
    /// Per triangle, whether another triangle lies on it or it is narrow (`ties.rs`): never
    /// removed.
    tied: Vec<bool>,
}

#[derive(Clone, Debug)]
struct Solid {
    cap: Option<Cap>,
    /// +1 when the triangles' winding faces out of the solid.
    orientation: f64,
    min: DVec3,
    max: DVec3,
    /// Its range of `members`.
    members: Range<usize>,
}

impl ClosedSolids {
    /// Finds the closed solids of `scene`.
    pub fn new(scene: &Scene) -> Self {
        let bounds = scene.bounds();
        let tie_distance = TIE_DISTANCE * f64::from((bounds.max - bounds.min).length());
        if !tie_distance.is_finite() || tie_distance <= 0.0 {
            return Self::default(); // empty, flat to a point, or non-finite corners
        }
        let candidates = topology::candidates(scene);
        let kept: Vec<topology::Candidate> = candidates
            .into_par_iter()
            .filter(|c| {
                if c.thickness < THIN_SOLID * tie_distance {
                    return false;
                }
                let corners: Vec<[DVec3; 3]> =
                    c.triangles.iter().map(|&t| corners_of(scene, t)).collect();
                let budget = PAIR_TEST_ALLOWANCE + MAX_PAIR_TESTS_PER_TRIANGLE * c.triangles.len();
                !embedded::may_meet_itself(&corners, budget)
            })
            .collect();
        let mut solids = Self {
            solid_of: vec![NO_SOLID; scene.triangle_count()],
            solids: Vec::with_capacity(kept.len()),
            members: Vec::with_capacity(kept.iter().map(|c| c.triangles.len()).sum()),
            tied: Vec::new(),
        };
        for c in kept {
            let index = solids.solids.len() as u32;
            let start = solids.members.len();
            for &t in &c.triangles {
                solids.solid_of[t as usize] = index;
            }
            solids.members.extend_from_slice(&c.triangles);
            solids.solids.push(Solid {
                cap: c.cap,
                orientation: c.orientation,
                min: c.min,
                max: c.max,
                members: start..solids.members.len(),
            });
        }
        let in_solid: Vec<bool> = solids.solid_of.iter().map(|&s| s != NO_SOLID).collect();
        let budget = PAIR_TEST_ALLOWANCE + MAX_PAIR_TESTS_PER_TRIANGLE * scene.triangle_count();
        match ties::tied_faces(scene, &in_solid, tie_distance, budget) {
            Some(tied) => solids.tied = tied,
            None => return Self::default(), // too crowded to tell: no face is trusted
        }
        // Narrow faces: the front and back of a thin rod or wall lie within f32 depth of each
        // other over a share of its width (`THIN_SOLID`).
        for (t, tied) in solids.tied.iter_mut().enumerate() {
            if in_solid[t] && !*tied {
                *tied =
                    ties::narrowest_width(&corners_of(scene, t as u32)) < THIN_SOLID * tie_distance;
            }
        }
        solids
    }

    /// How many closed solids the scene has.
    pub fn solid_count(&self) -> usize {
        self.solids.len()
    }

    /// How many triangles belong to them.
    pub fn triangles_in_solids(&self) -> usize {
        self.members.len()
    }

    /// Solid `index` as other rules read it.
    pub(crate) fn solid(&self, index: usize) -> SolidView<'_> {
        let s = &self.solids[index];
        SolidView {
            triangles: &self.members[s.members.clone()],
            orientation: s.orientation,
            open_at: s.cap.map(|c| (c.axis, c.at, c.side)),
        }
    }

    /// Per solid, whether the convex cell with `corners` lies wholly outside it (and on its
    /// side of its cap plane).
    pub(crate) fn outside_for(&self, scene: &Scene, corners: &[DVec3]) -> Vec<bool> {
        let (mut lo, mut hi) = (corners[0], corners[0]);
        for c in corners {
            lo = lo.min(*c);
            hi = hi.max(*c);
        }
        self.solids
            .par_iter()
            .map(|s| {
                let reach = (hi - lo)
                    .max_element()
                    .max((s.max - s.min).max_element())
                    .max((s.max - lo).abs().max_element())
                    .max((s.min - hi).abs().max_element());
                let margin = RELATIVE_MARGIN * reach;
                if let Some(cap) = s.cap {
                    if corners
                        .iter()
                        .any(|c| (c[cap.axis] - cap.at) * cap.side <= margin)
                    {
                        return false;
                    }
                }
                let pad = DVec3::splat(margin);
                let boxes_apart = (lo - pad).cmpgt(s.max).any() || (hi + pad).cmplt(s.min).any();
                if boxes_apart {
                    return true;
                }
                let triangles = || {
                    self.members[s.members.clone()]
                        .iter()
                        .map(|&t| corners_of(scene, t))
                };
                if triangles().any(|t| cell::may_meet_box(&t, lo, hi)) {
                    return false;
                }
                // A ray away from the cap plane never reaches the open bottom.
                let (axis, sign) = s.cap.map_or((2, 1.0), |c| (c.axis, c.side));
                cell::winding_number(triangles(), s.orientation, (lo + hi) * 0.5, axis, sign)
                    == Some(0)
            })
            .collect()
    }

    /// Removes from `visible` the triangles of closed solids that are back faces from every
    /// point of the convex cell with `corners`, of solids the cell lies wholly outside; returns
    /// how many it removed. `scene` must be the scene the solids were found in.
    pub fn remove_back_faces(
        &self,
        scene: &Scene,
        corners: &[Vec3],
        visible: &mut TriangleSet,
    ) -> usize {
        if self.solids.is_empty() || corners.iter().any(|c| !c.is_finite()) || corners.is_empty() {
            return 0;
        }
        let corners: Vec<DVec3> = corners.iter().map(|c| c.as_dvec3()).collect();
        let outside = self.outside_for(scene, &corners);
        let hidden: Vec<usize> = visible
            .ones()
            .filter(|&t| {
                let Some(&solid) = self.solid_of.get(t) else {
                    return false;
                };
                if solid == NO_SOLID || !outside[solid as usize] || self.tied[t] {
                    return false;
                }
                let c = corners_of(scene, t as u32);
                let normal = normal_of(&c) * self.solids[solid as usize].orientation;
                let length = normal.length();
                corners.iter().all(|p| {
                    let to = *p - c[0];
                    normal.dot(to) < -RELATIVE_MARGIN * length * to.length()
                })
            })
            .collect();
        for &t in &hidden {
            visible.set(t, false);
        }
        hidden.len()
    }
}

#[cfg(test)]
mod tests;
