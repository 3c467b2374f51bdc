// The viewer's passes (renderer/). Camera conventions of sightline_core::camera, as in
// sightline-gpu's occlusion_query.wgsl: view = (dot(d, right), dot(d, up), dot(d, forward)),
// NDC = (view.x / (view.z tan_half_x), view.y / (view.z tan_half_y)), reversed-Z with an
// infinite far plane (depth = near / view.z; Vulkan clips view.z < near). The overview's
// orthographic camera (projection.w = 1) maps view x, y by 1 / half extents and has a far plane.

struct Camera {
    eye: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    forward: vec4<f32>,
    // (1 / tan_half_x, 1 / tan_half_y, near, 0), orthographic (1 / half_w, 1 / half_h, near, 1)
    projection: vec4<f32>,
    // (width, height, flags, far); flags: bit 0 x-ray, bit 1 mark popping pixels; far: ortho only
    screen: vec4<f32>,
}

@group(0) @binding(0) var<uniform> camera: Camera;

fn is_orthographic() -> bool {
    return camera.projection.w > 0.5;
}

fn clip_from_world(p: vec3<f32>) -> vec4<f32> {
    let d = p - camera.eye.xyz;
    let view = vec3<f32>(dot(d, camera.right.xyz), dot(d, camera.up.xyz), dot(d, camera.forward.xyz));
    if (is_orthographic()) {
        // The overview: reversed depth, linear from 1 at the near plane to 0 at the far one.
        let near = camera.projection.z;
        let far = camera.screen.w;
        let depth = (far - view.z) / (far - near);
        return vec4<f32>(view.x * camera.projection.x, view.y * camera.projection.y, depth, 1.0);
    }
    return vec4<f32>(view.x * camera.projection.x, view.y * camera.projection.y, camera.projection.z, view.z);
}

// ---- Triangle-id pass: R32Uint target, id + 1 per pixel (0 = background). -----------------
// Vertices are expanded per triangle (3 per triangle, in id order), so in both the full
// (non-indexed) and the culled (indexed) draw the triangle id is vertex_index / 3.

struct IdVertex {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) id: u32,
}

@vertex
fn vs_id(@builtin(vertex_index) index: u32, @location(0) position: vec3<f32>) -> IdVertex {
    var out: IdVertex;
    out.position = clip_from_world(position);
    out.id = index / 3u + 1u;
    return out;
}

@fragment
fn fs_id(in: IdVertex) -> @location(0) u32 {
    return in.id;
}

// ---- Popping: count pixels whose id differs between the full and the culled image. --------

@group(0) @binding(1) var ids_full: texture_2d<u32>;
@group(0) @binding(2) var ids_culled: texture_2d<u32>;
@group(0) @binding(3) var<storage, read_write> counters: array<atomic<u32>, 4>;

@compute @workgroup_size(8, 8)
fn cs_compare(@builtin(global_invocation_id) gid: vec3<u32>) {
    let size = textureDimensions(ids_full);
    if (gid.x >= size.x || gid.y >= size.y) {
        return;
    }
    let full = textureLoad(ids_full, vec2<i32>(gid.xy), 0).x;
    let culled = textureLoad(ids_culled, vec2<i32>(gid.xy), 0).x;
    if (full != culled) {
        atomicAdd(&counters[0], 1u);
    }
    if (full != 0u) {
        atomicAdd(&counters[1], 1u);
    }
}

// ---- Resolve: flat Lambert shading of the id image into the colour target. -----------------

// Per triangle: (unit normal, object id as bits).
@group(1) @binding(0) var<storage, read> triangles: array<vec4<f32>>;
// Bit t set = triangle t drawn by the current method.
@group(1) @binding(1) var<storage, read> drawn: array<u32>;

struct FullscreenVertex {
    @builtin(position) position: vec4<f32>,
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    // One triangle covering the screen.
    let x = f32((index << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(index & 2u) * 2.0 - 1.0;
    var out: FullscreenVertex;
    out.position = vec4<f32>(x, y, 0.0, 1.0);
    return out;
}

fn hash(x: u32) -> u32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    return (h >> 22u) ^ h;
}

fn object_colour(object: u32) -> vec3<f32> {
    let h = hash(object);
    let c = vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0;
    return 0.45 + 0.45 * c;
}

fn is_drawn(t: u32) -> bool {
    return (drawn[t >> 5u] & (1u << (t & 31u))) != 0u;
}

@fragment
fn fs_resolve(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(in.position.xy);
    let full = textureLoad(ids_full, pixel, 0).x;
    let culled = textureLoad(ids_culled, pixel, 0).x;
    let flags = u32(camera.screen.z);
    let xray = (flags & 1u) != 0u;
    let mark_popping = (flags & 2u) != 0u;
    var id = culled;
    if (xray) {
        id = full;
    }
    if (mark_popping && !xray && full != culled) {
        return vec4<f32>(1.0, 0.0, 1.0, 1.0);
    }
    // The ray through the pixel centre (Camera::screen_ray).
    let s = in.position.xy / camera.screen.xy;
    let u = (2.0 * s.x - 1.0) / camera.projection.x;
    let v = (1.0 - 2.0 * s.y) / camera.projection.y;
    var dir = normalize(camera.forward.xyz + camera.right.xyz * u + camera.up.xyz * v);
    if (is_orthographic()) {
        dir = camera.forward.xyz;
    }
    if (id == 0u) {
        // Background: a dim gradient, lighter towards the top of the image.
        let g = 0.12 + 0.10 * (1.0 - s.y);
        return vec4<f32>(g, g, g * 1.15, 1.0);
    }
    let t = id - 1u;
    let info = triangles[t];
    var n = info.xyz;
    // Double-sided: the face towards the eye.
    if (dot(n, dir) > 0.0) {
        n = -n;
    }
    let sun = normalize(vec3<f32>(0.3, 0.5, 0.8));
    let sun2 = normalize(vec3<f32>(0.3, 0.8, 0.5));
    let lambert = 0.35 * max(dot(n, -dir), 0.0) + 0.4 * max(max(dot(n, sun), dot(n, sun2)), 0.0);
    var colour = object_colour(bitcast<u32>(info.w)) * (0.25 + lambert);
    if (xray && !is_drawn(t)) {
        colour = mix(colour, vec3<f32>(1.0, 0.1, 0.1), 0.6);
    }
    return vec4<f32>(colour, 1.0);
}

// ---- Guides: coloured lines and filled quads (cells, frustum, marker), depth-tested against
// the shown image. -----------------------------------------------------------------------------

struct LineVertex {
    @builtin(position) position: vec4<f32>,
    @location(0) colour: vec4<f32>,
}

@vertex
fn vs_line(@location(0) position: vec3<f32>, @location(1) colour: vec4<f32>) -> LineVertex {
    var out: LineVertex;
    out.position = clip_from_world(position);
    out.colour = colour;
    return out;
}

@fragment
fn fs_line(in: LineVertex) -> @location(0) vec4<f32> {
    return in.colour;
}
