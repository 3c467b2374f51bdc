//! Scene validation: the checks every loaded or generated scene goes through before an
//! algorithm sees it.
//!
//! Errors (the scene cannot be used): no triangles, a triangle index past the vertex array, a
//! non-finite coordinate on a vertex that a triangle uses. Warnings (the scene is used as is):
//! degenerate triangles (see [`is_degenerate`]) — kept so ids stay stable, never reported
//! visible — and duplicate triangles (same three corner positions in any order), and
//! unreferenced vertices.
//!
//! The degenerate test looks at the triangle alone, never at the rest of the scene: the
//! earlier rule of `shared/scenes/SOURCES.md` (area <= 1e-12 x the scene's bounding-box
//! diagonal²) called 69,436 of the 69,451 triangles of a bunny placed in a city degenerate.

use std::collections::HashMap;
use std::fmt;

use serde::Serialize;

use crate::geometry::Aabb;
use crate::scene::types::Scene;

/// How many example ids each finding lists.
const EXAMPLES: usize = 8;

/// The outcome of [`validate`].
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Report {
    /// Number of triangles.
    pub triangles: usize,
    /// Number of vertices.
    pub vertices: usize,
    /// Number of objects.
    pub objects: usize,
    /// Bounding box of the finite referenced vertices (`None` when there are none).
    pub bounds: Option<[[f32; 3]; 2]>,
    /// Triangles with an index past the vertex array.
    pub out_of_range_count: usize,
    /// First few such triangle ids.
    pub out_of_range_examples: Vec<u32>,
    /// Referenced vertices with a NaN or infinite coordinate.
    pub non_finite_count: usize,
    /// First few such vertex indices.
    pub non_finite_examples: Vec<u32>,
    /// Degenerate triangles (repeated index or near-zero area).
    pub degenerate_count: usize,
    /// First few degenerate triangle ids.
    pub degenerate_examples: Vec<u32>,
    /// Triangles whose corner positions equal an earlier triangle's.
    pub duplicate_count: usize,
    /// First few `(duplicate id, first id)` pairs.
    pub duplicate_examples: Vec<(u32, u32)>,
    /// Vertices no triangle uses.
    pub unreferenced_vertices: usize,
    /// Triangles whose object index is past the object table.
    pub bad_object_count: usize,
}

/// A problem that makes a scene unusable.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ValidationError {
    /// The scene has no triangles.
    #[error("the scene has no triangles")]
    Empty,
    /// A triangle indexes past the vertex array.
    #[error("{count} triangle(s) index past the {vertices} vertices, first: triangle {first}")]
    IndexOutOfRange {
        /// How many triangles.
        count: usize,
        /// Vertex count.
        vertices: usize,
        /// First bad triangle id.
        first: u32,
    },
    /// A used vertex has a NaN or infinite coordinate.
    #[error("{count} vertex/vertices have NaN or infinite coordinates, first: vertex {first}")]
    NonFinite {
        /// How many vertices.
        count: usize,
        /// First bad vertex index.
        first: u32,
    },
    /// A triangle's object index is past the object table.
    #[error("{count} triangle(s) name an object past the object table")]
    BadObject {
        /// How many triangles.
        count: usize,
    },
}

impl Report {
    /// The problems that make the scene unusable (empty when it can be used).
    pub fn errors(&self) -> Vec<ValidationError> {
        let mut e = Vec::new();
        if self.triangles == 0 {
            e.push(ValidationError::Empty);
        }
        if let Some(&first) = self.out_of_range_examples.first() {
            e.push(ValidationError::IndexOutOfRange {
                count: self.out_of_range_count,
                vertices: self.vertices,
                first,
            });
        }
        if let Some(&first) = self.non_finite_examples.first() {
            e.push(ValidationError::NonFinite {
                count: self.non_finite_count,
                first,
            });
        }
        if self.bad_object_count > 0 {
            e.push(ValidationError::BadObject {
                count: self.bad_object_count,
            });
        }
        e
    }

