//! One experiment: a drive from standstill under profiles of speed command, load and
//! supply, with steady-state metrics, a decimated speed record and an optional trace.
//! The library, `drive-bench run --scenario` (see [`crate::scenario_file`]) and the
//! bench's own experiments all build this one type.

mod fork;
mod measure;
mod runner;

use crate::config::DriveConfig;
use crate::drive::{BuildError, DriveEngine};
use crate::profile::{LoadProfile, Profile};
use crate::verdict::{VerdictRule, hold_window_from_s, shortest_hold_s};
use drive_core::error::ParamError;
use drive_core::{EngineError, Ticks};
pub use fork::ForkError;
pub use runner::Run;
use serde::Serialize;
use strategies::PluginLibrary;

/// What to simulate.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// What the experiment is for (free text, a scenario file's `description`); titles
    /// the plots. Empty: the plots describe the command.
    pub description: String,
    /// Plant, chip and strategy. Its `control.speed_ref_rpm` and `power_stage.supply_v`
    /// are replaced by the profiles' values at t = 0.
    pub config: DriveConfig,
    /// Simulated time \[s\].
    pub duration_s: f64,
    /// Speed command \[rpm\].
    pub speed_rpm: Profile,
    /// The driven machine.
    pub load: LoadProfile,
    /// Supply V_DD \[V\]; `None` holds the config's.
    pub supply_v: Option<Profile>,
    /// Stair length of the profiles' ramps \[s\] (see [`crate::profile`]). Default 1 ms.
    pub profile_update_s: f64,
    /// Start of the steady-state window \[s\]; it ends at `duration_s`.
    pub steady_from_s: f64,
    /// Trace sampling: period \[s\] and the window [from, to] in which rows are produced.
    pub trace: Option<TraceSpec>,
    /// Period of the decimated true-speed and duty record \[s\] (for step responses and
    /// plots); `None` (the default) keeps none, so a run's memory does not grow with its
    /// duration.
    pub speed_record_s: Option<f64>,
    /// A plugin strategy to use instead of the built-in one named in the config.
    pub plugin: Option<PluginLibrary>,
    /// How the run is judged from the true rotor.
    pub verdict_rule: VerdictRule,
    /// Cut-off of the low-frequency torque ripple, the vibration proxy \[Hz\]: the torque
    /// is averaged over blocks of 1/f_c (a boxcar, whose first null is at f_c) before its
    /// standard deviation is taken. Default 2000.
    pub torque_lowpass_hz: f64,
}

/// The longest run \[s\].
pub const MAX_DURATION_S: f64 = 3600.0;
/// The highest speed command \[rpm\].
pub const MAX_COMMAND_RPM: f64 = 16383.0;

/// The most points the speed record holds.
const MAX_RECORD_POINTS: f64 = 1e7;

/// Which trace rows to produce.
#[derive(Copy, Clone, Debug)]
pub struct TraceSpec {
    /// Sampling period \[s\], rounded to whole 20 ns ticks (at least one).
    pub every_s: f64,
    /// First instant traced \[s\].
    pub from_s: f64,
    /// Last instant traced \[s\].
    pub to_s: f64,
}

impl TraceSpec {
    /// Rows the trace will have.
    pub fn rows(&self) -> u64 {
        let every = self.every_s.max(Ticks(1).seconds());
        ((self.to_s - self.from_s).max(0.0) / every).floor() as u64 + 1
    }

    /// Its size as CSV, at [`TraceRow::TYPICAL_BYTES`] a row \[bytes\].
    pub fn expected_bytes(&self) -> u64 {
        self.rows().saturating_mul(TraceRow::TYPICAL_BYTES)
    }
}

impl Scenario {
    /// A constant command of `rpm` for `duration_s`, steady state over the last third
    /// (at least the last 0.5 s).
    pub fn hold(config: DriveConfig, rpm: f64, duration_s: f64) -> Self {
        let mut config = config;
        config.control.speed_ref_rpm = rpm;
        Scenario {
            description: String::new(),
            config,
            duration_s,
            speed_rpm: Profile::constant(rpm),
            load: LoadProfile::default(),
            supply_v: None,
            profile_update_s: 1e-3,
            steady_from_s: hold_window_from_s(duration_s),
            trace: None,
            speed_record_s: None,
            plugin: None,
            verdict_rule: VerdictRule::default(),
            torque_lowpass_hz: 2000.0,
        }
    }

