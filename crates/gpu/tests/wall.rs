//! A wall at `z = -5` in front of a camera at the origin looking down `-z`.

use glam::Vec3;
use sightline_core::{Aabb, Camera};
use sightline_cull::OcclusionBackend;
use sightline_gpu::QueryOutcome;

use super::gpu;

fn camera() -> Camera {
    Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 128, 96, 0.1).unwrap()
}

/// Two triangles, 100 x 100 m at `z`.
fn wall(z: f32) -> Vec<Vec3> {
    let (a, b, c, d) = (
        Vec3::new(-50.0, -50.0, z),
        Vec3::new(50.0, -50.0, z),
        Vec3::new(50.0, 50.0, z),
        Vec3::new(-50.0, 50.0, z),
    );
    vec![a, b, c, a, c, d]
}

fn behind() -> Aabb {
    Aabb::new(Vec3::new(-1.0, -1.0, -12.0), Vec3::new(1.0, 1.0, -10.0))
}

fn before() -> Aabb {
    Aabb::new(Vec3::new(-1.0, -1.0, -4.0), Vec3::new(1.0, 1.0, -3.0))
}

#[test]
fn box_behind_wall_has_no_samples_box_in_front_has_samples() {
    let mut gpu = gpu();
    gpu.begin_frame(&camera());
    gpu.draw_depth(&wall(-5.0));
    gpu.query(1, &behind());
    gpu.query(2, &before());
    let answers = gpu.finish_frame().unwrap().to_vec();
    assert_eq!(answers.len(), 2);
    assert_eq!(answers[0], (1, QueryOutcome::Samples(0)));
    let QueryOutcome::Samples(n) = answers[1].1 else {
        panic!("{answers:?}");
    };
    // The front box spans about 2 / (2 * 3 * tan 30°) of the image height: thousands of
    // samples, not a sliver.
    assert!(n > 1000, "{n} samples");
    let mut results = Vec::new();
    gpu.take_results(&mut results);
    assert_eq!(results, vec![(1, false), (2, true)]);
}

#[test]
fn without_occluders_both_boxes_are_visible() {
    let mut gpu = gpu();
    gpu.begin_frame(&camera());
    gpu.query(1, &behind());
    gpu.query(2, &before());
    let mut results = Vec::new();
    gpu.take_results(&mut results);
    assert_eq!(results, vec![(1, true), (2, true)]);
}

#[test]
fn query_order_matters_occluders_after_a_query_do_not_hide_it() {
    // The thesis interleaves the depth pre-pass with queries in traversal order: a query sees
    // only the depth drawn before it.
    let mut gpu = gpu();
    gpu.begin_frame(&camera());
    gpu.query(1, &behind());
    gpu.draw_depth(&wall(-5.0));
    gpu.query(2, &behind());
    let mut results = Vec::new();
    gpu.take_results(&mut results);
    assert_eq!(results, vec![(1, true), (2, false)]);
}

#[test]
fn depth_survives_a_mid_frame_readback() {
    // `latency = 0` (stop and wait) reads back after every query; later queries of the frame
    // still see the occluders drawn before the earlier readback.
    let mut gpu = gpu();
    gpu.begin_frame(&camera());
    gpu.draw_depth(&wall(-5.0));
    gpu.query(1, &before());
    let mut results = Vec::new();
    gpu.take_results(&mut results);
    gpu.query(2, &behind());
    gpu.take_results(&mut results);
    assert_eq!(results, vec![(1, true), (2, false)]);
    assert_eq!(gpu.stats().submissions, 2);
}

#[test]
fn frames_start_with_a_cleared_depth_buffer() {
    let mut gpu = gpu();
    let mut results = Vec::new();
    gpu.begin_frame(&camera());
    gpu.draw_depth(&wall(-5.0));
    gpu.query(1, &behind());
    gpu.take_results(&mut results);
    gpu.begin_frame(&camera());
    gpu.query(2, &behind());
    gpu.take_results(&mut results);
    assert_eq!(results, vec![(1, false), (2, true)]);
}

#[test]
fn boxes_at_the_near_plane_are_answered_on_the_cpu() {
    let mut gpu = gpu();
    gpu.begin_frame(&camera());
    gpu.draw_depth(&wall(-5.0));
    // Around the eye: visible (the camera is inside it).
    gpu.query(1, &Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0)));
    // Behind the camera: hidden.
    gpu.query(
        2,
        &Aabb::new(Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, 1.0, 3.0)),
    );
    let answers = gpu.finish_frame().unwrap().to_vec();
    assert_eq!(
        answers,
        vec![
            (1, QueryOutcome::NearPlane),
            (2, QueryOutcome::BehindCamera)
        ]
    );
    assert_eq!(gpu.stats().gpu_queries, 0);
    assert_eq!(gpu.stats().cpu_answers, 2);
}

