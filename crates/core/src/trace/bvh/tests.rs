//! Tests of [`super::Bvh`]: every node width against brute force, bit for bit, on scenes with
//! ties, degenerate triangles and deep trees.

use super::refs::PARALLEL_BIN;
use super::*;
use crate::geometry::Aabb;
use crate::random::SplitMix64;
use crate::scene::SceneBuilder;
use crate::trace::BruteForce;

/// Random points, directions and sizes from the project's generator, fixed seeds.
struct Rng(SplitMix64);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(SplitMix64::new(seed))
    }

    fn next_u32(&mut self) -> u32 {
        (self.0.next_u64() >> 32) as u32
    }

    /// Uniform in `[0, 1)`.
    fn unit(&mut self) -> f32 {
        self.0.next_f32()
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        self.0.range_f32(lo, hi)
    }

    fn point(&mut self, b: &Aabb) -> Vec3 {
        Vec3::new(
            self.range(b.min.x, b.max.x),
            self.range(b.min.y, b.max.y),
            self.range(b.min.z, b.max.z),
        )
    }

    fn direction(&mut self) -> Vec3 {
        loop {
            let d = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            if d.length_squared() > 1e-4 && d.length_squared() <= 1.0 {
                return d;
            }
        }
    }
}

fn one_triangle() -> Scene {
    let mut b = SceneBuilder::new("one triangle");
    let v = [Vec3::ZERO, Vec3::X, Vec3::Y].map(|p| b.add_vertex(p));
    b.add_triangle(v);
    b.finish()
}

/// `n` small random triangles in a 10-unit cube, with a few degenerate ones mixed in.
fn random_soup(n: usize, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut b = SceneBuilder::new("random soup");
    let cube = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
    for i in 0..n {
        let c = rng.point(&cube);
        let size = rng.range(0.05, 1.5);
        let mut corner = || c + rng.direction() * size;
        let (p, q, r) = (corner(), corner(), corner());
        let tri = match i % 50 {
            0 => [p, p, q],             // repeated corner
            1 => [p, (p + q) * 0.5, q], // collinear
            2 => [p, q, Vec3::NAN],     // non-finite
            _ => [p, q, r],
        };
        let v = tri.map(|p| b.add_vertex(p));
        b.add_triangle(v);
    }
    b.finish()
}

/// A 6x6x3 grid of unit boxes that touch along faces and edges (many ties on shared
/// edges and faces), plus random boxes.
fn box_scene(seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut b = SceneBuilder::new("boxes");
    for x in 0..6 {
        for y in 0..6 {
            for z in 0..3 {
                if (x + y + z) % 3 != 0 {
                    let min = Vec3::new(x as f32, y as f32, z as f32 * 2.0);
                    b.add_box(min, min + Vec3::ONE);
                }
            }
        }
    }
    let region = Aabb::new(Vec3::splat(-2.0), Vec3::splat(8.0));
    for _ in 0..200 {
        let min = rng.point(&region);
        let size = Vec3::new(rng.unit(), rng.unit(), rng.unit()) * 1.5 + 0.01;
        b.add_box(min, min + size);
    }
    b.finish()
}

/// Rays of every kind the casters must agree on: random origins inside and around the
/// scene, random and axis-aligned directions (with zero and negative-zero components),
/// lattice origins on box faces and edges, and limited `t` ranges.
fn random_rays(bounds: Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    let grown = Aabb::new(bounds.min - 2.0, bounds.max + 2.0);
    let axes = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 1.0),
        Vec3::new(-0.0, -0.0, 1.0),
        Vec3::new(-1.0, 0.0, -0.0),
    ];
    (0..n)
        .map(|i| {
            let mut origin = rng.point(&grown);
            let dir = match i % 4 {
                0 | 1 => rng.direction(),
                2 => axes[rng.next_u32() as usize % axes.len()],
                _ => {
                    // A lattice origin (on box faces and edges of the grid scene) with an
                    // axis-aligned direction.
                    origin = origin.round();
                    axes[rng.next_u32() as usize % axes.len()] * 0.5
                }
            };
            let ray = Ray::new(origin, dir);
            match i % 7 {
                0 => ray.with_range(rng.range(0.0, 3.0), rng.range(3.0, 12.0)),
                1 => ray.with_range(0.5, f32::INFINITY),
                _ => ray,
            }
        })
        .collect()
}

