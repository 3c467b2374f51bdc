//! Per-bin occluder state: edge-connected patches of visible triangles with their silhouette
//! edges, and how a new visible triangle creates, grows or merges occluders.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 5 ("internal state", "adding visible triangle to occluders", figure 5.14),
//! sections 6.3.1 (occluder storage, global batch pool) and 6.3.3 (occluder state update,
//! merging), and 7.1.4 (occluder depth bounds).
//!
//! Differences from the thesis, and why:
//! - Silhouette edges are kept per occluder (not in one flat per-bin buffer): on a CPU the
//!   per-occluder bounding rectangle then skips whole occluders before any edge is read.
//! - Triangles join an occluder when they share an edge (undirected, exact screen coordinates)
//!   with it, and the silhouette is the sum of the triangles' *directed* edges (the thesis'
//!   half-edges) with exactly opposite pairs cancelled. All triangles of an occluder have the
//!   same screen orientation (one facing), so the silhouette's winding number around a point
//!   counts the occluder's triangles covering it, whatever the manifoldness or self-overlap of
//!   the patch: this is what makes the silhouette test sound for the double-sided,
//!   non-manifold, self-intersecting input sightline accepts.
//! - Because triangles are double-sided here (see `geometry_stage.rs`), front- and back-facing
//!   triangles grow separate occluders: a closed mesh whose front and back halves merged would
//!   cover every point twice, have an empty silhouette and occlude nothing.
//! - Only triangles entirely in front of the near plane and not seen edge-on become occluders
//!   (their projections are bounded and their planes order depth along every eye ray).
//! - When a bin's occluder or edge limit is reached, occluders farther than the new visible
//!   triangle are dropped to make room (the thesis keeps the first ones; see
//!   `evict_farther_than`); when nothing can be dropped, or occluder memory is exhausted, the
//!   visible triangle is simply not added: it stays marked visible, the result stays
//!   conservative.

use glam::DVec2;

use super::fusion::FusedDepth;
use super::geometry_stage::ProjTri;
use super::memory::{release_to, reserve_from, Pool};
use super::occluder::{Edge, OccTri, Occluder};
use super::occluder_index::OccluderIndex;
use super::overlap::Rect;

/// Limits of one bin's state (thesis: occluders per bin, silhouette edge buffer size).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Limits {
    pub(crate) max_occluders: usize,
    pub(crate) max_edges: usize,
    /// Screen area (px²) a triangle needs to start an occluder in a full bin, where the new
    /// occluder takes the place of an evicted one (beyond the thesis; see `add`).
    pub(crate) min_evicting_area: f64,
}

/// What happened to a visible triangle offered to the occluders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum AddOutcome {
    /// Not eligible (crosses the near plane or seen edge-on).
    NotEligible,
    /// Started a new occluder.
    New,
    /// Grew one occluder.
    Grown,
    /// Joined several occluders into one.
    Merged,
    /// A pool was full; the triangle stays visible but does not occlude.
    Full,
}

/// The occluders of one bin.
#[derive(Debug, Default)]
pub(crate) struct BinState {
    pub(crate) occluders: Vec<Occluder>,
    edge_count: usize,
    /// The fused far-depth grid (see `fusion.rs`).
    pub(crate) fused: FusedDepth,
    /// Whether the bin has had its first work item (the initialization phase's).
    pub(crate) initialized: bool,
    /// Which occluders lie where (`occluder_index.rs`); off by default (linear scans).
    pub(crate) index: OccluderIndex,
    /// Changes to the occluders so far (evictions, new, grown and merged occluders): what the
    /// re-test pass needs to know whether a test would still give the same answer.
    pub(crate) changes: u64,
    /// The largest input id of the last batch during which the occluders changed (see
    /// `producer::Settled`); `None` while they never did.
    pub(crate) changed_up_to: Option<u32>,
    /// Emptied buffers of a dropped occluder, kept (still taken from the pool) for the next new
    /// one: in a full bin every new occluder follows an eviction, and reusing them saves an
    /// allocation and a free of each.
    spare_tris: Vec<OccTri>,
    spare_edges: Vec<Edge>,
    /// At least the largest `zmin` of the occluders (an upper bound, tightened when an
    /// eviction scan finds nothing to drop): a full bin offered a triangle in front of every
    /// occluder's near point then skips the scan. Occluders only ever get nearer `zmin`s by
    /// growing, so the bound stays valid.
    zmin_bound: f64,
}

