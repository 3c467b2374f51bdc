//! RV streaming throughput: a procedural city generated block by block (never held in memory)
//! streamed through RV from a street-level and an aerial view, with the re-test pass (RV's
//! default) and as the thesis' single pass.
//!
//! Method: the four configurations run once per round, alternated round by round, and each
//! reports its median, fastest and slowest round. On a shared, noisy machine a burst of load
//! then hits every configuration alike instead of one whole series, and the median discards
//! it; the spread shows how noisy the run was.

use serde::Serialize;
use sightline_point::rv::{conservative_visible, RvOptions, StreamingCity};

use super::common::{report, sorted, BenchError, OnProgress, Progress};

/// What `bench rv` measures.
#[derive(Clone, Debug)]
pub struct RvBenchOptions {
    /// Triangles of the streamed city (about; `procedural:city?size=N`).
    pub triangles: usize,
    /// Visibility workers, and as many geometry threads.
    pub threads: usize,
    /// Image size (square).
    pub size: u32,
    /// Rounds; every configuration runs once per round.
    pub rounds: usize,
    /// RV's memory budget in bytes.
    pub memory_budget_bytes: usize,
}

/// One configuration of `bench rv`, over all rounds.
#[derive(Serialize, Clone, Debug)]
pub struct RvRow {
    /// `street` or `aerial`.
    pub view: &'static str,
    /// Whether RV ran its re-test pass.
    pub retest_pass: bool,
    /// Triangles streamed through RV.
    pub triangles_streamed: u64,
    /// Of those, triangles on screen.
    pub on_screen: u64,
    /// Triangles in the final visible set.
    pub visible: usize,
    /// Triangles visible after the first pass.
    pub first_pass_visible: u64,
    /// Median wall-clock seconds over the rounds.
    pub median_seconds: f64,
    /// Fastest round, seconds.
    pub min_seconds: f64,
    /// Slowest round, seconds.
    pub max_seconds: f64,
    /// Triangles streamed per median second, in millions.
    pub mtriangles_per_second: f64,
    /// RV's peak memory, MiB.
    pub peak_memory_mib: f64,
}

/// Runs the RV benchmark: street and aerial view, each with and without the re-test pass, in
/// that order, alternated over `options.rounds` rounds.
pub fn bench_rv(
    options: &RvBenchOptions,
    progress: OnProgress<'_>,
) -> Result<Vec<RvRow>, BenchError> {
    if options.rounds == 0 {
        return Err(BenchError::Zero { what: "rounds" });
    }
    if options.triangles == 0 {
        return Err(BenchError::Zero { what: "triangles" });
    }
    let views = [
        ("street", StreamingCity::street_camera(options.size)?),
        ("aerial", StreamingCity::aerial_camera(options.size)?),
    ];
    let configs: Vec<(usize, bool)> = (0..views.len())
        .flat_map(|v| [(v, true), (v, false)])
        .collect();
    let mut times = vec![Vec::with_capacity(options.rounds); configs.len()];
    let mut rows: Vec<Option<RvRow>> = (0..configs.len()).map(|_| None).collect();
    for round in 0..options.rounds {
        report(
            progress,
            Progress::Round {
                round: round + 1,
                rounds: options.rounds,
            },
        );
        for (k, &(v, retest_pass)) in configs.iter().enumerate() {
            let (view, camera) = &views[v];
            let rv_options = RvOptions {
                memory_budget_bytes: options.memory_budget_bytes,
                threads: options.threads,
                geometry_threads: options.threads,
                retest_pass,
                ..RvOptions::default()
            };
            let mut city = StreamingCity::new(1, options.triangles);
            let r = conservative_visible(&mut city, camera, &rv_options)?;
            times[k].push(r.stats.seconds);
            rows[k].get_or_insert(RvRow {
                view,
                retest_pass,
                triangles_streamed: r.stats.triangles_streamed,
                on_screen: r.stats.triangles_on_screen,
                visible: r.visible.count_ones(..),
                first_pass_visible: r.stats.first_pass_visible,
                median_seconds: 0.0,
                min_seconds: 0.0,
                max_seconds: 0.0,
                mtriangles_per_second: 0.0,
                peak_memory_mib: r.peak_memory_bytes as f64 / f64::from(1 << 20),
            });
        }
    }
    Ok(rows
        .into_iter()
        .zip(times)
        .filter_map(|(row, t)| {
            let mut row = row?;
            let t = sorted(t);
            row.median_seconds = t[t.len() / 2];
            row.min_seconds = t[0];
            row.max_seconds = t[t.len() - 1];
            row.mtriangles_per_second = row.triangles_streamed as f64 / row.median_seconds / 1e6;
            Some(row)
        })
        .collect())
}
