//! The load models and the supply against closed-form mechanics and circuit solutions,
//! with the bridge off (no current: the motor's EMF at 1000 rpm stays far inside the
//! diode clamps) or the rotor locked.

use crate::common;

use bldc_drive::drive_core::{Abc, Hold, Plant, Ticks};
use bldc_drive::plants::{Load, PlantParams};
use common::*;
use std::f64::consts::TAU;

const W0_RPM: f64 = 1000.0;

/// A motor without friction, so that the load alone decelerates it.
fn frictionless() -> PlantParams {
    let mut p = PlantParams::default();
    p.motor.viscous_friction_nms = 0.0;
    p.motor.coulomb_friction_nm = 0.0;
    p
}

/// The true speed \[rad/s\] after coasting `t_s` from `rpm` with the bridge off.
fn coast(params: PlantParams, load: Load, rpm: f64, t_s: f64) -> f64 {
    let mut eng = engine(params, Hold(hold("FFF", 0, Abc::splat(false))));
    eng.plant.set_load(load);
    eng.plant.set_rotor(0.0, rpm, false);
    eng.run_until(Ticks::from_seconds(t_s).unwrap(), |_, _| {})
        .unwrap();
    let o = eng.plant.observe();
    assert!(o.i.u == 0.0 && o.i.v == 0.0 && o.i.w == 0.0, "{:?}", o.i);
    o.omega_m
}

#[test]
fn a_fan_load_decelerates_as_one_over_time() {
    let p = frictionless();
    let j = p.motor.inertia_kgm2;
    // J_L = J doubles the inertia the fan acts on.
    let load = Load {
        fan_nms2: 1e-7,
        inertia_kgm2: j,
        ..Load::default()
    };
    let w0 = W0_RPM * TAU / 60.0;
    let t = 0.5;
    // J_t·dω/dt = −K·ω² ⇒ ω = ω0 / (1 + K·ω0·t/J_t).
    let want = w0 / (1.0 + load.fan_nms2 * w0 * t / (2.0 * j));
    let got = coast(p, load, W0_RPM, t);
    assert!(
        want < 0.8 * w0,
        "the test must decelerate noticeably: {want}"
    );
    assert!((got - want).abs() < 1e-6 * w0, "{got} vs {want}");
}

#[test]
fn a_viscous_load_decays_exponentially() {
    let p = frictionless();
    let j = p.motor.inertia_kgm2;
    let load = Load {
        viscous_nms: 2e-6,
        ..Load::default()
    };
    let w0 = W0_RPM * TAU / 60.0;
    let t = 0.5;
    let want = w0 * (-load.viscous_nms * t / j).exp();
    let got = coast(p, load, W0_RPM, t);
    assert!(want < 0.8 * w0, "{want}");
    assert!((got - want).abs() < 1e-6 * w0, "{got} vs {want}");
}

#[test]
fn a_coulomb_load_decelerates_linearly_and_never_turns_a_rotor_at_rest() {
    let p = frictionless();
    let j = p.motor.inertia_kgm2;
    let load = Load {
        coulomb_nm: 5e-4,
        ..Load::default()
    };
    let w0 = W0_RPM * TAU / 60.0;
    let t = 0.2;
    // Far above the smoothing speed (0.5 rad/s) tanh is 1 to 1e-15.
    let want = w0 - load.coulomb_nm * t / j;
    assert!(want > 10.0 && want < 0.8 * w0, "{want}");
    let got = coast(p.clone(), load, W0_RPM, t);
    assert!((got - want).abs() < 1e-6 * w0, "{got} vs {want}");
    // Passive: a rotor at rest stays at rest, whatever the load.
    let heavy = Load {
        coulomb_nm: 0.5,
        viscous_nms: 1e-3,
        fan_nms2: 1e-6,
        ..Load::default()
    };
    assert_eq!(coast(p, heavy, 0.0, 0.1), 0.0);
}

#[test]
fn an_active_load_turns_a_rotor_at_rest_backwards() {
    let p = frictionless();
    let j = p.motor.inertia_kgm2;
    let load = Load {
        active_nm: 1e-4,
        ..Load::default()
    };
    let t = 0.05;
    let want = -load.active_nm * t / j;
    let got = coast(p, load, 0.0, t);
    assert!(want < -1.0, "{want}");
    assert!((got - want).abs() < 1e-6 * want.abs(), "{got} vs {want}");
}

#[test]
fn a_supply_change_moves_the_locked_rotor_current_to_its_new_level() {
    // u→v driven at full duty: i → V/R_loop with τ = L_loop/R_loop (as the RL-step test).
    let params = PlantParams::default();
    let m = &params.motor;
    let ps = &params.power_stage;
    let r_loop = 2.0 * m.resistance_ohm + 2.0 * ps.switch_on_resistance_ohm + ps.shunt_ohm;
    let tau = 2.0 * (m.self_inductance_h + m.mutual_inductance_h) / r_loop;
    let (v1, v2) = (ps.supply_v, 0.5 * ps.supply_v);
    let mut eng = engine(params.clone(), Hold(hold("VGF", 2000, Abc::splat(false))));
    eng.plant.set_rotor(0.3, 0.0, true);
    let t1 = 10.0 * tau;
    eng.run_until(Ticks::from_seconds(t1).unwrap(), |_, _| {})
        .unwrap();
    let i1 = eng.plant.observe().i.u;
    assert!((i1 - v1 / r_loop).abs() < 1e-4 * i1, "{i1}");
    eng.plant.set_supply_v(v2).unwrap();
    // One time constant after the change: i = i2 + (i1 − i2)·e^{−1}.
    let t = t1 + tau;
    eng.run_until(Ticks::from_seconds(t).unwrap(), |_, _| {})
        .unwrap();
    let dt = eng.plant.time_s() - t1;
    let i2 = v2 / r_loop;
    let want = i2 + (v1 / r_loop - i2) * (-dt / tau).exp();
    let got = eng.plant.observe().i.u;
    assert!((got - want).abs() < 1e-4 * want, "{got} vs {want}");
    // The rule of power_stage.supply_v, named.
    let e = eng.plant.set_supply_v(-1.0).unwrap_err().to_string();
    assert!(e.contains("power_stage.supply_v"), "{e}");
}
