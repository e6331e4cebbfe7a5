//! Loads the packaged FMU through the `fmi` crate (an independent importer) and
//! co-simulates it against the same scenario run natively on the drive: the traces must be
//! bit-identical, since both stop the engine at the same instants with the same inputs.

use bldc_drive::DriveConfig;
use bldc_drive::drive::{build, run_to};
use fmi::fmi2::instance::{CoSimulation, Common};
use fmi::traits::{FmiInstance, FmiStatus};

mod common;

use common::{import, vr};

const H: f64 = 0.5e-3;
const SPEED_REF: f64 = 3500.0;
const LOAD_AT_STEP: u32 = 2000; // 1.0 s
const LOAD_NM: f64 = 1e-4;
// 0.9 s: past the alignment (0.75 s), running closed loop, before the load step.
const SAVE_AT_STEP: u32 = 1800;
const STEPS: u32 = 3000; // 1.5 s

/// (t, speed_rpm, i_u) every 10 ms of the native run.
fn native() -> Vec<(f64, f64, f64)> {
    let mut cfg = DriveConfig::default();
    cfg.control.speed_ref_rpm = SPEED_REF;
    let mut eng = build(&cfg).unwrap();
    let mut out = Vec::new();
    for k in 0..STEPS {
        if k == LOAD_AT_STEP {
            eng.plant.set_load_torque(LOAD_NM);
        }
        run_to(&mut eng, f64::from(k + 1) * H, |_, _| {}).unwrap();
        if (k + 1) % 20 == 0 {
            let o = eng.plant.observe();
            out.push((f64::from(k + 1) * H, o.speed_rpm, o.i.u));
        }
    }
    out
}

#[test]
fn fmi_crate_co_simulates_the_fmu_bit_identically_to_the_native_drive() {
    let import = import();
    let (speed_ref, load, speed, i_u) = (
        vr(&import, "speed_ref_rpm"),
        vr(&import, "load_torque_nm"),
        vr(&import, "speed_rpm"),
        vr(&import, "i_u"),
    );
    let mut inst = import.instantiate_cs("import", false, true).unwrap();
    Common::set_real(&mut inst, &[speed_ref], &[SPEED_REF]).unwrap();
    FmiInstance::enter_initialization_mode(&mut inst, None, 0.0, None).unwrap();
    FmiInstance::exit_initialization_mode(&mut inst).unwrap();

    let mut fmu = Vec::new();
    let mut saved = None;
    for k in 0..STEPS {
        if k == LOAD_AT_STEP {
            Common::set_real(&mut inst, &[load], &[LOAD_NM]).unwrap();
        }
        if k == SAVE_AT_STEP {
            let mut v = [0.0];
            Common::get_real(&mut inst, &[speed], &mut v).unwrap();
            assert!(
                v[0] > 1000.0,
                "running closed loop at the save point: {} rpm",
                v[0]
            );
            let s = inst.get_fmu_state().unwrap();
            saved = Some(inst.serialize_fmu_state(&s).unwrap());
        }
        inst.do_step(f64::from(k) * H, H, true).unwrap();
        if (k + 1) % 20 == 0 {
            let mut v = [0.0; 2];
            Common::get_real(&mut inst, &[speed, i_u], &mut v).unwrap();
            fmu.push((f64::from(k + 1) * H, v[0], v[1]));
        }
    }
    let reference = native();
    assert_eq!(fmu.len(), reference.len());
    for (a, b) in fmu.iter().zip(&reference) {
        assert_eq!(a, b, "FMU vs native at t = {} s", b.0);
    }
    let peak = reference.iter().map(|r| r.1).fold(0.0, f64::max);
    assert!(
        peak > 0.98 * SPEED_REF,
        "the drive reached {peak} rpm of {SPEED_REF}"
    );

    // The state serialized at 0.9 s, restored through the importer, continues the run.
    let s = inst.deserialize_fmu_state(&saved.unwrap()).unwrap();
    inst.set_fmu_state(&s).ok().expect("state restored");
    for k in SAVE_AT_STEP..STEPS {
        if k == LOAD_AT_STEP {
            Common::set_real(&mut inst, &[load], &[LOAD_NM]).unwrap();
        }
        inst.do_step(f64::from(k) * H, H, true).unwrap();
    }
    let mut v = [0.0; 2];
    Common::get_real(&mut inst, &[speed, i_u], &mut v).unwrap();
    let end = reference.last().unwrap();
    assert_eq!((v[0], v[1]), (end.1, end.2));
    FmiInstance::terminate(&mut inst).unwrap();
}

#[test]
fn fmi_crate_sees_bad_calls_refused() {
    let import = import();
    let mut inst = import.instantiate_cs("bad", false, true).unwrap();
    assert!(
        inst.do_step(0.0, H, true).is_err(),
        "step before initialization"
    );
    FmiInstance::enter_initialization_mode(&mut inst, None, 0.0, None).unwrap();
    let r = vr(&import, "motor.resistance_ohm");
    let m = vr(&import, "motor.mutual_inductance_h");
    assert!(
        Common::set_real(&mut inst, &[r, m], &[2.2, -1.0]).is_err(),
        "a negative mutual inductance breaks its range: the call applies nothing"
    );
    // Within its own range, but not below the self inductance: refused when built.
    Common::set_real(&mut inst, &[m], &[0.9]).unwrap();
    assert!(
        FmiInstance::exit_initialization_mode(&mut inst).is_err(),
        "M >= Lp breaks the rule tying them"
    );
    Common::set_real(&mut inst, &[r, m], &[2.2, 0.0]).unwrap();
    FmiInstance::exit_initialization_mode(&mut inst).unwrap();
    assert!(inst.do_step(0.0, -H, true).is_err(), "negative step");
    assert!(inst.do_step(0.0, f64::NAN, true).is_err(), "NaN step");
    inst.do_step(0.0, H, true).unwrap();
}
