//! The 34 FMI 2.0 co-simulation functions. Each is a thin shim: check pointers, find the
//! instance, call the safe core ([`crate::model`]), log what went wrong, return a status.
//! Nothing panics across the boundary ([`crate::ffi::with_instance`], [`guarded`]).
//! Grouped as: life cycle (here), [`values`], [`states`], [`steps`].
#![allow(non_snake_case)]

pub mod states;
pub mod steps;
pub mod values;

use crate::ffi::{
    CallbackFunctions, Category, ERROR, Handle, Instance, OK, Status, guarded, log_raw, register,
    resources_of_uri, take_states_of, unregister, with_instance,
};
use crate::model::Fault;
use crate::xml::{LOG_CATEGORIES, guid};
use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::ptr;

pub(crate) type Component = *mut c_void;
pub(crate) type FmuState = *mut c_void;

/// Borrows `n` elements at `p` (empty when `n` is 0, whatever `p` is).
///
/// # Safety
/// When `n > 0`, `p` must be non-null and point to `n` readable elements.
pub(crate) unsafe fn slice<'a, T>(p: *const T, n: usize) -> &'a [T] {
    if n == 0 {
        &[]
    } else {
        // SAFETY: the caller's contract.
        unsafe { std::slice::from_raw_parts(p, n) }
    }
}

/// Borrows `n` writable elements at `p`.
///
/// # Safety
/// When `n > 0`, `p` must be non-null and point to `n` writable elements.
pub(crate) unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> &'a mut [T] {
    if n == 0 {
        &mut []
    } else {
        // SAFETY: the caller's contract.
        unsafe { std::slice::from_raw_parts_mut(p, n) }
    }
}

pub(crate) fn null_error(inst: &Instance, call: &str, what: &str) -> Status {
    inst.report(call, Err(Fault::Error(format!("{what} is NULL"))))
}

pub(crate) fn unsupported(c: Component, call: &str, why: &str) -> Status {
    guarded(ERROR, || {
        with_instance(c, call, |inst| {
            inst.report(call, Err(Fault::Error(format!("not supported: {why}"))))
        })
    })
}

/// `fmi2GetTypesPlatform`.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

/// `fmi2GetVersion`.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

/// `fmi2SetDebugLogging`: no categories switches all; otherwise only the named ones.
///
/// # Safety
/// FMI contract: `categories` holds `n` C strings.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Component,
    logging_on: c_int,
    n: usize,
    categories: *const *const c_char,
) -> Status {
    const CALL: &str = "fmi2SetDebugLogging";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            let on = logging_on != 0;
            if n == 0 {
                inst.enabled = [on; 3];
                return OK;
            }
            if categories.is_null() {
                return null_error(inst, CALL, "categories");
            }
            // SAFETY: non-null, `n` entries per the FMI contract.
            for &p in unsafe { slice(categories, n) } {
                if p.is_null() {
                    return null_error(inst, CALL, "a category");
                }
                // SAFETY: a NUL-terminated string per the FMI contract.
                let name = unsafe { CStr::from_ptr(p) }.to_string_lossy();
                match LOG_CATEGORIES.iter().position(|(c, _)| *c == name) {
                    Some(i) => inst.enabled[i] = on,
                    None => {
                        let msg = format!(
                            "unknown log category `{name}` (rule: one of logStatusError, logStatusWarning, logEvents)"
                        );
                        return inst.report(CALL, Err(Fault::Error(msg)));
                    }
                }
            }
            OK
        })
    })
}