    /// Checks every value, the config's included: nothing is simulated with a value that
    /// breaks its rule.
    pub fn validate(&self) -> Result<(), ParamError> {
        drive_core::error::check_range(
            "duration_s",
            self.duration_s,
            1e-6,
            MAX_DURATION_S,
            "must be > 0 and <= 3600 s",
        )?;
        drive_core::error::check_range(
            "steady_from_s",
            self.steady_from_s,
            0.0,
            self.duration_s,
            "must be within 0..=duration_s",
        )?;
        self.speed_rpm.validate("speed_rpm", self.duration_s, |v| {
            drive_core::error::check_range(
                "speed_rpm",
                v,
                0.0,
                MAX_COMMAND_RPM,
                "must be 0..=16383 rpm (the chip's 14-bit command)",
            )
        })?;
        // After the profile, so that a bad command is named as the profile's point.
        self.config.validate()?;
        self.load.validate(self.duration_s)?;
        // The load's drag, at its steepest (a Coulomb term at standstill, a fan at the top
        // command), must leave the speed's step stable.
        let max = |p: &Profile| p.points().iter().map(|q| q.1.abs()).fold(0.0, f64::max);
        let top = MAX_COMMAND_RPM * std::f64::consts::TAU / 60.0;
        let slope = max(&self.load.coulomb_nm) / self.config.motor.coulomb_speed_rad_s
            + max(&self.load.viscous_nms)
            + 2.0 * max(&self.load.fan_nms2) * top;
        self.config
            .plant_params()
            .check_mechanics(slope, self.load.inertia_kgm2)?;
        if let Some(p) = &self.supply_v {
            p.validate("supply_v", self.duration_s, |v| {
                let mut stage = self.config.power_stage.clone();
                stage.supply_v = v;
                stage.validate()
            })?;
        }
        drive_core::error::check_range(
            "profile_update_s",
            self.profile_update_s,
            1e-6,
            1.0,
            "must be 1e-6..=1 s",
        )?;
        if let Some(tr) = &self.trace {
            drive_core::error::check_range(
                "trace_from_s",
                tr.from_s,
                0.0,
                self.duration_s,
                "must be within 0..=duration_s",
            )?;
            drive_core::error::check_range(
                "trace_to_s",
                tr.to_s,
                tr.from_s,
                self.duration_s,
                "must be within trace_from_s..=duration_s",
            )?;
            drive_core::error::check_range(
                "trace_every_us",
                tr.every_s * 1e6,
                0.02,
                1e6,
                "must be 0.02 µs ..= 1 s",
            )?;
        }
        drive_core::error::check_range(
            "torque_lowpass_hz",
            self.torque_lowpass_hz,
            1.0,
            1e6,
            "must be in 1..=1e6 Hz (blocks of at least one µs)",
        )?;
        if let Some(x) = self.speed_record_s {
            drive_core::error::check_positive("speed_record_s", x)?;
            if self.duration_s / x > MAX_RECORD_POINTS {
                return Err(ParamError::new(
                    "speed_record_s",
                    x,
                    "must be >= duration_s / 1e7 (at most 10 million points are recorded)",
                ));
            }
        }
        Ok(())
    }
}

/// One trace row: true plant signals and what the chip sees and does.
#[derive(Copy, Clone, Debug, Default, PartialEq, Serialize)]
pub struct TraceRow {
    /// Time \[s\].
    pub t_s: f64,
    /// True mechanical speed \[rpm\].
    pub speed_rpm: f64,
    /// The chip's FG speed measurement \[rpm\].
    pub speed_est_rpm: f64,
    /// True electrical angle [°], 0..360, with e_u = λr·ωe·sin θe.
    pub theta_e_deg: f64,
    /// Phase currents \[A\].
    pub i_u: f64,
    /// Phase current v \[A\].
    pub i_v: f64,
    /// Phase current w \[A\].
    pub i_w: f64,
    /// Terminal voltages to ground \[V\].
    pub v_u: f64,
    /// Terminal v \[V\].
    pub v_v: f64,
    /// Terminal w \[V\].
    pub v_w: f64,
    /// Neutral to ground \[V\].
    pub v_n: f64,
    /// Electromagnetic torque [N·m].
    pub torque_nm: f64,
    /// Commutation state (1..12 twelve-step, 1..6 six-step), 0 when off or starting.
    pub state: u8,
    /// Raw zero-crossing signal Z_d (0/1).
    pub zd: u8,
    /// Z_d after the guard (0/1).
    pub zdf: u8,
    /// 1 inside a linear region (PWM stopped).
    pub linear: u8,
    /// Duty cycle (voltage command / carrier top), 0..1.
    pub duty: f64,
    /// Restarts so far.
    pub restarts: u32,
    /// The controller's speed command \[rpm\].
    pub speed_ref_rpm: f64,
    /// The controller's current command (the speed PI's output) \[A\].
    pub current_ref_a: f64,
    /// The load's torque on the shaft, opposing positive rotation [N·m].
    pub load_nm: f64,
    /// Supply V_DD \[V\].
    pub supply_v: f64,
    /// True shunt current, positive to ground \[A\] (what the chip's ADC samples).
    pub i_shunt_a: f64,
}

