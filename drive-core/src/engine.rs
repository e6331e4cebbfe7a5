//! The simulation engine: owns time, schedules every discrete instant, integrates the plant
//! between them.
//!
//! Discrete instants are whole master ticks: controller clock edges, PWM edges, dead-time
//! releases, trace samples. Between two of them the plant integrates continuously and may
//! stop early for a diode event or a watched comparator change. Each call to
//! [`Engine::step`] reports why it stopped. The step loop allocates nothing.

use crate::abc::Phase;
use crate::bridge::{GateMask, Gates, Pattern, ShootThrough};
use crate::control::{Command, Controller, Sensed};
use crate::gate_driver::GateDriver;
use crate::plant::{Plant, PlantStop, Watch};
use crate::pwm::{Carrier, PwmScheme};
use crate::state::{Persist, Reader, Writer, check};
use crate::time::Ticks;

/// Why a step ended.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum StopReason {
    /// The controller ran at one of its clock edges.
    ControllerTick,
    /// The PWM output changed.
    PwmEdge,
    /// A delayed turn-on (dead time) took effect.
    DeadTime,
    /// A diode started or stopped conducting (between ticks).
    Diode,
    /// A watched comparator output changed; the controller runs at its next clock edge.
    Sensing,
    /// A requested sampling instant (see [`Engine::set_sample_period`]).
    Sample,
    /// The requested end time was reached.
    End,
}

/// Errors that stop the engine.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EngineError {
    /// The controller asked for a pattern that shorts a leg; it is refused, never simulated.
    #[error("at t = {time_s} s the controller commanded a shoot-through: {source}")]
    ShootThrough {
        /// When it was commanded \[s\].
        time_s: f64,
        /// Which leg.
        source: ShootThrough,
    },
    /// The controller read a comparator output it had not declared (see [`Sensed`]).
    #[error(
        "at t = {time_s} s the controller read comparator output(s) {phases} without declaring \
         them in Command::reads (rule: a controller reads only the channels its last command \
         declared or watched)"
    )]
    UndecidedRead {
        /// When \[s\].
        time_s: f64,
        /// The phases read, e.g. "u, w".
        phases: String,
    },
    /// The controller reported a fault (see [`Controller::fault`]).
    #[error("at t = {time_s} s the controller stopped: {message}")]
    ControllerFault {
        /// When \[s\].
        time_s: f64,
        /// The controller's reason.
        message: String,
    },
}

/// Plant + controller + PWM scheme on one master clock.
pub struct Engine<P, C, S> {
    /// The continuous system.
    pub plant: P,
    /// The controller (strategy).
    pub controller: C,
    scheme: S,
    carrier: Carrier,
    driver: GateDriver,
    now: Ticks,
    cmd: Command,
    /// The scheme's gates for `cmd.pattern` with the PWM output off and on (derived from
    /// `cmd`, rebuilt when its pattern changes): a PWM edge picks one.
    masks: [GateMask; 2],
    /// The next PWM edge after `now` under `cmd.duty`, once known (derived: act, which
    /// changes both, sets it; `None` after a restore or a refused command, until the next
    /// step computes it). Diode and sensing stops leave both, so their steps reuse it.
    pwm_edge: Option<Ticks>,
    /// What the plant is told to watch: `cmd`'s channels and reads, and the controller's
    /// clock as of its last tick (derived; each step sets the horizon). A controller
    /// replaced or changed through the public field takes effect at its next tick.
    watch: Watch,
    /// The controller's planned change ([`Controller::planned_change`]) on its clock edge,
    /// with the PWM output off and on: [`Ticks::NEVER`] where it would leave the gates as
    /// they are; none after a controller fault or a failed restore. A plant step ends there
    /// too, unless it is not after the present (derived: read after each tick and when
    /// restored).
    planned: [Ticks; 2],
    pwm_on: bool,
    wake: Ticks,
    sample_period: Ticks,
    started: bool,
    last_tick: Option<Ticks>,
}

