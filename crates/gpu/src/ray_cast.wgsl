// Closest-hit and any-hit ray casting over a BVH of WIDTH-wide nodes (ray_layout.rs), one ray
// per invocation, with a per-invocation stack, nearer children first; the watertight
// ray/triangle test of sightline-core (crates/core/src/trace/triangle.rs) with the same
// operations in the same order.
//
// Based on: Aila, Laine. Understanding the efficiency of ray traversal on GPUs. HPG 2009.
// Based on: Woop, Benthin, Wald. Watertight Ray/Triangle Intersection. JCGT 2(1), 2013.
// Based on: Ize. Robust BVH ray traversal. JCGT 2(2), 2013 (the far-distance slack).
//
// ray_cast.rs prepends the constants WIDTH, STACK, ROBUST_FAR and CULL_SLACK and appends one
// of the two versions of `exact_edges` and `divide` (f64 where the adapter has it).

const NODE_WORDS: u32 = 7u * WIDTH;
const EMPTY: u32 = 0xffffffffu;
const NONE: u32 = 0xffffffffu;
const INF_BITS: u32 = 0x7f800000u;
const F32_MAX: f32 = 3.40282347e38;
const DEAD: u32 = 512u;
const PARALLEL: u32 = 64u;

struct Params {
    // Rays in this chunk.
    count: u32,
    // Always 0. XOR-ed into every product that feeds a sum (`rounded`): the compiler cannot
    // know it is 0, so it must round the product to f32 first and cannot contract the product
    // and the sum into a fused multiply-add (Vulkan drivers may contract unless told not to,
    // and naga does not emit NoContraction). The CPU caster never fuses.
    zero: u32,
    pad0: u32,
    pad1: u32,
}

struct Ray {
    origin: vec3<f32>,
    t_min: f32,
    shear: vec3<f32>,
    t_max: f32,
    inv: vec3<f32>,
    flags: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> nodes: array<u32>;
@group(0) @binding(2) var<storage, read> tris: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> rays: array<Ray>;
@group(0) @binding(4) var<storage, read_write> hits: array<vec2<u32>>;

// Bit tests, so that no compiler assumption about NaN or infinity can change them.
fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & INF_BITS) != INF_BITS;
}

fn rounded(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) ^ params.zero);
}

// `t` moved up by the culling slack (`slack_up` of traverse.rs), saturating at F32_MAX.
fn slack_up(t: f32) -> f32 {
    return select(t + abs(t) * CULL_SLACK, F32_MAX, t > 1e38);
}

fn slack_down(t: f32) -> f32 {
    return select(t - abs(t) * CULL_SLACK, -F32_MAX, t < -1e38);
}

struct TriHit {
    hit: bool,
    t: f32,
}

// triangle.rs `intersect`, operation for operation.
fn intersect(r: Ray, k: vec3<u32>, i: u32) -> TriHit {
    var miss: TriHit;
    miss.hit = false;
    let a = tris[3u * i].xyz - r.origin;
    let b = tris[3u * i + 1u].xyz - r.origin;
    let c = tris[3u * i + 2u].xyz - r.origin;
    let ax = a[k.x] - rounded(r.shear.x * a[k.z]);
    let ay = a[k.y] - rounded(r.shear.y * a[k.z]);
    let bx = b[k.x] - rounded(r.shear.x * b[k.z]);
    let by = b[k.y] - rounded(r.shear.y * b[k.z]);
    let cx = c[k.x] - rounded(r.shear.x * c[k.z]);
    let cy = c[k.y] - rounded(r.shear.y * c[k.z]);
    var u = rounded(cx * by) - rounded(cy * bx);
    var v = rounded(ax * cy) - rounded(ay * cx);
    var w = rounded(bx * ay) - rounded(by * ax);
    if (u == 0.0 || v == 0.0 || w == 0.0) {
        let e = exact_edges(ax, ay, bx, by, cx, cy, vec3<f32>(u, v, w));
        u = e.x;
        v = e.y;
        w = e.z;
    }
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return miss;
    }
    let det = u + v + w;
    if (det == 0.0 || !finite(det)) {
        return miss;
    }
    let az = r.shear.z * a[k.z];
    let bz = r.shear.z * b[k.z];
    let cz = r.shear.z * c[k.z];
    let t_scaled = rounded(u * az) + rounded(v * bz) + rounded(w * cz);
    let t = divide(t_scaled, det);
    if (t >= r.t_min && t <= r.t_max && finite(t)) {
        return TriHit(true, t);
    }
    return miss;
}

