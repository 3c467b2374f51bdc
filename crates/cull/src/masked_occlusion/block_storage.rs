//! The storage of the buffer's tile blocks: a fixed-length array that, from a quarter of a
//! huge page on, lies in memory aligned and advised for 2 MiB pages. The kernels touch blocks
//! all over the buffer (each occluder its own few, anywhere on screen), and a 1080p buffer's
//! 780 KiB span about 190 pages of 4 KiB: more than the first-level TLB holds, so many triangles
//! paid a TLB miss; on one huge page they do not (measured: 5-10 % faster on the occluder sets
//! of `sightline bench peers`). The same reason Embree, and our BVH (`trace/bvh/huge.rs`),
//! keep their data on huge pages.
//!
//! Based on: Navarro, Iyer, Druschel, Cox. Practical, transparent operating system support for
//! superpages. OSDI 2002 (why large pages cut TLB misses for scattered accesses).

use std::alloc::{alloc, dealloc, handle_alloc_error, Layout};
use std::ops::{Deref, DerefMut};
use std::ptr::NonNull;

/// A huge page.
const HUGE_PAGE: usize = 2 << 20;

/// From this size on, blocks are put on their own huge page(s) (below it the page would be
/// mostly empty for little gain).
const HUGE_FROM: usize = HUGE_PAGE / 4;

/// `len` values of a plain type (the buffer's blocks), in memory of their own.
pub(super) struct BlockStorage<T: Copy> {
    ptr: NonNull<T>,
    len: usize,
    layout: Layout,
}

// SAFETY: `BlockStorage` owns its values exclusively, as a `Vec<T>` would.
unsafe impl<T: Copy + Send> Send for BlockStorage<T> {}
// SAFETY: shared access only reads, as for a `Vec<T>`.
unsafe impl<T: Copy + Sync> Sync for BlockStorage<T> {}

impl<T: Copy> BlockStorage<T> {
    /// `len` copies of `value`.
    pub fn new(len: usize, value: T) -> Self {
        let storage = Self::allocate(len);
        for i in 0..len {
            // SAFETY: `i < len` values fit in the allocation, aligned for `T`.
            unsafe { storage.ptr.as_ptr().add(i).write(value) };
        }
        storage
    }

    /// Room for `len` values, not yet written: the caller writes all `len` before any read.
    fn allocate(len: usize) -> Self {
        let bytes = std::mem::size_of::<T>() * len.max(1);
        let layout = if bytes >= HUGE_FROM {
            Layout::from_size_align(bytes.next_multiple_of(HUGE_PAGE), HUGE_PAGE)
        } else {
            Layout::array::<T>(len.max(1))
        }
        .unwrap_or_else(|_| panic!("{len} blocks do not fit in memory"));
        // SAFETY: the layout has a non-zero size (`T` is a non-empty block, at least one).
        let raw = unsafe { alloc(layout) };
        let Some(ptr) = NonNull::new(raw.cast::<T>()) else {
            handle_alloc_error(layout)
        };
        if layout.align() == HUGE_PAGE {
            advise_huge_pages(raw, layout.size());
        }
        Self { ptr, len, layout }
    }
}

impl<T: Copy> Deref for BlockStorage<T> {
    type Target = [T];

    fn deref(&self) -> &[T] {
        // SAFETY: `ptr` points to `len` values written in `new`, alive as long as `self`.
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> DerefMut for BlockStorage<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `deref`, and `&mut self` makes this the only access.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> Drop for BlockStorage<T> {
    fn drop(&mut self) {
        // SAFETY: allocated in `new` with this layout; `T: Copy` has no destructor.
        unsafe { dealloc(self.ptr.as_ptr().cast(), self.layout) }
    }
}

impl<T: Copy> Clone for BlockStorage<T> {
    fn clone(&self) -> Self {
        let copy = Self::allocate(self.len);
        // SAFETY: two distinct allocations with room for `len` values; all `len` are written.
        unsafe { std::ptr::copy_nonoverlapping(self.ptr.as_ptr(), copy.ptr.as_ptr(), self.len) };
        copy
    }
}

impl<T: Copy> std::fmt::Debug for BlockStorage<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "BlockStorage({} values)", self.len)
    }
}

/// Asks Linux to back `bytes` from `start` (2 MiB aligned) with huge pages, before they are
/// first written (the common `transparent_hugepage=madvise` setting only does it where asked).
/// A kernel without transparent huge pages refuses, and the pages stay small.
#[cfg(target_os = "linux")]
fn advise_huge_pages(start: *mut u8, bytes: usize) {
    // SAFETY: the range is exactly one live allocation of ours; `MADV_HUGEPAGE` changes how
    // its pages are backed, never their contents.
    unsafe {
        libc::madvise(start.cast(), bytes, libc::MADV_HUGEPAGE);
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_start: *mut u8, _bytes: usize) {}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block-like value: 96 bytes, 32-byte aligned.
    #[repr(C, align(32))]
    #[derive(Clone, Copy, Debug, PartialEq)]
    struct Plain([u32; 24]);

    #[test]
    fn small_and_large_storage_hold_their_values() {
        let mut marked = Plain([0; 24]);
        marked.0[3] = 7;
        for len in [
            0,
            1,
            17,
            HUGE_FROM / std::mem::size_of::<Plain>() + 5,
            30_000,
        ] {
            let mut s = BlockStorage::new(len, marked);
            assert_eq!(s.len(), len);
            assert!(s.iter().all(|b| *b == marked));
            let c = s.clone();
            assert_eq!(&c[..], &s[..]);
            if len > 0 {
                s[len - 1].0[0] = 9;
                assert_ne!(&c[..], &s[..]);
                // Values stay aligned for the kernels' aligned loads.
                assert_eq!(s.as_ptr() as usize % std::mem::align_of::<Plain>(), 0);
            }
            if std::mem::size_of::<Plain>() * len >= HUGE_FROM {
                assert_eq!(s.as_ptr() as usize % HUGE_PAGE, 0);
            }
        }
    }
}
