//! Helpers shared by sightline's integration tests, written once: random occluder scenes,
//! cameras and boxes (`occluders`), the small culling-simulation configuration (`simulation`),
//! and, with the `vulkan` feature, the one Vulkan device a test binary shares (`vulkan`).
//!
//! A dev-dependency only: no product crate depends on it. Random numbers come from the
//! project's generator, [`sightline_core::random::SplitMix64`], so every test is reproducible
//! from its seed.

pub mod occluders;
pub mod simulation;
#[cfg(feature = "vulkan")]
pub mod vulkan;
