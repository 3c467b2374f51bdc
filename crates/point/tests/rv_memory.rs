//! RV memory: a counting global allocator shows the heap stays under the budget while a large
//! procedural city streams through (the city is generated on the fly, never materialised).
//!
//! The target: 10 million triangles under 256 MiB. The same stream also runs under
//! 32 MiB, where the occluder pool is small enough to fill. About a second per run on 2 cores
//! (`RV_MEMORY_TRIANGLES` and `RV_MEMORY_BUDGET` pick one other run).
#![allow(clippy::unwrap_used)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::Vec3;
use sightline_core::Camera;
use sightline_point::rv::{conservative_visible, RvError, RvOptions, StreamingCity};

struct Counting;

static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator unchanged; only counts bytes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: same contract as the caller's.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = CURRENT.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) };
        CURRENT.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn street_camera(city: &StreamingCity) -> Camera {
    let h = city.half_extent();
    Camera::look_at(
        Vec3::new(-0.9 * h, -0.8 * h, 40.0),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::Z,
        60.0,
        512,
        512,
        0.1,
    )
    .unwrap()
}

/// Streams a city of about `triangles` under `budget` bytes and checks the heap's peak (the
/// only heavy test of this binary: the counting allocator is global).
fn stream_under_budget(triangles: usize, budget: usize) {
    let mut city = StreamingCity::new(1, triangles);
    let cam = street_camera(&city);
    let options = RvOptions {
        memory_budget_bytes: budget,
        threads: 2,
        ..RvOptions::default()
    };
    let before = CURRENT.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    let result = conservative_visible(&mut city, &cam, &options).unwrap();
    let heap_peak = PEAK.load(Ordering::Relaxed) - before;
    let s = &result.stats;
    println!(
        "rv memory: {} triangles streamed in {:.2} s ({:.1} M/s), {} on screen, {} visible; \
         heap peak {:.1} MiB, accounted {:.1} MiB, budget {:.1} MiB; pool full {}",
        s.triangles_streamed,
        s.seconds,
        s.triangles_streamed as f64 / s.seconds / 1e6,
        s.triangles_on_screen,
        result.visible.count_ones(..),
        heap_peak as f64 / (1 << 20) as f64,
        result.peak_memory_bytes as f64 / (1 << 20) as f64,
        budget as f64 / (1 << 20) as f64,
        s.pool_full,
    );
    assert!(s.triangles_streamed as f64 >= triangles as f64 * 0.8);
    assert!(result.peak_memory_bytes <= budget);
    assert!(
        heap_peak <= budget,
        "heap peak {heap_peak} over budget {budget}"
    );
}

#[test]
fn rv_memory_streaming_city_stays_under_budget() {
    let env = |name: &str| {
        std::env::var(name)
            .ok()
            .and_then(|s| s.parse::<usize>().ok())
    };
    match (env("RV_MEMORY_TRIANGLES"), env("RV_MEMORY_BUDGET")) {
        (None, None) => {
            stream_under_budget(10_000_000, 256 << 20);
            stream_under_budget(10_000_000, 32 << 20);
        }
        (t, b) => stream_under_budget(t.unwrap_or(10_000_000), b.unwrap_or(256 << 20)),
    }
}

#[test]
fn rv_memory_impossible_budget_is_an_error() {
    let mut city = StreamingCity::new(1, 10_000);
    let cam = street_camera(&city);
    let options = RvOptions {
        memory_budget_bytes: 1 << 16,
        ..RvOptions::default()
    };
    match conservative_visible(&mut city, &cam, &options) {
        Err(RvError::BudgetTooSmall { budget, needed }) => {
            assert_eq!(budget, 1 << 16);
            assert!(needed > budget);
        }
        other => panic!("expected BudgetTooSmall, got {other:?}"),
    }
}
