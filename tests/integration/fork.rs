//! A run forked from another's state at an instant of both schedules (`Run::fork`) has
//! the summary of the same scenario run from standstill, bit for bit: every field (wall
//! time aside), the verdict's tracking included, for runs that hold and runs that lose the
//! rotor. Scenarios that differ before the fork instant are refused with an error.

use bldc_drive::DriveConfig;
use bldc_drive::bench::range::{self, Meter, TURN_DOWN_S, held_after_turn_down};
use bldc_drive::bench::seeded::Seeded;
use bldc_drive::profile::Profile;
use bldc_drive::scenario::{ForkError, Run, RunError, Scenario, Summary, run};
use bldc_drive::strategies::StrategyName;
use bldc_drive::verdict::Verdict;

/// Every field of `s` but the wall time, floats as their bits. Destructured in full, so a
/// field added to `Summary` fails to compile here until it is compared.
fn fields(s: &Summary) -> Vec<(&'static str, String)> {
    let Summary {
        strategy,
        speed_ref_rpm,
        speed_mean_rpm,
        speed_ripple_rpm,
        torque_mean_nm,
        torque_ripple_nm,
        torque_ripple_lf_nm,
        torque_lowpass_hz,
        current_rms_a,
        current_peak_a,
        commutation_peak_a,
        verdict,
        verdict_reason,
        judge_after_s,
        handover_s,
        started_at_s,
        sync_lost_at,
        restarts,
        chip_running,
        chip_speed_rpm,
        commutations,
        commutation_error_deg_mean,
        commutation_error_deg_max,
        forced_crossings,
        steady_from_s,
        sim_s,
        wall_s: _,
        realtime_factor: _,
    } = s;
    let b = |x: &f64| format!("{:016x}", x.to_bits());
    let ob = |x: &Option<f64>| format!("{:?}", x.map(f64::to_bits));
    vec![
        ("strategy", strategy.clone()),
        ("speed_ref_rpm", b(speed_ref_rpm)),
        ("speed_mean_rpm", b(speed_mean_rpm)),
        ("speed_ripple_rpm", b(speed_ripple_rpm)),
        ("torque_mean_nm", b(torque_mean_nm)),
        ("torque_ripple_nm", b(torque_ripple_nm)),
        ("torque_ripple_lf_nm", b(torque_ripple_lf_nm)),
        ("torque_lowpass_hz", b(torque_lowpass_hz)),
        ("current_rms_a", b(current_rms_a)),
        ("current_peak_a", b(current_peak_a)),
        ("commutation_peak_a", b(commutation_peak_a)),
        ("verdict", format!("{verdict:?}")),
        ("verdict_reason", verdict_reason.clone()),
        ("judge_after_s", ob(judge_after_s)),
        ("handover_s", ob(handover_s)),
        ("started_at_s", ob(started_at_s)),
        (
            "sync_lost_at",
            format!(
                "{:?}",
                sync_lost_at.map(|(t, v)| (t.to_bits(), v.to_bits()))
            ),
        ),
        ("restarts", restarts.to_string()),
        ("chip_running", chip_running.to_string()),
        ("chip_speed_rpm", b(chip_speed_rpm)),
        ("commutations", commutations.to_string()),
        ("commutation_error_deg_mean", b(commutation_error_deg_mean)),
        ("commutation_error_deg_max", b(commutation_error_deg_max)),
        ("forced_crossings", forced_crossings.to_string()),
        ("steady_from_s", b(steady_from_s)),
        ("sim_s", b(sim_s)),
    ]
}

/// The fields in which `a` and `b` differ, with both values.
fn differences(a: &Summary, b: &Summary) -> Vec<String> {
    fields(a)
        .into_iter()
        .zip(fields(b))
        .filter(|(x, y)| x.1 != y.1)
        .map(|(x, y)| format!("{}: {} vs {}", x.0, x.1, y.1))
        .collect()
}

fn config(name: StrategyName) -> DriveConfig {
    let mut c = Meter::WIDE.apply(&DriveConfig::default());
    c.strategy.name = name;
    c
}

#[test]
fn runs_forked_at_the_turn_have_the_summaries_of_runs_from_standstill() {
    let c = config(StrategyName::TwelveStepDf);
    let turned = |rpm| range::turned(&c, 3000.0, rpm, TURN_DOWN_S);
    let mut at_turn = Run::start(&turned(1500.0)).expect("starts");
    at_turn
        .advance_to(TURN_DOWN_S, |_| {}, |_| {})
        .expect("the turn is an instant of the schedule");
    let mut summaries = Vec::new();
    // Held at 1500; below the floor (≈ 516 rpm) at 504, where the rotor is lost; up to 6000.
    for rpm in [1500.0, 504.0, 6000.0] {
        let sc = turned(rpm);
        let forked = at_turn
            .fork(&sc)
            .expect("the same up to the turn")
            .finish(|_| {}, |_| {})
            .expect("runs")
            .summary;
        let plain = run(&sc, |_| {}).expect("runs").summary;
        let d = differences(&forked, &plain);
        assert!(d.is_empty(), "at {rpm} rpm the fork differs: {d:#?}");
        summaries.push(plain);
    }
    assert!(summaries[0].verdict.is_running() && summaries[2].verdict.is_running());
    let lost = &summaries[1];
    assert!(
        matches!(lost.verdict, Verdict::Stalled | Verdict::LostSync) && lost.sync_lost_at.is_some(),
        "{lost:?}"
    );
    // The comparison can fail: two different points differ in it.
    assert!(!differences(&summaries[0], &summaries[2]).is_empty());
}

