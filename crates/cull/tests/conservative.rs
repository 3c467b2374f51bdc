//! The occlusion buffer against the exact depth test: occluders rendered with the reference
//! rasterizer give a depth buffer; a box is truly visible when some pixel of its rasterized
//! faces is strictly in front of it. The buffer must never report such a box occluded.

use glam::Vec3;
use sightline_core::random::SplitMix64;
use sightline_core::raster::{render, Frame};
use sightline_core::scene::SceneBuilder;
use sightline_core::{Aabb, Camera, Scene};
use sightline_cull::OcclusionBuffer;
use sightline_test_support::occluders::{occluder_scene, random_box, random_camera, Ground};

/// True when some pixel of the box's rasterized faces is strictly in front of `depth`.
fn exactly_visible(aabb: &Aabb, camera: &Camera, depth: &Frame) -> bool {
    let mut b = SceneBuilder::new("box");
    b.add_box(aabb.min, aabb.max);
    let frame = render(&b.finish(), camera);
    frame
        .depth
        .iter()
        .zip(&depth.depth)
        .any(|(&boxd, &d)| boxd.is_finite() && boxd < d)
}

/// For `scenes` random scenes, `cameras` cameras each and `boxes` boxes per camera: no truly
/// visible box is culled. Returns (truly hidden boxes, of those culled by the buffer).
fn check_conservative(
    seed: u64,
    scenes: u32,
    cameras: u32,
    boxes: u32,
    w: u32,
    h: u32,
) -> (u32, u32) {
    let (mut hidden, mut culled) = (0, 0);
    for_each_view(
        seed,
        scenes,
        cameras,
        w,
        h,
        |rng, camera, reference, buffer| {
            for _ in 0..boxes {
                let aabb = random_box(rng);
                let visible = exactly_visible(&aabb, camera, reference);
                let reported = buffer.test_box(&aabb, camera);
                assert!(
                    reported || !visible,
                    "seed {seed}: visible box {aabb:?} culled from {camera:?}"
                );
                if !visible {
                    hidden += 1;
                    culled += u32::from(!reported);
                }
            }
        },
    );
    (hidden, culled)
}

/// For `scenes` random occluder scenes and `cameras` random cameras on each, calls `test`
/// with the random stream, the camera, the scene's exact depth (the reference rasterizer) and
/// an occlusion buffer holding the scene's occluders.
fn for_each_view(
    seed: u64,
    scenes: u32,
    cameras: u32,
    w: u32,
    h: u32,
    mut test: impl FnMut(&mut SplitMix64, &Camera, &Frame, &OcclusionBuffer),
) {
    let mut rng = SplitMix64::new(seed);
    for _ in 0..scenes {
        let scene = occluder_scene(&mut rng, Ground::Quad);
        let corners: Vec<Vec3> = (0..scene.triangle_count() as u32)
            .flat_map(|t| scene.triangle(t))
            .collect();
        for _ in 0..cameras {
            let camera = random_camera(&mut rng, w, h);
            let reference = render(&scene, &camera);
            let mut buffer = OcclusionBuffer::new(w, h);
            buffer.render_occluders(&corners, &camera);
            test(&mut rng, &camera, &reference, &buffer);
        }
    }
}

#[test]
fn never_culls_an_exactly_visible_box() {
    let (hidden, culled) = check_conservative(7, 4, 6, 150, 160, 120);
    eprintln!("culled {culled} of {hidden} truly hidden boxes");
    // Not a correctness property, but a buffer that culls nothing would pass trivially.
    assert!(hidden > 500, "{hidden}");
    assert!(
        culled * 2 > hidden,
        "culled {culled} of {hidden} hidden boxes"
    );
}

#[test]
fn never_culls_an_exactly_visible_box_odd_sizes() {
    // Sizes that are not multiples of the 8x4 tile, so edge tiles are partial.
    let (hidden, culled) = check_conservative(11, 2, 6, 150, 157, 93);
    assert!(culled > 0 && culled <= hidden);
}

