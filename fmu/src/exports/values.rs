//! `fmi2Get*` and `fmi2Set*`: variable access by value reference.
//!
//! One getter and one setter body, generic over the FMI type (`FmiType`); the eight
//! exported functions are generated from one table (`access!`), so every type checks its
//! pointers, logs and applies all-or-nothing the same way.

use super::{Component, null_error, slice, slice_mut};
use crate::ffi::{ERROR, Instance, OK, Status, guarded, with_instance};
use crate::model::{Access, Fault};
use std::ffi::{CStr, CString, c_char, c_int, c_uint};

/// One FMI base type as the exported functions see it: its C element and how values move
/// between C and the model.
trait FmiType {
    /// Element of the getter's output and of the setter's input array.
    type C: Copy;
    /// A value checked by [`FmiType::check`], ready to apply.
    type Checked;
    /// Writes the values of `vrs` to `out` (same length), or nothing on a fault.
    fn get(inst: &mut Instance, vrs: &[u32], out: &mut [Self::C]) -> Result<(), Fault>;
    /// Checks `x`, element `k` of a set call for `vr`, without applying it; a warning is
    /// logged once the whole call is applied.
    fn check(
        inst: &Instance,
        k: usize,
        vr: u32,
        x: Self::C,
    ) -> Result<(Self::Checked, Option<String>), Fault>;
    /// Applies a value [`FmiType::check`] accepted.
    fn apply(inst: &mut Instance, vr: u32, x: Self::Checked);
}

/// Real, Integer (with enumerations) and Boolean: stored as f64 in the model.
trait Numeric {
    type C: Copy;
    const ACCESS: Access;
    fn from_model(x: f64) -> Self::C;
    fn to_model(x: Self::C) -> f64;
}

impl<N: Numeric> FmiType for N {
    type C = N::C;
    type Checked = f64;
    fn get(inst: &mut Instance, vrs: &[u32], out: &mut [N::C]) -> Result<(), Fault> {
        let mut buf = vec![0.0; vrs.len()];
        inst.model.get(N::ACCESS, vrs, &mut buf)?;
        for (o, &x) in out.iter_mut().zip(&buf) {
            *o = N::from_model(x);
        }
        Ok(())
    }
    fn check(inst: &Instance, _k: usize, vr: u32, x: N::C) -> Result<(f64, Option<String>), Fault> {
        let x = N::to_model(x);
        inst.model.check_set(N::ACCESS, vr, x).map(|w| (x, w))
    }
    fn apply(inst: &mut Instance, vr: u32, x: f64) {
        inst.model.apply_set(vr, x);
    }
}

struct Real;
impl Numeric for Real {
    type C = f64;
    const ACCESS: Access = Access::Real;
    fn from_model(x: f64) -> f64 {
        x
    }
    fn to_model(x: f64) -> f64 {
        x
    }
}

struct Integer;
impl Numeric for Integer {
    type C = c_int;
    const ACCESS: Access = Access::Integer;
    fn from_model(x: f64) -> c_int {
        // Integer values are whole and within c_int (checked when set).
        x as c_int
    }
    fn to_model(x: c_int) -> f64 {
        f64::from(x)
    }
}

struct Boolean;
impl Numeric for Boolean {
    type C = c_int;
    const ACCESS: Access = Access::Boolean;
    fn from_model(x: f64) -> c_int {
        c_int::from(x != 0.0)
    }
    fn to_model(x: c_int) -> f64 {
        f64::from(u8::from(x != 0))
    }
}

/// Strings live in the model's texts; each is copied when set.
struct Text;
impl FmiType for Text {
    type C = *const c_char;
    type Checked = String;
    /// The returned pointers point into the instance and stay valid until the next
    /// `fmi2GetString` on it (FMI requires: until the next call of any kind).
    fn get(inst: &mut Instance, vrs: &[u32], out: &mut [*const c_char]) -> Result<(), Fault> {
        // Set from C strings, so never with an inner NUL.
        let texts: Vec<CString> = inst
            .model
            .get_texts(vrs)?
            .iter()
            .map(|t| CString::new(*t).unwrap_or_default())
            .collect();
        inst.strings_out = texts;
        for (o, t) in out.iter_mut().zip(&inst.strings_out) {
            *o = t.as_ptr();
        }
        Ok(())
    }
    fn check(
        inst: &Instance,
        k: usize,
        vr: u32,
        p: *const c_char,
    ) -> Result<(String, Option<String>), Fault> {
        if p.is_null() {
            return Err(Fault::Error(format!(
                "value[{k}] (value reference {vr}) is NULL (rule: a NUL-terminated UTF-8 string; \"\" for empty)"
            )));
        }
        // SAFETY: non-null, NUL-terminated per the FMI contract; copied here.
        let text = unsafe { CStr::from_ptr(p) };
        let t = text.to_str().map_err(|e| {
            Fault::Error(format!(
                "value[{k}] (value reference {vr}) = {:?} is not UTF-8 ({e}) (rule: FMI strings are UTF-8)",
                text.to_string_lossy()
            ))
        })?;
        inst.model.check_text(vr)?;
        Ok((t.to_string(), None))
    }
    fn apply(inst: &mut Instance, vr: u32, x: String) {
        // Checked above; cannot fail.
        let _ = inst.model.set_text(vr, &x);
    }
}

