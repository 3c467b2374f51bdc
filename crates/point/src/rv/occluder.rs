//! One occluder of a bin: an edge-connected patch of same-facing triangles, its silhouette
//! edges and its bounds. A leaf shared by the bin state that builds occluders
//! (`occluders.rs`), its index and edge map, occluder fusion and the occlusion test.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 5 ("internal state": occluder triangles and silhouette edges) and section
//! 7.1.4 (occluder depth bounds).

use glam::{DVec2, DVec3};

use super::overlap::Rect;

/// An occluder's triangle, as the triangle test needs it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct OccTri {
    pub(crate) corners: [DVec3; 3],
    pub(crate) screen: [DVec2; 3],
    pub(crate) plane: [f64; 4],
    pub(crate) rect: Rect,
}

/// A silhouette edge (undirected) in screen coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Edge {
    pub(crate) a: DVec2,
    pub(crate) b: DVec2,
}

impl Edge {
    /// The same segment, walked either way.
    #[inline]
    pub(crate) fn same(&self, o: &Edge) -> bool {
        (self.a == o.a && self.b == o.b) || self.inverse(o)
    }

    /// The same segment walked the other way (a manifold neighbour's shared edge).
    #[inline]
    pub(crate) fn inverse(&self, o: &Edge) -> bool {
        self.a == o.b && self.b == o.a
    }
}

/// One occluder: an edge-connected patch of same-facing visible triangles.
#[derive(Debug)]
pub(crate) struct Occluder {
    pub(crate) tris: Vec<OccTri>,
    pub(crate) edges: Vec<Edge>,
    /// Bounds of the triangles' projections (a superset of the silhouette's).
    pub(crate) rect: Rect,
    /// View depth bounds of the triangles (thesis 7.1.4).
    pub(crate) zmin: f64,
    pub(crate) zmax: f64,
    pub(crate) front: bool,
    /// Its slot in the bin's occluder index (`occluder_index.rs`; meaningless while the index
    /// is off).
    pub(crate) slot: u32,
}
