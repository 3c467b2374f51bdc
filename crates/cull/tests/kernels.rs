//! The SIMD kernels (SSE2, AVX2) and the scalar kernel of the occlusion buffer produce the same
//! buffer bit for bit, and so the same box test answers, on random occluder scenes seen from
//! random cameras (including triangles clipped at the near plane and the guard band, slivers,
//! and sizes that are not multiples of the tile). The baseline kernels the bench measures
//! against are compared too.

use glam::Vec3;
use sightline_core::random::SplitMix64;
use sightline_core::{Aabb, Camera};
use sightline_cull::{BaselineKernel, Kernel, OcclusionBuffer};

/// A public or a baseline kernel.
#[derive(Clone, Copy, Debug)]
enum AnyKernel {
    Public(Kernel),
    Baseline(BaselineKernel),
}

impl AnyKernel {
    /// Every kernel this CPU runs, the public ones first (scalar first of all).
    fn available() -> Vec<AnyKernel> {
        let public = Kernel::ALL.into_iter().filter(|k| k.available());
        let baseline = BaselineKernel::ALL.into_iter().filter(|k| k.available());
        public
            .map(AnyKernel::Public)
            .chain(baseline.map(AnyKernel::Baseline))
            .collect()
    }

    /// Draws the occluders into `b` with this kernel.
    fn render(self, b: &mut OcclusionBuffer, tris: &[Vec3], cam: &Camera) {
        match self {
            AnyKernel::Public(k) => {
                assert!(b.set_kernel(k), "{k:?} reported available");
                assert_eq!(b.kernel(), k);
                b.render_occluders(tris, cam);
            }
            AnyKernel::Baseline(k) => {
                assert!(
                    b.render_occluders_baseline(k, tris, cam),
                    "{k:?} reported available"
                );
            }
        }
    }
}

/// One `w x h` buffer per kernel with the occluders drawn into it.
fn render_each(
    kernels: &[AnyKernel],
    w: u32,
    h: u32,
    tris: &[Vec3],
    cam: &Camera,
) -> Vec<OcclusionBuffer> {
    kernels
        .iter()
        .map(|&k| {
            let mut b = OcclusionBuffer::new(w, h);
            k.render(&mut b, tris, cam);
            b
        })
        .collect()
}

fn random_triangles(rng: &mut SplitMix64, n: usize) -> Vec<Vec3> {
    let mut out = Vec::with_capacity(3 * n);
    for i in 0..n {
        let c = Vec3::new(
            rng.range_f32(-40.0, 40.0),
            rng.range_f32(-40.0, 40.0),
            rng.range_f32(-5.0, 20.0),
        );
        // Mostly small triangles, some large ones and some slivers.
        let s = match i % 10 {
            0 => 60.0,
            1 => 0.01,
            _ => rng.range_f32(0.2, 4.0),
        };
        for _ in 0..3 {
            out.push(
                c + Vec3::new(
                    rng.range_f32(-s, s),
                    rng.range_f32(-s, s),
                    rng.range_f32(-s, s),
                ),
            );
        }
    }
    out
}

#[test]
fn simd_and_scalar_kernels_give_identical_buffers_and_answers() {
    let mut rng = SplitMix64::new(17);
    let kernels = AnyKernel::available();
    eprintln!("kernels compared: {kernels:?}");
    let mut tested = 0;
    let mut differing_from_empty = 0;
    for case in 0..24 {
        let (w, h) = if case % 2 == 0 { (320, 180) } else { (157, 93) };
        let eye = Vec3::new(
            rng.range_f32(-30.0, 30.0),
            rng.range_f32(-30.0, 30.0),
            rng.range_f32(0.0, 15.0),
        );
        let look = Vec3::new(rng.range_f32(-20.0, 20.0), rng.range_f32(-20.0, 20.0), 2.0);
        let cam = Camera::look_at(eye, look, Vec3::Z, rng.range_f32(40.0, 100.0), w, h, 0.1)
            .expect("camera");
        let tris = random_triangles(&mut rng, 400);
        let buffers = render_each(&kernels, w, h, &tris, &cam);
        let empty = OcclusionBuffer::new(w, h);
        differing_from_empty += usize::from(!buffers[0].same_contents(&empty));
        for (k, b) in kernels.iter().zip(&buffers).skip(1) {
            assert!(
                b.same_contents(&buffers[0]),
                "case {case}: {k:?} differs from scalar"
            );
        }
        for _ in 0..200 {
            let c = Vec3::new(
                rng.range_f32(-40.0, 40.0),
                rng.range_f32(-40.0, 40.0),
                rng.range_f32(-5.0, 20.0),
            );
            let aabb = Aabb::new(c, c + Vec3::splat(rng.range_f32(0.1, 3.0)));
            let want = buffers[0].test_box(&aabb, &cam);
            for b in &buffers[1..] {
                assert_eq!(b.test_box(&aabb, &cam), want, "case {case}: {aabb:?}");
            }
            tested += 1;
        }
    }
    assert_eq!(tested, 24 * 200);
    // The comparison means something only if the occluders left marks.
    assert!(differing_from_empty >= 20, "{differing_from_empty}");
}

