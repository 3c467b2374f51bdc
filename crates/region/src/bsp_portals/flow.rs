//! What a box sees through a map's portals: the portal flow of the Quake tools' `vis`, from a
//! box instead of a portal, and down to triangles instead of leaves.
//!
//! Based on: Teller, Séquin. Visibility preprocessing for interactive walkthroughs. SIGGRAPH
//! 1991 (visibility through portal sequences; a sequence is seen through when a line stabs
//! every portal of it); Airey, Rohlf, Brooks. Towards image realism with interactive update
//! rates in complex virtual building environments. I3D 1990 (cells and portals); the
//! separating planes of the Quake tools' `ClipToSeperators` as the conservative stand-in for
//! Teller's exact stabbing test.
//!
//! # Why it is conservative
//! Empty leaves are convex and tile the empty space; everything else is solid. A segment from
//! the box to a point stays in empty space, so it leaves the box's leaves (the *sources*)
//! for the last time through a portal `p1` of one of them, and then passes from leaf to leaf
//! only through portals: a point seen from the box is in a source leaf, or at the end of a
//! portal sequence `p1, ..., pk` that the segment crosses in order. The flow walks every such
//! sequence depth first and keeps of each portal only what a segment from the box through the
//! part kept of the one before can reach: the part on the front of every *separating plane*
//! of the box and that part (a plane with the whole box on its back and the whole part on its
//! front: a segment from the box through the part is on the front from there on), and past
//! `p1` of every separating plane of `p1` and that part (the segment crosses `p1` too, and
//! the box alone lets through segments no point of `p1` sends); `p1` itself narrowed, as the
//! walk goes deeper, to what sends segments through the last two parts (the front of their
//! separating planes, as `vis` narrows its source portal). Dropping parts
//! only by such planes, with a sliver kept at every cut, never drops a point a segment
//! reaches, so a triangle is kept whenever some part of it survives the same cuts in a leaf
//! the flow enters (or it touches a source leaf).
//!
//! What this does not see: occluders inside leaves (detail brushes, patches, models: they do
//! not split the tree), which the other side of a two-sided bound, RV's umbrae, handles.

use fixedbitset::FixedBitSet;
use glam::DVec3;
use sightline_core::scene::q3::BspData;
use sightline_core::scene::Scene;
use sightline_core::TriangleSet;

use super::build::{is_empty, PortalGraph, GROW, TOUCH};
use super::might::all_complete;
use super::winding::{keep_front, side, Plane, Side};

/// The first walk gets this share of the budget (one part in this many): the cells whose
/// walk finishes need far less (the shared maps' cells at most 53,000 leaf entries), and
/// past it the merged flow and the pruned walk that follows it usually finish sooner.
pub(crate) const FIRST_WALK_SHARE: u64 = 5;

/// Tolerance of the separating-plane test: distances f64 cannot tell from 0 at map scale.
const SEPARATION: f64 = 1e-6;

/// The triangles touching each leaf: each triangle descends the tree to every side it has a
/// corner on or within [`TOUCH`] of, so a leaf's list holds every triangle with a point in the
/// leaf or on its boundary (grown by `TOUCH`), and perhaps more.
pub(crate) fn leaf_triangles(
    bsp: &BspData,
    planes: &[Option<Plane>],
    scene: &Scene,
) -> Vec<Vec<u32>> {
    let mut lists = vec![Vec::new(); bsp.leaves.len()];
    if bsp.nodes.is_empty() {
        if let Some(l) = lists.first_mut() {
            *l = (0..scene.triangles.len() as u32).collect();
        }
        return lists;
    }
    let mut stack = Vec::new();
    for (id, t) in scene.triangles.iter().enumerate() {
        let Some(corners) = t
            .iter()
            .map(|&i| scene.positions.get(i as usize).map(|p| p.as_dvec3()))
            .collect::<Option<Vec<DVec3>>>()
        else {
            continue;
        };
        if corners.iter().any(|c| !c.is_finite()) {
            continue;
        }
        stack.clear();
        stack.push(0i32);
        let mut budget = 2 * (bsp.nodes.len() + bsp.leaves.len()) + 1;
        while let Some(node) = stack.pop() {
            budget = budget.saturating_sub(1);
            if budget == 0 {
                break;
            }
            if node < 0 {
                if let Some(l) = lists.get_mut((-(node + 1)) as usize) {
                    l.push(id as u32);
                }
                continue;
            }
            let (Some(n), Some(Some(plane))) =
                (bsp.nodes.get(node as usize), planes.get(node as usize))
            else {
                continue;
            };
            // Closed sides: a triangle that only touches a leaf's boundary plane (an edge or a
            // corner on it) is in the leaf too, since a ray through that edge may stop on it
            // (the watertight test gives an edge to one of the triangles sharing it).
            let (lo, hi) = corners.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &c| {
                let d = plane.distance(c);
                (lo.min(d), hi.max(d))
            });
            if hi > -TOUCH {
                stack.push(n.children[0]);
            }
            if lo < TOUCH {
                stack.push(n.children[1]);
            }
        }
    }
    lists
}

