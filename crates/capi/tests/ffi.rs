//! The exported functions called directly from Rust: null arguments, out-of-range indices,
//! damaged files, buffers too small, names with NUL bytes, version-1 files, and the
//! thread-local last error.

// Test helpers panic on failure: that is the report we want.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::ffi::{c_char, CStr, CString};
use std::ptr;
use std::sync::OnceLock;

use sightline::*;
use sightline_runtime::Pvs;

fn last_error() -> String {
    // SAFETY: sl_last_error returns a valid NUL-terminated string.
    unsafe { CStr::from_ptr(sl_last_error()) }
        .to_str()
        .unwrap()
        .to_owned()
}

/// Asserts that the last error names `function` and contains `part`.
#[track_caller]
fn assert_error(function: &str, part: &str) {
    let message = last_error();
    assert!(
        message.starts_with(&format!("{function}: ")),
        "message {message:?}"
    );
    assert!(message.contains(part), "message {message:?} lacks {part:?}");
}

/// The test scene's bytes, baked once for all tests.
fn bytes() -> &'static [u8] {
    static BYTES: OnceLock<Vec<u8>> = OnceLock::new();
    BYTES.get_or_init(|| common::bake().bytes)
}

/// An open handle, closed when dropped.
struct Handle(*mut SlPvs);

impl Handle {
    fn of(bytes: &[u8]) -> Self {
        // SAFETY: a valid buffer.
        let h = unsafe { sl_pvs_open_memory(bytes.as_ptr(), bytes.len()) };
        assert!(!h.is_null(), "{}", last_error());
        Handle(h)
    }
    fn get(&self) -> Option<&SlPvs> {
        // SAFETY: open until drop.
        unsafe { self.0.as_ref() }
    }
}

impl Drop for Handle {
    fn drop(&mut self) {
        // SAFETY: opened by `of`, closed once.
        unsafe { sl_pvs_close(self.0) }
    }
}

fn open_memory(bytes: &[u8]) -> *mut SlPvs {
    // SAFETY: a valid buffer.
    unsafe { sl_pvs_open_memory(bytes.as_ptr(), bytes.len()) }
}

/// `sl_pvs_visible_objects` and `sl_pvs_visible_triangles`.
type VisibleFn =
    unsafe extern "C" fn(Option<&SlPvs>, u32, *mut u32, usize, Option<&mut usize>) -> SlStatus;

fn visible(h: Option<&SlPvs>, cell: u32, out: &mut [u32], objects: bool) -> (SlStatus, usize) {
    let mut count = usize::MAX;
    let f: VisibleFn = if objects {
        sl_pvs_visible_objects
    } else {
        sl_pvs_visible_triangles
    };
    // SAFETY: `out` has room for its length.
    let status = unsafe { f(h, cell, out.as_mut_ptr(), out.len(), Some(&mut count)) };
    (status, count)
}

#[test]
fn counts_and_answers_are_the_runtimes() {
    let pvs = Pvs::from_bytes(bytes().to_vec()).unwrap();
    let h = Handle::of(bytes());
    assert_eq!(sl_pvs_version(h.get()), pvs.version());
    assert_eq!(sl_pvs_cell_count(h.get()), pvs.cell_count());
    assert_eq!(sl_pvs_object_count(h.get()), pvs.object_count());
    assert_eq!(sl_pvs_triangle_count(h.get()), pvs.triangle_count());
    assert_eq!(sl_pvs_scene_hash(h.get()), pvs.scene_hash());
    for cell in 0..pvs.cell_count() {
        let mut c = SlCell::default();
        assert_eq!(sl_pvs_cell(h.get(), cell, Some(&mut c)), SlStatus::Ok);
        let r = pvs.cell(cell).unwrap();
        assert_eq!(
            (c.center, c.axes, c.half_extents),
            (r.center, r.axes, r.half_extents)
        );
        let mut ids = vec![0; 200];
        let (status, n) = visible(h.get(), cell, &mut ids, false);
        assert_eq!(
            (status, &ids[..n]),
            (SlStatus::Ok, &pvs.visible_triangles(cell).unwrap()[..])
        );
        if pvs.version() >= 2 {
            let (status, n) = visible(h.get(), cell, &mut ids, true);
            assert_eq!(
                (status, &ids[..n]),
                (SlStatus::Ok, &pvs.visible_objects(cell).unwrap()[..])
            );
        }
    }
    for text in &common::POSITIONS {
        let p = common::position(text);
        let mut cell = 12345;
        // SAFETY: 3 floats.
        let status = unsafe { sl_pvs_cell_at(h.get(), p.as_ptr(), Some(&mut cell)) };
        match pvs.cell_at(p) {
            Some(c) => assert_eq!((status, cell), (SlStatus::Ok, c), "{text:?}"),
            None => assert_eq!((status, cell), (SlStatus::Outside, SL_NONE), "{text:?}"),
        }
    }
}