#[test]
fn unavailable_kernel_is_refused_and_scalar_always_works() {
    let mut b = OcclusionBuffer::new(16, 16);
    assert!(b.set_kernel(Kernel::Scalar));
    assert_eq!(b.kernel(), Kernel::Scalar);
    for k in Kernel::ALL {
        assert_eq!(b.set_kernel(k), k.available());
    }
    assert!(Kernel::detect().available());
    let cam = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 16, 16, 0.1).expect("camera");
    for k in BaselineKernel::ALL {
        assert_eq!(b.render_occluders_baseline(k, &[], &cam), k.available());
    }
}

/// The point seen at screen `(sx, sy)` at view depth `z` by a camera at the origin looking
/// down -Z (+Y up) onto a `w x h` image.
fn unproject(cam: &Camera, w: u32, h: u32, sx: f32, sy: f32, z: f32) -> Vec3 {
    let u = (2.0 * sx / w as f32 - 1.0) * cam.tan_half_x();
    let v = (1.0 - 2.0 * sy / h as f32) * cam.tan_half_y();
    Vec3::new(u * z, v * z, -z)
}

#[test]
fn batched_avx2_path_equals_previous_kernels_on_small_edge_and_near_triangles() {
    if !Kernel::Avx2.available() {
        // Without AVX2 the batched path can never run: then it must not be selectable either.
        eprintln!("no AVX2 on this CPU: checking that the batched path cannot be selected");
        assert_ne!(Kernel::detect(), Kernel::Avx2);
        assert!(!OcclusionBuffer::new(8, 8).set_kernel(Kernel::Avx2));
        return;
    }
    let (w, h) = (480, 270);
    let cam = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, w, h, 0.1).expect("camera");
    let mut rng = SplitMix64::new(23);
    let mut tris = Vec::new();
    let (mut crossing_near, mut crossing_edge, mut beyond_guard) = (0, 0, 0);
    for i in 0..3001 {
        // Screen positions that reach past every image edge.
        let sx = rng.range_f32(-30.0, w as f32 + 20.0);
        let sy = rng.range_f32(-30.0, h as f32 + 20.0);
        let z = rng.range_f32(0.5, 30.0);
        let s = rng.range_f32(2.0, 14.0);
        let mut t = [
            unproject(&cam, w, h, sx, sy, z),
            unproject(&cam, w, h, sx + s, sy + rng.range_f32(-2.0, 2.0), z * 1.01),
            unproject(&cam, w, h, sx + rng.range_f32(-2.0, 2.0), sy + s, z * 0.99),
        ];
        match i % 10 {
            // One corner behind the camera: clipped at the near plane.
            0 => {
                t[1].z = rng.range_f32(0.05, 3.0);
                crossing_near += 1;
            }
            // A corner far outside the view: clipped at the guard band.
            1 => {
                t[2].x += rng.range_f32(-400.0, 400.0);
                beyond_guard += 1;
            }
            // Degenerate: two equal corners.
            2 => t[2] = t[1],
            // Clockwise order.
            3 => t.swap(1, 2),
            // Slivers of 0.2 to 3 pixels of area (the plane is used from 1 pixel on).
            4 => {
                let a = rng.range_f32(0.2, 3.0);
                t[2] = unproject(&cam, w, h, sx, sy + 2.0 * a / s, z * 0.7);
                t[1] = unproject(&cam, w, h, sx + s, sy, z * 1.5);
            }
            // A horizontal top edge (two corners on one screen row, at one depth), where
            // only the row range bounds the spans above it.
            5 => t[1] = unproject(&cam, w, h, sx + s, sy, z),
            // A horizontal bottom edge.
            6 => {
                t[1] = unproject(&cam, w, h, sx + s, sy + s, z);
                t[2] = unproject(&cam, w, h, sx - 0.5 * s, sy + s, z);
            }
            // Nearly horizontal edges, whose slopes are huge.
            7 => t[1] = unproject(&cam, w, h, sx + s, sy + 1e-4, z),
            _ => {}
        }
        crossing_edge +=
            usize::from(sx < 0.0 || sy < 0.0 || sx + s > w as f32 || sy + s > h as f32);
        tris.extend_from_slice(&t);
    }
    assert!(crossing_near > 250 && beyond_guard > 250 && crossing_edge > 300);
    let render = |k: AnyKernel, tris: &[Vec3]| {
        let mut b = OcclusionBuffer::new(w, h);
        // Uneven slices: batches of 8 with partial ones at every end.
        for part in tris.chunks(3 * 13) {
            k.render(&mut b, part, &cam);
        }
        b
    };
    let avx2 = AnyKernel::Public(Kernel::Avx2);
    let avx2_per_tile = AnyKernel::Baseline(BaselineKernel::Avx2PerTile);
    let new = render(avx2, &tris);
    assert!(!new.same_contents(&OcclusionBuffer::new(w, h)));
    for old in [
        avx2_per_tile,
        AnyKernel::Baseline(BaselineKernel::Sse2PerTile),
        AnyKernel::Public(Kernel::Scalar),
    ] {
        assert!(
            new.same_contents(&render(old, &tris)),
            "avx2 differs from {old:?}"
        );
    }
    // Fewer triangles than a batch, alone.
    for n in 1..8 {
        let part = &tris[..3 * n];
        assert!(render(avx2, part).same_contents(&render(avx2_per_tile, part)));
    }
    // The AVX-512 step (two block rows at once, the last of an odd count with the row below
    // it, or the storage's spare row) on the same triangles, at the image's edges and near
    // plane.
    if Kernel::Avx512.available() {
        let avx512 = AnyKernel::Public(Kernel::Avx512);
        assert!(
            render(avx512, &tris).same_contents(&new),
            "avx512 differs from avx2"
        );
        for n in 1..8 {
            let part = &tris[..3 * n];
            assert!(render(avx512, part).same_contents(&render(avx2, part)));
        }
    } else {
        eprintln!("no AVX-512 on this CPU: the AVX-512 kernel is not compared here");
        assert!(!OcclusionBuffer::new(8, 8).set_kernel(Kernel::Avx512));
    }
}