impl TraceRow {
    /// The CSV header, in field order.
    pub const HEADER: &'static str = "t_s,speed_rpm,speed_est_rpm,theta_e_deg,i_u,i_v,i_w,v_u,v_v,v_w,v_n,torque_nm,state,zd,zdf,linear,duty,restarts,speed_ref_rpm,current_ref_a,load_nm,supply_v,i_shunt_a";

    /// A row's usual length as CSV \[bytes\]: every float at full precision (the shortest
    /// decimal that reads back to the same value), ≈ 245 bytes measured at 3000 rpm.
    pub const TYPICAL_BYTES: u64 = 250;

    /// The row as CSV (no newline).
    pub fn csv(&self) -> String {
        let mut v = Vec::with_capacity(256);
        self.write_csv(&mut v).expect("a Vec takes every write");
        String::from_utf8(v).expect("the row is ASCII")
    }

    /// Writes the row as CSV (no newline). Values are the shortest decimals that read back
    /// as the same f64 (zmij, several times faster than fixed-precision `format!`, which
    /// dominated a traced run); the time is printed to the nanosecond from whole ticks.
    pub fn write_csv(&self, w: &mut impl std::io::Write) -> std::io::Result<()> {
        // The row is assembled here and handed over in one write.
        // 18 floats of at most 25 bytes, four flags, the restarts and the time: < 640.
        let mut row = [0u8; 640];
        let mut n = 0;
        let mut put = |b: &[u8]| {
            row[n..n + b.len()].copy_from_slice(b);
            n += b.len();
        };
        let mut f = zmij::Buffer::new();
        let mut int = Digits::default();
        // Whole 20 ns ticks: the nanosecond count is exact, printed as s with 9 decimals.
        let ns = self.time_ns();
        put(int.of(ns / 1_000_000_000));
        put(b".");
        // A leading 1 keeps the fraction's leading zeros.
        put(&int.of(ns % 1_000_000_000 + 1_000_000_000)[1..]);
        let theta = self.theta_e_deg_wrapped();
        for x in [
            self.speed_rpm,
            self.speed_est_rpm,
            theta,
            self.i_u,
            self.i_v,
            self.i_w,
            self.v_u,
            self.v_v,
            self.v_w,
            self.v_n,
            self.torque_nm,
        ] {
            put(b",");
            put(f.format(x).as_bytes());
        }
        for k in [self.state, self.zd, self.zdf, self.linear] {
            put(b",");
            put(int.of(u64::from(k)));
        }
        put(b",");
        put(f.format(self.duty).as_bytes());
        put(b",");
        put(int.of(u64::from(self.restarts)));
        for x in [
            self.speed_ref_rpm,
            self.current_ref_a,
            self.load_nm,
            self.supply_v,
            self.i_shunt_a,
        ] {
            put(b",");
            put(f.format(x).as_bytes());
        }
        w.write_all(&row[..n])
    }

    /// The time as written: whole nanoseconds (the tick is 20 ns, so nothing is lost).
    pub fn time_ns(&self) -> u64 {
        (self.t_s * 1e9).round().max(0.0) as u64
    }

    /// θe as written, in [0, 360): an angle a hair below 360° could round up to it.
    pub fn theta_e_deg_wrapped(&self) -> f64 {
        if self.theta_e_deg >= 360.0 {
            0.0
        } else {
            self.theta_e_deg
        }
    }

    /// The row of the drive as it is now.
    pub fn of(eng: &DriveEngine) -> Self {
        Self::observed(eng, &eng.plant.observe())
    }

