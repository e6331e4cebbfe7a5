//! The exported C functions called directly, as an importer calls them: set calls apply
//! all their values or none, damaged serialized states are refused before anything is built, and a
//! panic inside a call reaches neither stderr nor the importer.
// Calls the exported C functions as an importer does; every unsafe block says why it holds.
#![allow(unsafe_code)]

use bldc_drive::drive_core::{Command, Controller, Sensed, Ticks};
use bldc_drive::strategies::{ChipStatus, Strategy, Table};
use fmu::exports::states::{
    fmi2DeSerializeFMUstate, fmi2FreeFMUstate, fmi2GetFMUstate, fmi2SerializeFMUstate,
    fmi2SerializedFMUstateSize, fmi2SetFMUstate,
};
use fmu::exports::steps::fmi2DoStep;
use fmu::exports::values::{fmi2GetReal, fmi2SetInteger, fmi2SetReal};
use fmu::exports::{
    fmi2EnterInitializationMode, fmi2ExitInitializationMode, fmi2FreeInstance, fmi2SetupExperiment,
};
use fmu::ffi::{ERROR, OK, WARNING};
use fmu::variables::vr_of;
use std::ffi::c_void;
use std::ptr;

mod instance;
use instance::instantiate;

const H: f64 = 1e-3;

fn vr(name: &str) -> u32 {
    vr_of(name).unwrap()
}

fn initialized(name: &str) -> *mut c_void {
    let c = instantiate(name);
    assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), OK);
    assert_eq!(fmi2EnterInitializationMode(c), OK);
    assert_eq!(fmi2ExitInitializationMode(c), OK);
    c
}

fn set_reals(c: *mut c_void, names: &[&str], xs: &[f64]) -> i32 {
    let vrs: Vec<u32> = names.iter().map(|n| vr(n)).collect();
    // SAFETY: both arrays hold `names.len()` entries.
    unsafe { fmi2SetReal(c, vrs.as_ptr(), vrs.len(), xs.as_ptr()) }
}

fn get_real(c: *mut c_void, name: &str) -> f64 {
    let mut x = f64::NAN;
    // SAFETY: one entry each.
    assert_eq!(unsafe { fmi2GetReal(c, &vr(name), 1, &mut x) }, OK);
    x
}

fn get_state(c: *mut c_void) -> *mut c_void {
    let mut s = ptr::null_mut();
    // SAFETY: a writable state pointer.
    assert_eq!(unsafe { fmi2GetFMUstate(c, &mut s) }, OK);
    s
}

fn serialized(c: *mut c_void, s: *mut c_void) -> Vec<u8> {
    let mut n = 0;
    // SAFETY: a live state and a writable size; then a buffer of that size.
    unsafe {
        assert_eq!(fmi2SerializedFMUstateSize(c, s, &mut n), OK);
        let mut b = vec![0u8; n];
        assert_eq!(fmi2SerializeFMUstate(c, s, b.as_mut_ptr().cast(), n), OK);
        b
    }
}

fn deserialize(c: *mut c_void, b: &[u8]) -> (i32, *mut c_void) {
    let mut s = ptr::null_mut();
    // SAFETY: `b.len()` readable bytes and a writable state pointer.
    let st = unsafe { fmi2DeSerializeFMUstate(c, b.as_ptr().cast(), b.len(), &mut s) };
    (st, s)
}