impl<P: Plant, C: Controller, S: PwmScheme> Engine<P, C, S> {
    /// Assembles an engine at t = 0 with the bridge off; the controller first runs at t = 0.
    pub fn new(plant: P, controller: C, scheme: S, carrier: Carrier, dead_time: Ticks) -> Self {
        Engine {
            masks: Self::masks_of(&scheme, &Command::OFF.pattern),
            pwm_edge: None,
            watch: Self::watch_of(&Command::OFF, controller.clock()),
            planned: [Ticks::NEVER; 2],
            plant,
            controller,
            scheme,
            carrier,
            driver: GateDriver::new(dead_time),
            now: Ticks::ZERO,
            cmd: Command::OFF,
            pwm_on: false,
            wake: Ticks::ZERO,
            sample_period: Ticks::NEVER,
            started: false,
            last_tick: None,
        }
    }

    /// An independent copy in the same state, with the controller copied by `copy` (a
    /// controller behind a trait object or a C boundary may not be able to copy itself).
    pub fn try_clone_with<E>(&self, copy: impl FnOnce(&C) -> Result<C, E>) -> Result<Self, E>
    where
        P: Clone,
        S: Clone,
    {
        Ok(Engine {
            plant: self.plant.clone(),
            controller: copy(&self.controller)?,
            scheme: self.scheme.clone(),
            carrier: self.carrier,
            driver: self.driver.clone(),
            now: self.now,
            cmd: self.cmd,
            masks: self.masks,
            pwm_edge: self.pwm_edge,
            watch: self.watch,
            planned: self.planned,
            pwm_on: self.pwm_on,
            wake: self.wake,
            sample_period: self.sample_period,
            started: self.started,
            last_tick: self.last_tick,
        })
    }

    /// Adds a stop at every multiple of `period` (for traces); `Ticks::NEVER` disables it.
    pub fn set_sample_period(&mut self, period: Ticks) {
        self.sample_period = if period.0 == 0 { Ticks::NEVER } else { period };
    }

    /// Wakes the controller at its next clock edge after now. Call it after changing an
    /// input of the controller from outside (start, reset): a controller that asked to
    /// sleep (off, waiting for start) would otherwise never see the change.
    pub fn wake_controller(&mut self) {
        let edge = Ticks(self.now.0 + 1).next_edge(self.controller.clock());
        self.wake = self.wake.min(edge);
    }

    /// The last engine instant (a whole tick).
    pub fn now(&self) -> Ticks {
        self.now
    }

    /// The command in force.
    pub fn command(&self) -> &Command {
        &self.cmd
    }

    /// Whether the PWM output is on.
    pub fn pwm_on(&self) -> bool {
        self.pwm_on
    }

    /// The gates the bridge sees (after dead time).
    pub fn gates(&self) -> Gates {
        self.driver.effective()
    }

    /// The PWM carrier.
    pub fn carrier(&self) -> &Carrier {
        &self.carrier
    }

    /// Advances to the next stop, never beyond `end`.
    pub fn step(&mut self, end: Ticks) -> Result<StopReason, EngineError> {
        if !self.started {
            self.started = true;
            return self
                .act(self.now, true, false)
                .map(|_| StopReason::ControllerTick);
        }
        if self.now >= end {
            return Ok(StopReason::End);
        }
        let pwm_edge = self.next_pwm_edge();
        let release = self.driver.next_release();
        let sample = if self.sample_period == Ticks::NEVER {
            Ticks::NEVER
        } else {
            Ticks(self.now.0 + 1).next_edge(self.sample_period)
        };
        let target = end.min(pwm_edge).min(self.wake).min(release).min(sample);
        // A plan not after the present says nothing about where the step may end.
        let planned = match self.planned[usize::from(self.pwm_on)] {
            p if p > self.now => p,
            _ => Ticks::NEVER,
        };
        self.watch.horizon = pwm_edge.min(release).min(planned).max(target);
        match self.plant.advance(target, &self.watch) {
            PlantStop::Diode => Ok(StopReason::Diode),
            PlantStop::Sensing(at) => {
                let edge = at.next_edge(self.watch.clock);
                // A change the controller already sampled (it ran at or after that edge, e.g.
                // a channel it just started watching) must not clock it twice.
                if self.last_tick.is_none_or(|t| edge > t) {
                    self.wake = self.wake.min(edge);
                }
                Ok(StopReason::Sensing)
            }
            PlantStop::Reached => {
                self.now = target;
                let tick = target == self.wake;
                let released = target == release;
                self.act(target, tick, released)?;
                Ok(if tick {
                    StopReason::ControllerTick
                } else if target == pwm_edge {
                    StopReason::PwmEdge
                } else if released {
                    StopReason::DeadTime
                } else if target == sample {
                    StopReason::Sample
                } else {
                    StopReason::End
                })
            }
        }
    }

