//! The step loop allocates nothing, and a run's heap does not grow with its duration:
//! counted with a global allocator wrapper.

mod common;

use bldc_drive::drive_core::{OpenLoopSixStep, Ticks};
use bldc_drive::plants::PlantParams;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    // Only the test's own thread is counted, into its own counters: the harness may
    // allocate on other threads, and the tests here count concurrently (shared counters
    // made one test see another's allocations).
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
    /// Bytes allocated minus bytes freed on this thread, and the highest it reached.
    static LIVE: Cell<i64> = const { Cell::new(0) };
    static PEAK: Cell<i64> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator unchanged; only counts calls.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(|c| c.get()) {
            ALLOCS.with(|n| n.set(n.get() + 1));
            let live = LIVE.with(|l| {
                l.set(l.get() + layout.size() as i64);
                l.get()
            });
            PEAK.with(|p| p.set(p.get().max(live)));
        }
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if COUNTING.with(|c| c.get()) {
            LIVE.with(|l| l.set(l.get() - layout.size() as i64));
        }
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made on this thread while `f` runs.
fn allocations_during(f: impl FnOnce()) -> u64 {
    COUNTING.with(|c| c.set(true));
    let before = ALLOCS.with(Cell::get);
    f();
    let after = ALLOCS.with(Cell::get);
    COUNTING.with(|c| c.set(false));
    after - before
}

/// The peak of the heap allocated on this thread while `f` runs, above its level at the
/// start \[bytes\].
fn peak_heap_during(f: impl FnOnce()) -> i64 {
    COUNTING.with(|c| c.set(true));
    let start = LIVE.with(Cell::get);
    PEAK.with(|p| p.set(start));
    f();
    COUNTING.with(|c| c.set(false));
    PEAK.with(Cell::get) - start
}

#[test]
fn the_counter_sees_an_allocation() {
    let n = allocations_during(|| drop(std::hint::black_box(Box::new(7u64))));
    assert!(n >= 1, "the counting allocator is not counting");
}

#[test]
fn step_loop_does_not_allocate() {
    let step = Ticks::from_seconds(1.0 / (3000.0 / 60.0 * 36.0)).unwrap();
    let mut e = common::engine(PlantParams::default(), OpenLoopSixStep::new(step, 1000, 1));
    e.plant.set_rotor(0.5, 3000.0, true);
    e.run_until(Ticks::from_seconds(1e-3).unwrap(), |_, _| {})
        .unwrap();
    let mut stops = 0u64;
    let n = allocations_during(|| {
        e.run_until(Ticks::from_seconds(20e-3).unwrap(), |_, _| stops += 1)
            .unwrap();
    });
    assert!(stops > 1000, "the loop ran: {stops} stops");
    assert!(e.plant.comparator_toggles() > 100 && e.plant.stats().diode_events > 10);
    assert_eq!(n, 0, "allocations inside the step loop");
}

#[test]
fn closed_loop_drive_does_not_allocate_in_steady_state() {
    // The default drive: the chip (twelve-step, digital filter) closing the speed loop at
    // 3000 rpm, where it has settled by 2 s.
    let mut e = bldc_drive::drive::build(&bldc_drive::DriveConfig::default()).unwrap();
    let at = |s: f64| Ticks::from_seconds(s).unwrap();
    e.run_until(at(2.0), |_, _| {}).unwrap();
    let (t0, c0) = (e.plant.stats(), e.plant.comparator_toggles());
    let n = allocations_during(|| e.run_until(at(2.2), |_, _| {}).unwrap());
    let speed = e.plant.observe().speed_rpm;
    assert!(
        (speed - 3000.0).abs() < 100.0,
        "closed loop at speed: {speed} rpm"
    );
    assert!(e.plant.stats().steps - t0.steps > 5000);
    assert!(e.plant.comparator_toggles() > c0);
    assert_eq!(n, 0, "allocations inside the step loop");
}

#[test]
fn an_untraced_runs_peak_heap_does_not_grow_with_its_duration() {
    use bldc_drive::scenario::{Scenario, run};
    let peak = |duration_s: f64| {
        let sc = Scenario::hold(bldc_drive::DriveConfig::default(), 3000.0, duration_s);
        peak_heap_during(|| {
            let out = run(&sc, |_| {}).unwrap();
            assert!(out.summary.verdict.is_running(), "{:?}", out.summary);
        })
    };
    // 3 s: the window (from 2 s) begins after the start-up has settled (1.7 s).
    let (short, long) = (peak(3.0), peak(8.0));
    // 5 s more of drive: a record kept per millisecond would add 160 kB.
    assert!(
        (long - short).abs() < 16_000,
        "peak heap {short} B over 3 s, {long} B over 8 s"
    );
}