#[test]
fn a_seeded_bisection_point_is_the_point_run_from_standstill() {
    // six-step-120 loses synchronism just below its floor (≈ 504 rpm).
    let c = config(StrategyName::SixStep120);
    let mut seeded = Seeded::new(&c, None, 3000.0);
    for rpm in [492.0, 1200.0] {
        let (ok, forked) = seeded.held(rpm).expect("runs");
        let (plain_ok, plain) = held_after_turn_down(&c, None, 3000.0, rpm).expect("runs");
        let d = differences(&forked, &plain);
        assert!(d.is_empty(), "at {rpm} rpm the fork differs: {d:#?}");
        assert_eq!(ok, plain_ok);
    }
    let (ok, low) = seeded.held(492.0).expect("runs");
    assert!(!ok && low.verdict == Verdict::LostSync, "{low:?}");
}

/// A 0.2 s run stepped to `to_rpm` at `at_s`, its window from 0.15 s.
fn stepped(to_rpm: f64, at_s: f64) -> Scenario {
    let mut sc = Scenario::hold(DriveConfig::default(), 3000.0, 0.2);
    sc.speed_rpm = Profile::constant(3000.0).step_to(at_s, to_rpm);
    sc.steady_from_s = 0.15;
    sc
}

fn refusal(r: Result<Run, RunError>) -> String {
    match r {
        Ok(_) => panic!("forked"),
        Err(e @ RunError::Fork(ForkError::Differs { .. })) => e.to_string(),
        Err(e) => panic!("another error: {e}"),
    }
}

#[test]
fn a_fork_is_refused_when_the_scenarios_differ_before_its_instant() {
    let mut r = Run::start(&stepped(2000.0, 0.1)).expect("starts");
    r.advance_to(0.1, |_| {}, |_| {}).expect("advances");
    // Different after the instant (the step's value, the window's start): forked, and
    // exact.
    let mut other = stepped(2500.0, 0.1);
    other.steady_from_s = 0.12;
    let forked = r.fork(&other).expect("forks").finish(|_| {}, |_| {});
    let plain = run(&other, |_| {}).expect("runs").summary;
    let d = differences(&forked.expect("runs").summary, &plain);
    assert!(d.is_empty(), "{d:#?}");

    let e = refusal(r.fork(&stepped(2000.0, 0.05)));
    assert!(e.contains("at 0.1 s") && e.contains("schedule"), "{e}");
    let e = refusal(r.fork(&stepped(2000.0, 0.15)));
    assert!(e.contains("no setting at that instant"), "{e}");
    let mut sc = stepped(2000.0, 0.1);
    sc.config.control.speed_kp *= 2.0;
    assert!(refusal(r.fork(&sc)).contains("config"));
    // A window from before the instant is a setting before it; from the instant itself,
    // the stop there was judged outside it.
    sc = stepped(2000.0, 0.1);
    sc.steady_from_s = 0.05;
    assert!(refusal(r.fork(&sc)).contains("schedule"));
    sc.steady_from_s = 0.1;
    assert!(refusal(r.fork(&sc)).contains("steady_from_s"));
    sc = stepped(2000.0, 0.1);
    sc.speed_rpm = Profile::constant(2900.0).step_to(0.1, 2000.0);
    assert!(refusal(r.fork(&sc)).contains("speed_rpm"));
    sc.load = bldc_drive::profile::LoadProfile::coulomb(1e-4);
    sc.speed_rpm = stepped(2000.0, 0.1).speed_rpm;
    assert!(refusal(r.fork(&sc)).contains("load"));
    // A bad scenario is named as such, not forked.
    sc = stepped(2000.0, 0.1);
    sc.duration_s = -1.0;
    assert!(matches!(r.fork(&sc), Err(RunError::Param(_))));
}

#[test]
fn a_run_advances_only_to_instants_of_its_schedule_and_not_back() {
    let mut r = Run::start(&stepped(2000.0, 0.1)).expect("starts");
    for t in [0.07, f64::NAN, -1.0, 0.3] {
        let e = r.advance_to(t, |_| {}, |_| {}).expect_err("refused");
        assert!(
            e.to_string().contains("instant of the run's schedule"),
            "{e}"
        );
    }
    r.advance_to(0.1, |_| {}, |_| {}).expect("the step");
    assert_eq!(r.time_s(), 0.1);
    // The window's start; then back to the step: refused.
    r.advance_to(0.15, |_| {}, |_| {})
        .expect("the window's start");
    assert!(r.advance_to(0.1, |_| {}, |_| {}).is_err());
    let done = r.finish(|_| {}, |_| {}).expect("finishes").summary;
    let plain = run(&stepped(2000.0, 0.1), |_| {}).expect("runs").summary;
    assert!(differences(&done, &plain).is_empty());
}
