//! Serialized states forged on purpose: a value written over the bytes of a valid state at
//! every offset, the length and FNV-1a 64 resealed, so that only the rules can refuse it.
//! Whatever is accepted reads back finite and within its declared bounds, and steps on
//! with finite outputs; a state the FMU saved itself always restores; and the size of a
//! state is fixed by the parameters, whatever the steps taken.
// Calls the exported C functions as an importer does; every unsafe block says why it holds.
#![allow(unsafe_code)]

use bldc_drive::drive_core::state::Persist;
use fmu::exports::states::{
    fmi2DeSerializeFMUstate, fmi2FreeFMUstate, fmi2GetFMUstate, fmi2SerializeFMUstate,
    fmi2SerializedFMUstateSize, fmi2SetFMUstate,
};
use fmu::exports::steps::{fmi2DoStep, fmi2GetRealStatus};
use fmu::exports::values::{fmi2SetInteger, fmi2SetReal};
use fmu::exports::{
    fmi2EnterInitializationMode, fmi2ExitInitializationMode, fmi2FreeInstance, fmi2SetupExperiment,
};
use fmu::ffi::{OK, caught_panics, live_states};
use fmu::variables::{Kind, Role, table, vr_of};
use std::ffi::c_void;
use std::ptr;

mod instance;
use instance::{HEADER, instantiate, read_back, reseal};

/// An instance set up with `params` (by name, each set by its kind), initialized unless
/// `init` is false.
fn instance_with(params: &[(&str, f64)], init: bool) -> *mut c_void {
    let c = instantiate("forgery");
    // SAFETY: a live instance; arrays of the stated length.
    unsafe {
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), OK);
        assert_eq!(fmi2EnterInitializationMode(c), OK);
        for &(name, x) in params {
            let vr = vr_of(name).unwrap();
            let st = match table()[vr as usize].kind {
                Kind::Real => fmi2SetReal(c, &vr, 1, &x),
                _ => fmi2SetInteger(c, &vr, 1, &(x as i32)),
            };
            assert_eq!(st, OK, "{name} = {x}");
        }
        if init {
            assert_eq!(fmi2ExitInitializationMode(c), OK);
        }
    }
    c
}

/// Steps `c` from `t` to `to` by `h`; returns the time reached.
fn run(c: *mut c_void, mut t: f64, to: f64, h: f64) -> f64 {
    while t < to - 1e-12 {
        assert_eq!(fmi2DoStep(c, t, h, 1), OK, "step at {t}");
        t += h;
    }
    t
}

/// The serialized bytes of `c` now.
fn bytes_of(c: *mut c_void) -> Vec<u8> {
    // SAFETY: a live instance; the state is freed before returning.
    unsafe {
        let mut s = ptr::null_mut();
        assert_eq!(fmi2GetFMUstate(c, &mut s), OK);
        let mut n = 0;
        assert_eq!(fmi2SerializedFMUstateSize(c, s, &mut n), OK);
        let mut b = vec![0u8; n];
        assert_eq!(fmi2SerializeFMUstate(c, s, b.as_mut_ptr().cast(), n), OK);
        assert_eq!(fmi2FreeFMUstate(c, &mut s), OK);
        b
    }
}

/// Deserializes `b` into `c` and, if accepted, sets it: `Ok(None)` when refused,
/// `Ok(Some(t))` with the state's time when accepted and read back within the rules
/// (and, when `step`, stepped on with outputs within them too).
fn restore_and_check(c: *mut c_void, b: &[u8], step: bool) -> Result<Option<f64>, String> {
    // SAFETY: a live instance; `b` holds `b.len()` bytes; the state is freed here.
    unsafe {
        let mut s = ptr::null_mut();
        if fmi2DeSerializeFMUstate(c, b.as_ptr().cast(), b.len(), &mut s) != OK {
            return Ok(None);
        }
        assert_eq!(fmi2SetFMUstate(c, s), OK);
        assert_eq!(fmi2FreeFMUstate(c, &mut s), OK);
        read_back(c)?;
        let mut t = f64::NAN;
        fmi2GetRealStatus(c, 2, &mut t);
        if step && t.is_finite() && fmi2DoStep(c, t, 2e-5, 1) == OK {
            read_back(c).map_err(|e| format!("after a step: {e}"))?;
        }
        Ok(Some(t))
    }
}

/// The values written over a state's bytes: non-finite, and far out of any bound.
const FORGED: [f64; 5] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300, -1e300];