/// A triangle offered to the occluders, as an occluder stores it.
struct Offered {
    tri: OccTri,
    /// Its directed edges, in corner order.
    edges: [Edge; 3],
    /// Its view depth bounds.
    zmin: f64,
    zmax: f64,
    /// Its screen orientation (see `geometry_stage.rs`).
    front: bool,
}

/// Most occluders one triangle may join at once (3 edges, a few non-manifold duplicates).
const MAX_MATCHES: usize = 8;

impl BinState {
    /// An empty bin whose occluders are indexed over `area` (the bin's rectangle grown by the
    /// margin; any rectangle works, a tight one prunes best) once it has `from` of them.
    pub(crate) fn indexed(area: &Rect, from: usize) -> Self {
        Self {
            index: OccluderIndex::over(area, from),
            ..Self::default()
        }
    }

    /// Builds the index when the bin has just got enough occluders for it.
    fn start_index(&mut self, pool: &Pool) {
        if !self.index.wants_start(self.occluders.len()) {
            return;
        }
        self.index.start();
        for (i, o) in self.occluders.iter_mut().enumerate() {
            match self.index.insert(i, &o.rect, o.front, pool) {
                Some(slot) if self.index.add_edges(slot, &o.edges, pool) => o.slot = slot,
                // Out of memory: the index turned itself off.
                _ => return,
            }
        }
    }

    /// Takes the occluder at `i` out of the vector (`swap_remove`), keeping the index's
    /// positions right; it stays listed in the index (see `unlist`).
    fn detach(&mut self, i: usize) -> Occluder {
        let o = self.occluders.swap_remove(i);
        if self.index.active() {
            if let Some(m) = self.occluders.get(i) {
                self.index.moved(m.slot, i);
            }
        }
        o
    }

    /// Removes a detached occluder, and its edges, from the index.
    fn unlist(&mut self, o: &Occluder) {
        if self.index.active() {
            self.index.remove_edges(o.slot, &o.edges);
            self.index.remove(o.slot);
        }
    }

    /// Writes to `out` the positions of the occluders of facing `front` that share an edge (in
    /// either direction) with triangle `edges` (corners `corners`, bounds `rect`), each once,
    /// ascending, and returns how many; `None` when there are more than `out` holds. Through
    /// the index's edge map when it is on, else by a scan.
    fn sharing_an_edge(
        &self,
        edges: &[Edge; 3],
        corners: &[DVec2; 3],
        rect: &Rect,
        front: bool,
        out: &mut [usize; MAX_MATCHES],
    ) -> Option<usize> {
        let mut n = 0;
        if self.index.active() {
            let mut overflow = false;
            for e in edges {
                self.index.slots_with_edge(e, |slot| {
                    let entry = self.index.slot(slot);
                    let i = entry.pos as usize;
                    if entry.front != front || out[..n].contains(&i) {
                        return;
                    }
                    if n == MAX_MATCHES {
                        overflow = true;
                        return;
                    }
                    out[n] = i;
                    n += 1;
                });
            }
            if overflow {
                return None;
            }
        } else {
            for (i, o) in self.occluders.iter().enumerate() {
                if o.front != front || !o.rect.touches(rect, 0.0) {
                    continue;
                }
                // A shared edge starts at one of t's corners: most edges fail that first.
                if o.edges
                    .iter()
                    .any(|e| corners.contains(&e.a) && edges.iter().any(|f| e.same(f)))
                {
                    if n == MAX_MATCHES {
                        return None;
                    }
                    out[n] = i;
                    n += 1;
                }
            }
        }
        // In vector order, as a linear scan finds them (the merge target's tie-break and the
        // removals in `add` depend on it).
        out[..n].sort_unstable();
        Some(n)
    }

