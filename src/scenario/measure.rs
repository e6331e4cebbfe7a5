//! What a run measures at the engine's stops, and the summary and verdict made of it at
//! the end: the metrics half of [`super::Run`], kept apart from its schedule.

use super::{Outcome, Scenario, Summary};
use crate::config::DriveConfig;
use crate::drive::DriveEngine;
use crate::metrics::{AngleErrors, SampleStats, TimeStats};
use crate::verdict::{Ending, Judgement, Witness};
use drive_core::{Plant, Ticks};
use plants::{BldcPlant, Observation};
use strategies::Mode;

/// The metrics of a run so far.
#[derive(Clone)]
pub(super) struct Metrics {
    /// The window's start \[s\] (a fork may move it while no stop has reached it).
    pub steady_from: f64,
    speed: TimeStats,
    /// The window's start: time, copper loss, ∫Te dt, ∫Te² dt. The torque and the current
    /// vary within a PWM period, so sampling them at the engine's stops would weigh the
    /// values at PWM edges and diode events by the time until the next stop: biased.
    window: Option<(f64, f64, f64, f64)>,
    angles: AngleErrors,
    witness: Witness,
    /// Torque blocks for the low-frequency ripple: 1/f_c on whole ticks.
    pub block: Ticks,
    /// The last block boundary and ∫Te dt there; a boundary is served once even when the
    /// engine calls back twice at its tick (an event on a sample instant).
    block_start: Option<(Ticks, f64)>,
    blocks: SampleStats,
    /// Peak |i| in the window, and of the state in force once a state has begun inside it.
    current_peak: f64,
    state_peak: Option<f64>,
    /// States whose peak is counted, and the sum of their peaks.
    state_peaks: (u64, f64),
    record: Vec<(f64, f64)>,
    duty: Vec<(f64, f64)>,
    current_ref: Vec<(f64, f64)>,
    record_every: f64,
    /// Full duty (the carrier's top).
    top: f64,
    next_record: f64,
    last_state: u8,
    handover: Option<f64>,
}

/// Time, copper loss, ∫Te dt and ∫Te² dt of the plant now.
fn integrals(p: &BldcPlant) -> (f64, f64, f64, f64) {
    let (ti, ti2) = p.torque_integrals();
    (p.time_s(), p.energy().copper, ti, ti2)
}

impl Metrics {
    /// Nothing measured yet, for `sc` on `eng`.
    pub fn new(sc: &Scenario, eng: &DriveEngine) -> Self {
        let table = eng.controller.table();
        let record = Vec::with_capacity(
            sc.speed_record_s
                .map_or(0, |p| (sc.duration_s / p) as usize + 2),
        );
        let duty = Vec::with_capacity(record.capacity());
        let current_ref = Vec::with_capacity(record.capacity());
        Metrics {
            steady_from: sc.steady_from_s,
            speed: TimeStats::default(),
            window: None,
            angles: AngleErrors::default(),
            witness: Witness::new(sc.verdict_rule, table.states_per_turn()),
            block: Ticks(((1.0 / sc.torque_lowpass_hz / Ticks(1).seconds()).round() as u64).max(1)),
            block_start: None,
            blocks: SampleStats::default(),
            current_peak: 0.0,
            state_peak: None,
            state_peaks: (0, 0.0),
            record,
            duty,
            current_ref,
            record_every: sc.speed_record_s.unwrap_or(f64::INFINITY),
            top: f64::from(eng.carrier().top),
            next_record: if sc.speed_record_s.is_some() {
                0.0
            } else {
                f64::INFINITY
            },
            last_state: 0,
            handover: None,
        }
    }

    /// Measures at a whole-tick stop of `e`; the plant, when observed, is left in `obs`.
    pub fn stop(&mut self, e: &DriveEngine, obs: &mut Option<Observation>) {
        let t = e.plant.time_s();
        let s = e.controller.status();
        if self.handover.is_none() && s.mode == Mode::Running {
            self.handover = Some(t);
        }
        let (recorded, steady) = (t >= self.next_record, t >= self.steady_from);
        let last_state = self.last_state;
        let commutated = s.state != last_state && s.state != 0 && last_state != 0;
        // Observing inside an integrated step costs a step of its own: only when needed.
        if recorded || steady || commutated {
            let o = *obs.insert(e.plant.observe());
            let finite = o.speed_rpm.is_finite()
                && o.i.u.is_finite()
                && o.i.v.is_finite()
                && o.i.w.is_finite();
            let witness = &mut self.witness;
            witness.instant(t, s.mode == Mode::Running, s.restarts, finite, steady);
            let command = e.controller.speed_ref_rpm();
            witness.speed(t, o.speed_rpm, command, steady);
            if commutated {
                // The table in force: the chip may start narrower than configured.
                let boundary = e.controller.table().state_start_deg(s.state);
                let theta = o.theta_e.to_degrees();
                witness.commutation(t, theta, boundary, o.speed_rpm, steady);
                if steady {
                    self.angles.push(theta, boundary);
                }
            }
            if recorded {
                self.record.push((t, o.speed_rpm));
                self.duty.push((t, f64::from(s.duty) / self.top));
                self.current_ref.push((t, s.current_ref_a));
                self.next_record = t + self.record_every;
            }
            if steady {
                self.steady(e, t, &o, commutated);
            }
        }
        self.last_state = s.state;
    }

