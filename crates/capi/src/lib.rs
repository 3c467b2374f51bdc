//! # sightline C API
//!
//! The C interface of [`sightline_runtime`]: open a baked `.pvs` file, find the view cell of a
//! position, list the objects (or triangles) visible from a cell. The header is
//! `include/sightline.h`, generated from this file by cbindgen (`tests/header.rs` fails when
//! the committed header differs). Build with `cargo build --release -p sightline-capi`:
//! `target/release/libsightline.so` and `libsightline.a` (link the static one with
//! `-lpthread -ldl -lm`). Usage from C, Unity, Unreal and Godot: `docs/engine-integration.md`.
//!
//! Conventions of every function:
//! - No panic crosses the boundary: each body runs under `catch_unwind`, a panic becomes
//!   [`SlStatus::Internal`] (or `NULL` / 0) with a message.
//! - A status `>= 0` is success ([`SlStatus::Ok`], [`SlStatus::Outside`],
//!   [`SlStatus::Incomplete`]); a negative one is an error, and [`sl_last_error`] then says
//!   why, on the calling thread.
//! - Null pointers and out-of-range indices are errors, never crashes.
//! - A handle may be queried from many threads at once; [`sl_pvs_close`] must be the last
//!   call on it.

mod guard;
mod status;

use std::ffi::{c_char, CStr};
use std::ptr;

use guard::{fail, guard_status, guard_value, Failure};
use sightline_runtime::Pvs;
pub use status::SlStatus;

/// The value of an absent number (`UINT32_MAX`): `SlObject.index` and `SlObject.part` of an
/// object whose format has none, the cell of a position outside every cell.
pub const SL_NONE: u32 = 0xFFFF_FFFF;

/// An opened, checked `.pvs` file (opaque). Made by `sl_pvs_open` or `sl_pvs_open_memory`,
/// freed by `sl_pvs_close`.
pub struct SlPvs {
    pvs: Pvs,
    /// Every object's name followed by a NUL byte, back to back.
    names: Vec<u8>,
    /// Where each name starts in `names`; one more entry than objects.
    name_start: Vec<usize>,
}

// A handle is shared between threads by engines (render and game threads).
const _: () = {
    const fn send_sync<T: Send + Sync>() {}
    send_sync::<SlPvs>()
};

impl SlPvs {
    fn new(pvs: Pvs) -> Self {
        let mut names = Vec::new();
        let mut name_start = Vec::with_capacity(pvs.object_count() as usize + 1);
        for object in pvs.objects() {
            name_start.push(names.len());
            names.extend_from_slice(object.name.as_bytes());
            names.push(0);
        }
        name_start.push(names.len());
        Self {
            pvs,
            names,
            name_start,
        }
    }
}

/// A view cell: an oriented box (one half extent may be 0: a rectangle).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlCell {
    /// Centre.
    pub center: [f32; 3],
    /// The cell's local x, y and z axes (orthonormal unit vectors), in the scene's frame.
    pub axes: [[f32; 3]; 3],
    /// Half extents along those axes.
    pub half_extents: [f32; 3],
}

/// One object of the baked scene: what an engine draws as a mesh instance.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlObject {
    /// The name from the scene file (glTF: node path such as `Root/House/Door.001`), UTF-8,
    /// followed by a NUL byte. Owned by the handle: valid until `sl_pvs_close`. A name may
    /// itself contain NUL bytes: `name_len` is its full length in bytes (without the final
    /// NUL), C string functions see only the part before the first NUL.
    pub name: *const c_char,
    /// Length of `name` in bytes, without the final NUL.
    pub name_len: usize,
    /// Format-specific number (glTF node index, Quake 3 model number), `SL_NONE` if none.
    pub index: u32,
    /// Format-specific part (glTF primitive index, Quake 3 shader index), `SL_NONE` if none.
    pub part: u32,
    /// Minimum corner of the bounds of its triangles (+infinity for an object with none).
    pub bounds_min: [f32; 3],
    /// Maximum corner (-infinity for an object with no triangles).
    pub bounds_max: [f32; 3],
}

/// The message of the last call on this thread that failed, UTF-8 and NUL-terminated; an
/// empty string if none has. Successful calls do not clear it: look at a function's result
/// first. The pointer stays valid until the next call into this library on the same thread;
/// copy the text to keep it. Never returns `NULL`.
#[no_mangle]
pub extern "C" fn sl_last_error() -> *const c_char {
    guard::last_error()
}

