//! A per-bin index of occluders: a uniform grid over the bin's rectangle whose cells list the
//! occluders whose bounding rectangle overlaps them, so that the occlusion test visits only
//! occluders whose rectangle can pass its rectangle filter; and a map from silhouette edges to
//! occluders (`edge_map.rs`), so that a new occluder triangle finds the occluders it shares an
//! edge with without a search.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, section 6.3 (a bin's occluders are walked by the threads of a GPU work group). Ours,
//! beyond it: one CPU thread walks a bin, and near the vanishing point of a street a bin holds
//! hundreds of small occluders, so it visits only those listed in one cell (a uniform grid, as
//! in any 2D broad phase).
//!
//! Exactness: results are bit for bit those of a linear scan.
//! - `is_occluded(P)` needs `O.rect` to contain `P.rect` (grown by a non-negative margin), so
//!   it contains the point `P.rect.min`: only occluders listed in that point's cell qualify.
//!   This holds for any rectangles, inside the grid or not, because a coordinate's cell is a
//!   monotone function of it (clamped to the grid; IEEE subtraction and multiplication round
//!   monotonically), the same function for registration and look-up.
//! - `add(t)` needs an occluder with an edge equal to one of `t`'s: the edge map lists every
//!   silhouette edge of every indexed occluder.
//!
//! Occluders keep a stable slot id while their position in the bin's vector changes
//! (`swap_remove`); cells list slots. The free slots form a list threaded through `pos`, so
//! removing an occluder allocates nothing.
//!
//! Memory: cell lists and the slot table are taken from the occluder pool. When the pool cannot
//! give it, the index releases everything and the bin falls back to the linear scan (same
//! results, only slower) until it is cleared.

use glam::DVec2;

use super::edge_map::EdgeMap;
use super::memory::{release_to, reserve_from, Pool};
use super::occluder::Edge;
use super::overlap::Rect;

/// Occluders a bin must have before it indexes them: fewer are scanned as fast without the
/// index's upkeep.
pub(crate) const INDEX_FROM: usize = 32;

/// Cells per side of a bin's grid (4 px cells on the default 32 px bins).
pub(crate) const CELLS: usize = 8;

/// Marks a free slot in `pos` (the rest of the value is the next free slot).
const FREE: u32 = 1 << 31;
/// End of the free list.
const NONE: u32 = u32::MAX >> 1;

/// Inclusive cell range `[x0, y0, x1, y1]`.
pub(crate) type Range = [usize; 4];

/// What the index keeps of one occluder: where it is, and what the scans' first filters read
/// (a dense copy, so a rejected candidate costs no visit to the occluder itself).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Slot {
    /// The occluder's bounds (always equal to its `rect`).
    pub(crate) rect: Rect,
    /// Its position in the bin's vector, or `FREE | next free slot`.
    pub(crate) pos: u32,
    /// Its facing.
    pub(crate) front: bool,
}

/// The grid of one bin.
#[derive(Debug)]
pub(crate) struct OccluderIndex {
    /// The grid's rectangle (the bin's, grown by the margin).
    origin: DVec2,
    /// Cells per unit of screen, per axis.
    scale: DVec2,
    /// Whether the index may be built (false: no index, or memory ran out).
    usable: bool,
    /// Whether the index is built and in use.
    active: bool,
    /// Occluders a bin must have before its index is built.
    from: usize,
    /// Row-major cells, each listing slots; empty until the first occluder registers.
    cells: Vec<Vec<u32>>,
    /// Per slot id.
    slots: Vec<Slot>,
    /// First free slot, or `NONE`.
    free: u32,
    /// Each indexed occluder's silhouette edges, to its slot (`edge_map.rs`).
    edges: EdgeMap,
}

impl Default for OccluderIndex {
    /// No index: the bin scans its occluders linearly.
    fn default() -> Self {
        Self {
            origin: DVec2::ZERO,
            scale: DVec2::ZERO,
            usable: false,
            active: false,
            from: 0,
            cells: Vec::new(),
            slots: Vec::new(),
            free: NONE,
            edges: EdgeMap::default(),
        }
    }
}