/// The separating planes of the box `corners` (8, with `EDGES`) and the convex polygon
/// `pass`, each turned so that `pass` is on its front.
fn separators(corners: &[DVec3; 8], pass: &[DVec3]) -> Vec<Plane> {
    let box_edges = EDGES.map(|(i, j)| (corners[i], corners[j]));
    separators_of(corners, &box_edges, pass)
}

/// The separating planes of the convex polygon `source` (a portal every segment of the
/// sequence crosses) and the convex polygon `pass`, each turned so that `pass` is on its front.
fn polygon_separators(source: &[DVec3], pass: &[DVec3]) -> Vec<Plane> {
    let edges: Vec<(DVec3, DVec3)> = (0..source.len())
        .map(|i| (source[i], source[(i + 1) % source.len()]))
        .collect();
    separators_of(source, &edges, pass)
}

/// The separating planes of a convex body (its `points` and `edges`) and the convex polygon
/// `pass`: planes through an edge of one and a point of the other with the body on the back
/// and `pass` on the front (Teller and Séquin's, as the Quake tools' `ClipToSeperators` finds
/// them).
fn separators_of(points: &[DVec3], edges: &[(DVec3, DVec3)], pass: &[DVec3]) -> Vec<Plane> {
    let mut out = Vec::new();
    let mut try_plane = |a: DVec3, b: DVec3, c: DVec3| {
        let n = (b - a).cross(c - a);
        let len = n.length();
        // Degenerate (or NaN) planes separate nothing.
        if len.is_nan() || len <= 1e-9 {
            return;
        }
        let mut plane = Plane {
            normal: n / len,
            dist: (n / len).dot(a),
        };
        let body_side = side(points, &plane, SEPARATION);
        let pass_side = side(pass, &plane, SEPARATION);
        match (body_side, pass_side) {
            (Side::Back, Side::Front) => {}
            (Side::Front, Side::Back) => plane = plane.flipped(),
            _ => return,
        }
        out.push(plane);
    };
    for (i, &a) in pass.iter().enumerate() {
        let b = pass[(i + 1) % pass.len()];
        for &c in points {
            try_plane(a, b, c);
        }
    }
    for &(a, b) in edges {
        for &p in pass {
            try_plane(a, b, p);
        }
    }
    out
}

/// The 12 edges of a box whose corner `k` has `x` from bit 0, `y` from bit 1, `z` from bit 2.
const EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

/// `poly` cut by the plane of the portal passed (the side beyond it) and by `planes`, with a
/// sliver kept at each cut; empty when nothing is left.
fn reachable_part(poly: &[DVec3], beyond: Option<&Plane>, planes: &[Plane]) -> Vec<DVec3> {
    let mut w = poly.to_vec();
    for plane in beyond.into_iter().chain(planes) {
        w = keep_front(&w, plane, GROW);
        if w.is_empty() {
            break;
        }
    }
    w
}

/// The portal flow from one box (see the module documentation).
pub(crate) struct Flow<'a> {
    pub(crate) bsp: &'a BspData,
    pub(crate) scene: &'a Scene,
    pub(crate) graph: &'a PortalGraph,
    pub(crate) leaf_triangles: &'a [Vec<u32>],
    pub(crate) corners: [DVec3; 8],
    /// Per portal side, the leaves a sequence through it might enter (`might.rs`).
    pub(crate) might: &'a [FixedBitSet],
    /// Leaves entered so far by the walk of every sequence, which stops past its budget.
    pub(crate) steps: u64,
    pub(crate) budget: u64,
    pub(crate) marks: Marks<'a>,
    /// Leaves on the current sequence (a segment enters a convex leaf once).
    pub(crate) on_path: Vec<bool>,
    pub(crate) sources: Vec<bool>,
    /// Whether parts past a sequence's first leaf are also cut by the separating planes of
    /// its first portal (always, but in the test that measures what they take off).
    pub(crate) first_portal_cuts: bool,
    /// Whether portals that can mark nothing new are skipped (`might.rs`; always, but in the
    /// test that compares).
    pub(crate) prune: bool,
}

