//! FMU states: get, set, free, serialize and deserialize.

use super::{Component, FmuState, null_error, slice, slice_mut};
use crate::ffi::Category;
use crate::ffi::{
    ERROR, Handle, Instance, OK, Status, guarded, is_state_of, register, unregister, with_instance,
};
use crate::model::Fault;
use crate::state::{Snapshot, deserialize, serialize};
use std::ffi::{c_char, c_void};
use std::ptr;

/// The snapshot behind a live state pointer.
///
/// # Safety
/// `s` must be live (checked by the caller with `is_state_of`).
unsafe fn snapshot<'a>(s: FmuState) -> &'a mut Snapshot {
    // SAFETY: live states are `Box<Snapshot>` not yet freed.
    unsafe { &mut *s.cast::<Snapshot>() }
}

/// Why `fmi2GetFMUstate` and `fmi2DeSerializeFMUstate` refuse the `*FMUstate` given.
const FOREIGN: &str = "*FMUstate is neither NULL nor a live state of this instance (rule: NULL for a new state, or one from fmi2GetFMUstate or fmi2DeSerializeFMUstate on this instance, not yet freed, to overwrite)";

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
                Err(e) => {
                    return state_error(inst, CALL, format!("the drive cannot be copied: {e}"));
                }
            };
            // SAFETY: non-null per check; points to a pointer per the FMI contract.
            let old = unsafe { *state };
            if is_state_of(old, c) {
                // SAFETY: live.
                unsafe { snapshot(old) }.model = model;
            } else if !old.is_null() {
                return state_error(inst, CALL, FOREIGN.into());
            } else {
                let p = Box::into_raw(Box::new(Snapshot { model })).cast::<c_void>();
                register(Handle::State, p, c);
                // SAFETY: non-null, writable per the FMI contract.
                unsafe { *state = p };
            }
            OK
        })
    })
}

/// `fmi2SetFMUstate`: the instance continues exactly as when the state was taken.
///
/// # Safety
/// None beyond FMI's: `state` is checked against the live states before use.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Component, state: FmuState) -> Status {
    const CALL: &str = "fmi2SetFMUstate";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if !is_state_of(state, c) {
                return state_error(
                    inst,
                    CALL,
                    "FMUstate is not a live state of this instance (rule: a state from fmi2GetFMUstate or fmi2DeSerializeFMUstate on this instance, not yet freed)".into(),
                );
            }
            // SAFETY: live.
            match unsafe { snapshot(state) }.model.try_clone() {
                Ok(mut m) => {
                    // The resources folder is this instance's, whoever took the state.
                    m.resources = inst.model.resources.take();
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
            if !is_state_of(p, c) || !unregister(Handle::State, p) {
                return state_error(
                    inst,
                    CALL,
                    "FMUstate is not a live state of this instance (rule: a state from fmi2GetFMUstate or fmi2DeSerializeFMUstate on this instance, not yet freed)".into(),
                );
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
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: Component,
    state: FmuState,
    size: *mut usize,
) -> Status {
    const CALL: &str = "fmi2SerializedFMUstateSize";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if size.is_null() {
                return null_error(inst, CALL, "size");
            }
            if !is_state_of(state, c) {
                return state_error(
                    inst,
                    CALL,
                    "FMUstate is not a live state of this instance (rule: a state from fmi2GetFMUstate or fmi2DeSerializeFMUstate on this instance, not yet freed)".into(),
                );
            }
            // SAFETY: live.
            match serialize(&unsafe { snapshot(state) }.model) {
                // SAFETY: `size` non-null and writable.
                Ok(data) => unsafe { *size = data.len() },
                Err(e) => return state_error(inst, CALL, e),
            }
            OK
        })
    })
}

/// `fmi2SerializeFMUstate`: `size` must be the size reported for this state.
///
/// # Safety
/// FMI contract: `bytes` has room for `size` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: Component,
    state: FmuState,
    bytes: *mut c_char,
    size: usize,
) -> Status {
    const CALL: &str = "fmi2SerializeFMUstate";
    guarded(ERROR, || {
        with_instance(c, CALL, |inst| {
            if !is_state_of(state, c) {
                return state_error(
                    inst,
                    CALL,
                    "FMUstate is not a live state of this instance (rule: a state from fmi2GetFMUstate or fmi2DeSerializeFMUstate on this instance, not yet freed)".into(),
                );
            }
            // SAFETY: live.
            let data = match serialize(&unsafe { snapshot(state) }.model) {
                Ok(d) => d,
                Err(e) => return state_error(inst, CALL, e),
            };
            if data.len() != size {
                let msg = format!(
                    "size = {size} (rule: must be {}, from fmi2SerializedFMUstateSize)",
                    data.len()
                );
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

/// `fmi2DeSerializeFMUstate`: builds the drive from the stored values and restores its
/// dynamic state (see [`crate::state`]).
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
            // SAFETY: non-null, readable per the FMI contract.
            let old = unsafe { *state };
            if !old.is_null() && !is_state_of(old, c) {
                return state_error(inst, CALL, FOREIGN.into());
            }
            // SAFETY: non-null when size > 0; `size` bytes per the FMI contract.
            let data = unsafe { slice(bytes.cast::<u8>(), size) };
            let model = match deserialize(data, inst.model.resources.as_deref()) {
                Ok(m) => m,
                Err(e) => return state_error(inst, CALL, format!("bad serialized state: {e}")),
            };
            if is_state_of(old, c) {
                // SAFETY: live.
                unsafe { snapshot(old) }.model = model;
            } else {
                let p = Box::into_raw(Box::new(Snapshot { model })).cast::<c_void>();
                register(Handle::State, p, c);
                // SAFETY: non-null, writable.
                unsafe { *state = p };
            }
            OK
        })
    })
}