impl OccluderIndex {
    /// An index over `area`, to be built once the bin has `from` occluders (below that a
    /// linear scan is as fast and the index's upkeep is saved); no index when `area` is
    /// degenerate.
    pub(crate) fn over(area: &Rect, from: usize) -> Self {
        let size = area.max - area.min;
        let scale = DVec2::splat(CELLS as f64) / size;
        let ok = scale.is_finite() && scale.min_element() > 0.0;
        Self {
            origin: area.min,
            scale,
            usable: ok,
            from,
            ..Self::default()
        }
    }

    /// Whether a bin with `n` occluders should build its index now.
    #[inline]
    pub(crate) fn wants_start(&self, n: usize) -> bool {
        self.usable && !self.active && n >= self.from
    }

    /// Turns an empty index on: the caller then inserts the bin's occluders.
    pub(crate) fn start(&mut self) {
        self.active = self.usable;
    }

    /// Whether look-ups may use the index.
    #[inline]
    pub(crate) fn active(&self) -> bool {
        self.active
    }

    #[inline]
    fn coord(v: f64, lo: f64, scale: f64) -> usize {
        // `as` truncates towards zero (floor for the non-negative values that matter) and
        // saturates, negatives and NaN to 0: monotone, and always a valid cell.
        (((v - lo) * scale) as usize).min(CELLS - 1)
    }

    /// The cell of point `p` as `(x, y)`.
    #[inline]
    pub(crate) fn cell_of(&self, p: DVec2) -> (usize, usize) {
        (
            Self::coord(p.x, self.origin.x, self.scale.x),
            Self::coord(p.y, self.origin.y, self.scale.y),
        )
    }

    /// The cells `r` overlaps.
    #[inline]
    pub(crate) fn range(&self, r: &Rect) -> Range {
        let (x0, y0) = self.cell_of(r.min);
        let (x1, y1) = self.cell_of(r.max);
        [x0, y0, x1, y1]
    }

    /// The slots listed in cell `(x, y)`.
    #[inline]
    pub(crate) fn cell(&self, x: usize, y: usize) -> &[u32] {
        self.cells
            .get(y * CELLS + x)
            .map_or(&[][..], |c| c.as_slice())
    }

    /// Moves the `k`-th slot of cell `(x, y)` to the front of its list (lists are unordered
    /// sets; the order only decides which candidates a scan meets first).
    #[inline]
    pub(crate) fn promote(&mut self, x: usize, y: usize, k: usize) {
        if let Some(cell) = self.cells.get_mut(y * CELLS + x) {
            if k < cell.len() {
                cell.swap(0, k);
            }
        }
    }

    /// What the index keeps of the occluder in `slot`.
    #[inline]
    pub(crate) fn slot(&self, slot: u32) -> &Slot {
        &self.slots[slot as usize]
    }

    /// Records that the occluder in `slot` now sits at position `at`.
    #[inline]
    pub(crate) fn moved(&mut self, slot: u32, at: usize) {
        self.slots[slot as usize].pos = at as u32;
    }

    /// Registers a new occluder at position `at` with bounds `r` and facing `front`; its slot,
    /// or `None` when the pool is exhausted (the index has then released everything and is
    /// off).
    pub(crate) fn insert(&mut self, at: usize, r: &Rect, front: bool, pool: &Pool) -> Option<u32> {
        if self.cells.is_empty() {
            if !reserve_from(&mut self.cells, CELLS * CELLS, pool) {
                self.fail(pool);
                return None;
            }
            self.cells.resize_with(CELLS * CELLS, Vec::new);
        }
        let entry = Slot {
            rect: *r,
            pos: at as u32,
            front,
        };
        let slot = if self.free != NONE {
            let s = self.free;
            self.free = self.slots[s as usize].pos & !FREE;
            self.slots[s as usize] = entry;
            s
        } else {
            if self.slots.len() >= NONE as usize || !reserve_from(&mut self.slots, 1, pool) {
                self.fail(pool);
                return None;
            }
            self.slots.push(entry);
            (self.slots.len() - 1) as u32
        };
        let range = self.range(r);
        if !self.add_cells(slot, range, None, pool) {
            return None;
        }
        Some(slot)
    }