/// `fmi2Instantiate`: NULL (with a logged reason) for a wrong GUID, a missing name, or a
/// model-exchange request.
///
/// # Safety
/// FMI contract: strings are NUL-terminated or NULL; `functions` points to the callbacks.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: *const c_char,
    fmu_type: c_int,
    fmu_guid: *const c_char,
    resource_location: *const c_char,
    functions: *const CallbackFunctions,
    _visible: c_int,
    logging_on: c_int,
) -> Component {
    guarded(ptr::null_mut(), || {
        if functions.is_null() {
            return ptr::null_mut();
        }
        // SAFETY: non-null; copied because the pointer is only valid during this call.
        let cb = unsafe { *functions };
        let name = if instance_name.is_null() {
            CString::default()
        } else {
            // SAFETY: a NUL-terminated string per the FMI contract.
            unsafe { CStr::from_ptr(instance_name) }.to_owned()
        };
        let fail = |msg: String| {
            let log = format!("fmi2Instantiate: {msg}");
            log_raw(
                cb.logger,
                cb.component_environment,
                &name,
                ERROR,
                Category::Error,
                &log,
            );
            ptr::null_mut()
        };
        if name.is_empty() {
            return fail("instanceName is NULL or empty (rule: a non-empty name)".into());
        }
        if fmu_type != 1 {
            return fail(format!(
                "fmuType = {fmu_type} (rule: 1, fmi2CoSimulation; this FMU has no model exchange)"
            ));
        }
        let given = if fmu_guid.is_null() {
            String::from("NULL")
        } else {
            // SAFETY: a NUL-terminated string per the FMI contract.
            unsafe { CStr::from_ptr(fmu_guid) }
                .to_string_lossy()
                .into_owned()
        };
        if given != guid() {
            return fail(format!(
                "wrong GUID {given} (rule: must equal the modelDescription.xml guid {})",
                guid()
            ));
        }
        let mut inst = Instance::new(name, &cb, logging_on != 0);
        if !resource_location.is_null() {
            // SAFETY: a NUL-terminated string per the FMI contract; copied, not kept.
            let uri = unsafe { CStr::from_ptr(resource_location) }.to_string_lossy();
            inst.model.resources = resources_of_uri(&uri);
        }
        inst.log(OK, Category::Events, "instantiated");
        let p = Box::into_raw(Box::new(inst)).cast::<c_void>();
        register(Handle::Instance, p, ptr::null_mut());
        p
    })
}

/// `fmi2FreeInstance`: ignores NULL and pointers that are not live instances. Frees the
/// FMU states the instance made that the master did not free.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2FreeInstance(c: Component) {
    guarded((), || {
        if unregister(Handle::Instance, c) {
            for s in take_states_of(c) {
                // SAFETY: it was live, so it is our Box; unregistered, so freed exactly once.
                drop(unsafe { Box::from_raw(s.cast::<crate::state::Snapshot>()) });
            }
            // SAFETY: it was live, so it is our Box; unregistered, so freed exactly once.
            drop(unsafe { Box::from_raw(c.cast::<Instance>()) });
        }
    })
}

/// `fmi2SetupExperiment` (the tolerance is not used: the plant's step is a parameter).
#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetupExperiment(
    c: Component,
    _tolerance_defined: c_int,
    _tolerance: f64,
    start_time: f64,
    stop_time_defined: c_int,
    stop_time: f64,
) -> Status {
    const CALL: &str = "fmi2SetupExperiment";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            let stop = (stop_time_defined != 0).then_some(stop_time);
            let r = inst.model.setup_experiment(start_time, stop);
            inst.report(CALL, r)
        })
    })
}

/// `fmi2EnterInitializationMode`.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2EnterInitializationMode(c: Component) -> Status {
    const CALL: &str = "fmi2EnterInitializationMode";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            let r = inst.model.enter_initialization();
            inst.report(CALL, r)
        })
    })
}

/// `fmi2ExitInitializationMode`: every parameter is checked against its rule here.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2ExitInitializationMode(c: Component) -> Status {
    const CALL: &str = "fmi2ExitInitializationMode";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            let r = inst.model.exit_initialization();
            inst.report(CALL, r)
        })
    })
}

/// `fmi2Terminate`.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2Terminate(c: Component) -> Status {
    const CALL: &str = "fmi2Terminate";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            let r = inst.model.terminate();
            inst.report(CALL, r)
        })
    })
}

/// `fmi2Reset`: back to just after instantiation, every start value again.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2Reset(c: Component) -> Status {
    guarded(ERROR, || {
        with_instance(c, "fmi2Reset", |inst| {
            inst.model.reset();
            inst.log(OK, Category::Events, "reset");
            OK
        })
    })
}