/// Every offset of the payload, each forged value written there (8 bytes, unaligned):
/// the accepted forgeries must read back within the rules. Returns how many were accepted.
fn scan(state: &[u8], c: *mut c_void, values: &[f64], stride: usize) -> usize {
    let mut accepted = 0;
    for at in (HEADER..state.len() - 8).step_by(stride) {
        for &x in values {
            let mut b = state.to_vec();
            b[at..at + 8].copy_from_slice(&x.to_bits().to_le_bytes());
            if b == state {
                continue;
            }
            reseal(&mut b);
            let panics = caught_panics();
            match restore_and_check(c, &b, true) {
                Ok(None) => {}
                Ok(Some(_)) => accepted += 1,
                Err(e) => panic!("{x} at offset {at}: {e}"),
            }
            assert_eq!(
                caught_panics(),
                panics,
                "{x} at offset {at}: a panic inside the FMU"
            );
        }
    }
    accepted
}

/// A state of a running drive (1.5 s, a light load) forged at every offset with NaN, and
/// every third offset with ±inf and ±1e300.
#[test]
fn forged_states_of_a_running_drive_never_read_back_out_of_their_rules() {
    let c = instance_with(&[], true);
    // SAFETY: a live instance, one value reference and one value.
    unsafe {
        let vr = vr_of("load_torque_nm").unwrap();
        assert_eq!(fmi2SetReal(c, &vr, 1, &1e-4), OK);
    }
    run(c, 0.0, 1.5, 1e-3);
    let state = bytes_of(c);
    let before = live_states();
    let n = scan(&state, c, &FORGED[..1], 1) + scan(&state, c, &FORGED[1..], 3);
    assert_eq!(live_states(), before);
    assert_eq!(caught_panics(), 0);
    eprintln!("{n} forgeries accepted, all within the rules");
    fmi2FreeInstance(c);
}

/// A state saved during initialization (parameters and inputs only, no drive yet): a
/// forged value must be refused at once, not at fmi2ExitInitializationMode.
#[test]
fn forged_states_saved_during_initialization_are_checked_on_restore() {
    let c = instance_with(&[("load_torque_nm", 0.5)], false);
    let state = bytes_of(c);
    let mut accepted = 0;
    for at in (HEADER..state.len() - 8).step_by(1) {
        for &x in &FORGED {
            let mut b = state.to_vec();
            b[at..at + 8].copy_from_slice(&x.to_bits().to_le_bytes());
            reseal(&mut b);
            match restore_and_check(c, &b, false) {
                Ok(None) => {}
                Ok(Some(_)) => accepted += 1,
                Err(e) => panic!("{x} at offset {at}: {e}"),
            }
        }
    }
    eprintln!("{accepted} forgeries accepted, all within the rules");
    assert_eq!(caught_panics(), 0);
    fmi2FreeInstance(c);
}

/// Each variable's value in a state forged to one outside its rule (NaN, ±inf, out of
/// its bounds, not whole, a wrong Boolean): refused, naming it.
#[test]
fn every_stored_variable_forged_out_of_its_rule_is_refused() {
    let c = instance_with(&[], true);
    run(c, 0.0, 0.01, 1e-3);
    let state = bytes_of(c);
    // The values follow the GUID, the phase and three times (see fmu::state::payload).
    let guid_len = fmu::xml::guid().len();
    let values_at = HEADER + 8 + guid_len + 1 + 3 * 8 + 8;
    for (k, v) in table().iter().enumerate() {
        let at = values_at + 8 * k;
        let held = f64::from_bits(u64::from_le_bytes(state[at..at + 8].try_into().unwrap()));
        let mut bad = vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
        if let Some(m) = v.min {
            bad.push(m - m.abs().max(1.0));
        }
        if let Some(m) = v.max {
            bad.push(m + m.abs().max(1.0));
        }
        match (v.kind, v.role) {
            (Kind::Integer | Kind::Enumeration(_), _) => bad.push(held + 0.5),
            (Kind::Boolean, _) => bad.push(2.0),
            (_, Role::Output(_) | Role::Text(_)) => bad.push(1.0),
            _ => {}
        }
        if v.name == "load_torque_nm" {
            bad.push(5.0);
        }
        for x in bad {
            let mut b = state.clone();
            b[at..at + 8].copy_from_slice(&x.to_bits().to_le_bytes());
            reseal(&mut b);
            let e = fmu::state::deserialize(&b, None)
                .err()
                .unwrap_or_else(|| panic!("`{}` = {x} accepted", v.name));
            assert!(
                e.contains(v.name) && e.contains("rule"),
                "`{}` = {x}: {e}",
                v.name
            );
            assert_eq!(restore_and_check(c, &b, false), Ok(None));
        }
    }
    fmi2FreeInstance(c);
}

