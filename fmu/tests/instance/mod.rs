//! An instance of the FMU made through its exported C function, as an importer makes one
//! (no logger, no allocator callbacks): shared by the tests that call the exports directly.

use fmu::exports::fmi2Instantiate;
use fmu::ffi::CallbackFunctions;
use std::ffi::{CString, c_void};
use std::ptr;

/// A new co-simulation instance named `name`; panics if the FMU refuses it.
pub fn instantiate(name: &str) -> *mut c_void {
    let cb = CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: ptr::null_mut(),
    };
    let name = CString::new(name).unwrap();
    let guid = CString::new(fmu::xml::guid()).unwrap();
    // SAFETY: valid C strings and callbacks for the duration of the call (the FMU copies
    // what it keeps).
    let c = unsafe { fmi2Instantiate(name.as_ptr(), 1, guid.as_ptr(), ptr::null(), &cb, 0, 0) };
    assert!(!c.is_null());
    c
}