    /// Offers triangle `t` to this bin's occluders (chapter 5, figure 5.14). When `may_start`
    /// is false it only grows or merges existing occluders (a hidden triangle under
    /// [`super::HiddenOccluders::Joining`]).
    pub(crate) fn add(
        &mut self,
        t: &ProjTri,
        limits: &Limits,
        pool: &Pool,
        may_start: bool,
    ) -> AddOutcome {
        let Some(plane) = t.whole_front.then(|| t.plane()).flatten() else {
            return AddOutcome::NotEligible;
        };
        self.start_index(pool);
        let s = t.screen;
        let z = |f: fn(f64, f64) -> f64| f(f(t.corners[0].z, t.corners[1].z), t.corners[2].z);
        let offered = Offered {
            edges: [
                Edge { a: s[0], b: s[1] },
                Edge { a: s[1], b: s[2] },
                Edge { a: s[2], b: s[0] },
            ],
            tri: OccTri {
                corners: t.corners,
                screen: s,
                plane,
                rect: Rect::of(&s),
            },
            zmin: z(f64::min),
            zmax: z(f64::max),
            front: t.front,
        };
        // A full edge buffer makes room by dropping occluders farther than this triangle.
        while self.edge_count + 3 > limits.max_edges {
            if !self.evict_farther_than(offered.zmax, pool) {
                return AddOutcome::Full;
            }
        }
        // Occluders sharing an edge with t: same facing, an identical edge.
        let mut matches = [0usize; MAX_MATCHES];
        let Some(n_matches) = self.sharing_an_edge(
            &offered.edges,
            &s,
            &offered.tri.rect,
            offered.front,
            &mut matches,
        ) else {
            return AddOutcome::Full;
        };
        if n_matches > 0 {
            self.join(&mut matches[..n_matches], &offered, pool)
        } else if may_start {
            self.start_occluder(&offered, limits, pool)
        } else {
            AddOutcome::NotEligible
        }
    }

    /// Starts an occluder of the `offered` triangle alone (it shares no edge with any).
    fn start_occluder(&mut self, offered: &Offered, limits: &Limits, pool: &Pool) -> AddOutcome {
        // A full bin makes room by dropping its farthest occluder when this triangle lies
        // entirely in front of it (see `evict_farther_than`), and covers at least the bin's
        // share per occluder: near a street's vanishing point, full bins otherwise trade
        // occluders for sub-pixel ones that hide next to nothing, one eviction per visible
        // speck (measured in `docs/BENCHMARKS.md`).
        if self.occluders.len() >= limits.max_occluders {
            let s = &offered.tri.screen;
            let area = 0.5 * (s[1] - s[0]).perp_dot(s[2] - s[0]).abs();
            if area < limits.min_evicting_area || !self.evict_farther_than(offered.zmax, pool) {
                return AddOutcome::Full;
            }
        }
        if !reserve_from(&mut self.occluders, 1, pool) {
            return AddOutcome::Full;
        }
        let mut o = Occluder {
            tris: std::mem::take(&mut self.spare_tris),
            edges: std::mem::take(&mut self.spare_edges),
            rect: offered.tri.rect,
            zmin: offered.zmin,
            zmax: offered.zmax,
            front: offered.front,
            slot: 0,
        };
        if !reserve_from(&mut o.tris, 1, pool) || !reserve_from(&mut o.edges, 3, pool) {
            release_to(&mut o.tris, pool);
            release_to(&mut o.edges, pool);
            return AddOutcome::Full;
        }
        o.tris.push(offered.tri);
        o.edges.extend_from_slice(&offered.edges);
        self.edge_count += 3;
        if self.index.active() {
            // Without index memory the bin scans linearly (`insert` turned the index off).
            o.slot = self
                .index
                .insert(self.occluders.len(), &o.rect, o.front, pool)
                .filter(|&slot| self.index.add_edges(slot, &o.edges, pool))
                .unwrap_or(0);
        }
        self.zmin_bound = self.zmin_bound.max(offered.zmin);
        self.occluders.push(o);
        self.changes += 1;
        AddOutcome::New
    }

