//! The 34 FMI 2.0 co-simulation functions. Each is a thin shim: check pointers, find the
//! instance, call the safe core ([`crate::model`]), log what went wrong, return a status.
//! Nothing panics across the boundary ([`crate::ffi::with_instance`], [`guarded`]).
#![allow(non_snake_case)]

use crate::ffi::{
    CallbackFunctions, Category, ERROR, Handle, Instance, OK, Status, guarded, is_live, log_raw,
    register, unregister, with_instance,
};
use crate::model::{Access, Fault};
use crate::state::{Snapshot, deserialize, serialize};
use crate::xml::{LOG_CATEGORIES, guid};
use std::ffi::{CStr, CString, c_char, c_int, c_uint, c_void};
use std::ptr;

type Component = *mut c_void;
type FmuState = *mut c_void;

/// Borrows `n` elements at `p` (empty when `n` is 0, whatever `p` is).
///
/// # Safety
/// When `n > 0`, `p` must be non-null and point to `n` readable elements.
unsafe fn slice<'a, T>(p: *const T, n: usize) -> &'a [T] {
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
unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> &'a mut [T] {
    if n == 0 {
        &mut []
    } else {
        // SAFETY: the caller's contract.
        unsafe { std::slice::from_raw_parts_mut(p, n) }
    }
}

fn null_error(inst: &Instance, call: &str, what: &str) -> Status {
    inst.report(call, Err(Fault::Error(format!("{what} is NULL"))))
}

fn unsupported(c: Component, call: &str, why: &str) -> Status {
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
    _resource_location: *const c_char,
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
            log_raw(cb.logger, cb.component_environment, &name, ERROR, Category::Error, &log);
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
            unsafe { CStr::from_ptr(fmu_guid) }.to_string_lossy().into_owned()
        };
        if given != guid() {
            return fail(format!(
                "wrong GUID {given} (rule: must equal the modelDescription.xml guid {})",
                guid()
            ));
        }
        let inst = Instance::new(name, &cb, logging_on != 0);
        inst.log(OK, Category::Events, "instantiated");
        let p = Box::into_raw(Box::new(inst)).cast::<c_void>();
        register(Handle::Instance, p);
        p
    })
}