    /// The row of the drive as it is now, whose plant was observed as `o` (observing
    /// inside a step costs a step of its own: a caller that has `o` already passes it).
    pub fn observed(eng: &DriveEngine, o: &plants::Observation) -> Self {
        let s = eng.controller.status();
        TraceRow {
            t_s: o.t_s,
            speed_rpm: o.speed_rpm,
            speed_est_rpm: f64::from(s.speed_est_rpm),
            theta_e_deg: o.theta_e.to_degrees().rem_euclid(360.0),
            i_u: o.i.u,
            i_v: o.i.v,
            i_w: o.i.w,
            v_u: o.v_term.u,
            v_v: o.v_term.v,
            v_w: o.v_term.w,
            v_n: o.v_n,
            torque_nm: o.torque_nm,
            state: s.state,
            zd: s.zd.into(),
            zdf: s.zdf.into(),
            linear: s.linear.into(),
            duty: f64::from(s.duty) / f64::from(eng.carrier().top),
            restarts: s.restarts,
            speed_ref_rpm: eng.controller.speed_ref_rpm(),
            current_ref_a: s.current_ref_a,
            load_nm: eng
                .plant
                .load()
                .torque_nm(o.omega_m, eng.plant.params().motor.coulomb_speed_rad_s),
            supply_v: eng.plant.params().power_stage.supply_v,
            i_shunt_a: o.i_shunt,
        }
    }
}

/// A decimal buffer for unsigned integers (the trace's counters and time).
#[derive(Default)]
struct Digits([u8; 20]);

impl Digits {
    fn of(&mut self, mut n: u64) -> &[u8] {
        let mut k = self.0.len();
        loop {
            k -= 1;
            self.0[k] = b'0' + (n % 10) as u8;
            n /= 10;
            if n == 0 {
                break;
            }
        }
        &self.0[k..]
    }
}

/// The summary of a run, with the metric definitions of the report.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Strategy name.
    pub strategy: String,
    /// Speed command at the end \[rpm\].
    pub speed_ref_rpm: f64,
    /// Time-weighted mean of the true speed over the steady-state window \[rpm\].
    pub speed_mean_rpm: f64,
    /// Standard deviation of the true speed over the window \[rpm\].
    pub speed_ripple_rpm: f64,
    /// Mean electromagnetic torque over the window [N·m], exact: from the plant's ∫Te dt.
    pub torque_mean_nm: f64,
    /// Standard deviation of the torque over the window [N·m], exact: from ∫Te dt and
    /// ∫Te² dt.
    pub torque_ripple_nm: f64,
    /// Low-frequency torque ripple, the vibration proxy [N·m]: standard deviation of the
    /// torque's means over the whole blocks of 1/`torque_lowpass_hz` in the window (exact
    /// block means, from the plant's ∫Te dt; 0 with fewer than two blocks). What a spindle's structure feels; the
    /// full-band figure is dominated by PWM and commutation ripple it filters out.
    pub torque_ripple_lf_nm: f64,
    /// The cut-off of `torque_ripple_lf_nm` \[Hz\].
    pub torque_lowpass_hz: f64,
    /// Phase-current RMS over the window, √(mean(i_u² + i_v² + i_w²)/3) \[A\], exact: from
    /// the copper loss R·Σi² integrated by the plant.
    pub current_rms_a: f64,
    /// Largest phase-current magnitude seen at the engine's whole-tick stops in the window
    /// (PWM edges, controller ticks, samples) \[A\]. Between PWM edges a current changes
    /// monotonically, so this is its peak wherever the PWM chops; at full duty (a linear
    /// region, top speed) a peak between stops can be missed.
    pub current_peak_a: f64,
    /// Commutation surge: the mean, over the states both entered and left in the window,
    /// of the largest phase-current magnitude seen during the state (as `current_peak_a`)
    /// \[A\].
    pub commutation_peak_a: f64,
    /// What the run came to, judged from the true rotor (see [`crate::verdict`]).
    pub verdict: crate::verdict::Verdict,
    /// Why, in one line.
    pub verdict_reason: String,
    /// For an `unsettled` run: the instant after which a window can judge it (the first
    /// hand-over, where the speed settled, or, with no hand-over yet, the run's end) \[s\].
    pub judge_after_s: Option<f64>,
    /// Power-on to the controller's first hand-over to closed loop \[s\] (`None`: never).
    pub handover_s: Option<f64>,
    /// When the rotor first followed the commutation (see [`crate::verdict`]) \[s\].
    pub started_at_s: Option<f64>,
    /// The first commutation out of synchronism after that: (t \[s\], true speed \[rpm\]).
    pub sync_lost_at: Option<(f64, f64)>,
    /// Restarts (step-miss or supervisor errors) during the whole run.
    pub restarts: u32,
    /// Whether the controller *believes* it ended in closed-loop running (its mode; the
    /// verdict says whether the rotor agrees).
    pub chip_running: bool,
    /// The controller's own speed measurement at the end \[rpm\].
    pub chip_speed_rpm: f64,
    /// Commutations in the window.
    pub commutations: u64,
    /// Signed mean of the commutation-angle error in the window [°] (positive: late).
    pub commutation_error_deg_mean: f64,
    /// Largest |commutation-angle error| in the window [°].
    pub commutation_error_deg_max: f64,
    /// Zero crossings taken by the demagnetisation timeout instead of the comparator,
    /// since the last hand-over.
    pub forced_crossings: u64,
    /// Steady-state window \[s\].
    pub steady_from_s: f64,
    /// Simulated time \[s\].
    pub sim_s: f64,
    /// Wall-clock time of the simulation \[s\].
    pub wall_s: f64,
    /// sim_s / wall_s.
    pub realtime_factor: f64,
}

