//! The largest single allocation each thread asked for, recorded by this test binary's global
//! allocator, so a test can show that an importer never allocated what a hostile or refused
//! file claims: [`reset`], run the code, read [`peak_bytes`].

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct PeakAllocation;

thread_local! {
    static PEAK_BYTES: Cell<usize> = const { Cell::new(0) };
}

fn record(bytes: usize) {
    let _ = PEAK_BYTES.try_with(|peak| peak.set(peak.get().max(bytes)));
}

// SAFETY: every call is forwarded unchanged to the system allocator.
unsafe impl GlobalAlloc for PeakAllocation {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        record(layout.size());
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        record(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        record(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: PeakAllocation = PeakAllocation;

/// Forgets this thread's peak.
pub fn reset() {
    PEAK_BYTES.with(|peak| peak.set(0));
}

/// This thread's largest single allocation since [`reset`], bytes.
pub fn peak_bytes() -> usize {
    PEAK_BYTES.with(Cell::get)
}