#[test]
fn object_names_are_nul_terminated_and_keep_inner_nul_bytes() {
    let h = Handle::of(bytes());
    if sl_pvs_version(h.get()) < 2 {
        eprintln!("note: version-1 bake, no objects to check");
        return;
    }
    for (i, name) in common::NAMES.iter().enumerate() {
        let mut o = std::mem::MaybeUninit::<SlObject>::uninit();
        // SAFETY: the function writes the whole struct on success.
        let o = unsafe {
            assert_eq!(
                sl_pvs_object(h.get(), i as u32, Some(o.assume_init_mut())),
                SlStatus::Ok
            );
            o.assume_init()
        };
        assert_eq!(o.name_len, name.len());
        // SAFETY: name points to name_len bytes and a NUL, owned by the open handle.
        let bytes = unsafe { std::slice::from_raw_parts(o.name.cast::<u8>(), o.name_len + 1) };
        assert_eq!(&bytes[..o.name_len], name.as_bytes());
        assert_eq!(bytes[o.name_len], 0);
        // SAFETY: NUL-terminated.
        let c = unsafe { CStr::from_ptr(o.name) }.to_bytes();
        assert_eq!(c, name.split('\0').next().unwrap().as_bytes());
        assert_eq!((o.index, o.part), (SL_NONE, SL_NONE));
        assert!(o
            .bounds_min
            .iter()
            .zip(o.bounds_max)
            .all(|(lo, hi)| *lo <= hi));
    }
}

#[test]
fn null_arguments_are_errors_with_a_message() {
    let h = Handle::of(bytes());
    // SAFETY: null pointers are what is tested; nothing else is passed.
    unsafe {
        sl_pvs_close(ptr::null_mut()); // a no-op
        assert!(sl_pvs_open(ptr::null()).is_null());
        assert_error("sl_pvs_open", "path is NULL");
        assert!(sl_pvs_open_memory(ptr::null(), 0).is_null());
        assert_error("sl_pvs_open_memory", "data is NULL");
        assert!(sl_pvs_open_memory(ptr::null(), 10).is_null());
        assert_error("sl_pvs_open_memory", "data is NULL");
    }
    assert_eq!(sl_pvs_version(None), 0);
    assert_error("sl_pvs_version", "pvs is NULL");
    assert_eq!(sl_pvs_cell_count(None), 0);
    assert_error("sl_pvs_cell_count", "pvs is NULL");
    assert_eq!(sl_pvs_object_count(None), 0);
    assert_error("sl_pvs_object_count", "pvs is NULL");
    assert_eq!(sl_pvs_triangle_count(None), 0);
    assert_error("sl_pvs_triangle_count", "pvs is NULL");
    assert_eq!(sl_pvs_scene_hash(None), 0);
    assert_error("sl_pvs_scene_hash", "pvs is NULL");

    let mut cell = SlCell::default();
    assert_eq!(
        sl_pvs_cell(None, 0, Some(&mut cell)),
        SlStatus::NullArgument
    );
    assert_error("sl_pvs_cell", "pvs is NULL");
    assert_eq!(sl_pvs_cell(h.get(), 0, None), SlStatus::NullArgument);
    assert_error("sl_pvs_cell", "out is NULL");

    let p = [-6.0f32, -4.0, 1.5];
    let mut index = 0;
    // SAFETY: null or valid pointers.
    unsafe {
        assert_eq!(
            sl_pvs_cell_at(None, p.as_ptr(), Some(&mut index)),
            SlStatus::NullArgument
        );
        assert_error("sl_pvs_cell_at", "pvs is NULL");
        assert_eq!(
            sl_pvs_cell_at(h.get(), ptr::null(), Some(&mut index)),
            SlStatus::NullArgument
        );
        assert_error("sl_pvs_cell_at", "position is NULL");
        assert_eq!(
            sl_pvs_cell_at(h.get(), p.as_ptr(), None),
            SlStatus::NullArgument
        );
        assert_error("sl_pvs_cell_at", "out_cell is NULL");
    }

    assert_eq!(sl_pvs_object(None, 0, None), SlStatus::NullArgument);
    assert_error("sl_pvs_object", "pvs is NULL");
    assert_eq!(sl_pvs_object(h.get(), 0, None), SlStatus::NullArgument);
    assert_error("sl_pvs_object", "out is NULL");

    for (f, name) in [
        (
            sl_pvs_visible_objects as VisibleFn,
            "sl_pvs_visible_objects",
        ),
        (sl_pvs_visible_triangles, "sl_pvs_visible_triangles"),
    ] {
        let mut out = [0u32; 4];
        let mut count = 99;
        // SAFETY: null or valid pointers with their capacity.
        unsafe {
            assert_eq!(
                f(None, 0, out.as_mut_ptr(), 4, Some(&mut count)),
                SlStatus::NullArgument
            );
            assert_error(name, "pvs is NULL");
            assert_eq!(count, 0);
            assert_eq!(
                f(h.get(), 0, out.as_mut_ptr(), 4, None),
                SlStatus::NullArgument
            );
            assert_error(name, "out_count is NULL");
            count = 99;
            assert_eq!(
                f(h.get(), 0, ptr::null_mut(), 4, Some(&mut count)),
                SlStatus::NullArgument
            );
            assert_error(name, "out is NULL");
            assert_eq!(count, 0);
            // A misaligned buffer.
            let bytes = out.as_mut_ptr().cast::<u8>().add(1).cast::<u32>();
            assert_eq!(
                f(h.get(), 0, bytes, 2, Some(&mut count)),
                SlStatus::InvalidArgument
            );
            assert_error(name, "aligned");
        }
    }
}