fn assert_matches_brute_force(scene: &Scene, rays: &[Ray]) {
    let bvh = Bvh::build(scene);
    let brute = BruteForce::new(scene);
    let mut got = vec![Hit::MISS; rays.len()];
    let mut want = vec![Hit::MISS; rays.len()];
    bvh.cast(rays, &mut got);
    brute.cast(rays, &mut want);
    let mut hits = 0;
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g, w, "ray {i}: {:?}", rays[i]);
        hits += usize::from(w.is_hit());
    }
    assert!(hits > rays.len() / 10, "too few hits ({hits}) to test much");
    let mut occluded = vec![false; rays.len()];
    bvh.occluded(rays, &mut occluded);
    for (i, (o, w)) in occluded.iter().zip(&want).enumerate() {
        assert_eq!(*o, w.is_hit(), "occluded, ray {i}: {:?}", rays[i]);
    }
}

#[test]
fn empty_scene_misses() {
    let bvh = Bvh::build(&Scene::default());
    assert_eq!(bvh.triangle_count(), 0);
    assert_eq!(bvh.cast_one(&Ray::new(Vec3::ZERO, Vec3::X)), Hit::MISS);
    let mut out = [true];
    bvh.occluded(&[Ray::new(Vec3::ZERO, Vec3::X)], &mut out);
    assert!(!out[0]);
    bvh.cast(&[], &mut []);
}

#[test]
fn single_triangle_is_hit() {
    let bvh = Bvh::build(&one_triangle());
    let h = bvh.cast_one(&Ray::new(Vec3::new(0.25, 0.25, 2.0), Vec3::NEG_Z));
    assert_eq!(
        h,
        Hit {
            triangle: 0,
            t: 2.0
        }
    );
    let miss = bvh.cast_one(&Ray::new(Vec3::new(0.75, 0.75, 2.0), Vec3::NEG_Z));
    assert!(!miss.is_hit());
    let short = Ray::new(Vec3::new(0.25, 0.25, 2.0), Vec3::NEG_Z).with_range(0.0, 1.5);
    assert!(!bvh.cast_one(&short).is_hit());
}

#[test]
fn degenerate_triangles_are_skipped() {
    let mut b = SceneBuilder::new("degenerate");
    let v = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0].map(|p| b.add_vertex(p));
    b.add_triangle(v);
    b.add_triangle([v[0], v[0], v[1]]);
    b.add_triangle([0, 1, 99]); // index out of range
    let bvh = Bvh::build(&b.finish());
    assert_eq!(bvh.triangle_count(), 0);
    assert!(!bvh
        .cast_one(&Ray::new(Vec3::new(0.5, 0.0, 1.0), Vec3::NEG_Z))
        .is_hit());
}

#[test]
fn non_finite_ray_misses() {
    let bvh = Bvh::build(&one_triangle());
    for r in [
        Ray::new(Vec3::new(0.25, 0.25, f32::NAN), Vec3::NEG_Z),
        Ray::new(
            Vec3::new(0.25, 0.25, 1.0),
            Vec3::new(0.0, 0.0, f32::NEG_INFINITY),
        ),
        Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::ZERO),
        Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z).with_range(f32::NAN, 2.0),
    ] {
        assert!(!bvh.cast_one(&r).is_hit(), "{r:?}");
    }
}

