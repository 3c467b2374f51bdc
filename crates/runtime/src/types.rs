//! The value types a [`Pvs`](crate::Pvs) hands out: a view cell and an object of the baked
//! scene. A leaf: it imports nothing of the crate, so the reader's files (`cell_index.rs`)
//! take [`Cell`] from here and never from the crate root (`lib.rs`), which re-exports them.

/// A view cell: an oriented box (one half extent may be 0: a rectangle).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Centre.
    pub center: [f32; 3],
    /// The cell's local x, y, z axes (orthonormal unit vectors).
    pub axes: [[f32; 3]; 3],
    /// Half extents along the axes.
    pub half_extents: [f32; 3],
}

/// One object of the baked scene: what an engine draws as a mesh instance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Object<'a> {
    /// The object's name from the scene file (glTF: node path `Root/House/Door.001`; see
    /// `docs/objects.md` for every format).
    pub name: &'a str,
    /// Format-specific number: glTF node index, Quake 3 model number; `None` elsewhere.
    pub index: Option<u32>,
    /// Format-specific part: glTF primitive index, Quake 3 shader index; `None` elsewhere.
    pub part: Option<u32>,
    /// Minimum corner of the bounds of its triangles (`+inf` for an object with none).
    pub bounds_min: [f32; 3],
    /// Maximum corner (`-inf` for an object with no triangles).
    pub bounds_max: [f32; 3],
}
