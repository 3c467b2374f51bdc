// Closest-hit and any-hit ray casting with hardware ray queries (Vulkan VK_KHR_ray_query):
// one ray per invocation against the scene's acceleration structure, one BLAS of opaque
// triangles in the scene's id order under one TLAS instance with the identity transform, so
// the committed intersection's primitive index is the scene's triangle id.
//
// Based on: the Vulkan specification, VK_KHR_ray_query and section "Ray Traversal" (the
// watertight ray/triangle intersection it requires of implementations).
//
// ray_query.rs prepares the rays on the CPU: rays that can hit nothing are marked dead (never
// passed to rayQueryInitialize, whose arguments must be finite, with 0 <= t_min <= t_max), and
// a ray with a negative t_min starts where it enters the scene's box, with that start's `t`
// in `t_offset`, added back to the hit's `t` here.

enable wgpu_ray_query;

const NONE: u32 = 0xffffffffu;
const INF_BITS: u32 = 0x7f800000u;

struct Params {
    // Rays in this chunk.
    count: u32,
    // Unused here (the compute caster's shader reads it; both share the block).
    zero: u32,
    pad0: u32,
    pad1: u32,
}

struct Ray {
    origin: vec3<f32>,
    t_min: f32,
    dir: vec3<f32>,
    t_max: f32,
    // Added to the hit's `t` (the `t` of `origin` on the caller's ray; 0 for most rays).
    t_offset: f32,
    // 0: the ray can hit nothing.
    live: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var scene: acceleration_structure;
@group(0) @binding(2) var<storage, read> rays: array<Ray>;
@group(0) @binding(3) var<storage, read_write> hits: array<vec2<u32>>;

// The closest hit of ray `index` (flags without TERMINATE_ON_FIRST_HIT) or the first one the
// traversal finds (with it), as (triangle id, t bits); (NONE, +inf bits) for a miss.
fn trace(index: u32, flags: u32) -> vec2<u32> {
    let r = rays[index];
    if (r.live == 0u) {
        return vec2<u32>(NONE, INF_BITS);
    }
    var rq: ray_query;
    rayQueryInitialize(&rq, scene, RayDesc(flags, 0xffu, r.t_min, r.t_max, r.origin, r.dir));
    // Every triangle is opaque: the traversal commits hits itself and has no candidates to
    // hand back, so this loop runs once.
    while (rayQueryProceed(&rq)) {
    }
    let hit = rayQueryGetCommittedIntersection(&rq);
    if (hit.kind != RAY_QUERY_INTERSECTION_TRIANGLE) {
        return vec2<u32>(NONE, INF_BITS);
    }
    return vec2<u32>(hit.primitive_index, bitcast<u32>(hit.t + r.t_offset));
}

// Both faces count (no culling flag); FORCE_OPAQUE as the geometry is.
@compute @workgroup_size(64)
fn cast_closest(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = id.x;
    if (index < params.count) {
        hits[index] = trace(index, RAY_FLAG_FORCE_OPAQUE);
    }
}

@compute @workgroup_size(64)
fn cast_any(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = id.x;
    if (index < params.count) {
        hits[index] = trace(index, RAY_FLAG_FORCE_OPAQUE | RAY_FLAG_TERMINATE_ON_FIRST_HIT);
    }
}