#[test]
fn identical_centroids_match_brute_force() {
    // 100 copies of one triangle and 100 rotated ones around the same centroid: no SAH
    // split exists, the build falls back to splitting by index; ties go to the lowest id.
    let mut b = SceneBuilder::new("same centroid");
    for i in 0..200 {
        let angle = if i < 100 { 0.0 } else { i as f32 * 0.1 };
        let (s, c) = angle.sin_cos();
        let corners = [
            Vec3::new(c, s, 0.0),
            Vec3::new(-0.5 * c - 0.866 * s, -0.5 * s + 0.866 * c, 0.0),
            Vec3::new(-0.5 * c + 0.866 * s, -0.5 * s - 0.866 * c, 0.0),
        ];
        let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
        let v = corners.map(|p| b.add_vertex(p - centroid + Vec3::splat(5.0)));
        b.add_triangle(v);
    }
    let scene = b.finish();
    let h = Bvh::build(&scene).cast_one(&Ray::new(Vec3::new(5.0, 5.0, 9.0), Vec3::NEG_Z));
    assert_eq!(h.triangle, 0);
    // Rays aimed at the disc the triangles cover, plus the usual mix.
    let mut rng = Rng::new(7);
    let around = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
    let mut rays = random_rays(scene.bounds(), 1000, 8);
    for _ in 0..1000 {
        let o = rng.point(&around);
        let target = Vec3::new(rng.range(4.5, 5.5), rng.range(4.5, 5.5), 5.0);
        rays.push(Ray::new(o, target - o));
    }
    assert_matches_brute_force(&scene, &rays);
}

#[test]
fn random_soup_matches_brute_force() {
    let scene = random_soup(3000, 1);
    assert_matches_brute_force(&scene, &random_rays(scene.bounds(), 4000, 2));
}

#[test]
fn large_random_soup_matches_brute_force() {
    // Above the parallel binning and parallel build thresholds.
    let scene = random_soup(PARALLEL_BIN + 5000, 3);
    assert_matches_brute_force(&scene, &random_rays(scene.bounds(), 1000, 4));
}

#[test]
fn box_scene_matches_brute_force() {
    let scene = box_scene(5);
    assert_matches_brute_force(&scene, &random_rays(scene.bounds(), 8000, 6));
}

/// Both node widths against brute force, whatever the CPU picks for [`Bvh::build`].
fn assert_both_widths_match_brute_force(scene: &Scene, rays: &[Ray]) {
    let brute = BruteForce::new(scene);
    let mut want = vec![Hit::MISS; rays.len()];
    brute.cast(rays, &mut want);
    for width in [Width::Four, Width::widest()] {
        let bvh = Bvh::build_with(scene, width, true);
        let mut got = vec![Hit::MISS; rays.len()];
        bvh.cast(rays, &mut got);
        let mut occluded = vec![false; rays.len()];
        bvh.occluded(rays, &mut occluded);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(g, w, "{width:?}, ray {i}: {:?}", rays[i]);
            assert_eq!(occluded[i], w.is_hit(), "{width:?}, occluded, ray {i}");
        }
    }
}

#[test]
fn avx2_cpu_builds_eight_wide_nodes() {
    let bvh = Bvh::build(&box_scene(1));
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
        assert!(matches!(&bvh.nodes, Nodes::Eight(n) if !n.is_empty()));
        return;
    }
    assert!(matches!(&bvh.nodes, Nodes::Four(n) if !n.is_empty()));
}

#[test]
fn both_widths_match_brute_force_on_box_scene() {
    let scene = box_scene(11);
    assert_both_widths_match_brute_force(&scene, &random_rays(scene.bounds(), 4000, 12));
}

#[test]
fn both_widths_match_brute_force_on_random_soup() {
    let scene = random_soup(5000, 13);
    assert_both_widths_match_brute_force(&scene, &random_rays(scene.bounds(), 4000, 14));
}

