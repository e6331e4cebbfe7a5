//! The chip as one controller: start-up, supervision, phase shifter, guard and the
//! speed/current cascade, each on its own clock (docs/chip.md).
//!
//! Every internal event (end of an alignment step, post → pre commutation, opening of a
//! linear-region window, digital-filter settling, PI update, step-miss deadline) falls on a
//! 0.64 µs edge and is requested through `wake_at`, so the engine calls [`Chip::tick`] at
//! every edge where something happens and the counters catch up in between.

mod cascade;
mod commutation;
mod inputs;
mod persist;
mod resume;
mod startup;
mod wake;

use crate::guard::Guard;
use crate::params::{ControlParams, StrategyName, StrategyParams};
use crate::pi::{Pi, PiGains};
use crate::shifter::PhaseShifter;
use crate::speed::SpeedMeter;
use crate::supervisor::Supervisor;
use crate::table::Table;
use cascade::read_spacing;
pub use cascade::scheduled_duty;
use drive_core::bridge::{ALL_FLOAT, LegState};
use drive_core::error::ParamError;
use drive_core::{Abc, Command, Controller, Pattern, Sensed, Ticks, clocks};

/// Master clocks the start input must be held before start-up begins (docs/chip.md).
pub const START_DEBOUNCE: Ticks = Ticks(31);

/// Blanking after a commutation before a pre-crossing level counts as genuine \[ticks\]:
/// 10 µs, well above the comparator's response (≈ 1 µs RC + 0.1 µs) plus the filter's.
pub const BLANKING: Ticks = Ticks(500);

/// Range of the current PI's integrator relative to its output limit: the chip's 23-bit
/// anti-windup path holds up to 2^23 − 1 where the limit is 4 096 000 (= 2000 counts ×
/// 2048), so without anti-windup the integrator can wind to ≈ 2.05× full duty (docs/chip.md).
pub const CURRENT_INTEGRATOR_HEADROOM: f64 = ((1u64 << 23) - 1) as f64 / 4_096_000.0;

/// Duty step per ampere of phase-current error at each PI update of the alignment by
/// current (`control.align_current_a`) \[1/A\]. The phase current moves by ≈ V_DD/(2R) per
/// unit of duty, 10.6 A on a 0.4 Ω winding (a loop gain of 0.53 per update: monotone) and
/// 1.9 A at 3 Ω (0.1: 95 % in 30 updates, 0.16 s of the 0.7 s first step).
pub const ALIGN_GAIN: f64 = 0.05;

/// The three alignment patterns u→v, v→w, v→u (flags 0100, 0000, 0001).
pub const ALIGN_PATTERNS: [Pattern; 3] = {
    use LegState::{Float as F, High as V, Low as G};
    [
        Abc { u: V, v: G, w: F },
        Abc { u: F, v: V, w: G },
        Abc { u: G, v: V, w: F },
    ]
};

/// The sector the closed loop starts in: pre pattern w→v (u floating; state 12, or 1 in
/// six-step), the state for θe = 330..360°. The last alignment pattern v→u has zero
/// torque at 330° (T ∝ −√3·cos(θe − 60°)) and pulls the rotor there, so starting in its
/// own sector (v→u, waiting for w's crossing at 240°) would wait for a crossing the rotor
/// has passed, with no torque to move it; w→v gives 0.87 of its peak torque at 330°.
const HANDOVER_SECTOR: usize = 5;

/// What the chip is doing.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Bridge off (flag 0110), waiting for the start input.
    Off,
    /// Alignment step 0..2, ending at the given instant.
    Aligning {
        /// Step index.
        step: u8,
        /// When it ends.
        until: Ticks,
    },
    /// Closed-loop sensorless commutation.
    Running,
    /// Too many restarts: off until reset.
    GaveUp,
}