// The closest hit (any_hit false) or the first hit found (any_hit true) of ray `index`, as
// (triangle id, t bits); (NONE, +inf bits) for a miss. traverse.rs `traverse`, step for step.
fn trace(index: u32, any_hit: bool) -> vec2<u32> {
    let no_hit = vec2<u32>(NONE, INF_BITS);
    let r = rays[index];
    if ((r.flags & DEAD) != 0u) {
        return no_hit;
    }
    let k = vec3<u32>(r.flags & 3u, (r.flags >> 2u) & 3u, (r.flags >> 4u) & 3u);
    let t_lo = slack_down(r.t_min);
    var t_far = slack_up(r.t_max);
    var best_t = F32_MAX;
    var best_id = NONE;
    var stack_word: array<u32, STACK>;
    var stack_t: array<f32, STACK>;
    var top = 0u;
    // The root, an inner node.
    var current = 0u;
    loop {
        let count = current & 15u;
        if (count > 0u) {
            let first = current >> 4u;
            for (var j = 0u; j < count; j++) {
                let h = intersect(r, k, first + j);
                if (h.hit) {
                    let id = bitcast<u32>(tris[3u * (first + j)].w);
                    if (any_hit) {
                        return vec2<u32>(id, bitcast<u32>(h.t));
                    }
                    // Ties go to the lower id, as in brute force.
                    if (h.t < best_t || (h.t == best_t && id < best_id)) {
                        best_t = h.t;
                        best_id = id;
                    }
                }
            }
            if (best_id != NONE) {
                t_far = slack_up(best_t);
            }
        } else {
            let base = (current >> 4u) * NODE_WORDS;
            let pushed = top;
            for (var lane = 0u; lane < WIDTH; lane++) {
                let link = nodes[base + 6u * WIDTH + lane];
                if (link == EMPTY) {
                    break;
                }
                var t0 = t_lo;
                var t1 = t_far;
                var inside = true;
                for (var axis = 0u; axis < 3u; axis++) {
                    let lo = bitcast<f32>(nodes[base + axis * WIDTH + lane]);
                    let hi = bitcast<f32>(nodes[base + (axis + 3u) * WIDTH + lane]);
                    let o = r.origin[axis];
                    if ((r.flags & (PARALLEL << axis)) != 0u) {
                        // Parallel to the slab: inside it or never in the box.
                        inside = inside && lo <= o && o <= hi;
                    } else {
                        let inv = r.inv[axis];
                        let near = select(lo, hi, inv < 0.0);
                        let far = select(hi, lo, inv < 0.0);
                        let tn = (near - o) * inv;
                        let tf = (far - o) * inv * ROBUST_FAR;
                        if (tn > t0) {
                            t0 = tn;
                        }
                        if (tf < t1) {
                            t1 = tf;
                        }
                    }
                }
                if (inside && t0 <= t1) {
                    // Insert, keeping this node's entries sorted far to near.
                    var j = top;
                    while (j > pushed && stack_t[j - 1u] < t0) {
                        stack_t[j] = stack_t[j - 1u];
                        stack_word[j] = stack_word[j - 1u];
                        j--;
                    }
                    stack_t[j] = t0;
                    stack_word[j] = link;
                    top++;
                }
            }
            if (top > pushed) {
                top--;
                current = stack_word[top];
                continue;
            }
        }
        // Pop the next node that is not farther than the closest hit so far.
        loop {
            if (top == 0u) {
                if (best_id == NONE) {
                    return no_hit;
                }
                return vec2<u32>(best_id, bitcast<u32>(best_t));
            }
            top--;
            if (stack_t[top] <= t_far) {
                current = stack_word[top];
                break;
            }
        }
    }
    // Not reached: every path through the loop returns or continues.
    return no_hit;
}

@compute @workgroup_size(64)
fn cast_closest(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = id.x;
    if (index < params.count) {
        hits[index] = trace(index, false);
    }
}

@compute @workgroup_size(64)
fn cast_any(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = id.x;
    if (index < params.count) {
        hits[index] = trace(index, true);
    }
}