#[test]
fn both_widths_match_brute_force_on_one_triangle() {
    // The root is a leaf: both layouts give it a node of its own.
    let scene = one_triangle();
    assert_both_widths_match_brute_force(&scene, &random_rays(scene.bounds(), 500, 15));
}

#[test]
fn skewed_scene_stays_within_stack() {
    // Exponentially spaced triangles: a pure SAH build would peel one off per level.
    let mut b = SceneBuilder::new("skewed");
    for i in 0..300 {
        let x = 1.3f32.powi(i);
        let v = [
            Vec3::new(x, 0.0, 0.0),
            Vec3::new(x, 1.0, 0.0),
            Vec3::new(x, 0.0, 1.0),
        ]
        .map(|p| b.add_vertex(p));
        b.add_triangle(v);
    }
    let scene = b.finish();
    let ray = Ray::new(Vec3::new(1e36, 0.2, 0.2), Vec3::NEG_X);
    let h = Bvh::build(&scene).cast_one(&ray);
    assert_eq!(h, BruteForce::new(&scene).cast_one(&ray));
    assert!(h.is_hit());
}

/// Random small triangles, and long slivers and large quads across the whole cube, as the
/// walls and floors of a level lie among its details: where spatial splits pay.
fn sliver_scene(seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut b = SceneBuilder::new("slivers");
    let cube = Aabb::new(Vec3::ZERO, Vec3::splat(10.0));
    for _ in 0..3000 {
        let c = rng.point(&cube);
        let v = [0, 1, 2].map(|_| b.add_vertex(c + rng.direction() * 0.3));
        b.add_triangle(v);
    }
    for i in 0..200 {
        let (p, q) = (rng.point(&cube), rng.point(&cube));
        let v = [p, q, p + rng.direction() * 0.05].map(|p| b.add_vertex(p));
        b.add_triangle(v);
        if i % 10 == 0 {
            // An axis-aligned wall or floor quad: two triangles sharing a diagonal.
            let h = rng.range(0.0, 10.0);
            let corners = match i % 3 {
                0 => [
                    [0.0, 0.0, h],
                    [10.0, 0.0, h],
                    [10.0, 10.0, h],
                    [0.0, 10.0, h],
                ],
                1 => [
                    [h, 0.0, 0.0],
                    [h, 10.0, 0.0],
                    [h, 10.0, 10.0],
                    [h, 0.0, 10.0],
                ],
                _ => [
                    [0.0, h, 0.0],
                    [0.0, h, 10.0],
                    [10.0, h, 10.0],
                    [10.0, h, 0.0],
                ],
            };
            let [a, b1, c, d] = corners.map(|c| b.add_vertex(Vec3::from_array(c)));
            b.add_triangle([a, b1, c]);
            b.add_triangle([a, c, d]);
        }
    }
    b.finish()
}

#[test]
fn spatial_splits_keep_hits_equal_to_brute_force() {
    let scene = sliver_scene(21);
    let bvh = Bvh::build(&scene);
    let t = bvh.tree_stats();
    let triangles = bvh.triangle_count();
    assert_eq!(triangles, scene.triangles.len());
    // Splits happened, within their budget: each split triangle sits in several leaves.
    assert!(t.references > triangles, "{} references", t.references);
    assert!(t.references as f64 <= triangles as f64 * (1.0 + build::SPLIT_BUDGET));
    assert_both_widths_match_brute_force(&scene, &random_rays(scene.bounds(), 6000, 22));
}

#[test]
fn spatial_splits_visit_fewer_packets_among_large_triangles() {
    // The same tree without splits (as `FlatBvh` builds it) tests more triangles per ray.
    let scene = sliver_scene(23);
    let rays = random_rays(scene.bounds(), 4000, 24);
    let (with, without) = (Bvh::build(&scene), Bvh::build_without_splits(&scene));
    let mut hits = [vec![Hit::MISS; rays.len()], vec![Hit::MISS; rays.len()]];
    with.cast(&rays, &mut hits[0]);
    without.cast(&rays, &mut hits[1]);
    assert_eq!(hits[0], hits[1]);
    let split = with.traversal_stats(&rays);
    let unsplit = without.traversal_stats(&rays);
    assert!(
        split.packets < 0.9 * unsplit.packets,
        "{} packets a ray with splits, {} without",
        split.packets,
        unsplit.packets
    );
}

