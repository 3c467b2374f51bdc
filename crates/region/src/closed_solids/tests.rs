use glam::Vec3;
use sightline_core::random::SplitMix64;
use sightline_core::scene::SceneBuilder;
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::{Hit, Scene, TriangleSet};

use super::ClosedSolids;
use crate::ViewCell;

fn boxes(list: &[([f32; 3], [f32; 3])]) -> Scene {
    let mut b = SceneBuilder::new("boxes");
    for (min, max) in list {
        b.add_box(Vec3::from(*min), Vec3::from(*max));
    }
    b.finish()
}

fn all(scene: &Scene) -> TriangleSet {
    let mut s = TriangleSet::with_capacity(scene.triangle_count());
    s.insert_range(..);
    s
}

fn removed(scene: &Scene, cell: &ViewCell) -> TriangleSet {
    let solids = ClosedSolids::new(scene);
    let mut visible = all(scene);
    let n = solids.remove_back_faces(scene, &cell.corners(), &mut visible);
    let mut gone = all(scene);
    gone.difference_with(&visible);
    assert_eq!(gone.count_ones(..), n);
    gone
}

fn cell(min: [f32; 3], max: [f32; 3]) -> ViewCell {
    ViewCell::aabb(Vec3::from(min), Vec3::from(max)).unwrap()
}

#[test]
fn from_beside_a_box_only_the_face_towards_the_cell_stays() {
    let scene = boxes(&[([0.0; 3], [1.0; 3])]);
    assert_eq!(ClosedSolids::new(&scene).solid_count(), 1);
    let gone = removed(&scene, &cell([3.0, 0.25, 0.25], [4.0, 0.75, 0.75]));
    assert_eq!(gone.count_ones(..), 10);
    // The two triangles kept face +x, towards the cell.
    for t in 0..12u32 {
        let c = scene.triangle(t);
        let n = (c[1] - c[0]).cross(c[2] - c[0]);
        assert_eq!(gone.contains(t as usize), n.x <= 0.0, "triangle {t}");
    }
    // A cell level with the box's side faces sees them edge-on from its corners: kept.
    let gone = removed(&scene, &cell([3.0, 0.0, 0.25], [4.0, 1.0, 0.75]));
    assert_eq!(gone.count_ones(..), 6);
}

#[test]
fn nothing_is_removed_from_a_cell_inside_or_across_a_solid() {
    let scene = boxes(&[([0.0; 3], [10.0; 3])]);
    assert_eq!(removed(&scene, &cell([4.0; 3], [6.0; 3])).count_ones(..), 0);
    assert_eq!(
        removed(&scene, &cell([9.0, 4.0, 4.0], [11.0, 6.0, 6.0])).count_ones(..),
        0
    );
}

/// A box without its top (z = 1) face, as a city's buildings come without their floors.
fn open_box(scene_top_missing: bool) -> Scene {
    let full = boxes(&[([0.0; 3], [1.0; 3])]);
    let mut b = SceneBuilder::new("open box");
    let ids: Vec<u32> = full.positions.iter().map(|p| b.add_vertex(*p)).collect();
    for (t, idx) in full.triangles.iter().enumerate() {
        let c = full.triangle(t as u32);
        let missing = if scene_top_missing {
            c.iter().all(|p| p.z == 1.0)
        } else {
            c.iter().all(|p| p.z == 1.0) || c.iter().all(|p| p.x == 1.0)
        };
        if !missing {
            b.add_triangle(idx.map(|i| ids[i as usize]));
        }
    }
    b.finish()
}

#[test]
fn an_open_bottom_closes_only_for_cells_on_the_solids_side_of_it() {
    let scene = open_box(true);
    assert_eq!(scene.triangle_count(), 10);
    assert_eq!(ClosedSolids::new(&scene).solid_count(), 1);
    // Beside it and below the open side: the far faces are hidden.
    assert!(removed(&scene, &cell([3.0, 0.25, 0.25], [4.0, 0.75, 0.75])).count_ones(..) > 0);
    // Above the open side, the inside shows: nothing is removed.
    assert_eq!(
        removed(&scene, &cell([0.25, 0.25, 2.0], [0.75, 0.75, 3.0])).count_ones(..),
        0
    );
    // Open on two sides: not a solid.
    let scene = open_box(false);
    assert_eq!(ClosedSolids::new(&scene).solid_count(), 0);
}

#[test]
fn a_surface_through_itself_is_not_a_solid() {
    // A closed box whose top corner is pushed down through the bottom face.
    let mut scene = boxes(&[([0.0; 3], [1.0; 3])]);
    let top = scene
        .positions
        .iter()
        .position(|p| *p == Vec3::new(1.0, 1.0, 1.0))
        .unwrap();
    scene.positions[top] = Vec3::new(0.8, 0.8, -1.0);
    assert_eq!(ClosedSolids::new(&scene).solid_count(), 0);
    // Unmoved, it is one.
    assert_eq!(
        ClosedSolids::new(&boxes(&[([0.0; 3], [1.0; 3])])).solid_count(),
        1
    );
}

