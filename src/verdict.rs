//! The verdict of a run: judged from the true rotor, never from what the controller
//! believes.
//!
//! A sensorless controller can be wrong about everything at once: locked on false
//! crossings it reports a speed, commutates and stays "running" while the rotor stands
//! still. So the verdict compares the controller's commutations with the plant's true
//! electrical angle θe and the command with the true speed:
//!
//! - **in synchronism** over the steady-state window when the controller stayed in closed
//!   loop, at least [`VerdictRule::sync_share`] of its commutations fell within
//!   ±[`VerdictRule::sync_error_deg`] of the table boundary of the state they entered, and
//!   it commutated as often as the rotor passed states: N_comm = n_states·∫ωe dt/2π within
//!   one electrical turn's states (plus 2 %). A locked commutation is a few degrees off
//!   (sensing and filter delays); a lost one spreads its errors over ±180° (mean |error|
//!   ≈ 90°), so the 30° default sits far from both.
//! - **started** once the rotor has followed the commutation: at some time in the run,
//!   [`VerdictRule::started_turns`] electrical turns' worth of consecutive commutations all
//!   within the sync error.
//!
//! The verdicts, in the order they are tested (the first that applies):
//! `non-finite` (the plant state left the reals), `gave-up` (restarts exhausted, drive
//! off), `not-started` (never started), `stalled` (true mean speed below
//! [`VerdictRule::stalled_fraction`] of the command), `lost-sync` (the controller believes
//! it runs, or restarted in the window, and the rotor disagrees), `off-speed` (in
//! synchronism, but the true mean speed is outside ±[`VerdictRule::speed_tolerance`] of
//! the command: beyond reach, or hunting), `running`. Before all but `non-finite`: a run
//! whose command ends at 0 is `stopped` when its rotor is at rest over the window (rms
//! speed below [`VerdictRule::rest_rpm`]) and the controller did not restart there; any
//! other ending of a 0 command is judged as before (a drive that keeps turning is
//! `off-speed` or `lost-sync`, one that restarted `lost-sync`).
//!
//! A window can only judge a drive that has finished starting and settling. After
//! `gave-up` and before `not-started`, a run is `unsettled` (not judged) when its window
//! began before the first hand-over to closed loop, or the run ended before it, with no
//! restart in the run (the first start-up was still on its planned course); and after
//! `lost-sync` and before `off-speed` (a drive in synchronism), when, with a constant
//! command over the window, the true speed (low-passed over [`SETTLE_TAU_S`], sampled
//! every [`SETTLE_SAMPLE_S`], to see through the commutation ripple) was outside the
//! tolerance at the window's start and last outside in the window's first half, inside
//! from then to the end: it was still settling there. A speed that leaves the tolerance
//! in the second half is not settling but hunting or off, and is judged as before. The
//! reason names the hand-over (or the run's end, when none came), or the settling
//! instant, and the shortest hold ([`shortest_hold_s`]) whose window begins after it.

use crate::metrics::wrap_deg;
use serde::Serialize;
use std::fmt;

/// What a run came to.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Verdict {
    /// Closed loop, in synchronism, true mean speed within tolerance of the command.
    Running,
    /// In synchronism, but the true mean speed is off the command.
    OffSpeed,
    /// The controller believes it runs (or restarted in the window); the rotor disagrees.
    LostSync,
    /// The rotor (nearly) stands still after having started.
    Stalled,
    /// The rotor never followed the commutation.
    NotStarted,
    /// Restarts exhausted: the drive switched off for good.
    GaveUp,
    /// The plant state became non-finite.
    NonFinite,
    /// Told to stop (a command of 0), the rotor is at rest and the controller did not
    /// restart it: a success.
    Stopped,
    /// Not judged: the steady-state window began before the first hand-over to closed
    /// loop, or the speed was still settling into its tolerance in the window's first
    /// half. The run was too short for its window; the reason names the start-up and
    /// the shortest hold that judges.
    Unsettled,
}

impl Verdict {
    /// Every verdict: those of a speed command best first, then `stopped` and
    /// `unsettled` (last, in the order they were added, so that the FMU's enumeration
    /// items, counted from 1 in this order, keep their numbers).
    pub const ALL: [Verdict; 9] = [
        Verdict::Running,
        Verdict::OffSpeed,
        Verdict::LostSync,
        Verdict::Stalled,
        Verdict::NotStarted,
        Verdict::GaveUp,
        Verdict::NonFinite,
        Verdict::Stopped,
        Verdict::Unsettled,
    ];