/// Observable state of the chip (for traces, tests and the FMU).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ChipStatus {
    /// Mode.
    pub mode: Mode,
    /// Commutation state (1..12 twelve-step, 1..6 six-step), 0 when off or starting.
    pub state: u8,
    /// Bridge flag of the pattern in force.
    pub flag: u8,
    /// Raw Z_d (selected comparator) at the chip's last tick. In the post part the chip
    /// does not watch the comparators (nothing is detected there), so this holds the level
    /// seen at the crossing until the next tick.
    pub zd: bool,
    /// Z_d after the guard's filter (equal to `zd` without one), same instant as `zd`.
    pub zdf: bool,
    /// Inside a linear region (PWM stopped).
    pub linear: bool,
    /// Voltage command in force [carrier counts].
    pub duty: u32,
    /// FG speed measurement \[rpm\].
    pub speed_est_rpm: u32,
    /// Current command from the speed PI \[A\].
    pub current_ref_a: f64,
    /// Integrator of the current PI [carrier counts]; above the carrier top only without
    /// anti-windup (wound up).
    pub current_integrator: f64,
    /// Restarts so far (step-miss errors).
    pub restarts: u32,
    /// Accepted zero crossings since the last hand-over.
    pub crossings: u64,
    /// Of those, crossings taken by the demagnetisation timeout.
    pub forced_crossings: u64,
}

/// The chip's controller.
#[derive(Clone, Debug)]
pub struct Chip {
    name: StrategyName,
    control: ControlParams,
    /// `control.step_miss_s` in step-miss clocks (a parameter; the deadline is asked for at
    /// every tick).
    step_miss_clocks: u64,
    table: Table,
    /// The table after start-up (the configured angle); `table` until then.
    run_table: Table,
    /// A table set since the last tick: the shifter takes it at the end of the next one,
    /// so that the channels that tick reads were declared under the table it uses.
    pending_table: Option<Table>,
    guard: Guard,
    shifter: PhaseShifter,
    speed: SpeedMeter,
    speed_pi: Pi,
    /// The phase current the speed PI's integrator stood for at its last update off both
    /// its limits \[A\] (`control.speed_resume`).
    held_phase_a: f64,
    /// The speed PI's reference while it descends after a start \[rpm\] (0: none;
    /// `control.start_descent_rpm_s`).
    descent_rpm: f64,
    current_pi: Pi,
    supervisor: Supervisor,
    /// FG measurements the supervisor has seen.
    measurements_seen: u64,
    /// A linear region (full voltage) was in force at some tick since the last PI update.
    linear_seen: bool,
    pole_pairs: u32,
    amps_per_code: f64,
    top: u32,
    start: bool,
    start_since: Ticks,
    reset: bool,
    speed_ref_rpm: f64,
    mode: Mode,
    restarts: u32,
    fg: bool,
    fg_since: Ticks,
    cv: u32,
    i_ref: f64,
    linear: bool,
    zd: bool,
    zdf: bool,
    next_pi: Ticks,
    /// Spacing of the current reads averaged per PI update (`control.current_reads`): a
    /// carrier period over their number, on the 0.64 µs clock (a parameter).
    read_spacing: Ticks,
    /// Read slots of the coming PI update passed so far, the codes read in them and how
    /// many were read (a slot passed while the chip was not running is not read).
    read_slot: u32,
    read_sum: u32,
    read_count: u32,
    crossings: u64,
    pattern: Pattern,
}

fn counts(seconds: f64, clock: Ticks) -> u64 {
    (seconds / clock.seconds()).round().max(1.0) as u64
}

