//! Memory stays flat over instantiate/free and get/free-state cycles, and FMU states the
//! importer never freed are freed with their instance. One test in its own process: the
//! allocation counter and the live-state count see nothing else.
// Calls the exported C functions as an importer does; every unsafe block says why it holds.
#![allow(unsafe_code)]

use fmu::exports::states::{
    fmi2DeSerializeFMUstate, fmi2FreeFMUstate, fmi2GetFMUstate, fmi2SerializeFMUstate,
    fmi2SerializedFMUstateSize,
};
use fmu::exports::steps::fmi2DoStep;
use fmu::exports::{
    fmi2EnterInitializationMode, fmi2ExitInitializationMode, fmi2FreeInstance, fmi2SetupExperiment,
};
use fmu::ffi::{OK, live_states};
use std::alloc::{GlobalAlloc, Layout, System};
use std::ffi::c_void;
use std::ptr;

mod instance;
use instance::instantiate;
use std::sync::atomic::{AtomicIsize, Ordering};

/// The system allocator, counting the bytes currently allocated.
struct Counting;

static LIVE_BYTES: AtomicIsize = AtomicIsize::new(0);

// SAFETY: forwards to the system allocator unchanged; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        LIVE_BYTES.fetch_add(l.size() as isize, Ordering::Relaxed);
        // SAFETY: the caller's contract, forwarded.
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE_BYTES.fetch_sub(l.size() as isize, Ordering::Relaxed);
        // SAFETY: the caller's contract, forwarded.
        unsafe { System.dealloc(p, l) }
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// One importer's session: 10 steps, 50 states taken and never freed, 20 taken and
/// freed, one serialized and deserialized (left for the instance to free).
fn session() {
    // SAFETY: valid C strings and callbacks for the duration of each call; every state
    // pointer is written by the FMU before it is passed back.
    unsafe {
        let c = instantiate("memory");
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), OK);
        assert_eq!(fmi2EnterInitializationMode(c), OK);
        assert_eq!(fmi2ExitInitializationMode(c), OK);
        for k in 0..10 {
            assert_eq!(fmi2DoStep(c, f64::from(k) * 1e-3, 1e-3, 1), OK);
        }
        let mut kept: *mut c_void = ptr::null_mut();
        for _ in 0..50 {
            let mut s = ptr::null_mut();
            assert_eq!(fmi2GetFMUstate(c, &mut s), OK);
            kept = s;
        }
        for _ in 0..20 {
            let mut s = ptr::null_mut();
            assert_eq!(fmi2GetFMUstate(c, &mut s), OK);
            assert_eq!(fmi2FreeFMUstate(c, &mut s), OK);
            assert!(s.is_null());
        }
        let mut n = 0;
        assert_eq!(fmi2SerializedFMUstateSize(c, kept, &mut n), OK);
        let mut b = vec![0u8; n];
        assert_eq!(fmi2SerializeFMUstate(c, kept, b.as_mut_ptr().cast(), n), OK);
        let mut copy = ptr::null_mut();
        assert_eq!(
            fmi2DeSerializeFMUstate(c, b.as_ptr().cast(), n, &mut copy),
            OK
        );
        assert_eq!(live_states(), 51);
        fmi2FreeInstance(c);
    }
}

#[test]
fn states_the_importer_did_not_free_are_freed_with_the_instance_and_memory_stays_flat() {
    assert_eq!(live_states(), 0);
    session(); // first use fills the process-wide tables (variables, GUID, hook)
    assert_eq!(live_states(), 0, "every state freed with its instance");
    let before = LIVE_BYTES.load(Ordering::Relaxed);
    for _ in 0..30 {
        session();
    }
    assert_eq!(live_states(), 0);
    let grown = LIVE_BYTES.load(Ordering::Relaxed) - before;
    // 30 sessions of 51 unfreed states each: a leak would be megabytes.
    assert!(
        grown.abs() < 4096,
        "{grown} bytes still allocated after 30 sessions"
    );
}