/// Opens the `.pvs` file at `path` (a NUL-terminated path, in the platform's encoding on Unix,
/// UTF-8 on Windows) and checks it completely (structure and every checksum; the sets are
/// decoded, and checked again, when asked for). Reads at most 4 GiB.
///
/// Returns the handle, to be freed with `sl_pvs_close`, or `NULL` on failure (a missing file,
/// not a `.pvs` file, damage, a null `path`): then `sl_last_error()` says why.
///
/// # Safety
/// `path` must be `NULL` or point to a NUL-terminated string.
#[no_mangle]
pub unsafe extern "C" fn sl_pvs_open(path: *const c_char) -> *mut SlPvs {
    guard_value("sl_pvs_open", ptr::null_mut(), || {
        if path.is_null() {
            return Err(Failure::null("path"));
        }
        // SAFETY: non-null and NUL-terminated by the caller's contract.
        let bytes = unsafe { CStr::from_ptr(path) }.to_bytes();
        let pvs = Pvs::open(path_of(bytes)?)?;
        Ok(Box::into_raw(Box::new(SlPvs::new(pvs))))
    })
}

#[cfg(unix)]
fn path_of(bytes: &[u8]) -> Result<&std::path::Path, Failure> {
    use std::os::unix::ffi::OsStrExt;
    Ok(std::path::Path::new(std::ffi::OsStr::from_bytes(bytes)))
}

#[cfg(not(unix))]
fn path_of(bytes: &[u8]) -> Result<&std::path::Path, Failure> {
    match std::str::from_utf8(bytes) {
        Ok(s) => Ok(std::path::Path::new(s)),
        Err(e) => Err(fail(
            SlStatus::InvalidArgument,
            format!("path is not UTF-8: {e}"),
        )),
    }
}

/// Opens a `.pvs` file from `len` bytes at `data`, which are copied (the caller may free them
/// as soon as this returns), and checks it like `sl_pvs_open`.
///
/// Returns the handle, to be freed with `sl_pvs_close`, or `NULL` on failure (then
/// `sl_last_error()` says why). `data` must not be `NULL`, even when `len` is 0.
///
/// # Safety
/// `data` must be `NULL` or point to `len` readable bytes.
#[no_mangle]
pub unsafe extern "C" fn sl_pvs_open_memory(data: *const u8, len: usize) -> *mut SlPvs {
    guard_value("sl_pvs_open_memory", ptr::null_mut(), || {
        if data.is_null() {
            return Err(Failure::null("data"));
        }
        if len > isize::MAX as usize {
            return Err(fail(
                SlStatus::InvalidArgument,
                format!("len {len} is not a buffer size"),
            ));
        }
        // SAFETY: non-null, `len` readable bytes by the caller's contract, len <= isize::MAX.
        let bytes = unsafe { std::slice::from_raw_parts(data, len) }.to_vec();
        let pvs = Pvs::from_bytes(bytes)?;
        Ok(Box::into_raw(Box::new(SlPvs::new(pvs))))
    })
}

/// Frees a handle and everything it owns (object names included). `NULL` is a no-op.
///
/// # Safety
/// `pvs` must be `NULL` or a handle from `sl_pvs_open` / `sl_pvs_open_memory` that was not
/// closed yet, and no other call may be using it (on any thread) or use it afterwards.
#[no_mangle]
pub unsafe extern "C" fn sl_pvs_close(pvs: *mut SlPvs) {
    if pvs.is_null() {
        return;
    }
    // SAFETY: made by Box::into_raw in an open function, closed once, by the contract.
    let pvs = unsafe { Box::from_raw(pvs) };
    guard_value("sl_pvs_close", (), move || {
        drop(pvs);
        Ok(())
    })
}

fn handle(pvs: Option<&SlPvs>) -> Result<&SlPvs, Failure> {
    pvs.ok_or_else(|| Failure::null("pvs"))
}

/// The format version of the file: 1 (triangle sets only) or 2 (objects too). 0 when `pvs` is
/// `NULL` (an error: `sl_last_error()` says so).
#[no_mangle]
pub extern "C" fn sl_pvs_version(pvs: Option<&SlPvs>) -> u32 {
    guard_value("sl_pvs_version", 0, || Ok(handle(pvs)?.pvs.version()))
}