impl Chip {
    /// Builds the chip for a motor with `pole_pairs` (P/2), an ADC reading `amps_per_code`,
    /// and a PWM carrier of top `carrier_top` counts. The start input is held from t = 0.
    pub fn new(
        control: ControlParams,
        strategy: StrategyParams,
        pole_pairs: u32,
        amps_per_code: f64,
        carrier_top: u32,
    ) -> Result<Self, ParamError> {
        control.validate()?;
        strategy.validate()?;
        if !(amps_per_code.is_finite() && amps_per_code > 0.0) {
            return Err(ParamError::new(
                "sensing.current (A per ADC code)",
                amps_per_code,
                "must be finite and > 0",
            ));
        }
        let table = strategy.table();
        let top = carrier_top.max(1);
        // The speed PI's integrator is clamped at the current limit (no headroom), which
        // caps its windup there; back-calculation on it is a model option, not the chip's.
        let speed_pi = Pi::new(
            PiGains {
                kp: control.speed_kp,
                ki: control.speed_ki,
                lo: 0.0,
                hi: control.current_limit_a,
                ui_hi: control.current_limit_a,
                k_s: if control.speed_anti_windup {
                    control.speed_anti_windup_gain
                } else {
                    0.0
                },
            },
            0.0,
        );
        let current_pi = Pi::new(
            PiGains {
                kp: control.current_kp,
                ki: control.current_ki,
                lo: 0.0,
                hi: f64::from(top),
                ui_hi: f64::from(top) * CURRENT_INTEGRATOR_HEADROOM,
                k_s: if control.anti_windup {
                    control.anti_windup_gain
                } else {
                    0.0
                },
            },
            0.0,
        );
        Ok(Chip {
            name: strategy.name,
            table,
            run_table: table,
            pending_table: None,
            guard: Guard::from_params(&strategy),
            shifter: PhaseShifter::new(table, BLANKING),
            speed: SpeedMeter::windowed(
                control.speed_periods,
                control.speed_counter_bits,
                pole_pairs,
                (control.speed_window_s > 0.0)
                    .then(|| Ticks::from_seconds(control.speed_window_s))
                    .flatten(),
            ),
            speed_pi,
            held_phase_a: 0.0,
            descent_rpm: 0.0,
            current_pi,
            supervisor: Supervisor::new(&control),
            measurements_seen: 0,
            linear_seen: false,
            pole_pairs: pole_pairs.max(1),
            amps_per_code,
            top,
            start: true,
            start_since: Ticks::ZERO,
            reset: false,
            speed_ref_rpm: control.speed_ref_rpm,
            mode: Mode::Off,
            restarts: 0,
            fg: false,
            fg_since: Ticks::ZERO,
            cv: 0,
            i_ref: 0.0,
            linear: false,
            zd: false,
            zdf: false,
            next_pi: Ticks::NEVER,
            read_spacing: read_spacing(top, control.current_reads),
            read_slot: 0,
            read_sum: 0,
            read_count: 0,
            crossings: 0,
            pattern: ALL_FLOAT,
            step_miss_clocks: counts(control.step_miss_s, clocks::STEP_MISS),
            control,
        })
    }

    /// A command of 0 with `stop_at_zero`: off, and no start until it rises.
    fn told_to_stop(&self) -> bool {
        self.control.stop_at_zero && self.speed_ref_rpm == 0.0
    }

    fn duty(&self) -> u32 {
        if self.linear { self.top } else { self.cv }
    }

    fn switch_off(&mut self) {
        self.mode = Mode::Off;
        self.pattern = ALL_FLOAT;
        self.cv = 0;
        self.linear = false;
        self.next_pi = Ticks::NEVER;
        self.clear_reads();
    }
}

impl crate::Strategy for Chip {
    fn name(&self) -> &str {
        self.name.as_str()
    }
    fn status(&self) -> ChipStatus {
        Chip::status(self)
    }
    fn table(&self) -> Table {
        self.table
    }
    fn set_start(&mut self, now: Ticks, level: bool) {
        Chip::set_start(self, now, level)
    }
    fn set_reset(&mut self, level: bool) {
        Chip::set_reset(self, level)
    }
    fn set_speed_ref(&mut self, rpm: f64) {
        Chip::set_speed_ref(self, rpm)
    }
    fn speed_ref_rpm(&self) -> f64 {
        Chip::speed_ref_rpm(self)
    }
    fn set_conduction_angle(&mut self, deg: f64) -> Result<(), ParamError> {
        Chip::set_conduction_angle(self, deg)
    }
    fn try_clone(&self) -> Result<Box<dyn crate::Strategy>, String> {
        Ok(Box::new(self.clone()))
    }
    fn save_state(&self, w: &mut drive_core::Writer) {
        drive_core::Persist::save(self, w);
    }
    fn restore_state(&mut self, r: &mut drive_core::Reader) -> Result<(), String> {
        drive_core::Persist::restore(self, r)
    }
}