#[test]
fn out_of_range_indices_are_errors_with_a_message() {
    let h = Handle::of(bytes());
    let cells = sl_pvs_cell_count(h.get());
    let objects = sl_pvs_object_count(h.get());
    let mut cell = SlCell {
        center: [7.0; 3],
        ..SlCell::default()
    };
    for bad in [cells, cells + 1, u32::MAX] {
        assert_eq!(
            sl_pvs_cell(h.get(), bad, Some(&mut cell)),
            SlStatus::OutOfRange
        );
        assert_error(
            "sl_pvs_cell",
            &format!("cell {bad} does not exist (the file has {cells} cells)"),
        );
        assert_eq!(cell.center, [7.0; 3], "left unchanged");
        for objects_set in [true, false] {
            for capacity in [0, 8] {
                let mut out = vec![0; capacity];
                let (status, count) = visible(h.get(), bad, &mut out, objects_set);
                assert_eq!((status, count), (SlStatus::OutOfRange, 0));
                assert!(last_error().contains(&format!("cell {bad} does not exist")));
            }
        }
    }
    let mut o = SlObject {
        name: ptr::null(),
        name_len: 0,
        index: 0,
        part: 0,
        bounds_min: [0.0; 3],
        bounds_max: [0.0; 3],
    };
    for bad in [objects, objects + 1, u32::MAX] {
        assert_eq!(
            sl_pvs_object(h.get(), bad, Some(&mut o)),
            SlStatus::OutOfRange
        );
        assert_error(
            "sl_pvs_object",
            &format!("object {bad} does not exist (the file has {objects} objects)"),
        );
        assert!(o.name.is_null(), "left unchanged");
    }
}

#[test]
fn small_buffers_get_the_first_ids_and_the_full_count() {
    let pvs = Pvs::from_bytes(bytes().to_vec()).unwrap();
    let h = Handle::of(bytes());
    let mut sets = vec![(false, pvs.visible_triangles(2).unwrap())];
    if pvs.version() >= 2 {
        sets.push((true, pvs.visible_objects(2).unwrap()));
    }
    for (objects, full) in sets {
        let n = full.len();
        assert!(n >= 2, "the test scene's cell 2 sees {n} ids");
        // Sizing call: no buffer at all.
        let mut count = 0;
        let f: VisibleFn = if objects {
            sl_pvs_visible_objects
        } else {
            sl_pvs_visible_triangles
        };
        // SAFETY: capacity 0, no buffer needed.
        let status = unsafe { f(h.get(), 2, ptr::null_mut(), 0, Some(&mut count)) };
        assert_eq!((status, count), (SlStatus::Incomplete, n));
        for capacity in [1, n - 1, n, n + 3] {
            let mut out = vec![u32::MAX; capacity];
            let (status, count) = visible(h.get(), 2, &mut out, objects);
            let want = if capacity < n {
                SlStatus::Incomplete
            } else {
                SlStatus::Ok
            };
            assert_eq!((status, count), (want, n), "capacity {capacity}");
            let written = capacity.min(n);
            assert_eq!(&out[..written], &full[..written]);
            assert!(
                out[written..].iter().all(|&v| v == u32::MAX),
                "nothing written past the set"
            );
        }
    }
}

