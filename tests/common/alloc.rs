//! A counting global allocator for the tests that hold a path to zero allocations. Each such
//! test file installs it with
//! `#[global_allocator] static GLOBAL: Counting = Counting;` and wraps the path under test in
//! [`allocations_during`] (or, to weigh them, [`bytes_allocated_during`]). Only allocations on
//! the calling thread count: the test harness runs other threads beside it. A path that hands
//! work to a thread of its own is counted on every thread instead
//! ([`allocations_on_every_thread_during`]), in a test file that holds that one test.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// The allocator: the system's, with a per-thread count.
pub struct Counting;

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
    static BYTES: Cell<u64> = const { Cell::new(0) };
}

/// Count on every thread (see [`allocations_on_every_thread_during`]).
static EVERY_THREAD: AtomicBool = AtomicBool::new(false);
static EVERY_THREAD_ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

fn note_allocation(bytes: usize) {
    if EVERY_THREAD.load(Ordering::Relaxed) {
        EVERY_THREAD_ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    }
    if COUNTING.with(Cell::get) {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        BYTES.with(|b| b.set(b.get() + bytes as u64));
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_allocation(layout.size());
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_allocation(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_allocation(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Runs `f` and returns how many allocations it made on this thread. Checks first that the
/// counter sees a deliberate allocation, so a zero cannot come from a counter that is off.
pub fn allocations_during(f: impl FnOnce()) -> u64 {
    ALLOCATIONS.with(|a| a.set(0));
    COUNTING.with(|c| c.set(true));
    drop(std::hint::black_box(vec![1u8; 10]));
    let probe = ALLOCATIONS.with(Cell::get);
    assert_eq!(probe, 1, "the counting allocator is installed");
    ALLOCATIONS.with(|a| a.set(0));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.with(Cell::get)
}

/// Runs `f` and returns the bytes it allocated on this thread (a reallocation counts its new
/// size, a free nothing: an upper bound of what `f` leaves allocated).
pub fn bytes_allocated_during(f: impl FnOnce()) -> u64 {
    BYTES.with(|b| b.set(0));
    COUNTING.with(|c| c.set(true));
    drop(std::hint::black_box(vec![1u8; 10]));
    let probe = BYTES.with(Cell::get);
    assert_eq!(probe, 10, "the counting allocator is installed");
    BYTES.with(|b| b.set(0));
    f();
    COUNTING.with(|c| c.set(false));
    BYTES.with(Cell::get)
}

/// Runs `f` and returns how many allocations every thread of the process made meanwhile: for a
/// path that hands work to threads of its own. Only in a test file holding this one test, so
/// that no other test runs beside it (the harness's own thread waits for the test meanwhile).
/// Checks first that the counter sees a deliberate allocation.
pub fn allocations_on_every_thread_during(f: impl FnOnce()) -> u64 {
    EVERY_THREAD_ALLOCATIONS.store(0, Ordering::SeqCst);
    EVERY_THREAD.store(true, Ordering::SeqCst);
    drop(std::hint::black_box(vec![1u8; 10]));
    let probe = EVERY_THREAD_ALLOCATIONS.swap(0, Ordering::SeqCst);
    assert_eq!(probe, 1, "the counting allocator is installed");
    f();
    EVERY_THREAD.store(false, Ordering::SeqCst);
    EVERY_THREAD_ALLOCATIONS.load(Ordering::SeqCst)
}