/// `fmi2FreeInstance`: ignores NULL and pointers that are not live instances.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2FreeInstance(c: Component) {
    guarded((), || {
        if unregister(Handle::Instance, c) {
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

/// Shared body of the four getters.
///
/// # Safety
/// `vr` has `nvr` entries; `out` has room for `nvr`.
unsafe fn get<T>(
    c: Component,
    call: &'static str,
    access: Access,
    vr: *const c_uint,
    nvr: usize,
    out: *mut T,
    convert: fn(f64) -> T,
) -> Status {
    guarded(ERROR, || {
        with_instance(c, call, |inst| {
            if nvr > 0 && (vr.is_null() || out.is_null()) {
                return null_error(inst, call, "vr or value");
            }
            // SAFETY: non-null when nvr > 0; sizes per the FMI contract.
            let (vrs, out) = unsafe { (slice(vr, nvr), slice_mut(out, nvr)) };
            let mut buf = vec![0.0; nvr];
            let r = inst.model.get(access, vrs, &mut buf);
            if r.is_ok() {
                for (o, &x) in out.iter_mut().zip(&buf) {
                    *o = convert(x);
                }
            }
            inst.report(call, r)
        })
    })
}

/// Shared body of the three setters: every value is tried; the worst status wins.
///
/// # Safety
/// `vr` and `value` have `nvr` entries.
unsafe fn set<T: Copy>(
    c: Component,
    call: &'static str,
    access: Access,
    vr: *const c_uint,
    nvr: usize,
    value: *const T,
    convert: fn(T) -> f64,
) -> Status {
    guarded(ERROR, || {
        with_instance(c, call, |inst| {
            if nvr > 0 && (vr.is_null() || value.is_null()) {
                return null_error(inst, call, "vr or value");
            }
            // SAFETY: non-null when nvr > 0; sizes per the FMI contract.
            let (vrs, vals) = unsafe { (slice(vr, nvr), slice(value, nvr)) };
            let mut worst = OK;
            for (&r, &x) in vrs.iter().zip(vals) {
                let res = inst.model.set(access, r, convert(x));
                worst = worst.max(inst.report(call, res));
            }
            worst
        })
    })
}

/// `fmi2GetReal`.
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetReal(c: Component, vr: *const c_uint, nvr: usize, value: *mut f64) -> Status {
    // SAFETY: forwarded contract.
    unsafe { get(c, "fmi2GetReal", Access::Real, vr, nvr, value, |x| x) }
}

/// `fmi2GetInteger` (Integer and enumeration variables).
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetInteger(c: Component, vr: *const c_uint, nvr: usize, value: *mut c_int) -> Status {
    // SAFETY: forwarded contract.
    unsafe { get(c, "fmi2GetInteger", Access::Integer, vr, nvr, value, |x| x as c_int) }
}

/// `fmi2GetBoolean`.
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBoolean(c: Component, vr: *const c_uint, nvr: usize, value: *mut c_int) -> Status {
    // SAFETY: forwarded contract.
    unsafe { get(c, "fmi2GetBoolean", Access::Boolean, vr, nvr, value, |x| c_int::from(x != 0.0)) }
}

/// `fmi2GetString`: the model has no String variables.
///
/// # Safety
/// FMI contract: `vr` holds `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetString(c: Component, vr: *const c_uint, nvr: usize, _value: *mut *const c_char) -> Status {
    // SAFETY: forwarded contract.
    unsafe { no_strings(c, "fmi2GetString", vr, nvr) }
}

/// `fmi2SetReal`.
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetReal(c: Component, vr: *const c_uint, nvr: usize, value: *const f64) -> Status {
    // SAFETY: forwarded contract.
    unsafe { set(c, "fmi2SetReal", Access::Real, vr, nvr, value, |x| x) }
}

/// `fmi2SetInteger`.
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetInteger(c: Component, vr: *const c_uint, nvr: usize, value: *const c_int) -> Status {
    // SAFETY: forwarded contract.
    unsafe { set(c, "fmi2SetInteger", Access::Integer, vr, nvr, value, f64::from) }
}

/// `fmi2SetBoolean`.
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetBoolean(c: Component, vr: *const c_uint, nvr: usize, value: *const c_int) -> Status {
    // SAFETY: forwarded contract.
    unsafe { set(c, "fmi2SetBoolean", Access::Boolean, vr, nvr, value, |x| f64::from(u8::from(x != 0))) }
}

/// `fmi2SetString`: the model has no String variables.
///
/// # Safety
/// FMI contract: `vr` holds `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetString(c: Component, vr: *const c_uint, nvr: usize, _value: *const *const c_char) -> Status {
    // SAFETY: forwarded contract.
    unsafe { no_strings(c, "fmi2SetString", vr, nvr) }
}

/// # Safety
/// `vr` holds `nvr` entries.
unsafe fn no_strings(c: Component, call: &'static str, vr: *const c_uint, nvr: usize) -> Status {
    guarded(ERROR, || {
        with_instance(c, call, |inst| {
            if nvr == 0 {
                return OK;
            }
            if vr.is_null() {
                return null_error(inst, call, "vr");
            }
            // SAFETY: non-null, `nvr` entries.
            let first = unsafe { slice(vr, nvr) }[0];
            let msg = format!("value reference {first} is not a String variable (rule: this model has none)");
            inst.report(call, Err(Fault::Error(msg)))
        })
    })
}

/// The snapshot behind a live state pointer.
///
/// # Safety
/// `s` must be live (checked by the caller with `is_live`).
unsafe fn snapshot<'a>(s: FmuState) -> &'a mut Snapshot {
    // SAFETY: live states are `Box<Snapshot>` not yet freed.
    unsafe { &mut *s.cast::<Snapshot>() }
}

fn state_error(inst: &Instance, call: &str, msg: String) -> Status {
    inst.report(call, Err(Fault::Error(msg)))
}

/// `fmi2GetFMUstate`: a new copy, or overwrites `*state` if it already holds one.
///
/// # Safety
/// FMI contract: `state` points to an `fmi2FMUstate`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Component, state: *mut FmuState) -> Status {
    const CALL: &str = "fmi2GetFMUstate";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if state.is_null() {
                return null_error(inst, CALL, "FMUstate");
            }
            let model = match inst.model.try_clone() {
                Ok(m) => m,
                Err(e) => return state_error(inst, CALL, format!("the drive cannot be copied: {e}")),
            };
            // SAFETY: non-null per check; points to a pointer per the FMI contract.
            let old = unsafe { *state };
            if is_live(Handle::State, old) {
                // SAFETY: live.
                unsafe { snapshot(old) }.model = model;
            } else if !old.is_null() {
                return state_error(inst, CALL, "*FMUstate is neither NULL nor a state of this FMU".into());
            } else {
                let p = Box::into_raw(Box::new(Snapshot { model })).cast::<c_void>();
                register(Handle::State, p);
                // SAFETY: non-null, writable per the FMI contract.
                unsafe { *state = p };
            }
            OK
        })
    })
}