    /// The occluder in `slot` grew to bounds `new` (a superset of the old): lists it in the
    /// cells it now overlaps too. False when the pool is exhausted (the index is then off).
    pub(crate) fn grow(&mut self, slot: u32, new: &Rect, pool: &Pool) -> bool {
        let (before, after) = (self.range(&self.slots[slot as usize].rect), self.range(new));
        let entry = &mut self.slots[slot as usize];
        entry.rect = *new;
        before == after || self.add_cells(slot, after, Some(before), pool)
    }

    /// Lists `slot` in the cells of `range` outside `skip`.
    fn add_cells(&mut self, slot: u32, range: Range, skip: Option<Range>, pool: &Pool) -> bool {
        let [x0, y0, x1, y1] = range;
        for y in y0..=y1 {
            for x in x0..=x1 {
                if skip.is_some_and(|[a, b, c, d]| (a..=c).contains(&x) && (b..=d).contains(&y)) {
                    continue;
                }
                let cell = &mut self.cells[y * CELLS + x];
                if !reserve_from(cell, 1, pool) {
                    self.fail(pool);
                    return false;
                }
                cell.push(slot);
            }
        }
        true
    }

    /// Unlists the occluder in `slot` and frees the slot.
    pub(crate) fn remove(&mut self, slot: u32) {
        let [x0, y0, x1, y1] = self.range(&self.slots[slot as usize].rect);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let cell = &mut self.cells[y * CELLS + x];
                if let Some(k) = cell.iter().position(|&s| s == slot) {
                    cell.swap_remove(k);
                } else {
                    debug_assert!(false, "slot {slot} missing from cell ({x}, {y})");
                }
            }
        }
        self.slots[slot as usize].pos = FREE | self.free;
        self.free = slot;
    }

    /// Lists silhouette edges `edges` of the occluder in `slot`; false when the pool is
    /// exhausted (the index is then off).
    pub(crate) fn add_edges(&mut self, slot: u32, edges: &[Edge], pool: &Pool) -> bool {
        for e in edges {
            if !self.edges.insert(e, slot, pool) {
                self.fail(pool);
                return false;
            }
        }
        true
    }

    /// Unlists silhouette edges `edges` of the occluder in `slot` (one entry each).
    pub(crate) fn remove_edges(&mut self, slot: u32, edges: &[Edge]) {
        for e in edges {
            let found = self.edges.remove(e, slot);
            debug_assert!(found, "edge of slot {slot} missing from the edge map");
        }
    }

    /// Hands silhouette edges `edges` from the occluder in `from` to the one in `to` (a merge).
    pub(crate) fn move_edges(&mut self, edges: &[Edge], from: u32, to: u32) {
        for e in edges {
            let found = self.edges.repoint(e, from, to);
            debug_assert!(found, "edge of slot {from} missing from the edge map");
        }
    }

    /// Calls `f` with the slot of each occluder listing edge `e` (in either direction), once
    /// per listing.
    #[inline]
    pub(crate) fn slots_with_edge(&self, e: &Edge, f: impl FnMut(u32)) {
        self.edges.for_each_slot(e, f);
    }

    /// Returns all memory to `pool` and turns the index off for good (the bin scans
    /// linearly until cleared).
    pub(crate) fn fail(&mut self, pool: &Pool) {
        self.release(pool);
        self.active = false;
        self.usable = false;
    }

    /// Returns all memory to `pool` (for an emptied bin); the index is built again once the
    /// bin has enough occluders.
    pub(crate) fn clear(&mut self, pool: &Pool) {
        self.release(pool);
        self.active = false;
        self.usable = self.scale.is_finite() && self.scale.min_element() > 0.0;
    }

    fn release(&mut self, pool: &Pool) {
        for c in &mut self.cells {
            release_to(c, pool);
        }
        release_to(&mut self.cells, pool);
        release_to(&mut self.slots, pool);
        self.edges.release(pool);
        self.free = NONE;
    }

    /// Whether `slot` is listed exactly in the cells of `r` (for tests).
    #[cfg(test)]
    pub(crate) fn lists_exactly(&self, slot: u32, r: &Rect) -> bool {
        let [x0, y0, x1, y1] = self.range(r);
        (0..CELLS).all(|y| {
            (0..CELLS).all(|x| {
                let n = self.cell(x, y).iter().filter(|&&s| s == slot).count();
                let inside = (x0..=x1).contains(&x) && (y0..=y1).contains(&y);
                n == usize::from(inside)
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Rect {
        Rect {
            min: DVec2::new(x0, y0),
            max: DVec2::new(x1, y1),
        }
    }

    #[test]
    fn cells_are_monotone_and_clamped() {
        let idx = OccluderIndex::over(&rect(0.0, 0.0, 32.0, 32.0), 0);
        assert_eq!(idx.cell_of(DVec2::new(-100.0, 1e300)), (0, CELLS - 1));
        assert_eq!(idx.cell_of(DVec2::new(f64::NAN, 5.0)), (0, 1));
        let mut last = 0;
        for i in -10..=400 {
            let (x, _) = idx.cell_of(DVec2::new(f64::from(i) * 0.1, 0.0));
            assert!(x >= last && x < CELLS);
            last = x;
        }
        assert_eq!(last, CELLS - 1);
    }

    #[test]
    fn insert_grow_remove_keep_cells_exact() {
        let pool = Pool::new(1 << 20);
        let mut idx = OccluderIndex::over(&rect(0.0, 0.0, 32.0, 32.0), 0);
        assert!(idx.wants_start(0));
        idx.start();
        let a = rect(1.0, 1.0, 2.0, 2.0);
        let s = idx.insert(0, &a, true, &pool).expect("memory");
        assert!(idx.lists_exactly(s, &a));
        let b = rect(1.0, 1.0, 20.0, 9.0);
        assert!(idx.grow(s, &b, &pool));
        assert!(idx.lists_exactly(s, &b));
        assert_eq!(idx.slot(s).rect, b);
        let t = idx.insert(1, &a, false, &pool).expect("memory");
        assert_ne!(s, t);
        idx.remove(s);
        assert!((0..CELLS).all(|y| (0..CELLS).all(|x| !idx.cell(x, y).contains(&s))));
        assert!(idx.lists_exactly(t, &a));
        // The freed slot is reused.
        assert_eq!(idx.insert(0, &b, true, &pool), Some(s));
        assert_eq!(idx.slot(s).pos, 0);
        idx.moved(t, 3);
        assert_eq!(idx.slot(t).pos, 3);
        assert!(!idx.slot(t).front);
        idx.clear(&pool);
        assert!(!idx.active() && idx.wants_start(0));
        assert!(idx.cell(0, 0).is_empty());
        assert!(pool.try_take(1 << 20), "clear returned all memory");
    }

    #[test]
    fn exhausted_pool_turns_index_off_and_returns_memory() {
        let pool = Pool::new(64);
        let mut idx = OccluderIndex::over(&rect(0.0, 0.0, 32.0, 32.0), 0);
        idx.start();
        assert_eq!(idx.insert(0, &rect(1.0, 1.0, 2.0, 2.0), true, &pool), None);
        assert!(!idx.active() && !idx.wants_start(1));
        // Everything went back: the whole pool can be taken again.
        assert!(pool.try_take(64));
    }

    #[test]
    fn degenerate_area_has_no_index() {
        assert!(!OccluderIndex::over(&rect(0.0, 0.0, 0.0, 5.0), 0).wants_start(9));
        assert!(!OccluderIndex::default().wants_start(9));
        let idx = OccluderIndex::over(&rect(0.0, 0.0, 1.0, 5.0), 4);
        assert!(!idx.wants_start(3) && idx.wants_start(4));
    }
}
