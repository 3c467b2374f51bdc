//! One streamed RV run over a procedural city that is never materialised, for profiling and
//! CPU-time measurements:
//! `cargo run --release -p sightline-point --example rv_stream_once -- TRIANGLES [THREADS]
//! [street|aerial] [--single-pass | --source-only]`. `--source-only` only drains the city generator
//! once (the part of the run that is not RV's). Cameras at 1024²: `StreamingCity::street_camera`
//! and `aerial_camera` (as `sightline bench rv`, which alternates all four configurations).

use std::io::Write;

use sightline_point::rv::{conservative_visible, RvOptions, StreamingCity, TriangleSource};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Written with `writeln!` so that a closed pipe (`| head -1`) ends the run with an error
    // instead of a panic.
    let mut out = std::io::stdout().lock();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let size: usize = args.first().map_or(Ok(1_000_000), |s| s.parse())?;
    let threads: usize = args.get(1).map_or(Ok(2), |s| s.parse())?;
    let camera = match args.get(2).map(String::as_str) {
        Some("aerial") => StreamingCity::aerial_camera(1024)?,
        _ => StreamingCity::street_camera(1024)?,
    };
    let options = RvOptions {
        threads,
        geometry_threads: threads,
        retest_pass: !args.iter().any(|a| a == "--single-pass"),
        ..RvOptions::default()
    };
    let mut source = StreamingCity::new(1, size);
    if args.iter().any(|a| a == "--source-only") {
        let start = std::time::Instant::now();
        let (mut batch, mut n) = (Vec::with_capacity(options.batch_triangles), 0usize);
        while source.next_batch(options.batch_triangles, &mut batch)? > 0 {
            n += batch.len();
            batch.clear();
        }
        let s = start.elapsed().as_secs_f64();
        writeln!(
            out,
            "{n} generated, {s:.3} s, {:.2} M triangles/s",
            n as f64 / s / 1e6
        )?;
        return Ok(());
    }
    let r = conservative_visible(&mut source, &camera, &options)?;
    writeln!(
        out,
        "{} streamed, {} on screen, {} visible ({} after the first pass), {:.3} s, {:.2} M \
         triangles/s, peak {:.1} MiB",
        r.stats.triangles_streamed,
        r.stats.triangles_on_screen,
        r.visible.count_ones(..),
        r.stats.first_pass_visible,
        r.stats.seconds,
        r.stats.triangles_streamed as f64 / r.stats.seconds / 1e6,
        r.peak_memory_bytes as f64 / (1 << 20) as f64
    )?;
    writeln!(
        out,
        "{} bin entries (first pass), {} bin tests ({} occluded, {} of them by fusion), {} \
         silhouette tests, {} triangle tests, {} re-tests skipped (bins settled)",
        r.stats.bin_entries,
        r.stats.bin_tests,
        r.stats.bin_occluded,
        r.stats.fused_occluded,
        r.stats.silhouette_tests,
        r.stats.triangle_tests,
        r.stats.retest_settled
    )?;
    Ok(())
}
