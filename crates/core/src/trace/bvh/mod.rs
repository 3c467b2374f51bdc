//! Our default ray caster: a binned-SAH bounding volume hierarchy over the scene's triangles
//! with spatial splits (a large triangle may be referenced from several leaves, each holding
//! the box of its part there), built in parallel as a binary tree, collapsed into an 8-wide
//! tree whose eight child boxes are tested at once with AVX2 (and FMA) when the CPU has them,
//! else into a 4-wide tree tested with SSE, and traversed with a stack, nearer children first.
//!
//! Based on: Wald. On fast construction of SAH-based bounding volume hierarchies. 2007
//! (binned SAH build, 16 bins (8 for nodes of up to 64 references), bins keep bounds and
//! centroid bounds so children need no extra pass).
//! Based on: Stich, Friedrich, Dietrich. Spatial splits in bounding volume hierarchies. HPG
//! 2009 (`spatial.rs`).
//! Based on: Wald, Benthin, Boulos. Getting rid of packets: efficient SIMD single-ray traversal
//! using multi-branching BVHs. IRT 2008 (the 4-wide tree, collapsed from the binary one).
//! Based on: Ernst, Greiner. Multi bounding volume hierarchies. IRT 2008.
//! Based on: Fuetterling, Lojewski, Pfreundt, Ebert. Efficient Ray Tracing Kernels for Modern
//! CPU Architectures. JCGT 4(5), 2015 (the 8-wide tree).
//! Based on: Ize. Robust BVH ray traversal. JCGT 2(2), 2013 (the `1 + 2 gamma(3)` slab slack).
//! Based on: Woop, Benthin, Wald. Watertight ray/triangle intersection. JCGT 2(1), 2013
//! (the leaf test, [`super::triangle::intersect`]).
//!
//! # Files
//! One file per operation, as Embree's `kernels/bvh` and parry's `partitioning/bvh` split
//! theirs: `build.rs` (the binary SAH tree), `refs.rs` (its references, bins and SAH
//! sweep), `spatial.rs` (its spatial splits), `collapse.rs` (binary to wide nodes),
//! `traverse.rs` (the one traversal loop, closest-hit and any-hit), `node.rs` (the
//! `WideNode` trait both are generic over), one file per node layout (`node4.rs`,
//! `node8.rs`: the node, its child encoding and its SIMD box test) and `slab.rs` (the box test
//! every layout's kernel equals). `input.rs` says which triangles the tree holds and their boxes.
//! This file picks the layout and drives the rest.
//! `huge.rs` moves the finished arrays onto transparent huge pages (TLB misses bound incoherent
//! rays on big scenes otherwise); `stats.rs` counts what a traversal visits, for tuning.
//! `flatten.rs` hands the same tree, collapsed to any width, to engines outside this crate
//! (the GPU ray caster of `sightline-gpu`) as plain arrays ([`FlatBvh`]).
//!
//! # Layout
//! 4-wide nodes are 128 bytes on two cache lines: the four child boxes as six rows of four
//! lanes (min x, y, z, max x, y, z), then per child its node index or first packet, and its
//! packet count (0 for an inner child). 8-wide nodes are 224 bytes: eight lanes per row, and
//! index and packet count packed into one `u32` per child (`node8.rs`). Triangles are copied
//! in leaf order, four to a 160-byte packet (`Tri4`: corners as rows of four lanes, and the
//! scene ids), so a leaf is one contiguous run of packets tested four triangles at a time, and
//! the scene is not touched while tracing.
//!
//! # Memory
//! Per triangle that is kept (degenerate ones are dropped), with 8-wide nodes: 42 to 58 bytes of
//! packets (3.4 to 3.8 references per packet: the SAH costs leaves by packet lanes; 1.02 to 1.16
//! references per triangle, where spatial splits reference a triangle from several leaves, at most
//! 1 + `build::SPLIT_BUDGET` = 1.2) plus 12 to 17 bytes of nodes: 59 bytes per triangle on the
//! Stanford bunny (1.01 references per triangle), 65 on the 1M-triangle procedural city and on
//! munich, 67 to 73 on the Quake maps (czest3ctf 71, 1.16) ([`Bvh::memory_bytes`]; without spatial
//! splits, [`Bvh::build_without_splits`], 57 to 63). The build holds 24-byte boxes, then room
//! for 1.2 references of 48 bytes and 4-byte ids per triangle and a binary node array of 64
//! bytes per reference of room. Measured peak (the process's `VmHWM` over one build, less the
//! scene, the 1M-triangle city on one thread, 2026-12-07): about 200 bytes per triangle with
//! spatial splits and 137 without, i.e. about 2 GB for 10M triangles.
//!
//! # Exactness
//! Rays with a finite inverse direction (almost all) take a cheaper slab test on the bits of the
//! distances as integers, which enters every box the float test enters (`slab.rs`). Leaves use the
//! same watertight test as [`super::BruteForce`] (four lanes at a time with the same bits, see
//! `tri4.rs`) and ties in `t` go to the lower triangle id, so hits equal brute force bit for bit. A
//! triangle split by spatial splits is tested in each leaf that holds a part of it, with the same
//! result each time, and the boxes of its parts together hold every point of it (`spatial.rs`
//! widens them around the points where its edges cross a plane, which floats round), so no hit is
//! lost. Box tests are only ever made more conservative (Ize's slack on the far distance, a
//! relative slack on the culling distance) so that a box whose triangle the leaf test would accept
//! is never culled by rounding.