/// A portal side to go on from: side `2p` of portal `p` enters its front leaf, `2p + 1` its
/// back leaf, through the part `part` of the portal.
type Seed = (usize, Vec<DVec3>);

/// A leaf on the current portal sequence: the cuts of the part it was entered through, and
/// the next of its portals to try.
struct Frame {
    leaf: usize,
    beyond: Option<Plane>,
    seps: Vec<Plane>,
    next_portal: usize,
    /// The part of the portal the leaf was entered through.
    pass: Vec<DVec3>,
    /// The part of the sequence's first portal that segments reaching `pass` cross (with
    /// `first_portal_cuts`).
    source: Option<Vec<DVec3>>,
    /// The leaves every portal of the sequence so far might lead to (`might.rs`).
    might: FixedBitSet,
}

/// The triangles marked seen, and per leaf how many of its triangles are not yet: a leaf
/// whose triangles are all marked is `complete`, and a portal that leads only to complete
/// leaves is not walked (`might.rs`).
pub(crate) struct Marks<'a> {
    pub(crate) visible: TriangleSet,
    /// The leaves of each triangle (the inverse of `leaf_triangles`).
    leaves_of: &'a [Vec<u32>],
    unseen: Vec<u32>,
    complete: FixedBitSet,
    /// Only these triangles are counted, when set ([`Marks::limit_to`]).
    reachable: Option<TriangleSet>,
}

impl<'a> Marks<'a> {
    /// Nothing marked, for a scene of `triangles` triangles whose leaves hold
    /// `leaf_triangles` (and each triangle lies in the leaves `leaves_of`).
    pub(crate) fn new(
        triangles: usize,
        leaf_triangles: &[Vec<u32>],
        leaves_of: &'a [Vec<u32>],
    ) -> Self {
        let unseen: Vec<u32> = leaf_triangles.iter().map(|l| l.len() as u32).collect();
        let mut complete = FixedBitSet::with_capacity(unseen.len());
        complete.extend(
            unseen
                .iter()
                .enumerate()
                .filter(|(_, &n)| n == 0)
                .map(|(l, _)| l),
        );
        Marks {
            visible: TriangleSet::with_capacity(triangles),
            leaves_of,
            unseen,
            complete,
            reachable: None,
        }
    }

    /// Counts from now on only the triangles of `reachable` (a set no flow from the same
    /// box adds to): a leaf is complete when those of its triangles are all marked.
    fn limit_to(&mut self, reachable: &TriangleSet, leaf_triangles: &[Vec<u32>]) {
        for (leaf, list) in leaf_triangles.iter().enumerate() {
            let n = list
                .iter()
                .filter(|&&t| reachable.contains(t as usize) && !self.visible.contains(t as usize))
                .count() as u32;
            self.unseen[leaf] = n;
            self.complete.set(leaf, n == 0);
        }
        self.reachable = Some(reachable.clone());
    }

    /// Marks of `visible` alone, counting nothing per leaf (for the merged flow).
    fn copy_of(visible: &TriangleSet) -> Marks<'static> {
        Marks {
            visible: visible.clone(),
            leaves_of: &[],
            unseen: Vec::new(),
            complete: FixedBitSet::new(),
            reachable: None,
        }
    }

    fn contains(&self, t: u32) -> bool {
        self.visible.contains(t as usize)
    }

    /// Marks triangle `t` seen.
    fn insert(&mut self, t: u32) {
        if self.visible.put(t as usize) {
            return;
        }
        if self
            .reachable
            .as_ref()
            .is_some_and(|r| !r.contains(t as usize))
        {
            return;
        }
        for &leaf in self
            .leaves_of
            .get(t as usize)
            .map_or(&[][..], Vec::as_slice)
        {
            let n = &mut self.unseen[leaf as usize];
            *n = n.saturating_sub(1);
            if *n == 0 {
                self.complete.insert(leaf as usize);
            }
        }
    }
}

