//! The culling simulation's small test configuration, shared by the software backend's tests
//! (`sightline-cull`) and the GPU backend's (`sightline-gpu`) so both run under the same bounds.

use sightline_cull::{SchedulerConfig, SimConfig};

/// 40 frames at 160x90 with results read `latency` frames later. With `latency = 0` (stop and
/// wait) every cell is re-queried every frame, so culling is conservative frame by frame; with
/// the thesis' latency, visible cells keep the default 30-frame visible duration.
pub fn small_grid_config(latency: u32) -> SimConfig {
    SimConfig {
        frames: 40,
        width: 160,
        height: 90,
        latency,
        scheduler: SchedulerConfig {
            visible_duration: if latency == 0 { 1 } else { 30 },
            ..SchedulerConfig::default()
        },
        ..SimConfig::default()
    }
}
