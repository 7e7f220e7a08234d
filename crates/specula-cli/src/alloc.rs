//! The process's allocator: the system allocator, with large blocks (at least
//! [`HUGE_BLOCK`]) marked for transparent huge pages (`madvise(MADV_HUGEPAGE)` on Linux), so
//! that touching them costs one page fault per 2 MiB instead of one per 4 KiB. Start-up
//! fills tens of megabytes of fresh memory (decoded textures, mesh arrays, the BVH), and on
//! kernels that give huge pages only where asked (`transparent_hugepage/enabled` =
//! `madvise`, the common default) the faults were a tenth of its CPU time. Contents and
//! alignment are the system allocator's; the advice only chooses the page size, and where
//! the kernel ignores it (huge pages off) nothing changes.

use std::alloc::{GlobalAlloc, Layout, System};

/// Blocks at least this large are advised (two huge pages: a smaller block seldom holds a
/// whole aligned one).
pub const HUGE_BLOCK: usize = 4 << 20;

/// The system allocator, advising huge pages for large blocks.
pub struct HugePageAlloc;

#[cfg(target_os = "linux")]
fn advise(ptr: *mut u8, size: usize) {
    const HUGE_PAGE: usize = 2 << 20;
    if ptr.is_null() || size < HUGE_BLOCK {
        return;
    }
    // the whole 2 MiB pages inside the block
    let start = (ptr as usize).next_multiple_of(HUGE_PAGE);
    let end = (ptr as usize + size) & !(HUGE_PAGE - 1);
    if end > start {
        // SAFETY: advice on pages of the block just allocated, which it owns: it changes
        // neither their contents nor the mapping; an error (e.g. an old kernel) is ignored
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise(_ptr: *mut u8, _size: usize) {}

// SAFETY: every call is forwarded to `System` with the same arguments; `advise` only adds a
// hint on memory the returned block owns.
unsafe impl GlobalAlloc for HugePageAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        advise(p, layout.size());
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        advise(p, layout.size());
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        advise(p, new_size);
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Large and small blocks, zeroed or not, grown and shrunk, keep their contents.
    #[test]
    fn blocks_keep_their_contents() {
        let a = HugePageAlloc;
        for size in [16usize, HUGE_BLOCK - 1, HUGE_BLOCK, 3 * HUGE_BLOCK + 12_345] {
            let layout = Layout::from_size_align(size, 16).unwrap();
            unsafe {
                let z = a.alloc_zeroed(layout);
                assert!(!z.is_null());
                assert!(std::slice::from_raw_parts(z, size).iter().all(|&b| b == 0));
                a.dealloc(z, layout);
                let p = a.alloc(layout);
                assert!(!p.is_null() && (p as usize).is_multiple_of(16));
                for i in (0..size).step_by(4093) {
                    *p.add(i) = (i % 251) as u8;
                }
                let grown = 2 * size + 1;
                let q = a.realloc(p, layout, grown);
                assert!(!q.is_null());
                for i in (0..size).step_by(4093) {
                    assert_eq!(*q.add(i), (i % 251) as u8, "{size} at {i}");
                }
                *q.add(grown - 1) = 7;
                let grown_layout = Layout::from_size_align(grown, 16).unwrap();
                let r = a.realloc(q, grown_layout, size / 2 + 1);
                for i in (0..size / 2 + 1).step_by(4093) {
                    assert_eq!(*r.add(i), (i % 251) as u8, "{size} at {i}");
                }
                a.dealloc(r, Layout::from_size_align(size / 2 + 1, 16).unwrap());
            }
        }
    }
}
