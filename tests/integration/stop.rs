//! Stop means stop (docs/chip.md, "Stop"): a drive ramped to a command of 0 ends with its
//! rotor at rest, verdict `stopped` (exit 0), and the chip starts nothing after the
//! command reached 0; the published chip (`stop_at_zero` off) does not stay stopped.

use crate::common::traced;
use bldc_drive::DriveConfig;
use bldc_drive::profile::Profile;
use bldc_drive::scenario::Scenario;
use bldc_drive::verdict::Verdict;

/// twelve-step-df from standstill to 3000 rpm, ramped from 2 s to 0 at 4 s, judged over
/// 4.5..6 s; the restarts counted after the command reached 0, and the largest |speed|
/// then and in the window.
fn ramp_to_zero(config: DriveConfig) -> (Verdict, String, u32, f64) {
    let mut sc = Scenario::hold(config, 3000.0, 6.0);
    sc.config.strategy.name = "twelve-step-df".parse().unwrap();
    sc.speed_rpm = Profile::constant(3000.0).ramp_to(2.0, 4.0, 0.0);
    sc.steady_from_s = 4.5;
    let (s, restarts, speeds) = traced(sc, 4.0, 6.0);
    let window_peak = speeds
        .iter()
        .filter(|&&(t, _)| t >= 4.5)
        .map(|&(_, v)| v.abs())
        .fold(0.0, f64::max);
    (s.verdict, s.verdict_reason, restarts, window_peak)
}

#[test]
fn a_drive_ramped_to_zero_stops_and_stays_stopped() {
    let (verdict, reason, restarts_after, peak) = ramp_to_zero(DriveConfig::default());
    assert_eq!(verdict, Verdict::Stopped, "{reason}");
    assert_eq!(verdict.exit_code(), 0);
    assert_eq!(restarts_after, 0, "restarts after the command reached 0");
    assert!(
        peak < 5.0,
        "the rotor still turns at {peak} rpm in the window"
    );
}

#[test]
fn the_published_chip_restarts_a_rotor_told_to_stop() {
    let mut c = DriveConfig::default();
    c.control.stop_at_zero = false;
    let (verdict, reason, _, _) = ramp_to_zero(c);
    assert_ne!(verdict, Verdict::Stopped, "{reason}");
}
