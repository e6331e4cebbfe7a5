//! `fmi2Get*` and `fmi2Set*`: variable access by value reference.

use super::{Component, null_error, slice, slice_mut};
use crate::ffi::{ERROR, OK, Status, guarded, with_instance};
use crate::model::{Access, Fault};
use std::ffi::{c_char, c_int, c_uint};

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
pub unsafe extern "C" fn fmi2GetReal(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *mut f64,
) -> Status {
    // SAFETY: forwarded contract.
    unsafe { get(c, "fmi2GetReal", Access::Real, vr, nvr, value, |x| x) }
}

/// `fmi2GetInteger` (Integer and enumeration variables).
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetInteger(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *mut c_int,
) -> Status {
    // SAFETY: forwarded contract.
    unsafe {
        get(c, "fmi2GetInteger", Access::Integer, vr, nvr, value, |x| {
            x as c_int
        })
    }
}

/// `fmi2GetBoolean`.
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *mut c_int,
) -> Status {
    // SAFETY: forwarded contract.
    unsafe {
        get(c, "fmi2GetBoolean", Access::Boolean, vr, nvr, value, |x| {
            c_int::from(x != 0.0)
        })
    }
}

/// `fmi2GetString`: the model has no String variables.
///
/// # Safety
/// FMI contract: `vr` holds `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetString(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    _value: *mut *const c_char,
) -> Status {
    // SAFETY: forwarded contract.
    unsafe { no_strings(c, "fmi2GetString", vr, nvr) }
}

/// `fmi2SetReal`.
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetReal(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *const f64,
) -> Status {
    // SAFETY: forwarded contract.
    unsafe { set(c, "fmi2SetReal", Access::Real, vr, nvr, value, |x| x) }
}

/// `fmi2SetInteger`.
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetInteger(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *const c_int,
) -> Status {
    // SAFETY: forwarded contract.
    unsafe {
        set(
            c,
            "fmi2SetInteger",
            Access::Integer,
            vr,
            nvr,
            value,
            f64::from,
        )
    }
}

/// `fmi2SetBoolean`.
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *const c_int,
) -> Status {
    // SAFETY: forwarded contract.
    unsafe {
        set(c, "fmi2SetBoolean", Access::Boolean, vr, nvr, value, |x| {
            f64::from(u8::from(x != 0))
        })
    }
}

/// `fmi2SetString`: the model has no String variables.
///
/// # Safety
/// FMI contract: `vr` holds `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetString(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    _value: *const *const c_char,
) -> Status {
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
            let msg = format!(
                "value reference {first} is not a String variable (rule: this model has none)"
            );
            inst.report(call, Err(Fault::Error(msg)))
        })
    })
}
