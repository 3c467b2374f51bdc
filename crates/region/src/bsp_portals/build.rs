//! The portals of a Quake 3 BSP: the convex openings between neighbouring empty leaves.
//!
//! Based on: Teller, Séquin. Visibility preprocessing for interactive walkthroughs. SIGGRAPH
//! 1991 (cells and portals from a BSP's leaves); the construction is the one of the Quake
//! tools' `MakeTreePortals`, in another order: each node's plane, cut to the node's region,
//! is split down its front subtree into the pieces facing front leaves, and each piece down
//! its back subtree into the pieces that face a back leaf too. Such a piece lies on the
//! boundary of both leaves: it is the portal between them when both are empty.
//!
//! Conservative by construction where it matters: every cut keeps a sliver more
//! ([`GROW`]), so a portal is never smaller than the opening (a larger portal only lets the
//! flow see more), and a piece lying on a descendant's plane goes to both of its sides.

use glam::DVec3;
use sightline_core::scene::q3::BspData;

use super::winding::{base_winding, double_area, keep_front, side, Plane, Side};

/// Map units by which every cut errs on the large side: portals grow by this much and
/// targets keep this much more. Not for f64's rounding (1e-12 at map scale) but for the map's
/// own: the compiler snaps vertices to 1/8 unit and planes to its grid, so the drawn faces and
/// the tree's planes can disagree by a fraction of that.
pub(crate) const GROW: f64 = 0.125;

/// Map units within which a triangle counts as touching a leaf. Larger than [`GROW`]: the
/// drawn faces of slanted brushes lie up to a fraction of a unit inside the solid leaves the
/// tree gives them (on q3dm6ish, a ramp's face lies wholly in the solid leaf behind it).
pub(crate) const TOUCH: f64 = 0.5;

/// A portal: `winding` on `plane`, whose front holds `front` and whose back holds `back`.
#[derive(Clone, Debug)]
pub(crate) struct Portal {
    pub(crate) front: usize,
    pub(crate) back: usize,
    pub(crate) plane: Plane,
    pub(crate) winding: Vec<DVec3>,
}

impl Portal {
    /// The leaf on the other side from `leaf`.
    pub(crate) fn other(&self, leaf: usize) -> usize {
        if self.front == leaf {
            self.back
        } else {
            self.front
        }
    }
}

/// Every portal of a map, and the portals of each leaf.
#[derive(Clone, Debug, Default)]
pub(crate) struct PortalGraph {
    pub(crate) portals: Vec<Portal>,
    pub(crate) of_leaf: Vec<Vec<usize>>,
}

/// True when leaf `l` is empty space: it has a cluster (Quake 3 gives solid leaves, and the
/// sealed outside, cluster -1).
pub(crate) fn is_empty(bsp: &BspData, l: usize) -> bool {
    bsp.leaves.get(l).is_some_and(|leaf| leaf.cluster >= 0)
}

/// The plane of every node of `bsp` in f64, normalised (`None` for a node whose plane index is
/// out of range or whose normal is zero or not finite): made once, read by every descent.
pub(crate) fn node_planes(bsp: &BspData) -> Vec<Option<Plane>> {
    let plane_of = |n: &sightline_core::scene::q3::Node| {
        let p = bsp.planes.get(n.plane as usize)?;
        let normal = p.normal.as_dvec3();
        let len = normal.length();
        (len > 0.0 && len.is_finite()).then(|| Plane {
            normal: normal / len,
            dist: f64::from(p.dist) / len,
        })
    };
    bsp.nodes.iter().map(plane_of).collect()
}

/// The box the map lives in (its leaves' bounds, grown): the region of the root node, as its
/// six planes, with the box's largest extent.
fn world(bsp: &BspData) -> (Vec<Plane>, f64) {
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for leaf in &bsp.leaves {
        let b = leaf.bounds();
        lo = lo.min(b.min.as_dvec3());
        hi = hi.max(b.max.as_dvec3());
    }
    if lo.x > hi.x {
        return (Vec::new(), 0.0);
    }
    let (lo, hi) = (lo - 16.0, hi + 16.0);
    let mut planes = Vec::new();
    for a in 0..3 {
        let mut e = DVec3::ZERO;
        e[a] = 1.0;
        planes.push(Plane {
            normal: e,
            dist: lo[a],
        });
        planes.push(Plane {
            normal: -e,
            dist: -hi[a],
        });
    }
    (planes, (hi - lo).max_element())
}

