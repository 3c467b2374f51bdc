//! The masked occlusion buffer's constants: the tile size, and the tolerances of its tests.
//! A leaf: every file of the buffer takes them from here (the face, `mod.rs`, re-exports
//! them).

/// Tile width in pixels (a row of a tile is one byte of the mask).
pub const TILE_W: u32 = 8;
/// Tile height in pixels.
pub const TILE_H: u32 = 4;
/// Relative slack on `1/z` when comparing a box with the buffer: the box is treated as this
/// much nearer than it is, which absorbs the `f32` rounding of both sides (about 1e-6
/// relative inside the guard band) with a wide margin.
pub const DEPTH_SLACK: f32 = 2e-5;
/// Margin in pixels of [`OcclusionBuffer::covers_pixel_centre`]: far above the `f32` error of
/// screen positions inside the guard band (about 1/100 px at 1920x1080, see
/// `project::GUARD_PX`) and the reference rasterizer's snapping of vertices to 1/256 px.
///
/// [`OcclusionBuffer::covers_pixel_centre`]: super::OcclusionBuffer::covers_pixel_centre
pub const COVER_MARGIN: f32 = 1.0 / 16.0;
