//! Ray casting throughput: several ray casters (our BVH, Embree, the GPU caster: whichever the
//! caller built) on the same coherent camera rays and incoherent random rays, million rays
//! per second.
//!
//! Method: the backends alternate in several short rounds and each keeps its best round, so a
//! burst of load on a shared machine hits all of them alike and is then discarded. The
//! casters are built by the caller (the GPU one needs a device this crate does not know),
//! each timed by [`TraceBackend::timed`].

use std::time::Instant;

use serde::Serialize;
use sightline_core::trace::{measure, RayCaster};
use sightline_core::{Camera, Ray, Scene};

/// Rounds the measuring time is split into (the best is kept).
pub const TRACE_ROUNDS: usize = 5;

/// Seed of the incoherent rays.
const INCOHERENT_SEED: u64 = 7;

/// A ray caster to measure, with its name and build time.
pub struct TraceBackend {
    /// Name in the table, e.g. "sightline BVH".
    pub name: String,
    /// Seconds its construction took.
    pub build_seconds: f64,
    /// The caster.
    pub caster: Box<dyn RayCaster>,
}

impl TraceBackend {
    /// Builds a backend with `build` (which returns its name and caster), timing the build.
    pub fn timed<E>(
        build: impl FnOnce() -> Result<(String, Box<dyn RayCaster>), E>,
    ) -> Result<Self, E> {
        let t = Instant::now();
        let (name, caster) = build()?;
        Ok(Self {
            name,
            build_seconds: t.elapsed().as_secs_f64(),
            caster,
        })
    }
}

/// The rays every backend casts.
pub struct TraceRays {
    /// One ray per pixel of the camera.
    pub coherent: Vec<Ray>,
    /// Random rays through the scene's bounds.
    pub incoherent: Vec<Ray>,
}

impl TraceRays {
    /// The camera's pixel rays and `incoherent` random rays through `scene`'s bounds.
    pub fn new(scene: &Scene, camera: &Camera, incoherent: usize) -> Self {
        Self {
            coherent: measure::coherent_rays(camera),
            incoherent: measure::incoherent_rays(scene.bounds(), incoherent, INCOHERENT_SEED),
        }
    }
}

/// One backend on one scene.
#[derive(Serialize, Clone, Debug)]
pub struct TraceRow {
    /// The scene's name.
    pub scene: String,
    /// Its triangles.
    pub triangles: usize,
    /// The backend's name.
    pub backend: String,
    /// Seconds to build the backend.
    pub build_seconds: f64,
    /// Best coherent rate, million rays per second.
    pub coherent_mrays: f64,
    /// Best incoherent rate, million rays per second.
    pub incoherent_mrays: f64,
}

/// Measures every backend on `rays` for about `seconds` per backend and ray set, split into
/// [`TRACE_ROUNDS`] alternating rounds; one row per backend, in order.
pub fn bench_trace(
    scene_name: &str,
    triangles: usize,
    backends: &[TraceBackend],
    rays: &TraceRays,
    seconds: f64,
) -> Vec<TraceRow> {
    let mut coherent_rates = vec![0.0f64; backends.len()];
    let mut incoherent_rates = vec![0.0f64; backends.len()];
    let per_round = seconds / TRACE_ROUNDS as f64;
    for _ in 0..TRACE_ROUNDS {
        for (i, b) in backends.iter().enumerate() {
            let caster = b.caster.as_ref();
            let coh = measure::rays_per_second(caster, &rays.coherent, per_round);
            let inc = measure::rays_per_second(caster, &rays.incoherent, per_round);
            coherent_rates[i] = coherent_rates[i].max(coh);
            incoherent_rates[i] = incoherent_rates[i].max(inc);
        }
    }
    backends
        .iter()
        .enumerate()
        .map(|(i, b)| TraceRow {
            scene: scene_name.to_string(),
            triangles,
            backend: b.name.clone(),
            build_seconds: b.build_seconds,
            coherent_mrays: coherent_rates[i] / 1e6,
            incoherent_mrays: incoherent_rates[i] / 1e6,
        })
        .collect()
}