impl<'a> Flow<'a> {
    /// Every triangle the box may see, and whether every portal sequence was walked (else
    /// the budget ran out twice and the set is the merged flow's). The walk first gets a
    /// fifth of the budget; past it, the merged flow from the sources' portals, and the walk
    /// again with the whole budget, pruned against that flow.
    pub(crate) fn run(mut self, sources: &[usize]) -> (TriangleSet, bool) {
        let first_seeds = self.start(sources);
        let budget = self.budget;
        self.budget = budget / FIRST_WALK_SHARE;
        if self.walk_all(&first_seeds) {
            return (self.marks.visible, true);
        }
        self.budget = budget;
        // Past the budget: the merged flow from the sources' portals, a looser set that no
        // sequence adds to (`merged_from`), and then the walk once more (a fresh budget),
        // keeping what it marked and skipping every portal whose leaves have all their
        // triangles of that set marked: leaves fill up far sooner when only the triangles the
        // merged flow reaches count (czest3ctf: 62-84 % of the leaves, against 4-7 %).
        let loose = merged_from(
            &self,
            Marks::copy_of(&self.marks.visible),
            first_seeds.clone(),
        );
        self.marks.limit_to(&loose, self.leaf_triangles);
        self.steps = 0;
        if self.walk_all(&first_seeds) {
            (self.marks.visible, true)
        } else {
            (loose, false)
        }
    }

    /// Marks the triangles of the source leaves; returns the seeds of their portals.
    fn start(&mut self, sources: &[usize]) -> Vec<Seed> {
        for &s in sources {
            self.sources[s] = true;
            for &t in &self.leaf_triangles[s] {
                self.marks.insert(t);
            }
        }
        let mut seeds: Vec<Seed> = Vec::new();
        for &s in sources {
            for &p in &self.graph.of_leaf[s] {
                let portal = &self.graph.portals[p];
                let next = portal.other(s);
                if !self.sources[next] && is_empty(self.bsp, next) {
                    seeds.push((side_into(self.graph, p, next), portal.winding.clone()));
                }
            }
        }
        seeds
    }

    /// The first walk alone, with the whole budget (for the tests).
    #[cfg(test)]
    pub(crate) fn run_first_walk(mut self, sources: &[usize]) -> (TriangleSet, bool) {
        let seeds = self.start(sources);
        let walked = self.walk_all(&seeds);
        (self.marks.visible, walked)
    }

    /// Walks every sequence from `seeds` until the budget runs out; true when it did not.
    fn walk_all(&mut self, seeds: &[Seed]) -> bool {
        // A walk that ran out left its sequence's leaves marked as on the path.
        self.on_path.fill(false);
        seeds
            .iter()
            .all(|seed| self.nothing_new(None, seed.0) || self.walk(seed))
    }

    /// Whether a sequence through portal side `side`, after the portals of `path` (the
    /// leaves they might lead to), can only enter leaves whose triangles are all marked.
    fn nothing_new(&self, path: Option<&FixedBitSet>, side: usize) -> bool {
        if !self.prune {
            return false;
        }
        let own = &self.might[side];
        all_complete(path.unwrap_or(own), own, &self.marks.complete)
    }

