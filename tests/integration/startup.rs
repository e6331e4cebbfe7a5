//! Start-up from standstill: the failures reported against the chip's start-up, and a
//! small seeded Monte-Carlo over ±10 % motor, supply and comparator tolerances.

use bldc_drive::DriveConfig;
use bldc_drive::bench::range::Meter;
use bldc_drive::bench::startup::{
    RUN_S, STEADY_S, SplitMix64, Spread, monte_carlo, sample, start_once,
};
use bldc_drive::strategies::StrategyName;

/// The first hand-over: 31-clock debounce → first 327.68 µs align edge, then
/// round(0.7 s) + round(38 ms) + round(15 ms) = 2136 + 116 + 46 align periods.
const HANDOVER_S: f64 = 327.68e-6 * (1.0 + 2136.0 + 116.0 + 46.0);

fn started(cfg: &DriveConfig) -> bool {
    let mut rng = SplitMix64::new(0);
    let (_, sampled) = sample(cfg, Spread::default(), &mut rng);
    let run = start_once(cfg, sampled).expect("runs");
    run.started
}

fn with(name: StrategyName, angle: Option<f64>, r_ohm: f64) -> DriveConfig {
    let mut c = DriveConfig::default();
    c.strategy.name = name;
    c.strategy.conduction_angle_deg = angle;
    c.motor.resistance_ohm = r_ohm;
    c
}

/// R 23–27 % above nominal (twelve-step-df) and 9 % (six-step-120) used to lock on
/// PWM-edge glitches after the hand-over with the rotor standing.
#[test]
fn raised_resistance_starts() {
    for (name, r) in [
        (StrategyName::TwelveStepDf, 2.7),
        (StrategyName::TwelveStepDf, 2.8),
        (StrategyName::SixStep120, 2.4),
    ] {
        assert!(started(&with(name, None, r)), "{name} at R = {r} Ω");
    }
}

/// 165° (short floating window) and 135° start from standstill, as does the linear-
/// modulation guard on its first hand-over.
#[test]
fn wide_and_narrow_angles_and_lm_start_on_the_first_hand_over() {
    assert!(
        started(&with(StrategyName::TwelveStepDf, Some(165.0), 2.2)),
        "df@165"
    );
    assert!(
        started(&with(StrategyName::TwelveStepDf, Some(135.0), 2.2)),
        "df@135"
    );
    assert!(started(&with(StrategyName::TwelveStepLm, None, 2.2)), "lm");
}

/// Eight seeded samples of the default strategy all start (the target is ≥ 99 %, so
/// one failure in eight would already be far outside it), each handed over at the end of
/// the alignment and within 5 % of the command before the measuring window.
#[test]
fn a_seeded_monte_carlo_of_eight_starts_all_succeed() {
    let base = DriveConfig::default();
    let s = monte_carlo(&base, &base.strategy, 8, 2024, Spread::default(), 2).expect("runs");
    assert_eq!(s.runs, 8);
    assert_eq!(s.successes, 8, "failures: {:#?}", s.failures);
    assert_eq!(s.handover_s.len(), 8);
    for &t in &s.handover_s {
        assert!(
            (t - HANDOVER_S).abs() < 1e-6,
            "hand-over at {t} s, want {HANDOVER_S}"
        );
    }
    for &t in &s.within_s {
        assert!(
            t > HANDOVER_S && t < RUN_S - STEADY_S,
            "within 5 % from {t} s"
        );
    }
}

/// The sampler keeps every factor within ±10 %, offsets within ±5 mV, and L_self > M.
#[test]
fn samples_stay_within_the_spread() {
    let base = DriveConfig::default();
    let mut rng = SplitMix64::new(99);
    for _ in 0..200 {
        let (c, p) = sample(&base, Spread::default(), &mut rng);
        let ratio = |x: f64, x0: f64| (x / x0 - 1.0).abs();
        assert!(ratio(p.resistance_ohm, 2.2) <= 0.1);
        assert!(ratio(p.flux_linkage_wb, 7.62e-4) <= 0.1);
        assert!(ratio(p.inertia_kgm2, 17e-7) <= 0.1);
        assert!(ratio(p.supply_v, 12.0) <= 0.1);
        assert!(p.offset_v.iter().all(|o| o.abs() <= 5e-3));
        assert!(c.motor.self_inductance_h > c.motor.mutual_inductance_h);
        c.validate().expect("valid sample");
    }
}

/// Longest linear region (full voltage) of twelve-step-lm between 2.0 and 2.5 s of a
/// 3000 rpm run of the built-in motor \[s\].
fn longest_lm_region(capped: bool) -> f64 {
    use bldc_drive::drive::{build, run_to};
    use bldc_drive::drive_core::Plant;
    let mut c = with(StrategyName::TwelveStepLm, None, 2.2);
    c.strategy.lm_window_capped = capped;
    let mut eng = build(&c).expect("builds");
    let (mut since, mut longest) = (None::<f64>, 0.0f64);
    run_to(&mut eng, 2.5, |e, _| {
        let t = e.plant.time_s();
        if t < 2.0 {
            return;
        }
        match (e.controller.status().linear, since) {
            (true, None) => since = Some(t),
            (false, Some(t0)) => {
                longest = longest.max(t - t0);
                since = None;
            }
            _ => {}
        }
    })
    .expect("runs");
    longest
}

/// LM's window from 3000 rpm − 10 % to + 9 % is θZC = 1 + 14·(ω − 551)/(13430 − 551) < 4°,
/// so ≤ 3° in whole degrees, and a 60° interval at 2700 rpm with 6 pole pairs lasts
/// 60/(36·2700) s = 617 µs, so a capped region lasts at most 3/60·617 µs = 31 µs (+ one 0.64 µs clock).
/// Held to the detected crossing (the published chip), a region opened early after a
/// crossing taken early under PWM lasts several times that.
#[test]
fn the_lm_linear_region_lasts_no_longer_than_its_window_when_capped() {
    let bound = 3.0 / 60.0 * 60.0 / (36.0 * 2700.0) + 0.64e-6;
    let capped = longest_lm_region(true);
    assert!(
        capped > 0.0 && capped <= bound,
        "capped: {capped} s > {bound} s"
    );
    let published = longest_lm_region(false);
    assert!(published > 2.0 * bound, "uncapped: {published} s");
}

/// Ten seeded starts of twelve-step-lm as the bench runs them (24-bit meter, 3000 rpm):
/// all succeed, with no restart, handed over at the end of the alignment.
#[test]
fn a_seeded_monte_carlo_of_lm_starts_all_succeed() {
    let base = Meter::WIDE.apply(&with(StrategyName::TwelveStepLm, None, 2.2));
    let s = monte_carlo(&base, &base.strategy, 10, 1, Spread::default(), 2).expect("runs");
    assert_eq!(s.successes, 10, "failures: {:#?}", s.failures);
    for &t in &s.handover_s {
        assert!((t - HANDOVER_S).abs() < 1e-6, "hand-over at {t} s");
    }
}
