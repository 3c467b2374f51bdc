//! Intel Embree 3 as a [`RayCaster`]: the speed reference our [`super::Bvh`] is measured
//! against. Only built with the `embree` cargo feature; links the system `libembree3`
//! (Debian `libembree-dev`, 3.13).
//!
//! Based on: Wald, Woop, Benthin, Johnson, Ernst. Embree: a kernel framework for efficient CPU
//! ray tracing. ACM TOG 33(4), 2014.
//!
//! # Why our own bindings
//! The `embree` crate (0.3.8) targets Embree 3 but has had no release since 2021, pulls in
//! `cgmath`, and ties geometry and scenes together with lifetimes that make an owned,
//! `Sync` caster awkward. We need about a dozen functions of the stable Embree 3 C API, so they
//! are declared here against `rtcore.h` of 3.13 (`RTC_MAX_INSTANCE_LEVEL_COUNT = 1`,
//! `RTC_MIN_WIDTH = 0`, the Debian build), which keeps the feature free of a build script.
//!
//! # Semantics
//! Embree tests triangles with its own (not watertight by default, and differently rounded)
//! test, so hits agree with [`super::BruteForce`] only up to ties and edges. Triangles that
//! cannot be hit (index out of range, non-finite corner, zero area) are replaced by a triangle
//! on one extra vertex, which Embree never hits, so primitive ids stay the scene's ids.

use std::ffi::{c_char, c_int, c_uint, c_void};
use std::ptr;

use rayon::prelude::*;

use crate::geometry::{Hit, Ray};
use crate::scene::Scene;

use super::ray_caster::RayCaster;

/// Rays per `rayon` task.
const RAYS_PER_TASK: usize = 64;

#[allow(non_camel_case_types)]
type RTCDevice = *mut c_void;
#[allow(non_camel_case_types)]
type RTCScene = *mut c_void;
#[allow(non_camel_case_types)]
type RTCGeometry = *mut c_void;

const RTC_GEOMETRY_TYPE_TRIANGLE: c_int = 0;
const RTC_BUFFER_TYPE_INDEX: c_int = 0;
const RTC_BUFFER_TYPE_VERTEX: c_int = 1;
const RTC_FORMAT_UINT3: c_int = 0x5003;
const RTC_FORMAT_FLOAT3: c_int = 0x9003;
const RTC_BUILD_QUALITY_HIGH: c_int = 2;
const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: c_int = 0;
const RTC_INVALID_GEOMETRY_ID: c_uint = u32::MAX;

/// `struct RTCIntersectContext` of Embree 3.13 with one instance level and no min-width.
#[repr(C)]
struct RTCIntersectContext {
    flags: c_int,
    filter: *const c_void,
    inst_id: [c_uint; 1],
}

impl RTCIntersectContext {
    /// What the header's inline `rtcInitIntersectContext` does.
    fn new() -> Self {
        Self {
            flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
            filter: ptr::null(),
            inst_id: [RTC_INVALID_GEOMETRY_ID],
        }
    }
}

/// `struct RTCRay` (48 bytes, 16-byte aligned).
#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct RTCRay {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: c_uint,
    id: c_uint,
    flags: c_uint,
}

/// `struct RTCHit` (with one instance level).
#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct RTCHit {
    ng: [f32; 3],
    u: f32,
    v: f32,
    prim_id: c_uint,
    geom_id: c_uint,
    inst_id: [c_uint; 1],
}

/// `struct RTCRayHit`.
#[repr(C)]
#[derive(Clone, Copy)]
struct RTCRayHit {
    ray: RTCRay,
    hit: RTCHit,
}

#[link(name = "embree3")]
extern "C" {
    fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    fn rtcReleaseDevice(device: RTCDevice);
    fn rtcGetDeviceError(device: RTCDevice) -> c_int;
    fn rtcNewScene(device: RTCDevice) -> RTCScene;
    fn rtcReleaseScene(scene: RTCScene);
    fn rtcSetSceneBuildQuality(scene: RTCScene, quality: c_int);
    fn rtcCommitScene(scene: RTCScene);
    fn rtcNewGeometry(device: RTCDevice, kind: c_int) -> RTCGeometry;
    fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        kind: c_int,
        slot: c_uint,
        format: c_int,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    fn rtcCommitGeometry(geometry: RTCGeometry);
    fn rtcAttachGeometry(scene: RTCScene, geometry: RTCGeometry) -> c_uint;
    fn rtcReleaseGeometry(geometry: RTCGeometry);
    fn rtcIntersect1(scene: RTCScene, context: *mut RTCIntersectContext, rayhit: *mut RTCRayHit);
    fn rtcOccluded1(scene: RTCScene, context: *mut RTCIntersectContext, ray: *mut RTCRay);
}

