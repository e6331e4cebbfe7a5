//! A step down to a low speed (docs/chip.md, "At the lower limit"): on a step 3000 → 600
//! rpm the speed PI asks no current and the rotor coasts at the friction's deceleration,
//! (Tc + B·ω)/J ≈ 1760 rpm/s at 600 rpm. An integrator drained to 0 by that coast rebuilds
//! the friction's current at the low-speed gains only after the rotor has fallen below
//! twelve-step-df's floor (≈ 516 rpm turned down slowly), and the rotor is lost; held at
//! the lower limit (the shipped speed anti-windup), it returns that current at once and
//! the rotor stays above the floor.

use bldc_drive::DriveConfig;
use bldc_drive::profile::Profile;
use bldc_drive::scenario::{Scenario, TraceSpec, run};
use bldc_drive::verdict::Verdict;

/// twelve-step-df at 3000 rpm, the command stepped to 600 rpm at 2.5 s, judged over the
/// last 4 s of 12; and the lowest true speed after the step.
fn step_to_600(speed_anti_windup: bool) -> (Verdict, String, f64, f64) {
    let mut c = DriveConfig::default();
    c.strategy.name = "twelve-step-df".parse().unwrap();
    c.control.speed_anti_windup = speed_anti_windup;
    let mut sc = Scenario::hold(c, 3000.0, 12.0);
    sc.speed_rpm = Profile::constant(3000.0).step_to(2.5, 600.0);
    sc.steady_from_s = 8.0;
    sc.trace = Some(TraceSpec {
        every_s: 1e-3,
        from_s: 2.5,
        to_s: 12.0,
    });
    let mut lowest = f64::INFINITY;
    let s = run(&sc, |r| lowest = lowest.min(r.speed_rpm))
        .expect("the run")
        .summary;
    (s.verdict, s.verdict_reason, s.speed_mean_rpm, lowest)
}

#[test]
fn a_step_down_to_600_rpm_is_held_with_the_integrator_held_and_lost_without() {
    let (held, drained) = std::thread::scope(|s| {
        let a = s.spawn(|| step_to_600(true));
        let b = s.spawn(|| step_to_600(false));
        (a.join().unwrap(), b.join().unwrap())
    });
    assert_eq!(held.0, Verdict::Running, "{}", held.1);
    assert!((held.2 - 600.0).abs() < 12.0, "{} rpm", held.2);
    // Above the floor all the way: the current is back before the rotor passes it.
    assert!(held.3 > 516.0, "lowest {:.0} rpm", held.3);
    assert!(
        matches!(
            drained.0,
            Verdict::Stalled | Verdict::LostSync | Verdict::GaveUp
        ),
        "drained: {} {}",
        drained.0,
        drained.1
    );
}