/// A state the FMU serialized itself restores: after one short step at a tiny load (the
/// rotor nudged backwards, its angle a hair below 0 wraps to 2π) and at others.
#[test]
fn a_state_after_a_step_at_a_tiny_load_restores() {
    for load in [1e-12, 1e-200, f64::MIN_POSITIVE, 5e-324, 0.0, 1e-3] {
        let c = instance_with(&[], true);
        // SAFETY: a live instance, one value reference and one value.
        unsafe {
            let vr = vr_of("load_torque_nm").unwrap();
            assert_eq!(fmi2SetReal(c, &vr, 1, &load), OK);
        }
        run(c, 0.0, 1e-6, 1e-6);
        let state = bytes_of(c);
        let e = fmu::state::deserialize(&state, None).err();
        assert_eq!(e, None, "load {load}: the FMU refused its own state");
        fmi2FreeInstance(c);
    }
}

/// The size of a state is fixed by the parameters: the same at 0, 1 µs, 100 µs and 10 ms
/// with the current sense's conversion at its shortest (its pipeline then holds the most
/// conversions) and at the default.
#[test]
fn the_size_of_a_state_does_not_change_with_the_steps_taken() {
    for conv in [None, Some(1e-7), Some(1e-6)] {
        let params: Vec<(&str, f64)> = conv
            .map(|x| ("sensing.current.adc_conversion_s", x))
            .into_iter()
            .collect();
        let c = instance_with(&params, true);
        let mut sizes = vec![bytes_of(c).len()];
        let mut t = 0.0;
        for (to, h) in [(1e-6, 1e-6), (1e-4, 1e-6), (1e-2, 1e-4)] {
            t = run(c, t, to, h);
            sizes.push(bytes_of(c).len());
        }
        assert!(
            sizes.iter().all(|&n| n == sizes[0]),
            "conversion {conv:?}: sizes {sizes:?} at 0, 1 µs, 100 µs, 10 ms"
        );
        fmi2FreeInstance(c);
    }
}

/// The same for every Real parameter at each of its declared bounds (where the rules
/// that tie parameters together allow it): the size at 0, 1 µs and 100 µs is the same.
#[test]
fn the_size_is_fixed_for_every_parameter_at_its_bounds() {
    let mut checked = 0;
    for v in table() {
        if !(matches!(v.role, Role::Parameter { .. }) && v.kind == Kind::Real) {
            continue;
        }
        for x in [v.min, v.max].into_iter().flatten() {
            let c = instantiate("bounds");
            let vr = vr_of(v.name).unwrap();
            // SAFETY: a live instance; one value reference and one value.
            let ok = unsafe {
                fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) == OK
                    && fmi2EnterInitializationMode(c) == OK
                    && fmi2SetReal(c, &vr, 1, &x) == OK
                    && fmi2ExitInitializationMode(c) == OK
            };
            if ok {
                let mut sizes = vec![bytes_of(c).len()];
                let mut t = 0.0;
                for (to, h) in [(1e-6, 1e-6), (1e-4, 1e-5)] {
                    while t < to - 1e-12 && fmi2DoStep(c, t, h, 1) == OK {
                        t += h;
                    }
                    sizes.push(bytes_of(c).len());
                }
                // The one exception the docs state: a comparator toggling more than 64
                // times within the toggles it keeps (its propagation delay and the step
                // ahead: ringing or noise at the edge of their ranges) stores 9 bytes
                // (tick, state) for each toggle beyond.
                let toggles = |n: usize| n >= sizes[0] && (n - sizes[0]) % 9 == 0;
                let fixed = sizes.iter().all(|&n| n == sizes[0]);
                let comparator = v.name.starts_with("sensing.comparator.");
                if !fixed {
                    eprintln!("`{}` = {x}: sizes {sizes:?}", v.name);
                }
                assert!(
                    fixed || (comparator && sizes.iter().all(|&n| toggles(n))),
                    "`{}` = {x}: sizes {sizes:?} at 0, 1 µs, 100 µs",
                    v.name
                );
                checked += 1;
            }
            fmi2FreeInstance(c);
        }
    }
    assert!(checked > 50, "{checked} parameter bounds checked");
}