    /// The name used in tables, JSON and CSV.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Running => "running",
            Verdict::OffSpeed => "off-speed",
            Verdict::LostSync => "lost-sync",
            Verdict::Stalled => "stalled",
            Verdict::NotStarted => "not-started",
            Verdict::GaveUp => "gave-up",
            Verdict::NonFinite => "non-finite",
            Verdict::Stopped => "stopped",
            Verdict::Unsettled => "unsettled",
        }
    }

    /// Exit status of `drive-bench run` (1 is an error before or during the run, 2 a
    /// command-line error).
    pub fn exit_code(self) -> i32 {
        match self {
            Verdict::Running => 0,
            Verdict::OffSpeed => 3,
            Verdict::LostSync => 4,
            Verdict::Stalled => 5,
            Verdict::NotStarted => 6,
            Verdict::GaveUp => 7,
            Verdict::NonFinite => 8,
            Verdict::Stopped => 0,
            Verdict::Unsettled => 9,
        }
    }

    /// Whether the run's steady-state figures describe a drive doing its job at speed.
    pub fn is_running(self) -> bool {
        self == Verdict::Running
    }

    /// Whether the drive did what it was told: running at the command, or stopped.
    pub fn is_success(self) -> bool {
        matches!(self, Verdict::Running | Verdict::Stopped)
    }

    /// Whether the commutation followed the rotor to the end (running or off-speed): what
    /// a response measurement needs, whose settling is itself the object of study.
    pub fn in_sync(self) -> bool {
        matches!(self, Verdict::Running | Verdict::OffSpeed)
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Time constant of the low-passed true speed whose settling the window needs \[s\].
pub const SETTLE_TAU_S: f64 = 0.02;
/// Its sampling period \[s\].
pub const SETTLE_SAMPLE_S: f64 = 1e-3;

/// Where [`crate::scenario::Scenario::hold`] begins the steady-state window of a run of
/// `duration_s` \[s\]: the last third, at least the last 0.5 s.
pub fn hold_window_from_s(duration_s: f64) -> f64 {
    (duration_s * 2.0 / 3.0).min(duration_s - 0.5).max(0.0)
}

/// The shortest hold whose window ([`hold_window_from_s`]) begins at or after `t_s` \[s\].
pub fn shortest_hold_s(t_s: f64) -> f64 {
    // 2d/3 >= t where 2d/3 <= d - 0.5 (d >= 1.5 s), else d - 0.5 >= t.
    let d = t_s + 0.5;
    if d < 1.5 { d } else { (1.5 * t_s).max(1.5) }
}

/// The thresholds of the verdict (see the module doc for the reasoning).
#[derive(Copy, Clone, Debug, PartialEq, Serialize)]
pub struct VerdictRule {
    /// Tolerance of the true mean speed around the command \[fraction\]. Default 0.02.
    pub speed_tolerance: f64,
    /// Largest |commutation-angle error| of a commutation in synchronism [electrical °].
    /// Default 30.
    pub sync_error_deg: f64,
    /// Share of the window's commutations that must be in synchronism. Default 0.95.
    pub sync_share: f64,
    /// Below this fraction of the command the true mean speed counts as stalled.
    /// Default 0.1.
    pub stalled_fraction: f64,
    /// Electrical turns of consecutive commutations in synchronism that make a start.
    /// Default 2.
    pub started_turns: u32,
    /// Rms true speed over the window below which a rotor counts as at rest \[rpm\].
    /// Default 5: the bearing drag alone (2.5e-4 N·m on 17e-7 kg·m², 147 rad/s²) takes
    /// the built-in rotor from 5 rpm to rest in 3.6 ms, so over a window of tenths of a
    /// second an rms below it is a rotor at rest, not one coasting.
    pub rest_rpm: f64,
}

impl Default for VerdictRule {
    fn default() -> Self {
        VerdictRule {
            speed_tolerance: 0.02,
            sync_error_deg: 30.0,
            sync_share: 0.95,
            stalled_fraction: 0.1,
            started_turns: 2,
            rest_rpm: 5.0,
        }
    }
}

/// A verdict and its one-line reason.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Judgement {
    /// The verdict.
    pub verdict: Verdict,
    /// Why, in one line with the numbers that decided it.
    pub reason: String,
    /// For `unsettled`: the instant after which a window can judge (the hand-over, where
    /// the speed settled, or, with no hand-over yet, the run's end) \[s\].
    pub judge_after_s: Option<f64>,
}

/// Whether the commutation follows the true rotor now: the length of the current run of
/// consecutive commutations within ±`sync_error_deg` of their table boundary.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct SyncStreak {
    sync_error_deg: f64,
    needed: u32,
    streak: u32,
}

impl SyncStreak {
    /// In synchronism after `turns` electrical turns of a table of `states_per_turn`
    /// states, each commutation within ±`sync_error_deg`.
    pub fn new(sync_error_deg: f64, turns: u32, states_per_turn: u32) -> Self {
        SyncStreak {
            sync_error_deg,
            needed: turns.max(1) * states_per_turn.max(1),
            streak: 0,
        }
    }

    /// A commutation into a state starting at `boundary_deg` with the rotor at the true
    /// angle `theta_deg`; returns whether it was within the error.
    pub fn commutation(&mut self, theta_deg: f64, boundary_deg: f64) -> bool {
        let ok = wrap_deg(theta_deg - boundary_deg).abs() <= self.sync_error_deg;
        // Saturating: only its reaching `needed` matters.
        self.streak = if ok { self.streak.saturating_add(1) } else { 0 };
        ok
    }

    /// Whether the last commutations, enough for the turns asked, were all in synchronism.
    pub fn in_sync(&self) -> bool {
        self.streak >= self.needed
    }

    /// Forgets the streak (the controller left closed loop).
    pub fn reset(&mut self) {
        self.streak = 0;
    }
}

/// The verdict of a drive while it runs (the FMU's `verdict` output), by the run's rule
/// applied to the recent past instead of a steady window:
/// - non-finite: the plant's state is not finite now;
/// - gave-up: the controller switched off for good;
/// - not-started: no start (two electrical turns of commutations in synchronism) since the
///   drive was (re)started;
/// - stalled: the true speed, low-passed with a time constant of [`LiveVerdict::TAU_S`], is
///   below `stalled_fraction` of the command;
/// - lost-sync: a commutation fell outside ±`sync_error_deg` of the true rotor since the
///   last two turns in synchronism;
/// - off-speed: in synchronism, the low-passed speed outside `speed_tolerance` of the
///   command (during any speed transient, too);
/// - running: otherwise.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LiveVerdict {
    rule: VerdictRule,
    streak: SyncStreak,
    started: bool,
    lost: bool,
    mean_rpm: f64,
    last_t_s: Option<f64>,
}

