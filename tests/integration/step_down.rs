//! Falls to a low speed (docs/chip.md, "Resuming after a fall" and "Descent after a
//! start"): twelve-step-df stepped from 3000 to 600 rpm holds 600 rpm with the shipped
//! `control.speed_resume`, and the published PIs, which rebuild the friction's current
//! from what the fall left them, lose the rotor below DF's floor; started straight to 550
//! rpm, which the start current overshoots, it holds with `control.start_descent_rpm_s`
//! and is lost without it.

use crate::common::traced;
use bldc_drive::DriveConfig;
use bldc_drive::profile::Profile;
use bldc_drive::scenario::{Scenario, run};
use bldc_drive::verdict::Verdict;

/// twelve-step-df from standstill at 3000 rpm, stepped to 600 rpm at 2 s, judged over
/// 5..6 s: the verdict and reason, the restarts after the step and the true speed's
/// least value after it.
fn stepped(mut config: DriveConfig, seed: u64) -> (Verdict, String, u32, f64) {
    config.strategy.name = "twelve-step-df".parse().unwrap();
    config.sensing.seed = seed;
    let mut sc = Scenario::hold(config, 3000.0, 6.0);
    sc.speed_rpm = Profile::constant(3000.0).step_to(2.0, 600.0);
    sc.steady_from_s = 5.0;
    let (s, restarts, speeds) = traced(sc, 2.0, 6.0);
    let least = speeds.iter().map(|&(_, v)| v).fold(f64::INFINITY, f64::min);
    (s.verdict, s.verdict_reason, restarts, least)
}

#[test]
fn a_step_3000_to_600_rpm_is_held() {
    for seed in [1, 2, 3] {
        let (verdict, reason, restarts, least) = stepped(DriveConfig::default(), seed);
        assert_eq!(verdict, Verdict::Running, "seed {seed}: {reason}");
        assert_eq!(restarts, 0, "seed {seed}: restarts after the step");
        // The rotor coasts below the command while the meter, one FG period late, still
        // reads it above; it must not fall to a standstill.
        assert!(least > 300.0, "seed {seed}: the rotor fell to {least} rpm");
    }
}

#[test]
fn the_published_pis_lose_the_step() {
    let mut c = DriveConfig::default();
    c.control.speed_resume = false;
    let (verdict, reason, _, least) = stepped(c, 1);
    assert_ne!(verdict, Verdict::Running, "{reason}");
    assert!(least < 300.0, "the rotor fell only to {least} rpm");
}

/// twelve-step-df started straight to `rpm` from standstill, judged over 5..6 s: the
/// verdict and reason, and the restarts over the whole run.
fn started(config: DriveConfig, rpm: f64, seed: u64) -> (Verdict, String, u32) {
    let mut sc = Scenario::hold(config, rpm, 6.0);
    sc.config.strategy.name = "twelve-step-df".parse().unwrap();
    sc.config.sensing.seed = seed;
    sc.steady_from_s = 5.0;
    let s = run(&sc, |_| {}).expect("the run").summary;
    (s.verdict, s.verdict_reason, s.restarts)
}

#[test]
fn a_start_straight_to_550_rpm_descends_and_holds() {
    for seed in [1, 2, 3] {
        let (verdict, reason, restarts) = started(DriveConfig::default(), 550.0, seed);
        assert_eq!(verdict, Verdict::Running, "seed {seed}: {reason}");
        assert_eq!(restarts, 0, "seed {seed}");
    }
}

#[test]
fn without_the_descent_a_start_straight_to_550_rpm_is_lost() {
    let mut c = DriveConfig::default();
    c.control.start_descent_rpm_s = 0.0;
    let (verdict, reason, _) = started(c, 550.0, 1);
    assert_ne!(verdict, Verdict::Running, "{reason}");
}
