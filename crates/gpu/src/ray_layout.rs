//! What the GPU ray caster's shader (`ray_cast.wgsl`) reads: the BVH of `sightline-core` in
//! a flat word array, the triangles in leaf order, and rays prepared on the CPU for the
//! watertight test (the shear of Woop et al.) and the slab test (the inverse direction).
//!
//! Based on: Woop, Benthin, Wald. Watertight Ray/Triangle Intersection. JCGT 2(1), 2013
//! (the permutation and shear of the ray, prepared once per ray).
//! Based on: Aila, Laine. Understanding the efficiency of ray traversal on GPUs. HPG 2009 (the
//! children's boxes stored in the parent node, so one node fetch decides which to enter).
//!
//! # Node layout (width `W`, `7 W` 32-bit words)
//! The `W` child boxes as six rows of `W` lanes (min x, y, z, max x, y, z; `f32` bits), then one
//! word per child: an inner child is `index << 4`, a leaf is `first << 4 | count` (`count` in
//! 1..=8, `first` the position of its first triangle in leaf order), an unused slot is
//! [`EMPTY`]. Unused slots come after the used ones. The root is node 0.
//!
//! # Triangles
//! Three `vec4<f32>` per triangle in leaf order: the corners in `xyz`, the scene id's bits in the
//! first corner's `w`. 48 bytes a triangle.
//!
//! # Rays
//! [`GpuRay`], 48 bytes: origin, `t_min`, the shear `(sx, sy, sz)`, `t_max`, the inverse
//! direction and flags (the permutation `kx, ky, kz`, the axes the direction is parallel to,
//! unusable rays). The shear and the inverse are computed here, on the CPU, because WGSL
//! division is only accurate to 2.5 ulp: computed in the shader they would differ from the CPU
//! caster's bits, and so would the edge functions that decide which of two triangles sharing
//! an edge a ray hits. Every other operation of the test is a correctly rounded `+`, `-` or `*`.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use sightline_core::scene::Scene;
use sightline_core::trace::bvh::{FlatBvh, FlatLink};
use sightline_core::trace::triangle::ShearedRay;
use sightline_core::Ray;

use crate::device::GpuError;

/// An unused child slot.
pub(crate) const EMPTY: u32 = u32::MAX;
/// Flag: the ray can hit nothing (non-finite or zero direction or origin, empty or NaN range).
const DEAD: u32 = 1 << 9;
/// Flag of axis `a`: the direction's component `a` is zero (bit `6 + a`).
const PARALLEL: u32 = 1 << 6;
/// Node and first-triangle indices are stored above 4 bits of leaf count.
const MAX_INDEX: usize = 1 << 28;

/// The BVH in the shader's layout (see the module documentation).
pub(crate) struct GpuBvh {
    /// Children per node.
    pub(crate) width: usize,
    /// `7 * width` words per node.
    pub(crate) nodes: Vec<u32>,
    /// Three corners per triangle, leaf order, id bits in the first corner's `w`.
    pub(crate) triangles: Vec<[f32; 4]>,
    /// Traversal stack entries the tree needs (see [`stack_needed`]).
    pub(crate) stack_needed: usize,
}

impl GpuBvh {
    /// Builds the CPU caster's tree for `scene` with nodes of `width` children (2, 4 or 8) and
    /// lays it out for the shader. Errors when the indices do not fit the node words.
    pub(crate) fn new(scene: &Scene, width: usize) -> Result<Self, GpuError> {
        if !matches!(width, 2 | 4 | 8) {
            return Err(GpuError::UnsupportedWidth(width));
        }
        let flat = FlatBvh::build(scene, width);
        let node_count = flat.node_count();
        let ids = flat.triangles();
        if node_count >= MAX_INDEX || ids.len() >= MAX_INDEX {
            return Err(GpuError::SceneTooLarge {
                triangles: ids.len(),
                nodes: node_count,
            });
        }
        let mut nodes = vec![0u32; node_count * 7 * width];
        for (n, words) in nodes.chunks_exact_mut(7 * width).enumerate() {
            for (lane, child) in flat.node(n).iter().enumerate() {
                for a in 0..3 {
                    words[a * width + lane] = child.min[a].to_bits();
                    words[(a + 3) * width + lane] = child.max[a].to_bits();
                }
                words[6 * width + lane] = match child.link {
                    FlatLink::Empty => EMPTY,
                    FlatLink::Inner(i) => i << 4,
                    FlatLink::Leaf { first, count } => first << 4 | count,
                };
            }
        }
        let mut triangles = Vec::with_capacity(ids.len() * 3);
        for &id in ids {
            let t = scene.triangles[id as usize];
            // `FlatBvh` keeps only triangles whose indices are in range.
            let p = |i: usize| scene.positions[t[i] as usize];
            let (a, b, c) = (p(0), p(1), p(2));
            triangles.push([a.x, a.y, a.z, f32::from_bits(id)]);
            triangles.push([b.x, b.y, b.z, 0.0]);
            triangles.push([c.x, c.y, c.z, 0.0]);
        }
        Ok(Self {
            width,
            stack_needed: stack_needed(&flat),
            nodes,
            triangles,
        })
    }

    /// Number of nodes (0 for a scene with nothing to hit).
    pub(crate) fn node_count(&self) -> usize {
        self.nodes.len() / (7 * self.width)
    }
}