/// Number of view cells in the file (0 when `pvs` is `NULL`, an error).
#[no_mangle]
pub extern "C" fn sl_pvs_cell_count(pvs: Option<&SlPvs>) -> u32 {
    guard_value("sl_pvs_cell_count", 0, || Ok(handle(pvs)?.pvs.cell_count()))
}

/// Number of objects of the baked scene: object ids are `0 .. count - 1`. 0 in a version-1
/// file, and when `pvs` is `NULL` (an error).
#[no_mangle]
pub extern "C" fn sl_pvs_object_count(pvs: Option<&SlPvs>) -> u32 {
    guard_value("sl_pvs_object_count", 0, || {
        Ok(handle(pvs)?.pvs.object_count())
    })
}

/// Number of triangles of the baked scene: triangle ids are `0 .. count - 1`, in the order the
/// scene's loader emits them. 0 when `pvs` is `NULL` (an error).
#[no_mangle]
pub extern "C" fn sl_pvs_triangle_count(pvs: Option<&SlPvs>) -> u32 {
    guard_value("sl_pvs_triangle_count", 0, || {
        Ok(handle(pvs)?.pvs.triangle_count())
    })
}

/// The geometry hash of the scene the file was baked for (to check that a level and its
/// `.pvs` belong together). 0 when `pvs` is `NULL` (an error).
#[no_mangle]
pub extern "C" fn sl_pvs_scene_hash(pvs: Option<&SlPvs>) -> u64 {
    guard_value("sl_pvs_scene_hash", 0, || Ok(handle(pvs)?.pvs.scene_hash()))
}

/// Writes the box of cell `cell` to `*out`.
///
/// Returns `SL_STATUS_OK`, or `SL_STATUS_NULL_ARGUMENT` / `SL_STATUS_OUT_OF_RANGE` (then
/// `*out` is unchanged).
#[no_mangle]
pub extern "C" fn sl_pvs_cell(
    pvs: Option<&SlPvs>,
    cell: u32,
    out: Option<&mut SlCell>,
) -> SlStatus {
    guard_status("sl_pvs_cell", || {
        let pvs = handle(pvs)?;
        let out = out.ok_or_else(|| Failure::null("out"))?;
        let c = pvs.pvs.cell(cell)?;
        *out = SlCell {
            center: c.center,
            axes: c.axes,
            half_extents: c.half_extents,
        };
        Ok(SlStatus::Ok)
    })
}

/// Finds the view cell that holds `position` (3 floats: x, y, z in the scene's frame) and
/// writes its index to `*out_cell`.
///
/// Returns `SL_STATUS_OK` when a cell holds it; `SL_STATUS_OUTSIDE` when none does, or when a
/// coordinate is NaN or infinite (then `*out_cell` is `SL_NONE`, and the engine should draw
/// everything); or `SL_STATUS_NULL_ARGUMENT`. On a face shared by two cells, and where cells
/// overlap, the lowest cell index wins; a point within 1e-5 of a cell's size outside its
/// boundary counts as inside. The lookup uses an index built at open: no scan of all cells.
///
/// # Safety
/// `position` must be `NULL` or point to 3 readable floats; `out_cell` must be `NULL` or
/// point to a writable `uint32_t`.
#[no_mangle]
pub unsafe extern "C" fn sl_pvs_cell_at(
    pvs: Option<&SlPvs>,
    position: *const f32,
    out_cell: Option<&mut u32>,
) -> SlStatus {
    guard_status("sl_pvs_cell_at", || {
        let pvs = handle(pvs)?;
        let out_cell = out_cell.ok_or_else(|| Failure::null("out_cell"))?;
        if position.is_null() {
            return Err(Failure::null("position"));
        }
        // SAFETY: non-null and 3 readable floats by the caller's contract; read_unaligned
        // needs no alignment.
        let p: [f32; 3] = unsafe { position.cast::<[f32; 3]>().read_unaligned() };
        match pvs.pvs.cell_at(p) {
            Some(cell) => {
                *out_cell = cell;
                Ok(SlStatus::Ok)
            }
            None => {
                *out_cell = SL_NONE;
                Ok(SlStatus::Outside)
            }
        }
    })
}