    /// The window's part of [`Self::stop`]: speed, currents and torque blocks.
    fn steady(&mut self, e: &DriveEngine, t: f64, o: &Observation, commutated: bool) {
        self.speed.push(t, o.speed_rpm);
        self.window.get_or_insert_with(|| integrals(&e.plant));
        let i_max = o.i.u.abs().max(o.i.v.abs()).max(o.i.w.abs());
        self.current_peak = self.current_peak.max(i_max);
        if commutated {
            if let Some(p) = self.state_peak {
                self.state_peaks.0 += 1;
                self.state_peaks.1 += p;
            }
            self.state_peak = Some(i_max);
        }
        self.state_peak = self.state_peak.map(|p| p.max(i_max));
        let now = e.now();
        let block = self.block;
        if now.0 % block.0 == 0 && self.block_start.is_none_or(|b| now > b.0) {
            let ti = e.plant.torque_integrals().0;
            if let Some((_, t0)) = self.block_start {
                self.blocks.push((ti - t0) / block.seconds());
            }
            self.block_start = Some((now, ti));
        }
    }

    /// Mean torque, mean square torque and mean square phase current over the window,
    /// exact from the plant's integrals (zeros without a window).
    fn window_means(&self, eng: &DriveEngine, config: &DriveConfig) -> (f64, f64, f64) {
        match self.window {
            Some((t0, cu0, ti0, ti20)) => {
                let (t1, cu1, ti1, ti21) = integrals(&eng.plant);
                let dt = t1 - t0;
                if dt > 0.0 {
                    let r = config.motor.resistance_ohm;
                    (
                        (ti1 - ti0) / dt,
                        (ti21 - ti20) / dt,
                        (cu1 - cu0) / (3.0 * r * dt),
                    )
                } else {
                    (0.0, 0.0, 0.0)
                }
            }
            None => (0.0, 0.0, 0.0),
        }
    }

    /// The verdict on the run's end.
    fn judge(&self, sc: &Scenario, config: &DriveConfig, eng: &DriveEngine) -> Judgement {
        let s = eng.controller.status();
        let speed = &self.speed;
        self.witness.judge(&Ending {
            command_rpm: eng.controller.speed_ref_rpm(),
            speed_mean_rpm: speed.mean(),
            speed_rms_rpm: speed.mean().hypot(speed.std_dev()),
            window_s: speed.duration(),
            pole_pairs: config.motor.poles / 2,
            chip_speed_rpm: f64::from(s.speed_est_rpm),
            restarts: (s.restarts, sc.config.control.max_restarts),
            gave_up: s.mode == Mode::GaveUp,
        })
    }

    /// The run's outcome, at its end: `config` is the one `eng` was built from, `wall_s`
    /// the simulation's wall-clock time.
    pub fn outcome(
        self,
        sc: &Scenario,
        config: &DriveConfig,
        eng: &DriveEngine,
        wall_s: f64,
    ) -> Outcome {
        let (torque_mean, torque_ms, current_ms) = self.window_means(eng, config);
        let s = eng.controller.status();
        let sim_s = eng.now().seconds();
        let Judgement {
            verdict,
            reason,
            judge_after_s,
        } = self.judge(sc, config, eng);
        let speed = &self.speed;
        let state_peaks = self.state_peaks;
        Outcome {
            summary: Summary {
                strategy: eng.controller.name().to_string(),
                speed_ref_rpm: eng.controller.speed_ref_rpm(),
                speed_mean_rpm: speed.mean(),
                speed_ripple_rpm: speed.std_dev(),
                torque_mean_nm: torque_mean,
                // Rounding may leave the variance a hair below zero when the torque is steady.
                torque_ripple_nm: (torque_ms - torque_mean * torque_mean).max(0.0).sqrt(),
                current_rms_a: current_ms.max(0.0).sqrt(),
                torque_ripple_lf_nm: self.blocks.std_dev(),
                torque_lowpass_hz: sc.torque_lowpass_hz,
                current_peak_a: self.current_peak,
                commutation_peak_a: if state_peaks.0 > 0 {
                    state_peaks.1 / state_peaks.0 as f64
                } else {
                    0.0
                },
                verdict,
                verdict_reason: reason,
                judge_after_s,
                handover_s: self.handover,
                started_at_s: self.witness.started_at_s(),
                sync_lost_at: self.witness.sync_lost(),
                restarts: s.restarts,
                chip_running: s.mode == Mode::Running,
                chip_speed_rpm: f64::from(s.speed_est_rpm),
                commutations: self.angles.count,
                commutation_error_deg_mean: self.angles.mean_deg,
                commutation_error_deg_max: self.angles.max_abs_deg,
                forced_crossings: s.forced_crossings,
                steady_from_s: self.steady_from,
                sim_s,
                wall_s,
                realtime_factor: if wall_s > 0.0 {
                    sim_s / wall_s
                } else {
                    f64::INFINITY
                },
            },
            speed: self.record,
            duty: self.duty,
            current_ref: self.current_ref,
        }
    }
}
