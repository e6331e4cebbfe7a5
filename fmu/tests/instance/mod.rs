//! An instance of the FMU made through its exported C function, as an importer makes one
//! (no logger, no allocator callbacks): shared by the tests that call the exports directly,
//! with what they check of a state's bytes and of the values read back.
#![allow(dead_code)]

use fmu::exports::fmi2Instantiate;
use fmu::exports::values::{fmi2GetInteger, fmi2GetReal};
use fmu::ffi::{CallbackFunctions, OK};
use fmu::state::fnv1a64;
use fmu::variables::{Kind, table};
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

/// A serialized state's header: magic, payload length, checksum.
pub const HEADER: usize = 24;

/// The checksum of a state's bytes made to match its (edited) payload again, as bytes
/// forged on purpose would be: only the rules can refuse them then.
pub fn reseal(b: &mut [u8]) {
    let sum = fnv1a64(&b[HEADER..]);
    b[16..24].copy_from_slice(&sum.to_le_bytes());
}

/// Every Real and Integer variable of `c`, read back: `Err` names one that is not finite
/// or outside its declared bounds.
pub fn read_back(c: *mut c_void) -> Result<(), String> {
    for (vr, v) in table().iter().enumerate() {
        let vr = vr as u32;
        let x = match v.kind {
            Kind::Real => {
                let mut x = 0.0;
                // SAFETY: a live instance, one value reference and one value.
                if unsafe { fmi2GetReal(c, &vr, 1, &mut x) } != OK {
                    continue;
                }
                x
            }
            Kind::Integer | Kind::Enumeration(_) => {
                let mut x = 0;
                // SAFETY: as above.
                if unsafe { fmi2GetInteger(c, &vr, 1, &mut x) } != OK {
                    continue;
                }
                f64::from(x)
            }
            _ => continue,
        };
        let low = v.min.is_some_and(|m| x < m);
        let high = v.max.is_some_and(|m| x > m);
        if !x.is_finite() || low || high {
            return Err(format!(
                "`{}` = {x} read back with fmi2OK (bounds {:?}..={:?})",
                v.name, v.min, v.max
            ));
        }
        if v.name == "theta_e_deg" && !(0.0..360.0).contains(&x) {
            return Err(format!("`theta_e_deg` = {x} (rule: in [0, 360))"));
        }
    }
    Ok(())
}