mod build;
mod collapse;
mod flatten;
mod huge;
mod input;
mod node;
mod node4;
mod node8;
mod refs;
mod slab;
mod spatial;
pub mod stats;
#[cfg(test)]
mod tests;
mod traverse;

use glam::{Vec3, Vec3A};
use rayon::prelude::*;

use crate::geometry::{Hit, Ray};
use crate::scene::Scene;

use super::ray_caster::RayCaster;
use super::tri4::Tri4;
use collapse::collapse;
pub use flatten::{FlatBvh, FlatChild, FlatLink};
use huge::onto_huge_pages;
pub use input::hittable_corners;
use input::{corners, triangle_boxes};
use node::{assert_children_in_range, Tree, WideNode};
use node4::Node4;
use node8::Node8;

/// Rays per `rayon` task in [`Bvh::cast`].
const RAYS_PER_TASK: usize = 64;

/// A bounding volume hierarchy over a scene's triangles: the default [`RayCaster`].
///
/// Owns a copy of the triangles it needs, so it does not borrow the scene.
///
/// ```
/// use glam::{Vec3, Vec3A};
/// use sightline_core::scene::SceneBuilder;
/// use sightline_core::trace::{Bvh, RayCaster};
/// use sightline_core::Ray;
///
/// let mut b = SceneBuilder::new("one box");
/// b.add_box(Vec3::splat(1.0), Vec3::splat(2.0));
/// let bvh = Bvh::build(&b.finish());
/// let hit = bvh.cast_one(&Ray::new(Vec3::new(0.0, 1.5, 1.5), Vec3::X));
/// assert_eq!(hit.t, 1.0);
/// ```
#[derive(Debug)]
pub struct Bvh {
    /// The wide nodes, the root first (empty when `packets` is).
    nodes: Nodes,
    /// Triangles in leaf order, four to a packet; a leaf is a run of packets.
    packets: Vec<Tri4>,
    /// Triangles held (the packets' lanes less the padding).
    triangle_count: usize,
}

/// The node array, in the one layout this BVH was built with.
#[derive(Debug)]
enum Nodes {
    Four(Vec<Node4>),
    /// Only built where [`Node8::supported`] (AVX2 and FMA on x86_64).
    Eight(Vec<Node8>),
}

/// Node width: 8 (AVX2 box tests) where the CPU has AVX2 and FMA, else 4 (SSE or scalar).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Width {
    Four,
    Eight,
}

impl Width {
    /// The widest width this CPU traverses with SIMD.
    fn widest() -> Self {
        #[cfg(target_arch = "x86_64")]
        if Node8::supported() {
            return Width::Eight;
        }
        Width::Four
    }
}

impl Bvh {
    /// Builds the BVH for `scene`. Triangles with an index out of range, a non-finite corner
    /// or zero area are left out: the leaf test would never hit them.
    pub fn build(scene: &Scene) -> Self {
        Self::build_with(scene, Width::widest(), true)
    }

    /// [`Bvh::build`] without spatial splits: each triangle in one leaf. It builds in about
    /// half the time and takes 11-15 % less memory on the shared scenes, for rays up
    /// to a fifth slower among large triangles (Quake maps; the same on scanned models), so
    /// it suits a tree rebuilt often for few rays.
    pub fn build_without_splits(scene: &Scene) -> Self {
        Self::build_with(scene, Width::widest(), false)
    }