#[test]
fn a_set_call_with_one_invalid_element_applies_none() {
    let c = instantiate("atomic");
    assert_eq!(fmi2EnterInitializationMode(c), OK);
    let names = ["motor.resistance_ohm", "speed_ref_rpm", "load_torque_nm"];
    let before: Vec<f64> = names.iter().map(|n| get_real(c, n)).collect();
    for bad in [
        [2.0, 1000.0, 5.0],   // load beyond 1 N·m
        [-1.0, 1000.0, 0.5],  // resistance below its range
        [2.0, f64::NAN, 0.5], // NaN
        [2.0, 1000.0, f64::INFINITY],
        [2.0, 1000.0, -1e300],
    ] {
        assert_eq!(set_reals(c, &names, &bad), ERROR, "{bad:?}");
        let now: Vec<f64> = names.iter().map(|n| get_real(c, n)).collect();
        assert_eq!(now, before, "{bad:?} applied in part");
    }
    // An unknown value reference among valid ones: nothing applied either.
    let vrs = [vr("motor.resistance_ohm"), 99_999];
    // SAFETY: two entries each.
    assert_eq!(
        unsafe { fmi2SetReal(c, vrs.as_ptr(), 2, [2.0, 1.0].as_ptr()) },
        ERROR
    );
    assert_eq!(get_real(c, "motor.resistance_ohm"), before[0]);
    // Integers too: a valid pole count with a pole count below its range.
    let vrs = [vr("motor.poles"), vr("control.max_restarts")];
    // SAFETY: two entries each.
    assert_eq!(
        unsafe { fmi2SetInteger(c, vrs.as_ptr(), 2, [8, -1].as_ptr()) },
        ERROR
    );
    // The valid call is applied whole; a clamped speed is a warning, not a refusal.
    assert_eq!(set_reals(c, &names, &[2.0, 1000.0, 0.5]), OK);
    assert_eq!(get_real(c, "load_torque_nm"), 0.5);
    assert_eq!(set_reals(c, &names, &[2.0, 1e6, 0.5]), WARNING);
    assert_eq!(fmi2ExitInitializationMode(c), OK);
    fmi2FreeInstance(c);
}

#[test]
fn load_beyond_the_rule_with_the_drive_enabled_is_refused_and_steps_stay_finite() {
    let c = initialized("load");
    for k in 0..50 {
        assert_eq!(fmi2DoStep(c, f64::from(k) * H, H, 1), OK);
    }
    assert_eq!(set_reals(c, &["load_torque_nm"], &[1e300]), ERROR);
    assert_eq!(set_reals(c, &["load_torque_nm"], &[-1e300]), ERROR);
    assert_eq!(get_real(c, "load_torque_nm"), 0.0);
    for k in 50..100 {
        assert_eq!(fmi2DoStep(c, f64::from(k) * H, H, 1), OK);
        for name in ["speed_rpm", "i_u", "torque_nm"] {
            assert!(get_real(c, name).is_finite(), "{name} at step {k}");
        }
    }
    fmi2FreeInstance(c);
}

#[test]
fn a_damaged_serialized_state_is_refused_and_the_instance_goes_on() {
    let c = initialized("damaged");
    for k in 0..300 {
        assert_eq!(fmi2DoStep(c, f64::from(k) * H, H, 1), OK);
    }
    let mut s = get_state(c);
    let good = serialized(c, s);
    // SAFETY: live state, freed once.
    assert_eq!(unsafe { fmi2FreeFMUstate(c, &mut s) }, OK);
    let (st, mut copy) = deserialize(c, &good);
    assert_eq!(st, OK);
    // That the header is checked before anything is read or built is pinned by the
    // refusals' messages in the crate's own state tests; here, what the importer sees.
    for i in (0..good.len()).step_by(5) {
        for bit in [0, 3, 7] {
            let mut b = good.clone();
            b[i] ^= 1 << bit;
            let (st, s) = deserialize(c, &b);
            assert_eq!((st, s), (ERROR, ptr::null_mut()), "byte {i} bit {bit}");
        }
    }
    // The instance was not touched by the refusals and the good state still restores.
    assert_eq!(fmi2DoStep(c, 0.3, H, 1), OK);
    // SAFETY: live state of this instance.
    assert_eq!(unsafe { fmi2SetFMUstate(c, copy) }, OK);
    assert_eq!(fmi2DoStep(c, 0.3, H, 1), OK);
    // SAFETY: live state, freed once.
    assert_eq!(unsafe { fmi2FreeFMUstate(c, &mut copy) }, OK);
    fmi2FreeInstance(c);
}

#[test]
fn the_serialized_size_does_not_grow_with_steps() {
    let c = initialized("size");
    let mut sizes = Vec::new();
    for k in 0..1000 {
        assert_eq!(fmi2DoStep(c, f64::from(k) * H, H, 1), OK);
        if k % 250 == 10 {
            let mut s = get_state(c);
            sizes.push(serialized(c, s).len());
            // SAFETY: live state, freed once.
            assert_eq!(unsafe { fmi2FreeFMUstate(c, &mut s) }, OK);
        }
    }
    assert!(sizes.windows(2).all(|w| w[0] == w[1]), "{sizes:?}");
    fmi2FreeInstance(c);
}