/// The portal graph of `bsp`, whose [`node_planes`] are `planes` (empty for a map without
/// nodes). `None` when the tree is malformed (a child index out of range or a cycle).
pub(crate) fn build(bsp: &BspData, planes: &[Option<Plane>]) -> Option<PortalGraph> {
    let mut graph = PortalGraph {
        portals: Vec::new(),
        of_leaf: vec![Vec::new(); bsp.leaves.len()],
    };
    if bsp.nodes.is_empty() {
        return Some(graph);
    }
    let (world, extent) = world(bsp);
    let half = 2.0 * extent;
    // Depth-first over the nodes with the half-spaces of their ancestors; the loader checked
    // that the nodes form a tree, and the visit count guards hand-built data.
    let mut stack: Vec<(usize, Vec<Plane>)> = vec![(0, world)];
    let mut visits = 0usize;
    while let Some((node, bounds)) = stack.pop() {
        visits += 1;
        if visits > bsp.nodes.len() + 1 {
            return None;
        }
        let n = bsp.nodes.get(node)?;
        let plane = (*planes.get(node)?)?;
        let mut w = base_winding(&plane, half);
        for b in &bounds {
            w = keep_front(&w, b, GROW);
            if w.is_empty() {
                break;
            }
        }
        if !w.is_empty() {
            let mut fronts = Vec::new();
            filter(bsp, planes, n.children[0], w, &mut fronts, 0)?;
            for (front, piece) in fronts {
                if !is_empty(bsp, front) {
                    continue;
                }
                let mut backs = Vec::new();
                filter(bsp, planes, n.children[1], piece, &mut backs, 0)?;
                for (back, winding) in backs {
                    if is_empty(bsp, back) && double_area(&winding) > 0.0 {
                        let i = graph.portals.len();
                        graph.of_leaf[front].push(i);
                        graph.of_leaf[back].push(i);
                        graph.portals.push(Portal {
                            front,
                            back,
                            plane,
                            winding,
                        });
                    }
                }
            }
        }
        for (child, half_space) in [(n.children[0], plane), (n.children[1], plane.flipped())] {
            if child >= 0 {
                let mut b = bounds.clone();
                b.push(half_space);
                stack.push((child as usize, b));
            }
        }
    }
    Some(graph)
}

/// Splits `w` down the subtree `node` into the pieces over each of its leaves.
fn filter(
    bsp: &BspData,
    planes: &[Option<Plane>],
    node: i32,
    w: Vec<DVec3>,
    out: &mut Vec<(usize, Vec<DVec3>)>,
    depth: usize,
) -> Option<()> {
    if depth > bsp.nodes.len() {
        return None;
    }
    if node < 0 {
        let leaf = (-(node + 1)) as usize;
        if leaf < bsp.leaves.len() {
            out.push((leaf, w));
        }
        return Some(());
    }
    let n = bsp.nodes.get(node as usize)?;
    let plane = (*planes.get(node as usize)?)?;
    match side(&w, &plane, GROW) {
        Side::Front => filter(bsp, planes, n.children[0], w, out, depth + 1),
        Side::Back => filter(bsp, planes, n.children[1], w, out, depth + 1),
        Side::On => {
            filter(bsp, planes, n.children[0], w.clone(), out, depth + 1)?;
            filter(bsp, planes, n.children[1], w, out, depth + 1)
        }
        Side::Both => {
            let front = keep_front(&w, &plane, GROW);
            let back = keep_front(&w, &plane.flipped(), GROW);
            if !front.is_empty() {
                filter(bsp, planes, n.children[0], front, out, depth + 1)?;
            }
            if !back.is_empty() {
                filter(bsp, planes, n.children[1], back, out, depth + 1)?;
            }
            Some(())
        }
    }
}