#[test]
fn rays_leaving_boxes_through_the_plane_of_their_origin_skip_them() {
    // Boxes standing on the plane z = 0, and rays from that plane going down, as a bake's rays
    // leave a cell through its floor: they leave every box through the face their origin lies
    // on. A `-0.0` exit distance once made the box test enter all of them, every node of the
    // tree for every ray (a bake of the procedural city took 22 times as long).
    let mut b = SceneBuilder::new("boxes on a plane");
    for i in 0..400 {
        let p = Vec3::new((i % 20) as f32, (i / 20) as f32, 0.0);
        b.add_box(p, p + Vec3::new(0.5, 0.5, 1.0 + (i % 7) as f32));
    }
    let scene = b.finish();
    let mut rng = Rng::new(31);
    let rays: Vec<Ray> = (0..2000)
        .map(|_| {
            // In the gaps between the boxes' footprints, so no ray starts on a face.
            let gap = |rng: &mut Rng| rng.next_u32() as f32 % 20.0 + rng.range(0.6, 0.9);
            let origin = Vec3::new(gap(&mut rng), gap(&mut rng), 0.0);
            let mut dir = rng.direction();
            dir.z = -dir.z.abs() - 0.01;
            Ray::new(origin, dir)
        })
        .collect();
    assert_both_widths_match_brute_force_or_miss(&scene, &rays);
    let s = Bvh::build(&scene).traversal_stats(&rays);
    assert_eq!(s.hit_rate, 0.0);
    // Nodes whose box the origin lies on are entered at distance 0, as the closed boxes of
    // the float test are: about two a ray here; 100 nodes and 200 leaves with the old test.
    assert!(
        s.nodes < 4.0 && s.leaves < 1.0,
        "{} nodes and {} leaves a ray",
        s.nodes,
        s.leaves
    );
}

/// [`assert_both_widths_match_brute_force`] for ray sets that may all miss.
fn assert_both_widths_match_brute_force_or_miss(scene: &Scene, rays: &[Ray]) {
    let brute = BruteForce::new(scene);
    let mut want = vec![Hit::MISS; rays.len()];
    brute.cast(rays, &mut want);
    for width in [Width::Four, Width::widest()] {
        let mut got = vec![Hit::MISS; rays.len()];
        Bvh::build_with(scene, width, true).cast(rays, &mut got);
        assert_eq!(got, want, "{width:?}");
    }
}

/// The check that makes the traversal's unchecked indexing sound: it passes every built tree
/// (each build runs it) and stops a child slot pointing past the arrays, in each layout's
/// encoding of the slots.
fn catches_children_out_of_range<N: WideNode>() {
    let mut node = N::EMPTY;
    node.set_inner(1, 0);
    node.set_leaf(2, 3, 2);
    // Node 0 and packets 3 and 4 exist.
    assert_children_in_range(&[node], 5);
    // An inner child past the one node, and a leaf whose second packet is past the five.
    let mut past_nodes = node;
    past_nodes.set_inner(1, 1);
    let mut past_packets = node;
    past_packets.set_leaf(2, 4, 2);
    for broken in [past_nodes, past_packets] {
        let check = std::panic::AssertUnwindSafe(|| assert_children_in_range(&[broken], 5));
        let caught = std::panic::catch_unwind(check);
        assert!(caught.is_err(), "an out-of-range child passed");
    }
}

#[test]
fn children_out_of_range_are_caught() {
    catches_children_out_of_range::<Node4>();
    catches_children_out_of_range::<Node8>();
}