impl LiveVerdict {
    /// Time constant of the low-passed true speed \[s\].
    pub const TAU_S: f64 = 0.1;

    /// A drive at rest, judged by `rule` on a table of `states_per_turn` states.
    pub fn new(rule: VerdictRule, states_per_turn: u32) -> Self {
        LiveVerdict {
            rule,
            streak: SyncStreak::new(rule.sync_error_deg, rule.started_turns, states_per_turn),
            started: false,
            lost: false,
            mean_rpm: 0.0,
            last_t_s: None,
        }
    }

    /// A commutation into a state starting at `boundary_deg`, the rotor at `theta_deg`.
    pub fn commutation(&mut self, theta_deg: f64, boundary_deg: f64) {
        let ok = self.streak.commutation(theta_deg, boundary_deg);
        if self.streak.in_sync() {
            self.started = true;
            self.lost = false;
        } else if self.started && !ok {
            self.lost = true;
        }
    }

    /// The controller is off or starting (state 0): a start begins again.
    pub fn restart(&mut self) {
        self.streak.reset();
        self.started = false;
        self.lost = false;
    }

    /// The true speed `rpm` at `t_s` (any spacing; a step of dt weighs 1 − e^(−dt/τ)).
    pub fn speed(&mut self, t_s: f64, rpm: f64) {
        let w = match self.last_t_s {
            Some(t0) => 1.0 - (-(t_s - t0).max(0.0) / Self::TAU_S).exp(),
            None => 1.0,
        };
        self.mean_rpm += w * (rpm - self.mean_rpm);
        self.last_t_s = Some(t_s);
    }

    /// Whether the last two turns of commutations followed the true rotor.
    pub fn in_sync(&self) -> bool {
        self.streak.in_sync()
    }

    /// Checks a verdict restored from a state against the drive it judges, at time `t_s`
    /// \[s\] with its rotor's speed bound `max_rpm` (see
    /// `plants::bldc::BldcPlant::max_speed_rpm`): the low-passed speed is a mean of true
    /// speeds, so within that bound, and the last speed was taken by `t_s`.
    pub fn check_restored(&self, t_s: f64, max_rpm: f64) -> Result<(), String> {
        drive_core::state::check(self.mean_rpm.abs() <= max_rpm, || {
            format!(
                "mean_rpm = {} (rule: a mean of true speeds, |ω| <= {max_rpm} rpm)",
                self.mean_rpm
            )
        })?;
        drive_core::state::check(
            self.last_t_s.is_none_or(|t| (0.0..=t_s).contains(&t)),
            || {
                format!(
                    "last_t_s = {:?} (rule: an instant of the run, by its time {t_s} s)",
                    self.last_t_s
                )
            },
        )
    }

    /// The verdict against `command_rpm`, with the plant's state `finite` and the
    /// controller `gave_up`.
    pub fn verdict(&self, command_rpm: f64, finite: bool, gave_up: bool) -> Verdict {
        let command = command_rpm.abs().max(1.0);
        if !finite || !self.mean_rpm.is_finite() {
            Verdict::NonFinite
        } else if command_rpm == 0.0 && self.mean_rpm.abs() < self.rule.rest_rpm {
            Verdict::Stopped
        } else if gave_up {
            Verdict::GaveUp
        } else if !self.started {
            Verdict::NotStarted
        } else if self.mean_rpm.abs() < self.rule.stalled_fraction * command {
            Verdict::Stalled
        } else if self.lost {
            Verdict::LostSync
        } else if (self.mean_rpm - command_rpm).abs() > self.rule.speed_tolerance * command {
            Verdict::OffSpeed
        } else {
            Verdict::Running
        }
    }

    /// The low-passed true speed \[rpm\].
    pub fn mean_rpm(&self) -> f64 {
        self.mean_rpm
    }
}

/// What the run showed, collected while it runs (see [`Witness::commutation`] and
/// [`Witness::instant`]) and judged at its end.
#[derive(Clone, Debug, Default)]
pub struct Witness {
    rule: VerdictRule,
    states_per_turn: u32,
    streak: SyncStreak,
    started_at_s: Option<f64>,
    sync_lost: Option<(f64, f64)>,
    handed_over: bool,
    non_finite_at_s: Option<f64>,
    window_commutations: u64,
    window_in_sync: u64,
    window_left_closed_loop: bool,
    restarts_at_window: Option<u32>,
    /// The first hand-over to closed loop, and the restarts before it.
    handover: Option<(f64, u32)>,
    /// The window's first instant.
    window_from_s: Option<f64>,
    settle: Settle,
}

/// The low-passed true speed and where it was off the command in the window.
#[derive(Clone, Debug, Default)]
struct Settle {
    /// Last sample: (t \[s\], low-passed rpm).
    last: Option<(f64, f64)>,
    /// The command at the window's first sample \[rpm\], and whether it moved after.
    command: Option<f64>,
    command_moved: bool,
    /// The last in-window sample outside the tolerance, and whether the last one was.
    last_off_s: Option<f64>,
    off_now: bool,
    /// Whether the window's first sample was outside the tolerance.
    first_off: Option<bool>,
}

