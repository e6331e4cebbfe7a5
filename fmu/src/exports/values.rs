//! `fmi2Get*` and `fmi2Set*`: variable access by value reference.

use super::{Component, null_error, slice, slice_mut};
use crate::ffi::{ERROR, OK, Status, guarded, with_instance};
use crate::model::{Access, Fault};
use std::ffi::{CStr, CString, c_char, c_int, c_uint};

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

/// Shared body of the three setters: all or nothing. Every value is checked first; if any
/// is refused, each refusal is logged and nothing is applied.
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
            let mut warnings = Vec::new();
            let mut refused = 0;
            for (&r, &x) in vrs.iter().zip(vals) {
                match inst.model.check_set(access, r, convert(x)) {
                    Ok(w) => warnings.extend(w),
                    Err(f) => {
                        refused += 1;
                        inst.report(call, Err(f));
                    }
                }
            }
            if refused > 0 {
                let msg = format!(
                    "{refused} of {nvr} values refused; none of the {nvr} was applied (rule: a set call applies all its values or none)"
                );
                return inst.report(call, Err(Fault::Error(msg)));
            }
            for (&r, &x) in vrs.iter().zip(vals) {
                inst.model.apply_set(r, convert(x));
            }
            warnings
                .into_iter()
                .fold(OK, |s, w| s.max(inst.report(call, Err(Fault::Warning(w)))))
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

/// `fmi2GetString`: the returned pointers point into the instance and stay valid until
/// the next `fmi2GetString` on it (FMI requires: until the next call of any kind).
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetString(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *mut *const c_char,
) -> Status {
    const CALL: &str = "fmi2GetString";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if nvr > 0 && (vr.is_null() || value.is_null()) {
                return null_error(inst, CALL, "vr or value");
            }
            // SAFETY: non-null when nvr > 0; sizes per the FMI contract.
            let (vrs, out) = unsafe { (slice(vr, nvr), slice_mut(value, nvr)) };
            let texts = match inst.model.get_texts(vrs) {
                // Set from C strings, so never with an inner NUL.
                Ok(t) => t
                    .iter()
                    .map(|t| CString::new(*t).unwrap_or_default())
                    .collect(),
                Err(f) => return inst.report(CALL, Err(f)),
            };
            inst.strings_out = texts;
            for (o, t) in out.iter_mut().zip(&inst.strings_out) {
                *o = t.as_ptr();
            }
            OK
        })
    })
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

/// `fmi2SetString`: each string is copied; all or nothing.
///
/// # Safety
/// FMI contract: `vr` and `value` hold `nvr` entries, each a NUL-terminated string.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetString(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *const *const c_char,
) -> Status {
    const CALL: &str = "fmi2SetString";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if nvr > 0 && (vr.is_null() || value.is_null()) {
                return null_error(inst, CALL, "vr or value");
            }
            // SAFETY: non-null when nvr > 0; sizes per the FMI contract.
            let (vrs, vals) = unsafe { (slice(vr, nvr), slice(value, nvr)) };
            // All or nothing, as for the numbers: every text is checked before any is set.
            let mut texts = Vec::with_capacity(nvr);
            let mut refused = 0;
            for (k, (&r, &p)) in vrs.iter().zip(vals).enumerate() {
                let res = if p.is_null() {
                    Err(Fault::Error(format!(
                        "value[{k}] (value reference {r}) is NULL (rule: a NUL-terminated UTF-8 string; \"\" for empty)"
                    )))
                } else {
                    // SAFETY: non-null, NUL-terminated per the FMI contract; copied here.
                    let text = unsafe { CStr::from_ptr(p) };
                    match text.to_str() {
                        Ok(t) => inst.model.check_text(r).map(|()| texts.push((r, t))),
                        Err(e) => Err(Fault::Error(format!(
                            "value[{k}] (value reference {r}) = {:?} is not UTF-8 ({e}) (rule: FMI strings are UTF-8)",
                            text.to_string_lossy()
                        ))),
                    }
                };
                if res.is_err() {
                    refused += 1;
                    inst.report(CALL, res);
                }
            }
            if refused > 0 {
                let msg = format!(
                    "{refused} of {nvr} values refused; none of the {nvr} was applied (rule: a set call applies all its values or none)"
                );
                return inst.report(CALL, Err(Fault::Error(msg)));
            }
            for (r, t) in texts {
                // Checked above; cannot fail.
                let _ = inst.model.set_text(r, t);
            }
            OK
        })
    })
}