/// Why Embree could not build a scene.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[non_exhaustive]
pub enum EmbreeError {
    /// `rtcNewDevice` failed (for example an unsupported CPU).
    #[error("embree: could not create a device")]
    NoDevice,
    /// Embree reported an error code (see `RTCError` in `rtcore_device.h`).
    #[error("embree: error code {0} while building the scene")]
    Device(i32),
    /// The scene has more vertices or triangles than Embree's 32-bit ids allow.
    #[error("embree: scene too large ({0} triangles)")]
    TooLarge(usize),
}

/// Embree 3 as a [`RayCaster`]: one device, one committed scene with one triangle mesh.
#[derive(Debug)]
pub struct EmbreeCaster {
    device: RTCDevice,
    scene: RTCScene,
    /// True when the scene has no triangle (Embree is then not asked anything).
    empty: bool,
}

// SAFETY: after `rtcCommitScene` an Embree scene is immutable here and Embree documents
// `rtcIntersect*` / `rtcOccluded*` on a committed scene as safe to call from any number of
// threads at once; the device and scene handles are only released in `drop`, which needs
// exclusive access.
unsafe impl Send for EmbreeCaster {}
// SAFETY: see `Send`: every `&self` method only issues concurrent-safe queries.
unsafe impl Sync for EmbreeCaster {}

impl EmbreeCaster {
    /// Builds an Embree scene (high build quality) over `scene`'s triangles.
    pub fn build(scene: &Scene) -> Result<Self, EmbreeError> {
        Self::build_with_config(scene, c"")
    }

    /// [`EmbreeCaster::build`] with Embree building on `threads` threads (its device
    /// configuration `threads=N`; the default is every core), for single-thread benchmarks.
    pub fn build_with_threads(scene: &Scene, threads: usize) -> Result<Self, EmbreeError> {
        let config = std::ffi::CString::new(format!("threads={threads}"))
            .map_err(|_| EmbreeError::NoDevice)?;
        Self::build_with_config(scene, &config)
    }

    fn build_with_config(scene: &Scene, config: &std::ffi::CStr) -> Result<Self, EmbreeError> {
        let n_tri = scene.triangles.len();
        let n_vert = scene.positions.len() + 1;
        if n_tri >= u32::MAX as usize || n_vert >= u32::MAX as usize {
            return Err(EmbreeError::TooLarge(n_tri));
        }
        // SAFETY: `config` is a NUL-terminated string (empty: the default configuration).
        let device = unsafe { rtcNewDevice(config.as_ptr()) };
        if device.is_null() {
            return Err(EmbreeError::NoDevice);
        }
        // SAFETY: `device` is a live device.
        let scene_handle = unsafe { rtcNewScene(device) };
        let mut caster = Self {
            device,
            scene: scene_handle,
            empty: true,
        };
        if scene_handle.is_null() {
            return Err(caster.error());
        }
        // SAFETY: `scene_handle` is a live scene of `device`.
        unsafe { rtcSetSceneBuildQuality(scene_handle, RTC_BUILD_QUALITY_HIGH) };
        if n_tri > 0 {
            caster.add_mesh(scene, n_vert)?;
            caster.empty = false;
        }
        // SAFETY: the scene is live; committing builds its BVH.
        unsafe { rtcCommitScene(caster.scene) };
        // SAFETY: the device is live.
        if unsafe { rtcGetDeviceError(caster.device) } != 0 {
            return Err(caster.error());
        }
        Ok(caster)
    }

    fn error(&self) -> EmbreeError {
        // SAFETY: the device is live until `drop`.
        EmbreeError::Device(unsafe { rtcGetDeviceError(self.device) })
    }