/// What the run ended with, for [`Witness::judge`].
#[derive(Copy, Clone, Debug)]
pub struct Ending {
    /// Speed command at the end \[rpm\].
    pub command_rpm: f64,
    /// Time-weighted true mean speed over the window \[rpm\].
    pub speed_mean_rpm: f64,
    /// Time-weighted rms true speed over the window \[rpm\].
    pub speed_rms_rpm: f64,
    /// Length of the window \[s\].
    pub window_s: f64,
    /// Pole pairs P/2.
    pub pole_pairs: u32,
    /// The controller's speed estimate at the end \[rpm\].
    pub chip_speed_rpm: f64,
    /// Restarts in the whole run, and the controller's limit.
    pub restarts: (u32, u32),
    /// The controller ended switched off after exhausting its restarts.
    pub gave_up: bool,
}

impl Witness {
    /// A witness for a commutation table of `states_per_turn` states per electrical turn.
    pub fn new(rule: VerdictRule, states_per_turn: u32) -> Self {
        Witness {
            rule,
            states_per_turn: states_per_turn.max(1),
            streak: SyncStreak::new(rule.sync_error_deg, rule.started_turns, states_per_turn),
            ..Witness::default()
        }
    }

    /// A commutation at `t_s` into a state starting at `boundary_deg`, with the rotor at
    /// the true angle `theta_deg` and speed `rpm`; `in_window` when inside the steady-state
    /// window.
    pub fn commutation(
        &mut self,
        t_s: f64,
        theta_deg: f64,
        boundary_deg: f64,
        rpm: f64,
        in_window: bool,
    ) {
        let ok = self.streak.commutation(theta_deg, boundary_deg);
        if !ok && self.started_at_s.is_some() && self.sync_lost.is_none() {
            self.sync_lost = Some((t_s, rpm));
        }
        if self.started_at_s.is_none() && self.streak.in_sync() {
            self.started_at_s = Some(t_s);
        }
        if in_window {
            self.window_commutations += 1;
            self.window_in_sync += u64::from(ok);
        }
    }

    /// An engine instant at `t_s`: whether the controller is in closed loop, its restarts
    /// so far, whether the plant's signals are finite, and whether `t_s` is in the window.
    pub fn instant(
        &mut self,
        t_s: f64,
        closed_loop: bool,
        restarts: u32,
        finite: bool,
        in_window: bool,
    ) {
        self.handed_over |= closed_loop;
        if closed_loop && self.handover.is_none() {
            self.handover = Some((t_s, restarts));
        }
        if in_window {
            self.window_from_s.get_or_insert(t_s);
        }
        if !closed_loop {
            // A restart: the commutations before it do not carry over into a start.
            self.streak.reset();
        }
        if !finite && self.non_finite_at_s.is_none() {
            self.non_finite_at_s = Some(t_s);
        }
        if in_window {
            self.restarts_at_window.get_or_insert(restarts);
            self.window_left_closed_loop |= !closed_loop;
        }
    }

    /// The true speed `rpm` at an instant `t_s` of the run, under a command of
    /// `command_rpm`; `in_window` when inside the steady-state window. Any spacing: it is
    /// sampled every [`SETTLE_SAMPLE_S`].
    pub fn speed(&mut self, t_s: f64, rpm: f64, command_rpm: f64, in_window: bool) {
        let s = &mut self.settle;
        let lp = match s.last {
            Some((t0, _)) if t_s - t0 < SETTLE_SAMPLE_S => return,
            Some((t0, m)) => m + (1.0 - (-(t_s - t0) / SETTLE_TAU_S).exp()) * (rpm - m),
            None => rpm,
        };
        s.last = Some((t_s, lp));
        if in_window {
            s.command_moved |= s.command.is_some_and(|c| c != command_rpm);
            s.command.get_or_insert(command_rpm);
            let tol = self.rule.speed_tolerance * command_rpm.abs().max(1.0);
            let off = (lp - command_rpm).abs() > tol;
            s.first_off.get_or_insert(off);
            s.off_now = off;
            if off {
                s.last_off_s = Some(t_s);
            }
        }
    }

    /// When the rotor first followed the commutation \[s\].
    pub fn started_at_s(&self) -> Option<f64> {
        self.started_at_s
    }

    /// The first commutation out of synchronism after the start: (t \[s\], true speed
    /// \[rpm\]). Where a drive turned down lost its rotor.
    pub fn sync_lost(&self) -> Option<(f64, f64)> {
        self.sync_lost
    }

    /// The verdict: the first rule the run breaks, in order (see the module doc), else
    /// running.
    pub fn judge(&self, end: &Ending) -> Judgement {
        let restarts_in_window = end
            .restarts
            .0
            .saturating_sub(self.restarts_at_window.unwrap_or(end.restarts.0));
        self.non_finite(end)
            .or_else(|| self.stopped_or_gave_up(end, restarts_in_window))
            // (The speed's settling is judged below, once the drive is known in synchronism.)
            .or_else(|| self.in_start_up(end))
            .or_else(|| self.not_started_or_stalled(end))
            .or_else(|| self.out_of_sync(end, restarts_in_window))
            .or_else(|| self.settling(end))
            .unwrap_or_else(|| self.on_speed(end))
    }
}

/// A verdict other than `unsettled`, with its reason.
fn judged(verdict: Verdict, reason: String) -> Judgement {
    Judgement {
        verdict,
        reason,
        judge_after_s: None,
    }
}

/// The commutations in the window: the share in synchronism, their number, the states the
/// rotor passed through at its true mean speed, and the slack allowed between the two.
struct WindowSync {
    share: f64,
    n: f64,
    passed: f64,
    slack: f64,
}