/// What a run produced.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// Steady-state metrics.
    pub summary: Summary,
    /// True speed every `speed_record_s`: (t \[s\], rpm); empty without it.
    pub speed: Vec<(f64, f64)>,
    /// Duty (voltage command / carrier top) at the same instants: (t \[s\], 0..1).
    pub duty: Vec<(f64, f64)>,
    /// The controller's current command (the speed PI's output) at the same instants:
    /// (t \[s\], A).
    pub current_ref: Vec<(f64, f64)>,
}

/// Why a scenario could not run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A parameter or schedule value breaks its rule.
    #[error("{0}")]
    Param(#[from] ParamError),
    /// The engine refused a command (e.g. a shoot-through) or the strategy faulted.
    #[error("{0}")]
    Engine(#[from] EngineError),
    /// The plugin could not be instantiated.
    #[error("{0}")]
    Build(#[from] BuildError),
    /// A run could not be forked as the scenario asked for.
    #[error("{0}")]
    Fork(#[from] ForkError),
}

/// Runs `sc`, calling `on_row` for every trace row.
pub fn run(sc: &Scenario, on_row: impl FnMut(&TraceRow)) -> Result<Outcome, RunError> {
    run_observed(sc, on_row, |_| {})
}

/// [`run`], also calling `on_time` with the simulated time \[s\] every 0.5 % of the run
/// (for a progress bar).
pub fn run_observed(
    sc: &Scenario,
    on_row: impl FnMut(&TraceRow),
    on_time: impl FnMut(f64),
) -> Result<Outcome, RunError> {
    Run::start(sc)?.finish(on_row, on_time)
}

/// Runs `sc` through `attempt` and, while it ends `unsettled`, again with its window
/// moved after the start-up: a hold ([`Scenario::hold`]'s window) becomes the shortest
/// hold that judges it ([`crate::verdict::shortest_hold_s`]); any other scenario keeps
/// its window's length and starts it there. The run before the old end is the same run,
/// so the instant it names stays; [`SETTLE_MARGIN_S`] more covers last-digit changes
/// from the window's own stops. At most [`SETTLE_TRIES`] runs, within
/// [`MAX_DURATION_S`]. Returns the scenario of the last run with its outcome.
pub fn settled(
    sc: &Scenario,
    mut attempt: impl FnMut(&Scenario) -> Result<Outcome, RunError>,
) -> Result<(Scenario, Outcome), RunError> {
    let mut sc = sc.clone();
    let mut out = attempt(&sc)?;
    for _ in 1..SETTLE_TRIES {
        let Some(after) = out.summary.judge_after_s else {
            break;
        };
        let after = after + SETTLE_MARGIN_S;
        let (from, duration) = if sc.steady_from_s == hold_window_from_s(sc.duration_s) {
            let d = shortest_hold_s(after);
            (hold_window_from_s(d), d)
        } else {
            (after, after + sc.duration_s - sc.steady_from_s)
        };
        if duration <= sc.duration_s || duration > MAX_DURATION_S {
            break;
        }
        (sc.steady_from_s, sc.duration_s) = (from, duration);
        out = attempt(&sc)?;
    }
    Ok((sc, out))
}

/// Runs [`settled`] makes at most.
pub const SETTLE_TRIES: usize = 3;
/// Margin beyond the instant an `unsettled` run names \[s\].
pub const SETTLE_MARGIN_S: f64 = 0.05;
