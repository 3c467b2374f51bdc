//! Which cell holds a position: a bounding-volume hierarchy over the cells' world-space boxes,
//! built when a file is opened (median splits on the longest axis, up to four cells a leaf),
//! then an exact containment test against each candidate's oriented box.
//!
//! Policy (also in `docs/pvs-format.md`): a position belongs to a cell when it lies inside the
//! cell's box or on its boundary, within a tolerance of 1e-5 times the cell's size (so a
//! position on a face two cells share belongs to both); of all such cells the lowest index
//! wins, so the answer never depends on the tree's shape. A position in no cell (or not
//! finite) has no cell: a renderer should then draw everything.
//!
//! Memory: 32 bytes per node, about one node per two cells, and 4 bytes per cell.

use crate::types::Cell;

impl Cell {
    /// The tolerance of [`Cell::contains`]: 1e-5 of the cell's size (and of its distance
    /// from the origin, which bounds the rounding of its coordinates).
    fn tolerance(&self) -> f32 {
        let size = self.half_extents.iter().fold(0f32, |m, &h| m.max(h));
        let far = self.center.iter().fold(0f32, |m, &c| m.max(c.abs()));
        1e-5 * (size + far).max(1e-3)
    }

    /// True when `p` lies in the cell or on its boundary, within 1e-5 of the cell's size (the
    /// test behind [`crate::Pvs::cell_at`]).
    pub fn contains(&self, p: [f32; 3]) -> bool {
        let d = [
            p[0] - self.center[0],
            p[1] - self.center[1],
            p[2] - self.center[2],
        ];
        let t = self.tolerance();
        (0..3).all(|k| {
            let a = self.axes[k];
            (d[0] * a[0] + d[1] * a[1] + d[2] * a[2]).abs() <= self.half_extents[k] + t
        })
    }

    /// The world-space bounds, grown by the containment tolerance.
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let t = self.tolerance();
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for j in 0..3 {
            let reach: f32 = (0..3)
                .map(|k| self.axes[k][j].abs() * self.half_extents[k])
                .sum::<f32>()
                + 2.0 * t;
            lo[j] = self.center[j] - reach;
            hi[j] = self.center[j] + reach;
        }
        (lo, hi)
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: [f32; 3],
    hi: [f32; 3],
    /// Leaf: first entry in `order`; inner: index of the left child (the right one follows it).
    first: u32,
    /// Leaf: number of cells (1..=4); inner: 0.
    count: u32,
}

/// The hierarchy over a file's cells.
#[derive(Clone, Debug, Default)]
pub(crate) struct CellIndex {
    nodes: Vec<Node>,
    /// Cell indices in leaf order.
    order: Vec<u32>,
}

const LEAF_CELLS: usize = 4;

impl CellIndex {
    pub fn build(cells: &[Cell]) -> Self {
        if cells.is_empty() {
            return Self::default();
        }
        let bounds: Vec<_> = cells.iter().map(Cell::bounds).collect();
        let mut order: Vec<u32> = (0..cells.len() as u32).collect();
        let mut nodes = Vec::with_capacity(cells.len() / 2 + 1);
        nodes.push(Node {
            lo: [0.0; 3],
            hi: [0.0; 3],
            first: 0,
            count: 0,
        });
        // (node, range of `order`) still to build.
        let mut todo = vec![(0usize, 0usize, cells.len())];
        while let Some((node, start, end)) = todo.pop() {
            let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
            for &c in &order[start..end] {
                let (l, h) = bounds[c as usize];
                for j in 0..3 {
                    lo[j] = lo[j].min(l[j]);
                    hi[j] = hi[j].max(h[j]);
                }
            }
            if end - start <= LEAF_CELLS {
                nodes[node] = Node {
                    lo,
                    hi,
                    first: start as u32,
                    count: (end - start) as u32,
                };
                continue;
            }
            let axis = (0..3)
                .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
                .unwrap_or(0);
            let mid = start + (end - start) / 2;
            let centre = |c: &u32| {
                let (l, h) = bounds[*c as usize];
                l[axis] + h[axis]
            };
            order[start..end]
                .select_nth_unstable_by(mid - start, |a, b| centre(a).total_cmp(&centre(b)));
            let left = nodes.len();
            nodes.push(Node {
                lo: [0.0; 3],
                hi: [0.0; 3],
                first: 0,
                count: 0,
            });
            nodes.push(Node {
                lo: [0.0; 3],
                hi: [0.0; 3],
                first: 0,
                count: 0,
            });
            nodes[node] = Node {
                lo,
                hi,
                first: left as u32,
                count: 0,
            };
            todo.push((left, start, mid));
            todo.push((left + 1, mid, end));
        }
        Self { nodes, order }
    }

    /// The lowest-index cell whose box holds `p` (see the module's policy).
    pub fn cell_at(&self, p: [f32; 3], cell: impl Fn(u32) -> Cell) -> Option<u32> {
        if self.nodes.is_empty() || p.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let inside = |n: &Node| (0..3).all(|j| n.lo[j] <= p[j] && p[j] <= n.hi[j]);
        let mut best: Option<u32> = None;
        let mut stack = [0u32; 64];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let node = &self.nodes[stack[depth] as usize];
            if !inside(node) {
                continue;
            }
            if node.count > 0 {
                let leaf = &self.order[node.first as usize..(node.first + node.count) as usize];
                for &c in leaf {
                    if best.is_none_or(|b| c < b) && cell(c).contains(p) {
                        best = Some(c);
                    }
                }
            } else if depth + 2 <= stack.len() {
                stack[depth] = node.first;
                stack[depth + 1] = node.first + 1;
                depth += 2;
            }
        }
        best
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>() + self.order.capacity() * 4
    }
}