/// The floats of the drive's dynamic state in a serialized state (which it ends), with
/// their fields' paths, as a restore names them: NaN written over the 8 bytes at an
/// offset is refused as "path = NaN (rule: finite)" exactly where a float starts.
fn dynamic_floats(state: &[u8]) -> Vec<(usize, String)> {
    let model = fmu::state::deserialize(state, None).unwrap();
    let drive = model.drive.expect("a state with a drive");
    let bytes = drive.to_bytes().unwrap();
    let base = state.len() - bytes.len();
    assert_eq!(
        &state[base..],
        &bytes[..],
        "the drive's dynamic state ends the state"
    );
    let mut floats = Vec::new();
    let mut at = 0;
    while at + 8 <= bytes.len() {
        let mut b = bytes.clone();
        b[at..at + 8].copy_from_slice(&f64::NAN.to_bits().to_le_bytes());
        match drive.try_clone().unwrap().restore_from(&b) {
            Err(e) if e.contains(" = NaN (rule: finite)") => {
                let path = e.split(" = NaN").next().unwrap();
                floats.push((base + at, path.to_string()));
                at += 8;
            }
            _ => at += 1,
        }
    }
    floats
}

/// A field's path as refusals write it: indices without the dot ("records.buf[3]"), a
/// tuple's fields with one ("base.0").
fn normal(path: &str) -> String {
    path.replace(".[", "[").replace("..", ".")
}

/// A refusal with its numbers' long decimal expansions cut (1e300 prints 301 digits).
fn shorter(e: &str) -> String {
    let mut out = String::new();
    let mut run = 0;
    for ch in e.chars() {
        run = if ch.is_ascii_digit() { run + 1 } else { 0 };
        if run <= 20 {
            out.push(ch);
        } else if run == 21 {
            out.push('…');
        }
    }
    out
}

/// A field's kind: its path without indices ("records.buf[].fx[].a").
fn kind(path: &str) -> String {
    let mut k = String::new();
    let mut digits = false;
    for ch in normal(path).chars() {
        match ch {
            '0'..='9' if digits => {}
            '[' => {
                k.push('[');
                digits = true;
            }
            _ => {
                digits = false;
                k.push(ch);
            }
        }
    }
    k
}