    /// Adds one triangle mesh with Embree-owned (padded) copies of the positions and indices.
    fn add_mesh(&mut self, scene: &Scene, n_vert: usize) -> Result<(), EmbreeError> {
        let n_tri = scene.triangles.len();
        // SAFETY: the device is live.
        let geometry = unsafe { rtcNewGeometry(self.device, RTC_GEOMETRY_TYPE_TRIANGLE) };
        if geometry.is_null() {
            return Err(self.error());
        }
        // SAFETY: `geometry` is live; Embree allocates `n_vert` items of 12 bytes (with the
        // padding its SIMD loads need) and returns a pointer valid until the geometry dies.
        let vertices = unsafe {
            rtcSetNewGeometryBuffer(
                geometry,
                RTC_BUFFER_TYPE_VERTEX,
                0,
                RTC_FORMAT_FLOAT3,
                12,
                n_vert,
            )
        };
        // SAFETY: as above, `n_tri` items of three u32.
        let indices = unsafe {
            rtcSetNewGeometryBuffer(
                geometry,
                RTC_BUFFER_TYPE_INDEX,
                0,
                RTC_FORMAT_UINT3,
                12,
                n_tri,
            )
        };
        if vertices.is_null() || indices.is_null() {
            // SAFETY: `geometry` is live and released once.
            unsafe { rtcReleaseGeometry(geometry) };
            return Err(self.error());
        }
        // SAFETY: Embree returned buffers of exactly these sizes, 4-byte (in fact 16-byte)
        // aligned, not aliased by anything else we hold.
        let vertices =
            unsafe { std::slice::from_raw_parts_mut(vertices.cast::<[f32; 3]>(), n_vert) };
        // SAFETY: as above.
        let indices = unsafe { std::slice::from_raw_parts_mut(indices.cast::<[u32; 3]>(), n_tri) };
        let spare = (n_vert - 1) as u32;
        for (dst, p) in vertices.iter_mut().zip(&scene.positions) {
            *dst = p.to_array();
        }
        vertices[spare as usize] = [0.0; 3];
        indices
            .par_iter_mut()
            .zip(scene.triangles.par_iter())
            .for_each(|(dst, t)| {
                // The BVH's rule, so that both casters leave out the same triangles.
                let ok = super::bvh::hittable_corners(scene, t).is_some();
                *dst = if ok { *t } else { [spare; 3] };
            });
        // SAFETY: `geometry` is live, its buffers are filled; the scene keeps its own
        // reference after attaching, so we release ours.
        unsafe {
            rtcCommitGeometry(geometry);
            rtcAttachGeometry(self.scene, geometry);
            rtcReleaseGeometry(geometry);
        }
        Ok(())
    }