    /// The next PWM edge after now ([`Ticks::NEVER`] at 0 % and 100 %), computed once per
    /// engine instant (by act, or here after a restore).
    fn next_pwm_edge(&mut self) -> Ticks {
        *self.pwm_edge.get_or_insert_with(|| {
            self.carrier
                .next_edge(self.now, self.cmd.duty)
                .unwrap_or(Ticks::NEVER)
        })
    }

    /// Steps until `end`, calling `on_step` after every stop.
    pub fn run_until(
        &mut self,
        end: Ticks,
        mut on_step: impl FnMut(&Self, StopReason),
    ) -> Result<(), EngineError> {
        loop {
            let r = self.step(end)?;
            on_step(self, r);
            if r == StopReason::End {
                return Ok(());
            }
        }
    }

    /// The error for a tick that read an undecided comparator output, if it did.
    fn check_reads(t: Ticks, sensed: &Sensed) -> Result<(), EngineError> {
        let bad = sensed.misread();
        if bad == crate::abc::Abc::splat(false) {
            return Ok(());
        }
        let phases: Vec<&str> = Phase::ALL
            .into_iter()
            .filter(|&x| bad.get(x))
            .map(|x| ["u", "v", "w"][x.index()])
            .collect();
        Err(EngineError::UndecidedRead {
            time_s: t.seconds(),
            phases: phases.join(", "),
        })
    }

    /// The gates `scheme` gives `pattern` with the PWM output off and on.
    fn masks_of(scheme: &S, pattern: &Pattern) -> [GateMask; 2] {
        [false, true].map(|on| scheme.gates(pattern, on).into())
    }

    /// The controller's planned change for [`Engine::planned`], against the masks in force.
    fn plan(&mut self) {
        self.planned = match self.controller.planned_change() {
            Some((at, pattern)) if pattern != self.cmd.pattern => {
                let at = at.next_edge(self.watch.clock);
                let next = Self::masks_of(&self.scheme, &pattern);
                [0, 1].map(|k| {
                    if next[k] != self.masks[k] {
                        at
                    } else {
                        Ticks::NEVER
                    }
                })
            }
            _ => [Ticks::NEVER; 2],
        };
    }

    /// What the plant watches under `cmd` with the controller's `clock` (no horizon yet).
    fn watch_of(cmd: &Command, clock: Ticks) -> Watch {
        Watch {
            channels: cmd.watch,
            reads: cmd.reads,
            clock,
            horizon: Ticks::NEVER,
        }
    }

    /// Puts `cmd` in force, with its gates when its pattern differs, and its watch.
    fn set_command(&mut self, cmd: Command) {
        if cmd.pattern != self.cmd.pattern {
            self.masks = Self::masks_of(&self.scheme, &cmd.pattern);
        }
        self.watch.channels = cmd.watch;
        self.watch.reads = cmd.reads;
        self.cmd = cmd;
    }

