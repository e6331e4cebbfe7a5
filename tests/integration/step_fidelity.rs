//! Integrating ahead: the comparators see terminal and neutral voltages interpolated over
//! each plant step (up to `solver.max_step_s`, 80 µs by default): along their chords, and on
//! steps longer than `CHORD_S` (40 µs) with a floating terminal's back-EMF as its cubic
//! Hermite interpolant. Near a back-EMF crossing under PWM, what they report must agree
//! with a run whose steps are 100× shorter, within the interpolation error.
//!
//! The bounds, over a step of h, for a back-EMF E·sin θ: its chord is off by at most
//! h²/8·E·ωe²·|sin θ|, and within a step of the crossing |sin θ| ≤ ωe·h, so by E·ωe³·h³/8;
//! its Hermite cubic by at most h⁴/384·E·ωe⁴. On chords, the floating terminal carries e_w
//! and the neutral e_w/2, so the filtered difference is off by at most twice the first; with
//! the cubic, the neutral's chord (on both paths) cancels but for the filters' 5 % mismatch,
//! and twice the second is a margin for that. The crossing (slope E·ωe) moves by ωe²·h³/4,
//! or ωe³·h⁴/192 (1.4 ticks at 8000 rpm and 80 µs, where a chord moved it by 9); a tick is
//! added for the grid. Noise held over 0.5 µs segments can turn a smaller move into a jump
//! to the next segment of up to 2·noise/(E·ωe).

use crate::common;

use bldc_drive::drive_core::{Abc, Hold, Phase, Plant, StopReason, TICK_S, Ticks};
use bldc_drive::plants::bldc::CHORD_S;
use bldc_drive::plants::{PlantParams, SolverParams};
use common::*;

/// The default longest step.
fn coarse_s() -> f64 {
    SolverParams::default().max_step_s
}
const FINE_S: f64 = 0.8e-6;

/// w floats (u→v driven, PWM at `duty`) while the rotor turns at `rpm` through e_w's
/// falling crossing at θe = 60°; returns the ticks at which w_d's visible level changes.
fn edges(params: &PlantParams, rpm: f64, max_step_s: f64, duty: u32) -> Vec<(u64, bool)> {
    let mut params = params.clone();
    params.solver.max_step_s = max_step_s;
    let watch = Abc {
        u: false,
        v: false,
        w: true,
    };
    let mut eng = engine(params, Hold(hold("VGF", duty, watch)));
    eng.plant.set_rotor(30f64.to_radians(), rpm, true);
    let we = rpm_to_rad_s(rpm) * 6.0;
    let end = Ticks::from_seconds(60f64.to_radians() / we).unwrap();
    let mut out = Vec::new();
    let mut level = None;
    eng.run_until(end, |e, r| {
        if r == StopReason::End {
            return;
        }
        let tick = Ticks::at_or_after(e.plant.time_s()).0;
        let w = e.plant.sensed(tick).zc(Phase::W);
        if level.is_some_and(|l| l != w) {
            out.push((tick.0, w));
        }
        level = Some(w);
    })
    .unwrap();
    out
}

/// Coarse and fine runs: the same edges, each within `tol_ticks`; returns the largest gap.
fn compare(params: &PlantParams, rpm: f64, duty: u32, tol_ticks: f64) -> u64 {
    let coarse = edges(params, rpm, coarse_s(), duty);
    let fine = edges(params, rpm, FINE_S, duty);
    let case = format!("{rpm} rpm, duty {duty}");
    assert!(
        coarse.last().is_some_and(|e| !e.1),
        "{case}: the falling crossing expected, got {coarse:?}"
    );
    assert_eq!(coarse.len(), fine.len(), "{case}: {coarse:?} vs {fine:?}");
    let mut worst = 0;
    for (c, f) in coarse.iter().zip(&fine) {
        assert_eq!(c.1, f.1, "{case}: {coarse:?} vs {fine:?}");
        let gap = c.0.abs_diff(f.0);
        assert!(
            gap as f64 <= tol_ticks,
            "{case}: {gap} ticks apart (bound {tol_ticks:.1}): {coarse:?} vs {fine:?}"
        );
        worst = worst.max(gap);
    }
    worst
}

fn omega_e(rpm: f64) -> f64 {
    rpm_to_rad_s(rpm) * (PlantParams::default().motor.poles as f64 / 2.0)
}

/// The crossing's move on the default steps at `duty` (PWM intervals of duty and 1 − duty
/// of the 80 µs period, or the longest steps at 100 %) in ticks, plus one for the grid.
fn interpolation_ticks(rpm: f64, duty: u32) -> f64 {
    let we = omega_e(rpm);
    let on = coarse_s() * f64::from(duty) / 2000.0;
    let worst = [on, coarse_s() - on]
        .into_iter()
        .filter(|&h| h > 0.0)
        .map(|h| {
            if h <= CHORD_S {
                we.powi(2) * h.powi(3) / 4.0
            } else {
                we.powi(3) * h.powi(4) / 192.0
            }
        })
        .fold(0.0, f64::max);
    worst / TICK_S + 1.0
}

#[test]
fn without_noise_the_crossing_moves_less_than_the_interpolation_bound() {
    let mut params = PlantParams::default();
    params.sensing.comparator.noise_v = 0.0;
    // 20 % duty (PWM intervals of 16 µs, on chords, and 64 µs), 50 % (40 µs chords), and
    // 100 % (no PWM: 80 µs steps throughout). At 8000 rpm the bounds are 2.3, 21 and 2.4
    // ticks, the grid's included.
    for rpm in [2000.0, 8000.0] {
        for duty in [400, 1000, 2000] {
            compare(&params, rpm, duty, interpolation_ticks(rpm, duty));
        }
    }
}

#[test]
fn with_noise_glitches_and_crossing_agree_with_short_steps() {
    let rpm = 2000.0;
    let mut params = PlantParams::default();
    let m = &params.motor;
    let e_peak = m.flux_linkage_wb * (m.poles as f64 / 2.0) * rpm_to_rad_s(rpm);
    let jump = 2.0 * params.sensing.comparator.noise_v / (e_peak * omega_e(rpm)) / TICK_S;
    for seed in [1, 2, 3] {
        params.sensing.seed = seed;
        for duty in [400, 1000] {
            assert!(
                edges(&params, rpm, coarse_s(), duty).len() >= 5,
                "glitches expected"
            );
            compare(&params, rpm, duty, interpolation_ticks(rpm, duty) + jump);
        }
    }
}
