//! Upper bounds on the options that size memory, checked before anything is allocated: a
//! mistyped count (`--grid 1000,1000,1000`, `--frames 4294967295`) must be a message that
//! names the limit, not an allocation failure that aborts the process. Each check is on the
//! total the option leads to (cells = NX × NY × NZ, frames × per-frame records), in u64 with
//! checked arithmetic, so no product can wrap around to a small number.

use anyhow::{bail, Result};

/// Most view cells of one bake: each keeps its cell, its encoded set and its statistics in
/// memory until the file is written (hundreds of bytes to kilobytes per cell), and the .pvs
/// file holds them all. 2^20 cells is about a gigabyte at a kilobyte per cell.
pub(crate) const MAX_CELLS: u64 = 1 << 20;

/// Most frames of a camera path (`cull`, `view --frames`, `demo`): every frame keeps its
/// camera and its report row (per method) in memory, a few hundred bytes each, and `view`
/// writes one image per frame. A million frames is over nine hours at 30 per second.
pub(crate) const MAX_FRAMES: u64 = 1_000_000;

/// Most pixels of one image (`--size WxH`): the rasterizers keep about 12 bytes per pixel
/// (triangle ids, depth, colour), 800 MB at 8192 × 8192.
pub(crate) const MAX_PIXELS: u64 = 1 << 26;

/// Most rays `bench trace` generates in memory before casting (32 bytes each: 1 GiB).
pub(crate) const MAX_BENCH_RAYS: u64 = 1 << 25;

/// Refuses `n` above `max` for `option` (a count of things held in memory).
pub(crate) fn check_count(n: u64, max: u64, option: &str) -> Result<()> {
    if n > max {
        bail!("{option} {n} is above the limit of {max}: each is held in memory");
    }
    Ok(())
}

/// Refuses more than [`MAX_CELLS`] cells from `source` (e.g. `--grid 1000,1000,1000`).
pub(crate) fn check_cells(counts: &[u64], source: &str) -> Result<u64> {
    let total = counts
        .iter()
        .try_fold(1u64, |acc, &n| acc.checked_mul(n))
        .unwrap_or(u64::MAX);
    if total > MAX_CELLS {
        bail!(
            "{source} gives {} cells, more than the limit of {MAX_CELLS}: every cell's set and \
             statistics stay in memory until the file is written; bake a coarser grid, or \
             split the region into several bakes",
            if total == u64::MAX {
                "over 2^64".to_string()
            } else {
                total.to_string()
            }
        );
    }
    Ok(total)
}

/// Refuses more than [`MAX_FRAMES`] frames.
pub(crate) fn check_frames(frames: u64, option: &str) -> Result<()> {
    if frames > MAX_FRAMES {
        bail!(
            "{option} {frames} is above the limit of {MAX_FRAMES} frames: every frame keeps \
             its camera and report in memory; simulate a shorter path (or several runs)"
        );
    }
    Ok(())
}

/// Refuses an image of more than [`MAX_PIXELS`] pixels.
pub(crate) fn check_pixels(width: u32, height: u32) -> Result<(), String> {
    let pixels = u64::from(width) * u64::from(height);
    if pixels > MAX_PIXELS {
        return Err(format!(
            "{width}x{height} is {pixels} pixels, above the limit of {MAX_PIXELS} (8192x8192): \
             the rasterizers keep about 12 bytes per pixel"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn products_are_checked_not_only_each_count() {
        assert!(check_cells(&[1000, 1000, 1000], "--grid").is_err());
        assert!(check_cells(&[u64::MAX, u64::MAX, 2], "--grid").is_err());
        assert_eq!(check_cells(&[64, 64, 64], "--grid").unwrap(), 1 << 18);
        assert!(check_pixels(16384, 16384).is_err());
        assert!(check_pixels(8192, 8192).is_ok());
    }
}