impl Witness {
    /// `non-finite`: the plant's state, or the mean speed.
    fn non_finite(&self, end: &Ending) -> Option<Judgement> {
        let mean = end.speed_mean_rpm;
        if let Some(t) = self.non_finite_at_s {
            return Some(judged(
                Verdict::NonFinite,
                format!("the plant's state became non-finite at t = {t:.6} s"),
            ));
        }
        if !mean.is_finite() {
            return Some(judged(
                Verdict::NonFinite,
                format!("the true mean speed is {mean}"),
            ));
        }
        None
    }

    /// `stopped` (told to stop, at rest) or `gave-up` (the controller switched off).
    fn stopped_or_gave_up(&self, end: &Ending, restarts_in_window: u32) -> Option<Judgement> {
        let r = &self.rule;
        let cmd = end.command_rpm;
        if cmd == 0.0 && end.speed_rms_rpm < r.rest_rpm && restarts_in_window == 0 {
            return Some(judged(
                Verdict::Stopped,
                format!(
                    "told to stop, the rotor is at rest: rms true speed {:.2} rpm over the window (rule < {} rpm), no restart there ({} in the run)",
                    end.speed_rms_rpm, r.rest_rpm, end.restarts.0
                ),
            ));
        }
        if end.gave_up {
            return Some(judged(
                Verdict::GaveUp,
                format!(
                    "the controller switched off after {} restarts (limit {})",
                    end.restarts.0, end.restarts.1
                ),
            ));
        }
        None
    }

    /// `not-started` (the rotor never followed the commutation) or `stalled`.
    fn not_started_or_stalled(&self, end: &Ending) -> Option<Judgement> {
        let r = &self.rule;
        let cmd = end.command_rpm;
        let mean = end.speed_mean_rpm;
        if self.started_at_s.is_none() {
            let why = if self.handed_over {
                format!(
                    "the controller reached closed loop but the rotor never followed {} electrical turns of its commutation (within ±{}°)",
                    r.started_turns, r.sync_error_deg
                )
            } else {
                "the controller never reached closed loop".to_string()
            };
            return Some(judged(
                Verdict::NotStarted,
                format!(
                    "{why}; true mean speed {mean:.1} rpm, controller's estimate {:.0} rpm, {} restarts",
                    end.chip_speed_rpm, end.restarts.0
                ),
            ));
        }
        if mean.abs() < r.stalled_fraction * cmd {
            return Some(judged(
                Verdict::Stalled,
                format!(
                    "true mean speed {mean:.1} rpm, below {:.0} % of the {cmd:.0} rpm command (controller's estimate {:.0} rpm)",
                    100.0 * r.stalled_fraction,
                    end.chip_speed_rpm
                ),
            ));
        }
        None
    }

    /// `lost-sync`: out of closed loop in the window, or its commutations out of
    /// synchronism with the rotor or not as many as the states it passed.
    fn out_of_sync(&self, end: &Ending, restarts_in_window: u32) -> Option<Judgement> {
        let r = &self.rule;
        let mean = end.speed_mean_rpm;
        if restarts_in_window > 0 || self.window_left_closed_loop {
            return Some(judged(
                Verdict::LostSync,
                format!(
                    "the controller was not in closed loop throughout the steady-state window ({restarts_in_window} of its {} restarts there)",
                    end.restarts.0
                ),
            ));
        }
        let WindowSync {
            share,
            n,
            passed,
            slack,
        } = self.window_sync(end);
        if share < r.sync_share || (n - passed).abs() > slack {
            return Some(judged(
                Verdict::LostSync,
                format!(
                    "{:.0} % of {n:.0} commutations within ±{}° of the true angle (rule ≥ {:.0} %), the rotor passed {passed:.0} states; true mean {mean:.1} rpm, controller's estimate {:.0} rpm",
                    100.0 * share,
                    r.sync_error_deg,
                    100.0 * r.sync_share,
                    end.chip_speed_rpm
                ),
            ));
        }
        None
    }

    fn window_sync(&self, end: &Ending) -> WindowSync {
        // States the rotor passed through in the window, from its true mean speed.
        let passed = f64::from(self.states_per_turn)
            * (end.speed_mean_rpm / 60.0 * f64::from(end.pole_pairs) * end.window_s).abs();
        let slack = f64::from(self.states_per_turn) + 0.02 * passed;
        let n = self.window_commutations as f64;
        let share = if n > 0.0 {
            self.window_in_sync as f64 / n
        } else {
            0.0
        };
        WindowSync {
            share,
            n,
            passed,
            slack,
        }
    }

    /// In synchronism and settled: `off-speed` or `running`.
    fn on_speed(&self, end: &Ending) -> Judgement {
        let r = &self.rule;
        let cmd = end.command_rpm;
        let mean = end.speed_mean_rpm;
        let WindowSync { share, n, .. } = self.window_sync(end);
        // A command below 1 rpm is judged against 1 rpm (no stopped verdict yet).
        let off = (mean - cmd) / cmd.max(1.0);
        if off.abs() > r.speed_tolerance {
            return judged(
                Verdict::OffSpeed,
                format!(
                    "in synchronism, true mean {mean:.1} rpm against the {cmd:.0} rpm command ({:+.1} %, tolerance ±{:.0} %)",
                    100.0 * off,
                    100.0 * r.speed_tolerance
                ),
            );
        }
        judged(
            Verdict::Running,
            format!(
                "in synchronism ({:.1} % of {n:.0} commutations within ±{}°), true mean {mean:.1} rpm ({:+.2} % of the command)",
                100.0 * share,
                r.sync_error_deg,
                100.0 * off
            ),
        )
    }
}