#[test]
fn a_state_belongs_to_the_instance_that_made_it() {
    let a = initialized("owner-a");
    let b = initialized("owner-b");
    let mut s = get_state(a);
    let bytes = serialized(a, s);
    // SAFETY: the pointer is checked against b's states before use.
    unsafe {
        assert_eq!(fmi2SetFMUstate(b, s), ERROR);
        assert_eq!(fmi2FreeFMUstate(b, &mut s), ERROR);
        assert!(!s.is_null());
        // Neither NULL nor one of b's states: refused to overwrite, by both calls.
        let mut foreign = s;
        assert_eq!(fmi2GetFMUstate(b, &mut foreign), ERROR);
        assert_eq!(foreign, s);
        let st = fmi2DeSerializeFMUstate(b, bytes.as_ptr().cast(), bytes.len(), &mut foreign);
        assert_eq!(st, ERROR);
        assert_eq!(foreign, s, "a's state untouched");
    }
    fmi2FreeInstance(a);
    // Freed with its instance: no longer accepted anywhere.
    // SAFETY: checked against the live states before use.
    assert_eq!(unsafe { fmi2SetFMUstate(b, s) }, ERROR);
    fmi2FreeInstance(b);
}

/// A strategy that panics at its next tick and otherwise answers as the one it wraps.
struct Panicking(Option<Box<dyn Strategy>>);

impl Panicking {
    fn inner(&self) -> &dyn Strategy {
        self.0.as_deref().expect("a wrapped strategy")
    }
}

impl Controller for Panicking {
    fn clock(&self) -> Ticks {
        self.inner().clock()
    }
    fn tick(&mut self, _: Ticks, _: &Sensed) -> Command {
        panic!("a strategy bug, injected by the test");
    }
}

impl Strategy for Panicking {
    fn name(&self) -> &str {
        self.inner().name()
    }
    fn status(&self) -> ChipStatus {
        self.inner().status()
    }
    fn table(&self) -> Table {
        self.inner().table()
    }
    fn set_start(&mut self, _: Ticks, _: bool) {}
    fn set_reset(&mut self, _: bool) {}
    fn set_speed_ref(&mut self, _: f64) {}
    fn speed_ref_rpm(&self) -> f64 {
        self.inner().speed_ref_rpm()
    }
    fn try_clone(&self) -> Result<Box<dyn Strategy>, String> {
        Err("the panicking test strategy is not copied".into())
    }
}

/// The child half of `a_panic_inside_a_call_prints_nothing`: calls that panic inside.
#[test]
fn panic_child() {
    if std::env::var_os("FMU_PANIC_CHILD").is_none() {
        return;
    }
    // Every input is checked now, so no value reaches a panic: the test itself puts a
    // strategy that panics at its next tick into the drive (a bug inside the library, on
    // demand) and wakes it, so the next step panics inside the call.
    let c = instantiate("panics");
    assert_eq!(fmi2EnterInitializationMode(c), OK);
    assert_eq!(fmi2ExitInitializationMode(c), OK);
    assert_eq!(fmi2DoStep(c, 0.0, H, 1), OK);
    // SAFETY: `c` is the live `Box<Instance>` fmi2Instantiate returned; no call runs on it.
    let inst = unsafe { &mut *c.cast::<fmu::ffi::Instance>() };
    let drive = inst.model.drive.as_mut().expect("built by the first step");
    let inner = std::mem::replace(&mut drive.engine.controller, Box::new(Panicking(None)));
    drive.engine.controller = Box::new(Panicking(Some(inner)));
    drive.engine.wake_controller();
    let before = fmu::ffi::caught_panics();
    assert_eq!(fmi2DoStep(c, H, H, 1), ERROR);
    assert_eq!(fmu::ffi::caught_panics(), before + 1, "it did panic inside");
    // The instance is in the error phase: no further step.
    assert_eq!(fmi2DoStep(c, H, H, 1), ERROR);
    fmi2FreeInstance(c);
    // A panic outside FMU calls still reaches the default hook.
    let r = std::panic::catch_unwind(|| panic!("outside the FMU"));
    assert!(r.is_err());
}

#[test]
fn a_panic_inside_a_call_prints_nothing() {
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "panic_child", "--nocapture", "--test-threads=1"])
        .env("FMU_PANIC_CHILD", "1")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("1 passed"), "{stdout}");
    assert!(
        !stderr.contains("injected"),
        "panic text on stderr: {stderr}"
    );
    assert!(
        stderr.contains("outside the FMU"),
        "other panics keep the default hook: {stderr}"
    );
}