    /// Walks every portal sequence from `seed`, depth first with an explicit stack (a
    /// sequence may be as long as the map has leaves); false when the budget ran out first.
    fn walk(&mut self, seed: &Seed) -> bool {
        // Every segment of the sequences from this seed crosses its portal (it leaves the
        // sources there for the last time): past the first leaf, the cuts separate the part
        // from that portal as well as from the box.
        let source = self.first_portal_cuts.then(|| seed.1.clone());
        let might = self.might[seed.0].clone();
        let Some(frame) = self.enter(seed, source, might) else {
            return false;
        };
        let mut stack = vec![frame];
        loop {
            let depth = stack.len();
            let Some(frame) = stack.last_mut() else {
                break;
            };
            let leaf = frame.leaf;
            let Some(&p) = self.graph.of_leaf[leaf].get(frame.next_portal) else {
                self.on_path[leaf] = false;
                stack.pop();
                continue;
            };
            frame.next_portal += 1;
            let portal = &self.graph.portals[p];
            let next = portal.other(leaf);
            if self.on_path[next] || self.sources[next] || !is_empty(self.bsp, next) {
                continue;
            }
            let side = side_into(self.graph, p, next);
            if self.nothing_new(Some(&frame.might), side) {
                continue;
            }
            let part = reachable_part(&portal.winding, frame.beyond.as_ref(), &frame.seps);
            if part.is_empty() {
                continue;
            }
            // Of the first portal, only what sends segments through the pass to this part:
            // the front of every separating plane of the part and the pass (Quake's `vis`
            // narrows its source portal the same way).
            let source = match &frame.source {
                Some(source) if depth > 1 => {
                    let narrowed =
                        reachable_part(source, None, &polygon_separators(&part, &frame.pass));
                    if narrowed.is_empty() {
                        continue;
                    }
                    Some(narrowed)
                }
                other => other.clone(),
            };
            let mut might = frame.might.clone();
            might.intersect_with(&self.might[side]);
            match self.enter(&(side, part), source, might) {
                Some(entered) => stack.push(entered),
                None => return false,
            }
        }
        true
    }

    /// Enters a leaf through a seed: marks the triangles seen in it and returns its frame
    /// (`None` past the budget, with nothing marked). `source`: the portal every segment
    /// through the seed crossed before, if it is not the seed's own.
    fn enter(
        &mut self,
        (side, pass): &Seed,
        source: Option<Vec<DVec3>>,
        might: FixedBitSet,
    ) -> Option<Frame> {
        self.steps += 1;
        if self.steps > self.budget {
            return None;
        }
        let (leaf, into) = enters(self.graph, *side);
        // The first leaf is entered through the first portal itself: nothing to separate.
        let first = source.as_ref().is_some_and(|s| s == pass);
        let (beyond, seps) = cuts(
            &self.corners,
            &into,
            pass,
            source.as_deref().filter(|_| !first),
        );
        mark_seen(
            self.scene,
            &self.leaf_triangles[leaf],
            beyond.as_ref(),
            &seps,
            &mut self.marks,
        );
        self.on_path[leaf] = true;
        Some(Frame {
            leaf,
            beyond,
            seps,
            next_portal: 0,
            pass: pass.clone(),
            source,
            might,
        })
    }
}

/// The leaf side `side` of a portal enters, and the portal's plane turned to face into it.
fn enters(graph: &PortalGraph, side: usize) -> (usize, Plane) {
    let portal = &graph.portals[side / 2];
    if side.is_multiple_of(2) {
        (portal.front, portal.plane)
    } else {
        (portal.back, portal.plane.flipped())
    }
}

/// The side of portal `p` that enters `leaf`.
fn side_into(graph: &PortalGraph, p: usize, leaf: usize) -> usize {
    2 * p + usize::from(graph.portals[p].front != leaf)
}

/// The cuts for what is seen past `pass`, a part of a portal whose plane faces `into` the
/// leaf entered: the portal's plane (only when the whole box is behind it, else the cut could
/// drop points a segment from the part of the box in front of it reaches), the separating
/// planes of the box and the part, and those of `source` (a portal every segment through
/// `pass` crossed before) and the part.
fn cuts(
    corners: &[DVec3; 8],
    into: &Plane,
    pass: &[DVec3],
    source: Option<&[DVec3]>,
) -> (Option<Plane>, Vec<Plane>) {
    let beyond = matches!(side(corners, into, 0.0), Side::Back | Side::On).then_some(*into);
    let mut seps = separators(corners, pass);
    if let Some(source) = source {
        seps.extend(polygon_separators(source, pass));
    }
    (beyond, seps)
}

/// Marks in `visible` the triangles of a leaf (`triangles`) that keep a part through the cuts.
fn mark_seen(
    scene: &Scene,
    triangles: &[u32],
    beyond: Option<&Plane>,
    seps: &[Plane],
    marks: &mut Marks<'_>,
) {
    for &t in triangles {
        if marks.contains(t) {
            continue;
        }
        let tri = scene.triangles[t as usize].map(|i| scene.positions[i as usize].as_dvec3());
        if !reachable_part(&tri, beyond, seps).is_empty() {
            marks.insert(t);
        }
    }
}