/// Finite values beyond any rule (1e300, −1e300, 1e30) written over the floats of the
/// drive's dynamic state, resealed, in states through alignment, start-up and running,
/// and of six-step with noise, ringing and dead time (every kind of field covered: each
/// float of a kind of up to 16, the first, middle and last of a larger one): each is
/// refused at fmi2DeSerializeFMUstate naming the field (the value's own, or what it
/// belongs to: a kept step whose filter output it moves out of its rule). Were one
/// accepted, the next step would have to return fmi2OK with every output finite, or
/// fmi2Error, and never panic; none is.
#[test]
fn finite_out_of_rule_values_in_the_dynamic_state_are_refused_naming_them() {
    let six_step: &[(&str, f64)] = &[
        ("strategy.name", 1.0),
        ("sensing.comparator.noise_v", 0.02),
        ("sensing.comparator.ring_gain", 0.1),
        ("power_stage.dead_time_s", 1e-6),
    ];
    let mut kinds = std::collections::BTreeSet::new();
    let (mut forged, mut accepted, mut unnamed) = (0, Vec::new(), Vec::new());
    for (params, times) in [
        (&[][..], &[0.3, 1.0, 1.5][..]),
        (six_step, &[0.85, 1.05][..]),
    ] {
        let c = instance_with(params, true);
        // SAFETY: a live instance, one value reference and one value.
        unsafe {
            let vr = vr_of("load_torque_nm").unwrap();
            assert_eq!(fmi2SetReal(c, &vr, 1, &1e-4), OK);
        }
        let mut t = 0.0;
        for &at_s in times {
            t = run(c, t, at_s, 1e-3);
            // A little more, so the state is not at a communication point's round number.
            t = run(c, t, t + 7e-6, 7e-6);
            let state = bytes_of(c);
            let floats = dynamic_floats(&state);
            let mut by_kind: std::collections::BTreeMap<String, Vec<&(usize, String)>> =
                Default::default();
            for f in &floats {
                by_kind.entry(kind(&f.1)).or_default().push(f);
            }
            for (k, fs) in &by_kind {
                kinds.insert(k.clone());
                // Every one of a small kind (a state vector's components have rules of
                // their own); the first, middle and last of a larger one.
                let mut pick = if fs.len() <= 16 {
                    fs.clone()
                } else {
                    vec![fs[0], fs[fs.len() / 2], fs[fs.len() - 1]]
                };
                pick.dedup();
                for &(at, ref path) in pick {
                    for x in [1e300f64, -1e300, 1e30] {
                        let mut b = state.clone();
                        b[at..at + 8].copy_from_slice(&x.to_bits().to_le_bytes());
                        reseal(&mut b);
                        forged += 1;
                        let panics = caught_panics();
                        // SAFETY: a live instance; `b` holds `b.len()` bytes; the state is
                        // freed here.
                        let refused = unsafe {
                            let mut s = ptr::null_mut();
                            if fmi2DeSerializeFMUstate(c, b.as_ptr().cast(), b.len(), &mut s) == OK
                            {
                                assert_eq!(fmi2SetFMUstate(c, s), OK);
                                assert_eq!(fmi2FreeFMUstate(c, &mut s), OK);
                                let mut now = f64::NAN;
                                fmi2GetRealStatus(c, 2, &mut now);
                                if fmi2DoStep(c, now, 2e-5, 1) == OK {
                                    read_back(c).unwrap_or_else(|e| {
                                        panic!("{path} = {x} at {at_s} s, stepped: {e}")
                                    });
                                }
                                false
                            } else {
                                true
                            }
                        };
                        assert_eq!(
                            caught_panics(),
                            panics,
                            "{path} = {x}: a panic inside the FMU"
                        );
                        if !refused {
                            accepted.push(format!("{path} = {x} at {at_s} s"));
                            continue;
                        }
                        let Err(e) = fmu::state::deserialize(&b, None) else {
                            panic!("{path} = {x}: refused by the FMU, accepted by deserialize")
                        };
                        // The field itself, or what it belongs to (a bend's coefficient:
                        // the kept step), down to a component's part ("plant.cmp.front").
                        let p = normal(path);
                        let p = p.strip_prefix("drive.").unwrap_or(&p);
                        let p = p.strip_prefix("engine.").unwrap_or(p);
                        let mut names = vec![p.to_string()];
                        while let Some((s, last)) = names.last().unwrap().rsplit_once(['.', '[']) {
                            // A tuple's field is named with its tuple ("base_hint = (…)").
                            let tuple = last.bytes().all(|b| b.is_ascii_digit());
                            if s.split('.').count() < 3 && !tuple {
                                break;
                            }
                            names.push(s.to_string());
                        }
                        // Keys are quoted (`key` = value): the path is read without them.
                        let said = normal(&e).replace('`', "");
                        if !(said.contains("rule")
                            && names.iter().any(|n| said.contains(n.as_str())))
                        {
                            unnamed.push(format!("{path} = {x:e} at {at_s} s: {}", shorter(&e)));
                        }
                    }
                }
            }
            // The state itself still restores (the scan leaves the instance elsewhere).
            assert_eq!(
                restore_and_check(c, &state, false).map(|t| t.is_some()),
                Ok(true)
            );
        }
        fmi2FreeInstance(c);
    }
    eprintln!("{forged} forgeries over {} kinds of float", kinds.len());
    assert!(kinds.len() > 100, "{} kinds: {kinds:?}", kinds.len());
    assert!(accepted.is_empty(), "accepted: {accepted:#?}");
    assert!(
        unnamed.is_empty(),
        "refused, but not naming the field: {unnamed:#?}"
    );
    assert_eq!(caught_panics(), 0);
}

/// A state saved after steps whose phase is forged to one before initialization ends is
/// refused (no step is taken before it ends): set, an input would then drop a drive
/// whose time has moved, and the instance would save a state it refuses.
#[test]
fn a_running_state_forged_to_before_initialization_is_refused() {
    let c = instance_with(&[], true);
    run(c, 0.0, 0.005, 1e-3);
    let state = bytes_of(c);
    let at = HEADER + 8 + fmu::xml::guid().len();
    assert_eq!(state[at], 2, "the phase, StepComplete");
    for phase in [0, 1] {
        let mut b = state.clone();
        b[at] = phase;
        reseal(&mut b);
        let e = fmu::state::deserialize(&b, None).err().expect("accepted");
        assert!(e.starts_with("time = 0.005 in phase"), "{e}");
    }
    fmi2FreeInstance(c);
}
