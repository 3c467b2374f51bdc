// Depth pre-pass and occlusion-query boxes of the hardware-occlusion-query backend
// (occlusion_query/). One camera, the conventions of sightline_core::camera:
// view = (dot(p - eye, right), dot(p - eye, up), dot(p - eye, forward)),
// NDC x = view.x / (view.z tan_half_x), NDC y = view.y / (view.z tan_half_y) (wgpu's NDC +y is
// up and its framebuffer +y is down, so the screen mapping is exactly Camera::view_to_screen),
// and reversed-Z with an infinite far plane: depth = near / view.z, 1 at the near plane, 0 at
// infinity (clip z = near, clip w = view.z; Vulkan clips 0 <= z <= w, i.e. view.z >= near).

struct Camera {
    eye: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    forward: vec4<f32>,
    // (1 / tan_half_x, 1 / tan_half_y, near, 0)
    projection: vec4<f32>,
}

@group(0) @binding(0) var<uniform> camera: Camera;

fn clip_from_world(p: vec3<f32>) -> vec4<f32> {
    let d = p - camera.eye.xyz;
    let view = vec3<f32>(dot(d, camera.right.xyz), dot(d, camera.up.xyz), dot(d, camera.forward.xyz));
    return vec4<f32>(view.x * camera.projection.x, view.y * camera.projection.y, camera.projection.z, view.z);
}

// Occluder triangles: corners, moved by a per-draw translation (an instance attribute; zero
// for triangles given in world space).
@vertex
fn vs_depth(
    @location(0) position: vec3<f32>,
    @location(1) translation: vec3<f32>,
) -> @builtin(position) vec4<f32> {
    return clip_from_world(position + translation);
}

// A unit-cube corner (each coordinate 0 or 1) placed on a box instance. `select` rather than
// `mix` so that the corners are exactly the box's min and max coordinates.
@vertex
fn vs_box(
    @location(0) corner: vec3<f32>,
    @location(1) box_min: vec3<f32>,
    @location(2) box_max: vec3<f32>,
) -> @builtin(position) vec4<f32> {
    return clip_from_world(select(box_min, box_max, corner > vec3<f32>(0.5)));
}