    /// Adds the `offered` triangle to the occluders at positions `matches` (those it shares an
    /// edge with), merging them into the one with the most triangles (chapter 5).
    fn join(&mut self, matches: &mut [usize], offered: &Offered, pool: &Pool) -> AddOutcome {
        let target = matches
            .iter()
            .copied()
            .max_by_key(|&i| self.occluders[i].tris.len())
            .unwrap_or(matches[0]);
        let extra_tris: usize = matches
            .iter()
            .filter(|&&i| i != target)
            .map(|&i| self.occluders[i].tris.len())
            .sum::<usize>()
            + 1;
        let extra_edges: usize = matches
            .iter()
            .filter(|&&i| i != target)
            .map(|&i| self.occluders[i].edges.len())
            .sum::<usize>()
            + 3;
        {
            let o = &mut self.occluders[target];
            if !reserve_from(&mut o.tris, extra_tris, pool)
                || !reserve_from(&mut o.edges, extra_edges, pool)
            {
                return AddOutcome::Full;
            }
        }
        // Take all matched occluders out (highest index first so swap_remove keeps the rest
        // valid), fold the others into the target, put the target back.
        matches.sort_unstable_by(|a, b| b.cmp(a));
        let target_slot = self.occluders[target].slot;
        let mut taken: Vec<Occluder> = Vec::new();
        let mut main = None;
        for &i in matches.iter() {
            let o = self.detach(i);
            if i == target {
                main = Some(o);
            } else {
                if self.index.active() {
                    // Its edges become the target's.
                    self.index.move_edges(&o.edges, o.slot, target_slot);
                    self.index.remove(o.slot);
                }
                taken.push(o);
            }
        }
        let Some(mut main) = main else {
            return AddOutcome::Full;
        };
        let merged = !taken.is_empty();
        for mut o in taken {
            main.tris.append(&mut o.tris);
            main.edges.append(&mut o.edges);
            main.rect = main.rect.union(&o.rect);
            main.zmin = main.zmin.min(o.zmin);
            main.zmax = main.zmax.max(o.zmax);
            self.recycle(o, pool);
        }
        main.tris.push(offered.tri);
        main.rect = main.rect.union(&offered.tri.rect);
        main.zmin = main.zmin.min(offered.zmin);
        main.zmax = main.zmax.max(offered.zmax);
        self.add_edges_to(&mut main, &offered.edges, pool);
        if self.index.active() {
            self.index.moved(main.slot, self.occluders.len());
            // Without memory for the new cells the index turns off (see `grow`).
            self.index.grow(main.slot, &main.rect, pool);
        }
        self.occluders.push(main);
        self.changes += 1;
        if merged {
            AddOutcome::Merged
        } else {
            AddOutcome::Grown
        }
    }

    /// Directed edge update of a detached occluder `main` taking a triangle's `edges`: an edge
    /// walked the other way by the patch cancels (it leaves the silhouette), any other edge
    /// joins it. Cancelling only exact inverse pairs keeps the winding number of the
    /// silhouette equal to the sum of the triangles' windings.
    fn add_edges_to(&mut self, main: &mut Occluder, edges: &[Edge; 3], pool: &Pool) {
        for &e in edges {
            if let Some(k) = main.edges.iter().position(|f| f.inverse(&e)) {
                let gone = main.edges.swap_remove(k);
                self.edge_count -= 1;
                if self.index.active() {
                    self.index.remove_edges(main.slot, &[gone]);
                }
            } else {
                main.edges.push(e);
                self.edge_count += 1;
                if self.index.active() {
                    // Without memory the index turns off (see `add_edges`).
                    self.index.add_edges(main.slot, &[e], pool);
                }
            }
        }
    }

    /// Drops the occluder whose nearest point is farthest, if that is farther than `z`, and
    /// returns its memory to `pool`; false when there is none. Beyond the thesis, which keeps
    /// the first occluders of a full bin: in an unsorted stream those are often far, small
    /// ones, and the near occluders that hide most of the scene arrive later and were lost.
    /// Dropping an occluder is always sound: it only stops hiding later triangles.
    fn evict_farther_than(&mut self, z: f64, pool: &Pool) -> bool {
        if self.zmin_bound <= z {
            return false;
        }
        // The farthest near point (the last of equals, as `max_by` picks).
        let Some((i, far)) = self
            .occluders
            .iter()
            .enumerate()
            .map(|(i, o)| (i, o.zmin))
            .max_by(|a, b| a.1.total_cmp(&b.1))
        else {
            return false;
        };
        if far <= z {
            self.zmin_bound = far;
            return false;
        }
        let o = self.detach(i);
        self.unlist(&o);
        self.edge_count -= o.edges.len();
        self.recycle(o, pool);
        self.changes += 1;
        true
    }

    /// Keeps a dropped occluder's buffers as the spares (emptied), or returns them to `pool`
    /// when spares are already kept.
    fn recycle(&mut self, mut o: Occluder, pool: &Pool) {
        if self.spare_tris.capacity() == 0 {
            o.tris.clear();
            self.spare_tris = o.tris;
        } else {
            release_to(&mut o.tris, pool);
        }
        if self.spare_edges.capacity() == 0 {
            o.edges.clear();
            self.spare_edges = o.edges;
        } else {
            release_to(&mut o.edges, pool);
        }
    }

