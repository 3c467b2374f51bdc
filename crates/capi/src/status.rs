//! The status every function returns, in a file of its own: `guard.rs` turns failures into
//! it, and the functions in `lib.rs` return it (which re-exports it).

/// What a function did. Zero and positive values are success, negative values are errors
/// (then `sl_last_error()` says why). The values are fixed: new codes may be added, existing
/// ones never change.
#[repr(i32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlStatus {
    /// Success.
    Ok = 0,
    /// `sl_pvs_cell_at`: no cell holds the position (draw everything).
    Outside = 1,
    /// The caller's buffer was smaller than the set: it holds the first `capacity` ids and
    /// the reported count is the full one.
    Incomplete = 2,
    /// A pointer argument that must not be `NULL` was `NULL`.
    NullArgument = -1,
    /// A cell or object index past the file's cells or objects.
    OutOfRange = -2,
    /// Objects were asked of a version-1 file, which has triangle sets only (bake it again).
    NoObjects = -3,
    /// The file (or a set in it, decoded on demand) is damaged.
    Corrupt = -4,
    /// An argument is unusable (a misaligned buffer, a path that is not UTF-8 on Windows).
    InvalidArgument = -5,
    /// A bug in the library was caught (a Rust panic); the handle is still usable.
    Internal = -6,
    /// Any other failure; the message says what.
    Failed = -7,
    /// A conservative bound was asked of a file that holds none (bake with `--bound`).
    NoBound = -8,
}