/// Writes object `object`'s name, numbers and bounds to `*out`. The name stays owned by the
/// handle (valid until `sl_pvs_close`).
///
/// Returns `SL_STATUS_OK`, or `SL_STATUS_NULL_ARGUMENT` / `SL_STATUS_OUT_OF_RANGE` (every
/// index is out of range in a version-1 file, which has no objects; `*out` is then
/// unchanged).
#[no_mangle]
pub extern "C" fn sl_pvs_object(
    pvs: Option<&SlPvs>,
    object: u32,
    out: Option<&mut SlObject>,
) -> SlStatus {
    guard_status("sl_pvs_object", || {
        let h = handle(pvs)?;
        let out = out.ok_or_else(|| Failure::null("out"))?;
        let o = h.pvs.object(object)?;
        let start = h.name_start[object as usize];
        let end = h.name_start[object as usize + 1] - 1; // the NUL
        *out = SlObject {
            name: h.names[start..].as_ptr().cast(),
            name_len: end - start,
            index: o.index.unwrap_or(SL_NONE),
            part: o.part.unwrap_or(SL_NONE),
            bounds_min: o.bounds_min,
            bounds_max: o.bounds_max,
        };
        Ok(SlStatus::Ok)
    })
}

/// Which set of a cell to copy out.
#[derive(Clone, Copy)]
enum Set {
    Objects,
    Triangles,
    BoundObjects,
    BoundTriangles,
}

/// The body of `sl_pvs_visible_objects` and `sl_pvs_visible_triangles`.
///
/// # Safety
/// As theirs.
unsafe fn copy_visible(
    pvs: Option<&SlPvs>,
    cell: u32,
    out: *mut u32,
    capacity: usize,
    out_count: Option<&mut usize>,
    set: Set,
) -> Result<SlStatus, Failure> {
    let out_count = out_count.ok_or_else(|| Failure::null("out_count"))?;
    *out_count = 0;
    let pvs = &handle(pvs)?.pvs;
    if capacity == 0 {
        // Sizing call: the count is in the cell's record, nothing to decode.
        let n = match set {
            Set::Objects => pvs.visible_object_count(cell)?,
            Set::Triangles => pvs.visible_triangle_count(cell)?,
            Set::BoundObjects => pvs.bound_object_count(cell)?,
            Set::BoundTriangles => pvs.bound_triangle_count(cell)?,
        } as usize;
        *out_count = n;
        return Ok(if n == 0 {
            SlStatus::Ok
        } else {
            SlStatus::Incomplete
        });
    }
    if out.is_null() {
        return Err(Failure::null("out"));
    }
    if !out.is_aligned() {
        return Err(fail(
            SlStatus::InvalidArgument,
            "out is not aligned to 4 bytes",
        ));
    }
    guard::with_scratch(|ids| {
        match set {
            Set::Objects => pvs.visible_objects_into(cell, ids)?,
            Set::Triangles => pvs.visible_triangles_into(cell, ids)?,
            Set::BoundObjects => pvs.bound_objects_into(cell, ids)?,
            Set::BoundTriangles => pvs.bound_triangles_into(cell, ids)?,
        }
        let n = ids.len().min(capacity);
        // SAFETY: `out` is non-null, aligned and has room for `capacity` >= n ids by the
        // caller's contract; `ids` is our own buffer, so they do not overlap.
        unsafe { ptr::copy_nonoverlapping(ids.as_ptr(), out, n) };
        *out_count = ids.len();
        Ok(if ids.len() > capacity {
            SlStatus::Incomplete
        } else {
            SlStatus::Ok
        })
    })
}