#[test]
fn removed_triangles_are_never_hit_from_inside_the_cell() {
    // Boxes that touch, stand on one another and overlap, buildings without floors on a
    // ground plane, and random cells among them: no ray from the cell's interior ever
    // first hits a removed triangle, and the rule removes a good share.
    let mut b = SceneBuilder::new("block");
    let ground = [
        b.add_vertex(Vec3::new(-20.0, -20.0, 0.0)),
        b.add_vertex(Vec3::new(20.0, -20.0, 0.0)),
        b.add_vertex(Vec3::new(20.0, 20.0, 0.0)),
        b.add_vertex(Vec3::new(-20.0, 20.0, 0.0)),
    ];
    b.add_triangle([ground[0], ground[1], ground[2]]);
    b.add_triangle([ground[0], ground[2], ground[3]]);
    let full = boxes(&[
        ([-10.0, -10.0, 0.0], [-4.0, -2.0, 6.0]),
        ([-4.0, -10.0, 0.0], [0.0, -2.0, 9.0]),
        ([-4.0, -10.0, 9.0], [-2.0, -6.0, 12.0]),
        ([3.0, 3.0, 0.0], [8.0, 9.0, 4.0]),
        ([6.0, 7.0, 0.0], [10.0, 12.0, 7.0]),
        ([-9.0, 4.0, 0.0], [-3.0, 6.0, 15.0]),
    ]);
    let ids: Vec<u32> = full.positions.iter().map(|p| b.add_vertex(*p)).collect();
    for (t, idx) in full.triangles.iter().enumerate() {
        // Buildings without floors.
        if full.triangle(t as u32).iter().all(|p| p.z == 0.0) {
            continue;
        }
        b.add_triangle(idx.map(|i| ids[i as usize]));
    }
    let scene = b.finish();
    let solids = ClosedSolids::new(&scene);
    assert!(solids.solid_count() >= 4, "{}", solids.solid_count());
    let bvh = Bvh::build(&scene);
    let mut rng = SplitMix64::new(11);
    let mut total_removed = 0;
    for k in 0..24u64 {
        let lo = Vec3::new(
            rng.range_f32(-15.0, 12.0),
            rng.range_f32(-15.0, 12.0),
            rng.range_f32(0.5, 14.0),
        );
        let size = Vec3::new(
            rng.range_f32(0.5, 4.0),
            rng.range_f32(0.5, 4.0),
            rng.range_f32(0.2, 2.0),
        );
        let c = cell(lo.into(), (lo + size).into());
        let mut visible = all(&scene);
        total_removed += solids.remove_back_faces(&scene, &c.corners(), &mut visible);
        let rays = c.random_rays(20_000, k);
        let mut hits = vec![Hit::default(); rays.len()];
        bvh.cast(&rays, &mut hits);
        for h in hits.iter().filter(|h| h.triangle != Hit::NONE) {
            assert!(
                visible.contains(h.triangle as usize),
                "cell {k} ({lo:?} + {size:?}): triangle {} was hit but removed",
                h.triangle
            );
        }
    }
    // Most cells are outside every building, and about half the walls face away.
    assert!(total_removed > 24 * 10, "{total_removed}");
}

#[test]
fn empty_and_non_finite_scenes_give_no_solids_and_remove_nothing() {
    let empty = SceneBuilder::new("empty").finish();
    assert_eq!(ClosedSolids::new(&empty).solid_count(), 0);
    // A box beside a triangle with a NaN corner: the triangle belongs to no solid and stays,
    // the box is a solid as without it.
    let mut b = SceneBuilder::new("nan");
    b.add_box(Vec3::ZERO, Vec3::ONE);
    let v = [
        b.add_vertex(Vec3::new(f32::NAN, 0.0, 0.0)),
        b.add_vertex(Vec3::new(5.0, 0.0, 0.0)),
        b.add_vertex(Vec3::new(5.0, 1.0, 0.0)),
    ];
    b.add_triangle(v);
    let scene = b.finish();
    let solids = ClosedSolids::new(&scene);
    let mut visible = all(&scene);
    let c = cell([3.0, 0.25, 0.25], [4.0, 0.75, 0.75]);
    assert_eq!(solids.solid_count(), 1);
    assert_eq!(
        solids.remove_back_faces(&scene, &c.corners(), &mut visible),
        10
    );
    assert!(visible.contains(12));
    // Non-finite cell corners remove nothing either.
    let box_scene = boxes(&[([0.0; 3], [1.0; 3])]);
    let solids = ClosedSolids::new(&box_scene);
    let mut visible = all(&box_scene);
    let corners = [Vec3::new(f32::NAN, 0.5, 0.5); 8];
    assert_eq!(
        solids.remove_back_faces(&box_scene, &corners, &mut visible),
        0
    );
}
