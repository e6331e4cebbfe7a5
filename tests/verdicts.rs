//! Verdicts from physical cases: each run is judged from the true rotor, whatever the chip
//! believes; and the plausibility supervisor restarts a drive locked on false crossings.

use bldc_drive::DriveConfig;
use bldc_drive::drive::build;
use bldc_drive::drive_core::{Plant, Ticks};
use bldc_drive::metrics::wrap_deg;
use bldc_drive::scenario::{Scenario, Summary, run};
use bldc_drive::strategies::StrategyName;
use bldc_drive::verdict::Verdict;

fn summary(cfg: DriveConfig, rpm: f64, secs: f64, load_nm: f64) -> Summary {
    let mut sc = Scenario::hold(cfg, rpm, secs);
    if load_nm != 0.0 {
        sc.load_steps.push((0.0, load_nm));
    }
    run(&sc, |_| {}).expect("runs").summary
}

/// The published motor with its phase resistance raised to `ohm` (a normal tolerance:
/// 2.2 Ω nominal), the chip as published (no supervisor) or with it.
fn raised_r(name: StrategyName, ohm: f64, supervisor: bool) -> DriveConfig {
    let mut cfg = DriveConfig::default();
    cfg.strategy.name = name;
    cfg.motor.resistance_ohm = ohm;
    cfg.control.supervisor = supervisor;
    cfg
}

#[test]
fn the_nominal_drive_runs_in_synchronism() {
    let s = summary(DriveConfig::default(), 3000.0, 3.0, 0.0);
    assert_eq!(s.verdict, Verdict::Running, "{}", s.verdict_reason);
    assert!(s.started_at_s.is_some_and(|t| t > 0.75 && t < 1.0), "{s:?}");
}

/// As published, a raised resistance makes the start fail: after the hand-over the chip
/// locks on freewheel and PWM transients of a floating phase with no back-EMF; FG keeps
/// toggling, so step-miss never fires, and the chip "runs" at several krpm.
#[test]
fn a_drive_locked_on_false_crossings_is_not_started_although_the_chip_runs() {
    for (name, ohm) in [
        (StrategyName::TwelveStepDf, 2.8),
        (StrategyName::SixStep120, 2.4),
    ] {
        let s = summary(raised_r(name, ohm, false), 3000.0, 3.0, 0.0);
        assert_eq!(
            s.verdict,
            Verdict::NotStarted,
            "{name}: {}",
            s.verdict_reason
        );
        assert!(s.chip_running && s.restarts == 0, "{name}: {s:?}");
        assert!(
            s.chip_speed_rpm > 3000.0,
            "{name}: believes {}",
            s.chip_speed_rpm
        );
        assert!(
            s.speed_mean_rpm.abs() < 100.0,
            "{name}: {}",
            s.speed_mean_rpm
        );
    }
}

/// When synchronism was lost (from the true rotor: the last commutation before the
/// restart that was within 30° of its boundary) and when the chip restarted.
fn lost_and_restarted(cfg: &DriveConfig, until_s: f64) -> (f64, f64) {
    let mut eng = build(cfg).unwrap();
    let table = eng.controller.table();
    let (mut last_state, mut last_good, mut restart) = (0u8, 0.0, None);
    let end = Ticks::from_seconds(until_s).unwrap();
    eng.run_until(end, |e, _| {
        let s = e.controller.status();
        if restart.is_some() {
            return;
        }
        if s.restarts > 0 {
            restart = Some(e.plant.time_s());
        } else if s.state != last_state && s.state != 0 && last_state != 0 {
            let o = e.plant.observe();
            let err = wrap_deg(o.theta_e.to_degrees() - table.state_start_deg(s.state));
            if err.abs() <= 30.0 {
                last_good = o.t_s;
            }
        }
        last_state = s.state;
    })
    .unwrap();
    (
        last_good,
        restart.expect("the supervisor restarted the drive"),
    )
}

#[test]
fn the_supervisor_restarts_a_false_lock_within_a_tenth_of_a_second() {
    for (name, ohm) in [
        (StrategyName::TwelveStepDf, 2.8),
        (StrategyName::TwelveStepDf, 2.7),
        (StrategyName::SixStep120, 2.4),
    ] {
        let cfg = raised_r(name, ohm, true);
        let (lost, restart) = lost_and_restarted(&cfg, 1.5);
        assert!(
            restart - lost <= 0.1,
            "{name} at {ohm} Ω: lost at {lost:.4} s, restarted at {restart:.4} s"
        );
    }
}

#[test]
fn the_supervisor_leaves_healthy_drives_alone() {
    for name in StrategyName::ALL {
        for rpm in [1500.0, 8000.0] {
            let mut cfg = DriveConfig::default();
            cfg.strategy.name = name;
            let s = summary(cfg, rpm, 2.0, 0.0);
            assert_eq!(s.restarts, 0, "{name} at {rpm} rpm: {}", s.verdict_reason);
        }
    }
}

#[test]
fn with_no_restart_left_a_tripped_drive_gives_up() {
    let mut cfg = raised_r(StrategyName::TwelveStepDf, 2.8, true);
    cfg.control.max_restarts = 0;
    let s = summary(cfg, 3000.0, 1.5, 0.0);
    assert_eq!(s.verdict, Verdict::GaveUp, "{}", s.verdict_reason);
}

/// 500 rpm is below what the 15-bit meter reads (1192 rpm): the chip believes it is too
/// fast, cuts the current, and the rotor stops while false crossings keep FG toggling.
#[test]
fn a_command_below_the_published_meter_is_not_held() {
    let mut cfg = DriveConfig::default();
    cfg.control.supervisor = false;
    let s = summary(cfg, 500.0, 3.0, 0.0);
    assert_eq!(s.verdict, Verdict::Stalled, "{}", s.verdict_reason);
    assert!(s.chip_running, "the chip believes it runs");
}

#[test]
fn a_command_beyond_reach_is_off_speed_in_synchronism() {
    let s = summary(DriveConfig::default(), 16_000.0, 3.0, 0.0);
    assert_eq!(s.verdict, Verdict::OffSpeed, "{}", s.verdict_reason);
    // Full voltage against the back-EMF: the built-in motor tops out near 12.5 krpm.
    assert!(s.speed_mean_rpm > 10_000.0 && s.speed_mean_rpm < 15_000.0);
}

/// 1 N·m is 500 times the motor's torque at its current limit: the load spins the rotor
/// backwards, whatever the chip does.
#[test]
fn an_active_load_the_motor_cannot_hold_is_not_running() {
    let s = summary(DriveConfig::default(), 3000.0, 1.0, 1.0);
    assert_eq!(s.verdict, Verdict::NotStarted, "{}", s.verdict_reason);
    assert!(s.speed_mean_rpm < -1e4, "{}", s.speed_mean_rpm);
}

/// An inertia of 1e-12 kg·m² makes the mechanical equation too stiff for the step: the
/// state leaves the reals within a millisecond.
#[test]
fn a_state_that_leaves_the_reals_is_non_finite() {
    let mut cfg = DriveConfig::default();
    cfg.motor.inertia_kgm2 = 1e-12;
    let s = summary(cfg, 3000.0, 0.05, 0.0);
    assert_eq!(s.verdict, Verdict::NonFinite, "{}", s.verdict_reason);
}