impl Witness {
    /// The `unsettled` verdict of a window that began before the first hand-over (see
    /// the module doc).
    fn in_start_up(&self, end: &Ending) -> Option<Judgement> {
        let w0 = self.window_from_s?;
        // A restart anywhere in the run is a start-up that failed once: judged as such.
        if end.restarts.0 > 0 {
            return None;
        }
        let (why, from) = match self.handover {
            // The hand-over is not known: after the run's end, at least.
            None => (
                "the run ended before the first hand-over to closed loop".to_string(),
                self.settle.last.map_or(w0, |l| l.0.max(w0)),
            ),
            Some((t, _)) if t > w0 => (
                format!("the first hand-over to closed loop came at {t:.3} s"),
                t,
            ),
            _ => return None,
        };
        Some(Self::not_judged(
            format!("the steady-state window began at {w0:.3} s, inside the start-up: {why}"),
            from,
        ))
    }

    /// The `unsettled` verdict of a drive in synchronism whose speed was still settling
    /// into its tolerance in the window's first half (see the module doc).
    fn settling(&self, end: &Ending) -> Option<Judgement> {
        let w0 = self.window_from_s?;
        let s = &self.settle;
        let settled = s.last_off_s?;
        let end_s = s.last?.0;
        // Off from the window's start, last off in its first half, inside since: settling
        // (a ringing that decays may cross the band's edge more than once). A limit cycle
        // slower than twice the window looks the same here; `crate::scenario::settled`'s
        // rerun, whose window begins after this instant, sees it leave the band again.
        if s.command_moved || s.off_now || s.first_off != Some(true) || settled > (w0 + end_s) / 2.0
        {
            return None;
        }
        Some(Self::not_judged(
            format!(
                "the steady-state window began at {w0:.3} s, before the speed settled: the true speed (low-passed over {:.0} ms) came within ±{:.0} % of the {:.0} rpm command only at {settled:.3} s",
                SETTLE_TAU_S * 1e3,
                100.0 * self.rule.speed_tolerance,
                end.command_rpm
            ),
            settled,
        ))
    }

    fn not_judged(why: String, from: f64) -> Judgement {
        Judgement {
            verdict: Verdict::Unsettled,
            reason: format!(
                "not judged: {why}; a hold of at least {:.2} s (its window the last third) begins its window after that",
                shortest_hold_s(from)
            ),
            judge_after_s: Some(from),
        }
    }
}

// The streak so far; the tolerance and the length needed are the rule's.
drive_core::persist_fields!(SyncStreak { streak });
// The judgement so far; the rule is a parameter.
drive_core::persist_fields!(LiveVerdict {
    streak,
    started,
    lost,
    mean_rpm,
    last_t_s
});

#[cfg(test)]
mod tests {
    use super::*;

    fn ending(mean: f64) -> Ending {
        Ending {
            command_rpm: 3000.0,
            speed_mean_rpm: mean,
            speed_rms_rpm: mean.abs(),
            window_s: 1.0,
            pole_pairs: 6,
            chip_speed_rpm: 3000.0,
            restarts: (0, 5),
            gave_up: false,
        }
    }

    /// A rotor at `rpm` commutated by a twelve-step table with errors `err` (cycled).
    fn witness(rpm: f64, err: &[f64], window_s: f64) -> Witness {
        let mut w = Witness::new(VerdictRule::default(), 12);
        // 3000 rpm, 6 pole pairs: 300 electrical turns per second, 3600 commutations.
        let n = (12.0 * rpm / 60.0 * 6.0 * window_s).round() as usize;
        for k in 0..n {
            let t = 2.0 + window_s * k as f64 / n as f64;
            w.instant(t, true, 0, true, true);
            w.commutation(
                t,
                30.0 * (k % 12) as f64 + err[k % err.len()],
                30.0 * (k % 12) as f64,
                rpm,
                true,
            );
        }
        w
    }

    #[test]
    fn a_locked_drive_at_its_command_runs() {
        let j = witness(3000.0, &[2.0, -3.0, 5.0], 1.0).judge(&ending(2990.0));
        assert_eq!(j.verdict, Verdict::Running, "{}", j.reason);
    }

    #[test]
    fn in_sync_but_off_the_command_is_off_speed() {
        let j = witness(2900.0, &[2.0], 1.0).judge(&ending(2900.0));
        assert_eq!(j.verdict, Verdict::OffSpeed, "{}", j.reason);
        assert!(j.reason.contains("-3.3 %"), "{}", j.reason);
    }

    #[test]
    fn errors_spread_over_the_circle_are_lost_sync() {
        // After a good start, 1 commutation in 4 more than 30° off: 75 % < 95 %.
        let mut w = witness(3000.0, &[0.0], 0.1);
        for k in 0..3600 {
            let e = if k % 4 == 0 { 100.0 } else { 1.0 };
            w.commutation(2.1 + k as f64 / 3600.0, e, 0.0, 3000.0, true);
        }
        let j = w.judge(&ending(3000.0));
        assert_eq!(j.verdict, Verdict::LostSync, "{}", j.reason);
    }

