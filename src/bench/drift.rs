//! What sets the floors: each strategy ramped down through its floor, its commutation
//! error against the true rotor and the chip's speed estimate against the true speed,
//! binned by the true speed.
//!
//! The commutation error of a commutation into state s is θe − θ_s, wrapped to ±180°,
//! with θe the true electrical angle at the commutation (the midpoint of the two trace
//! samples around it: ±½ sample, 1.1° at 3000 rpm) and θ_s the table boundary of s
//! (`Table::state_start_deg`, the verdict's reference); negative is early.

use super::Comparison;
use super::range::{RAMP_RPM_PER_S, TURN_DOWN_S};
use super::svg::{Panel, Series, chart as chart_of};
use crate::config::DriveConfig;
use crate::metrics::wrap_deg;
use crate::profile::Profile;
use crate::scenario::{RunError, Scenario, TraceSpec, run};
use serde::Serialize;
use std::fmt::Write as _;
use strategies::Table;

/// Where the ramp starts and ends \[rpm\].
pub const FROM_RPM: f64 = 3000.0;
/// Where the ramp ends \[rpm\]: above 0, so the chip is never told to stop.
pub const TO_RPM: f64 = 100.0;
/// Trace period \[s\].
pub const TRACE_EVERY_S: f64 = 20e-6;
/// Width of the true-speed bins \[rpm\].
pub const BIN_RPM: f64 = 100.0;
/// Fewest commutations a bin needs to be shown.
const MIN_IN_BIN: usize = 3;

/// One bin of true speed.
#[derive(Clone, Debug, Serialize)]
pub struct DriftPoint {
    /// Bin centre, true speed \[rpm\].
    pub rpm: f64,
    /// Mean commutation error \[° electrical\] (negative: early).
    pub error_deg: f64,
    /// Mean of the chip's estimate minus the true speed over the bin's commutations \[rpm\].
    pub estimate_error_rpm: f64,
    /// Commutations in the bin.
    pub n: usize,
}

/// One strategy ramped down.
#[derive(Clone, Debug, Serialize)]
pub struct DriftRun {
    /// Variant label.
    pub variant: String,
    /// What differs from the comparison's config ("" for none).
    pub change: String,
    /// Bins from the ramp's start down to the first commutation out of synchronism,
    /// highest speed first.
    pub points: Vec<DriftPoint>,
    /// First commutation out of synchronism: (t \[s\], true speed \[rpm\]).
    pub sync_lost_at: Option<(f64, f64)>,
}

/// The ramp of [`FROM_RPM`] → [`TO_RPM`] at the range's rate from [`TURN_DOWN_S`].
pub fn scenario(config: &DriveConfig) -> Scenario {
    let end = TURN_DOWN_S + (FROM_RPM - TO_RPM) / RAMP_RPM_PER_S;
    let duration = end + 0.5;
    let mut sc = Scenario::hold(config.clone(), FROM_RPM, duration);
    sc.speed_rpm = Profile::constant(FROM_RPM).ramp_to(TURN_DOWN_S, end, TO_RPM);
    sc.profile_update_s = 0.01;
    sc.steady_from_s = end;
    sc.trace = Some(TraceSpec {
        every_s: TRACE_EVERY_S,
        from_s: TURN_DOWN_S,
        to_s: duration,
    });
    sc
}

/// Runs `config` (labelled `variant`, `change` saying how it differs) down the ramp, its
/// commutations judged against `table`.
pub fn run_drift(
    config: &DriveConfig,
    table: Table,
    variant: &str,
    change: &str,
) -> Result<DriftRun, RunError> {
    let sc = scenario(config);
    // (t, true rpm, error °, estimate − true rpm) per commutation, up to the first restart.
    let mut commutations: Vec<(f64, f64, f64, f64)> = Vec::new();
    let mut prev: Option<(u8, f64, u32)> = None;
    let out = run(&sc, |r| {
        if let Some((state, theta, restarts)) = prev
            && r.restarts == restarts
            && r.state != state
            && r.state != 0
            && state != 0
        {
            let mid = theta + 0.5 * wrap_deg(r.theta_e_deg - theta);
            let err = wrap_deg(mid - table.state_start_deg(r.state));
            commutations.push((r.t_s, r.speed_rpm, err, r.speed_est_rpm - r.speed_rpm));
        }
        if prev.is_none_or(|p| p.2 == r.restarts) {
            prev = Some((r.state, r.theta_e_deg, r.restarts));
        }
    })?;
    // What a drive does after it lost the rotor (false crossings, estimates of a rotor
    // at rest) is not the drift: the bins end at the first commutation out of synchronism.
    let lost = out.summary.sync_lost_at;
    let before: Vec<(f64, f64, f64)> = commutations
        .iter()
        .filter(|c| lost.is_none_or(|l| c.0 < l.0))
        .map(|c| (c.1, c.2, c.3))
        .collect();
    Ok(DriftRun {
        variant: variant.to_string(),
        change: change.to_string(),
        points: bin(&before),
        sync_lost_at: lost,
    })
}

