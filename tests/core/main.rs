//! The library's integration tests, in-process: the mask, heads and fits, every deformer,
//! the metrics, streams, parts and the wire, on the shipped heads and the population. One
//! binary (one link) for all of them; each file is a module named as it was.
//!
//! A counting global allocator watches each thread, so a test can check that per-frame
//! code allocates nothing while other tests run beside it.

#[path = "../common/mod.rs"]
mod common;

mod arkit;
mod automatic_fit;
mod biharmonic;
mod compare;
mod contact;
mod default_algorithm;
mod deform;
mod eyes;
mod fit_report;
mod fit_units;
mod frame_checks;
mod geometry;
mod glb;
mod head_motion;
mod jaw;
mod kshirsagar;
mod lip_sides;
mod lip_tint;
mod metrics;
mod mouth_calibration;
mod no_alloc;
mod population;
mod rbf;
mod streams;
mod visemes;
mod wire;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// Counts this thread's allocations and reallocations.
struct CountingAllocator;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn count_allocation() {
    let _ = ALLOCATIONS.try_with(|n| n.set(n.get() + 1));
}

// SAFETY: forwards every call unchanged to the system allocator; counting touches only a
// const-initialised thread-local `Cell`, which never allocates.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_allocation();
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_allocation();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Allocations (and reallocations) this thread made while `f` ran.
pub fn allocations_during(f: impl FnOnce()) -> u64 {
    let before = ALLOCATIONS.with(Cell::get);
    f();
    ALLOCATIONS.with(Cell::get) - before
}
