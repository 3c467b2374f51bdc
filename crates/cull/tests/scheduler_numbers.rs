//! The scheduler's numbers behave as configured: durations, the per-frame cap, growth after
//! consecutive overflowing frames, jitter bounds, the exemption of visible cells, and no
//! starvation when the cap is far below the number of cells.

use sightline_cull::{Scheduler, SchedulerConfig};

fn config() -> SchedulerConfig {
    SchedulerConfig {
        query_cap: 10,
        visible_duration: 30,
        visible_growth: 8,
        invisible_duration: 2,
        invisible_growth: 1,
        jitter_per_overflow: 0,
        depth_prepass_cap: 75,
        seed: 9,
    }
}

/// One frame: records `pending` (issued last frame) with `visible(cell)`, then offers `cells`
/// in order; returns the cells queried.
fn frame(
    s: &mut Scheduler,
    cells: &[u32],
    pending: &[u32],
    visible: impl Fn(u32) -> bool,
) -> Vec<u32> {
    s.begin_frame();
    let issued = s.frame() - 1;
    for &c in pending {
        s.record(c, issued, visible(c));
    }
    let q: Vec<u32> = cells
        .iter()
        .copied()
        .filter(|&c| s.should_query(c))
        .collect();
    s.end_frame();
    q
}

#[test]
fn invisible_cells_are_requeried_after_their_duration_under_the_cap() {
    let mut s = Scheduler::new(5, config());
    let cells = [0, 1, 2, 3, 4];
    let mut pending = Vec::new();
    let mut frames_with_query = Vec::new();
    for _ in 0..9 {
        pending = frame(&mut s, &cells, &pending, |_| false);
        frames_with_query.push(!pending.is_empty());
    }
    // Queried in frame 1; result (duration 2) recorded in frame 2, so due again in frame 3.
    assert_eq!(
        frames_with_query,
        vec![true, false, true, false, true, false, true, false, true]
    );
}

#[test]
fn visible_cells_are_requeried_after_thirty_frames() {
    let mut s = Scheduler::new(1, config());
    let mut pending = Vec::new();
    let mut query_frames = Vec::new();
    for _ in 0..70 {
        pending = frame(&mut s, &[0], &pending, |_| true);
        if !pending.is_empty() {
            query_frames.push(s.frame());
        }
    }
    assert_eq!(query_frames, vec![1, 31, 61]);
}

#[test]
fn cap_limits_invisible_queries_but_not_visible_ones() {
    let mut cfg = config();
    cfg.invisible_duration = 1;
    let mut s = Scheduler::new(100, cfg);
    let cells: Vec<u32> = (0..100).collect();
    // Frame 1: everything is new: exactly the cap is queried.
    let q1 = frame(&mut s, &cells, &[], |_| false);
    assert_eq!(q1.len(), 10);
    // Make the first 20 cells visible with an expired result: they are re-queried over the cap.
    s.begin_frame();
    for c in 0..20 {
        s.record(c, 0, true);
    }
    // Frame 1 overflowed once: due at 0 + 30 + 8 * 1.
    assert_eq!(s.due_frame(0), Some(38));
    while s.frame() < 38 {
        s.end_frame();
        s.begin_frame();
    }
    let q: Vec<u32> = cells
        .iter()
        .copied()
        .filter(|&c| s.should_query(c))
        .collect();
    assert!(
        (0..20).all(|c| q.contains(&c)),
        "every visible cell is re-queried"
    );
    assert_eq!(q.len(), 20, "no invisible cell once the cap is reached");
    assert_eq!(s.queries_this_frame(), 20);
}

#[test]
fn durations_grow_with_consecutive_overflowing_frames() {
    let mut s = Scheduler::new(1000, config());
    let cells: Vec<u32> = (0..1000).collect();
    for k in 1..=4u64 {
        frame(&mut s, &cells, &[], |_| false);
        assert_eq!(s.overflowed_frames(), k);
    }
    s.begin_frame();
    s.record(0, 4, false);
    s.record(1, 4, true);
    // invisible: 2 + 1 * 4, visible: 30 + 8 * 4 (jitter 0).
    assert_eq!(s.due_frame(0), Some(4 + 2 + 4));
    assert_eq!(s.due_frame(1), Some(4 + 30 + 32));
    // A frame under the cap resets the count.
    s.end_frame();
    frame(&mut s, &[], &[], |_| false);
    assert_eq!(s.overflowed_frames(), 0);
}

#[test]
fn jitter_stays_within_its_bound_and_varies() {
    let mut cfg = config();
    cfg.jitter_per_overflow = 2;
    let mut s = Scheduler::new(1000, cfg);
    let cells: Vec<u32> = (0..1000).collect();
    for _ in 0..3 {
        frame(&mut s, &cells, &[], |_| false);
    }
    s.begin_frame();
    let mut seen = std::collections::BTreeSet::new();
    for c in 0..200 {
        s.record(c, 3, false);
        let due = s.due_frame(c).unwrap();
        let base = 3 + 2 + 3;
        assert!((base..=base + 6).contains(&due), "{due}");
        seen.insert(due);
    }
    assert!(seen.len() > 3, "jitter spreads the due frames: {seen:?}");
}

#[test]
fn no_cell_starves_when_cells_far_exceed_the_cap() {
    let mut cfg = config();
    cfg.invisible_duration = 1;
    cfg.jitter_per_overflow = 2;
    let mut s = Scheduler::new(200, cfg);
    let cells: Vec<u32> = (0..200).collect();
    let mut queried = vec![0u32; 200];
    let mut pending = Vec::new();
    for _ in 0..60 {
        pending = frame(&mut s, &cells, &pending, |_| false);
        for &c in &pending {
            queried[c as usize] += 1;
        }
    }
    // 200 cells, cap 10: with growth and jitter the queries spread over all cells, whereas
    // fixed 1-frame durations would spend every query on the first 10 cells in order.
    assert!(queried.iter().all(|&n| n > 0), "{queried:?}");
}