/// A random object: a box (its 12 triangles) or, every other time, a "rock" of a
/// few random triangles in a small region (slanted, thin, sometimes sliver-sized).
fn random_object(rng: &mut SplitMix64, k: u32) -> Scene {
    let aabb = random_box(rng);
    let mut b = SceneBuilder::new("object");
    if k.is_multiple_of(2) {
        b.add_box(aabb.min, aabb.max);
    } else {
        let e = aabb.max - aabb.min;
        let mut point = |rng: &mut SplitMix64| {
            b.add_vertex(
                aabb.min
                    + Vec3::new(
                        rng.range_f32(0.0, e.x),
                        rng.range_f32(0.0, e.y),
                        rng.range_f32(0.0, e.z),
                    ),
            )
        };
        let tris: Vec<[u32; 3]> = (0..1 + rng.below(6))
            .map(|_| [point(rng), point(rng), point(rng)])
            .collect();
        for t in tris {
            b.add_triangle(t);
        }
    }
    b.finish()
}

/// As [`check_conservative`] for [`OcclusionBuffer::test_triangles`] on boxes and rocks,
/// against the exact depth test of the object's own triangles. Returns (truly hidden objects,
/// of those culled by the box test, of those culled by the triangle test).
fn check_triangles_conservative(seed: u64, cameras: u32, objects: u32, w: u32, h: u32) -> [u32; 3] {
    let mut counts = [0u32; 3];
    for_each_view(seed, 2, cameras, w, h, |rng, camera, reference, buffer| {
        for k in 0..objects {
            let object = random_object(rng, k);
            let tris: Vec<Vec3> = (0..object.triangle_count() as u32)
                .flat_map(|t| object.triangle(t))
                .collect();
            let frame = render(&object, camera);
            let visible = frame
                .depth
                .iter()
                .zip(&reference.depth)
                .any(|(&o, &d)| o.is_finite() && o < d);
            let by_triangles = buffer.test_triangles(&tris, camera);
            assert!(
                by_triangles || !visible,
                "seed {seed}: visible object {tris:?} culled from {camera:?}"
            );
            if !visible {
                let aabb = Aabb::from_points(tris.iter().copied());
                counts[0] += 1;
                counts[1] += u32::from(!buffer.test_box(&aabb, camera));
                counts[2] += u32::from(!by_triangles);
            }
        }
    });
    counts
}

#[test]
fn triangle_test_never_culls_an_exactly_visible_object() {
    let [hidden, by_box, by_triangles] = check_triangles_conservative(23, 6, 150, 160, 120);
    eprintln!("of {hidden} hidden objects, box test culls {by_box}, triangle test {by_triangles}");
    assert!(hidden > 300, "{hidden}");
    // Tighter than the box test, never looser (its pixels lie in the box's rectangle, at
    // depths no nearer than the box's nearest corner).
    assert!(by_triangles > by_box, "{by_triangles} <= {by_box}");
}

#[test]
fn triangle_test_never_culls_an_exactly_visible_object_odd_sizes() {
    let [hidden, by_box, by_triangles] = check_triangles_conservative(29, 6, 150, 157, 93);
    assert!(by_box <= by_triangles && by_triangles <= hidden);
}

#[test]
fn triangle_test_of_nothing_is_hidden() {
    let camera = random_camera(&mut SplitMix64::new(1), 32, 32);
    let buffer = OcclusionBuffer::new(32, 32);
    assert!(!buffer.test_triangles(&[], &camera));
    // A triangle behind the camera is not visible either; one in front of an empty buffer is.
    let back = camera.eye - camera.forward * 5.0;
    let front = camera.eye + camera.forward * 5.0;
    let tri = |c: Vec3| [c + camera.right, c + camera.up, c - camera.right];
    assert!(!buffer.test_triangles(&tri(back), &camera));
    assert!(buffer.test_triangles(&tri(front), &camera));
}