/// `fmi2SetFMUstate`: the instance continues exactly as when the state was taken.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetFMUstate(c: Component, state: FmuState) -> Status {
    const CALL: &str = "fmi2SetFMUstate";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if !is_live(Handle::State, state) {
                return state_error(inst, CALL, "FMUstate is not a live state of this FMU".into());
            }
            // SAFETY: live.
            match unsafe { snapshot(state) }.model.try_clone() {
                Ok(m) => {
                    inst.model = m;
                    inst.log(OK, Category::Events, "FMU state restored");
                    OK
                }
                Err(e) => state_error(inst, CALL, format!("the drive cannot be copied: {e}")),
            }
        })
    })
}

/// `fmi2FreeFMUstate`: ignores NULL; sets `*state` to NULL.
///
/// # Safety
/// FMI contract: `state` points to an `fmi2FMUstate` or is NULL.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: Component, state: *mut FmuState) -> Status {
    const CALL: &str = "fmi2FreeFMUstate";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if state.is_null() {
                return OK;
            }
            // SAFETY: non-null per check.
            let p = unsafe { *state };
            if p.is_null() {
                return OK;
            }
            if !unregister(Handle::State, p) {
                return state_error(inst, CALL, "FMUstate is not a live state of this FMU".into());
            }
            // SAFETY: it was live, so it is our Box; unregistered, so freed exactly once.
            drop(unsafe { Box::from_raw(p.cast::<Snapshot>()) });
            // SAFETY: non-null, writable.
            unsafe { *state = ptr::null_mut() };
            OK
        })
    })
}

/// `fmi2SerializedFMUstateSize`.
///
/// # Safety
/// FMI contract: `size` points to a `size_t`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(c: Component, state: FmuState, size: *mut usize) -> Status {
    const CALL: &str = "fmi2SerializedFMUstateSize";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if size.is_null() {
                return null_error(inst, CALL, "size");
            }
            if !is_live(Handle::State, state) {
                return state_error(inst, CALL, "FMUstate is not a live state of this FMU".into());
            }
            // SAFETY: live; `size` non-null and writable.
            unsafe { *size = serialize(&snapshot(state).model).len() };
            OK
        })
    })
}

/// `fmi2SerializeFMUstate`: `size` must be the size reported for this state.
///
/// # Safety
/// FMI contract: `bytes` has room for `size` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SerializeFMUstate(c: Component, state: FmuState, bytes: *mut c_char, size: usize) -> Status {
    const CALL: &str = "fmi2SerializeFMUstate";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if !is_live(Handle::State, state) {
                return state_error(inst, CALL, "FMUstate is not a live state of this FMU".into());
            }
            // SAFETY: live.
            let data = serialize(&unsafe { snapshot(state) }.model);
            if data.len() != size {
                let msg = format!("size = {size} (rule: must be {}, from fmi2SerializedFMUstateSize)", data.len());
                return state_error(inst, CALL, msg);
            }
            if bytes.is_null() {
                return null_error(inst, CALL, "serializedState");
            }
            // SAFETY: non-null with room for `size` bytes per the FMI contract.
            unsafe { slice_mut(bytes.cast::<u8>(), size) }.copy_from_slice(&data);
            OK
        })
    })
}

/// `fmi2DeSerializeFMUstate`: rebuilds the drive and replays its record.
///
/// # Safety
/// FMI contract: `bytes` holds `size` bytes; `state` points to an `fmi2FMUstate`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: Component,
    bytes: *const c_char,
    size: usize,
    state: *mut FmuState,
) -> Status {
    const CALL: &str = "fmi2DeSerializeFMUstate";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if state.is_null() || (bytes.is_null() && size > 0) {
                return null_error(inst, CALL, "serializedState or FMUstate");
            }
            // SAFETY: non-null when size > 0; `size` bytes per the FMI contract.
            let data = unsafe { slice(bytes.cast::<u8>(), size) };
            let model = match deserialize(data) {
                Ok(m) => m,
                Err(e) => return state_error(inst, CALL, format!("bad serialized state: {e}")),
            };
            // SAFETY: non-null, readable.
            let old = unsafe { *state };
            if is_live(Handle::State, old) {
                // SAFETY: live.
                unsafe { snapshot(old) }.model = model;
            } else {
                let p = Box::into_raw(Box::new(Snapshot { model })).cast::<c_void>();
                register(Handle::State, p);
                // SAFETY: non-null, writable.
                unsafe { *state = p };
            }
            OK
        })
    })
}