/// Copies the ids of the objects visible from cell `cell` (ascending; an object is visible
/// when any of its triangles is) to `out`: the first `min(count, capacity)` of them. Always
/// writes the full count to `*out_count`, so a caller can size its buffer: a call with
/// `capacity` 0 (and `out` `NULL`) only reports the count, without decoding the set.
///
/// Returns `SL_STATUS_OK` when all ids fit, `SL_STATUS_INCOMPLETE` when `capacity` was
/// smaller than the count; or an error: `SL_STATUS_NULL_ARGUMENT`, `SL_STATUS_OUT_OF_RANGE`
/// (cell), `SL_STATUS_NO_OBJECTS` (a version-1 file), `SL_STATUS_CORRUPT` (the set does not
/// decode), `SL_STATUS_INVALID_ARGUMENT` (`out` misaligned); then `*out_count` is 0 and
/// `out` may hold some ids.
///
/// The library keeps one buffer per calling thread for decoding (4 bytes per id of the
/// largest set asked for on that thread), so calls in a frame loop do not allocate.
///
/// # Safety
/// `out` must be `NULL` or point to `capacity` writable `uint32_t`s; `out_count` must be
/// `NULL` or point to a writable `size_t`.
#[no_mangle]
pub unsafe extern "C" fn sl_pvs_visible_objects(
    pvs: Option<&SlPvs>,
    cell: u32,
    out: *mut u32,
    capacity: usize,
    out_count: Option<&mut usize>,
) -> SlStatus {
    // SAFETY: the caller's contract is copy_visible's.
    guard_status("sl_pvs_visible_objects", || unsafe {
        copy_visible(pvs, cell, out, capacity, out_count, Set::Objects)
    })
}

/// Copies the ids of the triangles visible from cell `cell` (ascending) to `out`, exactly as
/// `sl_pvs_visible_objects` does with objects (also with a version-1 file).
///
/// # Safety
/// `out` must be `NULL` or point to `capacity` writable `uint32_t`s; `out_count` must be
/// `NULL` or point to a writable `size_t`.
#[no_mangle]
pub unsafe extern "C" fn sl_pvs_visible_triangles(
    pvs: Option<&SlPvs>,
    cell: u32,
    out: *mut u32,
    capacity: usize,
    out_count: Option<&mut usize>,
) -> SlStatus {
    // SAFETY: the caller's contract is copy_visible's.
    guard_status("sl_pvs_visible_triangles", || unsafe {
        copy_visible(pvs, cell, out, capacity, out_count, Set::Triangles)
    })
}

/// 1 when every cell of the file also holds a conservative bound (`pvs bake --bound`): a
/// superset of its set that misses no visible triangle; 0 when not (or `pvs` is `NULL`).
/// The cell's own set is sampled: every id in it is visible, but a few visible ones may be
/// absent. Draw the bound where a frame must never show a hole.
#[no_mangle]
pub extern "C" fn sl_pvs_has_bound(pvs: Option<&SlPvs>) -> u32 {
    guard_value("sl_pvs_has_bound", 0, || {
        Ok(u32::from(handle(pvs)?.pvs.has_bound()))
    })
}

/// Copies the ids of the objects in the conservative bound of cell `cell` (ascending: the
/// visible objects and those the bound adds) to `out`, as `sl_pvs_visible_objects` does;
/// `SL_STATUS_NO_BOUND` when the file holds no bounds.
///
/// # Safety
/// `out` must be `NULL` or point to `capacity` writable `uint32_t`s; `out_count` must be
/// `NULL` or point to a writable `size_t`.
#[no_mangle]
pub unsafe extern "C" fn sl_pvs_bound_objects(
    pvs: Option<&SlPvs>,
    cell: u32,
    out: *mut u32,
    capacity: usize,
    out_count: Option<&mut usize>,
) -> SlStatus {
    // SAFETY: the caller's contract is copy_visible's.
    guard_status("sl_pvs_bound_objects", || unsafe {
        copy_visible(pvs, cell, out, capacity, out_count, Set::BoundObjects)
    })
}

/// Copies the ids of the triangles in the conservative bound of cell `cell` (ascending) to
/// `out`, as `sl_pvs_bound_objects` does with objects.
///
/// # Safety
/// `out` must be `NULL` or point to `capacity` writable `uint32_t`s; `out_count` must be
/// `NULL` or point to a writable `size_t`.
#[no_mangle]
pub unsafe extern "C" fn sl_pvs_bound_triangles(
    pvs: Option<&SlPvs>,
    cell: u32,
    out: *mut u32,
    capacity: usize,
    out_count: Option<&mut usize>,
) -> SlStatus {
    // SAFETY: the caller's contract is copy_visible's.
    guard_status("sl_pvs_bound_triangles", || unsafe {
        copy_visible(pvs, cell, out, capacity, out_count, Set::BoundTriangles)
    })
}
