//! `boxes`: random axis-aligned boxes in a 100³ volume, one object each.

use glam::Vec3;

use crate::random::SplitMix64;
use crate::scene::builder::SceneBuilder;

/// Volume edge length.
const EXTENT: f32 = 100.0;

pub(super) fn generate(b: &mut SceneBuilder, seed: u64, size: usize) {
    let count = (size / 12).max(1);
    b.reserve(count * 8, count * 12);
    let mut rng = SplitMix64::new(seed);
    // Box edge scales with the density so that scenes of any size stay a mix of free space and
    // occlusion (about 10% of the volume filled).
    let edge = EXTENT * (0.1 / count as f32).cbrt();
    for i in 0..count {
        let center = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * EXTENT;
        let half = Vec3::new(
            rng.range_f32(0.3, 1.0),
            rng.range_f32(0.3, 1.0),
            rng.range_f32(0.3, 1.0),
        ) * edge;
        b.begin_object(format!("box{i}"));
        b.add_box(center - half, center + half);
    }
}