impl Controller for Chip {
    fn clock(&self) -> Ticks {
        clocks::COMMUTATION
    }

    /// The instants the chip keeps against the engine's `now`: the start input's and FG's
    /// last changes passed, the next PI update within a PI period (or none), an alignment
    /// step's end no later than one begun now would end, and the speed meter's, the
    /// shifter's and the guard filter's instants as they check them.
    fn check_restored(&self, now: Ticks) -> Result<(), String> {
        use drive_core::state::check;
        for (name, t) in [
            ("start_since", self.start_since),
            ("fg_since", self.fg_since),
        ] {
            check(t <= now, || {
                format!("{name} = {} (rule: an instant by now = {})", t.0, now.0)
            })?;
        }
        let pi = now.0.saturating_add(clocks::PI_UPDATE.0);
        check(self.next_pi == Ticks::NEVER || self.next_pi.0 <= pi, || {
            format!(
                "next_pi = {} (rule: within a PI period after now, by {pi}, or none)",
                self.next_pi.0
            )
        })?;
        if let Mode::Aligning { step, until } = self.mode {
            let end = self.align_end(now, usize::from(step));
            check(until <= end, || {
                format!(
                    "mode.until = {} (rule: the end of alignment step {step}, no later than one begun now, {})",
                    until.0, end.0
                )
            })?;
        }
        self.speed.check_at(now)?;
        self.shifter.check_at(now)?;
        self.guard.filter.check_at(now)
    }

