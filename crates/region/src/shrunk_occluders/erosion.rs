//! The union of solids shrunk sideways by a radius, as boxes: a column span survives where
//! every column within the radius (in columns, rounded up) holds it. A box over column
//! `(i, j)` grown sideways by `radius <= k * size` stays over the `(2k+1)^2` columns that all
//! hold the span. Neighbouring columns with nearly the same span become one box (their
//! intersection). Heights are shrunk per cell (`mod.rs`): whether a box may reach down
//! depends on whether the cell's viewpoints lie above its span.

use glam::DVec3;

use super::columns::{Columns, Span};

/// One box of the sideways-shrunk union: its extent across the up axis (`min`, `max`, whose
/// up coordinates are unused), and the span every column within reach holds (`open` when any
/// of them rests on an open bottom).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct OccluderBox {
    pub min: DVec3,
    pub max: DVec3,
    pub span: Span,
}

/// The boxes of `columns`' union shrunk sideways by `radius`. Spans of neighbouring columns in
/// a row merge when each end moves by at most `merge` (the merged box is their intersection).
pub(super) fn shrunk_boxes(columns: &Columns, radius: f64, merge: f64) -> Vec<OccluderBox> {
    let k = (radius / columns.size).ceil() as usize;
    let [nx, ny] = columns.dims;
    // Separable: along rows, then along columns.
    let mut along_x: Vec<Vec<Span>> = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            along_x.push(window(i, nx, k, |ii| columns.spans_of(ii, j)));
        }
    }
    let mut boxes = Vec::new();
    let mut open: Vec<(usize, Span)> = Vec::new(); // runs in the current row
    for j in 0..ny {
        for i in 0..nx {
            let spans = window(j, ny, k, |jj| &along_x[i + jj * nx][..]);
            let mut next_open = Vec::with_capacity(spans.len());
            for s in spans {
                let joins = open.iter().position(|(_, r)| {
                    (r.lo - s.lo).abs() <= merge && (r.hi - s.hi).abs() <= merge
                });
                match joins {
                    Some(at) => {
                        let (start, r) = open.swap_remove(at);
                        next_open.push((start, meet(&r, &s)));
                    }
                    None => next_open.push((i, s)),
                }
            }
            for (start, s) in open.drain(..) {
                boxes.push(columns.box_of(start, i - 1, j, s));
            }
            open = next_open;
        }
        for (start, s) in open.drain(..) {
            boxes.push(columns.box_of(start, nx - 1, j, s));
        }
    }
    boxes
}

/// The spans every position within `k` of `at` (in `0..n`) holds; nothing where the window
/// leaves the grid.
fn window<'a>(at: usize, n: usize, k: usize, column: impl Fn(usize) -> &'a [Span]) -> Vec<Span> {
    if at < k || at + k >= n {
        return Vec::new();
    }
    let mut spans = column(at - k).to_vec();
    for other in at - k + 1..=at + k {
        if spans.is_empty() {
            break;
        }
        spans = intersect(&spans, column(other));
    }
    spans
}

/// The common part of two overlapping spans; open when either is (conservative).
fn meet(a: &Span, b: &Span) -> Span {
    Span {
        lo: a.lo.max(b.lo),
        hi: a.hi.min(b.hi),
        open: a.open || b.open,
    }
}

/// The intersection of two sorted lists of disjoint spans.
fn intersect(a: &[Span], b: &[Span]) -> Vec<Span> {
    let (mut i, mut j) = (0, 0);
    let mut out = Vec::new();
    while i < a.len() && j < b.len() {
        let m = meet(&a[i], &b[j]);
        if m.hi > m.lo {
            out.push(m);
        }
        if a[i].hi < b[j].hi {
            i += 1;
        } else {
            j += 1;
        }
    }
    out
}

impl Columns {
    /// The box over columns `i0..=i1` of row `j` and `span`.
    fn box_of(&self, i0: usize, i1: usize, j: usize, span: Span) -> OccluderBox {
        let mut min = DVec3::ZERO;
        let mut max = DVec3::ZERO;
        min[self.across[0]] = self.origin[0] + i0 as f64 * self.size;
        max[self.across[0]] = self.origin[0] + (i1 + 1) as f64 * self.size;
        min[self.across[1]] = self.origin[1] + j as f64 * self.size;
        max[self.across[1]] = self.origin[1] + (j + 1) as f64 * self.size;
        OccluderBox { min, max, span }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn span(lo: f64, hi: f64) -> Span {
        Span {
            lo,
            hi,
            open: false,
        }
    }

    #[test]
    fn spans_intersect_as_intervals() {
        let a = [span(0.0, 5.0), span(6.0, 9.0)];
        let b = [span(2.0, 7.0)];
        assert_eq!(intersect(&a, &b), vec![span(2.0, 5.0), span(6.0, 7.0)]);
        assert!(intersect(&a, &[]).is_empty());
        let open = [Span {
            lo: 1.0,
            hi: 3.0,
            open: true,
        }];
        assert!(intersect(&a, &open)[0].open);
    }
}
