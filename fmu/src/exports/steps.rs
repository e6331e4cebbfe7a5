//! Co-simulation stepping and status queries, and the functions this FMU does not provide.

use super::{Component, unsupported};
use crate::ffi::{ERROR, Instance, OK, Status, guarded, with_instance};
use crate::model::Fault;
use std::ffi::{c_char, c_int, c_uint};

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
    unsupported(
        c,
        "fmi2GetDirectionalDerivative",
        "providesDirectionalDerivative is false",
    )
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
    unsupported(
        c,
        "fmi2SetRealInputDerivatives",
        "canInterpolateInputs is false",
    )
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
    unsupported(
        c,
        "fmi2GetRealOutputDerivatives",
        "maxOutputDerivativeOrder is 0",
    )
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
            let r = inst
                .model
                .do_step(current_communication_point, communication_step_size);
            inst.report(CALL, r)
        })
    })
}

/// `fmi2CancelStep`: steps are synchronous, there is nothing to cancel.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2CancelStep(c: Component) -> Status {
    unsupported(
        c,
        "fmi2CancelStep",
        "steps are synchronous (canRunAsynchronuously is false)",
    )
}

const DO_STEP_STATUS: c_int = 0;
const LAST_SUCCESSFUL_TIME: c_int = 2;
const TERMINATED: c_int = 3;

/// Shared body of the status queries: `answer` gives the value or `None` for a kind
/// this FMU does not provide.
fn status_query(
    c: Component,
    call: &'static str,
    kind: c_int,
    answer: impl FnOnce(&Instance) -> bool,
) -> Status {
    guarded(ERROR, || {
        with_instance(c, call, |inst| {
            if let Err(e) = inst.model.status_query(call) {
                return inst.report(call, Err(e));
            }
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
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: Component,
    kind: c_int,
    _value: *mut c_int,
) -> Status {
    status_query(c, "fmi2GetIntegerStatus", kind, |_| false)
}

/// `fmi2GetBooleanStatus`: `fmi2Terminated` is always false (the drive never ends a
/// simulation by itself).
///
/// # Safety
/// FMI contract: `value` points to an `fmi2Boolean`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: Component,
    kind: c_int,
    value: *mut c_int,
) -> Status {
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
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: Component,
    kind: c_int,
    _value: *mut *const c_char,
) -> Status {
    status_query(c, "fmi2GetStringStatus", kind, |_| false)
}