/// Images wider than 65,536 pixels get the same buffers from every kernel, with triangles
/// from the image's first block to its last: the AVX2 block kernel counts span ends from a
/// row's first block in 16 bits, which holds because drawn triangles lie in the guard band
/// (at most 32,768 pixels wide); with a wider guard band these spans would overflow.
#[test]
fn kernels_agree_on_images_wider_than_16_bit_span_counts() {
    let kernels = AnyKernel::available();
    let mut rng = SplitMix64::new(29);
    for w in [65_600, 100_000] {
        let h = 24;
        // Cameras stop at 16,384 pixels; the kernels draw to the buffer's own size.
        let cam = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0, 16_384, 6, 0.1)
            .expect("camera");
        let mut tris = Vec::new();
        for i in 0..60 {
            let sy = rng.range_f32(-4.0, h as f32);
            let z = rng.range_f32(1.0, 30.0);
            if i % 2 == 0 {
                // From the first block to a nearly upright right edge in the last 64 columns:
                // span ends more than 65,535 columns from their row's first block.
                let (sx, xr) = (
                    rng.range_f32(-40.0, 30.0),
                    w as f32 - rng.range_f32(5.0, 64.0),
                );
                tris.extend([
                    unproject(&cam, w, h, sx, sy, z),
                    unproject(&cam, w, h, xr, sy + 0.3, z * 1.1),
                    unproject(
                        &cam,
                        w,
                        h,
                        xr - rng.range_f32(0.0, 30.0),
                        sy + 24.0,
                        z * 0.9,
                    ),
                ]);
            } else {
                // Spans from a few pixels to the whole image, some past its right edge.
                let sx = rng.range_f32(-100.0, w as f32);
                let len = rng.range_f32(4.0, 70_000.0);
                tris.extend([
                    unproject(&cam, w, h, sx, sy, z),
                    unproject(&cam, w, h, sx + len, sy + rng.range_f32(1.0, 20.0), z * 1.1),
                    unproject(
                        &cam,
                        w,
                        h,
                        sx + rng.range_f32(-50.0, 50.0),
                        sy + 24.0,
                        z * 0.9,
                    ),
                ]);
            }
        }
        let buffers = render_each(&kernels, w, h, &tris, &cam);
        assert!(!buffers[0].same_contents(&OcclusionBuffer::new(w, h)));
        for (k, b) in kernels.iter().zip(&buffers).skip(1) {
            assert!(
                b.same_contents(&buffers[0]),
                "{w} px: {k:?} differs from scalar"
            );
        }
    }
}