    /// Everything due at instant `t`: controller tick, PWM state, gate-driver releases.
    fn act(&mut self, t: Ticks, tick: bool, released: bool) -> Result<(), EngineError> {
        // A new instant, and perhaps a new duty.
        self.pwm_edge = None;
        if tick {
            self.last_tick = Some(t);
            let sensed = self.plant.sensed(t);
            let cmd = self.controller.tick(t, &sensed);
            self.watch.clock = self.controller.clock();
            self.set_command(cmd);
            if let Err(e) = Self::check_reads(t, &sensed) {
                // Its command rests on a value it should not have read: none is applied.
                self.set_command(Command::OFF);
                self.planned = [Ticks::NEVER; 2];
                return Err(e);
            }
            if let Some(message) = self.controller.fault() {
                let message = message.to_string();
                self.set_command(Command::OFF);
                self.planned = [Ticks::NEVER; 2];
                return Err(EngineError::ControllerFault {
                    time_s: t.seconds(),
                    message,
                });
            }
            self.plan();
            let clock = self.watch.clock;
            let asked = self.cmd.wake_at.max(Ticks(t.0 + 1));
            self.wake = if self.cmd.wake_at == Ticks::NEVER {
                Ticks::NEVER
            } else {
                asked.next_edge(clock)
            };
        }
        let (on, edge) = self.carrier.on_and_next_edge(t, self.cmd.duty);
        self.pwm_on = on;
        self.pwm_edge = Some(edge.unwrap_or(Ticks::NEVER));
        let before = self.driver.effective_mask();
        let commanded = self.masks[usize::from(self.pwm_on)];
        self.driver
            .command(t, commanded)
            .map_err(|source| EngineError::ShootThrough {
                time_s: t.seconds(),
                source,
            })?;
        if released {
            self.driver.release(t);
        }
        let after = self.driver.effective_mask();
        if after != before {
            self.plant.set_gates(&after.into());
        }
        Ok(())
    }
}

/// The engine's clocks, command and gate driver, then the plant's and the controller's
/// state; the scheme, carrier, dead time and sample period are parameters.
impl<P: Plant + Persist, C: Controller + Persist, S: PwmScheme> Persist for Engine<P, C, S> {
    fn save(&self, w: &mut Writer) {
        self.driver.save(w);
        self.now.save(w);
        self.cmd.save(w);
        self.pwm_on.save(w);
        self.wake.save(w);
        self.started.save(w);
        self.last_tick.save(w);
        self.plant.save(w);
        self.controller.save(w);
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        let restored = self.restore_saved(r);
        // What derives from the command and the controller follows whatever was restored,
        // also when a later field failed.
        self.masks = Self::masks_of(&self.scheme, &self.cmd.pattern);
        self.pwm_edge = None;
        self.watch = Self::watch_of(&self.cmd, self.controller.clock());
        // A half-restored controller is not asked: its state may not hold together.
        if restored.is_ok() {
            self.plan();
        } else {
            self.planned = [Ticks::NEVER; 2];
        }
        restored
    }
}

