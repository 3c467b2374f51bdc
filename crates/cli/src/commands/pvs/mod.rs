//! `sightline pvs`: bake, show, diff and compare potentially visible sets.
//!
//! The face: `run` dispatches to one file per subcommand (`bake.rs` with merge, `bound.rs`,
//! `show.rs`, `diff.rs`, `compare_q3.rs`, `merge_cells.rs`); the arguments are in `args.rs`, the bake's
//! cell sources in `cells.rs`, its GPU caster in `gpu.rs`.

mod args;
mod bake;
mod bound;
mod cells;
mod compare_q3;
mod diff;
mod gpu;
mod merge_cells;
mod show;

use anyhow::Result;

pub(crate) use args::Args;
use args::What;
use bake::{run_bake, run_merge};
use bound::run_bound;
use compare_q3::run_compare_q3;
use diff::run_diff;
use merge_cells::run_merge_cells;
use show::run_show;

use crate::errors::ExitStatus;

pub(crate) fn run(args: Args) -> Result<()> {
    match args.what {
        What::Bake(a) => run_bake(*a),
        What::Show(a) => run_show(a),
        What::Merge(a) => run_merge(a),
        What::MergeCells(a) => run_merge_cells(a),
        What::Bound(a) => run_bound(a),
        // As `diff`: 0 same sets, 1 different, 2 trouble (unreadable or unrelated files).
        What::Diff(a) => run_diff(a).map_err(|e| match e.downcast_ref::<ExitStatus>() {
            Some(_) => e,
            None => e.context(ExitStatus(2)),
        }),
        What::CompareQ3(a) => run_compare_q3(a),
    }
}