    #[test]
    fn commutating_faster_than_the_rotor_turns_is_lost_sync() {
        // Every commutation on its boundary, but twice as many as a 3000 rpm rotor passes.
        let w = witness(6000.0, &[0.0], 1.0);
        assert_eq!(w.judge(&ending(3000.0)).verdict, Verdict::LostSync);
        // One turn's states more is within the slack.
        let mut w = witness(3000.0, &[0.0], 1.0);
        for k in 0..12 {
            w.commutation(3.0, 30.0 * k as f64, 30.0 * k as f64, 3000.0, true);
        }
        assert_eq!(w.judge(&ending(3000.0)).verdict, Verdict::Running);
    }

    #[test]
    fn a_rotor_that_never_followed_did_not_start_and_a_stopped_one_stalled() {
        // 23 good commutations, one bad, 23 good: never 24 in a row.
        let mut w = Witness::new(VerdictRule::default(), 12);
        for k in 0..47 {
            w.instant(1.0, true, 0, true, false);
            w.commutation(1.0, if k == 23 { 90.0 } else { 0.0 }, 0.0, 0.0, false);
        }
        let j = w.judge(&ending(0.0));
        assert_eq!(j.verdict, Verdict::NotStarted, "{}", j.reason);
        assert!(j.reason.contains("reached closed loop"), "{}", j.reason);
        assert_eq!(
            Witness::new(VerdictRule::default(), 12)
                .judge(&ending(0.0))
                .verdict,
            Verdict::NotStarted
        );
        w.commutation(1.0, 0.0, 0.0, 0.0, false);
        assert_eq!(w.started_at_s(), Some(1.0));
        assert_eq!(w.sync_lost(), None);
        w.commutation(1.5, 45.0, 0.0, 250.0, false);
        w.commutation(1.6, 90.0, 0.0, 200.0, false);
        assert_eq!(
            w.sync_lost(),
            Some((1.5, 250.0)),
            "the first slip after the start"
        );
        assert_eq!(w.judge(&ending(299.0)).verdict, Verdict::Stalled);
    }

    #[test]
    fn give_up_and_non_finite_come_first() {
        let mut w = witness(3000.0, &[0.0], 1.0);
        let mut e = ending(3000.0);
        e.gave_up = true;
        assert_eq!(w.judge(&e).verdict, Verdict::GaveUp);
        assert_eq!(w.judge(&ending(f64::NAN)).verdict, Verdict::NonFinite);
        w.instant(2.5, true, 0, false, true);
        assert_eq!(w.judge(&ending(3000.0)).verdict, Verdict::NonFinite);
    }

    #[test]
    fn a_restart_in_the_window_is_lost_sync() {
        let mut w = witness(3000.0, &[0.0], 1.0);
        w.instant(2.9, false, 1, true, true);
        let j = w.judge(&Ending {
            restarts: (1, 5),
            ..ending(3000.0)
        });
        assert_eq!(j.verdict, Verdict::LostSync, "{}", j.reason);
    }

    /// A witness of a drive handed over at `handover_s` and started at once, whose
    /// window (from 2 s to 3 s) sees the true speed `rpm(t)` ten times a commutation
    /// under a 3000 rpm command, in synchronism (3600 commutations a second).
    fn settling(handover_s: f64, rpm: impl Fn(f64) -> f64) -> Witness {
        let mut w = Witness::new(VerdictRule::default(), 12);
        for k in 0..108_000 {
            let t = f64::from(k) / 36_000.0;
            let in_window = t >= 2.0;
            w.instant(t, t >= handover_s, 0, true, in_window);
            w.speed(t, rpm(t), 3000.0, in_window);
            if t >= handover_s && k % 10 == 0 {
                let b = 30.0 * f64::from(k / 10 % 12);
                w.commutation(t, b, b, rpm(t), in_window);
            }
        }
        w
    }

    #[test]
    fn a_window_before_the_hand_over_is_unsettled_and_names_it() {
        let j = settling(2.4, |_| 3000.0).judge(&ending(3000.0));
        assert_eq!(j.verdict, Verdict::Unsettled, "{}", j.reason);
        assert!(
            j.reason
                .contains("hand-over to closed loop came at 2.400 s"),
            "{}",
            j.reason
        );
        // 1.5 × 2.4 s: the window (the last third) of a 3.6 s hold begins at 2.4 s.
        assert!(j.reason.contains("at least 3.60 s"), "{}", j.reason);
        assert_eq!(j.judge_after_s, Some(2.4));
        // A restart in the run: the start-up failed once, not a short run.
        let restarted = Ending {
            restarts: (1, 5),
            ..ending(3000.0)
        };
        assert_ne!(
            settling(2.4, |_| 3000.0).judge(&restarted).verdict,
            Verdict::Unsettled
        );
        // No hand-over at all: the instant named is the run's end, not the window's start.
        let j = settling(9.0, |_| 3000.0).judge(&ending(3000.0));
        assert_eq!(j.verdict, Verdict::Unsettled, "{}", j.reason);
        assert!(j.judge_after_s.unwrap() > 2.99, "{:?}", j.judge_after_s);
        assert_eq!(
            settling(1.0, |_| 3000.0).judge(&ending(3000.0)).verdict,
            Verdict::Running
        );
    }