    /// Human-readable warnings (degenerate, duplicate, unreferenced).
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.degenerate_count > 0 {
            w.push(format!(
                "{} degenerate triangle(s) (kept, never visible), e.g. {:?}",
                self.degenerate_count, self.degenerate_examples
            ));
        }
        if self.duplicate_count > 0 {
            w.push(format!(
                "{} duplicate triangle(s) (same corners as an earlier one), e.g. {:?}",
                self.duplicate_count, self.duplicate_examples
            ));
        }
        if self.unreferenced_vertices > 0 {
            w.push(format!(
                "{} unreferenced vertex/vertices",
                self.unreferenced_vertices
            ));
        }
        w
    }

    /// `Ok(())` when the scene is usable, else the first error.
    pub fn check(&self) -> Result<(), ValidationError> {
        match self.errors().into_iter().next() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let errors = self.errors();
        let warnings = self.warnings();
        if errors.is_empty() && warnings.is_empty() {
            return f.write_str("valid");
        }
        for e in &errors {
            writeln!(f, "error: {e}")?;
        }
        for w in &warnings {
            writeln!(f, "warning: {w}")?;
        }
        Ok(())
    }
}

/// Checks `scene` (see the module documentation for what is checked).
pub fn validate(scene: &Scene) -> Report {
    let n_vertices = scene.positions.len();
    let mut report = Report {
        triangles: scene.triangles.len(),
        vertices: n_vertices,
        objects: scene.objects.len(),
        ..Report::default()
    };
    let mut referenced = vec![false; n_vertices];
    for (id, tri) in scene.triangles.iter().enumerate() {
        if tri.iter().any(|&i| i as usize >= n_vertices) {
            report.out_of_range_count += 1;
            push_example(&mut report.out_of_range_examples, id as u32);
            continue;
        }
        for &i in tri {
            referenced[i as usize] = true;
        }
    }
    let mut bounds = Aabb::EMPTY;
    for (v, p) in scene.positions.iter().enumerate() {
        if !referenced[v] {
            report.unreferenced_vertices += 1;
        } else if !p.is_finite() {
            report.non_finite_count += 1;
            push_example(&mut report.non_finite_examples, v as u32);
        } else {
            bounds.grow(*p);
        }
    }
    if !bounds.is_empty() {
        report.bounds = Some([bounds.min.to_array(), bounds.max.to_array()]);
    }
    report.bad_object_count = scene
        .object_of_triangle
        .iter()
        .filter(|&&o| o as usize >= scene.objects.len())
        .count()
        + scene
            .triangles
            .len()
            .saturating_sub(scene.object_of_triangle.len());

    let mut first_with_corners: HashMap<[[u32; 3]; 3], u32> = HashMap::new();
    for (id, tri) in scene.triangles.iter().enumerate() {
        if tri.iter().any(|&i| i as usize >= n_vertices) {
            continue;
        }
        let corners = tri.map(|i| scene.positions[i as usize]);
        if corners.iter().any(|p| !p.is_finite()) {
            continue;
        }
        if is_degenerate(*tri, corners) {
            report.degenerate_count += 1;
            push_example(&mut report.degenerate_examples, id as u32);
            continue;
        }
        let mut key = corners.map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]);
        key.sort_unstable();
        match first_with_corners.entry(key) {
            std::collections::hash_map::Entry::Occupied(first) => {
                report.duplicate_count += 1;
                if report.duplicate_examples.len() < EXAMPLES {
                    report.duplicate_examples.push((id as u32, *first.get()));
                }
            }
            std::collections::hash_map::Entry::Vacant(slot) => {
                slot.insert(id as u32);
            }
        }
    }
    report
}

/// Largest height of a degenerate triangle, relative to its longest edge: 1e-6, about 8 units
/// in the last place of an `f32` edge length, below which rounding the corners can already
/// flip the triangle and every method sees a line.
pub const DEGENERATE_HEIGHT_RATIO: f64 = 1e-6;

/// Whether the triangle with indices `tri` and (finite) `corners` is degenerate: two equal
/// indices, or a height (twice its area over its longest edge) of at most
/// [`DEGENERATE_HEIGHT_RATIO`] times its longest edge, that is twice the area at most
/// `DEGENERATE_HEIGHT_RATIO x longest edge²` (all in `f64`); three equal corners have no
/// longest edge and are degenerate too. Only the triangle's own corners count: the test is
/// the same wherever the triangle lies and whatever else the scene holds.
pub fn is_degenerate(tri: [u32; 3], corners: [glam::Vec3; 3]) -> bool {
    if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
        return true;
    }
    let [a, b, c] = corners.map(|p| p.as_dvec3());
    let twice_area = (b - a).cross(c - a).length();
    let longest_squared = (b - a)
        .length_squared()
        .max((c - b).length_squared())
        .max((a - c).length_squared());
    twice_area <= DEGENERATE_HEIGHT_RATIO * longest_squared
}