/// The body of every getter.
///
/// # Safety
/// `vr` has `nvr` entries; `out` has room for `nvr`.
unsafe fn get<T: FmiType>(
    c: Component,
    call: &'static str,
    vr: *const c_uint,
    nvr: usize,
    out: *mut T::C,
) -> Status {
    guarded(ERROR, || {
        with_instance(c, call, |inst| {
            if nvr > 0 && (vr.is_null() || out.is_null()) {
                return null_error(inst, call, "vr or value");
            }
            // SAFETY: non-null when nvr > 0; sizes per the FMI contract.
            let (vrs, out) = unsafe { (slice(vr, nvr), slice_mut(out, nvr)) };
            let r = T::get(inst, vrs, out);
            inst.report(call, r)
        })
    })
}

/// The body of every setter: all or nothing. Every value is checked first; if any is
/// refused, each refusal is logged and nothing is applied.
///
/// # Safety
/// `vr` and `value` have `nvr` entries (strings NUL-terminated).
unsafe fn set<T: FmiType>(
    c: Component,
    call: &'static str,
    vr: *const c_uint,
    nvr: usize,
    value: *const T::C,
) -> Status {
    guarded(ERROR, || {
        with_instance(c, call, |inst| {
            if nvr > 0 && (vr.is_null() || value.is_null()) {
                return null_error(inst, call, "vr or value");
            }
            // SAFETY: non-null when nvr > 0; sizes per the FMI contract.
            let (vrs, vals) = unsafe { (slice(vr, nvr), slice(value, nvr)) };
            let mut accepted = Vec::with_capacity(nvr);
            let mut warnings = Vec::new();
            let mut refused = 0;
            for (k, (&r, &x)) in vrs.iter().zip(vals).enumerate() {
                match T::check(inst, k, r, x) {
                    Ok((x, w)) => {
                        accepted.push((r, x));
                        warnings.extend(w);
                    }
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
            for (r, x) in accepted {
                T::apply(inst, r, x);
            }
            warnings
                .into_iter()
                .fold(OK, |s, w| s.max(inst.report(call, Err(Fault::Warning(w)))))
        })
    })
}

/// The exported getter and setter of each FMI type, from one row each (the C element type
/// is written out so that the exported signatures name no private type).
macro_rules! access {
    ($($get:ident, $set:ident: $ty:ident, $c:ty;)+) => {$(
        #[doc = concat!("`", stringify!($get), "`.")]
        ///
        /// # Safety
        /// FMI contract: `vr` and `value` hold `nvr` entries.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $get(
            c: Component,
            vr: *const c_uint,
            nvr: usize,
            value: *mut $c,
        ) -> Status {
            // SAFETY: forwarded contract.
            unsafe { get::<$ty>(c, stringify!($get), vr, nvr, value) }
        }

        #[doc = concat!("`", stringify!($set), "`: all or nothing.")]
        ///
        /// # Safety
        /// FMI contract: `vr` and `value` hold `nvr` entries.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $set(
            c: Component,
            vr: *const c_uint,
            nvr: usize,
            value: *const $c,
        ) -> Status {
            // SAFETY: forwarded contract.
            unsafe { set::<$ty>(c, stringify!($set), vr, nvr, value) }
        }
    )+};
}

access! {
    fmi2GetReal, fmi2SetReal: Real, f64;
    fmi2GetInteger, fmi2SetInteger: Integer, c_int;
    fmi2GetBoolean, fmi2SetBoolean: Boolean, c_int;
    fmi2GetString, fmi2SetString: Text, *const c_char;
}