#[test]
fn version_1_files_have_no_objects() {
    let v1 = common::bake_v1();
    let h = Handle::of(&v1.bytes);
    assert_eq!(sl_pvs_version(h.get()), 1);
    assert_eq!(sl_pvs_object_count(h.get()), 0);
    for capacity in [0, 16] {
        let mut out = vec![0; capacity];
        let (status, count) = visible(h.get(), 0, &mut out, true);
        assert_eq!((status, count), (SlStatus::NoObjects, 0));
        assert_error("sl_pvs_visible_objects", "no object table (version 1)");
    }
    let mut out = vec![0; 200];
    let (status, count) = visible(h.get(), 0, &mut out, false);
    assert_eq!(status, SlStatus::Ok);
    assert!(count > 0);
    let mut o = std::mem::MaybeUninit::<SlObject>::uninit();
    // SAFETY: a valid out pointer (not written on failure).
    assert_eq!(
        sl_pvs_object(h.get(), 0, Some(unsafe { o.assume_init_mut() })),
        SlStatus::OutOfRange
    );
}

#[test]
fn damaged_files_give_null_and_a_message() {
    let good = bytes();
    // Every truncation.
    for len in 0..good.len() {
        let h = open_memory(&good[..len]);
        assert!(h.is_null(), "truncated to {len} bytes opened");
        let message = last_error();
        assert!(
            message.starts_with("sl_pvs_open_memory: ") && message.len() > 20,
            "{len}: {message}"
        );
    }
    // Every byte flipped (each bit of it in turn, a byte at a time). The file's checksums
    // cover every byte, so each must be caught at open.
    let mut damaged = good.to_vec();
    for i in 0..good.len() {
        for bit in 0..8 {
            damaged[i] ^= 1 << bit;
            let h = open_memory(&damaged);
            damaged[i] = good[i];
            if !h.is_null() {
                // SAFETY: just opened.
                unsafe { sl_pvs_close(h) };
                panic!("byte {i} with bit {bit} flipped opened");
            }
            let message = last_error();
            assert!(
                message.starts_with("sl_pvs_open_memory: ") && message.len() > 20,
                "{i}: {message}"
            );
        }
    }
    // The message is the runtime's.
    damaged[good.len() / 2] ^= 0xff;
    assert!(open_memory(&damaged).is_null());
    let want = Pvs::from_bytes(damaged.clone()).unwrap_err().to_string();
    assert_eq!(last_error(), format!("sl_pvs_open_memory: {want}"));
    assert!(open_memory(b"not a pvs file at all").is_null());
    assert_error("sl_pvs_open_memory", "not a .pvs file");
}

#[test]
fn open_reads_files_and_reports_the_path_of_a_missing_one() {
    let baked = common::bake();
    let path = CString::new(baked.path.to_str().unwrap()).unwrap();
    // SAFETY: NUL-terminated paths.
    unsafe {
        let h = sl_pvs_open(path.as_ptr());
        assert!(!h.is_null(), "{}", last_error());
        assert_eq!(sl_pvs_cell_count(h.as_ref()), 4);
        sl_pvs_close(h);
        let missing = CString::new(baked.dir.path().join("missing.pvs").to_str().unwrap()).unwrap();
        assert!(sl_pvs_open(missing.as_ptr()).is_null());
        assert_error("sl_pvs_open", "missing.pvs");
        let dir = CString::new(baked.dir.path().to_str().unwrap()).unwrap();
        assert!(sl_pvs_open(dir.as_ptr()).is_null());
        assert_error("sl_pvs_open", baked.dir.path().to_str().unwrap());
    }
}

#[test]
fn the_last_error_is_per_thread_and_kept_by_successful_calls() {
    std::thread::spawn(|| {
        assert_eq!(last_error(), "", "a fresh thread has no error");
        assert_eq!(sl_pvs_cell_count(None), 0);
        let message = last_error();
        assert!(message.starts_with("sl_pvs_cell_count"));
        let h = Handle::of(bytes());
        assert!(sl_pvs_cell_count(h.get()) > 0);
        assert_eq!(
            last_error(),
            message,
            "a successful call leaves the message"
        );
        std::thread::spawn(|| assert_eq!(last_error(), ""))
            .join()
            .unwrap();
    })
    .join()
    .unwrap();
    // The pointer is never null, and is the same string until the next call.
    let p: *const c_char = sl_last_error();
    assert!(!p.is_null());
}

