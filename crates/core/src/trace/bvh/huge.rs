//! Moving the BVH's arrays onto transparent huge pages. Incoherent rays jump across tens of
//! megabytes of nodes and packets; with 4 KiB pages nearly every step also misses the TLB and
//! walks the page tables, which 2 MiB pages avoid (a 1M-triangle tree spans about 30 of them).
//! Linux backs anonymous memory with huge pages only where asked (`madvise(MADV_HUGEPAGE)`,
//! the common `transparent_hugepage=madvise` setting), and the advice must come before the
//! pages are first written, so the finished arrays are copied into advised memory. Embree
//! does the same for its BVH on Linux (its `hugepages` device option, on by default there).
//!
//! Based on: Navarro, Iyer, Druschel, Cox. Practical, transparent operating system support for
//! superpages. OSDI 2002 (why large pages cut TLB misses for big, scattered working sets).

/// `v` moved into memory advised for huge pages, without spare capacity. Elsewhere than Linux,
/// or where the advice is refused, only the spare capacity goes.
pub(super) fn onto_huge_pages<T: Copy>(v: Vec<T>) -> Vec<T> {
    let bytes = std::mem::size_of_val(v.as_slice());
    // Below one huge page the advice cannot help.
    if bytes < 2 << 20 {
        let mut v = v;
        v.shrink_to_fit();
        return v;
    }
    let mut out: Vec<T> = Vec::with_capacity(v.len());
    advise(out.as_ptr().cast(), bytes);
    out.extend_from_slice(&v);
    out
}

#[cfg(target_os = "linux")]
fn advise(start: *const u8, bytes: usize) {
    const PAGE: usize = 4096;
    let first = start as usize / PAGE * PAGE;
    let len = start as usize + bytes - first;
    // SAFETY: the range covers only pages of one live allocation (the start is rounded down
    // to its page, which the allocation occupies); `MADV_HUGEPAGE` changes how they are
    // backed, never their contents. A failure (a kernel without THP) leaves them as they are.
    unsafe {
        libc::madvise(first as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
    }
}

#[cfg(not(target_os = "linux"))]
fn advise(_start: *const u8, _bytes: usize) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_contents() {
        for n in [0usize, 5, 1 << 20] {
            let v: Vec<u32> = (0..n as u32).collect();
            let mut spare = v.clone();
            spare.reserve(100);
            assert_eq!(onto_huge_pages(spare), v);
        }
    }
}
