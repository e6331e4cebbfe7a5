//! The controller side of the engine: what a strategy reads and what it returns.

use crate::abc::{Abc, Phase};
use crate::bridge::{ALL_FLOAT, Pattern, SIX_STEP_120, floating_phase};
use crate::pwm::DutyCounts;
use crate::time::Ticks;
use std::cell::Cell;

/// Signals a controller can read at one of its clock edges.
///
/// A comparator output is decided only if the controller declared it in
/// [`Command::reads`] (or watches it): the plant need not decide the others. Reading one
/// that is not decided is recorded, and the engine stops with
/// [`crate::EngineError::UndecidedRead`] after the tick, so a wrong declaration is an
/// error, never a silently stale value.
#[derive(Clone, Debug)]
pub struct Sensed {
    zc: Abc<bool>,
    decided: Abc<bool>,
    misread: Cell<u8>,
    /// Latest completed ADC conversion of the shunt-current channel \[codes\].
    pub current_code: u16,
}

impl Sensed {
    /// Comparator outputs u_d, v_d, w_d (true: terminal above neutral), all decided, and
    /// the current reading.
    pub fn new(zc: Abc<bool>, current_code: u16) -> Self {
        Sensed::partly(zc, Abc::splat(true), current_code)
    }

    /// As [`Sensed::new`], with only the channels in `decided` decided.
    pub fn partly(zc: Abc<bool>, decided: Abc<bool>, current_code: u16) -> Self {
        Sensed {
            zc,
            decided,
            misread: Cell::new(0),
            current_code,
        }
    }

    /// Comparator output of phase `x` as seen at the controller's input, i.e. after the
    /// comparators' propagation delay (true: terminal above neutral).
    pub fn zc(&self, x: Phase) -> bool {
        if !self.decided.get(x) {
            self.misread.set(self.misread.get() | 1 << x.index());
        }
        self.zc.get(x)
    }

    /// All three comparator outputs (each read as by [`Sensed::zc`]).
    pub fn zc_all(&self) -> Abc<bool> {
        Abc::from_fn(|x| self.zc(x))
    }

    /// The comparator outputs read although not decided.
    pub fn misread(&self) -> Abc<bool> {
        Abc::from_fn(|x| self.misread.get() & 1 << x.index() != 0)
    }
}

impl Default for Sensed {
    /// All comparator outputs low and decided, code 0.
    fn default() -> Self {
        Sensed::new(Abc::splat(false), 0)
    }
}

/// Equal when the same channels are decided with the same values and the code is the
/// same: undecided values and what was read are not part of what is sensed.
impl PartialEq for Sensed {
    fn eq(&self, other: &Self) -> bool {
        let seen = |s: &Sensed| Abc::from_fn(|x| s.decided.get(x) && s.zc.get(x));
        self.decided == other.decided
            && seen(self) == seen(other)
            && self.current_code == other.current_code
    }
}

impl Eq for Sensed {}

/// What a controller returns at each of its ticks. It never touches the bridge itself.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Command {
    /// Leg states to apply (the PWM scheme turns them into gates).
    pub pattern: Pattern,
    /// Voltage command in carrier counts (duty = cv / carrier top).
    pub duty: DutyCounts,
    /// Comparator channels whose changes must wake the controller at its next clock edge.
    pub watch: Abc<bool>,
    /// From which instant the controller reads each comparator channel at its ticks until
    /// its next command ([`Ticks::ZERO`]: at once, [`Ticks::NEVER`]: not at all; watched
    /// channels are read anyway). The plant leaves a channel undecided until then, which
    /// saves it that channel's work; declare [`Command::READS_ALL`] when in doubt.
    pub reads: Abc<Ticks>,
    /// The next instant the controller must run even if no watched input changes
    /// ([`Ticks::NEVER`] for none). Rounded up to the controller's clock by the engine.
    pub wake_at: Ticks,
}

impl Command {
    /// Everything off, nothing watched, no wake-up; every channel read (a controller's
    /// first tick sees what this command declared).
    pub const OFF: Command = Command {
        pattern: ALL_FLOAT,
        duty: 0,
        watch: Abc::splat(false),
        reads: Command::READS_ALL,
        wake_at: Ticks::NEVER,
    };

    /// Every channel read, at once.
    pub const READS_ALL: Abc<Ticks> = Abc::splat(Ticks::ZERO);
}

/// A clocked controller (commutation strategy, speed/current control, supervision).
///
/// Contract: the engine calls [`Controller::tick`] only on edges of [`Controller::clock`],
/// at least at every edge where a watched comparator output has changed since the previous
/// call and at every edge the controller asked for through `wake_at`. Between calls the
/// inputs it watches are constant, so a controller that models a chip clocked at every edge
/// must catch up from `now` (counters advance by the number of elapsed edges). This is what
/// lets a 0.64 µs clock run without simulating every edge.
pub trait Controller {
    /// Clock period in master ticks (e.g. 32 = 0.64 µs). The engine reads it when built or
    /// restored and after each tick, so it may change only at a tick.
    fn clock(&self) -> Ticks;

    /// Runs the controller at the clock edge `now` with the signals it sees there.
    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command;

    /// Why the controller cannot go on (e.g. a plugin that failed or returned a command
    /// the host refused). The engine stops with an error after a tick that set it.
    fn fault(&self) -> Option<&str> {
        None
    }