    fn embree_ray(ray: &Ray) -> RTCRay {
        RTCRay {
            org: ray.origin.to_array(),
            tnear: ray.t_min,
            dir: ray.dir.to_array(),
            time: 0.0,
            tfar: ray.t_max,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }

    /// True when Embree must not see the ray (its documentation requires `tnear <= tfar`,
    /// finite values, `tnear >= 0`).
    fn skip(&self, ray: &Ray) -> bool {
        let range_ok = ray.t_min <= ray.t_max; // false for NaN
        self.empty || !range_ok || !ray.origin.is_finite() || !ray.dir.is_finite()
    }

    fn closest(&self, ray: &Ray) -> Hit {
        if self.skip(ray) {
            return Hit::MISS;
        }
        let mut rayhit = RTCRayHit {
            ray: Self::embree_ray(ray),
            hit: RTCHit {
                ng: [0.0; 3],
                u: 0.0,
                v: 0.0,
                prim_id: RTC_INVALID_GEOMETRY_ID,
                geom_id: RTC_INVALID_GEOMETRY_ID,
                inst_id: [RTC_INVALID_GEOMETRY_ID],
            },
        };
        let mut context = RTCIntersectContext::new();
        // SAFETY: the scene is committed and alive for `&self`; `context` and `rayhit` are
        // valid, properly aligned and exclusively ours for the call.
        unsafe { rtcIntersect1(self.scene, &mut context, &mut rayhit) };
        if rayhit.hit.geom_id == RTC_INVALID_GEOMETRY_ID {
            Hit::MISS
        } else {
            Hit {
                triangle: rayhit.hit.prim_id,
                t: rayhit.ray.tfar,
            }
        }
    }

    fn any_hit(&self, ray: &Ray) -> bool {
        if self.skip(ray) {
            return false;
        }
        let mut r = Self::embree_ray(ray);
        let mut context = RTCIntersectContext::new();
        // SAFETY: as in `closest`.
        unsafe { rtcOccluded1(self.scene, &mut context, &mut r) };
        // Embree marks an occluded ray by setting `tfar` to -inf.
        r.tfar == f32::NEG_INFINITY
    }
}

impl Drop for EmbreeCaster {
    fn drop(&mut self) {
        // SAFETY: both handles are live and released exactly once, scene before device.
        unsafe {
            if !self.scene.is_null() {
                rtcReleaseScene(self.scene);
            }
            rtcReleaseDevice(self.device);
        }
    }
}

impl RayCaster for EmbreeCaster {
    fn cast(&self, rays: &[Ray], hits: &mut [Hit]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        rays.par_chunks(RAYS_PER_TASK)
            .zip(hits.par_chunks_mut(RAYS_PER_TASK))
            .for_each(|(rs, hs)| {
                for (r, h) in rs.iter().zip(hs) {
                    *h = self.closest(r);
                }
            });
    }

    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "one output slot per ray");
        rays.par_chunks(RAYS_PER_TASK)
            .zip(out.par_chunks_mut(RAYS_PER_TASK))
            .for_each(|(rs, os)| {
                for (r, o) in rs.iter().zip(os) {
                    *o = self.any_hit(r);
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Aabb;
    use crate::random::SplitMix64;
    use crate::scene::SceneBuilder;
    use crate::trace::bvh::Bvh;
    use glam::Vec3;

    /// Random points and directions from the project's generator, fixed seeds.
    struct Rng(SplitMix64);

    impl Rng {
        fn unit(&mut self) -> f32 {
            self.0.next_f32()
        }

        fn point(&mut self, b: &Aabb) -> Vec3 {
            let e = b.extent();
            b.min + Vec3::new(self.unit() * e.x, self.unit() * e.y, self.unit() * e.z)
        }

        fn direction(&mut self) -> Vec3 {
            let cube = Aabb::new(Vec3::splat(-1.0), Vec3::ONE);
            loop {
                let d = self.point(&cube);
                if d.length_squared() > 1e-4 && d.length_squared() <= 1.0 {
                    return d;
                }
            }
        }
    }

    fn random_boxes(n: usize, seed: u64) -> Scene {
        let mut rng = Rng(SplitMix64::new(seed));
        let mut b = SceneBuilder::new("random boxes");
        let region = Aabb::new(Vec3::ZERO, Vec3::splat(20.0));
        for _ in 0..n {
            let min = rng.point(&region);
            let size = Vec3::new(rng.unit(), rng.unit(), rng.unit()) * 2.0 + 0.05;
            b.add_box(min, min + size);
        }
        b.finish()
    }

    fn random_soup(n: usize, seed: u64) -> Scene {
        let mut rng = Rng(SplitMix64::new(seed));
        let mut b = SceneBuilder::new("random soup");
        let region = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
        for i in 0..n {
            let c = rng.point(&region);
            let mut corner = || c + rng.direction();
            let tri = if i % 40 == 0 {
                let p = corner();
                [p, p, corner()]
            } else {
                [corner(), corner(), corner()]
            };
            let v = tri.map(|p| b.add_vertex(p));
            b.add_triangle(v);
        }
        b.finish()
    }

    fn random_rays(bounds: Aabb, n: usize, seed: u64) -> Vec<Ray> {
        let mut rng = Rng(SplitMix64::new(seed));
        (0..n)
            .map(|_| Ray::new(rng.point(&bounds), rng.direction()))
            .collect()
    }

    /// Casts with both and returns (agreeing ids, rays compared). Disagreements are only
    /// allowed where both hit at `t` within 1e-4 relative (ties, shared edges).
    fn compare(scene: &Scene, rays: &[Ray]) -> (usize, usize) {
        let ours = Bvh::build(scene);
        let embree = EmbreeCaster::build(scene).expect("embree builds");
        let mut a = vec![Hit::MISS; rays.len()];
        let mut b = vec![Hit::MISS; rays.len()];
        ours.cast(rays, &mut a);
        embree.cast(rays, &mut b);
        let mut same = 0;
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            if x.triangle == y.triangle {
                same += 1;
                if x.is_hit() {
                    assert!((x.t - y.t).abs() <= 1e-4 * x.t.abs().max(1.0), "ray {i}");
                }
                continue;
            }
            let close = x.is_hit()
                && y.is_hit()
                && (x.t - y.t).abs() <= 1e-4 * x.t.abs().max(y.t.abs()).max(1e-3);
            assert!(close, "ray {i} {:?}: ours {x:?}, embree {y:?}", rays[i]);
        }
        let mut occluded = vec![false; rays.len()];
        embree.occluded(rays, &mut occluded);
        let agree = occluded.iter().zip(&b).filter(|(o, h)| **o == h.is_hit());
        assert!(agree.count() >= rays.len() * 999 / 1000);
        (same, rays.len())
    }

    #[test]
    fn empty_scene_misses() {
        let e = EmbreeCaster::build(&Scene::default()).expect("embree builds");
        assert!(!e.cast_one(&Ray::new(Vec3::ZERO, Vec3::X)).is_hit());
    }

    #[test]
    fn single_box_is_hit() {
        let mut b = SceneBuilder::new("box");
        b.add_box(Vec3::splat(1.0), Vec3::splat(2.0));
        let e = EmbreeCaster::build(&b.finish()).expect("embree builds");
        let h = e.cast_one(&Ray::new(Vec3::new(0.0, 1.5, 1.3), Vec3::X));
        assert!(h.is_hit() && (h.t - 1.0).abs() < 1e-6 && h.triangle < 2);
    }

    #[test]
    fn random_soup_agrees_with_bvh() {
        let scene = random_soup(5000, 11);
        compare(&scene, &random_rays(scene.bounds(), 5000, 12));
    }

    #[test]
    fn box_scene_agrees_with_bvh() {
        let scene = random_boxes(2000, 13);
        let (same, n) = compare(&scene, &random_rays(scene.bounds(), 10_000, 14));
        assert!(same * 1000 >= n * 999, "{same} of {n} ids agree");
    }
}