/// Means per [`BIN_RPM`] of true speed, highest first.
fn bin(commutations: &[(f64, f64, f64)]) -> Vec<DriftPoint> {
    let mut bins: std::collections::BTreeMap<i64, (f64, f64, usize)> = Default::default();
    for &(rpm, err, est) in commutations {
        let b = bins.entry((rpm / BIN_RPM).floor() as i64).or_default();
        b.0 += err;
        b.1 += est;
        b.2 += 1;
    }
    bins.into_iter()
        .rev()
        .filter(|(_, b)| b.2 >= MIN_IN_BIN)
        .map(|(k, (err, est, n))| DriftPoint {
            rpm: (k as f64 + 0.5) * BIN_RPM,
            error_deg: err / n as f64,
            estimate_error_rpm: est / n as f64,
            n,
        })
        .collect()
}

/// The mean error of the bin holding `rpm`, if shown.
pub fn error_at(run: &DriftRun, rpm: f64) -> Option<f64> {
    run.points
        .iter()
        .find(|p| (p.rpm - rpm).abs() <= 0.5 * BIN_RPM)
        .map(|p| p.error_deg)
}

/// The figure's file.
pub const CHART: &str = "floor_drift.svg";

/// Commutation error and the chip's speed error against the true speed, per strategy.
pub fn chart(c: &Comparison) -> String {
    let series = |f: fn(&DriftPoint) -> f64| -> Vec<Series> {
        c.drifts
            .iter()
            .map(|d| Series {
                name: if d.change.is_empty() {
                    d.variant.clone()
                } else {
                    format!("{}, filters matched", d.variant)
                },
                points: d.points.iter().map(|p| (p.rpm, f(p))).collect(),
                color: c.color_of(&d.variant),
                dash: (!d.change.is_empty()).then_some("6 3"),
                ..Series::default()
            })
            .collect()
    };
    chart_of(
        &format!(
            "Ramped down {FROM_RPM:.0} → {TO_RPM:.0} rpm at {RAMP_RPM_PER_S:.0} rpm/s: mean per {BIN_RPM:.0} rpm of true speed"
        ),
        "true speed [rpm]",
        &[
            Panel {
                y_label: "commutation error [° electrical] (negative: early)".into(),
                series: series(|p| p.error_deg),
            },
            Panel {
                y_label: "chip's estimate − true speed [rpm]".into(),
                series: series(|p| p.estimate_error_rpm),
            },
        ],
    )
}

fn cell(x: Option<f64>) -> String {
    x.map_or("–".into(), |x| format!("{x:+.1}"))
}

