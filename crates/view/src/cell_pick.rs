//! Which view cell the `pvs` method uses: the cell picked with `[` / `]` (or `--cell`), else
//! the cell containing the eye. A picked cell lets a designer look at one cell's set from
//! anywhere, in particular from outside the cell, where the eye's cell would be another one
//! or none.

/// Where the cell in use came from (the HUD names it: "cell 12 (picked)", "cell 12 (eye)").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellSource {
    /// Picked by the user; used from any viewpoint.
    Picked,
    /// The cell containing the eye (of the frozen camera while frozen).
    Eye,
}

impl CellSource {
    /// `picked` or `eye`.
    pub fn name(self) -> &'static str {
        match self {
            CellSource::Picked => "picked",
            CellSource::Eye => "eye",
        }
    }
}

/// The cell in use: the picked one if any, else the eye's; `None` when neither exists.
pub fn cell_in_use(picked: Option<usize>, eye: Option<usize>) -> Option<(usize, CellSource)> {
    match (picked, eye) {
        (Some(p), _) => Some((p, CellSource::Picked)),
        (None, Some(e)) => Some((e, CellSource::Eye)),
        (None, None) => None,
    }
}

/// The cell picked by one step (`next`: `]`, else `[`) among `cells` cells, wrapping around at
/// both ends. The first step starts from the eye's cell when nothing is picked yet (so `]`
/// shows the eye's neighbour), from before cell 0 when the eye is in no cell (`]` picks 0,
/// `[` the last). `None` when there are no cells.
pub fn step_cell(
    picked: Option<usize>,
    eye: Option<usize>,
    cells: usize,
    next: bool,
) -> Option<usize> {
    if cells == 0 {
        return None;
    }
    let from = picked.or(eye).filter(|&c| c < cells);
    Some(match (from, next) {
        (Some(c), true) => (c + 1) % cells,
        (Some(c), false) => (c + cells - 1) % cells,
        (None, true) => 0,
        (None, false) => cells - 1,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_wrap_around_both_ends() {
        assert_eq!(step_cell(Some(3), None, 4, true), Some(0));
        assert_eq!(step_cell(Some(0), None, 4, false), Some(3));
        assert_eq!(step_cell(Some(1), None, 4, true), Some(2));
        assert_eq!(step_cell(Some(1), None, 4, false), Some(0));
        // One cell: every step stays on it.
        assert_eq!(step_cell(Some(0), None, 1, true), Some(0));
        assert_eq!(step_cell(Some(0), None, 1, false), Some(0));
    }

    #[test]
    fn first_step_starts_from_the_eye_or_the_ends() {
        assert_eq!(step_cell(None, Some(2), 5, true), Some(3));
        assert_eq!(step_cell(None, Some(2), 5, false), Some(1));
        assert_eq!(step_cell(None, None, 5, true), Some(0));
        assert_eq!(step_cell(None, None, 5, false), Some(4));
        // A picked cell wins over the eye's.
        assert_eq!(step_cell(Some(0), Some(3), 5, true), Some(1));
    }

    #[test]
    fn no_cells_no_pick_and_stale_picks_restart() {
        assert_eq!(step_cell(None, None, 0, true), None);
        assert_eq!(step_cell(Some(2), Some(1), 0, false), None);
        // A pick beyond the cells (another file) restarts from the ends.
        assert_eq!(step_cell(Some(9), None, 3, true), Some(0));
    }

    #[test]
    fn picked_cell_wins_over_the_eyes() {
        assert_eq!(cell_in_use(Some(4), Some(1)), Some((4, CellSource::Picked)));
        assert_eq!(cell_in_use(Some(4), None), Some((4, CellSource::Picked)));
        assert_eq!(cell_in_use(None, Some(1)), Some((1, CellSource::Eye)));
        assert_eq!(cell_in_use(None, None), None);
        assert_eq!(CellSource::Picked.name(), "picked");
    }
}
