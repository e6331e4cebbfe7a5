//! Closed loop on the built-in motor: start from standstill, lock, hold speed, reject a
//! load step, commutate on the table boundaries. Numbers come from the true plant state.

use bldc_drive::DriveConfig;
use bldc_drive::drive::{build, run_to};
use bldc_drive::drive_core::pwm::PwmSchemeKind;
use bldc_drive::strategies::{Mode, StrategyName};

/// What a closed-loop run produced.
struct Run {
    /// (t [s], true mechanical speed [rpm]) at every engine stop.
    speed: Vec<(f64, f64)>,
    /// Signed error of the true electrical angle at each commutation after `settle_s`
    /// against the boundary of the state entered [electrical degrees].
    angle_err: Vec<f64>,
    restarts: u32,
    mode: Mode,
}

fn run(name: StrategyName, rpm: f64, secs: f64, load: Option<(f64, f64)>, settle_s: f64) -> Run {
    let mut cfg = DriveConfig::default();
    cfg.strategy.name = name;
    run_config(cfg, rpm, secs, load, settle_s)
}

fn run_config(
    mut cfg: DriveConfig,
    rpm: f64,
    secs: f64,
    load: Option<(f64, f64)>,
    settle_s: f64,
) -> Run {
    cfg.control.speed_ref_rpm = rpm;
    let mut eng = build(&cfg).expect("default config is valid");
    let table = eng.controller.table();
    let mut out = Run {
        speed: Vec::new(),
        angle_err: Vec::new(),
        restarts: 0,
        mode: Mode::Off,
    };
    let mut last_state = 0u8;
    let mut t_load = load;
    let mut t = 0.0;
    while t < secs {
        let next = (t + 0.05).min(secs);
        if let Some((at, nm)) = t_load
            && next > at
        {
            run_to(&mut eng, at, |_, _| {}).unwrap();
            eng.plant.set_load_torque(nm);
            t_load = None;
        }
        run_to(&mut eng, next, |e, _| {
            let o = e.plant.observe();
            out.speed.push((o.t_s, o.speed_rpm));
            let s = e.controller.status();
            if s.state != last_state && s.state != 0 && last_state != 0 && o.t_s > settle_s {
                let th = o.theta_e.to_degrees();
                let err = (th - table.state_start_deg(s.state) + 540.0).rem_euclid(360.0) - 180.0;
                out.angle_err.push(err);
            }
            last_state = s.state;
        })
        .unwrap();
        t = next;
    }
    let s = eng.controller.status();
    out.restarts = s.restarts;
    out.mode = s.mode;
    out
}

/// Time-weighted mean of the speed over [a, b].
fn mean_speed(r: &Run, a: f64, b: f64) -> f64 {
    let mut acc = 0.0;
    let mut w = 0.0;
    for p in r.speed.windows(2) {
        let (t0, s0) = p[0];
        let (t1, _) = p[1];
        if t0 >= a && t1 <= b {
            acc += s0 * (t1 - t0);
            w += t1 - t0;
        }
    }
    acc / w
}

#[test]
fn df_guarded_strategies_start_lock_and_hold_the_commanded_speed() {
    for (name, rpm) in [
        (StrategyName::TwelveStepDf, 2000.0),
        (StrategyName::TwelveStepDf, 6000.0),
        (StrategyName::SixStep120, 3000.0),
    ] {
        let r = run(name, rpm, 4.0, None, 3.0);
        assert_eq!(r.mode, Mode::Running, "{name} {rpm} rpm");
        assert_eq!(r.restarts, 0, "{name} {rpm} rpm");
        let m = mean_speed(&r, 3.0, 4.0);
        assert!(
            (m - rpm).abs() < 0.02 * rpm,
            "{name} {rpm} rpm: mean {m:.0}"
        );
    }
}

#[test]
fn every_pwm_scheme_drives_the_same_strategy() {
    for scheme in PwmSchemeKind::ALL {
        let mut cfg = DriveConfig::default();
        cfg.power_stage.pwm_scheme = scheme;
        cfg.power_stage.dead_time_s = 0.5e-6;
        let r = run_config(cfg, 3000.0, 3.0, None, 9.0);
        let m = mean_speed(&r, 2.5, 3.0);
        assert_eq!(r.restarts, 0, "{}", scheme.name());
        assert!((m - 3000.0).abs() < 60.0, "{}: mean {m:.0}", scheme.name());
    }
}

#[test]
fn a_load_step_is_rejected() {
    // 0.4 mN·m is about half the no-load drag at 3000 rpm again, ≈ 0.05 A more current.
    let r = run(
        StrategyName::TwelveStepDf,
        3000.0,
        5.5,
        Some((3.0, 4e-4)),
        9.0,
    );
    let before = mean_speed(&r, 2.5, 3.0);
    let dip = r
        .speed
        .iter()
        .filter(|p| p.0 > 3.0 && p.0 < 4.0)
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min);
    let after = mean_speed(&r, 5.0, 5.5);
    assert!((before - 3000.0).abs() < 60.0, "before {before:.0}");
    assert!(dip < before - 20.0, "the load must be felt: dip {dip:.0}");
    assert!((after - 3000.0).abs() < 60.0, "after {after:.0}");
    assert_eq!(r.restarts, 0);
}

#[test]
fn commutations_fall_on_the_table_boundaries() {
    let r = run(StrategyName::TwelveStepDf, 3000.0, 4.0, None, 3.0);
    angle_stats("twelve-step-df", &r);
    let r = run(StrategyName::SixStep120, 3000.0, 4.0, None, 3.0);
    angle_stats("six-step-120", &r);
}

fn angle_stats(name: &str, r: &Run) {
    let n = r.angle_err.len() as f64;
    let mean = r.angle_err.iter().sum::<f64>() / n;
    let mean_abs = r.angle_err.iter().map(|e| e.abs()).sum::<f64>() / n;
    let max = r.angle_err.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    println!(
        "{name} 3000 rpm: {n} commutations, error mean {mean:+.2}°, mean |e| {mean_abs:.2}°, max |e| {max:.2}°"
    );
    // One second at 3000 rpm is 300 electrical turns, 6 or 12 commutations each.
    assert!(n > 1700.0, "{name}: {n}");
    assert!(mean_abs < 3.0, "{name}: mean |error| {mean_abs:.2}°");
    assert!(max < 15.0, "{name}: max |error| {max:.2}°");
}
