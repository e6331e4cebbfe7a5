//! The step loop allocates nothing: counted with a global allocator wrapper.

mod common;

use bldc_drive::drive_core::{OpenLoopSixStep, Ticks};
use bldc_drive::plants::PlantParams;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU64, Ordering};

struct Counting;
static ALLOCS: AtomicU64 = AtomicU64::new(0);

thread_local! {
    // Only the test's own thread is counted: the harness may allocate on other threads.
    static COUNTING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

// SAFETY: forwards to the system allocator unchanged; only counts calls.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(|c| c.get()) {
            ALLOCS.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn step_loop_does_not_allocate() {
    let step = Ticks::from_seconds(1.0 / (3000.0 / 60.0 * 36.0)).unwrap();
    let mut e = common::engine(PlantParams::default(), OpenLoopSixStep::new(step, 1000, 1));
    e.plant.set_rotor(0.5, 3000.0, true);
    e.run_until(Ticks::from_seconds(1e-3).unwrap(), |_, _| {})
        .unwrap();
    let before = ALLOCS.load(Ordering::Relaxed);
    let mut stops = 0u64;
    e.run_until(Ticks::from_seconds(20e-3).unwrap(), |_, _| stops += 1)
        .unwrap();
    let after = ALLOCS.load(Ordering::Relaxed);
    assert!(stops > 1000, "the loop ran: {stops} stops");
    assert!(e.plant.comparator_toggles() > 100 && e.plant.stats().diode_events > 10);
    assert_eq!(after - before, 0, "allocations inside the step loop");
}