impl<P: Plant + Persist, C: Controller + Persist, S: PwmScheme> Engine<P, C, S> {
    /// [`Persist::restore`] of the saved fields, in the order saved.
    fn restore_saved(&mut self, r: &mut Reader) -> Result<(), String> {
        r.field("driver", &mut self.driver)?;
        r.field("now", &mut self.now)?;
        r.field("cmd", &mut self.cmd)?;
        r.field("pwm_on", &mut self.pwm_on)?;
        r.field("wake", &mut self.wake)?;
        r.field("started", &mut self.started)?;
        r.field("last_tick", &mut self.last_tick)?;
        let now = self.now;
        check(self.now < Ticks::NEVER, || {
            format!("now = {} (rule: a reachable instant)", now.0)
        })?;
        check(self.wake >= self.now || !self.started, || {
            format!("wake = {} (rule: not before now = {})", self.wake.0, now.0)
        })?;
        check(self.last_tick.is_none_or(|t| t <= now), || {
            format!(
                "last_tick = {:?} (rule: not after now = {})",
                self.last_tick, now.0
            )
        })?;
        check(self.cmd.duty <= self.carrier.top, || {
            format!(
                "cmd.duty = {} (rule: at most the carrier top {})",
                self.cmd.duty, self.carrier.top
            )
        })?;
        let late = now + self.driver.dead_time();
        check(
            self.driver.next_release() <= late || self.driver.next_release() == Ticks::NEVER,
            || {
                format!(
                    "driver.pending_on (rule: turn-ons within the dead time after now = {})",
                    now.0
                )
            },
        )?;
        r.field("plant", &mut self.plant)?;
        let t = self.plant.time_s();
        check((t - now.seconds()).abs() <= 0.5 * crate::TICK_S, || {
            format!(
                "plant time {t} s (rule: the engine's instant {} s)",
                now.seconds()
            )
        })?;
        r.field("controller", &mut self.controller)?;
        // The wake-up the last command asked for, on the controller's clock after its
        // tick; a sensing stop or an input changed from outside only brings it forward.
        if let (true, Some(t)) = (self.started, self.last_tick) {
            let asked = if self.cmd.wake_at == Ticks::NEVER {
                Ticks::NEVER
            } else {
                self.cmd
                    .wake_at
                    .max(Ticks(t.0.saturating_add(1)))
                    .next_edge(self.controller.clock())
            };
            check(self.wake <= asked, || {
                format!(
                    "wake = {} (rule: at most the wake-up the last command asked for, {})",
                    self.wake.0, asked.0
                )
            })?;
        }
        self.controller
            .check_restored(now)
            .map_err(|e| crate::state::named("controller", &e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::abc::Abc;
    use crate::bridge::SIX_STEP_120;
    use crate::control::Sensed;
    use crate::pwm::HighSideChop;

    /// Records what the engine does; reports one comparator change at `change_at`.
    struct MockPlant {
        t: Ticks,
        change_at: Ticks,
        level: bool,
        gate_log: Vec<(Ticks, Gates)>,
        declared: Watch,
    }

    impl MockPlant {
        fn new(change_at: Ticks) -> Self {
            MockPlant {
                t: Ticks::ZERO,
                change_at,
                level: false,
                gate_log: Vec::new(),
                // What the engine declares before the controller's first command.
                declared: Watch {
                    channels: Abc::splat(false),
                    reads: Command::READS_ALL,
                    clock: Ticks(32),
                    horizon: Ticks::NEVER,
                },
            }
        }
    }

    impl Plant for MockPlant {
        fn time_s(&self) -> f64 {
            self.t.seconds()
        }
        fn set_gates(&mut self, g: &Gates) {
            self.gate_log.push((self.t, *g));
        }
        fn advance(&mut self, until: Ticks, watch: &Watch) -> PlantStop {
            self.declared = *watch;
            let edge = self.change_at.next_edge(watch.clock);
            if watch.channels.w && self.t < edge && until >= edge {
                self.t = edge;
                self.level = true;
                return PlantStop::Sensing(edge);
            }
            self.t = until;
            PlantStop::Reached
        }
        fn sensed(&self, at: Ticks) -> Sensed {
            let zc = Abc {
                u: false,
                v: false,
                w: self.level && at >= self.change_at,
            };
            // Only the declared channels are decided, as a plant may do.
            let d = self.declared;
            Sensed::partly(
                zc,
                Abc::from_fn(|x| d.channels.get(x) || d.reads.get(x) <= at),
                0,
            )
        }
    }

    impl Persist for MockPlant {
        fn save(&self, w: &mut Writer) {
            self.t.save(w);
        }
        fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
            r.field("t", &mut self.t)
        }
    }

    struct Logger {
        calls: Vec<(Ticks, bool)>,
        cmd: Command,
    }

    impl Controller for Logger {
        fn clock(&self) -> Ticks {
            Ticks(32)
        }
        fn tick(&mut self, now: Ticks, s: &Sensed) -> Command {
            self.calls.push((now, s.zc(Phase::W)));
            self.cmd
        }
    }

    fn engine(cmd: Command, change_at: Ticks) -> Engine<MockPlant, Logger, HighSideChop> {
        let plant = MockPlant::new(change_at);
        Engine::new(
            plant,
            Logger {
                calls: Vec::new(),
                cmd,
            },
            HighSideChop,
            Carrier { top: 100 },
            Ticks::ZERO,
        )
    }

    #[test]
    fn controller_runs_at_the_clock_edge_after_a_watched_change_and_when_asked() {
        let pattern = SIX_STEP_120[1]; // u = V, v = G, w = F
        let cmd = Command {
            pattern,
            duty: 100,
            watch: Abc {
                u: false,
                v: false,
                w: true,
            },
            reads: Abc::splat(Ticks::NEVER),
            wake_at: Ticks(1000),
        };
        let mut e = engine(cmd, Ticks(100));
        e.run_until(Ticks(1100), |_, _| {}).unwrap();
        let calls = &e.controller.calls;
        assert_eq!(calls[0], (Ticks(0), false));
        // Change at tick 100 → sampled at the next 0.64 µs edge, 128, where it is visible.
        assert_eq!(calls[1], (Ticks(128), true));
        // wake_at 1000 → the next clock edge at or after it, 1024.
        assert!(calls.iter().any(|&(t, _)| t == Ticks(1024)));
        assert!(
            calls.iter().all(|&(t, _)| t.0 % 32 == 0),
            "only clock edges: {calls:?}"
        );
    }

    #[test]
    fn reading_an_undeclared_comparator_output_stops_the_engine_with_an_error() {
        // w neither watched nor declared read before tick 200, but the controller reads it
        // at every tick.
        let cmd = Command {
            pattern: SIX_STEP_120[1],
            duty: 50,
            watch: Abc::splat(false),
            reads: Abc {
                u: Ticks::ZERO,
                v: Ticks::ZERO,
                w: Ticks(200),
            },
            wake_at: Ticks(100),
        };
        let mut e = engine(cmd, Ticks::NEVER);
        // The first tick sees what the initial command (every channel) declared.
        e.step(Ticks(1000)).unwrap();
        let err = e.run_until(Ticks(1000), |_, _| {}).unwrap_err();
        assert_eq!(
            err,
            EngineError::UndecidedRead {
                time_s: Ticks(128).seconds(),
                phases: "w".into(),
            }
        );
        assert!(err.to_string().contains("Command::reads"), "{err}");
        assert_eq!(
            e.command(),
            &Command::OFF,
            "the tick's command is not applied"
        );
        // Declared, the same reads are fine.
        let mut e = engine(
            Command {
                reads: Command::READS_ALL,
                ..cmd
            },
            Ticks::NEVER,
        );
        e.run_until(Ticks(1000), |_, _| {}).unwrap();
    }

    #[test]
    fn pwm_edges_switch_the_gates_on_exact_ticks() {
        let pattern = SIX_STEP_120[1]; // u = V, v = G, w = F
        let cmd = Command {
            pattern,
            duty: 25,
            watch: Abc::splat(false),
            reads: Abc::splat(Ticks::NEVER),
            wake_at: Ticks::NEVER,
        };
        let mut e = engine(cmd, Ticks::NEVER);
        e.run_until(Ticks(400), |_, _| {}).unwrap();
        // Carrier top 100 (period 200), cv 25: on for p < 25 or p ≥ 175.
        let changes: Vec<(u64, bool)> = e
            .plant
            .gate_log
            .iter()
            .map(|(t, g)| (t.0, g.high.u))
            .collect();
        assert_eq!(
            changes,
            vec![
                (0, true),
                (25, false),
                (175, true),
                (225, false),
                (375, true)
            ]
        );
        assert!(e.plant.gate_log.iter().all(|(_, g)| g.low.v && !g.high.v));
    }

    /// A controller that holds one command, and plans a change it does not make.
    struct Planner {
        cmd: Command,
        plan: Option<(Ticks, Pattern)>,
    }

    impl Controller for Planner {
        fn clock(&self) -> Ticks {
            Ticks(32)
        }
        fn tick(&mut self, now: Ticks, _s: &Sensed) -> Command {
            if self.plan.is_some_and(|p| now >= p.0) {
                self.plan = None;
                self.cmd.wake_at = Ticks::NEVER;
            }
            self.cmd
        }
        fn planned_change(&self) -> Option<(Ticks, Pattern)> {
            self.plan
        }
    }

    /// The command the planning tests hold: u high, v low, w floating at duty 50, nothing
    /// watched or read, no wake-up.
    fn held() -> Command {
        use crate::bridge::LegState::{Float as F, High as V, Low as G};
        Command {
            pattern: Abc { u: V, v: G, w: F },
            duty: 50,
            watch: Abc::splat(false),
            reads: Abc::splat(Ticks::NEVER),
            wake_at: Ticks::NEVER,
        }
    }

    /// The horizons the plant is given over the steps up to `end`.
    fn horizons(plan: Option<(Ticks, Pattern)>, end: Ticks) -> Vec<u64> {
        let cmd = Command {
            wake_at: plan.map_or(Ticks::NEVER, |p| p.0),
            ..held()
        };
        horizons_of(Planner { cmd, plan }, end)
    }

    /// The horizons the plant is given over the steps up to `end` under `controller`, on
    /// high-side chop with carrier top 100.
    fn horizons_of(controller: impl Controller, end: Ticks) -> Vec<u64> {
        let mut e = Engine::new(
            MockPlant::new(Ticks::NEVER),
            controller,
            HighSideChop,
            Carrier { top: 100 },
            Ticks::ZERO,
        );
        let mut h = Vec::new();
        e.step(end).unwrap();
        loop {
            let r = e.step(end).unwrap();
            h.push(e.plant.declared.horizon.0);
            if r == StopReason::End {
                return h;
            }
        }
    }

    #[test]
    fn a_plant_step_ends_at_a_planned_change_only_where_it_changes_the_gates() {
        use crate::bridge::LegState::{Float as F, High as V, Low as G};
        // Carrier top 100, cv 50: on for p < 50 or p ≥ 150, edges at 50, 150, 250; the last
        // step, to 200, is given the edge after it.
        assert_eq!(horizons(None, Ticks(200)), vec![50, 150, 250]);
        // At 32 the output is on: u's high side would turn off, w's on.
        let at_32 = Some((Ticks(32), Abc { u: F, v: G, w: V }));
        assert_eq!(horizons(at_32, Ticks(200)), vec![32, 50, 150, 250]);
        // Planned between clock edges: the tick, and the step's end, at the next edge.
        let at_20 = Some((Ticks(20), Abc { u: F, v: G, w: V }));
        assert_eq!(horizons(at_20, Ticks(200)), vec![32, 50, 150, 250]);
        // At 96 the output is off: floating u (chopped, so off) changes no gate ...
        let off_same = Some((Ticks(96), Abc { u: F, v: G, w: F }));
        assert_eq!(horizons(off_same, Ticks(200)), vec![50, 150, 150, 250]);
        // ... moving the low side from v to w does.
        let off_other = Some((Ticks(96), Abc { u: V, v: F, w: G }));
        assert_eq!(horizons(off_other, Ticks(200)), vec![50, 96, 150, 250]);
    }

    #[test]
    fn a_plan_not_after_the_present_is_no_hint() {
        use crate::bridge::LegState::{Float as F, High as V, Low as G};
        // A controller that keeps planning a change at tick 0, one that would change the
        // gates: the horizons are those of no plan (the last step, to 200, is given the
        // PWM edge after it, not cut to its end).
        struct Stale(Command);
        impl Controller for Stale {
            fn clock(&self) -> Ticks {
                Ticks(32)
            }
            fn tick(&mut self, _now: Ticks, _s: &Sensed) -> Command {
                self.0
            }
            fn planned_change(&self) -> Option<(Ticks, Pattern)> {
                Some((Ticks::ZERO, Abc { u: F, v: G, w: V }))
            }
        }
        let cmd = held();
        let end = Ticks(200);
        let h = horizons_of(Stale(cmd), end);
        assert_eq!(h, horizons(None, end));
        assert_eq!(h, vec![50, 150, 250]);
    }

    #[test]
    fn a_controller_whose_restore_failed_is_not_asked_for_a_plan() {
        use crate::bridge::LegState::{Float as F, High as V, Low as G};
        /// Plans a change at `at`; its state holds together only once a restore has read
        /// all of it, and a restore refuses an `at` of 0.
        struct Strict {
            cmd: Command,
            at: Ticks,
            whole: bool,
        }
        impl Controller for Strict {
            fn clock(&self) -> Ticks {
                Ticks(32)
            }
            fn tick(&mut self, _now: Ticks, _s: &Sensed) -> Command {
                self.cmd
            }
            fn planned_change(&self) -> Option<(Ticks, Pattern)> {
                assert!(self.whole, "asked for a plan with a half-restored state");
                Some((self.at, Abc { u: F, v: G, w: V }))
            }
        }
        impl Persist for Strict {
            fn save(&self, w: &mut Writer) {
                self.at.save(w);
            }
            fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
                self.whole = false;
                r.field("at", &mut self.at)?;
                check(self.at != Ticks::ZERO, || "at = 0 (rule: after 0)".into())?;
                self.whole = true;
                Ok(())
            }
        }
        let cmd = held();
        let strict = |at| Strict {
            cmd,
            at,
            whole: true,
        };
        let engine = |at| {
            let plant = MockPlant::new(Ticks::NEVER);
            Engine::new(
                plant,
                strict(at),
                HighSideChop,
                Carrier { top: 100 },
                Ticks::ZERO,
            )
        };
        let mut e = engine(Ticks(96));
        e.step(Ticks(200)).unwrap();
        let good = e.to_bytes().unwrap();
        let bad = engine(Ticks::ZERO).to_bytes().unwrap();
        // A whole restore asks for the plan again; a refused one leaves none and asks nothing.
        let mut e = engine(Ticks(64));
        e.restore_from(&good).unwrap();
        assert_eq!(e.planned, [Ticks::NEVER, Ticks(96)]);
        let err = e.restore_from(&bad).unwrap_err();
        assert!(err.contains("at = 0"), "{err}");
        assert_eq!(e.planned, [Ticks::NEVER; 2]);
    }

    #[test]
    fn a_restored_wake_up_and_controller_are_held_to_now() {
        /// Keeps one instant, which a restore holds to the engine's `now`.
        struct Keeps(Ticks);
        impl Controller for Keeps {
            fn clock(&self) -> Ticks {
                Ticks(32)
            }
            fn tick(&mut self, now: Ticks, _s: &Sensed) -> Command {
                self.0 = now;
                Command {
                    wake_at: Ticks(now.0 + 64),
                    ..Command::OFF
                }
            }
            fn check_restored(&self, now: Ticks) -> Result<(), String> {
                check(self.0 <= now, || {
                    format!("kept = {} (rule: by now)", self.0.0)
                })
            }
        }
        impl Persist for Keeps {
            fn save(&self, w: &mut Writer) {
                self.0.save(w);
            }
            fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
                r.field("kept", &mut self.0)
            }
        }
        let engine = || {
            let plant = MockPlant::new(Ticks::NEVER);
            Engine::new(
                plant,
                Keeps(Ticks::ZERO),
                HighSideChop,
                Carrier { top: 100 },
                Ticks::ZERO,
            )
        };
        let mut e = engine();
        e.step(Ticks(100)).unwrap();
        e.step(Ticks(100)).unwrap();
        assert_eq!((e.now, e.wake), (Ticks(64), Ticks(128)), "woken as asked");
        engine().restore_from(&e.to_bytes().unwrap()).unwrap();
        // Later than the command asked: no run leaves it so (earlier is a sensing stop's).
        e.wake = Ticks(160);
        let err = engine().restore_from(&e.to_bytes().unwrap()).unwrap_err();
        assert!(
            err.starts_with(
                "wake = 160 (rule: at most the wake-up the last command asked for, 128)"
            ),
            "{err}"
        );
        e.wake = Ticks(96);
        engine().restore_from(&e.to_bytes().unwrap()).unwrap();
        // The controller is asked with the engine's instant.
        e.controller.0 = Ticks(65);
        let err = engine().restore_from(&e.to_bytes().unwrap()).unwrap_err();
        assert_eq!(err, "controller.kept = 65 (rule: by now)");
    }

    #[test]
    fn shoot_through_is_refused_not_simulated() {
        struct Bad;
        impl PwmScheme for Bad {
            fn gates(&self, _p: &crate::bridge::Pattern, _on: bool) -> Gates {
                let mut g = Gates::OFF;
                g.high.u = true;
                g.low.u = true;
                g
            }
        }
        let plant = MockPlant::new(Ticks::NEVER);
        let logger = Logger {
            calls: Vec::new(),
            cmd: Command::OFF,
        };
        let mut e = Engine::new(plant, logger, Bad, Carrier::default(), Ticks::ZERO);
        let err = e.step(Ticks(10)).unwrap_err();
        assert!(err.to_string().contains("shoot-through"), "{err}");
        assert!(e.plant.gate_log.is_empty(), "the bridge never saw it");
    }
}