    /// [`Bvh::build`] with nodes of the given width, and spatial splits where `spatial`.
    fn build_with(scene: &Scene, width: Width, spatial: bool) -> Self {
        // Only usable triangles have references, so their corners are in range.
        let simd_corners = |id: u32| {
            corners(scene, &scene.triangles[id as usize])
                .unwrap_or_default()
                .map(Vec3A::from)
        };
        let splits: Option<refs::Corners> = spatial.then_some(&simd_corners);
        let tree = build::binary_tree(&triangle_boxes(scene), splits);
        let Some(tree) = tree else {
            let nodes = match width {
                Width::Four => Nodes::Four(Vec::new()),
                Width::Eight => Nodes::Eight(Vec::new()),
            };
            return Self {
                nodes,
                packets: Vec::new(),
                triangle_count: 0,
            };
        };
        let ids = &tree.ids;
        let mut packets = Vec::with_capacity(ids.len() / 2);
        let mut pack = |first: u32, count: u32| {
            let start = packets.len() as u32;
            let leaf = &ids[first as usize..(first + count) as usize];
            for chunk in leaf.chunks(4) {
                let mut tris = [([Vec3::ZERO; 3], 0); 4];
                for (slot, &id) in tris.iter_mut().zip(chunk) {
                    let c = corners(scene, &scene.triangles[id as usize]).unwrap_or_default();
                    *slot = (c, id);
                }
                packets.push(Tri4::new(&tris[..chunk.len()]));
            }
            (start, packets.len() as u32 - start)
        };
        let mut nodes = match width {
            Width::Four => Nodes::Four(collapse(&tree.root, &tree.pairs, &mut pack)),
            Width::Eight => {
                // `RayCaster::cast` relies on this for its AVX2 calls.
                assert!(Node8::supported(), "8-wide nodes need AVX2 and FMA");
                Nodes::Eight(collapse(&tree.root, &tree.pairs, &mut pack))
            }
        };
        drop(tree.pairs);
        // The collapse reserves for the worst case; the copy drops the spare capacity.
        nodes = match nodes {
            Nodes::Four(n) => Nodes::Four(onto_huge_pages(n)),
            Nodes::Eight(n) => Nodes::Eight(onto_huge_pages(n)),
        };
        let packets = onto_huge_pages(packets);
        match &nodes {
            Nodes::Four(n) => assert_children_in_range(n, packets.len()),
            Nodes::Eight(n) => assert_children_in_range(n, packets.len()),
        }
        Self {
            nodes,
            packets,
            triangle_count: tree.triangles,
        }
    }

    /// Number of triangles the BVH holds (the scene's, less degenerate ones).
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// Heap bytes held by the BVH (nodes and leaf triangles).
    pub fn memory_bytes(&self) -> usize {
        let nodes = match &self.nodes {
            Nodes::Four(n) => n.capacity() * std::mem::size_of::<Node4>(),
            Nodes::Eight(n) => n.capacity() * std::mem::size_of::<Node8>(),
        };
        nodes + self.packets.capacity() * std::mem::size_of::<Tri4>()
    }

    fn tree<'a, N>(&'a self, nodes: &'a [N]) -> Tree<'a, N> {
        Tree {
            nodes,
            packets: &self.packets,
        }
    }
}

/// `run(rays, out, stack)` over `rays` and their `out` slots in tasks of [`RAYS_PER_TASK`]
/// rays, with a traversal stack for each run of tasks a thread takes on (`for_each_init`: a
/// few per thread) rather than per task.
fn in_tasks<N: WideNode, T: Send>(
    rays: &[Ray],
    out: &mut [T],
    run: impl Fn(&[Ray], &mut [T], &mut N::Stack) + Sync + Send,
) {
    assert_eq!(rays.len(), out.len(), "one output slot per ray");
    rays.par_chunks(RAYS_PER_TASK)
        .zip(out.par_chunks_mut(RAYS_PER_TASK))
        .for_each_init(N::new_stack, |stack, (rs, os)| run(rs, os, stack));
}

impl RayCaster for Bvh {
    fn cast(&self, rays: &[Ray], hits: &mut [Hit]) {
        match &self.nodes {
            Nodes::Four(n) => {
                let tree = self.tree(n);
                // SAFETY: the 4-wide layout needs nothing beyond the baseline.
                in_tasks::<Node4, _>(rays, hits, |r, h, s| unsafe { Node4::cast(tree, r, h, s) });
            }
            Nodes::Eight(n) => {
                let tree = self.tree(n);
                // SAFETY: `build_with` only builds 8-wide nodes where `Node8::supported`.
                in_tasks::<Node8, _>(rays, hits, |r, h, s| unsafe { Node8::cast(tree, r, h, s) });
            }
        }
    }

    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        match &self.nodes {
            Nodes::Four(n) => {
                let tree = self.tree(n);
                // SAFETY: as in `cast`.
                in_tasks::<Node4, _>(rays, out, |r, o, s| unsafe {
                    Node4::occluded(tree, r, o, s)
                });
            }
            Nodes::Eight(n) => {
                let tree = self.tree(n);
                // SAFETY: as in `cast`.
                in_tasks::<Node8, _>(rays, out, |r, o, s| unsafe {
                    Node8::occluded(tree, r, o, s)
                });
            }
        }
    }
}
