//! The SIMD kernels (SSE2, AVX2) and the scalar kernel of the occlusion buffer produce the same
//! buffer bit for bit, and so the same box test answers, on random occluder scenes seen from
//! random cameras (including triangles clipped at the near plane and the guard band, slivers,
//! and sizes that are not multiples of the tile).

use glam::Vec3;
use sightline_core::random::SplitMix64;
use sightline_core::{Aabb, Camera};
use sightline_cull::{Kernel, OcclusionBuffer};

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
    let kernels: Vec<Kernel> = Kernel::ALL.into_iter().filter(|k| k.available()).collect();
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
        let buffers: Vec<OcclusionBuffer> = kernels
            .iter()
            .map(|&k| {
                let mut b = OcclusionBuffer::new(w, h);
                assert!(b.set_kernel(k), "{k:?} reported available");
                assert_eq!(b.kernel(), k);
                b.render_occluders(&tris, &cam);
                b
            })
            .collect();
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
}