/// Stack entries the shader's traversal needs for `flat`: at an inner node it pushes every
/// entered child (then takes the nearest back off), on top of what the node's ancestors left
/// there, at most their child counts less one each. The maximum over inner nodes of that sum
/// plus the node's own child count.
fn stack_needed(flat: &FlatBvh) -> usize {
    if flat.node_count() == 0 {
        return 0;
    }
    let used = |n: usize| {
        flat.node(n)
            .iter()
            .filter(|c| c.link != FlatLink::Empty)
            .count()
    };
    let mut needed = 0;
    // (node, entries its ancestors may leave on the stack)
    let mut todo = vec![(0usize, 0usize)];
    while let Some((n, below)) = todo.pop() {
        let kids = used(n);
        needed = needed.max(below + kids);
        for c in flat.node(n) {
            if let FlatLink::Inner(i) = c.link {
                todo.push((i as usize, below + kids - 1));
            }
        }
    }
    needed
}

/// A ray as the shader reads it (see the module documentation); `vec3` members are 16-byte
/// aligned in WGSL, so each is followed by a scalar.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub(crate) struct GpuRay {
    origin: [f32; 3],
    t_min: f32,
    shear: [f32; 3],
    t_max: f32,
    inv: [f32; 3],
    flags: u32,
}

/// False for a ray the CPU caster never lets hit anything: a non-finite or zero direction, a
/// non-finite origin, an empty or NaN range, or a range that lies wholly at an infinity. Both
/// GPU casters mark such rays dead before their shader sees them (shader compilers may assume
/// no NaN or infinity, and Vulkan's ray queries require a finite range).
pub(crate) fn can_hit(ray: &Ray) -> bool {
    ray.origin.is_finite()
        && ray.dir.is_finite()
        && ray.dir != Vec3::ZERO
        && ray.t_min <= ray.t_max
        && ray.t_min < f32::INFINITY
        && ray.t_max > f32::NEG_INFINITY
}

impl GpuRay {
    /// The ray prepared as the CPU caster prepares it (`ShearedRay::new` and `BoxRay::new` of
    /// `sightline-core`), with the same operations, so the shader starts from the same bits.
    /// Infinite range ends become `±f32::MAX` (the same finite hits are accepted) and a ray
    /// the CPU caster never lets hit anything is marked dead.
    pub(crate) fn new(ray: &Ray) -> Self {
        let d = ray.dir;
        if !can_hit(ray) {
            return Self {
                flags: DEAD,
                ..Self::zeroed()
            };
        }
        // The CPU caster's permutation and shear, the same bits (the direction is not zero).
        let sheared = ShearedRay::new(ray);
        let [kx, ky, kz] = sheared.axes();
        let shear = sheared.shear();
        let mut flags = (kx | ky << 2 | kz << 4) as u32;
        let mut inv = [0.0; 3];
        for axis in 0..3 {
            if d[axis] == 0.0 {
                flags |= PARALLEL << axis;
            } else {
                inv[axis] = 1.0 / d[axis];
            }
        }
        Self {
            origin: ray.origin.to_array(),
            t_min: ray.t_min.max(-f32::MAX),
            shear,
            t_max: ray.t_max.min(f32::MAX),
            inv,
            flags,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;

    fn boxes(n: usize) -> Scene {
        let mut b = SceneBuilder::new("boxes");
        for i in 0..n {
            let p = Vec3::new(i as f32 * 3.0, (i % 5) as f32, 0.0);
            b.add_box(p, p + Vec3::ONE);
        }
        b.finish()
    }

    #[test]
    fn empty_scene_has_no_nodes_and_needs_no_stack() {
        let bvh = GpuBvh::new(&Scene::default(), 4).unwrap();
        assert_eq!(bvh.node_count(), 0);
        assert_eq!(bvh.stack_needed, 0);
        assert!(bvh.triangles.is_empty());
    }

    #[test]
    fn odd_width_is_an_error() {
        assert!(matches!(
            GpuBvh::new(&boxes(1), 3),
            Err(GpuError::UnsupportedWidth(3))
        ));
    }

    #[test]
    fn every_triangle_once_with_its_id() {
        let scene = boxes(50);
        let bvh = GpuBvh::new(&scene, 2).unwrap();
        let mut ids: Vec<u32> = bvh.triangles.chunks(3).map(|c| c[0][3].to_bits()).collect();
        ids.sort_unstable();
        assert_eq!(ids, (0..scene.triangles.len() as u32).collect::<Vec<_>>());
    }

    #[test]
    fn binary_stack_need_is_at_most_depth_plus_one() {
        // A binary tree over n triangles (leaves of up to 8) pushes one entry per level.
        let bvh = GpuBvh::new(&boxes(500), 2).unwrap();
        assert!(bvh.stack_needed >= 2);
        assert!(bvh.stack_needed <= 64, "{}", bvh.stack_needed);
    }

    #[test]
    fn dead_rays() {
        let o = Vec3::ZERO;
        for ray in [
            Ray::new(o, Vec3::ZERO),
            Ray::new(Vec3::splat(f32::NAN), Vec3::X),
            Ray::new(o, Vec3::new(f32::NAN, 0.0, 1.0)),
            Ray::new(o, Vec3::X).with_range(2.0, 1.0),
            Ray::new(o, Vec3::X).with_range(f32::NAN, 1.0),
            Ray::new(o, Vec3::X).with_range(f32::INFINITY, f32::INFINITY),
        ] {
            assert_eq!(GpuRay::new(&ray).flags, DEAD, "{ray:?}");
        }
    }

    #[test]
    fn axis_ray_is_parallel_to_two_axes() {
        let r = GpuRay::new(&Ray::new(Vec3::ZERO, Vec3::NEG_Y));
        assert_eq!(r.flags & DEAD, 0);
        assert_eq!((r.flags >> 4) & 3, 1, "kz is y");
        assert_eq!(r.flags & (7 * PARALLEL), PARALLEL | PARALLEL << 2);
        assert_eq!(r.t_max, f32::MAX);
        assert_eq!(r.inv[1], -1.0);
    }
}