    /// Returns all occluder memory to `pool`.
    pub(crate) fn clear(&mut self, pool: &Pool) {
        for o in &mut self.occluders {
            release_to(&mut o.tris, pool);
            release_to(&mut o.edges, pool);
        }
        release_to(&mut self.occluders, pool);
        release_to(&mut self.spare_tris, pool);
        release_to(&mut self.spare_edges, pool);
        self.edge_count = 0;
        self.fused.clear(pool);
        self.index.clear(pool);
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;

    fn limits() -> Limits {
        Limits {
            max_occluders: 4,
            max_edges: 64,
            min_evicting_area: 0.0,
        }
    }

    /// Offers the triangle with screen corners `s` (at depth 5) to `b` under `limits()`.
    fn add(b: &mut BinState, s: [[f64; 2]; 3], pool: &Pool) -> AddOutcome {
        b.add(&tri(s), &limits(), pool, true)
    }

    fn tri(s: [[f64; 2]; 3]) -> ProjTri {
        let screen = s.map(|p| DVec2::new(p[0], p[1]));
        let corners = s.map(|p| DVec3::new(p[0], p[1], 5.0));
        ProjTri {
            id: 0,
            corners,
            screen,
            whole_front: true,
            front: true,
        }
    }

    #[test]
    fn first_triangle_starts_occluder() {
        let pool = Pool::new(1 << 20);
        let mut b = BinState::default();
        let out = add(&mut b, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &pool);
        assert_eq!(out, AddOutcome::New);
        assert_eq!(b.occluders[0].edges.len(), 3);
    }

    #[test]
    fn shared_edge_grows_and_drops_edge() {
        let pool = Pool::new(1 << 20);
        let mut b = BinState::default();
        add(&mut b, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &pool);
        let out = add(&mut b, [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], &pool);
        assert_eq!(out, AddOutcome::Grown);
        assert_eq!(b.occluders.len(), 1);
        assert_eq!(b.occluders[0].edges.len(), 4);
    }

    #[test]
    fn bridge_triangle_merges() {
        let pool = Pool::new(1 << 20);
        let mut b = BinState::default();
        add(&mut b, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &pool);
        add(&mut b, [[1.0, 1.0], [2.0, 1.0], [1.0, 2.0]], &pool);
        // Shares edge (1,0)-(0,1) with the first and nothing with the second...
        let out = add(&mut b, [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], &pool);
        assert_eq!(out, AddOutcome::Grown);
        // ...then one touching both.
        let out = add(&mut b, [[1.0, 1.0], [1.0, 0.0], [2.0, 1.0]], &pool);
        assert_eq!(out, AddOutcome::Merged);
        assert_eq!(b.occluders.len(), 1);
        assert_eq!(b.occluders[0].tris.len(), 4);
    }

    /// An empty bin with room for one occluder (`min_evicting_area` as given), and a far
    /// triangle (depth 50, 0.5 px²).
    fn one_slot_bin(min_evicting_area: f64) -> (Pool, Limits, BinState, ProjTri) {
        let one = Limits {
            max_occluders: 1,
            max_edges: 64,
            min_evicting_area,
        };
        let mut far = tri([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        far.corners.iter_mut().for_each(|c| c.z = 50.0);
        (Pool::new(1 << 20), one, BinState::default(), far)
    }

    #[test]
    fn full_bin_drops_a_farther_occluder_for_a_nearer_triangle() {
        let (pool, one, mut b, far) = one_slot_bin(0.0);
        assert_eq!(b.add(&far, &one, &pool, true), AddOutcome::New);
        // A nearer, unconnected triangle replaces it...
        let near = tri([[5.0, 5.0], [6.0, 5.0], [5.0, 6.0]]);
        assert_eq!(b.add(&near, &one, &pool, true), AddOutcome::New);
        assert_eq!(b.occluders.len(), 1);
        assert_eq!(b.occluders[0].zmin, 5.0);
        // ...but a farther one does not replace the near occluder.
        assert_eq!(b.add(&far, &one, &pool, true), AddOutcome::Full);
        assert_eq!(b.occluders[0].zmin, 5.0);
    }

    #[test]
    fn full_bin_evicts_only_for_a_triangle_of_its_share() {
        let (pool, one, mut b, far) = one_slot_bin(2.0);
        // Below the share, but the bin has room: it starts an occluder.
        assert_eq!(b.add(&far, &one, &pool, true), AddOutcome::New);
        // A nearer speck (0.5 px²) does not evict it...
        let speck = tri([[5.0, 5.0], [6.0, 5.0], [5.0, 6.0]]);
        assert_eq!(b.add(&speck, &one, &pool, true), AddOutcome::Full);
        assert_eq!(b.occluders[0].zmin, 50.0);
        // ...a nearer triangle of 2 px² does.
        let big = tri([[5.0, 5.0], [7.0, 5.0], [5.0, 7.0]]);
        assert_eq!(b.add(&big, &one, &pool, true), AddOutcome::New);
        assert_eq!(b.occluders[0].zmin, 5.0);
        // A speck sharing an edge with an occluder still grows it.
        let neighbour = tri([[7.0, 5.0], [5.0, 5.0], [6.0, 4.9]]);
        assert_eq!(b.add(&neighbour, &one, &pool, true), AddOutcome::Grown);
    }

    #[test]
    fn full_pool_refuses() {
        let pool = Pool::new(0);
        let mut b = BinState::default();
        let out = add(&mut b, [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &pool);
        assert_eq!(out, AddOutcome::Full);
        assert!(b.occluders.is_empty());
    }

    /// Small triangles on a lattice (so that many share edges) in a 32 px bin, both facings,
    /// at varied depths; deterministic.
    fn lattice_tris(n: usize) -> Vec<ProjTri> {
        let mut seed = 12345u64;
        let mut next = move |m: u64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) % m
        };
        (0..n)
            .map(|_| {
                let (x, y) = (next(14) as f64 * 2.0 - 2.0, next(14) as f64 * 2.0 - 2.0);
                let step = [2.0, 2.0, 2.0, 4.0, 16.0][next(5) as usize];
                let mut t = if next(2) == 0 {
                    tri([[x, y], [x + step, y], [x, y + step]])
                } else {
                    tri([[x + step, y], [x + step, y + step], [x, y + step]])
                };
                t.front = next(4) != 0;
                let z = 1.0 + next(50) as f64;
                t.corners.iter_mut().for_each(|c| c.z = z);
                t
            })
            .collect()
    }

    /// The occluders as a comparable list (everything but the index slot).
    fn summary(b: &BinState) -> Vec<(Rect, f64, f64, bool, usize, Vec<Edge>)> {
        (b.occluders.iter())
            .map(|o| {
                (
                    o.rect,
                    o.zmin,
                    o.zmax,
                    o.front,
                    o.tris.len(),
                    o.edges.clone(),
                )
            })
            .collect()
    }

    #[test]
    fn index_gives_the_same_occluders_as_a_linear_scan() {
        let area = Rect {
            min: DVec2::splat(-0.004),
            max: DVec2::splat(32.004),
        };
        let lim = Limits {
            max_occluders: 40,
            max_edges: 300,
            min_evicting_area: 0.0,
        };
        // Index on all along, and turned off half way (what an exhausted pool does).
        for fail_at in [usize::MAX, 300] {
            let pool = Pool::new(1 << 24);
            // Built once the bin has 6 occluders.
            let (mut linear, mut indexed) = (BinState::default(), BinState::indexed(&area, 6));
            let mut outcomes = [0usize; 6];
            for (k, t) in lattice_tris(600).iter().enumerate() {
                if k == fail_at {
                    indexed.index.fail(&pool);
                }
                let out = linear.add(t, &lim, &pool, true);
                assert_eq!(indexed.add(t, &lim, &pool, true), out, "triangle {k}");
                assert_eq!(summary(&indexed), summary(&linear), "triangle {k}");
                outcomes[out as usize] += 1;
                if indexed.index.active() {
                    for (i, o) in indexed.occluders.iter().enumerate() {
                        assert_eq!(indexed.index.slot(o.slot).pos as usize, i);
                        assert!(indexed.index.lists_exactly(o.slot, &o.rect));
                    }
                }
            }
            assert_eq!(indexed.index.active(), fail_at == usize::MAX);
            // Every path was taken: new, grown, merged, full (evictions make room).
            assert!(outcomes[1..5].iter().all(|&n| n > 0), "{outcomes:?}");
            linear.clear(&pool);
            indexed.clear(&pool);
            assert!(pool.try_take(1 << 24), "all memory returned");
        }
    }

    #[test]
    fn near_crossing_triangle_is_not_eligible() {
        let pool = Pool::new(1 << 20);
        let mut b = BinState::default();
        let mut t = tri([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        t.whole_front = false;
        assert_eq!(b.add(&t, &limits(), &pool, true), AddOutcome::NotEligible);
    }
}
