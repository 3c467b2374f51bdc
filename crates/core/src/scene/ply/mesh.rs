//! What the data pass collects from either encoding: positions, the fan triangulation of
//! each face with its indices checked, and the counts behind the load warnings.

use glam::Vec3;

/// What the data pass collects.
#[derive(Default)]
pub(super) struct Mesh {
    pub(super) positions: Vec<Vec3>,
    pub(super) triangles: Vec<[u32; 3]>,
    /// Faces with fewer than 3 indices (no triangle), and the first of them.
    pub(super) short_faces: u64,
    pub(super) first_short_face: u64,
    /// Load warnings.
    pub(super) warnings: Vec<String>,
}

/// Appends the fan triangulation of `face` (index `face_index` in the face element) after
/// checking every index against `vertex_count`; a face of fewer than 3 indices is counted in
/// `mesh.short_faces`.
#[inline]
pub(super) fn add_face(
    face: &[i64],
    face_index: u64,
    vertex_count: u32,
    mesh: &mut Mesh,
) -> Result<(), String> {
    for &i in face {
        if i < 0 || i >= i64::from(vertex_count) {
            return Err(format!(
                "face {face_index}: vertex index {i} out of range ({vertex_count} vertices)"
            ));
        }
    }
    if face.len() < 3 {
        if mesh.short_faces == 0 {
            mesh.first_short_face = face_index;
        }
        mesh.short_faces += 1;
    }
    for k in 1..face.len().saturating_sub(1) {
        mesh.triangles
            .push([face[0] as u32, face[k] as u32, face[k + 1] as u32]);
    }
    Ok(())
}

/// Converts a list item read as `f64` to an index; fractional or huge values become -1 so
/// that the range check rejects them.
#[inline]
pub(super) fn as_index(v: f64) -> i64 {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        v as i64
    } else {
        -1
    }
}
