//! [`LoadOptions`]: how files are turned into triangles, and the limits of loading. A leaf: the
//! loaders and the limit checks take their options from here, not from `spec.rs`, which
//! dispatches to the loaders.

use super::types::UpAxis;

/// Options that change how files are turned into triangles, and the limits of loading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoadOptions {
    /// Quake 3 bezier patches: each 3x3 sub-patch is tessellated into an `n x n` grid of quads
    /// (`2 n²` triangles). 0 leaves patches out.
    pub patch_subdivisions: u32,
    /// The most memory one load may take, in bytes, checked separately for the file's bytes
    /// (after gzip inflation; a larger file is an error, never read to the end) and for the
    /// geometry (12 bytes per vertex, 16 per triangle, see [`Scene`](super::Scene)): counts a file declares
    /// are checked before anything is allocated for them. Default
    /// [`LoadOptions::DEFAULT_MAX_SCENE_BYTES`].
    pub max_scene_bytes: u64,
    /// glTF external buffers (`"uri": "file.bin"`): `false` (the default) reads only regular
    /// files whose canonical path lies in the folder of the `.gltf` file or below it, so a
    /// file from elsewhere cannot make the loader read `/etc/passwd` or `../../secret`;
    /// `true` also follows absolute paths and paths that leave the folder.
    pub allow_outside_refs: bool,
    /// The scene's up axis, whatever the file says or the loader would infer (`--up-axis`).
    /// `None` (the default): glTF is Y-up, Quake 3 maps Z-up, sightline's own `.glb` files
    /// keep the axis they were written from, and OBJ, PLY and STL files are inferred
    /// ([`infer_up_axis`](super::infer_up_axis)).
    pub up_axis: Option<UpAxis>,
}

impl LoadOptions {
    /// 4 GiB: a load holds the file's bytes and the geometry at once, so this bounds it to
    /// about 8 GiB, what a machine that runs these tools can spare; and 4 GiB of geometry is
    /// about 190 million triangles (22 bytes each for a closed mesh), past any scene the
    /// visibility methods handle in reasonable time. A fixed figure rather than a fraction
    /// of RAM, so a scene that loads on one machine loads on every other.
    pub const DEFAULT_MAX_SCENE_BYTES: u64 = 4 << 30;
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            patch_subdivisions: 4,
            max_scene_bytes: Self::DEFAULT_MAX_SCENE_BYTES,
            allow_outside_refs: false,
            up_axis: None,
        }
    }
}