#[test]
fn one_handle_answers_many_threads_at_once() {
    let pvs = Pvs::from_bytes(bytes().to_vec()).unwrap();
    let h = Handle::of(bytes());
    let want: Vec<Vec<u32>> = (0..pvs.cell_count())
        .map(|c| pvs.visible_triangles(c).unwrap())
        .collect();
    struct Shared(*mut SlPvs);
    // SAFETY: the handle is Send + Sync (checked at compile time in the library).
    unsafe impl Sync for Shared {}
    let shared = Shared(h.0);
    std::thread::scope(|s| {
        for t in 0..4 {
            let (shared, want) = (&shared, &want);
            s.spawn(move || {
                // SAFETY: open for the whole scope.
                let handle = unsafe { shared.0.as_ref() };
                for round in 0..200 {
                    let cell = ((t + round) % want.len()) as u32;
                    let mut out = vec![0; 256];
                    let (status, n) = visible(handle, cell, &mut out, false);
                    assert_eq!(
                        (status, &out[..n]),
                        (SlStatus::Ok, &want[cell as usize][..])
                    );
                }
            });
        }
    });
}

/// The test file with a conservative bound per cell: its set and every triangle of the
/// hidden box (in no cell's set: a bound may hold what is not visible).
fn bytes_with_bounds() -> Vec<u8> {
    let mut file = sightline_region::PvsFile::read(bytes()).unwrap();
    let hidden: Vec<u32> = Pvs::from_bytes(bytes().to_vec())
        .unwrap()
        .object_triangles(common::HIDDEN)
        .unwrap()
        .flatten()
        .collect();
    for c in &mut file.cells {
        let mut bound = c.visible.clone();
        hidden.iter().for_each(|&t| bound.insert(t as usize));
        c.bound = Some(bound);
    }
    let mut out = Vec::new();
    file.write(&mut out).unwrap();
    out
}

type BoundFn =
    unsafe extern "C" fn(Option<&SlPvs>, u32, *mut u32, usize, Option<&mut usize>) -> SlStatus;

fn call(f: BoundFn, h: Option<&SlPvs>, cell: u32, out: &mut [u32]) -> (SlStatus, usize) {
    let mut count = usize::MAX;
    // SAFETY: `out` has room for its length; `count` is writable.
    let status = unsafe { f(h, cell, out.as_mut_ptr(), out.len(), Some(&mut count)) };
    (status, count)
}

#[test]
fn bounds_are_the_runtimes_and_their_absence_is_an_error() {
    let bytes = bytes_with_bounds();
    let pvs = Pvs::from_bytes(bytes.clone()).unwrap();
    let h = Handle::of(&bytes);
    assert_eq!(sl_pvs_has_bound(h.get()), 1);
    for cell in 0..pvs.cell_count() {
        let mut want = Vec::new();
        pvs.bound_triangles_into(cell, &mut want).unwrap();
        assert!(want.len() > pvs.visible_triangle_count(cell).unwrap() as usize);
        // A sizing call, then the copy.
        assert_eq!(
            call(sl_pvs_bound_triangles, h.get(), cell, &mut []),
            (SlStatus::Incomplete, want.len())
        );
        let mut out = vec![u32::MAX; want.len()];
        let (status, n) = call(sl_pvs_bound_triangles, h.get(), cell, &mut out);
        assert_eq!((status, n, &out), (SlStatus::Ok, want.len(), &want));
        // The hidden box's object is in every cell's bound and in no cell's set.
        let mut objects = vec![0; 16];
        let (status, n) = call(sl_pvs_bound_objects, h.get(), cell, &mut objects);
        assert_eq!(status, SlStatus::Ok);
        assert!(objects[..n].contains(&common::HIDDEN));
        assert!(!pvs.visible_objects(cell).unwrap().contains(&common::HIDDEN));
    }
    let plain = Handle::of(self::bytes());
    assert_eq!(sl_pvs_has_bound(plain.get()), 0);
    assert_eq!(sl_pvs_has_bound(None), 0);
    let (status, n) = call(sl_pvs_bound_triangles, plain.get(), 0, &mut [0; 8]);
    assert_eq!((status, n), (SlStatus::NoBound, 0));
    assert_error("sl_pvs_bound_triangles", "no conservative bounds");
}