#[test]
fn empty_frame_has_no_results() {
    let mut gpu = gpu();
    let mut results = Vec::new();
    gpu.take_results(&mut results);
    gpu.begin_frame(&camera());
    gpu.draw_depth(&[]);
    gpu.take_results(&mut results);
    assert!(results.is_empty());
    assert_eq!(gpu.stats().submissions, 0);
}

#[test]
fn query_before_any_frame_is_visible() {
    let mut gpu = gpu();
    gpu.query(3, &behind());
    let mut results = Vec::new();
    gpu.take_results(&mut results);
    assert_eq!(results, vec![(3, true)]);
}

#[test]
fn more_queries_than_one_query_set_holds() {
    // wgpu caps a query set at 4096 queries; the backend chains render passes.
    let n = wgpu::QUERY_SET_MAX_QUERIES + 904;
    let mut gpu = gpu();
    gpu.begin_frame(&camera());
    gpu.draw_depth(&wall(-5.0));
    let (visible, occluded) = (before(), behind());
    for i in 0..n {
        gpu.query(i, if i % 3 == 0 { &visible } else { &occluded });
    }
    let mut results = Vec::new();
    gpu.take_results(&mut results);
    assert_eq!(results.len(), n as usize);
    for (i, &(tag, visible)) in results.iter().enumerate() {
        assert_eq!(tag, i as u32);
        assert_eq!(visible, i % 3 == 0, "query {i}");
    }
}

#[test]
fn uploaded_mesh_occludes_where_it_is_translated_to() {
    // The wall uploaded once at z = 0, drawn at z = -5 (occludes) and at z = -20 (behind both).
    let mut gpu = gpu();
    let mesh = gpu.upload_mesh(&wall(0.0));
    let mut results = Vec::new();
    for (frame, z) in [(0u32, -5.0), (1, -20.0)] {
        gpu.begin_frame(&camera());
        gpu.draw_mesh(mesh, Vec3::new(0.0, 0.0, z)).unwrap();
        gpu.query(2 * frame, &behind());
        gpu.query(2 * frame + 1, &before());
        gpu.take_results(&mut results);
    }
    assert_eq!(results, vec![(0, false), (1, true), (2, true), (3, true)]);
}

#[test]
fn meshes_and_triangles_interleave_in_order() {
    let mut gpu = gpu();
    let far_wall = gpu.upload_mesh(&wall(-30.0));
    gpu.begin_frame(&camera());
    gpu.draw_mesh(far_wall, Vec3::ZERO).unwrap();
    gpu.query(0, &behind());
    gpu.draw_depth(&wall(-5.0));
    gpu.query(1, &behind());
    let mut results = Vec::new();
    gpu.take_results(&mut results);
    assert_eq!(results, vec![(0, true), (1, false)]);
}

#[test]
fn unknown_mesh_is_an_error() {
    let mut other = gpu();
    let foreign = other.upload_mesh(&wall(-5.0));
    let mut gpu = gpu();
    gpu.begin_frame(&camera());
    assert!(matches!(
        gpu.draw_mesh(foreign, Vec3::ZERO),
        Err(sightline_gpu::GpuError::UnknownMesh(0))
    ));
}

#[test]
fn empty_mesh_draws_nothing() {
    let mut gpu = gpu();
    let empty = gpu.upload_mesh(&[]);
    gpu.begin_frame(&camera());
    gpu.draw_mesh(empty, Vec3::ZERO).unwrap();
    gpu.query(0, &behind());
    let mut results = Vec::new();
    gpu.take_results(&mut results);
    assert_eq!(results, vec![(0, true)]);
}

#[test]
fn occluders_recorded_before_an_empty_readback_are_kept() {
    // A readback with nothing to answer must not drop occluders a later query needs.
    let mut gpu = gpu();
    let mut results = Vec::new();
    gpu.begin_frame(&camera());
    gpu.draw_depth(&wall(-5.0));
    gpu.take_results(&mut results);
    gpu.query(0, &behind());
    gpu.take_results(&mut results);
    assert_eq!(results, vec![(0, false)]);
}