/// The section, in Markdown.
pub fn section(c: &Comparison, config: &DriveConfig) -> String {
    if c.drifts.is_empty() {
        return String::new();
    }
    let mut s = format!(
        "\n## What sets the floors: the commutation drifts early as the speed falls\n\nEach strategy (24-bit meter) ramped from {FROM_RPM:.0} to {TO_RPM:.0} rpm at {RAMP_RPM_PER_S:.0} rpm/s from {TURN_DOWN_S} s, traced every {:.0} µs; each commutation's error is the true θe at it (midpoint of the two samples around it, ±{:.1}° at 3000 rpm) against the table boundary of the state it enters, averaged per {BIN_RPM:.0} rpm of true speed up to the first restart. Beside it, the chip's speed estimate against the true speed.\n\n![{CHART}]({CHART})\n\n| strategy | changed | error at 2000 rpm ° | at 1000 rpm ° | at 500 rpm ° | first out of synchronism, true rpm | floor rpm (24-bit meter) | error at the floor ° |\n|---|---|---:|---:|---:|---:|---:|---:|\n",
        TRACE_EVERY_S * 1e6,
        0.5 * 360.0 * 3000.0 / 60.0 * f64::from(config.motor.poles / 2) * TRACE_EVERY_S
    );
    for d in &c.drifts {
        let floor = c
            .ranges
            .iter()
            .find(|r| r.strategy == d.variant && r.meter == super::range::Meter::WIDE.label)
            .and_then(|r| r.min_rpm);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            d.variant,
            if d.change.is_empty() {
                "–"
            } else {
                &d.change
            },
            cell(error_at(d, 2000.0)),
            cell(error_at(d, 1000.0)),
            cell(error_at(d, 500.0)),
            d.sync_lost_at.map_or("–".into(), |x| format!("{:.0}", x.1)),
            if d.change.is_empty() {
                floor.map_or("–".into(), |x| format!("{x:.0}"))
            } else {
                "–".into()
            },
            if d.change.is_empty() {
                cell(floor.and_then(|f| error_at(d, f)))
            } else {
                "–".into()
            },
        );
    }
    let cmp = &config.sensing.comparator;
    let step_v = 0.5 * config.power_stage.supply_v;
    let mismatch = (cmp.neutral_filter_tau_s - cmp.phase_filter_tau_s) / cmp.phase_filter_tau_s;
    let _ = writeln!(
        s,
        "\nThe mechanism (docs/chip.md, \"Why the commutation drifts early at low speed\"): the comparator compares the floating terminal with the motor's neutral, each through its own RC filter ({:.2} µs and {:.2} µs, a {:.0} % mismatch). Every PWM edge moves both together by about half the supply ({step_v:.1} V); the mismatch turns that into a differential spike of about {step_v:.1} V × {:.2} / e ≈ {:.0} mV lasting a few µs, which looks like a rising crossing at the on-edge and a falling one at the off-edge. Whenever the floating phase's back-EMF is within a fixed threshold of its crossing (≈ 0.09 V for the digital filter's three samples, ≈ 0.10–0.11 V for a single sample: raw, and LM's 1° window at low speed), a spike long enough for the guard is taken as the crossing. The crossing is then found at a fixed back-EMF, not at a fixed angle: the lead grows as asin(E_th / E_peak) with E_peak ∝ speed, the torque per ampere falls with it, the speed loop asks for more current, and near E_peak ≈ E_th the rotor is lost. The row with the filters matched is the experiment that shows it. Not the published chip's, but a designer's remedies: matched filters (1 %: ≈ 0.02 V), or blanking the comparator for a few µs after each carrier edge.",
        cmp.phase_filter_tau_s * 1e6,
        cmp.neutral_filter_tau_s * 1e6,
        100.0 * mismatch.abs(),
        mismatch.abs(),
        1e3 * step_v * mismatch.abs() / std::f64::consts::E
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commutations_are_binned_by_true_speed_highest_first() {
        let c = [
            (2950.0, -1.0, 10.0),
            (2990.0, -3.0, 20.0),
            (2910.0, -2.0, 30.0),
            (510.0, -20.0, 5.0),
            (520.0, -22.0, 5.0),
            (530.0, -24.0, 5.0),
            (150.0, -80.0, 0.0), // alone in its bin: not shown
        ];
        let b = bin(&c);
        assert_eq!(b.len(), 2);
        assert_eq!((b[0].rpm, b[0].n), (2950.0, 3));
        assert!(
            (b[0].error_deg + 2.0).abs() < 1e-12 && (b[0].estimate_error_rpm - 20.0).abs() < 1e-12
        );
        assert_eq!(b[1].rpm, 550.0);
        assert!((b[1].error_deg + 22.0).abs() < 1e-12);
        let run = DriftRun {
            variant: "v".into(),
            change: String::new(),
            points: b,
            sync_lost_at: None,
        };
        assert_eq!(error_at(&run, 540.0), Some(-22.0));
        assert_eq!(error_at(&run, 1000.0), None);
    }

    /// The ramp passes the range's rate and ends above 0 (the chip is never told to stop).
    #[test]
    fn the_ramp_runs_at_the_ranges_rate_to_above_zero() {
        let sc = scenario(&DriveConfig::default());
        let at = |t: f64| sc.speed_rpm.value_at(t);
        assert_eq!(at(TURN_DOWN_S), FROM_RPM);
        let mid = TURN_DOWN_S + 1.0;
        assert!((at(mid) - (FROM_RPM - RAMP_RPM_PER_S)).abs() <= RAMP_RPM_PER_S * 0.01 + 1e-9);
        assert_eq!(at(sc.duration_s), TO_RPM);
    }
}