    /// The next instant at which the controller already knows it will command another
    /// pattern (e.g. a commutation timed by a counter), with that pattern, if its inputs
    /// hold; `None` when it knows none (the default). Only a hint for the engine, which ends
    /// the plant's step there when the gates would change, instead of integrating past it
    /// and going back: a wrong or missing hint costs time, never correctness. The engine
    /// reads it after each tick and when restored, so it may change only at a tick. A
    /// controller wrapping another forwards it, or its runs differ in the last digits.
    fn planned_change(&self) -> Option<(Ticks, Pattern)> {
        None
    }

    /// Checks a controller restored from a state (see [`crate::state`]) against the
    /// engine's instant `now`, on the same time base: the instants it keeps lie where a run
    /// leaves them (passed ones by `now`, deadlines within their periods after it). The
    /// engine calls it after restoring the controller; the default has nothing to check. A
    /// controller wrapping another forwards it.
    fn check_restored(&self, now: Ticks) -> Result<(), String> {
        let _ = now;
        Ok(())
    }
}

impl<C: Controller + ?Sized> Controller for &mut C {
    fn clock(&self) -> Ticks {
        (**self).clock()
    }
    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command {
        (**self).tick(now, sensed)
    }
    fn fault(&self) -> Option<&str> {
        (**self).fault()
    }
    fn planned_change(&self) -> Option<(Ticks, Pattern)> {
        (**self).planned_change()
    }
    fn check_restored(&self, now: Ticks) -> Result<(), String> {
        (**self).check_restored(now)
    }
}

impl<C: Controller + ?Sized> Controller for Box<C> {
    fn clock(&self) -> Ticks {
        (**self).clock()
    }
    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command {
        (**self).tick(now, sensed)
    }
    fn fault(&self) -> Option<&str> {
        (**self).fault()
    }
    fn planned_change(&self) -> Option<(Ticks, Pattern)> {
        (**self).planned_change()
    }
    fn check_restored(&self, now: Ticks) -> Result<(), String> {
        (**self).check_restored(now)
    }
}

/// A controller that holds one command forever (tests, locked-rotor runs, coasting).
#[derive(Copy, Clone, Debug)]
pub struct Hold(pub Command);

impl Controller for Hold {
    fn clock(&self) -> Ticks {
        Ticks(1)
    }
    fn tick(&mut self, _now: Ticks, _sensed: &Sensed) -> Command {
        Command {
            wake_at: Ticks::NEVER,
            ..self.0
        }
    }
}

/// Open-loop six-step stepping: the 120° table advanced every `step` ticks at a fixed duty,
/// the way a drive is started before back-EMF can be sensed. It watches the floating
/// phase's comparator and counts the edges it sees (an observer of the crossings).
#[derive(Copy, Clone, Debug)]
pub struct OpenLoopSixStep {
    /// Ticks per 60° state.
    pub step: Ticks,
    /// Voltage command [carrier counts].
    pub duty: crate::pwm::DutyCounts,
    /// Table index of the first state (0 = state 1).
    pub first_state: usize,
    /// Controller clock (default 0.64 µs).
    pub clock: Ticks,
    last: Option<(usize, bool)>,
    /// Floating-phase comparator edges seen so far.
    pub zc_edges: u64,
}

impl OpenLoopSixStep {
    /// Steps every `step` ticks at `duty`, starting in table index `first_state`.
    pub fn new(step: Ticks, duty: crate::pwm::DutyCounts, first_state: usize) -> Self {
        OpenLoopSixStep {
            step,
            duty,
            first_state,
            clock: crate::time::clocks::COMMUTATION,
            last: None,
            zc_edges: 0,
        }
    }

    /// Table index (0..5) in force at `now`.
    pub fn state_at(&self, now: Ticks) -> usize {
        let n = now.0.checked_div(self.step.0).unwrap_or(0);
        ((self.first_state as u64 + n) % 6) as usize
    }
}

impl Controller for OpenLoopSixStep {
    fn clock(&self) -> Ticks {
        self.clock
    }

    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command {
        let k = self.state_at(now);
        let pattern = SIX_STEP_120[k];
        let floating = floating_phase(&pattern);
        let level = floating.map(|x| sensed.zc(x)).unwrap_or(false);
        if let Some((k0, l0)) = self.last {
            if k0 == k && l0 != level {
                self.zc_edges += 1;
            }
        }
        self.last = Some((k, level));
        let watch = Abc::from_fn(|x| Some(x) == floating);
        let next = now
            .0
            .checked_div(self.step.0)
            .map_or(Ticks::NEVER, |n| Ticks((n + 1) * self.step.0));
        // The next tick may be in the next state: both floating phases are read (every
        // phase when a state is shorter than the clock, so that a tick may skip one).
        let after = floating_phase(&SIX_STEP_120[(k + 1) % 6]);
        let short = self.step < self.clock;
        Command {
            pattern,
            duty: self.duty,
            watch,
            reads: Abc::from_fn(|x| {
                if short || Some(x) == floating {
                    Ticks::ZERO
                } else if Some(x) == after {
                    next
                } else {
                    Ticks::NEVER
                }
            }),
            wake_at: next,
        }
    }
}