    #[test]
    fn a_speed_settling_in_the_first_half_is_unsettled_and_hunting_is_not() {
        // 5 % over the command, decaying with τ = 0.1 s from 2 s: within the 2 % band
        // (low-passed, a lag of ≈ 20 ms) after 2 + 0.1·ln 2.5 ≈ 2.092 s.
        let overshoot = |t: f64| 3000.0 * (1.0 + 0.05 * (-(t - 2.0).max(0.0) / 0.1).exp());
        let j = settling(1.0, overshoot).judge(&ending(3000.0));
        assert_eq!(j.verdict, Verdict::Unsettled, "{}", j.reason);
        let at = j.judge_after_s.unwrap();
        assert!((2.09..2.13).contains(&at), "{at}");
        // Hunting ±5 % at 10 Hz (±3.1 % low-passed) through the whole window: off the
        // band in its second half too, so judged as is (its mean is the command).
        let hunting = |t: f64| 3000.0 * (1.0 + 0.05 * (std::f64::consts::TAU * 10.0 * t).sin());
        let j = settling(1.0, hunting).judge(&ending(3000.0));
        assert_eq!(j.verdict, Verdict::Running, "{}", j.reason);
        // In the band at the window's start, off, then back (a disturbance in the first
        // half): not a start-up's settling, judged as is.
        let bump = |t: f64| {
            if (2.1..2.2).contains(&t) {
                3300.0
            } else {
                3000.0
            }
        };
        let j = settling(1.0, bump).judge(&ending(3000.0));
        assert_ne!(j.verdict, Verdict::Unsettled, "{}", j.reason);
        // Off only in the second half (a late disturbance): judged as is, not unsettled.
        let late = |t: f64| {
            if (2.6..2.7).contains(&t) {
                3300.0
            } else {
                3000.0
            }
        };
        assert_ne!(
            settling(1.0, late).judge(&ending(3000.0)).verdict,
            Verdict::Unsettled
        );
    }

    #[test]
    fn the_shortest_hold_begins_its_window_at_the_instant() {
        for t in [0.1, 0.75, 0.999, 1.0, 1.2, 2.0, 7.5] {
            let d = shortest_hold_s(t);
            assert!((hold_window_from_s(d) - t).abs() < 1e-12, "{t}: {d}");
            // And no shorter hold does.
            assert!(hold_window_from_s(d - 1e-3) < t, "{t}");
        }
    }

    #[test]
    fn exit_codes_are_distinct_and_zero_only_on_success() {
        let mut codes: Vec<i32> = Verdict::ALL.iter().map(|v| v.exit_code()).collect();
        for (v, c) in Verdict::ALL.iter().zip(&codes) {
            assert_eq!(*c == 0, v.is_success(), "{v}");
        }
        codes.sort();
        codes.dedup();
        // Running and stopped share 0; every failure has its own code.
        assert_eq!(codes.len(), Verdict::ALL.len() - 1);
        assert!(!codes[1..].contains(&1) && !codes.contains(&2));
    }

    #[test]
    fn a_zero_command_with_the_rotor_at_rest_and_no_restart_there_is_stopped() {
        let w = witness(3000.0, &[0.0], 1.0);
        let stop = Ending {
            command_rpm: 0.0,
            speed_rms_rpm: 0.3,
            ..ending(0.0)
        };
        assert_eq!(w.judge(&stop).verdict, Verdict::Stopped);
        // Still turning at 6 rpm rms: not at rest, so judged as a speed command.
        let turning = Ending {
            speed_rms_rpm: 6.0,
            ..stop
        };
        assert_ne!(w.judge(&turning).verdict, Verdict::Stopped);
        // A restart in the window: the chip started the rotor it was told to stop.
        let mut w = witness(3000.0, &[0.0], 1.0);
        w.instant(2.9, false, 1, true, true);
        let restarted = Ending {
            restarts: (1, 5),
            ..stop
        };
        assert_eq!(w.judge(&restarted).verdict, Verdict::LostSync);
        // A non-zero command is never stopped, however still the rotor.
        assert_ne!(w.judge(&ending(0.0)).verdict, Verdict::Stopped);
    }

    #[test]
    fn the_live_verdict_follows_start_slip_and_speed() {
        // Six states a turn: two turns in synchronism make a start.
        let mut v = LiveVerdict::new(VerdictRule::default(), 6);
        v.speed(0.0, 0.0);
        assert_eq!(v.verdict(3000.0, true, false), Verdict::NotStarted);
        for k in 0..12 {
            v.commutation(f64::from(k) * 60.0 + 5.0, f64::from(k) * 60.0);
        }
        // Started, but the low-passed speed is still 0: stalled.
        assert_eq!(v.verdict(3000.0, true, false), Verdict::Stalled);
        // 3000 rpm held for 10 τ: the low-pass is within 5e-5 of it.
        for k in 1..=1000 {
            v.speed(f64::from(k) * 1e-3, 3000.0);
        }
        assert!((v.mean_rpm() - 3000.0).abs() < 0.15, "{}", v.mean_rpm());
        assert_eq!(v.verdict(3000.0, true, false), Verdict::Running);
        assert_eq!(v.verdict(3200.0, true, false), Verdict::OffSpeed);
        // A commutation 40° off: lost until two turns in synchronism again.
        v.commutation(100.0, 60.0);
        assert_eq!(v.verdict(3000.0, true, false), Verdict::LostSync);
        for k in 0..12 {
            v.commutation(f64::from(k) * 60.0, f64::from(k) * 60.0);
        }
        assert_eq!(v.verdict(3000.0, true, false), Verdict::Running);
        assert_eq!(v.verdict(3000.0, false, false), Verdict::NonFinite);
        assert_eq!(v.verdict(3000.0, true, true), Verdict::GaveUp);
        v.restart();
        assert_eq!(v.verdict(3000.0, true, false), Verdict::NotStarted);
    }
}