    /// The end of the post part (the commutation to the sector's pre pattern) or of an
    /// alignment step before the last (the next alignment pattern): both are timed.
    fn planned_change(&self) -> Option<(Ticks, Pattern)> {
        match self.mode {
            Mode::Running => Some((self.shifter.post_end()?, self.shifter.sector().pre)),
            Mode::Aligning { step, until } => {
                Some((until, *ALIGN_PATTERNS.get(usize::from(step) + 1)?))
            }
            Mode::Off | Mode::GaveUp => None,
        }
    }

    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command {
        if self.reset {
            self.switch_off();
            self.restarts = 0;
        } else {
            match self.mode {
                Mode::Off => {
                    if self.start
                        && !self.told_to_stop()
                        && now.0 >= self.start_since.0 + START_DEBOUNCE.0
                    {
                        self.begin_align(now);
                    }
                }
                Mode::GaveUp => {}
                Mode::Aligning { step, until } => {
                    if self.start && self.next_pi != Ticks::NEVER {
                        // Alignment by current, first step: reads and PI updates.
                        self.take_reads(now, sensed.current_code);
                        if now >= self.next_pi {
                            self.align_update(sensed.current_code);
                            while self.next_pi <= now {
                                self.next_pi += clocks::PI_UPDATE;
                            }
                        }
                    }
                    if !self.start || self.told_to_stop() {
                        self.switch_off();
                    } else if now >= until {
                        let next = usize::from(step) + 1;
                        if next < ALIGN_PATTERNS.len() {
                            self.mode = Mode::Aligning {
                                step: next as u8,
                                until: self.align_end(now, next),
                            };
                            self.pattern = ALIGN_PATTERNS[next];
                            // The duty reached is held for the other steps.
                            self.next_pi = Ticks::NEVER;
                            self.clear_reads();
                        } else {
                            self.hand_over(now);
                            self.run(now, sensed);
                        }
                    }
                }
                Mode::Running => {
                    if self.start && !self.told_to_stop() {
                        self.run(now, sensed);
                    } else {
                        self.switch_off();
                    }
                }
            }
        }
        if let Some(t) = self.pending_table.take() {
            self.shifter.set_table(t);
        }
        let watch = if self.mode == Mode::Running && self.shifter.in_pre() {
            let zd = self.shifter.zd_phase();
            Abc::from_fn(|x| x == zd)
        } else {
            Abc::splat(false)
        };
        let reads = match self.mode {
            Mode::Running => self.shifter.zd_reads(),
            // The hand-over at the end of the alignment reads Z_d at once.
            Mode::Aligning { .. } => Command::READS_ALL,
            Mode::Off | Mode::GaveUp => Abc::splat(Ticks::NEVER),
        };
        Command {
            pattern: self.pattern,
            duty: self.duty(),
            watch,
            reads,
            wake_at: self.wake_at(now),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(super) fn chip(max_restarts: u32) -> Chip {
        let control = ControlParams {
            max_restarts,
            ..ControlParams::default()
        };
        Chip::new(control, StrategyParams::default(), 6, 0.5 / 4095.0, 2000).unwrap()
    }

    /// Runs the chip the way the engine does with constant inputs: at t = 0, then at each
    /// requested wake-up (rounded up to the 0.64 µs clock). Returns (instant, command).
    pub(super) fn next(c: &mut Chip, now: &mut Ticks, cmd: &Command) -> Command {
        *now = next_edge(*now, cmd);
        c.tick(*now, &Sensed::default())
    }

    /// A chip running as the engine runs it, restored: each register, count and instant
    /// forged out of its rule is refused naming it, and the chip as it was is accepted.
    #[test]
    fn restored_registers_counts_and_instants_keep_their_rules() {
        use drive_core::Persist;
        let mut c = chip(5);
        let mut now = Ticks::ZERO;
        let mut cmd = c.tick(now, &Sensed::default());
        while c.status().mode == Mode::Off || now < Ticks(40_000) {
            cmd = next(&mut c, &mut now, &cmd);
        }
        let restore = |c: &Chip| {
            let mut r = chip(5);
            r.restore_from(&c.to_bytes().unwrap())
                .and_then(|()| Controller::check_restored(&r, now))
        };
        restore(&c).unwrap();
        let refused = |edit: &dyn Fn(&mut Chip), want: &str| {
            let mut f = c.clone();
            edit(&mut f);
            let e = restore(&f).unwrap_err();
            assert!(e.starts_with(want), "{want}: {e}");
        };
        refused(
            &|f| f.i_ref = 1e30,
            "i_ref = 1000000000000000000000000000000 (rule: 0..=",
        );
        refused(&|f| f.i_ref = -1e-3, "i_ref = -0.001 (rule:");
        refused(&|f| f.held_phase_a = -1.0, "held_phase_a = -1 (rule: 0..=");
        refused(&|f| f.descent_rpm = -5.0, "descent_rpm = -5 (rule: 0..=");
        refused(
            &|f| f.descent_rpm = 1e30,
            "descent_rpm = 1000000000000000000000000000000 (rule: 0..=",
        );
        refused(
            &|f| f.restarts = 6,
            "restarts = 6 (rule: at most control.max_restarts = 5",
        );
        refused(
            &|f| f.measurements_seen = 1,
            "measurements_seen = 1 (rule: at most the 0",
        );
        refused(&|f| f.start_since = Ticks(now.0 + 1), "start_since = ");
        refused(&|f| f.fg_since = Ticks(u64::MAX - 5), "fg_since = ");
        refused(
            &|f| f.next_pi = Ticks(now.0 + clocks::PI_UPDATE.0 + 1),
            "next_pi = ",
        );
        if let Mode::Aligning { step, .. } = c.mode {
            refused(
                &|f| {
                    f.mode = Mode::Aligning {
                        step,
                        until: Ticks(u64::MAX - 1),
                    }
                },
                "mode.until = ",
            );
        } else {
            panic!("still aligning at {now:?}: {:?}", c.mode);
        }
        // Given up, one restart more than allowed is the count that gave up.
        let mut g = c.clone();
        (g.mode, g.restarts) = (Mode::GaveUp, 6);
        restore(&g).unwrap();
    }

    /// The clock edge of the chip's next tick after `now` under command `cmd`.
    pub(super) fn next_edge(now: Ticks, cmd: &Command) -> Ticks {
        cmd.wake_at
            .max(Ticks(now.0 + 1))
            .next_edge(clocks::COMMUTATION)
    }

    /// As [`next`], with every comparator at `level` and decided only where the last
    /// command declared it (or watched it): what a plant may do. Fails on a read of an
    /// undeclared output.
    fn next_declared(c: &mut Chip, now: &mut Ticks, cmd: &Command, level: bool) -> Command {
        *now = next_edge(*now, cmd);
        let decided = Abc::from_fn(|x| cmd.watch.get(x) || cmd.reads.get(x) <= *now);
        let sensed = Sensed::partly(Abc::splat(level), decided, 0);
        let out = c.tick(*now, &sensed);
        assert_eq!(
            sensed.misread(),
            Abc::splat(false),
            "undeclared read at {now:?}"
        );
        out
    }

    /// A conduction angle with an empty post part (120°) set just before the tick that
    /// accepts a crossing: that crossing still takes the old angle, whose post part keeps
    /// Z_d on the phase declared, so the tick reads only what its command declared.
    #[test]
    fn a_conduction_angle_set_between_ticks_never_makes_a_tick_read_undeclared() {
        let raw = StrategyParams {
            name: StrategyName::TwelveStepRaw,
            ..StrategyParams::default()
        };
        // Without start-up confirmation, as once a speed is measured: a crossing is then
        // taken at the tick that sees it, and the pre part may declare one phase alone.
        let control = ControlParams {
            startup_confirm_deg: 0,
            ..ControlParams::default()
        };
        let mut c = Chip::new(control, raw, 6, 0.5 / 4095.0, 2000).unwrap();
        let mut now = Ticks::ZERO;
        let mut cmd = c.tick(now, &Sensed::default());
        while c.status().mode != Mode::Running {
            cmd = next_declared(&mut c, &mut now, &cmd, false);
        }
        // The floating phase u was driven until the hand-over: the detector arms on the
        // pre level lasting the blanking time.
        let until = Ticks(now.0 + BLANKING.0 + clocks::COMMUTATION.0);
        while now < until {
            let pre = !c.shifter.sector().rising;
            cmd = next_declared(&mut c, &mut now, &cmd, pre);
        }
        // In the pre part, Z_d at the pre-crossing level until a crossing is plausible.
        let post_level = c.shifter.sector().rising;
        let earliest = c.shifter.earliest_crossing();
        while now < earliest {
            cmd = next_declared(&mut c, &mut now, &cmd, !post_level);
        }
        let declared = drive_core::Phase::ALL
            .iter()
            .filter(|&&x| cmd.reads.get(x) != Ticks::NEVER);
        assert_eq!(
            declared.count(),
            1,
            "the pre part declares Z_d's phase alone"
        );
        let state = c.status().state;
        c.set_conduction_angle(120.0).unwrap();
        // The next tick sees the crossing (no guard): accepted there.
        cmd.wake_at = Ticks(now.0 + 1);
        cmd = next_declared(&mut c, &mut now, &cmd, post_level);
        assert_ne!(c.status().state, state, "crossed");
        // From now on the new angle's empty post part is declared for.
        for _ in 0..20 {
            cmd = next_declared(&mut c, &mut now, &cmd, !post_level);
        }
    }

    /// What the chip plans (alignment steps' ends, post parts' ends) is the instant and
    /// the pattern of its next pattern change, ticked at every clock edge with a clean
    /// crossing in each sector; a copy restored at each edge plans the same.
    #[test]
    fn a_planned_change_is_the_next_pattern_change() {
        let mut c = chip(5);
        let mut now = Ticks::ZERO;
        let mut cmd = c.tick(now, &Sensed::default());
        let mut plan = c.planned_change();
        let mut changes = 0;
        let mut commutations = 0;
        let mut pre_since = Ticks::ZERO;
        while commutations < 12 {
            let running = c.status().mode == Mode::Running;
            // At every edge: Z_d at the pre level until a crossing is plausible and the
            // detector has had its blanking time, then at the post level.
            let post = c.shifter.sector().rising;
            let cross = running
                && c.shifter.in_pre()
                && now >= c.shifter.earliest_crossing()
                && now.0 >= pre_since.0 + 2 * BLANKING.0;
            let level = if cross { post } else { !post };
            cmd.wake_at = cmd.wake_at.min(Ticks(now.0 + 1));
            let before = cmd.pattern;
            let was_pre = c.shifter.in_pre();
            cmd = next_declared(&mut c, &mut now, &cmd, level);
            if c.shifter.in_pre() && !was_pre {
                pre_since = now;
            }
            if let Some((at, pattern)) = plan {
                assert!(now <= at, "{now:?} passed the plan {at:?}");
                if now == at {
                    assert_eq!(cmd.pattern, pattern, "at {now:?}");
                    changes += 1;
                    commutations += usize::from(running);
                }
            }
            if running && !was_pre && cmd.pattern != before {
                // A post part ends at its planned instant alone (crossings are not planned).
                assert_eq!(plan.map(|p| p.0), Some(now), "unplanned change");
            }
            plan = c.planned_change();
            // The plan is a function of the saved state: a chip restored here plans the same
            // (the engine asks again after a restore).
            let mut restored = chip(5);
            drive_core::Persist::restore_from(
                &mut restored,
                &drive_core::Persist::to_bytes(&c).unwrap(),
            )
            .unwrap();
            assert_eq!(restored.planned_change(), plan, "restored at {now:?}");
            assert!(
                now < Ticks::from_seconds(2.0).unwrap(),
                "12 planned ends by 2 s"
            );
        }
        assert_eq!(
            changes,
            2 + 12,
            "two alignment steps, then 12 post parts' ends"
        );
    }

    #[test]
    fn conduction_angle_changes_only_within_its_rule_and_only_for_twelve_step() {
        let mut c = chip(5);
        assert!(c.set_conduction_angle(165.0).is_ok());
        assert_eq!(
            c.table(),
            Table::TwelveStep {
                conduction_deg: 165.0
            }
        );
        let e = c.set_conduction_angle(180.0).unwrap_err();
        assert!(
            e.to_string().contains("strategy.conduction_angle_deg"),
            "{e}"
        );
        let six = StrategyParams {
            name: StrategyName::SixStep120,
            ..StrategyParams::default()
        };
        let mut c = Chip::new(ControlParams::default(), six, 6, 0.5 / 4095.0, 2000).unwrap();
        assert!(c.set_conduction_angle(150.0).is_err());
        assert_eq!(c.table(), Table::SixStep);
    }

    /// From the hand-over until the first speed measurement the twelve-step angle is at
    /// most `startup_conduction_deg` (150°): 165° starts at 150°, 135° stays 135°.
    #[test]
    fn a_wide_conduction_angle_starts_at_the_startup_angle() {
        for (angle, start) in [(165.0, 150.0), (135.0, 135.0)] {
            let df = StrategyParams {
                conduction_angle_deg: Some(angle),
                ..StrategyParams::default()
            };
            let mut c = Chip::new(ControlParams::default(), df, 6, 0.5 / 4095.0, 2000).unwrap();
            let want = |deg| Table::TwelveStep {
                conduction_deg: deg,
            };
            assert_eq!(c.table(), want(angle));
            let mut now = Ticks::ZERO;
            let mut cmd = c.tick(now, &Sensed::default());
            while c.status().mode != Mode::Running {
                cmd = next(&mut c, &mut now, &cmd);
            }
            assert_eq!(c.table(), want(start), "configured {angle}°");
        }
    }
}
