//! Start-up across the winding resistance (issue #36): with only `motor.resistance_ohm`
//! changed, twelve-step-df must start and run at 3000 rpm from 0.4 to 3 Ω.
//!
//! The published start-up aligns at a fixed duty, so its current, ≈ (d·V_DD − V_diode)/(2R),
//! grows as 1/R; the rotor's swing between the timed steps v→w (38 ms) and v→u (15 ms)
//! then ends anywhere, and a fixed shunt-current start command gives a phase current
//! ≈ √(i_s·V_DD/(2R)) that outruns the hand-over's assumed t_60. The shipped defaults
//! align by current (`control.align_current_a`) and start by phase current
//! (`control.start_phase_current_a`); `examples/configs/published-chip.toml` keeps the
//! published start-up (docs/chip.md, "Start-up").

use bldc_drive::DriveConfig;
use bldc_drive::scenario::{Scenario, Summary, run};
use bldc_drive::verdict::Verdict;

const RESISTANCES: [f64; 7] = [0.4, 0.5, 0.6, 0.7, 0.8, 1.5, 3.0];

fn summary(cfg: DriveConfig) -> Summary {
    run(&Scenario::hold(cfg, 3000.0, 4.0), |_| {})
        .expect("runs")
        .summary
}

/// Runs `cfg` with each resistance on its own thread: (R, verdict, restarts, reason).
fn across(cfg: &DriveConfig, rs: &[f64]) -> Vec<(f64, Verdict, u32, String)> {
    std::thread::scope(|s| {
        let runs: Vec<_> = rs
            .iter()
            .map(|&r| {
                let mut c = cfg.clone();
                c.motor.resistance_ohm = r;
                s.spawn(move || {
                    let sm = summary(c);
                    (r, sm.verdict, sm.restarts, sm.verdict_reason)
                })
            })
            .collect();
        runs.into_iter().map(|h| h.join().expect("run")).collect()
    })
}

#[test]
fn the_shipped_start_up_runs_at_every_resistance_from_0_4_to_3_ohm() {
    let results = across(&DriveConfig::default(), &RESISTANCES);
    let failed: Vec<_> = results
        .iter()
        .filter(|(_, v, _, _)| *v != Verdict::Running)
        .collect();
    assert!(failed.is_empty(), "not running: {failed:#?}");
}

/// The published start-up (fixed duty, shunt-current start command) keeps the band the
/// issue reported: 0.6 Ω does not start, 2.2 Ω (the built-in motor) does.
#[test]
fn the_published_start_up_fails_inside_the_band() {
    let published = include_str!("../../examples/configs/published-chip.toml");
    let cfg = DriveConfig::from_toml(published).expect("published preset");
    assert_eq!(cfg.control.align_current_a, 0.0);
    assert_eq!(cfg.control.start_phase_current_a, 0.0);
    let results = across(&cfg, &[0.6, 2.2]);
    assert_eq!(results[0].1, Verdict::NotStarted, "{:?}", results[0]);
    assert_eq!(results[1].1, Verdict::Running, "{:?}", results[1]);
}
