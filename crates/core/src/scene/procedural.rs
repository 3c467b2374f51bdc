//! Deterministic procedural scenes (being written).

use super::{Scene, SceneBuilder};

/// Parameters of a procedural scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Generator name.
    pub name: String,
    /// Random seed.
    pub seed: u64,
    /// Approximate triangle count.
    pub size: usize,
}

impl Params {
    /// Parses `NAME[?seed=S&size=N]`.
    pub fn parse(s: &str) -> Result<Self, String> {
        Ok(Self {
            name: s.to_string(),
            seed: 1,
            size: 1000,
        })
    }
}

/// Generates the scene.
pub fn generate(params: &Params) -> Scene {
    let mut b = SceneBuilder::new(format!("procedural:{}", params.name));
    b.add_box(glam::Vec3::ZERO, glam::Vec3::ONE);
    b.finish()
}