fn push_example(list: &mut Vec<u32>, id: u32) {
    if list.len() < EXAMPLES {
        list.push(id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builder::SceneBuilder;
    use glam::Vec3;

    fn unit_triangle() -> SceneBuilder {
        let mut b = SceneBuilder::new("t");
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y].map(|p| b.add_vertex(p));
        b.add_triangle(v);
        b
    }

    #[test]
    fn empty_scene_is_error() {
        let r = validate(&Scene::default());
        assert_eq!(r.check(), Err(ValidationError::Empty));
    }

    #[test]
    fn clean_triangle_is_valid() {
        let r = validate(&unit_triangle().finish());
        assert_eq!(r.check(), Ok(()));
        assert!(r.warnings().is_empty());
        assert_eq!(r.to_string(), "valid");
    }

    #[test]
    fn out_of_range_index_is_error() {
        let mut b = unit_triangle();
        b.add_triangle([0, 1, 7]);
        let r = validate(&b.finish());
        assert!(matches!(
            r.check(),
            Err(ValidationError::IndexOutOfRange { first: 1, .. })
        ));
    }

    #[test]
    fn nan_vertex_is_error() {
        let mut b = unit_triangle();
        let v = b.add_vertex(Vec3::new(f32::NAN, 0.0, 0.0));
        b.add_triangle([0, 1, v]);
        let r = validate(&b.finish());
        assert!(matches!(
            r.check(),
            Err(ValidationError::NonFinite { first: 3, .. })
        ));
    }

    #[test]
    fn nan_on_unused_vertex_is_only_unreferenced() {
        let mut b = unit_triangle();
        b.add_vertex(Vec3::splat(f32::INFINITY));
        let r = validate(&b.finish());
        assert_eq!(r.check(), Ok(()));
        assert_eq!(r.unreferenced_vertices, 1);
    }

    #[test]
    fn degenerate_and_duplicate_are_warnings() {
        let mut b = unit_triangle();
        b.add_triangle([0, 0, 1]);
        let v = [Vec3::Y, Vec3::ZERO, Vec3::X].map(|p| b.add_vertex(p));
        b.add_triangle(v);
        let r = validate(&b.finish());
        assert_eq!(r.check(), Ok(()));
        assert_eq!(
            (r.degenerate_count, r.degenerate_examples.clone()),
            (1, vec![1])
        );
        assert_eq!(r.duplicate_examples, vec![(2, 0)]);
        assert_eq!(r.warnings().len(), 2);
    }

    #[test]
    fn small_triangle_beside_a_large_one_is_not_degenerate() {
        // A millimetre triangle next to a 10 km one (a bunny in a city).
        let mut b = unit_triangle();
        let far = [Vec3::ZERO, Vec3::X * 1e4, Vec3::Y * 1e4].map(|p| b.add_vertex(p));
        b.add_triangle(far);
        let small = [Vec3::ZERO, Vec3::X * 1e-3, Vec3::Y * 1e-3].map(|p| b.add_vertex(p));
        b.add_triangle(small);
        assert_eq!(validate(&b.finish()).degenerate_count, 0);
    }

    #[test]
    fn sliver_is_degenerate_at_any_scale() {
        for scale in [1e-3f32, 1.0, 1e4] {
            let corners = [Vec3::ZERO, Vec3::X, Vec3::new(0.5, 1e-7, 0.0)].map(|p| p * scale);
            assert!(is_degenerate([0, 1, 2], corners), "scale {scale}");
            let fine = [Vec3::ZERO, Vec3::X, Vec3::new(0.5, 1e-5, 0.0)].map(|p| p * scale);
            assert!(!is_degenerate([0, 1, 2], fine), "scale {scale}");
        }
        assert!(is_degenerate([0, 1, 2], [Vec3::ONE; 3]));
    }

    #[test]
    fn near_zero_area_is_degenerate() {
        let mut b = unit_triangle();
        let v = [Vec3::ZERO, Vec3::X, Vec3::new(0.5, 1e-13, 0.0)].map(|p| b.add_vertex(p));
        b.add_triangle(v);
        assert_eq!(validate(&b.finish()).degenerate_count, 1);
    }
}