/// `fmi2GetDirectionalDerivative`: not provided.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetDirectionalDerivative(
    c: Component,
    _v_unknown: *const c_uint,
    _n_unknown: usize,
    _v_known: *const c_uint,
    _n_known: usize,
    _dv_known: *const f64,
    _dv_unknown: *mut f64,
) -> Status {
    unsupported(c, "fmi2GetDirectionalDerivative", "providesDirectionalDerivative is false")
}

/// `fmi2SetRealInputDerivatives`: not provided.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2SetRealInputDerivatives(
    c: Component,
    _vr: *const c_uint,
    _nvr: usize,
    _order: *const c_int,
    _value: *const f64,
) -> Status {
    unsupported(c, "fmi2SetRealInputDerivatives", "canInterpolateInputs is false")
}

/// `fmi2GetRealOutputDerivatives`: not provided.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetRealOutputDerivatives(
    c: Component,
    _vr: *const c_uint,
    _nvr: usize,
    _order: *const c_int,
    _value: *mut f64,
) -> Status {
    unsupported(c, "fmi2GetRealOutputDerivatives", "maxOutputDerivativeOrder is 0")
}

/// `fmi2DoStep` (always synchronous).
#[unsafe(no_mangle)]
pub extern "C" fn fmi2DoStep(
    c: Component,
    current_communication_point: f64,
    communication_step_size: f64,
    _no_set_fmu_state_prior_to_current_point: c_int,
) -> Status {
    const CALL: &str = "fmi2DoStep";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            let r = inst.model.do_step(current_communication_point, communication_step_size);
            inst.report(CALL, r)
        })
    })
}

/// `fmi2CancelStep`: steps are synchronous, there is nothing to cancel.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2CancelStep(c: Component) -> Status {
    unsupported(c, "fmi2CancelStep", "steps are synchronous (canRunAsynchronuously is false)")
}

const DO_STEP_STATUS: c_int = 0;
const LAST_SUCCESSFUL_TIME: c_int = 2;
const TERMINATED: c_int = 3;

/// Shared body of the status queries: `answer` gives the value or `None` for a kind
/// this FMU does not provide.
fn status_query(c: Component, call: &'static str, kind: c_int, answer: impl FnOnce(&Instance) -> bool) -> Status {
    guarded(ERROR, || {
        with_instance(c, call, |inst| {
            if answer(inst) {
                OK
            } else {
                let msg = format!("status kind {kind} is not provided (no asynchronous steps)");
                inst.report(call, Err(Fault::Error(msg)))
            }
        })
    })
}

/// `fmi2GetStatus`: `fmi2DoStepStatus` is always `fmi2OK` (steps are synchronous).
///
/// # Safety
/// FMI contract: `value` points to an `fmi2Status`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetStatus(c: Component, kind: c_int, value: *mut Status) -> Status {
    status_query(c, "fmi2GetStatus", kind, |_| {
        if kind != DO_STEP_STATUS || value.is_null() {
            return false;
        }
        // SAFETY: non-null, writable.
        unsafe { *value = OK };
        true
    })
}

/// `fmi2GetRealStatus`: `fmi2LastSuccessfulTime` is the end of the last step.
///
/// # Safety
/// FMI contract: `value` points to an `fmi2Real`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetRealStatus(c: Component, kind: c_int, value: *mut f64) -> Status {
    status_query(c, "fmi2GetRealStatus", kind, |inst| {
        if kind != LAST_SUCCESSFUL_TIME || value.is_null() {
            return false;
        }
        // SAFETY: non-null, writable.
        unsafe { *value = inst.model.time };
        true
    })
}

/// `fmi2GetIntegerStatus`: FMI 2.0 defines no integer status.
///
/// # Safety
/// FMI contract: `value` points to an `fmi2Integer`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetIntegerStatus(c: Component, kind: c_int, _value: *mut c_int) -> Status {
    status_query(c, "fmi2GetIntegerStatus", kind, |_| false)
}

/// `fmi2GetBooleanStatus`: `fmi2Terminated` is always false (the drive never ends a
/// simulation by itself).
///
/// # Safety
/// FMI contract: `value` points to an `fmi2Boolean`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBooleanStatus(c: Component, kind: c_int, value: *mut c_int) -> Status {
    status_query(c, "fmi2GetBooleanStatus", kind, |_| {
        if kind != TERMINATED || value.is_null() {
            return false;
        }
        // SAFETY: non-null, writable.
        unsafe { *value = 0 };
        true
    })
}

/// `fmi2GetStringStatus`: no string status is provided.
///
/// # Safety
/// FMI contract: `value` points to an `fmi2String`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetStringStatus(c: Component, kind: c_int, _value: *mut *const c_char) -> Status {
    status_query(c, "fmi2GetStringStatus", kind, |_| false)
}