/// The flow with one part per portal side instead of one per sequence: what a leaf is
/// entered through by a portal is the convex hull of every part that reached it that way,
/// and the walk from it is redone whenever that hull grows. Looser than the walk of every
/// sequence (a hull holds segments no sequence carries, and no leaf is barred for being on
/// the path), but its work is bounded: hulls only grow, inside their portals, each time by
/// more than [`GROW`]. It starts from `seeds` (the sources' portals), with what is already
/// marked in `marks`.
fn merged_from(flow: &Flow<'_>, mut marks: Marks<'_>, seeds: Vec<Seed>) -> TriangleSet {
    let graph = flow.graph;
    let mut hulls: Vec<Option<Vec<DVec3>>> = vec![None; 2 * graph.portals.len()];
    let mut work = Vec::new();
    for (side, part) in seeds {
        offer(graph, &mut hulls, &mut work, side, part);
    }
    while let Some(side) = work.pop() {
        let Some(pass) = hulls[side].clone() else {
            continue;
        };
        let (leaf, into) = enters(graph, side);
        let (beyond, seps) = cuts(&flow.corners, &into, &pass, None);
        mark_seen(
            flow.scene,
            &flow.leaf_triangles[leaf],
            beyond.as_ref(),
            &seps,
            &mut marks,
        );
        for &p in &graph.of_leaf[leaf] {
            if p == side / 2 {
                continue;
            }
            let next = graph.portals[p].other(leaf);
            if flow.sources[next] || !is_empty(flow.bsp, next) {
                continue;
            }
            let part = reachable_part(&graph.portals[p].winding, beyond.as_ref(), &seps);
            if !part.is_empty() {
                offer(
                    graph,
                    &mut hulls,
                    &mut work,
                    side_into(graph, p, next),
                    part,
                );
            }
        }
    }
    marks.visible
}

/// Joins `part` to the hull of portal side `side`, and queues the side when its hull grew by
/// more than [`GROW`] (or is new).
fn offer(
    graph: &PortalGraph,
    hulls: &mut [Option<Vec<DVec3>>],
    work: &mut Vec<usize>,
    side: usize,
    part: Vec<DVec3>,
) {
    let normal = graph.portals[side / 2].plane.normal;
    let grown = match &hulls[side] {
        Some(h) if contains(h, &part, &normal) => return,
        Some(h) => convex_hull(h.iter().chain(&part).copied(), &normal),
        None => part,
    };
    hulls[side] = Some(grown);
    work.push(side);
}

/// Whether convex polygon `inner` lies inside convex polygon `outer` grown by [`GROW`], both
/// on one plane with normal `normal`.
fn contains(outer: &[DVec3], inner: &[DVec3], normal: &DVec3) -> bool {
    let centre = outer.iter().copied().sum::<DVec3>() / outer.len() as f64;
    (0..outer.len()).all(|i| {
        let (a, b) = (outer[i], outer[(i + 1) % outer.len()]);
        let n = (b - a).cross(*normal);
        let len = n.length();
        if len.is_nan() || len == 0.0 {
            return true;
        }
        let mut n = n / len;
        // Turned inwards.
        if n.dot(centre - a) < 0.0 {
            n = -n;
        }
        inner.iter().all(|&p| n.dot(p - a) >= -GROW)
    })
}

/// The convex hull of `points`, all on one plane with normal `normal` (Andrew's monotone
/// chain in the plane's coordinates).
fn convex_hull(points: impl Iterator<Item = DVec3>, normal: &DVec3) -> Vec<DVec3> {
    let a = if normal.x.abs() < 0.6 {
        DVec3::X
    } else {
        DVec3::Y
    };
    let u = normal.cross(a).normalize();
    let v = normal.cross(u);
    let mut pts: Vec<(f64, f64, DVec3)> = points.map(|p| (p.dot(u), p.dot(v), p)).collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let cross = |o: &(f64, f64, DVec3), a: &(f64, f64, DVec3), b: &(f64, f64, DVec3)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64, DVec3)> = Vec::with_capacity(pts.len() * 2);
    for pass in 0..2 {
        let start = hull.len();
        let ordered: Box<dyn Iterator<Item = &(f64, f64, DVec3)>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for p in ordered {
            while hull.len() >= start + 2
                && cross(&hull[hull.len() - 2], &hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(*p);
        }
        hull.pop();
    }
    hull.into_iter().map(|p| p.2).collect()
}
